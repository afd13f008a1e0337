//! The tasks of a real-time run, declared in one place (RTIC style), and the pipeline that runs
//! them.
//!
//! | task       | priority                 | period              | reads                          | writes                          |
//! |------------|--------------------------|---------------------|--------------------------------|---------------------------------|
//! | servo      | SCHED_FIFO 80, last core | 1 ms, absolute      | device, `ContactState` (triple buffer) | force to device, `ToolSample` ring |
//! | simulation | normal                   | as fast as it can   | `ToolSample` ring              | `ContactState`, `SimStatus` (triple buffers) |
//! | status     | normal                   | 250 ms              | `SimStatus`, servo counters (atomics) | the status line          |
//! | viewer     | normal, the main thread  | about 60 Hz         | `Snapshot` queue, servo counters | `Controls` (triple buffer) |
//!
//! Hand-offs are lock-free and allocation-free after start-up: the servo pushes every tick's
//! tool sample into a bounded SPSC ring (crossbeam `ArrayQueue`; a full ring drops the sample
//! and counts it) so the simulation sees the whole swept path even when it runs slower; the
//! simulation publishes its latest contact plane and status through triple buffers, which the
//! servo and the status task read without ever waiting. When the simulation is slower than the
//! servo, the servo keeps computing the force from the last contact plane at the tool's current
//! position: the extrapolation of seed 001 section 3.3.

use std::sync::atomic::{AtomicBool, AtomicU32, AtomicU64, Ordering};
use std::sync::Arc;

use crossbeam::queue::ArrayQueue;
use tetradrill_core::drill::Sphere;
use tetradrill_core::force::{ForceDigest, ToolState};
use tetradrill_core::servo::{servo_force, ContactState, World};
use tetradrill_core::Vec3;
use tetradrill_device::{DeviceError, ForceCommand, HapticDevice};

use crate::engine::TickParams;
use crate::platform::now_ns;
use crate::rt::{Periodic, RtConfig, RtStatus};

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
pub const TASKS: [TaskDecl; 4] = [
    TaskDecl {
        name: "servo",
        priority: "SCHED_FIFO 80, pinned to the last core, memory locked",
        period: "1 ms on absolute deadlines",
        reads: "device sample; ContactState (triple buffer)",
        writes: "force command to the device; ToolSample (SPSC ring); servo counters (atomics)",
    },
    TaskDecl {
        name: "simulation",
        priority: "normal",
        period: "as fast as it can, at most once per servo tick",
        reads: "ToolSample (SPSC ring); Controls (triple buffer)",
        writes: "ContactState, SimStatus (triple buffers); Snapshot queue (refuses when full)",
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
        writes: "Controls (triple buffer)",
    },
];

/// The servo's period.
pub const SERVO_PERIOD_NS: u64 = 1_000_000;

/// Tool samples the ring holds: 1 s of servo ticks.
pub const TOOL_RING: usize = 1000;

/// Most burr positions one simulation step erodes along the swept path.
pub const MAX_SPHERES: usize = 16;

/// A tool sample handed from the servo to the simulation.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct ToolSample {
    /// Servo tick.
    pub tick: u64,
    /// Tool centre, mesh units.
    pub position: Vec3,
    /// Buttons (bit 0 = drill on).
    pub buttons: u32,
}

/// What the simulation publishes for the status line and the summary.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct SimStatus {
    /// Simulation steps done.
    pub steps: u64,
    /// Removed volume.
    pub removed_volume: f64,
    /// Hierarchy nodes.
    pub hierarchy_nodes: usize,
    /// Visible faces.
    pub visible_faces: u32,
    /// Saturations so far, all kinds.
    pub saturations: u32,
    /// Last step's compute time, ns.
    pub last_step_ns: u64,
    /// Longest step, ns.
    pub max_step_ns: u64,
}

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
    /// Wake-up latency histogram (see [`wake_bucket`]).
    pub wake_hist: [AtomicU64; WAKE_BUCKETS],
    /// Largest wake-up latency of the run, ns.
    pub wake_max_ns: AtomicU64,
    /// Largest wake-up latency of the last complete second, ns.
    pub wake_recent_max_ns: AtomicU64,
    /// Burr radius the servo uses, f32 bits; 0 = the scenario's (set from the viewer's
    /// controls by the simulation task).
    pub radius_bits: AtomicU32,
    /// Stiffness the servo uses, f32 bits; 0 = the scenario's.
    pub stiffness_bits: AtomicU32,
}

