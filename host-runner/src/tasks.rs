//! The tasks of a real-time run, declared in one place (RTIC style), and the pipeline that runs
//! them.
//!
//! | task       | priority                 | period              | reads                          | writes                          |
//! |------------|--------------------------|---------------------|--------------------------------|---------------------------------|
//! | servo      | SCHED_FIFO 80, last core | 1 ms, absolute      | device, `ContactState` or `HeldPen`, camera `C` (triple buffers) | force to device, `ToolSample` ring |
//! | simulation | normal                   | as fast as it can   | `ToolSample` ring              | `ContactState` or `HeldPen`, `SimStatus` (triple buffers) |
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
use tetradrill_core::drill::Sphere;
use tetradrill_core::force::{
    penalty_storage, ForceDigest, ForceParams, PassivityObserver, PassivityParams, Storage,
    ToolState,
};
use tetradrill_core::servo::{servo_force, ContactState, World};
use tetradrill_core::{Quat, Vec3};
use tetradrill_device::{DeviceError, ForceCommand, HapticDevice, MotorCutoff};

use crate::engine::TickParams;
use crate::platform::now_ns;
use crate::rt::{Periodic, RtConfig, RtStatus};
use crate::stats::Histogram;
use crate::watchdog::StopRequest;

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
        reads: "device sample; ContactState or HeldPen (mesh tool), camera C (triple buffers); the stop request (atomic)",
        writes: "force command to the device; ToolSample (SPSC rings: simulation, recorder); servo counters and timing histograms (atomics)",
    },
    TaskDecl {
        name: "simulation",
        priority: "normal",
        period: "as fast as it can, at most once per servo tick",
        reads: "ToolSample (SPSC ring); Controls (triple buffer)",
        writes: "ContactState or HeldPen (mesh tool), SimStatus (triple buffers); Snapshot queue",
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

/// The identity, column-major: the camera `C` when no viewer turns the device frame.
pub const IDENTITY: [f32; 16] = [
    1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0,
];

/// How far a published camera may be from a rotation (`|C^T C - I|` per entry, and the
/// translation and the last row) before the servo refuses it.
pub const ROTATION_TOLERANCE: f32 = 1e-3;

/// A column-major 4x4 matrix as the glam matrix core's `force::frames` functions take (this
/// crate does not name glam; the layout is the one OpenGL and [`crate::viewer::camera`] use).
pub(crate) fn frame_mat<M: Default + AsMut<[f32; 16]>>(cols: &[f32; 16]) -> M {
    let mut m = M::default();
    m.as_mut().copy_from_slice(cols);
    m
}

/// The egocentric frame of the device (seed 000 section 5; DESIGN 2.5): the device reports the
/// pen in egocentric coordinates, the scene pose is `P_a = C * P_e` (core's
/// [`allocentric`](tetradrill_core::force::frames::allocentric)), and a scene force goes back
/// through `C`'s inverse ([`force_to_device`](tetradrill_core::force::frames::force_to_device)).
///
/// `C` is a pure rotation (the viewer's orbit relative to its start view; pan and zoom do not
/// enter it): the device frame is the scene frame as the start view shows it, so without a
/// viewer `C` is the identity and the map is exactly [`Workspace::to_mesh`]. `C` turns the
/// device's displacement about `pivot`, the workspace centre (the mesh's centre, which the
/// camera orbits), so the tool stays at the same place on screen while the view turns, and
/// never swings away from the mesh as a turn about the mesh origin would.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DeviceFrame {
    camera: [f32; 16],
    identity: bool,
    /// The point `C` turns about, mesh units.
    pub pivot: Vec3,
}

impl Default for DeviceFrame {
    fn default() -> Self {
        Self::new(Vec3::ZERO)
    }
}

impl DeviceFrame {
    /// The identity frame turning about `pivot`.
    pub fn new(pivot: Vec3) -> Self {
        Self {
            camera: IDENTITY,
            identity: true,
            pivot,
        }
    }

    /// The camera `C` in use, column-major.
    pub fn camera(&self) -> [f32; 16] {
        self.camera
    }

    /// `C` is the identity: positions and forces pass unchanged.
    pub fn is_identity(&self) -> bool {
        self.identity
    }

    /// Takes `c` as the camera when it is a finite proper rotation (columns orthonormal within
    /// [`ROTATION_TOLERANCE`], determinant +1, no translation); otherwise keeps the camera it
    /// had and returns `false`. A rotation keeps `C`'s inverse equal to its transpose, so the
    /// frame neither adds nor takes power: `F_device . v_device == F_scene . v_scene`.
    ///
    /// # Bounded work
    /// Constant (about 60 flops).
    pub fn set_camera(&mut self, c: &[f32; 16]) -> bool {
        if !is_rotation(c) {
            return false;
        }
        self.camera = *c;
        self.identity = *c == IDENTITY;
        true
    }

