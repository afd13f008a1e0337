//! Helpers shared by the fuzz targets (docs/FUZZING.md): a scratch directory for the readers
//! that take a path, and the checks every mesh file must pass whatever it holds.

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use tetradrill::meshio::{self, MeshError};

/// A file in this process's scratch directory: `$TETRADRILL_FUZZ_SCRATCH` when set (the
/// script sets it and removes it afterwards), else a directory under the system temp dir.
pub fn scratch(name: &str) -> PathBuf {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    let dir = DIR.get_or_init(|| {
        let base = std::env::var_os("TETRADRILL_FUZZ_SCRATCH")
            .map(PathBuf::from)
            .unwrap_or_else(std::env::temp_dir);
        let d = base.join(format!("tetradrill-fuzz-{}", std::process::id()));
        std::fs::create_dir_all(&d).expect("cannot create the fuzz scratch directory");
        d
    });
    dir.join(name)
}

/// Writes `bytes` to a scratch file called `name` and returns its path.
pub fn write_scratch(name: &str, bytes: &[u8]) -> PathBuf {
    let p = scratch(name);
    std::fs::write(&p, bytes).expect("cannot write a fuzz scratch file");
    p
}

/// The scratch names of the `mesh_gz` target, picked by its input's first byte.
pub const GZ_NAMES: [&str; 5] = [
    "input.mesh.gz",
    "input.msh.gz",
    "input.vtk.gz",
    "input.vtu.gz",
    "input.meshb.gz",
];

/// The error contract of the command line: bad input is exit status 2 and one non-empty line.
pub fn check_line(code: i32, message: &str) {
    assert_eq!(code, 2, "bad input must exit 2: {message}");
    assert!(!message.is_empty(), "empty error message");
    assert!(
        !message.contains(['\n', '\r']),
        "error message is not one line: {message:?}"
    );
}

/// [`check_line`] for a mesh reader's error: bad input, not an internal failure.
pub fn check_error(e: &MeshError) {
    let code = if e.is_input() { 2 } else { 1 };
    check_line(code, &e.message);
}

/// Reads and loads a mesh file: neither may panic; a refusal is a one-line exit-2 error; a
/// file `load` accepts must also be accepted by `read`, and the mesh it builds must pass the
/// core's `validate()`.
pub fn check_mesh_file(path: &Path) {
    let read = meshio::read(path);
    match &read {
        Ok(raw) => {
            assert_eq!(raw.tets.len(), raw.tet_lines.len(), "one line per tet");
            assert_eq!(raw.tets.len(), raw.labels.len(), "one label per tet");
            assert!(
                raw.positions.iter().flatten().all(|c| c.is_finite()),
                "non-finite node"
            );
        }
        Err(e) => check_error(e),
    }
    match meshio::load(path, 1.0) {
        Ok(mut loaded) => {
            let raw = read.as_ref().expect("load accepted a file read refused");
            assert_eq!(
                loaded.mesh.tets().len(),
                raw.tets.len(),
                "tets lost in load"
            );
            assert_eq!(
                loaded.mesh.positions().len() + loaded.dropped_nodes,
                raw.positions.len(),
                "nodes lost in load"
            );
            if let Err(e) = loaded.mesh.view().validate() {
                panic!("a loaded mesh fails validate(): {e}");
            }
        }
        Err(e) => check_error(&e),
    }
}

/// Reads a fuzz input front to back for the targets that script a device session.
#[derive(Debug)]
pub struct Input<'a> {
    data: &'a [u8],
    pos: usize,
}

impl<'a> Input<'a> {
    /// A reader over `data`.
    pub fn new(data: &'a [u8]) -> Input<'a> {
        Input { data, pos: 0 }
    }

    /// Whether every byte has been read.
    pub fn is_empty(&self) -> bool {
        self.pos >= self.data.len()
    }

    /// The next byte, `None` at the end.
    pub fn byte(&mut self) -> Option<u8> {
        let b = self.data.get(self.pos).copied();
        self.pos += 1;
        b
    }

    /// Fills `out` from the input (zeros past the end).
    pub fn fill(&mut self, out: &mut [u8]) {
        for slot in out {
            *slot = self.byte().unwrap_or(0);
        }
    }

    /// A force component, N: mostly small values, sometimes huge, NaN or infinite.
    pub fn force(&mut self) -> f64 {
        match self.byte().unwrap_or(0) {
            0xFF => f64::NAN,
            0xFE => f64::INFINITY,
            0xFD => f64::NEG_INFINITY,
            0xFC => 1e300,
            b => (f64::from(b) - 126.0) / 8.0,
        }
    }
}
