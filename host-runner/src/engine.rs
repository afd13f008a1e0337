//! The host's side of the core's [`World`]: storage allocated once for a scenario, and the
//! per-tick step that replays, real-time runs and `timing` share.

use tetradrill_core::drill::{DrillParams, Pending};
use tetradrill_core::force::{ForceParams, ToolState};
use tetradrill_core::hash::{Aabb, HashEntry};
use tetradrill_core::hierarchy::{HNode, HierarchyStorage, SphereSlot, VEntry};
use tetradrill_core::servo::{
    servo_force, SimReport, World, WorldSizes, WorldStorage, DEFAULT_MAX_CELLS, DEFAULT_PENDING,
};
use tetradrill_core::{TetId, Vec3};

use crate::error::CliError;
use crate::meshio;
use crate::owned::OwnedMesh;
use crate::scenario::{Scenario, ToolKind, DEFAULT_HIERARCHY_CAPACITY};
use crate::traces::{Pose, PERIOD_S};

/// What a burr needs on a mesh: the candidate list and the zone query's cells, sized from the
/// tool's radius against the size of the tets at the mesh's boundary (where a burr works).
///
/// A step looks for tets in the box `radius + reach` around the burr (`reach` = half the
/// radius, [`TickParams::reach`]), widened by one more radius for the several burr positions
/// one step may queue. The tets whose boxes meet it number about `(L + 2 e)^3 / v` for a box
/// side `L`, boundary tets of mean box side `e` and mean volume `v`; the list gets 1.5 times
/// that (at least the core's 1,024). The query visits at most as many cells as that zone
/// covers at the hash's cell size (the mesh's average edge), twice over (at least the core's
/// 4,096). A burr of 4 mm on a mesh of 0.3 mm tets needs about a hundred times what the same
/// burr needs on a mesh of 1.4 mm tets: fixed defaults would starve it (every step saturated,
/// nothing drilled).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ToolSizing {
    /// Burr radius the sizes are for, mesh units.
    pub radius: f64,
    /// Mean box side of the tets with a boundary face, mesh units.
    pub boundary_edge: f64,
    /// Candidate list entries.
    pub candidates: usize,
    /// Most hash cells one step's zone query visits ([`World::set_max_cells`]).
    pub max_cells: u32,
    /// Pending drill work items: two for every tet whose box meets one burr position's box
    /// (a new position queues one item per tet it touches; refining them queues more), at
    /// least the core's [`DEFAULT_PENDING`].
    pub pending: usize,
    /// Hierarchy arena nodes: the drilled surface a burr leaves grows with its area in
    /// boundary tets, `(radius / e)^2`, and with its leaves per tet face, four times for every
    /// level of `--max-depth` past [`SIZED_FOR_DEPTH`]; so [`DEFAULT_HIERARCHY_CAPACITY`]
    /// (enough for a burr about one tet wide at that depth) times both, between the default
    /// and [`MAX_SIZED_ARENA`].
    pub arena: usize,
}

/// The `--max-depth` [`DEFAULT_HIERARCHY_CAPACITY`] is meant for (the default depth).
pub const SIZED_FOR_DEPTH: u8 = 5;

/// The largest arena [`ToolSizing`] chooses on its own: 2^23 nodes (128 MiB). A burr
/// wider than that is meant for a finer `--max-depth`'s leaves than the mesh needs; set
/// `--hierarchy-capacity` to go further.
pub const MAX_SIZED_ARENA: usize = 1 << 23;