    /// A device position (metres, device frame) to the scene: `pivot + C (to_mesh(p) - pivot)`.
    ///
    /// # Bounded work
    /// Constant.
    pub fn to_scene(&self, workspace: &Workspace, p: [f64; 3]) -> Vec3 {
        let m = workspace.to_mesh(p);
        if self.identity {
            return m;
        }
        let t = m - self.pivot;
        let mut pen = IDENTITY;
        pen[12] = t.x;
        pen[13] = t.y;
        pen[14] = t.z;
        let a =
            tetradrill_core::force::frames::allocentric(frame_mat(&self.camera), frame_mat(&pen));
        let a: &[f32; 16] = a.as_ref();
        let q = self.pivot + Vec3::new(a[12], a[13], a[14]);
        if q.is_finite() {
            q
        } else {
            m
        }
    }

    /// A device rotation (unit quaternion `[w, x, y, z]`, device frame) to the scene: `C q`, the
    /// rotation part of `P_a = C P_e`. A quaternion that is not finite or has length zero gives
    /// [`Quat::NAN`] (a mesh tool's law then gives zero force); others are normalised.
    ///
    /// # Bounded work
    /// Constant.
    pub fn rotation_to_scene(&self, q: [f64; 4]) -> Quat {
        let [w, x, y, z] = q.map(|v| v as f32);
        let q = Quat::from_xyzw(x, y, z, w);
        let len = q.length();
        if !(len.is_finite() && len > 0.0) {
            return Quat::NAN;
        }
        let q = q / len;
        if self.identity {
            return q;
        }
        (Quat::from_mat4(&frame_mat(&self.camera)) * q).normalize()
    }

    /// A scene force (newtons) to the device frame: `C^-1 F` (zero for a singular `C`, which
    /// [`set_camera`](Self::set_camera) never takes).
    ///
    /// # Bounded work
    /// Constant (one 4x4 inverse).
    pub fn force_to_device(&self, f: Vec3) -> Vec3 {
        if self.identity {
            return f;
        }
        tetradrill_core::force::frames::force_to_device(frame_mat(&self.camera), f)
    }
}

/// `c` (column-major) is a finite proper rotation without translation.
fn is_rotation(c: &[f32; 16]) -> bool {
    if !c.iter().all(|v| v.is_finite()) {
        return false;
    }
    let tol = ROTATION_TOLERANCE;
    // No translation, last row (0, 0, 0, 1).
    if [c[3], c[7], c[11], c[12], c[13], c[14]]
        .iter()
        .any(|v| v.abs() > tol)
        || (c[15] - 1.0).abs() > tol
    {
        return false;
    }
    let col = |j: usize| Vec3::new(c[4 * j], c[4 * j + 1], c[4 * j + 2]);
    let (x, y, z) = (col(0), col(1), col(2));
    let gram = [
        (x.dot(x), 1.0),
        (y.dot(y), 1.0),
        (z.dot(z), 1.0),
        (x.dot(y), 0.0),
        (x.dot(z), 0.0),
        (y.dot(z), 0.0),
    ];
    gram.iter().all(|(g, want)| (g - want).abs() <= tol) && x.cross(y).dot(z) > 0.0
}

/// Where the device's positions land in the mesh: `mesh = device * scale + offset`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Workspace {
    /// Mesh units per device unit (metre).
    pub scale: f32,
    /// Mesh-space position of the device origin.
    pub offset: Vec3,
}

impl Workspace {
    /// Device position (metres, f64) to mesh units.
    pub fn to_mesh(&self, p: [f64; 3]) -> Vec3 {
        Vec3::new(p[0] as f32, p[1] as f32, p[2] as f32) * self.scale + self.offset
    }
}

/// Why the servo task ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ServoEnd {
    /// It ran the ticks it was given (`--duration`, a trace's length).
    Ticks,
    /// A stop was requested ([`StopRequest`]: a signal, or a caller): the force was zeroed
    /// within the tick that saw it.
    Requested,
    /// Another task set the pipeline's stop flag (the live window closed).
    Stopped,
    /// The device failed.
    DeviceError,
}

impl ServoEnd {
    /// The name the JSON's `stop_reason` gives it: `duration`, `signal`, `window`,
    /// `device_error`.
    pub fn name(self) -> &'static str {
        match self {
            Self::Ticks => "duration",
            Self::Requested => "signal",
            Self::Stopped => "window",
            Self::DeviceError => "device_error",
        }
    }
}

