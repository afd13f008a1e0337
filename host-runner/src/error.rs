//! The command line's one error type: a single line for the user and an exit status
//! (2 for bad input: a file, a trace, a flag; 1 for a failure of the run itself).

use std::fmt;
use std::path::Path;

/// Exit status for bad input (a mesh file, a trace, a device frame, a flag).
pub const EXIT_BAD_INPUT: i32 = tetradrill_meshio::EXIT_BAD_INPUT;
/// Exit status for a failure of the run itself (a device lost, an I/O error on output).
pub const EXIT_FAILURE: i32 = tetradrill_meshio::EXIT_FAILURE;

/// One line for the user and the exit status that goes with it.
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

impl From<tetradrill_meshio::MeshError> for CliError {
    fn from(e: tetradrill_meshio::MeshError) -> Self {
        Self {
            code: e.code,
            message: e.message,
        }
    }
}
