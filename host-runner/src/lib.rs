//! tetradrill host runner: reads mesh files, runs the servo and simulation tasks, serves the
//! command line. The core (`tetradrill-core`) never sees a file, a thread or a clock; this crate
//! does all of that around it. The devices, their codecs and their OS transports (FireWire
//! cdev, the HD library loader) are `tetradrill-device`'s; `commands::run` builds the device
//! factories from them.
//!
//! | module            | what                                                                 |
//! |-------------------|----------------------------------------------------------------------|
//! | [`cli`]           | the command line: `demo`, `run`, `replay`, `info`, `timing`, `devices`, `export` |
//! | [`commands`]      | one file per command, and the real-time pipeline `run` and `demo` share |
//! | [`device_config`] | `--device-config FILE`: the device constants from TOML               |
//! | [`engine`]        | storage for a scenario's core world, allocated once, and the per-tick step |
//! | [`error`]         | one-line errors with exit status 2 for bad input, 1 for a failed run  |
//! | [`meshio`]        | mesh files: the `tetradrill-meshio` crate, re-exported               |
//! | [`owned`]         | host-owned storage for one core mesh (from `tetradrill-meshio`)      |
//! | [`pen`]           | a tet-mesh tool (the pen) against an object: its storage and scene   |
//! | [`pen_pair`]      | the pen's contact pass on two threads (`--pass-threads 2`)           |
//! | [`pen_tasks`]     | the pen in the real-time run: the contact task and the servo's law   |
//! | [`platform`]      | clock, absolute sleeps, SCHED_FIFO, mlockall, pinning, signals (`unsafe`, libc) |
//! | [`report`]        | the JSON reports the commands write                                  |
//! | [`rt`]            | servo thread set-up and the absolute-deadline period                 |
//! | [`scenario`]      | what a run needs (mesh, tool, trace, forces, capacities): defaults, file, flags |
//! | [`soft`]          | host-owned storage for one soft body (`tetradrill_core::soft`)       |
//! | [`stats`]         | percentiles and histograms of timing samples                         |
//! | [`tasks`]         | the task table (`TASKS`) and the tasks of a real-time run            |
//! | [`traces`]        | where a run's tool poses come from: trace file, scripted path, wander |
//! | [`viewer`]        | the live 3D view and headless screenshots (feature `viewer`)         |
//! | [`watchdog`]      | the servo's supervisor (stalls) and its panic guard                  |
//! | [`workload`]      | the per-tick work `timing` measures                                  |

#![deny(unsafe_code)]

// Output that never panics. `println!` panics when stdout is gone (`tetradrill replay | head
// -1` closes the pipe): that would lose the run's JSON and, mid-run, its orderly stop. These
// drop the line instead; the run goes on.

/// `println!` to stdout, a failed write dropped.
macro_rules! outln {
    ($($t:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stdout(), $($t)*);
    }};
}

/// `print!` to stdout, a failed write dropped.
macro_rules! out {
    ($($t:tt)*) => {{
        use std::io::Write as _;
        let _ = write!(std::io::stdout(), $($t)*);
    }};
}

/// `eprintln!` to stderr, a failed write dropped.
macro_rules! errln {
    ($($t:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stderr(), $($t)*);
    }};
}

/// `eprint!` to stderr, a failed write dropped.
macro_rules! err {
    ($($t:tt)*) => {{
        use std::io::Write as _;
        let _ = write!(std::io::stderr(), $($t)*);
    }};
}

pub mod cli;
pub mod commands;
pub mod device_config;
pub mod engine;
pub mod error;
pub mod pen;
pub mod pen_pair;
pub mod pen_tasks;
pub mod platform;
pub mod report;
pub mod rt;
pub mod scenario;
pub mod soft;
pub mod stats;
pub mod tasks;
pub mod traces;
pub mod viewer;
pub mod watchdog;
pub mod workload;

pub use tetradrill_meshio as meshio;
pub use tetradrill_meshio::owned;