/// Buckets of the wake-up latency histogram the servo keeps in atomics.
pub const WAKE_BUCKETS: usize = 32;

/// The histogram bucket of a wake-up latency: 4 us wide up to 96 us, then 96-128, 128-192,
/// 192-256, 256-512, 512-1000, 1000-2000, 2000-5000 us and the rest.
pub fn wake_bucket(ns: u64) -> usize {
    let us = ns / 1000;
    match us {
        0..=95 => (us / 4) as usize,
        96..=127 => 24,
        128..=191 => 25,
        192..=255 => 26,
        256..=511 => 27,
        512..=999 => 28,
        1000..=1999 => 29,
        2000..=4999 => 30,
        _ => 31,
    }
}

/// The upper edge of bucket `b`, microseconds (the last bucket's is unbounded: infinity).
pub fn wake_bucket_upper_us(b: usize) -> f64 {
    const EDGES: [f64; 8] = [
        128.0,
        192.0,
        256.0,
        512.0,
        1000.0,
        2000.0,
        5000.0,
        f64::INFINITY,
    ];
    if b < 24 {
        4.0 * (b + 1) as f64
    } else {
        EDGES[(b - 24).min(7)]
    }
}

impl ServoCounters {
    /// Counts one wake-up latency (atomics only: no allocation, no lock).
    pub fn record_wake(&self, ns: u64, tick: u64, window_max: &mut u64) {
        self.wake_hist[wake_bucket(ns)].fetch_add(1, Ordering::Relaxed);
        self.wake_max_ns.fetch_max(ns, Ordering::Relaxed);
        *window_max = (*window_max).max(ns);
        if tick % 1000 == 999 {
            self.wake_recent_max_ns
                .store(*window_max, Ordering::Relaxed);
            *window_max = 0;
        }
    }

    /// The wake-up latency percentile `q` (0..1) from the histogram, as the upper edge of its
    /// bucket in microseconds (`None` before the first tick).
    pub fn wake_percentile_us(&self, q: f64) -> Option<f64> {
        let counts: Vec<u64> = self
            .wake_hist
            .iter()
            .map(|c| c.load(Ordering::Relaxed))
            .collect();
        let total: u64 = counts.iter().sum();
        if total == 0 {
            return None;
        }
        let want = (q * total as f64).ceil().max(1.0) as u64;
        let mut seen = 0;
        for (b, c) in counts.iter().enumerate() {
            seen += c;
            if seen >= want {
                return Some(wake_bucket_upper_us(b));
            }
        }
        Some(f64::INFINITY)
    }

