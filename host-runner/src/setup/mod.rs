//! The typed set-up of a session: the mesh, the tool, where the poses come from, the forces,
//! drilling, the materials, the buffers' sizes, a tet-mesh tool's contact and the soft body.
//! One value, made once (by a program, or by the command line from its flags and scenario
//! file, [`crate::scenario::Scenario::setup`]) and passed down; nothing below it parses a
//! string again.
//!
//! ```
//! use tetradrill::setup::{Setup, Tool, Poses};
//!
//! let mut setup = Setup::default(); // the demo: builtin:block:8, a 0.1 burr, its path
//! setup.tool = Tool::sphere(0.05);
//! setup.poses = Poses::Wander { seed: 7 };
//! setup.forces.stiffness = 150.0;
//! setup.check()?;
//! assert_eq!(setup.tool.to_string(), "sphere:0.05");
//! # Ok::<(), tetradrill::setup::SetupError>(())
//! ```

use std::collections::BTreeMap;
use std::fmt;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

mod capacity;
mod materials;
mod sources;
mod tool;

pub use capacity::{capacity, Capacity, CAPACITIES, MAX_BUFFER_BYTES};
pub use materials::{
    demo_regions, tooth_regions, Colour, RegionSpec, DEMO_CORE_YOUNG, DEMO_SHELL_YOUNG,
    TOOTH_DENTIN, TOOTH_ENAMEL, TOOTH_PULP,
};
pub use sources::{FixBelow, MeshSpec, Poses};
pub use tool::Tool;

/// Which way depth finds the surface intersections of border edges.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum DepthMethod {
    /// Walk the border edge through the tets to a boundary face (Praktikum report, section
    /// 4).
    Traced,
    /// Hash the boundary faces and query them with the edge (Heidelberger et al. 2004).
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

/// The force law's settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Forces {
    /// Newtons per mesh unit of penetration depth.
    pub stiffness: f64,
    /// Newton-seconds per mesh unit.
    pub damping: f64,
    /// Force clamp, newtons.
    pub max_force: f64,
    /// Milliseconds over which the burr's force moves from one contact plane to the next
    /// (`servo_force`); 0 switches at once.
    pub switch_ms: f64,
    /// The burr's vibration while it cuts, hertz (0: none; at most
    /// [`MAX_VIBRATION_HZ`]); its amplitude is each region's `vibration` (docs/DRILLING.md,
    /// "Vibration").
    pub vibration_hz: f64,
    /// Which way the burr spins while the drill is on (the sideways pull of each region's
    /// `friction` follows it; docs/DRILLING.md, "Sideways pull").
    pub spin: Spin,
}

/// Which way the burr spins about the tool's axis (burr to handle) while the drill is on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum Spin {
    /// Clockwise seen from the handle looking at the burr: the angular velocity along the
    /// axis towards the burr.
    #[default]
    Cw,
    /// Counter-clockwise seen from the handle: the angular velocity along the axis towards
    /// the handle.
    Ccw,
}

impl Spin {
    /// The angular velocity's direction along the tool's axis (burr to handle): -1 or +1.
    pub fn sign(self) -> f32 {
        match self {
            Self::Cw => -1.0,
            Self::Ccw => 1.0,
        }
    }

    /// `true` for the default, clockwise.
    pub fn is_default(&self) -> bool {
        *self == Self::Cw
    }
}

/// The highest vibration frequency a set-up takes, hertz: the 1 kHz servo's Nyquist
/// frequency.
pub const MAX_VIBRATION_HZ: f64 = 500.0;

/// `Ok` for a vibration frequency a set-up takes: finite, in `0..=`[`MAX_VIBRATION_HZ`].
///
/// # Errors
/// One line saying what is wrong.
pub fn check_vibration_hz(v: f64) -> Result<(), String> {
    if v.is_finite() && (0.0..=MAX_VIBRATION_HZ).contains(&v) {
        Ok(())
    } else {
        Err(format!(
            "`{v}` is not a vibration frequency in 0..={MAX_VIBRATION_HZ} Hz (a 1 kHz servo \
             renders at most 500 Hz)"
        ))
    }
}

