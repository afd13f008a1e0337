//! Ctrl-C in a long call: the loops that tick or step with the GIL released look at Python's
//! signals every [`EVERY`], so a `KeyboardInterrupt` (or the exception of the caller's own
//! signal handler) ends the call between two ticks or steps, the work done so far kept by the
//! object (`Drilling.ticks`, `SoftBody.steps`).

use std::time::{Duration, Instant};

use pyo3::prelude::*;

/// How often a long call looks at Python's signals: a user's Ctrl-C takes effect within this
/// and one tick or step.
pub const EVERY: Duration = Duration::from_millis(50);

/// The signal check of one long call.
#[derive(Debug)]
pub struct Signals {
    next: Instant,
}

impl Signals {
    /// A check whose first look is [`EVERY`] from now.
    pub fn new() -> Self {
        Self {
            next: Instant::now() + EVERY,
        }
    }

    /// `Ok` unless a signal arrived and its Python handler raised (Ctrl-C's default handler
    /// raises `KeyboardInterrupt`): then that exception. Takes the GIL only when [`EVERY`]
    /// has passed since the last look; otherwise one clock read.
    pub fn check(&mut self) -> PyResult<()> {
        let now = Instant::now();
        if now < self.next {
            return Ok(());
        }
        self.next = now + EVERY;
        Python::attach(|py| py.check_signals())
    }
}

impl Default for Signals {
    fn default() -> Self {
        Self::new()
    }
}
