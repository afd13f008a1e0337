//! [`rigid_tets_over_points_coherent`]: the points inside the tets of a rigid body moved by a
//! pose, cluster by cluster over its [`RigidTets`].

use glam::{Affine3A, Vec3};

use super::rigid::{holds_point, RigidTets};
use super::rigid_locate::{Pending, BATCH};
use super::rigid_near::NearClusters;
use super::teschner::{tets_over_points_coherent, MAX_CELLS_PER_TET};
use super::{Body, CollideReport, Collision};
use crate::hash::{Aabb, SpatialHash};
use crate::ids::{NodeId, TetId};

/// The points (hashed in `points_hash`, item = index into `points`) inside the tets of
/// `body`, a rigid body moved by `pose` from the rest frame `rigid` was built in
/// (`body.positions` = `pose` applied to the rest positions). Same contract and result as
/// `tets_over_points_coherent` with `own` unset: each point once, with the smallest tet
/// that holds it, sorted by point; `out[..kept]` the previous call's result, whose points are
/// tested first and keep their entries while inside. When `out` cannot hold every hit, the
/// remaining room goes to the new points with the smallest indices (the walk's order is not
/// kept), and `saturated` is set.
///
/// Only the clusters `near` names are searched: it must hold every cluster whose moved box
/// may hold one of the points ([`RigidTets::near`] over an [`Occupancy`] of the body whose
/// nodes the points are, or `NearClusters::ALL`). When that occupancy lists as many nodes
/// as `points` ([`Occupancy::with_node_lists`]), the points in a cluster's moved box are
/// read from its lists, positions included, instead of `points_hash`: they must be the
/// nodes of the static body the lists were built over, at the same positions.
///
/// With `max_walk` above 0 each previous point first walks from its previous tet through
/// `body` (`super::walk_to_holder`, at most `max_walk` tets) and keeps the tet it ends in
/// when that holds it by `super::WALK_MARGIN`: the same tet when `body` passes
/// [`super::walks_exact`] and `rigid` holds all its tets (pass 0 otherwise).
///
/// Falls back to `tets_over_points_coherent` (same result) when the pose is not a rotation
/// (a quaternion far from unit length), or so far from the origin that rounding could exceed
/// `rigid`'s margin (`64 x f32::EPSILON x (|translation| + rest radius) > margin`), or when a
/// cluster's moved box could cover more than [`MAX_CELLS_PER_TET`] cells of `points_hash`. A
/// cluster whose moved box covers more than [`MAX_CELLS_PER_TET`] cells of the node lists
/// reads `points_hash` instead.
///
/// # Bounded work
/// O(kept x (max_walk + b)) for the previous points, then per near cluster one box transform
/// and a read of at most [`MAX_CELLS_PER_TET`] cells (one run per row of cells of the node
/// lists, with the nodes outside their grid, or one bucket per cell of `points_hash`); per
/// point met one box test, for those in the cluster's moved box one transform and, for the
/// points in the cluster's own cell, at most `b` entry tests and `b` candidate tets
/// (`RigidTets::locate_batch`), for `b` the fullest cell of the rest grid; a binary search
/// over `kept` entries and, once `out` is full, a heap step (O(log out.len())) per new hit;
/// one sort of at most `out.len()` entries.
///
/// [`Occupancy`]: super::Occupancy
/// [`Occupancy::with_node_lists`]: super::Occupancy::with_node_lists
#[allow(clippy::too_many_arguments)]
pub fn rigid_tets_over_points_coherent(
    points_hash: &SpatialHash<'_>,
    points: &[Vec3],
    rigid: &RigidTets<'_>,
    body: &Body<'_, '_>,
    pose: Affine3A,
    near: &NearClusters<'_>,
    out: &mut [Collision],
    kept: usize,
    max_walk: u32,
) -> CollideReport {
    let g = points_hash.cell_size();
    let per_axis = libm::floorf(2.0 * (rigid.reach + 2.0 * rigid.margin) / g) as u64 + 2;
    let fits = per_axis.saturating_mul(per_axis).saturating_mul(per_axis);
    if !rigid.pose_in_margin(&pose) || fits > MAX_CELLS_PER_TET as u64 {
        return tets_over_points_coherent(points_hash, points, body, false, out, kept);
    }
    let inv = pose.inverse();
    let mut r = CollideReport::default();

    // The previous points still inside, compacted in place (in node order).
    let m = super::keep_previous(out, kept, points, |_, p, was| {
        if max_walk > 0 && was.idx() < body.tet_count() {
            let t = super::walk_to_holder(body, was, p, max_walk, &mut r.candidates);
            if t.is_some() {
                return t;
            }
        }
        rigid.locate(inv.transform_point3(p), p, body, &mut r)
    });

    // New points, cluster by cluster: those a cluster keeps wait in a batch for their
    // lookups (the order they are found in does not change the result: it is sorted, and a
    // full list keeps the smallest nodes whatever the order).
    let (kept_part, new_part) = out.split_at_mut(m);
    let search = Search {
        rigid,
        body,
        inv,
        kept: kept_part,
    };
    let mut look = Lookups {
        part: new_part,
        n: 0,
        heap: false,
        batch: [Pending::default(); BATCH],
        waiting: 0,
    };
    let bounds = points_hash.bounds();
    let lists = near
        .cells
        .filter(|c| c.listed_nodes() == Some(points.len()));
    for ci in 0..rigid.clusters() {
        if !near.is_near(ci) {
            continue;
        }
        let Some(wb) = rigid.moved_box(ci, &pose) else {
            continue;
        };
        if !wb.overlaps(&bounds) {
            continue;
        }
        // The nodes in the box from the lists, one run per row of cells; else (no lists, or
        // a box over too many of their cells) from the hash, one bucket per cell.
        let listed = lists.is_some_and(|cells| {
            cells.nodes_in(&wb, MAX_CELLS_PER_TET, |run| {
                // The box test on a run's nodes without a branch each, then the rest of
                // `consider` for those in the box.
                for chunk in run.chunks(64) {
                    let mut inside = 0u64;
                    for (j, e) in chunk.iter().enumerate() {
                        inside |= (holds_point(&wb, e.pos) as u64) << j;
                    }
                    while inside != 0 {
                        let j = inside.trailing_zeros() as usize;
                        inside &= inside - 1;
                        if let Some(e) = chunk.get(j) {
                            look.admit(&search, ci, e.node, e.pos, &mut r);
                        }
                    }
                }
            })
        });
        let visited = listed
            || points_hash.query_box_ro(&wb, MAX_CELLS_PER_TET, |_, item| {
                if let Some(&p) = points.get(item as usize) {
                    look.consider(&search, &wb, ci, item, p, &mut r);
                }
            });
        if !visited {
            r.clipped = r.clipped.wrapping_add(1);
        }
    }
    look.flush(&search, &mut r);
    let n = look.n;
    let all = out.get_mut(..m + n).unwrap_or(&mut []);
    all.sort_unstable();
    r.count = all.len();
    r
}

