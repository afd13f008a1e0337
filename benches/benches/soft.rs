//! Soft-body bench: one `SoftBody::step` (1 ms, 10 substeps, 1 iteration) on the cow
//! (spot, about 18k tets) and the teddy (about 80k tets), with gravity and the lowest tenth of
//! the nodes fixed, timed from a body already sagging (the state of a running scene).
//!
//! Run: `cargo bench -p tetradrill-benches --bench soft` (set `TETRADRILL_MESHES` if the meshes
//! are not the repository's `tests/data/meshes`). Besides criterion's means, a plain pass prints
//! per mesh the mean, minimum and maximum of single steps (`STEPS`) and the time per tet
//! projection. `SOFT_PROFILE=1` (or `=cow`, `=teddy` for one mesh) skips criterion and runs
//! 20 steps per mesh after the 20 of the set-up, for instruction counts under callgrind:
//! `valgrind --tool=callgrind --toggle-collect='*SoftBody*step*'` counts those 40 steps;
//! `SOFT_PROFILE=parts-cow` (or `parts-teddy`) does the same on the body reordered in two parts
//! (`SoftOwned::in_two_parts`), stepped by `step` on one thread, and `SOFT_PROFILE=two-cow` (or
//! `two-teddy`) by `step_two` on two threads (add `--separate-threads=yes
//! --toggle-collect='*PartSweep*run*'` for each thread's count); `SOFT_PROFILE=lanes-cow` (or
//! `lanes-teddy`) on the body's tets grouped for the sweep's lanes (`SoftOwned::in_lanes`),
//! stepped by `step`. Two more `STEPS` lines per mesh time the body in lanes on one thread and
//! the body in two parts (its parts in lanes too) stepped by `SoftBody::step_two` on two
//! threads.
//!
//! The world's side of a deforming mesh is timed in the same pass (`WORLD` lines): after each
//! soft step (of the body in two parts) the body's positions are handed to a world over the
//! same mesh (`World::set_positions` after a step on one thread: boundary normals, tet boxes,
//! the tet hash moved, the contact caches; `World::set_positions_two` after a step on two
//! threads, its passes over the nodes and tets in two parts on two threads, in turn), and,
//! apart, the tet boxes and the hash rebuild alone on storage of the world's sizes.
//! `SOFT_WORLD_ONLY=1` stops after these two passes (no criterion); `SOFT_PROFILE=world` (or
//! `world-cow`, `world-teddy`) runs 10 `set_positions` per mesh for callgrind
//! (`--toggle-collect='*World*set_positions*'`), `SOFT_PROFILE=world-two` (or
//! `world-two-cow`, `world-two-teddy`) 10 `set_positions_two` (add `--separate-threads=yes`;
//! `--toggle-collect='*MovePart*run*'` counts the parts).

use std::hint::black_box;
use std::time::{Duration, Instant};

use criterion::{criterion_group, Criterion};
use glam::Vec3;
use tetradrill::engine::EngineStorage;
use tetradrill::owned::OwnedMesh;
use tetradrill::setup::Setup;
use tetradrill::soft::{move_on_two_threads, on_two_threads, SoftOwned};
use tetradrill_benches::{load_mesh, soft_bench_body};
use tetradrill_core::hash::{average_edge_length, prime_at_most, Aabb, HashEntry, SpatialHash};
use tetradrill_core::servo::WorldSizes;
use tetradrill_core::soft::SoftBody;
use tetradrill_core::TetId;

fn load(rel: &str) -> OwnedMesh {
    load_mesh(rel, 1.0).expect("mesh loads")
}

const MESHES: [(&str, &str); 2] = [
    ("cow", "models/spot_tetgen_q1.414.node"),
    ("teddy", "models/teddy_cgalbear_tetgen_q1.414.node"),
];

/// Owned storage of one soft body.
struct Scene(SoftOwned);

