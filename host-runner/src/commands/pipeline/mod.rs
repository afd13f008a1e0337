//! The real-time pipeline shared by `run` and `demo`: the tasks of [`crate::tasks`] on their
//! threads, a live status line, and the summary at the end.
//!
//! The servo runs under a panic guard and a watchdog ([`crate::watchdog`]): a servo that
//! stalls past the watchdog time has its force zeroed by the watchdog thread (one warning line,
//! the run goes on: exit status 0, `servo_stalls` in the JSON); a servo that panics has its
//! force zeroed and ends the run with one line and exit status 1.
//!
//! A run ends when its ticks are done (`--duration`, a trace's length; [`UNTIL_STOPPED`]: no
//! end), when the live window closes, when its device fails, or on a [`StopRequest`] (the
//! signal handlers of `run` and `demo` raise it): the servo tick that sees the request writes
//! zero force, then the tasks stop, the summary and the JSON are written and the device is
//! released. `stop_reason` in the JSON says which.

use std::path::PathBuf;
use std::sync::atomic::Ordering;

use tetradrill_core::servo::ContactState;
use tetradrill_core::Vec3;
use tetradrill_device::{DeviceError, DeviceKind, HapticDevice};

use crate::commands::replay::{DebrisSummary, SaturationCounts};
use crate::engine::{self, EngineStorage, TickParams};
use crate::error::CliError;
use crate::meshio::LoadedMesh;
use crate::rt::RtConfig;
use crate::setup::{Setup, Tool};
use crate::tasks::{self, Shared, SimStatus, Workspace};
use crate::watchdog::StopRequest;

mod pen;
mod report;
mod threads;

use pen::run_pen;
pub use report::*;
use threads::*;

/// Ticks of a run without an end of its own: it runs until the window closes, a stop request
/// (a signal) or a device error.
pub const UNTIL_STOPPED: u64 = u64::MAX;

/// Opens the device on the servo thread (a device handle need not be `Send`).
pub type DeviceFactory = Box<dyn FnOnce() -> Result<Box<dyn HapticDevice>, DeviceError> + Send>;

/// The outputs `run` and `demo` take besides the summary and JSON: a picture at the end, a
/// clip plane, the burr's sound as a file or live.
#[derive(Debug, Clone, Default, clap::Args)]
pub struct RunOutputs {
    /// Write a PNG of the view at the end of the run (no display needed).
    #[arg(long)]
    pub screenshot: Option<PathBuf>,
    /// Write the burr's sound (its whine falling under load, its grinding) as a WAV file at
    /// the end.
    #[arg(long, value_name = "FILE.wav")]
    pub audio_out: Option<PathBuf>,
    /// Play the burr's sound live on the default output device (a build with the `sound`
    /// feature; without a device, one line and the run goes on).
    #[arg(long)]
    pub sound: bool,
    /// Cut the view open with a plane across an axis: `x`, `y` or `z` (through the tool's
    /// work area), or `x:AT` (at that coordinate); the section shows the regions. The window's
    /// `C` key toggles it.
    #[arg(long, value_name = "AXIS[:AT]", value_parser = crate::viewer::ClipSpec::parse)]
    pub clip: Option<crate::viewer::ClipSpec>,
}

impl RunOutputs {
    /// The view these ask for (`headless`: no window).
    ///
    /// # Errors
    /// `--screenshot` or `--sound` in a build without the feature they need (exit 2).
    pub fn view(&self, headless: bool) -> Result<crate::viewer::ViewOptions, CliError> {
        crate::audio::check_sound_flag(self.sound)?;
        let mut view = crate::viewer::ViewOptions::of(headless, self.screenshot.clone())?;
        view.clip = self.clip;
        Ok(view)
    }
}