impl ToolSizing {
    /// The sizes for a burr of `radius` on `mesh`, drilling down to `max_depth`.
    ///
    /// Work: O(T) over the mesh's tets, once at start-up.
    pub fn of(mesh: &OwnedMesh, radius: f64, max_depth: u8) -> Self {
        let positions = mesh.positions();
        let (mut side, mut vol, mut n) = (0.0f64, 0.0f64, 0usize);
        let (mut all_side, mut all_edge) = (0.0f64, 0.0f64);
        for tet in mesh.tets() {
            // f32 is plenty for a size estimate.
            let p = tet.nodes.map(|v| positions[v.idx()]);
            let lo = p[0].min(p[1]).min(p[2]).min(p[3]);
            let hi = p[0].max(p[1]).max(p[2]).max(p[3]);
            let s = (hi - lo).max_element() as f64;
            all_side += s;
            for a in 0..4 {
                for b in a + 1..4 {
                    all_edge += (p[a] - p[b]).length() as f64;
                }
            }
            if tet.neighbours.contains(&TetId::NONE) {
                side += s;
                vol += (p[1] - p[0]).dot((p[2] - p[0]).cross(p[3] - p[0])).abs() as f64 / 6.0;
                n += 1;
            }
        }
        let tets = mesh.tets().len().max(1) as f64;
        let (e, v) = if n > 0 && vol > 0.0 {
            (side / n as f64, vol / n as f64)
        } else {
            (all_side / tets, 1.0)
        };
        let zone = 2.0 * (radius + 0.5 * radius) + radius;
        let defaults = WorldSizes::new(0, 0);
        let estimate = (zone + 2.0 * e).powi(3) / v;
        let candidates = ((1.5 * estimate).ceil() as usize)
            .max(defaults.candidates)
            .min(mesh.tets().len().max(defaults.candidates));
        let cell = all_edge / (6.0 * tets);
        let per_axis = if cell > 0.0 {
            (zone / cell).ceil() + 2.0
        } else {
            16.0
        };
        let max_cells = (2.0 * per_axis.powi(3)).min(u32::MAX as f64) as u32;
        let sphere = (2.0 * radius + 2.0 * e).powi(3) / v;
        let pending = ((2.0 * sphere).ceil() as usize).max(DEFAULT_PENDING);
        let widths = if e > 0.0 { (radius / e).max(1.0) } else { 1.0 };
        let deeper = 4f64.powi(i32::from(max_depth.saturating_sub(SIZED_FOR_DEPTH)));
        let arena = ((DEFAULT_HIERARCHY_CAPACITY as f64) * widths * widths * deeper)
            .min(MAX_SIZED_ARENA as f64) as usize;
        Self {
            radius,
            boundary_edge: e,
            arena,
            pending,
            candidates,
            max_cells: max_cells.max(DEFAULT_MAX_CELLS),
        }
    }
}

/// Storage for one [`World`], allocated once before the run.
#[derive(Debug)]
pub struct EngineStorage {
    mesh: OwnedMesh,
    hash_starts: Vec<u32>,
    hash_entries: Vec<HashEntry>,
    tet_boxes: Vec<Aabb>,
    roots: Vec<HNode>,
    arena: Vec<HNode>,
    vlist: Vec<VEntry>,
    pending: Vec<Pending>,
    candidates: Vec<TetId>,
    sphere_memo: Vec<SphereSlot>,
    contact_search_nodes: u32,
    tick_budget: u32,
    sizing: Option<ToolSizing>,
}

/// The storage sizes of a scenario's world over a mesh of `tets` tets: the core's defaults
/// ([`WorldSizes::new`]) with the scenario's capacities. A v_list smaller than the arena needs
/// shrinks the arena to what it can list (every block of 8 adds 7 leaves).
///
/// # Errors
/// A v_list shorter than the mesh's tet count (one entry per coarse tet is the least the
/// hierarchy needs), naming the key and the flag.
pub fn world_sizes(tets: usize, sc: &Scenario) -> Result<WorldSizes, String> {
    world_sizes_for(tets, sc, None)
}

/// [`world_sizes`] with the candidate list sized for the scenario's burr on the mesh
/// (`sizing`) when the scenario does not set `candidate_capacity`.
fn world_sizes_for(
    tets: usize,
    sc: &Scenario,
    sizing: Option<&ToolSizing>,
) -> Result<WorldSizes, String> {
    let pending = match (sc.pending_capacity, sizing) {
        (Some(p), _) => p,
        (None, Some(z)) => z.pending,
        (None, None) => DEFAULT_PENDING,
    };
    let arena = match (sc.hierarchy_capacity, sizing) {
        (Some(a), _) => a,
        (None, Some(z)) => z.arena,
        (None, None) => DEFAULT_HIERARCHY_CAPACITY,
    };
    let mut s = WorldSizes::new(tets, arena).with_pending(pending);
    s.candidates = match (sc.candidate_capacity, sizing) {
        (Some(c), _) => c,
        (None, Some(z)) => z.candidates,
        (None, None) => s.candidates,
    };
    if let Some(h) = sc.hash_capacity {
        s.hash_entries = h;
    }
    if let Some(v) = sc.vlist_capacity {
        if v < tets {
            return Err(format!(
                "vlist_capacity (--vlist-capacity) {v} is below the mesh's {tets} coarse tets \
                 (the v_list needs one entry per tet)"
            ));
        }
        s.vlist = v;
        s.arena = s.arena.min((v - tets) / 7 * 8);
    }
    Ok(s)
}

