//! What a drill step may spend: its parameters and the work units its budget counts.

/// Parameters of the drill step.
#[derive(Clone, Copy, PartialEq, Debug)]
pub struct DrillParams {
    /// Deepest refinement level (clamped to [`crate::hierarchy::MAX_DEPTH`]).
    pub max_depth: u8,
    /// A node whose smallest face area is below this is not refined further.
    pub min_area: f32,
    /// Work units per tick, each about 100 Cortex-M4 instructions ([`WorkCost`]). The step
    /// stops starting operations once it is spent.
    pub budget: u32,
}

impl Default for DrillParams {
    fn default() -> Self {
        Self {
            max_depth: 6,
            min_area: 0.0,
            budget: 11_000,
        }
    }
}

/// What the drill charges its budget, in work units of about 100 Cortex-M4 instructions, so
/// the budget bounds the step's time however the work is made up (before 2026-11-22 every
/// item taken cost 1 unit and every NTree node visited 1 too, though an item costs several
/// times a visit: a budget then bought very different times).
///
/// Where the weights come from (docs/TIMING.md): per-call costs measured with callgrind on
/// x86-64 (an item taken ~530 instructions with its class and leaf tests, a node expanded
/// ~1,400-2,200, an erasure ~2,800 of which its NTree visits are most, a refinement ~6,000)
/// and a least-squares fit of the firmware scenario's per-tick instruction counts on the
/// Cortex-M4 (QEMU `-icount`, `scripts/fit-work-weights.py`: an item ~875-1,580, an expansion
/// ~1,450-2,000, a visit ~130-170, a created node ~1,200-1,350). The fit is noisy (the
/// contact search it cannot separate leaves residuals of ~40k instructions a tick, and two
/// runs at different budgets give the ranges above), so the weights are set within those
/// ranges; a unit is about 60 instructions on x86-64.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct WorkCost;

impl WorkCost {
    /// An item taken from the deque (its corners, its class, the leaf tests).
    pub const TAKEN: u32 = 9;
    /// A node's eight children classified from the ten points of its refinement, the
    /// survivors queued.
    pub const EXPANDED: u32 = 20;
    /// A node touched by an NTree visit of a refinement or erasure.
    pub const VISIT: u32 = 2;
    /// A tet-sphere classification that needed the exact test (no corner inside, the box
    /// within the radius: a barycentric test and up to four closest points on triangles,
    /// ~450 Cortex-M4 / ~350 x86-64 instructions), on top of the item or expansion.
    pub const EXACT_TEST: u32 = 5;
    /// A node created by a refinement (eight a refinement, besides its visits).
    pub const CREATED: u32 = 13;
    /// Finding an item's sphere among the remembered ones (up to `super::SWEPT` comparisons; once
    /// per sphere whose items reach the swept test).
    pub const LOCATE: u32 = 4;
}