    /// The last force vector.
    pub fn force(&self) -> Vec3 {
        let f = |i: usize| f32::from_bits(self.force_xyz[i].load(Ordering::Relaxed));
        Vec3::new(f(0), f(1), f(2))
    }
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

/// What the servo task measured, returned when it ends.
#[derive(Debug)]
pub struct ServoResult {
    /// Real-time settings achieved.
    pub rt: RtStatus,
    /// Wake-up latency per tick, ns.
    pub wake_ns: Vec<u64>,
    /// Compute time per tick, ns.
    pub tick_ns: Vec<u64>,
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
}

/// The servo task: `ticks` ticks at 1 kHz, or until `stop`. Everything it needs is allocated
/// before its loop; the loop neither allocates nor locks (the allocation-counting test runs
/// [`servo_tick`], the loop's body).
#[allow(clippy::too_many_arguments)]
pub fn servo_task(
    device: &mut dyn HapticDevice,
    rt: RtConfig,
    ticks: u64,
    workspace: Workspace,
    params: TickParams,
    contact: &mut triple_buffer::Output<ContactState>,
    ring: &ArrayQueue<ToolSample>,
    counters: &ServoCounters,
    stop: &AtomicBool,
) -> ServoResult {
    let rt = rt.apply();
    let n = ticks as usize;
    let mut wake_ns = vec![0u64; n];
    let mut tick_ns = vec![0u64; n];
    let mut state = ServoState::default();
    let mut timer = Periodic::new(SERVO_PERIOD_NS, 0);
    let mut error = None;
    let mut done = 0u64;
    let mut live = params;
    let mut window_max = 0u64;
    while done < ticks && !stop.load(Ordering::Relaxed) {
        let w = timer.wait();
        let t0 = now_ns();
        // The viewer's controls (0: the scenario's value).
        let r = counters.radius_bits.load(Ordering::Relaxed);
        live.radius = if r == 0 {
            params.radius
        } else {
            f32::from_bits(r)
        };
        let k = counters.stiffness_bits.load(Ordering::Relaxed);
        live.force.stiffness = if k == 0 {
            params.force.stiffness
        } else {
            f32::from_bits(k)
        };
        let out = servo_tick(
            device,
            &workspace,
            &live,
            contact.read(),
            ring,
            &mut state,
            done,
        );
        let i = done as usize;
        counters.record_wake(w.latency_ns, done, &mut window_max);
        for (a, v) in counters.force_xyz.iter().zip(state.last_force.to_array()) {
            a.store(v.to_bits(), Ordering::Relaxed);
        }
        wake_ns[i] = w.latency_ns;
        tick_ns[i] = now_ns() - t0;
        done += 1;
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
            break;
        }
    }
    // Leave the device safe: force off, whatever happened.
    let _ = device.write(&ForceCommand::OFF);
    stop.store(true, Ordering::Relaxed);
    wake_ns.truncate(done as usize);
    tick_ns.truncate(done as usize);
    ServoResult {
        rt,
        wake_ns,
        tick_ns,
        ticks: done,
        overruns: timer.overruns,
        digest: state.digest,
        max_force: state.max_force,
        error,
    }
}

/// What the servo carries from tick to tick.
#[derive(Debug, Default)]
pub struct ServoState {
    /// Damping state.
    pub tool: ToolState,
    /// Digest of the forces.
    pub digest: ForceDigest,
    /// Largest force.
    pub max_force: f32,
    /// Last force.
    pub last_force: Vec3,
    /// Tool samples dropped (ring full).
    pub dropped: u64,
}

/// One servo tick: read the device, hand the sample to the simulation, compute the force from
/// the latest contact plane, write it. Allocation-free and lock-free.
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
    let s = match device.read() {
        Ok(s) => s,
        Err(e) => {
            let _ = device.write(&ForceCommand::OFF);
            return Err(e);
        }
    };
    let position = workspace.to_mesh(s.position);
    if ring
        .push(ToolSample {
            tick,
            position,
            buttons: s.buttons,
        })
        .is_err()
    {
        st.dropped += 1;
    }
    let f = servo_force(
        contact,
        position,
        params.radius,
        &mut st.tool,
        &params.force,
    );
    st.digest.push(f);
    st.max_force = st.max_force.max(f.length());
    st.last_force = f;
    // Mesh-space force to the device frame: the workspace map is a uniform scale and a shift.
    let cmd = ForceCommand::force([f.x as f64, f.y as f64, f.z as f64]);
    device.write(&cmd)
}

/// How the simulation task ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SimEnd {
    /// `stop` was set.
    Stopped,
    /// The viewer asked for a reset: rebuild the world and call the task again.
    Reset,
}

/// The simulation task: drains the tool ring, erodes along the swept path (burr positions at
/// most a quarter radius apart, up to [`MAX_SPHERES`] per step), updates the contact plane at
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
        let spacing = 0.25 * params.radius;
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
