//! Passive sample points (Turini et al. 2006, section 3.2): points of the tool that collide and
//! push back but never erode, such as the samples along a drill's shaft. Each is tracked from tick
//! to tick: the segment from where it was last seen outside the material (its *proxy*) to where the
//! device puts it now is tested against the visible faces near it, so a point that crosses the
//! surface, however fast, is caught at the face it entered and held there (a god-object) until it
//! comes back out in front of that face. It cannot tunnel.
//!
//! [`PassiveProbe`] takes the triangles near one point, one at a time (from any source: a
//! slice, the hierarchy's visible faces near the point), and [`PassiveProbe::finish`] updates
//! the point's [`PassivePoint`]; [`passive_force`] turns the points' planes into one force.

use glam::Vec3;

use super::response::clamp_force;
use super::MAX_PASSIVE;
use crate::geom::closest_point_on_triangle;
use crate::hash::Aabb;
use crate::hierarchy::{bounding_sphere, FaceRef, Hierarchy, SurfaceVisit, VisibleTri};
use crate::ids::TetId;
use crate::mesh::Mesh;

/// One passive point's state, carried from tick to tick.
#[derive(Clone, Copy, PartialEq, Debug, Default)]
pub struct PassivePoint {
    /// Where the point was last seen outside the material, or, while held, its place on the
    /// held face's plane (none before the first tick).
    pub proxy: Option<Vec3>,
    /// The plane `(point on the surface, outward unit normal)` of the face the point crossed:
    /// while set, the point is inside the material and held on this plane.
    pub held: Option<(Vec3, Vec3)>,
    /// The contact plane the servo springs from (the held plane, or the closest visible face
    /// within reach), if any.
    pub plane: Option<(Vec3, Vec3)>,
}

impl PassivePoint {
    /// `true` while the point is held at a face it crossed.
    ///
    /// # Bounded work
    /// Constant.
    pub fn is_held(&self) -> bool {
        self.held.is_some()
    }
}

/// A face's place in the hierarchy, `(coarse tet, tree index, face)`: ties between faces go to
/// the smallest, whatever order they are offered in.
pub(crate) type FaceKey = (u32, u32, u8);

/// The triangles near one passive point, offered one at a time: the first face the segment
/// from the proxy to the new position enters, and the closest face to the new position.
#[derive(Clone, Copy, Debug)]
pub(crate) struct PassiveProbe {
    from: Vec3,
    to: Vec3,
    /// How far from `to` a face may lie and still be offered.
    reach: f32,
    reach2: f32,
    /// First entering crossing: `(s along the segment, point, unit normal, face key)`.
    hit: Option<(f32, Vec3, Vec3, FaceKey)>,
    /// Closest face within reach: `(squared distance, closest point, unit face normal, face
    /// key)`.
    near: Option<(f32, Vec3, Vec3, FaceKey)>,
    triangles: u32,
}

impl PassiveProbe {
    /// A probe for the point `state` moving to `to`, looking for faces within `reach` of
    /// `to` (the point's radius plus how far the servo may extrapolate).
    ///
    /// # Bounded work
    /// Constant.
    pub(crate) fn new(state: &PassivePoint, to: Vec3, reach: f32) -> Self {
        Self {
            from: state.proxy.unwrap_or(to),
            to,
            reach,
            reach2: reach * reach,
            hit: None,
            near: None,
            triangles: 0,
        }
    }

    /// The box around the point's way (its proxy to its position) grown by its reach: no
    /// face outside it is within reach or across the way. `None` when it is not finite.
    ///
    /// # Bounded work
    /// Constant.
    pub(crate) fn zone(&self) -> Option<Aabb> {
        let b = Aabb::point(self.from)
            .union(Aabb::point(self.to))
            .grown(self.reach);
        (b.min.is_finite() && b.max.is_finite()).then_some(b)
    }

