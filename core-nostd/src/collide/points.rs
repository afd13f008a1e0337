//! Points against a body whose tets are hashed.

use glam::Vec3;

use super::{candidate_holds, Body, CollideReport, Collision, Occupancy};
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
/// When `out` is full, the remaining points are not examined and `saturated` is set: the
/// points with the smallest indices are kept (`points_in_tets_coherent` keeps the previous
/// call's instead).
pub fn points_in_tets(
    tets: &SpatialHash<'_>,
    body: &Body<'_, '_>,
    points: &[Vec3],
    own: bool,
    out: &mut [Collision],
) -> CollideReport {
    points_in_tets_coherent(tets, body, points, own, out, 0)
}

/// [`points_in_tets`] that keeps last call's collisions first when `out` cannot hold every
/// colliding point (temporal coherence).
///
/// `out[..kept]` must be the previous call's result, left as it was written (its `count`);
/// entries that are not in increasing node order or name a point beyond `points` are
/// ignored, so any contents give a valid result. First the points listed there are tested
/// again and those still inside a tet keep their entries; then the other points are
/// examined in index order and fill the entries left. The result is the same set and order
/// as [`points_in_tets`] whenever every colliding point fits: only which points a full
/// output keeps differs, the previous ones first and then the smallest new indices. Listed
/// points leave only when they leave the tets, so a caller summing a quantity that is zero
/// at the tets' surface over the list sees it change continuously while the output is full.
///
/// # Bounded work
/// O(P * b) as [`points_in_tets`] (each point is tested once), plus one sort of at most
/// `out.len()` entries when the previous entries and new ones are merged. When `out` is full
/// the remaining points are not examined and `saturated` is set.
pub(crate) fn points_in_tets_coherent(
    tets: &SpatialHash<'_>,
    body: &Body<'_, '_>,
    points: &[Vec3],
    own: bool,
    out: &mut [Collision],
    kept: usize,
) -> CollideReport {
    coherent(tets, body, points, own, out, kept, None, |_| true)
}

/// `points_in_tets_coherent` that looks a point up only when `cells` says a tet box of
/// `body` may hold it (`Occupancy::may_hold`), and tests a candidate tet's barycentric
/// coordinates only when its grown box holds the point (`Occupancy::tet_may_hold`);
/// `cells` must be built over `body`'s tets ([`Occupancy::build`]). Same result, bit for
/// bit: a point outside every occupied cell, or outside a tet's grown box, is not inside it.
/// Cheaper when most points are away from the body (a tool mostly outside the object). When
/// `cells` has tet lists ([`Occupancy::with_tet_lists`]), a point's candidates are its grid
/// cell's list instead of the hash's cell: every tet whose grown box holds the point, in
/// increasing id order, each entry with that box in the cell quantised outward
/// ([`super::GridEntry`]): the tets whose entry rules the point out are skipped, and those
/// it admits face the barycentric test without the box's (the entry holds the box), so the
/// answer is again the smallest tet that holds the point (the hash's, unless the f32 test
/// puts the point in a tet whose ungrown box misses the point's hash cell, where the list,
/// like a brute force, still finds it).
///
/// Point `i` is examined only when `may_hit(i)` holds: it must hold for every point that may
/// be inside a tet (`|_| true`, or e.g. `super::RigidTets::node_near` for the nodes of a
/// rigid tool whose clusters [`super::RigidTets::near`] found near `cells`).
///
/// # Bounded work
/// As `points_in_tets_coherent`, plus one `may_hit` call and one bit test per point
/// examined and one box test (or, with tet lists, one entry test) per candidate.
#[allow(clippy::too_many_arguments)]
pub fn points_in_tets_occupied<F: Fn(usize) -> bool>(
    tets: &SpatialHash<'_>,
    cells: &Occupancy<'_>,
    body: &Body<'_, '_>,
    points: &[Vec3],
    own: bool,
    out: &mut [Collision],
    kept: usize,
    may_hit: F,
) -> CollideReport {
    coherent(tets, body, points, own, out, kept, Some(cells), may_hit)
}

