//! The servo's run-time policy for deadline misses.
//!
//! A tick whose due contact has not arrived (the simulation step released the tick before has
//! not finished) is late. The first late tick in a row holds the last on-time force; from the
//! second on, the force ramps linearly to zero over [`RAMP_TICKS`] ticks and stays zero until
//! a contact arrives on time again, when the force computed that tick is written. Every late
//! tick is counted (held or ramped) and reported with the run's results.

use tetradrill_core::Vec3;

/// Late ticks in a row that hold the last force.
pub const HOLD_TICKS: u32 = 1;
/// Late ticks in a row, after the held ones, over which the force ramps to zero (the force
/// is zero from the last of them on).
pub const RAMP_TICKS: u32 = 10;

/// The policy's state and counts.
#[derive(Clone, Copy, Debug, Default)]
pub struct LatePolicy {
    in_row: u32,
    last: Vec3,
    /// Late ticks that held the last force.
    pub held: u32,
    /// Late ticks that ramped the force down (or kept it at zero).
    pub ramped: u32,
    /// The longest run of late ticks.
    pub longest: u32,
}

impl LatePolicy {
    /// The force to write this tick: `computed` when the tick is on time, else the held or
    /// ramped force.
    #[inline(always)]
    pub fn apply(&mut self, on_time: bool, computed: Vec3) -> Vec3 {
        if on_time {
            self.in_row = 0;
            self.last = computed;
            return computed;
        }
        self.in_row += 1;
        self.longest = self.longest.max(self.in_row);
        if self.in_row <= HOLD_TICKS {
            self.held += 1;
            return self.last;
        }
        self.ramped += 1;
        let k = self.in_row - HOLD_TICKS;
        if k >= RAMP_TICKS {
            return Vec3::ZERO;
        }
        self.last * ((RAMP_TICKS - k) as f32 / RAMP_TICKS as f32)
    }
}
