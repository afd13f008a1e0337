//! tetradrill host runner: reads mesh files, runs the servo and simulation tasks, serves the
//! command line. The core (`tetradrill-core`) never sees a file, a thread or a clock; this crate
//! does all of that around it.
//!
//! | module      | what                                                        |
//! |-------------|-------------------------------------------------------------|
//! | [`cli`]     | the command line: `demo`, `run`, `replay`, `info`, `timing` |
//! | [`error`]   | one-line errors with exit status 2 for bad input            |
//! | [`hdapi`]   | the Touch through the vendor HD library, loaded at run time (`unsafe`, FFI) |
//! | [`meshio`]  | mesh file readers (TetGen, MEDIT, Gmsh, VTK)                |
//! | [`owned`]   | host-owned storage for one core mesh                        |
//! | [`platform`]| clock, absolute sleeps, SCHED_FIFO, mlockall, pinning (`unsafe`, libc)       |
//! | [`rt`]      | servo thread set-up and the absolute-deadline period        |
//! | [`stats`]   | percentiles and histograms of timing samples                |
//! | [`workload`]| the per-tick work of the built-in scenario                  |
//! | [`viewer`]  | the live 3D view and headless screenshots (feature `viewer`) |
//! | [`watchdog`]| the servo's supervisor (stalls) and its panic guard          |

#![deny(unsafe_code)]

pub mod cli;
pub mod commands;
pub mod engine;
pub mod error;
pub mod firewire;
pub mod hdapi;
pub mod meshio;
pub mod owned;
pub mod pen;
pub mod pen_tasks;
pub mod platform;
pub mod rt;
pub mod scenario;
pub mod stats;
pub mod tasks;
pub mod traces;
pub mod viewer;
pub mod watchdog;
pub mod workload;