/// Where the walks of [`points_in_tets_walked`] start.
#[derive(Debug)]
pub struct WalkStarts<'w, N> {
    /// One entry per point, written by the call: the tet the point was found in (`NONE` when
    /// it is in none or was not examined). A point beyond its length walks only from its own
    /// tet of last call.
    pub found: &'w mut [TetId],
    /// The points near point `i` (a mesh's node neighbours, say): a point not listed last
    /// call walks from the tet of the first of them found already in this call.
    pub near: N,
    /// Most tets one walk tests (0: no walks, every point looked up in the hash).
    pub max_steps: u32,
}

/// [`points_in_tets_occupied`] (with `own` false) that first walks to each point from a tet
/// near it: the tet the point was in last call (its entry in `out[..kept]`) or else the tet
/// of a nearby point found earlier in this call ([`WalkStarts::near`]). The walk
/// (`walk_to_holder`) is taken only when it ends in a tet that holds the point by at least
/// `WALK_MARGIN` in every barycentric coordinate; otherwise the point is looked up in the
/// hash as [`points_in_tets_occupied`] does.
///
/// A point that deep inside a tet is in no other tet when `body`'s tets do not overlap and
/// are well shaped ([`walks_exact`]: the f32 rounding of their barycentric coordinates stays
/// under the margin), so the tet found is the smallest-id tet that holds the point and the
/// result is [`points_in_tets_occupied`]'s, bit for bit (tests compare the two on the shared
/// meshes). On a body that fails [`walks_exact`] (slivers), or with a `tets` hash that did not
/// hold every tet, a walk may name another tet that holds the point, or a point the hash
/// misses: pass `max_steps` 0 there. For the nodes of a tool in the object most
/// points inside are found by a walk of one or two tets (a barycentric test each) instead of
/// a cell's candidates.
///
/// # Bounded work
/// As [`points_in_tets_occupied`], plus clearing `found` and at most `max_steps`
/// barycentric tests and one `near` call (with a look at each point it names) per point
/// examined.
#[allow(clippy::too_many_arguments)]
pub fn points_in_tets_walked<'g, N: Fn(usize) -> &'g [NodeId], F: Fn(usize) -> bool>(
    tets: &SpatialHash<'_>,
    cells: &Occupancy<'_>,
    body: &Body<'_, '_>,
    points: &[Vec3],
    out: &mut [Collision],
    kept: usize,
    starts: WalkStarts<'_, N>,
    may_hit: F,
) -> CollideReport {
    let WalkStarts {
        found,
        near,
        max_steps,
    } = starts;
    found.fill(TetId::NONE);
    let tet_count = body.tet_count();
    // A walk starts in the tet the point was in last call, else in a near point's.
    let locate = |node: NodeId, p: Vec3, was: TetId, r: &mut CollideReport| {
        let mut t = TetId::NONE;
        if max_steps > 0 {
            let mut start = was;
            if start.is_none() {
                for j in near(node.idx()) {
                    if let Some(&f) = found.get(j.idx()) {
                        if f.is_some() {
                            start = f;
                            break;
                        }
                    }
                }
            }
            if start.idx() < tet_count {
                t = walk_to_holder(body, start, p, max_steps, &mut r.candidates);
            }
        }
        if t.is_none() {
            t = smallest_tet(tets, body, Some(cells), p, node, false, r);
        }
        if let Some(f) = found.get_mut(node.idx()) {
            *f = t;
        }
        t
    };
    scan(
        points,
        out,
        kept,
        |i, p| may_hit(i) && cells.may_hold(p),
        locate,
    )
}

/// Barycentric margin for accepting a walk's tet ([`points_in_tets_walked`]).
pub(crate) const WALK_MARGIN: f32 = 1.0e-3;

/// Largest tet shape measure `L^3 / (6 V)` (longest edge cubed over six times the volume;
/// 8.5 for a regular tet) of a body whose walks give the hash's answers ([`walks_exact`]).
pub(crate) const WALK_MAX_SHAPE: f64 = 100.0;