    /// The nearest face within reach offered so far, else the face the way enters first.
    ///
    /// # Bounded work
    /// Constant.
    pub(crate) fn nearest_face(&self) -> Option<FaceRef> {
        let (tet, index, face) = self.near.map(|m| m.3).or(self.hit.map(|h| h.3))?;
        Some(FaceRef {
            tet: TetId(tet),
            index,
            face,
        })
    }

    /// [`PassiveProbe::offer`] for a visible face of the hierarchy, keyed by its place.
    ///
    /// # Bounded work
    /// Constant.
    #[inline]
    pub(crate) fn offer_visible(&mut self, tri: &VisibleTri) {
        self.offer(tri.corners, (tri.tet.0, tri.index, tri.face));
    }

    /// Triangles offered so far.
    ///
    /// # Bounded work
    /// Constant.
    pub(crate) fn triangles(&self) -> u32 {
        self.triangles
    }

    /// Offers one outward counter-clockwise triangle, `key` its place. Ties (the same
    /// crossing fraction, the same distance: a segment through a shared edge, a point nearest
    /// a shared corner of a concave step) go to the smallest key, so the answer does not
    /// depend on the order the triangles come in.
    ///
    /// # Bounded work
    /// Constant.
    pub(crate) fn offer(&mut self, [a, b, c]: [Vec3; 3], key: FaceKey) {
        self.triangles = self.triangles.wrapping_add(1);
        let n = (b - a).cross(c - a);
        let d = self.to - self.from;
        let den = n.dot(d);
        // Entering crossing (moving against the outward normal).
        if den < 0.0 {
            let s = n.dot(a - self.from) / den;
            if (0.0..=1.0).contains(&s)
                && self.hit.is_none_or(|h| s < h.0 || (s == h.0 && key < h.3))
            {
                let x = self.from + d * s;
                let inside = (b - a).cross(x - a).dot(n) >= 0.0
                    && (c - b).cross(x - b).dot(n) >= 0.0
                    && (a - c).cross(x - c).dot(n) >= 0.0;
                if inside {
                    self.hit = Some((s, x, n.normalize_or_zero(), key));
                }
            }
        }
        let x = closest_point_on_triangle(self.to, [a, b, c]);
        let d2 = (self.to - x).length_squared();
        if d2 <= self.reach2
            && self
                .near
                .is_none_or(|m| d2 < m.0 || (d2 == m.0 && key < m.3))
        {
            self.near = Some((d2, x, n.normalize_or_zero(), key));
        }
    }

    /// Whether a face inside the sphere `(mid, rad)` could change this probe's answer: the
    /// sphere meets the segment (an entering crossing may lie in it), or it comes within the
    /// distance of the closest face offered so far (within the reach before one is). Ruled
    /// out with a thousandth to spare for rounding, such a face is neither crossed by the
    /// segment nor nearer than the nearest so far, so skipping it leaves the answer of
    /// offering every face (ties go by key, whatever the order).
    ///
    /// # Bounded work
    /// Constant.
    #[inline]
    pub(crate) fn may_need(&self, mid: Vec3, rad: f32) -> bool {
        const SLACK: f32 = 1.001;
        let d = self.to - self.from;
        let len2 = d.length_squared();
        if len2 > 0.0 {
            let t = ((mid - self.from).dot(d) / len2).clamp(0.0, 1.0);
            let r = rad * SLACK;
            if mid.distance_squared(self.from + d * t) <= r * r {
                return true;
            }
        }
        let bound2 = self.near.map_or(self.reach2, |m| m.0);
        let lim = (rad + libm::sqrtf(bound2)) * SLACK;
        mid.distance_squared(self.to) <= lim * lim
    }

