//! The servo step for a spherical burr on a drilled mesh, in two halves that a host runs in
//! two tasks and a replay or a firmware runs one after the other, tick by tick:
//!
//! - [`World::simulate`]: the coarse tets near the tool through the tet spatial hash, the
//!   budgeted drill step when the drill is on, and the contact with the *drilled* surface
//!   (the hierarchy's visible faces, not the original boundary) as one contact plane;
//! - [`servo_force`]: the force from the last contact plane at the tool's current position:
//!   stiffness x depth along the plane normal, damping, clamping. When the simulation runs
//!   slower than the servo, this is the extrapolation of Turini et al. 2006, section 3.3: the
//!   plane is a first-order model of the surface near the tool, so the force stays continuous
//!   at 1 kHz.
//!
//! A replay calls both with the same pose every tick, so its forces equal the exact contact
//! with the drilled surface at that pose. Two tasks that may preempt each other hand the
//! contact over through a [`ContactHandoff`] (`handoff.rs`: two sequence-locked slots over
//! atomics), which a [`Servo`] reads at its own rate.
//!
//! The mesh may move and deform between simulation steps: [`World::set_positions`]
//! (`deform.rs`) takes new node positions and updates what depends on them, or
//! [`World::prepare_positions`] prepares that update over several calls in spare storage and
//! [`World::commit_positions`] takes it at once.
//!
//! Files: this one holds the [`World`], its storage, sizes, errors and accessors;
//! `simulate.rs` the simulation step ([`World::simulate`], [`World::simulate_spheres`] and the
//! contact update), `zone_memo.rs` the step's candidate tets on a small mesh without a hash
//! scan, `force.rs` [`servo_force`], `passive.rs` a drill's shaft (its passive
//! points tracked by [`World::simulate_drill`], the force at the handle [`drill_force`], the
//! shaft's moment [`drill_torque`]), `handoff.rs` and `drill_handoff.rs` the lock-free hand-offs
//! to a servo ([`ContactHandoff`] and [`Servo`], [`DrillHandoff`] and [`DrillServo`]),
//! `pen_handoff.rs` a tet-mesh tool's passes to its servo ([`PenHandoff`]); the
//! unit tests of [`servo_force`] are in `tests.rs`.

use glam::Vec3;

use crate::collide::ZoneGather;
use crate::drill::{Drill, DrillReport, Material, Regions, Spacing};
pub use crate::drill::{DRILL_HOLD_STEPS, DRILL_SETTLE, DRILL_SPACING, MAX_STEP_SPHERES};
use crate::hash::{average_edge_length, prime_at_most, Aabb, HashError, SpatialHash};
use crate::hierarchy::{Hierarchy, HierarchyError, Kept, NearestCursor, SphereMemo};
use crate::ids::TetId;
use crate::mesh::Mesh;

mod deform;
mod drill_handoff;
mod force;
mod handoff;
mod passive;
mod pen_handoff;
mod simulate;
mod sizes;
#[cfg(test)]
mod sizes_tests;
#[cfg(test)]
mod tests;
mod zone_memo;

pub use deform::{DeformError, DeformReport, MovePart, Prepared, SpareStorage, FIRST_PART_TETS};
pub(crate) use deform::{PREP_BOX_UNITS, PREP_FACE_UNITS, PREP_NODE_UNITS, PREP_NORMALISE_UNITS};
pub use drill_handoff::{DrillHandoff, DrillPublished, DrillServo};
pub use force::servo_force;
pub use handoff::{burr_storage, ContactHandoff, Published, Servo, HANDOFF_TRIES};
pub use passive::{drill_force, drill_torque, DrillState, PassiveReport, ShaftWalk};
pub use pen_handoff::{PenHandoff, PenPublished};
pub use sizes::{carve_rest, WorldSizes, WorldStorage, DEFAULT_PENDING, DEFAULT_SPHERE_MEMO};

/// Why a [`World`] could not be made.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
#[non_exhaustive]
pub enum WorldError {
    /// The spatial hash refused its storage or cell size.
    Hash(HashError),
    /// The hierarchy refused its storage.
    Hierarchy(HierarchyError),
    /// The region table refused its storage ([`Regions::new`]).
    Regions(crate::drill::RegionError),
    /// The memory could not hold the world's storage ([`WorldStorage::carve`]).
    Storage(crate::storage::StorageError),
    /// The deformation storage was refused ([`World::enable_deformation`],
    /// [`World::set_spare`]).
    Deform(DeformError),
}

