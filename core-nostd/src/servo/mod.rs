//! The servo step for a spherical burr on a drilled mesh, in two halves that a host runs in
//! two tasks and a replay or a firmware runs one after the other, tick by tick:
//!
//! - [`World::simulate`]: the coarse tets near the tool through the static spatial hash, the
//!   budgeted drill step when the drill is on, and the contact with the *drilled* surface
//!   (the hierarchy's visible faces, not the original boundary) as one contact plane;
//! - [`servo_force`]: the force from the last contact plane at the tool's current position:
//!   stiffness x depth along the plane normal, damping, clamping. When the simulation runs
//!   slower than the servo, this is the extrapolation of seed 001 section 3.3: the plane is a
//!   first-order model of the surface near the tool, so the force stays continuous at 1 kHz.
//!
//! A replay calls both with the same pose every tick, so its forces equal the exact contact
//! with the drilled surface at that pose.

use glam::Vec3;

use crate::drill::{Drill, DrillParams, DrillReport, Pending, Spacing, Sphere};
pub use crate::drill::{DRILL_HOLD_STEPS, DRILL_SETTLE, DRILL_SPACING, MAX_STEP_SPHERES};
use crate::force::{clamp_force, damping_force, sphere_contact, ForceParams, ToolState};
use crate::hash::{average_edge_length, prime_at_most, Aabb, HashEntry, HashError, SpatialHash};
use crate::hierarchy::{
    Hierarchy, HierarchyError, HierarchyStorage, Kept, NearestCursor, NearestQuery, SphereMemo,
    SphereSlot, VisibleTri, KEEP,
};
use crate::ids::TetId;
use crate::mesh::Mesh;

/// Storage for a [`World`], handed in by the caller; [`WorldSizes`] says how much.
#[derive(Debug)]
pub struct WorldStorage<'a> {
    /// Bucket offsets of the static tet hash (`buckets + 1`, the bucket count prime).
    pub hash_starts: &'a mut [u32],
    /// Entries of the static tet hash (one per tet and overlapped cell).
    pub hash_entries: &'a mut [HashEntry],
    /// Each tet's bounding box, filled once by [`World::new`] (one per tet; a tet beyond the
    /// slice has its box made from its corners each time it is needed, the same box).
    pub tet_boxes: &'a mut [Aabb],
    /// The hierarchy's roots, arena and v_list.
    pub hierarchy: HierarchyStorage<'a>,
    /// The drill's pending-work deque.
    pub pending: &'a mut [Pending],
    /// Candidate coarse tets near the tool, refilled each simulation step.
    pub candidates: &'a mut [TetId],
    /// The contact search's memo of node bounding spheres ([`SphereMemo`], 24 bytes a slot;
    /// empty: none). It saves work, never changes a result.
    pub sphere_memo: &'a mut [SphereSlot],
}

/// Storage sizes for a [`World`] over a mesh of `tets` tets.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct WorldSizes {
    /// `hash_starts` length.
    pub hash_starts: usize,
    /// `hash_entries` length.
    pub hash_entries: usize,
    /// `tet_boxes` length (24 bytes each).
    pub tet_boxes: usize,
    /// Hierarchy root slots.
    pub roots: usize,
    /// Hierarchy arena nodes.
    pub arena: usize,
    /// v_list entries.
    pub vlist: usize,
    /// Pending drill work items.
    pub pending: usize,
    /// Candidate tets near the tool.
    pub candidates: usize,
    /// `sphere_memo` slots.
    pub sphere_memo: usize,
}

/// Default capacity of the drill's pending deque: the demo path (`builtin:demo`, burr 0.1 on
/// `builtin:block:8`, max depth 5) peaked at about 22,400 items with the budget of the time
/// (docs/DRILLING.md), and runs free of saturations at today's default and at every budget
/// from 4,000 to 32,000 units, so 32,768 (64 bytes each, 2.0 MB). A board with little RAM
/// sizes it with [`WorldSizes::with_pending`] (the firmware's scenario peaks under 2,000).
pub const DEFAULT_PENDING: usize = 1 << 15;

