//! The real-time pipeline shared by `run` and `demo`: the tasks of [`crate::tasks`] on their
//! threads, a live status line, and the summary at the end.
//!
//! The servo runs under a panic guard and a watchdog ([`crate::watchdog`]): a servo that
//! stalls past the watchdog time has its force zeroed by the watchdog thread (one warning line,
//! the run goes on: exit status 0, `servo_stalls` in the JSON); a servo that panics has its
//! force zeroed and ends the run with one line and exit status 1.

use std::path::PathBuf;
use std::sync::atomic::Ordering;
use std::time::Duration;

use serde::Serialize;
use tetradrill_core::servo::ContactState;
use tetradrill_core::Vec3;
use tetradrill_device::{DeviceError, DeviceKind, HapticDevice};

use crate::commands::replay::SaturationCounts;
use crate::engine::{self, EngineStorage, TickParams};
use crate::error::CliError;
use crate::rt::RtConfig;
use crate::scenario::Scenario;
use crate::stats::{histogram_us, summarise_ns, Summary};
use crate::tasks::{self, Shared, SimStatus, Workspace};
use crate::watchdog;

/// Opens the device on the servo thread (a device handle need not be `Send`).
pub type DeviceFactory = Box<dyn FnOnce() -> Result<Box<dyn HapticDevice>, DeviceError> + Send>;

/// Everything a pipeline run needs besides the scenario.
pub struct PipelineSetup {
    /// Which device (for messages).
    pub kind: DeviceKind,
    /// Opens the device.
    pub open: DeviceFactory,
    /// Servo ticks to run.
    pub ticks: u64,
    /// Device-to-mesh map.
    pub workspace: Workspace,
    /// Real-time settings of the servo thread.
    pub rt: RtConfig,
    /// Print the live status line.
    pub status_line: bool,
    /// Live window and/or screenshot.
    pub view: crate::viewer::ViewOptions,
}

impl std::fmt::Debug for PipelineSetup {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("PipelineSetup")
            .field("kind", &self.kind)
            .field("ticks", &self.ticks)
            .field("workspace", &self.workspace)
            .finish_non_exhaustive()
    }
}

/// The summary of a real-time run (`--json`).
#[derive(Debug, Serialize)]
pub struct RunReport {
    /// Device used.
    pub device: String,
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
    /// Servo tick compute times, microseconds.
    pub timing_us: RunTiming,
    /// Servo wake-up latency, microseconds.
    pub wake_us: Summary,
    /// Wake-up latency histogram, 1 us buckets, the last is the overflow bucket.
    pub wake_histogram_us: Vec<u64>,
    /// Real-time settings achieved.
    pub realtime: crate::commands::timing::RealtimeReport,
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
    let params = TickParams::of(sc)?;
    let loaded = engine::load_mesh(sc)?;
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
    let (mut status_in, mut status_out) =
        triple_buffer::TripleBuffer::new(&SimStatus::default()).split();
    let shared = Shared::new();
    let PipelineSetup {
        kind,
        open,
        ticks,
        workspace,
        rt,
        status_line,
        view,
    } = setup;
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
    let mut scene = crate::viewer::scene::Scene::new();

