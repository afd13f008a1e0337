//! Real-time set-up of the servo thread and its absolute-deadline period.
//!
//! [`RtConfig::apply`] tries core pinning, SCHED_FIFO and `mlockall`, and reports each as one
//! line when it is not permitted (the run goes on without it). [`Periodic`] wakes at absolute
//! deadlines `start + k * period`, optionally spinning the last few microseconds, and counts
//! overruns (a deadline missed by more than a whole period); it measures every wake-up's
//! latency, as cyclictest does.

use crate::platform;

/// The servo's period: 1 ms (1 kHz).
pub const SERVO_PERIOD_NS: u64 = 1_000_000;

/// What the servo thread asks of the operating system.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RtConfig {
    /// SCHED_FIFO priority (1..=99); `None` keeps the default scheduler.
    pub fifo_priority: Option<i32>,
    /// Core to pin to; `None` leaves the thread unpinned.
    pub core: Option<usize>,
    /// Lock all memory (`mlockall`).
    pub lock_memory: bool,
}

/// Holds `/dev/cpu_dma_latency` at 0 for the rest of the process, as cyclictest does: the
/// power-management QoS request keeps idle cores out of deep sleep states, whose exit latency
/// would otherwise add to every wake-up. The request lasts while the file stays open.
fn hold_zero_dma_latency() -> std::io::Result<()> {
    use std::io::Write as _;
    static HELD: std::sync::OnceLock<std::fs::File> = std::sync::OnceLock::new();
    if HELD.get().is_some() {
        return Ok(());
    }
    let mut f = std::fs::OpenOptions::new()
        .write(true)
        .open("/dev/cpu_dma_latency")?;
    f.write_all(&0i32.to_ne_bytes())?;
    let _ = HELD.set(f);
    Ok(())
}

impl Default for RtConfig {
    fn default() -> Self {
        // The last core: the one least likely to carry the other tasks.
        Self {
            fifo_priority: Some(80),
            core: Some(platform::cores() - 1),
            lock_memory: true,
        }
    }
}

/// What [`RtConfig::apply`] achieved.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct RtStatus {
    /// SCHED_FIFO in force.
    pub fifo: bool,
    /// The core pinned to.
    pub pinned: Option<usize>,
    /// Memory locked.
    pub memory_locked: bool,
    /// `/dev/cpu_dma_latency` held at 0 (idle cores kept out of deep sleep).
    pub low_latency_idle: bool,
    /// One line per thing that was asked for and not permitted.
    pub warnings: Vec<String>,
}

impl RtConfig {
    /// Applies the configuration to the calling thread. Never fails: what is not permitted is
    /// reported in [`RtStatus::warnings`] and the run goes on without it.
    pub fn apply(&self) -> RtStatus {
        let mut st = RtStatus::default();
        if let Some(core) = self.core {
            match platform::pin_to_core(core) {
                Ok(()) => st.pinned = Some(core),
                Err(e) => st
                    .warnings
                    .push(format!("servo not pinned to core {core}: {e}")),
            }
        }
        if let Some(p) = self.fifo_priority {
            match platform::set_fifo(p) {
                Ok(()) => st.fifo = true,
                Err(e) => st.warnings.push(format!(
                    "servo runs without SCHED_FIFO ({e}); wake-ups may be late under load \
                     (run as root or grant CAP_SYS_NICE / an rtprio limit)"
                )),
            }
        }
        if self.fifo_priority.is_some() {
            match hold_zero_dma_latency() {
                Ok(()) => st.low_latency_idle = true,
                Err(e) => st.warnings.push(format!(
                    "idle cores may sleep deeply (/dev/cpu_dma_latency: {e}); wake-ups can be \
                     tens of microseconds later"
                )),
            }
        }
        if self.lock_memory {
            match platform::lock_memory() {
                Ok(()) => st.memory_locked = true,
                Err(e) => st.warnings.push(format!(
                    "memory not locked ({e}); a page fault can delay a tick \
                     (raise the memlock limit or run as root)"
                )),
            }
        }
        st
    }
}

/// One wake-up of a [`Periodic`] timer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Wake {
    /// The deadline this wake-up was for (ns, CLOCK_MONOTONIC).
    pub deadline_ns: u64,
    /// How late the thread woke (ns).
    pub latency_ns: u64,
    /// Deadlines skipped because the previous tick ran past them.
    pub missed: u64,
}

/// A periodic timer on absolute deadlines. Neither allocates nor locks.
#[derive(Debug, Clone)]
pub struct Periodic {
    next_ns: u64,
    period_ns: u64,
    spin_ns: u64,
    /// Deadlines missed so far (a tick that ran longer than a period).
    pub overruns: u64,
}

impl Periodic {
    /// A timer whose first deadline is one period from now. `spin_ns` > 0 sleeps until that
    /// long before each deadline and spins the rest (lower latency, one core busy).
    pub fn new(period_ns: u64, spin_ns: u64) -> Self {
        let period_ns = period_ns.max(1);
        Self {
            next_ns: platform::now_ns() + period_ns,
            period_ns,
            spin_ns: spin_ns.min(period_ns / 2),
            overruns: 0,
        }
    }

    /// The period in nanoseconds.
    pub fn period_ns(&self) -> u64 {
        self.period_ns
    }

    /// Waits for the next deadline and reports how late the wake-up was. A deadline already
    /// passed by more than a period counts as overrun(s) and is skipped, so the timer never
    /// runs a burst of catch-up ticks.
    pub fn wait(&mut self) -> Wake {
        let now = platform::now_ns();
        let mut missed = 0;
        if now > self.next_ns + self.period_ns {
            missed = (now - self.next_ns) / self.period_ns;
            self.next_ns += missed * self.period_ns;
            self.overruns += missed;
        }
        let deadline = self.next_ns;
        if self.spin_ns > 0 {
            platform::sleep_until_ns(deadline.saturating_sub(self.spin_ns));
            while platform::now_ns() < deadline {
                std::hint::spin_loop();
            }
        } else {
            platform::sleep_until_ns(deadline);
        }
        let woke = platform::now_ns();
        self.next_ns = deadline + self.period_ns;
        Wake {
            deadline_ns: deadline,
            latency_ns: woke.saturating_sub(deadline),
            missed,
        }
    }
}
