//! Where a run's tool poses come from: a trace CSV file, a built-in scripted path computed
//! by the core (bit-identical to what the firmware computes), or a seeded random wander over
//! the mesh's surface (`wander:SEED`, for soak runs).

use std::path::Path;

use tetradrill_core::script::{Script, DEMO, DRILL_ON, PREMOLAR_ACCESS, TOOTH_ACCESS};
use tetradrill_core::Vec3;
use tetradrill_device::{PathPoint, Trace};

use crate::error::Error;
use crate::owned::OwnedMesh;
use crate::setup::Poses;

/// Servo period of replays and scripted paths, seconds.
pub const PERIOD_S: f64 = 1e-3;

/// `wander:SEED`: ticks the tool takes from one waypoint to the next (2 s at 1 kHz).
pub const WANDER_HOP_TICKS: u64 = 2000;

/// `wander:SEED`: how long a wander lasts when no duration is given (60 s at 1 kHz).
pub const WANDER_TICKS: u64 = 60_000;

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

impl Pose {
    /// The tool at `position`, unrotated, the drill off.
    pub fn at(position: Vec3) -> Self {
        Self {
            position,
            rotation: [1.0, 0.0, 0.0, 0.0],
            buttons: 0,
        }
    }

    /// The tool at `position`, unrotated, the drill on.
    pub fn drilling(position: Vec3) -> Self {
        Self {
            buttons: DRILL_ON,
            ..Self::at(position)
        }
    }
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
    /// A seeded random wander, drill on: every [`WANDER_HOP_TICKS`] the tool heads for
    /// another of the mesh's boundary nodes, picked by the seed, easing in and out (smoothstep),
    /// so it touches the surface at each waypoint and drills its way between them.
    /// Deterministic: the pose at a tick depends only on the seed, the tick and the mesh.
    Wander {
        /// The seed.
        seed: u64,
        /// Waypoint candidates: the mesh's boundary nodes (never empty).
        anchors: Vec<Vec3>,
    },
}

/// splitmix64's finaliser: a well-mixed 64-bit value from any 64-bit input.
fn mix(x: u64) -> u64 {
    let mut z = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

impl PoseSource {
    /// The poses of `poses`: the scripted path, the trace file read (bad traces name the file
    /// and line), or a wander over the boundary nodes of `mesh` (which it needs).
    ///
    /// # Errors
    /// [`Error::Input`] for an unreadable or bad trace file, a wander without a mesh or over a
    /// mesh with no boundary node.
    pub fn new(poses: &Poses, mesh: Option<&OwnedMesh>) -> Result<Self, Error> {
        match poses {
            Poses::Demo => Ok(Self::Script(DEMO)),
            Poses::ToothAccess => Ok(Self::Script(TOOTH_ACCESS)),
            Poses::PremolarAccess => Ok(Self::Script(PREMOLAR_ACCESS)),
            Poses::Trace(path) => Self::trace_file(path, 1.0),
            Poses::Wander { seed } => {
                let Some(mesh) = mesh else {
                    return Err(Error::Unsupported(format!(
                        "trace `{poses}`: a wander takes its waypoints from the mesh (run and \
                         replay only)"
                    )));
                };
                let anchors: Vec<Vec3> = mesh
                    .nodes()
                    .iter()
                    .zip(mesh.positions())
                    .filter(|(n, _)| n.boundary())
                    .map(|(_, p)| *p)
                    .collect();
                if anchors.is_empty() {
                    return Err(Error::Unsupported(format!(
                        "trace `{poses}`: the mesh has no boundary node to wander over"
                    )));
                }
                Ok(Self::Wander {
                    seed: *seed,
                    anchors,
                })
            }
        }
    }

    /// A trace CSV file, positions times `scale` (bad traces name the file and line).
    ///
    /// # Errors
    /// [`Error::Input`] naming the file, the line and the reason.
    pub fn trace_file(path: &Path, scale: f64) -> Result<Self, Error> {
        let bytes = std::fs::read(path)
            .map_err(|e| Error::at(path, None, format!("cannot read trace: {e}")))?;
        let text = String::from_utf8(bytes)
            .map_err(|_| Error::at(path, None, "not a text file (binary trace?)"))?;
        let trace = Trace::parse(&text, &path.to_string_lossy())
            .map_err(|e| Error::at(path, Some(e.line), e.kind))?;
        Ok(Self::Trace { trace, scale })
    }

    /// The pose at device time `t` seconds, for the simulated device's hand.
    pub fn path_point(&self, t: f64) -> PathPoint {
        let i = if t.is_finite() && t > 0.0 {
            (t / PERIOD_S).round() as u64
        } else {
            0
        };
        let p = self.at(i);
        PathPoint {
            position: p.position.to_array().map(f64::from),
            rotation: p.rotation.map(f64::from),
            buttons: p.buttons,
        }
    }

    /// Number of ticks the source lasts at 1 kHz ([`WANDER_TICKS`] for a wander, which has no
    /// end).
    pub fn ticks(&self) -> u64 {
        match self {
            Self::Wander { .. } => WANDER_TICKS,
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
            Self::Wander { seed, anchors } => {
                let waypoint = |k: u64| {
                    let j = mix(seed ^ mix(k)) % anchors.len() as u64;
                    anchors.get(j as usize).copied().unwrap_or(Vec3::ZERO)
                };
                let k = i / WANDER_HOP_TICKS;
                let u = (i % WANDER_HOP_TICKS) as f32 / WANDER_HOP_TICKS as f32;
                let (a, b) = (waypoint(k), waypoint(k + 1));
                Pose {
                    position: a + (b - a) * (u * u * (3.0 - 2.0 * u)),
                    rotation: [1.0, 0.0, 0.0, 0.0],
                    buttons: DRILL_ON,
                }
            }
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

#[cfg(test)]
mod tests {
    use super::*;

    fn wander(seed: u64) -> PoseSource {
        let mesh = crate::meshio::load(Path::new("builtin:block:2"), 1.0).expect("block");
        PoseSource::new(&Poses::Wander { seed }, Some(&mesh.mesh)).expect("a wander")
    }

    #[test]
    fn a_wander_is_seeded_visits_the_surface_and_drills() {
        let (a, b, c) = (wander(5), wander(5), wander(6));
        assert_eq!(a.ticks(), WANDER_TICKS);
        let mut differs = false;
        for i in (0..20_000).step_by(7) {
            let p = a.at(i);
            assert_eq!(p, b.at(i), "same seed, same pose");
            differs |= p != c.at(i);
            assert_eq!(p.buttons, DRILL_ON);
            // Inside the unit block's box, by construction (waypoints are boundary nodes).
            assert!(p.position.abs().max_element() <= 0.5 + 1e-6, "{p:?}");
            // The simulated device's hand sees the same pose at the same time.
            let h = a.path_point(i as f64 * PERIOD_S);
            assert_eq!(h.position, p.position.to_array().map(f64::from));
        }
        assert!(differs, "another seed, another path");
        // At each waypoint the tool is on the block's surface (a face of the box).
        for k in 0..10 {
            let p = a.at(k * WANDER_HOP_TICKS).position;
            assert!(
                (p.abs().max_element() - 0.5).abs() < 1e-6,
                "waypoint {k} at {p:?}"
            );
        }
        assert!(Poses::parse("wander:-1").is_err());
        assert!(PoseSource::new(&Poses::Wander { seed: 1 }, None).is_err());
    }
}
