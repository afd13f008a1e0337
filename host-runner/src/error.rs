//! Errors. The library's are typed ([`Error`]: what went wrong, and the one line that says
//! so); the command line turns any of them into a [`CliError`]: the line and an exit status
//! (2 for bad input: a file, a trace, a flag; 1 for a failure of the run itself).

use std::fmt;
use std::path::Path;

use tetradrill_core::servo::WorldError;
use tetradrill_core::storage::StorageError;

use crate::meshio::MeshError;
use crate::setup::SetupError;

/// Exit status for bad input (a mesh file, a trace, a device frame, a flag).
pub const EXIT_BAD_INPUT: i32 = 2;
/// Exit status for a failure of the run itself (a device lost, an I/O error on output).
pub const EXIT_FAILURE: i32 = 1;

/// What the library refuses or fails at.
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub enum Error {
    /// A value of the set-up out of range (its key named).
    Setup(SetupError),
    /// A mesh file that cannot be read or built.
    Mesh(MeshError),
    /// A trace or other input file, at a line when known.
    Input {
        /// One line: `FILE:LINE: reason`.
        message: String,
    },
    /// A combination of settings the session does not support (one line naming the flag).
    Unsupported(String),
    /// The mesh has more region labels than materials work on.
    TooManyRegions {
        /// Its distinct labels.
        labels: usize,
    },
    /// A mesh other than the one the storage was made for.
    MeshMismatch {
        /// The mesh's tets.
        tets: usize,
        /// The tets the storage holds.
        storage: usize,
    },
    /// The heap refused the storage, or the sizes overflow.
    Storage(StorageError),
    /// The core refused its storage.
    World(WorldError),
    /// A soft body the core refuses (a flat or inverted tet, a material out of range).
    Soft(String),
    /// A tet-mesh tool's scene that cannot be made from the meshes and sizes given.
    Rig(String),
    /// A failure of the run itself, not of its input.
    Failure(String),
}

impl Error {
    /// `true` when the input (a file, a flag, a combination of settings) is at fault, not the
    /// run: the command line's exit status 2.
    pub fn is_input(&self) -> bool {
        match self {
            Self::Setup(_)
            | Self::Input { .. }
            | Self::Unsupported(_)
            | Self::TooManyRegions { .. }
            | Self::Soft(_)
            | Self::Rig(_) => true,
            Self::Mesh(e) => e.is_input(),
            Self::MeshMismatch { .. } | Self::Storage(_) | Self::World(_) | Self::Failure(_) => {
                false
            }
        }
    }

    /// Bad input in a file, at a line when known: `FILE:LINE: reason`.
    pub fn at(path: &Path, line: Option<usize>, reason: impl fmt::Display) -> Self {
        let message = match line {
            Some(l) => format!("{}:{l}: {reason}", path.display()),
            None => format!("{}: {reason}", path.display()),
        };
        Self::Input { message }
    }
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Setup(e) => write!(f, "{e}"),
            Self::Mesh(e) => write!(f, "{e}"),
            Self::Input { message } | Self::Unsupported(message) => f.write_str(message),
            Self::TooManyRegions { labels } => write!(
                f,
                "the mesh has {labels} region labels; materials work on at most 256"
            ),
            Self::MeshMismatch { tets, storage } => write!(
                f,
                "cannot set up the simulation: a mesh of {tets} tets over storage for {storage}"
            ),
            Self::Storage(e) => write!(f, "cannot set up the simulation: {e}"),
            Self::World(e) => write!(f, "cannot set up the simulation: {e}"),
            Self::Soft(m) | Self::Rig(m) | Self::Failure(m) => f.write_str(m),
        }
    }
}

impl std::error::Error for Error {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            Self::Setup(e) => Some(e),
            Self::Mesh(e) => Some(e),
            Self::Storage(e) => Some(e),
            Self::World(e) => Some(e),
            _ => None,
        }
    }
}

impl From<SetupError> for Error {
    fn from(e: SetupError) -> Self {
        Self::Setup(e)
    }
}

impl From<MeshError> for Error {
    fn from(e: MeshError) -> Self {
        Self::Mesh(e)
    }
}

impl From<StorageError> for Error {
    fn from(e: StorageError) -> Self {
        Self::Storage(e)
    }
}

impl From<WorldError> for Error {
    fn from(e: WorldError) -> Self {
        Self::World(e)
    }
}

/// One line for the user and the exit status that goes with it: what the command line
/// makes of any error.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CliError {
    /// Exit status.
    pub code: i32,
    /// One line, naming the file and line where there is one, and the reason.
    pub message: String,
}

impl CliError {
    /// Bad input (exit 2).
    pub fn input(message: impl Into<String>) -> Self {
        Self {
            code: EXIT_BAD_INPUT,
            message: message.into(),
        }
    }

    /// Bad input in a file, at a line when known: `FILE:LINE: reason`.
    pub fn at(path: &Path, line: Option<usize>, reason: impl fmt::Display) -> Self {
        match line {
            Some(l) => Self::input(format!("{}:{l}: {reason}", path.display())),
            None => Self::input(format!("{}: {reason}", path.display())),
        }
    }

    /// A failure of the run (exit 1).
    pub fn failure(message: impl Into<String>) -> Self {
        Self {
            code: EXIT_FAILURE,
            message: message.into(),
        }
    }
}

impl fmt::Display for CliError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.message)
    }
}

impl std::error::Error for CliError {}

impl From<Error> for CliError {
    fn from(e: Error) -> Self {
        let code = if e.is_input() {
            EXIT_BAD_INPUT
        } else {
            EXIT_FAILURE
        };
        Self {
            code,
            message: e.to_string(),
        }
    }
}

impl From<MeshError> for CliError {
    fn from(e: MeshError) -> Self {
        Error::Mesh(e).into()
    }
}

impl From<SetupError> for CliError {
    fn from(e: SetupError) -> Self {
        Error::Setup(e).into()
    }
}
