//! The branch-and-bound walk of the contact search: one search's node and triangle tests
//! ([`Search`]), the walk over the trees depth first with nearest children first and pruning by
//! the best distance so far, and the rounds a continued search makes from a [`NearestCursor`].

use glam::Vec3;

use super::hints::{keep_all, keep_face};
use super::{
    beats, closer, cut_skips, Entry, FaceRef, Kept, Nearest, NearestCursor, NearestQuery, Search,
    Walk, STACK,
};
use crate::geom::closest_point_on_triangle;
use crate::hierarchy::geometry::{
    child_of_ten, child_packed, refinement_points_masked, RootFrame, CHILD_POINTS,
};
use crate::hierarchy::memo::SphereMemo;
use crate::hierarchy::node::HNode;
use crate::hierarchy::store::Hierarchy;
use crate::hierarchy::surface::{bounding_sphere, face_corners, VisibleTri};
use crate::hierarchy::table::MAX_DEPTH;
use crate::ids::TetId;
use crate::mesh::Mesh;

impl Search {
    /// `true` when a bounding sphere `(d2 = |mid - centre|^2, rad)` may hold a point at most
    /// `bound` (plus slack) from the centre.
    #[inline]
    fn may_hold_better(&self, d2: f32, rad: f32) -> bool {
        let lim = rad + self.bound + self.slack;
        d2 <= lim * lim
    }

    /// `true` when a bounding sphere lies inside the cutting sphere with room to spare: every
    /// triangle below has all three corners inside it, so the cutting rule skips them all.
    #[inline]
    fn all_cut(&self, d2: f32, rad: f32) -> bool {
        if self.cut2 < 0.0 {
            return false;
        }
        let lim = self.cut_r - rad - self.slack;
        lim > 0.0 && d2 < lim * lim
    }

    /// Tests the visible faces of leaf `(t, index)` with corners `p`. A face that would become
    /// the best is taken only when the leaf passes the reach test of the exhaustive walk
    /// (checked once, lazily: it almost always passes, and most faces never need it).
    fn offer_leaf(&mut self, t: TetId, index: u32, node: HNode, p: [Vec3; 4], sphere: (Vec3, f32)) {
        let mut in_reach: Option<bool> = None;
        for face in 0..4u8 {
            if node.visible() & (1 << face) == 0 {
                continue;
            }
            self.triangles = self.triangles.wrapping_add(1);
            let corners = face_corners(p, face, node.inverted());
            let x = closest_point_on_triangle(self.centre, corners);
            if cut_skips(&corners, self.centre, x, self.cut2) {
                continue;
            }
            let d2 = (self.centre - x).length_squared();
            if d2.is_nan() || d2 > self.reach2 {
                continue;
            }
            let key = FaceRef {
                tet: t,
                index,
                face,
            };
            keep_face(
                &mut self.kept,
                d2,
                VisibleTri {
                    tet: t,
                    index,
                    face,
                    corners,
                },
            );
            if !beats((d2, key), self.best.as_ref().map(|b| (b.0, b.1))) {
                continue;
            }
            let ok = *in_reach.get_or_insert_with(|| {
                let (mid, rad) = sphere;
                let lim = rad + self.reach;
                mid.distance_squared(self.centre) <= lim * lim
            });
            if !ok {
                return;
            }
            let vt = VisibleTri {
                tet: t,
                index,
                face,
                corners,
            };
            self.best = Some((d2, key, vt));
            let d = libm::sqrtf(d2);
            if d < self.bound {
                self.bound = d;
            }
        }
    }
}

