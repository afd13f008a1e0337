//! Scenarios: everything a run needs to know (mesh, tool, trace, stiffness, drilling limits,
//! capacities), with defaults in one place. A scenario comes from the defaults, then a TOML
//! file or a `builtin:NAME`, then the command-line flags, each overriding the one before.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::error::CliError;

mod regions;
pub use regions::{
    demo_regions, tooth_regions, RegionSpec, DEMO_CORE_YOUNG, DEMO_SHELL_YOUNG, TOOTH_DENTIN,
    TOOTH_ENAMEL, TOOTH_PULP,
};

/// Which way depth finds the surface intersections of border edges.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum DepthMethod {
    /// Walk the border edge through the tets to a boundary face (Praktikum report, section 4).
    Traced,
    /// Hash the boundary faces and query them with the edge (Heidelberger 2004).
    Hashed,
}

/// Where a mesh tool's border edges take their surface crossings from, tick after tick.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum Crossings {
    /// Every border edge searches (`depth_method`) every tick: the exact first crossing.
    Search,
    /// A border edge first tries the face it crossed last tick (one face test) and searches
    /// only when the edge no longer crosses it (`tetradrill_core::depth::DepthScratch::
    /// with_crossings`): not exact where a fold of the surface comes between.
    Reuse,
}

/// What the object is: rigid (its nodes never move) or a soft body whose nodes the simulation
/// loop moves with the core's XPBD physics (docs/SOFT.md, "On the command line").
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum Body {
    /// The mesh stays where it was loaded.
    #[default]
    Rigid,
    /// An elastic body (`young`, `poisson`, `fix_below`, `soft_rate`) pushed by the tool.
    Soft,
}

impl Body {
    /// `true` for [`Body::Rigid`] (the key is left out of a rigid scenario's JSON).
    pub fn is_rigid(&self) -> bool {
        *self == Body::Rigid
    }
}