impl Scene {
    fn new(rel: &str) -> Self {
        let mut owned = load(rel);
        Self(SoftOwned::from_mesh(&owned.view()))
    }

    fn body(&mut self) -> SoftBody<'_> {
        let (mut body, _) = soft_bench_body(&mut self.0, 1).expect("the mesh is a valid soft body");
        // Sag a little first: the bench times a moving body, not one at rest.
        for _ in 0..20 {
            body.step(1e-3, &[]).expect("valid step");
        }
        body
    }
}

const DT: f32 = 1e-3;

/// Each of `runs` calls of `step` timed alone.
fn timed(runs: usize, mut step: impl FnMut()) -> Vec<Duration> {
    (0..runs)
        .map(|_| {
            let t0 = Instant::now();
            step();
            t0.elapsed()
        })
        .collect()
}

fn steps_pass() {
    for (name, rel) in MESHES {
        let mut scene = Scene::new(rel);
        let mut body = scene.body();
        let times = timed(100, || body.step(black_box(DT), &[]).expect("valid step"));
        let (mean, min, max) = spread(&times);
        let p = body.params();
        let projections = (p.substeps * p.iterations) as f64 * body.tet_count() as f64;
        println!(
            "STEPS soft {name}: {} nodes, {} tets, {} substeps x {} iterations: mean {:.2} ms, min {:.2} ms, max {:.2} ms per step, {:.1} ns per tet projection (min)",
            body.node_count(),
            body.tet_count(),
            p.substeps,
            p.iterations,
            mean,
            min,
            max,
            min * 1e6 / projections,
        );
        let worst = body
            .displacements()
            .iter()
            .map(|u| u.length())
            .fold(0.0f32, f32::max);
        assert!(worst.is_finite(), "the {name} stays finite");
        lanes_pass(name, rel);
        two_parts_pass(name, rel);
    }
}

/// The same steps with the body's tets in groups of four that share no node
/// (`SoftOwned::in_lanes`), the sweep's lanes: a `STEPS` line with `in lanes` in it.
fn lanes_pass(name: &str, rel: &str) {
    let (soft, _) = Scene::new(rel).0.in_lanes();
    let mut scene = Scene(soft);
    let mut body = scene.body();
    let times = timed(100, || body.step(black_box(DT), &[]).expect("valid step"));
    let (mean, min, max) = spread(&times);
    println!(
        "STEPS soft {name}, in lanes on one thread: mean {mean:.2} ms, min {min:.2} ms, max {max:.2} ms per step",
    );
}

/// The same steps with the body in two parts on two threads (`SoftBody::step_two` with
/// `on_two_threads`): a `STEPS` line with `two threads` in it.
fn two_parts_pass(name: &str, rel: &str) {
    let mut owned = load(rel);
    let (soft, order) = SoftOwned::from_mesh(&owned.view()).in_two_parts();
    let mut scene = Scene(soft);
    let mut body = scene.body();
    let parts = order.parts(&body).expect("two parts");
    let times = timed(100, || {
        body.step_two(black_box(DT), &[], parts, &mut on_two_threads)
            .expect("valid step")
    });
    let (mean, min, max) = spread(&times);
    println!(
        "STEPS soft {name}, two parts on two threads: {} + {} tets, {} joining: mean {mean:.2} ms, min {min:.2} ms, max {max:.2} ms per step",
        parts.tets_a(),
        parts.tets_b() - parts.tets_a(),
        body.tet_count() - parts.tets_b(),
    );
}

/// Mean, minimum and maximum of `times`, in ms.
fn spread(times: &[Duration]) -> (f64, f64, f64) {
    let ms = |d: Duration| d.as_secs_f64() * 1e3;
    let mean = times.iter().sum::<Duration>() / times.len().max(1) as u32;
    let min = times.iter().min().copied().unwrap_or_default();
    let max = times.iter().max().copied().unwrap_or_default();
    (ms(mean), ms(min), ms(max))
}