/// What a call of [`rigid_tets_over_points_coherent`] searches with: the body at rest and
/// moved, the pose's inverse and the previous points kept.
struct Search<'a> {
    rigid: &'a RigidTets<'a>,
    body: &'a Body<'a, 'a>,
    inv: Affine3A,
    kept: &'a [Collision],
}

/// The new points of [`rigid_tets_over_points_coherent`]: those waiting for their lookups,
/// and the hits, `part[..n]` in use; once full, a max-heap by node that keeps the smallest
/// nodes.
struct Lookups<'o> {
    part: &'o mut [Collision],
    n: usize,
    heap: bool,
    batch: [Pending; BATCH],
    waiting: usize,
}

impl Lookups<'_> {
    /// Point `item` at `p`, met in cluster `ci`'s moved box `wb`: a point outside the box is
    /// in none of the cluster's tets (the box holds their moved parts with the margin); one
    /// in it goes on ([`Lookups::admit`]).
    #[inline(always)]
    fn consider(
        &mut self,
        s: &Search<'_>,
        wb: &Aabb,
        ci: usize,
        item: u32,
        p: Vec3,
        r: &mut CollideReport,
    ) {
        if holds_point(wb, p) {
            self.admit(s, ci, item, p, r);
        }
    }

    /// Point `item` at `p`, in cluster `ci`'s moved box: moved back, it waits for its lookup
    /// when the cluster's cell holds it (so no point is looked up twice) and it is not among
    /// the points kept. A full batch is looked up.
    #[inline(always)]
    fn admit(&mut self, s: &Search<'_>, ci: usize, item: u32, p: Vec3, r: &mut CollideReport) {
        let q = s.inv.transform_point3(p);
        if !s.rigid.in_cluster(q, ci) {
            return;
        }
        if !s.kept.is_empty()
            && s.kept
                .binary_search_by_key(&NodeId(item), |c| c.node)
                .is_ok()
        {
            return; // tested above
        }
        if let Some(slot) = self.batch.get_mut(self.waiting) {
            *slot = Pending { node: item, p, q };
            self.waiting += 1;
        }
        if self.waiting == BATCH {
            self.flush(s, r);
        }
    }

    /// Looks the waiting points up (`RigidTets::locate_batch`) and lists those found.
    fn flush(&mut self, s: &Search<'_>, r: &mut CollideReport) {
        let mut found = [TetId::NONE; BATCH];
        let batch = self.batch;
        let waiting = batch.get(..self.waiting).unwrap_or(&[]);
        s.rigid.locate_batch(waiting, s.body, r, &mut found);
        self.waiting = 0;
        for (pt, &tet) in waiting.iter().zip(found.iter()) {
            if tet.is_some()
                && !self.push(Collision {
                    node: NodeId(pt.node),
                    tet,
                })
            {
                r.saturated = true;
            }
        }
    }

    /// Lists `c` (`true`); once full (`false`), keeps it instead of the largest node when its
    /// node is smaller.
    fn push(&mut self, c: Collision) -> bool {
        if self.n < self.part.len() {
            self.part[self.n] = c;
            self.n += 1;
            return true;
        }
        if self.n == 0 {
            return false;
        }
        if !self.heap {
            heapify(self.part);
            self.heap = true;
        }
        if c.node < self.part[0].node {
            self.part[0] = c;
            sift_down(self.part, 0);
        }
        false
    }
}

/// Makes `h` a max-heap by node.
fn heapify(h: &mut [Collision]) {
    for i in (0..h.len() / 2).rev() {
        sift_down(h, i);
    }
}

/// Restores the max-heap (by node) below `i`.
fn sift_down(h: &mut [Collision], mut i: usize) {
    loop {
        let (l, rr) = (2 * i + 1, 2 * i + 2);
        let mut big = i;
        if l < h.len() && h[l].node > h[big].node {
            big = l;
        }
        if rr < h.len() && h[rr].node > h[big].node {
            big = rr;
        }
        if big == i {
            return;
        }
        h.swap(i, big);
        i = big;
    }
}