impl EngineStorage {
    /// Allocates everything the scenario's world needs for `mesh`. Capacities the mesh cannot
    /// take (a v_list shorter than its tet count) are raised to the least it needs; use
    /// [`EngineStorage::try_allocate`] to refuse them instead.
    pub fn allocate(mesh: OwnedMesh, sc: &Scenario) -> Self {
        let tets = mesh.tets().len();
        let raised = Scenario {
            vlist_capacity: sc.vlist_capacity.map(|v| v.max(tets)),
            ..sc.clone()
        };
        let sizing = Self::sizing(&mesh, sc);
        let s = world_sizes_for(tets, &raised, sizing.as_ref()).unwrap_or_else(|_| {
            let arena = sizing
                .as_ref()
                .map_or(DEFAULT_HIERARCHY_CAPACITY, |z| z.arena);
            WorldSizes::new(tets, sc.hierarchy_capacity.unwrap_or(arena))
        });
        Self::with_sizes(mesh, s, sc, sizing)
    }

    /// The burr's sizes on `mesh` ([`ToolSizing`]) when the scenario's tool is a sphere.
    fn sizing(mesh: &OwnedMesh, sc: &Scenario) -> Option<ToolSizing> {
        match sc.tool_kind() {
            Ok(ToolKind::Sphere(r)) => Some(ToolSizing::of(mesh, r, sc.max_depth)),
            _ => None,
        }
    }

    /// The sizes chosen for the scenario's burr, `None` for a mesh tool.
    pub fn tool_sizing(&self) -> Option<&ToolSizing> {
        self.sizing.as_ref()
    }

    /// The candidate list's length.
    pub fn candidate_capacity(&self) -> usize {
        self.candidates.len()
    }

    /// The hierarchy arena's nodes.
    pub fn hierarchy_capacity(&self) -> usize {
        self.arena.len()
    }

    /// [`EngineStorage::allocate`] refusing, with exit status 2, a capacity the mesh cannot
    /// take.
    pub fn try_allocate(mesh: OwnedMesh, sc: &Scenario) -> Result<Self, CliError> {
        let sizing = Self::sizing(&mesh, sc);
        let s = world_sizes_for(mesh.tets().len(), sc, sizing.as_ref()).map_err(CliError::input)?;
        Ok(Self::with_sizes(mesh, s, sc, sizing))
    }

    fn with_sizes(
        mesh: OwnedMesh,
        s: WorldSizes,
        sc: &Scenario,
        sizing: Option<ToolSizing>,
    ) -> Self {
        Self {
            mesh,
            hash_starts: vec![0; s.hash_starts],
            hash_entries: vec![HashEntry::default(); s.hash_entries],
            tet_boxes: vec![Aabb::point(Vec3::ZERO); s.tet_boxes],
            roots: vec![HNode::default(); s.roots],
            arena: vec![HNode::default(); s.arena],
            vlist: vec![VEntry::default(); s.vlist],
            pending: vec![Pending::default(); s.pending],
            candidates: vec![TetId::NONE; s.candidates],
            sphere_memo: vec![SphereSlot::EMPTY; s.sphere_memo],
            contact_search_nodes: sc.contact_search_nodes,
            tick_budget: sc.tick_budget,
            sizing,
        }
    }

    /// The world over this storage (hashes the mesh once).
    pub fn world(&mut self) -> Result<World<'_>, CliError> {
        // The zone query may visit as many cells as the burr's zone covers, and never fewer
        // than a list of this length can be filled from.
        let cells = self.sizing.map_or(DEFAULT_MAX_CELLS, |z| z.max_cells);
        let by_list = (self.candidates.len() / 2).min(u32::MAX as usize) as u32;
        let max_cells = cells.max(by_list).max(DEFAULT_MAX_CELLS);
        World::new(
            self.mesh.view(),
            WorldStorage {
                hash_starts: &mut self.hash_starts,
                hash_entries: &mut self.hash_entries,
                tet_boxes: &mut self.tet_boxes,
                hierarchy: HierarchyStorage {
                    roots: &mut self.roots,
                    arena: &mut self.arena,
                    vlist: &mut self.vlist,
                },
                pending: &mut self.pending,
                candidates: &mut self.candidates,
                sphere_memo: &mut self.sphere_memo,
            },
        )
        .map(|mut w| {
            w.set_contact_max_nodes(self.contact_search_nodes);
            w.set_max_cells(max_cells);
            w.set_tick_budget((self.tick_budget > 0).then_some(self.tick_budget));
            w
        })
        .map_err(|e| CliError::failure(format!("cannot set up the simulation: {e}")))
    }
}