impl core::fmt::Display for WorldError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::Hash(e) => write!(f, "{e}"),
            Self::Hierarchy(e) => write!(f, "{e}"),
            Self::Regions(e) => write!(f, "{e}"),
            Self::Storage(e) => write!(f, "{e}"),
            Self::Deform(e) => write!(f, "{e}"),
        }
    }
}

impl core::error::Error for WorldError {}

/// The contact of the tool with the drilled surface, as the last simulation step saw it: the
/// closest surface point and the outward normal there (a plane the servo extrapolates with).
#[derive(Clone, Copy, PartialEq, Debug, Default)]
pub struct ContactState {
    /// `true` when a visible triangle was within reach of the tool.
    pub valid: bool,
    /// Closest point on the drilled surface.
    pub point: Vec3,
    /// Unit normal pointing out of the material at `point`.
    pub normal: Vec3,
    /// Depth at the simulated position (`radius - signed distance`; > 0 in contact).
    pub depth: f32,
    /// Tool centre the contact was computed for.
    pub centre: Vec3,
    /// Visible triangles examined.
    pub triangles: u32,
    /// Contact stiffness of the material under the contact, newtons per mesh unit; zero: the
    /// force parameters' own ([`crate::drill::Material::stiffness`]).
    pub stiffness: f32,
    /// The burr's vibration over this contact (all zero: none): the frequency of
    /// [`World::set_vibration_hz`] with every contact (the servo's phase runs on between
    /// cuts), the amplitude and threshold of the region under the contact while the drill is
    /// on.
    pub vibration: VibrationCue,
    /// The friction coefficient between the spinning burr and the material under the
    /// contact while the drill is on (the region's, [`crate::drill::Region::friction`]); zero:
    /// no sideways pull ([`servo_force`], "Sideways pull").
    pub friction: f32,
}

/// What [`servo_force`] needs to add the burr's vibration (docs/DRILLING.md, "Vibration"):
/// while the force `F` pressing the burr exceeds the `threshold` of the material under it, a
/// sinusoid of `hz` along the force, of amplitude `amplitude * s` newtons with
/// `s = min(1, (|F| - threshold) / (max_force - threshold))`, the removal rate's share of the
/// rate at the force clamp (the removal law `(F - threshold) / hardness`, normalised).
/// Zero `hz` or `amplitude`: no vibration, and the force is exactly the one without.
#[derive(Clone, Copy, PartialEq, Debug, Default)]
pub struct VibrationCue {
    /// Frequency, hertz ([`World::set_vibration_hz`]).
    pub hz: f32,
    /// Newtons at full cut: the region's ([`crate::drill::Region::vibration`]).
    pub amplitude: f32,
    /// Newtons: the region's pressure threshold ([`crate::drill::Material::threshold`]).
    pub threshold: f32,
}

/// What one [`World::simulate`] did.
#[derive(Clone, Copy, PartialEq, Debug, Default)]
pub struct SimReport {
    /// Coarse tets near the tool.
    pub candidates: u32,
    /// Burr positions this step gave the drill as new work ([`DRILL_SPACING`],
    /// [`DRILL_HOLD_STEPS`]).
    pub queued: u32,
    /// The drill step (all zero when the drill was off).
    pub drill: DrillReport,
    /// Visible triangles examined for the contact.
    pub triangles: u32,
    /// Hierarchy nodes tested by the contact search.
    pub contact_nodes: u32,
    /// The node bound the contact search had: [`World::contact_max_nodes`], or less under a
    /// tick budget ([`World::set_tick_budget`]).
    pub contact_bound: u32,
    /// The contact search hit its node bound (`contact_bound`): the contact is the closest
    /// triangle met or kept from the last step (never deeper than the exact one), or the
    /// previous plane when there is neither (counted in `saturations().contact`).
    pub contact_saturated: bool,
    /// The candidate list filled up, or the zone covered more than [`World::max_cells`]
    /// cells (tets were left out of this step; counted).
    pub candidates_saturated: bool,
    /// The candidates came from the zone memo (a small mesh's tets gathered near the burr
    /// over steps, `zone_memo.rs`) rather than from a hash scan: the same list either way.
    pub candidates_memo: bool,
}

