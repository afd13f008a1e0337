//! The compact records: [`Tet`] (36 bytes), [`Node`] (8 bytes), the packed reverse index and the
//! entity uses that name a vertex, edge or face of one tet.

use crate::ids::{NodeId, TetId};

/// Per-face reverse index in one byte (Celes et al. 2005): bits 0-1 hold the neighbour's face
/// id that matches this face, bits 2-3 the ring offset (0..=2) between the two listings of the
/// shared face. Meaningless for a boundary face (neighbour `NONE`).
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
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
    pub(crate) const fn offset(self) -> u8 {
        (self.0 >> 2) & 3
    }
}

/// A tetrahedron: four node ids, four neighbours ordered by face (face `i` opposite vertex
/// `i`), and one reverse-index byte per face.
#[derive(Clone, Copy, PartialEq, Eq, Debug, bytemuck::Pod, bytemuck::Zeroable)]
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

impl Tet {
    /// The record as the mesh blob stores it ([`crate::blob`]): the four node ids, the four
    /// neighbour ids (`u32::MAX` for [`TetId::NONE`]), each a little-endian `u32`, then the
    /// four reverse-index bytes.
    ///
    /// # Bounded work
    /// O(1).
    pub fn to_le_bytes(&self) -> [u8; TET_RECORD] {
        let mut out = [0u8; TET_RECORD];
        for k in 0..4 {
            out[4 * k..4 * k + 4].copy_from_slice(&self.nodes[k].0.to_le_bytes());
            out[16 + 4 * k..20 + 4 * k].copy_from_slice(&self.neighbours[k].0.to_le_bytes());
            out[32 + k] = self.reverse[k].0;
        }
        out
    }

    /// The record [`Tet::to_le_bytes`] wrote (no field is checked here; a
    /// [`super::TetView`] checks its records once when it is made).
    ///
    /// # Bounded work
    /// O(1).
    #[inline]
    pub fn from_le_bytes(rec: &[u8; TET_RECORD]) -> Self {
        Self {
            nodes: [0, 1, 2, 3].map(|k| NodeId(le32(rec, 4 * k))),
            neighbours: [4, 5, 6, 7].map(|k| TetId(le32(rec, 4 * k))),
            reverse: [32, 33, 34, 35].map(|k| Reverse(rec[k])),
        }
    }
}

/// The little-endian `u32` at byte `at` of a tet record (0 past its end; callers pass
/// constant or masked offsets that are inside).
#[inline(always)]
pub(crate) fn le32(rec: &[u8; TET_RECORD], at: usize) -> u32 {
    match rec.get(at..at + 4) {
        Some(&[a, b, c, d]) => u32::from_le_bytes([a, b, c, d]),
        _ => 0,
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
/// Bytes of one tet record in its little-endian encoding ([`Tet::to_le_bytes`]).
pub const TET_RECORD: usize = 36;
const _: () = assert!(TET_BYTES == TET_RECORD);
const _: () = assert!(core::mem::size_of::<Reverse>() == 1);

/// A node's topology record: one incident tet and the node's local index in it, and whether
/// it lies on the boundary. Its position lives in the mesh's separate position array
/// (structure of arrays: the hash and the collision loops stream positions only). Eight bytes
/// with no padding (the flag is a byte, two explicit zero bytes follow), so a block of bytes
/// can hold nodes ([`super::MeshStorage::carve`]).
#[derive(Clone, Copy, PartialEq, Eq, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C)]
pub struct Node {
    /// One tet that uses this node, or [`TetId::NONE`] for an unreferenced node.
    pub tet: TetId,
    /// The node's local index (0..=3) in `tet`.
    pub local: u8,
    /// Bit 0: the node lies on a boundary face ([`Node::boundary`]); the others zero.
    flags: u8,
    /// Zero.
    pad: [u8; 2],
}

impl Node {
    /// A record: incident tet `tet`, local index `local`, on the boundary or not.
    #[inline]
    pub const fn new(tet: TetId, local: u8, boundary: bool) -> Self {
        Self {
            tet,
            local,
            flags: boundary as u8,
            pad: [0; 2],
        }
    }

    /// `true` when the node lies on a boundary face.
    #[inline]
    pub const fn boundary(&self) -> bool {
        self.flags & 1 != 0
    }

    /// Marks the node on the boundary or not.
    #[inline]
    pub fn set_boundary(&mut self, on: bool) {
        self.flags = (self.flags & !1) | on as u8;
    }
}

impl Default for Node {
    fn default() -> Self {
        Self::new(TetId::NONE, 0, false)
    }
}

impl core::fmt::Debug for Node {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("Node")
            .field("tet", &self.tet)
            .field("local", &self.local)
            .field("boundary", &self.boundary())
            .finish()
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
