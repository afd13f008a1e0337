//! PHANTOM Omni arm kinematics (l1 = l2 = 133.35 mm by default), analytic Jacobian,
//! torque = J^T F.
//!
//! `r = l1 cos t2 + l2 sin t3; x = -sin(t1) r; y = l1 sin t2 - l2 cos t3 + l2;
//! z = -l1 + cos(t1) r` (metres here). `t3` is the forearm's angle from the vertical, not its
//! angle to the upper arm: the forearm keeps its direction when only `t2` changes (the Omni
//! drives it from the base). The `_with` functions take the link lengths `[l1, l2]` (the
//! device file's `link_lengths_m`); the plain ones use [`L1`] and [`L2`].

use crate::device::Vec3;

/// Upper-arm length, m.
pub const L1: f64 = 0.13335;
/// Forearm length, m.
pub const L2: f64 = 0.13335;

/// Tool position, m, from the three arm joint angles, rad.
pub fn forward(t: Vec3) -> Vec3 {
    forward_with(t, [L1, L2])
}

/// Tool position, m, from the three arm joint angles, rad, and the link lengths `[l1, l2]`, m.
pub fn forward_with(t: Vec3, l: [f64; 2]) -> Vec3 {
    let [l1, l2] = l;
    let r = l1 * t[1].cos() + l2 * t[2].sin();
    [
        -t[0].sin() * r,
        l1 * t[1].sin() - l2 * t[2].cos() + l2,
        -l1 + t[0].cos() * r,
    ]
}

/// `J = d p / d t` (row = position component, column = joint), analytic.
pub fn jacobian(t: Vec3) -> [[f64; 3]; 3] {
    jacobian_with(t, [L1, L2])
}

/// [`jacobian`] for the link lengths `[l1, l2]`, m.
pub fn jacobian_with(t: Vec3, l: [f64; 2]) -> [[f64; 3]; 3] {
    let [l1, l2] = l;
    let (s1, c1) = t[0].sin_cos();
    let (s2, c2) = t[1].sin_cos();
    let (s3, c3) = t[2].sin_cos();
    let r = l1 * c2 + l2 * s3;
    [
        [-c1 * r, l1 * s1 * s2, -s1 * l2 * c3],
        [0.0, l1 * c2, l2 * s3],
        [-s1 * r, -l1 * c1 * s2, c1 * l2 * c3],
    ]
}

/// Joint torques, N m, rendering force `f`, N: `tau = J^T F`.
pub fn joint_torques(t: Vec3, f: Vec3) -> Vec3 {
    joint_torques_with(t, f, [L1, L2])
}

/// [`joint_torques`] for the link lengths `[l1, l2]`, m.
pub fn joint_torques_with(t: Vec3, f: Vec3, l: [f64; 2]) -> Vec3 {
    let j = jacobian_with(t, l);
    [
        j[0][0] * f[0] + j[1][0] * f[1] + j[2][0] * f[2],
        j[0][1] * f[0] + j[1][1] * f[1] + j[2][1] * f[2],
        j[0][2] * f[0] + j[1][2] * f[1] + j[2][2] * f[2],
    ]
}

#[cfg(test)]
mod tests {
    use super::*;
    use core::f64::consts::FRAC_PI_2;

    #[test]
    fn known_poses() {
        // All zero: r = l1, x = 0, y = -l2 + l2 = 0, z = -l1 + l1 = 0.
        let p = forward([0.0; 3]);
        assert!(p.iter().all(|v| v.abs() < 1e-15), "{p:?}");
        // Upper arm raised 90 deg: r = 0, y = l1 - l2 cos 0 + l2 = l1, z = -l1.
        let p = forward([0.0, FRAC_PI_2, 0.0]);
        assert!((p[1] - L1).abs() < 1e-12 && (p[2] + L1).abs() < 1e-12 && p[0].abs() < 1e-12);
        // Base turned 90 deg: the arm swings from +z to -x.
        let p = forward([FRAC_PI_2, 0.0, 0.0]);
        assert!((p[0] + L1).abs() < 1e-12 && (p[2] + L1).abs() < 1e-12);
    }

    #[test]
    fn jacobian_matches_finite_differences() {
        let h = 1e-6;
        for t in [
            [0.1, 0.2, 0.3],
            [-0.7, 0.4, 1.1],
            [0.0, 0.0, 0.0],
            [1.2, -0.3, 0.5],
        ] {
            let j = jacobian(t);
            for k in 0..3 {
                let mut tp = t;
                let mut tm = t;
                tp[k] += h;
                tm[k] -= h;
                let (pp, pm) = (forward(tp), forward(tm));
                for i in 0..3 {
                    let fd = (pp[i] - pm[i]) / (2.0 * h);
                    assert!(
                        (j[i][k] - fd).abs() < 1e-8,
                        "J[{i}][{k}] {} vs {fd}",
                        j[i][k]
                    );
                }
            }
            // Virtual work: tau . dt = F . dp.
            let f = [0.7, -1.1, 2.0];
            let tau = joint_torques(t, f);
            let dt = [1e-7, 2e-7, -1e-7];
            let p0 = forward(t);
            let p1 = forward([t[0] + dt[0], t[1] + dt[1], t[2] + dt[2]]);
            let wj: f64 = (0..3).map(|i| tau[i] * dt[i]).sum();
            let wc: f64 = (0..3).map(|i| f[i] * (p1[i] - p0[i])).sum();
            assert!((wj - wc).abs() < 1e-12, "{wj} vs {wc}");
        }
    }
}
