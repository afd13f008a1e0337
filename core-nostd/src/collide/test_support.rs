//! Tiny meshes over fixed arrays for the unit tests of collide, depth and force.

use glam::Vec3;

use crate::builtin;
use crate::mesh::{BuildOptions, FaceKey, Mesh, MeshStorage, Node, Tet};

/// Fixed storage for a mesh of at most `N` nodes and `T` tets.
pub(crate) struct Store<const N: usize, const T: usize> {
    pub positions: [Vec3; N],
    pub tet_nodes: [[u32; 4]; T],
    pub nodes: [Node; N],
    pub normals: [Vec3; N],
    pub tets: [Tet; T],
    pub scratch: [[FaceKey; 4]; T],
    pub n: usize,
    pub t: usize,
}

impl<const N: usize, const T: usize> Store<N, T> {
    pub fn empty() -> Self {
        Self {
            positions: [Vec3::ZERO; N],
            tet_nodes: [[0; 4]; T],
            nodes: [Node::default(); N],
            normals: [Vec3::ZERO; N],
            tets: [Tet::default(); T],
            scratch: [[FaceKey::default(); 4]; T],
            n: 0,
            t: 0,
        }
    }

    /// A block of `k^3` cubes of edge `edge` from `origin`.
    pub fn block(k: usize, edge: f32, origin: Vec3) -> Self {
        let mut s = Self::empty();
        let (n, t) =
            builtin::block(k, edge, origin, &mut s.positions, &mut s.tet_nodes).expect("fits");
        s.n = n;
        s.t = t;
        s
    }

    /// The 12-tet cube, scaled and moved.
    pub fn cube12(scale: f32, origin: Vec3) -> Self {
        let mut s = Self::empty();
        let (p, t) = builtin::cube12();
        for (d, q) in s.positions.iter_mut().zip(p.iter()) {
            *d = *q * scale + origin;
        }
        s.tet_nodes[..t.len()].copy_from_slice(&t);
        s.n = p.len();
        s.t = t.len();
        s
    }

    /// The mesh as collide, depth and force tests use it (tets kept as given).
    pub fn mesh(&mut self) -> Mesh<'_> {
        self.mesh_with(BuildOptions {
            relabel_for_refinement: false,
        })
    }

    /// The mesh as the drill and the hierarchy need it (each tet relabelled for refinement).
    pub fn refinable_mesh(&mut self) -> Mesh<'_> {
        self.mesh_with(BuildOptions::default())
    }

    fn mesh_with(&mut self, options: BuildOptions) -> Mesh<'_> {
        let flat = self.scratch.as_flattened_mut();
        Mesh::build(
            &mut self.positions[..self.n],
            &self.tet_nodes[..self.t],
            MeshStorage {
                nodes: &mut self.nodes,
                normals: &mut self.normals,
                tets: &mut self.tets,
            },
            flat,
            options,
        )
        .expect("test mesh builds")
    }
}

/// `cube_hierarchy!(h, &mesh, A)`: `let mut h` = a hierarchy over the 12-tet cube's roots, an
/// arena of `A` nodes and the v_list that arena needs, all on the stack.
macro_rules! cube_hierarchy {
    ($h:ident, $mesh:expr, $arena:expr) => {
        let mut roots = [$crate::hierarchy::HNode::LEAF; $crate::builtin::CUBE12_TETS];
        let mut arena = [$crate::hierarchy::HNode::LEAF; $arena];
        let mut vlist =
            [$crate::hierarchy::VEntry::default(); $crate::builtin::CUBE12_TETS + 7 * ($arena / 8)];
        let mut $h = $crate::hierarchy::Hierarchy::new(
            $mesh,
            $crate::hierarchy::HierarchyStorage {
                roots: &mut roots,
                arena: &mut arena,
                vlist: &mut vlist,
            },
        )
        .expect("test hierarchy");
    };
}
pub(crate) use cube_hierarchy;
