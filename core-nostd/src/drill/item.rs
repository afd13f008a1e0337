//! One item of the drill step ([`Drill::step`]): its node classified against its sphere, then
//! dropped, expanded (the children that meet the sphere queued), refined or erased.

use glam::Vec3;

use super::cost::{DrillParams, WorkCost};
use super::deque::{Ring, FINE_DESCENT};
use super::material::Spend;
use super::sphere::{classify_costed, Class, Sphere};
use super::step::{epoch_of, Drill, DrillReport, Pass, Pending, DEFER_LAG};
use crate::geom::tri_area;
use crate::hierarchy::{
    child_of_refinement, child_of_ten, depth_limit, refinement_points, refinement_points_masked,
    Hierarchy, HierarchyError, Path, RootFrame, ALL_POINTS, MAX_DEPTH,
};
use crate::ids::TetId;
use crate::mesh::template::FACE_VERTS;
use crate::mesh::Mesh;

/// [`super::classify`], charging the exact test when it runs ([`WorkCost::EXACT_TEST`]).
fn classify_charged(p: [Vec3; 4], s: &Sphere, rep: &mut DrillReport) -> Class {
    let (class, exact) = classify_costed(p, s);
    if exact {
        rep.exact_tests += 1;
        rep.work = rep.work.saturating_add(WorkCost::EXACT_TEST);
    }
    class
}

/// A node whose children were queued, with the ten points of its red refinement: its
/// children's corners.
#[derive(Clone, Copy, Debug)]
pub(super) struct Parent {
    tet: TetId,
    index: u32,
    pts: [Vec3; 10],
}

impl Parent {
    /// No node ([`TetId::NONE`] matches no item).
    pub(super) const EMPTY: Self = Self {
        tet: TetId::NONE,
        index: 0,
        pts: [Vec3::ZERO; 10],
    };
}

/// The ten points of a node's refinement: integer barycentric rows and positions.
type Ten = ([u64; 10], [Vec3; 10]);

