//! A drill's shaft in the [`World`]: its passive points tracked against the drilled surface
//! each simulation step ([`World::simulate_drill`], [`World::track_passive`]), and the force
//! of the burr and the shaft together ([`drill_force`]).

use glam::Vec3;

use super::{servo_force, ContactState, SimReport, World, SHAFT_NODE_UNITS, SHAFT_RESERVE_MIN};
use crate::drill::DrillParams;
use crate::force::{
    clamp_force, damping_force, offer_near, passive_force, DrillTool, ForceParams, PassivePoint,
    PassiveProbe, ToolState, Walked, MAX_PASSIVE,
};
use crate::hash::{cells_in, Aabb, Cell};
use crate::hierarchy::FaceRef;
use crate::ids::TetId;

/// What one `World::track_passive` did.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default)]
pub struct PassiveReport {
    /// Passive points tracked.
    pub points: u32,
    /// Of them, held at a face they crossed.
    pub held: u32,
    /// Of them, with a contact plane (a face within reach, or held).
    pub near: u32,
    /// Visible triangles offered to the points' probes.
    pub triangles: u32,
    /// Hierarchy nodes the points' walk entered.
    pub nodes: u32,
    /// The walk hit its node bound ([`World::set_shaft_max_nodes`]) and was cut: the points
    /// it was for keep the state of the last step they were tracked in.
    pub cut: bool,
    /// Points that needed the walk and were left with the last step's state (the walk cut,
    /// or the point not in this step's group).
    pub stale: u32,
}

/// Which passive points a bounded walk takes next ([`World::set_shaft_max_nodes`]): `span`
/// points from `next` on, round the ring of points.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default)]
pub struct ShaftWalk {
    /// The first point of the next group.
    pub next: u8,
    /// How many points the next group holds; zero: all.
    pub span: u8,
}

impl ShaftWalk {
    /// The bits of the group of `n` points this step walks.
    ///
    /// # Bounded work
    /// Constant.
    fn group(&self, n: usize) -> u32 {
        let all = if n >= 32 { u32::MAX } else { (1u32 << n) - 1 };
        let span = usize::from(self.span);
        if span == 0 || span >= n {
            return all;
        }
        // next, span < n <= 32: the run fits a u64, and its bits past the last point wrap
        // round to the first.
        let run = ((1u64 << span) - 1) << (usize::from(self.next) % n);
        ((run | run >> n) as u32) & all
    }

    /// The next step's group after this one's walk: on past the group when it was walked
    /// whole, twice as many if the walk took at most half its bound (`roomy`), as many
    /// otherwise; half as many when it was cut (one point alone: the next one).
    ///
    /// # Bounded work
    /// Constant.
    fn after(&mut self, n: usize, cut: bool, roomy: bool) {
        if n == 0 {
            return;
        }
        let span = match usize::from(self.span) {
            0 => n,
            s => s.min(n),
        };
        let next = usize::from(self.next) % n;
        let (next, span) = match (cut, span) {
            (false, _) if roomy => ((next + span) % n, (span * 2).min(n)),
            (false, _) => ((next + span) % n, span),
            (true, 1) => ((next + 1) % n, 1),
            (true, _) => (next, span / 2),
        };
        // At most MAX_PASSIVE (32) points: both fit a byte.
        self.next = next as u8;
        self.span = if span >= n { 0 } else { span as u8 };
    }
}

/// A drill's passive points and the state they carry from step to step.
#[derive(Clone, Copy, PartialEq, Debug)]
pub struct DrillState {
    /// Each passive point's proxy, held plane and contact plane.
    pub points: [PassivePoint; MAX_PASSIVE],
    /// The passive points' positions at the last step.
    pub positions: [Vec3; MAX_PASSIVE],
    /// How many of `points` and `positions` are in use.
    pub count: usize,
    /// The points the next bounded walk takes ([`World::set_shaft_max_nodes`]).
    pub walk: ShaftWalk,
    /// Each point's nearest face within reach at the step it was last tracked (else the face
    /// it crossed): the next walk for it starts with that face, if still visible, as its
    /// nearest so far (`World::track_passive`).
    pub nearest: [Option<FaceRef>; MAX_PASSIVE],
}

