//! Geometry kernels shared by the mesh, collision, depth and drilling modules.
//!
//! All f32 kernels are plain multiply/add sequences (no fused multiply-add, no SIMD-dependent
//! paths), so the host and a Cortex-M4F produce the same bits.
//!
//! ```
//! use tetradrill_core::geom::{barycentric, closest_point_on_triangle, det6, inside, tet_volume};
//! use tetradrill_core::Vec3;
//!
//! // The corner tet of the unit cube: positively oriented, volume 1/6.
//! let p = [Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z];
//! assert_eq!(det6(p[0], p[1], p[2], p[3]), 1.0);
//! assert_eq!(det6(p[0], p[2], p[1], p[3]), -1.0); // two corners swapped: negative
//! assert!((tet_volume(p) - 1.0 / 6.0).abs() < 1e-7);
//!
//! // Its centroid has four equal barycentric coordinates; a point past a face has a negative one.
//! let b = barycentric(Vec3::splat(0.25), p).unwrap();
//! assert!(b.iter().all(|w| (w - 0.25).abs() < 1e-6));
//! assert!(!inside(barycentric(Vec3::splat(0.4), p).unwrap(), 0.0));
//!
//! // The closest point of the floor triangle to a point above it is straight below.
//! let q = closest_point_on_triangle(Vec3::new(0.2, 0.2, 1.0), [p[0], p[1], p[2]]);
//! assert!((q - Vec3::new(0.2, 0.2, 0.0)).length() < 1e-6);
//! ```

#[cfg(test)]
pub(crate) mod test_rng;

use glam::Vec3;

/// Six times the signed volume of the tet `(a, b, c, d)`: `det[b-a, c-a, d-a]`.
/// Positive when `d` lies on the side of `(a, b, c)` that `(b-a) x (c-a)` points to.
#[inline]
pub fn det6(a: Vec3, b: Vec3, c: Vec3, d: Vec3) -> f32 {
    (b - a).cross(c - a).dot(d - a)
}

/// [`det6`] evaluated in f64 from f32 inputs: used where a sign must be trusted (orientation
/// at load, validation), never on the servo path.
#[inline]
pub(crate) fn det6_f64(a: Vec3, b: Vec3, c: Vec3, d: Vec3) -> f64 {
    let (ax, ay, az) = (a.x as f64, a.y as f64, a.z as f64);
    let (ux, uy, uz) = (b.x as f64 - ax, b.y as f64 - ay, b.z as f64 - az);
    let (vx, vy, vz) = (c.x as f64 - ax, c.y as f64 - ay, c.z as f64 - az);
    let (wx, wy, wz) = (d.x as f64 - ax, d.y as f64 - ay, d.z as f64 - az);
    ux * (vy * wz - vz * wy) - uy * (vx * wz - vz * wx) + uz * (vx * wy - vy * wx)
}

/// Volume of the tet (always non-negative).
#[inline]
pub fn tet_volume(p: [Vec3; 4]) -> f32 {
    libm::fabsf(det6(p[0], p[1], p[2], p[3])) / 6.0
}

/// Barycentric coordinates of `x` in the tet `p`, or `None` for a degenerate tet
/// (|det| not above `f32::MIN_POSITIVE`): callers skip those instead of dividing by zero.
///
/// # Bounded work
/// Constant: four 3x3 determinants.
#[inline]
pub fn barycentric(x: Vec3, p: [Vec3; 4]) -> Option<[f32; 4]> {
    let d = det6(p[0], p[1], p[2], p[3]);
    // Written so that a NaN determinant also counts as degenerate.
    let big_enough = libm::fabsf(d) > f32::MIN_POSITIVE;
    if !big_enough {
        return None;
    }
    let b1 = det6(p[0], x, p[2], p[3]) / d;
    let b2 = det6(p[0], p[1], x, p[3]) / d;
    let b3 = det6(p[0], p[1], p[2], x) / d;
    Some([1.0 - b1 - b2 - b3, b1, b2, b3])
}

/// `true` when all barycentric coordinates are at least `-eps`.
#[inline]
pub fn inside(b: [f32; 4], eps: f32) -> bool {
    b[0] >= -eps && b[1] >= -eps && b[2] >= -eps && b[3] >= -eps
}

/// Unit normal of triangle `(a, b, c)` by the right-hand rule, or zero for a degenerate one.
#[inline]
pub(crate) fn tri_normal(a: Vec3, b: Vec3, c: Vec3) -> Vec3 {
    (b - a).cross(c - a).normalize_or_zero()
}

/// Area of triangle `(a, b, c)`.
#[inline]
pub(crate) fn tri_area(a: Vec3, b: Vec3, c: Vec3) -> f32 {
    0.5 * (b - a).cross(c - a).length()
}

/// The closest point to `p` on triangle `t` (Voronoi regions of the corners, edges and face,
/// after Ericson's *Real-Time Collision Detection* 5.1.5; a degenerate triangle falls back to an
/// edge or a corner without dividing by zero). The one copy the force, drilling and hierarchy
/// code share.
///
/// # Bounded work
/// Constant.
pub fn closest_point_on_triangle(p: Vec3, t: [Vec3; 3]) -> Vec3 {
    let [a, b, c] = t;
    let ab = b - a;
    let ac = c - a;
    let ap = p - a;
    let d1 = ab.dot(ap);
    let d2 = ac.dot(ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = p - b;
    let d3 = ab.dot(bp);
    let d4 = ac.dot(bp);
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let den = d1 - d3;
        return if den > 0.0 { a + ab * (d1 / den) } else { a };
    }
    let cp = p - c;
    let d5 = ab.dot(cp);
    let d6 = ac.dot(cp);
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let den = d2 - d6;
        return if den > 0.0 { a + ac * (d2 / den) } else { a };
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let den = (d4 - d3) + (d5 - d6);
        return if den > 0.0 {
            b + (c - b) * ((d4 - d3) / den)
        } else {
            b
        };
    }
    let sum = va + vb + vc;
    if sum.is_nan() || sum <= 0.0 {
        return a; // degenerate triangle
    }
    let v = vb / sum;
    let w = vc / sum;
    a + ab * v + ac * w
}
