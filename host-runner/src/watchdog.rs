//! The servo's supervisor: a watchdog thread that zeroes the force when the servo thread
//! misses its ticks, and the servo's guard against its own panics.
//!
//! The device's own watchdog ([`tetradrill_device::ForceSafety`]) counts device ticks, which
//! only the servo's reads advance: a servo thread that stalls altogether (blocked, spinning,
//! descheduled) stops that clock too. The supervisor counts wall time instead:
//!
//! - the servo bumps [`ServoWatch::beat`] once a tick (an atomic store: no lock, no
//!   allocation) from its first tick to its last;
//! - the supervisor thread ([`supervisor_task`]) looks every [`SUPERVISOR_POLL_NS`]; when the
//!   beat has not changed for [`SERVO_WATCHDOG_NS`], it trips: it calls the device's
//!   [`MotorCutoff`], which sets the latch the device's write path honours and puts zero force,
//!   motors off, on the device through a path that does not need the servo thread
//!   (`docs/SAFETY.md` lists what each backend does), and reports the stall once;
//! - when the servo runs again it sees the trip at the top of its next tick, writes
//!   [`ForceCommand::OFF`] through its own path, re-arms the cutoff and goes on: the device's
//!   filter ramps the force up again from zero. The run recovers; the stalls are counted.
//!
//! A servo that panics (a bug) is caught by [`quiet_unwind`] around its task; the pipeline then
//! zeroes the force through the cutoff and the device ([`after_panic`]) and ends the run with
//! one line and exit status 1.
//!
//! A clean stop (a signal, or a caller) goes through a [`StopRequest`]: the servo looks at it
//! after each wake-up and the tick that sees it zeroes the force the way a trip does
//! ([`zero_force`]: the cutoff, then [`ForceCommand::OFF`] through the servo's own path)
//! before the run winds down.

use std::cell::{Cell, RefCell};
use std::panic::AssertUnwindSafe;
use std::sync::atomic::{AtomicBool, AtomicI32, AtomicU32, AtomicU64, Ordering};
use std::sync::{Arc, Mutex, Once};

use tetradrill_device::{Cut, DeviceError, ForceCommand, HapticDevice, MotorCutoff};

use crate::platform;
use crate::rt::RtConfig;
use crate::rt::SERVO_PERIOD_NS;

/// How long the servo may go without a tick before the supervisor zeroes the force: 10 servo
/// periods (10 ms).
pub const SERVO_WATCHDOG_NS: u64 = 10 * SERVO_PERIOD_NS;

/// How often the supervisor looks at the servo's beat (1 ms).
pub const SUPERVISOR_POLL_NS: u64 = 1_000_000;

/// What the servo and its supervisor share. The servo's side is atomics only.
#[derive(Debug, Default)]
pub struct ServoWatch {
    /// Ticks done while armed; 0 before the servo's first tick and after its last.
    heartbeat: AtomicU64,
    /// Set by the supervisor when it trips; cleared by the servo when it runs again.
    tripped: AtomicBool,
    /// Stalls the supervisor caught.
    trips: AtomicU64,
    /// Longest stall the servo came back from (the longest time without a tick end), ns.
    stall_max_ns: AtomicU64,
    /// The device's cutoff, handed over by the servo thread before its loop.
    cutoff: Mutex<Option<Arc<dyn MotorCutoff>>>,
}

impl ServoWatch {
    /// The servo thread hands over its device's cutoff (before its loop: this takes a lock).
    pub fn attach(&self, cutoff: Option<Arc<dyn MotorCutoff>>) {
        match self.cutoff.lock() {
            Ok(mut c) => *c = cutoff,
            Err(p) => *p.into_inner() = cutoff,
        }
    }

    fn cutoff(&self) -> Option<Arc<dyn MotorCutoff>> {
        match self.cutoff.lock() {
            Ok(c) => c.clone(),
            Err(p) => p.into_inner().clone(),
        }
    }

    /// The servo finished tick `done` (at least 1): arms the watchdog and feeds it. An atomic
    /// store.
    pub fn beat(&self, done: u64) {
        self.heartbeat.store(done.max(1), Ordering::Release);
    }

