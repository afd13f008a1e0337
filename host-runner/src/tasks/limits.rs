//! The device's own limits on the servo path, between the force law and the passivity
//! observer: the force clamped at the device's peak, derated by a thermal (I-squared-t) model of
//! its motors toward its continuous rating, and ramped back in after a passivity trip; the
//! trip's recovery (after [`RECOVER_TICKS`] out of contact) and its bound
//! ([`MAX_TRIPS_PER_MINUTE`]). The observer is fed the force these leave, the force the device
//! is sent.
//!
//! The thermal model: a heat `h`, 1 being the steady state of the continuous force `Fc`, follows
//! `dh/dt = ((|F| / Fc)^2 - h) / tau` (a first-order winding, `tau` the device's
//! [`DeviceSpec::thermal_time_s`]) on the force sent. The force allowed is the peak `Fp` while
//! `h <= DERATE_FROM` and falls linearly to `Fc` as `h` reaches 1:
//! `L = Fc + (Fp - Fc) * clamp((1 - h) / (1 - DERATE_FROM), 0, 1)`. A force held at the limit
//! settles at `Fc`; a device whose continuous rating is its peak (the Falcon) is never derated.
//!
//! # Bounded work
//! Every method does a fixed amount of arithmetic: no loop over the run, no allocation, no lock.

use tetradrill_core::Vec3;
use tetradrill_device::DeviceSpec;

/// Ticks (1 ms) the tool must be out of contact (the law's force zero) after a passivity trip
/// before the force comes back: one second.
pub const RECOVER_TICKS: u32 = 1000;
/// Ticks over which the force ramps back in after a recovery (the default `ramp_ticks` of the
/// device's safety filter, which ramps the motors in after the cut as well).
pub const RECOVERY_RAMP_TICKS: u32 = 500;
/// Trips within a minute after which the motors stay off for the rest of the run.
pub const MAX_TRIPS_PER_MINUTE: usize = 3;
/// Ticks in a minute.
const MINUTE_TICKS: u64 = 60_000;
/// The heat (1 = the continuous force's steady state) at which the derating begins.
pub const DERATE_FROM: f32 = 0.5;

/// The clamp, the derating and the recovery of one servo loop (module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DeviceLimits {
    peak_n: f32,
    continuous_n: f32,
    /// `dt / tau`.
    heat_rate: f32,
    heat: f32,
    derated_ticks: u64,
    /// Ticks since the last recovery (the ramp), saturating at [`RECOVERY_RAMP_TICKS`].
    ramp: u32,
    out_of_contact: u32,
    recoveries: u32,
    /// The ticks of the last trips (a ring), and how many are known.
    trip_ticks: [u64; MAX_TRIPS_PER_MINUTE],
    trips_known: usize,
    locked_out: bool,
}

impl Default for DeviceLimits {
    /// No limit: an infinite peak, no derating (the limits of a device are set with
    /// [`DeviceLimits::new`]).
    fn default() -> Self {
        Self {
            peak_n: f32::INFINITY,
            continuous_n: f32::INFINITY,
            heat_rate: 0.0,
            heat: 0.0,
            derated_ticks: 0,
            ramp: RECOVERY_RAMP_TICKS,
            out_of_contact: 0,
            recoveries: 0,
            trip_ticks: [0; MAX_TRIPS_PER_MINUTE],
            trips_known: 0,
            locked_out: false,
        }
    }
}

impl DeviceLimits {
    /// The limits of a device of `spec` at a servo period of `dt` seconds: its peak force, and a
    /// thermal model from its continuous force and thermal time (none when either is not
    /// finite and positive, or the continuous force is not below the peak).
    pub fn new(spec: &DeviceSpec, dt: f32) -> Self {
        let ok = |v: f64| v.is_finite() && v > 0.0;
        let mut l = Self::default();
        if ok(spec.max_force_n) {
            l.peak_n = spec.max_force_n as f32;
        }
        if ok(spec.max_continuous_force_n)
            && ok(spec.thermal_time_s)
            && spec.max_continuous_force_n < spec.max_force_n
            && dt.is_finite()
            && dt > 0.0
        {
            l.continuous_n = spec.max_continuous_force_n as f32;
            l.heat_rate = (f64::from(dt) / spec.thermal_time_s).min(1.0) as f32;
        }
        l
    }

