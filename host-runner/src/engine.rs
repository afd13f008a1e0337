//! The host's side of the core's [`World`]: storage allocated once for a scenario, and the
//! per-tick step that replays, real-time runs and `timing` share.

use std::collections::BTreeMap;

use tetradrill_core::collide::{ZoneGather, ZONE_MARGIN_RADII};
use tetradrill_core::drill::{DrillParams, Material};
use tetradrill_core::force::{DrillTool, ForceParams, ToolState};
use tetradrill_core::mesh::Mesh;
use tetradrill_core::owned::WorldBuffers;
use tetradrill_core::servo::{
    drill_force, servo_force, DrillState, PassiveReport, SimReport, World, WorldSizes,
    DEFAULT_MAX_CELLS, DEFAULT_PENDING,
};
use tetradrill_core::storage::StorageError;
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

/// Storage for one [`World`], allocated once before the run: the mesh, the world's buffers
/// ([`WorldBuffers`]: the core's one layout of a world's storage) and the scenario's settings
/// of each world made over them.
#[derive(Debug)]
pub struct EngineStorage {
    mesh: OwnedMesh,
    buffers: WorldBuffers,
    contact_search_nodes: u32,
    tick_budget: u32,
    zone_gather_work: u32,
    sizing: Option<ToolSizing>,
    /// The mesh label of each region (empty: no regions).
    region_labels: Vec<i32>,
    /// The mesh's positions when deformation was enabled: each world over this storage (a
    /// viewer's reset too) starts from them, whatever the last world left (empty: the world
    /// is rigid).
    rest_copy: Vec<Vec3>,
}

/// The regions of a scenario's world: one per distinct label of the mesh, in label order.
#[derive(Debug, Clone, PartialEq)]
pub struct RegionTable {
    /// The label of each region.
    pub labels: Vec<i32>,
    /// The material of each region: the scenario's `[regions]` entry for its label, else the
    /// default region's (`hardness`, `pressure_threshold`, the scenario's stiffness).
    pub materials: Vec<Material>,
    /// The display colour of each region, where the scenario sets one.
    pub colours: Vec<Option<[f32; 3]>>,
    /// Each tet's region index.
    pub of_tet: Vec<u8>,
}

/// The regions of `labels` (one per tet) under the scenario's materials. `Ok(None)` when the
/// mesh has more than 256 distinct labels and the scenario sets no material (a world then
/// runs without regions, as every material would be the default one).
///
/// # Errors
/// More than 256 distinct labels with materials set, naming the count.
pub fn region_table(labels: &[i32], sc: &Scenario) -> Result<Option<RegionTable>, String> {
    let mut distinct: Vec<i32> = labels.to_vec();
    distinct.sort_unstable();
    distinct.dedup();
    if distinct.is_empty() {
        distinct.push(0);
    }
    let default = Material {
        hardness: sc.hardness as f32,
        threshold: sc.pressure_threshold as f32,
        stiffness: 0.0,
    };
    if distinct.len() > 256 {
        if sc.regions.is_empty() && default == Material::DEFAULT {
            return Ok(None);
        }
        return Err(format!(
            "the mesh has {} region labels; materials work on at most 256",
            distinct.len()
        ));
    }
    let by_label: BTreeMap<i32, &crate::scenario::RegionSpec> = sc
        .regions
        .iter()
        .filter_map(|(k, v)| k.trim().parse::<i32>().ok().map(|l| (l, v)))
        .collect();
    let materials = distinct
        .iter()
        .map(|l| by_label.get(l).map_or(default, |r| r.material()))
        .collect();
    let colours = distinct
        .iter()
        .map(|l| by_label.get(l).and_then(|r| r.rgb().ok().flatten()))
        .collect();
    let of_tet = labels
        .iter()
        .map(|l| distinct.binary_search(l).unwrap_or(0) as u8)
        .collect();
    Ok(Some(RegionTable {
        labels: distinct,
        materials,
        colours,
        of_tet,
    }))
}

