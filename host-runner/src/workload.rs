//! The work one tick runs in `timing`: nothing, the servo task's work (device read, tool
//! sample hand-off, force from the contact plane, device write), or the whole single-thread
//! tick (simulation step + force) that a replay or a firmware runs.

use crossbeam::queue::ArrayQueue;
use tetradrill_core::force::ToolState;
use tetradrill_core::servo::ContactState;
use tetradrill_device::{PathPoint, Scripted, SimConfig, SimDevice, QUAT_IDENTITY};

use crate::engine::{self, EngineStorage, TickParams};
use crate::error::CliError;
use crate::setup::Setup;
use crate::tasks::{servo_tick, ServoState, Workspace};
use crate::traces::PoseSource;

/// Which work a `timing` tick runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Work {
    /// Wake-ups only.
    None,
    /// The servo task's tick of a real-time run, on the demo's scripted path.
    Servo,
    /// Simulation step and force in one thread (replay and firmware), on the demo's path.
    Full,
}

impl Work {
    /// One line naming the work.
    pub fn describe(self) -> &'static str {
        match self {
            Work::None => "none (wake-ups only)",
            Work::Servo => "the servo task's tick (simulated device, demo path, contact plane)",
            Work::Full => "simulation step + force in one thread (demo scenario)",
        }
    }
}

/// Runs `f` with a per-tick closure doing `work` (set up here, before any tick: the closure
/// itself does not allocate for `Servo`).
pub fn with_work<R>(work: Work, f: impl FnOnce(&mut dyn FnMut(u64)) -> R) -> Result<R, CliError> {
    let sc = Setup::default();
    let params = TickParams::of(&sc)?;
    let poses = PoseSource::new(&sc.poses, None)?;
    let n = poses.ticks().max(1);
    match work {
        Work::None => Ok(f(&mut |_| {})),
        Work::Servo => {
            let script = tetradrill_core::script::DEMO;
            let path = Scripted(move |t: f64| {
                let (p, buttons) = script.at((t * 1000.0).round().max(0.0) as u32);
                PathPoint {
                    position: [p.x as f64, p.y as f64, p.z as f64],
                    rotation: QUAT_IDENTITY,
                    buttons,
                }
            });
            let mut device = SimDevice::new(path, SimConfig::default());
            let ring = ArrayQueue::new(16);
            // The block's top face as the contact plane: the force path runs whenever the
            // stylus is below it.
            let plane = ContactState {
                valid: true,
                point: tetradrill_core::Vec3::new(0.0, 0.0, 0.5),
                normal: tetradrill_core::Vec3::Z,
                ..ContactState::default()
            };
            let ws = Workspace {
                scale: 1.0,
                offset: tetradrill_core::Vec3::ZERO,
            };
            let mut st = ServoState::default();
            Ok(f(&mut |i| {
                let _ = servo_tick(&mut device, &ws, &params, &plane, &ring, &mut st, i);
                let _ = ring.pop();
            }))
        }
        Work::Full => {
            let loaded = engine::load_mesh(&sc)?;
            let mut store = EngineStorage::new(loaded.mesh, &sc)?;
            let mut world = store.world()?;
            let mut tool = ToolState::default();
            Ok(f(&mut |i| {
                let _ = engine::tick(&mut world, &mut tool, &params, &poses.at(i % n));
            }))
        }
    }
}
