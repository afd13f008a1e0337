//! tetradrill: touch and drill tetrahedral meshes with a haptic device, in real time.
//!
//! This crate is the host side of tetradrill: mesh files, the typed set-up of a session, the
//! 1 kHz servo and its tasks, the viewer and the `tetradrill` command line. The computing
//! happens in `tetradrill-core` (`no_std`, allocation-free), which never sees a file, a
//! thread or a clock; the devices are `tetradrill-device`'s.
//!
//! Drill the built-in block with a burr and see what came out:
//!
//! ```
//! use tetradrill::prelude::*;
//!
//! let setup = Setup::new("builtin:block:4", Tool::sphere(0.1));
//! let mut drilling = Drilling::new(&setup)?;
//! let mut run = drilling.start()?;
//! for i in 0..300 {
//!     // In through the top face, 0.25 deep, the drill on.
//!     let depth = 0.25 * i as f32 / 300.0;
//!     run.tick(&Pose::drilling(Vec3::new(0.0, 0.0, 0.55 - depth)));
//! }
//! for (label, volume) in run.removed_by_region() {
//!     println!("region {label}: {volume:.5} removed");
//! }
//! assert!(run.removed_volume() > 0.0 && run.surface().triangles() > 0);
//! # Ok::<(), tetradrill::Error>(())
//! ```
//!
//! The same set-up drives a touch with a tet-mesh tool ([`pen`]), a soft body ([`soft`]),
//! and the real-time servo with a device of one's own ([`servo`]); `examples/` in the
//! repository has a program for each.
//!
//! | module            | what                                                                 |
//! |-------------------|----------------------------------------------------------------------|
//! | [`audio`]         | the burr's sound: a whine falling under load, its timbre by material, WAV and live |
//! | [`cli`]           | the command line: `demo`, `run`, `replay`, `info`, `timing`, `devices`, `export` |
//! | [`commands`]      | one file per command, and the real-time pipeline `run` and `demo` share |
//! | [`device_config`] | `--device-config FILE`: the device constants from TOML               |
//! | [`engine`]        | storage for a scenario's core world, allocated once, and the per-tick step |
//! | [`error`]         | the library's typed [`Error`], and the command line's one line and exit status |
//! | [`meshio`]        | mesh files: the `tetradrill-meshio` crate, re-exported               |
//! | [`motors`]        | the motor-sign self-test (`devices --check --motors`), a device whose force is blocked |
//! | [`owned`]         | host-owned storage for one core mesh (from `tetradrill-meshio`)      |
//! | [`pen`]           | a tet-mesh tool (the pen) against an object: its storage and scene   |
//! | [`pen_pair`]      | the pen's contact pass on two threads (`--pass-threads 2`)           |
//! | [`pen_tasks`]     | the pen in the real-time run: the contact task and the servo's law   |
//! | [`prelude`]         | what a program using tetradrill needs most, in one `use`             |
//! | [`platform`]      | clock, absolute sleeps, SCHED_FIFO, mlockall, pinning, signals (`unsafe`, libc) |
//! | [`report`]        | the JSON reports the commands write                                  |
//! | [`rt`]            | servo thread set-up and the absolute-deadline period                 |
//! | [`servo`]         | the 1 kHz servo with a device of one's own, for a program             |
//! | [`session`]       | the front door for drilling: `Drilling`, `DrillRun`, `Surface`       |
//! | [`smooth_surface`] | the drilled surface with shared vertices and smooth normals (`replay --surface`) |
//! | [`scenario`]      | the set-up as flags and scenario files write it: file, built-ins, flags |
//! | [`setup`]         | the typed set-up (mesh, tool, poses, forces, materials, sizes, body), checked once |
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

pub mod audio;
pub mod cli;
pub mod commands;
pub mod device_config;
pub mod engine;
pub mod error;
pub mod motors;
pub mod pen;
pub mod pen_pair;
pub mod pen_tasks;
pub mod platform;
pub mod report;
pub mod rt;
pub mod scenario;
pub mod servo;
pub mod session;
pub mod setup;
pub mod smooth_surface;
pub mod soft;
pub mod stats;
pub mod tasks;
pub mod traces;
pub mod viewer;
pub mod watchdog;
pub mod workload;

pub use error::Error;
pub use session::{DrillRun, Drilling, Surface};
pub use setup::{MeshSpec, Poses, Setup, Tool};
pub use tetradrill_meshio as meshio;
pub use tetradrill_meshio::owned;
pub use traces::Pose;

/// What a program using tetradrill needs most, in one `use`.
pub mod prelude {
    pub use crate::error::Error;
    pub use crate::session::{DrillRun, Drilling, Surface};
    pub use crate::setup::{Body, MeshSpec, Poses, Setup, SoftSettings, Tool};
    pub use crate::traces::{Pose, PoseSource};
    pub use tetradrill_core::{Quat, Vec3};
}