    /// The servo's loop is over (or never started): the supervisor stops watching.
    pub fn disarm(&self) {
        self.heartbeat.store(0, Ordering::Release);
    }

    /// The supervisor caught a stall the servo has not come back from yet. An atomic load.
    pub fn tripped(&self) -> bool {
        self.tripped.load(Ordering::Acquire)
    }

    /// The servo runs again after a trip; `stalled_ns` is how long it went without ending a tick.
    /// Atomics only.
    pub fn resumed(&self, stalled_ns: u64) {
        self.stall_max_ns.fetch_max(stalled_ns, Ordering::Relaxed);
        self.tripped.store(false, Ordering::Release);
    }

    /// Stalls caught so far.
    pub fn stalls(&self) -> u64 {
        self.trips.load(Ordering::Relaxed)
    }

    /// The longest stall the servo came back from, ns.
    pub fn stall_max_ns(&self) -> u64 {
        self.stall_max_ns.load(Ordering::Relaxed)
    }
}

/// How a trip's cut ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Outcome {
    /// The cutoff put zero on the device.
    Zeroed,
    /// The device has no path but the servo's.
    NoPath,
    /// The cutoff's path stayed busy until the servo ran again; the latch zeroed its writes.
    BusyUntilResumed,
    /// The cutoff failed.
    Failed(DeviceError),
}

/// One line saying what a stall did: `the servo stalled for 11 ms after 300 ticks; force was
/// set to zero (...)`.
fn stall_line(stalled_ns: u64, ticks: u64, device: &str, outcome: Outcome) -> String {
    let ms = stalled_ns.div_ceil(1_000_000);
    let what = match outcome {
        Outcome::Zeroed => {
            "force was set to zero (it ramps up again when the servo runs again)".to_string()
        }
        Outcome::NoPath => format!(
            "the {device} device can be reached only through the servo thread: its last force \
             stays until the servo runs again"
        ),
        Outcome::BusyUntilResumed => {
            "the device's second path stayed busy: force was set to zero when the servo ran \
             again"
                .to_string()
        }
        Outcome::Failed(e) => format!("setting the force to zero failed: {e}"),
    };
    format!("the servo stalled for {ms} ms after {ticks} ticks; {what}")
}

/// The supervisor thread's scheduling: SCHED_FIFO one above the servo's priority when the
/// servo asks for SCHED_FIFO and it is permitted, then pinned to a core that is not the
/// servo's (so that it neither waits behind a spinning servo nor disturbs its core). Without
/// SCHED_FIFO it stays unpinned at normal priority. Never fails.
pub fn supervisor_rt(rt: &RtConfig) {
    let Some(p) = rt.fifo_priority else {
        return;
    };
    if platform::set_fifo((p + 1).min(99)).is_err() {
        return;
    }
    let cores = platform::cores();
    if cores > 1 {
        let other = match rt.core {
            Some(0) => 1,
            _ => 0,
        };
        let _ = platform::pin_to_core(other);
    }
}

