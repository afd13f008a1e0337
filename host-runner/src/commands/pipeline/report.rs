//! What a run reports: the JSON's structure (`RunReport` and its parts) and the summary printed
//! at the end.

use serde::Serialize;

use crate::commands::replay::{DebrisSummary, SaturationCounts, TickTiming};
use crate::stats::Summary;

/// The summary of a real-time run (`--json`).
#[derive(Debug, Serialize)]
pub struct RunReport {
    /// Device used.
    pub device: String,
    /// Why the run ended: `duration` (its ticks were done), `signal` (a stop request: SIGINT,
    /// SIGTERM, SIGHUP or a caller), `window` (the live window closed), `device_error`.
    pub stop_reason: &'static str,
    /// The signal that asked for the stop (`SIGINT`, `SIGTERM`, `SIGHUP`), if one did.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub stop_signal: Option<String>,
    /// After a stop request: microseconds from the request to the end of the zero-force write.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub stop_to_zero_force_us: Option<f64>,
    /// The force commands written to the device.
    pub force: RunForce,
    /// The passivity observer and controller on the servo path.
    pub safety: RunSafety,
    /// The tool's contact.
    pub contact: RunContact,
    /// Rows `--record` wrote to its trace.
    pub recorded_rows: u64,
    /// Rows `--record` could not take (its ring was full, or a pose was not finite).
    pub dropped_rows: u64,
    /// Servo ticks done.
    pub ticks: u64,
    /// Deadlines missed by more than a period.
    pub overruns: u64,
    /// Wall time of the run, seconds.
    pub duration_s: f64,
    /// Volume of the mesh before drilling.
    pub initial_volume: f64,
    /// Removed volume (sum of erased leaves).
    pub removed_volume: f64,
    /// The removed volume by region label (each leaf counts for its root tet's label); the
    /// values sum to `removed_volume`. Absent for a mesh tool.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub removed_by_region: Option<std::collections::BTreeMap<String, f64>>,
    /// Debris (detached pieces smaller than `tetradrill_core::hierarchy::DEBRIS_LEAVES`
    /// max-depth leaves) the drill's checks erased while the run drilled; its volume is in
    /// `removed_volume`. A run ends as the user left it: no final sweep (`final_sweep` is 0;
    /// `replay` sweeps).
    pub debris_erased: DebrisSummary,
    /// Hierarchy nodes at the end.
    pub hierarchy_nodes: usize,
    /// Visible faces at the end.
    pub visible_faces: u32,
    /// Simulation steps done.
    pub simulation_steps: u64,
    /// Simulation rate, steps per second.
    pub simulation_hz: f64,
    /// Longest simulation step, microseconds.
    pub simulation_step_max_us: f64,
    /// Tool samples the simulation could not take (ring full).
    pub dropped_samples: u64,
    /// Device samples with a NaN or infinite position (the force was zero on those ticks).
    pub nonfinite_samples: u64,
    /// Stalls the watchdog caught (the servo went more than 10 ms without a tick; the force
    /// was set to zero and ramped up again when it ran again).
    pub servo_stalls: u64,
    /// The longest of them (the longest time the servo went without ending a tick), milliseconds.
    pub servo_stall_max_ms: f64,
    /// Saturations by kind, and their total.
    pub saturations: SaturationCounts,
    /// The final state passed the core's `validate()` (mesh and hierarchy).
    pub valid: bool,
    /// Largest force, newtons.
    pub force_max_n: f32,
    /// Digest of the servo's force series (hex).
    pub force_digest: String,
    /// Servo tick compute times, microseconds (from the servo's fixed-bucket histogram: the
    /// mean and max exact, percentiles within 125 ns or 1/128 above the exact ones).
    pub timing_us: RunTiming,
    /// Servo wake-up latency, microseconds (the same histogram as the status line's).
    pub wake_us: Summary,
    /// Wake-up latency histogram, 1 us buckets, the last is the overflow bucket.
    pub wake_histogram_us: Vec<u64>,
    /// Real-time settings achieved.
    pub realtime: crate::commands::timing::RealtimeReport,
    /// A mesh tool's contact (`--tool mesh:FILE` only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub pen: Option<PenRunSummary>,
    /// A drill's shaft (`--tool drill:...` only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub shaft: Option<RunShaft>,
    /// The soft body (`--body soft` only): its largest displacement, step time (the physics
    /// step with the world's update) and the rate it reached in real time.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub deform: Option<crate::soft::DeformSummary>,
}

