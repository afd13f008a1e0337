//! The budgeted drill step: refine the nodes that cross a sample sphere, erase the frontier
//! nodes inside it, carry what does not fit to the next tick.
//!
//! Files: this one holds the [`Drill`], its pending items ([`Pending`]), its report and
//! [`Drill::step`] (new work, then items taken until the budget is spent); `item.rs` what the
//! step does with one item (classify, refine, erase, queue the children), `swept.rs` the
//! spheres remembered as the swept volume ([`SWEPT`], [`SWEPT_AHEAD`]).
//!
//! [`SWEPT_AHEAD`]: super::SWEPT_AHEAD

use glam::Vec3;

use super::cost::{DrillParams, WorkCost};
use super::deque::{split, Ring};
use super::item::Parent;
use super::material::Regions;
use super::sphere::Sphere;
use super::swept::SWEPT;
use crate::hierarchy::{Crumbs, Hierarchy, RootFrame, MAX_DEPTH};
use crate::ids::TetId;
use crate::mesh::Mesh;

/// One unit of pending work: a node of a tree, against the sphere it was queued for, with the
/// node's integer barycentric coordinates in its root (so processing it costs no walk from the
/// root). 64 bytes (pinned at compile time).
#[derive(Clone, Copy, PartialEq, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C)]
pub struct Pending {
    /// The coarse tet.
    pub tet: TetId,
    /// Tree index.
    pub index: u32,
    /// Node reference (looked up again by `(tet, index)` when the hierarchy has taken back
    /// blocks since the item was queued: see [`Hierarchy::reclaimed`]).
    pub node: u32,
    /// The sphere, as it was when the work was queued (so the removed shape converges to the
    /// swept volume even when the work finishes ticks later).
    pub sphere: Sphere,
    /// [`epoch_of`] the hierarchy when the item was queued: while [`Hierarchy::reclaimed`]
    /// still equals it, no block has been taken back since and `node` is still the node it
    /// was; otherwise the node is looked up again by `(tet, index)`. Placed before `bary`,
    /// it fills what would be padding.
    pub(super) epoch: u32,
    /// The node's corners as integer barycentric coordinates of its root's, scaled by
    /// `2^depth`: one `u64` per corner holding four 16-bit weights (each at most
    /// `2^MAX_DEPTH` = 1024, so a child's row is one `u64` addition of two parent rows).
    pub(super) bary: [u64; 4],
}

/// The epoch an item queued now records: [`Hierarchy::reclaimed`], but never `u32::MAX`,
/// where that count saturates, so once it has saturated no item is trusted without a look-up.
#[inline]
pub(super) fn epoch_of(h: &Hierarchy<'_>) -> u32 {
    h.reclaimed().min(u32::MAX - 1)
}

const _: () = assert!(core::mem::size_of::<Pending>() == 64);

impl Pending {
    /// An empty item (for initialising static storage).
    pub const EMPTY: Self = Self {
        tet: TetId(0),
        index: 0,
        node: 0,
        sphere: Sphere {
            center: Vec3::ZERO,
            radius: 0.0,
        },
        bary: [0; 4],
        epoch: 0,
    };

    /// The root of `tet`'s tree against `sphere`, queued at `epoch` (see [`epoch_of`]).
    pub(super) fn root(tet: TetId, sphere: Sphere, epoch: u32) -> Self {
        Self {
            tet,
            index: 0,
            node: tet.0,
            sphere,
            // The root's rows depend on its frame's corner order: filled in when taken.
            bary: [0; 4],
            epoch,
        }
    }
}

/// What one [`Drill::step`] did.
#[derive(Clone, Copy, PartialEq, Debug, Default)]
pub struct DrillReport {
    /// Nodes created by refinement.
    pub created: u32,
    /// Leaves erased.
    pub erased: u32,
    /// Volume removed during this step.
    pub removed_volume: f64,
    /// Work units used (may exceed the budget by the cost of the last operation).
    pub work: u32,
    /// Work items taken from the deque.
    pub taken: u32,
    /// Nodes whose eight children were classified (and the survivors queued), or, one level
    /// above `max_depth`, whose children's centroids were tested before a refinement.
    pub expanded: u32,
    /// Nodes touched by the NTree visits of the refinements and erasures.
    pub visits: u32,
    /// Tet-sphere classifications that needed the exact test ([`WorkCost::EXACT_TEST`]).
    pub exact_tests: u32,
    /// Searches of the remembered spheres for an item's sphere ([`WorkCost::LOCATE`]).
    pub located: u32,
    /// Work items left for the next tick.
    pub pending: u32,
    /// Capacity saturations this step (arena full, pending queue full).
    pub saturations: u32,
    /// Items dropped because the pressing force does not remove their region's material
    /// (`super::Material::admits`).
    pub held: u32,
    /// 1 when the step ended on a leaf waiting for its region's credit
    /// (`super::Regions::spend`).
    pub waited: u32,
    /// Erased leaves checked for debris cut off (`crumbs.rs`).
    pub debris_checked: u32,
    /// Leaves erased as debris (in `removed_volume`, not in `erased`).
    pub debris_erased: u32,
}

