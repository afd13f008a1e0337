//! The work one servo tick runs in `timing` and the real-time runs: the built-in demo scenario
//! (generated block, spherical burr, scripted drilling path) stepped tick by tick.

use crate::error::CliError;

/// A scenario stepped one servo tick at a time.
#[derive(Debug)]
pub struct Workload {
    _private: (),
}

impl Workload {
    /// The built-in demo scenario.
    pub fn demo() -> Result<Self, CliError> {
        Err(CliError::failure("the servo step is not wired yet; use --idle"))
    }

    /// One line naming the scenario.
    pub fn describe(&self) -> String {
        "demo".into()
    }

    /// Runs one servo tick.
    pub fn tick(&mut self) {}
}
