//! Bounded traversals over the compact mesh, writing into caller scratch (Praktikum report,
//! section 2.2): the tets, vertex uses, faces and edges around a vertex, and every edge exactly once.
//!
//! Each vertex traversal is a breadth-first walk from the node's one incident tet through the
//! three faces that contain the vertex, using [`Mesh::vertex_match`] to step across a face.
//! The output slice doubles as the visited set (a linear scan: vertex valences are small, and a
//! scan of a slice has no hidden cost), so the work is O(k^2) for k entries written, k at most
//! the slice length.

use super::record::{EdgeUse, FaceUse, VertexUse};
use super::template::{EDGE_FACES, EDGE_OF_VERTS, EDGE_VERTS, VERTEX_EDGES, VERTEX_FACES};
use super::Mesh;
use crate::ids::{NodeId, TetId};

/// A traversal's output slice filled up before the traversal ended. The slice holds valid
/// entries up to its length; the ones not reached are missing.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct Full;

impl core::fmt::Display for Full {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str("traversal scratch is full")
    }
}

/// Something a vertex walk can record: it must name the tet it stands for.
trait WalkEntry: Copy {
    fn of(vu: VertexUse) -> Self;
    fn tet(self) -> TetId;
}

impl WalkEntry for VertexUse {
    fn of(vu: VertexUse) -> Self {
        vu
    }
    fn tet(self) -> TetId {
        self.tet
    }
}

impl WalkEntry for TetId {
    fn of(vu: VertexUse) -> Self {
        vu.tet
    }
    fn tet(self) -> TetId {
        self
    }
}

