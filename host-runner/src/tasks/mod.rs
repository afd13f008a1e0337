//! The tasks of a real-time run, declared in one place (RTIC style), and the pipeline that runs
//! them.
//!
//! [`TASKS`] is the task table: one [`TaskDecl`] per task ([`SERVO`], [`SIMULATION`],
//! [`STATUS`], [`VIEWER`], [`WATCHDOG`], [`RECORDER`], [`PASS_WORKER`]) with its priority, its
//! period, what it does and what it reads and writes. The servo, simulation, status, watchdog
//! and recorder threads take their names from it. docs/ARCHITECTURE.md ("Tasks and
//! hand-offs") shows the first four fields, one line per task, and `tests/tests/docs_tables.rs`
//! checks that line against this table.
//!
//! Hand-offs are lock-free and allocation-free after start-up: the servo pushes every tick's
//! tool sample into a bounded SPSC ring (crossbeam `ArrayQueue`; a full ring drops the sample
//! and counts it) so the simulation sees the whole swept path even when it runs slower; the
//! simulation publishes its latest contact plane and status through triple buffers, which the
//! servo and the status task read without ever waiting. When the simulation is slower than the
//! servo, the servo keeps computing the force from the last contact plane at the tool's current
//! position: the extrapolation of Turini et al. 2006, section 3.3.
//!
//! With a tet-mesh tool (`--tool mesh:FILE`) the same servo, watchdog and status tasks run, the
//! servo's force law is [`crate::pen_tasks::PenLaw`] and the simulation task is the pen's
//! contact task ([`crate::pen_tasks::pen_contact_task`]): it runs the contact pass (collisions
//! and consistent depths) at the newest pose and publishes the pass's penetrations and pose
//! ([`crate::pen_tasks::HeldPen`], a triple buffer); the servo carries them to the pose of each
//! tick. The viewer draws the pen with its boundary triangles, clear of the object.
//!
//! With the drill tool (`--tool drill:BURR_R:SHAFT_LEN:SHAFT_R`) the simulation task also
//! tracks the shaft's passive points at the newest pose and publishes their planes with the
//! burr's, from the same step ([`DrillContact`], a triple buffer); the servo's law is
//! [`DrillLaw`]: the burr's spring and the passive points' springs at the tool's current pose,
//! summed into one force at the handle (O(32) a tick, no face looked at). The viewer draws the
//! shaft along the tool's axis.
//!
//! With the live window, the viewer also publishes its camera rotation through a triple buffer
//! the servo reads each tick ([`DeviceFrame`]): the device's positions turn with the view
//! (egocentric pen coordinates, Praktikum report, section 5) and forces turn back before they reach
//! the device. Without a window the frame is the identity and nothing changes.
//!
//! The watchdog task ([`crate::watchdog`]) supervises the servo: the servo bumps an atomic beat
//! each tick; when it stops for [`crate::watchdog::SERVO_WATCHDOG_NS`], the watchdog zeroes the
//! force through the device's cutoff, without the servo thread.
//!
//! Every servo tick, for every device, runs the core's time-domain passivity observer and
//! controller ([`tetradrill_core::force::PassivityObserver`]) between the force law and the device, in
//! SI units (scene positions divided by the workspace scale: metres, in the scene's rotated
//! frame, where the power is the same as at the device). It is fed the force the device is
//! sent: the law's, clamped at the device's peak, derated by the device's continuous-force
//! model and ramped in after a recovery ([`DeviceLimits`]). With the burr's law and the drill
//! off (its penalty spring is then a storage function) it dissipates what the rendered wall
//! generates and trips when the law stores energy past its force limit beyond the bound (a
//! reversed force or a mirrored axis); with the drill on it damps on the classic form and trips
//! on the same measure; with a mesh tool (no storage function) it observes and reports only. A trip cuts the motors through the device's cutoff (the watchdog's path:
//! direct zero, latch) and writes zero force with the motors off until the tool has been out of
//! contact for a second ([`RECOVER_TICKS`]); then the cutoff is re-armed and the force ramps
//! back in. After [`MAX_TRIPS_PER_MINUTE`] trips within a minute the motors stay off for the
//! rest of the run. The JSON counts the trips, the recoveries and the seconds derated.
//!
//! After the observer, in contact, the force-sign probe ([`SignProbe`]) adds a small
//! pseudo-random force to what the device is sent and regresses the device's response on it:
//! a device that moves against it (a reversed force, a mirrored axis) trips the observer, at
//! any force level and while drilling, where nothing is stored past the limit.

use std::sync::atomic::{AtomicBool, AtomicU32, AtomicU64, Ordering};
use std::sync::Arc;

use crossbeam::queue::ArrayQueue;
use tetradrill_core::{Quat, Vec3};