/// A drill step whose debris seed queue is full checks a seed before each item until it has
/// spent `budget / CRUMB_SHARE` on checks: a drill lagging behind the burr keeps seven eighths
/// of its budget for material, and its crumbs are still found while it drills.
pub(crate) const CRUMB_SHARE: u32 = 8;

/// The coarse pass defers the last level's refinements only while at least this many spheres
/// were queued after the item's own: a drill that keeps up with the burr refines at once (the
/// fine pass walks the trees down again, about 7 % more work).
pub(crate) const DEFER_LAG: usize = 8;

/// Which ring an item came from (its children go to the same one).
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub(super) enum Pass {
    Coarse,
    Fine,
}

/// Spheres remembered to skip re-queueing an unchanged sphere whose work is already queued.
const MEMO: usize = 8;

/// The drill: a pending-work deque in caller storage (two rings, coarse and fine: see
/// [`Drill::step`]) and counters.
#[derive(Debug)]
pub struct Drill<'a> {
    /// The coarse pass: every sphere's work except the refinement of the last level.
    pub(super) coarse: Ring<'a>,
    /// The fine pass: the roots whose coarse pass met a leaf one level above `max_depth`
    /// worth refining, taken only once the coarse ring is empty.
    pub(super) fine: Ring<'a>,
    memo: [Option<Sphere>; MEMO],
    /// The last [`SWEPT`] spheres queued (a ring; `swept_len` of them valid).
    pub(super) swept: [Sphere; SWEPT],
    pub(super) swept_next: usize,
    pub(super) swept_len: usize,
    /// The sphere whose successors were last looked up (cleared when a sphere is
    /// remembered), the slot of the first of them and how many (see [`Drill::swept_after`]).
    pub(super) swept_for: Option<Sphere>,
    pub(super) swept_first: usize,
    pub(super) swept_count: usize,
    /// How many remembered spheres were queued after that sphere (all of them when it is
    /// forgotten): how far the drill lags behind the burr.
    pub(super) swept_lag: usize,
    /// The root frame of the last tet processed (items come tree by tree), with that tree's
    /// depth limit from the resolution ([`Drill::set_resolution`]).
    pub(super) frame: Option<(TetId, RootFrame, u8)>,
    /// The finest leaf's edge in mesh units (0: none; every tree refines to `max_depth`).
    pub(super) resolution: f32,
    /// Per depth, the last node whose children were queued and the ten points of its
    /// refinement (see [`Drill::corners`]); [`Parent::EMPTY`] for none. Written in place:
    /// the ten points are evaluated into their entry, not copied there (on the Cortex-M4 a
    /// copy of the 120 bytes is a call to `memcpy`).
    pub(super) parents: [Parent; MAX_DEPTH],
    pub(super) retry: bool,
    saturations: u32,
    /// The materials per region, if set ([`Drill::set_regions`]).
    pub(super) regions: Option<Regions<'a>>,
    /// A leaf waits for its region's credit: the step stops.
    pub(super) stalled: bool,
    /// The erased leaves waiting for their debris check.
    pub(super) crumbs: Crumbs,
}

impl<'a> Drill<'a> {
    /// A drill whose pending deque is `queue` (its length is the capacity). From
    /// `super::FINE_MIN_DEQUE` entries up, the second half holds the fine pass's roots; a smaller
    /// deque is all coarse pass (every refinement done at once).
    ///
    /// # Bounded work
    /// O(1).
    pub fn new(queue: &'a mut [Pending]) -> Self {
        let (coarse, fine) = split(queue);
        Self {
            coarse,
            fine,
            memo: [None; MEMO],
            swept: [Sphere::default(); SWEPT],
            swept_next: 0,
            swept_len: 0,
            swept_for: None,
            swept_first: 0,
            swept_count: 0,
            swept_lag: 0,
            frame: None,
            resolution: 0.0,
            parents: [Parent::EMPTY; MAX_DEPTH],
            retry: false,
            saturations: 0,
            regions: None,
            stalled: false,
            crumbs: Crumbs::default(),
        }
    }

    /// Sets the drill's resolution: the edge of its finest leaves in mesh units. A tree whose
    /// root's longest edge is `e` refines to depth `ceil(log2(e / resolution))` at most (each
    /// level halves the edges), and never past the step's `max_depth`: a fine mesh and a
    /// coarse one then drill with leaves of the same size. 0, negative or not finite: none
    /// (every tree to `max_depth`, the default).
    ///
    /// # Bounded work
    /// Constant; each tree's limit is computed once when the step meets it (six distances
    /// and at most [`MAX_DEPTH`] halvings).
    pub fn set_resolution(&mut self, resolution: f32) {
        self.resolution = if resolution.is_finite() && resolution > 0.0 {
            resolution
        } else {
            0.0
        };
        self.crumbs.set_resolution(self.resolution);
        self.frame = None;
    }

