//! The spheres a [`Drill`] remembers, in the order they were queued: for an item, those
//! queued after its own are the swept volume a leaf may lie inside ([`Drill::step`]).

use glam::Vec3;

use super::cost::WorkCost;
use super::sphere::Sphere;
use super::step::{Drill, DrillReport};

/// Spheres the drill remembers, in the order they were queued (a ring: the oldest is
/// forgotten). Work is taken in that order too, so while the drill lags behind the burr the
/// spheres queued after the one being worked on are known; [`SWEPT_AHEAD`] of them are its
/// swept volume (see [`Drill::step`]). The ring holds that many past a lag of
/// `SWEPT - SWEPT_AHEAD` spheres; a drill further behind sees fewer, down to none once its
/// sphere has been forgotten.
pub(crate) const SWEPT: usize = 64;

/// How many spheres queued after an item's own count as the swept volume for it: a burr queued
/// every eighth of the radius ([`crate::servo::DRILL_SPACING`]) meets the next sixteen
/// positions, the only ones a node on its surface can lie inside. Spheres queued *before* an
/// item's are not tested: their work came first, and it erased what lay inside them.
pub(crate) const SWEPT_AHEAD: usize = 16;

impl Drill<'_> {
    /// Remembers `s` as part of the swept volume (the oldest of [`SWEPT`] is forgotten).
    pub(super) fn remember(&mut self, s: Sphere) {
        if let Some(slot) = self.swept.get_mut(self.swept_next) {
            *slot = s;
        }
        self.swept_next = (self.swept_next + 1) % SWEPT;
        self.swept_len = (self.swept_len + 1).min(SWEPT);
        self.swept_for = None;
    }

    /// The spheres queued after `s`, oldest first, at most [`SWEPT_AHEAD`] of them. When `s`
    /// is no longer remembered, every remembered sphere was queued after it: the oldest
    /// [`SWEPT_AHEAD`] of them. The answer for the last sphere asked for is kept (items come
    /// sphere by sphere); remembering a new sphere clears it.
    ///
    /// # Bounded work
    /// O(1) when `s` is the last sphere asked for, else O([`SWEPT`]) comparisons, charged
    /// [`WorkCost::LOCATE`].
    pub(super) fn swept_after<'s>(
        &'s mut self,
        s: &Sphere,
        rep: &mut DrillReport,
    ) -> impl Iterator<Item = &'s Sphere> + 's {
        if self.swept_for != Some(*s) {
            rep.work = rep.work.saturating_add(WorkCost::LOCATE);
            rep.located += 1;
            let oldest = (self.swept_next + SWEPT - self.swept_len) % SWEPT;
            let ring = &self.swept;
            let (first, count) =
                match (0..self.swept_len).find(|&k| ring.get((oldest + k) % SWEPT) == Some(s)) {
                    Some(k) => (oldest + k + 1, self.swept_len - 1 - k),
                    None => (oldest, self.swept_len),
                };
            self.swept_for = Some(*s);
            self.swept_first = first % SWEPT;
            self.swept_count = count.min(SWEPT_AHEAD);
            self.swept_lag = count;
        }
        let (first, ring) = (self.swept_first, &self.swept);
        (0..self.swept_count).filter_map(move |k| ring.get((first + k) % SWEPT))
    }

    /// `true` when all four corners `p` lie inside one of the spheres queued after `s`.
    pub(super) fn inside_swept(
        &mut self,
        s: &Sphere,
        p: &[Vec3; 4],
        rep: &mut DrillReport,
    ) -> bool {
        self.swept_after(s, rep).any(|t| {
            let r2 = t.radius * t.radius;
            p.iter().all(|q| q.distance_squared(t.center) <= r2)
        })
    }

    /// `true` when `x` lies inside one of the spheres queued after `s`.
    pub(super) fn point_in_swept(&mut self, s: &Sphere, x: Vec3, rep: &mut DrillReport) -> bool {
        self.swept_after(s, rep)
            .any(|t| x.distance_squared(t.center) <= t.radius * t.radius)
    }
}