/// What the servo task measured, returned when it ends (its timing distributions are in the
/// [`ServoCounters`] it was given).
#[derive(Debug)]
pub struct ServoResult {
    /// Real-time settings achieved.
    pub rt: RtStatus,
    /// Why it ended.
    pub end: ServoEnd,
    /// After a stop request: nanoseconds from the request to the end of the zero-force write.
    pub request_to_zero_ns: Option<u64>,
    /// Magnitude of the last force command the device took (newtons, device frame): 0 after
    /// the closing zero-force write went through.
    pub last_written_n: f32,
    /// Ticks done.
    pub ticks: u64,
    /// Deadlines missed.
    pub overruns: u64,
    /// Digest of the force series.
    pub digest: ForceDigest,
    /// Largest force, newtons.
    pub max_force: f32,
    /// The device error that ended the run, if one did.
    pub error: Option<DeviceError>,
    /// Device samples with a NaN or infinite position (force zero on those ticks).
    pub nonfinite_samples: u64,
    /// The passivity observer at the end of the run (trips, energies).
    pub passivity: PassivityObserver,
    /// Deepest penetration of the tool's contact point, metres (0 for a law that does not
    /// report one).
    pub max_depth_m: f32,
}

/// The servo's end of the camera hand-off: the latest camera `C` the viewer published
/// (column-major), read without waiting.
pub type CameraOut = triple_buffer::Output<[f32; 16]>;
/// The viewer's end of the camera hand-off.
pub type CameraIn = triple_buffer::Input<[f32; 16]>;

/// A camera hand-off starting at the identity (a triple buffer: the last write wins, neither
/// side ever waits).
pub fn camera_handoff() -> (CameraIn, CameraOut) {
    triple_buffer::TripleBuffer::new(&IDENTITY).split()
}

/// The servo task: `ticks` ticks at 1 kHz (`u64::MAX`: no end), or until `stop` or a
/// `request`, each computing its force with `law` ([`BurrLaw`] for the drill,
/// [`crate::pen_tasks::PenLaw`] for a mesh tool). Everything it needs is allocated before its
/// loop; the loop neither allocates nor locks (the allocation-counting tests run [`servo_io`],
/// the loop's body, with either law, and the histogram and recorder pushes). Wake-up latency
/// and tick time go into `counters.wake` and `counters.tick` (fixed buckets: memory does not
/// grow with the run). With a `record` ring, each tick's sample is pushed there too (a full
/// ring drops the row and counts it; never a wait).
///
/// A stop `request` is looked at right after each wake-up: the tick that sees it writes zero
/// force ([`crate::watchdog::zero_force`], the watchdog's cutoff and the servo's own path)
/// and ends the loop, so the device gets zero force within one period of the request. `frame` is
/// the device frame it starts with; with a
/// `camera` hand-off, each tick takes the latest camera the viewer published (a triple-buffer
/// read: a few atomic operations, never a wait).
///
/// Each tick feeds the watchdog (`counters.watch`, an atomic store) from the first tick to the
/// last. When the watchdog caught a stall (or the device's cutoff latch is set), the next tick
/// first writes [`ForceCommand::OFF`] through the device and re-arms the cutoff, so the force
/// ramps up again from zero; the stall's length is counted.
#[allow(clippy::too_many_arguments)]
pub fn servo_task(
    device: &mut dyn HapticDevice,
    rt: RtConfig,
    ticks: u64,
    workspace: Workspace,
    law: &mut dyn ForceLaw,
    ring: &ArrayQueue<ToolSample>,
    counters: &ServoCounters,
    stop: &AtomicBool,
    request: &StopRequest,
    record: Option<Arc<RecordRing>>,
    frame: DeviceFrame,
    mut camera: Option<&mut CameraOut>,
) -> ServoResult {
    let rt = rt.apply();
    let mut state = ServoState {
        frame,
        record,
        ..ServoState::default()
    };
    state
        .passivity
        .set_params(passivity_params(&device.spec(), SERVO_PERIOD_NS));
    let mut end = ServoEnd::Ticks;
    let mut request_to_zero_ns = None;
    let watch = &counters.watch;
    let cutoff = device.cutoff();
    let mut timer = Periodic::new(SERVO_PERIOD_NS, 0);
    let mut error = None;
    let mut done = 0u64;
    let mut window_max = 0u64;
    // The end of the last tick, and the time between the last two ends: a stall is the longer
    // of that gap (stalled inside a tick) and the time since (stalled between ticks).
    let mut last_end = now_ns();
    let mut last_gap = 0u64;
    while done < ticks {
        if stop.load(Ordering::Relaxed) {
            end = ServoEnd::Stopped;
            break;
        }
        let w = timer.wait();
        if request.is_requested() {
            if crate::watchdog::zero_force(device, cutoff.as_deref()).is_ok() {
                state.last_written = 0.0;
            }
            let at = request.requested_at_ns().unwrap_or(0);
            request_to_zero_ns = Some(now_ns().saturating_sub(at));
            request.force_zeroed();
            end = ServoEnd::Requested;
            break;
        }
        let t0 = now_ns();
        let stalled = last_gap.max(t0.saturating_sub(last_end));
        if recover_from_stall(device, cutoff.as_deref(), watch, stalled) {
            // The force was off: what the tool did meanwhile was not the loop's doing.
            state.passivity.restart();
        }
        // The viewer's camera (a matrix that is not a rotation is refused: the old one stays).
        if let Some(c) = camera.as_deref_mut() {
            if c.update() {
                state.frame.set_camera(c.output_buffer());
            }
        }
        let out = servo_io(device, &workspace, law, ring, &mut state, done);
        counters.record_wake(w.latency_ns, done, &mut window_max);
        for (a, v) in counters.force_xyz.iter().zip(state.last_force.to_array()) {
            a.store(v.to_bits(), Ordering::Relaxed);
        }
        let t1 = now_ns();
        counters.tick.record(t1 - t0);
        last_gap = t1.saturating_sub(last_end);
        last_end = t1;
        done += 1;
        watch.beat(done);
        counters.ticks.store(done, Ordering::Relaxed);
        counters.overruns.store(timer.overruns, Ordering::Relaxed);
        counters
            .dropped_samples
            .store(state.dropped, Ordering::Relaxed);
        counters.force_bits.store(
            state.last_force.length().to_bits() as u64,
            Ordering::Relaxed,
        );
        if let Err(e) = out {
            error = Some(e);
            end = ServoEnd::DeviceError;
            break;
        }
    }
    // Leave the device safe: force off, whatever happened.
    watch.disarm();
    if device.write(&ForceCommand::OFF).is_ok() {
        state.last_written = 0.0;
    }
    stop.store(true, Ordering::Release);
    ServoResult {
        rt,
        end,
        request_to_zero_ns,
        last_written_n: state.last_written,
        ticks: done,
        overruns: timer.overruns,
        digest: state.digest,
        max_force: state.max_force,
        error,
        nonfinite_samples: state.nonfinite_samples,
        passivity: state.passivity,
        max_depth_m: state.max_depth_m,
    }
}