impl Hierarchy<'_> {
    pub(super) fn nearest_inner(
        &self,
        mesh: &Mesh<'_>,
        q: &NearestQuery<'_>,
        memo: &mut SphereMemo<'_>,
        mut cursor: Option<&mut NearestCursor>,
        kept_out: Option<&mut Kept>,
    ) -> Nearest {
        let NearestQuery {
            tets,
            start,
            centre,
            reach,
            cut,
            hints,
            max_nodes,
        } = *q;
        let n = tets.len();
        let start = if start < n { start } else { 0 };
        if !(centre.is_finite() && reach.is_finite() && reach >= 0.0) {
            if let Some(c) = cursor {
                c.clear();
            }
            return Nearest::default();
        }
        // Go on from the cursor's place when it is still good: from its tree up to the tree
        // its round started with (or the end of the list when that one is gone).
        let mut local: heapless::Vec<Entry, STACK> = heapless::Vec::new();
        let mut going_on: Option<(usize, usize)> = None;
        if let Some(c) = cursor.as_deref_mut() {
            let at = c
                .tet
                .filter(|_| c.reclaimed == self.reclaimed())
                .and_then(|t| tets.iter().position(|&x| x == t));
            match at {
                Some(i) => {
                    let count = match c.first.and_then(|f| tets.iter().position(|&x| x == f)) {
                        Some(f) if f != i => (f + n - i) % n,
                        Some(_) => n,
                        None => n - i,
                    };
                    going_on = Some((i, count));
                }
                None => c.clear(),
            }
        }
        let reach2 = reach * reach;
        let cut2 = cut
            .filter(|r| r.is_finite() && *r >= 0.0)
            .map_or(-1.0, |r| r * r);
        // The hints still in play, measured from this centre; the closest prunes.
        let mut measured = Kept::new();
        let mut hint_tri: Option<(f32, VisibleTri)> = None;
        for vt in hints {
            if let Some(d2) = self.hint_in_play(vt, centre, reach2, cut2) {
                keep_face(&mut measured, d2, *vt);
                if beats((d2, vt.key()), hint_tri.map(|(h, t)| (h, t.key()))) {
                    hint_tri = Some((d2, *vt));
                }
            }
        }
        let hinted = hint_tri.map(|(d2, _)| d2);
        let fresh = Walk {
            tets,
            start,
            count: n,
            centre,
            reach,
            cut2,
        };
        let stack = match cursor.as_deref_mut() {
            Some(c) => &mut c.stack,
            None => &mut local,
        };
        let mut ended = 0u32;
        let mut s = match going_on {
            Some((i, count)) => {
                let on = Walk {
                    start: i,
                    count,
                    ..fresh
                };
                let s = self.nearest_walk(mesh, &on, hinted, max_nodes, memo, stack, true);
                if s.stopped {
                    s
                } else {
                    // The round ended within the bound: a fresh one with what is left (exact
                    // when it ends too); the triangles met so far stay in the running.
                    let left = max_nodes.saturating_sub(s.nodes);
                    let mut again =
                        self.nearest_walk(mesh, &fresh, hinted, left, memo, stack, false);
                    again.nodes += s.nodes;
                    again.triangles += s.triangles;
                    again.best = closer(again.best, s.best);
                    keep_all(&mut again.kept, &s.kept);
                    going_on = None;
                    ended += 1;
                    again
                }
            }
            None => self.nearest_walk(mesh, &fresh, hinted, max_nodes, memo, stack, false),
        };
        if let Some(h) = hinted {
            // Pruning at the hint's distance is exact iff the walk met a triangle at most as
            // far (then the true closest one is no farther than that triangle).
            let ok = s.best.is_some_and(|(d2, _, _)| d2 <= h);
            if !ok && !s.stopped && going_on.is_none() {
                let left = max_nodes.saturating_sub(s.nodes);
                let again = self.nearest_walk(mesh, &fresh, None, left, memo, stack, false);
                let (nodes, triangles) = (s.nodes + again.nodes, s.triangles + again.triangles);
                let mut again = again;
                keep_all(&mut again.kept, &s.kept);
                s = again;
                s.nodes = nodes;
                s.triangles = triangles;
            }
        }
        if let Some(c) = cursor {
            c.rounds = c.rounds.saturating_add(ended + u32::from(!s.stopped));
            if s.stopped {
                if going_on.is_none() {
                    c.first = tets.get(start).copied();
                }
                c.tet = tets.get(s.stopped_in).copied();
                c.reclaimed = self.reclaimed();
            } else {
                c.clear();
            }
        }
        if s.stopped {
            // Anytime answer: the closer of the closest hint and the closest triangle met (ties:
            // the smaller face), so the answer is the first kept face.
            if let Some((h, vt)) = hint_tri {
                if beats((h, vt.key()), s.best.map(|(d2, k, _)| (d2, k))) {
                    s.best = Some((h, vt.key(), vt));
                }
            }
        }
        if let Some(out) = kept_out {
            *out = s.kept.clone();
            keep_all(out, &measured);
        }
        Nearest {
            tri: s.best.map(|(_, _, vt)| vt),
            d2: s.best.map_or(f32::INFINITY, |(d2, _, _)| d2),
            nodes: s.nodes,
            triangles: s.triangles,
            resume: if s.stopped {
                (s.stopped_in + 1) as u32
            } else {
                0
            },
            complete: !s.stopped,
        }
    }

    /// The bounding sphere of node `index` of `t` (corners `p()` when it must be evaluated),
    /// from the memo or evaluated and left there.
    #[inline]
    fn sphere_of(
        memo: &mut SphereMemo<'_>,
        t: TetId,
        index: u32,
        p: impl FnOnce() -> [Vec3; 4],
    ) -> (Vec3, f32) {
        match memo.get(t, index) {
            Some(sp) => sp,
            None => {
                let sp = bounding_sphere(p());
                memo.put(t, index, sp);
                sp
            }
        }
    }

    /// The walk over the trees of `w` from `w.start`, depth first in each, on `stack`: when
    /// `goes_on`, the first tree goes on with the nodes waiting on `stack` (none: from its
    /// root). A walk stopped by `max_nodes` leaves the waiting nodes of the tree it stopped in
    /// (`stopped_in`) on `stack`.
    #[allow(clippy::too_many_arguments)]
    fn nearest_walk(
        &self,
        mesh: &Mesh<'_>,
        w: &Walk<'_>,
        hint_d2: Option<f32>,
        max_nodes: u32,
        memo: &mut SphereMemo<'_>,
        stack: &mut heapless::Vec<Entry, STACK>,
        goes_on: bool,
    ) -> Search {
        let (tets, start, centre, reach) = (w.tets, w.start, w.centre, w.reach);
        let scale = centre.abs().max_element() + reach;
        let mut s = Search {
            centre,
            reach,
            reach2: reach * reach,
            cut2: w.cut2,
            cut_r: if w.cut2 < 0.0 {
                0.0
            } else {
                libm::sqrtf(w.cut2)
            },
            slack: scale * 1.0e-5 + 1.0e-30,
            bound: hint_d2.map_or(reach, libm::sqrtf).min(reach),
            best: None,
            nodes: 0,
            triangles: 0,
            max_nodes,
            stopped: false,
            stopped_in: 0,
            kept: Kept::new(),
        };
        // The ten points of the refinement being expanded (only those some child needs) and
        // the spheres of its children (from the memo or evaluated).
        let mut ten_rows = [0; 10];
        let mut ten = [Vec3::ZERO; 10];
        let mut spheres = [(Vec3::ZERO, 0.0f32); 8];
        let n = tets.len();
        for (k, &t) in tets
            .iter()
            .cycle()
            .skip(start)
            .take(w.count.min(n))
            .enumerate()
        {
            if s.stopped {
                break;
            }
            s.stopped_in = (start + k) % n.max(1);
            // A tree with no surface (interior or erased material) costs one node look-up.
            if t.idx() >= self.tet_count() || !self.node(t.0).is_some_and(|n| n.surface()) {
                continue;
            }
            let Some(frame) = RootFrame::of(mesh, t) else {
                continue;
            };
            if k == 0 && goes_on && !stack.is_empty() {
                // The nodes still waiting in this tree, measured from this centre.
                for e in stack.iter_mut() {
                    e.d2 = e.mid.distance_squared(centre);
                }
            } else {
                stack.clear();
                let rows = frame.root_packed();
                let sp = Self::sphere_of(memo, t, 0, || frame.positions_packed(&rows, 0));
                let Some((d2, rad)) = Self::test_node(&mut s, sp) else {
                    continue;
                };
                let _ = stack.push(Entry {
                    r: t.0,
                    index: 0,
                    depth: 0,
                    bary: rows,
                    mid: sp.0,
                    d2,
                    rad,
                });
            }
            while !s.stopped {
                let Some(e) = stack.pop() else {
                    break;
                };
                if !s.may_hold_better(e.d2, e.rad) {
                    continue;
                }
                // (A node waiting since an earlier search may have lost its surface since.)
                let Some(node) = self.node(e.r).filter(|n| n.surface()) else {
                    continue;
                };
                let Some(b) = node.block() else {
                    // A root that is a leaf (its reach test is done).
                    let p = frame.positions_packed(&e.bary, e.depth);
                    let sp = Self::sphere_of(memo, t, e.index, || p);
                    s.offer_leaf(t, e.index, node, p, sp);
                    continue;
                };
                if e.depth as usize >= MAX_DEPTH {
                    continue;
                }
                // The children kept go straight onto the stack, then that segment is sorted
                // farthest first so the nearest is walked first.
                let first = self.block_ref(b);
                let Some(block) = self.block_nodes(b) else {
                    continue;
                };
                let mut order = [(0.0f32, 0u8); 8];
                let mut kept = 0usize;
                // The children holding surface, their spheres from the memo, and of the ten
                // points of this refinement only the corners of the children whose sphere
                // is not remembered (a third of the children hold surface on a drilled
                // groove); a leaf whose faces are tested gets its corners later.
                let mut kids = 0u8;
                for (c, k) in block.iter().enumerate() {
                    if k.surface() {
                        kids |= 1 << c;
                    }
                }
                // An expansion is never split: when its children do not all fit in the
                // bound, the node waits (on the stack, for a search that goes on).
                if s.nodes.saturating_add(kids.count_ones()) > s.max_nodes {
                    let _ = stack.push(e);
                    s.stopped = true;
                    break;
                }
                let mut remembered = 0u8;
                let mut need = 0u16;
                for c in 0..8u8 {
                    if kids & (1 << c) != 0 {
                        let index = e.index * 8 + 1 + c as u32;
                        match memo.get(t, index) {
                            Some(sp) => {
                                remembered |= 1 << c;
                                if let Some(slot) = spheres.get_mut(c as usize) {
                                    *slot = sp;
                                }
                            }
                            None => need |= CHILD_POINTS[c as usize],
                        }
                    }
                }
                if need != 0 {
                    refinement_points_masked(
                        &frame,
                        &e.bary,
                        e.depth,
                        need,
                        &mut ten_rows,
                        &mut ten,
                    );
                }
                let mut have = need;
                for c in 0..8u8 {
                    if kids & (1 << c) == 0 {
                        continue;
                    }
                    let Some(&child) = block.get(c as usize) else {
                        continue;
                    };
                    let index = e.index * 8 + 1 + c as u32;
                    let sp = match spheres.get(c as usize) {
                        Some(&sp) if remembered & (1 << c) != 0 => sp,
                        _ => {
                            let sp = bounding_sphere(child_of_ten(&ten, c));
                            memo.put(t, index, sp);
                            sp
                        }
                    };
                    if child.is_leaf() {
                        // Leaves are tested at once (no stack round trip), after the same
                        // bound test as an inner node: a leaf that cannot hold a better
                        // triangle costs no triangle tests.
                        if s.nodes >= s.max_nodes {
                            s.stopped = true;
                            break;
                        }
                        s.nodes += 1;
                        let d2 = sp.0.distance_squared(s.centre);
                        if s.may_hold_better(d2, sp.1) && !s.all_cut(d2, sp.1) {
                            let more = CHILD_POINTS[c as usize] & !have;
                            if more != 0 {
                                refinement_points_masked(
                                    &frame,
                                    &e.bary,
                                    e.depth,
                                    more,
                                    &mut ten_rows,
                                    &mut ten,
                                );
                                have |= more;
                            }
                            s.offer_leaf(t, index, child, child_of_ten(&ten, c), sp);
                        }
                        continue;
                    }
                    if let Some((d2, _)) = Self::test_node(&mut s, sp) {
                        // Kept: into `order` by decreasing distance (ties in child order),
                        // its sphere in `spheres`.
                        if let Some(slot) = spheres.get_mut(c as usize) {
                            *slot = sp;
                        }
                        let mut at = kept;
                        while at > 0 && order.get(at - 1).is_some_and(|o| o.0 < d2) {
                            at -= 1;
                        }
                        if let Some(o @ [_, ..]) = order.get_mut(at..=kept) {
                            o.rotate_right(1);
                            o[0] = (d2, c);
                        }
                        kept += 1;
                    }
                }
                // The kept children onto the stack farthest first, so the nearest is walked
                // first (never full: at most 7 entries per level wait, plus 8).
                for &(d2, c) in order.iter().take(kept) {
                    let (mid, rad) = spheres.get(c as usize).copied().unwrap_or_default();
                    let _ = stack.push(Entry {
                        r: first + c as u32,
                        index: e.index * 8 + 1 + c as u32,
                        depth: e.depth + 1,
                        bary: child_packed(&e.bary, c),
                        mid,
                        d2,
                        rad,
                    });
                }
            }
        }
        s
    }

    /// The tests a node holding surface with bounding sphere `(mid, rad)` passes to be kept:
    /// the reach test of [`Hierarchy::for_each_visible_in`], the bound and the cutting rule;
    /// counts one node of work (or stops the search when `max_nodes` are spent). Returns the
    /// squared distance to the sphere's centre and its radius when the node is kept.
    #[inline]
    fn test_node(s: &mut Search, (mid, rad): (Vec3, f32)) -> Option<(f32, f32)> {
        if s.nodes >= s.max_nodes {
            s.stopped = true;
            return None;
        }
        s.nodes += 1;
        let d2 = mid.distance_squared(s.centre);
        let lim = rad + s.reach;
        if d2 > lim * lim || !s.may_hold_better(d2, rad) || s.all_cut(d2, rad) {
            return None;
        }
        Some((d2, rad))
    }
}
