//! Per-tet rest data and the coupled projection of a tet's two constraints, a deviatoric one
//! on the Green strain and a volumetric one on `det F - 1`, both zero at rest and formed from
//! the displacement gradient, solved together as one 2x2 system.

use glam::{Mat3, Vec3};

use super::material::Lame;
use crate::geom;

/// What a tet keeps from its rest shape: the inverse rest shape matrix, the rest volume and
/// its material's compliances. 52 bytes.
#[derive(Debug, Clone, Copy, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C)]
pub struct TetRest {
    /// Inverse of `Dm = [X1 - X0, X2 - X0, X3 - X0]` (rest edge vectors as columns).
    pub inv_dm: Mat3,
    /// Rest volume.
    pub volume: f32,
    /// Compliance of the deviatoric constraint `|dev E|`: `1 / (2 mu V)`.
    pub alpha_dev: f32,
    /// Compliance of the volumetric constraint `det F - gamma`: `1 / (K V)`, `K = lambda +
    /// 2 mu / 3` the bulk modulus.
    pub alpha_hydro: f32,
    /// Rest value of `det F` in the volumetric constraint: 1 (the rest shape).
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
        let mu = lame.mu as f64;
        // `hydro` is Lamé lambda + mu, so the bulk modulus lambda + 2 mu / 3 is hydro - mu / 3.
        let bulk = lame.hydro as f64 - mu / 3.0;
        Some(Self {
            inv_dm,
            volume,
            alpha_dev: (1.0 / (2.0 * mu * v)) as f32,
            alpha_hydro: (1.0 / (bulk * v)) as f32,
            gamma: 1.0,
        })
    }

    /// The displacement gradient `H = F - I = [u1 - u0, u2 - u0, u3 - u0] Dm^-1` from the
    /// corner displacements `u` (formed without the identity, so small strains keep their
    /// f32 precision whatever their size).
    #[inline]
    pub fn displacement_gradient(&self, u: [Vec3; 4]) -> Mat3 {
        let us = Mat3::from_cols(u[1] - u[0], u[2] - u[0], u[3] - u[0]);
        us * self.inv_dm
    }

    /// The deformation gradient `F = I + H` ([`Self::displacement_gradient`]).
    #[inline]
    pub fn deformation(&self, u: [Vec3; 4]) -> Mat3 {
        Mat3::IDENTITY + self.displacement_gradient(u)
    }

    /// Elastic energy of the tet at corner displacements `u`, zero at rest:
    /// `V (mu |dev E|^2 + K/2 (det F - 1)^2)` with `E = (F^T F - I) / 2` the Green strain,
    /// that is `C_D^2 / (2 alpha_dev) + C_H^2 / (2 alpha_hydro)`, in f64.
    ///
    /// # Bounded work
    /// Constant.
    pub fn energy(&self, u: [Vec3; 4]) -> f64 {
        let h = self.displacement_gradient(u);
        let h = [h.x_axis, h.y_axis, h.z_axis].map(|c| [c.x as f64, c.y as f64, c.z as f64]);
        // h[j][i] is row i, column j.
        let at = |i: usize, j: usize| h[j][i];
        let mut e = [[0.0f64; 3]; 3];
        for (i, row) in e.iter_mut().enumerate() {
            for (j, x) in row.iter_mut().enumerate() {
                let hth: f64 = (0..3).map(|k| at(k, i) * at(k, j)).sum();
                *x = 0.5 * (at(i, j) + at(j, i) + hth);
            }
        }
        let tr = (e[0][0] + e[1][1] + e[2][2]) / 3.0;
        let mut dev2 = 0.0;
        for (i, row) in e.iter().enumerate() {
            for (j, x) in row.iter().enumerate() {
                let d = if i == j { x - tr } else { *x };
                dev2 += d * d;
            }
        }
        let f = |i: usize, j: usize| at(i, j) + if i == j { 1.0 } else { 0.0 };
        let det = f(0, 0) * (f(1, 1) * f(2, 2) - f(1, 2) * f(2, 1))
            - f(0, 1) * (f(1, 0) * f(2, 2) - f(1, 2) * f(2, 0))
            + f(0, 2) * (f(1, 0) * f(2, 1) - f(1, 1) * f(2, 0));
        let ch = det - self.gamma as f64;
        dev2 / (2.0 * self.alpha_dev as f64) + ch * ch / (2.0 * self.alpha_hydro as f64)
    }
}

