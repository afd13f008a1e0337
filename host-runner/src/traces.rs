//! Where a run's tool poses come from: a trace CSV file, or a built-in scripted path computed
//! by the core (bit-identical to what the firmware computes).

use std::path::Path;

use tetradrill_core::script::{Script, DEMO};
use tetradrill_core::Vec3;
use tetradrill_device::Trace;

use crate::error::CliError;

/// Servo period of replays and scripted paths, seconds.
pub const PERIOD_S: f64 = 1e-3;

/// One tool pose for one servo tick.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pose {
    /// Tool position (sphere centre or tool tip), mesh units.
    pub position: Vec3,
    /// Tool rotation as a unit quaternion `[w, x, y, z]`.
    pub rotation: [f32; 4],
    /// Button mask (bit 0 = drill on).
    pub buttons: u32,
}

/// A source of poses, one per tick.
#[derive(Debug, Clone)]
pub enum PoseSource {
    /// A scripted path from the core.
    Script(Script<'static>),
    /// A recorded trace, sampled at each tick's time (positions scaled into mesh units).
    Trace {
        /// The trace.
        trace: Trace,
        /// Mesh units per trace unit.
        scale: f64,
    },
}

impl PoseSource {
    /// `builtin:demo` or a trace CSV file (bad traces exit 2 naming the file and line).
    pub fn load(spec: &str, scale: f64) -> Result<Self, CliError> {
        if let Some(name) = spec.strip_prefix("builtin:") {
            return match name {
                "demo" => Ok(Self::Script(DEMO)),
                _ => Err(CliError::input(format!(
                    "unknown built-in trace `{spec}` (built-in: builtin:demo)"
                ))),
            };
        }
        let path = Path::new(spec);
        let bytes = std::fs::read(path)
            .map_err(|e| CliError::at(path, None, format!("cannot read trace: {e}")))?;
        let text = String::from_utf8(bytes)
            .map_err(|_| CliError::at(path, None, "not a text file (binary trace?)"))?;
        let trace =
            Trace::parse(&text, spec).map_err(|e| CliError::at(path, Some(e.line), e.kind))?;
        Ok(Self::Trace { trace, scale })
    }

    /// Number of ticks the source lasts at 1 kHz.
    pub fn ticks(&self) -> u64 {
        match self {
            Self::Script(s) => s.ticks() as u64,
            Self::Trace { trace, .. } => match trace.time_span() {
                Some((t0, t1)) => ((t1 - t0) / PERIOD_S).floor() as u64 + 1,
                None => 0,
            },
        }
    }

    /// The pose at tick `i` (held at the ends).
    pub fn at(&self, i: u64) -> Pose {
        match self {
            Self::Script(s) => {
                let (position, buttons) = s.at(i.min(u32::MAX as u64) as u32);
                Pose {
                    position,
                    rotation: [1.0, 0.0, 0.0, 0.0],
                    buttons,
                }
            }
            Self::Trace { trace, scale } => {
                let t0 = trace.time_span().map_or(0.0, |(a, _)| a);
                match trace.sample_at(t0 + i as f64 * PERIOD_S) {
                    Some(s) => Pose {
                        position: Vec3::new(
                            (s.position[0] * scale) as f32,
                            (s.position[1] * scale) as f32,
                            (s.position[2] * scale) as f32,
                        ),
                        rotation: s.rotation.map(|q| q as f32),
                        buttons: s.buttons,
                    },
                    None => Pose {
                        position: Vec3::ZERO,
                        rotation: [1.0, 0.0, 0.0, 0.0],
                        buttons: 0,
                    },
                }
            }
        }
    }
}