impl Default for DrillState {
    fn default() -> Self {
        Self {
            points: [PassivePoint::default(); MAX_PASSIVE],
            positions: [Vec3::ZERO; MAX_PASSIVE],
            count: 0,
            walk: ShaftWalk::default(),
            nearest: [None; MAX_PASSIVE],
        }
    }
}

impl DrillState {
    /// The points in use.
    ///
    /// # Bounded work
    /// Constant.
    pub fn points(&self) -> &[PassivePoint] {
        &self.points[..self.count.min(MAX_PASSIVE)]
    }
}

impl World<'_> {
    /// One simulation step for a drill: the burr exactly as [`World::simulate`] (it alone is
    /// drilled), then the candidate list refilled with the tets near the shaft's points and
    /// their proxies (`World::shaft_candidates`), then the shaft's passive points at
    /// `centre + axis * offset` tracked by `World::track_passive`. `reach` is the burr's; the
    /// shaft's points get [`DrillTool::shaft_reach`] of it.
    ///
    /// # Bounded work
    /// [`World::simulate`]'s bound, the shaft's zone queries (at most one a point, each at
    /// most [`World::max_cells`] cells, together at most the candidate list), and
    /// `World::track_passive`'s bound for at most [`MAX_PASSIVE`] points.
    #[allow(clippy::too_many_arguments)]
    pub fn simulate_drill(
        &mut self,
        tool: &DrillTool,
        centre: Vec3,
        axis: Vec3,
        reach: f32,
        drill_on: bool,
        params: &DrillParams,
        state: &mut DrillState,
    ) -> (SimReport, PassiveReport) {
        let mut rep = self.simulate(centre, tool.burr_radius, reach, drill_on, params);
        let shaft_reach = tool.shaft_reach(reach);
        let (prep, saturated) = self.track_shaft(tool, centre, axis, shaft_reach, state);
        rep.candidates_saturated |= saturated;
        (rep, prep)
    }

    /// The shaft's half of [`World::simulate_drill`], also for a step that drilled the burr
    /// some other way (a real-time task's swept spheres, [`World::simulate_spheres`]): the
    /// tets near each passive point of `tool` (burr at `centre`, shaft along the unit `axis`)
    /// and near its proxy (`World::shaft_candidates`), then the points tracked against them
    /// (`World::track_passive`). `reach` is the shaft's own ([`DrillTool::shaft_reach`] of
    /// the burr's, as [`World::simulate_drill`] passes it). Returns the tracking's report and
    /// whether the candidate storage saturated. Passive points never erode.
    ///
    /// # Bounded work
    /// At most one zone query per point (each at most [`World::max_cells`] cells; together
    /// at most the candidate storage's entries), a sort of the tets they list, and
    /// `World::track_passive`'s bound for at most [`MAX_PASSIVE`] points.
    pub fn track_shaft(
        &mut self,
        tool: &DrillTool,
        centre: Vec3,
        axis: Vec3,
        reach: f32,
        state: &mut DrillState,
    ) -> (PassiveReport, bool) {
        let mut pos = [Vec3::ZERO; MAX_PASSIVE];
        let n = tool.passive_positions(centre, axis, &mut pos);
        let grow = tool.shaft_radius + reach;
        let mut zones = [None; MAX_PASSIVE];
        for ((z, p), pt) in zones.iter_mut().zip(&pos).zip(&state.points).take(n) {
            let mut b = Aabb::point(*p).grown(grow);
            if let Some(q) = pt.proxy.filter(|q| q.is_finite()) {
                b = b.union(Aabb::point(q).grown(grow));
            }
            *z = Some(b).filter(|b| b.min.is_finite() && b.max.is_finite());
        }
        state.count = n;
        state.positions = pos;
        let saturated = self.shaft_candidates(zones.get(..n).unwrap_or_default());
        let given = self.shaft_bound();
        let prep = self.track_passive(
            pos.get(..n).unwrap_or_default(),
            tool.shaft_radius,
            reach,
            &mut state.points,
            &mut state.walk,
            &mut state.nearest,
        );
        self.hold_for_shaft(given, &prep);
        (prep, saturated)
    }

    /// The hold for the next shaft walk after one that had `given` nodes
    /// ([`World::shaft_reserve`]).
    ///
    /// # Bounded work
    /// Constant.
    fn hold_for_shaft(&mut self, given: Option<u32>, walk: &PassiveReport) {
        self.shaft_reserve = match (self.tick_budget, self.shaft_max_nodes, given) {
            (Some(t), Some(max), Some(given)) => {
                let hold = if walk.cut {
                    given.saturating_mul(2).max(SHAFT_RESERVE_MIN)
                } else {
                    walk.nodes.max(self.shaft_reserve - self.shaft_reserve / 8)
                };
                hold.min(max).min(t / 3 / SHAFT_NODE_UNITS)
            }
            _ => 0,
        };
    }

    /// Fills the candidate storage with the tets whose boxes meet one of `zones` (`None`:
    /// no zone), each once, in ascending order ([`World::candidates`]). With a candidate
    /// gather ([`World::set_zone_gather`]) they take the first third of the storage and leave
    /// the gather's; without, all of it. Returns `true` (and counts
    /// `saturations().candidates`) when the storage filled up or a zone covered more than
    /// [`World::max_cells`] cells: the tets of the zones after are what fitted. The next
    /// simulation step refills the storage for the burr.
    ///
    /// A shaft's points spread along a segment, and their zones overlap. Consecutive zones
    /// are queried as one box while that box covers no more hash cells than the zones do
    /// together (each cell counted once, as far as a zone overlaps the one before it) and no
    /// more than [`World::max_cells`]: an upright or axis-aligned shaft's zones make one thin
    /// box, a tilted shaft's one per zone or a few. So the query never lists the tets of a
    /// box around a tilted shaft, which would cost each listed tree a root check for every
    /// point (on a 0.3 shaft in the teddy, a tick's p99 of 650 us), and a tet meeting
    /// several zones of one box is listed once. Sorted, each is listed once, and
    /// `World::track_passive` walks its tree once for them all.
    ///
    /// # Bounded work
    /// Per zone, constant work to group it and at most one query of O(max cells + hash
    /// entries met); then O(m log m) for the m tets listed (at most the storage).
    pub(crate) fn shaft_candidates(&mut self, zones: &[Option<Aabb>]) -> bool {
        let room = match self.zone {
            Some(_) => self.candidates.len() / 3,
            None => self.candidates.len(),
        };
        self.cand_at = 0;
        let (cands, mesh, hash, boxes, max_cells) = (
            self.candidates.get_mut(..room).unwrap_or_default(),
            &self.mesh,
            &self.hash,
            &self.boxes,
            self.max_cells,
        );
        let (mut at, mut saturated) = (0usize, false);
        let mut query = |zone: &Aabb| {
            let mut full = false;
            let visited = hash.query_box_once(zone, max_cells, |item| {
                let t = TetId(item);
                if full || t.idx() >= mesh.tet_count() {
                    return;
                }
                let meets = match boxes.get(t.idx()) {
                    Some(b) => b.overlaps(zone),
                    None => zone.overlaps_points(&mesh.tet_positions(t)),
                };
                if !meets {
                    return;
                }
                match cands.get_mut(at) {
                    Some(c) => {
                        *c = t;
                        at += 1;
                    }
                    None => full = true,
                }
            });
            saturated |= full || !visited;
        };
        let mut group: Option<ZoneGroup> = None;
        for zone in zones.iter().flatten() {
            let cells = hash.cell_range(zone);
            group = Some(match group {
                Some(g) => g.grown(zone, cells, max_cells).unwrap_or_else(|| {
                    query(&g.bounds);
                    ZoneGroup::new(*zone, cells)
                }),
                None => ZoneGroup::new(*zone, cells),
            });
        }
        if let Some(g) = group {
            query(&g.bounds);
        }
        let listed = cands.get_mut(..at).unwrap_or_default();
        listed.sort_unstable();
        self.ncand = dedup_sorted(listed);
        if saturated {
            self.sat.candidates += 1;
        }
        saturated
    }

    /// Tracks passive points of `radius` now at `positions` (`points[i]` for
    /// `positions[i]`) against the drilled surface: each point's [`PassiveProbe`] is offered
    /// the visible faces of the candidate trees ([`World::candidates`], as
    /// [`World::shaft_candidates`] leaves them) that may change its answer (`offer_near`: the
    /// trees walked once for all the points, a point going into a node while its bounding
    /// sphere meets the segment from the point's proxy to its position or comes within the
    /// closest face found so far, at first `radius + reach`); a point held at a face and
    /// still behind it needs none. A point's walk starts from its face in `nearest` (its
    /// nearest face at the step it was last tracked), offered first if still visible, so
    /// the walk goes only where a face may be nearer still; `nearest` then holds the new
    /// nearest face of each point walked. Each point answers as if offered every face of
    /// those trees. Passive points never erode.
    ///
    /// With a shaft bound ([`World::shaft_bound`]: the node bound, and under a tick budget
    /// what the simulation step left of it) the walk is for the group of points `walk` names
    /// (all of them at first) and enters at most that many nodes. Walked
    /// whole, its points answer as above and the next group follows it, twice as large when
    /// the walk took at most half the bound, as large otherwise; cut at the bound, its points
    /// keep the state of the last step they were tracked in (their proxies where they were
    /// then, so the next walk tests the whole way since) and the next group is half as large
    /// (one point alone: the next one). A point held and still behind its face is tracked
    /// whatever the group. So a step's walk is bounded, and every point is tracked again
    /// within a few steps unless one point alone needs more than the bound (its way from its
    /// proxy grows while it waits).
    ///
    /// # Bounded work
    /// O(candidates + hierarchy nodes holding surface that a point may need, times the points
    /// that may need each), at most [`MAX_PASSIVE`] points, and one O(depth) look-up of each
    /// walked point's last nearest face; with a shaft bound, at most that many nodes entered
    /// (one root check per candidate tree besides).
    pub(crate) fn track_passive(
        &self,
        positions: &[Vec3],
        radius: f32,
        reach: f32,
        points: &mut [PassivePoint],
        walk: &mut ShaftWalk,
        nearest: &mut [Option<FaceRef>; MAX_PASSIVE],
    ) -> PassiveReport {
        let mut rep = PassiveReport::default();
        let reach = radius
            + if reach.is_finite() {
                reach.max(0.0)
            } else {
                0.0
            };
        let n = positions.len().min(points.len()).min(MAX_PASSIVE);
        let bound = self.shaft_bound();
        let group = match bound {
            Some(_) => walk.group(n),
            None => u32::MAX,
        };
        let mut probes = [None; MAX_PASSIVE];
        let mut want = 0u32;
        for (k, (probe, ((pt, &p), seed))) in probes
            .iter_mut()
            .zip(points.iter().zip(positions).zip(nearest.iter()))
            .take(n)
            .enumerate()
        {
            let still_held = pt.held.is_some_and(|(q, n)| (p - q).dot(n) < 0.0);
            let mut probe_k = PassiveProbe::new(pt, p, reach);
            if !still_held && p.is_finite() {
                want |= 1 << k;
                // The face nearest at the last step, still visible, offered first: the walk
                // then goes only where a face may be nearer still. Offered again by the walk,
                // it changes nothing (the same distance and key), so the answer is the walk's
                // alone, whatever the seed.
                if let Some(tri) = seed
                    .filter(|_| group & (1 << k) != 0)
                    .and_then(|key| self.hier.visible_face(&self.mesh, key))
                {
                    probe_k.offer_visible(&tri);
                }
            }
            *probe = Some(probe_k);
        }
        let walked = if want & group != 0 {
            let bound = bound.unwrap_or(u32::MAX);
            // A group short of the points that need the walk goes only into the trees that
            // meet one of its points' zones (the box around the point and its proxy, grown
            // by the reach, as the candidates were listed): no other tree holds a face within
            // its reach or across its way.
            let mut zones = [None; MAX_PASSIVE];
            let mut part = want & !group != 0;
            if part {
                for (k, (z, probe)) in zones.iter_mut().zip(&probes).enumerate().take(n) {
                    if want & group & (1 << k) != 0 {
                        *z = probe.as_ref().and_then(PassiveProbe::zone);
                        // A way that is not finite: every tree, as for the whole shaft.
                        part &= z.is_some();
                    }
                }
            }
            let (hier, mesh, boxes) = (&self.hier, &self.mesh, &self.boxes);
            let keep = |t: TetId| {
                !part
                    || zones.iter().flatten().any(|z| match boxes.get(t.idx()) {
                        Some(b) => b.overlaps(z),
                        None => z.overlaps_points(&mesh.tet_positions(t)),
                    })
            };
            let cands = self.candidates();
            offer_near(hier, mesh, cands, &mut probes, (want & group, bound), keep)
        } else {
            Walked::default()
        };
        if let Some(bound) = bound {
            walk.after(n, walked.cut, walked.nodes <= bound / 2);
        }
        // Tracked: the points that need no walk, and the walked group unless it was cut.
        let tracked = !want | if walked.cut { 0 } else { group };
        rep.nodes = walked.nodes;
        rep.cut = walked.cut;
        for (k, ((pt, probe), seed)) in points
            .iter_mut()
            .zip(&probes)
            .zip(nearest.iter_mut())
            .take(n)
            .enumerate()
        {
            let Some(probe) = probe else { continue };
            rep.points += 1;
            if tracked & (1 << k) == 0 {
                rep.stale += 1;
            } else {
                rep.triangles = rep.triangles.wrapping_add(probe.triangles());
                if want & (1 << k) != 0 {
                    *seed = probe.nearest_face();
                }
                probe.finish(pt);
            }
            rep.held += pt.is_held() as u32;
            rep.near += pt.plane.is_some() as u32;
        }
        rep
    }
}