/// The passivity observer's settings for a device: its force and damping limits, the servo
/// period, the core's default slack and trip bound.
pub fn passivity_params(spec: &tetradrill_device::DeviceSpec, period_ns: u64) -> PassivityParams {
    let mut p = PassivityParams {
        dt: period_ns as f32 * 1e-9,
        ..PassivityParams::default()
    };
    if spec.max_force_n.is_finite() && spec.max_force_n > 0.0 {
        p.max_force = spec.max_force_n as f32;
    }
    if spec.max_damping_n_s_per_m.is_finite() && spec.max_damping_n_s_per_m > 0.0 {
        p.max_damping = spec.max_damping_n_s_per_m as f32;
    }
    p
}

/// The top of a servo tick: when the watchdog caught a stall (or the device's cutoff latch is
/// set), writes [`ForceCommand::OFF`] through the device, re-arms the cutoff (the device's
/// filter then ramps the force up again from zero) and counts the stall, `stalled_ns` long.
/// Returns whether it did. Atomics and at most one device write: no lock, no allocation.
pub fn recover_from_stall(
    device: &mut dyn HapticDevice,
    cutoff: Option<&dyn MotorCutoff>,
    watch: &crate::watchdog::ServoWatch,
    stalled_ns: u64,
) -> bool {
    let tripped = watch.tripped();
    if !(tripped || cutoff.is_some_and(|c| c.is_cut())) {
        return false;
    }
    let _ = device.write(&ForceCommand::OFF);
    if let Some(c) = cutoff {
        c.rearm();
    }
    if tripped {
        watch.resumed(stalled_ns);
    }
    true
}

/// What the servo carries from tick to tick.
#[derive(Debug, Default)]
pub struct ServoState {
    /// Damping state of [`servo_tick`] (the laws of [`servo_task`] keep their own).
    pub tool: ToolState,
    /// Digest of the forces.
    pub digest: ForceDigest,
    /// Largest force.
    pub max_force: f32,
    /// Last force.
    pub last_force: Vec3,
    /// Tool samples dropped (ring full).
    pub dropped: u64,
    /// The egocentric frame positions and forces go through (the identity by default).
    pub frame: DeviceFrame,
    /// Device samples whose position was NaN or infinite (their force is zero).
    pub nonfinite_samples: u64,
    /// Magnitude of the last force command the device took, newtons (device frame).
    pub last_written: f32,
    /// Where each tick's sample is recorded (`--record`), if anywhere.
    pub record: Option<Arc<RecordRing>>,
    /// The time-domain passivity observer and controller between the law and the device.
    pub passivity: PassivityObserver,
    /// Deepest penetration of the tool's contact point so far, metres.
    pub max_depth_m: f32,
    /// The device's position resets seen so far ([`HapticDevice::position_resets`]: the
    /// Falcon's homing moves its coordinates); a new one restarts the passivity observer, whose
    /// energy would otherwise count the jump as the tool's motion.
    pub position_resets: u64,
}

