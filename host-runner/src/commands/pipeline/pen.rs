//! A run with a tet-mesh tool (`--tool mesh:FILE`): the pen's contact task beside the servo, in
//! place of the simulation.

use std::path::PathBuf;

use crate::commands::replay::{DebrisSummary, SaturationCounts, TickTiming};
use crate::engine;
use crate::error::CliError;
use crate::meshio::LoadedMesh;
use crate::pen::PenRig;
use crate::setup::Setup;
use crate::tasks::{self, Shared, SimStatus};

use super::threads::{main_thread_tasks, spawn_servo, spawn_watchdog, Front, Recorder, ServoRun};
use super::{conclude, mesh_centre, Ended, PenRunSummary, PipelineSetup, RunReport};

/// The pipeline with a tet-mesh tool (`--tool mesh:FILE`): the simulation task is the pen's
/// contact task ([`crate::pen_tasks::pen_contact_task`]: collisions and depths at the newest
/// pose, as often as it can), the servo carries the latest pass to every tick's pose
/// ([`crate::pen_tasks::PenLaw`]). The object is touched, not drilled. The live window and
/// `--screenshot` show the object and the pen where it is drawn clear of it; the window's
/// stiffness slider sets the pen's stiffness (its drilling controls are hidden).
pub(super) fn run_pen(
    sc: &Setup,
    loaded: LoadedMesh,
    setup: PipelineSetup,
    json: Option<&PathBuf>,
    pen_path: &std::path::Path,
    pen_scale: f64,
) -> Result<RunReport, CliError> {
    use crate::pen_pair::with_pass_runner;
    use crate::pen_tasks::{held_handoff, pen_contact_task, PenLaw, PenTaskReport, PenViewer};
    if sc.pen.contact_period != 1 {
        return Err(CliError::input(format!(
            "--contact-period {}: a real-time run's contact pass runs as often as it can; the \
             period is for replay",
            sc.pen.contact_period
        )));
    }
    let obj = loaded.mesh;
    let mut pen = crate::meshio::load(pen_path, pen_scale)?;
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
    let pass_threads = sc.pen.pass_threads;
    let shape = crate::viewer::publish::tool_shape(&pen.mesh.view());
    let mut summary = PenRunSummary {
        tool_nodes: pen.mesh.positions().len(),
        tool_tets: pen.mesh.tets().len(),
        depth_method: format!("{:?}", sc.pen.depth_method).to_lowercase(),
        entry_remedy: sc.pen.entry_remedy,
        ..PenRunSummary::default()
    };
    let shared = Shared::new();
    let recorder = Recorder::open(setup.record.as_deref())?;
    let mut rig = PenRig { pen: pen.mesh, obj };
    let initial_controls = crate::viewer::handoff::Controls {
        radius: 0.0,
        stiffness: opts.params.stiffness,
        max_depth: sc.drilling.max_depth,
        paused: false,
        reset: 0,
    };
    let ((servo, sim_status, task, stats, elapsed, (mut shown, recorded)), built) = rig
        .with_sizes(sc.capacities.pen(), |scene, bufs| {
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
                gate: setup.gate,
            };
            // The run's time starts with its tasks (the scene is built by now).
            let started = std::time::Instant::now();
            let servo = std::thread::scope(|scope| -> Result<_, CliError> {
                let sh = &shared;
                let task = &mut task;
                let (world, link) = (&world, link.as_mut());
                let sim = std::thread::Builder::new()
                    .name(tasks::SIMULATION.name.into())
                    .spawn_scoped(scope, move || {
                        let viewer = link.map(|link| PenViewer {
                            link,
                            world,
                            last_picture: !setup.view.window,
                        });
                        with_pass_runner(scene, bufs, pass_threads, |runner| {
                            pen_contact_task(
                                runner,
                                &opts,
                                sh,
                                &mut held_in,
                                &mut status_in,
                                task,
                                viewer,
                            )
                        });
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
    if let Some(e) = task.worker_gone {
        return Err(CliError::failure(format!("{e}; the run stopped")));
    }
    summary.pass_threads = sc.pen.pass_threads;
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
        deform: None,
        shaft: None,
        removed_by_region: None,
        debris_erased: DebrisSummary::default(),
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
        gate_armed: setup.gate.arm_on_exit,
        checks: setup.checks.clone(),
    };
    let (rep, error) = ended.report(servo, &shared, Some(summary))?;
    if let Some(path) = &setup.view.screenshot {
        crate::viewer::screenshot(&mut shown, path, setup.view.clip)?;
    }
    if let Some(p) = rep.pen.as_ref().filter(|_| setup.summary) {
        outln!(
            "tool {} nodes / {} tets, depth {}: {} contact passes ({} thread{}), us: mean {:.1}  \
             p99 {:.1}  max {:.1}; pass age ticks: mean {:.2}  max {}",
            p.tool_nodes,
            p.tool_tets,
            p.depth_method,
            p.passes,
            p.pass_threads,
            if p.pass_threads == 1 { "" } else { "s" },
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