/// The supervisor: until `stop` is set and the servo has disarmed, looks at the servo's beat
/// every [`SUPERVISOR_POLL_NS`]; after `watchdog_ns` without a change, trips (see the module
/// docs) and hands the first stall's line to `report` (later stalls are counted, not
/// reported). `device` names the device in that line.
///
/// It never waits for the servo: a busy cutoff is tried again at the next look, until it
/// works or the servo runs again.
pub fn supervisor_task(
    watch: &ServoWatch,
    device: &str,
    watchdog_ns: u64,
    stop: &AtomicBool,
    mut report: impl FnMut(String),
) {
    let mut last_beat = 0u64;
    let mut last_change = platform::now_ns();
    // A trip whose cut has not resolved yet: (stalled ns at the trip, ticks).
    let mut pending: Option<(u64, u64)> = None;
    let mut reported = false;
    let mut next = platform::now_ns();
    let mut say = |line: String, reported: &mut bool| {
        if !*reported {
            *reported = true;
            report(line);
        }
    };
    loop {
        next += SUPERVISOR_POLL_NS;
        let now = platform::now_ns();
        if next <= now {
            next = now + SUPERVISOR_POLL_NS;
        }
        platform::sleep_until_ns(next);
        let beat = watch.heartbeat.load(Ordering::Acquire);
        let now = platform::now_ns();
        if beat == 0 {
            if stop.load(Ordering::Relaxed) {
                break;
            }
            last_beat = 0;
            last_change = now;
            continue;
        }
        if beat != last_beat {
            last_beat = beat;
            last_change = now;
            if let Some((stalled, ticks)) = pending.take() {
                say(
                    stall_line(stalled, ticks, device, Outcome::BusyUntilResumed),
                    &mut reported,
                );
            }
            continue;
        }
        let silent = now.saturating_sub(last_change);
        if pending.is_none() && !watch.tripped() && silent > watchdog_ns {
            watch.tripped.store(true, Ordering::Release);
            watch.trips.fetch_add(1, Ordering::Relaxed);
            pending = Some((silent, beat));
        }
        if let Some((stalled, ticks)) = pending {
            let outcome = match watch.cutoff() {
                None => Outcome::NoPath,
                Some(c) => match c.cut() {
                    Ok(Cut::Done) => Outcome::Zeroed,
                    Ok(Cut::Busy) => continue,
                    Err(e) => Outcome::Failed(e),
                },
            };
            pending = None;
            say(stall_line(stalled, ticks, device, outcome), &mut reported);
        }
    }
}

/// Zeroes the force now, through both of the paths a trip uses: the device's cutoff when it
/// has one (the latch is set, so no later write of this run renders force; zero force with
/// the motors off through the device's second path), then [`ForceCommand::OFF`] through the
/// device itself. Called on the servo thread.
///
/// # Bounded work
/// One cutoff call and one device write; no allocation, no lock of this crate's.
///
/// # Errors
/// The device write's error (the cutoff's latch is set whatever happens).
pub fn zero_force(
    device: &mut dyn HapticDevice,
    cutoff: Option<&dyn MotorCutoff>,
) -> Result<(), DeviceError> {
    if let Some(c) = cutoff {
        let _ = c.cut();
    }
    device.write(&ForceCommand::OFF)
}

/// A request to end a real-time run cleanly, shared by whoever asks (the signal handlers of
/// `run` and `demo`, a test, an embedding program) and the servo, which looks at it once a
/// tick. Cloning shares the request. Raising it is atomics and a clock read only, so a signal
/// handler may do it.
#[derive(Debug, Clone, Default)]
pub struct StopRequest(Arc<StopFlags>);

/// The atomics behind a [`StopRequest`].
#[derive(Debug, Default)]
pub struct StopFlags {
    /// Requests so far (signals and calls).
    requests: AtomicU32,
    /// Signals among them.
    signals: AtomicU32,
    /// The first signal's number (0: none yet).
    signal: AtomicI32,
    /// The latest signal's number.
    last: AtomicI32,
    /// CLOCK_MONOTONIC time of the first request, ns.
    at_ns: AtomicU64,
    /// The servo has written zero force for the request, or the run is over: a signal now
    /// ends the process at once.
    zeroed: AtomicBool,
}

impl StopFlags {
    /// Raises the request for signal `signal` (0: a call, not a signal). Returns whether the
    /// process should exit at once: a signal that comes when the force is zero already (a
    /// second signal after the servo's zero-force write, or any after the run is over).
    /// Async-signal-safe: atomic operations and `clock_gettime` only.
    pub fn raise(&self, signal: i32) -> bool {
        let _ = self.at_ns.compare_exchange(
            0,
            platform::now_ns().max(1),
            Ordering::SeqCst,
            Ordering::SeqCst,
        );
        if signal != 0 {
            let _ = self
                .signal
                .compare_exchange(0, signal, Ordering::SeqCst, Ordering::SeqCst);
            self.last.store(signal, Ordering::SeqCst);
            self.signals.fetch_add(1, Ordering::SeqCst);
        }
        self.requests.fetch_add(1, Ordering::SeqCst);
        signal != 0 && self.zeroed.load(Ordering::SeqCst)
    }
}

