//! Falcon delta-mechanism kinematics (R. E. Stamper's parallel-manipulator model with the
//! Falcon's published dimensions, as listed in libnifalcon's `FalconGeometry.h`).
//!
//! Each leg i is rotated by `PHI[i]` about z. In the leg frame the tool centre is
//! `u = a cos t1 - c + L cos t2`, `v = b cos t3 - f`, `w = a sin t1 + L sin t2`,
//! `L = b sin t3 + d + e`, with t1 the motor angle and t2, t3 passive. Eliminating t2, t3 gives
//! one constraint `G(t1, p) = (u + c - a cos t1)^2 + (w - a sin t1)^2 - L(v)^2 = 0` per leg.
//!
//! - [`inverse`]: motor angles from a position (closed form);
//! - [`angle_jacobian`]: `A = d theta / d p` by implicit differentiation of G (analytic);
//! - [`forward`]: position from motor angles by Newton's method on `inverse(p) = theta`;
//! - [`motor_torques`]: `tau = J^T F` with `J = A^-1` (solves `A^T tau = F`).
//!
//! Positions are metres in the mechanism frame (z away from the base).

use crate::device::Vec3;

/// Upper-arm length, m.
pub const A: f64 = 0.060;
/// Parallelogram side, m.
pub const B: f64 = 0.1025;
/// Shin joint to effector centre, u component, m.
pub const C: f64 = 0.01443;
/// Shin to effector joint, m.
pub const D: f64 = 0.01125;
/// Knee to shin joint, m.
pub const E: f64 = D;
/// Shin joint to effector centre, v component, m.
pub const F: f64 = -0.025;
/// Fixed-frame origin to leg base, u component, m.
pub const R: f64 = 0.0400;
/// Fixed-frame origin to leg base, v component, m.
pub const S: f64 = -0.02309;
/// Offset of each axis from the desk plane: 15 degrees.
pub const OFFSET_ANGLE: f64 = core::f64::consts::PI / 12.0;
/// Leg angles about z, rad: 90, -30, -150 degrees, each plus the 15-degree offset.
pub const PHI: [f64; 3] = [
    core::f64::consts::FRAC_PI_2 + OFFSET_ANGLE,
    -core::f64::consts::FRAC_PI_6 + OFFSET_ANGLE,
    -5.0 * core::f64::consts::FRAC_PI_6 + OFFSET_ANGLE,
];
/// Transparent slots on each encoder wheel.
pub const WHEEL_SLOTS: f64 = 320.0;
/// Motor shaft diameter, m.
pub const SHAFT_DIAMETER: f64 = 0.01425;
/// Small diameter of the arm (capstan), m.
pub const SMALL_ARM_DIAMETER: f64 = 0.110;
/// Motor angle at encoder count 0, degrees (approximate; homing fixes the count).
pub const THETA_OFFSET_DEG: f64 = 35.0;
/// A position near the middle of the workspace, m: the Newton solver's default start.
pub const WORKSPACE_CENTRE: Vec3 = [0.0, 0.0, 0.11];

/// Motor angle, rad, of an encoder count (quadrature: 4 counts per slot, capstan reduction).
pub fn encoder_to_angle(count: i16) -> f64 {
    let deg = f64::from(count) * 360.0 * SHAFT_DIAMETER / (4.0 * WHEEL_SLOTS * SMALL_ARM_DIAMETER)
        + THETA_OFFSET_DEG;
    deg.to_radians()
}

fn leg_frame(leg: usize, p: Vec3) -> (f64, f64, f64, f64, f64) {
    let phi = PHI.get(leg).copied().unwrap_or(0.0);
    let (s, c) = phi.sin_cos();
    let u = c * p[0] + s * p[1] - R;
    let v = -s * p[0] + c * p[1] - S;
    (u, v, p[2], c, s)
}

/// Motor angles (rad) that put the tool centre at `p`; `None` outside the reachable set.
pub fn inverse(p: Vec3) -> Option<[f64; 3]> {
    let mut out = [0.0; 3];
    for (leg, slot) in out.iter_mut().enumerate() {
        let (u, v, w, _, _) = leg_frame(leg, p);
        let cos3 = (v + F) / B;
        if !(-1.0..=1.0).contains(&cos3) {
            return None;
        }
        let sin3 = (1.0 - cos3 * cos3).sqrt();
        let l = B * sin3 + D + E;
        // (u + c - a cos t)^2 + (w - a sin t)^2 = l^2 with t = 2 atan(x):
        // k0 + k1 x + k2 x^2 = 0.
        let q = u * u + w * w + 2.0 * C * u + A * A + C * C - l * l;
        let k0 = q - 2.0 * A * (u + C);
        let k1 = -4.0 * A * w;
        let k2 = q + 2.0 * A * (u + C);
        let disc = k1 * k1 - 4.0 * k2 * k0;
        if disc < 0.0 || k2 == 0.0 {
            return None;
        }
        let x = -(disc.sqrt() + k1) / (2.0 * k2);
        *slot = 2.0 * x.atan();
    }
    Some(out)
}