/// A complete scenario. Field names are the TOML keys and match the flags.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Scenario {
    /// Mesh file, or `builtin:cube12` / `builtin:block:N` (the unit cube `[-0.5, 0.5]^3`).
    pub mesh: String,
    /// Factor applied to the mesh's coordinates.
    pub scale: f64,
    /// The integer cell array of a VTK or VTU mesh that holds its region labels (absent: the
    /// first of `tetradrill_meshio::REGION_ARRAYS` the file has).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub region_array: Option<String>,
    /// Trace CSV file, `builtin:demo`, `builtin:tooth-access`, or `wander:SEED` (a seeded random wander over the
    /// mesh's surface, drill on); positions in mesh units after `scale`.
    pub trace: String,
    /// `sphere:R` (a spherical burr of radius R), `drill:BURR_R:SHAFT_LEN:SHAFT_R` (a burr on
    /// a shaft from its centre along the tool's axis, +z rotated by the pose, whose passive
    /// points collide but never erode) or `mesh:FILE` (a tet-mesh tool, tip at
    /// the origin, axis +z).
    pub tool: String,
    /// Factor applied to a mesh tool's coordinates.
    pub tool_scale: f64,
    /// Newtons per mesh unit of penetration depth.
    pub stiffness: f64,
    /// Newton-seconds per mesh unit.
    pub damping: f64,
    /// Force clamp, newtons.
    pub max_force: f64,
    /// Milliseconds over which the burr's force moves from one contact plane to the next
    /// (`servo_force`); 0 switches at once.
    pub switch_ms: f64,
    /// Hardness of the default region (every label the `regions` table does not name),
    /// newton-seconds per cubic mesh unit: the burr pressing `F` newtons above the threshold
    /// removes `F / hardness` cubic mesh units a second (docs/DRILLING.md, "Materials"); 0
    /// removes at once.
    pub hardness: f64,
    /// Pressure threshold of the default region, newtons: below it the burr removes nothing.
    pub pressure_threshold: f64,
    /// Materials by region label (the mesh file's labels; the built-in block's shell is 1 and
    /// its core 2): `[regions.LABEL]` with `hardness`, `threshold`, `stiffness`, `colour`, and
    /// for a soft body `young`, `poisson`, `density`.
    #[serde(skip_serializing_if = "BTreeMap::is_empty")]
    pub regions: BTreeMap<String, RegionSpec>,
    /// Depth method for a mesh tool.
    pub depth_method: DepthMethod,
    /// Whether a mesh tool's border edges reuse last tick's crossing faces.
    pub crossings: Crossings,
    /// Mesh tool: servo ticks per contact pass. The pass (collisions and depths) runs every
    /// `contact_period`-th tick and the servo carries its penetrations to the pose of the
    /// ticks between (`tetradrill_core::force::pen_servo_force`); 1 passes every tick (exact).
    pub contact_period: u32,
    /// Mesh tool: threads of a contact pass, 1 or 2. With 2 the pass's object side runs on a
    /// second thread (`crate::pen_pair`): the same forces, bit for bit, in about the longer
    /// side's time; the second thread spins between passes while they come back to back.
    pub pass_threads: u32,
    /// Mesh tool: measure the pen's depths against the plane where it entered the object
    /// while a contact lasts (the Praktikum report's remedy, section 6, for a thin pen pushed
    /// sideways, `tetradrill_core::force::EntryPlane`; docs/CONTACT.md).
    pub entry_remedy: bool,
    /// Deepest subdivision level of a drilled tet.
    pub max_depth: u8,
    /// Refinement stops below this face area (mesh units squared).
    pub min_area: f64,
    /// Hierarchy nodes available for drilling (absent: sized from the burr's radius against
    /// the mesh's boundary tets, `crate::engine::ToolSizing`, at least
    /// [`DEFAULT_HIERARCHY_CAPACITY`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub hierarchy_capacity: Option<usize>,
    /// Work units of erosion per servo tick (about 100 Cortex-M4 instructions each:
    /// `tetradrill_core::drill::WorkCost`); the rest is carried to later ticks.
    pub budget_per_tick: u32,
    /// Work units for the whole simulation step, drill and contact search together (the
    /// search gets what the drill left, `tetradrill_core::servo::World::set_tick_budget`);
    /// 0: each has its own bound.
    pub tick_budget: u32,
    /// Entries of the static spatial hash of the mesh's tets (absent: 8 per tet).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub hash_capacity: Option<usize>,
    /// Coarse tets one simulation step may take near the tool (absent: sized from the burr's
    /// radius against the mesh's boundary tets, `crate::engine::ToolSizing`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub candidate_capacity: Option<usize>,
    /// v_list entries (absent: what the arena needs). Fewer than the arena needs shrink the
    /// arena to fit (refinements refused when it is full are counted as `arena`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub vlist_capacity: Option<usize>,
    /// Drill work items the pending deque holds (absent: sized from the burr's radius against
    /// the mesh's boundary tets, `crate::engine::ToolSizing`, at least
    /// `tetradrill_core::servo::DEFAULT_PENDING`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub pending_capacity: Option<usize>,
    /// Hierarchy nodes one contact search may test (then the closest face met, or the last
    /// step's, answers).
    pub contact_search_nodes: u32,
    /// A sphere tool's candidate tets gathered through the hash in parts of at most this many
    /// work units a step (cells and entries scanned) around a box a fifth of the radius wider
    /// than the zone, kept while the zone stays inside it
    /// (`tetradrill_core::collide::ZoneGather`); 0: one zone query every step.
    #[serde(skip_serializing_if = "is_zero")]
    pub zone_gather_work: u32,
    /// When a sphere tool's servo uses a simulation step's contact: 0, the step and the force
    /// in the same tick (step first); 1, the RTIC firmware's release rule: the servo computes
    /// tick `i`'s force from the contact of the step released at tick `i - 1`, then releases
    /// the step of tick `i` (docs/PORTING.md, "The release rule").
    #[serde(skip_serializing_if = "is_zero")]
    pub servo_lag: u32,
    /// Collisions each body of a tet-mesh tool contact may hold per tick, pen nodes in the
    /// object and object nodes in the pen (absent: each body's node count).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub contact_capacity: Option<usize>,
    /// Entries of each depth propagation queue of a tet-mesh tool contact (absent: each
    /// body's node count).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub queue_capacity: Option<usize>,
    /// `rigid` (default) or `soft`: an elastic body the tool dents (docs/SOFT.md).
    #[serde(skip_serializing_if = "Body::is_rigid")]
    pub body: Body,
    /// Soft body: Young's modulus, pascal (mesh units taken as metres; absent:
    /// `crate::soft::DEFAULT_YOUNG`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub young: Option<f64>,
    /// Soft body: Poisson ratio, `0..=0.49` (absent: `crate::soft::DEFAULT_POISSON`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub poisson: Option<f64>,
    /// Soft body: `AXIS:VALUE` (`x`, `y` or `z`): the nodes whose rest coordinate on that axis
    /// is at or below the value are fixed (absent: the lowest tenth of the body's z extent).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub fix_below: Option<String>,
    /// Soft body: physics steps a second; a whole number of 1 ms ticks per step, so a divisor
    /// of 1000 (absent: `crate::soft::DEFAULT_RATE_HZ`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub soft_rate: Option<f64>,
    /// Soft body: XPBD substeps a physics step, `1..=1000` (absent: `crate::soft::SUBSTEPS`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub soft_substeps: Option<u32>,
    /// Soft body: each physics step and the world's update spread over the ticks of its
    /// cycle, a bounded amount a tick, the positions a cycle later
    /// (`tetradrill_core::soft::Link`; docs/SOFT.md); false (default): the whole step at the
    /// cycle's last tick.
    #[serde(skip_serializing_if = "is_false")]
    pub soft_spread: bool,
}

/// `serde`'s `skip_serializing_if` for a flag whose default is false.
fn is_false(v: &bool) -> bool {
    !*v
}

/// A parsed `fix_below`: the axis (0, 1, 2 for x, y, z) and the value.
pub fn parse_fix_below(s: &str) -> Result<(usize, f64), String> {
    let bad = |why: &str| format!("fix_below `{s}`: {why}");
    let Some((axis, value)) = s.split_once(':') else {
        return Err(bad("expected AXIS:VALUE, for example z:-0.45"));
    };
    let axis = match axis.trim() {
        "x" | "X" => 0,
        "y" | "Y" => 1,
        "z" | "Z" => 2,
        _ => return Err(bad("the axis must be x, y or z")),
    };
    match value.trim().parse::<f64>() {
        Ok(v) if v.is_finite() => Ok((axis, v)),
        _ => Err(bad("the value must be a finite number")),
    }
}

