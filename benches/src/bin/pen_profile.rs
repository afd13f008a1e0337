//! The pen's contact pass (`pen_contact`, traced depth, crossings searched) over the contact
//! bench's poses of the pen x10, for wall clock and instruction counts without criterion.
//!
//! Usage: `pen_profile MESH touching|impaled [REPS]` (MESH relative to the meshes folder:
//! `TETRADRILL_MESHES` or the repository's `tests/data/meshes`). Every pose runs REPS times
//! (default 20), each run from a fresh `PenState` (`SHARED=1`: one state for all, as the
//! contact bench keeps it); prints the mean, p99 and maximum over the
//! poses of each pose's fastest run, the slowest poses with their counts (nodes inside, border
//! points, border edges and walk work, each side), and a digest of the raw forces (the same on
//! every run and every build that keeps the forces). Instruction counts: `valgrind
//! --tool=callgrind --dump-instr=no --toggle-collect='*run_pose*' pen_profile MESH touching 1`
//! (one call per pose); `POSE=i` in the environment runs only pose i; `THREADS=2` runs the
//! pass's object side on a second thread (`tetradrill::pen_pair`, callgrind then counts only
//! the calling thread: `--toggle-collect='*run_pair*'`); `SIDES=1` times the pass's three
//! calls apart (`pen_place`, `pen_side`, `object_side`) and prints each one's fastest for the
//! slowest poses. Exit status 2 for bad
//! arguments or an unreadable mesh.

use std::hint::black_box;
use std::io::Write;
use std::process::ExitCode;
use std::time::Instant;

use glam::{Quat, Vec3};
use tetradrill::pen::PenRig;
use tetradrill::pen_pair::{with_pen_pair, PenPair};
use tetradrill_benches::{pen_profile_setup, PenProfile};
use tetradrill_core::force::{
    force_digest, object_side, pen_contact, pen_place, pen_side, PenBuffers, PenContact,
    PenOptions, PenScene, PenState,
};

/// One pen contact call at one pose, on its own so callgrind can count it alone.
#[inline(never)]
fn run_pose(
    scene: &PenScene<'_, '_, '_>,
    bufs: &mut PenBuffers<'_>,
    pose: (Vec3, Quat),
    opts: &PenOptions,
    state: &mut PenState,
) -> PenContact {
    black_box(pen_contact(scene, bufs, pose.0, pose.1, opts, state))
}

/// [`run_pose`] on two threads.
#[inline(never)]
fn run_pair(
    pair: &mut PenPair<'_, '_>,
    pose: (Vec3, Quat),
    opts: &PenOptions,
    state: &mut PenState,
) -> PenContact {
    black_box(pair.contact(pose.0, pose.1, opts, state)).unwrap_or_default()
}

