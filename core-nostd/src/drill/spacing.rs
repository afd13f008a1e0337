//! Which burr positions become drill work: one per eighth of the radius of motion, and the
//! place where a burr settles. [`crate::servo::World`] applies it to every simulation step;
//! anything else that drives a [`super::Drill`] with a moving burr (the drill bench) takes the
//! same rule from here, so its queue holds what the product's would.

use glam::Vec3;

use super::Sphere;

/// A burr position goes to the drill once it is this fraction of the radius away from the last
/// one queued: spheres an eighth of the radius apart cover the swept capsule to within
/// `r - sqrt(r^2 - (r/16)^2)`, 0.2 % of the radius. On the demo path the removed volume with
/// every position queued densely is 3.45 %, at this spacing 3.44 %, at a quarter radius 3.34 %
/// (the erosion criterion at the depth limit loses more in the wider grooves than their
/// volume; measured 2026-11-22).
pub const DRILL_SPACING: f32 = 0.125;

/// A burr that has settled (stayed within [`DRILL_SETTLE`] of one point) for this many steps
/// is queued again where it is, if it moved at all since the last position queued, so the
/// last position of a motion is eroded too.
pub const DRILL_HOLD_STEPS: u32 = 16;

/// The distance, as a fraction of the radius, within which a burr counts as settled for
/// [`DRILL_HOLD_STEPS`]: a sixteenth of [`DRILL_SPACING`]. A burr still moving (on the demo
/// path about a 24th of the radius every 16 steps) is queued by distance only; before
/// 2026-11-22 any motion re-queued it every 16 steps, six times as many burr positions as the
/// spacing asks for on that path, each walking its whole neighbourhood again.
pub const DRILL_SETTLE: f32 = DRILL_SPACING / 16.0;

/// Most burr positions one step takes ([`Spacing::admit`]).
pub const MAX_STEP_SPHERES: usize = 16;

/// The state of the queuing rule: the last position queued and where the burr settled.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Spacing {
    last_queued: Option<Vec3>,
    since_queued: u32,
    /// Where the burr settled (see [`DRILL_SETTLE`]) and for how many steps it has stayed
    /// within that distance of it.
    anchor: Option<Vec3>,
    settled_steps: u32,
}

impl Spacing {
    /// Nothing queued yet: the first position offered is taken.
    pub const fn new() -> Self {
        Self {
            last_queued: None,
            since_queued: 0,
            anchor: None,
            settled_steps: 0,
        }
    }

    /// One step of a burr of `radius` at `centre` offering the positions `spheres` (the path
    /// swept since the last step; empty when the drill is off): writes into `out` those that
    /// become new drill work, in order, and returns how many. A position is taken when it lies
    /// [`DRILL_SPACING`] radii or more from the last one taken, or when the burr has stayed
    /// within [`DRILL_SETTLE`] radii of one point for [`DRILL_HOLD_STEPS`] steps, moved since
    /// the last position taken and none was taken for as many steps. Positions that are not
    /// finite or have no positive radius are never taken.
    ///
    /// # Bounded work
    /// O(`spheres`).
    ///
    /// # Capacity
    /// At most [`MAX_STEP_SPHERES`] positions a step: past that each newer one replaces the
    /// one in the last slot (the newest is always kept).
    #[inline]
    pub fn admit(
        &mut self,
        centre: Vec3,
        radius: f32,
        spheres: &[Sphere],
        out: &mut [Sphere; MAX_STEP_SPHERES],
    ) -> usize {
        self.admit_pressing(centre, radius, spheres, out, false)
    }

    /// [`Spacing::admit`], and when `pressing` (work the feed did waits in the regions' pool
    /// while the drill has no work left), a position is also taken once it moved at all
    /// since the last one taken and none was taken for [`DRILL_HOLD_STEPS`] steps, settled or
    /// not: a burr creeping into material cut by the feed more slowly than [`DRILL_SPACING`]
    /// radii per hold period still has the material it presses queued, so the work the feed
    /// does (kept for [`crate::drill::Regions`]' two hold periods) finds leaves to pay for.
    ///
    /// # Bounded work
    /// O(`spheres`).
    #[inline]
    pub fn admit_pressing(
        &mut self,
        centre: Vec3,
        radius: f32,
        spheres: &[Sphere],
        out: &mut [Sphere; MAX_STEP_SPHERES],
        pressing: bool,
    ) -> usize {
        let mut n = 0usize;
        self.since_queued = self.since_queued.saturating_add(1);
        match self.anchor {
            Some(a) if a.distance(centre) <= DRILL_SETTLE * radius => {
                self.settled_steps = self.settled_steps.saturating_add(1);
            }
            _ => {
                self.anchor = Some(centre);
                self.settled_steps = 0;
            }
        }
        let settled = pressing || self.settled_steps >= DRILL_HOLD_STEPS;
        for s in spheres
            .iter()
            .filter(|s| s.center.is_finite() && s.radius > 0.0)
        {
            let far = match self.last_queued {
                None => true,
                Some(q) => {
                    let d = q.distance(s.center);
                    d >= DRILL_SPACING * s.radius
                        || (d > 0.0 && settled && self.since_queued >= DRILL_HOLD_STEPS)
                }
            };
            if far {
                if n == MAX_STEP_SPHERES {
                    n -= 1; // keep the newest in the last slot
                }
                if let Some(slot) = out.get_mut(n) {
                    *slot = *s;
                }
                n += 1;
                self.last_queued = Some(s.center);
                self.since_queued = 0;
            }
        }
        n
    }
}