/// A drill's shaft over a real-time run: `replay`'s `shaft` figures, counted by the servo over
/// its ticks from the planes the simulation handed it, and the ticks its springs pushed.
#[derive(Debug, Clone, Copy, Default, Serialize)]
pub struct RunShaft {
    /// Passive points along the shaft.
    pub passive_points: usize,
    /// Servo ticks in which a passive point had a contact plane (a face within reach, or
    /// held).
    pub near_ticks: u64,
    /// Servo ticks in which a passive point was held at a face it had crossed.
    pub held_ticks: u64,
    /// Most passive points held in one tick.
    pub held_max: u32,
    /// Servo ticks in which a passive point's spring pushed (the shaft touching).
    pub pushing_ticks: u64,
}

/// A mesh tool's figures in a real-time run: the contact task's passes and what the servo
/// carried from them.
#[derive(Debug, Default, Serialize)]
pub struct PenRunSummary {
    /// Tool nodes.
    pub tool_nodes: usize,
    /// Tool tets.
    pub tool_tets: usize,
    /// Depth method used.
    pub depth_method: String,
    /// The entry-plane remedy was on (`--entry-remedy`).
    pub entry_remedy: bool,
    /// Threads of a contact pass (`--pass-threads`).
    pub pass_threads: u32,
    /// Contact passes run (the simulation task's steps).
    pub passes: u64,
    /// Time of the contact passes, microseconds.
    pub pass_us: TickTiming,
    /// Servo ticks that carried a pass (every tick after the first pass).
    pub carried_ticks: u64,
    /// Age of the pass a servo tick carried (servo ticks since the tool sample the pass was
    /// run at), mean over the carried ticks.
    pub pass_age_mean_ticks: f64,
    /// The oldest pass a servo tick carried, servo ticks.
    pub pass_age_max_ticks: u64,
    /// Most tool nodes inside the object in one pass.
    pub pen_collisions_max: usize,
    /// Most object nodes inside the tool in one pass.
    pub object_collisions_max: usize,
    /// Colliding nodes that got no depth (a region without a border edge), summed over passes.
    pub unreached: u64,
    /// Passes in which a buffer saturated.
    pub saturated_passes: u64,
    /// Servo ticks whose force was clamped.
    pub clamped_ticks: u64,
    /// Servo ticks that could not carry every held penetration (left out of the force).
    pub servo_short_ticks: u64,
    /// Servo ticks whose pose (position or rotation) was not finite: zero force.
    pub nonfinite_ticks: u64,
}

/// The force commands of a run.
#[derive(Debug, Clone, Copy, Default, Serialize)]
pub struct RunForce {
    /// Magnitude of the last force command the device took, newtons: 0 after a clean stop.
    pub last_written_n: f32,
}

/// The passivity observer and controller of a run ([`tetradrill_core::force::PassivityObserver`]),
/// and the device's checks.
#[derive(Debug, Clone, Default, Serialize)]
pub struct RunSafety {
    /// Times it tripped (each trip cuts the motors until the tool has been out of contact for
    /// a second).
    pub passivity_trips: u32,
    /// Of those, the trips of the force-sign probe (`tasks::SignProbe`): the device's response
    /// to a small probe force ran against the force (a reversed force or a mirrored axis).
    pub probe_trips: u32,
    /// The probe's least sign statistic with a full enough window (0 before; below
    /// `-tasks::TRIP_Z` it trips).
    pub probe_z_min: f64,
    /// Times the force came back after a trip (the tool out of contact for a second, the
    /// force ramped back in).
    pub trip_recoveries: u32,
    /// Too many trips came within a minute: the motors stayed off for the rest of the run.
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub trips_locked_out: bool,
    /// Seconds the device's continuous-force (thermal) model derated the force below its peak.
    pub derated_s: f64,
    /// Energy its damper dissipated, joules.
    pub dissipated_j: f64,
    /// The largest energy the rendered environment had generated at a tick (before the
    /// damper took it), joules.
    pub generated_j_max: f64,
    /// The largest energy the force law stored past its force limit since its contact began
    /// (the trip's measure; for a mesh tool, whose law has no storage function, the generated
    /// energy, observed only), joules.
    pub past_limit_j_max: f64,
    /// The servo tick the force was armed: the first with the device ready and the tool
    /// outside the solid (a real device or a simulated model; absent when it never was, and
    /// for the plain simulated device, which renders from the start).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub armed_at_tick: Option<u64>,
    /// The joints the motor-sign self-test found reversed, 1-based: the run rendered no force.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub reversed_joints: Vec<u8>,
    /// The scene asked for a stiffness past the device's maximum stable one: what it asked and
    /// what was used.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub stiffness_capped: Option<StiffnessCap>,
    /// The scene's damping at the device, checked against the device's range (a real device
    /// or a simulated model).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub damping: Option<DampingCheck>,
    /// The scene asked for a peak force past the device's: the peak used, newtons.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_force_capped_n: Option<f64>,
    /// Warnings the device's vendor library reported (the Touch's force warnings,
    /// `HD_WARM_MOTORS` among them); the run went on through them, the force ramping in again
    /// after each.
    #[serde(skip_serializing_if = "is_zero")]
    pub library_warnings: u64,
    /// The last of those warnings, by name.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub library_warning_last: Option<&'static str>,
}

