//! The exceptions: `TetradrillError` for what the library refuses or fails at, `InputError`
//! (a subclass) for bad input (a file, a value out of range, a combination of settings), each
//! with the library's one line (`FILE:LINE: reason` where there is a file).

use pyo3::create_exception;
use pyo3::exceptions::PyException;
use pyo3::PyErr;

create_exception!(
    tetradrill,
    TetradrillError,
    PyException,
    "What the tetradrill library refuses or fails at, with its one-line message."
);
create_exception!(
    tetradrill,
    InputError,
    TetradrillError,
    "Bad input: a mesh or trace file (the message names the file and line), a scenario, a \
     value out of range, settings that do not go together."
);

/// A library error as an exception: [`InputError`] for bad input, else [`TetradrillError`].
pub fn of(e: tetradrill::Error) -> PyErr {
    if e.is_input() {
        InputError::new_err(e.to_string())
    } else {
        TetradrillError::new_err(e.to_string())
    }
}

/// Bad input, in one line.
pub fn input(message: impl Into<String>) -> PyErr {
    InputError::new_err(message.into())
}

/// A command-line error (a scenario file's) as an exception: exit status 2 is bad input.
pub fn cli(e: tetradrill::error::CliError) -> PyErr {
    if e.code == tetradrill::error::EXIT_BAD_INPUT {
        InputError::new_err(e.message)
    } else {
        TetradrillError::new_err(e.message)
    }
}

/// A set-up value out of range.
pub fn setup(e: tetradrill::setup::SetupError) -> PyErr {
    of(tetradrill::Error::Setup(e))
}

/// A mesh file that cannot be read or built.
pub fn mesh(e: tetradrill::meshio::MeshError) -> PyErr {
    of(tetradrill::Error::Mesh(e))
}
