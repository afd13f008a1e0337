//! Compact tetrahedral mesh with templates and reverse indices (seed 000 section 2, after
//! Celes, Paulino and Espinha 2005).
//!
//! A [`Mesh`] borrows caller storage: node positions, one [`Node`] (8 bytes) and one boundary
//! normal per node, one [`Tet`] (36 bytes) per tet. Faces, edges and vertices are named by
//! entity uses (`(tet, local index)`) through the const [`template`] tables; the neighbour
//! across a face and the matching vertex in it are found in O(1) ([`Mesh::vertex_match`]).

mod build;
mod record;
pub mod template;
mod traverse;
mod validate;

pub use build::{refinement_relabel, BuildError, BuildOptions, BuildStats, FaceKey, MeshStorage};
pub use record::{EdgeUse, FaceUse, Node, Reverse, Tet, VertexUse, TET_BYTES};
pub use traverse::{EdgeIter, Full};
pub use validate::ValidationError;

use glam::Vec3;

use crate::geom;
use crate::ids::{NodeId, TetId};
use template::{ELEM_VERTEX_NR, FACE_VERTEX_NR, FACE_VERTS, NOT_ON_FACE};

/// A tetrahedral mesh over caller storage. Built by [`Mesh::build`].
#[derive(Debug)]
pub struct Mesh<'a> {
    positions: &'a mut [Vec3],
    /// Rest positions of a deforming mesh (empty: the positions are the rest state).
    rest: &'a mut [Vec3],
    normals: &'a mut [Vec3],
    nodes: &'a mut [Node],
    tets: &'a mut [Tet],
    stats: BuildStats,
}

impl<'a> Mesh<'a> {
    /// Reassembles a mesh from storage that an earlier [`Mesh::build`] filled (a host keeps
    /// its buffers and takes a view again; nothing is checked here: call
    /// [`Mesh::validate`] if the storage may have been changed).
    ///
    /// `positions.len()` is the node count; `normals` and `nodes` are cut to it.
    ///
    /// # Bounded work
    /// O(1).
    pub fn from_parts(
        positions: &'a mut [Vec3],
        storage: MeshStorage<'a>,
        tet_count: usize,
        stats: BuildStats,
    ) -> Self {
        let n = positions.len();
        let MeshStorage {
            nodes,
            normals,
            tets,
        } = storage;
        let n = n.min(nodes.len()).min(normals.len());
        let t = tet_count.min(tets.len());
        let (positions, _) = positions.split_at_mut(n);
        let (nodes, _) = nodes.split_at_mut(n);
        let (normals, _) = normals.split_at_mut(n);
        let (tets, _) = tets.split_at_mut(t);
        Self {
            positions,
            rest: &mut [],
            normals,
            nodes,
            tets,
            stats,
        }
    }

    /// Number of nodes.
    #[inline]
    pub fn node_count(&self) -> usize {
        self.positions.len()
    }

    /// Number of tets.
    #[inline]
    pub fn tet_count(&self) -> usize {
        self.tets.len()
    }

    /// All node positions.
    #[inline]
    pub fn positions(&self) -> &[Vec3] {
        self.positions
    }

    /// Node positions for moving or deforming the mesh. Call [`Mesh::update_boundary`]
    /// afterwards if the boundary normals are used.
    #[inline]
    pub fn positions_mut(&mut self) -> &mut [Vec3] {
        self.positions
    }

