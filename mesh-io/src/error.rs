//! The readers' one error type: what went wrong (the input, or the reader itself) and a single
//! line for the user naming the file and the line (or byte offset) where there is one. Exit
//! statuses belong to a command line, not here: `tetradrill` gives bad input status 2.

use std::fmt;
use std::path::Path;

/// Whose fault a [`MeshError`] is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum MeshErrorKind {
    /// The input: a file that cannot be read as what it says it is, a missing file, a bad
    /// option for it.
    Input,
    /// The reader: an internal error, not the input's fault.
    Internal,
}

/// Where in its file a [`MeshError`] is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum Location {
    /// A line of a text file, from 1.
    Line(usize),
    /// A byte offset into a binary file, from 0.
    Byte(u64),
}

/// A mesh that could not be read or built.
#[derive(Debug, Clone, PartialEq, Eq)]
#[non_exhaustive]
pub struct MeshError {
    /// Whose fault it is.
    pub kind: MeshErrorKind,
    /// One line, naming the file and line (or byte offset) where there is one, and the reason.
    pub message: String,
    /// The line or byte the message names, where there is one.
    pub location: Option<Location>,
}

impl MeshError {
    /// Bad input.
    pub fn input(message: impl Into<String>) -> Self {
        Self {
            kind: MeshErrorKind::Input,
            message: message.into(),
            location: None,
        }
    }

    /// Bad input in a file, at a line when known: `FILE:LINE: reason`.
    pub fn at(path: &Path, line: Option<usize>, reason: impl fmt::Display) -> Self {
        match line {
            Some(l) => Self {
                location: Some(Location::Line(l)),
                ..Self::input(format!("{}:{l}: {reason}", path.display()))
            },
            None => Self::input(format!("{}: {reason}", path.display())),
        }
    }

    /// Bad input in a binary file, at a byte offset: `FILE: byte N: reason`.
    pub fn at_byte(path: &Path, offset: u64, reason: impl fmt::Display) -> Self {
        Self {
            location: Some(Location::Byte(offset)),
            ..Self::input(format!("{}: byte {offset}: {reason}", path.display()))
        }
    }

    /// A failure that is not the input's fault.
    pub fn failure(message: impl Into<String>) -> Self {
        Self {
            kind: MeshErrorKind::Internal,
            message: message.into(),
            location: None,
        }
    }

    /// `true` when the input is at fault.
    pub fn is_input(&self) -> bool {
        self.kind == MeshErrorKind::Input
    }
}

impl fmt::Display for MeshError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.message)
    }
}

impl std::error::Error for MeshError {}