    /// The resolution set ([`Drill::set_resolution`]); 0 for none.
    pub fn resolution(&self) -> f32 {
        self.resolution
    }

    /// Work items waiting for the next tick.
    #[inline]
    pub fn pending(&self) -> usize {
        self.coarse.len() + self.fine.len()
    }

    /// The pending deque's high-water marks since creation: the most items the coarse ring
    /// and the fine ring have each held at once, beside their capacities, as
    /// `[coarse peak, coarse capacity, fine peak, fine capacity]` (a deque under
    /// `super::FINE_MIN_DEQUE` entries has no fine ring: its capacity is 0). A ring whose peak
    /// stays below its capacity never dropped work.
    #[inline]
    pub fn pending_peaks(&self) -> [usize; 4] {
        [
            self.coarse.peak(),
            self.coarse.capacity(),
            self.fine.peak(),
            self.fine.capacity(),
        ]
    }

    /// Work items dropped because the pending deque was full (since creation). The arena's
    /// refusals are counted by [`Hierarchy::saturations`].
    #[inline]
    pub fn saturations(&self) -> u32 {
        self.saturations
    }

    /// An item the pressing force does not remove now: counted as held, and the burr's
    /// positions queued again once the backlog is done.
    pub(super) fn hold(&mut self, rep: &mut DrillReport) {
        rep.held += 1;
        self.retry = true;
    }

    pub(super) fn saturate(&mut self, rep: &mut DrillReport) {
        self.saturations += 1;
        rep.saturations += 1;
        // Dropped work is retried once the backlog is done (re-queueing now would only be
        // dropped again).
        self.retry = true;
    }