/// Where a servo tick's force comes from: the burr's contact plane ([`BurrLaw`]) or a mesh
/// tool's held contact ([`crate::pen_tasks::PenLaw`]). Any `FnMut(tick, position, rotation)`
/// closure is one too.
pub trait ForceLaw {
    /// The force on the tool at `position` and `rotation` (scene frame) at servo tick `tick`,
    /// newtons. Runs on the servo thread every tick: bounded work, no allocation, no lock, no
    /// wait (hand-offs are read through triple buffers).
    fn force(&mut self, tick: u64, position: Vec3, rotation: Quat) -> Vec3;

    /// The contact behind the last force, when the law knows its storage function (the
    /// passivity observer then uses its stricter form and trips on the energy stored past the
    /// force limit); `None` (the default) leaves the observer its classic form.
    fn contact(&self) -> Option<LawContact> {
        None
    }
}

impl<F: FnMut(u64, Vec3, Quat) -> Vec3> ForceLaw for F {
    fn force(&mut self, tick: u64, position: Vec3, rotation: Quat) -> Vec3 {
        self(tick, position, rotation)
    }
}

/// What a law knows of its contact at the tool's pose (scene units).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct LawContact {
    /// Penetration of the tool's contact point, mesh units (0 out of contact).
    pub depth: f32,
    /// The energy its spring holds there, newton mesh units.
    pub storage: Storage,
}

/// The burr's contact at `centre`: the depth below the contact plane and the storage of its
/// penalty spring (stiffness and force limit of `force`). Out of contact, or for a pose that
/// is not finite, zero.
///
/// # Bounded work
/// Constant.
pub fn burr_contact(
    contact: &ContactState,
    centre: Vec3,
    radius: f32,
    force: &ForceParams,
) -> LawContact {
    if !contact.valid {
        return LawContact::default();
    }
    let depth = radius - (centre - contact.point).dot(contact.normal);
    if !(depth.is_finite() && depth > 0.0) {
        return LawContact::default();
    }
    LawContact {
        depth,
        storage: penalty_storage(depth, force.stiffness, force.max_force),
    }
}

/// The burr's force law: the latest contact plane the simulation published, at the burr's
/// current position (seed 001 section 3.3), with the viewer's radius and stiffness when it set
/// them (`counters`).
#[derive(Debug)]
pub struct BurrLaw<'a> {
    /// The scenario's parameters.
    pub params: TickParams,
    /// The simulation's contact plane.
    pub contact: &'a mut triple_buffer::Output<ContactState>,
    /// The viewer's controls (radius and stiffness, 0 = the scenario's).
    pub counters: &'a ServoCounters,
    /// Damping state.
    pub tool: ToolState,
    /// The contact behind the last force.
    pub last: LawContact,
}

impl<'a> BurrLaw<'a> {
    /// The law for `params` over `contact`, controlled through `counters`.
    pub fn new(
        params: TickParams,
        contact: &'a mut triple_buffer::Output<ContactState>,
        counters: &'a ServoCounters,
    ) -> Self {
        Self {
            params,
            contact,
            counters,
            tool: ToolState::default(),
            last: LawContact::default(),
        }
    }
}

impl ForceLaw for BurrLaw<'_> {
    fn force(&mut self, _tick: u64, position: Vec3, _rotation: Quat) -> Vec3 {
        // The viewer's controls (0: the scenario's value).
        let mut live = self.params;
        let r = self.counters.radius_bits.load(Ordering::Relaxed);
        if r != 0 {
            live.radius = f32::from_bits(r);
        }
        let k = self.counters.stiffness_bits.load(Ordering::Relaxed);
        if k != 0 {
            live.force.stiffness = f32::from_bits(k);
        }
        let contact = self.contact.read();
        self.last = burr_contact(contact, position, live.radius, &live.force);
        servo_force(contact, position, live.radius, &mut self.tool, &live.force)
    }

    fn contact(&self) -> Option<LawContact> {
        Some(self.last)
    }
}

/// [`servo_tick`]'s law: the burr's force from a fixed contact plane.
struct PlaneLaw<'a> {
    contact: &'a ContactState,
    params: &'a TickParams,
    tool: ToolState,
    last: LawContact,
}

impl ForceLaw for PlaneLaw<'_> {
    fn force(&mut self, _tick: u64, position: Vec3, _rotation: Quat) -> Vec3 {
        let p = self.params;
        self.last = burr_contact(self.contact, position, p.radius, &p.force);
        servo_force(self.contact, position, p.radius, &mut self.tool, &p.force)
    }

    fn contact(&self) -> Option<LawContact> {
        Some(self.last)
    }
}

/// One burr servo tick: [`servo_io`] with the force from `contact` (the damping state in
/// `st.tool`). Allocation-free and lock-free.
///
/// # Errors
/// A device error (disconnect, NaN refused, ...) is returned after the force was zeroed.
pub fn servo_tick(
    device: &mut dyn HapticDevice,
    workspace: &Workspace,
    params: &TickParams,
    contact: &ContactState,
    ring: &ArrayQueue<ToolSample>,
    st: &mut ServoState,
    tick: u64,
) -> Result<(), DeviceError> {
    let mut law = PlaneLaw {
        contact,
        params,
        tool: st.tool,
        last: LawContact::default(),
    };
    let out = servo_io(device, workspace, &mut law, ring, st, tick);
    st.tool = law.tool;
    out
}