impl Drill<'_> {
    /// The root frame of `tet` and its tree's depth limit from the resolution, cached across
    /// consecutive items of one tree.
    fn frame(&mut self, mesh: &Mesh<'_>, tet: TetId) -> Option<(RootFrame, u8)> {
        match self.frame {
            Some((t, f, limit)) if t == tet => Some((f, limit)),
            _ => {
                let f = RootFrame::of(mesh, tet)?;
                // Without a resolution nothing is computed: every tree to `max_depth`.
                let limit = if self.resolution > 0.0 {
                    depth_limit(f.longest_edge(), self.resolution)
                } else {
                    MAX_DEPTH as u8
                };
                self.frame = Some((tet, f, limit));
                Some((f, limit))
            }
        }
    }

    /// The corners of `item` at `depth`. Children are queued at the front, so a node's eight
    /// children are taken before any other node of its depth has its children queued: the
    /// parent's refinement points, kept per depth, are still there and a child's corners are
    /// four of them (the same bits as [`RootFrame::positions_packed`] of its own
    /// coordinates). Otherwise (a root, an item carried from an earlier tick whose parent
    /// entry was overwritten) they are evaluated from the item's coordinates.
    ///
    /// # Bounded work
    /// Constant: four look-ups, or four point evaluations.
    fn corners(&self, frame: &RootFrame, item: &Pending, depth: u8) -> [Vec3; 4] {
        if depth > 0 {
            let parent = (item.index - 1) / 8;
            if let Some(q) = self.parents.get(depth as usize - 1) {
                if q.tet == item.tet && q.index == parent {
                    let c = ((item.index - 1) % 8) as u8;
                    return child_of_ten(&q.pts, c);
                }
            }
        }
        frame.positions_packed(&item.bary, depth)
    }

    #[allow(clippy::too_many_arguments)]
    pub(super) fn process(
        &mut self,
        h: &mut Hierarchy<'_>,
        mesh: &Mesh<'_>,
        item: Pending,
        pass: Pass,
        max_depth: u8,
        params: &DrillParams,
        rep: &mut DrillReport,
    ) -> bool {
        let min_area = params.min_area;
        // A reference stays valid until the arena takes back the block holding it (only
        // blocks of erased leaves are taken back, once the fresh ones are used up). When a
        // block has been taken back since the item was queued, the reference may name a node
        // of a reused block: the item is looked up again by its tree index (a collapsed
        // subtree's nodes answer `None`; they were all erased, so the item had nothing left
        // to do).
        if item.epoch != h.reclaimed() && h.find(item.tet, item.index) != Some(item.node) {
            return true;
        }
        let Some(node) = h.node(item.node) else {
            return true;
        };
        if node.all_erased() {
            return true;
        }
        // Material the pressing force does not remove is neither refined nor erased; the
        // burr's unchanged positions are queued again once the backlog is done (as after a
        // full deque), so a burr held still cuts when pressed harder. Once the burr presses
        // nothing, the feed's pool still pays for the queued material its work was done on.
        if !self.admits(item.tet) && !self.admits_paid(mesh, item.tet, max_depth) {
            self.hold(rep);
            return true;
        }
        let Some(depth) = Path::depth_of(item.index) else {
            return true;
        };
        let Some((frame, limit)) = self.frame(mesh, item.tet) else {
            return true;
        };
        let max_depth = max_depth.min(limit);
        let item = match item.index {
            0 => Pending {
                bary: frame.root_packed(),
                ..item
            },
            _ => item,
        };
        let p = self.corners(&frame, &item, depth);
        let class = classify_charged(p, &item.sphere, rep);
        if class == Class::Outside {
            return true;
        }
        if !node.is_leaf() {
            self.queue_children(h, &frame, item, depth, pass, None, rep);
            return true;
        }
        // Inside this sphere: erased at once, never refined.
        let Some(path) = Path::of_index(item.index) else {
            return true;
        };
        if class == Class::Inside {
            self.erase(h, mesh, item, pass, &path, rep);
            return true;
        }
        // Areas are never negative (and `f32::min` skips NaN), so a `min_area` of zero or
        // less passes without computing them; at `max_depth` they are not needed at all.
        let big_enough = || {
            min_area <= 0.0
                || FACE_VERTS
                    .iter()
                    .map(|f| tri_area(p[f[0] as usize], p[f[1] as usize], p[f[2] as usize]))
                    .fold(f32::INFINITY, f32::min)
                    >= min_area
        };
        let refinable = path.depth < max_depth && big_enough();
        // One level above the last: refined in the fine pass (the coarse pass of every sphere
        // comes first). Deferred before the swept test: a leaf inside a later sphere is
        // erased by that sphere's own coarse pass.
        if refinable
            && path.depth + 1 == max_depth
            && pass == Pass::Coarse
            && self.defer(&item, rep)
        {
            return true;
        }
        // Inside another sphere of the swept path (which erases it anyway when its own work
        // arrives): erased at once, never refined.
        if self.inside_swept(&item.sphere, &p, rep) {
            self.erase(h, mesh, item, pass, &path, rep);
            return true;
        }
        if refinable {
            // Not started when its nodes alone would overrun the budget, unless it is the
            // tick's first item (the step always makes progress): the overrun of a tick is
            // then at most an erasure or an expansion, not a refinement.
            if rep.taken > 1 && rep.work.saturating_add(WorkCost::CREATED * 8) > params.budget {
                return false;
            }
            let ten = if path.depth + 1 == max_depth {
                match self.a_child_would_go(&frame, &item, depth, rep) {
                    Some(ten) => Some(ten),
                    None => return true,
                }
            } else {
                None
            };
            match h.refine_at(mesh, item.tet, &path, item.node) {
                Ok(r) => {
                    rep.work = rep
                        .work
                        .saturating_add(WorkCost::VISIT * r.work + WorkCost::CREATED * r.created);
                    rep.visits = rep.visits.saturating_add(r.work);
                    rep.created += r.created;
                    self.queue_children(h, &frame, item, depth, pass, ten, rep);
                    return true;
                }
                Err(HierarchyError::Full) => {
                    // Counted by the hierarchy. The leaf stays: erasing a coarse leaf by its
                    // centroid would move the surface past the burr in one tick (a force
                    // jump); kept, it still bounds the material and the burr feels it.
                    // Not retried here: the arena only gets blocks back when more material
                    // is erased; a later sphere's work reaches the leaf again.
                    return true;
                }
                Err(_) => return true,
            }
        }
        let centroid = (p[0] + p[1] + p[2] + p[3]) * 0.25;
        let r = item.sphere.radius;
        if centroid.distance_squared(item.sphere.center) <= r * r
            || self.point_in_swept(&item.sphere, centroid, rep)
        {
            self.erase(h, mesh, item, pass, &path, rep);
        }
        true
    }

    /// The ten points of `item`'s refinement (rows and positions) when the centroid of one of
    /// its eight children lies inside its sphere or one of the spheres queued after it: refined
    /// to the last level, the leaf would lose that child. `None` otherwise: no child would go
    /// (a child inside a sphere has its centroid inside it), and refining the leaf would only
    /// add nodes. Counted as the expansion that follows the refinement, which takes the points
    /// from here ([`WorkCost::EXPANDED`], charged once).
    fn a_child_would_go(
        &mut self,
        frame: &RootFrame,
        item: &Pending,
        depth: u8,
        rep: &mut DrillReport,
    ) -> Option<Ten> {
        rep.expanded += 1;
        rep.work = rep.work.saturating_add(WorkCost::EXPANDED);
        let (rows, pts) = refinement_points(frame, &item.bary, depth);
        let s = item.sphere;
        let goes = (0..8u8).any(|c| {
            let q = child_of_ten(&pts, c);
            let centroid = (q[0] + q[1] + q[2] + q[3]) * 0.25;
            centroid.distance_squared(s.center) <= s.radius * s.radius
                || self.point_in_swept(&s, centroid, rep)
        });
        goes.then_some((rows, pts))
    }

    /// Leaves `item`'s refinement of the last level to the fine pass: its tree's root against
    /// its sphere goes to the fine ring (once for a run of such leaves of one tree). `false`
    /// when the fine ring has no room for it and a descent (the refinement is then done now).
    fn defer(&mut self, item: &Pending, rep: &mut DrillReport) -> bool {
        let _ = self.swept_after(&item.sphere, rep);
        if self.swept_lag < DEFER_LAG {
            return false;
        }
        if let Some(b) = self.fine.back() {
            if b.tet == item.tet && b.index == 0 && b.sphere == item.sphere {
                return true;
            }
        }
        self.fine.free() > FINE_DESCENT
            && self
                .fine
                .push_back(Pending::root(item.tet, item.sphere, item.epoch))
    }

    fn erase(
        &mut self,
        h: &mut Hierarchy<'_>,
        mesh: &Mesh<'_>,
        item: Pending,
        pass: Pass,
        path: &Path,
        rep: &mut DrillReport,
    ) {
        // A leaf of a rate-limited material waits at the front of its ring until its region
        // has earned its volume; the step stops there.
        match self.spend(mesh, item.tet, path.depth) {
            Spend::Erase => {}
            Spend::Wait => {
                let _ = match pass {
                    Pass::Coarse => self.coarse.push_front(item),
                    Pass::Fine => self.fine.push_front(item),
                };
                self.stalled = true;
                rep.waited = 1;
                return;
            }
            Spend::Drop => {
                self.hold(rep);
                return;
            }
        }
        if let Ok(r) = h.erase_at(mesh, item.tet, path, item.node) {
            rep.work = rep.work.saturating_add(WorkCost::VISIT * r.work);
            rep.visits = rep.visits.saturating_add(r.work);
            rep.erased += 1;
            self.note_removed(item.tet, r.removed);
            self.crumbs.note(item.tet, item.index);
        }
    }

    #[allow(clippy::too_many_arguments)]
    fn queue_children(
        &mut self,
        h: &Hierarchy<'_>,
        frame: &RootFrame,
        item: Pending,
        depth: u8,
        pass: Pass,
        ten: Option<Ten>,
        rep: &mut DrillReport,
    ) {
        let ring = match pass {
            Pass::Coarse => &mut self.coarse,
            Pass::Fine => &mut self.fine,
        };
        if ring.free() < 8 {
            self.saturate(rep);
            return;
        }
        // The 8 children are contiguous: child `c` is `first + c`.
        let Some(first) = h.child(item.node, 0) else {
            return;
        };
        let epoch = epoch_of(h);
        // Points from the last level's child test were counted there.
        if ten.is_none() {
            rep.expanded += 1;
            rep.work = rep.work.saturating_add(WorkCost::EXPANDED);
        }
        let ring = match pass {
            Pass::Coarse => &mut self.coarse,
            Pass::Fine => &mut self.fine,
        };
        match self.parents.get_mut(depth as usize) {
            Some(slot) => {
                slot.tet = item.tet;
                slot.index = item.index;
                let rows = match ten {
                    Some((rows, pts)) => {
                        slot.pts = pts;
                        rows
                    }
                    None => {
                        let mut rows = [0; 10];
                        refinement_points_masked(
                            frame,
                            &item.bary,
                            depth,
                            ALL_POINTS,
                            &mut rows,
                            &mut slot.pts,
                        );
                        rows
                    }
                };
                queue_eight(ring, h, &item, first, epoch, (&rows, &slot.pts), rep);
            }
            None => {
                let (rows, pts) =
                    ten.unwrap_or_else(|| refinement_points(frame, &item.bary, depth));
                queue_eight(ring, h, &item, first, epoch, (&rows, &pts), rep);
            }
        }
    }
}

/// Queues the children of `item` (the eight nodes from `first`) that are not erased and
/// not wholly outside its sphere, at the front of `ring`, the last child first; `ten`: the
/// rows and points of `item`'s refinement.
///
/// # Bounded work
/// Constant: eight node look-ups and up to eight classifications.
fn queue_eight(
    ring: &mut Ring<'_>,
    h: &Hierarchy<'_>,
    item: &Pending,
    first: u32,
    epoch: u32,
    (rows, pts): (&[u64; 10], &[Vec3; 10]),
    rep: &mut DrillReport,
) {
    for c in (0..8u8).rev() {
        // A child wholly outside the sphere, or with nothing left to erase, would be
        // dropped when taken: it is not queued.
        let gone = h.node(first + c as u32).is_none_or(|n| n.all_erased());
        if gone || classify_charged(child_of_ten(pts, c), &item.sphere, rep) == Class::Outside {
            continue;
        }
        let next = Pending {
            tet: item.tet,
            index: item.index * 8 + 1 + c as u32,
            node: first + c as u32,
            bary: child_of_refinement(rows, pts, c).0,
            epoch,
            ..*item
        };
        let _ = ring.push_front(next);
    }
}