/// Saturation counters of a [`World`], by kind.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default)]
pub struct Saturations {
    /// Tet hash builds ([`World::new`], [`World::set_positions`]) that ran out of entries.
    pub hash: u32,
    /// Simulation steps whose candidate list filled up or whose zone was too many cells
    /// wide ([`World::set_max_cells`]).
    pub candidates: u32,
    /// Refinements refused because the hierarchy arena was full.
    pub arena: u32,
    /// Drill work items dropped because the pending deque was full.
    pub pending: u32,
    /// Simulation steps whose contact search hit its node bound (the contact then comes from
    /// the closest triangle met or the last step's, see [`SimReport::contact_saturated`]).
    pub contact: u32,
}

impl Saturations {
    /// All kinds added up.
    pub fn total(&self) -> u32 {
        self.hash + self.candidates + self.arena + self.pending + self.contact
    }
}

/// The object being touched and drilled: its mesh, the spatial hash of its tets, its
/// subdivision hierarchy and the drill, all over caller storage.
///
/// ```
/// use tetradrill_core::builtin;
/// use tetradrill_core::prelude::*;
///
/// let (mut pos, tets) = builtin::cube12();
/// let (mut nodes, mut normals) = ([Node::default(); 9], [Vec3::ZERO; 9]);
/// let (mut recs, mut scratch) = ([Tet::default(); 12], [FaceKey::default(); 48]);
/// let storage = MeshStorage { nodes: &mut nodes, normals: &mut normals, tets: &mut recs };
/// let mesh = Mesh::build(&mut pos, &tets, storage, &mut scratch, BuildOptions::default())?;
/// let sizes = WorldSizes::new(12, 4096);
/// let mut lines = vec![Line::ZERO; sizes.lines().unwrap()];
/// let storage = WorldStorage::carve(&sizes, &mut Block::from_lines(&mut lines))?;
/// let mut world = World::new(mesh, storage)?;
///
/// // One simulation step sees a burr of radius 0.1 just above the top face (z = 0.5) ...
/// world.simulate(Vec3::new(0.1, 0.2, 0.65), 0.1, 0.1, false, &DrillParams::default());
/// let contact = world.contact();
/// assert!(contact.valid && (contact.normal - Vec3::Z).length() < 1e-6);
/// assert!((contact.depth + 0.05).abs() < 1e-6); // 0.05 short of touching
///
/// // ... and the servo's next ticks extrapolate its plane: 0.02 deep, 100 N per unit x 0.02.
/// let params = ForceParams { stiffness: 100.0, damping: 0.0, ..ForceParams::default() };
/// let mut tool = ToolState::default();
/// let forces = [0.65, 0.6, 0.58].map(|z| {
///     servo_force(contact, Vec3::new(0.1, 0.2, z), 0.1, &mut tool, &params)
/// });
/// assert_eq!(forces[..2], [Vec3::ZERO; 2]);
/// assert!((forces[2] - Vec3::Z * 2.0).length() < 1e-4);
/// # Ok::<(), tetradrill_core::Error>(())
/// ```
#[derive(Debug)]
pub struct World<'a> {
    mesh: Mesh<'a>,
    hash: SpatialHash<'a>,
    boxes: &'a mut [Aabb],
    hier: Hierarchy<'a>,
    drill: Drill<'a>,
    candidates: &'a mut [TetId],
    ncand: usize,
    /// Where the list of [`World::candidates`] starts in `candidates` (not 0 with a
    /// [`ZoneGather`]).
    cand_at: usize,
    /// The candidate gather spread over steps, if set ([`World::set_zone_gather`]).
    zone: Option<ZoneGather>,
    memo: SphereMemo<'a>,
    max_cells: u32,
    contact: ContactState,
    /// The closest faces the last contact search met, its answer among them: the hints of the
    /// next search.
    kept: Kept,
    contact_max_nodes: u32,
    /// Work units for a whole simulation step (drill and contact search), if set.
    tick_budget: Option<u32>,
    /// The nodes a drill's shaft walk may enter a step, if bounded
    /// ([`World::set_shaft_max_nodes`]).
    shaft_max_nodes: Option<u32>,
    /// The work units the last simulation step counted (its drill work and contact search):
    /// under a tick budget the shaft's walk gets what they left ([`World::shaft_bound`]).
    step_units: u32,
    /// The nodes held for the next shaft walk under a tick budget, taken from the drill's
    /// share of the next step ([`World::shaft_reserve`]).
    shaft_reserve: u32,
    /// Where the last contact search that hit its node bound stopped: the next one goes on
    /// from there ([`Hierarchy::nearest_continued`]).
    cursor: NearestCursor,
    sat: Saturations,
    /// Which burr positions become drill work.
    spacing: Spacing,
    /// The pressing force (newtons) and the seconds it lasted, for the next step's grant
    /// ([`World::set_pressing`]).
    press: (f32, f32),
    /// The coarse tet under the last contact, if any.
    contact_tet: Option<TetId>,
    /// The burr's centre at the last step, for the feed's work (`Regions::grant`).
    fed_from: Option<Vec3>,
    /// The spare storage of a spread position update ([`World::set_spare`]).
    spare: Option<deform::Spare<'a>>,
    /// The last one-shot zone query's hash scan, kept while the zone stays in its cells.
    zone_memo: zone_memo::ZoneMemo,
    /// The burr's vibration frequency while it cuts, hertz; zero: none
    /// ([`World::set_vibration_hz`]).
    vibration_hz: f32,
}

