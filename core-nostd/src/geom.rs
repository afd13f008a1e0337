//! Geometry kernels shared by the mesh, collision, depth and drilling modules.
//!
//! All f32 kernels are plain multiply/add sequences (no fused multiply-add, no SIMD-dependent
//! paths), so the host and a Cortex-M4F produce the same bits.

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
pub fn det6_f64(a: Vec3, b: Vec3, c: Vec3, d: Vec3) -> f64 {
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
pub fn tri_normal(a: Vec3, b: Vec3, c: Vec3) -> Vec3 {
    (b - a).cross(c - a).normalize_or_zero()
}

/// Area of triangle `(a, b, c)`.
#[inline]
pub fn tri_area(a: Vec3, b: Vec3, c: Vec3) -> f32 {
    0.5 * (b - a).cross(c - a).length()
}