/// `World::set_positions` and `World::set_positions_two` after soft steps, in turn, and the
/// boxes and hash rebuild alone.
fn world_pass() {
    for (name, rel) in MESHES {
        // The body in two parts, as the soft driver steps it on two threads; its node `i` is
        // the world's node `node_of[i]`.
        let (soft, order) = Scene::new(rel).0.in_two_parts();
        let mut scene = Scene(soft);
        let mut body = scene.body();
        let parts = order.parts(&body).expect("two parts");
        let mut storage = EngineStorage::new(load(rel), &Setup::default()).expect("storage");
        // Deforming as the soft driver's world is: rest state and spare tables.
        storage.enable_deformation().expect("deformation storage");
        let mut world = storage.world().expect("world");
        let mut now = vec![Vec3::ZERO; body.node_count()];
        let runs = 50;
        let (mut times, mut two) = (Vec::with_capacity(runs), Vec::with_capacity(runs));
        let mut entries = 0;
        // One thread and two in turn, each after its own soft step.
        for k in 0..2 * runs {
            // Each update after a step on as many threads, as the driver runs them.
            if k % 2 == 0 {
                body.step(DT, &[]).expect("valid step");
            } else {
                body.step_two(DT, &[], parts, &mut on_two_threads)
                    .expect("valid step");
            }
            for ((&x, &u), &i) in body
                .rest()
                .iter()
                .zip(body.displacements())
                .zip(&order.node_of)
            {
                now[i as usize] = x + u;
            }
            let t0 = Instant::now();
            let rep = if k % 2 == 0 {
                world.set_positions(black_box(&now))
            } else {
                world.set_positions_two(black_box(&now), &mut move_on_two_threads)
            }
            .expect("positions");
            [&mut times, &mut two][k % 2].push(t0.elapsed());
            assert!(!rep.hash_saturated, "the {name}'s hash fits");
            entries = rep.hash_entries;
        }
        let (mean, min, max) = spread(&times);
        let (tmean, tmin, tmax) = spread(&two);
        let updates = world.hash().stats().updates;
        // The boxes and the hash alone, on storage of the world's sizes.
        let mesh = world.mesh();
        let sizes = WorldSizes::new(mesh.tet_count(), 0);
        let buckets = prime_at_most((sizes.hash_starts - 1) as u32) as usize;
        let mut starts = vec![0u32; buckets + 1];
        let mut slots = vec![HashEntry::default(); sizes.hash_entries];
        let mut boxes = vec![Aabb::point(Vec3::ZERO); mesh.tet_count()];
        let mut hash = SpatialHash::new(&mut starts, &mut slots, average_edge_length(mesh))
            .expect("hash storage");
        let mut alone = Vec::with_capacity(runs);
        for _ in 0..runs {
            let t0 = Instant::now();
            for (t, b) in boxes.iter_mut().enumerate() {
                *b = Aabb::of(mesh.tet_positions(TetId::from_idx(t)));
            }
            let built = hash.rebuild(boxes.len(), |t| boxes.get(t).copied());
            black_box(built);
            alone.push(t0.elapsed());
        }
        let (hmean, hmin, hmax) = spread(&alone);
        println!(
            "WORLD soft {name}: {} nodes, {} tets, {} buckets, {entries} hash entries: set_positions ({updates} of {} in place) mean {mean:.3} ms, min {min:.3} ms, max {max:.3} ms; set_positions_two on two threads mean {tmean:.3} ms, min {tmin:.3} ms, max {tmax:.3} ms; boxes and hash rebuild alone mean {hmean:.3} ms, min {hmin:.3} ms, max {hmax:.3} ms",
            mesh.node_count(),
            mesh.tet_count(),
            buckets,
            2 * runs,
        );
    }
}