/// Default bound on the hash cells one step's zone query visits ([`World::set_max_cells`]):
/// 16^3 cells, a zone 16 average edges wide.
pub const DEFAULT_MAX_CELLS: u32 = 4096;

/// Default bound on the hierarchy nodes the contact search of one simulation step tests
/// (see [`World::set_contact_max_nodes`]).
pub const CONTACT_MAX_NODES: u32 = 4096;

/// What one contact-search node test is charged under a tick budget
/// ([`World::set_tick_budget`]), in drill work units ([`crate::drill::WorkCost`], about 100
/// Cortex-M4 instructions each): a node test costs 500 to 800 M4 instructions in a drilled
/// cavity (docs/PORTING.md), and about 6 drill units' worth of host instructions on the demo's
/// slowest ticks (docs/DRILLING.md, "One budget for the whole tick").
pub const CONTACT_NODE_UNITS: u32 = 6;

/// Default bound on the hierarchy nodes a drill shaft's walk enters a step (see
/// [`World::set_shaft_max_nodes`]); under a tick budget the walk gets at most what the step
/// left of it.
pub const SHAFT_MAX_NODES: u32 = 4096;

/// The least hold a cut shaft walk leaves for the next ([`World::shaft_reserve`]).
pub const SHAFT_RESERVE_MIN: u32 = 64;

/// What one node of a drill shaft's walk ([`World::track_shaft`]) is charged under a tick
/// budget ([`World::shaft_bound`]), in drill work units: about 560 host instructions
/// a node entered on the teddy's moving path at its busiest ticks, against about 90 for a
/// drill unit, as a contact-search node test (docs/DRILLING.md, "The shaft in the tick
/// budget").
pub const SHAFT_NODE_UNITS: u32 = 6;