/// One XPBD projection of a tet's deviatoric constraint `C_D = |dev E|` (compliance
/// `alpha_dev`; `E = (F^T F - I) / 2 = (H + H^T + H^T H) / 2` the Green strain, `dev E = E -
/// tr E / 3 I`) and volumetric constraint `C_H = det F - gamma` (compliance `alpha_hydro`,
/// `gamma = 1`; `det F - 1 = tr H + (tr^2 H - tr H^2) / 2 + det H`), solved as one 2x2 system.
/// Both constraints and both gradients (`dC_D/dF = F dev E / |dev E|`, `dC_H/dF = cof F =
/// (1 + tr H) I - H^T + cof H`) are formed from the displacement gradient `H`, so the rest
/// shape gives exactly zero and a small strain its own pushes, with no large opposing terms
/// whatever the stiffness or the mesh's scale. The 2x2 system is solved in a basis where its
/// determinant is a sum of non-negative terms. `u` are the corner displacements, `w` their
/// inverse masses, `lambda` the multipliers accumulated in this substep, `inv_h2` one over
/// the squared substep. Returns the corner corrections (zero when every corner is fixed or
/// the system is singular).
///
/// # Bounded work
/// Constant: about 400 floating-point operations.
#[inline]
pub(crate) fn project(
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
    let h = strain_floor(rest.displacement_gradient(u));
    let ht = h.transpose();
    let tr_h = h.x_axis.x + h.y_axis.y + h.z_axis.z;

    // Green strain and its deviator.
    let e = (h + ht + ht * h) * 0.5;
    let tr_e = (e.x_axis.x + e.y_axis.y + e.z_axis.z) * (1.0 / 3.0);
    let dev = e - Mat3::from_diagonal(Vec3::splat(tr_e));
    let c_dev = libm::sqrtf(
        dev.x_axis.length_squared() + dev.y_axis.length_squared() + dev.z_axis.length_squared(),
    );
    // dC_D/dF = F dev / |dev| = (dev + H dev) / |dev|; undefined (taken as zero) at dev = 0,
    // where C_D is zero too.
    let p_dev = if c_dev > 0.0 {
        (dev + h * dev) * (1.0 / c_dev)
    } else {
        Mat3::ZERO
    };

    // det F - 1 and cof F from H: the cofactor of H has the columns h1 x h2, h2 x h0, h0 x h1.
    let (h0, h1, h2) = (h.x_axis, h.y_axis, h.z_axis);
    let cof_h = Mat3::from_cols(h1.cross(h2), h2.cross(h0), h0.cross(h1));
    let tr_h2 =
        h0.x * h0.x + h1.y * h1.y + h2.z * h2.z + 2.0 * (h1.x * h0.y + h2.x * h0.z + h2.y * h1.z);
    let minors = 0.5 * (tr_h * tr_h - tr_h2);
    let det_h = h0.dot(cof_h.x_axis);
    let c_hyd = tr_h + minors + det_h - (rest.gamma - 1.0);
    let p_hyd = Mat3::from_diagonal(Vec3::splat(1.0 + tr_h)) - ht + cof_h;

    let inv_dm_t = rest.inv_dm.transpose();
    let g_dev = grads(p_dev * inv_dm_t);
    let g_hyd = grads(p_hyd * inv_dm_t);

    let (mut a01, mut a11) = (0.0f32, 0.0f32);
    for i in 0..4 {
        a01 += w[i] * g_dev[i].dot(g_hyd[i]);
        a11 += w[i] * g_hyd[i].length_squared();
    }
    // W-orthogonal basis: e = g_dev - k g_hyd, so |g_dev|_W^2 = |e|_W^2 + k^2 a11 and the
    // determinant below has no cancelling terms.
    let k = if a11 > 0.0 { a01 / a11 } else { 0.0 };
    let mut ee = 0.0f32;
    for i in 0..4 {
        ee += w[i] * (g_dev[i] - g_hyd[i] * k).length_squared();
    }
    let a01 = k * a11;
    let ad = rest.alpha_dev * inv_h2;
    let ah = rest.alpha_hydro * inv_h2;
    let r0 = -(c_dev + ad * lambda[0]);
    let r1 = -(c_hyd + ah * lambda[1]);
    let m00 = ee + k * k * a11 + ad;
    let m11 = a11 + ah;
    let d = (ee + ad) * m11 + k * k * a11 * ah;
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

/// Displacement gradients below this (dimensionless strain) are taken as zero in a tet's
/// solve: a body at rest pressed at one point carries a front of ever smaller displacements,
/// and the solve's squares and cubes of such gradients are subnormal floats, which cost x86-64
/// a hundred times a normal operation (a pressed cow's first steps took 29-37 ms against 6).
/// At 1e-12 every square is at least 1e-24 and every cube 1e-36, normal floats; a strain of
/// 1e-12 moves nothing any instrument measures (docs/SOFT.md, "Timing").
pub(crate) const STRAIN_FLOOR: f32 = 1e-12;

/// `h` with each entry below [`STRAIN_FLOOR`] in magnitude set to zero (a NaN kept).
#[inline]
fn strain_floor(h: Mat3) -> Mat3 {
    let floor = |v: Vec3| {
        let m = |x: f32| if x.abs() < STRAIN_FLOOR { 0.0 } else { x };
        Vec3::new(m(v.x), m(v.y), m(v.z))
    };
    Mat3::from_cols(floor(h.x_axis), floor(h.y_axis), floor(h.z_axis))
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
    fn rest_is_an_exact_fixed_point_at_any_stiffness_and_scale() {
        let tet = [
            Vec3::new(0.1, -0.2, 0.3),
            Vec3::new(1.2, 0.1, 0.2),
            Vec3::new(0.3, 0.9, 0.1),
            Vec3::new(0.2, 0.3, 1.4),
        ];
        for scale in [1e-4f32, 1e-2, 1.0, 1e3] {
            for young in [1e3f32, 1e7, 84e9] {
                let m = Material {
                    young,
                    poisson: 0.33,
                    density: 2900.0,
                };
                let x = tet.map(|p| p * scale);
                let r = TetRest::new(x, m.lame()).unwrap();
                let mass = 2900.0 * r.volume / 4.0;
                let w = [1.0 / mass; 4];
                let mut l = [0.0; 2];
                let out = project(&r, [Vec3::ZERO; 4], w, &mut l, 1e8);
                assert_eq!(out, [Vec3::ZERO; 4], "scale {scale}, E {young}");
                // A rigid turn: only rounding, a small fraction of the tet's size.
                let rot = glam::Quat::from_axis_angle(Vec3::new(1.0, 2.0, 3.0).normalize(), 0.7);
                let u = x.map(|p| rot * p - p);
                let mut l = [0.0; 2];
                let out = project(&r, u, w, &mut l, 1e8);
                for c in out {
                    assert!(
                        c.length() < 1e-6 * scale,
                        "{c:?} at scale {scale}, E {young}"
                    );
                }
            }
        }
    }

    #[test]
    fn a_soft_projection_is_the_energy_gradient_step() {
        // With compliance far above |grad C|_W^2 h^2 the correction is -h^2 W grad(energy);
        // the gradient by central differences of the f64 energy.
        let x = [
            Vec3::ZERO,
            Vec3::new(1.0, 0.1, 0.0),
            Vec3::new(0.2, 1.0, 0.1),
            Vec3::new(0.1, 0.2, 1.0),
        ];
        let r = TetRest::new(x, lame()).unwrap();
        let u = [
            Vec3::new(0.01, -0.02, 0.0),
            Vec3::new(0.03, 0.01, -0.02),
            Vec3::new(-0.01, 0.02, 0.01),
            Vec3::new(0.0, -0.01, 0.04),
        ];
        let inv_h2 = 1e6;
        let mut l = [0.0; 2];
        let out = project(&r, u, [1.0; 4], &mut l, inv_h2);
        let step = 1e-3f32;
        let mut worst = 0.0f64;
        let mut size = 0.0f64;
        for i in 0..4 {
            for a in 0..3 {
                let mut up = u;
                let mut dn = u;
                up[i][a] += step;
                dn[i][a] -= step;
                let grad = (r.energy(up) - r.energy(dn)) / (2.0 * step as f64);
                let want = -grad / inv_h2 as f64;
                worst = worst.max((out[i][a] as f64 - want).abs());
                size = size.max(want.abs());
            }
        }
        assert!(size > 0.0 && worst < 0.01 * size, "{worst} of {size}");
    }

    #[test]
    fn fully_fixed_tets_do_not_move() {
        let r = TetRest::new(unit_tet(), lame()).unwrap();
        let u = [Vec3::ZERO, Vec3::X * 0.1, Vec3::ZERO, Vec3::ZERO];
        let mut l = [0.0; 2];
        assert_eq!(project(&r, u, [0.0; 4], &mut l, 1.0), [Vec3::ZERO; 4]);
    }
}