    /// One drill tick. New work: every candidate coarse tet against every sphere (skipped for
    /// a sphere identical to last tick's when its work is already queued or done; after work
    /// was dropped for a full deque, unchanged spheres are queued again once the deque is
    /// empty). Then work items are taken until the budget is spent, in two passes: the coarse
    /// ring first, oldest sphere first (each node's children go to the front, so one sphere's
    /// subtree is finished depth first); once it is empty, the fine ring, where the coarse pass
    /// left the refinement of the last level (below). A path's work at a fine `max_depth` can
    /// be more than its ticks' budget (the last level's refinements cost most of it and hold
    /// the least volume): every sphere's coarse material goes first, and the drill no longer
    /// falls behind the burr refining the first spheres' walls.
    ///
    /// Each item:
    /// - a node outside the sphere, or with every leaf erased, is dropped;
    /// - an inner node's eight children are classified from the ten points of its refinement
    ///   and those that meet the sphere and still hold material are queued (the others would
    ///   only be dropped);
    /// - a leaf entirely inside the sphere (all four corners), or inside one of the
    ///   `SWEPT_AHEAD` spheres queued after it (the swept path, which erases it anyway when
    ///   its own work arrives), is erased at once: only the boundary of the swept volume is
    ///   refined, not the shell of every sphere along it. The later spheres are known when
    ///   the drill lags behind the burr, which is when the work matters (before 2026-11-24 the
    ///   last `SWEPT_AHEAD` spheres queued were tested instead: useless once the drill was
    ///   more than that many spheres behind, and the earlier ones never hold material);
    /// - a leaf crossing the sphere is refined when it is above `max_depth` and its smallest
    ///   face is at least `min_area`, and its children are queued. One level above
    ///   `max_depth`, while the drill lags `DEFER_LAG` spheres or more behind the burr: in
    ///   the coarse pass its tree's root goes to the fine ring instead (once for a run of such
    ///   leaves of one tree, while the fine ring has room for the root and a descent, else it
    ///   is refined now); the fine pass, or a coarse pass that keeps up, refines it only when
    ///   the centroid of one of its children lies inside the sphere or the spheres queued
    ///   after it (the children would otherwise all stay: the refinement would only add
    ///   nodes);
    /// - a crossing leaf at `max_depth` or below `min_area` is erased iff its centroid is
    ///   inside the sphere or one of the spheres queued after it. This is the erosion
    ///   criterion: the misclassified volume lies within one leaf of the sphere's surface and
    ///   is unbiased to first order, so the removed volume converges to the swept volume as
    ///   the leaves shrink;
    /// - a crossing leaf whose refinement the full arena refuses stays whole.
    ///
    /// `candidates` are the coarse tets near the tool (from the spatial hash, or
    /// [`super::candidates_brute_force`]).
    ///
    /// # Bounded work
    /// The new work is O(candidates * spheres) pushes. After that no operation starts once
    /// `budget` units are spent ([`WorkCost`]: each item taken, each node expanded, each
    /// NTree node visited and each node created is charged what it costs); the last one may
    /// overrun it by its own cost. A refinement does not start when its 8 created nodes alone
    /// would pass the budget, unless it is the tick's first item: the item waits at the front
    /// of its ring for the next tick. A refinement is 8 nodes created plus 16 NTree visits (one
    /// level above `max_depth`, after its children's centroid test, counted as the expansion
    /// that follows the refinement), an
    /// erasure 4 NTree visits, each O(depth) plus the instantiated nodes across one face. A
    /// leaf's swept test is at most `SWEPT_AHEAD` sphere tests, after a search of the
    /// `SWEPT` remembered spheres when the item's sphere is not the last one looked up
    /// ([`WorkCost::LOCATE`]). Every leaf erased leaves a debris seed; the seeds are checked
    /// after the items, while the budget lasts, and before the next item when their queue is
    /// full ([`crate::hierarchy::Crumbs::check_one`], charged [`WorkCost::TAKEN`] plus its NTree
    /// visits; the rest wait for the next step).
    ///
    /// # Capacity
    /// Arena full (no fresh block, and no wholly erased subtree to take one back from): the
    /// leaf is not refined and stays whole (erasing a coarse leaf by its centroid would move
    /// the surface past the burr in one tick, a force jump); the hierarchy counts it. Once
    /// the arena takes blocks back, an item queued before a block was taken back is looked
    /// up again by its tree index before it is used (O(depth) more for that item; stale
    /// items are dropped). Pending deque full: the new item or the children are dropped and
    /// counted; the hierarchy stays valid, only the erosion is coarser there.
    pub fn step(
        &mut self,
        h: &mut Hierarchy<'_>,
        mesh: &Mesh<'_>,
        candidates: &[TetId],
        spheres: &[Sphere],
        params: &DrillParams,
    ) -> DrillReport {
        let mut rep = DrillReport::default();
        self.stalled = false;
        let removed0 = h.removed_volume();
        let sat0 = h.saturations();
        if self.retry && self.pending() == 0 {
            self.retry = false;
            self.memo = [None; MEMO];
        }
        for (k, s) in spheres.iter().enumerate() {
            if k < MEMO && self.memo[k] == Some(*s) {
                continue;
            }
            if self.swept_len == 0 || self.swept[(self.swept_next + SWEPT - 1) % SWEPT] != *s {
                self.remember(*s);
            }
            let mut all = true;
            for &t in candidates {
                if t.idx() >= h.tet_count() {
                    continue;
                }
                if !self.coarse.push_back(Pending::root(t, *s, epoch_of(h))) {
                    all = false;
                }
            }
            if all {
                if let Some(m) = self.memo.get_mut(k) {
                    *m = Some(*s);
                }
            } else {
                self.saturate(&mut rep);
            }
        }
        let max_depth = params.max_depth.min(crate::hierarchy::MAX_DEPTH as u8);
        // While the seed queue is full, a seed is checked before the next item, up to an
        // eighth of the budget ([`CRUMB_SHARE`]); past that, new seeds are dropped (counted)
        // and the items get the rest.
        let share = params.budget / CRUMB_SHARE;
        let mut checks = 0u32;
        while rep.work < params.budget && !self.stalled {
            if self.crumbs.is_full() && checks < share {
                // Items may have changed the hierarchy since the last check.
                self.crumbs.forget();
                let w0 = rep.work;
                if self.check_crumb(h, mesh, max_depth, &mut rep) {
                    checks = checks.saturating_add(rep.work - w0);
                    continue;
                }
            }
            let (item, pass) = match self.coarse.pop_front() {
                Some(item) => (item, Pass::Coarse),
                None => match self.fine.pop_front() {
                    Some(item) => (item, Pass::Fine),
                    None => break,
                },
            };
            rep.work = rep.work.saturating_add(WorkCost::TAKEN);
            rep.taken += 1;
            if !self.process(h, mesh, item, pass, max_depth, params, &mut rep) {
                // A refinement that would overrun the budget: the item waits at the front.
                let _ = match pass {
                    Pass::Coarse => self.coarse.push_front(item),
                    Pass::Fine => self.fine.push_front(item),
                };
                break;
            }
        }
        // Debris checks take what the drill's items leave of the budget: removing material
        // comes first (a seed queue still full drops seeds, counted in
        // `CrumbStats::saturations`).
        self.check_crumbs(h, mesh, max_depth, params.budget, &mut rep);
        rep.pending = self.pending() as u32;
        rep.removed_volume = h.removed_volume() - removed0;
        rep.saturations += h.saturations() - sat0;
        rep
    }
}