    /// The force allowed now: the peak, derated by the heat (module docs).
    pub fn allowed_n(&self) -> f32 {
        if self.heat_rate == 0.0 {
            return self.peak_n;
        }
        let u = ((1.0 - self.heat) / (1.0 - DERATE_FROM)).clamp(0.0, 1.0);
        self.continuous_n + (self.peak_n - self.continuous_n) * u
    }

    /// The law's force `f` as the device is to render it: clamped at the allowed force (the
    /// peak, derated) and scaled by the recovery ramp. Returns it with the factor it was scaled
    /// by (1 when it passed unchanged, bit for bit), for the law's storage. A tick whose force
    /// the derating reduced counts toward [`derated_s`](Self::derated_s).
    pub fn shape(&mut self, f: Vec3) -> (Vec3, f32) {
        let mut k = 1.0f32;
        let n = f.length();
        let allowed = self.allowed_n();
        if n.is_finite() && n > allowed {
            k = allowed / n;
            if allowed < self.peak_n {
                self.derated_ticks += 1;
            }
        }
        if self.ramp < RECOVERY_RAMP_TICKS {
            self.ramp += 1;
            k *= self.ramp as f32 / RECOVERY_RAMP_TICKS as f32;
        }
        if k == 1.0 {
            (f, 1.0)
        } else {
            (f * k, k)
        }
    }

    /// Heats the model by the force `sent` over one tick.
    pub fn heat_by(&mut self, sent: Vec3) {
        if self.heat_rate == 0.0 {
            return;
        }
        let r = sent.length() / self.continuous_n;
        if r.is_finite() {
            self.heat += self.heat_rate * (r * r - self.heat);
        }
    }

    /// A passivity trip at servo tick `tick`: counted against [`MAX_TRIPS_PER_MINUTE`]; the
    /// motors stay off for good when that many trips came within a minute. Returns whether
    /// they do.
    pub fn tripped_at(&mut self, tick: u64) -> bool {
        self.trip_ticks[self.trips_known % MAX_TRIPS_PER_MINUTE] = tick;
        self.trips_known += 1;
        if self.trips_known >= MAX_TRIPS_PER_MINUTE {
            // The oldest of the last MAX_TRIPS_PER_MINUTE trips.
            let oldest = self.trip_ticks[self.trips_known % MAX_TRIPS_PER_MINUTE];
            if tick.saturating_sub(oldest) < MINUTE_TICKS {
                self.locked_out = true;
            }
        }
        self.out_of_contact = 0;
        self.locked_out
    }

    /// One tick while tripped, the law's force `law_force`: whether the force comes back now
    /// (the tool out of contact for [`RECOVER_TICKS`], and not locked out). On `true` the
    /// recovery is counted and the ramp starts.
    pub fn recovers(&mut self, law_force: Vec3) -> bool {
        if self.locked_out {
            return false;
        }
        if law_force == Vec3::ZERO {
            self.out_of_contact = self.out_of_contact.saturating_add(1);
        } else {
            self.out_of_contact = 0;
        }
        if self.out_of_contact < RECOVER_TICKS {
            return false;
        }
        self.out_of_contact = 0;
        self.recoveries += 1;
        self.ramp = 0;
        true
    }

    /// Recoveries from a trip so far.
    pub fn recoveries(&self) -> u32 {
        self.recoveries
    }

    /// Whether the motors stay off for the rest of the run (too many trips in a minute).
    pub fn locked_out(&self) -> bool {
        self.locked_out
    }