/// Checks a soft body's rate: positive, at most 1000 Hz, a whole number of 1 ms ticks a step.
pub fn check_soft_rate(hz: f64) -> Result<(), String> {
    let ticks = 1000.0 / hz;
    if !(hz.is_finite() && hz > 0.0 && hz <= 1000.0) {
        return Err(format!("soft_rate must be in (0, 1000] Hz, got {hz}"));
    }
    if (ticks - ticks.round()).abs() > 1e-9 * ticks {
        return Err(format!(
            "soft_rate {hz} Hz is not a whole number of 1 ms ticks a step (1000 / {hz} = {ticks}); \
             use a divisor of 1000 such as 1000, 500, 250, 200, 100"
        ));
    }
    Ok(())
}

/// Largest storage one buffer may take. A larger capacity is refused as absurd: a mistyped
/// value would otherwise abort the allocation or push the machine into swap.
pub const MAX_BUFFER_BYTES: usize = 1 << 30;

/// One capacity of a scenario: its key (the TOML key, and the flag with `-` for `_`), the
/// bytes of one entry (0: a bound on work, not storage) and the smallest value that works.
#[derive(Debug, Clone, Copy)]
pub struct Capacity {
    /// TOML key.
    pub key: &'static str,
    /// Bytes per entry.
    pub entry_bytes: usize,
    /// Smallest value accepted.
    pub min: usize,
}

impl Capacity {
    /// The command-line flag.
    pub fn flag(&self) -> String {
        format!("--{}", self.key.replace('_', "-"))
    }

    /// Largest value accepted: [`MAX_BUFFER_BYTES`] of entries, and ids fit in `u32`.
    pub fn max(&self) -> usize {
        let by_bytes = MAX_BUFFER_BYTES
            .checked_div(self.entry_bytes)
            .unwrap_or(usize::MAX);
        by_bytes.min(u32::MAX as usize)
    }

    /// `Ok` when `v` is within `min..=max`, else one line naming the key and the flag.
    pub fn check(&self, v: usize) -> Result<(), String> {
        if (self.min..=self.max()).contains(&v) {
            return Ok(());
        }
        let unit = if self.entry_bytes == 0 {
            String::new()
        } else {
            format!(" ({} MiB at most)", MAX_BUFFER_BYTES >> 20)
        };
        Err(format!(
            "{} ({}) must be {}..={}{unit}, got {v}",
            self.key,
            self.flag(),
            self.min,
            self.max()
        ))
    }
}

/// Every capacity a scenario sets, in one place (docs/SAFETY.md lists what each does when full).
pub const CAPACITIES: [Capacity; 8] = {
    use std::mem::size_of;
    use tetradrill_core::collide::Collision;
    use tetradrill_core::depth::Penetration;
    use tetradrill_core::drill::Pending;
    use tetradrill_core::hash::HashEntry;
    use tetradrill_core::hierarchy::{HNode, VEntry};
    [
        // One block of eight children at least: a smaller arena holds no block at all.
        Capacity {
            key: "hierarchy_capacity",
            entry_bytes: size_of::<HNode>(),
            min: 8,
        },
        Capacity {
            key: "hash_capacity",
            entry_bytes: size_of::<HashEntry>(),
            min: 1,
        },
        Capacity {
            key: "candidate_capacity",
            entry_bytes: size_of::<tetradrill_core::TetId>(),
            min: 1,
        },
        Capacity {
            key: "vlist_capacity",
            entry_bytes: size_of::<VEntry>(),
            min: 1,
        },
        Capacity {
            key: "pending_capacity",
            entry_bytes: size_of::<Pending>(),
            min: 1,
        },
        Capacity {
            key: "contact_search_nodes",
            entry_bytes: 0,
            min: 1,
        },
        Capacity {
            key: "contact_capacity",
            entry_bytes: size_of::<Collision>() + size_of::<Penetration>(),
            min: 1,
        },
        Capacity {
            key: "queue_capacity",
            entry_bytes: size_of::<tetradrill_core::NodeId>(),
            min: 1,
        },
    ]
};

/// The capacity named `key` (one of [`CAPACITIES`]).
pub fn capacity(key: &str) -> Option<Capacity> {
    CAPACITIES.iter().copied().find(|c| c.key == key)
}

impl Default for Scenario {
    fn default() -> Self {
        Self {
            mesh: "builtin:block:8".into(),
            scale: 1.0,
            region_array: None,
            trace: "builtin:demo".into(),
            tool: "sphere:0.1".into(),
            tool_scale: 1.0,
            stiffness: 200.0,
            damping: 0.5,
            max_force: 8.0,
            switch_ms: 16.0,
            hardness: 0.0,
            pressure_threshold: 0.0,
            regions: BTreeMap::new(),
            depth_method: DepthMethod::Traced,
            crossings: Crossings::Reuse,
            contact_period: 1,
            pass_threads: 1,
            entry_remedy: false,
            max_depth: 5,
            min_area: 0.0,
            hierarchy_capacity: None,
            budget_per_tick: 11_000,
            tick_budget: DEFAULT_TICK_BUDGET,
            hash_capacity: None,
            candidate_capacity: None,
            vlist_capacity: None,
            pending_capacity: None,
            contact_search_nodes: tetradrill_core::servo::CONTACT_MAX_NODES,
            zone_gather_work: 0,
            servo_lag: 0,
            contact_capacity: None,
            queue_capacity: None,
            body: Body::Rigid,
            young: None,
            poisson: None,
            fix_below: None,
            soft_rate: None,
            soft_substeps: None,
            soft_spread: false,
        }
    }
}

