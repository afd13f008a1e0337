//! Per-tet rest data and the coupled projection of a tet's two stable Neo-Hookean constraints
//! (deviatoric and hydrostatic), solved together as one 2x2 system.

use glam::{Mat3, Vec3};

use super::material::Lame;
use crate::geom;

/// What a tet keeps from its rest shape: the inverse rest shape matrix, the rest volume and
/// its material's compliances. 52 bytes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TetRest {
    /// Inverse of `Dm = [X1 - X0, X2 - X0, X3 - X0]` (rest edge vectors as columns).
    pub inv_dm: Mat3,
    /// Rest volume.
    pub volume: f32,
    /// Compliance of the deviatoric constraint: `1 / (mu V)`.
    pub alpha_dev: f32,
    /// Compliance of the hydrostatic constraint: `1 / ((lambda + mu) V)`.
    pub alpha_hydro: f32,
    /// Rest value of `det F` in the hydrostatic constraint ([`Lame::gamma`]).
    pub gamma: f32,
}

const _: () = assert!(core::mem::size_of::<TetRest>() == 52);

impl Default for TetRest {
    fn default() -> Self {
        Self {
            inv_dm: Mat3::IDENTITY,
            volume: 0.0,
            alpha_dev: 0.0,
            alpha_hydro: 0.0,
            gamma: 1.0,
        }
    }
}

impl TetRest {
    /// All zero (for initialising static storage; [`crate::soft::SoftBody::new`] fills it).
    pub const ZERO: Self = Self {
        inv_dm: Mat3::ZERO,
        volume: 0.0,
        alpha_dev: 0.0,
        alpha_hydro: 0.0,
        gamma: 0.0,
    };

    /// Rest data for the tet with corners `x` (positively oriented) and material `lame`, or
    /// `None` when the tet is inverted, degenerate (volume not above `1e-7` times the cube of
    /// its longest edge) or its inverse shape matrix is not finite.
    ///
    /// # Bounded work
    /// Constant.
    pub fn new(x: [Vec3; 4], lame: Lame) -> Option<Self> {
        let det = geom::det6_f64(x[0], x[1], x[2], x[3]);
        let mut longest = 0.0f64;
        for i in 0..4 {
            for j in i + 1..4 {
                longest = longest.max((x[i] - x[j]).length() as f64);
            }
        }
        let floor = 6.0 * 1e-7 * longest * longest * longest;
        if det.is_nan() || det <= floor {
            return None;
        }
        let dm = Mat3::from_cols(x[1] - x[0], x[2] - x[0], x[3] - x[0]);
        let inv_dm = dm.inverse();
        if !inv_dm.is_finite() {
            return None;
        }
        let volume = (det / 6.0) as f32;
        let v = volume as f64;
        Some(Self {
            inv_dm,
            volume,
            alpha_dev: (1.0 / (lame.mu as f64 * v)) as f32,
            alpha_hydro: (1.0 / (lame.hydro as f64 * v)) as f32,
            gamma: lame.gamma,
        })
    }

    /// The deformation gradient `F = I + [u1 - u0, u2 - u0, u3 - u0] Dm^-1` from the corner
    /// displacements `u` (displacements rather than positions keep small strains exact in
    /// f32 far from the origin).
    #[inline]
    pub fn deformation(&self, u: [Vec3; 4]) -> Mat3 {
        let us = Mat3::from_cols(u[1] - u[0], u[2] - u[0], u[3] - u[0]);
        Mat3::IDENTITY + us * self.inv_dm
    }

    /// Elastic energy of the tet at corner displacements `u`, zero at rest:
    /// `V (mu/2 (tr F^T F - 3) + (lambda + mu)/2 ((det F - gamma)^2 - (1 - gamma)^2))`, in f64.
    ///
    /// # Bounded work
    /// Constant.
    pub fn energy(&self, u: [Vec3; 4]) -> f64 {
        let f = self.deformation(u);
        let [a, b, c] =
            [f.x_axis, f.y_axis, f.z_axis].map(|v| [v.x as f64, v.y as f64, v.z as f64]);
        let d = |p: [f64; 3], q: [f64; 3]| p[0] * q[0] + p[1] * q[1] + p[2] * q[2];
        let frob = d(a, a) + d(b, b) + d(c, c);
        let cross = [
            b[1] * c[2] - b[2] * c[1],
            b[2] * c[0] - b[0] * c[2],
            b[0] * c[1] - b[1] * c[0],
        ];
        let det = d(a, cross);
        let v = self.volume as f64;
        let mu = 1.0 / (self.alpha_dev as f64 * v);
        let hydro = 1.0 / (self.alpha_hydro as f64 * v);
        let g = self.gamma as f64;
        v * (0.5 * mu * (frob - 3.0)
            + 0.5 * hydro * ((det - g) * (det - g) - (1.0 - g) * (1.0 - g)))
    }
}