/// Consecutive shaft zones queried as one box (`World::shaft_candidates`).
#[derive(Clone, Copy)]
struct ZoneGroup {
    /// The box around the zones.
    bounds: Aabb,
    /// Its hash cells (inclusive range).
    cells: (Cell, Cell),
    /// The cells the zones cover, each counted once as far as a zone overlaps only the one
    /// before it (exact for equal zones along a line).
    cover: u64,
    /// The last zone's cells.
    last: (Cell, Cell),
}

impl ZoneGroup {
    /// The group of `zone` alone, covering `cells`.
    fn new(zone: Aabb, cells: (Cell, Cell)) -> Self {
        Self {
            bounds: zone,
            cells,
            cover: cells_in(cells.0, cells.1),
            last: cells,
        }
    }

    /// The group with `zone` (covering `cells`) added, if its box then covers no more cells
    /// than its zones do and at most `max_cells`.
    ///
    /// # Bounded work
    /// Constant.
    fn grown(&self, zone: &Aabb, cells: (Cell, Cell), max_cells: u32) -> Option<Self> {
        let alone = cells_in(cells.0, cells.1);
        let shared = cells_in(
            max_cell(cells.0, self.last.0),
            min_cell(cells.1, self.last.1),
        );
        let cover = self.cover.saturating_add(alone - shared.min(alone));
        let hull = (
            min_cell(self.cells.0, cells.0),
            max_cell(self.cells.1, cells.1),
        );
        let n = cells_in(hull.0, hull.1);
        (n <= cover && n <= u64::from(max_cells)).then(|| Self {
            bounds: self.bounds.union(*zone),
            cells: hull,
            cover,
            last: cells,
        })
    }
}

