//! Four tets that share no node projected at once, one per lane of four-wide f32 arithmetic
//! ([`project4`]), with the operations of [`super::project`] in its order, lane by lane, so
//! each lane's result is that function's bits. Tets that share no node commute in a
//! Gauss-Seidel sweep (neither reads what the other writes), so a sweep that solves such a
//! group at once gives the bits of solving them one after the other: the lanes change the
//! time of a sweep, never its result.
//!
//! The lanes are `wide::f32x4` (SSE2 on x86-64, NEON on AArch64): each operation is the
//! IEEE 754 one per lane (no fused multiply-add), the square root correctly rounded as
//! `libm::sqrtf`'s, so a lane gives the scalar bits. Compiled where the target has four-wide
//! f32 arithmetic; elsewhere (the Cortex-M4F, scalar f32) the sweep solves one tet at a time.

use core::ops::{Add, Div, Mul, Neg, Sub};

use glam::Vec3;
use wide::f32x4;

use super::TetRest;

/// Four f32 lanes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct F4(f32x4);

macro_rules! lane_op {
    ($tr:ident, $f:ident, $op:tt) => {
        impl $tr for F4 {
            type Output = F4;
            #[inline(always)]
            fn $f(self, o: F4) -> F4 {
                F4(self.0 $op o.0)
            }
        }
    };
}
lane_op!(Add, add, +);
lane_op!(Sub, sub, -);
lane_op!(Mul, mul, *);
lane_op!(Div, div, /);

impl Neg for F4 {
    type Output = F4;
    #[inline(always)]
    fn neg(self) -> F4 {
        F4(-self.0)
    }
}

/// Four lanes' truth values (all bits set or clear per lane).
#[derive(Debug, Clone, Copy)]
struct Mask(f32x4);

/// `[f(0), f(1), f(2), f(3)]`, written out (an array's `map` is not always inlined, and a
/// call in the kernel spills every lane register).
#[inline(always)]
pub(super) fn each<T>(f: impl Fn(usize) -> T) -> [T; 4] {
    [f(0), f(1), f(2), f(3)]
}

impl F4 {
    #[inline(always)]
    pub(super) fn new(a: [f32; 4]) -> Self {
        Self(f32x4::new(a))
    }

    #[inline(always)]
    pub(super) fn splat(x: f32) -> Self {
        Self(f32x4::splat(x))
    }

    #[inline(always)]
    pub(super) fn to_array(self) -> [f32; 4] {
        self.0.to_array()
    }

    #[inline(always)]
    fn gt_zero(self) -> Mask {
        Mask(self.0.simd_gt(f32x4::ZERO))
    }

    #[inline(always)]
    fn finite(self) -> Mask {
        Mask(self.0.is_finite())
    }

    /// Correctly rounded, as `libm::sqrtf` (IEEE 754 square root).
    #[inline(always)]
    fn sqrt(self) -> Self {
        Self(self.0.sqrt())
    }

    /// `self` where `m`, else `other`.
    #[inline(always)]
    fn or(self, other: Self, m: Mask) -> Self {
        Self(m.0.bitselect(self.0, other.0))
    }

    /// `self` where `m`, else zero.
    #[inline(always)]
    fn or_zero(self, m: Mask) -> Self {
        Self(self.0 & m.0)
    }

    /// Zero where `|self| < floor`, else `self` (a NaN kept), as the one-tet solve's floor.
    #[inline(always)]
    fn floored(self, floor: f32) -> Self {
        let below = self.0.abs().simd_lt(f32x4::splat(floor));
        Self(below.bitselect(f32x4::ZERO, self.0))
    }
}

#[inline(always)]
fn and(a: Mask, b: Mask) -> Mask {
    Mask(a.0 & b.0)
}

/// A vector per lane, as `glam::Vec3`'s operations compute it.
#[derive(Debug, Clone, Copy)]
pub(super) struct V3 {
    pub(super) x: F4,
    pub(super) y: F4,
    pub(super) z: F4,
}

impl V3 {
    #[inline(always)]
    fn zero() -> Self {
        let z = F4::splat(0.0);
        V3 { x: z, y: z, z }
    }

