//! Scenarios: a session's set-up as the command line and scenario files write it, flat, one
//! key per value, with defaults from [`Setup::default`]. A scenario comes from the defaults,
//! then a TOML file or a `builtin:NAME`, then the command-line flags, each overriding the one
//! before; [`Scenario::setup`] turns it into the typed [`Setup`] once, and everything below
//! the command line takes that.

use std::collections::BTreeMap;
use std::path::Path;

mod builtins;
mod chips;
pub use builtins::*;
pub use chips::*;
pub mod teeth;

use serde::{Deserialize, Serialize};

use crate::error::CliError;
use crate::setup::{
    demo_regions, tooth_regions, Body, Capacities, Crossings, DepthMethod, Drilling, FixBelow,
    Forces, Materials, MeshSpec, PenContact, Poses, RegionSpec, Setup, SetupError, SoftSettings,
    Spin, Tool,
};

/// What the object is, as a flag or key: rigid or soft (the soft values are their own keys).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum BodyKind {
    /// The mesh stays where it was loaded.
    #[default]
    Rigid,
    /// An elastic body (`young`, `poisson`, `fix_below`, `soft_rate`) pushed by the tool.
    Soft,
}

impl BodyKind {
    /// `true` for [`BodyKind::Rigid`] (the key is left out of a rigid scenario's JSON).
    pub fn is_rigid(&self) -> bool {
        *self == BodyKind::Rigid
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
    /// Trace CSV file, `builtin:demo`, `builtin:tooth-access`, `builtin:premolar-access`, or `wander:SEED` (a seeded random wander over the
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
    /// The burr's vibration while it cuts, hertz (0: none, at most 500); its amplitude is each
    /// region's `vibration` (docs/DRILLING.md, "Vibration").
    #[serde(skip_serializing_if = "is_zero_f64")]
    pub vibration_hz: f64,
    /// Which way the burr spins while the drill is on, `cw` (clockwise seen from the handle,
    /// the default) or `ccw`: the direction of each region's sideways pull (`friction`).
    #[serde(skip_serializing_if = "Spin::is_default")]
    pub spin: Spin,
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
    /// The drill's finest leaf edge, mesh units: each coarse tet refines only as deep as its
    /// size needs (`max_depth` stays the upper bound), so fine and coarse meshes drill with
    /// leaves of the same size; 0: none, every tet to `max_depth`; absent: the burr's radius
    /// over [`crate::setup::RESOLUTION_PER_RADIUS`].
    pub resolution: Option<f64>,
    /// Hierarchy nodes available for drilling (absent: sized from the burr's radius against
    /// the mesh's boundary tets, `crate::engine::ToolSizing`, at least
    /// [`crate::setup::DEFAULT_HIERARCHY_CAPACITY`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub hierarchy_capacity: Option<usize>,
    /// Work units of erosion per servo tick (about 100 Cortex-M4 instructions each:
    /// `tetradrill_core::drill::WorkCost`); the rest is carried to later ticks.
    pub budget_per_tick: u32,
    /// Work units for the whole simulation step, drill and contact search together (the
    /// search gets what the drill left, `tetradrill_core::servo::World::set_tick_budget`);
    /// 0: each has its own bound.
    pub tick_budget: u32,
    /// Hierarchy nodes a drill tool's shaft walk may enter a step (4,096; under the tick
    /// budget at most what the burr's step left of it); 0: unbounded.
    pub shaft_nodes: u32,
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
    /// (`tetradrill_core::collide::ZoneGather`); 0: one zone query every step; absent:
    /// gathered, exactly, only where the burr's zone holds thousands of tets
    /// (`crate::engine::GATHER_FROM_TETS`), else one query a step.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub zone_gather_work: Option<u32>,
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
    #[serde(skip_serializing_if = "BodyKind::is_rigid")]
    pub body: BodyKind,
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

impl Default for Scenario {
    /// [`Setup::default`], written flat.
    fn default() -> Self {
        Self::from(&Setup::default())
    }
}

/// The scenario flags shared by `demo`, `run` and `replay`; each overrides the scenario.
#[derive(Debug, Clone, Default, clap::Args)]
pub struct ScenarioFlags {
    /// A scenario file (TOML, keys as these flags with `_` for `-`) or `builtin:demo`,
    /// `builtin:firmware`, `builtin:firmware-cow`, `builtin:firmware-regions`,
    /// `builtin:firmware-soft`, `builtin:firmware-tooth`, `builtin:tooth`.
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
    /// Trace CSV (`t,x,y,z,qw,qx,qy,qz,buttons`), `builtin:demo`, `builtin:tooth-access`,
    /// `builtin:premolar-access` or `wander:SEED`.
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
    /// The burr's vibration while it cuts, hertz (0: none, at most 500); its amplitude is
    /// each region's `vibration` key, newtons.
    #[arg(long, allow_negative_numbers = true, value_parser = vibration_hz, value_name = "HZ")]
    pub vibration_hz: Option<f64>,
    /// Which way the burr spins while the drill is on (clockwise seen from the handle by
    /// default): the direction of each region's sideways pull (`friction`).
    #[arg(long, value_enum)]
    pub spin: Option<Spin>,
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
    /// The drill's finest leaf edge, mesh units (each tet refines as deep as its size needs,
    /// at most `--max-depth`; 0: none; default: the burr's radius / 8).
    #[arg(long, allow_negative_numbers = true, value_parser = non_negative)]
    pub resolution: Option<f64>,
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
    /// Hierarchy nodes a drill tool's shaft walk may enter a step (default 4,096; under the
    /// tick budget at most what the burr's step left of it); 0: unbounded.
    #[arg(long, allow_negative_numbers = true, value_parser = clap::value_parser!(u32))]
    pub shaft_nodes: Option<u32>,
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
    pub body: Option<BodyKind>,
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
    FixBelow::parse(s).map(|_| s.to_string())
}

fn soft_rate(s: &str) -> Result<f64, String> {
    let v = s
        .parse::<f64>()
        .map_err(|_| format!("`{s}` is not a number of hertz"))?;
    crate::setup::check_soft_rate(v).map(|()| v)
}

/// `serde`'s `skip_serializing_if` for a key whose default is 0.
fn is_zero(v: &u32) -> bool {
    *v == 0
}

/// `serde`'s `skip_serializing_if` for a number whose default is 0.
fn is_zero_f64(v: &f64) -> bool {
    *v == 0.0
}

fn vibration_hz(s: &str) -> Result<f64, String> {
    let v = s
        .parse::<f64>()
        .map_err(|_| format!("`{s}` is not a number of hertz"))?;
    crate::setup::check_vibration_hz(v).map(|()| v)
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

impl Scenario {
    /// Loads `builtin:NAME` or a TOML file. Unknown keys and bad values exit 2 naming the
    /// file and line.
    pub fn load(spec: &str) -> Result<Self, CliError> {
        if let Some(name) = spec.strip_prefix("builtin:") {
            return builtin(name).ok_or_else(|| {
                CliError::input(format!(
                    "unknown scenario `{spec}` (built-in: builtin:demo, builtin:firmware, builtin:firmware-cow, builtin:firmware-regions, builtin:firmware-soft, builtin:firmware-tooth, builtin:f405-block, builtin:f405-regions, builtin:h743-tooth, builtin:tooth)"
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
        sc.setup().map_err(|e| {
            // A bad region: the line of its own table when it has one.
            let table = e.table.as_deref().and_then(|t| key_line(&text, t));
            CliError::at(path, table.or_else(|| key_line(&text, e.key)), e.message)
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
        take!(vibration_hz, spin);
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
        take!(contact_search_nodes, shaft_nodes, servo_lag, body);
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
            resolution,
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
        let unused = s.unused_soft_flags();
        if !unused.is_empty() {
            errln!(
                "tetradrill: warning: {} set for a rigid body: no effect without --body soft",
                unused.join(", ")
            );
        }
        Ok(s)
    }

    /// Values no flag parser can refuse on its own (a scenario file sets them directly).
    ///
    /// # Errors
    /// The first bad value, in one line.
    pub fn check(&self) -> Result<(), String> {
        self.setup().map(|_| ()).map_err(|e| e.message)
    }

    /// The typed set-up: every string parsed (the tool, the trace, the fixed nodes, the
    /// region labels) and every value checked, once.
    ///
    /// # Errors
    /// The first bad value: its key (and, for a region, the region's table) and one line.
    pub fn setup(&self) -> Result<Setup, SetupError> {
        let mut regions = BTreeMap::new();
        for (label, r) in &self.regions {
            let Ok(l) = label.trim().parse::<i32>() else {
                return Err(SetupError::new(
                    "regions",
                    format!("regions: `{label}` is not a region label (an integer)"),
                )
                .in_table(format!("regions.{label}")));
            };
            if let Err(m) = r.check() {
                return Err(SetupError::new("regions", format!("regions.{label}{m}"))
                    .in_table(format!("regions.{label}")));
            }
            regions.insert(l, r.clone());
        }
        let soft = SoftSettings {
            young: self.young,
            poisson: self.poisson,
            fix_below: self
                .fix_below
                .as_deref()
                .map(FixBelow::parse)
                .transpose()
                .map_err(|m| SetupError::new("fix_below", m))?,
            rate_hz: self.soft_rate,
            substeps: self.soft_substeps,
            spread: self.soft_spread,
        };
        crate::setup::check_vibration_hz(self.vibration_hz)
            .map_err(|m| SetupError::new("vibration_hz", format!("vibration_hz: {m}")))?;
        let setup = Setup {
            mesh: MeshSpec {
                path: self.mesh.clone().into(),
                scale: self.scale,
                region_array: self.region_array.clone(),
            },
            tool: Tool::parse(&self.tool, self.tool_scale)?,
            poses: Poses::parse(&self.trace)?,
            forces: Forces {
                stiffness: self.stiffness,
                damping: self.damping,
                max_force: self.max_force,
                switch_ms: self.switch_ms,
                vibration_hz: self.vibration_hz,
                spin: self.spin,
            },
            drilling: Drilling {
                max_depth: self.max_depth,
                min_area: self.min_area,
                resolution: self.resolution,
                budget_per_tick: self.budget_per_tick,
                tick_budget: self.tick_budget,
                shaft_nodes: self.shaft_nodes,
                contact_search_nodes: self.contact_search_nodes,
                zone_gather_work: self.zone_gather_work,
                servo_lag: self.servo_lag,
            },
            materials: Materials {
                hardness: self.hardness,
                pressure_threshold: self.pressure_threshold,
                regions,
            },
            capacities: Capacities {
                hierarchy: self.hierarchy_capacity,
                hash: self.hash_capacity,
                candidates: self.candidate_capacity,
                vlist: self.vlist_capacity,
                pending: self.pending_capacity,
                contacts: self.contact_capacity,
                queue: self.queue_capacity,
            },
            pen: PenContact {
                depth_method: self.depth_method,
                crossings: self.crossings,
                contact_period: self.contact_period,
                pass_threads: self.pass_threads,
                entry_remedy: self.entry_remedy,
            },
            body: match self.body {
                BodyKind::Rigid => Body::Rigid,
                BodyKind::Soft => Body::Soft(soft),
            },
        };
        // Soft values are checked whatever the body: a bad one is refused, not ignored.
        soft.check()?;
        setup.check()?;
        Ok(setup)
    }

    /// The soft-body keys set on a rigid body (their flags), which then have no effect.
    pub fn unused_soft_flags(&self) -> Vec<&'static str> {
        if self.body == BodyKind::Soft {
            return Vec::new();
        }
        [
            ("--young", self.young.is_some()),
            ("--poisson", self.poisson.is_some()),
            ("--fix-below", self.fix_below.is_some()),
            ("--soft-rate", self.soft_rate.is_some()),
            ("--soft-substeps", self.soft_substeps.is_some()),
            ("--soft-spread", self.soft_spread),
        ]
        .iter()
        .filter(|(_, on)| *on)
        .map(|(flag, _)| *flag)
        .collect()
    }
}

impl From<&Setup> for Scenario {
    /// The set-up written flat, as a scenario file holds it.
    fn from(s: &Setup) -> Self {
        let soft = s.soft().copied().unwrap_or_default();
        let tool_scale = match &s.tool {
            Tool::Mesh { scale, .. } => *scale,
            _ => 1.0,
        };
        Self {
            mesh: s.mesh.to_string(),
            scale: s.mesh.scale,
            region_array: s.mesh.region_array.clone(),
            trace: s.poses.to_string(),
            tool: s.tool.to_string(),
            tool_scale,
            stiffness: s.forces.stiffness,
            damping: s.forces.damping,
            max_force: s.forces.max_force,
            switch_ms: s.forces.switch_ms,
            vibration_hz: s.forces.vibration_hz,
            spin: s.forces.spin,
            hardness: s.materials.hardness,
            pressure_threshold: s.materials.pressure_threshold,
            regions: labelled(s.materials.regions.clone()),
            depth_method: s.pen.depth_method,
            crossings: s.pen.crossings,
            contact_period: s.pen.contact_period,
            pass_threads: s.pen.pass_threads,
            entry_remedy: s.pen.entry_remedy,
            max_depth: s.drilling.max_depth,
            min_area: s.drilling.min_area,
            resolution: s.drilling.resolution,
            hierarchy_capacity: s.capacities.hierarchy,
            budget_per_tick: s.drilling.budget_per_tick,
            tick_budget: s.drilling.tick_budget,
            shaft_nodes: s.drilling.shaft_nodes,
            hash_capacity: s.capacities.hash,
            candidate_capacity: s.capacities.candidates,
            vlist_capacity: s.capacities.vlist,
            pending_capacity: s.capacities.pending,
            contact_search_nodes: s.drilling.contact_search_nodes,
            zone_gather_work: s.drilling.zone_gather_work,
            servo_lag: s.drilling.servo_lag,
            contact_capacity: s.capacities.contacts,
            queue_capacity: s.capacities.queue,
            body: match s.body {
                Body::Rigid => BodyKind::Rigid,
                Body::Soft(_) => BodyKind::Soft,
            },
            young: soft.young,
            poisson: soft.poisson,
            fix_below: soft.fix_below.map(|f| f.to_string()),
            soft_rate: soft.rate_hz,
            soft_substeps: soft.substeps,
            soft_spread: soft.spread,
        }
    }
}

/// Materials by label, keyed by the label's text as a TOML table names it.
fn labelled(regions: BTreeMap<i32, RegionSpec>) -> BTreeMap<String, RegionSpec> {
    regions
        .into_iter()
        .map(|(l, r)| (l.to_string(), r))
        .collect()
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

#[cfg(test)]
mod tests;
