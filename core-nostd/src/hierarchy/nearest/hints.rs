//! The hints of the contact search: the closest faces a search keeps for the next one
//! ([`Kept`]), and a face named by its key ([`FaceRef`]) looked up again: still visible, and
//! measured from a new centre.

use glam::Vec3;

use super::{cut_skips, FaceRef};
use crate::geom::closest_point_on_triangle;
use crate::hierarchy::geometry::node_positions;
use crate::hierarchy::node::HNode;
use crate::hierarchy::store::Hierarchy;
use crate::hierarchy::surface::{face_corners, VisibleTri};
use crate::hierarchy::table::Path;
use crate::mesh::Mesh;

/// How many of the closest faces a search keeps for the next one ([`Kept`]).
///
/// Why more than the answer: a search stopped by its node bound answers with the closest face
/// it met or was hinted, and the next step's closest face is most often one that was nearly
/// as close a step before (a neighbour of the answer on the same wall, or the near wall of a
/// cavity the burr is crossing). On the demo replay with the contact bound at 1,024 nodes,
/// hinting the 4 closest faces met instead of the answer alone cut the contact depth's
/// shortfall against the exhaustive search from 2.5e-4 to 5.4e-5 mesh units on average and
/// the ticks short by more than 1e-3 from 115 to 32 (2, 8, 16, 64 faces: 85, 28, 36, 35
/// ticks; docs/DRILLING.md). Each hint costs a node look-up per level and a triangle test
/// a search (4 of them: 0.2 % of the firmware's worst tick).
pub const KEEP: usize = 4;

/// The closest faces a search met or was hinted, with their squared distances from its
/// centre, nearest first (ties: the smaller face), each face once.
pub type Kept = heapless::Vec<(f32, VisibleTri), KEEP>;

/// Puts face `tri` at squared distance `d2` into `kept` when it is among the [`KEEP`] nearest
/// by `(d2, face)`; a face already there stays as it is.
///
/// # Bounded work
/// O([`KEEP`]).
pub(crate) fn keep_face(kept: &mut Kept, d2: f32, tri: VisibleTri) {
    let key = tri.key();
    let before = |&(d, t): &(f32, VisibleTri)| d2 < d || (d2 == d && key < t.key());
    if kept.is_full() && kept.last().is_some_and(|e| !before(e)) {
        return;
    }
    if kept.iter().any(|(_, t)| t.key() == key) {
        return;
    }
    let at = kept.iter().position(before).unwrap_or(kept.len());
    if at >= KEEP {
        return;
    }
    if kept.is_full() {
        kept.pop();
    }
    let _ = kept.insert(at, (d2, tri));
}

/// [`keep_face`] for every face of `from`.
pub(super) fn keep_all(kept: &mut Kept, from: &Kept) {
    for &(d2, t) in from {
        keep_face(kept, d2, t);
    }
}

impl Hierarchy<'_> {
    /// The squared distance from `centre` to visible face `key`, and the face, when that face
    /// is still visible on a non-erased leaf.
    ///
    /// # Bounded work
    /// O(depth).
    pub(crate) fn visible_face_distance2(
        &self,
        mesh: &Mesh<'_>,
        key: FaceRef,
        centre: Vec3,
    ) -> Option<(f32, VisibleTri)> {
        let vt = self.visible_face(mesh, key)?;
        let x = closest_point_on_triangle(centre, vt.corners);
        Some(((centre - x).length_squared(), vt))
    }

    /// Visible face `key` with its corners, when that face is still visible on a non-erased
    /// leaf.
    ///
    /// # Bounded work
    /// O(depth).
    pub(crate) fn visible_face(&self, mesh: &Mesh<'_>, key: FaceRef) -> Option<VisibleTri> {
        let node = self.visible_leaf(key)?;
        let path = Path::of_index(key.index)?;
        let p = node_positions(mesh, key.tet, &path);
        Some(VisibleTri {
            tet: key.tet,
            index: key.index,
            face: key.face,
            corners: face_corners(p, key.face, node.inverted()),
        })
    }

    /// `true` when face `key` is still visible: its node is a non-erased leaf with that face
    /// visible.
    ///
    /// # Bounded work
    /// O(depth) node look-ups.
    pub(crate) fn face_visible(&self, key: FaceRef) -> bool {
        self.visible_leaf(key).is_some()
    }

    /// The leaf of face `key` when it is not erased and has that face visible.
    fn visible_leaf(&self, key: FaceRef) -> Option<HNode> {
        let node = self.node(self.find(key.tet, key.index)?)?;
        (node.is_leaf() && !node.erased() && node.visible() & (1 << (key.face & 3)) != 0)
            .then_some(node)
    }

    /// Hint `tri` measured from `centre` when a search with squared reach `reach2` and squared
    /// cutting radius `cut2` (negative: not cutting) would consider it: still a visible face,
    /// within reach, not skipped by the cutting rule. Its squared distance.
    ///
    /// # Bounded work
    /// O(depth) node look-ups and one triangle test (the corners come with the hint).
    pub(super) fn hint_in_play(
        &self,
        tri: &VisibleTri,
        centre: Vec3,
        reach2: f32,
        cut2: f32,
    ) -> Option<f32> {
        if !self.face_visible(tri.key()) {
            return None;
        }
        let x = closest_point_on_triangle(centre, tri.corners);
        let d2 = (centre - x).length_squared();
        (d2 <= reach2 && !cut_skips(&tri.corners, centre, x, cut2)).then_some(d2)
    }
}