/// `SOFT_PROFILE=world` (or `world-cow`, `world-teddy` for one mesh): per mesh, 10
/// `World::set_positions` after soft steps, as the `WORLD` lines time them, for instruction
/// counts: `valgrind --tool=callgrind --toggle-collect='*World*set_positions*'` counts
/// those calls. `world-two` (`world-two-cow`, `world-two-teddy`): `set_positions_two` on
/// two threads instead.
fn world_profile(only: &str) {
    // `two-cow`, `two-teddy`: `World::set_positions_two` on two threads instead.
    let (two, only) = match only.strip_prefix("two") {
        Some(rest) => (true, rest.trim_start_matches('-')),
        None => (false, only),
    };
    for (_, rel) in MESHES
        .iter()
        .filter(|(name, _)| only.is_empty() || only == *name)
    {
        let mut scene = Scene::new(rel);
        let mut body = scene.body();
        let mut storage = EngineStorage::new(load(rel), &Setup::default()).expect("storage");
        // Deforming as the soft driver's world is: rest state and spare tables.
        storage.enable_deformation().expect("deformation storage");
        let mut world = storage.world().expect("world");
        let mut now = vec![Vec3::ZERO; body.node_count()];
        for _ in 0..10 {
            body.step(DT, &[]).expect("valid step");
            body.write_positions(&mut now);
            let rep = if two {
                world.set_positions_two(black_box(&now), &mut move_on_two_threads)
            } else {
                world.set_positions(black_box(&now))
            };
            black_box(rep.expect("positions"));
        }
    }
}

fn bench_soft(c: &mut Criterion) {
    for (name, rel) in MESHES {
        let mut scene = Scene::new(rel);
        let mut body = scene.body();
        c.bench_function(&format!("soft_step_{name}"), |b| {
            b.iter(|| body.step(black_box(DT), &[]).expect("valid step"))
        });
    }
}

criterion_group! {
    name = benches;
    config = Criterion::default()
        .measurement_time(Duration::from_secs(3))
        .sample_size(10);
    targets = bench_soft
}

fn main() {
    if let Some(only) = std::env::var("SOFT_PROFILE")
        .ok()
        .and_then(|v| v.strip_prefix("world").map(str::to_owned))
    {
        world_profile(only.trim_start_matches('-'));
        return;
    }
    if let Ok(only) = std::env::var("SOFT_PROFILE") {
        // `parts-cow`, `parts-teddy`: the body reordered in two parts, stepped by `step` on one
        // thread; `two-cow`, `two-teddy`: the same body stepped by `step_two` on two threads.
        // `lanes-cow`, `lanes-teddy`: the tets in groups of four for the sweep's lanes
        // (`SoftOwned::in_lanes`), stepped by `step`.
        let (mode, only) = match (
            only.strip_prefix("parts-"),
            only.strip_prefix("two-"),
            only.strip_prefix("lanes-"),
        ) {
            (Some(name), _, _) => (1, name.to_owned()),
            (_, Some(name), _) => (2, name.to_owned()),
            (_, _, Some(name)) => (3, name.to_owned()),
            _ => (0, only),
        };
        for (_, rel) in MESHES
            .iter()
            .filter(|(name, _)| only == "1" || only == *name)
        {
            let mut scene = Scene::new(rel);
            let mut order = None;
            if mode == 3 {
                scene = Scene(scene.0.in_lanes().0);
            } else if mode > 0 {
                let (soft, o) = scene.0.in_two_parts();
                scene = Scene(soft);
                order = Some(o);
            }
            let mut body = scene.body();
            let parts = order.and_then(|o| o.parts(&body));
            for _ in 0..20 {
                match parts {
                    Some(p) if mode == 2 => body
                        .step_two(black_box(DT), &[], p, &mut on_two_threads)
                        .expect("valid step"),
                    _ => body.step(black_box(DT), &[]).expect("valid step"),
                }
            }
        }
        return;
    }
    steps_pass();
    world_pass();
    if std::env::var("SOFT_WORLD_ONLY").is_ok() {
        return;
    }
    benches();
    Criterion::default().configure_from_args().final_summary();
}
