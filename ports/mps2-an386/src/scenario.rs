//! The scenario's numbers exactly as the host derives them (`TickParams::of` of
//! `builtin:firmware`, `-cow`, `-regions`, `-soft` and `-tooth`): the host parses f64 and converts to
//! f32, so the firmware writes the same f64 literals and converts.

use tetradrill_core::drill::{DrillParams, Material};
use tetradrill_core::force::ForceParams;
use tetradrill_core::script::{Script, DEMO, DRILL_ON, TOOTH_ACCESS};
use tetradrill_core::storage::PartSet;
use tetradrill_core::Vec3;

/// `tool = "sphere:0.1"` (the tooth, in metres: `sphere:0.0007`).
pub const RADIUS: f32 = if cfg!(scenario_tooth) {
    0.0007_f64 as f32
} else {
    0.1_f64 as f32
};
/// The servo's extrapolation range: half the radius.
pub const REACH: f32 = 0.5 * RADIUS;
/// N per mesh unit (the tooth: N/m).
pub const STIFFNESS: f32 = if cfg!(scenario_tooth) {
    6_000.0_f64 as f32
} else {
    200.0_f64 as f32
};
/// N s/m.
pub const DAMPING: f32 = 0.5_f64 as f32;
/// N.
pub const MAX_FORCE: f32 = 8.0_f64 as f32;
/// `PERIOD_S` of the host, 1 kHz.
pub const DT: f32 = 1e-3_f64 as f32;
/// Deepest refinement level.
pub const MAX_DEPTH: u8 = 4;
/// Smallest face area refined.
pub const MIN_AREA: f32 = 0.0_f64 as f32;
/// Drill work units per tick.
pub const BUDGET: u32 = 300;
/// Hierarchy nodes one contact search may test (`contact_search_nodes`).
pub const CONTACT_NODES: u32 = 64;

/// Hierarchy arena nodes (`hierarchy_capacity`): 20,000 on the block, 40,000 on the cow,
/// 60,000 on the tooth; on a chip, [`chip::ARENA`].
pub const ARENA: usize = if CHIP {
    chip::ARENA
} else if cfg!(scenario_cow) {
    40_000
} else if cfg!(scenario_tooth) {
    60_000
} else {
    20_000
};
/// Entries of the drill's pending deque (`pending_capacity`, 60 bytes each): 16,384 on the
/// block (its peak is under 9,400), 8,192 on the cow (it fills there; the host's
/// `builtin:firmware-cow` drops the same work); on a chip, [`chip::PENDING`].
pub const PENDING_ITEMS: usize = if CHIP {
    chip::PENDING
} else if cfg!(scenario_cow) {
    8_192
} else {
    16_384
};
/// Coarse tets one step takes near the tool (`candidate_capacity`): the core's default 1,024
/// on the block; on the cow's finer tets 12,288, in thirds for its candidate gather (the tets
/// near the burr, the list in use, the list being gathered: `ZoneGather`); on a chip,
/// [`chip::CANDIDATES`].
pub const CANDIDATES: usize = if CHIP {
    chip::CANDIDATES
} else if cfg!(scenario_cow) {
    12_288
} else if cfg!(scenario_tooth) {
    3_072
} else {
    1_024
};
/// The cow's candidate gather (`zone_gather_work`): hash cells and entries scanned a step,
/// around a box a fifth of the radius wider than the zone, instead of one zone query a step
/// (which takes up to 270,000 instructions there).
pub const ZONE_WORK: u32 = 2_000;
/// The most hash cells a zone (or a gathered box) may cover on the cow: the host's choice for
/// its candidate list (half its length), so both give up on the same boxes.
pub const COW_MAX_CELLS: u32 = 6_144;
/// `builtin:firmware-soft`: physics steps a second (`soft_rate`), so ticks a step.
#[cfg(scenario_soft)]
pub const SOFT_RATE_HZ: f64 = 20.0;
/// Servo ticks a soft step: the host's `(1000 / soft_rate).round()`.
#[cfg(scenario_soft)]
pub const SOFT_TICKS: u32 = 50;
/// XPBD substeps a soft step (`soft_substeps`).
#[cfg(scenario_soft)]
pub const SOFT_SUBSTEPS: u32 = 4;
/// The soft body's material: the scenario's Young's modulus and the host's default Poisson
/// ratio (f64, converted as the host converts them) and its density (`soft::DENSITY`, an
/// f32).
#[cfg(scenario_soft)]
pub const SOFT_MATERIAL: tetradrill_core::soft::Material = tetradrill_core::soft::Material {
    young: 2_000.0_f64 as f32,
    poisson: 0.3_f64 as f32,
    density: 1000.0,
};
/// Sphere memo slots of `builtin:firmware-soft` (`World::commit_positions` empties the memo
/// each step; the results do not depend on its size).
pub const SOFT_SPHERE_MEMO: usize = 256;
/// The soft body's damping rate (the host's `soft::DAMPING`, an f32).
#[cfg(scenario_soft)]
pub const SOFT_DAMPING: f32 = 10.0;
/// Hash entries (`hash_capacity`): the host's default (8 a tet) but on a chip,
/// [`chip::HASH_ENTRIES`].
pub const HASH_ENTRIES: Option<usize> = if CHIP { Some(chip::HASH_ENTRIES) } else { None };
/// Sphere memo slots: the host's default (4,096) but on a chip, [`chip::SPHERE_MEMO`] (any
/// size gives the same results; a smaller one costs instructions, not bits).
pub const SPHERE_MEMO: Option<usize> = if CHIP { Some(chip::SPHERE_MEMO) } else { None };
/// The world's parts in its second array, in the chip's second region (none off a chip).
pub const SECOND_PARTS: PartSet = if CHIP {
    chip::SECOND_PARTS
} else {
    PartSet::EMPTY
};