/// How the burr drills and how much work a tick may do.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Drilling {
    /// Deepest subdivision level of a drilled tet (1..=9).
    pub max_depth: u8,
    /// Refinement stops below this face area (mesh units squared).
    pub min_area: f64,
    /// The drill's finest leaf edge, mesh units (`World::set_drill_resolution`); 0: none;
    /// `None`: the burr's radius over [`RESOLUTION_PER_RADIUS`] ([`Setup::drill_resolution`]).
    pub resolution: Option<f64>,
    /// Work units of erosion per servo tick (about 100 Cortex-M4 instructions each:
    /// `tetradrill_core::drill::WorkCost`); the rest is carried to later ticks.
    pub budget_per_tick: u32,
    /// Work units for the whole simulation step, drill and contact search together (the
    /// search gets what the drill left, `tetradrill_core::servo::World::set_tick_budget`); 0:
    /// each has its own bound.
    pub tick_budget: u32,
    /// Hierarchy nodes a drill tool's shaft walk may enter a step
    /// (`tetradrill_core::servo::World::set_shaft_max_nodes`; under a tick budget at most
    /// what the burr's step left of it); 0: unbounded. Not used by other tools.
    pub shaft_nodes: u32,
    /// Hierarchy nodes one contact search may test (then the closest face met, or the last
    /// step's, answers).
    pub contact_search_nodes: u32,
    /// A sphere tool's candidate tets gathered through the hash in parts of at most this many
    /// work units a step (`tetradrill_core::collide::ZoneGather`, bounded: a step the burr
    /// outruns it counts a saturation); 0: one zone query every step; `None`: chosen for
    /// the burr on the mesh (`crate::engine::ToolSizing::gather_work`, an exact gather).
    pub zone_gather_work: Option<u32>,
    /// When a sphere tool's servo uses a simulation step's contact: 0, the step and the force
    /// in the same tick (step first); 1, the RTIC firmware's release rule (the force of tick
    /// `i` from the step released at tick `i - 1`; docs/PORTING.md, "The release rule").
    pub servo_lag: u32,
}

/// What the material is made of: the default region's drilling values and one material per
/// region label of the mesh.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Materials {
    /// Hardness of every label `regions` does not name, newton-seconds per cubic mesh unit:
    /// the burr pressing `F` newtons above the threshold removes `F / hardness` cubic mesh
    /// units a second (docs/DRILLING.md, "Materials"); 0 removes at once.
    pub hardness: f64,
    /// Pressure threshold of the default region, newtons: below it the burr removes nothing.
    pub pressure_threshold: f64,
    /// Materials by the mesh's region label (the built-in block's shell is 1, its core 2).
    pub regions: BTreeMap<i32, RegionSpec>,
}

/// The buffers' sizes a session asks for; `None` sizes a buffer from the mesh and the tool
/// (`crate::engine::ToolSizing`, the core's defaults).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Capacities {
    /// Hierarchy nodes available for drilling.
    pub hierarchy: Option<usize>,
    /// Entries of the static spatial hash of the mesh's tets (default 8 per tet).
    pub hash: Option<usize>,
    /// Coarse tets one simulation step may take near the tool.
    pub candidates: Option<usize>,
    /// v_list entries (default: what the arena needs; fewer shrink the arena to fit).
    pub vlist: Option<usize>,
    /// Drill work items the pending deque holds.
    pub pending: Option<usize>,
    /// A tet-mesh tool: collisions each body may hold per tick (default: its node count).
    pub contacts: Option<usize>,
    /// A tet-mesh tool: entries of each depth propagation queue (default: its node count).
    pub queue: Option<usize>,
}

impl Capacities {
    /// The capacities of a tet-mesh tool's rig (`hash_capacity`, `contact_capacity`,
    /// `queue_capacity`).
    pub fn pen(&self) -> crate::pen::PenSizes {
        crate::pen::PenSizes {
            hash: self.hash,
            contacts: self.contacts,
            queue: self.queue,
        }
    }
}