/// [`run_pose`] call by call, each timed: the contact and the microseconds of
/// `pen_place`, `pen_side` and `object_side`.
fn run_sides(
    scene: &PenScene<'_, '_, '_>,
    bufs: &mut PenBuffers<'_>,
    pose: (Vec3, Quat),
    opts: &PenOptions,
    state: &mut PenState,
) -> (PenContact, [f64; 3]) {
    let t0 = Instant::now();
    let at = pen_place(scene, bufs.world, pose.0, pose.1);
    let t1 = Instant::now();
    let (world, found, pen, object) = bufs.sides();
    let pen = pen_side(scene, &at, world, found, pen, opts, state.pen_listed);
    let t2 = Instant::now();
    let object = object_side(scene, &at, world, object, opts, state.object_listed);
    let t3 = Instant::now();
    let pass = at.pass(pen, object, opts, state);
    let c = pass.contact(
        bufs.world,
        bufs.pen_pens,
        bufs.object_pens,
        pose.0,
        opts,
        state,
    );
    let us = |a: Instant, b: Instant| (b - a).as_secs_f64() * 1e6;
    (black_box(c), [us(t0, t1), us(t1, t2), us(t2, t3)])
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
    } = match pen_profile_setup("pen_profile", 20) {
        Ok(p) => p,
        Err(line) => {
            eprintln!("{line}");
            return ExitCode::from(2);
        }
    };
    // `SHARED=1`: one `PenState` for every call, as the contact bench does (each pose then
    // starts from the previous pose's lists), instead of a fresh one per call.
    let shared = std::env::var("SHARED").is_ok_and(|v| v == "1");
    let opts = PenOptions::default();
    let mut rig = PenRig { pen, obj };
    // `SIDES=1`: each pose's pass also timed call by call (`pen_place`, `pen_side`,
    // `object_side`, untimed between), the fastest of each printed for the slowest poses.
    let sides = std::env::var("SIDES").is_ok_and(|v| v == "1");
    // `THREADS=2`: the pass's object side on a second thread (`PenPair`).
    let pair = std::env::var("THREADS").is_ok_and(|v| v == "2");
    let run = rig.with(|scene, bufs| {
        let mut state = PenState::default();
        let mut best = vec![f64::INFINITY; poses.len()];
        let mut last = vec![PenContact::default(); poses.len()];
        let mut sweep = |call: &mut dyn FnMut((Vec3, Quat), &mut PenState) -> PenContact| {
            for _ in 0..reps {
                for (i, &pose) in poses.iter().enumerate() {
                    let s = Instant::now();
                    if !shared {
                        state = PenState::default();
                    }
                    let c = call(pose, &mut state);
                    best[i] = best[i].min(s.elapsed().as_secs_f64() * 1e6);
                    last[i] = c;
                }
            }
        };
        let mut parts = vec![[f64::INFINITY; 3]; poses.len()];
        if pair {
            with_pen_pair(scene, bufs, |pair| {
                sweep(&mut |pose, st| run_pair(pair, pose, &opts, st))
            });
        } else if sides {
            let mut i = 0;
            sweep(&mut |pose, st| {
                let k = i % poses.len();
                i += 1;
                let (c, t) = run_sides(scene, bufs, pose, &opts, st);
                for (b, t) in parts[k].iter_mut().zip(t) {
                    *b = b.min(t);
                }
                c
            });
        } else {
            sweep(&mut |pose, st| run_pose(scene, bufs, pose, &opts, st));
        }
        (best, last, parts)
    });
    let (best, last, parts) = match run {
        Ok(r) => r,
        Err(e) => {
            eprintln!("pen_profile: {mesh}: {e}");
            return ExitCode::from(2);
        }
    };
    let mut sorted = best.clone();
    sorted.sort_by(f64::total_cmp);
    let mean = sorted.iter().sum::<f64>() / sorted.len() as f64;
    let p99 = sorted[(sorted.len() * 99 / 100).min(sorted.len() - 1)];
    let max = sorted[sorted.len() - 1];
    let raw: Vec<Vec3> = last.iter().map(|c| c.raw).collect();
    let mut out = std::io::stdout().lock();
    // A closed pipe (`| head`) ends the output, not the program.
    let _ = writeln!(
        out,
        "{mesh} {}: {} poses, fastest of {reps}: mean {mean:.2} us, p99 {p99:.2} us, max {max:.2} us; raw force digest {:016x}",
        if touching { "touching" } else { "impaled" },
        poses.len(),
        force_digest(&raw)
    );
    let mut order: Vec<usize> = (0..best.len()).collect();
    order.sort_by(|&a, &b| best[b].total_cmp(&best[a]));
    for &i in order.iter().take(5) {
        let c = &last[i];
        let _ = writeln!(
            out,
            "  pose {:3}: {:8.2} us; pen nodes in {:4}, object nodes in {:4}; border points {:4} + {:4}, edges {:4} + {:4}, walk work {:6} + {:6}",
            first + i,
            best[i],
            c.pen_collisions.count,
            c.object_collisions.count,
            c.pen_depth.border_points,
            c.object_depth.border_points,
            c.pen_depth.border_edges,
            c.object_depth.border_edges,
            c.pen_depth.work,
            c.object_depth.work,
        );
        if sides {
            let [a, b, o] = parts[i];
            let _ = writeln!(
                out,
                "            place {a:.2} us, pen side {b:.2} us, object side {o:.2} us (each its fastest)"
            );
        }
    }
    ExitCode::SUCCESS
}