    /// Lane `i` holds `v[i]`.
    #[inline(always)]
    pub(super) fn gather(v: [Vec3; 4]) -> Self {
        Self {
            x: F4::new(each(|i| v[i].x)),
            y: F4::new(each(|i| v[i].y)),
            z: F4::new(each(|i| v[i].z)),
        }
    }

    /// Lane `i`'s vector.
    #[inline(always)]
    pub(super) fn lane(&self, i: usize) -> Vec3 {
        let (x, y, z) = (self.x.to_array(), self.y.to_array(), self.z.to_array());
        Vec3::new(x[i], y[i], z[i])
    }

    #[inline(always)]
    fn scale(self, s: F4) -> Self {
        Self {
            x: self.x * s,
            y: self.y * s,
            z: self.z * s,
        }
    }

    /// `x x' + y y' + z z'`, left to right.
    #[inline(always)]
    fn dot(self, o: Self) -> F4 {
        self.x * o.x + self.y * o.y + self.z * o.z
    }

    #[inline(always)]
    fn cross(self, o: Self) -> Self {
        Self {
            x: self.y * o.z - o.y * self.z,
            y: self.z * o.x - o.z * self.x,
            z: self.x * o.y - o.x * self.y,
        }
    }

    #[inline(always)]
    fn or_zero(self, m: Mask) -> Self {
        Self {
            x: self.x.or_zero(m),
            y: self.y.or_zero(m),
            z: self.z.or_zero(m),
        }
    }
}

/// `Add` and `Sub` of a type of three fields `x`, `y`, `z`, field by field.
macro_rules! fieldwise {
    ($t:ty) => {
        impl Add for $t {
            type Output = $t;
            #[inline(always)]
            fn add(self, o: $t) -> $t {
                Self {
                    x: self.x + o.x,
                    y: self.y + o.y,
                    z: self.z + o.z,
                }
            }
        }

        impl Sub for $t {
            type Output = $t;
            #[inline(always)]
            fn sub(self, o: $t) -> $t {
                Self {
                    x: self.x - o.x,
                    y: self.y - o.y,
                    z: self.z - o.z,
                }
            }
        }
    };
}
fieldwise!(V3);
fieldwise!(M3);

impl Neg for V3 {
    type Output = V3;
    #[inline(always)]
    fn neg(self) -> V3 {
        V3 {
            x: -self.x,
            y: -self.y,
            z: -self.z,
        }
    }
}

/// A 3x3 matrix per lane by columns, as `glam::Mat3`'s operations compute it.
#[derive(Debug, Clone, Copy)]
pub(super) struct M3 {
    x: V3,
    y: V3,
    z: V3,
}

impl M3 {
    /// Each entry floored ([`F4::floored`]).
    #[inline(always)]
    fn floored(self, floor: f32) -> Self {
        let v = |c: V3| V3 {
            x: c.x.floored(floor),
            y: c.y.floored(floor),
            z: c.z.floored(floor),
        };
        Self {
            x: v(self.x),
            y: v(self.y),
            z: v(self.z),
        }
    }

    /// Lane `i` holds `m[i]`.
    #[inline(always)]
    pub(super) fn gather(m: [glam::Mat3; 4]) -> Self {
        Self {
            x: V3::gather(each(|i| m[i].x_axis)),
            y: V3::gather(each(|i| m[i].y_axis)),
            z: V3::gather(each(|i| m[i].z_axis)),
        }
    }

    #[inline(always)]
    fn transpose(self) -> Self {
        Self {
            x: V3 {
                x: self.x.x,
                y: self.y.x,
                z: self.z.x,
            },
            y: V3 {
                x: self.x.y,
                y: self.y.y,
                z: self.z.y,
            },
            z: V3 {
                x: self.x.z,
                y: self.y.z,
                z: self.z.z,
            },
        }
    }

    /// `x v.x + y v.y + z v.z`, left to right (`Mat3::mul_vec3`).
    #[inline(always)]
    fn mul_v3(self, v: V3) -> V3 {
        self.x.scale(v.x) + self.y.scale(v.y) + self.z.scale(v.z)
    }