/// A build for a named chip (`chip-f405` or `chip-h743`): its scenario sized for its memory.
pub const CHIP: bool = cfg!(any(feature = "chip-f405", feature = "chip-h743"));

/// The sizes of a chip's scenario, each from the peak the host measured on the scenario at the
/// default sizes (`tetradrill replay --scenario builtin:firmware[-regions|-tooth] --json`, its
/// `peaks`; docs/PORTING.md, "On named chips"). A buffer that holds its peak has it with a
/// margin of at least a quarter, rounded up to 64 entries (the hash's entries, fixed by the
/// mesh, exactly, rounded up to 64); a buffer the chip's RAM cannot give its peak (the arena,
/// the pending deque) gets what is left, and its saturations are counted, the same on the
/// host (`builtin:f405-block`, `builtin:f405-regions`, `builtin:h743-tooth` have these
/// sizes).
#[cfg(feature = "chip-f405")]
pub mod chip {
    use tetradrill_core::storage::{Part, PartSet};

    /// Hierarchy arena nodes: what the CCM and SRAM have left (the block's peak is 13,944).
    pub const ARENA: usize = 2_000;
    /// Pending deque entries: under `FINE_MIN_DEQUE` (1,024), one coarse ring (the block's
    /// peaks at 16,384 entries: 1,159 coarse, 1,483 fine).
    pub const PENDING: usize = 128;
    /// Candidates a step: the block's peak is 108.
    pub const CANDIDATES: usize = 192;
    /// Hash entries: the block's hash stores 2,058.
    pub const HASH_ENTRIES: usize = 2_112;
    /// Sphere memo slots.
    pub const SPHERE_MEMO: usize = 128;
    /// The world's parts in the CCM (the rest in SRAM).
    pub const SECOND_PARTS: PartSet = PartSet::EMPTY
        .with(Part::HashEntries)
        .with(Part::SphereMemo)
        .with(Part::Candidates);
}

/// The sizes of a chip's scenario (see the F405's).
#[cfg(feature = "chip-h743")]
pub mod chip {
    use tetradrill_core::storage::{Part, PartSet};

    /// Hierarchy arena nodes: what SRAM1-3 has left beside the tet boxes (the tooth's peak
    /// is 57,240).
    pub const ARENA: usize = 9_000;
    /// Pending deque entries: under `FINE_MIN_DEQUE` (1,024), one coarse ring, which peaks at
    /// 639 on the tooth with this arena (at 16,384 entries: 1,229 coarse, 519 fine).
    pub const PENDING: usize = 832;
    /// Candidates a step, in thirds (the tooth's peak is 283 a third).
    pub const CANDIDATES: usize = 1_152;
    /// Hash entries: the tooth's hash stores 23,824.
    pub const HASH_ENTRIES: usize = 23_872;
    /// Sphere memo slots.
    pub const SPHERE_MEMO: usize = 256;
    /// The world's parts in SRAM1-3 (the rest, the hash above all, in the AXI SRAM).
    pub const SECOND_PARTS: PartSet = PartSet::EMPTY
        .with(Part::TetBoxes)
        .with(Part::Arena)
        .with(Part::VList);
}

/// Off a chip: unused.
#[cfg(not(any(feature = "chip-f405", feature = "chip-h743")))]
pub mod chip {
    use tetradrill_core::storage::PartSet;

    /// Unused.
    pub const ARENA: usize = 0;
    /// Unused.
    pub const PENDING: usize = 0;
    /// Unused.
    pub const CANDIDATES: usize = 0;
    /// Unused.
    pub const HASH_ENTRIES: usize = 0;
    /// Unused.
    pub const SPHERE_MEMO: usize = 0;
    /// Unused.
    pub const SECOND_PARTS: PartSet = PartSet::EMPTY;
}

/// The scenario's name in the output (the host's built-in scenario of the same run).
pub const NAME: &str = if cfg!(feature = "chip-f405") {
    if cfg!(scenario_regions) {
        "builtin:f405-regions"
    } else {
        "builtin:f405-block"
    }
} else if cfg!(feature = "chip-h743") {
    "builtin:h743-tooth"
} else if cfg!(scenario_cow) {
    "builtin:firmware-cow"
} else if cfg!(scenario_tooth) {
    "builtin:firmware-tooth"
} else if cfg!(scenario_regions) {
    "builtin:firmware-regions"
} else if cfg!(scenario_soft) {
    "builtin:firmware-soft"
} else {
    "builtin:firmware"
};

