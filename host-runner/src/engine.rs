//! The host's side of the core's [`World`]: storage allocated once for a scenario, and the
//! per-tick step that replays, real-time runs and `timing` share.

use tetradrill_core::drill::{DrillParams, Pending};
use tetradrill_core::force::{ForceParams, ToolState};
use tetradrill_core::hash::{Aabb, HashEntry};
use tetradrill_core::hierarchy::{HNode, HierarchyStorage, SphereSlot, VEntry};
use tetradrill_core::servo::{servo_force, SimReport, World, WorldSizes, WorldStorage};
use tetradrill_core::{TetId, Vec3};

use crate::error::CliError;
use crate::meshio;
use crate::owned::OwnedMesh;
use crate::scenario::{Scenario, ToolKind};
use crate::traces::{Pose, PERIOD_S};

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
}

/// The storage sizes of a scenario's world over a mesh of `tets` tets: the core's defaults
/// ([`WorldSizes::new`]) with the scenario's capacities. A v_list smaller than the arena needs
/// shrinks the arena to what it can list (every block of 8 adds 7 leaves).
///
/// # Errors
/// A v_list shorter than the mesh's tet count (one entry per coarse tet is the least the
/// hierarchy needs), naming the key and the flag.
pub fn world_sizes(tets: usize, sc: &Scenario) -> Result<WorldSizes, String> {
    let mut s = WorldSizes::new(tets, sc.hierarchy_capacity).with_pending(sc.pending_capacity);
    s.candidates = sc.candidate_capacity;
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
        let s = world_sizes(tets, &raised)
            .unwrap_or_else(|_| WorldSizes::new(tets, sc.hierarchy_capacity));
        Self::with_sizes(mesh, s, sc)
    }

    /// [`EngineStorage::allocate`] refusing, with exit status 2, a capacity the mesh cannot
    /// take.
    pub fn try_allocate(mesh: OwnedMesh, sc: &Scenario) -> Result<Self, CliError> {
        let s = world_sizes(mesh.tets().len(), sc).map_err(CliError::input)?;
        Ok(Self::with_sizes(mesh, s, sc))
    }

    fn with_sizes(mesh: OwnedMesh, s: WorldSizes, sc: &Scenario) -> Self {
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
        }
    }

    /// The world over this storage (hashes the mesh once).
    pub fn world(&mut self) -> Result<World<'_>, CliError> {
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
    let loaded = meshio::load(std::path::Path::new(&sc.mesh), sc.scale)?;
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
        })
    }
}

/// One whole tick in one thread: the simulation step at `pose`, then the servo force at the
/// same pose. Replays, `timing` and the firmware run exactly this.
pub fn tick(
    world: &mut World<'_>,
    tool: &mut ToolState,
    p: &TickParams,
    pose: &Pose,
) -> (Vec3, SimReport) {
    let drill_on = pose.buttons & tetradrill_core::script::DRILL_ON != 0;
    let rep = world.simulate(pose.position, p.radius, p.reach, drill_on, &p.drill);
    let f = servo_force(world.contact(), pose.position, p.radius, tool, &p.force);
    (f, rep)
}
