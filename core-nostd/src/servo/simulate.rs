//! The simulation step of a [`World`]: the candidate tets near the tool, the budgeted drill
//! step, the contact plane with the drilled surface.

use glam::Vec3;

use super::zone_memo::MEMO_MAX_TETS;
use super::{ContactState, SimReport, VibrationCue, World, CONTACT_NODE_UNITS};
use crate::collide::ZoneGather;
use crate::drill::{DrillParams, Sphere, MAX_STEP_SPHERES};
use crate::force::sphere_contact;
use crate::hash::Aabb;
use crate::hierarchy::{Kept, NearestQuery, VisibleTri, KEEP};
use crate::ids::TetId;

impl World<'_> {
    /// One simulation step for a spherical burr of `radius` at `centre`: candidates near the
    /// tool (the box `radius + reach` around it), the budgeted drill step when `drill_on`,
    /// then the contact with the drilled surface within `radius + reach`. `reach` is how far
    /// the servo may extrapolate before the next step (half the radius is a good default).
    ///
    /// # Bounded work
    /// O(max cells + candidates) for the query, the drill step's budget (see
    /// [`Drill::step`]), and for the contact at most [`World::contact_max_nodes`] node tests
    /// of [`Hierarchy::nearest_visible`] (typically a few hundred), plus O(candidates + depth)
    /// and O(depth) per kept face ([`crate::hierarchy::KEEP`]). Under a tick budget
    /// ([`World::set_tick_budget`]) the drill and the contact search share it, less the
    /// nodes held for a drill shaft's walk out of the drill's share
    /// ([`World::shaft_reserve`]). With regions
    /// ([`World::set_regions`]), O(regions) to grant them their credit, charged to the drill
    /// as one work unit per rate-limited region and one for the feed's pool when a region is
    /// cut by the feed ([`crate::drill::Region::with_cutting_energy`]).
    ///
    /// # Capacity
    /// A full candidate list keeps the tets found first and counts `saturations().candidates`,
    /// and so does a zone of more than [`World::max_cells`] cells (which finds none);
    /// the drill and the hierarchy saturate as they document; a contact search that reaches
    /// its node bound answers with the closest triangle it met or kept (see
    /// [`World::set_contact_max_nodes`]) and counts `saturations().contact`.
    /// The state stays valid.
    ///
    /// [`Drill::step`]: crate::drill::Drill::step
    /// [`Hierarchy::nearest_visible`]: crate::hierarchy::Hierarchy::nearest_visible
    pub fn simulate(
        &mut self,
        centre: Vec3,
        radius: f32,
        reach: f32,
        drill_on: bool,
        params: &DrillParams,
    ) -> SimReport {
        let sphere = [Sphere {
            center: centre,
            radius,
        }];
        let spheres: &[Sphere] = if drill_on { &sphere } else { &[] };
        self.simulate_spheres(centre, radius, reach, spheres, params)
    }

    /// [`World::simulate`] eroding with several burr positions at once (the path swept since
    /// the last step, when the simulation runs slower than the servo); the contact is computed
    /// at `centre`.
    ///
    /// # Bounded work
    /// As [`World::simulate`], with the query box covering every sphere.
    pub fn simulate_spheres(
        &mut self,
        centre: Vec3,
        radius: f32,
        reach: f32,
        spheres: &[Sphere],
        params: &DrillParams,
    ) -> SimReport {
        let mut rep = SimReport::default();
        if !(centre.is_finite() && radius.is_finite() && radius > 0.0) {
            self.contact = ContactState::default();
            self.kept.clear();
            self.fed_from = None;
            self.step_units = 0;
            return rep;
        }
        // The burr's advance into the material since the last step, along the last
        // contact's outward normal: what the feed's work is paid on.
        let feed = match self.fed_from.replace(centre) {
            Some(from) if self.contact.valid => (from - centre).dot(self.contact.normal).max(0.0),
            _ => 0.0,
        };
        let reach = if reach.is_finite() && reach > 0.0 {
            reach
        } else {
            0.0
        };
        // The burr cuts while the drill is on, whether or not this step queues new work.
        let cutting = !spheres.is_empty();
        // Only positions far enough from the last one queued (or held long enough) become new
        // drill work; the rest is covered by the spheres already queued.
        let mut kept = [Sphere::default(); MAX_STEP_SPHERES];
        // A burr creeping into material cut by the feed is queued again every hold period
        // while the work it did waits for leaves and the drill has nothing left
        // (`Spacing::admit_pressing`).
        let pressing = cutting
            && self.drill.pending() == 0
            && self.drill.regions().is_some_and(|r| r.feed_pool() > 0.0);
        let nk = self
            .spacing
            .admit_pressing(centre, radius, spheres, &mut kept, pressing);
        let spheres = kept.get(..nk).unwrap_or_default();
        rep.queued = nk as u32;
        let mut tight = Aabb::of::<0>([]);
        for s in spheres {
            tight = tight.union(Aabb::point(s.center).grown(s.radius));
        }
        let zone = tight.union(Aabb::point(centre).grown(radius + reach));
        // The gathered list (`Some` with the near tets' count), or the one-shot query: every
        // step without a gather, on a step an exact gather's list does not cover the zone.
        let gathered = match self.zone.as_mut() {
            Some(z) => {
                // The list gathered over the last steps around the zone; the tets near the
                // burr filtered from it only when a position is queued (the drill reads
                // them for new positions only).
                let list = z.step(
                    &zone,
                    radius,
                    &self.hash,
                    self.boxes,
                    &self.mesh,
                    self.candidates,
                    self.max_cells,
                    !spheres.is_empty(),
                );
                if !list.covered && z.is_exact() {
                    z.fell_back();
                    None
                } else {
                    self.cand_at = list.at;
                    self.ncand = list.len;
                    let (m, full) = if spheres.is_empty() {
                        (0, false)
                    } else {
                        ZoneGather::tight(list, &tight, self.boxes, &self.mesh, self.candidates)
                    };
                    if full || !list.covered {
                        self.sat.candidates += 1;
                        rep.candidates_saturated = true;
                    }
                    rep.candidates = list.len as u32;
                    Some(m)
                }
            }
            None => None,
        };
        let m = match gathered {
            Some(m) => m,
            None => {
                // A gather's lists keep the second and third thirds of the storage.
                let len = self.candidates.len();
                let room = if self.zone.is_some() { len / 3 } else { len };
                self.query_zone(&zone, &tight, radius, room, &mut rep)
            }
        };
        // The regions earn their erosion credit from the servo's force, or from the feed's
        // work (one unit of work per rate-limited region and one for the feed's pool,
        // charged to the drill).
        let (force, seconds) = self.press;
        let under = self.contact_tet;
        let queued = self.drill.pending() > 0;
        let granted = self
            .drill
            .regions_mut()
            .map_or(0, |r| r.grant(force, seconds, cutting, feed, under, queued));
        if !spheres.is_empty() || self.drill.pending() > 0 || self.drill.debris_pending() > 0 {
            let budget = self.drill_budget(params.budget);
            let params = DrillParams {
                budget: budget.saturating_sub(granted),
                ..*params
            };
            rep.drill = self.drill.step(
                &mut self.hier,
                &self.mesh,
                self.candidates.get(..m).unwrap_or_default(),
                spheres,
                &params,
            );
        }
        rep.drill.work = rep.drill.work.saturating_add(granted);
        self.update_contact(centre, radius, radius + reach, cutting, &mut rep);
        self.step_units = rep
            .drill
            .work
            .saturating_add(rep.contact_nodes.saturating_mul(CONTACT_NODE_UNITS));
        rep
    }

    /// The one-shot candidate query of [`World::simulate_spheres`]: the tets whose boxes meet
    /// `zone`, those meeting `tight` first, in the first `room` entries of the candidate
    /// storage; returns how many meet `tight`. The tets come from
    /// the zone memo (`zone_memo.rs`, gathered around the zone over steps, a box `radius / 2`
    /// wider) in the hash query's order when it serves the zone, from the hash otherwise.
    #[inline(always)]
    fn query_zone(
        &mut self,
        zone: &Aabb,
        tight: &Aabb,
        radius: f32,
        room: usize,
        rep: &mut SimReport,
    ) -> usize {
        let zone = *zone;
        let tight = *tight;
        self.cand_at = 0;
        let max_cells = self.max_cells;
        let hash_complete = self.sat.hash == 0;
        let (cands, mesh, hash, boxes, memo) = (
            self.candidates.get_mut(..room).unwrap_or_default(),
            &self.mesh,
            &self.hash,
            &*self.boxes,
            &mut self.zone_memo,
        );
        // Each tet once (in the first cell of the query that holds it), and only when its box
        // meets the zone. The tets that meet the burr itself (`tight`: the drill works on
        // those only) fill the list from the front, the others from the back; both keep the
        // tets found first when the list is full.
        let cap = cands.len();
        let (mut m, mut back) = (0usize, 0usize);
        let mut full = false;
        let mut place = |t: TetId, near: bool| {
            if full {
                return;
            }
            if m + back == cap {
                full = true;
                return;
            }
            let slot = if near {
                m += 1;
                m - 1
            } else {
                back += 1;
                cap - back
            };
            if let Some(c) = cands.get_mut(slot) {
                *c = t;
            }
        };
        // The memo needs every tet hashed, with its stored box, and a small mesh.
        let tets = mesh.tet_count();
        let served = if boxes.len() >= tets && tets <= MEMO_MAX_TETS && hash_complete {
            memo.prepare(&zone, 0.5 * radius, hash, boxes, tets, max_cells)
                .and_then(|s| memo.ordered(s, &zone, hash, boxes, max_cells))
        } else {
            None
        };
        let visited = match served {
            Some(keys) => {
                rep.candidates_memo = true;
                for &item in keys {
                    let t = TetId(item);
                    let near = boxes.get(t.idx()).is_some_and(|b| b.overlaps(&tight));
                    place(t, near);
                }
                true
            }
            None => {
                hash.query_box_once(&zone, max_cells, |item| {
                    let t = TetId(item);
                    if t.idx() >= mesh.tet_count() {
                        return;
                    }
                    // The stored box, or the same box from the corners (the mesh's positions
                    // are finite, so both tests agree); the burr's box only for a tet in the
                    // zone.
                    let near = match boxes.get(t.idx()) {
                        Some(b) => {
                            if !b.overlaps(&zone) {
                                return;
                            }
                            b.overlaps(&tight)
                        }
                        None => {
                            let p = mesh.tet_positions(t);
                            if !zone.overlaps_points(&p) {
                                return;
                            }
                            tight.overlaps_points(&p)
                        }
                    };
                    place(t, near);
                })
            }
        };
        // The others next to the burr's, moved down from the back (`m + back <= cap`) and put
        // back in the order found. No sort: the query reports the tets cell by cell (x
        // fastest) and in tet order within a cell, an order that depends on the mesh and the
        // zone only, not on the table's size, so every platform walks the same list; sorting
        // it by tet cost 7,700 of the 130,000 instructions of the firmware's worst tick.
        for i in 0..back {
            if let Some(&t) = cands.get(cap - back + i) {
                if let Some(slot) = cands.get_mut(m + i) {
                    *slot = t;
                }
            }
        }
        let k = m + back;
        if let Some(rest) = cands.get_mut(m..k) {
            rest.reverse();
        }
        self.ncand = k;
        // A zone of more cells than the query may visit finds nothing at all: as much a
        // saturation as a full list (the drill and the contact see no tets this step).
        if full || !visited {
            self.sat.candidates += 1;
            rep.candidates_saturated = true;
        }
        rep.candidates = k as u32;
        m
    }

    /// The closest visible triangle of the candidate trees within `reach` of `centre`, turned
    /// into a contact plane by [`sphere_contact`], through [`Hierarchy::nearest_uncut`]
    /// hinted with the closest faces the last step met ([`Kept`], the last answer among
    /// them); while the burr is `cutting` (drill on this
    /// step), triangles entirely inside it are material being removed and are skipped, so
    /// the burr is never pushed through a sliver it is eroding. Ties go to the smallest
    /// (tet, index, face), so
    /// the result never depends on visiting order, and it is the triangle the exhaustive
    /// search over [`Hierarchy::for_each_visible_in`] finds. When the search reaches
    /// `contact_max_nodes` the answer is the closest of the hints in play and the triangles
    /// met (or the previous plane when there is none), and it is counted; the next search
    /// goes on where this one stopped ([`Hierarchy::nearest_continued`]), so searches that
    /// keep hitting the bound walk every tree near the tool to the end in turn, and the kept
    /// faces carry the closest triangles found.
    ///
    /// [`Hierarchy::nearest_uncut`]: crate::hierarchy::Hierarchy::nearest_uncut
    /// [`Hierarchy::for_each_visible_in`]: crate::hierarchy::Hierarchy::for_each_visible_in
    /// [`Hierarchy::nearest_continued`]: crate::hierarchy::Hierarchy::nearest_continued
    fn update_contact(
        &mut self,
        centre: Vec3,
        radius: f32,
        reach: f32,
        cutting: bool,
        rep: &mut SimReport,
    ) {
        let cands = self
            .candidates
            .get(self.cand_at..self.cand_at + self.ncand)
            .unwrap_or(&[]);
        let mut hints: heapless::Vec<VisibleTri, KEEP> = heapless::Vec::new();
        for &(_, t) in &self.kept {
            let _ = hints.push(t);
        }
        let bound = match self.step_units_left() {
            Some(t) => {
                (t.saturating_sub(rep.drill.work) / CONTACT_NODE_UNITS).min(self.contact_max_nodes)
            }
            None => self.contact_max_nodes,
        };
        rep.contact_bound = bound;
        let q = NearestQuery {
            tets: cands,
            start: 0,
            centre,
            reach,
            cut: cutting.then_some(radius),
            hints: &hints,
            max_nodes: bound,
        };
        let mut kept = Kept::new();
        let near = self.hier.nearest_continued_keeping(
            &self.mesh,
            &q,
            &mut self.memo,
            &mut self.cursor,
            &mut kept,
        );
        rep.triangles = near.triangles;
        rep.contact_nodes = near.nodes;
        if !near.complete {
            rep.contact_saturated = true;
            self.sat.contact += 1;
            if near.tri.is_none() {
                // Nothing found within the bound and no hint: keep the previous plane.
                self.contact.triangles = near.triangles;
                return;
            }
            // Otherwise the closest triangle met (or the hint): a true visible face, no
            // deeper than the exact answer; the next step starts from it.
        }
        self.kept = kept;
        self.contact_tet = near.tri.map(|vt| vt.tet);
        let stiffness = match (self.drill.regions(), near.tri) {
            (Some(r), Some(vt)) => r.material_of(vt.tet).stiffness,
            _ => 0.0,
        };
        // The burr vibrates while the drill is on, as the region under it sets; the frequency
        // goes with every contact, so the servo's phase runs on between cuts.
        let idle = VibrationCue {
            hz: self.vibration_hz,
            ..VibrationCue::default()
        };
        let vibration = match (self.drill.regions(), near.tri) {
            (Some(r), Some(vt)) if cutting && self.vibration_hz > 0.0 => r
                .region_entry(vt.tet)
                .filter(|g| g.vibration() > 0.0)
                .map_or(idle, |g| VibrationCue {
                    hz: self.vibration_hz,
                    amplitude: g.vibration(),
                    threshold: g.material.threshold,
                }),
            _ => idle,
        };
        // The spinning burr's friction with the material under it, while the drill is on.
        let friction = match (self.drill.regions(), near.tri) {
            (Some(r), Some(vt)) if cutting => r.region_entry(vt.tet).map_or(0.0, |g| g.friction()),
            _ => 0.0,
        };
        self.contact = match near.tri {
            None => ContactState {
                centre,
                triangles: near.triangles,
                vibration: idle,
                ..ContactState::default()
            },
            Some(vt) => {
                let c = sphere_contact(centre, radius, [vt.corners]);
                ContactState {
                    valid: c.normal != Vec3::ZERO,
                    point: c.point,
                    normal: c.normal,
                    depth: c.depth,
                    centre,
                    triangles: near.triangles,
                    stiffness,
                    vibration,
                    friction,
                }
            }
        };
    }
}
