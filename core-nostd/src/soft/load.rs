//! Loads and supports: a point force spread over a tet's corners, nodes fixed below a plane.

use glam::Vec3;

use crate::geom;

/// Spreads a point force `force` applied at `point` over the corners `p` of the tet that
/// holds it, by barycentric weights. Weights are clamped to `[0, 1]` and renormalised, so a
/// point just outside the tet still gives all of its force to the nearest corners and the
/// four parts always add up to `force` (and, for a point inside, their moment about any
/// origin equals the point force's). `None` for a degenerate tet.
///
/// # Bounded work
/// Constant.
pub fn spread_point_force(p: [Vec3; 4], point: Vec3, force: Vec3) -> Option<[Vec3; 4]> {
    let b = geom::barycentric(point, p)?;
    let c = b.map(|x| x.clamp(0.0, 1.0));
    let sum = c[0] + c[1] + c[2] + c[3];
    // `sum` is positive or NaN here (weights are clamped to [0, 1], and one is at least
    // 1/4 for a finite point); NaN means a non-finite input.
    if sum.is_nan() || sum <= 0.0 {
        return None;
    }
    Some(c.map(|x| force * (x / sum)))
}

/// `true` when `x` lies on or below the plane through `origin` with upward normal `up`.
#[inline]
pub(crate) fn below_plane(x: Vec3, origin: Vec3, up: Vec3) -> bool {
    (x - origin).dot(up) <= 0.0
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_force_at_a_corner_goes_to_that_corner() {
        let p = [Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z];
        let f = spread_point_force(p, Vec3::X, Vec3::new(0.0, 0.0, -2.0)).unwrap();
        assert!((f[1].z + 2.0).abs() < 1e-6);
        assert!(f[0].length() + f[2].length() + f[3].length() < 1e-6);
    }

    #[test]
    fn parts_add_up_to_the_force_and_keep_its_moment() {
        let p = [Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z];
        let x = Vec3::new(0.2, 0.3, 0.1);
        let force = Vec3::new(1.0, -2.0, 0.5);
        let f = spread_point_force(p, x, force).unwrap();
        let sum = f[0] + f[1] + f[2] + f[3];
        assert!((sum - force).length() < 1e-6);
        let moment: Vec3 = (0..4).map(|i| p[i].cross(f[i])).sum();
        assert!((moment - x.cross(force)).length() < 1e-6);
        // Outside: still the whole force.
        let f = spread_point_force(p, Vec3::new(2.0, -1.0, 0.0), force).unwrap();
        assert!((f[0] + f[1] + f[2] + f[3] - force).length() < 1e-6);
        // Degenerate tet.
        assert!(spread_point_force([Vec3::ZERO; 4], x, force).is_none());
    }

    #[test]
    fn below_plane_includes_the_plane() {
        assert!(below_plane(Vec3::ZERO, Vec3::ZERO, Vec3::Z));
        assert!(below_plane(Vec3::new(5.0, 0.0, -1.0), Vec3::ZERO, Vec3::Z));
        assert!(!below_plane(Vec3::new(0.0, 0.0, 1e-3), Vec3::ZERO, Vec3::Z));
    }
}