/// Everything a pipeline run needs besides the scenario.
pub struct PipelineSetup {
    /// Which device (for messages).
    pub kind: DeviceKind,
    /// Opens the device.
    pub open: DeviceFactory,
    /// Servo ticks to run ([`UNTIL_STOPPED`]: no end of its own).
    pub ticks: u64,
    /// Device-to-mesh map.
    pub workspace: Workspace,
    /// Real-time settings of the servo thread.
    pub rt: RtConfig,
    /// Print the live status line.
    pub status_line: bool,
    /// Print the summary on stdout at the end (the report is returned either way).
    pub summary: bool,
    /// Live window and/or screenshot.
    pub view: crate::viewer::ViewOptions,
    /// Ends the run cleanly when raised (zero force within a tick, then the summary).
    pub stop: StopRequest,
    /// Record the tool samples as a trace CSV to this file (`--record`).
    pub record: Option<PathBuf>,
    /// When the servo renders force at all (the arming outside the solid).
    pub gate: tasks::ServoGate,
    /// What the device's checks found before the run: the motor-sign self-test's reversed
    /// joints (filled by the device factory), the stiffness cap.
    pub checks: RunChecks,
    /// Write the burr's sound as a WAV file at the end (`--audio-out`; [`crate::audio`]).
    pub audio_out: Option<PathBuf>,
    /// Play the burr's sound live (`--sound`; the `sound` feature).
    pub sound: bool,
}

/// What the device's checks found, for the report: shared with the device factory, which runs
/// the motor-sign self-test on the servo thread.
#[derive(Debug, Clone, Default)]
pub struct RunChecks {
    /// The joints the motor-sign self-test found reversed (1-based; the run renders no
    /// force); unset when no test ran.
    pub reversed_joints: std::sync::Arc<std::sync::OnceLock<Vec<u8>>>,
    /// The stiffness used when the scene asked for more than the device's maximum.
    pub stiffness_capped: Option<StiffnessCap>,
    /// The scene's damping checked against the device's range.
    pub damping: Option<DampingCheck>,
    /// The peak force used when the scene asked for more than the device's.
    pub max_force_capped_n: Option<f64>,
}

impl PipelineSetup {
    /// The plainest setup for an in-process run (tests, embedding): the device from `open`
    /// moving in mesh units, no real-time settings, no status line, no summary, no view.
    pub fn plain(kind: DeviceKind, open: DeviceFactory, ticks: u64) -> Self {
        Self {
            kind,
            open,
            ticks,
            workspace: MESH_UNITS,
            rt: RtConfig {
                fifo_priority: None,
                core: None,
                lock_memory: false,
            },
            status_line: false,
            summary: false,
            view: crate::viewer::ViewOptions::default(),
            stop: StopRequest::new(),
            record: None,
            gate: tasks::ServoGate {
                arm_on_exit: false,
                sign_probe: true,
            },
            checks: RunChecks::default(),
            audio_out: None,
            sound: false,
        }
    }
}

impl std::fmt::Debug for PipelineSetup {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("PipelineSetup")
            .field("kind", &self.kind)
            .field("ticks", &self.ticks)
            .field("workspace", &self.workspace)
            .field("record", &self.record)
            .finish_non_exhaustive()
    }
}

/// What the simulation task leaves: saturations by kind, the final state's validity, the
/// removed volume by region and the debris erased while drilling.
type SimEnding = (
    SaturationCounts,
    Result<(), String>,
    Option<std::collections::BTreeMap<String, f64>>,
    DebrisSummary,
    Option<crate::soft::DeformSummary>,
);

