//! The keys of a surface exporter's faces: where a face comes in its tree's listing
//! ([`walk_key`]) and its corners' subdivision-lattice keys ([`face_keys`]).

use glam::Vec3;

use super::geometry::RootFrame;
use super::smooth::VertexKey;
use super::table::{Path, MAX_DEPTH};
use crate::ids::TetId;
use crate::mesh::template::FACE_VERTS;
use crate::mesh::Mesh;

/// The lattice keys of the corners of face `face` of the node of tree index `index` in the
/// tree of `t`, in the order of `corners` (the listing's), and whether the face is drilled:
/// it lies on no boundary face of the coarse mesh.
pub(super) fn face_keys(
    mesh: &Mesh<'_>,
    t: TetId,
    index: u32,
    face: u8,
    corners: &[Vec3; 3],
) -> ([VertexKey; 3], bool) {
    let (Some(path), Some(ids), Some(frame)) = (
        Path::of_index(index),
        mesh.get_tet_nodes(t),
        RootFrame::of(mesh, t),
    ) else {
        return ([VertexKey::NONE; 3], true);
    };
    let bary = path.bary();
    let ids = ids.map(|n| n.0);
    let [a, b, c] = FACE_VERTS[(face & 3) as usize].map(|k| bary[(k & 3) as usize]);
    // The listing is `a, c, b` from a positively oriented node, `a, b, c` otherwise.
    let order = if frame.point(&c, path.depth) == corners[1] {
        [a, c, b]
    } else {
        [a, b, c]
    };
    let keys = order.map(|w| VertexKey::of(ids, w, path.depth));
    // On root face `j` when every corner has no weight on root corner `j`.
    let drilled = (0..4u8).all(|j| {
        let on = order.iter().all(|w| w[(j & 3) as usize] == 0);
        !(on && mesh.is_boundary_face(t, j))
    });
    (keys, drilled)
}

/// Where face `face` of the node of tree index `index` comes in a tree's listing
/// ([`Hierarchy::for_each_visible_in`]: depth first, the children of a node in descending
/// digit order, a node's faces in ascending order), as a number: the digits root first,
/// each as `7 - digit` in 3 bits and padded to [`MAX_DEPTH`] levels, then the depth (an
/// ancestor before its descendants), then the face. Any consistent order would do; this
/// one matches the listing, so a tet's unchanged faces keep their slots.
pub(super) fn walk_key(index: u32, face: u8) -> u64 {
    let mut digits = [0u8; MAX_DEPTH];
    let mut depth = 0usize;
    let mut i = index;
    while i > 0 {
        let Some(d) = digits.get_mut(depth) else {
            break;
        };
        *d = ((i - 1) & 7) as u8;
        i = (i - 1) >> 3;
        depth += 1;
    }
    let mut key = 0u64;
    // `digits[depth - 1]` is the root's child, `digits[0]` the deepest.
    for (level, &d) in digits.iter().take(depth).rev().enumerate() {
        key |= u64::from(7 - d) << (3 * (MAX_DEPTH - 1 - level));
    }
    (key << 4 | depth as u64) << 2 | u64::from(face & 3)
}