/// A tet-mesh tool's contact pass.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PenContact {
    /// Depth method.
    pub depth_method: DepthMethod,
    /// Whether border edges reuse last tick's crossing faces.
    pub crossings: Crossings,
    /// Servo ticks per contact pass (1..=1000): between passes the servo carries the last
    /// pass's penetrations to the current pose (`tetradrill_core::force::pen_servo_force`).
    pub contact_period: u32,
    /// Threads of a contact pass, 1 or 2 (the object side on a second thread,
    /// `crate::pen_pair`: the same forces, bit for bit).
    pub pass_threads: u32,
    /// Depths measured against the plane where the pen entered the object while a contact
    /// lasts (the Praktikum report's remedy for a thin pen pushed sideways, section 6).
    pub entry_remedy: bool,
}

/// A soft body's settings (docs/SOFT.md); each `None` takes the body's default
/// (`crate::soft`).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct SoftSettings {
    /// Young's modulus, pascal (mesh units taken as metres).
    pub young: Option<f64>,
    /// Poisson ratio, `0..=0.49`.
    pub poisson: Option<f64>,
    /// The fixed nodes (default: the lowest tenth of the body's z extent).
    pub fix_below: Option<FixBelow>,
    /// Physics steps a second, a divisor of 1000 (a whole number of 1 ms ticks a step).
    pub rate_hz: Option<f64>,
    /// XPBD substeps a physics step, `1..=1000`.
    pub substeps: Option<u32>,
    /// Each step and the world's update spread over the ticks of its cycle
    /// (`tetradrill_core::soft::Link`).
    pub spread: bool,
}

/// What the object is.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum Body {
    /// The mesh stays where it was loaded.
    #[default]
    Rigid,
    /// An elastic body the tool dents (the core's XPBD physics in the simulation loop).
    Soft(SoftSettings),
}

/// Everything a session needs to know, typed and checked ([`Setup::check`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Setup {
    /// The object's mesh.
    pub mesh: MeshSpec,
    /// The tool.
    pub tool: Tool,
    /// Where the tool's poses come from (a replay, the simulated device).
    pub poses: Poses,
    /// The force law.
    pub forces: Forces,
    /// Drilling and the work per tick.
    pub drilling: Drilling,
    /// The materials.
    pub materials: Materials,
    /// The buffers' sizes.
    pub capacities: Capacities,
    /// A tet-mesh tool's contact pass.
    pub pen: PenContact,
    /// Rigid or soft.
    pub body: Body,
}

/// Default work units of a whole simulation step, drill and contact search together
/// (`--tick-budget`): the drill's 11,000 plus about 900 contact-node tests of 6 units. It
/// keeps the demo's whole tick under 200 us, removing the same material, at the price of
/// contact searches cut short on busy drilling ticks (docs/DRILLING.md, "One budget for the
/// whole tick").
pub const DEFAULT_TICK_BUDGET: u32 = 16_500;

/// Default bound on a drill tool's shaft walk, hierarchy nodes a step (`--shaft-nodes`; 0:
/// unbounded): the core's. Under the tick budget the walk gets at most what the burr's step
/// left of it, so the whole tick stays within the budget (docs/DRILLING.md, "The shaft in
/// the tick budget").
pub const DEFAULT_SHAFT_NODES: u32 = tetradrill_core::servo::SHAFT_MAX_NODES;

/// The least hierarchy arena a burr gets when the set-up does not size it: 2^20 nodes (16
/// MiB), what a burr about one boundary tet wide needs over long sessions (docs/DRILLING.md).
pub const DEFAULT_HIERARCHY_CAPACITY: usize = 1 << 20;

/// The default drill resolution is the burr's radius over this ([`Setup::drill_resolution`]):
/// an 8th of the radius, so a coarse mesh and a fine re-mesh of it drill with leaves of the
/// same size and remove the swept volume within 2 % on a moving path (the teddy's trees stop
/// at depth 4 under a 0.03 burr instead of 5, its 2-million-tet re-mesh's at 2 or 3 instead
/// of 5), where a 32nd left the fine mesh 3 % short (docs/DRILLING.md, "Resolution").
pub const RESOLUTION_PER_RADIUS: f64 = 8.0;

