//! The coarse tets near a moving tool, gathered through the static spatial hash in parts of
//! bounded work over several steps ([`ZoneGather`]).
//!
//! A one-shot zone query ([`SpatialHash::query_box_once`]) scans every hash entry of every
//! cell the tool's zone covers, each step: on a fine mesh (the cow, 1,600 to 1,800 tets near
//! a burr of radius 0.1) that is more than a Cortex-M4's whole servo period. A
//! [`ZoneGather`] instead gathers the tets whose boxes meet a *larger* box (the zone grown by
//! a margin) a few thousand entries a step, and keeps the list while the zone stays inside
//! that box: a superset of the one-shot query's tets, so a contact search that completes over
//! it finds the same triangle, and the tets of it that meet a box are exactly the one-shot
//! query's tets for that box. When the zone comes within half the margin of the box's edge,
//! the next box is gathered in the other half of the storage while the old list serves; a
//! step whose zone has left the old box before the new one is complete uses the old list
//! anyway and says so (a saturation: tets may be missing).

use crate::hash::{Aabb, Cell, SpatialHash};
use crate::ids::TetId;
use crate::mesh::Mesh;

/// Default margin of a [`ZoneGather`], in tool radii: the gathered box is the zone grown by a
/// fifth of the radius on every side.
pub const ZONE_MARGIN_RADII: f32 = 0.2;

/// A gather under way: the box, its cell range, the next cell and the tets found so far.
#[derive(Clone, Copy, Debug)]
struct Gathering {
    target: Aabb,
    range: (Cell, Cell),
    next: u64,
    found: usize,
    full: bool,
}

/// The list a step uses, from [`ZoneGather::step`].
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default)]
pub(crate) struct ZoneList {
    /// Where the list starts in the candidate storage.
    pub(crate) at: usize,
    /// Its length.
    pub(crate) len: usize,
    /// `true` when the list holds every tet whose box meets the zone (the zone lies in the
    /// gathered box and the list did not fill up); `false`: tets may be missing.
    pub(crate) covered: bool,
}

/// The gathered tets near a tool, kept across steps and refreshed in parts of bounded work.
///
/// The candidate storage handed to `ZoneGather::step` is used in thirds: the first for the
/// tets near the burr that a caller filters from the list (`ZoneGather::tight`), the
/// second and third for the list in use and the list being gathered.
#[derive(Clone, Copy, Debug)]
pub struct ZoneGather {
    work: u32,
    margin_radii: f32,
    /// A step whose list does not cover the zone queries the hash once instead
    /// ([`ZoneGather::exact`]).
    exact: bool,
    /// Steps that did (`exact` only).
    fallbacks: u32,
    /// The box whose tets the list in use holds (complete), which third holds them, how many,
    /// and whether that third filled up.
    active: Option<(Aabb, usize, usize, bool)>,
    gathering: Option<Gathering>,
    /// Gathers finished so far.
    gathers: u32,
}

impl ZoneGather {
    /// A gather of at most `work` units a step (one per hash cell and per entry scanned, about
    /// 8 Cortex-M4 instructions each, plus a box test per tet found), keeping boxes grown by
    /// `margin_radii` tool radii beyond the zone.
    pub const fn new(work: u32, margin_radii: f32) -> Self {
        Self {
            work,
            margin_radii,
            exact: false,
            fallbacks: 0,
            active: None,
            gathering: None,
            gathers: 0,
        }
    }

    /// [`ZoneGather::new`] that is never short of a tet: a step whose list does not cover the
    /// zone (the burr outran the gather, or the list filled up) queries the hash once
    /// instead, as a world without a gather does every step, into the first third of the
    /// candidate storage, and the gather goes on at the next step
    /// ([`crate::servo::World::simulate_spheres`]). For a host, where a slow step now and
    /// then costs less than a missed tet: the work of such a step is the one-shot query's.
    pub const fn exact(work: u32, margin_radii: f32) -> Self {
        let mut z = Self::new(work, margin_radii);
        z.exact = true;
        z
    }

    /// `true` for a gather made by [`ZoneGather::exact`].
    pub fn is_exact(&self) -> bool {
        self.exact
    }

    /// Steps an exact gather answered with the one-shot query ([`ZoneGather::exact`]).
    pub fn fallbacks(&self) -> u32 {
        self.fallbacks
    }

    /// Counts a step answered with the one-shot query.
    pub(crate) fn fell_back(&mut self) {
        self.fallbacks = self.fallbacks.saturating_add(1);
    }

    /// The work units one step may spend.
    pub fn work(&self) -> u32 {
        self.work
    }

    /// Gathers finished so far.
    pub fn gathers(&self) -> u32 {
        self.gathers
    }

    /// Forgets the lists (the storage was used for something else): the next step gathers
    /// afresh.
    pub(crate) fn forget(&mut self) {
        self.active = None;
        self.gathering = None;
    }

