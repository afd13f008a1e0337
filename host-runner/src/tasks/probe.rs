//! The force-sign probe: a check, while the tool is in contact, that the device pushes the way
//! it is told and reports the way it moves. A reversed force (a motor or an amplifier wired the
//! other way) or a mirrored encoder axis looks, to any energy measure at the device's port, like
//! a user pushing harder; what tells them apart is the sign of the device's response to a
//! known force.
//!
//! Each tick in contact the servo adds a small probe force `u_k = a s_k n_k` to the force it
//! sends, in the device's frame: `a` the probe's amplitude, `n_k` the direction of the force
//! sent (the probe moves the stylus along what it already pushes, never sideways) and
//! `s_k = +-1` from a pseudo-random sequence (a 16-bit Galois LFSR, so a run repeats). The
//! stylus and the hand holding it are a passive mass: a force held on it over a tick moves it by
//! `u T^2 / 2m` that tick and by `u T^2 / m` each tick after. The fourth difference of the
//! reported position, `d_k = p_k - 4 p_{k-1} + 6 p_{k-2} - 4 p_{k-3} + p_{k-4}`, then holds
//! `G (u_{k-1} - u_{k-2} - u_{k-3} + u_{k-4}) T^2 / 2` (a zero-order hold on a mass whose
//! inverse mass matrix is `G`; `G (u_{k-1} - 2 u_{k-2} + u_{k-3}) T^2` for a stylus integrated
//! in lockstep with the servo), the same response to the differences `l_k` of the rest of the
//! force sent (the law's), and what the hand did, which is smooth at the tick's scale (a fourth
//! difference takes out any motion of constant jerk) and does not follow the probe's random
//! signs. `G` is positive definite for any passive mass, so each of its diagonal entries is
//! positive. A reversed force makes them all negative, a mirrored encoder axis its own.
//!
//! So, per axis `i` that carries at least [`AXIS_SHARE`] of the probe, the probe regresses `d_i`
//! on the probes of the last four ticks and the changes of the rest of the force over them
//! (least squares over sums that forget with a time constant of [`WINDOW_TICKS`]) and takes the
//! newest probe's coefficient over its standard error, `t_i`: positive on a healthy axis,
//! negative on a reversed one, growing like the square root of the samples. Per axis, a
//! mirrored axis shows even under a force oblique to it, whose response along the force may
//! still be positive. The statistic `z` is the least `t_i` of the axes whose window holds at
//! least [`MIN_SAMPLES`] samples; the probe trips when `z < -`[`TRIP_Z`]. The rest of the force
//! is a regressor of its own so that its changes (the contact plane moving while drilling) are
//! not counted as noise, and so that the part of it that follows the position (the wall's
//! spring) biases nothing.
//!
//! The probe works on the device's own readings (`f64` metres as reported, newtons as sent),
//! before any rounding to the scene's `f32`. It is not in the force digest, the passivity
//! observer's energy or the continuous-force model (its work is nanojoules a tick).
//!
//! # Bounded work
//! Every method does a fixed amount of arithmetic: no loop over the run, no allocation, no
//! lock.

use tetradrill_device::{DeviceSpec, Vec3};

fn dot(a: Vec3, b: Vec3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn finite(a: Vec3) -> bool {
    a.iter().all(|x| x.is_finite())
}

/// The probe's amplitude as a fraction of the device's peak force (80 mN on the simulated
/// device and the Falcon, 33 mN on the Omni and the Touch).
pub const PROBE_FRACTION: f64 = 0.01;
/// The least share of the probe an axis must carry for a sample to count on it.
pub const AXIS_SHARE: f64 = 0.1;
/// The time constant of the regression's sums, ticks.
pub const WINDOW_TICKS: f64 = 256.0;
/// The threshold: `z` below minus this trips.
pub const TRIP_Z: f64 = 6.0;
/// Samples an axis's window must hold before its `t` counts (three times the regressors).
pub const MIN_SAMPLES: f64 = 20.0;

/// The probe's state (module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SignProbe {
    amplitude_n: f64,
    lfsr: u16,
    /// The last five positions (metres, newest first) and how many of them are known.
    positions: [Vec3; 5],
    known: u8,
    /// The probe forces of the last four ticks (newest first).
    probes: [Vec3; 4],
    /// The forces sent besides the probe, the last four ticks (newest first).
    forces: [Vec3; 4],
    /// The regression's sums, per axis.
    sums: [Sums; 3],
    /// The statistic after the last step ([`decided`](Self::decided) then).
    z_now: Option<f64>,
    z_min: f64,
    trips: u32,
}

