//! `validate()`: the mesh invariants every operation must keep. Used after building, after
//! every step of randomised tests, and by `tetradrill info`.

use super::template::FACE_VERTS;
use super::Mesh;
use crate::geom::det6_f64;
use crate::ids::{NodeId, TetId};

/// The first broken invariant [`Mesh::validate`] found.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
#[non_exhaustive]
pub enum ValidationError {
    /// A tet names a node that does not exist.
    NodeOutOfRange(TetId),
    /// A tet names the same node twice.
    RepeatedNode(TetId),
    /// A tet is not positively oriented.
    NotPositive(TetId),
    /// A neighbour id is out of range.
    NeighbourOutOfRange(TetId, u8),
    /// The neighbour across a face does not point back through the reverse index.
    ReverseMismatch(TetId, u8),
    /// The shared face's vertices do not match as the ring offset says.
    VertexMismatch(TetId, u8),
    /// A node's incident tet does not hold it at its local index.
    NodeRecord(NodeId),
    /// Boundary counts are stale.
    BoundaryCount,
}

impl core::fmt::Display for ValidationError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match *self {
            Self::NodeOutOfRange(t) => write!(f, "tet {} names a missing node", t.0),
            Self::RepeatedNode(t) => write!(f, "tet {} names a node twice", t.0),
            Self::NotPositive(t) => write!(f, "tet {} is not positively oriented", t.0),
            Self::NeighbourOutOfRange(t, i) => write!(f, "tet {} face {i}: no such neighbour", t.0),
            Self::ReverseMismatch(t, i) => {
                write!(f, "tet {} face {i}: neighbour does not point back", t.0)
            }
            Self::VertexMismatch(t, i) => {
                write!(f, "tet {} face {i}: shared vertices do not match", t.0)
            }
            Self::NodeRecord(n) => write!(f, "node {}: incident tet does not hold it", n.0),
            Self::BoundaryCount => write!(f, "boundary counts are stale"),
        }
    }
}

impl core::error::Error for ValidationError {}

impl Mesh<'_> {
    /// Checks every invariant: node ids in range and distinct per tet, positive volumes,
    /// neighbours pointing back through the reverse index, shared faces matching vertex by
    /// vertex through [`Mesh::vertex_match`], node records, boundary counts.
    ///
    /// # Bounded work
    /// O(T + N).
    pub fn validate(&self) -> Result<(), ValidationError> {
        let n = self.node_count();
        let mut boundary_faces = 0u32;
        for ti in 0..self.tet_count() {
            let t = TetId::from_idx(ti);
            let tet = self.tet(t);
            for (i, a) in tet.nodes.iter().enumerate() {
                if a.idx() >= n {
                    return Err(ValidationError::NodeOutOfRange(t));
                }
                if tet.nodes[i + 1..].contains(a) {
                    return Err(ValidationError::RepeatedNode(t));
                }
            }
            let p = self.tet_positions(t);
            let positive = det6_f64(p[0], p[1], p[2], p[3]) > 0.0;
            if !positive {
                return Err(ValidationError::NotPositive(t));
            }
            for f in 0..4u8 {
                let nb = tet.neighbours[f as usize];
                if nb.is_none() {
                    boundary_faces += 1;
                    continue;
                }
                if nb.idx() >= self.tet_count() || nb == t {
                    return Err(ValidationError::NeighbourOutOfRange(t, f));
                }
                let g = tet.reverse[f as usize].face();
                let other = self.tet(nb);
                if other.neighbours[g as usize] != t
                    || other.reverse[g as usize].face() != f
                    || other.reverse[g as usize].offset() != tet.reverse[f as usize].offset()
                    || tet.reverse[f as usize].offset() > 2
                {
                    return Err(ValidationError::ReverseMismatch(t, f));
                }
                for v in FACE_VERTS[f as usize] {
                    match self.vertex_match(t, v, f) {
                        Some(vu) if other.nodes[vu.local as usize] == tet.nodes[v as usize] => {}
                        _ => return Err(ValidationError::VertexMismatch(t, f)),
                    }
                }
            }
        }
        for (i, node) in self.nodes().iter().enumerate() {
            let id = NodeId::from_idx(i);
            if node.tet.is_none() {
                continue;
            }
            if node.tet.idx() >= self.tet_count()
                || node.local > 3
                || self.tet(node.tet).nodes[node.local as usize] != id
            {
                return Err(ValidationError::NodeRecord(id));
            }
        }
        if boundary_faces != self.stats().boundary_faces {
            return Err(ValidationError::BoundaryCount);
        }
        Ok(())
    }
}