/// `A = d theta / d p` (row i = gradient of motor angle i), analytic; `None` outside the
/// reachable set or at a singular leg pose.
pub fn angle_jacobian(p: Vec3) -> Option<[[f64; 3]; 3]> {
    let theta = inverse(p)?;
    let mut rows = [[0.0; 3]; 3];
    for (leg, row) in rows.iter_mut().enumerate() {
        let (u, v, w, c, s) = leg_frame(leg, p);
        let t1 = theta.get(leg).copied()?;
        let (s1, c1) = t1.sin_cos();
        let vf = v + F;
        let root = (B * B - vf * vf).sqrt();
        if root == 0.0 {
            return None;
        }
        let l = root + D + E;
        let dl_dv = -vf / root;
        let dg_dt = 2.0 * A * ((u + C) * s1 - w * c1);
        if dg_dt.abs() < 1e-15 {
            return None;
        }
        let dg_du = 2.0 * (u + C - A * c1);
        let dg_dv = -2.0 * l * dl_dv;
        let dg_dw = 2.0 * (w - A * s1);
        // d(u, v, w)/d(x, y, z) = [[c, s, 0], [-s, c, 0], [0, 0, 1]].
        let gx = dg_du * c - dg_dv * s;
        let gy = dg_du * s + dg_dv * c;
        *row = [-gx / dg_dt, -gy / dg_dt, -dg_dw / dg_dt];
    }
    Some(rows)
}

fn det(m: &[[f64; 3]; 3]) -> f64 {
    m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
        - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
        + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
}

/// Solves `m x = b` by Cramer's rule; `None` when singular.
pub fn solve3(m: &[[f64; 3]; 3], b: Vec3) -> Option<Vec3> {
    let d = det(m);
    if !d.is_finite() || d.abs() < 1e-300 {
        return None;
    }
    let mut x = [0.0; 3];
    for (k, xk) in x.iter_mut().enumerate() {
        let mut mk = *m;
        for (row, bi) in mk.iter_mut().zip(b) {
            if let Some(cell) = row.get_mut(k) {
                *cell = bi;
            }
        }
        *xk = det(&mk) / d;
    }
    Some(x)
}

fn transpose(m: &[[f64; 3]; 3]) -> [[f64; 3]; 3] {
    [
        [m[0][0], m[1][0], m[2][0]],
        [m[0][1], m[1][1], m[2][1]],
        [m[0][2], m[1][2], m[2][2]],
    ]
}

/// Position from motor angles by Newton's method from `guess`; `None` if it does not converge
/// to 1e-12 rad within 20 iterations.
///
/// # Bounded work
/// At most 20 iterations of one inverse solve and one 3x3 solve.
pub fn forward(theta: [f64; 3], guess: Vec3) -> Option<Vec3> {
    let mut p = guess;
    for _ in 0..20 {
        let t = inverse(p)?;
        let r = [t[0] - theta[0], t[1] - theta[1], t[2] - theta[2]];
        if r.iter().all(|e| e.abs() < 1e-12) {
            return Some(p);
        }
        let a = angle_jacobian(p)?;
        let dp = solve3(&a, r)?;
        p = [p[0] - dp[0], p[1] - dp[1], p[2] - dp[2]];
        if !p.iter().all(|x| x.is_finite()) {
            return None;
        }
    }
    None
}

/// `J = d p / d theta` (the inverse of [`angle_jacobian`]).
pub fn jacobian(p: Vec3) -> Option<[[f64; 3]; 3]> {
    let a = angle_jacobian(p)?;
    let c0 = solve3(&a, [1.0, 0.0, 0.0])?;
    let c1 = solve3(&a, [0.0, 1.0, 0.0])?;
    let c2 = solve3(&a, [0.0, 0.0, 1.0])?;
    Some(transpose(&[c0, c1, c2]))
}

/// Motor torques, N m, rendering force `force` (N) at `p`: `tau = J^T F`.
pub fn motor_torques(p: Vec3, force: Vec3) -> Option<Vec3> {
    let a = angle_jacobian(p)?;
    solve3(&transpose(&a), force)
}

#[cfg(test)]
mod tests {
    use super::*;

