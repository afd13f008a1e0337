//! `replay --tool mesh:FILE`: the tet-mesh tool against the object, contact only.

use tetradrill_core::depth::Penetration;
use tetradrill_core::force::{pen_servo_force, ForceDigest, HeldContact, PenState, ServoScratch};
use tetradrill_core::Quat;
use tetradrill_core::Vec3;

use super::*;
use crate::pen::PenRig;
use crate::pen_pair::with_pass_runner;

/// `replay --tool mesh:FILE`: the tet-mesh tool (the pen) against the object, contact only
/// (consistent penetration depth, Praktikum report, section 4): the tool sits at the trace's pose
/// each tick (tip at the position, identity rotation = axis along +z).
pub(super) fn replay_pen(
    args: &ReplayArgs,
    scenario: Scenario,
    sc: &Setup,
    loaded: crate::meshio::LoadedMesh,
    pen_path: &std::path::Path,
    pen_scale: f64,
) -> Result<(), CliError> {
    if args.surface.is_some() || args.screenshot.is_some() {
        return Err(CliError::input(
            "--surface and --screenshot show the drilled surface: they need a sphere:R tool",
        ));
    }
    let poses = PoseSource::new(&sc.poses, Some(&loaded.mesh))?;
    let mut forces_out = args.forces.as_deref().map(ForcesCsv::create).transpose()?;
    let mut forces = Vec::new();
    let obj = loaded.mesh;
    let pen = crate::meshio::load(pen_path, pen_scale)?;
    for w in &pen.warnings {
        errln!("tetradrill: warning: {w}");
    }
    let ticks = replay_ticks(args, &poses);
    // The object is not drilled here: its components come from an untouched hierarchy.
    let mut store = crate::pen::object_store(obj.clone(), sc)?;
    let world = store.world()?;
    // The object is only read: its state is checked once, at the end as at the start.
    let valid = engine::validate(&world);
    let h = world.hierarchy();
    let mut scratch = vec![0u32; h.components_scratch_needed()];
    let components = h
        .components(world.mesh(), &mut scratch)
        .map_err(|e| CliError::failure(format!("cannot count components: {e}")))?;
    let (initial_volume, counts, visible_faces) = (
        world.mesh().volume(),
        MeshCounts {
            nodes: world.mesh().node_count(),
            tets: world.mesh().tet_count(),
            boundary_faces: world.mesh().stats().boundary_faces,
        },
        h.visible_face_count(),
    );
    let opts = crate::pen::options(sc);
    let mut pen_info = PenSummary {
        tool_nodes: pen.mesh.positions().len(),
        tool_tets: pen.mesh.tets().len(),
        depth_method: format!("{:?}", sc.pen.depth_method).to_lowercase(),
        ..PenSummary::default()
    };
    let mut rig = PenRig { pen: pen.mesh, obj };
    let mut times = vec![0u64; ticks as usize];
    let mut digest = ForceDigest::new();
    let (mut max_n, mut last, mut contact_ticks) = (0.0f32, Vec3::ZERO, 0u64);
    let mut sat = SaturationCounts::default();
    let progress = !args.quiet && ticks >= 20_000;
    let sizes = sc.capacities.pen();
    let period = u64::from(sc.pen.contact_period.max(1));
    pen_info.contact_period = sc.pen.contact_period;
    pen_info.pass_threads = sc.pen.pass_threads;
    let mut servo_times = vec![0u64; ticks as usize];
    let mut pass_times = Vec::with_capacity(ticks.div_ceil(period) as usize);
    let (ran, setup) = rig
        .with_sizes(sizes, |scene, bufs| {
            let mut state = PenState::default();
            // The servo's scratch: as many penetrations as the pass may write.
            let mut now_pen = vec![Penetration::default(); bufs.pen_pens.len()];
            let mut now_obj = vec![Penetration::default(); bufs.object_pens.len()];
            let mut now = ServoScratch {
                pen: &mut now_pen,
                object: &mut now_obj,
            };
            let mut held = (Vec3::ZERO, Quat::IDENTITY, (0usize, 0usize));
            with_pass_runner(scene, bufs, sc.pen.pass_threads, |runner| {
                for i in 0..ticks {
                    let pose = poses.at(i);
                    let [w, x, y, z] = pose.rotation;
                    let rot = Quat::from_xyzw(x, y, z, w).normalize();
                    let t0 = now_ns();
                    let pass = (i % period == 0)
                        .then(|| runner.pass(pose.position, rot, &opts, &mut state))
                        .transpose()?;
                    let t1 = now_ns();
                    if let Some(c) = &pass {
                        held = (pose.position, rot, c.penetrations);
                    }
                    let (pens, objs) = runner.pens();
                    let contact = HeldContact {
                        position: held.0,
                        rotation: held.1,
                        pen: pens.get(..held.2 .0).unwrap_or(&[]),
                        object: objs.get(..held.2 .1).unwrap_or(&[]),
                    };
                    let f = pen_servo_force(
                        scene,
                        &contact,
                        &mut now,
                        pose.position,
                        rot,
                        &opts,
                        &mut state,
                    );
                    let t2 = now_ns();
                    times[i as usize] = t2 - t0;
                    servo_times[i as usize] = t2 - t1;
                    digest.push(f.force.force);
                    if forces_out.is_some() {
                        forces.push(f.force.force);
                    }
                    max_n = max_n.max(f.force.force.length());
                    contact_ticks += (f.force.force != Vec3::ZERO) as u64;
                    last = f.force.force;
                    pen_info.clamped_ticks += f.force.clamped as u64;
                    pen_info.servo_short_ticks += f.short as u64;
                    let Some(c) = pass else { continue };
                    pass_times.push(t1 - t0);
                    pen_info.passes += 1;
                    pen_info.pen_collisions_max =
                        pen_info.pen_collisions_max.max(c.pen_collisions.count);
                    pen_info.object_collisions_max = pen_info
                        .object_collisions_max
                        .max(c.object_collisions.count);
                    pen_info.unreached += (c.pen_depth.unreached + c.object_depth.unreached) as u64;
                    pen_info.border_edges +=
                        (c.pen_depth.border_edges + c.object_depth.border_edges) as u64;
                    pen_info.reused_crossings +=
                        (c.pen_depth.reused + c.object_depth.reused) as u64;
                    pen_info.saturated_ticks += c.saturated() as u64;
                    sat.contacts += c.contacts_full() as u32;
                    sat.queue += c.queue_full() as u32;
                    if progress && i % 5000 == 0 {
                        err!(
                            "\rreplay: {:>3}% ({i}/{ticks} ticks)",
                            i * 100 / ticks.max(1)
                        );
                    }
                }
                Ok(())
            })
        })
        .map_err(|e| CliError::failure(format!("cannot set up the tool contact: {e}")))?;
    ran.map_err(|e: crate::pen_pair::WorkerGone| CliError::failure(e.to_string()))?;
    if progress {
        errln!("\rreplay: 100% ({ticks}/{ticks} ticks)");
    }
    if let Some(mut out) = forces_out.take() {
        for (i, f) in forces.iter().enumerate() {
            out.row(i as u64, *f)?;
        }
        out.finish()?;
    }
    let t = summarise_ns(&times);
    pen_info.servo_us = TickTiming::from(summarise_ns(&servo_times));
    pen_info.pass_us = TickTiming::from(summarise_ns(&pass_times));
    let rep = ReplayReport {
        mesh: counts,
        ticks,
        initial_volume,
        removed_volume: 0.0,
        removed_by_region: None,
        drill: None,
        hierarchy_nodes: h.node_count(),
        visible_faces,
        components,
        debris_erased: DebrisSummary::default(),
        force: ForceSummary {
            max_n,
            last: last.to_array(),
            contact_ticks,
        },
        force_digest: format!("{:016x}", digest.value()),
        timing_us: TickTiming::from(t),
        runs: 1,
        peaks: None,
        saturations: SaturationCounts {
            hash: setup.hash_saturations,
            ..sat
        }
        .totalled(),
        valid: valid.is_ok(),
        scenario,
        sizing: None,
        shaft: None,
        pen: Some(pen_info),
        deform: None,
    };
    print_summary(&rep);
    if let Some(p) = &rep.pen {
        outln!(
            "tool {} nodes / {} tets, depth {}: most tool nodes inside {}, object nodes inside {}, \
             unreached {}, clamped ticks {}, crossings reused {} of {}",
            p.tool_nodes,
            p.tool_tets,
            p.depth_method,
            p.pen_collisions_max,
            p.object_collisions_max,
            p.unreached,
            p.clamped_ticks,
            p.reused_crossings,
            p.border_edges
        );
        outln!(
            "servo half us: mean {:.1}  p99 {:.1}  max {:.1};  {} contact passes (every {} \
             ticks, {} thread{}) us: mean {:.1}  p99 {:.1}  max {:.1}",
            p.servo_us.tick_mean,
            p.servo_us.tick_p99,
            p.servo_us.tick_max,
            p.passes,
            p.contact_period,
            p.pass_threads,
            if p.pass_threads == 1 { "" } else { "s" },
            p.pass_us.tick_mean,
            p.pass_us.tick_p99,
            p.pass_us.tick_max
        );
    }
    if let Some(path) = &args.json {
        crate::report::write_json(path, &rep)?;
    }
    valid.map_err(|e| CliError::failure(format!("the object's state is invalid: {e}")))
}
