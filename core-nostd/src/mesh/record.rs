//! The compact records: [`Tet`] (36 bytes), [`Node`] (8 bytes), the packed reverse index and the
//! entity uses that name a vertex, edge or face of one tet.

use crate::ids::{NodeId, TetId};

/// Per-face reverse index in one byte (Celes et al. 2005): bits 0-1 hold the neighbour's face
/// id that matches this face, bits 2-3 the ring offset (0..=2) between the two listings of the
/// shared face. Meaningless for a boundary face (neighbour `NONE`).
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default)]
#[repr(transparent)]
pub struct Reverse(pub u8);

impl Reverse {
    /// Packs a neighbour face (0..=3) and a ring offset (0..=2).
    #[inline]
    pub const fn new(face: u8, offset: u8) -> Self {
        Self((face & 3) | ((offset & 3) << 2))
    }
    /// The neighbour's face id that is this face.
    #[inline]
    pub const fn face(self) -> u8 {
        self.0 & 3
    }
    /// The ring offset between the two listings: the vertex at position `p` of this face's
    /// listing is at position `(3 - p + offset) % 3` of the neighbour's listing.
    #[inline]
    pub const fn offset(self) -> u8 {
        (self.0 >> 2) & 3
    }
}

/// A tetrahedron: four node ids, four neighbours ordered by face (face `i` opposite vertex
/// `i`), and one reverse-index byte per face.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
#[repr(C)]
pub struct Tet {
    /// The four nodes, positively oriented after the mesh is built.
    pub nodes: [NodeId; 4],
    /// The tet across each face, or [`TetId::NONE`] on the boundary.
    pub neighbours: [TetId; 4],
    /// Reverse index per face.
    pub reverse: [Reverse; 4],
}

impl Tet {
    /// A tet with the given nodes and no neighbours yet.
    pub const fn new(nodes: [NodeId; 4]) -> Self {
        Self {
            nodes,
            neighbours: [TetId::NONE; 4],
            reverse: [Reverse(0); 4],
        }
    }
}

impl Default for Tet {
    fn default() -> Self {
        Self::new([NodeId::NONE; 4])
    }
}

/// Bytes per tet; pinned at compile time (the bound is 36).
pub const TET_BYTES: usize = core::mem::size_of::<Tet>();
const _: () = assert!(TET_BYTES <= 36, "Tet must stay within 36 bytes");
const _: () = assert!(core::mem::size_of::<Reverse>() == 1);

/// A node's topology record: one incident tet and the node's local index in it. Its position
/// lives in the mesh's separate position array (structure of arrays: the hash and the
/// collision loops stream positions only).
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
#[repr(C)]
pub struct Node {
    /// One tet that uses this node, or [`TetId::NONE`] for an unreferenced node.
    pub tet: TetId,
    /// The node's local index (0..=3) in `tet`.
    pub local: u8,
    /// `true` when the node lies on a boundary face.
    pub boundary: bool,
}

impl Default for Node {
    fn default() -> Self {
        Self {
            tet: TetId::NONE,
            local: 0,
            boundary: false,
        }
    }
}

const _: () = assert!(core::mem::size_of::<Node>() == 8);

/// A vertex of one tet: `(tet, 0..=3)`.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default)]
pub struct VertexUse {
    /// The tet.
    pub tet: TetId,
    /// Local vertex index, 0..=3.
    pub local: u8,
}

/// An edge of one tet: `(tet, 0..=5)`, see [`super::template::EDGE_VERTS`].
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default)]
pub struct EdgeUse {
    /// The tet.
    pub tet: TetId,
    /// Local edge index, 0..=5.
    pub local: u8,
}

/// A face of one tet: `(tet, 0..=3)`, face `i` opposite vertex `i`.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default)]
pub struct FaceUse {
    /// The tet.
    pub tet: TetId,
    /// Local face index, 0..=3.
    pub local: u8,
}
