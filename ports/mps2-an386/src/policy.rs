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

/// Late ticks of the first run whose written force [`LatePolicy::first_run`] keeps: the hold,
/// the ramp and one tick at zero.
pub const TRACE_TICKS: usize = (HOLD_TICKS + RAMP_TICKS + 1) as usize;

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
    /// The first run of late ticks: the magnitude of the last on-time force before it, then
    /// of the force written on each of its first [`TRACE_TICKS`] ticks, so a check can read
    /// the hold and the ramp from the report.
    pub first_run: [f32; TRACE_TICKS + 1],
    /// Late ticks recorded in [`LatePolicy::first_run`].
    pub first_run_len: u32,
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
        self.in_row = self.in_row.saturating_add(1);
        self.longest = self.longest.max(self.in_row);
        let f = if self.in_row <= HOLD_TICKS {
            self.held = self.held.saturating_add(1);
            self.last
        } else {
            self.ramped = self.ramped.saturating_add(1);
            let k = self.in_row - HOLD_TICKS;
            if k >= RAMP_TICKS {
                Vec3::ZERO
            } else {
                self.last * ((RAMP_TICKS - k) as f32 / RAMP_TICKS as f32)
            }
        };
        self.trace(f);
        f
    }

    /// Records `f` while the first run of late ticks lasts (nothing once it has ended).
    fn trace(&mut self, f: Vec3) {
        let n = self.first_run_len as usize;
        // The first run is the only one whose ticks follow the recorded ones without a gap.
        if n == 0 && self.in_row == 1 {
            self.first_run[0] = self.last.length();
        } else if n == 0 || self.in_row as usize != n + 1 {
            return;
        }
        if let Some(slot) = self.first_run.get_mut(n + 1) {
            *slot = f.length();
            self.first_run_len += 1;
        }
    }
}
