//! The readers' one error type: a single line for the user, naming the file and the line (or
//! byte offset) where there is one, and the exit status a command line should give it.

use std::fmt;
use std::path::Path;

/// Exit status for bad input (a mesh file that cannot be read as what it says it is).
pub const EXIT_BAD_INPUT: i32 = 2;
/// Exit status for a failure that is not the input's fault (an internal error).
pub const EXIT_FAILURE: i32 = 1;

/// One line for the user and the exit status that goes with it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct MeshError {
    /// Exit status: [`EXIT_BAD_INPUT`] for bad input, [`EXIT_FAILURE`] otherwise.
    pub code: i32,
    /// One line, naming the file and line where there is one, and the reason.
    pub message: String,
}

impl MeshError {
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

    /// Bad input in a binary file, at a byte offset: `FILE: byte N: reason`.
    pub fn at_byte(path: &Path, offset: u64, reason: impl fmt::Display) -> Self {
        Self::input(format!("{}: byte {offset}: {reason}", path.display()))
    }

    /// A failure that is not the input's fault (exit 1).
    pub fn failure(message: impl Into<String>) -> Self {
        Self {
            code: EXIT_FAILURE,
            message: message.into(),
        }
    }
}

impl fmt::Display for MeshError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.message)
    }
}

impl std::error::Error for MeshError {}