/// Default size of the contact search's [`SphereMemo`]: 4,096 slots (96 KB).
pub const DEFAULT_SPHERE_MEMO: usize = 1 << 12;

impl WorldSizes {
    /// Sizes for `tets` coarse tets and an arena of `arena` hierarchy nodes. The hash gets about
    /// two buckets per tet and eight entries per tet (a tet's box covers one to eight cells of
    /// an average edge length; slivers more, and a full table is counted, not fatal); the
    /// pending deque gets [`DEFAULT_PENDING`] entries.
    pub const fn new(tets: usize, arena: usize) -> Self {
        let arena = arena / 8 * 8;
        Self {
            hash_starts: 2 * tets + 2,
            hash_entries: 8 * tets,
            tet_boxes: tets,
            roots: tets,
            arena,
            vlist: HierarchyStorage::vlist_needed(tets, arena),
            pending: DEFAULT_PENDING,
            candidates: 1024,
            sphere_memo: DEFAULT_SPHERE_MEMO,
        }
    }

    /// The same sizes with a pending deque of `pending` entries. A deque that never fills
    /// gives the same results whatever its capacity.
    pub const fn with_pending(self, pending: usize) -> Self {
        Self { pending, ..self }
    }

    /// The same sizes with a sphere memo of `slots` slots (any size, zero included, gives the
    /// same results).
    pub const fn with_sphere_memo(self, slots: usize) -> Self {
        Self {
            sphere_memo: slots,
            ..self
        }
    }
}

/// Why a [`World`] could not be made.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum WorldError {
    /// The spatial hash refused its storage or cell size.
    Hash(HashError),
    /// The hierarchy refused its storage.
    Hierarchy(HierarchyError),
}

impl core::fmt::Display for WorldError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::Hash(e) => write!(f, "{e}"),
            Self::Hierarchy(e) => write!(f, "{e}"),
        }
    }
}

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
}