/// The least hierarchy arena a burr gets when the scenario does not size it: 2^20 nodes
/// (16 MiB), what a burr about one boundary tet wide needs over long sessions
/// (docs/DRILLING.md).
pub const DEFAULT_HIERARCHY_CAPACITY: usize = 1 << 20;

/// Default work units of a whole simulation step, drill and contact search together
/// (`--tick-budget`): the drill's 11,000 plus about 900 contact-node tests of 6 units. On this
/// machine it keeps the demo's whole tick under 200 us (max 184 us, each tick's fastest of 3,
/// against 438 us with separate bounds), removing the same material, at the price of contact
/// searches cut short on busy drilling ticks: force errors above 1 N against the exhaustive
/// contact on 75 of 6,001 ticks (docs/DRILLING.md, "One budget for the whole tick").
pub const DEFAULT_TICK_BUDGET: u32 = 16_500;

/// The scenario flags shared by `demo`, `run` and `replay`; each overrides the scenario.
#[derive(Debug, Clone, Default, clap::Args)]
pub struct ScenarioFlags {
    /// A scenario file (TOML, keys as these flags with `_` for `-`) or `builtin:demo`,
    /// `builtin:firmware`, `builtin:firmware-cow`, `builtin:firmware-regions`,
    /// `builtin:firmware-soft`, `builtin:firmware-tooth`.
    #[arg(long)]
    pub scenario: Option<String>,
    /// Mesh file or `builtin:cube12`, `builtin:block:N`.
    #[arg(long)]
    pub mesh: Option<String>,
    /// Scale the mesh's coordinates.
    #[arg(long, allow_negative_numbers = true, value_parser = positive)]
    pub scale: Option<f64>,
    /// The integer cell array of a VTK/VTU mesh holding region labels.
    #[arg(long, value_name = "NAME")]
    pub region_array: Option<String>,
    /// Trace CSV (`t,x,y,z,qw,qx,qy,qz,buttons`), `builtin:demo`, `builtin:tooth-access` or
    /// `wander:SEED`.
    #[arg(long)]
    pub trace: Option<String>,
    /// `sphere:R`, `drill:BURR_R:SHAFT_LEN:SHAFT_R` or `mesh:FILE`.
    #[arg(long)]
    pub tool: Option<String>,
    /// Scale a mesh tool's coordinates.
    #[arg(long, allow_negative_numbers = true, value_parser = positive)]
    pub tool_scale: Option<f64>,
    /// Stiffness, newtons per mesh unit of depth.
    #[arg(long, allow_negative_numbers = true, value_parser = positive)]
    pub stiffness: Option<f64>,
    /// Damping, newton-seconds per mesh unit.
    #[arg(long, allow_negative_numbers = true, value_parser = non_negative)]
    pub damping: Option<f64>,
    /// Force clamp, newtons.
    #[arg(long, allow_negative_numbers = true, value_parser = positive)]
    pub max_force: Option<f64>,
    /// Milliseconds over which the burr's force moves from one contact plane to the next (0:
    /// at once).
    #[arg(long, allow_negative_numbers = true, value_parser = non_negative)]
    pub switch_ms: Option<f64>,
    /// Hardness of the default region, newton-seconds per cubic mesh unit (0: removed at
    /// once).
    #[arg(long, allow_negative_numbers = true, value_parser = non_negative)]
    pub hardness: Option<f64>,
    /// Pressure threshold of the default region, newtons (the burr removes nothing below it).
    #[arg(long, allow_negative_numbers = true, value_parser = non_negative)]
    pub pressure_threshold: Option<f64>,
    /// Depth method for a mesh tool.
    #[arg(long, value_enum)]
    pub depth_method: Option<DepthMethod>,
    /// Mesh tool: `reuse` last tick's crossing face of each border edge when it still holds
    /// (default), or `search` every tick (exact).
    #[arg(long, value_enum)]
    pub crossings: Option<Crossings>,
    /// Mesh tool: servo ticks per contact pass (1..=1000); between passes the servo carries
    /// the last pass's penetrations to the current pose. 1 (default): a pass every tick.
    #[arg(long, allow_negative_numbers = true, value_parser = clap::value_parser!(u32).range(1..=1000))]
    pub contact_period: Option<u32>,
    /// Mesh tool: threads of a contact pass, 1 (default) or 2 (the object side on a second
    /// thread: the same forces, about half the pass's time on two free cores).
    #[arg(long, allow_negative_numbers = true, value_parser = clap::value_parser!(u32).range(1..=2))]
    pub pass_threads: Option<u32>,
    /// Mesh tool: the entry-plane remedy for a thin pen pushed sideways (Praktikum report,
    /// section 6): `--entry-remedy` or `--entry-remedy true|false` (default false).
    #[arg(long, num_args = 0..=1, default_missing_value = "true", value_name = "BOOL")]
    pub entry_remedy: Option<bool>,
    /// Deepest subdivision level (1..=9).
    #[arg(long, allow_negative_numbers = true, value_parser = clap::value_parser!(u8).range(1..=9))]
    pub max_depth: Option<u8>,
    /// Smallest face area refined (mesh units squared).
    #[arg(long, allow_negative_numbers = true, value_parser = non_negative)]
    pub min_area: Option<f64>,
    /// Hierarchy nodes available (at least 8: one block of children).
    #[arg(long, allow_negative_numbers = true, value_parser = clap::value_parser!(usize))]
    pub hierarchy_capacity: Option<usize>,
    /// Work units of erosion per tick (about 100 Cortex-M4 instructions each).
    #[arg(long, allow_negative_numbers = true, value_parser = clap::value_parser!(u32).range(1..))]
    pub budget_per_tick: Option<u32>,
    /// Work units for the whole step, drill and contact search together (the search gets
    /// what the drill left); 0: separate bounds.
    #[arg(long, allow_negative_numbers = true, value_parser = clap::value_parser!(u32))]
    pub tick_budget: Option<u32>,
    /// Entries of the static tet hash (default: 8 per tet).
    #[arg(long, allow_negative_numbers = true, value_parser = clap::value_parser!(usize))]
    pub hash_capacity: Option<usize>,
    /// Coarse tets one simulation step takes near the tool.
    #[arg(long, allow_negative_numbers = true, value_parser = clap::value_parser!(usize))]
    pub candidate_capacity: Option<usize>,
    /// v_list entries (default: what the arena needs; fewer shrink the arena to fit).
    #[arg(long, allow_negative_numbers = true, value_parser = clap::value_parser!(usize))]
    pub vlist_capacity: Option<usize>,
    /// Drill work items carried from tick to tick.
    #[arg(long, allow_negative_numbers = true, value_parser = clap::value_parser!(usize))]
    pub pending_capacity: Option<usize>,
    /// Hierarchy nodes one contact search may test.
    #[arg(long, allow_negative_numbers = true, value_parser = clap::value_parser!(u32))]
    pub contact_search_nodes: Option<u32>,
    /// Sphere tool: 0, each tick's force from its own simulation step; 1, from the step
    /// released the tick before (the RTIC firmware's release rule).
    #[arg(long, allow_negative_numbers = true, value_parser = clap::value_parser!(u32).range(0..=1))]
    pub servo_lag: Option<u32>,
    /// Collisions per body per tick of a mesh tool (default: the body's node count).
    #[arg(long, allow_negative_numbers = true, value_parser = clap::value_parser!(usize))]
    pub contact_capacity: Option<usize>,
    /// Depth propagation queue entries per body of a mesh tool (default: its node count).
    #[arg(long, allow_negative_numbers = true, value_parser = clap::value_parser!(usize))]
    pub queue_capacity: Option<usize>,
    /// `rigid` (default) or `soft`: an elastic body the tool dents.
    #[arg(long, value_enum)]
    pub body: Option<Body>,
    /// Soft body: Young's modulus, pascal (mesh units as metres).
    #[arg(long, allow_negative_numbers = true, value_parser = positive, value_name = "PA")]
    pub young: Option<f64>,
    /// Soft body: Poisson ratio, 0..=0.49.
    #[arg(long, allow_negative_numbers = true, value_parser = poisson, value_name = "NU")]
    pub poisson: Option<f64>,
    /// Soft body: fix the nodes whose rest coordinate on AXIS is at or below VALUE
    /// (`z:-0.45`; default: the lowest tenth in z).
    #[arg(long, allow_negative_numbers = true, value_parser = fix_below, value_name = "AXIS:VALUE")]
    pub fix_below: Option<String>,
    /// Soft body: physics steps a second, a divisor of 1000 (default 250).
    #[arg(long, allow_negative_numbers = true, value_parser = soft_rate, value_name = "HZ")]
    pub soft_rate: Option<f64>,
    /// Soft body: XPBD substeps a physics step, 1..=1000 (default 10).
    #[arg(long, allow_negative_numbers = true, value_parser = clap::value_parser!(u32).range(1..=1000), value_name = "N")]
    pub soft_substeps: Option<u32>,
    /// Soft body: spread each physics step and the world's update over the ticks of its
    /// cycle (bounded work a tick, positions a cycle later): `--soft-spread` or
    /// `--soft-spread true|false` (default false).
    #[arg(long, num_args = 0..=1, default_missing_value = "true", value_name = "BOOL")]
    pub soft_spread: Option<bool>,
}