/// Runs the pipeline of `sc` on its mesh, `loaded` (read once by the caller), with `setup`;
/// returns the report (the device error that ended the run, if any, as an error: exit 2 when
/// the device was not found, 1 when it failed mid-run).
pub fn run(
    sc: &Setup,
    loaded: LoadedMesh,
    setup: PipelineSetup,
    json: Option<&PathBuf>,
) -> Result<RunReport, CliError> {
    let soft = crate::soft::SoftSpec::of(sc)?;
    if let Tool::Mesh { path, scale } = &sc.tool {
        return run_pen(sc, loaded, setup, json, path, *scale);
    }
    let params = TickParams::of(sc)?;
    let mut store = EngineStorage::new(loaded.mesh, sc)?;
    store.set_labels(&loaded.labels, sc)?;
    let mut soft_owned = match soft.as_ref() {
        Some(spec) => Some(store.soft_body(spec, &loaded.labels)?),
        None => None,
    };
    let region_labels = store.region_labels().to_vec();
    let region_colours = engine::region_table(&loaded.labels, &sc.materials)
        .ok()
        .flatten()
        .map(|t| t.colours);
    let (initial_volume, tets, centre, smooth_store, regions_view) = {
        let world = store.world()?;
        (
            world.mesh().volume(),
            world.mesh().tet_count(),
            mesh_centre(world.mesh().positions()),
            // The viewer's smooth normals: storage sized once for the run.
            setup
                .view
                .any()
                .then(|| crate::viewer::smooth_live::SmoothStore::for_world(&world)),
            // The regions' colours and grid, for the viewer only.
            setup.view.any().then(|| {
                crate::viewer::publish::RegionsView::of(
                    world.mesh(),
                    &loaded.labels,
                    region_colours.clone(),
                )
            }),
        )
    };
    let (mut contact_in, mut contact_out) =
        triple_buffer::TripleBuffer::new(&ContactState::default()).split();
    let (mut status_in, status_out) =
        triple_buffer::TripleBuffer::new(&SimStatus::default()).split();
    // A drill's planes: the burr's and its passive points', from the same step.
    let (mut drill_in, mut drill_out) =
        triple_buffer::TripleBuffer::new(&tasks::DrillContact::default()).split();
    let shared = Shared::new();
    let PipelineSetup {
        kind,
        open,
        ticks,
        workspace,
        rt,
        status_line,
        summary,
        view,
        stop: request,
        record,
        gate,
        checks,
        audio_out,
        sound,
    } = setup;
    let recorder = Recorder::open(record.as_deref())?;
    let started = std::time::Instant::now();
    let initial_controls = crate::viewer::handoff::Controls {
        radius: params.radius,
        stiffness: params.force.stiffness,
        max_depth: params.drill.max_depth,
        paused: false,
        reset: 0,
    };
    let (controls_in, controls_out) = crate::viewer::handoff::controls(initial_controls);
    // The camera C: from the live window to the servo (egocentric device frame). Without a
    // window the servo keeps the identity frame.
    let (camera_in, mut camera_out) = tasks::camera_handoff();
    let frame = tasks::DeviceFrame::new(centre);

    let mut law = match params.shaft {
        Some(tool) => tasks::DrillingLaw::Drill(tasks::DrillLaw::new(
            params,
            tool,
            &mut drill_out,
            &shared.counters,
        )),
        None => tasks::DrillingLaw::Burr(tasks::BurrLaw::new(
            params,
            &mut contact_out,
            &shared.counters,
        )),
    };
    let (servo, sim_status, ending, scene) = std::thread::scope(|scope| -> Result<_, CliError> {
        let sh = &shared;
        let any_view = view.any();
        let sim = std::thread::Builder::new()
            .name(tasks::SIMULATION.name.into())
            .spawn_scoped(scope, move || -> Result<SimEnding, CliError> {
                let mut smooth_store = smooth_store;
                let mut link = any_view.then(|| {
                    let mut l = crate::viewer::publish::SimViewer::new(
                        &sh.snapshots,
                        Some(controls_out),
                        tets,
                    );
                    l.set_initial_volume(initial_volume);
                    if let Some(r) = regions_view {
                        l.set_regions_view(r);
                    }
                    if let Some(st) = smooth_store.as_mut() {
                        l.set_smooth_store(st);
                    }
                    l
                });
                loop {
                    // The world is rebuilt, untouched, when the viewer asks for a reset (the
                    // shaft's points tracked anew).
                    let mut world = store.world()?;
                    let shaft = params
                        .shaft
                        .map(|t| tasks::ShaftLink::new(t, &mut drill_in));
                    // A reset starts the soft body at rest too.
                    let mut body = match (soft.as_ref(), soft_owned.as_mut()) {
                        // Beside the servo's thread: a second step thread only where a core
                        // is left for it.
                        (Some(s), Some(o)) => Some(
                            crate::soft::SoftDriver::new(o, s)?
                                .with_threads(crate::soft::step_threads(2)),
                        ),
                        _ => None,
                    };
                    let begun = std::time::Instant::now();
                    let end = tasks::simulation_task_soft(
                        &mut world,
                        params,
                        &sh.ring,
                        &mut contact_in,
                        &mut status_in,
                        &sh.stop,
                        &sh.counters,
                        link.as_mut(),
                        shaft,
                        body.as_mut(),
                    );
                    match end {
                        tasks::SimEnd::Stopped => {
                            // The final state: saturations by kind, and the core's validate().
                            let sat = SaturationCounts::from(world.saturations());
                            let by_region = engine::removed_by_region(&world, &region_labels);
                            let debris = DebrisSummary::during(world.debris());
                            // In real time: the rate the body reached.
                            let deform = body.as_ref().map(|b| {
                                let d = b.summary();
                                crate::soft::DeformSummary {
                                    rate_hz: d.steps as f64
                                        / begun.elapsed().as_secs_f64().max(1e-9),
                                    ..d
                                }
                            });
                            return Ok((sat, engine::validate(&world), by_region, debris, deform));
                        }
                        tasks::SimEnd::Reset => {
                            if let Some(l) = link.as_mut() {
                                l.restart();
                            }
                        }
                    }
                }
            })
            .map_err(|e| CliError::failure(format!("cannot start the simulation task: {e}")))?;
        let servo = spawn_servo(
            scope,
            sh,
            ServoRun {
                open,
                rt,
                ticks,
                workspace,
                frame,
                camera: view.window.then_some(&mut camera_out),
                request: &request,
                record: recorder.ring(),
                gate,
            },
            &mut law,
        )?;
        let supervisor = spawn_watchdog(scope, sh, rt, kind)?;
        let rec = recorder.spawn(scope, sh)?;
        let audio = (audio_out.is_some() || sound)
            .then(|| {
                threads::spawn_audio(
                    scope,
                    sh,
                    crate::audio::BurrSound::default(),
                    audio_out.is_some(),
                    sound,
                )
            })
            .transpose()?;
        let front = Front {
            view: &view,
            status_line,
            initial_volume,
            controls: controls_in,
            initial_controls,
            camera: camera_in,
        };
        let (servo, status, ending, scene) =
            main_thread_tasks(scope, sh, front, status_out, servo, supervisor, sim)?;
        let recorded = Recorder::join(rec)?;
        let voice = audio
            .map(|h| h.join())
            .transpose()
            .map_err(|_| CliError::failure("the audio task panicked"))?;
        Ok((servo, status, ending?, (scene, recorded, voice)))
    })?;
    let (mut scene, recorded, voice) = scene;
    if let (Some(path), Some(v)) = (audio_out.as_ref(), voice) {
        crate::audio::write_wav(path, v.samples())?;
        errln!("tetradrill: the burr's sound written to {}", path.display());
    }
    let (saturations, valid, removed_by_region, debris_erased, deform) = ending;
    let shaft = params.shaft.zip(law.shaft_counts()).map(|(t, c)| RunShaft {
        passive_points: t.passive_count(),
        near_ticks: c.near_ticks,
        held_ticks: c.held_ticks,
        held_max: c.held_max,
        pushing_ticks: c.pushing_ticks,
    });
    let ended = Ended {
        deform,
        shaft,
        removed_by_region,
        debris_erased,
        kind,
        elapsed: started.elapsed().as_secs_f64(),
        initial_volume,
        sim: sim_status,
        saturations,
        summary,
        request: request.clone(),
        recorded: (recorded, recorder.dropped()),
        gate_armed: gate.arm_on_exit,
        checks,
    };
    let (rep, error) = ended.report(servo, &shared, None)?;
    if let Some(path) = &view.screenshot {
        crate::viewer::screenshot(&mut scene, path, view.clip)?;
    }
    conclude(rep, json, error, valid)
}

