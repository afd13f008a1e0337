//! [`ForceSafety`]: the filter every backend runs its commands through.
//!
//! Rules, all driven by the device's own tick (never wall time):
//! - non-finite commands are refused with [`DeviceError::NonFiniteCommand`] and force is zeroed;
//! - force (and torque) magnitudes are clamped to the limits, keeping the direction;
//! - after enabling, force ramps up linearly over `ramp_ticks` ticks;
//! - when no write arrives for `watchdog_ticks` ticks in a row the output drops to zero and the
//!   motors are disabled; the next enabled write starts a fresh ramp.
//!
//! # Bounded work
//! Every method does a fixed amount of arithmetic; nothing allocates, locks or panics.

use crate::device::{v3, DeviceError, ForceCommand, Vec3};

/// Settings of a [`ForceSafety`] filter.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SafetyConfig {
    /// Largest force magnitude let through, N.
    pub max_force_n: f64,
    /// Largest torque magnitude let through, N m.
    pub max_torque_nm: f64,
    /// Ticks over which force ramps from zero to full after enabling (0 or 1 = no ramp).
    pub ramp_ticks: u32,
    /// Ticks without a write after which force is zeroed (at least 1).
    pub watchdog_ticks: u32,
}

impl SafetyConfig {
    /// Defaults for a device's peak force: 500-tick ramp (0.5 s at 1 kHz), 3-tick watchdog.
    pub const fn for_max_force(max_force_n: f64) -> SafetyConfig {
        SafetyConfig {
            max_force_n,
            max_torque_nm: 0.0,
            ramp_ticks: 500,
            watchdog_ticks: 3,
        }
    }
}

/// The safety filter. See the module docs for the rules.
#[derive(Clone, Copy, Debug)]
pub struct ForceSafety {
    config: SafetyConfig,
    enabled: bool,
    ticks_enabled: u32,
    ticks_since_write: u32,
    output: ForceCommand,
    watchdog_trips: u32,
    refused: u32,
    clamped: u32,
}

impl ForceSafety {
    /// A filter with motors off.
    pub fn new(config: SafetyConfig) -> ForceSafety {
        let max_force_n = if config.max_force_n.is_finite() {
            config.max_force_n.max(0.0)
        } else {
            0.0
        };
        let max_torque_nm = if config.max_torque_nm.is_finite() {
            config.max_torque_nm.max(0.0)
        } else {
            0.0
        };
        ForceSafety {
            config: SafetyConfig {
                max_force_n,
                max_torque_nm,
                ramp_ticks: config.ramp_ticks,
                watchdog_ticks: config.watchdog_ticks.max(1),
            },
            enabled: false,
            ticks_enabled: 0,
            ticks_since_write: 0,
            output: ForceCommand::OFF,
            watchdog_trips: 0,
            refused: 0,
            clamped: 0,
        }
    }

    /// The settings in force.
    pub fn config(&self) -> SafetyConfig {
        self.config
    }

    /// Advances the device clock by one tick; call once per device tick (each `read`).
    /// Returns what the motors must render during this tick (zero after a watchdog trip).
    pub fn tick(&mut self) -> ForceCommand {
        self.ticks_since_write = self.ticks_since_write.saturating_add(1);
        if self.enabled {
            self.ticks_enabled = self.ticks_enabled.saturating_add(1);
            // One read per tick is normal: a write is "missed" once a second read arrives
            // without a write in between.
            if self.ticks_since_write > self.config.watchdog_ticks {
                self.enabled = false;
                self.output = ForceCommand::OFF;
                self.watchdog_trips = self.watchdog_trips.saturating_add(1);
            }
        }
        self.output
    }

    /// Filters a command; returns what the motors may render.
    /// A non-finite command is refused: the output becomes zero with motors off.
    pub fn filter(&mut self, command: &ForceCommand) -> Result<ForceCommand, DeviceError> {
        self.ticks_since_write = 0;
        if !(v3::finite(command.force) && v3::finite(command.torque)) {
            self.disable();
            self.refused = self.refused.saturating_add(1);
            return Err(DeviceError::NonFiniteCommand);
        }
        if !command.enable {
            self.disable();
            return Ok(self.output);
        }
        if !self.enabled {
            self.enabled = true;
            self.ticks_enabled = 0;
        }
        let ramp = if self.config.ramp_ticks <= 1 {
            1.0
        } else {
            (f64::from(self.ticks_enabled) + 1.0) / f64::from(self.config.ramp_ticks)
        }
        .min(1.0);
        let (force, cf) = clamp_norm(command.force, self.config.max_force_n);
        let (torque, ct) = clamp_norm(command.torque, self.config.max_torque_nm);
        if cf || ct {
            self.clamped = self.clamped.saturating_add(1);
        }
        self.output = ForceCommand {
            force: v3::scale(force, ramp),
            torque: v3::scale(torque, ramp),
            enable: true,
        };
        Ok(self.output)
    }

    /// Zeroes the output and turns the motors off (e.g. on a disconnect).
    pub fn disable(&mut self) {
        self.enabled = false;
        self.ticks_enabled = 0;
        self.output = ForceCommand::OFF;
    }