/// Saturation counters of a [`World`], by kind.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default)]
pub struct Saturations {
    /// Static hash builds that ran out of entries.
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

/// The object being touched and drilled: its mesh, the static hash of its tets, its
/// subdivision hierarchy and the drill, all over caller storage.
#[derive(Debug)]
pub struct World<'a> {
    mesh: Mesh<'a>,
    hash: SpatialHash<'a>,
    boxes: &'a mut [Aabb],
    hier: Hierarchy<'a>,
    drill: Drill<'a>,
    candidates: &'a mut [TetId],
    ncand: usize,
    memo: SphereMemo<'a>,
    max_cells: u32,
    contact: ContactState,
    /// The closest faces the last contact search met, its answer among them: the hints of the
    /// next search.
    kept: Kept,
    contact_max_nodes: u32,
    /// Work units for a whole simulation step (drill and contact search), if set.
    tick_budget: Option<u32>,
    /// Where the last contact search that hit its node bound stopped: the next one goes on
    /// from there ([`Hierarchy::nearest_continued`]).
    cursor: NearestCursor,
    sat: Saturations,
    /// Which burr positions become drill work.
    spacing: Spacing,
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
        let WorldStorage {
            hash_starts,
            hash_entries,
            tet_boxes,
            hierarchy,
            pending,
            candidates,
            sphere_memo,
        } = storage;
        let buckets =
            prime_at_most((hash_starts.len().saturating_sub(1)).min(u32::MAX as usize) as u32);
        let starts_len = (buckets as usize + 1).min(hash_starts.len());
        let (hash_starts, _) = hash_starts.split_at_mut(starts_len);
        let cell = average_edge_length(&mesh);
        let mut hash =
            SpatialHash::new(hash_starts, hash_entries, cell).map_err(WorldError::Hash)?;
        let box_of = |t: usize| Aabb::of(mesh.tet_positions(TetId::from_idx(t)));
        for (t, b) in tet_boxes.iter_mut().enumerate().take(mesh.tet_count()) {
            *b = box_of(t);
        }
        let built = hash.rebuild(mesh.tet_count(), |t| {
            Some(tet_boxes.get(t).copied().unwrap_or_else(|| box_of(t)))
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
            memo: SphereMemo::new(sphere_memo),
            max_cells: DEFAULT_MAX_CELLS,
            contact: ContactState::default(),
            kept: Kept::new(),
            contact_max_nodes: CONTACT_MAX_NODES,
            tick_budget: None,
            cursor: NearestCursor::new(),
            sat,
            spacing: Spacing::new(),
        })
    }

    /// The mesh.
    pub fn mesh(&self) -> &Mesh<'a> {
        &self.mesh
    }

    /// The hierarchy.
    pub fn hierarchy(&self) -> &Hierarchy<'a> {
        &self.hier
    }

    /// The static tet hash.
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
    /// closest face met or kept, never too deep) and goes on next step. `None` (the default):
    /// the two bounds apply separately.
    pub fn set_tick_budget(&mut self, units: Option<u32>) {
        self.tick_budget = units;
    }

    /// The coarse tets the last [`World::simulate`] found near the tool, each once: those
    /// whose box meets the burr's positions first, then the others, each part in the order
    /// the hash query met them (cell by cell, tet order within a cell).
    pub fn candidates(&self) -> &[TetId] {
        &self.candidates[..self.ncand]
    }

    /// The most hash cells one step's zone query visits ([`World::set_max_cells`]).
    pub fn max_cells(&self) -> u32 {
        self.max_cells
    }

    /// Sets the most hash cells one step's zone query visits (default
    /// [`DEFAULT_MAX_CELLS`]). A zone (the burr's box grown by `radius + reach`) that covers
    /// more cells than this finds no tets: the step drills nothing, keeps the previous contact
    /// plane and counts `saturations().candidates`. Size it with the candidate list from the
    /// tool's radius against the mesh's cell size ([`World::cell_size`]).
    ///
    /// # Bounded work
    /// O(1); a step's query then costs O(`n` + entries met).
    pub fn set_max_cells(&mut self, n: u32) {
        self.max_cells = n;
    }

    /// The edge of the spatial hash's cells (the mesh's average edge length).
    pub fn cell_size(&self) -> f32 {
        self.hash.cell_size()
    }

    /// Drill work items carried to the next tick.
    pub fn pending(&self) -> usize {
        self.drill.pending()
    }

    /// Saturations so far, by kind.
    pub fn saturations(&self) -> Saturations {
        Saturations {
            arena: self.hier.saturations(),
            pending: self.drill.saturations(),
            ..self.sat
        }
    }

    /// One simulation step for a spherical burr of `radius` at `centre`: candidates near the
    /// tool (the box `radius + reach` around it), the budgeted drill step when `drill_on`,
    /// then the contact with the drilled surface within `radius + reach`. `reach` is how far
    /// the servo may extrapolate before the next step (half the radius is a good default).
    ///
    /// # Bounded work
    /// O(max cells + candidates) for the query, the drill step's budget (see
    /// [`Drill::step`]), and for the contact at most [`World::contact_max_nodes`] node tests
    /// of [`Hierarchy::nearest_visible`] (typically a few hundred), plus O(candidates + depth)
    /// and O(depth) per kept face ([`crate::hierarchy::KEEP`]). Under a tick budget
    /// ([`World::set_tick_budget`]) the drill and the contact search share it.
    ///
    /// # Capacity
    /// A full candidate list keeps the tets found first and counts `saturations().candidates`,
    /// and so does a zone of more than [`World::max_cells`] cells (which finds none);
    /// the drill and the hierarchy saturate as they document; a contact search that reaches
    /// its node bound answers with the closest triangle it met or kept (see
    /// [`World::set_contact_max_nodes`]) and counts `saturations().contact`.
    /// The state stays valid.
    pub fn simulate(
        &mut self,
        centre: Vec3,
        radius: f32,
        reach: f32,
        drill_on: bool,
        params: &DrillParams,
    ) -> SimReport {
        let sphere = [Sphere {
            center: centre,
            radius,
        }];
        let spheres: &[Sphere] = if drill_on { &sphere } else { &[] };
        self.simulate_spheres(centre, radius, reach, spheres, params)
    }

    /// [`World::simulate`] eroding with several burr positions at once (the path swept since
    /// the last step, when the simulation runs slower than the servo); the contact is computed
    /// at `centre`.
    ///
    /// # Bounded work
    /// As [`World::simulate`], with the query box covering every sphere.
    pub fn simulate_spheres(
        &mut self,
        centre: Vec3,
        radius: f32,
        reach: f32,
        spheres: &[Sphere],
        params: &DrillParams,
    ) -> SimReport {
        let mut rep = SimReport::default();
        if !(centre.is_finite() && radius.is_finite() && radius > 0.0) {
            self.contact = ContactState::default();
            self.kept.clear();
            return rep;
        }
        let reach = if reach.is_finite() && reach > 0.0 {
            reach
        } else {
            0.0
        };
        // The burr cuts while the drill is on, whether or not this step queues new work.
        let cutting = !spheres.is_empty();
        // Only positions far enough from the last one queued (or held long enough) become new
        // drill work; the rest is covered by the spheres already queued.
        let mut kept = [Sphere::default(); MAX_STEP_SPHERES];
        let nk = self.spacing.admit(centre, radius, spheres, &mut kept);
        let spheres = &kept[..nk];
        rep.queued = nk as u32;
        let mut tight = Aabb::of::<0>([]);
        for s in spheres {
            tight = tight.union(Aabb::point(s.center).grown(s.radius));
        }
        let zone = tight.union(Aabb::point(centre).grown(radius + reach));
        let (cands, mesh, hash, boxes) =
            (&mut *self.candidates, &self.mesh, &self.hash, &self.boxes);
        // Each tet once (in the first cell of the query that holds it), and only when its box
        // meets the zone. The tets that meet the burr itself (`tight`: the drill works on
        // those only) fill the list from the front, the others from the back; both keep the
        // tets found first when the list is full.
        let cap = cands.len();
        let (mut m, mut back) = (0usize, 0usize);
        let mut full = false;
        let visited = hash.query_box_once(&zone, self.max_cells, |item| {
            let t = TetId(item);
            if full || t.idx() >= mesh.tet_count() {
                return;
            }
            // The stored box, or the same box from the corners (the mesh's positions are
            // finite, so both tests agree).
            let (in_zone, near) = match boxes.get(t.idx()) {
                Some(b) => (b.overlaps(&zone), b.overlaps(&tight)),
                None => {
                    let p = mesh.tet_positions(t);
                    (zone.overlaps_points(&p), tight.overlaps_points(&p))
                }
            };
            if !in_zone {
                return;
            }
            if m + back == cap {
                full = true;
                return;
            }
            let slot = if near {
                m += 1;
                m - 1
            } else {
                back += 1;
                cap - back
            };
            if let Some(c) = cands.get_mut(slot) {
                *c = t;
            }
        });
        // The others next to the burr's, moved down from the back (`m + back <= cap`) and put
        // back in the order found. No sort: the query reports the tets cell by cell (x
        // fastest) and in tet order within a cell, an order that depends on the mesh and the
        // zone only, not on the table's size, so every platform walks the same list; sorting
        // it by tet cost 7,700 of the 130,000 instructions of the firmware's worst tick.
        for i in 0..back {
            if let Some(&t) = cands.get(cap - back + i) {
                if let Some(slot) = cands.get_mut(m + i) {
                    *slot = t;
                }
            }
        }
        let k = m + back;
        if let Some(rest) = cands.get_mut(m..k) {
            rest.reverse();
        }
        self.ncand = k;
        // A zone of more cells than the query may visit finds nothing at all: as much a
        // saturation as a full list (the drill and the contact see no tets this step).
        if full || !visited {
            self.sat.candidates += 1;
            rep.candidates_saturated = true;
        }
        rep.candidates = k as u32;
        if !spheres.is_empty() || self.drill.pending() > 0 {
            let params = DrillParams {
                budget: self
                    .tick_budget
                    .map_or(params.budget, |t| t.min(params.budget)),
                ..*params
            };
            rep.drill = self.drill.step(
                &mut self.hier,
                &self.mesh,
                &self.candidates[..m],
                spheres,
                &params,
            );
        }
        self.update_contact(centre, radius, radius + reach, cutting, &mut rep);
        rep
    }

    /// The closest visible triangle of the candidate trees within `reach` of `centre`, turned
    /// into a contact plane by [`sphere_contact`], through [`Hierarchy::nearest_uncut`]
    /// hinted with the closest faces the last step met ([`Kept`], the last answer among
    /// them); while the burr is `cutting` (drill on this
    /// step), triangles entirely inside it are material being removed and are skipped, so
    /// the burr is never pushed through a sliver it is eroding. Ties go to the smallest
    /// (tet, index, face), so
    /// the result never depends on visiting order, and it is the triangle the exhaustive
    /// search over [`Hierarchy::for_each_visible_in`] finds. When the search reaches
    /// `contact_max_nodes` the answer is the closest of the hints in play and the triangles
    /// met (or the previous plane when there is none), and it is counted; the next search
    /// goes on where this one stopped ([`Hierarchy::nearest_continued`]), so searches that
    /// keep hitting the bound walk every tree near the tool to the end in turn, and the kept
    /// faces carry the closest triangles found.
    fn update_contact(
        &mut self,
        centre: Vec3,
        radius: f32,
        reach: f32,
        cutting: bool,
        rep: &mut SimReport,
    ) {
        let cands = &self.candidates[..self.ncand];
        let mut hints: heapless::Vec<VisibleTri, KEEP> = heapless::Vec::new();
        for &(_, t) in &self.kept {
            let _ = hints.push(t);
        }
        let bound = match self.tick_budget {
            Some(t) => {
                (t.saturating_sub(rep.drill.work) / CONTACT_NODE_UNITS).min(self.contact_max_nodes)
            }
            None => self.contact_max_nodes,
        };
        rep.contact_bound = bound;
        let q = NearestQuery {
            tets: cands,
            start: 0,
            centre,
            reach,
            cut: cutting.then_some(radius),
            hints: &hints,
            max_nodes: bound,
        };
        let mut kept = Kept::new();
        let near = self.hier.nearest_continued_keeping(
            &self.mesh,
            &q,
            &mut self.memo,
            &mut self.cursor,
            &mut kept,
        );
        rep.triangles = near.triangles;
        rep.contact_nodes = near.nodes;
        if !near.complete {
            rep.contact_saturated = true;
            self.sat.contact += 1;
            if near.tri.is_none() {
                // Nothing found within the bound and no hint: keep the previous plane.
                self.contact.triangles = near.triangles;
                return;
            }
            // Otherwise the closest triangle met (or the hint): a true visible face, no
            // deeper than the exact answer; the next step starts from it.
        }
        self.kept = kept;
        self.contact = match near.tri {
            None => ContactState {
                centre,
                triangles: near.triangles,
                ..ContactState::default()
            },
            Some(vt) => {
                let c = sphere_contact(centre, radius, [vt.corners]);
                ContactState {
                    valid: c.normal != Vec3::ZERO,
                    point: c.point,
                    normal: c.normal,
                    depth: c.depth,
                    centre,
                    triangles: near.triangles,
                }
            }
        };
    }
}