fn poisson(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if (0.0..=0.49).contains(&v) => Ok(v),
        _ => Err(format!("`{s}` is not a Poisson ratio in 0..=0.49")),
    }
}

fn fix_below(s: &str) -> Result<String, String> {
    parse_fix_below(s).map(|_| s.to_string())
}

fn soft_rate(s: &str) -> Result<f64, String> {
    let v = s
        .parse::<f64>()
        .map_err(|_| format!("`{s}` is not a number of hertz"))?;
    check_soft_rate(v).map(|()| v)
}

/// `serde`'s `skip_serializing_if` for a key whose default is 0.
fn is_zero(v: &u32) -> bool {
    *v == 0
}

fn positive(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 => Ok(v),
        _ => Err(format!("`{s}` is not a positive number")),
    }
}

/// Parses a positive, finite number of seconds (a clap value parser).
pub fn positive_seconds(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 => Ok(v),
        _ => Err(format!("`{s}` is not a positive number of seconds")),
    }
}

fn non_negative(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if v.is_finite() && v >= 0.0 => Ok(v),
        _ => Err(format!("`{s}` is not a non-negative number")),
    }
}

/// A built-in scenario by name.
pub fn builtin(name: &str) -> Option<Scenario> {
    match name {
        // The demo's block has two regions (`tetradrill_core::builtin::block_labels`): a hard
        // outer shell and a soft core (docs/DRILLING.md, "Materials").
        "demo" => Some(Scenario {
            regions: demo_regions(),
            ..Scenario::default()
        }),
        // Small enough for the Cortex-M4 firmware's static storage; same path as the demo.
        // The firmware's numbers (ports/mps2-an386/src/main.rs and storage.rs): a budget and a
        // contact-search bound sized for a tick of a few hundred thousand instructions on a
        // Cortex-M4 (docs/PORTING.md), a pending deque that never fills on this path.
        "firmware" => Some(Scenario {
            mesh: "builtin:block:4".into(),
            max_depth: 4,
            hierarchy_capacity: Some(20_000),
            budget_per_tick: 300,
            contact_search_nodes: 64,
            pending_capacity: Some(16_384),
            tick_budget: 0,
            servo_lag: 1,
            ..Scenario::default()
        }),
        // The firmware scenario on the shared cow (18,098 tets; `scripts/port-check.sh
        // --scenario cow`): the same path and settings, sized for the firmware's 4 MB of RAM
        // (ports/mps2-an386/src/scenario.rs holds the same numbers).
        "firmware-cow" => Some(Scenario {
            mesh: firmware_cow_mesh(),
            hierarchy_capacity: Some(40_000),
            pending_capacity: Some(8_192),
            candidate_capacity: Some(12_288),
            zone_gather_work: 2_000,
            ..builtin("firmware")?
        }),
        // The firmware scenario with the demo's two materials on the block's shell and core
        // (`scripts/port-check.sh --scenario regions`; ports/mps2-an386/src/scenario.rs holds
        // the same numbers).
        "firmware-regions" => Some(Scenario {
            regions: demo_regions(),
            ..builtin("firmware")?
        }),
        // The firmware scenario on the premolar (`scripts/port-check.sh --scenario tooth`):
        // a 0.7 mm burr (an ISO 014 round burr) cuts an access cavity through the enamel into
        // the dentin and opens the pulp chamber (`script::TOOTH_ACCESS`), with the tooth's
        // three materials (`tooth_regions`); metres and newtons. The capacities hold the whole
        // path (ports/mps2-an386/src/scenario.rs holds the same numbers).
        "firmware-tooth" => Some(Scenario {
            mesh: test_mesh(TOOTH),
            trace: "builtin:tooth-access".into(),
            tool: "sphere:0.0007".into(),
            stiffness: 6_000.0,
            regions: tooth_regions(),
            hierarchy_capacity: Some(60_000),
            pending_capacity: Some(16_384),
            // The candidates gathered over steps, as on the cow (in thirds of 3,072): a zone
            // query every step left the M4 3 % of its period.
            candidate_capacity: Some(3_072),
            zone_gather_work: 2_000,
            ..builtin("firmware")?
        }),
        // The firmware block soft (`scripts/port-check.sh --scenario soft`): its step and the
        // world's update spread over the ticks of each cycle, sized so that a tick's share
        // fits the Cortex-M4's period beside the simulation step (docs/SOFT.md, "On the
        // Cortex-M4"; ports/mps2-an386/src/scenario.rs holds the same numbers).
        "firmware-soft" => Some(Scenario {
            body: Body::Soft,
            young: Some(FIRMWARE_SOFT_YOUNG),
            soft_rate: Some(FIRMWARE_SOFT_RATE),
            soft_substeps: Some(FIRMWARE_SOFT_SUBSTEPS),
            soft_spread: true,
            ..builtin("firmware")?
        }),
        _ => None,
    }
}