fn is_zero(n: &u64) -> bool {
    *n == 0
}

/// The scene's damping at the device against the device's range.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct DampingCheck {
    /// What the scene asked for, N s/m at the device (its damping times the workspace scale).
    pub asked_n_s_per_m: f64,
    /// What was used, N s/m: the device's maximum stable damping when the scene asked for
    /// more.
    pub used_n_s_per_m: f64,
    /// The device's maximum stable damping, N s/m.
    pub max_n_s_per_m: f64,
}

/// A stiffness capped at the device's maximum stable stiffness (N/m at the device: the scene's
/// stiffness times the workspace's scale).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct StiffnessCap {
    /// What the scene asked for, N/m at the device.
    pub asked_n_per_m: f64,
    /// What was used: the device's maximum, N/m.
    pub used_n_per_m: f64,
    /// The scene stiffness used, N per mesh unit.
    pub scene_stiffness: f64,
}

/// The tool's contact over a run.
#[derive(Debug, Clone, Copy, Default, Serialize)]
pub struct RunContact {
    /// The deepest penetration of the tool's contact point (the burr's depth below the
    /// contact plane), metres; 0 for a mesh tool; for a drill, over the ticks no passive point
    /// of its shaft pushed.
    pub max_depth_m: f64,
}

/// Servo tick timing.
#[derive(Debug, Serialize)]
pub struct RunTiming {
    /// Mean.
    pub tick_mean: f64,
    /// 99th percentile.
    pub tick_p99: f64,
    /// 99.9th percentile.
    pub tick_p999: f64,
    /// Largest.
    pub tick_max: f64,
}

pub(super) fn print_summary(r: &RunReport) {
    outln!(
        "{} ticks in {:.2} s on the {} device, {} overruns",
        r.ticks,
        r.duration_s,
        r.device,
        r.overruns
    );
    outln!(
        "servo tick us: mean {:.1}  p99 {:.1}  max {:.1};  wake-up us: p50 {:.1}  p99 {:.1}  p99.9 {:.1}  max {:.1}",
        r.timing_us.tick_mean,
        r.timing_us.tick_p99,
        r.timing_us.tick_max,
        r.wake_us.p50,
        r.wake_us.p99,
        r.wake_us.p999,
        r.wake_us.max
    );
    outln!(
        "simulation: {} steps ({:.0} Hz), longest {:.0} us;  removed volume {} of {} ({:.2}%)",
        r.simulation_steps,
        r.simulation_hz,
        r.simulation_step_max_us,
        crate::stats::volume_text(r.removed_volume, r.initial_volume),
        crate::stats::volume_text(r.initial_volume, r.initial_volume),
        100.0 * r.removed_volume / r.initial_volume.max(f64::MIN_POSITIVE)
    );
    outln!(
        "hierarchy nodes {}, visible faces {}, saturations {}, dropped samples {}, force max {:.2} N",
        r.hierarchy_nodes, r.visible_faces, r.saturations, r.dropped_samples, r.force_max_n
    );
    outln!(
        "passivity: {} trips, dissipated {:.6} J, generated max {:.6} J; deepest contact {:.4} m",
        r.safety.passivity_trips,
        r.safety.dissipated_j,
        r.safety.generated_j_max,
        r.contact.max_depth_m
    );
    if let Some(s) = &r.shaft {
        outln!(
            "shaft: {} passive points; touching {} ticks, a point within reach {} ticks, held {} ticks (at most {} points)",
            s.passive_points, s.pushing_ticks, s.near_ticks, s.held_ticks, s.held_max
        );
    }
    if let Some(d) = &r.deform {
        outln!("{}", d.line());
    }
    if r.servo_stalls > 0 {
        outln!(
            "servo stalls {} (longest {:.1} ms): the watchdog set the force to zero each time",
            r.servo_stalls,
            r.servo_stall_max_ms
        );
    }
    for w in r.saturations.warnings(r.ticks) {
        errln!("tetradrill: warning: {w}");
    }
}