impl<'a> World<'a> {
    /// Hashes the mesh's tets once (cell size = average edge length), stores each tet's box
    /// and creates an untouched hierarchy.
    ///
    /// # Bounded work
    /// O(T + buckets + hash entries + memo slots) for T tets.
    ///
    /// # Errors
    /// [`WorldError`] when the hash or the hierarchy refuses its storage. A hash too small for
    /// every tet is not an error: the first tets that fit are kept and `saturations().hash`
    /// says so.
    pub fn new(mesh: Mesh<'a>, storage: WorldStorage<'a>) -> Result<Self, WorldError> {
        let hash_starts = storage.hash_starts;
        let hash_entries = storage.hash_entries;
        let tet_boxes = storage.tet_boxes;
        let (hierarchy, pending) = (storage.hierarchy, storage.pending);
        let (candidates, sphere_memo) = (storage.candidates, storage.sphere_memo);
        let buckets =
            prime_at_most((hash_starts.len().saturating_sub(1)).min(u32::MAX as usize) as u32);
        let starts_len = (buckets as usize + 1).min(hash_starts.len());
        let (hash_starts, _) = hash_starts.split_at_mut(starts_len);
        let cell = average_edge_length(&mesh);
        let mut hash =
            SpatialHash::new(hash_starts, hash_entries, cell).map_err(WorldError::Hash)?;
        // The boxes and the hash as a move of the nodes makes them (`deform.rs`).
        let positions = mesh.positions();
        for (t, b) in tet_boxes.iter_mut().enumerate().take(mesh.tet_count()) {
            *b = deform::tet_box(&mesh, positions, t);
        }
        let built = hash.rebuild(mesh.tet_count(), |t| {
            Some(deform::stored_box(tet_boxes, &mesh, positions, t))
        });
        let hier = Hierarchy::new(&mesh, hierarchy).map_err(WorldError::Hierarchy)?;
        let sat = Saturations {
            hash: built.saturated as u32,
            ..Saturations::default()
        };
        Ok(Self {
            mesh,
            hash,
            boxes: tet_boxes,
            hier,
            drill: Drill::new(pending),
            candidates,
            ncand: 0,
            cand_at: 0,
            zone: None,
            memo: SphereMemo::new(sphere_memo),
            max_cells: DEFAULT_MAX_CELLS,
            contact: ContactState::default(),
            kept: Kept::new(),
            contact_max_nodes: CONTACT_MAX_NODES,
            tick_budget: None,
            shaft_max_nodes: Some(SHAFT_MAX_NODES),
            step_units: 0,
            shaft_reserve: 0,
            cursor: NearestCursor::new(),
            sat,
            spacing: Spacing::new(),
            press: (0.0, 0.0),
            contact_tet: None,
            fed_from: None,
            spare: None,
            zone_memo: zone_memo::ZoneMemo::new(),
            vibration_hz: 0.0,
        })
    }

    /// Sets the materials per region ([`Regions`]): the drill then removes a region's
    /// material only while the burr presses harder than its threshold, at the rate its
    /// hardness gives ([`crate::drill::Material`]), and the contact takes the stiffness of the
    /// material under it. Without regions (the default) every leaf in the burr is removed at
    /// once and the force uses [`crate::force::ForceParams::stiffness`]. The force comes from
    /// [`World::set_pressing`]: until it is told one, a world presses with zero force, which
    /// removes only the materials of threshold and hardness zero.
    ///
    /// # Bounded work
    /// O(1).
    pub fn set_regions(&mut self, regions: Regions<'a>) {
        self.drill.set_regions(regions);
    }

