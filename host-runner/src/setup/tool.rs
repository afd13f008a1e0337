//! [`Tool`]: the burr, the drill on its shaft or the tet-mesh tool, parsed once from its
//! command-line form (`sphere:R`, `drill:BURR_R:SHAFT_LEN:SHAFT_R`, `mesh:FILE`).

use std::fmt;
use std::path::{Path, PathBuf};
use std::str::FromStr;

use super::{owned, shown, SetupError};

/// The tool, in mesh units.
#[derive(Debug, Clone, PartialEq)]
pub enum Tool {
    /// A spherical burr.
    Sphere {
        /// Its radius.
        radius: f64,
    },
    /// A burr on a shaft from its centre along the tool's axis (+z rotated by the pose),
    /// whose passive points collide but never erode.
    Drill {
        /// The burr's radius.
        burr: f64,
        /// The shaft's length, from the burr's centre to the handle.
        shaft_length: f64,
        /// The shaft's radius (at most the burr's).
        shaft_radius: f64,
    },
    /// A tet-mesh tool (the pen): tip at its origin, axis +z.
    Mesh {
        /// Its mesh file.
        path: PathBuf,
        /// Factor applied to its coordinates.
        scale: f64,
    },
}

impl Tool {
    /// A spherical burr of `radius`.
    pub fn sphere(radius: f64) -> Self {
        Self::Sphere { radius }
    }

    /// A burr of `burr` radius on a shaft of `shaft_length` and `shaft_radius`.
    pub fn drill(burr: f64, shaft_length: f64, shaft_radius: f64) -> Self {
        Self::Drill {
            burr,
            shaft_length,
            shaft_radius,
        }
    }

    /// The tet-mesh tool in `path`, at its own scale.
    pub fn mesh(path: impl AsRef<Path>) -> Self {
        Self::Mesh {
            path: owned(path),
            scale: 1.0,
        }
    }

    /// The burr's radius (`None` for a mesh tool).
    pub fn burr_radius(&self) -> Option<f64> {
        match self {
            Self::Sphere { radius } => Some(*radius),
            Self::Drill { burr, .. } => Some(*burr),
            Self::Mesh { .. } => None,
        }
    }

    /// The factor applied to a mesh tool's coordinates (1 for a burr).
    pub fn scale(&self) -> f64 {
        match self {
            Self::Mesh { scale, .. } => *scale,
            _ => 1.0,
        }
    }

    /// `true` for a tet-mesh tool.
    pub fn is_mesh(&self) -> bool {
        matches!(self, Self::Mesh { .. })
    }

    /// Parses the command-line form, a mesh tool at `scale`.
    ///
    /// # Errors
    /// One line naming the form and what is wrong with it.
    pub fn parse(spec: &str, scale: f64) -> Result<Self, SetupError> {
        let bad = |why: &str| Err(SetupError::new("tool", format!("tool `{spec}`: {why}")));
        let t = if let Some(r) = spec.strip_prefix("sphere:") {
            match r.parse::<f64>() {
                Ok(radius) => Self::Sphere { radius },
                Err(_) => return bad("the radius must be a positive number"),
            }
        } else if let Some(rest) = spec.strip_prefix("drill:") {
            let v: Vec<Option<f64>> = rest.split(':').map(|x| x.parse::<f64>().ok()).collect();
            let [Some(burr), Some(len), Some(shaft)] = v[..] else {
                return bad("expected drill:BURR_R:SHAFT_LEN:SHAFT_R (three numbers)");
            };
            Self::drill(burr, len, shaft)
        } else if let Some(file) = spec.strip_prefix("mesh:") {
            if file.is_empty() {
                return bad("needs a file");
            }
            Self::Mesh {
                path: PathBuf::from(file),
                scale,
            }
        } else {
            return bad("expected sphere:R or mesh:FILE, or drill:BURR_R:SHAFT_LEN:SHAFT_R");
        };
        t.check()?;
        Ok(t)
    }

    /// The first value out of range.
    ///
    /// # Errors
    /// One line naming the tool and what is wrong.
    pub fn check(&self) -> Result<(), SetupError> {
        let bad = |why: &str| Err(SetupError::new("tool", format!("tool `{self}`: {why}")));
        match *self {
            Self::Sphere { radius } => {
                if !(radius.is_finite() && radius > 0.0) {
                    return bad("the radius must be a positive number");
                }
            }
            Self::Drill {
                burr,
                shaft_length,
                shaft_radius,
            } => {
                if ![burr, shaft_length, shaft_radius]
                    .iter()
                    .all(|x| x.is_finite() && *x > 0.0)
                {
                    return bad("the radii and the length must be positive numbers");
                }
                if shaft_radius > burr {
                    return bad("the shaft's radius must be at most the burr's radius");
                }
                if shaft_length <= burr {
                    return bad("the shaft must be longer than the burr's radius");
                }
            }
            Self::Mesh { scale, .. } => {
                if !(scale.is_finite() && scale > 0.0) {
                    return Err(SetupError::new(
                        "tool_scale",
                        format!("tool_scale must be a positive number, got {scale}"),
                    ));
                }
            }
        }
        Ok(())
    }
}

impl fmt::Display for Tool {
    /// The command-line form (a mesh tool's scale is its own flag, `--tool-scale`).
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Sphere { radius } => write!(f, "sphere:{radius}"),
            Self::Drill {
                burr,
                shaft_length,
                shaft_radius,
            } => write!(f, "drill:{burr}:{shaft_length}:{shaft_radius}"),
            Self::Mesh { path, .. } => write!(f, "mesh:{}", shown(path)),
        }
    }
}

impl FromStr for Tool {
    type Err = SetupError;

    /// [`Tool::parse`] at scale 1.
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Self::parse(s, 1.0)
    }
}