/// The volume removed from each region of `world`, by label (`None` without regions).
pub fn removed_by_region(world: &World<'_>, labels: &[i32]) -> Option<BTreeMap<String, f64>> {
    let r = world.regions()?;
    Some(
        r.table()
            .iter()
            .zip(labels)
            .map(|(reg, l)| (l.to_string(), reg.removed()))
            .collect(),
    )
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
            .unwrap_or_else(|e| panic!("cannot allocate the world's storage: {e}"))
    }

    /// The burr's sizes on `mesh` ([`ToolSizing`]) when the scenario's tool is a sphere.
    fn sizing(mesh: &OwnedMesh, sc: &Scenario) -> Option<ToolSizing> {
        match sc.tool_kind() {
            Ok(ToolKind::Sphere(r)) => Some(ToolSizing::of(mesh, r, sc.max_depth)),
            Ok(ToolKind::Drill {
                burr, shaft_length, ..
            }) => {
                // The burr's buffers, with the candidate list and the zone query grown to
                // the shaft's reach (a burr as wide as the whole tool, for those two only).
                let z = ToolSizing::of(mesh, burr, sc.max_depth);
                let whole = ToolSizing::of(mesh, 0.5 * (shaft_length + burr), sc.max_depth);
                Some(ToolSizing {
                    candidates: z.candidates.max(whole.candidates),
                    max_cells: z.max_cells.max(whole.max_cells),
                    ..z
                })
            }
            _ => None,
        }
    }

    /// The sizes chosen for the scenario's burr, `None` for a mesh tool.
    pub fn tool_sizing(&self) -> Option<&ToolSizing> {
        self.sizing.as_ref()
    }

    /// The candidate list's length.
    pub fn candidate_capacity(&self) -> usize {
        self.buffers.sizes().candidates
    }

    /// The hierarchy arena's nodes.
    pub fn hierarchy_capacity(&self) -> usize {
        self.buffers.sizes().arena
    }

    /// [`EngineStorage::allocate`] refusing, with exit status 2, a capacity the mesh cannot
    /// take.
    pub fn try_allocate(mesh: OwnedMesh, sc: &Scenario) -> Result<Self, CliError> {
        let sizing = Self::sizing(&mesh, sc);
        let s = world_sizes_for(mesh.tets().len(), sc, sizing.as_ref()).map_err(CliError::input)?;
        Self::with_sizes(mesh, s, sc, sizing)
            .map_err(|e| CliError::failure(format!("cannot set up the simulation: {e}")))
    }

    fn with_sizes(
        mesh: OwnedMesh,
        s: WorldSizes,
        sc: &Scenario,
        sizing: Option<ToolSizing>,
    ) -> Result<Self, StorageError> {
        Ok(Self {
            mesh,
            buffers: WorldBuffers::new(s)?,
            contact_search_nodes: sc.contact_search_nodes,
            tick_budget: sc.tick_budget,
            zone_gather_work: sc.zone_gather_work,
            sizing,
            region_labels: Vec::new(),
            rest_copy: Vec::new(),
        })
    }

    /// Makes the worlds over this storage deforming ([`World::enable_deformation`], the rest
    /// state kept here), with the spare tables of a spread update (`--soft-spread`): a soft
    /// body then hands them its positions every physics step.
    ///
    /// # Errors
    /// The heap refused the deformation storage.
    pub fn enable_deformation(&mut self) -> Result<(), CliError> {
        let nodes = self.mesh.positions().len();
        self.buffers
            .enable_deformation(nodes)
            .map_err(storage_failure)?;
        self.rest_copy = self.mesh.positions().to_vec();
        Ok(())
    }

    /// Storage for a soft body over the mesh at rest (node and tet order the world's).
    pub fn soft_owned(&mut self) -> crate::soft::SoftOwned {
        crate::soft::SoftOwned::from_mesh(&self.mesh.view())
    }

    /// Gives the world regions from the mesh's `labels` (one per tet) and the scenario's
    /// materials ([`region_table`]); labels the `[regions]` table names that the mesh lacks
    /// get one warning line. Without this call a world has no regions.
    ///
    /// # Errors
    /// Exit status 2 for a table [`region_table`] refuses.
    pub fn set_labels(&mut self, labels: &[i32], sc: &Scenario) -> Result<(), CliError> {
        let Some(t) = region_table(labels, sc).map_err(CliError::input)? else {
            return Ok(());
        };
        let missing: Vec<&str> = sc
            .regions
            .keys()
            .filter(|k| {
                k.trim()
                    .parse::<i32>()
                    .is_ok_and(|l| t.labels.binary_search(&l).is_err())
            })
            .map(String::as_str)
            .collect();
        if !missing.is_empty() {
            errln!(
                "tetradrill: warning: the mesh has no region labelled {} (materials set in \
                 [regions] for nothing)",
                missing.join(", ")
            );
        }
        self.buffers.set_regions(&t.materials, t.of_tet);
        self.region_labels = t.labels;
        Ok(())
    }

    /// The mesh label of each region (empty without regions).
    pub fn region_labels(&self) -> &[i32] {
        &self.region_labels
    }

    /// The world over this storage (hashes the mesh once).
    pub fn world(&mut self) -> Result<World<'_>, CliError> {
        self.world_of(None)
    }

    /// The world over this storage with `mesh` in place of the storage's own: a mesh whose
    /// tets are read in place from a blob ([`tetradrill_core::blob::MeshBlob::mesh`]), which
    /// must have the storage's tet count.
    pub fn world_with<'s>(&'s mut self, mesh: Mesh<'s>) -> Result<World<'s>, CliError> {
        if mesh.tet_count() != self.mesh.tets().len() {
            return Err(CliError::failure(format!(
                "cannot set up the simulation: a mesh of {} tets over storage for {}",
                mesh.tet_count(),
                self.mesh.tets().len()
            )));
        }
        self.world_of(Some(mesh))
    }

    fn world_of<'s>(&'s mut self, mesh: Option<Mesh<'s>>) -> Result<World<'s>, CliError> {
        let mesh = match mesh {
            Some(m) => m,
            None => {
                let mut m = self.mesh.view();
                if !self.rest_copy.is_empty() {
                    // A deforming world left the nodes where its body had moved them.
                    m.positions_mut().copy_from_slice(&self.rest_copy);
                }
                m
            }
        };
        // The zone query may visit as many cells as the burr's zone covers, and never fewer
        // than a list of this length can be filled from.
        let cells = self.sizing.map_or(DEFAULT_MAX_CELLS, |z| z.max_cells);
        let by_list = (self.buffers.sizes().candidates / 2).min(u32::MAX as usize) as u32;
        let max_cells = cells.max(by_list).max(DEFAULT_MAX_CELLS);
        let mut w = self
            .buffers
            .world(mesh)
            .map_err(|e| CliError::failure(format!("cannot set up the simulation: {e}")))?;
        w.set_contact_max_nodes(self.contact_search_nodes);
        w.set_max_cells(max_cells);
        w.set_tick_budget((self.tick_budget > 0).then_some(self.tick_budget));
        w.set_zone_gather(
            (self.zone_gather_work > 0)
                .then(|| ZoneGather::new(self.zone_gather_work, ZONE_MARGIN_RADII)),
        );
        Ok(w)
    }
}

