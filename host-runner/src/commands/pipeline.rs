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
use std::time::Duration;

use serde::Serialize;
use tetradrill_core::servo::ContactState;
use tetradrill_core::Vec3;
use tetradrill_device::{DeviceError, DeviceKind, HapticDevice};

use crate::commands::replay::{SaturationCounts, TickTiming};
use crate::engine::{self, EngineStorage, TickParams};
use crate::error::CliError;
use crate::pen::{PenRig, PenSizes};
use crate::rt::RtConfig;
use crate::scenario::{Scenario, ToolKind};
use crate::stats::Summary;
use crate::tasks::{self, RecordRing, Shared, SimStatus, Workspace};
use crate::watchdog::{self, StopRequest};

/// Ticks of a run without an end of its own: it runs until the window closes, a stop request
/// (a signal) or a device error.
pub const UNTIL_STOPPED: u64 = u64::MAX;

/// Opens the device on the servo thread (a device handle need not be `Send`).
pub type DeviceFactory = Box<dyn FnOnce() -> Result<Box<dyn HapticDevice>, DeviceError> + Send>;

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
            view: crate::viewer::ViewOptions {
                window: false,
                screenshot: None,
            },
            stop: StopRequest::new(),
            record: None,
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

/// The passivity observer and controller of a run ([`tetradrill_core::force::passivity`]).
#[derive(Debug, Clone, Copy, Default, Serialize)]
pub struct RunSafety {
    /// Times it tripped (0 or 1: a trip cuts the motors for the rest of the run).
    pub passivity_trips: u32,
    /// Energy its damper dissipated, joules.
    pub dissipated_j: f64,
    /// The largest energy the rendered environment had generated at a tick (before the
    /// damper took it), joules.
    pub generated_j_max: f64,
    /// The largest energy the force law stored past its force limit since its contact began
    /// (the trip's measure; for a mesh tool, whose law has no storage function, the generated
    /// energy, observed only), joules.
    pub past_limit_j_max: f64,
}

