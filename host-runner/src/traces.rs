//! Where a run's tool poses come from: a trace CSV file, a built-in scripted path computed
//! by the core (bit-identical to what the firmware computes), or a seeded random wander over
//! the mesh's surface (`wander:SEED`, for soak runs).

use std::path::Path;

use tetradrill_core::script::{Script, DEMO, DRILL_ON, TOOTH_ACCESS};
use tetradrill_core::Vec3;
use tetradrill_device::{PathPoint, Trace};

use crate::error::CliError;
use crate::scenario::Scenario;

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
    /// `builtin:demo`, `builtin:tooth-access` or a trace CSV file (bad traces exit 2 naming the file and line); see
    /// [`PoseSource::for_scenario`] for `wander:SEED`.
    pub fn load(spec: &str, scale: f64) -> Result<Self, CliError> {
        if let Some(name) = spec.strip_prefix("builtin:") {
            return match name {
                "demo" => Ok(Self::Script(DEMO)),
                "tooth-access" => Ok(Self::Script(TOOTH_ACCESS)),
                _ => Err(CliError::input(format!(
                    "unknown built-in trace `{spec}` (built-in: builtin:demo, builtin:tooth-access)"
                ))),
            };
        }
        if spec.starts_with("wander:") {
            return Err(CliError::input(format!(
                "trace `{spec}`: a wander takes its waypoints from the mesh (run and replay only)"
            )));
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

    /// The source a scenario names: its `trace` (`wander:SEED` takes its waypoints from the
    /// scenario's mesh).
    pub fn for_scenario(sc: &Scenario) -> Result<Self, CliError> {
        let Some(seed) = sc.trace.strip_prefix("wander:") else {
            return Self::load(&sc.trace, 1.0);
        };
        let seed = seed.parse::<u64>().map_err(|_| {
            CliError::input(format!(
                "trace `{}`: expected wander:SEED with SEED a whole number",
                sc.trace
            ))
        })?;
        let mut loaded = crate::meshio::load(Path::new(&sc.mesh), sc.scale)?;
        let mesh = loaded.mesh.view();
        let anchors: Vec<Vec3> = mesh
            .nodes()
            .iter()
            .zip(mesh.positions())
            .filter(|(n, _)| n.boundary)
            .map(|(_, p)| *p)
            .collect();
        if anchors.is_empty() {
            return Err(CliError::input(format!(
                "trace `{}`: the mesh {} has no boundary node to wander over",
                sc.trace, sc.mesh
            )));
        }
        Ok(Self::Wander { seed, anchors })
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

    fn wander(seed: &str) -> PoseSource {
        let sc = Scenario {
            mesh: "builtin:block:2".into(),
            trace: format!("wander:{seed}"),
            ..Scenario::default()
        };
        PoseSource::for_scenario(&sc).expect("a wander")
    }

    #[test]
    fn a_wander_is_seeded_visits_the_surface_and_drills() {
        let (a, b, c) = (wander("5"), wander("5"), wander("6"));
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
        let bad = Scenario {
            trace: "wander:-1".into(),
            ..Scenario::default()
        };
        assert_eq!(
            PoseSource::for_scenario(&bad).map(|_| ()).unwrap_err().code,
            2
        );
        assert!(PoseSource::load("wander:1", 1.0).is_err());
    }
}