impl StopRequest {
    /// A request not raised yet.
    pub fn new() -> Self {
        Self::default()
    }

    /// Asks the run to stop cleanly (what the first signal does).
    pub fn request(&self) {
        let _ = self.0.raise(0);
    }

    /// Whether a stop was asked for. An atomic load.
    pub fn is_requested(&self) -> bool {
        self.0.requests.load(Ordering::SeqCst) > 0
    }

    /// CLOCK_MONOTONIC time of the first request, ns.
    pub fn requested_at_ns(&self) -> Option<u64> {
        Some(self.0.at_ns.load(Ordering::SeqCst)).filter(|&t| t > 0)
    }

    /// The first signal that raised the request, if a signal did.
    pub fn signal(&self) -> Option<i32> {
        Some(self.0.signal.load(Ordering::SeqCst)).filter(|&s| s != 0)
    }

    /// The servo wrote zero force for the request. When a second signal came already, the
    /// process exits here with status 128 + that signal's number (the summary and the JSON are
    /// skipped, as a second signal asks); a signal after this exits from its handler.
    pub fn force_zeroed(&self) {
        self.0.zeroed.store(true, Ordering::SeqCst);
        if self.0.signals.load(Ordering::SeqCst) > 1 {
            platform::exit_now(128 + self.0.last.load(Ordering::SeqCst));
        }
    }

    /// The run is over (the force off, the device released): from now on a signal ends the
    /// process at once, as if no handler were installed.
    pub fn run_over(&self) {
        self.0.zeroed.store(true, Ordering::SeqCst);
    }

    /// The shared atomics (for the signal handlers, [`platform::on_stop_signals`]).
    pub fn flags(&self) -> &Arc<StopFlags> {
        &self.0
    }
}

thread_local! {
    /// This thread's panics are caught by [`quiet_unwind`]: the hook keeps their line instead
    /// of printing it.
    static QUIET: Cell<bool> = const { Cell::new(false) };
    /// The line of the last quiet panic on this thread.
    static CAUGHT: RefCell<Option<String>> = const { RefCell::new(None) };
}

static HOOK: Once = Once::new();

/// The panic's message on one line (newlines become "; "), with its place when known.
fn panic_line(payload: &(dyn std::any::Any + Send), at: Option<String>) -> String {
    let msg = payload
        .downcast_ref::<&str>()
        .map(|s| (*s).to_string())
        .or_else(|| payload.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "a panic without a message".to_string());
    let msg = msg
        .lines()
        .map(str::trim)
        .filter(|l| !l.is_empty())
        .collect::<Vec<_>>()
        .join("; ");
    match at {
        Some(at) => format!("{msg} (at {at})"),
        None => msg,
    }
}

/// Installs, once per process, a panic hook that stays silent for threads inside
/// [`quiet_unwind`] (it keeps their line for the caller) and hands every other panic to the
/// hook that was there before.
fn install_quiet_hook() {
    HOOK.call_once(|| {
        let previous = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            if QUIET.try_with(Cell::get).unwrap_or(false) {
                let at = info
                    .location()
                    .map(|l| format!("{}:{}", l.file(), l.line()));
                let line = panic_line(info.payload(), at);
                let _ = CAUGHT.try_with(|c| {
                    if let Ok(mut c) = c.try_borrow_mut() {
                        *c = Some(line);
                    }
                });
            } else {
                previous(info);
            }
        }));
    });
}

/// Runs `f`; a panic inside it is caught and comes back as one line (its message and place)
/// instead of being printed by the default hook. Other threads' panics print as before.
///
/// # Errors
/// The panic's line.
pub fn quiet_unwind<R>(f: impl FnOnce() -> R) -> Result<R, String> {
    install_quiet_hook();
    let was = QUIET.with(|q| q.replace(true));
    let _ = CAUGHT.try_with(|c| c.replace(None));
    let r = std::panic::catch_unwind(AssertUnwindSafe(f));
    QUIET.with(|q| q.set(was));
    r.map_err(|payload| {
        CAUGHT
            .try_with(RefCell::take)
            .ok()
            .flatten()
            .unwrap_or_else(|| panic_line(&*payload, None))
    })
}

