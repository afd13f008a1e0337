//! Compact tetrahedral mesh with templates and reverse indices (Praktikum report, section 2,
//! after Celes, Paulino and Espinha 2005).
//!
//! A [`Mesh`] borrows caller storage: node positions, one [`Node`] (8 bytes) and one boundary
//! normal per node, one [`Tet`] (36 bytes) per tet. Faces, edges and vertices are named by
//! entity uses (`(tet, local index)`) through the const [`template`] tables; the neighbour
//! across a face and the matching vertex in it are found in O(1) ([`Mesh::vertex_match`]).
//!
//! The tets live in RAM ([`Mesh::build`], `Mesh::from_parts`) or are read in place from a
//! mesh blob's bytes by a [`TetView`] ([`Mesh::in_place`], [`crate::blob::MeshBlob::mesh`]);
//! every accessor returns records by value, so callers never see which ([`Mesh::tet_store`]
//! says).
//! Positions, normals and node records stay in RAM either way: positions change whenever the
//! mesh moves or deforms, and [`Mesh::update_boundary`] rewrites the normals and the nodes'
//! boundary flags.
//!
//! ```
//! use tetradrill_core::builtin;
//! use tetradrill_core::prelude::*;
//!
//! // The cube [-0.5, 0.5]^3 in 12 tets around its centre (node 8).
//! let (mut pos, tets) = builtin::cube12();
//! let (mut nodes, mut normals) = ([Node::default(); 9], [Vec3::ZERO; 9]);
//! let (mut recs, mut scratch) = ([Tet::default(); 12], [FaceKey::default(); 48]);
//! let storage = MeshStorage { nodes: &mut nodes, normals: &mut normals, tets: &mut recs };
//! let mesh = Mesh::build(&mut pos, &tets, storage, &mut scratch, BuildOptions::default())?;
//! mesh.validate()?;
//!
//! // Two triangles on each cube face; the centre node is the only one inside.
//! assert_eq!((mesh.stats().boundary_faces, mesh.stats().boundary_nodes), (12, 8));
//! assert!((mesh.volume() - 1.0).abs() < 1e-6);
//! assert!(mesh.normal(NodeId(8)) == Vec3::ZERO && mesh.normal(NodeId(7)).z > 0.0);
//!
//! // Across an inner face and back again through the reverse index.
//! let t = TetId(0);
//! let f = (0..4).find(|&f| !mesh.is_boundary_face(t, f)).unwrap();
//! let back = mesh.reverse(t, f).face();
//! assert_eq!(mesh.neighbour(mesh.neighbour(t, f), back), t);
//! # Ok::<(), tetradrill_core::Error>(())
//! ```

mod build;
mod record;
pub mod template;
#[cfg(test)]
mod tests;
mod traverse;
mod validate;
mod view;