impl Default for Setup {
    /// The demo's set-up, every default in one place: the built-in block of 8 cubes a side, a
    /// burr of radius 0.1 on the demo path, 200 N per unit, 8 N at most, depth 5.
    fn default() -> Self {
        Self {
            mesh: MeshSpec::new("builtin:block:8"),
            tool: Tool::sphere(0.1),
            poses: Poses::Demo,
            forces: Forces {
                stiffness: 200.0,
                damping: 0.5,
                max_force: 8.0,
                switch_ms: 16.0,
                vibration_hz: 0.0,
                spin: Spin::Cw,
            },
            drilling: Drilling {
                max_depth: 5,
                min_area: 0.0,
                resolution: None,
                budget_per_tick: 11_000,
                tick_budget: DEFAULT_TICK_BUDGET,
                shaft_nodes: DEFAULT_SHAFT_NODES,
                contact_search_nodes: tetradrill_core::servo::CONTACT_MAX_NODES,
                zone_gather_work: None,
                servo_lag: 0,
            },
            materials: Materials::default(),
            capacities: Capacities::default(),
            pen: PenContact {
                depth_method: DepthMethod::Traced,
                crossings: Crossings::Reuse,
                contact_period: 1,
                pass_threads: 1,
                entry_remedy: false,
            },
            body: Body::Rigid,
        }
    }
}

/// A value a set-up refuses: the scenario key (and flag, with `-` for `_`) it belongs to and
/// one line saying why.
#[derive(Debug, Clone, PartialEq, Eq)]
#[non_exhaustive]
pub struct SetupError {
    /// The scenario key, e.g. `"max_depth"` (`"regions"` for a region's material).
    pub key: &'static str,
    /// One line: the value and what it must be.
    pub message: String,
    /// The scenario file's table the value is in, when it is not the top level (a region's
    /// `regions.LABEL`).
    pub table: Option<String>,
}

impl SetupError {
    /// A refusal of `key`.
    pub fn new(key: &'static str, message: impl Into<String>) -> Self {
        Self {
            key,
            message: message.into(),
            table: None,
        }
    }

    /// The same refusal, of a value in the table `table`.
    pub fn in_table(self, table: impl Into<String>) -> Self {
        Self {
            table: Some(table.into()),
            ..self
        }
    }
}

impl fmt::Display for SetupError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.message)
    }
}

impl std::error::Error for SetupError {}

/// `Ok` for a finite `v > 0`.
fn positive(key: &'static str, v: f64) -> Result<(), SetupError> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(SetupError::new(
            key,
            format!("{key} must be a positive number, got {v}"),
        ))
    }
}

/// `Ok` for a finite `v >= 0`.
fn non_negative(key: &'static str, v: f64) -> Result<(), SetupError> {
    if v.is_finite() && v >= 0.0 {
        Ok(())
    } else {
        Err(SetupError::new(
            key,
            format!("{key} must be non-negative, got {v}"),
        ))
    }
}

impl Setup {
    /// The drill's finest leaf edge in mesh units: the one set (`--resolution`, key
    /// `resolution`; 0: none), else the burr's radius over [`RESOLUTION_PER_RADIUS`] (0 for a
    /// mesh tool, which does not drill).
    pub fn drill_resolution(&self) -> f64 {
        self.drilling.resolution.unwrap_or_else(|| {
            self.tool
                .burr_radius()
                .map_or(0.0, |r| r / RESOLUTION_PER_RADIUS)
        })
    }

    /// A set-up of `mesh` (a file, `builtin:cube12` or `builtin:block:N`) and `tool` (a burr
    /// drills it, a tet-mesh tool touches it), every other value the default's.
    pub fn new(mesh: impl AsRef<Path>, tool: Tool) -> Self {
        Self {
            mesh: MeshSpec::new(mesh),
            tool,
            ..Self::default()
        }
    }

