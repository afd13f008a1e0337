//! Host-owned storage for one soft body (`tetradrill_core::soft`): the caller slices the core
//! borrows, sized from a rest mesh, so a host, a test or a bench builds a body in one call.

use tetradrill_core::mesh::Mesh;
use tetradrill_core::soft::{
    mesh_tets, Material, SoftBody, SoftError, SoftMesh, SoftParams, SoftStorage, TetRest,
};
use tetradrill_core::Vec3;

/// Every slice a [`SoftBody`] borrows, owned: the rest mesh and the per-node and per-tet state.
#[derive(Debug, Clone)]
pub struct SoftOwned {
    /// Rest positions.
    pub rest: Vec<Vec3>,
    /// Tets as node indices.
    pub tets: Vec<[u32; 4]>,
    /// Each tet's material index ([`SoftMesh::tet_material`]; empty: all of material 0).
    pub tet_material: Vec<u32>,
    /// [`SoftStorage::displacement`].
    pub displacement: Vec<Vec3>,
    /// [`SoftStorage::velocity`].
    pub velocity: Vec<Vec3>,
    /// [`SoftStorage::previous`].
    pub previous: Vec<Vec3>,
    /// [`SoftStorage::mass`].
    pub mass: Vec<f32>,
    /// [`SoftStorage::inv_mass`].
    pub inv_mass: Vec<f32>,
    /// [`SoftStorage::tet_rest`].
    pub tet_rest: Vec<TetRest>,
    /// [`SoftStorage::lambdas`].
    pub lambdas: Vec<[f32; 2]>,
}

impl SoftOwned {
    /// Storage for a body over `rest` and `tets` (zeroed state; [`SoftOwned::body`] fills it).
    pub fn new(rest: Vec<Vec3>, tets: Vec<[u32; 4]>) -> Self {
        let (n, t) = (rest.len(), tets.len());
        Self {
            rest,
            tets,
            tet_material: Vec::new(),
            displacement: vec![Vec3::ZERO; n],
            velocity: vec![Vec3::ZERO; n],
            previous: vec![Vec3::ZERO; n],
            mass: vec![0.0; n],
            inv_mass: vec![0.0; n],
            tet_rest: vec![TetRest::default(); t],
            lambdas: vec![[0.0; 2]; t],
        }
    }

    /// Storage for a body over a built core mesh at its current positions.
    pub fn from_mesh(mesh: &Mesh<'_>) -> Self {
        let mut tets = vec![[0u32; 4]; mesh.tet_count()];
        let n = mesh_tets(mesh, &mut tets).unwrap_or(0);
        tets.truncate(n);
        Self::new(mesh.positions().to_vec(), tets)
    }

    /// A body at rest over this storage, each tet of the material [`SoftOwned::tet_material`]
    /// names in `materials` (all of `materials[0]` when that is empty).
    ///
    /// # Errors
    /// What [`SoftBody::new`] refuses (flat or inverted tets, bad materials or parameters).
    pub fn body(
        &mut self,
        materials: &[Material],
        params: SoftParams,
    ) -> Result<SoftBody<'_>, SoftError> {
        SoftBody::new(
            SoftMesh {
                rest: &self.rest,
                tets: &self.tets,
                tet_material: &self.tet_material,
            },
            materials,
            params,
            SoftStorage {
                displacement: &mut self.displacement,
                velocity: &mut self.velocity,
                previous: &mut self.previous,
                mass: &mut self.mass,
                inv_mass: &mut self.inv_mass,
                tet_rest: &mut self.tet_rest,
                lambdas: &mut self.lambdas,
            },
        )
    }
}