/// One servo tick: read the device, map its pose into the scene through `st.frame`, hand the
/// sample to the simulation, compute the force with `law`, pass it through the passivity
/// observer and controller (`st.passivity`), write it back through the frame.
/// Allocation-free and lock-free when `law` is.
///
/// A non-finite position is counted and still handed to `law` (the laws give it zero force).
///
/// The tick the observer trips, the device's cutoff is cut (direct zero, latch: the
/// watchdog's path); that tick and every later one writes [`ForceCommand::OFF`].
///
/// # Errors
/// A device error (disconnect, NaN refused, ...) is returned after the force was zeroed.
pub fn servo_io(
    device: &mut dyn HapticDevice,
    workspace: &Workspace,
    law: &mut dyn ForceLaw,
    ring: &ArrayQueue<ToolSample>,
    st: &mut ServoState,
    tick: u64,
) -> Result<(), DeviceError> {
    let s = match device.read() {
        Ok(s) => s,
        Err(e) => {
            if device.write(&ForceCommand::OFF).is_ok() {
                st.last_written = 0.0;
            }
            return Err(e);
        }
    };
    let s_buttons = s.buttons;
    let resets = device.position_resets();
    if resets != st.position_resets {
        st.position_resets = resets;
        st.passivity.restart();
    }
    let position = st.frame.to_scene(workspace, s.position);
    let rotation = st.frame.rotation_to_scene(s.rotation);
    st.nonfinite_samples += u64::from(!position.is_finite());
    let sample = ToolSample {
        tick,
        position,
        rotation,
        buttons: s.buttons,
    };
    if ring.push(sample).is_err() {
        st.dropped += 1;
    }
    if let Some(r) = &st.record {
        r.push(sample);
    }
    let f = law.force(tick, position, rotation);
    // The observer works in SI: scene positions over the workspace scale are metres (in the
    // scene's rotated frame, where the power is the device's).
    let s = workspace.scale;
    let to_si = if s.is_finite() && s > 0.0 {
        1.0 / s
    } else {
        1.0
    };
    let contact = law.contact();
    if let Some(c) = contact {
        let d = c.depth * to_si;
        if d.is_finite() {
            st.max_depth_m = st.max_depth_m.max(d);
        }
    }
    // With the drill on the material gives way by design (removal dissipates what the tool
    // pushes into it), so the law's spring is no storage function: the classic form.
    let drilling = s_buttons & tetradrill_core::script::DRILL_ON != 0;
    let storage = contact
        .filter(|_| !drilling)
        .map(|c| c.storage.scaled(to_si));
    let tripped = st.passivity.tripped();
    let f = st.passivity.step(position * to_si, f, storage);
    if st.passivity.tripped() {
        if !tripped {
            if let Some(c) = device.cutoff() {
                let _ = c.cut();
            }
        }
        st.digest.push(Vec3::ZERO);
        st.last_force = Vec3::ZERO;
        device.write(&ForceCommand::OFF)?;
        st.last_written = 0.0;
        return Ok(());
    }
    st.digest.push(f);
    st.max_force = st.max_force.max(f.length());
    st.last_force = f;
    // Scene force to the device frame: back through the camera (the workspace map is a uniform
    // scale and a shift, which leave directions alone).
    let d = st.frame.force_to_device(f);
    let cmd = ForceCommand::force([d.x as f64, d.y as f64, d.z as f64]);
    device.write(&cmd)?;
    st.last_written = d.length();
    Ok(())
}

/// How the simulation task ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SimEnd {
    /// `stop` was set.
    Stopped,
    /// The viewer asked for a reset: rebuild the world and call the task again.
    Reset,
}