/// Checks a world's invariants: the mesh ([`tetradrill_core::mesh::Mesh::validate`]) and the
/// hierarchy over it ([`tetradrill_core::hierarchy::Hierarchy::validate`]).
///
/// # Errors
/// The first broken invariant, as one line.
pub fn validate(world: &World<'_>) -> Result<(), String> {
    world.mesh().validate().map_err(|e| format!("mesh: {e}"))?;
    world
        .hierarchy()
        .validate(world.mesh())
        .map_err(|e| format!("hierarchy: {e}"))
}

/// The scenario's mesh, loaded and built.
pub fn load_mesh(sc: &Scenario) -> Result<meshio::LoadedMesh, CliError> {
    let options = meshio::ReadOptions {
        region_array: sc.region_array.clone(),
        ..meshio::ReadOptions::default()
    };
    let loaded = meshio::load_with(std::path::Path::new(&sc.mesh), sc.scale, &options)?;
    for w in &loaded.warnings {
        errln!("tetradrill: warning: {w}");
    }
    Ok(loaded)
}

/// The per-tick parameters derived from a scenario.
#[derive(Debug, Clone, Copy)]
pub struct TickParams {
    /// Burr radius, mesh units.
    pub radius: f32,
    /// How far beyond the burr the simulation looks for the surface (the servo's
    /// extrapolation range).
    pub reach: f32,
    /// Drill step parameters.
    pub drill: DrillParams,
    /// Force parameters.
    pub force: ForceParams,
    /// Servo ticks between a simulation step and the force that uses its contact: 0 or 1
    /// (`Scenario::servo_lag`).
    pub servo_lag: u32,
}

impl TickParams {
    /// From a scenario with a spherical tool.
    pub fn of(sc: &Scenario) -> Result<Self, CliError> {
        let radius = match sc.tool_kind().map_err(CliError::input)? {
            ToolKind::Sphere(r) => r as f32,
            ToolKind::Mesh(p) => {
                return Err(CliError::input(format!(
                    "tool mesh:{}: the drilling pipeline takes a spherical burr (sphere:R); \
                     tet-mesh tools are for contact-only runs",
                    p.display()
                )))
            }
        };
        if sc.contact_period != 1 {
            return Err(CliError::input(
                "--contact-period spaces a mesh tool's contact passes; a sphere tool simulates \
                 every tick",
            ));
        }
        if sc.entry_remedy {
            return Err(CliError::input(
                "--entry-remedy is a mesh tool's remedy (seed 000 section 6); a sphere tool has \
                 none",
            ));
        }
        Ok(Self {
            radius,
            reach: 0.5 * radius,
            drill: DrillParams {
                max_depth: sc.max_depth,
                min_area: sc.min_area as f32,
                budget: sc.budget_per_tick,
            },
            force: ForceParams {
                stiffness: sc.stiffness as f32,
                damping: sc.damping as f32,
                max_force: sc.max_force as f32,
                dt: PERIOD_S as f32,
                switch_time: (sc.switch_ms / 1000.0) as f32,
            },
            servo_lag: sc.servo_lag,
        })
    }
}

/// One whole tick in one thread. With `servo_lag` 0: the simulation step at `pose`, then
/// the servo force at the same pose. With `servo_lag` 1 (the RTIC firmware's release rule):
/// the servo force at `pose` from the contact of the previous tick's step, then the step at
/// `pose`, whose contact the next tick uses. Replays, `timing` and the firmware run exactly
/// this.
pub fn tick(
    world: &mut World<'_>,
    tool: &mut ToolState,
    p: &TickParams,
    pose: &Pose,
) -> (Vec3, SimReport) {
    let drill_on = pose.buttons & tetradrill_core::script::DRILL_ON != 0;
    if p.servo_lag == 0 {
        let rep = world.simulate(pose.position, p.radius, p.reach, drill_on, &p.drill);
        let f = servo_force(world.contact(), pose.position, p.radius, tool, &p.force);
        (f, rep)
    } else {
        let f = servo_force(world.contact(), pose.position, p.radius, tool, &p.force);
        let rep = world.simulate(pose.position, p.radius, p.reach, drill_on, &p.drill);
        (f, rep)
    }
}