use crate::stats::Histogram;

mod drill;
mod frame;
mod limits;
mod probe;
mod record;
mod servo;
mod simulation;

pub use drill::*;
pub use frame::*;
pub use limits::*;
pub use probe::*;
pub use record::*;
pub use servo::*;
pub use simulation::*;

/// One task's declaration: what it is, how urgent, how often, what it does and what it shares.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TaskDecl {
    /// Name, and the name of the task's thread when it has one of its own (the viewer runs on
    /// the main thread, the status task on the main thread or its own, the pass worker on an
    /// unnamed scoped thread).
    pub name: &'static str,
    /// Scheduling: priority, core, memory.
    pub priority: &'static str,
    /// Period.
    pub period: &'static str,
    /// What it does.
    pub does: &'static str,
    /// What it reads from the other tasks.
    pub reads: &'static str,
    /// What it writes: to the other tasks, the device or a file.
    pub writes: &'static str,
}

/// The servo ([`servo_task`], one tick [`servo_io`]): the 1 kHz loop from the device to the
/// force law and back; nothing in it allocates, locks or waits.
pub const SERVO: TaskDecl = TaskDecl {
    name: "servo",
    priority: "SCHED_FIFO 80, pinned to the last core, memory locked (each when allowed)",
    period: "1 ms on absolute deadlines",
    does: "device read; the servo half of the force (`tasks::ForceLaw`); the passivity observer and controller (`force::passivity`); the device's `ForceSafety` (clamp, ramp, NaN filter); device write; pushes the tool sample to the simulation's ring (and the recorder's)",
    reads: "device sample; ContactState, DrillContact (drill) or HeldPen (mesh tool), camera C (triple buffers); the stop request (atomic)",
    writes: "force command to the device; ToolSample (SPSC rings: simulation, recorder); servo counters and timing histograms (atomics)",
};

/// The simulation ([`simulation_task`]; with a tet-mesh tool the pen's contact task,
/// [`crate::pen_tasks::pen_contact_task`]): the work that may take longer than a servo tick.
pub const SIMULATION: TaskDecl = TaskDecl {
    name: "simulation",
    priority: "normal",
    period: "as fast as it can, at most once per servo tick",
    does: "`World::simulate`: candidates through the hash, budgeted drilling, the contact search; publishes the contact plane (a tet-mesh tool: the pen's contact pass, `pen_tasks::pen_contact_task`)",
    reads: "ToolSample (SPSC ring); Controls (triple buffer)",
    writes: "ContactState, DrillContact (drill) or HeldPen (mesh tool), SimStatus (triple buffers); Snapshot queue",
};

/// The status line (`status_loop` of the run's pipeline).
pub const STATUS: TaskDecl = TaskDecl {
    name: "status",
    priority: "normal (the main thread; its own thread while the viewer has the main thread)",
    period: "250 ms",
    does: "the status line (one line a second when stderr is not a terminal)",
    reads: "SimStatus (triple buffer); servo counters (atomics)",
    writes: "the status line on stderr",
};

/// The live window ([`crate::viewer`]).
pub const VIEWER: TaskDecl = TaskDecl {
    name: "viewer",
    priority: "normal, the main thread (with a window)",
    period: "about 60 Hz",
    does: "the live window: drains snapshots, writes the controls and the camera frame",
    reads: "Snapshot queue (drained, never waited on); servo counters (atomics)",
    writes: "Controls, camera C (triple buffers)",
};

/// The servo's supervisor ([`crate::watchdog::supervisor_task`]).
pub const WATCHDOG: TaskDecl = TaskDecl {
    name: "watchdog",
    priority: "SCHED_FIFO one above the servo, on another core (when the servo has SCHED_FIFO); else normal",
    period: "1 ms",
    does: "cuts the motors through a second path (`MotorCutoff`) when the servo's heartbeat stops for 10 ms (docs/SAFETY.md)",
    reads: "the servo's beat (atomic)",
    writes: "the device's cutoff (force off, latch)",
};

/// The trace writer of `--record` ([`recorder_task`]).
pub const RECORDER: TaskDecl = TaskDecl {
    name: "recorder",
    priority: "normal (`--record`)",
    period: "10 ms",
    does: "the run's tool poses as a trace CSV",
    reads: "RecordRing (SPSC ring; a full ring drops the row and counts it)",
    writes: "the trace CSV file",
};

/// The object side of a tet-mesh tool's contact pass on a thread of its own
/// ([`crate::pen_pair::PenPair`]), beside the simulation task that runs the pen side.
pub const PASS_WORKER: TaskDecl = TaskDecl {
    name: "pass worker",
    priority: "normal (a tet-mesh tool, `--pass-threads 2`)",
    period: "with each contact pass",
    does: "the object side of the pen's contact pass (`pen_pair`)",
    reads: "each pass's job: the pose, the options and the object side's storage (bounded channel)",
    writes: "the side's report, with its storage back (bounded channel)",
};