/// Young's modulus of `builtin:firmware-soft`, pascal: the demo's `--soft` block's, a dent
/// of several millimetres under the firmware path's force.
pub const FIRMWARE_SOFT_YOUNG: f64 = 2_000.0;
/// Physics steps a second of `builtin:firmware-soft`.
pub const FIRMWARE_SOFT_RATE: f64 = 20.0;
/// XPBD substeps a step of `builtin:firmware-soft`.
pub const FIRMWARE_SOFT_SUBSTEPS: u32 = 4;

/// The tooth of `builtin:firmware-tooth`, in the project's test data folder.
pub const TOOTH: &str = "models/tooth_premolar_gmsh.msh22.msh";

/// `NAME` (a path relative to the test data folder) in the folder `TETRADRILL_MESHES` names
/// when it has one, else in the project's test data.
fn test_mesh(name: &str) -> String {
    if let Some(dir) = std::env::var_os("TETRADRILL_MESHES") {
        let p = Path::new(&dir).join(name);
        if p.is_file() {
            return p.to_string_lossy().into_owned();
        }
    }
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../tests/data/meshes")
        .join(name)
        .to_string_lossy()
        .into_owned()
}

/// The cow of `builtin:firmware-cow`: `models/spot_tetgen_q1.414.node` in the folder
/// `TETRADRILL_MESHES` names when it has one, else in the project's test data.
fn firmware_cow_mesh() -> String {
    test_mesh("models/spot_tetgen_q1.414.node")
}