    /// The materials per region, if set (their credits and removed volumes).
    pub fn regions(&self) -> Option<&Regions<'a>> {
        self.drill.regions()
    }

    /// The force pressing the burr against the material, newtons (the magnitude of the
    /// servo's last force), and the seconds since the last simulation step: the next
    /// [`World::simulate`] earns each region's erosion credit from them (with the drill on).
    /// Without regions it changes nothing.
    ///
    /// # Bounded work
    /// O(1).
    pub fn set_pressing(&mut self, force: f32, seconds: f32) {
        self.press = (force, seconds);
    }

    /// The material under the last contact (`None` without a contact or without regions).
    pub fn contact_material(&self) -> Option<Material> {
        let r = self.drill.regions()?;
        self.contact_tet.map(|t| r.material_of(t))
    }

    /// The coarse tet under the last contact (the root of the closest visible face), if any:
    /// where a two-way coupling applies the tool's reaction to a deforming body (for example
    /// [`crate::soft::SoftBody::add_point_force`] at the contact point).
    pub fn contact_tet(&self) -> Option<TetId> {
        self.contact_tet
    }

    /// The mesh.
    pub fn mesh(&self) -> &Mesh<'a> {
        &self.mesh
    }

    /// The hierarchy.
    pub fn hierarchy(&self) -> &Hierarchy<'a> {
        &self.hier
    }

    /// The tet hash (rebuilt by [`World::set_positions`]).
    pub fn hash(&self) -> &SpatialHash<'a> {
        &self.hash
    }

    /// The contact search's sphere memo (its size and hit counts).
    pub fn sphere_memo(&self) -> &SphereMemo<'a> {
        &self.memo
    }

    /// The contact the last [`World::simulate`] found.
    pub fn contact(&self) -> &ContactState {
        &self.contact
    }

    /// The bound on the hierarchy nodes one contact search tests ([`CONTACT_MAX_NODES`] by
    /// default).
    pub fn contact_max_nodes(&self) -> u32 {
        self.contact_max_nodes
    }

    /// Sets the bound on the hierarchy nodes one contact search tests. A search that reaches
    /// it takes the closest triangle it met or the last step's triangle (whichever is closer:
    /// a true visible face, so the depth is never overestimated), or keeps the previous plane
    /// when it has neither, and counts `saturations().contact`.
    pub fn set_contact_max_nodes(&mut self, n: u32) {
        self.contact_max_nodes = n;
    }

    /// The work units one simulation step may spend on the drill and the contact search
    /// together, if set ([`World::set_tick_budget`]).
    pub fn tick_budget(&self) -> Option<u32> {
        self.tick_budget
    }

    /// Sets one budget for a whole simulation step, in drill work units: the drill step gets
    /// at most `units` (and at most its own `DrillParams::budget`), and the contact search
    /// that follows gets what the drill left, `(units - drill work) / CONTACT_NODE_UNITS`
    /// node tests (and at most [`World::contact_max_nodes`]). So a step's counted work is at
    /// most `units` plus the overshoot of the drill's last operation, however the work falls
    /// between the two; a contact search cut short answers as any bounded one does (the
    /// closest face met or kept, never too deep) and goes on next step. A drill's shaft walk
    /// after the step gets what the step left, the nodes held for it out of the drill's
    /// share at least ([`World::shaft_bound`], [`World::shaft_reserve`]). `None` (the
    /// default): the bounds apply separately.
    pub fn set_tick_budget(&mut self, units: Option<u32>) {
        self.tick_budget = units;
        self.shaft_reserve = 0;
    }

    /// The nodes a drill shaft's walk may enter a step, if bounded
    /// ([`World::set_shaft_max_nodes`]).
    pub fn shaft_max_nodes(&self) -> Option<u32> {
        self.shaft_max_nodes
    }

    /// Bounds the walk that tracks a drill shaft's passive points ([`World::track_shaft`],
    /// [`World::simulate_drill`]) to `nodes` hierarchy nodes a step ([`SHAFT_MAX_NODES`] by
    /// default). Under a tick budget ([`World::set_tick_budget`]) the walk gets what the
    /// simulation step before it left of the budget, at least the nodes held for it out of
    /// the drill's share ([`World::shaft_bound`], [`World::shaft_reserve`]), so a drill's
    /// whole step stays within the budget and the burr's contact search keeps its share. A
    /// walk that wants more is cut there, its points keep the state of the last step they
    /// were tracked in, and the next steps walk smaller groups of the points until each is
    /// tracked again ([`PassiveReport::cut`], [`PassiveReport::stale`]). `None`: the walk is
    /// unbounded, whatever the tick budget, and every point is tracked every step.
    ///
    /// # Bounded work
    /// Constant.
    pub fn set_shaft_max_nodes(&mut self, nodes: Option<u32>) {
        self.shaft_max_nodes = nodes;
        self.shaft_reserve = 0;
    }

    /// The nodes the next shaft walk may enter ([`World::set_shaft_max_nodes`]): the bound,
    /// and under a tick budget at most `(units - step units) / SHAFT_NODE_UNITS`, the step
    /// units being what the last simulation step counted (its drill work and
    /// `CONTACT_NODE_UNITS` a contact-search node). `None`: unbounded.
    ///
    /// # Bounded work
    /// Constant.
    pub fn shaft_bound(&self) -> Option<u32> {
        let bound = self.shaft_max_nodes?;
        Some(match self.tick_budget {
            Some(t) => bound.min(t.saturating_sub(self.step_units) / SHAFT_NODE_UNITS),
            None => bound,
        })
    }

    /// The nodes held for the next shaft walk under a tick budget: the drill's share of the
    /// next simulation step is `SHAFT_NODE_UNITS` a node smaller, and the contact search's
    /// bound leaves them, so the walk after the step gets at least these. After each walk
    /// the hold follows it, with `given` the walk's bound ([`World::shaft_bound`]):
    ///
    /// ```text
    /// cut        max(2 given, SHAFT_RESERVE_MIN)
    /// otherwise  max(nodes entered, hold - hold / 8)
    /// both       at most the node bound and a third of the tick budget
    ///            (units / 3 / SHAFT_NODE_UNITS)
    /// ```
    ///
    /// So the hold rises at once to the walks the shaft needs and decays over tens of steps
    /// when it needs less; the drill, whose work waits in its queue, gives the units up.
    /// Zero without a tick budget or a bound.
    pub fn shaft_reserve(&self) -> u32 {
        self.shaft_reserve
    }

    /// The units the drill and the contact search share this step: the tick budget less the
    /// nodes held for the shaft ([`World::shaft_reserve`]), if there is a tick budget.
    fn step_units_left(&self) -> Option<u32> {
        let hold = self.shaft_reserve.saturating_mul(SHAFT_NODE_UNITS);
        self.tick_budget.map(|t| t.saturating_sub(hold))
    }

    /// The drill's budget this step, out of its own (`drill`): under a tick budget at most
    /// the tick budget, less the nodes held for the shaft ([`World::shaft_reserve`]), so the
    /// hold comes out of the drill's share and the contact search keeps its own.
    fn drill_budget(&self, drill: u32) -> u32 {
        let hold = self.shaft_reserve.saturating_mul(SHAFT_NODE_UNITS);
        self.tick_budget
            .map_or(drill, |t| t.min(drill).saturating_sub(hold))
    }

    /// Sets the frequency of the burr's vibration while it cuts, hertz: from the next step on,
    /// each contact carries a [`VibrationCue`] of this frequency, with the amplitude of the
    /// region under it ([`crate::drill::Region::vibration`]) while the drill is on, which
    /// [`servo_force`] renders
    /// (docs/DRILLING.md, "Vibration"). Zero (the default), negative or not finite: none. A
    /// servo at `1 / dt` hertz renders frequencies below `1 / (2 dt)` (500 Hz at 1 kHz); the
    /// caller bounds it.
    ///
    /// # Bounded work
    /// Constant.
    pub fn set_vibration_hz(&mut self, hz: f32) {
        self.vibration_hz = if hz > 0.0 && hz.is_finite() { hz } else { 0.0 };
    }

    /// The burr's vibration frequency while it cuts, hertz; zero: none.
    pub fn vibration_hz(&self) -> f32 {
        self.vibration_hz
    }

    /// Sets the drill's resolution, the edge of its finest leaves in mesh units: each coarse
    /// tet refines only as deep as its size needs, never past `DrillParams::max_depth`
    /// (`Drill::set_resolution`); 0 for none (every tet to `max_depth`, the default).
    ///
    /// # Bounded work
    /// Constant.
    pub fn set_drill_resolution(&mut self, resolution: f32) {
        self.drill.set_resolution(resolution);
    }

    /// The drill's resolution ([`World::set_drill_resolution`]); 0 for none.
    pub fn drill_resolution(&self) -> f32 {
        self.drill.resolution()
    }

    /// The coarse tets the last [`World::simulate`] found near the tool, each once: those
    /// whose box meets the burr's positions first, then the others, each part in the order
    /// the hash query met them (cell by cell, tet order within a cell). With a candidate
    /// gather ([`World::set_zone_gather`]), the gathered list the step used (in the order it
    /// was gathered).
    pub fn candidates(&self) -> &[TetId] {
        self.candidates
            .get(self.cand_at..self.cand_at + self.ncand)
            .unwrap_or(&[])
    }

    /// Gathers the candidates of [`World::simulate`] in parts over several steps instead of
    /// one zone query a step ([`ZoneGather`]: `Some` with its work a step and margin), or
    /// with the one-shot query (`None`, the default). The candidate storage is then used in
    /// thirds (the tets near the burr, the list in use, the list being gathered), and
    /// [`World::candidates`] is the list in use: the tets whose boxes meet a box around the
    /// zone, a superset of the one-shot query's (the contact search walks all of them; the
    /// drill gets those that meet the burr's positions). A step whose zone is not inside the
    /// gathered box, or whose list filled up, counts `saturations().candidates`; with an exact
    /// gather ([`ZoneGather::exact`]) such a step makes the one-shot query instead, into the
    /// first third, and counts [`ZoneGather::fallbacks`].
    ///
    /// # Bounded work
    /// O(1); a step's gathering then costs at most the gather's work a step (and, with an
    /// exact gather, a step that falls back the one-shot query's).
    pub fn set_zone_gather(&mut self, zone: Option<ZoneGather>) {
        self.zone = zone;
        self.cand_at = 0;
        self.ncand = 0;
    }

    /// The candidate gather, if set ([`World::set_zone_gather`]).
    pub fn zone_gather(&self) -> Option<&ZoneGather> {
        self.zone.as_ref()
    }

    /// The most hash cells one step's zone query visits ([`World::set_max_cells`]).
    pub fn max_cells(&self) -> u32 {
        self.max_cells
    }

    /// Sets the most hash cells one step's zone query visits (default
    /// [`DEFAULT_MAX_CELLS`]). A zone (the burr's box grown by `radius + reach`) that covers
    /// more cells than this finds no tets: the step drills nothing, keeps the previous contact
    /// plane and counts `saturations().candidates`. Size it with the candidate list from the
    /// tool's radius against the mesh's cell size (its average edge length, [`crate::hash::average_edge_length`]).
    ///
    /// # Bounded work
    /// O(1); a step's query then costs O(`n` + entries met).
    pub fn set_max_cells(&mut self, n: u32) {
        self.max_cells = n;
    }

    /// Drill work items carried to the next tick.
    pub fn pending(&self) -> usize {
        self.drill.pending()
    }

    /// The drill's pending deque's high-water marks, ring by ring, beside the rings'
    /// capacities ([`Drill::pending_peaks`]): what a board sizes the deque from.
    pub fn pending_peaks(&self) -> [usize; 4] {
        self.drill.pending_peaks()
    }

    /// Erases the debris of the drilled material: detached pieces smaller than `max_leaves`
    /// leaves of depth `max_depth` ([`Hierarchy::remove_debris`], usually with
    /// [`crate::hierarchy::DEBRIS_LEAVES`] and the drill's `max_depth`); with a drill
    /// resolution ([`World::set_drill_resolution`]) a tree's unit is the leaf of its own depth
    /// limit where that is shallower. `scratch` holds
    /// [`Hierarchy::debris_scratch_needed`] entries. With regions, the debris's volume is
    /// counted in the removed volume of the region each leaf belongs to.
    ///
    /// # Bounded work
    /// As [`Hierarchy::remove_debris`]: O(hierarchy nodes), not for a servo tick.
    ///
    /// # Errors
    /// [`HierarchyError::StorageTooSmall`] for a short `scratch` (nothing changed).
    pub fn remove_debris(
        &mut self,
        max_leaves: u32,
        max_depth: u8,
        scratch: &mut [u32],
    ) -> Result<crate::hierarchy::DebrisReport, HierarchyError> {
        let resolution = self.drill.resolution();
        let mut regions = self.drill.regions_mut();
        self.hier.remove_debris_with(
            &self.mesh,
            max_leaves,
            max_depth,
            resolution,
            scratch,
            |tet, v| {
                if let Some(r) = regions.as_mut() {
                    r.note_removed(tet, v);
                }
            },
        )
    }

    /// Sets the size below which a piece the drill cuts off is erased as debris while
    /// drilling, in max-depth leaves ([`crate::hierarchy::DEBRIS_LEAVES`] by default; 0 turns
    /// the checks off): each leaf the drill erases is checked within the drill's budget
    /// ([`crate::hierarchy::Crumbs`]).
    ///
    /// # Bounded work
    /// Constant.
    pub fn set_debris_leaves(&mut self, max_leaves: u32) {
        self.drill.set_debris_leaves(max_leaves);
    }

    /// What the drill's debris checks erased so far (also in the removed volume and, with
    /// regions, in each region's), and how often their storage was full.
    pub fn debris(&self) -> crate::hierarchy::CrumbStats {
        self.drill.debris()
    }

    /// Erased leaves whose debris check waits for the drill's budget.
    pub fn debris_pending(&self) -> usize {
        self.drill.debris_pending()
    }

    /// Saturations so far, by kind.
    pub fn saturations(&self) -> Saturations {
        Saturations {
            arena: self.hier.saturations(),
            pending: self.drill.saturations(),
            ..self.sat
        }
    }
}