/// How the tasks of a run ended.
struct Ended {
    /// The soft body's figures (`--body soft` only).
    deform: Option<crate::soft::DeformSummary>,
    /// A drill's shaft figures (`--tool drill:...` only).
    shaft: Option<RunShaft>,
    /// The removed volume by region label, when the world had regions.
    removed_by_region: Option<std::collections::BTreeMap<String, f64>>,
    /// The debris the drill's checks erased while the run drilled.
    debris_erased: DebrisSummary,
    kind: DeviceKind,
    elapsed: f64,
    initial_volume: f64,
    sim: SimStatus,
    saturations: SaturationCounts,
    /// Print the summary.
    summary: bool,
    /// The run's stop request.
    request: StopRequest,
    /// `--record`'s rows written and dropped.
    recorded: (u64, u64),
    /// The force waited for the tool to leave the solid.
    gate_armed: bool,
    /// What the device's checks found.
    checks: RunChecks,
}

impl Ended {
    /// The run's report (printed, with the servo's warnings) and the device error that ended
    /// the run, if one did; a servo that could not open its device or panicked is the run's
    /// error.
    fn report(
        &self,
        servo: Result<tasks::ServoResult, ServoFailure>,
        shared: &Shared,
        pen: Option<PenRunSummary>,
    ) -> Result<(RunReport, Option<DeviceError>), CliError> {
        let kind = self.kind;
        let servo = servo.map_err(|e| match e {
            ServoFailure::Device(e) => device_error(kind, e),
            ServoFailure::Panicked {
                ticks,
                panic,
                force,
            } => CliError::failure(format!(
                "the servo panicked after {ticks} ticks (a bug): {panic}; {force}"
            )),
        })?;
        for w in &servo.rt.warnings {
            errln!("tetradrill: warning: {w}");
        }
        let (elapsed, sim) = (self.elapsed, &self.sim);
        let c = &shared.counters;
        let t = c.tick.summary();
        let stopped_by = (servo.end == tasks::ServoEnd::Requested)
            .then(|| self.request.signal())
            .flatten();
        let rep = RunReport {
            device: format!("{kind:?}").to_lowercase(),
            stop_reason: servo.end.name(),
            stop_signal: stopped_by.map(signal_name),
            stop_to_zero_force_us: servo.request_to_zero_ns.map(|ns| ns as f64 / 1000.0),
            force: RunForce {
                last_written_n: servo.last_written_n,
            },
            safety: RunSafety {
                passivity_trips: servo.passivity.trips(),
                probe_trips: servo.probe.trips(),
                probe_z_min: servo.probe.z_min(),
                trip_recoveries: servo.limits.recoveries(),
                trips_locked_out: servo.limits.locked_out(),
                derated_s: servo.limits.derated_s(tasks::SERVO_PERIOD_NS as f64 * 1e-9),
                dissipated_j: servo.passivity.dissipated_j(),
                generated_j_max: f64::from(servo.passivity.generated_j_max()),
                past_limit_j_max: f64::from(servo.passivity.trip_measure_j_max()),
                armed_at_tick: servo.armed_at,
                reversed_joints: self
                    .checks
                    .reversed_joints
                    .get()
                    .cloned()
                    .unwrap_or_default(),
                stiffness_capped: self.checks.stiffness_capped,
                damping: self.checks.damping,
                max_force_capped_n: self.checks.max_force_capped_n,
                library_warnings: servo.library_warnings.count,
                library_warning_last: servo.library_warnings.last,
            },
            contact: RunContact {
                max_depth_m: f64::from(servo.max_depth_m),
            },
            recorded_rows: self.recorded.0,
            dropped_rows: self.recorded.1,
            ticks: servo.ticks,
            overruns: servo.overruns,
            duration_s: elapsed,
            initial_volume: self.initial_volume,
            removed_volume: sim.removed_volume,
            removed_by_region: self.removed_by_region.clone(),
            debris_erased: self.debris_erased,
            hierarchy_nodes: sim.hierarchy_nodes,
            visible_faces: sim.visible_faces,
            simulation_steps: sim.steps,
            simulation_hz: sim.steps as f64 / elapsed.max(1e-9),
            simulation_step_max_us: sim.max_step_ns as f64 / 1000.0,
            dropped_samples: shared.counters.dropped_samples.load(Ordering::Relaxed),
            nonfinite_samples: servo.nonfinite_samples,
            servo_stalls: shared.counters.watch.stalls(),
            servo_stall_max_ms: shared.counters.watch.stall_max_ns() as f64 / 1e6,
            saturations: self.saturations.totalled(),
            force_max_n: servo.max_force,
            force_digest: format!("{:016x}", servo.digest.value()),
            timing_us: RunTiming {
                tick_mean: t.mean,
                tick_p99: t.p99,
                tick_p999: t.p999,
                tick_max: t.max,
            },
            wake_us: c.wake.summary(),
            wake_histogram_us: c.wake.histogram_us(200),
            realtime: crate::commands::timing::RealtimeReport {
                fifo: servo.rt.fifo,
                pinned: servo.rt.pinned,
                memory_locked: servo.rt.memory_locked,
            },
            valid: false,
            pen,
            shaft: self.shaft,
            deform: self.deform.clone(),
        };
        if self.summary {
            print_summary(&rep);
        }
        if let Some(last) = rep.safety.library_warning_last {
            errln!(
                "tetradrill: warning: the {} device's library warned {} time{} (last: {last}); \
                 the force ramped in again after each",
                rep.device,
                rep.safety.library_warnings,
                if rep.safety.library_warnings == 1 {
                    ""
                } else {
                    "s"
                }
            );
        }
        if rep.safety.passivity_trips > 0 {
            let after = if rep.safety.trips_locked_out {
                format!(
                    "{} trips within a minute: the motors stayed off for the rest of the run",
                    tasks::MAX_TRIPS_PER_MINUTE
                )
            } else {
                format!(
                    "the motors were cut until the tool had been out of contact for a second \
                     ({} recoveries)",
                    rep.safety.trip_recoveries
                )
            };
            let why = if rep.safety.probe_trips > 0 {
                format!(
                    "the {} device moved against the force-sign probe in {} of them and put \
                     {:.3} J past the force limit into the tool (a reversed force or a mirrored \
                     axis?)",
                    rep.device, rep.safety.probe_trips, rep.safety.past_limit_j_max
                )
            } else {
                format!(
                    "the {} device put {:.3} J past the force limit into the tool (a reversed \
                     force or a mirrored axis?)",
                    rep.device, rep.safety.past_limit_j_max
                )
            };
            errln!(
                "tetradrill: warning: the passivity controller tripped {} times: {why}; {after}",
                rep.safety.passivity_trips
            );
        }
        if !rep.safety.reversed_joints.is_empty() {
            errln!(
                "tetradrill: warning: the {} device has reversed joints {:?}: no force was \
                 rendered",
                rep.device,
                rep.safety.reversed_joints
            );
        } else if self.gate_armed && rep.safety.armed_at_tick.is_none() {
            errln!(
                "tetradrill: warning: the tool never left the solid with the {} device ready: \
                 no force was rendered",
                rep.device
            );
        }
        if rep.nonfinite_samples > 0 {
            errln!(
                "tetradrill: warning: the {} device sent {} non-finite positions; the force was \
                 zero on those ticks",
                rep.device,
                rep.nonfinite_samples
            );
        }
        Ok((rep, servo.error))
    }
}