/// Every task of a real-time run.
pub const TASKS: [TaskDecl; 7] = [
    SERVO,
    SIMULATION,
    STATUS,
    VIEWER,
    WATCHDOG,
    RECORDER,
    PASS_WORKER,
];

pub use crate::rt::SERVO_PERIOD_NS;

/// Tool samples the ring holds: 1 s of servo ticks.
pub const TOOL_RING: usize = 1000;

/// Most burr positions one simulation step erodes along the swept path.
pub const MAX_SPHERES: usize = 16;

/// A tool sample handed from the servo to the simulation.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct ToolSample {
    /// Servo tick.
    pub tick: u64,
    /// Tool centre (the burr) or tip (a mesh tool), mesh units.
    pub position: Vec3,
    /// Tool rotation in the scene (the identity for a device that senses none).
    pub rotation: Quat,
    /// Buttons (bit 0 = drill on).
    pub buttons: u32,
}

pub use crate::viewer::handoff::SimStatus;

/// Counters the servo shares through atomics (read by the status task).
#[derive(Debug, Default)]
pub struct ServoCounters {
    /// Ticks done.
    pub ticks: AtomicU64,
    /// Deadlines missed.
    pub overruns: AtomicU64,
    /// Tool samples dropped because the ring was full.
    pub dropped_samples: AtomicU64,
    /// Last force magnitude, f32 bits.
    pub force_bits: AtomicU64,
    /// Last force vector, f32 bits of x, y, z (for the viewer's arrow).
    pub force_xyz: [AtomicU32; 3],
    /// Wake-up latencies of the run (fixed buckets: the status line, the viewer and the JSON
    /// read it).
    pub wake: Histogram,
    /// Tick compute times of the run (fixed buckets).
    pub tick: Histogram,
    /// Largest wake-up latency of the last complete second, ns.
    pub wake_recent_max_ns: AtomicU64,
    /// Burr radius the servo uses, f32 bits; 0 = the scenario's (set from the viewer's
    /// controls by the simulation task).
    pub radius_bits: AtomicU32,
    /// Stiffness the servo uses, f32 bits; 0 = the scenario's.
    pub stiffness_bits: AtomicU32,
    /// A drill's burr force alone (without the shaft's push), f32 bits of its magnitude: what
    /// presses the burr into the material ([`DrillLaw`] writes it each tick; unused otherwise).
    pub burr_press_bits: AtomicU32,
    /// The servo's beat and the watchdog's trips ([`crate::watchdog`]).
    pub watch: crate::watchdog::ServoWatch,
}

impl ServoCounters {
    /// Counts one wake-up latency (atomics only: no allocation, no lock).
    pub fn record_wake(&self, ns: u64, tick: u64, window_max: &mut u64) {
        self.wake.record(ns);
        *window_max = (*window_max).max(ns);
        if tick % 1000 == 999 {
            self.wake_recent_max_ns
                .store(*window_max, Ordering::Relaxed);
            *window_max = 0;
        }
    }

    /// The wake-up latency percentile `q` (0..1) from [`ServoCounters::wake`], microseconds
    /// (`None` before the first tick).
    pub fn wake_percentile_us(&self, q: f64) -> Option<f64> {
        let per_mille = (q.clamp(0.0, 1.0) * 1000.0).round() as u32;
        self.wake
            .percentile_ns(per_mille)
            .map(|ns| ns as f64 / 1000.0)
    }

    /// The last force vector.
    pub fn force(&self) -> Vec3 {
        let f = |i: usize| f32::from_bits(self.force_xyz[i].load(Ordering::Relaxed));
        Vec3::new(f(0), f(1), f(2))
    }
}

/// Shared pieces of one pipeline run.
#[derive(Debug)]
pub struct Shared {
    /// Servo to simulation.
    pub ring: ArrayQueue<ToolSample>,
    /// Servo counters.
    pub counters: ServoCounters,
    /// Set to end every task.
    pub stop: AtomicBool,
    /// Simulation to viewer (drained only when a viewer or a screenshot is asked for).
    pub snapshots: crate::viewer::handoff::SnapshotQueue,
}

impl Shared {
    /// Fresh shared state.
    pub fn new() -> Arc<Self> {
        Arc::new(Self {
            ring: ArrayQueue::new(TOOL_RING),
            counters: ServoCounters::default(),
            stop: AtomicBool::new(false),
            snapshots: crate::viewer::handoff::SnapshotQueue::default(),
        })
    }
}
