//! SysTick as the servo's 1 kHz timer and as an instruction counter.
//!
//! Under QEMU with `-icount shift=S` every instruction takes `2^S` ns of virtual time, and the
//! SysTick counts at the processor clock QEMU gives it when CLKSOURCE selects it, so every
//! SysTick count is a fixed fraction of an instruction, [`INSTRUCTIONS_PER_COUNT`]:
//!
//! | machine | SysTick's processor clock | `S` | ns a count | instructions a count |
//! |---|---|---|---|---|
//! | `mps2-an386`, `mps2-an500` (and the H743's map on it) | 25 MHz | 10 | 40 | 40 / 1024 |
//! | `netduinoplus2` (the F405) | 168 MHz (its reference clock: 21 MHz) | 3 | 125 / 21 | 125 / 168 |
//!
//! On the F405 a count is 0.744 instructions, so a count of instructions is exact to one
//! instruction, and 168,000 instructions (1 ms at 168 MHz) are exactly 225,792 counts, within
//! the 24-bit reload. The firmware gives the servo period in instructions
//! ([`crate::target::PERIOD_INSTRUCTIONS`], 1 ms at the target's clock, one instruction a
//! cycle) and sets the SysTick reload to that many instructions' counts: the SysTick exception
//! is the servo's timer event, and `reload - current` is the time since the event. [`now`]
//! extends it with the number of events the servo has counted ([`EVENTS`]). The DWT cycle
//! counter reads 0 under QEMU and is not used.

use core::sync::atomic::{AtomicU32, Ordering};

use cortex_m::peripheral::syst::SystClkSource;
use cortex_m::peripheral::{SCB, SYST};

use crate::target::PERIOD_INSTRUCTIONS;

/// The `-icount shift` the runner uses (scripts/port-check.sh passes the same).
#[cfg(not(feature = "chip-f405"))]
pub const ICOUNT_SHIFT: u32 = 10;
/// The `-icount shift` the runner uses (scripts/port-check.sh passes the same).
#[cfg(feature = "chip-f405")]
pub const ICOUNT_SHIFT: u32 = 3;

/// Instructions a SysTick count, as `(numerator, denominator)`: `ns a count / 2^S`.
#[cfg(not(feature = "chip-f405"))]
pub const INSTRUCTIONS_PER_COUNT: (u64, u64) = (40, 1 << ICOUNT_SHIFT);
/// Instructions a SysTick count, as `(numerator, denominator)`: `ns a count / 2^S`, a count
/// being 1 / 168 MHz = 125 / 21 ns.
#[cfg(feature = "chip-f405")]
pub const INSTRUCTIONS_PER_COUNT: (u64, u64) = (125, 21 << ICOUNT_SHIFT);

/// SysTick counts in one servo period: `PERIOD_INSTRUCTIONS` over [`INSTRUCTIONS_PER_COUNT`].
pub const PERIOD_COUNTS: u32 = {
    let (num, den) = INSTRUCTIONS_PER_COUNT;
    let c = PERIOD_INSTRUCTIONS as u64 * den;
    assert!(
        c.is_multiple_of(num),
        "the period must be a whole number of counts"
    );
    let c = c / num;
    assert!(c <= 0x0100_0000, "the period must fit the 24-bit SysTick");
    c as u32
};
/// The SysTick reload value for one period.
pub const RELOAD: u32 = PERIOD_COUNTS - 1;
/// The full 24-bit reload used while calibrating.
const FULL: u32 = 0x00FF_FFFF;

/// Timer events the servo has taken (incremented first thing in its handler).
pub static EVENTS: AtomicU32 = AtomicU32::new(0);

/// Instructions in `counts` SysTick counts (rounded down: exact on the MPS2 boards, within
/// one instruction on the F405).
pub fn instructions(counts: u64) -> u64 {
    let (num, den) = INSTRUCTIONS_PER_COUNT;
    counts * num / den
}