    /// The interval along the unit `u` (or zero) outside which, by more than a node's
    /// [`span_slack`], no node is needed ([`PassiveProbe::may_need`]): the projections of
    /// `from` and `to` widened by the reach, with a hundredth and the rounding to spare. A
    /// projection is no longer than the distance it projects, so a node beyond it meets
    /// neither the segment nor the reach of `to`. Unbounded when not finite.
    ///
    /// # Bounded work
    /// Constant.
    pub(crate) fn span_along(&self, u: Vec3) -> (f32, f32) {
        let (a, b) = (self.from.dot(u), self.to.dot(u));
        let size = self.from.abs().max(self.to.abs()).max_element();
        let widen = libm::sqrtf(self.reach2) * SPAN_SLACK + ROUNDING * (1.0 + size);
        let (lo, hi) = (a.min(b) - widen, a.max(b) + widen);
        if lo.is_finite() && hi.is_finite() {
            (lo, hi)
        } else {
            (f32::NEG_INFINITY, f32::INFINITY)
        }
    }

    /// Updates `state` for the point now at `to`:
    ///
    /// - held, and `to` is still behind the held plane: stays held, the proxy slides to
    ///   `to`'s projection on the plane (the faces are not needed);
    /// - otherwise (free, or back in front of the held plane), when the segment from the
    ///   proxy to `to` enters a face: held on that face's plane at the entry point;
    /// - otherwise free: the proxy is `to`, the contact plane the closest face within reach
    ///   (normal from the face towards the point; the face's normal when the point lies on
    ///   it or behind it).
    ///
    /// # Bounded work
    /// Constant.
    pub(crate) fn finish(self, state: &mut PassivePoint) {
        let to = self.to;
        if !to.is_finite() {
            *state = PassivePoint::default();
            return;
        }
        if let Some((q, n)) = state.held {
            let behind = (to - q).dot(n);
            if behind < 0.0 {
                state.proxy = Some(to - n * behind);
                state.plane = state.held;
                return;
            }
            state.held = None;
        }
        if let Some((_, x, n, _)) = self.hit.filter(|h| h.2 != Vec3::ZERO) {
            state.held = Some((x, n));
            state.proxy = Some(x);
            state.plane = state.held;
            return;
        }
        state.proxy = Some(to);
        state.plane = self.near.and_then(|(d2, x, face_n, _)| {
            let v = to - x;
            let n = if d2 > 0.0 && v.dot(face_n) > 0.0 {
                v / libm::sqrtf(d2)
            } else {
                face_n
            };
            (n != Vec3::ZERO).then_some((x, n))
        });
    }
}

/// [`PassiveProbe::may_need`]'s slack (1/1000) and a hundredth more, for the spans along
/// the walkers' line ([`PassiveProbe::span_along`]).
const SPAN_SLACK: f32 = 1.001 * 1.01;

/// Rounding allowed per unit of a coordinate's size in a span's test: far above `f32`'s,
/// so a span never rules out what `may_need` would keep.
const ROUNDING: f32 = 1e-5;

/// How far the sphere `(mid, rad)` reaches beyond its centre's projection on the walkers'
/// line, with the spans' slack and rounding ([`PassiveProbe::span_along`]).
fn span_slack(mid: Vec3, rad: f32) -> f32 {
    rad * SPAN_SLACK + ROUNDING * (1.0 + mid.abs().max_element())
}

/// Passive points walking the drilled surface together, bit `k` of a walk's mask for
/// `probes[k]`: a point goes on into a node while [`PassiveProbe::may_need`] its faces.
/// The cheap test first: a node whose projection on the line the points spread along
/// (`axis`, from the first point to the last; zero for one point) lies beyond a point's
/// span (`spans[k]`, [`PassiveProbe::span_along`]) cannot be needed by it; a shaft's points
/// lie on a line, so at a tree's root most are ruled out so, not by `may_need`.
struct Probes<'p> {
    probes: &'p mut [Option<PassiveProbe>; MAX_PASSIVE],
    axis: Vec3,
    spans: [(f32, f32); MAX_PASSIVE],
    /// Nodes the walk may still enter.
    left: u32,
    /// Nodes entered.
    entered: u32,
    /// The walk wanted a node past the limit and ended.
    cut: bool,
}