impl Mesh<'_> {
    /// Local index of node `n` in tet `t`, if `t` uses it. O(1): four comparisons.
    #[inline]
    pub fn local_of(&self, t: TetId, n: NodeId) -> Option<u8> {
        self.tet_nodes(t)
            .iter()
            .position(|&m| m == n)
            .map(|i| i as u8)
    }

    fn walk<E: WalkEntry>(&self, n: NodeId, out: &mut [E]) -> Result<usize, Full> {
        let node = self.node(n);
        if node.tet.is_none() {
            return Ok(0);
        }
        let Some(first) = out.first_mut() else {
            return Err(Full);
        };
        *first = E::of(VertexUse {
            tet: node.tet,
            local: node.local,
        });
        let mut count = 1;
        let mut head = 0;
        while head < count {
            let t = out[head].tet();
            head += 1;
            let Some(local) = self.local_of(t, n) else {
                continue;
            };
            for f in VERTEX_FACES[local as usize] {
                let Some(vu) = self.vertex_match(t, local, f) else {
                    continue;
                };
                if out[..count].iter().any(|e| e.tet() == vu.tet) {
                    continue;
                }
                if count == out.len() {
                    return Err(Full);
                }
                out[count] = E::of(vu);
                count += 1;
            }
        }
        Ok(count)
    }

    /// Every use of node `n`: one `(tet, local)` per tet around it.
    ///
    /// # Bounded work
    /// O(k^2) for k = uses written, k <= `out.len()`.
    ///
    /// # Errors
    /// [`Full`] when `out` fills before the walk ends (`out` then holds `out.len()` uses).
    pub fn vertex_uses(&self, n: NodeId, out: &mut [VertexUse]) -> Result<usize, Full> {
        self.walk(n, out)
    }

    /// The tets around node `n`.
    ///
    /// # Bounded work
    /// O(k^2) for k = tets written, k <= `out.len()`.
    ///
    /// # Errors
    /// [`Full`] when `out` fills before the walk ends.
    pub fn tets_around_vertex(&self, n: NodeId, out: &mut [TetId]) -> Result<usize, Full> {
        self.walk(n, out)
    }

    /// The faces that contain node `n`, each once (an inner face is reported by the tet with
    /// the smaller id). `scratch` receives the tets around `n`.
    ///
    /// # Bounded work
    /// O(k^2) for k tets around `n`, k <= `scratch.len()`, plus 3k for the faces.
    ///
    /// # Errors
    /// [`Full`] when `scratch` or `out` fills.
    pub fn faces_around_vertex(
        &self,
        n: NodeId,
        scratch: &mut [TetId],
        out: &mut [FaceUse],
    ) -> Result<usize, Full> {
        let k = self.walk(n, scratch)?;
        let mut count = 0;
        for &t in &scratch[..k] {
            let Some(local) = self.local_of(t, n) else {
                continue;
            };
            for f in VERTEX_FACES[local as usize] {
                let nb = self.neighbour(t, f);
                if nb.is_some() && nb < t {
                    continue;
                }
                if count == out.len() {
                    return Err(Full);
                }
                out[count] = FaceUse { tet: t, local: f };
                count += 1;
            }
        }
        Ok(count)
    }

    /// The edges at node `n`, each once (one use per distinct other end). `scratch` receives
    /// the tets around `n`.
    ///
    /// # Bounded work
    /// O(k^2) for k tets around `n` plus O(3k * e) for e edges written.
    ///
    /// # Errors
    /// [`Full`] when `scratch` or `out` fills.
    pub fn edges_at_vertex(
        &self,
        n: NodeId,
        scratch: &mut [TetId],
        out: &mut [EdgeUse],
    ) -> Result<usize, Full> {
        let k = self.walk(n, scratch)?;
        let mut count = 0;
        for &t in &scratch[..k] {
            let Some(local) = self.local_of(t, n) else {
                continue;
            };
            for e in VERTEX_EDGES[local as usize] {
                let other = self.edge_other(t, e, local);
                if out[..count]
                    .iter()
                    .any(|&u| self.edge_nodes(u).contains(&other))
                {
                    continue;
                }
                if count == out.len() {
                    return Err(Full);
                }
                out[count] = EdgeUse { tet: t, local: e };
                count += 1;
            }
        }
        Ok(count)
    }

    /// The two node ids of an edge use.
    #[inline]
    pub fn edge_nodes(&self, e: EdgeUse) -> [NodeId; 2] {
        let nodes = self.tet_nodes(e.tet);
        EDGE_VERTS[e.local as usize].map(|k| nodes[k as usize])
    }

    /// The node at the other end of edge `e` of `t` from local vertex `local`.
    #[inline]
    fn edge_other(&self, t: TetId, e: u8, local: u8) -> NodeId {
        let [a, b] = EDGE_VERTS[e as usize];
        let other = if a == local { b } else { a };
        self.tet_nodes(t)[other as usize]
    }

    /// Walks around the edge `e` of `t` and returns the smallest tet id that uses it.
    ///
    /// # Bounded work
    /// O(valence of the edge), at most T steps even on a corrupt mesh.
    pub(crate) fn edge_min_tet(&self, e: EdgeUse) -> TetId {
        let mut best = e.tet;
        let [a, b] = EDGE_VERTS[e.local as usize];
        for start_face in EDGE_FACES[e.local as usize] {
            let (mut t, mut la, mut lb, mut f) = (e.tet, a, b, start_face);
            for _ in 0..self.tet_count() {
                let (Some(ua), Some(ub)) =
                    (self.vertex_match(t, la, f), self.vertex_match(t, lb, f))
                else {
                    break; // boundary: walk the other way round
                };
                let entered = self.reverse(t, f).face();
                t = ua.tet;
                if t == e.tet {
                    return best; // closed ring: both directions see the same tets
                }
                best = best.min(t);
                (la, lb) = (ua.local, ub.local);
                let edge = EDGE_OF_VERTS[la as usize][lb as usize];
                let [f1, f2] = EDGE_FACES[edge as usize];
                f = if f1 == entered { f2 } else { f1 };
            }
        }
        best
    }

    /// Every edge of the mesh exactly once (reported by the smallest tet that uses it).
    ///
    /// # Bounded work
    /// O(T * 6 * v) for T tets and v the largest edge valence.
    pub fn edges(&self) -> EdgeIter<'_, '_> {
        EdgeIter {
            mesh: self,
            next: 0,
        }
    }
}

/// Iterator over every edge once; see [`Mesh::edges`].
#[derive(Debug)]
pub struct EdgeIter<'m, 'a> {
    mesh: &'m Mesh<'a>,
    next: usize,
}

impl Iterator for EdgeIter<'_, '_> {
    type Item = EdgeUse;

    fn next(&mut self) -> Option<EdgeUse> {
        while self.next < self.mesh.tet_count() * 6 {
            let e = EdgeUse {
                tet: TetId::from_idx(self.next / 6),
                local: (self.next % 6) as u8,
            };
            self.next += 1;
            if self.mesh.edge_min_tet(e) == e.tet {
                return Some(e);
            }
        }
        None
    }
}