    #[inline(always)]
    fn mul(self, o: Self) -> Self {
        Self {
            x: self.mul_v3(o.x),
            y: self.mul_v3(o.y),
            z: self.mul_v3(o.z),
        }
    }

    #[inline(always)]
    fn scale(self, s: F4) -> Self {
        Self {
            x: self.x.scale(s),
            y: self.y.scale(s),
            z: self.z.scale(s),
        }
    }
}

/// Per-corner gradients from `dC/dDs` (columns for corners 1..3; corner 0 takes minus their
/// sum), as `tet::grads`.
#[inline(always)]
fn grads(m: M3) -> [V3; 4] {
    [-(m.x + m.y + m.z), m.x, m.y, m.z]
}

/// The rest data of four tets, one per lane.
#[derive(Debug, Clone, Copy)]
pub(super) struct Rest4 {
    pub(super) inv_dm: M3,
    pub(super) alpha_dev: F4,
    pub(super) alpha_hydro: F4,
    pub(super) gamma: F4,
}

impl Rest4 {
    #[inline(always)]
    pub(super) fn gather(r: [&TetRest; 4]) -> Self {
        Self {
            inv_dm: M3::gather(each(|i| r[i].inv_dm)),
            alpha_dev: F4::new(each(|i| r[i].alpha_dev)),
            alpha_hydro: F4::new(each(|i| r[i].alpha_hydro)),
            gamma: F4::new(each(|i| r[i].gamma)),
        }
    }
}