impl Default for SignProbe {
    /// No probe (amplitude 0): the force passes unchanged and nothing trips.
    fn default() -> Self {
        Self::with_amplitude(0.0)
    }
}

impl SignProbe {
    /// The probe for `spec`: [`PROBE_FRACTION`] of its peak force.
    pub fn new(spec: &DeviceSpec) -> Self {
        Self::with_amplitude(spec.max_force_n * PROBE_FRACTION)
    }

    /// A probe of `amplitude_n` newtons (0: none).
    pub fn with_amplitude(amplitude_n: f64) -> Self {
        SignProbe {
            amplitude_n: if amplitude_n.is_finite() {
                amplitude_n.max(0.0)
            } else {
                0.0
            },
            lfsr: 0xACE1,
            positions: [[0.0; 3]; 5],
            known: 0,
            probes: [[0.0; 3]; 4],
            forces: [[0.0; 3]; 4],
            sums: [Sums::ZERO; 3],
            z_now: None,
            z_min: 0.0,
            trips: 0,
        }
    }

    /// The probe's amplitude, newtons.
    pub fn amplitude_n(&self) -> f64 {
        self.amplitude_n
    }

    /// One tick: the tool at `position` (metres, as the device reported it) and the force
    /// about to be sent, `force` (newtons, the device's frame). Takes in the response to the
    /// earlier probes and returns this tick's probe force, to be added to `force` (zero with a
    /// zero force or without a probe). A non-finite position or force forgets the history.
    pub fn step(&mut self, position: Vec3, force: Vec3) -> Vec3 {
        if !finite(position) || !finite(force) {
            self.restart();
            return [0.0; 3];
        }
        let [p1, p2, p3, p4, _] = self.positions;
        self.positions = [position, p1, p2, p3, p4];
        self.known = (self.known + 1).min(5);
        let [u1, u2, u3, u4] = self.probes;
        let [f1, f2, f3, f4] = self.forces;
        if self.known == 5 {
            let p0 = position;
            for (i, sums) in self.sums.iter_mut().enumerate() {
                // An axis the force hardly has a part on has too little probe to say anything.
                if u1[i].abs() >= AXIS_SHARE * self.amplitude_n {
                    let d = (p0[i] + p4[i]) - 4.0 * (p1[i] + p3[i]) + 6.0 * p2[i];
                    let g = [f1[i] - f2[i], f2[i] - f3[i], f3[i] - f4[i]];
                    sums.add([u1[i], u2[i], u3[i], u4[i], g[0], g[1], g[2]], d);
                }
            }
            self.z_now = self.decided();
            if let Some(z) = self.z_now {
                self.z_min = self.z_min.min(z);
            }
        }
        let len = dot(force, force).sqrt();
        let probe = if self.amplitude_n > 0.0 && len > 0.0 {
            let bit = self.lfsr & 1;
            self.lfsr >>= 1;
            let sign = if bit != 0 {
                self.lfsr ^= 0xB400;
                1.0
            } else {
                -1.0
            };
            force.map(|f| f * (sign * self.amplitude_n / len))
        } else {
            [0.0; 3]
        };
        self.probes = [probe, u1, u2, u3];
        self.forces = [force, f1, f2, f3];
        probe
    }

    /// The least `t` of the axes whose window holds [`MIN_SAMPLES`] samples, if any does.
    fn decided(&self) -> Option<f64> {
        self.sums
            .iter()
            .filter(|s| s.n >= MIN_SAMPLES)
            .map(Sums::t)
            .reduce(f64::min)
    }

    /// The sign test's statistic now (module docs): the least `t` of the axes whose window
    /// holds [`MIN_SAMPLES`] samples (0 while none does), positive on a healthy device.
    pub fn z(&self) -> f64 {
        self.z_now.unwrap_or(0.0)
    }

    /// The least `z` seen with the window full enough to decide (0 before).
    pub fn z_min(&self) -> f64 {
        self.z_min
    }

