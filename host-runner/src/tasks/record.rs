//! The recorder task (`--record`): the servo's tool samples through a lock-free ring into a
//! trace CSV, off the servo thread.

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

use crossbeam::queue::ArrayQueue;

use super::ToolSample;

/// Rows the recorder's ring holds: 8 s of servo ticks.
pub const RECORD_RING: usize = 8192;

/// The servo-to-recorder hand-off of `--record`: a bounded lock-free ring of tool samples
/// (crossbeam `ArrayQueue`, allocated when it is made). The servo pushes and never waits: a
/// full ring drops the row and counts it.
#[derive(Debug)]
pub struct RecordRing {
    queue: ArrayQueue<ToolSample>,
    dropped: AtomicU64,
}

impl RecordRing {
    /// A ring of `capacity` rows (at least one).
    pub fn new(capacity: usize) -> Self {
        Self {
            queue: ArrayQueue::new(capacity.max(1)),
            dropped: AtomicU64::new(0),
        }
    }

    /// Hands one sample to the recorder; a full ring drops it and counts it.
    ///
    /// # Bounded work
    /// Constant: one lock-free push, at most one relaxed atomic add; no allocation, no wait.
    pub fn push(&self, sample: ToolSample) {
        if self.queue.push(sample).is_err() {
            self.dropped.fetch_add(1, Ordering::Relaxed);
        }
    }

    /// Takes the oldest row (the recorder's side).
    pub fn pop(&self) -> Option<ToolSample> {
        self.queue.pop()
    }

    /// Rows dropped so far (the ring was full, or a pose was not finite).
    pub fn dropped(&self) -> u64 {
        self.dropped.load(Ordering::Relaxed)
    }
}

/// The header of a trace CSV (docs/DEVICES.md, "Traces").
pub const TRACE_HEADER: &str = "t,x,y,z,qw,qx,qy,qz,buttons";

/// The recorder task (`--record FILE`, normal priority): until `stop` is set and the ring is
/// empty, drains `ring` every 10 ms and writes each sample as a row of a trace CSV to `out`:
/// the servo tick's time (tick / 1000 s, written exactly), the tool pose the servo used (mesh
/// units, scene frame: what the simulation drilled) and the buttons. `replay --trace` reads the
/// file back. A sample whose pose is not finite is left out and counted with the ring's
/// dropped rows. Returns the rows written.
///
/// # Errors
/// The first write error (the task stops there; the servo goes on, its later rows are counted
/// as dropped when the ring fills).
pub fn recorder_task<W: std::io::Write>(
    ring: &RecordRing,
    out: W,
    stop: &AtomicBool,
) -> std::io::Result<u64> {
    use std::io::Write as _;
    let mut out = std::io::BufWriter::new(out);
    writeln!(out, "{TRACE_HEADER}")?;
    let mut rows = 0u64;
    loop {
        let stopping = stop.load(Ordering::Acquire);
        while let Some(s) = ring.pop() {
            let [x, y, z] = s.position.to_array();
            let [qx, qy, qz, qw] = s.rotation.to_array();
            if !(s.position.is_finite() && s.rotation.is_finite()) {
                ring.dropped.fetch_add(1, Ordering::Relaxed);
                continue;
            }
            writeln!(
                out,
                "{}.{:03},{x},{y},{z},{qw},{qx},{qy},{qz},{}",
                s.tick / 1000,
                s.tick % 1000,
                s.buttons
            )?;
            rows += 1;
        }
        if stopping {
            break;
        }
        out.flush()?;
        std::thread::sleep(std::time::Duration::from_millis(10));
    }
    out.flush()?;
    Ok(rows)
}