    /// Keeps the current positions as the rest state in `rest` (at least one entry per node):
    /// volumes ([`Mesh::rest_tet_positions`], the hierarchy's leaf volumes) are then measured
    /// there whatever [`Mesh::positions_mut`] does afterwards. Without it the positions are
    /// their own rest state.
    ///
    /// # Bounded work
    /// O(N).
    ///
    /// # Errors
    /// `rest` back, unchanged, when it is shorter than the node count.
    pub fn set_rest(&mut self, rest: &'a mut [Vec3]) -> Result<(), &'a mut [Vec3]> {
        let n = self.positions.len();
        if rest.len() < n {
            return Err(rest);
        }
        let (rest, _) = rest.split_at_mut(n);
        rest.copy_from_slice(self.positions);
        self.rest = rest;
        Ok(())
    }

    /// The rest positions: the ones kept by [`Mesh::set_rest`], else the positions.
    #[inline]
    pub fn rest_positions(&self) -> &[Vec3] {
        if self.rest.is_empty() {
            self.positions
        } else {
            self.rest
        }
    }

    /// `true` when [`Mesh::set_rest`] kept a rest state apart from the positions.
    #[inline]
    pub fn has_rest(&self) -> bool {
        !self.rest.is_empty()
    }

    /// The four corner positions of a tet in the rest state ([`Mesh::rest_positions`]).
    #[inline]
    pub fn rest_tet_positions(&self, t: TetId) -> [Vec3; 4] {
        let rest = self.rest_positions();
        self.tets[t.idx()].nodes.map(|n| rest[n.idx()])
    }

    /// Position of one node.
    #[inline]
    pub fn position(&self, n: NodeId) -> Vec3 {
        self.positions[n.idx()]
    }

    /// All node records.
    #[inline]
    pub fn nodes(&self) -> &[Node] {
        self.nodes
    }

    /// One node record.
    #[inline]
    pub fn node(&self, n: NodeId) -> Node {
        self.nodes[n.idx()]
    }

    /// All tets.
    #[inline]
    pub fn tets(&self) -> &[Tet] {
        self.tets
    }

    /// One tet.
    #[inline]
    pub fn tet(&self, t: TetId) -> &Tet {
        &self.tets[t.idx()]
    }

    /// Averaged outward unit normal of a boundary node (zero for inner nodes).
    #[inline]
    pub fn normal(&self, n: NodeId) -> Vec3 {
        self.normals[n.idx()]
    }

    /// All node normals.
    #[inline]
    pub fn normals(&self) -> &[Vec3] {
        self.normals
    }

    /// Counts gathered at build time, with boundary counts kept current by
    /// [`Mesh::update_boundary`].
    #[inline]
    pub fn stats(&self) -> BuildStats {
        self.stats
    }

    /// The four corner positions of a tet.
    #[inline]
    pub fn tet_positions(&self, t: TetId) -> [Vec3; 4] {
        self.tets[t.idx()].nodes.map(|n| self.positions[n.idx()])
    }

    /// The tet across face `f` of `t`, or `NONE` on the boundary.
    #[inline]
    pub fn neighbour(&self, t: TetId, f: u8) -> TetId {
        self.tets[t.idx()].neighbours[f as usize]
    }

    /// `true` when face `f` of `t` has no neighbour.
    #[inline]
    pub fn is_boundary_face(&self, t: TetId, f: u8) -> bool {
        self.neighbour(t, f).is_none()
    }

    /// The same face seen from the other side: `(neighbour, its face id)`, or `None` on the
    /// boundary. O(1).
    #[inline]
    pub fn face_match(&self, face: FaceUse) -> Option<FaceUse> {
        let tet = &self.tets[face.tet.idx()];
        let nb = tet.neighbours[face.local as usize];
        nb.is_some().then(|| FaceUse {
            tet: nb,
            local: tet.reverse[face.local as usize].face(),
        })
    }

    /// The three node ids of face `f` of `t`, clockwise seen from outside `t`.
    #[inline]
    pub fn face_nodes(&self, t: TetId, f: u8) -> [NodeId; 3] {
        let tet = &self.tets[t.idx()];
        FACE_VERTS[f as usize].map(|k| tet.nodes[k as usize])
    }

    /// The three corner positions of face `f` of `t`, clockwise seen from outside `t`.
    #[inline]
    pub fn face_positions(&self, t: TetId, f: u8) -> [Vec3; 3] {
        self.face_nodes(t, f).map(|n| self.positions[n.idx()])
    }

    /// Unit normal of face `f` of `t` pointing out of `t`.
    #[inline]
    pub fn face_normal(&self, t: TetId, f: u8) -> Vec3 {
        let [a, b, c] = self.face_positions(t, f);
        // Listings are clockwise from outside, so the right-hand normal points inward.
        -geom::tri_normal(a, b, c)
    }

    /// `getVertexMatch` of seed 000 Figure 2: the use of local vertex `v` of `t` in the
    /// neighbour across face `f`. `None` when `f` is a boundary face or `v` is the vertex
    /// opposite `f`.
    ///
    /// # Bounded work
    /// O(1): two table look-ups and one modulo.
    #[inline]
    pub fn vertex_match(&self, t: TetId, v: u8, f: u8) -> Option<VertexUse> {
        let tet = &self.tets[t.idx()];
        let nb = tet.neighbours[f as usize];
        let pos = FACE_VERTEX_NR[f as usize][v as usize];
        if nb.is_none() || pos == NOT_ON_FACE {
            return None;
        }
        let r = tet.reverse[f as usize];
        let in_face = (3 - pos + r.offset()) % 3;
        let local = ELEM_VERTEX_NR[r.face() as usize][in_face as usize];
        Some(VertexUse { tet: nb, local })
    }

    /// Total volume of all tets.
    ///
    /// # Bounded work
    /// O(T).
    pub fn volume(&self) -> f64 {
        (0..self.tets.len())
            .map(|t| geom::tet_volume(self.tet_positions(TetId::from_idx(t))) as f64)
            .sum()
    }

    /// Marks boundary nodes and recomputes their averaged outward normals (seed
    /// `determineBoundary()`): each boundary face adds its area-weighted outward normal to its
    /// three nodes; the sums are normalised. Call after moving nodes.
    ///
    /// # Bounded work
    /// O(T + N).
    pub fn update_boundary(&mut self) {
        for (node, normal) in self.nodes.iter_mut().zip(self.normals.iter_mut()) {
            node.boundary = false;
            *normal = Vec3::ZERO;
        }
        let mut faces = 0u32;
        for ti in 0..self.tets.len() {
            let t = TetId::from_idx(ti);
            for f in 0..4u8 {
                if self.neighbour(t, f).is_some() {
                    continue;
                }
                faces += 1;
                let ids = self.face_nodes(t, f);
                let [a, b, c] = ids.map(|n| self.positions[n.idx()]);
                // Inward right-hand normal, twice the area: negate for outward.
                let w = -(b - a).cross(c - a);
                for n in ids {
                    self.nodes[n.idx()].boundary = true;
                    self.normals[n.idx()] += w;
                }
            }
        }
        let mut bnodes = 0u32;
        for (node, normal) in self.nodes.iter().zip(self.normals.iter_mut()) {
            if node.boundary {
                bnodes += 1;
                *normal = normal.normalize_or_zero();
            }
        }
        self.stats.boundary_faces = faces;
        self.stats.boundary_nodes = bnodes;
    }
}
