//! The platform layer of the real-time tasks: the monotonic clock, absolute-deadline sleeps,
//! SCHED_FIFO, memory locking, core pinning and the stop signals' handlers. This is the only
//! file of the host runner with `unsafe` (each block is one libc call with its `// SAFETY:`
//! reason; the device crate's OS transports have their own); everything else calls these safe
//! wrappers.
#![allow(unsafe_code)]

use std::io;

/// Nanoseconds on CLOCK_MONOTONIC: the device crate's clock, which the transports' deadlines
/// use too.
pub use tetradrill_device::os::clock::now_ns;

/// Sleeps until the absolute CLOCK_MONOTONIC time `t_ns` (`clock_nanosleep` with
/// TIMER_ABSTIME, restarted after signals). Neither allocates nor locks.
pub fn sleep_until_ns(t_ns: u64) {
    let ts = libc::timespec {
        tv_sec: (t_ns / 1_000_000_000) as libc::time_t,
        tv_nsec: (t_ns % 1_000_000_000) as libc::c_long,
    };
    loop {
        // SAFETY: `ts` is a valid timespec; a null remainder is allowed with TIMER_ABSTIME.
        let rc = unsafe {
            libc::clock_nanosleep(
                libc::CLOCK_MONOTONIC,
                libc::TIMER_ABSTIME,
                &ts,
                std::ptr::null_mut(),
            )
        };
        if rc != libc::EINTR {
            return;
        }
    }
}

/// Locks all current and future pages in memory (`mlockall`), so the servo never waits for a
/// page fault.
pub fn lock_memory() -> io::Result<()> {
    // SAFETY: plain system call with flag arguments; no pointers.
    let rc = unsafe { libc::mlockall(libc::MCL_CURRENT | libc::MCL_FUTURE) };
    if rc == 0 {
        Ok(())
    } else {
        Err(io::Error::last_os_error())
    }
}

/// Gives the calling thread SCHED_FIFO at `priority` (1..=99).
pub fn set_fifo(priority: i32) -> io::Result<()> {
    let param = libc::sched_param {
        sched_priority: priority,
    };
    // SAFETY: `param` is a valid sched_param; `pthread_self()` is the calling thread.
    let rc = unsafe { libc::pthread_setschedparam(libc::pthread_self(), libc::SCHED_FIFO, &param) };
    if rc == 0 {
        Ok(())
    } else {
        Err(io::Error::from_raw_os_error(rc))
    }
}

/// Pins the calling thread to one CPU core.
pub fn pin_to_core(core: usize) -> io::Result<()> {
    if core >= libc::CPU_SETSIZE as usize {
        return Err(io::Error::new(io::ErrorKind::InvalidInput, "no such core"));
    }
    // SAFETY: an all-zero cpu_set_t is a valid empty set.
    let mut set: libc::cpu_set_t = unsafe { std::mem::zeroed() };
    // SAFETY: `core` is below CPU_SETSIZE (checked above), `set` is a valid cpu_set_t.
    unsafe { libc::CPU_SET(core, &mut set) };
    // SAFETY: `set` is a valid cpu_set_t of the size passed; pid 0 is the calling thread.
    let rc = unsafe { libc::sched_setaffinity(0, std::mem::size_of::<libc::cpu_set_t>(), &set) };
    if rc == 0 {
        Ok(())
    } else {
        Err(io::Error::last_os_error())
    }
}

/// Number of CPU cores this process may run on.
pub fn cores() -> usize {
    std::thread::available_parallelism()
        .map(|n| n.get())
        .unwrap_or(1)
}

/// Ends the process at once with `code` (`_exit`: no destructors, no buffered output; what a
/// second stop signal asks for once the force is zero).
pub fn exit_now(code: i32) -> ! {
    // SAFETY: `_exit` takes a plain integer and never returns; it is async-signal-safe.
    unsafe { libc::_exit(code) }
}

/// The signals that stop a run: SIGINT (Ctrl-C), SIGTERM and SIGHUP.
pub const STOP_SIGNALS: [i32; 3] = [libc::SIGINT, libc::SIGTERM, libc::SIGHUP];

/// Handlers for [`STOP_SIGNALS`] that call `raise(signal)` (through `signal-hook`, which
/// chains them with any handler already there), for the rest of the process. `raise` returns
/// whether the process should end now: the first signal only raises the stop request
/// (`watchdog::StopFlags::raise`); a later one, once the servo has written zero force (or any
/// once the run is over), ends the process at once with status 128 + the signal's number.
/// `raise` runs in a signal handler: it must be async-signal-safe (atomic operations, at most
/// `clock_gettime`; nothing that allocates or locks).
///
/// # Errors
/// A signal whose handler could not be installed.
pub fn on_stop_signals<F>(raise: F) -> io::Result<()>
where
    F: Fn(i32) -> bool + Clone + Send + Sync + 'static,
{
    for sig in STOP_SIGNALS {
        let r = raise.clone();
        let action = move || {
            if r(sig) {
                exit_now(128 + sig);
            }
        };
        // SAFETY: the action is async-signal-safe when `raise` is, as this function requires of
        // it, and `exit_now` is `_exit`. The clone of `raise` it holds was made here, before.
        let _ = unsafe { signal_hook::low_level::register(sig, action) }?;
    }
    Ok(())
}