/// What the pipeline does after the servo panicked: stops the watchdog, zeroes the force
/// through the device's cutoff (it does not depend on the state the panic left the device
/// in) and then through the device itself (a second panic there is caught too), drops the
/// device (same) and sets `stop`. Returns the end of the line the runner prints: `force was
/// set to zero` or why it could not be.
pub fn after_panic(
    watch: &ServoWatch,
    device: Box<dyn HapticDevice>,
    cutoff: Option<Arc<dyn MotorCutoff>>,
    stop: &AtomicBool,
) -> String {
    watch.disarm();
    let mut device = device;
    let cut = cutoff.as_ref().map(|c| c.cut());
    let wrote = quiet_unwind(|| device.write(&ForceCommand::OFF));
    let _ = quiet_unwind(move || drop(device));
    stop.store(true, Ordering::Relaxed);
    let zeroed = matches!(cut, Some(Ok(Cut::Done))) || matches!(wrote, Ok(Ok(())));
    if zeroed {
        return "force was set to zero".to_string();
    }
    let why = match (cut, wrote) {
        (Some(Err(e)), _) | (_, Ok(Err(e))) => e.to_string(),
        (_, Err(p)) => format!("writing it panicked too: {p}"),
        _ => "the device's path stayed busy".to_string(),
    };
    format!("setting the force to zero failed: {why}")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_quiet_panic_comes_back_as_one_line_with_its_place() {
        let r: Result<(), String> = quiet_unwind(|| {
            let v: Vec<u32> = Vec::new();
            let i = std::hint::black_box(3);
            assert_eq!(v.len(), i, "two\nlines");
        });
        let line = r.expect_err("it panicked");
        assert_eq!(line.lines().count(), 1, "{line}");
        assert!(line.contains("two; lines"), "{line}");
        assert!(line.contains("watchdog.rs:"), "{line}");
        // Nothing is left over for the next call.
        assert_eq!(quiet_unwind(|| 5), Ok(5));
    }

    #[test]
    fn a_stop_request_keeps_its_first_time_and_signal() {
        let r = StopRequest::new();
        assert!(!r.is_requested());
        assert_eq!((r.requested_at_ns(), r.signal()), (None, None));
        let shared = r.clone();
        let before = platform::now_ns();
        assert!(!shared.flags().raise(15), "a first signal never exits");
        let at = r.requested_at_ns().expect("stamped");
        assert!(r.is_requested() && at >= before && at <= platform::now_ns());
        // A second signal before the force is zero does not exit either (the servo does,
        // once it has written zero); one after it does.
        assert!(!shared.flags().raise(2));
        r.0.zeroed.store(true, Ordering::SeqCst);
        assert!(r.flags().raise(2));
        assert_eq!(
            r.requested_at_ns(),
            Some(at),
            "the first request's time stays"
        );
        assert_eq!(r.signal(), Some(15), "and its signal");
        // After the run, even a first signal exits.
        let over = StopRequest::new();
        over.run_over();
        assert!(over.flags().raise(1));
        // Calls are no signals: they never ask for an exit.
        let c = StopRequest::new();
        c.request();
        c.0.zeroed.store(true, Ordering::SeqCst);
        assert!(!c.flags().raise(0));
        assert_eq!(c.signal(), None);
    }

    #[test]
    fn the_stall_line_says_what_happened() {
        let l = stall_line(10_400_000, 300, "sim", Outcome::Zeroed);
        assert_eq!(
            l,
            "the servo stalled for 11 ms after 300 ticks; force was set to zero (it ramps up \
             again when the servo runs again)"
        );
        let l = stall_line(12_000_000, 7, "touch", Outcome::NoPath);
        assert!(l.contains("12 ms") && l.contains("the touch device"), "{l}");
        let l = stall_line(1, 7, "omni", Outcome::Failed(DeviceError::Disconnected));
        assert!(l.ends_with("setting the force to zero failed: device disconnected"));
    }
}
