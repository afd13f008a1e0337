//! [`OwnedMesh`]: the host's storage for one core mesh. The core borrows caller slices; the
//! host allocates them once here, builds the mesh once, and takes cheap views afterwards.

use tetradrill_core::mesh::{BuildError, BuildOptions, BuildStats, FaceKey, Mesh, MeshStorage};
use tetradrill_core::mesh::{Node, Tet};
use tetradrill_core::Vec3;

/// Storage for one built mesh, allocated once.
#[derive(Debug, Clone)]
pub struct OwnedMesh {
    positions: Vec<Vec3>,
    normals: Vec<Vec3>,
    nodes: Vec<Node>,
    tets: Vec<Tet>,
    stats: BuildStats,
}

impl OwnedMesh {
    /// Allocates storage for the counts and builds the mesh (see [`Mesh::build`]).
    pub fn build(
        positions: Vec<Vec3>,
        tet_nodes: &[[u32; 4]],
        options: BuildOptions,
    ) -> Result<Self, BuildError> {
        let n = positions.len();
        let t = tet_nodes.len();
        let mut me = Self {
            positions,
            normals: vec![Vec3::ZERO; n],
            nodes: vec![Node::default(); n],
            tets: vec![Tet::default(); t],
            stats: BuildStats::default(),
        };
        let mut scratch = vec![FaceKey::default(); 4 * t];
        let mesh = Mesh::build(
            &mut me.positions,
            tet_nodes,
            MeshStorage {
                nodes: &mut me.nodes,
                normals: &mut me.normals,
                tets: &mut me.tets,
            },
            &mut scratch,
            options,
        )?;
        me.stats = mesh.stats();
        Ok(me)
    }

    /// A view of the mesh (O(1)).
    pub fn view(&mut self) -> Mesh<'_> {
        let t = self.tets.len();
        Mesh::from_parts(
            &mut self.positions,
            MeshStorage {
                nodes: &mut self.nodes,
                normals: &mut self.normals,
                tets: &mut self.tets,
            },
            t,
            self.stats,
        )
    }

    /// Build statistics.
    pub fn stats(&self) -> BuildStats {
        self.stats
    }

    /// Node positions.
    pub fn positions(&self) -> &[Vec3] {
        &self.positions
    }

    /// Tets.
    pub fn tets(&self) -> &[Tet] {
        &self.tets
    }
}