pub use build::{BuildError, BuildOptions, BuildStats, FaceKey, MeshStorage};
pub use record::{EdgeUse, FaceUse, Node, Reverse, Tet, VertexUse, TET_BYTES, TET_RECORD};
pub use traverse::{EdgeIter, Full};
pub use validate::ValidationError;
pub use view::{TetIter, TetStore, TetView, TetViewError};

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
    /// RAM records; empty when the tets are read in place.
    ram: &'a [Tet],
    /// The in-place records; empty when the tets are in RAM. Every accessor tries `ram`
    /// first: on a RAM mesh that is the bounds check slice indexing does anyway, so the RAM
    /// path pays nothing for the choice; an in-place mesh pays one failed comparison.
    view: TetView<'a>,
    /// `ram.len()` or `view.len()`, whichever holds the tets.
    tet_count: usize,
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
    #[cfg(any(test, feature = "alloc"))]
    pub(crate) fn from_parts(
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
            tet_count: tets.len(),
            ram: tets,
            view: TetView::EMPTY,
            stats,
        }
    }

    /// A mesh whose tets are read in place through `tets` (checked when the view was made);
    /// positions, normals and node records in RAM, as an earlier build left them (a blob's
    /// copies: [`crate::blob::MeshBlob::mesh`]). Nothing else is checked here: call
    /// [`Mesh::validate`] to check the node records and the orientation.
    ///
    /// `positions.len()` is the node count; `normals` and `nodes` are cut to it.
    ///
    /// # Bounded work
    /// O(1).
    ///
    /// # Errors
    /// `None` when `positions` does not hold the node count the view was checked against
    /// ([`TetView::node_count`]) or `normals` or `nodes` is shorter.
    pub fn in_place(
        positions: &'a mut [Vec3],
        normals: &'a mut [Vec3],
        nodes: &'a mut [Node],
        tets: TetView<'a>,
        stats: BuildStats,
    ) -> Option<Self> {
        let n = positions.len();
        if n != tets.node_count() || normals.len() < n || nodes.len() < n {
            return None;
        }
        let (normals, _) = normals.split_at_mut(n);
        let (nodes, _) = nodes.split_at_mut(n);
        Some(Self {
            positions,
            normals,
            nodes,
            rest: &mut [],
            ram: &[],
            tet_count: tets.len(),
            view: tets,
            stats,
        })
    }

    /// Number of nodes.
    #[inline]
    pub fn node_count(&self) -> usize {
        self.positions.len()
    }

    /// Number of tets.
    #[inline]
    pub fn tet_count(&self) -> usize {
        self.tet_count
    }

    /// Where the tets live: RAM records or an in-place view.
    #[inline]
    pub fn tet_store(&self) -> TetStore<'a> {
        if self.view.is_empty() {
            TetStore::Ram(self.ram)
        } else {
            TetStore::InPlace(self.view)
        }
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
    pub(crate) fn set_rest(&mut self, rest: &'a mut [Vec3]) -> Result<(), &'a mut [Vec3]> {
        let n = self.positions.len();
        if rest.len() < n {
            return Err(rest);
        }
        let (rest, _) = rest.split_at_mut(n);
        rest.copy_from_slice(self.positions);
        self.rest = rest;
        Ok(())
    }

    /// The rest positions: the ones kept by `Mesh::set_rest`, else the positions.
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
    pub(crate) fn has_rest(&self) -> bool {
        !self.rest.is_empty()
    }

    /// The four corner positions of a tet in the rest state ([`Mesh::rest_positions`]); zeros
    /// for a tet or node id out of range (as [`Mesh::tet_positions`]).
    #[inline]
    pub(crate) fn rest_tet_positions(&self, t: TetId) -> [Vec3; 4] {
        let rest = self.rest_positions();
        match self.tet_nodes(t).map(|n| rest.get(n.idx())) {
            [Some(&a), Some(&b), Some(&c), Some(&d)] => [a, b, c, d],
            _ => [Vec3::ZERO; 4],
        }
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

    /// Every tet in id order, by value.
    #[inline]
    pub fn tets(&self) -> TetIter<'a> {
        TetIter::new(self.tet_store())
    }

    /// One tet, by value; a record of `NONE` ids when `t` is out of range (never a panic).
    ///
    /// # Bounded work
    /// O(1).
    #[inline(always)]
    pub fn tet(&self, t: TetId) -> Tet {
        match self.ram.get(t.idx()) {
            Some(r) => *r,
            None => self.view.get(t).unwrap_or_default(),
        }
    }

    /// One tet, by value; `None` out of range.
    #[inline(always)]
    pub fn get_tet(&self, t: TetId) -> Option<Tet> {
        match self.ram.get(t.idx()) {
            Some(r) => Some(*r),
            None => self.view.get(t),
        }
    }

    /// The four node ids of `t`; `NONE` ids when `t` is out of range.
    #[inline(always)]
    pub fn tet_nodes(&self, t: TetId) -> [NodeId; 4] {
        match self.ram.get(t.idx()) {
            Some(r) => r.nodes,
            None => self.view.nodes(t).unwrap_or([NodeId::NONE; 4]),
        }
    }

    /// The four node ids of `t`; `None` out of range.
    #[inline(always)]
    pub fn get_tet_nodes(&self, t: TetId) -> Option<[NodeId; 4]> {
        match self.ram.get(t.idx()) {
            Some(r) => Some(r.nodes),
            None => self.view.nodes(t),
        }
    }

    /// The tet across face `f` of `t`, `NONE` on the boundary; `None` when `t` or `f` is
    /// out of range.
    #[inline(always)]
    pub fn get_neighbour(&self, t: TetId, f: u8) -> Option<TetId> {
        match self.ram.get(t.idx()) {
            Some(r) => r.neighbours.get(f as usize).copied(),
            None => self.view.neighbour(t, f),
        }
    }

    /// The reverse index of face `f` of `t` (`Reverse(0)` when `t` or `f` is out of range).
    #[inline(always)]
    pub fn reverse(&self, t: TetId, f: u8) -> Reverse {
        self.across(t, f).1
    }

    /// The neighbour across face `f` of `t` and the face's reverse index, from one record
    /// look-up (`(NONE, Reverse(0))` when `t` or `f` is out of range).
    #[inline(always)]
    fn across(&self, t: TetId, f: u8) -> (TetId, Reverse) {
        match self.ram.get(t.idx()) {
            Some(r) => (
                r.neighbours.get(f as usize).copied().unwrap_or(TetId::NONE),
                r.reverse.get(f as usize).copied().unwrap_or_default(),
            ),
            None => {
                let nb = self.view.neighbour(t, f).unwrap_or(TetId::NONE);
                (nb, self.view.reverse(t, f).unwrap_or_default())
            }
        }
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

    /// Swaps the node normals with `other` (the same length, one per node): a caller that
    /// computed the normals of new positions elsewhere, as [`Mesh::update_boundary`] would,
    /// takes them into use at once (the deforming world's spread update). Refused (`false`,
    /// nothing changed) for another length.
    ///
    /// # Bounded work
    /// Constant.
    pub(crate) fn swap_normals(&mut self, other: &mut &'a mut [Vec3]) -> bool {
        if other.len() != self.normals.len() {
            return false;
        }
        core::mem::swap(&mut self.normals, other);
        true
    }

    /// Counts gathered at build time, with boundary counts kept current by
    /// [`Mesh::update_boundary`].
    #[inline]
    pub fn stats(&self) -> BuildStats {
        self.stats
    }

    /// The four corner positions of a tet; all four zero when `t` or one of its node ids is
    /// out of range (a mesh [`Mesh::validate`] accepts has no such id).
    #[inline(always)]
    pub fn tet_positions(&self, t: TetId) -> [Vec3; 4] {
        match self.tet_nodes(t).map(|n| self.positions.get(n.idx())) {
            [Some(&a), Some(&b), Some(&c), Some(&d)] => [a, b, c, d],
            _ => [Vec3::ZERO; 4],
        }
    }

    /// The tet across face `f` of `t`, or `NONE` on the boundary (and when `t` or `f` is out
    /// of range).
    #[inline(always)]
    pub fn neighbour(&self, t: TetId, f: u8) -> TetId {
        match self.ram.get(t.idx()) {
            Some(r) => r.neighbours.get(f as usize).copied().unwrap_or(TetId::NONE),
            None => self.view.neighbour(t, f).unwrap_or(TetId::NONE),
        }
    }

    /// `true` when face `f` of `t` has no neighbour.
    #[inline]
    pub fn is_boundary_face(&self, t: TetId, f: u8) -> bool {
        self.neighbour(t, f).is_none()
    }

    /// The same face seen from the other side: `(neighbour, its face id)`, or `None` on the
    /// boundary. O(1).
    #[inline(always)]
    pub fn face_match(&self, face: FaceUse) -> Option<FaceUse> {
        let (nb, r) = self.across(face.tet, face.local);
        nb.is_some().then(|| FaceUse {
            tet: nb,
            local: r.face(),
        })
    }

    /// The three node ids of face `f` of `t`, clockwise seen from outside `t`.
    #[inline(always)]
    pub fn face_nodes(&self, t: TetId, f: u8) -> [NodeId; 3] {
        let nodes = self.tet_nodes(t);
        FACE_VERTS[f as usize].map(|k| nodes[k as usize])
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

    /// `getVertexMatch` of the Praktikum report's Figure 2: the use of local vertex `v` of `t` in
    /// the neighbour across face `f`. `None` when `f` is a boundary face or `v` is the vertex
    /// opposite `f`.
    ///
    /// # Bounded work
    /// O(1): two table look-ups and one modulo.
    #[inline(always)]
    pub fn vertex_match(&self, t: TetId, v: u8, f: u8) -> Option<VertexUse> {
        let (nb, r) = self.across(t, f);
        let pos = FACE_VERTEX_NR[f as usize][v as usize];
        if nb.is_none() || pos == NOT_ON_FACE {
            return None;
        }
        let in_face = (3 - pos + r.offset()) % 3;
        let local = ELEM_VERTEX_NR[r.face() as usize][in_face as usize];
        Some(VertexUse { tet: nb, local })
    }

    /// Total volume of all tets.
    ///
    /// # Bounded work
    /// O(T).
    pub fn volume(&self) -> f64 {
        (0..self.tet_count())
            .map(|t| geom::tet_volume(self.tet_positions(TetId::from_idx(t))) as f64)
            .sum()
    }

    /// Marks boundary nodes and recomputes their averaged outward normals (seed
    /// `determineBoundary()`): each boundary face adds its area-weighted outward normal to its
    /// three nodes; the sums are normalised. Call after moving nodes. A node id out of range
    /// (none in a mesh [`Mesh::validate`] accepts) counts as the origin and is not marked.
    /// The sums and the normalisation are `Mesh::add_boundary_normals` for every tet and
    /// `Mesh::finish_boundary_normal` for every node, the pieces a caller that builds the
    /// normals of new positions elsewhere runs too.
    ///
    /// # Bounded work
    /// O(T + N).
    pub fn update_boundary(&mut self) {
        // Out of the mesh while its pieces fill them; back below.
        let nodes = core::mem::take(&mut self.nodes);
        let normals = core::mem::take(&mut self.normals);
        for node in nodes.iter_mut() {
            node.set_boundary(false);
        }
        normals.fill(Vec3::ZERO);
        let mut faces = 0u32;
        for ti in 0..self.tet_count() {
            faces += self.sum_boundary_faces(TetId::from_idx(ti), self.positions, normals, |n| {
                if let Some(node) = nodes.get_mut(n.idx()) {
                    node.set_boundary(true);
                }
            });
        }
        self.nodes = nodes;
        let mut bnodes = 0u32;
        for i in 0..normals.len() {
            bnodes += u32::from(self.finish_boundary_normal(NodeId::from_idx(i), normals));
        }
        self.normals = normals;
        self.stats.boundary_faces = faces;
        self.stats.boundary_nodes = bnodes;
    }

    /// One tet's part of [`Mesh::update_boundary`]'s sums: adds the outward normal of each
    /// boundary face of `t` (twice its area, at `positions`) to the entries of `normals` of its
    /// three nodes, and returns how many faces of `t` are on the boundary. A node id or
    /// position out of range counts as the origin and adds nowhere.
    ///
    /// # Bounded work
    /// Constant.
    #[inline]
    pub(crate) fn add_boundary_normals(
        &self,
        t: TetId,
        positions: &[Vec3],
        normals: &mut [Vec3],
    ) -> u32 {
        self.sum_boundary_faces(t, positions, normals, |_| {})
    }

    /// [`Mesh::add_boundary_normals`], with `mark` called on each node of each boundary face.
    #[inline(always)]
    fn sum_boundary_faces(
        &self,
        t: TetId,
        positions: &[Vec3],
        normals: &mut [Vec3],
        mut mark: impl FnMut(NodeId),
    ) -> u32 {
        let mut faces = 0u32;
        for f in 0..4u8 {
            if self.neighbour(t, f).is_some() {
                continue;
            }
            faces += 1;
            let ids = self.face_nodes(t, f);
            let [a, b, c] = ids.map(|n| positions.get(n.idx()).copied().unwrap_or_default());
            // Inward right-hand normal, twice the area: negate for outward.
            let w = -(b - a).cross(c - a);
            for n in ids {
                mark(n);
                if let Some(normal) = normals.get_mut(n.idx()) {
                    *normal += w;
                }
            }
        }
        faces
    }

    /// One node's part of [`Mesh::update_boundary`]'s normalisation: normalises node `n`'s
    /// entry of `normals` (the sum of [`Mesh::add_boundary_normals`]) when `n` is a boundary
    /// node (zero stays zero), and returns whether it is. Nothing for an id out of range.
    ///
    /// # Bounded work
    /// Constant.
    #[inline]
    pub(crate) fn finish_boundary_normal(&self, n: NodeId, normals: &mut [Vec3]) -> bool {
        let boundary = self.nodes.get(n.idx()).is_some_and(|node| node.boundary());
        if boundary {
            if let Some(normal) = normals.get_mut(n.idx()) {
                *normal = normal.normalize_or_zero();
            }
        }
        boundary
    }
}