/// [`super::project`] for four tets at once, lane `i` the `i`th tet: `u` the corners'
/// displacements, `w` their inverse masses, `lambda` the two multipliers (updated where a
/// lane's solve succeeds). Returns the corner corrections, zero in a lane whose corners are
/// all fixed or whose system is singular, as the one-tet function returns.
///
/// # Bounded work
/// Constant: the one-tet function's operations, four lanes wide.
#[inline(always)]
pub(super) fn project4(
    rest: &Rest4,
    u: [V3; 4],
    w: [F4; 4],
    lambda: &mut [F4; 2],
    inv_h2: f32,
) -> [V3; 4] {
    let active = (w[0] + w[1] + w[2] + w[3]).gt_zero();

    // H = [u1 - u0, u2 - u0, u3 - u0] Dm^-1.
    let us = M3 {
        x: u[1] - u[0],
        y: u[2] - u[0],
        z: u[3] - u[0],
    };
    let h = us.mul(rest.inv_dm).floored(super::tet::STRAIN_FLOOR);
    let ht = h.transpose();
    let tr_h = h.x.x + h.y.y + h.z.z;

    // Green strain and its deviator (the off-diagonal `- 0.0` of `Mat3::from_diagonal`
    // changes no bit and is left out).
    let half = F4::splat(0.5);
    let e = (h + ht + ht.mul(h)).scale(half);
    let tr_e = (e.x.x + e.y.y + e.z.z) * F4::splat(1.0 / 3.0);
    let mut dev = e;
    dev.x.x = e.x.x - tr_e;
    dev.y.y = e.y.y - tr_e;
    dev.z.z = e.z.z - tr_e;
    let c_dev = (dev.x.dot(dev.x) + dev.y.dot(dev.y) + dev.z.dot(dev.z)).sqrt();
    let has_dev = c_dev.gt_zero();
    let inv_c = F4::splat(1.0) / c_dev;
    let p_dev_raw = (dev + h.mul(dev)).scale(inv_c);
    let p_dev = M3 {
        x: p_dev_raw.x.or_zero(has_dev),
        y: p_dev_raw.y.or_zero(has_dev),
        z: p_dev_raw.z.or_zero(has_dev),
    };

    // det F - 1 and cof F from H.
    let (h0, h1, h2) = (h.x, h.y, h.z);
    let cof_h = M3 {
        x: h1.cross(h2),
        y: h2.cross(h0),
        z: h0.cross(h1),
    };
    let tr_h2 = h0.x * h0.x
        + h1.y * h1.y
        + h2.z * h2.z
        + F4::splat(2.0) * (h1.x * h0.y + h2.x * h0.z + h2.y * h1.z);
    let minors = half * (tr_h * tr_h - tr_h2);
    let det_h = h0.dot(cof_h.x);
    let one = F4::splat(1.0);
    let c_hyd = tr_h + minors + det_h - (rest.gamma - one);
    // diag(1 + tr H) - H^T + cof H, the off-diagonal as `0.0 - x` (the sign of a zero kept).
    let zero = F4::splat(0.0);
    let diag = one + tr_h;
    let p_hyd = M3 {
        x: V3 {
            x: diag - ht.x.x,
            y: zero - ht.x.y,
            z: zero - ht.x.z,
        },
        y: V3 {
            x: zero - ht.y.x,
            y: diag - ht.y.y,
            z: zero - ht.y.z,
        },
        z: V3 {
            x: zero - ht.z.x,
            y: zero - ht.z.y,
            z: diag - ht.z.z,
        },
    } + cof_h;

    let inv_dm_t = rest.inv_dm.transpose();
    let g_dev = grads(p_dev.mul(inv_dm_t));
    let g_hyd = grads(p_hyd.mul(inv_dm_t));

    let (mut a01, mut a11) = (zero, zero);
    for i in 0..4 {
        a01 = a01 + w[i] * g_dev[i].dot(g_hyd[i]);
        a11 = a11 + w[i] * g_hyd[i].dot(g_hyd[i]);
    }
    let k = (a01 / a11).or_zero(a11.gt_zero());
    let mut ee = zero;
    for i in 0..4 {
        let e = g_dev[i] - g_hyd[i].scale(k);
        ee = ee + w[i] * e.dot(e);
    }
    let a01 = k * a11;
    let inv_h2 = F4::splat(inv_h2);
    let ad = rest.alpha_dev * inv_h2;
    let ah = rest.alpha_hydro * inv_h2;
    let r0 = -(c_dev + ad * lambda[0]);
    let r1 = -(c_hyd + ah * lambda[1]);
    let m00 = ee + k * k * a11 + ad;
    let m11 = a11 + ah;
    let d = (ee + ad) * m11 + k * k * a11 * ah;
    let dl0 = (r0 * m11 - a01 * r1) / d;
    let dl1 = (m00 * r1 - a01 * r0) / d;
    let ok = and(
        and(active, and(d.gt_zero(), d.finite())),
        and(dl0.finite(), dl1.finite()),
    );
    // A lane that fails keeps its multipliers as they are (not `+ 0.0`, which would turn a
    // -0.0 into +0.0).
    lambda[0] = (lambda[0] + dl0).or(lambda[0], ok);
    lambda[1] = (lambda[1] + dl1).or(lambda[1], ok);
    let (dl0, dl1) = (dl0.or_zero(ok), dl1.or_zero(ok));
    let mut out = [V3::zero(); 4];
    for i in 0..4 {
        out[i] = (g_dev[i].scale(dl0) + g_hyd[i].scale(dl1))
            .scale(w[i])
            .or_zero(ok);
    }
    out
}

/// The node slots of four tets (`k - first_node`), when all are below `nodes` and no two of
/// the tets share one.
///
/// # Bounded work
/// Constant: at most 96 comparisons.
#[inline(always)]
pub(super) fn disjoint(
    group: &[[u32; 4]],
    first_node: usize,
    nodes: usize,
) -> Option<[[usize; 4]; 4]> {
    let [t0, t1, t2, t3] = group else {
        return None;
    };
    let t = [*t0, *t1, *t2, *t3];
    for a in 0..3 {
        for b in a + 1..4 {
            if t[a].iter().any(|k| t[b].contains(k)) {
                return None;
            }
        }
    }
    let slots = each(|j| each(|c| (t[j][c] as usize).wrapping_sub(first_node)));
    if slots.iter().flatten().all(|&s| s < nodes) {
        Some(slots)
    } else {
        None
    }
}

