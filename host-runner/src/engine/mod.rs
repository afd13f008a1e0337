//! The host's side of the core's [`World`]: storage allocated once for a set-up
//! ([`EngineStorage`]), its sizes ([`sizing`]), its regions ([`regions`]), and the per-tick
//! step that replays, real-time runs and `timing` share ([`mod@tick`]).

use tetradrill_core::collide::{ZoneGather, ZONE_MARGIN_RADII};
use tetradrill_core::mesh::Mesh;
use tetradrill_core::owned::WorldBuffers;
use tetradrill_core::servo::{World, WorldSizes, DEFAULT_MAX_CELLS};
use tetradrill_core::Vec3;

use crate::error::Error;
use crate::meshio;
use crate::owned::OwnedMesh;
use crate::setup::Setup;

pub mod regions;
pub mod sizing;
pub mod tick;

pub use regions::{region_table, removed_by_region, RegionTable};
pub use sizing::{
    world_sizes, ToolSizing, GATHER_FROM_TETS, GATHER_MIN_WORK, GATHER_STEPS, MAX_SIZED_ARENA,
    SIZED_FOR_DEPTH,
};
pub use tick::{tick, tick_tool, ShaftState, TickParams};

/// Storage for one [`World`], allocated once before the run: the mesh, the world's buffers
/// ([`WorldBuffers`]: the core's one layout of a world's storage) and the set-up's settings
/// of each world made over them.
#[derive(Debug)]
pub struct EngineStorage {
    mesh: OwnedMesh,
    buffers: WorldBuffers,
    contact_search_nodes: u32,
    tick_budget: u32,
    /// The bound on a drill tool's shaft walk (`None`: unbounded, or not a drill).
    shaft_nodes: Option<u32>,
    /// The candidate gather each world gets (`None`: the one-shot query).
    zone_gather: Option<ZoneGather>,
    resolution: f32,
    /// The burr's vibration frequency, hertz (0: none).
    vibration_hz: f32,
    sizing: Option<ToolSizing>,
    /// The mesh label of each region (empty: no regions).
    region_labels: Vec<i32>,
    /// The mesh's positions when deformation was enabled: each world over this storage (a
    /// viewer's reset too) starts from them, whatever the last world left (empty: the world
    /// is rigid).
    rest_copy: Vec<Vec3>,
}

impl EngineStorage {
    /// Allocates everything the set-up's world needs for `mesh`: the buffers the set-up's
    /// capacities ask for, the others sized for its tool on the mesh ([`ToolSizing`]).
    ///
    /// # Errors
    /// A capacity the mesh cannot take ([`Error::Setup`]: a v_list shorter than its tet
    /// count), or storage the heap refuses ([`Error::Storage`]).
    pub fn new(mesh: OwnedMesh, setup: &Setup) -> Result<Self, Error> {
        let sizing = ToolSizing::for_tool(&mesh, &setup.tool, setup.drilling.max_depth);
        let s = sizing::world_sizes_for(mesh.tets().len(), &setup.capacities, sizing.as_ref())?;
        Self::with_sizes(mesh, s, setup, sizing)
    }

    /// The sizes chosen for the set-up's burr, `None` for a mesh tool.
    pub fn tool_sizing(&self) -> Option<&ToolSizing> {
        self.sizing.as_ref()
    }

    /// The candidate gather each world over this storage gets, `None` for the one-shot query
    /// every step (the set-up's `zone_gather_work`, or chosen for the burr on the mesh).
    pub fn zone_gather(&self) -> Option<&ZoneGather> {
        self.zone_gather.as_ref()
    }

    /// The candidate list's length.
    pub fn candidate_capacity(&self) -> usize {
        self.buffers.sizes().candidates
    }

    /// The hierarchy arena's nodes.
    pub fn hierarchy_capacity(&self) -> usize {
        self.buffers.sizes().arena
    }