    /// Whether the response says the force, or the axis along it, is reversed: `z` below
    /// `-TRIP_Z` with at least [`MIN_SAMPLES`] samples in the window.
    pub fn reversed(&self) -> bool {
        self.z_now.is_some_and(|z| z < -TRIP_Z)
    }

    /// Counts a trip the probe caused and starts afresh ([`restart`](Self::restart)).
    pub fn tripped(&mut self) {
        self.trips = self.trips.saturating_add(1);
        self.restart();
    }

    /// Trips the probe caused.
    pub fn trips(&self) -> u32 {
        self.trips
    }

    /// Forgets the positions, the probes and the sums (after a pause, a position reset, a
    /// trip): what the tool did meanwhile was not the probe's doing.
    pub fn restart(&mut self) {
        self.z_now = None;
        self.known = 0;
        self.probes = [[0.0; 3]; 4];
        self.forces = [[0.0; 3]; 4];
        self.sums = [Sums::ZERO; 3];
    }
}

/// Regressors of one axis's sample: the probe of each of the last four ticks and the
/// differences of the rest of the force over them.
const K: usize = 7;

/// The leaky sums of one axis's least-squares regression of the position's fourth difference
/// `d` on the regressors `x` (the probes of the last four ticks, newest first, and the
/// differences of the rest of the force sent over those ticks: the fourth difference takes out
/// a constant force, so any response to the force is a combination of them).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Sums {
    /// `sum x x^T`.
    xx: [[f64; K]; K],
    /// `sum x d`.
    xd: [f64; K],
    /// `sum d^2`.
    dd: f64,
    /// Samples in the window.
    n: f64,
}

impl Sums {
    const ZERO: Sums = Sums {
        xx: [[0.0; K]; K],
        xd: [0.0; K],
        dd: 0.0,
        n: 0.0,
    };

    fn add(&mut self, x: [f64; K], d: f64) {
        if !d.is_finite() || x.iter().any(|v| !v.is_finite()) {
            return;
        }
        let keep = 1.0 - 1.0 / WINDOW_TICKS;
        for (row, xi) in self.xx.iter_mut().zip(x) {
            for (cell, xj) in row.iter_mut().zip(x) {
                *cell = *cell * keep + xi * xj;
            }
        }
        for (cell, xi) in self.xd.iter_mut().zip(x) {
            *cell = *cell * keep + xi * d;
        }
        self.dd = self.dd * keep + d * d;
        self.n = self.n * keep + 1.0;
    }

