//! Where a session's inputs come from: the mesh ([`MeshSpec`]), the tool's poses
//! ([`Poses`]) and a soft body's fixed nodes ([`FixBelow`]), each parsed once from its
//! command-line form.

use std::fmt;
use std::path::{Path, PathBuf};
use std::str::FromStr;

use super::{owned, shown, SetupError};
use crate::meshio::{self, LoadedMesh, MeshError, ReadOptions};

/// A mesh to load: a file in any format `tetradrill-meshio` reads, or a built-in name
/// (`builtin:cube12`, `builtin:block:N`).
#[derive(Debug, Clone, PartialEq)]
pub struct MeshSpec {
    /// The file, or the built-in name.
    pub path: PathBuf,
    /// Factor applied to its coordinates.
    pub scale: f64,
    /// The integer cell array of a VTK or VTU file that holds its region labels (`None`: the
    /// first of `tetradrill_meshio::REGION_ARRAYS` the file has).
    pub region_array: Option<String>,
}

impl MeshSpec {
    /// The mesh in `path` at its own scale.
    pub fn new(path: impl AsRef<Path>) -> Self {
        Self {
            path: owned(path),
            scale: 1.0,
            region_array: None,
        }
    }

    /// Reads the mesh and builds it (once: the caller keeps the [`LoadedMesh`]).
    ///
    /// # Errors
    /// A [`MeshError`] naming the file, the line or byte where there is one, and the reason.
    pub fn load(&self) -> Result<LoadedMesh, MeshError> {
        let options = ReadOptions {
            region_array: self.region_array.clone(),
            ..ReadOptions::default()
        };
        meshio::load_with(&self.path, self.scale, &options)
    }
}

impl fmt::Display for MeshSpec {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&shown(&self.path))
    }
}

/// Where the tool's poses come from, one per 1 ms tick.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Poses {
    /// The demo's scripted path (`builtin:demo`): over the block, in, across, out.
    Demo,
    /// The tooth's access cavity (`builtin:tooth-access`).
    ToothAccess,
    /// The real-size premolar's access cavity (`builtin:premolar-access`).
    PremolarAccess,
    /// A seeded random wander over the mesh's surface, drill on (`wander:SEED`).
    Wander {
        /// The seed.
        seed: u64,
    },
    /// A trace CSV file (`t,x,y,z,qw,qx,qy,qz,buttons`).
    Trace(PathBuf),
}

impl Poses {
    /// Parses the command-line form.
    ///
    /// # Errors
    /// An unknown built-in or a bad seed, in one line.
    pub fn parse(spec: &str) -> Result<Self, SetupError> {
        if let Some(name) = spec.strip_prefix("builtin:") {
            return match name {
                "demo" => Ok(Self::Demo),
                "tooth-access" => Ok(Self::ToothAccess),
                "premolar-access" => Ok(Self::PremolarAccess),
                _ => Err(SetupError::new(
                    "trace",
                    format!(
                        "unknown built-in trace `{spec}` (built-in: builtin:demo, \
                         builtin:tooth-access, builtin:premolar-access)"
                    ),
                )),
            };
        }
        if let Some(seed) = spec.strip_prefix("wander:") {
            return seed
                .parse::<u64>()
                .map(|seed| Self::Wander { seed })
                .map_err(|_| {
                    SetupError::new(
                        "trace",
                        format!("trace `{spec}`: expected wander:SEED with SEED a whole number"),
                    )
                });
        }
        Ok(Self::Trace(PathBuf::from(spec)))
    }
}

impl fmt::Display for Poses {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Demo => f.write_str("builtin:demo"),
            Self::ToothAccess => f.write_str("builtin:tooth-access"),
            Self::PremolarAccess => f.write_str("builtin:premolar-access"),
            Self::Wander { seed } => write!(f, "wander:{seed}"),
            Self::Trace(p) => f.write_str(&shown(p)),
        }
    }
}

impl FromStr for Poses {
    type Err = SetupError;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Self::parse(s)
    }
}

/// A soft body's fixed nodes: those whose rest coordinate on `axis` is at or below `value`
/// (`AXIS:VALUE`, e.g. `z:-0.45`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FixBelow {
    /// 0, 1, 2 for x, y, z.
    pub axis: usize,
    /// The coordinate, mesh units.
    pub value: f64,
}

impl FixBelow {
    /// Parses `AXIS:VALUE`.
    ///
    /// # Errors
    /// One line saying what is wrong.
    pub fn parse(s: &str) -> Result<Self, String> {
        let bad = |why: &str| format!("fix_below `{s}`: {why}");
        let Some((axis, value)) = s.split_once(':') else {
            return Err(bad("expected AXIS:VALUE, for example z:-0.45"));
        };
        let axis = match axis.trim() {
            "x" | "X" => 0,
            "y" | "Y" => 1,
            "z" | "Z" => 2,
            _ => return Err(bad("the axis must be x, y or z")),
        };
        match value.trim().parse::<f64>() {
            Ok(value) if value.is_finite() => Ok(Self { axis, value }),
            _ => Err(bad("the value must be a finite number")),
        }
    }
}

impl fmt::Display for FixBelow {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let axis = ["x", "y", "z"].get(self.axis).copied().unwrap_or("?");
        write!(f, "{axis}:{}", self.value)
    }
}