/// `true` when every tet of `body` has a shape measure `L^3 / (6 V)` of at most
/// `WALK_MAX_SHAPE` (computed in f64; degenerate or non-finite tets fail): then the f32
/// rounding of a barycentric coordinate, below about `6e-6 L^3 / (6 V)` (at most 6e-4
/// here), stays under `WALK_MARGIN`, so a point that deep inside one tet is in no other
/// tet of comparable size by the f32 test either, and a walk's tet is the smallest-id tet
/// that holds the point ([`points_in_tets_walked`]). Sliver meshes fail it (the shared
/// `spot_tetgen_coarse` reaches 6,206 and has points that the f32 test puts in two tets);
/// the tetgen meshes made with a quality bound pass (teddy 52, cow 87).
///
/// # Bounded work
/// O(T): a volume and six edges per tet. Call it at set-up.
pub fn walks_exact(body: &Body<'_, '_>) -> bool {
    (0..body.tet_count()).all(|t| {
        let Some(c) = body.tet_positions(TetId::from_idx(t)) else {
            return false;
        };
        let det = crate::geom::det6_f64(c[0], c[1], c[2], c[3]);
        let mut longest = 0.0f64;
        for [i, j] in crate::mesh::template::EDGE_VERTS {
            let (a, b) = (c[i as usize], c[j as usize]);
            let e = [
                b.x as f64 - a.x as f64,
                b.y as f64 - a.y as f64,
                b.z as f64 - a.z as f64,
            ];
            longest = longest.max(e[0] * e[0] + e[1] * e[1] + e[2] * e[2]);
        }
        let l3 = longest * libm::sqrt(longest);
        let shape = l3 / libm::fabs(det);
        shape.is_finite() && shape <= WALK_MAX_SHAPE
    })
}

/// From tet `from`, steps towards `p` (across the face whose barycentric coordinate is the
/// most negative) until a tet holds `p` with every coordinate at least [`WALK_MARGIN`]
/// (returned), or gives up (`NONE`): `p` near a face of the tet it is in, the walk leaving
/// the body, a degenerate tet, or `max_steps` tets tested.
///
/// `tests` counts the barycentric tests made.
///
/// # Bounded work
/// At most `max_steps` barycentric tests.
pub(crate) fn walk_to_holder(
    body: &Body<'_, '_>,
    from: TetId,
    p: Vec3,
    max_steps: u32,
    tests: &mut u32,
) -> TetId {
    let mut t = from;
    for _ in 0..max_steps {
        *tests = tests.wrapping_add(1);
        // The whole record at once: its neighbours are read with its nodes, not after the
        // barycentric test that picks one.
        let Some(tet) = body.mesh.get_tet(t) else {
            return TetId::NONE;
        };
        let n = tet.nodes;
        let corners = (|| {
            Some([
                body.pos(n[0])?,
                body.pos(n[1])?,
                body.pos(n[2])?,
                body.pos(n[3])?,
            ])
        })();
        let Some(b) = corners.and_then(|corners| crate::geom::barycentric(p, corners)) else {
            return TetId::NONE;
        };
        if b.iter().any(|c| c.is_nan()) {
            return TetId::NONE;
        }
        let mut low = 0usize;
        for k in 1..4 {
            if b[k] < b[low] {
                low = k;
            }
        }
        if b[low] >= WALK_MARGIN {
            return t;
        }
        if b[low] >= 0.0 {
            return TetId::NONE; // inside, near a face: the hash decides
        }
        t = tet.neighbours.get(low).copied().unwrap_or(TetId::NONE);
        if t.is_none() {
            return TetId::NONE;
        }
    }
    TetId::NONE
}

/// [`points_in_tets_coherent`], culled by `cells` when given and by `filter`.
#[allow(clippy::too_many_arguments)]
fn coherent<F: Fn(usize) -> bool>(
    tets: &SpatialHash<'_>,
    body: &Body<'_, '_>,
    points: &[Vec3],
    own: bool,
    out: &mut [Collision],
    kept: usize,
    cells: Option<&Occupancy<'_>>,
    filter: F,
) -> CollideReport {
    scan(
        points,
        out,
        kept,
        |i, p| filter(i) && cells.is_none_or(|c| c.may_hold(p)),
        |node, p, _, r| smallest_tet(tets, body, cells, p, node, own, r),
    )
}