impl Scenario {
    /// Loads `builtin:NAME` or a TOML file. Unknown keys and bad values exit 2 naming the
    /// file and line.
    pub fn load(spec: &str) -> Result<Self, CliError> {
        if let Some(name) = spec.strip_prefix("builtin:") {
            return builtin(name).ok_or_else(|| {
                CliError::input(format!(
                    "unknown scenario `{spec}` (built-in: builtin:demo, builtin:firmware, builtin:firmware-cow, builtin:firmware-regions, builtin:firmware-soft, builtin:firmware-tooth)"
                ))
            });
        }
        let path = Path::new(spec);
        let text = std::fs::read_to_string(path)
            .map_err(|e| CliError::at(path, None, format!("cannot read scenario: {e}")))?;
        let sc: Scenario = toml::from_str(&text).map_err(|e| {
            let line = e
                .span()
                .map(|s| text[..s.start.min(text.len())].matches('\n').count() + 1);
            CliError::at(path, line, e.message().replace('\n', " "))
        })?;
        sc.problem().map_err(|(key, m)| {
            // A bad region: the line of its own table when it has one.
            let region = (key == "regions")
                .then(|| sc.region_problem().err())
                .flatten()
                .and_then(|(label, _)| key_line(&text, &format!("regions.{label}")));
            CliError::at(path, region.or_else(|| key_line(&text, key)), m)
        })?;
        Ok(sc)
    }

    /// Applies the scenario flags: first `--scenario`, then each flag given.
    pub fn from_flags(f: &ScenarioFlags) -> Result<Self, CliError> {
        let mut s = match &f.scenario {
            Some(spec) => Self::load(spec)?,
            None => Self::default(),
        };
        macro_rules! take {
            ($($field:ident),*) => { $( if let Some(v) = &f.$field { s.$field = v.clone(); } )* };
        }
        take!(mesh, scale, trace, tool, tool_scale, stiffness, damping, max_force);
        take!(switch_ms, hardness, pressure_threshold);
        take!(
            depth_method,
            crossings,
            contact_period,
            pass_threads,
            entry_remedy,
            max_depth,
            min_area,
            budget_per_tick,
            tick_budget
        );
        take!(contact_search_nodes, servo_lag, body);
        if let Some(v) = &f.fix_below {
            s.fix_below = Some(v.clone());
        }
        macro_rules! take_some {
            ($($field:ident),*) => { $( if let Some(v) = f.$field { s.$field = Some(v); } )* };
        }
        if let Some(v) = &f.region_array {
            s.region_array = Some(v.clone());
        }
        take_some!(
            hierarchy_capacity,
            candidate_capacity,
            pending_capacity,
            hash_capacity,
            vlist_capacity,
            contact_capacity,
            queue_capacity,
            young,
            poisson,
            soft_rate,
            soft_substeps
        );
        if let Some(v) = f.soft_spread {
            s.soft_spread = v;
        }
        s.check().map_err(CliError::input)?;
        Ok(s)
    }

    /// Values no flag parser can refuse on its own (a scenario file sets them directly).
    pub fn check(&self) -> Result<(), String> {
        self.problem().map_err(|(_, m)| m)
    }