/// The force on a spherical burr of `radius` at `centre` from the contact plane `contact`,
/// with `tool` carrying what the force needs from the last tick.
///
/// The spring of a plane `(point, normal)` is `s = clamp(stiffness * depth * normal)` with
/// `depth = radius - (centre - point) . normal` (zero when not positive): first order in
/// the position, so a plane kept from an older simulation step extrapolates the surface
/// (seed 001 section 3.3). The force is `clamp(E + damping)`, damping only while the plane's
/// depth is positive, with the elastic part `E = clamp(s + residual)`.
///
/// Plane switches. When the contact plane changes (another face became the closest, the
/// drill removed the one under the burr), `s` jumps; a burr buried in half-eroded material,
/// nearly equidistant from walls that face each other, would see the force reverse from one
/// tick to the next. So the residual takes up the difference at the switch,
/// `residual = E_old - s_new` with `E_old` the old plane's elastic force at `centre`, and
/// shrinks towards zero by `2 max_force dt / switch_time` every tick, that one included: a
/// switch is rendered as a ramp of at most `switch_time`. A plane that appears already
/// penetrated (no plane before) ramps in from zero the same way. Per tick the force changes by at most
/// `stiffness |dc| + damping (|v| + |v_prev|) + 2 max_force dt / switch_time`, plane change
/// or not (`|dc|` the tool's motion, `v` its velocities). A `switch_time` of zero (or not
/// finite) switches at once.
///
/// # Bounded work
/// Constant. Never allocates, locks or panics; non-finite input gives zero force (and
/// forgets the plane and the residual).
pub fn servo_force(
    contact: &ContactState,
    centre: Vec3,
    radius: f32,
    tool: &mut ToolState,
    params: &ForceParams,
) -> Vec3 {
    let plane = contact.valid.then_some((contact.point, contact.normal));
    let spring = |plane: Option<(Vec3, Vec3)>| match plane {
        Some((p, n)) => {
            let depth = radius - (centre - p).dot(n);
            if depth > 0.0 {
                clamp_force(n * (params.stiffness * depth), params.max_force)
            } else {
                Vec3::ZERO
            }
        }
        None => Vec3::ZERO,
    };
    let s = spring(plane);
    let damping = damping_force(tool, centre, s != Vec3::ZERO, params);
    if !(centre.is_finite() && radius.is_finite()) {
        tool.plane = None;
        tool.residual = Vec3::ZERO;
        return Vec3::ZERO;
    }
    let step = 2.0 * params.max_force * params.dt / params.switch_time;
    let mut residual = tool.residual;
    if tool.plane != plane {
        residual = clamp_force(spring(tool.plane) + residual, params.max_force) - s;
        tool.plane = plane;
    }
    let residual = shrink(residual, step);
    tool.residual = residual;
    clamp_force(
        clamp_force(s + residual, params.max_force) + damping,
        params.max_force,
    )
}