/// One XPBD projection of a tet's deviatoric constraint `C_D = |F|` (compliance
/// `alpha_dev`) and hydrostatic constraint `C_H = det F - gamma` (compliance `alpha_hydro`),
/// solved as one 2x2 system so that the rest shape is an exact fixed point (at `F = I` the
/// two gradients are parallel and their pushes cancel). `u` are the corner displacements,
/// `w` their inverse masses, `lambda` the multipliers accumulated in this substep,
/// `inv_h2` one over the squared substep. Returns the corner corrections (zero when every
/// corner is fixed or the system is singular).
///
/// # Bounded work
/// Constant: about 250 floating-point operations.
#[inline]
pub fn project(
    rest: &TetRest,
    u: [Vec3; 4],
    w: [f32; 4],
    lambda: &mut [f32; 2],
    inv_h2: f32,
) -> [Vec3; 4] {
    let zero = [Vec3::ZERO; 4];
    if w[0] + w[1] + w[2] + w[3] <= 0.0 {
        return zero;
    }
    let f = rest.deformation(u);
    let inv_dm_t = rest.inv_dm.transpose();

    // Deviatoric: dC/dF = F / |F|.
    let frob = libm::sqrtf(
        f.x_axis.length_squared() + f.y_axis.length_squared() + f.z_axis.length_squared(),
    );
    let p_dev = if frob > 0.0 {
        f * (1.0 / frob)
    } else {
        Mat3::ZERO
    };
    // Hydrostatic: dC/dF = cof(F), columns f1 x f2, f2 x f0, f0 x f1.
    let (f0, f1, f2) = (f.x_axis, f.y_axis, f.z_axis);
    let p_hyd = Mat3::from_cols(f1.cross(f2), f2.cross(f0), f0.cross(f1));
    let det = f0.dot(f1.cross(f2));

    let g_dev = grads(p_dev * inv_dm_t);
    let g_hyd = grads(p_hyd * inv_dm_t);

    let (mut a00, mut a01, mut a11) = (0.0f32, 0.0f32, 0.0f32);
    for i in 0..4 {
        a00 += w[i] * g_dev[i].length_squared();
        a01 += w[i] * g_dev[i].dot(g_hyd[i]);
        a11 += w[i] * g_hyd[i].length_squared();
    }
    let ad = rest.alpha_dev * inv_h2;
    let ah = rest.alpha_hydro * inv_h2;
    let r0 = -(frob + ad * lambda[0]);
    let r1 = -(det - rest.gamma + ah * lambda[1]);
    let m00 = a00 + ad;
    let m11 = a11 + ah;
    let d = m00 * m11 - a01 * a01;
    // Positive for any positive compliance; NaN or zero means nothing sensible to do.
    if !(d > 0.0 && d.is_finite()) {
        return zero;
    }
    let dl0 = (r0 * m11 - a01 * r1) / d;
    let dl1 = (m00 * r1 - a01 * r0) / d;
    if !(dl0.is_finite() && dl1.is_finite()) {
        return zero;
    }
    lambda[0] += dl0;
    lambda[1] += dl1;
    let mut out = zero;
    for i in 0..4 {
        out[i] = (g_dev[i] * dl0 + g_hyd[i] * dl1) * w[i];
    }
    out
}

/// Per-corner gradients from `dC/dDs` (columns for corners 1..3; corner 0 takes minus their
/// sum).
#[inline]
fn grads(m: Mat3) -> [Vec3; 4] {
    let (g1, g2, g3) = (m.x_axis, m.y_axis, m.z_axis);
    [-(g1 + g2 + g3), g1, g2, g3]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::soft::Material;

    fn unit_tet() -> [Vec3; 4] {
        [Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z]
    }

    fn lame() -> Lame {
        Material {
            young: 1000.0,
            poisson: 0.3,
            density: 1.0,
        }
        .lame()
    }

    #[test]
    fn rest_data_of_the_unit_tet() {
        let r = TetRest::new(unit_tet(), lame()).unwrap();
        assert!((r.volume - 1.0 / 6.0).abs() < 1e-7);
        assert_eq!(r.inv_dm, Mat3::IDENTITY);
    }

    #[test]
    fn inverted_and_flat_tets_are_refused() {
        let [a, b, c, d] = unit_tet();
        assert!(TetRest::new([a, c, b, d], lame()).is_none());
        assert!(TetRest::new([a, b, c, Vec3::new(0.3, 0.3, 0.0)], lame()).is_none());
        assert!(TetRest::new([a, b, c, Vec3::new(0.3, 0.3, f32::NAN)], lame()).is_none());
    }

    #[test]
    fn rest_is_a_fixed_point_of_the_projection() {
        let r = TetRest::new(unit_tet(), lame()).unwrap();
        for inv_h2 in [1.0, 1e4, 1e8] {
            let mut l = [0.0; 2];
            let out = project(&r, [Vec3::ZERO; 4], [1.0; 4], &mut l, inv_h2);
            for c in out {
                assert!(c.length() < 1e-6, "{c:?} at 1/h^2 = {inv_h2}");
            }
        }
    }

    #[test]
    fn a_stretched_tet_is_pulled_back_and_momentum_is_kept() {
        let r = TetRest::new(unit_tet(), lame()).unwrap();
        // Corner 1 pulled out along x by 0.1.
        let u = [Vec3::ZERO, Vec3::X * 0.1, Vec3::ZERO, Vec3::ZERO];
        let mut l = [0.0; 2];
        let out = project(&r, u, [1.0; 4], &mut l, 1.0);
        assert!(out[1].x < 0.0, "{out:?}");
        let sum = out[0] + out[1] + out[2] + out[3];
        assert!(sum.length() < 1e-6, "{sum:?}");
        assert!(r.energy(u) > 0.0);
        assert!(r.energy([Vec3::ZERO; 4]).abs() < 1e-9);
    }

    #[test]
    fn fully_fixed_tets_do_not_move() {
        let r = TetRest::new(unit_tet(), lame()).unwrap();
        let u = [Vec3::ZERO, Vec3::X * 0.1, Vec3::ZERO, Vec3::ZERO];
        let mut l = [0.0; 2];
        assert_eq!(project(&r, u, [0.0; 4], &mut l, 1.0), [Vec3::ZERO; 4]);
    }
}