/// A storage refusal as a run's failure.
fn storage_failure(e: StorageError) -> CliError {
    CliError::failure(format!("cannot set up the simulation: {e}"))
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
    /// The drill's shape when the tool is `drill:...` (a burr on a shaft of passive points).
    pub shaft: Option<DrillTool>,
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
        let mut shaft = None;
        let radius = match sc.tool_kind().map_err(CliError::input)? {
            ToolKind::Sphere(r) => r as f32,
            ToolKind::Drill {
                burr,
                shaft_length,
                shaft_radius,
            } => {
                shaft = Some(DrillTool {
                    burr_radius: burr as f32,
                    shaft_length: shaft_length as f32,
                    shaft_radius: shaft_radius as f32,
                });
                burr as f32
            }
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
        if sc.pass_threads != 1 {
            return Err(CliError::input(
                "--pass-threads splits a mesh tool's contact pass over two threads; a sphere \
                 tool has no such pass",
            ));
        }
        if sc.entry_remedy {
            return Err(CliError::input(
                "--entry-remedy is a mesh tool's remedy (Praktikum report, section 6); a sphere \
                 tool has none",
            ));
        }
        Ok(Self {
            radius,
            shaft,
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
/// this. The force's magnitude presses the burr into the material at the next step
/// ([`World::set_pressing`]; with `servo_lag` 0 the step after this tick's, with 1 this tick's
/// own step, which follows the force).
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
        // What presses the burr against the material in the next step: this tick's force.
        world.set_pressing(f.length(), PERIOD_S as f32);
        (f, rep)
    } else {
        let f = servo_force(world.contact(), pose.position, p.radius, tool, &p.force);
        world.set_pressing(f.length(), PERIOD_S as f32);
        let rep = world.simulate(pose.position, p.radius, p.reach, drill_on, &p.drill);
        (f, rep)
    }
}

/// What a drill tool carries from tick to tick besides the burr's [`ToolState`]: its passive
/// points ([`DrillState`]) and the shaft's damping state.
#[derive(Debug, Clone, Copy, Default)]
pub struct ShaftState {
    /// The passive points' proxies and planes.
    pub drill: DrillState,
    /// The shaft's damping state.
    pub damping: ToolState,
    /// The last step's passive-point report.
    pub last: PassiveReport,
}

/// [`tick`] for any burr tool: a drill (`p.shaft`) runs [`World::simulate_drill`] and
/// [`drill_force`] with the tool's axis from the pose's rotation (`shaft` carries its
/// state); a plain burr runs [`tick`] exactly.
pub fn tick_tool(
    world: &mut World<'_>,
    tool: &mut ToolState,
    shaft: &mut ShaftState,
    p: &TickParams,
    pose: &Pose,
) -> (Vec3, SimReport) {
    let Some(d) = p.shaft else {
        return tick(world, tool, p, pose);
    };
    let drill_on = pose.buttons & tetradrill_core::script::DRILL_ON != 0;
    let [w, x, y, z] = pose.rotation;
    let axis = DrillTool::axis(tetradrill_core::Quat::from_xyzw(x, y, z, w));
    let (rep, prep) = world.simulate_drill(
        &d,
        pose.position,
        axis,
        p.reach,
        drill_on,
        &p.drill,
        &mut shaft.drill,
    );
    shaft.last = prep;
    let (f, on_burr) = drill_force(
        world.contact(),
        &d,
        pose.position,
        axis,
        &shaft.drill,
        tool,
        &mut shaft.damping,
        &p.force,
    );
    // What presses the burr in the next step: the burr's own force, not the shaft's.
    world.set_pressing(on_burr.length(), PERIOD_S as f32);
    (f, rep)
}