/// The tool's contact over a run.
#[derive(Debug, Clone, Copy, Default, Serialize)]
pub struct RunContact {
    /// The deepest penetration of the tool's contact point (the burr's depth below the
    /// contact plane), metres; 0 for a mesh tool.
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

/// Runs the pipeline on `sc` with `setup`; returns the report (the device error that ended the
/// run, if any, as an error: exit 2 when the device was not found, 1 when it failed mid-run).
pub fn run(
    sc: &Scenario,
    setup: PipelineSetup,
    json: Option<&PathBuf>,
) -> Result<RunReport, CliError> {
    if let ToolKind::Mesh(pen) = sc.tool_kind().map_err(CliError::input)? {
        return run_pen(sc, setup, json, &pen);
    }
    let params = TickParams::of(sc)?;
    let loaded = engine::load_mesh(sc)?;
    let regions = crate::viewer::handoff::region_slots(&loaded.labels);
    let mut store = EngineStorage::try_allocate(loaded.mesh, sc)?;
    let (initial_volume, tets, centre) = {
        let world = store.world()?;
        (
            world.mesh().volume(),
            world.mesh().tet_count(),
            mesh_centre(world.mesh().positions()),
        )
    };
    let (mut contact_in, mut contact_out) =
        triple_buffer::TripleBuffer::new(&ContactState::default()).split();
    let (mut status_in, status_out) =
        triple_buffer::TripleBuffer::new(&SimStatus::default()).split();
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

    let mut law = tasks::BurrLaw::new(params, &mut contact_out, &shared.counters);
    let (servo, sim_status, ending, scene) = std::thread::scope(|scope| -> Result<_, CliError> {
        let sh = &shared;
        let any_view = view.any();
        let sim = std::thread::Builder::new()
            .name("simulation".into())
            .spawn_scoped(scope, move || -> Result<SimEnding, CliError> {
                let mut link = any_view.then(|| {
                    let mut l = crate::viewer::publish::SimViewer::new(
                        &sh.snapshots,
                        Some(controls_out),
                        tets,
                    );
                    l.set_initial_volume(initial_volume);
                    l.set_regions(regions);
                    l
                });
                loop {
                    // The world is rebuilt, untouched, when the viewer asks for a reset.
                    let mut world = store.world()?;
                    let end = tasks::simulation_task(
                        &mut world,
                        params,
                        &sh.ring,
                        &mut contact_in,
                        &mut status_in,
                        &sh.stop,
                        &sh.counters,
                        link.as_mut(),
                    );
                    match end {
                        tasks::SimEnd::Stopped => {
                            // The final state: saturations by kind, and the core's validate().
                            let sat = SaturationCounts::from(world.saturations());
                            return Ok((sat, engine::validate(&world)));
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
            },
            &mut law,
        )?;
        let supervisor = spawn_watchdog(scope, sh, rt, kind)?;
        let rec = recorder.spawn(scope, sh)?;
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
        Ok((servo, status, ending?, (scene, recorded)))
    })?;
    let (mut scene, recorded) = scene;
    let (saturations, valid) = ending;
    let ended = Ended {
        kind,
        elapsed: started.elapsed().as_secs_f64(),
        initial_volume,
        sim: sim_status,
        saturations,
        summary,
        request: request.clone(),
        recorded: (recorded, recorder.dropped()),
    };
    let (rep, error) = ended.report(servo, &shared, None)?;
    if let Some(path) = &view.screenshot {
        crate::viewer::screenshot(&mut scene, path)?;
    }
    conclude(rep, json, error, valid)
}

/// How the tasks of a run ended.
struct Ended {
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
                dissipated_j: servo.passivity.dissipated_j(),
                generated_j_max: f64::from(servo.passivity.generated_j_max()),
                past_limit_j_max: f64::from(servo.passivity.trip_measure_j_max()),
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
        };
        if self.summary {
            print_summary(&rep);
        }
        if rep.safety.passivity_trips > 0 {
            errln!(
                "tetradrill: warning: the passivity controller tripped: the {} device put \
                 {:.3} J past the force limit into the tool (a reversed force or a mirrored \
                 axis?); the motors were cut for the rest of the run",
                rep.device,
                rep.safety.past_limit_j_max
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

/// The pipeline with a tet-mesh tool (`--tool mesh:FILE`): the simulation task is the pen's
/// contact task ([`crate::pen_tasks::pen_contact_task`]: collisions and depths at the newest
/// pose, as often as it can), the servo carries the latest pass to every tick's pose
/// ([`crate::pen_tasks::PenLaw`]). The object is touched, not drilled. The live window and
/// `--screenshot` show the object and the pen where it is drawn clear of it; the window's
/// stiffness slider sets the pen's stiffness (its drilling controls are hidden).
fn run_pen(
    sc: &Scenario,
    setup: PipelineSetup,
    json: Option<&PathBuf>,
    pen_path: &std::path::Path,
) -> Result<RunReport, CliError> {
    use crate::pen_tasks::{held_handoff, pen_contact_task, PenLaw, PenTaskReport, PenViewer};
    if sc.contact_period != 1 {
        return Err(CliError::input(format!(
            "--contact-period {}: a real-time run's contact pass runs as often as it can; the \
             period is for replay",
            sc.contact_period
        )));
    }
    let obj = engine::load_mesh(sc)?.mesh;
    let mut pen = crate::meshio::load(pen_path, sc.tool_scale)?;
    for w in &pen.warnings {
        errln!("tetradrill: warning: {w}");
    }
    // The object's counts and state, from an untouched hierarchy (it is only read).
    let mut store = crate::pen::object_store(obj.clone(), sc)?;
    let world = store.world()?;
    let base = SimStatus {
        hierarchy_nodes: world.hierarchy().node_count(),
        visible_faces: world.hierarchy().visible_face_count(),
        ..SimStatus::default()
    };
    let (initial_volume, centre, valid) = (
        world.mesh().volume(),
        mesh_centre(world.mesh().positions()),
        engine::validate(&world),
    );
    let tets = world.mesh().tet_count();
    let opts = crate::pen::options(sc);
    let shape = crate::viewer::publish::tool_shape(&pen.mesh.view());
    let mut summary = PenRunSummary {
        tool_nodes: pen.mesh.positions().len(),
        tool_tets: pen.mesh.tets().len(),
        depth_method: format!("{:?}", sc.depth_method).to_lowercase(),
        entry_remedy: sc.entry_remedy,
        ..PenRunSummary::default()
    };
    let shared = Shared::new();
    let recorder = Recorder::open(setup.record.as_deref())?;
    let mut rig = PenRig { pen: pen.mesh, obj };
    let initial_controls = crate::viewer::handoff::Controls {
        radius: 0.0,
        stiffness: opts.params.stiffness,
        max_depth: sc.max_depth,
        paused: false,
        reset: 0,
    };
    let ((servo, sim_status, task, stats, elapsed, (mut shown, recorded)), built) = rig
        .with_sizes(PenSizes::of(sc), |scene, bufs| {
            let (mut held_in, held_out) = held_handoff(bufs.pen_pens.len(), bufs.object_pens.len());
            let (mut status_in, status_out) = triple_buffer::TripleBuffer::new(&base).split();
            let mut law = PenLaw::new(scene, &shared.counters, held_out, opts);
            let mut task = PenTaskReport::new();
            // The window's stiffness reaches the pen's law through the contact task.
            let (controls_in, controls_out) = crate::viewer::handoff::controls(initial_controls);
            let (camera_in, mut camera_out) = tasks::camera_handoff();
            let mut link = setup.view.any().then(|| {
                let mut l = crate::viewer::publish::SimViewer::new(
                    &shared.snapshots,
                    Some(controls_out),
                    tets,
                );
                l.set_initial_volume(initial_volume);
                l.set_tool_shape(shape.clone());
                l
            });
            let run = ServoRun {
                open: setup.open,
                rt: setup.rt,
                ticks: setup.ticks,
                workspace: setup.workspace,
                frame: tasks::DeviceFrame::new(centre),
                camera: setup.view.window.then_some(&mut camera_out),
                request: &setup.stop,
                record: recorder.ring(),
            };
            // The run's time starts with its tasks (the scene is built by now).
            let started = std::time::Instant::now();
            let servo = std::thread::scope(|scope| -> Result<_, CliError> {
                let sh = &shared;
                let task = &mut task;
                let (world, link) = (&world, link.as_mut());
                let sim = std::thread::Builder::new()
                    .name("simulation".into())
                    .spawn_scoped(scope, move || {
                        let viewer = link.map(|link| PenViewer {
                            link,
                            world,
                            last_picture: !setup.view.window,
                        });
                        pen_contact_task(
                            scene,
                            bufs,
                            &opts,
                            sh,
                            &mut held_in,
                            &mut status_in,
                            task,
                            viewer,
                        );
                    })
                    .map_err(|e| {
                        CliError::failure(format!("cannot start the contact task: {e}"))
                    })?;
                let servo = spawn_servo(scope, sh, run, &mut law)?;
                let supervisor = spawn_watchdog(scope, sh, setup.rt, setup.kind)?;
                let rec = recorder.spawn(scope, sh)?;
                let front = Front {
                    view: &setup.view,
                    status_line: setup.status_line,
                    initial_volume,
                    controls: controls_in,
                    initial_controls,
                    camera: camera_in,
                };
                let joined =
                    main_thread_tasks(scope, sh, front, status_out, servo, supervisor, sim)?;
                Ok((joined, Recorder::join(rec)?))
            })?;
            let ((servo, status, (), shown), recorded) = servo;
            let elapsed = started.elapsed().as_secs_f64();
            Ok((servo, status, task, law.stats, elapsed, (shown, recorded)))
        })
        .map_err(|e| CliError::failure(format!("cannot set up the tool contact: {e}")))
        .and_then(|(r, built)| r.map(|r| (r, built)))?;
    summary.passes = task.passes;
    summary.pass_us = TickTiming::from(task.pass.summary());
    summary.carried_ticks = stats.carried_ticks;
    summary.pass_age_mean_ticks = stats.age_sum as f64 / stats.carried_ticks.max(1) as f64;
    summary.pass_age_max_ticks = stats.age_max;
    summary.pen_collisions_max = task.pen_collisions_max;
    summary.object_collisions_max = task.object_collisions_max;
    summary.unreached = task.unreached;
    summary.saturated_passes = task.saturated;
    summary.clamped_ticks = stats.clamped_ticks;
    summary.servo_short_ticks = stats.short_ticks;
    summary.nonfinite_ticks = stats.nonfinite_ticks;
    let ended = Ended {
        kind: setup.kind,
        elapsed,
        initial_volume,
        sim: sim_status,
        saturations: SaturationCounts {
            hash: built.hash_saturations,
            contacts: task.contacts_full,
            queue: task.queue_full,
            ..SaturationCounts::default()
        },
        summary: setup.summary,
        request: setup.stop.clone(),
        recorded: (recorded, recorder.dropped()),
    };
    let (rep, error) = ended.report(servo, &shared, Some(summary))?;
    if let Some(path) = &setup.view.screenshot {
        crate::viewer::screenshot(&mut shown, path)?;
    }
    if let Some(p) = rep.pen.as_ref().filter(|_| setup.summary) {
        outln!(
            "tool {} nodes / {} tets, depth {}: {} contact passes, us: mean {:.1}  p99 {:.1}  \
             max {:.1}; pass age ticks: mean {:.2}  max {}",
            p.tool_nodes,
            p.tool_tets,
            p.depth_method,
            p.passes,
            p.pass_us.tick_mean,
            p.pass_us.tick_p99,
            p.pass_us.tick_max,
            p.pass_age_mean_ticks,
            p.pass_age_max_ticks
        );
        outln!(
            "most tool nodes inside {}, object nodes inside {}, unreached {}, saturated passes {}, \
             clamped ticks {}, short ticks {}",
            p.pen_collisions_max,
            p.object_collisions_max,
            p.unreached,
            p.saturated_passes,
            p.clamped_ticks,
            p.servo_short_ticks
        );
    }
    conclude(rep, json, error, valid)
}

/// What the simulation task leaves: saturations by kind and the final state's validity.
type SimEnding = (SaturationCounts, Result<(), String>);

/// Why the servo thread ended without its result.
#[derive(Debug)]
enum ServoFailure {
    /// The device could not be opened.
    Device(DeviceError),
    /// The servo (or the device under it) panicked: a bug.
    Panicked {
        /// Ticks done before.
        ticks: u64,
        /// The panic's one line.
        panic: String,
        /// What happened to the force (`force was set to zero`, or why not).
        force: String,
    },
}

/// What the servo thread needs besides its law.
struct ServoRun<'c> {
    open: DeviceFactory,
    rt: RtConfig,
    ticks: u64,
    workspace: Workspace,
    frame: tasks::DeviceFrame,
    camera: Option<&'c mut tasks::CameraOut>,
    request: &'c StopRequest,
    record: Option<std::sync::Arc<RecordRing>>,
}

/// The servo thread: opens the device, attaches its cutoff to the watchdog, and runs
/// [`tasks::servo_task`] with `law` under a panic guard (a panic zeroes the force).
fn spawn_servo<'scope, 'env: 'scope, L: tasks::ForceLaw + Send>(
    scope: &'scope std::thread::Scope<'scope, 'env>,
    sh: &'env Shared,
    run: ServoRun<'env>,
    law: &'env mut L,
) -> Result<std::thread::ScopedJoinHandle<'scope, Result<tasks::ServoResult, ServoFailure>>, CliError>
{
    let ServoRun {
        open,
        rt,
        ticks,
        workspace,
        frame,
        camera,
        request,
        record,
    } = run;
    std::thread::Builder::new()
        .name("servo".into())
        .spawn_scoped(scope, move || {
            let watch = &sh.counters.watch;
            let opened = watchdog::quiet_unwind(open);
            let mut device = match opened {
                Ok(Ok(d)) => d,
                Ok(Err(e)) => {
                    sh.stop.store(true, Ordering::Relaxed);
                    return Err(ServoFailure::Device(e));
                }
                Err(panic) => {
                    sh.stop.store(true, Ordering::Relaxed);
                    return Err(ServoFailure::Panicked {
                        ticks: 0,
                        panic,
                        force: "the motors were never turned on".into(),
                    });
                }
            };
            let cutoff = device.cutoff();
            watch.attach(cutoff.clone());
            let run = watchdog::quiet_unwind(|| {
                tasks::servo_task(
                    device.as_mut(),
                    rt,
                    ticks,
                    workspace,
                    law,
                    &sh.ring,
                    &sh.counters,
                    &sh.stop,
                    request,
                    record,
                    frame,
                    camera,
                )
            });
            run.map_err(|panic| {
                let force = watchdog::after_panic(watch, device, cutoff, &sh.stop);
                ServoFailure::Panicked {
                    ticks: sh.counters.ticks.load(Ordering::Relaxed),
                    panic,
                    force,
                }
            })
        })
        .map_err(|e| {
            // The tasks already started end too (the scope waits for them).
            sh.stop.store(true, Ordering::Relaxed);
            CliError::failure(format!("cannot start the servo task: {e}"))
        })
}

/// `--record FILE`: the file, created before the run starts (a path that cannot be written is
/// bad input: exit 2 naming it), and the ring the servo feeds.
struct Recorder {
    file: Option<(PathBuf, std::fs::File)>,
    ring: Option<std::sync::Arc<RecordRing>>,
}

/// The recorder thread's handle: the rows it wrote, or why it stopped.
type RecorderHandle<'scope> = Option<(
    PathBuf,
    std::thread::ScopedJoinHandle<'scope, std::io::Result<u64>>,
)>;

impl Recorder {
    fn open(path: Option<&std::path::Path>) -> Result<Self, CliError> {
        let Some(path) = path else {
            return Ok(Self {
                file: None,
                ring: None,
            });
        };
        let file = std::fs::File::create(path)
            .map_err(|e| CliError::at(path, None, format!("--record: cannot create: {e}")))?;
        Ok(Self {
            file: Some((path.to_path_buf(), file)),
            ring: Some(std::sync::Arc::new(RecordRing::new(tasks::RECORD_RING))),
        })
    }

    fn ring(&self) -> Option<std::sync::Arc<RecordRing>> {
        self.ring.clone()
    }

    fn dropped(&self) -> u64 {
        self.ring.as_ref().map_or(0, |r| r.dropped())
    }

    /// The recorder task ([`tasks::recorder_task`]) on its own thread, until `sh.stop`.
    fn spawn<'scope, 'env: 'scope>(
        &'env self,
        scope: &'scope std::thread::Scope<'scope, 'env>,
        sh: &'env Shared,
    ) -> Result<RecorderHandle<'scope>, CliError> {
        let (Some((path, file)), Some(ring)) = (&self.file, &self.ring) else {
            return Ok(None);
        };
        let h = std::thread::Builder::new()
            .name("recorder".into())
            .spawn_scoped(scope, move || tasks::recorder_task(ring, file, &sh.stop))
            .map_err(|e| {
                sh.stop.store(true, Ordering::Relaxed);
                CliError::failure(format!("cannot start the recorder task: {e}"))
            })?;
        Ok(Some((path.clone(), h)))
    }

    /// The rows written (0 without `--record`); a write error ends the run with exit 1.
    fn join(h: RecorderHandle<'_>) -> Result<u64, CliError> {
        let Some((path, h)) = h else {
            return Ok(0);
        };
        h.join()
            .map_err(|_| CliError::failure("the recorder task panicked"))?
            .map_err(|e| {
                CliError::failure(format!("{}: --record: cannot write: {e}", path.display()))
            })
    }
}

/// A signal's name (`SIGINT`), or its number.
fn signal_name(sig: i32) -> String {
    match sig {
        libc::SIGINT => "SIGINT".into(),
        libc::SIGTERM => "SIGTERM".into(),
        libc::SIGHUP => "SIGHUP".into(),
        n => format!("signal {n}"),
    }
}

/// The watchdog thread ([`watchdog::supervisor_task`]) for a run of `kind`.
fn spawn_watchdog<'scope, 'env: 'scope>(
    scope: &'scope std::thread::Scope<'scope, 'env>,
    sh: &'env Shared,
    rt: RtConfig,
    kind: DeviceKind,
) -> Result<std::thread::ScopedJoinHandle<'scope, ()>, CliError> {
    std::thread::Builder::new()
        .name("watchdog".into())
        .spawn_scoped(scope, move || {
            watchdog::supervisor_rt(&rt);
            watchdog::supervisor_task(
                &sh.counters.watch,
                kind.name(),
                watchdog::SERVO_WATCHDOG_NS,
                &sh.stop,
                |line| errln!("tetradrill: warning: {line}"),
            );
        })
        .map_err(|e| {
            sh.stop.store(true, Ordering::Relaxed);
            CliError::failure(format!("cannot start the watchdog task: {e}"))
        })
}