/// `v` shortened by `step` (zero when no longer than `step`, or when `v` or `step` is NaN or
/// infinite).
fn shrink(v: Vec3, step: f32) -> Vec3 {
    let l = v.length();
    if l.is_finite() && step.is_finite() && step >= 0.0 && l > step {
        v * ((l - step) / l)
    } else {
        Vec3::ZERO
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn params(switch_time: f32) -> ForceParams {
        ForceParams {
            stiffness: 200.0,
            damping: 0.0,
            max_force: 8.0,
            dt: 1e-3,
            switch_time,
        }
    }

    fn plane(point: Vec3, normal: Vec3) -> ContactState {
        ContactState {
            valid: true,
            point,
            normal,
            ..ContactState::default()
        }
    }

    /// A burr of radius 0.1 at the origin between two walls facing each other (planes x =
    /// -0.08 facing +x and x = 0.07 facing -x): springs of 200 * 0.02 = 4 N along +x and
    /// 200 * 0.03 = 6 N along -x.
    fn walls() -> (ContactState, ContactState) {
        (
            plane(Vec3::new(-0.08, 0.0, 0.0), Vec3::X),
            plane(Vec3::new(0.07, 0.0, 0.0), -Vec3::X),
        )
    }

    /// A tool that has been on `c` at the origin long enough for any ramp to be over.
    fn settled(c: &ContactState, p: &ForceParams) -> ToolState {
        let mut tool = ToolState::default();
        for _ in 0..20 {
            servo_force(c, Vec3::ZERO, 0.1, &mut tool, p);
        }
        tool
    }

    /// The spring of one plane, felt at once when the tool moves into it; a plane that shows
    /// up already penetrated (first tick, a jump of the tool) ramps in from zero.
    #[test]
    fn one_plane_gives_the_spring() {
        let (a, _) = walls();
        let p = params(0.016);
        let mut tool = ToolState::default();
        let out = Vec3::new(0.5, 0.0, 0.0);
        assert_eq!(servo_force(&a, out, 0.1, &mut tool, &p), Vec3::ZERO);
        let f = servo_force(&a, Vec3::ZERO, 0.1, &mut tool, &p);
        assert!((f - Vec3::new(4.0, 0.0, 0.0)).length() < 1e-5, "{f:?}");
        assert_eq!(tool.residual, Vec3::ZERO);
        let mut fresh = ToolState::default();
        for t in 0..6 {
            let f = servo_force(&a, Vec3::ZERO, 0.1, &mut fresh, &p);
            let expected = (t as f32 + 1.0).min(4.0);
            assert!((f.x - expected).abs() < 1e-4, "tick {t}: {f:?}");
        }
    }

    /// Switching from one wall to the other ramps the force linearly (f64 oracle) from the
    /// old wall's 4 N to the new wall's -6 N, 2 * 8 N * 1 ms / 16 ms = 1 N per tick, the
    /// switch tick included: 10 ticks.
    #[test]
    fn a_plane_switch_is_a_ramp_of_bounded_slope() {
        let (a, b) = walls();
        let p = params(0.016);
        let mut tool = settled(&a, &p);
        let mut last = servo_force(&a, Vec3::ZERO, 0.1, &mut tool, &p);
        for t in 0..14 {
            let f = servo_force(&b, Vec3::ZERO, 0.1, &mut tool, &p);
            let expected = (3.0 - t as f64).max(-6.0);
            assert!(
                (f64::from(f.x) - expected).abs() < 1e-4 && f.y == 0.0 && f.z == 0.0,
                "tick {t}: {f:?}, expected {expected}"
            );
            assert!(f.distance(last) <= 1.0 + 1e-4);
            last = f;
        }
        // Without the ramp the force reverses at once.
        let p0 = params(0.0);
        let mut tool = settled(&a, &p0);
        let f = servo_force(&b, Vec3::ZERO, 0.1, &mut tool, &p0);
        assert!((f - Vec3::new(-6.0, 0.0, 0.0)).length() < 1e-5, "{f:?}");
    }

    /// Walls swapping every tick (the burr equidistant from both): the force never jumps by
    /// more than the ramp's slope and stays between the two springs.
    #[test]
    fn flickering_planes_never_reverse_the_force() {
        let (a, b) = walls();
        let p = params(0.016);
        let mut tool = settled(&a, &p);
        let mut last = servo_force(&a, Vec3::ZERO, 0.1, &mut tool, &p);
        for t in 0..200 {
            let c = if (t / 3) % 2 == 0 { &b } else { &a };
            let f = servo_force(c, Vec3::ZERO, 0.1, &mut tool, &p);
            assert!(
                f.distance(last) <= 1.0 + 1e-4,
                "tick {t}: {last:?} -> {f:?}"
            );
            assert!(f.x >= -6.0 - 1e-4 && f.x <= 4.0 + 1e-4, "tick {t}: {f:?}");
            last = f;
        }
    }

    /// Moving while a switch is under way: the spring of the new plane follows the motion at
    /// once, the ramp only carries the jump.
    #[test]
    fn motion_is_felt_at_once_during_a_ramp() {
        let (a, b) = walls();
        let p = params(0.016);
        let mut tool = settled(&a, &p);
        let f0 = servo_force(&b, Vec3::ZERO, 0.1, &mut tool, &p);
        // 1 mm towards the new wall: its spring grows by 0.2 N, the residual shrinks by 1 N.
        let f1 = servo_force(&b, Vec3::new(0.001, 0.0, 0.0), 0.1, &mut tool, &p);
        assert!(
            (f64::from(f1.x - f0.x) - (-0.2 - 1.0)).abs() < 1e-4,
            "{f0:?} {f1:?}"
        );
    }

    /// Contact lost (erosion took the material): the force fades out over at most the switch
    /// time; non-finite input gives zero and forgets the residual.
    #[test]
    fn lost_contact_fades_and_nan_forgets() {
        let (a, _) = walls();
        let p = params(0.016);
        let mut tool = settled(&a, &p);
        let none = ContactState::default();
        for t in 0..6 {
            let x = servo_force(&none, Vec3::ZERO, 0.1, &mut tool, &p).x;
            let expected = (3.0 - t as f32).max(0.0);
            assert!((x - expected).abs() < 1e-4, "tick {t}: {x}");
        }
        servo_force(&a, Vec3::ZERO, 0.1, &mut tool, &p);
        let nan = servo_force(&none, Vec3::splat(f32::NAN), 0.1, &mut tool, &p);
        assert_eq!(nan, Vec3::ZERO);
        assert_eq!((tool.residual, tool.plane), (Vec3::ZERO, None));
    }
}
