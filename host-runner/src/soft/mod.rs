//! Host-owned storage for one soft body (`tetradrill_core::soft`): the caller slices the core
//! borrows, sized from a rest mesh, so a host, a test or a bench builds a body in one call;
//! and the simulation loop's side of `--body soft` ([`SoftSpec`], [`SoftDriver`]), with a
//! material per region of the mesh where the set-up's materials give one.

use tetradrill_core::mesh::Mesh;
use tetradrill_core::owned::SoftBuffers;
use tetradrill_core::soft::{
    mesh_tets, Material, SoftBody, SoftError, SoftMesh, SoftParams, SoftStorage,
};
use tetradrill_core::storage::StorageError;
use tetradrill_core::Vec3;

use crate::error::Error;

mod driver;
mod lanes;
mod spec;
mod two;

pub use driver::{DeformSummary, SoftDriver, SpreadSummary, StepTiming, TWO_THREADS_FROM_TETS};
pub use lanes::{lane_order, LANE_WINDOW};
pub use spec::{
    material_uses, Fix, MaterialUse, SoftRegion, SoftSpec, Stiffness, DAMPING, DEFAULT_POISSON,
    DEFAULT_RATE_HZ, DEFAULT_YOUNG, DENSITY, SUBSTEPS,
};
pub use two::{move_on_two_threads, on_two_threads, PartsOrder};

/// Threads for a whole soft step ([`SoftDriver::with_threads`]): 2 when the machine has a
/// core for each beside the `busy` threads of the caller's own (the servo's, the simulation's),
/// else 1. The same bits either way.
pub fn step_threads(busy: usize) -> usize {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    if cores > busy {
        2
    } else {
        1
    }
}

/// A soft body's rest mesh, owned, and its state and scratch on the heap (the core's
/// [`SoftBuffers`], carved by `SoftStorage::carve`, allocated once for the mesh's counts).
#[derive(Debug, Clone)]
pub struct SoftOwned {
    /// Rest positions.
    pub rest: Vec<Vec3>,
    /// Tets as node indices.
    pub tets: Vec<[u32; 4]>,
    /// Each tet's material index ([`SoftMesh::tet_material`]; empty: all of material 0).
    pub tet_material: Vec<u32>,
    /// The state and scratch, allocated for the counts they hold (made by the first body).
    buffers: Option<SoftBuffers>,
    /// Where [`SoftDriver`] put the world's nodes and tets when it reordered this body (kept,
    /// so a driver made again over it, at a reset, finds the world's order through it).
    pub(crate) driven: Option<PartsOrder>,
}

impl SoftOwned {
    /// A body's mesh over `rest` and `tets` and its storage for their counts (allocated here;
    /// when the heap refuses it, again by the first [`SoftOwned::body`], which then says so).
    pub fn new(rest: Vec<Vec3>, tets: Vec<[u32; 4]>) -> Self {
        let buffers = SoftBuffers::new(rest.len(), tets.len()).ok();
        Self {
            rest,
            tets,
            tet_material: Vec::new(),
            buffers,
            driven: None,
        }
    }

    /// Fills [`SoftOwned::tet_material`] from the mesh's region `labels` (one per tet, the
    /// world's order): a tet whose label is one of `spec`'s regions takes that region's
    /// material (index `1 + ` its place in [`SoftSpec::regions`], the order of
    /// [`SoftSpec::materials`]), every other tet the global one (index 0). Left empty when no
    /// tet takes a region's material, so such a body is the single-material one. Warns in one
    /// line when `--young` or `--poisson` was given but every tet's region sets its own.
    ///
    /// # Errors
    /// [`Error::Failure`] when `labels` does not have one label per tet (a failure of the
    /// caller).
    pub fn set_regions(&mut self, labels: &[i32], spec: &SoftSpec) -> Result<(), Error> {
        self.tet_material.clear();
        if spec.regions.is_empty() {
            return Ok(());
        }
        if labels.len() != self.tets.len() {
            return Err(Error::Failure(format!(
                "soft body: {} region labels for {} tets",
                labels.len(),
                self.tets.len()
            )));
        }
        let index = |l: &i32| {
            spec.regions
                .binary_search_by_key(l, |r| r.label)
                .map_or(0, |i| i as u32 + 1)
        };
        self.tet_material = labels.iter().map(index).collect();
        let global = |pick: fn(&SoftRegion) -> Option<f64>| {
            self.tet_material
                .iter()
                .any(|&m| m == 0 || pick(&spec.regions[m as usize - 1]).is_none())
        };
        let unused: Vec<&str> = [
            ("--young", spec.young_given && !global(|r| r.young)),
            ("--poisson", spec.poisson_given && !global(|r| r.poisson)),
        ]
        .iter()
        .filter(|(_, unused)| *unused)
        .map(|(flag, _)| *flag)
        .collect();
        if !unused.is_empty() {
            errln!(
                "tetradrill: warning: {} set, but every tet's region sets its own \
                 ([regions]): no effect",
                unused.join(", ")
            );
        }
        if self.tet_material.iter().all(|&m| m == 0) {
            self.tet_material.clear();
        }
        Ok(())
    }

    /// Storage for a body over a built core mesh at its current positions.
    pub fn from_mesh(mesh: &Mesh<'_>) -> Self {
        let mut tets = vec![[0u32; 4]; mesh.tet_count()];
        let n = mesh_tets(mesh, &mut tets).unwrap_or(0);
        tets.truncate(n);
        Self::new(mesh.positions().to_vec(), tets)
    }

    /// The mesh and the storage of a body at rest over it, every slot at its starting value
    /// (`SoftStorage::carve`): for a caller that sets the starting state (a displacement)
    /// before `SoftBody::new`. The storage is allocated again only when the mesh's counts
    /// changed.
    ///
    /// # Errors
    /// [`StorageError`] when the heap refuses the storage.
    pub fn parts(&mut self) -> Result<(SoftMesh<'_>, SoftStorage<'_>), StorageError> {
        let counts = (self.rest.len(), self.tets.len());
        let buffers = match self.buffers.take() {
            Some(b) if b.counts() == counts => b,
            _ => SoftBuffers::new(counts.0, counts.1)?,
        };
        let buffers = self.buffers.insert(buffers);
        let mesh = SoftMesh {
            rest: &self.rest,
            tets: &self.tets,
            tet_material: &self.tet_material,
        };
        Ok((mesh, buffers.storage()?))
    }

    /// A body at rest over this mesh and storage (whatever an earlier body left in it), each
    /// tet of the material [`SoftOwned::tet_material`] names in `materials` (all of
    /// `materials[0]` when that is empty).
    ///
    /// # Errors
    /// What [`SoftBody::new`] refuses (flat or inverted tets, bad materials or parameters),
    /// [`SoftError::Storage`] when the heap refuses the storage.
    pub fn body(
        &mut self,
        materials: &[Material],
        params: SoftParams,
    ) -> Result<SoftBody<'_>, SoftError> {
        let (mesh, storage) = self.parts().map_err(SoftError::Storage)?;
        SoftBody::new(mesh, materials, params, storage)
    }
}