    /// Seconds the derating reduced the force, at a servo period of `dt` seconds.
    pub fn derated_s(&self, dt: f64) -> f64 {
        self.derated_ticks as f64 * dt
    }

    /// The heat now (1 = the continuous force's steady state).
    pub fn heat(&self) -> f32 {
        self.heat
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn omni() -> DeviceLimits {
        DeviceLimits::new(&DeviceSpec::OMNI, 1e-3)
    }

    #[test]
    fn a_held_peak_derates_toward_the_continuous_force() {
        let mut l = omni();
        let mut sent = Vec3::ZERO;
        for _ in 0..120_000 {
            sent = l.shape(Vec3::X * 3.3).0;
            l.heat_by(sent);
        }
        // Two minutes at the limit: settled at the continuous rating.
        assert!((sent.length() - 0.88).abs() < 0.01, "{sent}");
        assert!(l.derated_s(1e-3) > 100.0);
        // The heat's steady state for the force held: (|F| / Fc)^2.
        let r = sent.length() / 0.88;
        assert!((l.heat() - r * r).abs() < 0.02, "{}", l.heat());
    }

    #[test]
    fn below_the_continuous_force_nothing_is_derated_and_the_force_passes_bit_for_bit() {
        let mut l = omni();
        let f = Vec3::new(0.5, -0.3, 0.1);
        for _ in 0..100_000 {
            let (out, k) = l.shape(f);
            assert_eq!(
                out.to_array().map(f32::to_bits),
                f.to_array().map(f32::to_bits)
            );
            assert_eq!(k, 1.0);
            l.heat_by(out);
        }
        assert_eq!(l.derated_s(1e-3), 0.0);
        // The Falcon's continuous rating is its peak: never derated.
        let mut l = DeviceLimits::new(&DeviceSpec::FALCON, 1e-3);
        for _ in 0..100_000 {
            let (out, _) = l.shape(Vec3::X * 8.0);
            assert_eq!(out, Vec3::X * 8.0);
            l.heat_by(out);
        }
        assert_eq!(l.derated_s(1e-3), 0.0);
    }

    #[test]
    fn the_peak_is_clamped_and_the_recovery_ramps_the_force_back_in() {
        let mut l = omni();
        let (out, k) = l.shape(Vec3::Z * 6.6);
        assert!((out.z - 3.3).abs() < 1e-6 && (k - 0.5).abs() < 1e-6);
        assert!(!l.tripped_at(10));
        // In contact: no recovery; out of contact for a second: recovered.
        assert!(!l.recovers(Vec3::Z));
        for _ in 1..RECOVER_TICKS {
            assert!(!l.recovers(Vec3::ZERO));
        }
        assert!(l.recovers(Vec3::ZERO));
        assert_eq!(l.recoveries(), 1);
        let ramp: Vec<f32> = (0..RECOVERY_RAMP_TICKS + 2)
            .map(|_| l.shape(Vec3::Z).0.z)
            .collect();
        assert!((ramp[0] - 1.0 / RECOVERY_RAMP_TICKS as f32).abs() < 1e-6);
        assert!(ramp.windows(2).all(|w| w[1] >= w[0]));
        assert_eq!(ramp[ramp.len() - 1], 1.0);
    }

    #[test]
    fn too_many_trips_in_a_minute_keep_the_motors_off() {
        let mut l = omni();
        // A trip every 30 s: never three within a minute.
        for i in 0..5u64 {
            assert!(!l.tripped_at(i * 30_001));
        }
        let mut l = omni();
        assert!(!l.tripped_at(1000));
        assert!(!l.tripped_at(5000));
        assert!(l.tripped_at(60_999));
        assert!(l.locked_out());
        for _ in 0..10 * RECOVER_TICKS {
            assert!(!l.recovers(Vec3::ZERO));
        }
    }
}