/// SysTick counts since the current period's timer event (the event itself counts 1).
#[inline(always)]
pub fn since_event() -> u32 {
    RELOAD - SYST::get_current() + 1
}

/// Instructions since the current period's timer event.
#[inline(always)]
pub fn instructions_since_event() -> u32 {
    instructions(since_event() as u64) as u32
}

/// SysTick counts since the servo timer started: events counted by the servo times the
/// period, plus the time into the current period. Read from below the servo's priority: an
/// event taken between the reads is seen by the event count changing and the reads redone; an
/// event not yet taken (the exception pending for the instruction or two before it preempts
/// the reader) is added here.
#[inline(never)]
pub fn now() -> u64 {
    loop {
        let a = EVENTS.load(Ordering::Acquire);
        let v = SYST::get_current();
        let pending = SCB::is_pendst_pending();
        let b = EVENTS.load(Ordering::Acquire);
        if a == b {
            let mut events = a as u64;
            if pending && v > RELOAD / 2 {
                events += 1;
            }
            return events * PERIOD_COUNTS as u64 + (RELOAD - v) as u64;
        }
    }
}

/// What [`calibrate`] found.
#[derive(Clone, Copy, Debug)]
pub struct Calibration {
    /// Instructions the delay loop executes.
    pub expected: u64,
    /// Instructions measured for it, less the read overhead.
    pub measured: u64,
    /// Instructions between two back-to-back reads of the counter.
    pub overhead: u64,
}

/// Reads the free-running counter [`calibrate`] leaves running until the servo timer starts
/// (no wrap: the intervals measured with it are short).
#[inline(never)]
pub fn read() -> u32 {
    FULL - SYST::get_current()
}

/// Checks the formula on a loop of known length before the servo timer starts, with the full
/// 24-bit reload and no exception: `cortex_m::asm::delay(n)` (cortex-m 0.7.10) runs `n + 1`
/// iterations of `subs; bne`, 2 instructions each. The counter keeps running, free, for
/// [`read`].
pub fn calibrate(syst: &mut SYST) -> Calibration {
    syst.disable_interrupt();
    syst.set_clock_source(SystClkSource::Core);
    syst.set_reload(FULL);
    syst.clear_current();
    syst.enable_counter();
    let a = read();
    let b = read();
    let overhead = instructions((b - a) as u64);
    const N: u32 = 100_000;
    let expected = 2 * (N as u64 + 1);
    let t0 = read();
    cortex_m::asm::delay(N);
    let t1 = read();
    Calibration {
        expected,
        measured: instructions((t1 - t0) as u64).saturating_sub(overhead),
        overhead,
    }
}

/// Starts SysTick as the servo timer: one exception every [`PERIOD_COUNTS`] counts.
pub fn start_servo_timer(syst: &mut SYST) {
    syst.set_clock_source(SystClkSource::Core);
    syst.set_reload(RELOAD);
    syst.clear_current();
    syst.enable_interrupt();
    syst.enable_counter();
}

/// Stops the servo timer (after the last scripted tick).
pub fn stop_servo_timer(syst: &mut SYST) {
    syst.disable_interrupt();
    syst.disable_counter();
}

/// Max and mean of per-tick instruction counts.
#[derive(Clone, Copy, Debug, Default)]
pub struct Stats {
    /// Largest count.
    pub max: u64,
    /// The tick it was seen at.
    pub max_at: u32,
    sum: u64,
    n: u64,
}

impl Stats {
    /// Adds tick `tick`'s count.
    pub fn add(&mut self, tick: u32, count: u64) {
        if count > self.max || self.n == 0 {
            self.max = count;
            self.max_at = tick;
        }
        self.sum += count;
        self.n += 1;
    }

    /// The mean, rounded to the nearest instruction.
    pub fn mean(&self) -> u64 {
        (self.sum + self.n / 2).checked_div(self.n).unwrap_or(0)
    }
}