/// Writes the JSON (with `valid`), then gives the run's error if it had one: the device that
/// failed mid-run (`error`), a final state that is not valid.
fn conclude(
    mut rep: RunReport,
    json: Option<&PathBuf>,
    error: Option<DeviceError>,
    valid: Result<(), String>,
) -> Result<RunReport, CliError> {
    rep.valid = valid.is_ok();
    if let Some(path) = json {
        crate::report::write_json(path, &rep)?;
    }
    if let Some(e) = error {
        return Err(CliError::failure(format!(
            "the {} device failed after {} ticks: {e}; force was set to zero",
            rep.device, rep.ticks
        )));
    }
    valid.map_err(|e| CliError::failure(format!("the final state is invalid: {e}")))?;
    Ok(rep)
}

/// A device that could not be opened is bad input (exit 2, one line naming the device).
fn device_error(kind: DeviceKind, e: DeviceError) -> CliError {
    let name = format!("{kind:?}").to_lowercase();
    match e {
        DeviceError::NotFound(_)
        | DeviceError::LibraryNotFound
        | DeviceError::Unsupported(_)
        | DeviceError::FirmwareFile => CliError::input(format!("--device {name}: {e}")),
        _ => CliError::failure(format!("--device {name}: {e}")),
    }
}

/// The centre of the box around `positions` (the origin when there are none): the point the
/// viewer's camera orbits and the device frame turns about.
pub fn mesh_centre(positions: &[Vec3]) -> Vec3 {
    let Some(first) = positions.first() else {
        return Vec3::ZERO;
    };
    let (lo, hi) = positions
        .iter()
        .fold((*first, *first), |(lo, hi), p| (lo.min(*p), hi.max(*p)));
    0.5 * (lo + hi)
}

/// The identity device-to-mesh map (the simulated device moves in mesh units).
pub const MESH_UNITS: Workspace = Workspace {
    scale: 1.0,
    offset: Vec3::ZERO,
};