/// The simulation task: drains the tool ring, erodes along the swept path (burr positions
/// [`tetradrill_core::servo::DRILL_SPACING`] radii apart, up to [`MAX_SPHERES`] per step), updates the contact plane at
/// the newest position and publishes it, until `stop`. With a `viewer`, it applies the
/// viewer's controls (radius and stiffness also go to the servo through `counters`) and
/// publishes snapshots of the changed surface without ever waiting.
#[allow(clippy::too_many_arguments)]
pub fn simulation_task(
    world: &mut World<'_>,
    params: TickParams,
    ring: &ArrayQueue<ToolSample>,
    contact: &mut triple_buffer::Input<ContactState>,
    status: &mut triple_buffer::Input<SimStatus>,
    stop: &AtomicBool,
    counters: &ServoCounters,
    mut viewer: Option<&mut crate::viewer::publish::SimViewer<'_>>,
) -> SimEnd {
    let mut params = params;
    let mut st = SimStatus::default();
    let mut spheres = [Sphere::default(); MAX_SPHERES];
    let mut paused = false;
    let mut reset_seen: Option<u32> = None;
    let mut last_tool: Option<ToolSample> = None;
    loop {
        if let Some(c) = viewer.as_deref_mut().and_then(|v| v.new_controls()) {
            if reset_seen.is_some_and(|r| r != c.reset) {
                return SimEnd::Reset;
            }
            reset_seen = Some(c.reset);
            params.radius = c.radius;
            params.reach = 0.5 * c.radius;
            params.force.stiffness = c.stiffness;
            params.drill.max_depth = c.max_depth;
            paused = c.paused;
            counters
                .radius_bits
                .store(c.radius.to_bits(), Ordering::Relaxed);
            counters
                .stiffness_bits
                .store(c.stiffness.to_bits(), Ordering::Relaxed);
        }
        let spacing = tetradrill_core::servo::DRILL_SPACING * params.radius;
        let stopping = stop.load(Ordering::Relaxed);
        let mut ns = 0usize;
        let mut latest: Option<ToolSample> = None;
        while let Some(s) = ring.pop() {
            let on = s.buttons & tetradrill_core::script::DRILL_ON != 0 && !paused;
            if on {
                let far = ns == 0 || spheres[ns - 1].center.distance(s.position) >= spacing;
                if far && ns < MAX_SPHERES {
                    spheres[ns] = Sphere {
                        center: s.position,
                        radius: params.radius,
                    };
                    ns += 1;
                } else if far {
                    spheres[MAX_SPHERES - 1].center = s.position;
                }
            }
            latest = Some(s);
        }
        // When stopping with nothing new, one more step at the last position (no erosion)
        // lets the viewer's last snapshot out.
        let last = if stopping && viewer.is_some() {
            last_tool.take()
        } else {
            None
        };
        let Some(tool) = latest.or(last) else {
            if stopping {
                break;
            }
            std::thread::sleep(std::time::Duration::from_micros(200));
            continue;
        };
        last_tool = Some(tool);
        let t0 = now_ns();
        let on = tool.buttons & tetradrill_core::script::DRILL_ON != 0 && !paused;
        if on && ns > 0 && spheres[ns - 1].center != tool.position {
            if ns < MAX_SPHERES {
                ns += 1;
            }
            spheres[ns - 1] = Sphere {
                center: tool.position,
                radius: params.radius,
            };
        }
        let rep = world.simulate_spheres(
            tool.position,
            params.radius,
            params.reach,
            &spheres[..ns],
            &params.drill,
        );
        contact.write(*world.contact());
        let dt = now_ns() - t0;
        st.steps += 1;
        st.last_step_ns = dt;
        st.max_step_ns = st.max_step_ns.max(dt);
        st.removed_volume = world.hierarchy().removed_volume();
        st.hierarchy_nodes = world.hierarchy().node_count();
        st.visible_faces = world.hierarchy().visible_face_count();
        st.saturations = world.saturations().total();
        status.write(st);
        if let Some(v) = viewer.as_deref_mut() {
            v.note_step(world, rep.drill.created + rep.drill.erased > 0);
            let tv = crate::viewer::publish::tool_view(
                world,
                tool.position,
                params.radius,
                counters.force(),
                on,
            );
            if stopping {
                // The last picture must get through: the servo has stopped, waiting is fine.
                let until = now_ns() + 2_000_000_000;
                while !v.publish_now(world, tv, &st, now_ns()) && now_ns() < until {
                    std::thread::sleep(std::time::Duration::from_millis(2));
                }
            } else {
                v.publish(world, tv, &st, now_ns());
            }
        }
        if stopping {
            break;
        }
    }
    SimEnd::Stopped
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

/// Rows the recorder's ring holds: 8 s of servo ticks.
pub const RECORD_RING: usize = 8192;

/// The servo-to-recorder hand-off of `--record`: a bounded lock-free ring of tool samples
/// (crossbeam `ArrayQueue`, allocated when it is made). The servo pushes and never waits: a
/// full ring drops the row and counts it.
#[derive(Debug)]
pub struct RecordRing {
    queue: ArrayQueue<ToolSample>,
    dropped: AtomicU64,
}

impl RecordRing {
    /// A ring of `capacity` rows (at least one).
    pub fn new(capacity: usize) -> Self {
        Self {
            queue: ArrayQueue::new(capacity.max(1)),
            dropped: AtomicU64::new(0),
        }
    }

    /// Hands one sample to the recorder; a full ring drops it and counts it.
    ///
    /// # Bounded work
    /// Constant: one lock-free push, at most one relaxed atomic add; no allocation, no wait.
    pub fn push(&self, sample: ToolSample) {
        if self.queue.push(sample).is_err() {
            self.dropped.fetch_add(1, Ordering::Relaxed);
        }
    }

    /// Takes the oldest row (the recorder's side).
    pub fn pop(&self) -> Option<ToolSample> {
        self.queue.pop()
    }

    /// Rows dropped so far (the ring was full, or a pose was not finite).
    pub fn dropped(&self) -> u64 {
        self.dropped.load(Ordering::Relaxed)
    }
}

/// The header of a trace CSV (DESIGN section 4).
pub const TRACE_HEADER: &str = "t,x,y,z,qw,qx,qy,qz,buttons";

/// The recorder task (`--record FILE`, normal priority): until `stop` is set and the ring is
/// empty, drains `ring` every 10 ms and writes each sample as a row of a trace CSV to `out`:
/// the servo tick's time (tick / 1000 s, written exactly), the tool pose the servo used (mesh
/// units, scene frame: what the simulation drilled) and the buttons. `replay --trace` reads the
/// file back. A sample whose pose is not finite is left out and counted with the ring's
/// dropped rows. Returns the rows written.
///
/// # Errors
/// The first write error (the task stops there; the servo goes on, its later rows are counted
/// as dropped when the ring fills).
pub fn recorder_task<W: std::io::Write>(
    ring: &RecordRing,
    out: W,
    stop: &AtomicBool,
) -> std::io::Result<u64> {
    use std::io::Write as _;
    let mut out = std::io::BufWriter::new(out);
    writeln!(out, "{TRACE_HEADER}")?;
    let mut rows = 0u64;
    loop {
        let stopping = stop.load(Ordering::Acquire);
        while let Some(s) = ring.pop() {
            let [x, y, z] = s.position.to_array();
            let [qx, qy, qz, qw] = s.rotation.to_array();
            if !(s.position.is_finite() && s.rotation.is_finite()) {
                ring.dropped.fetch_add(1, Ordering::Relaxed);
                continue;
            }
            writeln!(
                out,
                "{}.{:03},{x},{y},{z},{qw},{qx},{qy},{qz},{}",
                s.tick / 1000,
                s.tick % 1000,
                s.buttons
            )?;
            rows += 1;
        }
        if stopping {
            break;
        }
        out.flush()?;
        std::thread::sleep(std::time::Duration::from_millis(10));
    }
    out.flush()?;
    Ok(rows)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rot_z(a: f32) -> [f32; 16] {
        let (s, c) = a.sin_cos();
        let mut m = IDENTITY;
        m[0] = c;
        m[1] = s;
        m[4] = -s;
        m[5] = c;
        m
    }

    #[test]
    fn the_default_frame_is_exactly_the_workspace_map() {
        let ws = Workspace {
            scale: 2.5,
            offset: Vec3::new(1.0, -2.0, 0.25),
        };
        let f = DeviceFrame::new(Vec3::new(7.0, 8.0, 9.0));
        assert!(f.is_identity());
        for p in [[0.0, 0.0, 0.0], [-0.0, 0.1, -0.3], [1e-3, -7.0, 2.0]] {
            let a = f.to_scene(&ws, p);
            let b = ws.to_mesh(p);
            assert_eq!(
                a.to_array().map(f32::to_bits),
                b.to_array().map(f32::to_bits)
            );
        }
        let force = Vec3::new(-0.0, 1.5, -2.0);
        assert_eq!(f.force_to_device(force), force);
    }

    #[test]
    fn only_finite_proper_rotations_are_taken() {
        let mut f = DeviceFrame::default();
        let turn = rot_z(0.5);
        assert!(f.set_camera(&turn));
        let mut zoom = turn;
        for v in &mut zoom[..11] {
            *v *= 1.5;
        }
        let mut shifted = turn;
        shifted[12] = 0.5;
        let mut mirror = turn;
        mirror[10] = -1.0;
        let mut nan = turn;
        nan[5] = f32::NAN;
        for bad in [zoom, shifted, mirror, nan, [0.0; 16]] {
            assert!(!f.set_camera(&bad), "{bad:?}");
            assert_eq!(f.camera(), turn, "the old camera stays");
        }
        assert!(f.set_camera(&IDENTITY));
        assert!(f.is_identity());
    }

    #[test]
    fn the_frame_turns_about_its_pivot() {
        let pivot = Vec3::new(10.0, -4.0, 3.0);
        let mut f = DeviceFrame::new(pivot);
        assert!(f.set_camera(&rot_z(std::f32::consts::FRAC_PI_2)));
        let ws = Workspace {
            scale: 1.0,
            offset: Vec3::ZERO,
        };
        // The pivot stays; a point 1 along +x from it goes 1 along +y from it.
        let p = f.to_scene(&ws, [10.0, -4.0, 3.0]);
        assert!((p - pivot).length() < 1e-5, "{p}");
        let q = f.to_scene(&ws, [11.0, -4.0, 3.0]);
        assert!((q - (pivot + Vec3::Y)).length() < 1e-5, "{q}");
        // A force along +y in the scene is a force along +x at the device.
        let d = f.force_to_device(Vec3::Y);
        assert!((d - Vec3::X).length() < 1e-6, "{d}");
    }
}