    /// What the motors currently render.
    pub fn output(&self) -> ForceCommand {
        self.output
    }

    /// Whether the motors are on.
    pub fn is_enabled(&self) -> bool {
        self.enabled
    }

    /// How often the watchdog zeroed the force.
    pub fn watchdog_trips(&self) -> u32 {
        self.watchdog_trips
    }

    /// How many commands were refused as non-finite.
    pub fn refused(&self) -> u32 {
        self.refused
    }

    /// How many commands were clamped.
    pub fn clamped(&self) -> u32 {
        self.clamped
    }
}

/// Scales `v` down to magnitude `max` if longer; says whether it did.
fn clamp_norm(v: Vec3, max: f64) -> (Vec3, bool) {
    let n = v3::norm(v);
    if n > max {
        if n > 0.0 && max > 0.0 {
            (v3::scale(v, max / n), true)
        } else {
            ([0.0; 3], true)
        }
    } else {
        (v, false)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cfg(ramp: u32, wd: u32) -> SafetyConfig {
        SafetyConfig {
            max_force_n: 3.3,
            max_torque_nm: 0.0,
            ramp_ticks: ramp,
            watchdog_ticks: wd,
        }
    }

    #[test]
    fn clamps_magnitude_and_keeps_direction() {
        let mut s = ForceSafety::new(cfg(1, 3));
        s.tick();
        let out = s.filter(&ForceCommand::force([30.0, 40.0, 0.0])).unwrap();
        // |(30,40,0)| = 50 -> 3.3, direction (0.6, 0.8, 0).
        assert!((out.force[0] - 1.98).abs() < 1e-12);
        assert!((out.force[1] - 2.64).abs() < 1e-12);
        assert_eq!(out.force[2], 0.0);
        assert_eq!(s.clamped(), 1);
        let small = s.filter(&ForceCommand::force([1.0, 0.0, 0.0])).unwrap();
        assert_eq!(small.force, [1.0, 0.0, 0.0]);
    }

    #[test]
    fn ramps_linearly_over_n_ticks_then_holds() {
        let mut s = ForceSafety::new(cfg(4, 3));
        let want = [0.25, 0.5, 0.75, 1.0, 1.0, 1.0];
        for w in want {
            s.tick();
            let out = s.filter(&ForceCommand::force([2.0, 0.0, 0.0])).unwrap();
            assert!(
                (out.force[0] - 2.0 * w).abs() < 1e-12,
                "got {} want {}",
                out.force[0],
                2.0 * w
            );
        }
        // Disabling and re-enabling restarts the ramp.
        s.filter(&ForceCommand::OFF).unwrap();
        s.tick();
        let out = s.filter(&ForceCommand::force([2.0, 0.0, 0.0])).unwrap();
        assert!((out.force[0] - 0.5).abs() < 1e-12);
    }

    #[test]
    fn watchdog_zeroes_after_three_missed_writes() {
        let mut s = ForceSafety::new(cfg(1, 3));
        s.tick();
        s.filter(&ForceCommand::force([1.0, 2.0, 0.5])).unwrap();
        // Ticks 1..=3 without a write still hold the last force (3 missed writes allowed).
        assert_eq!(s.tick().force, [1.0, 2.0, 0.5]);
        assert_eq!(s.tick().force, [1.0, 2.0, 0.5]);
        assert_eq!(s.tick().force, [1.0, 2.0, 0.5]);
        // The fourth tick without a write trips.
        let out = s.tick();
        assert_eq!(out.force, [0.0; 3]);
        assert!(!out.enable);
        assert_eq!(s.watchdog_trips(), 1);
        // A later write restarts from a fresh ramp, not from full force.
        let mut r = ForceSafety::new(cfg(10, 3));
        r.tick();
        r.filter(&ForceCommand::force([1.0, 0.0, 0.0])).unwrap();
        for _ in 0..5 {
            r.tick();
        }
        let out = r.filter(&ForceCommand::force([1.0, 0.0, 0.0])).unwrap();
        assert!((out.force[0] - 0.1).abs() < 1e-12);
    }

    #[test]
    fn regular_writes_never_trip() {
        let mut s = ForceSafety::new(cfg(1, 1));
        for _ in 0..1000 {
            s.tick();
            s.filter(&ForceCommand::force([0.1, 0.0, 0.0])).unwrap();
        }
        assert_eq!(s.watchdog_trips(), 0);
        assert!(s.is_enabled());
    }

    #[test]
    fn non_finite_is_refused_and_zeroes() {
        for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
            let mut s = ForceSafety::new(cfg(1, 3));
            s.tick();
            s.filter(&ForceCommand::force([1.0, 0.0, 0.0])).unwrap();
            let err = s.filter(&ForceCommand::force([0.0, bad, 0.0]));
            assert_eq!(err, Err(DeviceError::NonFiniteCommand));
            assert_eq!(s.output().force, [0.0; 3]);
            assert!(!s.output().enable);
            let mut t = ForceCommand::force([0.0; 3]);
            t.torque[2] = bad;
            assert_eq!(s.filter(&t), Err(DeviceError::NonFiniteCommand));
            assert_eq!(s.refused(), 2);
        }
    }
}
