//! The hashed intersection (Heidelberger 2004): candidate boundary faces from a hash.

use glam::{Affine3A, Vec3};

use super::surface::{exit_values, hit_on_face, on_edge, SurfaceHit};
use crate::collide::Body;
use crate::hash::{Aabb, Rebuilt, SpatialHash};
use crate::ids::TetId;

/// Hashes the boundary faces of `body` (item `tet * 4 + face`) into the cells their boxes
/// overlap, at the body's current positions.
///
/// # Bounded work
/// O(buckets + 4T + capacity); a full table keeps the first faces that fit and reports
/// `saturated`.
pub fn hash_boundary_faces(hash: &mut SpatialHash<'_>, body: &Body<'_, '_>) -> Rebuilt {
    let count = body.tet_count().saturating_mul(4).min(u32::MAX as usize);
    hash.rebuild(count, |i| {
        let t = TetId::from_idx(i / 4);
        let f = (i % 4) as u8;
        if body.neighbour(t, f).is_some() {
            return None;
        }
        let n = body.tet_nodes(t)?;
        let lv = crate::mesh::template::FACE_VERTS[f as usize];
        let pts = [
            body.pos(n[lv[0] as usize])?,
            body.pos(n[lv[1] as usize])?,
            body.pos(n[lv[2] as usize])?,
        ];
        Some(Aabb::of(pts))
    })
}

/// The outward crossing of `p -> q` with a hashed boundary face nearest to `p` (smallest
/// `s`, ties to the smaller `tet * 4 + face`). Returns `None` when no face qualifies or the
/// edge's box covers more than `max_cells` cells.
///
/// # Bounded work
/// O(max_cells + entries met), each candidate face one constant-time face test, once per
/// face ([`SpatialHash::query_box_once`]).
pub(crate) fn hashed_hit(
    faces: &SpatialHash<'_>,
    world_to_hash: &Affine3A,
    body: &Body<'_, '_>,
    p: Vec3,
    q: Vec3,
    max_cells: u32,
    candidates: &mut u32,
) -> Option<SurfaceHit> {
    let hp = world_to_hash.transform_point3(p);
    let hq = world_to_hash.transform_point3(q);
    // A small margin so rounding of the frame change never drops the crossing's cell.
    let margin = faces.cell_size() * 1e-3;
    let b = Aabb::of([hp, hq]).grown(margin);
    let mut best: Option<(SurfaceHit, u32)> = None;
    faces.query_box_once(&b, max_cells, |item| {
        *candidates = candidates.wrapping_add(1);
        let t = TetId(item / 4);
        let f = (item % 4) as u8;
        let Some(e) = exit_values(body, t, f, p, q) else {
            return;
        };
        let Some(h) = hit_on_face(body, t, f, e, p, q) else {
            return;
        };
        if !on_edge(&h) {
            return;
        }
        let better = match &best {
            None => true,
            Some((o, oi)) => h.s < o.s || (h.s == o.s && item < *oi),
        };
        if better {
            best = Some((h, item));
        }
    });
    best.map(|(h, _)| h)
}
