//! Tets walking the cells of their bounding boxes over hashed points (Teschner's order).
//!
//! ```
//! use tetradrill_core::builtin;
//! use tetradrill_core::collide::{tets_over_points, Body, Collision};
//! use tetradrill_core::hash::{HashEntry, SpatialHash};
//! use tetradrill_core::prelude::*;
//!
//! let (mut pos, tets) = builtin::cube12();
//! let (mut nodes, mut normals) = ([Node::default(); 9], [Vec3::ZERO; 9]);
//! let (mut recs, mut scratch) = ([Tet::default(); 12], [FaceKey::default(); 48]);
//! let storage = MeshStorage { nodes: &mut nodes, normals: &mut normals, tets: &mut recs };
//! let mesh = Mesh::build(&mut pos, &tets, storage, &mut scratch, BuildOptions::default())?;
//!
//! // The points are hashed (one entry each); the cube's tets walk their cells.
//! let points = [Vec3::new(0.1, 0.2, 0.3), Vec3::new(0.9, 0.0, 0.0), Vec3::new(-0.4, 0.4, -0.1)];
//! let (mut starts, mut entries) = ([0u32; 8], [HashEntry::EMPTY; 3]);
//! let mut hashed = SpatialHash::new(&mut starts, &mut entries, 0.5).expect("valid sizes");
//! hashed.rebuild_points(&points);
//! let mut out = [Collision::default(); 3];
//! let found = tets_over_points(&hashed, &points, &Body::fixed(&mesh), false, &mut out);
//! let inside: Vec<u32> = out[..found.count].iter().map(|c| c.node.0).collect();
//! assert_eq!(inside, [0, 2]);
//! # Ok::<(), tetradrill_core::Error>(())
//! ```

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
/// is set; the written pairs stay valid (the hits of the first tets walked are kept;
/// `tets_over_points_coherent` keeps the previous call's points first).
pub fn tets_over_points(
    points_hash: &SpatialHash<'_>,
    points: &[Vec3],
    body: &Body<'_, '_>,
    own: bool,
    out: &mut [Collision],
) -> CollideReport {
    walk(points_hash, points, body, own, out, 0).0
}

/// [`tets_over_points`] that keeps last call's points first when `out` cannot hold every hit
/// (temporal coherence).
///
/// `out[..kept]` must be the previous call's result, left as it was written (its `count`);
/// entries out of increasing node order or naming a point beyond `points` are ignored, so any
/// contents give a valid result. Those points keep their entries while they are inside a tet
/// (with the smallest such tet); the other hits fill what is left in the order the tets are
/// walked. The result is the same set and order as [`tets_over_points`] whenever that one
/// does not fill `out`: when keeping the entries of points that have left costs room that a
/// new point needed, the walk is done again without them. Listed points leave only when they
/// leave the tets, so a caller summing a quantity that is zero at the tets' surface over the
/// list sees it change continuously while the output is full.
///
/// # Bounded work
/// At most two walks as in [`tets_over_points`], a binary search over at most `kept` entries
/// per hit, and one sort of at most `out.len()` entries. When `out` is full further new points
/// are dropped and `saturated` is set.
pub(crate) fn tets_over_points_coherent(
    points_hash: &SpatialHash<'_>,
    points: &[Vec3],
    body: &Body<'_, '_>,
    own: bool,
    out: &mut [Collision],
    kept: usize,
) -> CollideReport {
    // The previous entries, compacted in place to increasing node order within range.
    let mut k = 0usize;
    for i in 0..kept.min(out.len()) {
        let node = out[i].node;
        if node.idx() >= points.len() || (k > 0 && node <= out[k - 1].node) {
            continue;
        }
        out[k] = out[i];
        k += 1;
    }
    let (r, hits) = walk(points_hash, points, body, own, out, k);
    if k == 0 || !r.saturated || hits > out.len() {
        return r;
    }
    // Every hit would have fitted without the entries kept for points that have left.
    let (mut again, _) = walk(points_hash, points, body, own, out, 0);
    again.candidates = again.candidates.wrapping_add(r.candidates);
    again
}

/// The walk: `out[..k]` are points kept from the previous call (increasing node order), the
/// other hits are appended after them. Returns the report and the number of hits (a point in
/// several tets counts once per tet).
fn walk(
    points_hash: &SpatialHash<'_>,
    points: &[Vec3],
    body: &Body<'_, '_>,
    own: bool,
    out: &mut [Collision],
    k: usize,
) -> (CollideReport, usize) {
    let mut r = CollideReport::default();
    let k = k.min(out.len());
    for c in &mut out[..k] {
        c.tet = TetId::NONE; // not found yet
    }
    let bounds = points_hash.bounds();
    let mut n = k;
    let mut hits = 0usize;
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
                    hits += 1;
                    if k > 0 {
                        if let Ok(j) = out_ref[..k].binary_search_by_key(&node, |c| c.node) {
                            // Tets come in increasing order: the first is the smallest.
                            if out_ref[j].tet.is_none() {
                                out_ref[j].tet = t;
                            }
                            return;
                        }
                    }
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
    // Drop kept points that were not met again, then the new hits after them.
    let mut m = 0usize;
    for i in 0..k {
        if out[i].tet.is_some() {
            out[m] = out[i];
            m += 1;
        }
    }
    out.copy_within(k..n, m);
    let found = out.get_mut(..m + n - k).unwrap_or(&mut []);
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
    (r, hits)
}
