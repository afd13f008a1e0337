//! [`HomingGate`]: no Falcon force before all three axes are homed, then a ramp.
//!
//! The Falcon's firmware homes each axis as the user pulls the grip out and pushes it in; when
//! an axis is homed its encoder count is reset, so the reported position jumps. libnifalcon's
//! `FalconFirmware.h` ("Homing Mode") asks programs to wait for all three homed bits before
//! sending any torque computed from positions, because that jump "completely resets the
//! coordinate system". The gate holds the force at zero until the report's homed bits read
//! `0b111`, then scales it from 0 to 1 over a ramp, so the first force after the jump is never
//! a step. Losing a homed bit closes the gate again; the next full homing ramps again.
//!
//! Every newly set homed bit is counted as a position reset
//! ([`HomingGate::position_resets`]), so the host can restart anything that differentiates
//! positions (its velocity filter) instead of seeing the jump as a velocity spike.
//!
//! # Bounded work
//! Every method does a fixed amount of integer and float arithmetic; no allocation.

/// All three axes homed (bit i = axis i).
pub const ALL_HOMED: u8 = 0b111;

/// The homing gate. See the module docs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct HomingGate {
    ramp_ticks: u32,
    homed: u8,
    ticks_homed: u32,
    resets: u64,
}

impl HomingGate {
    /// A closed gate (nothing homed) whose ramp lasts `ramp_ticks` reports (0 or 1: no ramp).
    pub const fn new(ramp_ticks: u32) -> HomingGate {
        HomingGate {
            ramp_ticks,
            homed: 0,
            ticks_homed: 0,
            resets: 0,
        }
    }

    /// Reports of a ramp of `ramp_s` seconds at a servo period of `period_s` seconds, rounded
    /// to the nearest report (0 for a non-positive or non-finite time or period).
    pub fn ramp_ticks_for(ramp_s: f64, period_s: f64) -> u32 {
        let t = ramp_s / period_s;
        if t.is_finite() && t > 0.0 {
            t.round().min(f64::from(u32::MAX)) as u32
        } else {
            0
        }
    }

    /// Takes the homed bits of one report (only the low three bits count). Returns whether
    /// an axis became homed in it, that is, whether the reported position was reset.
    pub fn update(&mut self, homed: u8) -> bool {
        let homed = homed & ALL_HOMED;
        let gained = homed & !self.homed != 0;
        if gained {
            self.resets = self.resets.saturating_add(1);
        }
        if homed == ALL_HOMED {
            // Counts the reports since homing ended, the first one included.
            self.ticks_homed = if self.homed == ALL_HOMED {
                self.ticks_homed.saturating_add(1)
            } else {
                1
            };
        } else {
            self.ticks_homed = 0;
        }
        self.homed = homed;
        gained
    }

    /// The factor applied to the force: 0 until all three axes are homed, then rising by
    /// `1 / ramp_ticks` per report up to 1.
    pub fn scale(&self) -> f64 {
        if self.homed != ALL_HOMED {
            0.0
        } else if self.ramp_ticks <= 1 {
            1.0
        } else {
            (f64::from(self.ticks_homed) / f64::from(self.ramp_ticks)).min(1.0)
        }
    }

    /// Whether the last report had all three axes homed.
    pub fn all_homed(&self) -> bool {
        self.homed == ALL_HOMED
    }

    /// The homed bits of the last report.
    pub fn homed(&self) -> u8 {
        self.homed
    }

    /// How many reports newly set a homed bit (each one a jump of the reported position).
    pub fn position_resets(&self) -> u64 {
        self.resets
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn zero_until_all_homed_then_a_linear_ramp() {
        let mut g = HomingGate::new(4);
        for bits in [0b000, 0b001, 0b011, 0b101, 0b110] {
            g.update(bits);
            assert_eq!(g.scale(), 0.0, "{bits:03b}");
        }
        // 0.25, 0.5, 0.75, 1, 1: the values of a 4-report ramp written out.
        for want in [0.25, 0.5, 0.75, 1.0, 1.0] {
            g.update(0b111);
            assert_eq!(g.scale(), want);
        }
        // Losing an axis closes the gate; homing again ramps again from the start.
        g.update(0b011);
        assert_eq!(g.scale(), 0.0);
        g.update(0b111);
        assert_eq!(g.scale(), 0.25);
    }

    #[test]
    fn counts_each_report_that_sets_a_homed_bit() {
        let mut g = HomingGate::new(0);
        let seq = [0b000, 0b001, 0b001, 0b011, 0b111, 0b111, 0b110, 0b111];
        let resets: Vec<bool> = seq.iter().map(|&b| g.update(b)).collect();
        assert_eq!(resets, [false, true, false, true, true, false, false, true]);
        assert_eq!(g.position_resets(), 4);
        // No ramp: full force on the first homed report; bits above the third are ignored.
        assert_eq!(g.scale(), 1.0);
        g.update(0xF8);
        assert_eq!((g.homed(), g.scale()), (0, 0.0));
    }

    #[test]
    fn ramp_length_from_seconds() {
        assert_eq!(HomingGate::ramp_ticks_for(0.5, 1e-3), 500);
        assert_eq!(HomingGate::ramp_ticks_for(0.0, 1e-3), 0);
        assert_eq!(HomingGate::ramp_ticks_for(-1.0, 1e-3), 0);
        assert_eq!(HomingGate::ramp_ticks_for(f64::NAN, 1e-3), 0);
        assert_eq!(HomingGate::ramp_ticks_for(0.5, 0.0), 0);
    }
}