/// The block's hard outer shell in `builtin:firmware-regions` (label 1): the host's
/// `demo_regions` numbers, parsed as f64 and converted as the host converts them.
#[cfg_attr(scenario_tooth, allow(dead_code))]
pub const SHELL: Material = Material {
    hardness: 300.0_f64 as f32,
    threshold: 2.0_f64 as f32,
    stiffness: 300.0_f64 as f32,
};
/// The block's soft core in `builtin:firmware-regions` (label 2).
#[cfg_attr(scenario_tooth, allow(dead_code))]
pub const CORE: Material = Material {
    hardness: 120.0_f64 as f32,
    threshold: 0.5_f64 as f32,
    stiffness: 150.0_f64 as f32,
};

/// The tooth's region labels in label order (enamel, dentin, pulp), as the host numbers its
/// regions; a tet's region index is its label's place here.
pub const TOOTH_LABELS: [i32; 3] = [1, 2, 3];
/// The tooth's enamel in `builtin:firmware-tooth` (label 1): the host's `tooth_regions`
/// numbers, parsed as f64 and converted as the host converts them.
#[cfg_attr(not(scenario_tooth), allow(dead_code))]
pub const ENAMEL: Material = Material {
    hardness: 1.0e9_f64 as f32,
    threshold: 1.0_f64 as f32,
    stiffness: 10_000.0_f64 as f32,
};
/// The tooth's dentin (label 2).
#[cfg_attr(not(scenario_tooth), allow(dead_code))]
pub const DENTIN: Material = Material {
    hardness: 2.0e8_f64 as f32,
    threshold: 0.5_f64 as f32,
    stiffness: 6_000.0_f64 as f32,
};
/// The tooth's pulp (label 3).
#[cfg_attr(not(scenario_tooth), allow(dead_code))]
pub const PULP: Material = Material {
    hardness: 4.0e6_f64 as f32,
    threshold: 0.1_f64 as f32,
    stiffness: 1_000.0_f64 as f32,
};

/// Scripted ticks to run: the whole path, or fewer when set at build time with
/// `TETRADRILL_TICKS=N` (the host then runs `replay --ticks N`).
const TICKS: Option<&str> = option_env!("TETRADRILL_TICKS");

/// A whole number given at build time (an empty or unset variable is `None`).
pub fn build_number(v: Option<&str>) -> Option<u32> {
    v.and_then(|s| s.parse().ok())
}

/// Drill work units per tick for this build: [`BUDGET`], or `TETRADRILL_BUDGET=N` at build
/// time for a settings sweep (the host then runs `replay --scenario builtin:firmware
/// --budget-per-tick N`).
pub fn budget() -> u32 {
    build_number(option_env!("TETRADRILL_BUDGET")).unwrap_or(BUDGET)
}

/// [`CONTACT_NODES`], or `TETRADRILL_CONTACT_NODES=N` at build time (host:
/// `--contact-search-nodes N`).
pub fn contact_nodes() -> u32 {
    build_number(option_env!("TETRADRILL_CONTACT_NODES")).unwrap_or(CONTACT_NODES)
}

/// The drill step's parameters.
pub fn drill_params() -> DrillParams {
    DrillParams {
        max_depth: MAX_DEPTH,
        min_area: MIN_AREA,
        budget: budget(),
    }
}

/// The servo's force parameters.
pub fn force_params() -> ForceParams {
    ForceParams {
        stiffness: STIFFNESS,
        damping: DAMPING,
        max_force: MAX_FORCE,
        dt: DT,
        ..ForceParams::default()
    }
}

/// The scripted path the device stand-in plays.
pub struct Scenario {
    /// The path.
    pub script: Script<'static>,
}

/// `builtin:firmware` and `builtin:firmware-cow`: the demo's path (over the unit block; on
/// the cow it drills the back).
pub static DEMO_PATH: Scenario = Scenario { script: DEMO };

/// `builtin:firmware-tooth`: the access cavity in the premolar.
pub static TOOTH_PATH: Scenario = Scenario {
    script: TOOTH_ACCESS,
};

/// The path of this build's scenario.
pub fn path() -> &'static Scenario {
    if cfg!(scenario_tooth) {
        &TOOTH_PATH
    } else {
        &DEMO_PATH
    }
}

impl Scenario {
    /// The pose and the drill button at tick `i`.
    #[inline(always)]
    pub fn pose(&self, i: u32) -> (Vec3, bool) {
        let (p, buttons) = self.script.at(i);
        (p, buttons & DRILL_ON != 0)
    }

    /// Ticks to run: the path's, or `TETRADRILL_TICKS` when fewer.
    pub fn ticks(&self) -> u32 {
        let all = self.script.ticks();
        build_number(TICKS).map_or(all, |t| t.min(all))
    }
}
