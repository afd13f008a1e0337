//! The monotonic clock of the transports: their waits and deadlines (register requests,
//! packet waits, stall limits) are measured on CLOCK_MONOTONIC, the clock the host runner's
//! servo schedules its ticks on. One libc call, with its `// SAFETY:` reason.
#![allow(unsafe_code)]

/// Nanoseconds on CLOCK_MONOTONIC.
///
/// # Bounded work
/// One `clock_gettime` call (a vDSO read on Linux); never blocks.
pub fn now_ns() -> u64 {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `ts` is a valid, writable timespec; CLOCK_MONOTONIC always exists on Linux.
    unsafe { libc::clock_gettime(libc::CLOCK_MONOTONIC, &mut ts) };
    ts.tv_sec as u64 * 1_000_000_000 + ts.tv_nsec as u64
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_clock_runs_forward_from_boot() {
        let a = now_ns();
        let b = now_ns();
        // CLOCK_MONOTONIC counts from boot: a zero reading would be a failed call.
        assert!(a > 0);
        assert!(b >= a, "{a} then {b}");
    }
}
