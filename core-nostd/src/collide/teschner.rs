//! Tets walking the cells of their bounding boxes over hashed points (Teschner's order).

use glam::Vec3;

use super::{Body, CollideReport, Collision, INSIDE_EPS};
use crate::geom;
use crate::hash::{Aabb, SpatialHash};
use crate::ids::{NodeId, TetId};

/// Cells one tet's box may cover before the tet is skipped as far too large for the grid.
pub const MAX_CELLS_PER_TET: u32 = 4096;

/// Finds the points (hashed in `points_hash`, item = index into `points`) inside the tets of
/// `body`; each point is reported once with the smallest tet id, sorted by node. With `own`,
/// the points are `body`'s own nodes and a tet never collides with its own nodes.
///
/// # Bounded work
/// O(T * (cells per tet box + points met)) with the cells per box capped at
/// [`MAX_CELLS_PER_TET`] (larger boxes are skipped and counted in `clipped`), plus one sort of
/// at most `out.len()` entries. When `out` fills, further hits are dropped and `saturated`
/// is set; the written pairs stay valid.
pub fn tets_over_points(
    points_hash: &SpatialHash<'_>,
    points: &[Vec3],
    body: &Body<'_, '_>,
    own: bool,
    out: &mut [Collision],
) -> CollideReport {
    let mut r = CollideReport::default();
    let bounds = points_hash.bounds();
    let mut n = 0usize;
    for ti in 0..body.tet_count() {
        let t = TetId::from_idx(ti);
        let (Some(ids), Some(corners)) = (body.tet_nodes(t), body.tet_positions(t)) else {
            continue;
        };
        let b = Aabb::of(corners);
        if !b.overlaps(&bounds) {
            continue;
        }
        let mut degenerate = false;
        let out_ref = &mut *out;
        let visited = points_hash.query_box_ro(&b, MAX_CELLS_PER_TET, |_, item| {
            let node = NodeId(item);
            if own && ids.contains(&node) {
                return;
            }
            let Some(&p) = points.get(item as usize) else {
                return;
            };
            r.candidates = r.candidates.wrapping_add(1);
            match geom::barycentric(p, corners) {
                None => degenerate = true,
                Some(bc) if geom::inside(bc, INSIDE_EPS) => {
                    if let Some(slot) = out_ref.get_mut(n) {
                        *slot = Collision { node, tet: t };
                        n += 1;
                    } else {
                        r.saturated = true;
                    }
                }
                Some(_) => {}
            }
        });
        if !visited {
            r.clipped = r.clipped.wrapping_add(1);
        }
        if degenerate {
            r.degenerate = r.degenerate.wrapping_add(1);
        }
    }
    let found = out.get_mut(..n).unwrap_or(&mut []);
    found.sort_unstable();
    // Keep the first (smallest tet) pair of each node.
    let mut w = 0usize;
    for i in 0..found.len() {
        if w == 0 || found[w - 1].node != found[i].node {
            found[w] = found[i];
            w += 1;
        }
    }
    r.count = w;
    r
}