/// What the main thread needs for its part of a run.
struct Front<'v> {
    view: &'v crate::viewer::ViewOptions,
    status_line: bool,
    initial_volume: f64,
    controls: crate::viewer::handoff::ControlsIn,
    initial_controls: crate::viewer::handoff::Controls,
    camera: tasks::CameraIn,
}

/// What [`main_thread_tasks`] gives back: the servo's result, the last status, the simulation
/// task's result and the scene a screenshot draws.
type Joined<S> = (
    Result<tasks::ServoResult, ServoFailure>,
    SimStatus,
    S,
    crate::viewer::scene::Scene,
);

/// The main thread's part of a run once the simulation, servo and watchdog threads are up: the
/// live window (the status task then on its own thread; a closed window ends the run) or the
/// status task, draining snapshots for a screenshot; then the joins, in the order that lets
/// every task end (servo, watchdog, simulation).
fn main_thread_tasks<'scope, 'env: 'scope, S>(
    scope: &'scope std::thread::Scope<'scope, 'env>,
    sh: &'env Shared,
    front: Front<'_>,
    mut status_out: triple_buffer::Output<SimStatus>,
    servo: std::thread::ScopedJoinHandle<'scope, Result<tasks::ServoResult, ServoFailure>>,
    supervisor: std::thread::ScopedJoinHandle<'scope, ()>,
    sim: std::thread::ScopedJoinHandle<'scope, S>,
) -> Result<Joined<S>, CliError> {
    let Front {
        view,
        status_line,
        initial_volume,
        controls,
        initial_controls,
        camera,
    } = front;
    let any_view = view.any();
    let mut scene = crate::viewer::scene::Scene::new();
    let drain = |scene: &mut crate::viewer::scene::Scene| {
        while let Some(snap) = sh.snapshots.take() {
            scene.apply(snap);
        }
    };
    if view.window {
        // The viewer on the main thread, the status task on its own.
        let status = std::thread::Builder::new()
            .name("status".into())
            .spawn_scoped(scope, move || {
                status_loop(sh, &mut status_out, status_line, initial_volume, || {});
                status_out
            })
            .map_err(|e| {
                sh.stop.store(true, Ordering::Relaxed);
                CliError::failure(format!("cannot start the status task: {e}"))
            })?;
        let link = crate::viewer::LiveLink {
            shared: sh,
            controls,
            initial: initial_controls,
            camera: Some(camera),
        };
        let shown = crate::viewer::run_window(link);
        // A closed window ends the run.
        sh.stop.store(true, Ordering::Relaxed);
        scene = shown?;
        status_out = status
            .join()
            .map_err(|_| CliError::failure("the status task panicked"))?;
    } else {
        drop(controls);
        drop(camera);
        // The status task: the main thread.
        status_loop(sh, &mut status_out, status_line, initial_volume, || {
            if any_view {
                drain(&mut scene)
            }
        });
    }
    let servo = servo.join();
    sh.stop.store(true, Ordering::Relaxed);
    let servo = servo.map_err(|_| CliError::failure("the servo task panicked"))?;
    supervisor
        .join()
        .map_err(|_| CliError::failure("the watchdog task panicked"))?;
    while !sim.is_finished() {
        if any_view && !view.window {
            drain(&mut scene);
        }
        std::thread::sleep(Duration::from_millis(2));
    }
    let ending = sim
        .join()
        .map_err(|_| CliError::failure("the simulation task panicked"))?;
    if any_view && !view.window {
        drain(&mut scene);
    }
    Ok((servo, *status_out.read(), ending, scene))
}

