//! tetradrill host runner: reads mesh files, runs the servo and simulation tasks, serves the
//! command line. The core (`tetradrill-core`) never sees a file, a thread or a clock; this crate
//! does all of that around it.
//!
//! | module      | what                                                        |
//! |-------------|-------------------------------------------------------------|
//! | [`cli`]     | the command line: `demo`, `run`, `replay`, `info`, `timing` |
//! | [`error`]   | one-line errors with exit status 2 for bad input            |
//! | [`meshio`]  | mesh file readers (TetGen, MEDIT, Gmsh, VTK)                |
//! | [`owned`]   | host-owned storage for one core mesh                        |

pub mod cli;
pub mod commands;
pub mod error;
pub mod meshio;
pub mod owned;