impl<'p> Probes<'p> {
    /// The walkers of `probes` with bits in `want`, their spans along the line from the
    /// first to the last, entering at most `max_nodes` nodes.
    ///
    /// # Bounded work
    /// O([`MAX_PASSIVE`]).
    fn new(probes: &'p mut [Option<PassiveProbe>; MAX_PASSIVE], want: u32, max_nodes: u32) -> Self {
        let walkers = || {
            probes
                .iter()
                .enumerate()
                .filter(|(k, _)| want & (1u32 << k) != 0)
                .filter_map(|(_, p)| p.as_ref())
        };
        let axis = match (walkers().next(), walkers().next_back()) {
            (Some(a), Some(b)) => (b.to - a.to).normalize_or_zero(),
            _ => Vec3::ZERO,
        };
        let mut spans = [(f32::NEG_INFINITY, f32::INFINITY); MAX_PASSIVE];
        for (span, probe) in spans.iter_mut().zip(probes.iter()) {
            if let Some(probe) = probe {
                *span = probe.span_along(axis);
            }
        }
        Self {
            probes,
            axis,
            spans,
            left: max_nodes,
            entered: 0,
            cut: false,
        }
    }
}

impl SurfaceVisit for Probes<'_> {
    #[inline]
    fn enter(&mut self, p: &[Vec3; 4], mask: u32) -> u32 {
        let Some(left) = self.left.checked_sub(1) else {
            self.cut = true;
            return 0;
        };
        self.left = left;
        self.entered += 1;
        let (mid, rad) = bounding_sphere(*p);
        let (s, slack) = (mid.dot(self.axis), span_slack(mid, rad));
        let (mut kept, mut rest) = (mask, mask);
        while rest != 0 {
            let k = rest.trailing_zeros() as usize;
            rest &= rest - 1;
            let within = self
                .spans
                .get(k)
                .is_some_and(|&(lo, hi)| s + slack >= lo && s - slack <= hi);
            let needs = within
                && self
                    .probes
                    .get(k)
                    .and_then(Option::as_ref)
                    .is_some_and(|probe| probe.may_need(mid, rad));
            if !needs {
                kept &= !(1u32 << k);
            }
        }
        kept
    }

    #[inline]
    fn face(&mut self, mask: u32, tri: VisibleTri) {
        let mut rest = mask;
        while rest != 0 {
            let k = rest.trailing_zeros() as usize;
            rest &= rest - 1;
            if let Some(Some(probe)) = self.probes.get_mut(k) {
                probe.offer_visible(&tri);
            }
        }
    }

    #[inline]
    fn stop(&self) -> bool {
        self.cut
    }
}

/// What one [`offer_near`] walked.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default)]
pub(crate) struct Walked {
    /// Nodes entered (each tested against the walkers).
    pub nodes: u32,
    /// The walk wanted more than its limit of nodes and ended there: the probes were not
    /// offered every face they may need.
    pub cut: bool,
}

/// Offers each probe `probes[k]` whose bit `k` of `want` is set the visible faces of the
/// trees of `tets` that may change its answer, each tree walked once for all of them
/// ([`Hierarchy::walk_surface`], pruned by [`PassiveProbe::may_need`] as the probes learn):
/// each probe answers as if it had been offered every visible face of those trees, unless
/// the walk is cut. A tree `keep` refuses is not walked (the caller's to say it holds no
/// face a probe may need).
///
/// # Bounded work
/// At most `max_nodes` nodes entered (the walk ends at the first node past them and says
/// so: [`Walked::cut`]), each O(probes that may need it), at most [`MAX_PASSIVE`] probes;
/// one `keep` per tree of `tets` before the cut.
pub(crate) fn offer_near(
    hier: &Hierarchy<'_>,
    mesh: &Mesh<'_>,
    tets: &[TetId],
    probes: &mut [Option<PassiveProbe>; MAX_PASSIVE],
    (want, max_nodes): (u32, u32),
    mut keep: impl FnMut(TetId) -> bool,
) -> Walked {
    let mut walkers = Probes::new(probes, want, max_nodes);
    for tet in tets {
        if walkers.cut {
            break;
        }
        if keep(*tet) {
            hier.walk_surface(mesh, core::slice::from_ref(tet), want, &mut walkers);
        }
    }
    Walked {
        nodes: walkers.entered,
        cut: walkers.cut,
    }
}

