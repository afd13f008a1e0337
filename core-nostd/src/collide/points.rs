//! Points against a body whose tets are hashed.

use glam::Vec3;

use super::{Body, CollideReport, Collision, INSIDE_EPS};
use crate::geom;
use crate::hash::{Aabb, Rebuilt, SpatialHash};
use crate::ids::{NodeId, TetId};

/// Hashes every tet of `body` into the cells its bounding box overlaps (item = tet id).
///
/// # Bounded work
/// O(buckets + T + capacity); a full table keeps the first tets that fit and reports
/// `saturated` (see [`SpatialHash::rebuild`]).
pub fn hash_tets(hash: &mut SpatialHash<'_>, body: &Body<'_, '_>) -> Rebuilt {
    hash.rebuild(body.tet_count(), |t| {
        body.tet_positions(TetId::from_idx(t)).map(Aabb::of)
    })
}

/// Finds, for each point, the smallest-id tet of `body` that contains it; `tets` must hold
/// `body`'s tets ([`hash_tets`]). With `own`, point `i` is node `i` of `body` and tets that use
/// it are not candidates (self-collision). Writes `(node, tet)` pairs sorted by node.
///
/// # Bounded work
/// O(P * b) for P points and b the largest bucket; no more than `out.len()` writes.
/// When `out` is full, the remaining points are not examined and `saturated` is set.
pub fn points_in_tets(
    tets: &SpatialHash<'_>,
    body: &Body<'_, '_>,
    points: &[Vec3],
    own: bool,
    out: &mut [Collision],
) -> CollideReport {
    let mut r = CollideReport::default();
    let bounds = tets.bounds();
    for (i, &p) in points.iter().enumerate() {
        if !bounds.overlaps(&Aabb::point(p)) {
            continue;
        }
        let node = NodeId::from_idx(i);
        let mut best = TetId::NONE;
        for item in tets.items_in_cell(tets.cell_of(p)) {
            let t = TetId(item);
            if t >= best {
                continue;
            }
            let Some(ids) = body.tet_nodes(t) else {
                continue;
            };
            if own && ids.contains(&node) {
                continue;
            }
            let Some(corners) = body.tet_positions(t) else {
                continue;
            };
            r.candidates = r.candidates.wrapping_add(1);
            match geom::barycentric(p, corners) {
                None => r.degenerate = r.degenerate.wrapping_add(1),
                Some(b) if geom::inside(b, INSIDE_EPS) => best = t,
                Some(_) => {}
            }
        }
        if best.is_some() {
            let Some(slot) = out.get_mut(r.count) else {
                r.saturated = true;
                break;
            };
            *slot = Collision { node, tet: best };
            r.count += 1;
        }
    }
    r
}