    /// The first bad value: its key and one line saying why.
    pub fn problem(&self) -> Result<(), (&'static str, String)> {
        let pos = |name: &'static str, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err((name, format!("{name} must be a positive number, got {v}")))
            }
        };
        pos("scale", self.scale)?;
        pos("tool_scale", self.tool_scale)?;
        pos("stiffness", self.stiffness)?;
        pos("max_force", self.max_force)?;
        if !(self.damping.is_finite() && self.damping >= 0.0) {
            return Err((
                "damping",
                format!("damping must be non-negative, got {}", self.damping),
            ));
        }
        if !(self.switch_ms.is_finite() && self.switch_ms >= 0.0) {
            return Err((
                "switch_ms",
                format!("switch_ms must be non-negative, got {}", self.switch_ms),
            ));
        }
        for (key, v) in [
            ("hardness", self.hardness),
            ("pressure_threshold", self.pressure_threshold),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err((key, format!("{key} must be non-negative, got {v}")));
            }
        }
        self.region_problem().map_err(|(_, m)| ("regions", m))?;
        if !(self.min_area.is_finite() && self.min_area >= 0.0) {
            return Err((
                "min_area",
                format!("min_area must be non-negative, got {}", self.min_area),
            ));
        }
        if !(1..=9).contains(&self.max_depth) {
            return Err((
                "max_depth",
                format!("max_depth must be 1..=9, got {}", self.max_depth),
            ));
        }
        if !(1..=1000).contains(&self.contact_period) {
            return Err((
                "contact_period",
                format!(
                    "contact_period must be 1..=1000, got {}",
                    self.contact_period
                ),
            ));
        }
        if !(1..=2).contains(&self.pass_threads) {
            return Err((
                "pass_threads",
                format!("pass_threads must be 1 or 2, got {}", self.pass_threads),
            ));
        }
        if self.servo_lag > 1 {
            return Err((
                "servo_lag",
                format!("servo_lag must be 0 or 1, got {}", self.servo_lag),
            ));
        }
        if self.budget_per_tick == 0 {
            return Err((
                "budget_per_tick",
                "budget_per_tick must be at least 1".into(),
            ));
        }
        for c in CAPACITIES {
            if let Some(v) = self.capacity_value(c.key) {
                c.check(v).map_err(|m| (c.key, m))?;
            }
        }
        self.tool_kind().map_err(|m| ("tool", m))?;
        if let Some(e) = self.young {
            if !(e.is_finite() && e > 0.0 && e < f32::MAX as f64) {
                return Err(("young", format!("young must be a positive number, got {e}")));
            }
        }
        if let Some(nu) = self.poisson {
            if !(0.0..=0.49).contains(&nu) {
                return Err(("poisson", format!("poisson must be in 0..=0.49, got {nu}")));
            }
        }
        if let Some(f) = &self.fix_below {
            parse_fix_below(f).map_err(|m| ("fix_below", m))?;
        }
        if let Some(hz) = self.soft_rate {
            check_soft_rate(hz).map_err(|m| ("soft_rate", m))?;
        }
        if let Some(n) = self.soft_substeps {
            if !(1..=tetradrill_core::soft::MAX_SUBSTEPS).contains(&n) {
                return Err((
                    "soft_substeps",
                    format!("soft_substeps must be 1..=1000, got {n}"),
                ));
            }
        }
        Ok(())
    }

    /// The first bad `[regions]` entry: its label and one line saying why.
    pub fn region_problem(&self) -> Result<(), (String, String)> {
        for (label, r) in &self.regions {
            if label.trim().parse::<i32>().is_err() {
                return Err((
                    label.clone(),
                    format!("regions: `{label}` is not a region label (an integer)"),
                ));
            }
            for (what, v, ok) in [
                ("hardness", r.hardness, r.hardness >= 0.0),
                ("threshold", r.threshold, r.threshold >= 0.0),
                (
                    "stiffness",
                    r.stiffness.unwrap_or(1.0),
                    r.stiffness.is_none_or(|k| k > 0.0),
                ),
            ] {
                if !(v.is_finite() && ok) {
                    let sign = if what == "stiffness" {
                        "positive"
                    } else {
                        "non-negative"
                    };
                    return Err((
                        label.clone(),
                        format!("regions.{label}.{what} must be a {sign} number, got {v}"),
                    ));
                }
            }
            r.rgb()
                .map_err(|m| (label.clone(), format!("regions.{label}: {m}")))?;
            r.soft_problem()
                .map_err(|(key, m)| (label.clone(), format!("regions.{label}.{key} {m}")))?;
        }
        Ok(())
    }

    /// The value of the capacity `key` when the scenario sets one.
    pub fn capacity_value(&self, key: &str) -> Option<usize> {
        match key {
            "hierarchy_capacity" => self.hierarchy_capacity,
            "hash_capacity" => self.hash_capacity,
            "candidate_capacity" => self.candidate_capacity,
            "vlist_capacity" => self.vlist_capacity,
            "pending_capacity" => self.pending_capacity,
            "contact_search_nodes" => Some(self.contact_search_nodes as usize),
            "contact_capacity" => self.contact_capacity,
            "queue_capacity" => self.queue_capacity,
            _ => None,
        }
    }

    /// The tool as parsed from `tool`.
    pub fn tool_kind(&self) -> Result<ToolKind, String> {
        if let Some(r) = self.tool.strip_prefix("sphere:") {
            match r.parse::<f64>() {
                Ok(r) if r.is_finite() && r > 0.0 => Ok(ToolKind::Sphere(r)),
                _ => Err(format!(
                    "tool `{}`: the radius must be a positive number",
                    self.tool
                )),
            }
        } else if let Some(rest) = self.tool.strip_prefix("drill:") {
            let v: Vec<Option<f64>> = rest.split(':').map(|x| x.parse::<f64>().ok()).collect();
            let bad = |why: &str| Err(format!("tool `{}`: {why}", self.tool));
            let [Some(burr), Some(len), Some(shaft)] = v[..] else {
                return bad("expected drill:BURR_R:SHAFT_LEN:SHAFT_R (three numbers)");
            };
            if ![burr, len, shaft].iter().all(|x| x.is_finite() && *x > 0.0) {
                return bad("the radii and the length must be positive numbers");
            }
            if shaft > burr {
                return bad("the shaft's radius must be at most the burr's radius");
            }
            if len <= burr {
                return bad("the shaft must be longer than the burr's radius");
            }
            Ok(ToolKind::Drill {
                burr,
                shaft_length: len,
                shaft_radius: shaft,
            })
        } else if let Some(file) = self.tool.strip_prefix("mesh:") {
            if file.is_empty() {
                Err("tool `mesh:` needs a file".into())
            } else {
                Ok(ToolKind::Mesh(PathBuf::from(file)))
            }
        } else {
            Err(format!(
                "tool `{}`: expected sphere:R or mesh:FILE, or drill:BURR_R:SHAFT_LEN:SHAFT_R",
                self.tool
            ))
        }
    }
}

/// The 1-based line of a TOML text where `key` is set (`key = ...` at the start of a line),
/// or where its table starts (`[key]` or `[key.` at the start of a line).
fn key_line(text: &str, key: &str) -> Option<usize> {
    text.lines()
        .position(|l| {
            let l = l.trim_start();
            l.strip_prefix(key)
                .is_some_and(|rest| rest.trim_start().starts_with('='))
                || l.strip_prefix('[')
                    .and_then(|rest| rest.trim_start().strip_prefix(key))
                    .is_some_and(|rest| rest.trim_start().starts_with(']') || rest.starts_with('.'))
        })
        .map(|i| i + 1)
}

/// The tool of a scenario.
#[derive(Debug, Clone, PartialEq)]
pub enum ToolKind {
    /// A spherical burr of this radius (mesh units).
    Sphere(f64),
    /// A burr on a shaft (mesh units): the burr's radius, the shaft's length from the burr's
    /// centre to the handle and its radius.
    Drill {
        /// Burr radius.
        burr: f64,
        /// Shaft length, burr centre to handle.
        shaft_length: f64,
        /// Shaft radius.
        shaft_radius: f64,
    },
    /// A tet-mesh tool from this file.
    Mesh(PathBuf),
}

#[cfg(test)]
mod tests;