/// The spring force of passive points of `radius` at `positions` from their planes
/// (`points[i].plane`, paired with `positions[i]`): for each, `stiffness * depth` along the
/// plane's normal with `depth = radius - (position - plane point) . normal` when positive,
/// summed and clamped to `max_force`. Also returns how many points push.
///
/// # Bounded work
/// O(points).
pub(crate) fn passive_force(
    points: &[PassivePoint],
    positions: &[Vec3],
    radius: f32,
    stiffness: f32,
    max_force: f32,
) -> (Vec3, u32) {
    let mut f = Vec3::ZERO;
    let mut touching = 0u32;
    for (pt, &p) in points.iter().zip(positions) {
        if let Some((q, n)) = pt.plane {
            let depth = radius - (p - q).dot(n);
            if depth > 0.0 {
                f += n * (stiffness * depth);
                touching += 1;
            }
        }
    }
    (clamp_force(f, max_force), touching)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The square `x = 0`, `|y|, |z| <= 1`, outward normal +x (material at `x < 0`), and the
    /// square `x = -0.1` facing -x: a slab 0.1 thick.
    fn slab() -> [[Vec3; 3]; 4] {
        let v = |x: f32, y: f32, z: f32| Vec3::new(x, y, z);
        [
            [v(0., -1., -1.), v(0., 1., -1.), v(0., 1., 1.)],
            [v(0., -1., -1.), v(0., 1., 1.), v(0., -1., 1.)],
            [v(-0.1, -1., -1.), v(-0.1, 1., 1.), v(-0.1, 1., -1.)],
            [v(-0.1, -1., -1.), v(-0.1, -1., 1.), v(-0.1, 1., 1.)],
        ]
    }

    fn step(pt: &mut PassivePoint, to: Vec3, reach: f32) {
        let mut probe = PassiveProbe::new(pt, to, reach);
        for (k, t) in (0u32..).zip(slab()) {
            probe.offer(t, (0, k, 0));
        }
        probe.finish(pt);
    }

    #[test]
    fn a_point_that_jumps_through_a_thin_slab_is_held_at_the_face_it_entered() {
        let mut pt = PassivePoint::default();
        step(&mut pt, Vec3::new(0.5, 0.2, 0.0), 0.05);
        assert_eq!(pt.plane, None, "nothing within reach");
        // One tick later it is past the slab: the segment entered the face at x = 0.
        step(&mut pt, Vec3::new(-0.5, 0.2, 0.0), 0.05);
        let (q, n) = pt.held.expect("held");
        assert!((q - Vec3::new(0.0, 0.2, 0.0)).length() < 1e-6);
        assert_eq!(n, Vec3::X);
        let (f, k) = passive_force(&[pt], &[Vec3::new(-0.5, 0.2, 0.0)], 0.05, 100.0, 1e3);
        assert_eq!(k, 1);
        assert!((f - Vec3::new(55.0, 0.0, 0.0)).length() < 1e-3, "{f}");
        // Sliding behind the face: still held, the proxy on the plane.
        step(&mut pt, Vec3::new(-0.3, -0.4, 0.1), 0.05);
        assert!(pt.is_held());
        assert!((pt.proxy.unwrap() - Vec3::new(0.0, -0.4, 0.1)).length() < 1e-6);
        // Back out in front: released, free, the closest face within reach is the plane.
        step(&mut pt, Vec3::new(0.03, -0.4, 0.1), 0.05);
        assert!(!pt.is_held());
        let (q, n) = pt.plane.expect("a face within reach");
        assert!(
            (q - Vec3::new(0.0, -0.4, 0.1)).length() < 1e-5 && (n - Vec3::X).length() < 1e-5,
            "{pt:?}"
        );
        let (f, _) = passive_force(&[pt], &[Vec3::new(0.03, -0.4, 0.1)], 0.05, 100.0, 1e3);
        assert!((f.x - 2.0).abs() < 1e-3 && f.y.abs() < 1e-3, "{f}");
    }

    #[test]
    fn leaving_the_material_is_not_a_hit_and_far_faces_give_no_plane() {
        let mut pt = PassivePoint {
            proxy: Some(Vec3::new(-0.05, 0.0, 0.0)),
            ..PassivePoint::default()
        };
        // From inside the slab out through x = 0: an exit, not an entry.
        step(&mut pt, Vec3::new(0.5, 0.0, 0.0), 0.05);
        assert!(!pt.is_held());
        assert_eq!(pt.plane, None);
        assert_eq!(pt.proxy, Some(Vec3::new(0.5, 0.0, 0.0)));
        // Non-finite positions forget everything.
        step(&mut pt, Vec3::NAN, 0.05);
        assert_eq!(pt, PassivePoint::default());
    }

    /// A concave step: the floor `z = 0` for `x` in [0, 1] (outward +z) and the wall `x = 0`
    /// for `z` in [0, 1] (outward +x), sharing the edge on the y axis, and a face far away.
    fn step_faces() -> [[Vec3; 3]; 3] {
        let v = |x: f32, y: f32, z: f32| Vec3::new(x, y, z);
        [
            [v(0., 0., 0.), v(1., 0., 0.), v(0., 1., 0.)],
            [v(0., 0., 0.), v(0., 1., 0.), v(0., 0., 1.)],
            [v(5., 5., 5.), v(6., 5., 5.), v(5., 6., 5.)],
        ]
    }

    /// Every order of `faces` (keys `(0, k, 0)` for face `k`, whatever its place), and
    /// `to` reached from `from`: the point's state after each order.
    fn in_every_order(faces: [[Vec3; 3]; 3], from: Vec3, to: Vec3) -> [PassivePoint; 6] {
        let orders = [
            [0, 1, 2],
            [0, 2, 1],
            [1, 0, 2],
            [1, 2, 0],
            [2, 0, 1],
            [2, 1, 0],
        ];
        orders.map(|order| {
            let mut pt = PassivePoint {
                proxy: Some(from),
                ..PassivePoint::default()
            };
            let mut probe = PassiveProbe::new(&pt, to, 0.5);
            for k in order {
                probe.offer(faces[k], (0, k as u32, 0));
            }
            probe.finish(&mut pt);
            pt
        })
    }

    /// Ties go to the smallest key, so the order the faces come in (a walk over the trees in
    /// any order) changes nothing: a point behind both faces of the step, nearest their
    /// shared edge (the same distance to each, each giving its own normal), and a segment
    /// that enters both at their shared edge (the same crossing fraction).
    #[test]
    fn ties_go_to_the_smallest_key_in_any_order() {
        let faces = step_faces();
        let behind = Vec3::new(-0.25, 0.25, -0.25);
        let near = in_every_order(faces, behind, behind);
        for pt in near {
            assert_eq!(pt, near[0]);
        }
        // Face 0 (the floor) wins the tie: its normal, from behind it.
        assert_eq!(near[0].plane, Some((Vec3::new(0.0, 0.25, 0.0), Vec3::Z)));
        let crossing = in_every_order(
            faces,
            Vec3::new(0.5, 0.25, 0.5),
            Vec3::new(-0.5, 0.25, -0.5),
        );
        for pt in crossing {
            assert_eq!(pt, crossing[0]);
        }
        assert_eq!(
            crossing[0].held,
            Some((Vec3::new(0.0, 0.25, 0.0), Vec3::Z)),
            "held at the floor, entered at the shared edge"
        );
        // With the keys swapped, the wall wins the same ties.
        let swapped = [faces[1], faces[0], faces[2]];
        let near = in_every_order(swapped, behind, behind);
        assert_eq!(near[0].plane, Some((Vec3::new(0.0, 0.25, 0.0), Vec3::X)));
    }
}