    const POSES: [Vec3; 5] = [
        [0.0, 0.0, 0.11],
        [0.02, 0.0, 0.12],
        [-0.015, 0.02, 0.10],
        [0.01, -0.025, 0.13],
        [0.0, 0.03, 0.09],
    ];

    #[test]
    fn inverse_satisfies_leg_closure() {
        // Independent oracle: rebuild each leg from the angles with the forward leg equations
        // (u = a cos t1 - c + L cos t2, w = a sin t1 + L sin t2) and check |.| closes.
        for p in POSES {
            let t = inverse(p).expect("reachable");
            for leg in 0..3 {
                let phi = PHI[leg];
                let u = phi.cos() * p[0] + phi.sin() * p[1] - R;
                let v = -phi.sin() * p[0] + phi.cos() * p[1] - S;
                let t3 = ((v + F) / B).acos();
                let l = B * t3.sin() + D + E;
                let du = u - (A * t[leg].cos() - C);
                let dw = p[2] - A * t[leg].sin();
                assert!(
                    ((du * du + dw * dw).sqrt() - l).abs() < 1e-12,
                    "leg {leg} at {p:?}"
                );
            }
        }
        assert_eq!(inverse([0.0, 0.0, 1.0]), None);
    }

    #[test]
    fn forward_inverts_inverse() {
        for p in POSES {
            let t = inverse(p).unwrap();
            let q = forward(t, WORKSPACE_CENTRE).expect("converges");
            for k in 0..3 {
                assert!((p[k] - q[k]).abs() < 1e-9, "{p:?} vs {q:?}");
            }
        }
    }

    #[test]
    fn angle_jacobian_matches_finite_differences() {
        let h = 1e-6;
        for p in POSES {
            let a = angle_jacobian(p).unwrap();
            for j in 0..3 {
                let mut pp = p;
                let mut pm = p;
                pp[j] += h;
                pm[j] -= h;
                let tp = inverse(pp).unwrap();
                let tm = inverse(pm).unwrap();
                for i in 0..3 {
                    let fd = (tp[i] - tm[i]) / (2.0 * h);
                    assert!(
                        (a[i][j] - fd).abs() < 1e-5 * (1.0 + fd.abs()),
                        "A[{i}][{j}] {} vs {fd}",
                        a[i][j]
                    );
                }
            }
        }
    }

    #[test]
    fn jacobian_matches_forward_differences_and_virtual_work() {
        let h = 1e-7;
        for p in POSES {
            let j = jacobian(p).unwrap();
            let t = inverse(p).unwrap();
            for k in 0..3 {
                let mut tp = t;
                let mut tm = t;
                tp[k] += h;
                tm[k] -= h;
                let pp = forward(tp, p).unwrap();
                let pm = forward(tm, p).unwrap();
                for i in 0..3 {
                    let fd = (pp[i] - pm[i]) / (2.0 * h);
                    assert!(
                        (j[i][k] - fd).abs() < 1e-5 * (1.0 + fd.abs()),
                        "J[{i}][{k}]"
                    );
                }
            }
            // Virtual work: tau . dtheta = F . dp for any small motion.
            let force = [1.5, -2.0, 3.0];
            let tau = motor_torques(p, force).unwrap();
            let dtheta = [1e-6, -2e-6, 0.5e-6];
            let p2 = forward([t[0] + dtheta[0], t[1] + dtheta[1], t[2] + dtheta[2]], p).unwrap();
            let dp = [p2[0] - p[0], p2[1] - p[1], p2[2] - p[2]];
            let w_joint: f64 = (0..3).map(|i| tau[i] * dtheta[i]).sum();
            let w_cart: f64 = (0..3).map(|i| force[i] * dp[i]).sum();
            assert!(
                (w_joint - w_cart).abs() < 1e-3 * w_cart.abs().max(1e-9),
                "{w_joint} vs {w_cart}"
            );
        }
    }

    #[test]
    fn symmetric_pose_and_encoder_scale() {
        // On the axis the three legs are identical by symmetry: equal motor angles.
        let t = inverse([0.0, 0.0, 0.11]).unwrap();
        assert!(
            (t[0] - t[1]).abs() < 1e-12 && (t[1] - t[2]).abs() < 1e-12,
            "{t:?}"
        );
        // 0 counts = 35 degrees; 1280 counts (one wheel turn) = 360 * 14.25 / 110 degrees.
        assert!((encoder_to_angle(0) - 35f64.to_radians()).abs() < 1e-15);
        let turn = encoder_to_angle(1280) - encoder_to_angle(0);
        assert!((turn - (360.0f64 * 14.25 / 110.0).to_radians()).abs() < 1e-12);
    }
}
