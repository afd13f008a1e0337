//! The tasks of a real-time run, declared in one place (RTIC style), and the pipeline that runs
//! them.
//!
//! | task       | priority                 | period              | reads                          | writes                          |
//! |------------|--------------------------|---------------------|--------------------------------|---------------------------------|
//! | servo      | SCHED_FIFO 80, last core | 1 ms, absolute      | device, `ContactState`, `DrillContact` or `HeldPen`, camera `C` (triple buffers) | force to device, `ToolSample` ring |
//! | simulation | normal                   | as fast as it can   | `ToolSample` ring              | `ContactState`, `DrillContact` or `HeldPen`, `SimStatus` (triple buffers) |
//! | status     | normal                   | 250 ms              | `SimStatus`, servo counters (atomics) | the status line          |
//! | watchdog   | SCHED_FIFO 81, not the servo's core | 1 ms     | the servo's beat (atomic)      | the device's cutoff (force off) |
//! | viewer     | normal, the main thread  | about 60 Hz         | `Snapshot` queue, servo counters | `Controls`, camera `C` (triple buffers) |
//! | recorder   | normal (`--record` only) | 10 ms               | `RecordRing` (SPSC ring)       | the trace CSV file              |
//!
//! Hand-offs are lock-free and allocation-free after start-up: the servo pushes every tick's
//! tool sample into a bounded SPSC ring (crossbeam `ArrayQueue`; a full ring drops the sample
//! and counts it) so the simulation sees the whole swept path even when it runs slower; the
//! simulation publishes its latest contact plane and status through triple buffers, which the
//! servo and the status task read without ever waiting. When the simulation is slower than the
//! servo, the servo keeps computing the force from the last contact plane at the tool's current
//! position: the extrapolation of seed 001 section 3.3.
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
//! (egocentric pen coordinates, seed 000 section 5) and forces turn back before they reach the
//! device. Without a window the frame is the identity and nothing changes.
//!
//! The watchdog task ([`crate::watchdog`]) supervises the servo: the servo bumps an atomic beat
//! each tick; when it stops for [`crate::watchdog::SERVO_WATCHDOG_NS`], the watchdog zeroes the
//! force through the device's cutoff, without the servo thread.
//!
//! Every servo tick, for every device, runs the core's time-domain passivity observer and
//! controller ([`tetradrill_core::force::passivity`]) between the force law and the device, in
//! SI units (scene positions divided by the workspace scale: metres, in the scene's rotated
//! frame, where the power is the same as at the device). With the burr's law and the drill off
//! (its penalty spring is then a storage function) it dissipates what the rendered wall
//! generates and trips when the law stores energy past its force limit beyond the bound (a
//! reversed force or a mirrored axis); with the drill on, or a mesh tool, it observes and
//! reports only. A trip cuts the motors through the device's cutoff (the watchdog's path:
//! direct zero, latch) and writes zero force with the motors off, and every later tick of the
//! run does the same: the run goes on to its end with zero force (the observer's trip is
//! latched for the run), and the JSON counts the trip.

use std::sync::atomic::{AtomicBool, AtomicU32, AtomicU64, Ordering};
use std::sync::Arc;

use crossbeam::queue::ArrayQueue;
use tetradrill_core::{Quat, Vec3};

use crate::stats::Histogram;

mod drill;
mod frame;
mod record;
mod servo;
mod simulation;

pub use drill::*;
pub use frame::*;
pub use record::*;
pub use servo::*;
pub use simulation::*;

/// One task's declaration: what it is, how urgent, how often, what it shares.
#[derive(Debug, Clone, Copy)]
pub struct TaskDecl {
    /// Name (also the thread name).
    pub name: &'static str,
    /// Scheduling.
    pub priority: &'static str,
    /// Period.
    pub period: &'static str,
    /// What it reads.
    pub reads: &'static str,
    /// What it writes.
    pub writes: &'static str,
}

/// Every task of a real-time run.
pub const TASKS: [TaskDecl; 6] = [
    TaskDecl {
        name: "servo",
        priority: "SCHED_FIFO 80, pinned to the last core, memory locked",
        period: "1 ms on absolute deadlines",
        reads: "device sample; ContactState, DrillContact (drill) or HeldPen (mesh tool), camera C (triple buffers); the stop request (atomic)",
        writes: "force command to the device; ToolSample (SPSC rings: simulation, recorder); servo counters and timing histograms (atomics)",
    },
    TaskDecl {
        name: "simulation",
        priority: "normal",
        period: "as fast as it can, at most once per servo tick",
        reads: "ToolSample (SPSC ring); Controls (triple buffer)",
        writes: "ContactState, DrillContact (drill) or HeldPen (mesh tool), SimStatus (triple buffers); Snapshot queue",
    },
    TaskDecl {
        name: "status",
        priority: "normal (the main thread)",
        period: "250 ms",
        reads: "SimStatus (triple buffer); servo counters (atomics)",
        writes: "the status line on stderr",
    },
    TaskDecl {
        name: "viewer",
        priority: "normal (the main thread; status moves to its own thread)",
        period: "about 60 Hz",
        reads: "Snapshot queue (drained, never waited on); servo counters (atomics)",
        writes: "Controls, camera C (triple buffers)",
    },
    TaskDecl {
        name: "watchdog",
        priority: "SCHED_FIFO one above the servo when permitted, on another core; else normal",
        period: "1 ms",
        reads: "the servo's beat (atomic)",
        writes: "the device's cutoff (force off, latch) when the servo misses 10 ms of ticks",
    },
    TaskDecl {
        name: "recorder",
        priority: "normal (only with --record)",
        period: "10 ms",
        reads: "RecordRing (SPSC ring; a full ring drops the row and counts it)",
        writes: "the trace CSV file",
    },
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
