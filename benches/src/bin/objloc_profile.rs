//! The object side's location phase of the pen's contact pass alone
//! (`rigid_tets_over_points_coherent`: the object's nodes inside the moved pen), cold and warm,
//! over the contact bench's poses of the pen x10.
//!
//! Usage: `objloc_profile MESH touching|impaled [REPS]` (MESH relative to the meshes folder:
//! `TETRADRILL_MESHES` or the repository's `tests/data/meshes`). Cold: every pose's phase runs
//! once per round with the poses interleaved, each followed by the whole pass at the same pose
//! (so the next pose meets the caches a pass leaves); warm: each pose's phase `REPS` times in a
//! row. Prints the mean and the slowest poses of each pose's fastest run, and a digest of the
//! collision lists (node and tet of every entry, every pose: the same on every build that keeps
//! the lists). `POSE=i` runs only pose i. Exit status 2 for bad arguments or an unreadable mesh.

use std::hint::black_box;
use std::io::Write;
use std::process::ExitCode;
use std::time::Instant;

use glam::{Affine3A, Quat, Vec3};
use tetradrill::pen::PenRig;
use tetradrill_benches::{pen_profile_setup, PenProfile};
use tetradrill_core::collide::{rigid_tets_over_points_coherent, Body, CollideReport};
use tetradrill_core::force::{pen_contact, PenBuffers, PenOptions, PenScene, PenState};

/// The phase at one pose: the pen placed (untimed by callers that time only the phase), its
/// near clusters, the object's nodes located in it. Returns the report.
#[inline(never)]
fn run_phase(
    scene: &PenScene<'_, '_, '_>,
    bufs: &mut PenBuffers<'_>,
    pose: (Vec3, Quat),
    opts: &PenOptions,
) -> (CollideReport, f64) {
    let affine = Affine3A::from_rotation_translation(pose.1, pose.0);
    for (w, &r) in bufs.world.iter_mut().zip(scene.pen.positions()) {
        *w = affine.transform_point3(r);
    }
    let pen_body = Body::moved(scene.pen, bufs.world, pose.1);
    let near = scene.pen_rest.near(affine, scene.object_cells);
    let s = Instant::now();
    let r = black_box(rigid_tets_over_points_coherent(
        scene.object_nodes,
        scene.object.positions,
        scene.pen_rest,
        &pen_body,
        affine,
        &near,
        bufs.object_hits,
        0,
        if scene.pen_walks { opts.max_walk } else { 0 },
    ));
    (r, s.elapsed().as_secs_f64() * 1e6)
}

/// FNV-1a over the words.
fn fnv(h: &mut u64, w: u32) {
    for b in w.to_le_bytes() {
        *h ^= b as u64;
        *h = h.wrapping_mul(0x100_0000_01b3);
    }
}

fn main() -> ExitCode {
    let PenProfile {
        mesh,
        pen,
        obj,
        touching,
        poses,
        first,
        reps,
    } = match pen_profile_setup("objloc_profile", 20) {
        Ok(p) => p,
        Err(line) => {
            eprintln!("{line}");
            return ExitCode::from(2);
        }
    };
    let opts = PenOptions::default();
    let mut rig = PenRig { pen, obj };
    let run = rig.with(|scene, bufs| {
        let mut cold = vec![f64::INFINITY; poses.len()];
        let mut warm = vec![f64::INFINITY; poses.len()];
        let mut digest = 0xcbf2_9ce4_8422_2325u64;
        let mut counts = vec![0usize; poses.len()];
        for round in 0..reps {
            for (i, &pose) in poses.iter().enumerate() {
                let (r, us) = run_phase(scene, bufs, pose, &opts);
                cold[i] = cold[i].min(us);
                if round == 0 {
                    counts[i] = r.count;
                    for c in bufs.object_hits.iter().take(r.count) {
                        fnv(&mut digest, c.node.0);
                        fnv(&mut digest, c.tet.0);
                    }
                }
                let mut state = PenState::default();
                black_box(pen_contact(scene, bufs, pose.0, pose.1, &opts, &mut state));
            }
        }
        for (i, &pose) in poses.iter().enumerate() {
            for _ in 0..reps {
                let (_, us) = run_phase(scene, bufs, pose, &opts);
                warm[i] = warm[i].min(us);
            }
        }
        (cold, warm, digest, counts)
    });
    let (cold, warm, digest, counts) = match run {
        Ok(r) => r,
        Err(e) => {
            eprintln!("objloc_profile: {mesh}: {e}");
            return ExitCode::from(2);
        }
    };
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    let mut out = std::io::stdout().lock();
    let _ = writeln!(
        out,
        "{mesh} {}: {} poses, fastest of {reps}: cold mean {:.2} us, warm mean {:.2} us; collision digest {digest:016x}",
        if touching { "touching" } else { "impaled" },
        poses.len(),
        mean(&cold),
        mean(&warm),
    );
    let mut order: Vec<usize> = (0..cold.len()).collect();
    order.sort_by(|&a, &b| cold[b].total_cmp(&cold[a]));
    for &i in order.iter().take(5) {
        let _ = writeln!(
            out,
            "  pose {:3}: cold {:7.2} us, warm {:7.2} us; object nodes in {:4}",
            first + i,
            cold[i],
            warm[i],
            counts[i]
        );
    }
    ExitCode::SUCCESS
}