/// The smaller of each coordinate.
fn min_cell(a: Cell, b: Cell) -> Cell {
    [a[0].min(b[0]), a[1].min(b[1]), a[2].min(b[2])]
}

/// The larger of each coordinate.
fn max_cell(a: Cell, b: Cell) -> Cell {
    [a[0].max(b[0]), a[1].max(b[1]), a[2].max(b[2])]
}

/// Keeps the first of each run of equal entries of the sorted `s` at its front; returns how
/// many are kept.
///
/// # Bounded work
/// O(len).
fn dedup_sorted(s: &mut [TetId]) -> usize {
    let mut kept = 0usize;
    for i in 0..s.len() {
        let (Some(&t), last) = (s.get(i), kept.checked_sub(1).and_then(|j| s.get(j))) else {
            continue;
        };
        if last != Some(&t) {
            if let Some(slot) = s.get_mut(kept) {
                *slot = t;
            }
            kept += 1;
        }
    }
    kept
}

/// The force at a drill's handle, and the burr's part of it (what presses the burr against the
/// material: [`World::set_pressing`]): the burr's ([`servo_force`] from `contact`, with `burr`'s
/// state) plus the shaft's passive points' springs (`passive_force` at the points'
/// positions for the burr at `centre` along `axis`, from the planes of the last step) and,
/// while one of them pushes, damping of the tool's motion (`shaft`'s state), clamped.
///
/// All the forces are added as one force at the handle, torque-free: the devices rendered
/// here have 3 actuated degrees of freedom (position), so a moment about the handle, which a
/// shaft pushed at one end would produce, cannot be displayed and is dropped.
///
/// # Bounded work
/// O([`MAX_PASSIVE`]). Never allocates or panics.
#[allow(clippy::too_many_arguments)]
pub fn drill_force(
    contact: &ContactState,
    tool: &DrillTool,
    centre: Vec3,
    axis: Vec3,
    state: &DrillState,
    burr: &mut ToolState,
    shaft: &mut ToolState,
    params: &ForceParams,
) -> (Vec3, Vec3) {
    let f = servo_force(contact, centre, tool.burr_radius, burr, params);
    let mut pos = [Vec3::ZERO; MAX_PASSIVE];
    let n = tool
        .passive_positions(centre, axis, &mut pos)
        .min(state.count);
    let (s, touching) = passive_force(
        state.points.get(..n).unwrap_or_default(),
        pos.get(..n).unwrap_or_default(),
        tool.shaft_radius,
        params.stiffness,
        params.max_force,
    );
    let d = damping_force(shaft, centre, touching > 0, params);
    (
        clamp_force(f + clamp_force(s + d, params.max_force), params.max_force),
        f,
    )
}