    /// The coefficient of the newest probe over its standard error (0 with too little to
    /// say). A regressor that never varied (the law's force on an axis it has no part on) is
    /// left out.
    fn t(&self) -> f64 {
        if self.n <= (K + 1) as f64 || self.xx[0][0] <= 0.0 {
            return 0.0;
        }
        // Gauss-Jordan on [X^T X | X^T d | e_0], with the regressors that carry nothing
        // replaced by identity rows.
        let mut m = [[0.0f64; K + 2]; K];
        let scale = (0..K).map(|i| self.xx[i][i]).fold(0.0, f64::max);
        let used: [bool; K] = core::array::from_fn(|i| self.xx[i][i] > 1e-12 * scale);
        let mut kept = 0.0;
        for i in 0..K {
            for j in 0..K {
                m[i][j] = if used[i] && used[j] {
                    self.xx[i][j]
                } else if i == j {
                    1.0
                } else {
                    0.0
                };
            }
            m[i][K] = if used[i] { self.xd[i] } else { 0.0 };
            m[i][K + 1] = if i == 0 { 1.0 } else { 0.0 };
            kept += f64::from(u8::from(used[i]));
        }
        for col in 0..K {
            let pivot = (col..K)
                .max_by(|&a, &b| m[a][col].abs().total_cmp(&m[b][col].abs()))
                .unwrap_or(col);
            m.swap(col, pivot);
            let p = m[col][col];
            if p.abs() <= 1e-300 || !p.is_finite() {
                return 0.0;
            }
            for v in m[col].iter_mut() {
                *v /= p;
            }
            let pivot_row = m[col];
            for (r, row) in m.iter_mut().enumerate() {
                if r != col {
                    let f = row[col];
                    for (v, pv) in row.iter_mut().zip(pivot_row) {
                        *v -= f * pv;
                    }
                }
            }
        }
        let b: [f64; K] = core::array::from_fn(|i| m[i][K]);
        let inv00 = m[0][K + 1];
        let explained: f64 = (0..K)
            .map(|i| b[i] * if used[i] { self.xd[i] } else { 0.0 })
            .sum();
        let dof = (self.n - kept).max(1.0);
        // The residual's variance, floored at a part in 10^12 of the response's (a response
        // with no residual at all is as sure as it gets).
        let var = ((self.dd - explained) / dof).max(self.dd / self.n * 1e-12);
        let se = (var * inv00).sqrt();
        if se > 0.0 && se.is_finite() {
            b[0] / se
        } else {
            0.0
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 0.1 kg mass free in three axes under a force held over each 1 ms tick (exact),
    /// pushed along x by `hand(t)` and by the device's `gain` times what it is sent, against a
    /// wall at x = 0 facing -x (200 N/m, clamped at 3 N); the reported x `mirror`ed.
    /// The probe at the end and the tick it tripped at, if it did.
    fn run(
        gain: f64,
        mirror: bool,
        hand: impl Fn(f64) -> f64,
        ticks: u32,
    ) -> (SignProbe, Option<u32>) {
        let (m, dt) = (0.1, 1e-3);
        let mut probe = SignProbe::with_amplitude(0.02);
        // Out of contact (reported x < 0) at the start.
        let mut x: Vec3 = [if mirror { 0.01 } else { -0.01 }, 0.0, 0.0];
        let mut v: Vec3 = [0.0; 3];
        for k in 0..ticks {
            let reported = [if mirror { -x[0] } else { x[0] }, x[1], x[2]];
            let wall = if reported[0] > 0.0 {
                (-200.0 * reported[0]).max(-3.0)
            } else {
                0.0
            };
            let u = probe.step(reported, [wall, 0.0, 0.0]);
            for i in 0..3 {
                // A mirrored encoder: the force goes out as sent, the position comes back
                // mirrored.
                let sent = if i == 0 { wall + u[0] } else { u[i] };
                let push = if i == 0 { hand(f64::from(k) * dt) } else { 0.0 };
                let a = (gain * sent + push) / m;
                x[i] += v[i] * dt + 0.5 * a * dt * dt;
                v[i] += a * dt;
            }
            if probe.reversed() {
                return (probe, Some(k));
            }
        }
        (probe, None)
    }

    #[test]
    fn a_healthy_device_never_trips_and_its_statistic_is_positive() {
        // A hand pushing 3 N, wavering by 1 N at 3 Hz, into the wall.
        let (p, tripped) = run(1.0, false, |t| 3.0 + (20.0 * t).sin(), 3000);
        assert_eq!(tripped, None);
        assert!(p.z() > TRIP_Z, "z {}", p.z());
        assert!(p.z_min() > -2.0, "z_min {}", p.z_min());
    }

    #[test]
    fn a_reversed_force_or_a_mirrored_axis_trips_within_a_tenth_of_a_second() {
        for (gain, mirror) in [(-1.0, false), (1.0, true)] {
            // A gentle hand: 0.5 N; the reversed wall pulls the mass in.
            let hand = if mirror { -0.5 } else { 0.5 };
            // In contact after about 63 ticks (1 cm at 5 m/s^2).
            let (p, tripped) = run(gain, mirror, |_| hand, 1000);
            let at = tripped.unwrap_or(u32::MAX);
            assert!(at < 163, "gain {gain} mirror {mirror}: {at}, z {}", p.z());
        }
    }

    #[test]
    fn no_probe_without_a_force_or_an_amplitude() {
        let mut p = SignProbe::with_amplitude(0.02);
        assert_eq!(p.step([0.0; 3], [0.0; 3]), [0.0; 3]);
        let mut off = SignProbe::default();
        assert_eq!(off.step([0.0; 3], [1.0, 0.0, 0.0]), [0.0; 3]);
        let u = p.step([0.0; 3], [0.0, 3.0, 0.0]);
        assert_eq!((u[0], u[2]), (0.0, 0.0));
        assert!((u[1].abs() - 0.02).abs() < 1e-15, "{u:?}");
        assert_eq!(SignProbe::with_amplitude(f64::NAN).amplitude_n(), 0.0);
    }
}