/// The `_coherent` searches' two passes: the previous entries `out[..kept]` whose point
/// `locate` still finds in a tet (given its old tet), compacted in place, then every other
/// point in index order into what is left; only points `may_hit` lets through are looked
/// up. Sorts the entries when both passes wrote some.
#[inline(always)]
fn scan<M, L>(
    points: &[Vec3],
    out: &mut [Collision],
    kept: usize,
    may_hit: M,
    mut locate: L,
) -> CollideReport
where
    M: Fn(usize, Vec3) -> bool,
    L: FnMut(NodeId, Vec3, TetId, &mut CollideReport) -> TetId,
{
    let mut r = CollideReport::default();
    // The previous entries still inside, compacted in place (in node order).
    let m = super::keep_previous(out, kept, points, |node, p, was| {
        if may_hit(node.idx(), p) {
            locate(node, p, was, &mut r)
        } else {
            TetId::NONE
        }
    });
    // Every other point, in index order, into what is left.
    let mut n = m;
    let mut j = 0usize;
    for (i, &p) in points.iter().enumerate() {
        let node = NodeId::from_idx(i);
        if j < m {
            while out.get(j).is_some_and(|c| j < m && c.node < node) {
                j += 1;
            }
            if j < m && out.get(j).is_some_and(|c| c.node == node) {
                continue; // tested above
            }
        }
        if !may_hit(i, p) {
            continue;
        }
        let tet = locate(node, p, TetId::NONE, &mut r);
        if tet.is_some() {
            let Some(slot) = out.get_mut(n) else {
                r.saturated = true;
                break;
            };
            *slot = Collision { node, tet };
            n += 1;
        }
    }
    if m > 0 && n > m {
        if let Some(all) = out.get_mut(..n) {
            all.sort_unstable();
        }
    }
    r.count = n;
    r
}

/// The smallest-id tet of `body` in `tets` (or in `cells`' list of `p`'s cell, when it has
/// lists) holding `p` (`NONE` when none), counting the candidates and degenerate tets met in
/// `r`: the cell's tets in increasing id order, the first that holds `p` ends the search.
fn smallest_tet(
    tets: &SpatialHash<'_>,
    body: &Body<'_, '_>,
    cells: Option<&Occupancy<'_>>,
    p: Vec3,
    node: NodeId,
    own: bool,
    r: &mut CollideReport,
) -> TetId {
    // The barycentric test, after the grown box's when `boxed` (a list entry that admits
    // `p` stands for the box: it is the box, quantised outward, and a point the f32 test
    // puts in a tet is in its grown box).
    let mut holds = |t: TetId, boxed: bool| {
        if boxed && cells.is_some_and(|c| !c.tet_may_hold(t, p)) {
            return false;
        }
        let Some(ids) = body.tet_nodes(t) else {
            return false;
        };
        if own && ids.contains(&node) {
            return false;
        }
        body.tet_positions(t)
            .is_some_and(|corners| candidate_holds(p, corners, r))
    };
    // The grid's own list of the cell's tets when it has one, else the hash's cell.
    // Entries that do not admit `p` are tets whose grown box misses it: skipped without
    // loading the box, and those that do go straight to the barycentric test.
    if let Some(list) = cells.and_then(|c| c.tets_at(p)) {
        return list
            .entries
            .iter()
            .filter(|e| list.admits(e))
            .map(|e| e.tet())
            .find(|&t| holds(t, false))
            .unwrap_or(TetId::NONE);
    }
    if !tets.bounds().contains(p) {
        return TetId::NONE;
    }
    tets.items_in_cell_ascending(tets.cell_of(p))
        .map(TetId)
        .find(|&t| holds(t, true))
        .unwrap_or(TetId::NONE)
}
