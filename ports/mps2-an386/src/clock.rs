//! SysTick as an instruction counter.
//!
//! Under QEMU with `-icount shift=S` every instruction takes `2^S` ns of virtual time, and the
//! mps2-an386 SysTick runs from the 25 MHz processor clock (40 ns a count) when CLKSOURCE
//! selects it, so `instructions = counts * 40 / 2^S`. The 24-bit counter wraps every 2^24
//! counts (about 655,000 instructions at S = 10); the SysTick exception counts the wraps, so
//! [`Clock::now`] is a 64-bit count that never wraps in practice. The DWT cycle counter reads
//! 0 under QEMU and is not used.

use core::sync::atomic::{AtomicU32, Ordering};

use cortex_m::peripheral::syst::SystClkSource;
use cortex_m::peripheral::{SCB, SYST};

/// The `-icount shift` the runner uses.
pub const ICOUNT_SHIFT: u32 = 10;
/// SysTick counts per 2^ICOUNT_SHIFT instructions: 40 ns per count at 25 MHz.
const NS_PER_COUNT: u64 = 40;
/// The reload value: the full 24 bits.
const RELOAD: u32 = 0x00FF_FFFF;

/// SysTick wraps since [`Clock::start`], counted by the SysTick exception.
static WRAPS: AtomicU32 = AtomicU32::new(0);

/// Called by the SysTick exception handler.
pub fn wrapped() {
    WRAPS.fetch_add(1, Ordering::Relaxed);
}

/// Instructions in `counts` SysTick counts.
pub fn instructions(counts: u64) -> u64 {
    (counts * NS_PER_COUNT) >> ICOUNT_SHIFT
}

/// The running SysTick.
pub struct Clock {
    _syst: SYST,
}

/// What [`Clock::calibrate`] found.
#[derive(Clone, Copy, Debug)]
pub struct Calibration {
    /// Instructions the delay loop executes.
    pub expected: u64,
    /// Instructions measured for it, less the read overhead.
    pub measured: u64,
    /// Instructions between two back-to-back [`Clock::now`] calls (subtracted from each
    /// measured interval).
    pub overhead: u64,
}

impl Clock {
    /// Starts SysTick from the processor clock with the full 24-bit reload and its exception
    /// enabled.
    pub fn start(mut syst: SYST) -> Self {
        syst.set_clock_source(SystClkSource::Core);
        syst.set_reload(RELOAD);
        syst.clear_current();
        syst.enable_interrupt();
        syst.enable_counter();
        Self { _syst: syst }
    }

    /// SysTick counts since [`Clock::start`].
    ///
    /// A wrap whose exception is still pending when the counter is read (the counter is back
    /// near the top but the handler has not run) is added here, so the count never goes back.
    #[inline(never)]
    pub fn now(&mut self) -> u64 {
        cortex_m::interrupt::free(|_| {
            let mut wraps = WRAPS.load(Ordering::Relaxed) as u64;
            let v = SYST::get_current();
            if SCB::is_pendst_pending() && v > RELOAD / 2 {
                wraps += 1;
            }
            wraps * (RELOAD as u64 + 1) + (RELOAD - v) as u64
        })
    }

    /// Checks the formula on a loop of known length: `cortex_m::asm::delay(n)` (cortex-m
    /// 0.7.10) runs `n + 1` iterations of `subs; bne`, 2 instructions each.
    pub fn calibrate(&mut self) -> Calibration {
        let a = self.now();
        let b = self.now();
        let overhead = instructions(b - a);
        const N: u32 = 2_000_000;
        let expected = 2 * (N as u64 + 1);
        let t0 = self.now();
        cortex_m::asm::delay(N);
        let t1 = self.now();
        let measured = instructions(t1 - t0).saturating_sub(overhead);
        Calibration {
            expected,
            measured,
            overhead,
        }
    }
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