    let (servo, sim_status, ending) = std::thread::scope(|scope| -> Result<_, CliError> {
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
        let servo = std::thread::Builder::new()
            .name("servo".into())
            .spawn_scoped(
                scope,
                move || -> Result<tasks::ServoResult, ServoFailure> {
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
                            params,
                            &mut contact_out,
                            &sh.ring,
                            &sh.counters,
                            &sh.stop,
                            frame,
                            view.window.then_some(&mut camera_out),
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
                },
            )
            .map_err(|e| CliError::failure(format!("cannot start the servo task: {e}")))?;
        let supervisor = std::thread::Builder::new()
            .name("watchdog".into())
            .spawn_scoped(scope, move || {
                watchdog::supervisor_rt(&rt);
                watchdog::supervisor_task(
                    &sh.counters.watch,
                    kind.name(),
                    watchdog::SERVO_WATCHDOG_NS,
                    &sh.stop,
                    |line| eprintln!("tetradrill: warning: {line}"),
                );
            })
            .map_err(|e| {
                sh.stop.store(true, Ordering::Relaxed);
                CliError::failure(format!("cannot start the watchdog task: {e}"))
            })?;
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
                .map_err(|e| CliError::failure(format!("cannot start the status task: {e}")))?;
            let link = crate::viewer::LiveLink {
                shared: sh,
                controls: controls_in,
                initial: initial_controls,
                camera: Some(camera_in),
            };
            scene = crate::viewer::run_window(link)?;
            // A closed window ends the run.
            sh.stop.store(true, Ordering::Relaxed);
            status_out = status
                .join()
                .map_err(|_| CliError::failure("the status task panicked"))?;
        } else {
            drop(controls_in);
            drop(camera_in);
            // The status task: the main thread.
            status_loop(sh, &mut status_out, status_line, initial_volume, || {
                if any_view {
                    drain(&mut scene)
                }
            });
        }
        let servo = servo
            .join()
            .map_err(|_| CliError::failure("the servo task panicked"))?;
        sh.stop.store(true, Ordering::Relaxed);
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
            .map_err(|_| CliError::failure("the simulation task panicked"))??;
        if any_view && !view.window {
            drain(&mut scene);
        }
        Ok((servo, *status_out.read(), ending))
    })?;
    let (saturations, valid) = ending;
    let elapsed = started.elapsed().as_secs_f64();
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
        eprintln!("tetradrill: warning: {w}");
    }
    let t = summarise_ns(&servo.tick_ns);
    let rep = RunReport {
        device: format!("{kind:?}").to_lowercase(),
        ticks: servo.ticks,
        overruns: servo.overruns,
        duration_s: elapsed,
        initial_volume,
        removed_volume: sim_status.removed_volume,
        hierarchy_nodes: sim_status.hierarchy_nodes,
        visible_faces: sim_status.visible_faces,
        simulation_steps: sim_status.steps,
        simulation_hz: sim_status.steps as f64 / elapsed.max(1e-9),
        simulation_step_max_us: sim_status.max_step_ns as f64 / 1000.0,
        dropped_samples: shared.counters.dropped_samples.load(Ordering::Relaxed),
        nonfinite_samples: servo.nonfinite_samples,
        servo_stalls: shared.counters.watch.stalls(),
        servo_stall_max_ms: shared.counters.watch.stall_max_ns() as f64 / 1e6,
        saturations,
        valid: valid.is_ok(),
        force_max_n: servo.max_force,
        force_digest: format!("{:016x}", servo.digest.value()),
        timing_us: RunTiming {
            tick_mean: t.mean,
            tick_p99: t.p99,
            tick_p999: t.p999,
            tick_max: t.max,
        },
        wake_us: summarise_ns(&servo.wake_ns),
        wake_histogram_us: histogram_us(&servo.wake_ns, 200),
        realtime: crate::commands::timing::RealtimeReport {
            fifo: servo.rt.fifo,
            pinned: servo.rt.pinned,
            memory_locked: servo.rt.memory_locked,
        },
    };
    print_summary(&rep);
    if rep.nonfinite_samples > 0 {
        eprintln!(
            "tetradrill: warning: the {} device sent {} non-finite positions; the force was zero \
             on those ticks",
            rep.device, rep.nonfinite_samples
        );
    }
    if let Some(path) = &view.screenshot {
        crate::viewer::screenshot(&mut scene, path)?;
    }
    if let Some(path) = json {
        crate::cli::write_json(path, &rep)?;
    }
    if let Some(e) = servo.error {
        return Err(CliError::failure(format!(
            "the {} device failed after {} ticks: {e}; force was set to zero",
            rep.device, rep.ticks
        )));
    }
    valid.map_err(|e| CliError::failure(format!("the final state is invalid: {e}")))?;
    Ok(rep)
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
        eprint!(
            "{} t {:5.1} s | servo {:4} Hz, overruns {} | sim {:4} Hz | removed {:.5} ({:.2}%) | force {:5.2} N   {}",
            if tty { "\r" } else { "" },
            t as f64 / 1000.0,
            ((t - last_ticks) as f64 / last_at.elapsed().as_secs_f64()).round(),
            c.overruns.load(Ordering::Relaxed),
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
        eprintln!();
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
    println!(
        "{} ticks in {:.2} s on the {} device, {} overruns",
        r.ticks, r.duration_s, r.device, r.overruns
    );
    println!(
        "servo tick us: mean {:.1}  p99 {:.1}  max {:.1};  wake-up us: p50 {:.1}  p99 {:.1}  p99.9 {:.1}  max {:.1}",
        r.timing_us.tick_mean,
        r.timing_us.tick_p99,
        r.timing_us.tick_max,
        r.wake_us.p50,
        r.wake_us.p99,
        r.wake_us.p999,
        r.wake_us.max
    );
    println!(
        "simulation: {} steps ({:.0} Hz), longest {:.0} us;  removed volume {:.6} of {:.6} ({:.2}%)",
        r.simulation_steps,
        r.simulation_hz,
        r.simulation_step_max_us,
        r.removed_volume,
        r.initial_volume,
        100.0 * r.removed_volume / r.initial_volume.max(f64::MIN_POSITIVE)
    );
    println!(
        "hierarchy nodes {}, visible faces {}, saturations {}, dropped samples {}, force max {:.2} N",
        r.hierarchy_nodes, r.visible_faces, r.saturations, r.dropped_samples, r.force_max_n
    );
    if r.servo_stalls > 0 {
        println!(
            "servo stalls {} (longest {:.1} ms): the watchdog set the force to zero each time",
            r.servo_stalls, r.servo_stall_max_ms
        );
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
