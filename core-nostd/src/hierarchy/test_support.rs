//! A hierarchy over the 12-tet cube on the stack, for the unit tests of the hierarchy and
//! the drill.

use glam::Vec3;

use super::Hierarchy;
use crate::builtin::{CUBE12_NODES, CUBE12_TETS};
use crate::ids::TetId;
use crate::mesh::{BuildOptions, FaceKey, Mesh, MeshStorage, Node, Tet};

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
                changes: &mut [],
            },
        )
        .expect("test hierarchy");
    };
}
pub(crate) use cube_hierarchy;

/// A small xorshift generator.
pub(crate) struct Rng(pub(crate) u64);

impl Rng {
    pub(crate) fn next(&mut self) -> u32 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 32) as u32
    }
}

/// A random operation: refine a non-erased leaf above depth 3, or erase one.
pub(crate) fn random_op(h: &mut Hierarchy<'_>, mesh: &Mesh<'_>, rng: &mut Rng) {
    let t = TetId(rng.next() % CUBE12_TETS as u32);
    let mut leaves = [0u32; 512];
    let mut n = 0;
    h.for_each_leaf(t, |l| {
        if !l.record.erased() && n < leaves.len() {
            leaves[n] = l.index;
            n += 1;
        }
    });
    if n == 0 {
        return;
    }
    let index = leaves[rng.next() as usize % n];
    let depth = super::table::Path::of_index(index).unwrap().depth;
    if depth < 3 && !rng.next().is_multiple_of(3) {
        let _ = h.refine(mesh, t, index);
    } else {
        let _ = h.erase(mesh, t, index);
    }
}

/// The 12-tet cube's mesh storage on the stack, with its tets.
pub(crate) struct Cube {
    pub(crate) pos: [Vec3; CUBE12_NODES],
    pub(crate) nodes: [Node; CUBE12_NODES],
    pub(crate) normals: [Vec3; CUBE12_NODES],
    pub(crate) tets: [Tet; CUBE12_TETS],
    pub(crate) t: [[u32; 4]; CUBE12_TETS],
}

impl Cube {
    /// The paper's 12-tet cube ([`crate::builtin::cube12`]), its storage empty.
    pub(crate) fn new() -> Self {
        let (pos, t) = crate::builtin::cube12();
        Self {
            pos,
            nodes: [Node::default(); CUBE12_NODES],
            normals: [Vec3::ZERO; CUBE12_NODES],
            tets: [Tet::default(); CUBE12_TETS],
            t,
        }
    }
}

/// The 12-tet cube's mesh in `c`.
pub(crate) fn mesh(c: &mut Cube) -> Mesh<'_> {
    let mut scratch = [FaceKey::default(); 4 * CUBE12_TETS];
    let storage = MeshStorage {
        nodes: &mut c.nodes,
        normals: &mut c.normals,
        tets: &mut c.tets,
    };
    Mesh::build(
        &mut c.pos,
        &c.t,
        storage,
        &mut scratch,
        BuildOptions::default(),
    )
    .unwrap()
}