/// The moment about the burr's centre `centre` of the shaft's springs as [`drill_force`]
/// renders them from `state`'s planes (the drill `tool` along the unit `axis`): for each
/// passive point `p` that pushes, `(p - centre) x stiffness * depth * normal`, summed, and
/// scaled by the factor the clamp of the springs' sum to `max_force` applies to the force
/// (1 when the sum is within it). The burr's spring and the damping act through the centre
/// and add none. About another point `h` (the handle, `centre + axis * shaft_length`) the moment is
/// this plus `(centre - h) x force`.
///
/// # Bounded work
/// O([`MAX_PASSIVE`]). Never allocates or panics; non-finite input gives zero.
pub fn drill_torque(
    tool: &DrillTool,
    centre: Vec3,
    axis: Vec3,
    state: &DrillState,
    params: &ForceParams,
) -> Vec3 {
    let mut pos = [Vec3::ZERO; MAX_PASSIVE];
    let n = tool
        .passive_positions(centre, axis, &mut pos)
        .min(state.count);
    let (mut sum, mut moment) = (Vec3::ZERO, Vec3::ZERO);
    for (pt, &p) in state.points.iter().zip(&pos).take(n) {
        if let Some((q, normal)) = pt.plane {
            let depth = tool.shaft_radius - (p - q).dot(normal);
            if depth > 0.0 {
                let s = normal * (params.stiffness * depth);
                sum += s;
                moment += (p - centre).cross(s);
            }
        }
    }
    let clamped = clamp_force(sum, params.max_force);
    if !moment.is_finite() || (clamped == Vec3::ZERO && sum != Vec3::ZERO) {
        return Vec3::ZERO;
    }
    if clamped == sum {
        moment
    } else {
        moment * (clamped.length() / sum.length())
    }
}