    /// One step's list for `zone` (a tool of `radius`): starts a gather when the zone comes
    /// within half the margin of the gathered box's edge (or has none), advances it by at most
    /// the step's work (a quarter of it when `busy`, the caller filtering the list this step,
    /// unless the zone has left the gathered box), and returns the list to use. `cands` is the candidate storage (the
    /// same slice every step), `boxes` each tet's stored box (a tet beyond it has its box made
    /// from its corners), `max_cells` the most cells a gathered box may cover (a larger one is
    /// not gathered: the old list serves, not covered).
    ///
    /// # Bounded work
    /// At most the step's work units of hash cells and entries (plus one bucket; the first
    /// cell of a part is always scanned), one box test per tet found, O(1) otherwise.
    ///
    /// # Capacity
    /// A third of `cands` holds a list; a gather that finds more tets keeps the first ones and
    /// its list is never `covered`.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn step(
        &mut self,
        zone: &Aabb,
        radius: f32,
        hash: &SpatialHash<'_>,
        boxes: &[Aabb],
        mesh: &Mesh<'_>,
        cands: &mut [TetId],
        max_cells: u32,
        busy: bool,
    ) -> ZoneList {
        let third = cands.len() / 3;
        let margin = (self.margin_radii * radius).max(0.0);
        let steady = self
            .active
            .is_some_and(|(b, ..)| holds(&b, &zone.grown(0.5 * margin)));
        if !steady && !self.gathering.is_some_and(|g| holds(&g.target, zone)) {
            let target = zone.grown(margin);
            let range = hash.cell_range(&target);
            self.gathering = (crate::hash::cells_in(range.0, range.1) <= max_cells as u64)
                .then_some(Gathering {
                    target,
                    range,
                    next: 0,
                    found: 0,
                    full: false,
                });
        }
        let covered = self.active.is_some_and(|(b, ..)| holds(&b, zone));
        let work = if busy && covered {
            self.work / 4
        } else {
            self.work
        };
        if let Some(mut g) = self.gathering {
            // Into the third the list in use does not hold.
            let into = match self.active {
                Some((_, 1, ..)) => 2,
                _ => 1,
            };
            let (lo, hi) = (into * third, (into + 1) * third);
            let out = cands.get_mut(lo..hi).unwrap_or(&mut []);
            let total = crate::hash::cells_in(g.range.0, g.range.1);
            g.next = hash.query_cells_once_from(g.range, g.next, work, |item| {
                let t = TetId(item);
                if t.idx() >= mesh.tet_count() {
                    return;
                }
                let meets = match boxes.get(t.idx()) {
                    Some(b) => b.overlaps(&g.target),
                    None => g.target.overlaps_points(&mesh.tet_positions(t)),
                };
                if !meets {
                    return;
                }
                match out.get_mut(g.found) {
                    Some(slot) => {
                        *slot = t;
                        g.found += 1;
                    }
                    None => g.full = true,
                }
            });
            if g.next >= total {
                self.active = Some((g.target, into, g.found, g.full));
                self.gathering = None;
                self.gathers = self.gathers.saturating_add(1);
            } else {
                self.gathering = Some(g);
            }
        }
        match self.active {
            Some((b, which, len, full)) => ZoneList {
                at: which * third,
                len,
                covered: !full && holds(&b, zone),
            },
            None => ZoneList::default(),
        }
    }

    /// Writes the tets of `list` whose boxes meet `near` into the first third of `cands`, in
    /// the list's order, and returns how many; `true` with it when they did not all fit.
    ///
    /// # Bounded work
    /// One box test per tet of the list.
    pub(crate) fn tight(
        list: ZoneList,
        near: &Aabb,
        boxes: &[Aabb],
        mesh: &Mesh<'_>,
        cands: &mut [TetId],
    ) -> (usize, bool) {
        let third = cands.len() / 3;
        let (front, rest) = cands.split_at_mut(third.min(list.at));
        let from = rest
            .get(list.at - front.len()..list.at - front.len() + list.len)
            .unwrap_or(&[]);
        let (mut m, mut full) = (0usize, false);
        for &t in from {
            let meets = match boxes.get(t.idx()) {
                Some(b) => b.overlaps(near),
                None => near.overlaps_points(&mesh.tet_positions(t)),
            };
            if meets {
                match front.get_mut(m) {
                    Some(slot) => {
                        *slot = t;
                        m += 1;
                    }
                    None => full = true,
                }
            }
        }
        (m, full)
    }
}

/// `true` when `outer` holds all of `inner` (faces included).
#[inline]
fn holds(outer: &Aabb, inner: &Aabb) -> bool {
    outer.min.cmple(inner.min).all() && inner.max.cmple(outer.max).all()
}