/// The status task: until `stop`, the status line every 250 ms (one line a second in logs),
/// and `each` every 25 ms (the screenshot's snapshot drain).
fn status_loop(
    sh: &Shared,
    status_out: &mut triple_buffer::Output<SimStatus>,
    status_line: bool,
    initial_volume: f64,
    mut each: impl FnMut(),
) {
    let mut last_ticks = 0u64;
    let mut last_steps = 0u64;
    let mut printed = false;
    let mut last_at = std::time::Instant::now();
    let mut slice = 0u32;
    while !sh.stop.load(Ordering::Relaxed) {
        std::thread::sleep(Duration::from_millis(25));
        each();
        slice += 1;
        if !slice.is_multiple_of(10) || !status_line {
            continue;
        }
        let st = *status_out.read();
        let c = &sh.counters;
        let t = c.ticks.load(Ordering::Relaxed);
        let f = f32::from_bits(c.force_bits.load(Ordering::Relaxed) as u32);
        // On a terminal the line updates in place; in a log, one line a second.
        let tty = std::io::IsTerminal::is_terminal(&std::io::stderr());
        if !tty && !(sh.counters.ticks.load(Ordering::Relaxed) / 250).is_multiple_of(4) {
            continue;
        }
        err!(
            "{} t {:5.1} s | servo {:4} Hz, overruns {}, wake p99 {:4.0} us | sim {:4} Hz | removed {:.5} ({:.2}%) | force {:5.2} N   {}",
            if tty { "\r" } else { "" },
            t as f64 / 1000.0,
            ((t - last_ticks) as f64 / last_at.elapsed().as_secs_f64()).round(),
            c.overruns.load(Ordering::Relaxed),
            c.wake_percentile_us(0.99).unwrap_or(0.0),
            ((st.steps - last_steps) as f64 / last_at.elapsed().as_secs_f64()).round(),
            st.removed_volume,
            100.0 * st.removed_volume / initial_volume.max(f64::MIN_POSITIVE),
            f,
            if tty { "" } else { "\n" }
        );
        printed = tty;
        last_ticks = t;
        last_steps = st.steps;
        last_at = std::time::Instant::now();
    }
    if printed {
        errln!();
    }
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

fn print_summary(r: &RunReport) {
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
        "simulation: {} steps ({:.0} Hz), longest {:.0} us;  removed volume {:.6} of {:.6} ({:.2}%)",
        r.simulation_steps,
        r.simulation_hz,
        r.simulation_step_max_us,
        r.removed_volume,
        r.initial_volume,
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