/// Four tets that share no node solved at once ([`project4`]), lane `j` the `j`th tet;
/// `slots` their nodes' slots, all in range ([`disjoint`]).
#[inline(always)]
pub(super) fn solve4(
    slots: [[usize; 4]; 4],
    rest: &[TetRest],
    lambda: &mut [[f32; 2]],
    displacement: &mut [Vec3],
    inv_mass: &[f32],
    first: bool,
    inv_h2: f32,
) {
    let ([r0, r1, r2, r3], [l0, l1, l2, l3]) = (rest, lambda) else {
        return;
    };
    let rest = Rest4::gather([r0, r1, r2, r3]);
    let mut lam = if first {
        [F4::splat(0.0); 2]
    } else {
        [
            F4::new([l0[0], l1[0], l2[0], l3[0]]),
            F4::new([l0[1], l1[1], l2[1], l3[1]]),
        ]
    };
    // Corner c of lane j is node slots[j][c]; in range (checked by `disjoint`).
    let d: &[Vec3] = displacement;
    let u = each(|c| V3::gather(each(|j| d.get(slots[j][c]).copied().unwrap_or_default())));
    let w = each(|c| F4::new(each(|j| inv_mass.get(slots[j][c]).copied().unwrap_or(0.0))));
    let du = project4(&rest, u, w, &mut lam, inv_h2);
    for (j, l) in [l0, l1, l2, l3].into_iter().enumerate() {
        *l = [lam[0].to_array()[j], lam[1].to_array()[j]];
    }
    for (c, du) in du.iter().enumerate() {
        for (j, s) in slots.iter().enumerate() {
            if let Some(x) = displacement.get_mut(s[c]) {
                *x += du.lane(j);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::resume::{sweep, TetRun};
    use super::super::{project, Material};
    use super::*;
    use crate::collide::test_support::Rng;

    /// A vector of components drawn in `[-scale, scale)`.
    fn vec(rng: &mut Rng, scale: f32) -> Vec3 {
        Vec3::new(
            rng.range(-1.0, 1.0),
            rng.range(-1.0, 1.0),
            rng.range(-1.0, 1.0),
        ) * scale
    }

    /// A whole number drawn in `0..n`.
    fn below(rng: &mut Rng, n: u32) -> u32 {
        ((rng.next() * n as f32) as u32).min(n - 1)
    }

    /// A positively oriented tet near the unit corner tet, of size `size`, with material
    /// `young`.
    fn rest(rng: &mut Rng, size: f32, young: f32) -> TetRest {
        loop {
            let x = [
                vec(rng, 0.3),
                Vec3::X + vec(rng, 0.3),
                Vec3::Y + vec(rng, 0.3),
                Vec3::Z + vec(rng, 0.3),
            ]
            .map(|p| p * size);
            let m = Material {
                young,
                poisson: 0.3,
                density: 1.0,
            };
            if let Some(r) = TetRest::new(x, m.lame()) {
                return r;
            }
        }
    }

    fn bits(v: Vec3) -> [u32; 3] {
        v.to_array().map(f32::to_bits)
    }

    #[test]
    fn each_lane_is_the_one_tet_projection_bit_for_bit() {
        let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
        for case in 0..4000 {
            let size = [1e-3, 1.0, 40.0][case % 3];
            let strain = [0.0, 1e-7, 1e-3, 0.3, 2.0][case % 5];
            let rests: [TetRest; 4] =
                core::array::from_fn(|_| rest(&mut rng, size, [1e3, 1e7][case % 2]));
            let mut u = [[Vec3::ZERO; 4]; 4];
            let mut w = [[1.0f32; 4]; 4];
            let mut lambda = [[0.0f32; 2]; 4];
            for j in 0..4 {
                for c in 0..4 {
                    u[j][c] = vec(&mut rng, strain * size);
                    // Some corners fixed, and now and then a lane with every corner fixed.
                    w[j][c] = match below(&mut rng, 6) {
                        0 => 0.0,
                        1 => 1e-3,
                        _ => 1.0 + rng.range(-1.0, 1.0),
                    };
                }
                if below(&mut rng, 9) == 0 {
                    w[j] = [0.0; 4];
                }
                if case % 4 != 0 {
                    lambda[j] = [rng.range(-1e-3, 1e-3), rng.range(-1e-3, 1e-3)];
                }
            }
            // A lane without strain: its deviator is zero, the gradient taken as zero.
            if case % 7 == 0 {
                u[1] = [Vec3::splat(0.25 * size); 4];
            }
            let inv_h2 = [1.0, 1e4, 1e8][case % 3];
            let mut lam4 = [F4::new(lambda.map(|l| l[0])), F4::new(lambda.map(|l| l[1]))];
            let u4 = core::array::from_fn(|c| V3::gather(u.map(|t| t[c])));
            let w4 = core::array::from_fn(|c| F4::new(w.map(|t| t[c])));
            let out4 = project4(
                &Rest4::gather([&rests[0], &rests[1], &rests[2], &rests[3]]),
                u4,
                w4,
                &mut lam4,
                inv_h2,
            );
            for j in 0..4 {
                let mut l = lambda[j];
                let out = project(&rests[j], u[j], w[j], &mut l, inv_h2);
                for c in 0..4 {
                    assert_eq!(
                        bits(out4[c].lane(j)),
                        bits(out[c]),
                        "case {case}, lane {j}, corner {c}: {:?} against {:?}",
                        out4[c].lane(j),
                        out[c]
                    );
                }
                assert_eq!(
                    [
                        lam4[0].to_array()[j].to_bits(),
                        lam4[1].to_array()[j].to_bits()
                    ],
                    l.map(f32::to_bits),
                    "case {case}, lane {j}: multipliers"
                );
            }
        }
    }

    /// The sweep, lanes or not, against the tets solved one after the other by the one-tet
    /// projection, on tets drawn at random over a few nodes (so some groups of four share a
    /// node and others do not), some naming a node outside the slices.
    #[test]
    fn a_sweep_gives_the_bits_of_the_tets_one_after_the_other() {
        const NODES: usize = 40;
        let mut rng = Rng(0x2545_f491_4f6c_dd1d);
        let mut grouped = 0;
        for case in 0..200 {
            let count = 4 + case % 37;
            let mut tets = [[0u32; 4]; 40];
            let mut rests = [TetRest::default(); 40];
            for t in 0..count {
                let mut k = [0u32; 4];
                let mut c = 0;
                while c < 4 {
                    let n = below(&mut rng, NODES as u32 + 1);
                    if !k[..c].contains(&n) {
                        k[c] = n;
                        c += 1;
                    }
                }
                tets[t] = k;
                rests[t] = rest(&mut rng, 1.0, 1e3);
            }
            let mut u = [Vec3::ZERO; NODES];
            let mut w = [0.0f32; NODES];
            for n in 0..NODES {
                u[n] = vec(&mut rng, 0.05);
                w[n] = if below(&mut rng, 8) == 0 { 0.0 } else { 1.0 };
            }
            let (mut u_ref, mut l_ref) = (u, [[0.0f32; 2]; 40]);
            let mut l = l_ref;
            for pass in 0..3 {
                let first = pass == 0;
                sweep(
                    TetRun {
                        tets: &tets[..count],
                        rests: &rests[..count],
                        lambdas: &mut l[..count],
                    },
                    &mut u,
                    &w,
                    0,
                    first,
                    1e4,
                );
                for t in 0..count {
                    if first {
                        l_ref[t] = [0.0; 2];
                    }
                    let k = tets[t].map(|k| k as usize);
                    if k.iter().any(|&k| k >= NODES) {
                        continue;
                    }
                    let du = project(
                        &rests[t],
                        k.map(|k| u_ref[k]),
                        k.map(|k| w[k]),
                        &mut l_ref[t],
                        1e4,
                    );
                    for c in 0..4 {
                        u_ref[k[c]] += du[c];
                    }
                }
            }
            for n in 0..NODES {
                assert_eq!(bits(u[n]), bits(u_ref[n]), "case {case}, node {n}");
            }
            for t in 0..count {
                assert_eq!(
                    l[t].map(f32::to_bits),
                    l_ref[t].map(f32::to_bits),
                    "case {case}, tet {t}"
                );
            }
            grouped += (0..count / 4)
                .filter(|g| {
                    let s = &tets[4 * g..4 * g + 4];
                    (0..4).all(|a| (a + 1..4).all(|b| !s[a].iter().any(|k| s[b].contains(k))))
                })
                .count();
        }
        // The lanes were taken, not only the one-tet path.
        assert!(grouped > 50, "{grouped} disjoint groups");
    }
}