    /// Storage of the sizes `s`, with the set-up's bounds on a world's work.
    ///
    /// # Errors
    /// [`Error::Storage`] when the heap refuses the buffers.
    pub fn with_sizes(
        mesh: OwnedMesh,
        s: WorldSizes,
        setup: &Setup,
        sizing: Option<ToolSizing>,
    ) -> Result<Self, Error> {
        let d = &setup.drilling;
        Ok(Self {
            mesh,
            buffers: WorldBuffers::new(s)?,
            contact_search_nodes: d.contact_search_nodes,
            tick_budget: d.tick_budget,
            shaft_nodes: (d.shaft_nodes > 0
                && matches!(setup.tool, crate::setup::Tool::Drill { .. }))
            .then_some(d.shaft_nodes),
            zone_gather: match d.zone_gather_work {
                Some(0) => None,
                Some(w) => Some(ZoneGather::new(w, ZONE_MARGIN_RADII)),
                None => sizing
                    .and_then(|z| z.gather_work)
                    .filter(|_| setup.capacities.candidates.is_none())
                    .map(|w| ZoneGather::exact(w, ZONE_MARGIN_RADII)),
            },
            resolution: setup.drill_resolution() as f32,
            vibration_hz: setup.forces.vibration_hz as f32,
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
    pub fn enable_deformation(&mut self) -> Result<(), Error> {
        let nodes = self.mesh.positions().len();
        self.buffers.enable_deformation(nodes)?;
        self.rest_copy = self.mesh.positions().to_vec();
        Ok(())
    }

    /// Storage for a soft body over the mesh at rest (node and tet order the world's).
    pub fn soft_owned(&mut self) -> crate::soft::SoftOwned {
        crate::soft::SoftOwned::from_mesh(&self.mesh.view())
    }

    /// The worlds over this storage made deforming ([`EngineStorage::enable_deformation`])
    /// and a soft body over the mesh at rest ([`EngineStorage::soft_owned`]) with `spec`'s
    /// materials by the mesh's region `labels` (one per tet): what `replay`, `run` and the
    /// library's `Drilling` set up for a soft set-up.
    ///
    /// # Errors
    /// The heap refused the deformation storage; a region table `spec` refuses.
    pub fn soft_body(
        &mut self,
        spec: &crate::soft::SoftSpec,
        labels: &[i32],
    ) -> Result<crate::soft::SoftOwned, Error> {
        self.enable_deformation()?;
        let mut owned = self.soft_owned();
        owned.set_regions(labels, spec)?;
        Ok(owned)
    }

    /// Gives the world regions from the mesh's `labels` (one per tet) and the set-up's
    /// materials ([`region_table`]); labels the materials name that the mesh lacks get one
    /// warning line. Without this call a world has no regions.
    ///
    /// # Errors
    /// A table [`region_table`] refuses.
    pub fn set_labels(&mut self, labels: &[i32], setup: &Setup) -> Result<(), Error> {
        let Some(t) = region_table(labels, &setup.materials)? else {
            return Ok(());
        };
        let missing: Vec<String> = setup
            .materials
            .regions
            .keys()
            .filter(|l| t.labels.binary_search(l).is_err())
            .map(i32::to_string)
            .collect();
        if !missing.is_empty() {
            errln!(
                "tetradrill: warning: the mesh has no region labelled {} (materials set in \
                 [regions] for nothing)",
                missing.join(", ")
            );
        }
        self.buffers.set_regions(&t.regions, t.of_tet);
        self.region_labels = t.labels;
        Ok(())
    }

    /// The mesh label of each region (empty without regions).
    pub fn region_labels(&self) -> &[i32] {
        &self.region_labels
    }

    /// The world over this storage (hashes the mesh once).
    ///
    /// # Errors
    /// [`Error::World`] when the core refuses the storage.
    pub fn world(&mut self) -> Result<World<'_>, Error> {
        self.world_of(None)
    }

    /// The world over this storage with `mesh` in place of the storage's own: a mesh whose
    /// tets are read in place from a blob ([`tetradrill_core::blob::MeshBlob::mesh`]), which
    /// must have the storage's tet count.
    ///
    /// # Errors
    /// [`Error::MeshMismatch`] for another tet count, [`Error::World`] when the core refuses
    /// the storage.
    pub fn world_with<'s>(&'s mut self, mesh: Mesh<'s>) -> Result<World<'s>, Error> {
        if mesh.tet_count() != self.mesh.tets().len() {
            return Err(Error::MeshMismatch {
                tets: mesh.tet_count(),
                storage: self.mesh.tets().len(),
            });
        }
        self.world_of(Some(mesh))
    }

    fn world_of<'s>(&'s mut self, mesh: Option<Mesh<'s>>) -> Result<World<'s>, Error> {
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
        let mut w = self.buffers.world(mesh)?;
        w.set_contact_max_nodes(self.contact_search_nodes);
        w.set_max_cells(max_cells);
        w.set_tick_budget((self.tick_budget > 0).then_some(self.tick_budget));
        w.set_shaft_max_nodes(self.shaft_nodes);
        w.set_drill_resolution(self.resolution);
        w.set_vibration_hz(self.vibration_hz);
        w.set_zone_gather(self.zone_gather);
        Ok(w)
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

/// The set-up's mesh, loaded and built, its warnings printed (one line each).
///
/// # Errors
/// [`Error::Mesh`] naming the file, the line and the reason.
pub fn load_mesh(setup: &Setup) -> Result<meshio::LoadedMesh, Error> {
    let loaded = setup.mesh.load()?;
    for w in &loaded.warnings {
        errln!("tetradrill: warning: {w}");
    }
    Ok(loaded)
}