    /// The first value out of range, with its key.
    ///
    /// # Errors
    /// A [`SetupError`] naming the key and what the value must be.
    pub fn check(&self) -> Result<(), SetupError> {
        positive("scale", self.mesh.scale)?;
        self.tool.check()?;
        let f = &self.forces;
        positive("stiffness", f.stiffness)?;
        positive("max_force", f.max_force)?;
        non_negative("damping", f.damping)?;
        non_negative("switch_ms", f.switch_ms)?;
        non_negative("hardness", self.materials.hardness)?;
        non_negative("pressure_threshold", self.materials.pressure_threshold)?;
        for (label, r) in &self.materials.regions {
            r.check().map_err(|m| {
                SetupError::new("regions", format!("regions.{label}{m}"))
                    .in_table(format!("regions.{label}"))
            })?;
        }
        let d = &self.drilling;
        non_negative("min_area", d.min_area)?;
        if let Some(r) = d.resolution {
            non_negative("resolution", r)?;
        }
        if !(1..=9).contains(&d.max_depth) {
            return Err(SetupError::new(
                "max_depth",
                format!("max_depth must be 1..=9, got {}", d.max_depth),
            ));
        }
        if d.servo_lag > 1 {
            return Err(SetupError::new(
                "servo_lag",
                format!("servo_lag must be 0 or 1, got {}", d.servo_lag),
            ));
        }
        if d.budget_per_tick == 0 {
            return Err(SetupError::new(
                "budget_per_tick",
                "budget_per_tick must be at least 1",
            ));
        }
        let p = &self.pen;
        if !(1..=1000).contains(&p.contact_period) {
            return Err(SetupError::new(
                "contact_period",
                format!("contact_period must be 1..=1000, got {}", p.contact_period),
            ));
        }
        if !(1..=2).contains(&p.pass_threads) {
            return Err(SetupError::new(
                "pass_threads",
                format!("pass_threads must be 1 or 2, got {}", p.pass_threads),
            ));
        }
        for c in CAPACITIES {
            if let Some(v) = self.capacity_value(c.key) {
                c.check(v).map_err(|m| SetupError::new(c.key, m))?;
            }
        }
        if let Body::Soft(s) = &self.body {
            s.check()?;
        }
        Ok(())
    }

    /// The value of the capacity `key` ([`CAPACITIES`]) when the set-up sets one.
    pub fn capacity_value(&self, key: &str) -> Option<usize> {
        let c = &self.capacities;
        match key {
            "hierarchy_capacity" => c.hierarchy,
            "hash_capacity" => c.hash,
            "candidate_capacity" => c.candidates,
            "vlist_capacity" => c.vlist,
            "pending_capacity" => c.pending,
            "contact_search_nodes" => Some(self.drilling.contact_search_nodes as usize),
            "contact_capacity" => c.contacts,
            "queue_capacity" => c.queue,
            _ => None,
        }
    }

    /// The soft body's settings, `None` for a rigid one.
    pub fn soft(&self) -> Option<&SoftSettings> {
        match &self.body {
            Body::Rigid => None,
            Body::Soft(s) => Some(s),
        }
    }
}

impl SoftSettings {
    /// The first value out of range.
    ///
    /// # Errors
    /// A [`SetupError`] naming the key.
    pub fn check(&self) -> Result<(), SetupError> {
        if let Some(e) = self.young {
            if !(e.is_finite() && e > 0.0 && e < f32::MAX as f64) {
                return Err(SetupError::new(
                    "young",
                    format!("young must be a positive number, got {e}"),
                ));
            }
        }
        if let Some(nu) = self.poisson {
            if !(0.0..=0.49).contains(&nu) {
                return Err(SetupError::new(
                    "poisson",
                    format!("poisson must be in 0..=0.49, got {nu}"),
                ));
            }
        }
        if let Some(hz) = self.rate_hz {
            check_soft_rate(hz).map_err(|m| SetupError::new("soft_rate", m))?;
        }
        if let Some(n) = self.substeps {
            if !(1..=tetradrill_core::soft::MAX_SUBSTEPS).contains(&n) {
                return Err(SetupError::new(
                    "soft_substeps",
                    format!("soft_substeps must be 1..=1000, got {n}"),
                ));
            }
        }
        if let Some(f) = &self.fix_below {
            if !f.value.is_finite() {
                return Err(SetupError::new(
                    "fix_below",
                    format!("fix_below `{f}`: the value must be a finite number"),
                ));
            }
        }
        Ok(())
    }
}

/// Checks a soft body's rate: positive, at most 1000 Hz, a whole number of 1 ms ticks a step.
///
/// # Errors
/// One line saying what the rate must be.
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

/// A path's display form for messages.
fn shown(p: &Path) -> String {
    p.display().to_string()
}

/// The owned form of a path given as anything path-like.
fn owned(p: impl AsRef<Path>) -> PathBuf {
    p.as_ref().to_path_buf()
}
