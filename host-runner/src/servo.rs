//! The 1 kHz servo with a device of the program's own: the real-time pipeline of `tetradrill
//! run` (the servo on absolute deadlines, the simulation beside it, the passivity observer and
//! the watchdog) driving any [`HapticDevice`], for as long as the program says.
//!
//! ```no_run
//! use tetradrill::prelude::*;
//! use tetradrill::servo::{self, ServoOptions};
//! use tetradrill_device::{SimConfig, SimDevice, Still};
//!
//! // A device that holds its stylus 0.05 below the block's top face (a stand-in for one's own).
//! let device = SimDevice::new(Still([0.0, 0.0, 0.45]), SimConfig::default());
//! let report = servo::run(&Setup::default(), device, ServoOptions::for_ms(1000))?;
//! assert_eq!(report.ticks, 1000);
//! # Ok::<(), tetradrill::Error>(())
//! ```

use tetradrill_device::{DeviceKind, HapticDevice};

use crate::commands::pipeline::{self, DeviceFactory, PipelineSetup, RunReport};
use crate::error::{Error, EXIT_BAD_INPUT};
use crate::rt::RtConfig;
use crate::setup::Setup;
use crate::tasks::Workspace;

/// How a servo run goes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ServoOptions {
    /// Servo ticks (1 ms each) to run.
    pub ticks: u64,
    /// Ask for SCHED_FIFO, core pinning and locked memory (each one that is refused is one
    /// warning line; the run goes on without it).
    pub realtime: bool,
    /// Where the device's positions land in the mesh (default: the device moves in mesh
    /// units, origin at the mesh's origin).
    pub workspace: Workspace,
}

impl ServoOptions {
    /// `ms` ticks, no real-time requests, the device in mesh units.
    pub fn for_ms(ms: u64) -> Self {
        Self {
            ticks: ms,
            realtime: false,
            workspace: pipeline::MESH_UNITS,
        }
    }
}

/// Runs the servo at 1 kHz with `device` over `setup` (its mesh read here) for
/// `options.ticks` ticks; returns the run's report (forces, deadlines, removed volume).
///
/// # Errors
/// What the set-up refuses, the device's error that ended the run ([`Error::Input`] when it
/// could not start, [`Error::Failure`] when it failed mid-run).
pub fn run<D: HapticDevice + Send + 'static>(
    setup: &Setup,
    device: D,
    options: ServoOptions,
) -> Result<RunReport, Error> {
    run_with(
        setup,
        Box::new(move || Ok(Box::new(device) as Box<_>)),
        options,
    )
}

/// [`run`] with a factory that opens the device on the servo thread (for a device whose
/// handle must not move between threads).
///
/// # Errors
/// As [`run`].
pub fn run_with(
    setup: &Setup,
    open: DeviceFactory,
    options: ServoOptions,
) -> Result<RunReport, Error> {
    let loaded = crate::engine::load_mesh(setup)?;
    let mut p = PipelineSetup::plain(DeviceKind::Custom, open, options.ticks.max(1));
    p.workspace = options.workspace;
    if options.realtime {
        p.rt = RtConfig::default();
    }
    pipeline::run(setup, loaded, p, None).map_err(|e| {
        if e.code == EXIT_BAD_INPUT {
            Error::Input { message: e.message }
        } else {
            Error::Failure(e.message)
        }
    })
}
