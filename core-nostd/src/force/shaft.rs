//! A drill: the burr (one active sample point at its centre, Turini et al. 2006, section 3.2) on a
//! shaft sampled by passive points ([`super::passive`]) along the tool's axis, from the burr
//! to the handle.

use glam::{Quat, Vec3};

/// Most passive points a shaft carries: a fixed bound, so a tick's work is bounded whatever
/// the shaft's proportions.
pub const MAX_PASSIVE: usize = 32;

/// A drill's shape, mesh units: a burr of `burr_radius` at the tool's position and a shaft of
/// `shaft_radius` from the burr's centre along the tool's axis (its local +z) to the handle,
/// `shaft_length` away.
#[derive(Clone, Copy, PartialEq, Debug)]
pub struct DrillTool {
    /// Burr radius.
    pub burr_radius: f32,
    /// Shaft length, burr centre to handle.
    pub shaft_length: f32,
    /// Shaft radius (each passive point's radius of action).
    pub shaft_radius: f32,
}

impl DrillTool {
    /// The number of passive points: spaced at most a shaft radius apart (neighbouring
    /// spheres overlap, so the shaft's side dips by at most 13 % of its radius between
    /// them) from the burr's surface to the handle, both ends included; at most
    /// [`MAX_PASSIVE`] (a longer shaft gets its points spread wider), at least one, none for
    /// a shaft no longer than the burr's radius or not finite.
    ///
    /// # Bounded work
    /// Constant.
    pub fn passive_count(&self) -> usize {
        let span = self.shaft_length - self.burr_radius;
        if !(span.is_finite() && span > 0.0 && self.shaft_radius > 0.0) {
            return 0;
        }
        let gaps = libm::ceilf(span / self.shaft_radius);
        if !gaps.is_finite() || gaps >= (MAX_PASSIVE - 1) as f32 {
            MAX_PASSIVE
        } else {
            gaps as usize + 1
        }
    }

    /// Distance of passive point `i` from the burr's centre along the axis (evenly spaced
    /// from `burr_radius` to `shaft_length`).
    ///
    /// # Bounded work
    /// Constant.
    pub(crate) fn passive_offset(&self, i: usize) -> f32 {
        let n = self.passive_count();
        if n <= 1 {
            return self.shaft_length;
        }
        let t = i.min(n - 1) as f32 / (n - 1) as f32;
        self.burr_radius + (self.shaft_length - self.burr_radius) * t
    }

    /// The reach of the shaft's points for the burr's `burr_reach`: the same share of the
    /// shaft's radius as `burr_reach` is of the burr's (0 when either is not positive and
    /// finite). A face within `shaft_radius + shaft_reach` of a point gives it a plane before
    /// it touches; a face farther off gives none until the point is nearer, at most one step
    /// later, and a face the point crosses holds it whatever the reach. The walk for the
    /// points costs about the square of `shaft_radius + shaft_reach`: with the burr's reach
    /// instead, a thin shaft in a wide hole met the hole's walls at every step.
    ///
    /// # Bounded work
    /// Constant.
    pub fn shaft_reach(&self, burr_reach: f32) -> f32 {
        let r = burr_reach / self.burr_radius * self.shaft_radius;
        if r.is_finite() && r > 0.0 {
            r
        } else {
            0.0
        }
    }

    /// The tool's axis (burr to handle) for a rotation: the rotated +z, unit (+z for a
    /// rotation that is not finite or not unit).
    ///
    /// # Bounded work
    /// Constant.
    pub fn axis(rotation: Quat) -> Vec3 {
        let a = (rotation * Vec3::Z).normalize_or_zero();
        if a.is_finite() && a != Vec3::ZERO {
            a
        } else {
            Vec3::Z
        }
    }

    /// The passive points' positions for the burr at `centre` and the shaft along the unit
    /// `axis`, written into `out` (at most [`MAX_PASSIVE`]); returns how many.
    ///
    /// # Bounded work
    /// O([`MAX_PASSIVE`]).
    pub fn passive_positions(
        &self,
        centre: Vec3,
        axis: Vec3,
        out: &mut [Vec3; MAX_PASSIVE],
    ) -> usize {
        let n = self.passive_count();
        for (i, p) in out.iter_mut().enumerate().take(n) {
            *p = centre + axis * self.passive_offset(i);
        }
        n
    }

    /// The handle: the shaft's far end, where the device holds the tool and where the forces
    /// of all its points are applied.
    ///
    /// # Bounded work
    /// Constant.
    #[cfg(test)]
    pub(crate) fn handle(&self, centre: Vec3, axis: Vec3) -> Vec3 {
        centre + axis * self.shaft_length
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_shafts_reach_is_the_burrs_share_of_its_radius() {
        let t = DrillTool {
            burr_radius: 0.1,
            shaft_length: 0.6,
            shaft_radius: 0.03,
        };
        // Half the burr's radius for the burr: half the shaft's for the shaft.
        assert!((t.shaft_reach(0.05) - 0.015).abs() < 1e-7);
        assert_eq!(t.shaft_reach(0.0), 0.0);
        assert_eq!(t.shaft_reach(-0.05), 0.0);
        assert_eq!(t.shaft_reach(f32::NAN), 0.0);
        assert_eq!(t.shaft_reach(f32::INFINITY), 0.0);
        let flat = DrillTool {
            burr_radius: 0.0,
            ..t
        };
        assert_eq!(flat.shaft_reach(0.05), 0.0);
    }

    #[test]
    fn passive_points_span_the_shaft_at_most_a_radius_apart() {
        let t = DrillTool {
            burr_radius: 0.1,
            shaft_length: 0.6,
            shaft_radius: 0.03,
        };
        // 0.5 / 0.03 = 16.7: 17 gaps, 18 points.
        assert_eq!(t.passive_count(), 18);
        assert_eq!(t.passive_offset(0), 0.1);
        assert!((t.passive_offset(17) - 0.6).abs() < 1e-6);
        for i in 1..18 {
            let gap = t.passive_offset(i) - t.passive_offset(i - 1);
            assert!(gap <= 0.03 + 1e-6 && gap > 0.0);
        }
        let mut out = [Vec3::ZERO; MAX_PASSIVE];
        let n = t.passive_positions(Vec3::ONE, Vec3::X, &mut out);
        assert_eq!(n, 18);
        assert!((out[17] - t.handle(Vec3::ONE, Vec3::X)).length() < 1e-6);
        // A thin long shaft is capped; a shaft inside the burr has none.
        let long = DrillTool {
            shaft_radius: 0.001,
            ..t
        };
        assert_eq!(long.passive_count(), MAX_PASSIVE);
        let short = DrillTool {
            shaft_length: 0.05,
            ..t
        };
        assert_eq!(short.passive_count(), 0);
        assert_eq!(DrillTool::axis(Quat::IDENTITY), Vec3::Z);
        let q = Quat::from_rotation_y(core::f32::consts::FRAC_PI_2);
        assert!((DrillTool::axis(q) - Vec3::X).length() < 1e-6);
    }
}
