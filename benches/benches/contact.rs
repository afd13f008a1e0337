//! Contact benchmarks (issue 3): per-tick contact + depth + force of the pen against the cow
//! and the teddy, traced vs hashed depth, the sphere burr, and point location (the pen's nodes
//! at touching and impaled poses: our hash alone, with the occupancy grid, with walks) against
//! parry3d's BVH with its tetrahedron point queries, the same pairs checked on both sides.
//!
//! Run: `cargo bench -p tetradrill-benches --bench contact` (set `TETRADRILL_MESHES` if the
//! meshes are not the repository's `tests/data/meshes`). Besides criterion's means, a worst-case pass
//! prints, per scenario, the mean, the 99th percentile and the maximum of single ticks
//! (`WORST`), and the same over the poses with each pose's fastest call (`POSES`: the work's
//! worst case without the preemption of a shared machine, each call after the other poses', so
//! with the caches full of other data), and for the pen each pose's fastest of its calls in a
//! row (`WARM`: its data in the caches, as successive passes of a session find it). The pen's
//! lines marked "two threads" run the pass's object side on a second thread
//! (`tetradrill::pen_pair`).

use std::hint::black_box;
use std::time::{Duration, Instant};

use criterion::{criterion_group, criterion_main, Criterion};
use glam::{Quat, Vec3};
use parry3d::bounding_volume::Aabb as PAabb;
use parry3d::math::Vector as PVec;
use parry3d::partitioning::{Bvh, BvhBuildStrategy};
use parry3d::query::PointQuery;
use parry3d::shape::Tetrahedron;
use tetradrill::owned::OwnedMesh;
use tetradrill::pen::{HashStore, PenRig};
use tetradrill::pen_pair::with_pen_pair;
use tetradrill_benches::{impaled_poses, load_mesh, touch_poses, Lcg};
use tetradrill_core::collide::{
    hash_tets, points_in_tets, points_in_tets_occupied, points_in_tets_walked, walks_exact,
    Collision, WalkStarts,
};
use tetradrill_core::depth::Penetration;
use tetradrill_core::force::{
    mesh_sphere_contact, pen_contact, pen_pass, pen_servo_force, DepthMethod, HeldContact,
    PenBuffers, PenOptions, PenScene, PenState, ServoScratch,
};
use tetradrill_core::hash::average_edge_length;
use tetradrill_core::ids::{NodeId, TetId};

fn load(rel: &str, scale: f64) -> OwnedMesh {
    load_mesh(rel, scale).expect("mesh loads")
}

/// Single-call timings in microseconds: over every call (mean, p99, max), and over the poses
/// with each pose's fastest call (its cost without preemption on this shared machine: the
/// worst pose is the worst case of the work, the raw max is mostly a scheduler slice).
struct Timings {
    calls: (f64, f64, f64),
    poses: (f64, f64, f64),
}

/// `(mean, p99, max)` of `t` (sorted here).
fn summary(t: &mut [f64]) -> (f64, f64, f64) {
    t.sort_by(|a, b| a.partial_cmp(b).unwrap());
    let mean = t.iter().sum::<f64>() / t.len() as f64;
    let p99 = t[(t.len() * 99 / 100).min(t.len() - 1)];
    (mean, p99, *t.last().unwrap())
}

fn worst<F: FnMut(usize)>(n: usize, reps: usize, mut f: F) -> Timings {
    let mut t = Vec::with_capacity(n * reps);
    let mut best = vec![f64::INFINITY; n];
    for _ in 0..reps {
        for (i, b) in best.iter_mut().enumerate() {
            let s = Instant::now();
            f(i);
            let us = s.elapsed().as_secs_f64() * 1e6;
            t.push(us);
            *b = b.min(us);
        }
    }
    Timings {
        calls: summary(&mut t),
        poses: summary(&mut best),
    }
}

/// Each pose's fastest of `reps` calls in a row (mean, p99, max over the poses): the cost with
/// the pose's data in the caches, as in a session where successive passes see nearly the same
/// pose. [`worst`] interleaves the poses instead, so each call finds the caches full of other
/// poses' data (the cold case).
fn warm<F: FnMut(usize)>(n: usize, reps: usize, mut f: F) -> (f64, f64, f64) {
    let mut best: Vec<f64> = (0..n)
        .map(|i| {
            (0..reps)
                .map(|_| {
                    let s = Instant::now();
                    f(i);
                    s.elapsed().as_secs_f64() * 1e6
                })
                .fold(f64::INFINITY, f64::min)
        })
        .collect();
    summary(&mut best)
}

fn report_warm(name: &str, (mean, p99, max): (f64, f64, f64)) {
    println!("WARM  {name:<34} mean {mean:8.2} us  p99 {p99:8.2} us  max {max:8.2} us (fastest of each pose, calls in a row)");
}

fn report(name: &str, t: Timings) {
    let (mean, p99, max) = t.calls;
    println!("WORST {name:<34} mean {mean:8.2} us  p99 {p99:8.2} us  max {max:8.2} us");
    let (mean, p99, max) = t.poses;
    println!("POSES {name:<34} mean {mean:8.2} us  p99 {p99:8.2} us  max {max:8.2} us (fastest of each pose)");
}

fn pen_benches(c: &mut Criterion, label: &str, obj_rel: &str) {
    // The scene and the per-tick buffers of every pen run: the core's `owned::PenRig`.
    let mut rig = PenRig {
        pen: load("models/pen_tool_gmsh.mesh", 10.0),
        obj: load(obj_rel, 1.0),
    };
    rig.with(|scene, bufs| pen_benches_over(c, label, scene, bufs))
        .expect("the pen's contact scene builds");
}

fn pen_benches_over(
    c: &mut Criterion,
    label: &str,
    scene: &PenScene<'_, '_, '_>,
    bufs: &mut PenBuffers<'_>,
) {
    let pen = scene.pen;
    let obj = scene.object.mesh;
    let ob = scene.object;
    let pg = scene.pen_graph;
    let th = scene.object_tets;
    let cells = scene.object_cells;
    let fh = scene
        .object_faces
        .expect("the rig hashes the object's faces");
    let cell = average_edge_length(obj);
    let ps_list = touch_poses(obj, 200, 0.05, 7);
    let deep_list = impaled_poses(obj, 200, 0.25, 7);
    let traced = PenOptions::default();
    let hashed = PenOptions {
        method: DepthMethod::Hashed,
        ..PenOptions::default()
    };
    let mut contacts = 0usize;
    for &(p, q) in &ps_list {
        let r = pen_contact(scene, bufs, p, q, &traced, &mut PenState::default());
        assert!(!r.saturated());
        contacts += r.pen_collisions.count + r.object_collisions.count;
    }
    println!(
        "{label}: {} tets, {} poses, {:.1} colliding nodes per pose on average",
        obj.tet_count(),
        ps_list.len(),
        contacts as f64 / ps_list.len() as f64
    );

    let mut deep_contacts = 0usize;
    for &(p, q) in &deep_list {
        let r = pen_contact(scene, bufs, p, q, &traced, &mut PenState::default());
        deep_contacts += r.pen_collisions.count + r.object_collisions.count;
    }
    println!(
        "{label}: adversarial poses: {:.1} colliding nodes per pose on average",
        deep_contacts as f64 / deep_list.len() as f64
    );
    for (name, opts) in [("traced", &traced), ("hashed", &hashed)] {
        let mut st = PenState::default();
        report(
            &format!("pen_tick_impaled/{label}/{name}"),
            worst(deep_list.len(), 5, |i| {
                let (p, q) = deep_list[i];
                black_box(pen_contact(scene, bufs, p, q, opts, &mut st));
            }),
        );
        report_warm(
            &format!("pen_tick_impaled/{label}/{name}"),
            warm(deep_list.len(), 5, |i| {
                let (p, q) = deep_list[i];
                black_box(pen_contact(scene, bufs, p, q, opts, &mut st));
            }),
        );
    }

    // Worst case over the poses (single ticks).
    for (name, opts) in [("traced", &traced), ("hashed", &hashed)] {
        let mut st = PenState::default();
        report(
            &format!("pen_tick/{label}/{name}"),
            worst(ps_list.len(), 20, |i| {
                let (p, q) = ps_list[i];
                black_box(pen_contact(scene, bufs, p, q, opts, &mut st));
            }),
        );
        report_warm(
            &format!("pen_tick/{label}/{name}"),
            warm(ps_list.len(), 20, |i| {
                let (p, q) = ps_list[i];
                black_box(pen_contact(scene, bufs, p, q, opts, &mut st));
            }),
        );
    }

    // The same, the object side on a second thread (`PenPair`): the same forces, about the
    // longer side's time.
    with_pen_pair(scene, bufs, |pair| {
        let opts = &traced;
        for (kind, list, reps) in [
            ("pen_tick", &ps_list, 20),
            ("pen_tick_impaled", &deep_list, 5),
        ] {
            let name = format!("{kind}/{label}/traced, two threads");
            let mut st = PenState::default();
            let mut call = |i: usize| {
                let (p, q) = list[i];
                black_box(pair.contact(p, q, opts, &mut st).expect("worker runs"));
            };
            report(&name, worst(list.len(), reps, &mut call));
            report_warm(&name, warm(list.len(), reps, &mut call));
        }
    });

    let mut g = c.benchmark_group(format!("pen_tick/{label}"));
    for (name, opts) in [("traced", &traced), ("hashed", &hashed)] {
        let mut i = 0usize;
        let mut st = PenState::default();
        g.bench_function(name, |b| {
            b.iter(|| {
                let (p, q) = ps_list[i % ps_list.len()];
                i += 1;
                black_box(pen_contact(scene, bufs, p, q, opts, &mut st))
            })
        });
    }
    g.finish();

    // The servo half alone (`pen_servo_force`): each touching pose's pass held (copied,
    // untimed), carried to the pose moved 0.5 mm, as a servo tick does between passes.
    let held: Vec<(Vec3, Quat, Vec<Penetration>, Vec<Penetration>)> = ps_list
        .iter()
        .map(|&(p, q)| {
            let r = pen_pass(scene, bufs, p, q, &traced, &mut PenState::default());
            let (np, no) = r.penetrations;
            (
                p,
                q,
                bufs.pen_pens[..np].to_vec(),
                bufs.object_pens[..no].to_vec(),
            )
        })
        .collect();
    let (mut a, mut b) = (
        vec![Penetration::default(); pen.node_count()],
        vec![Penetration::default(); obj.node_count()],
    );
    let mut now = ServoScratch {
        pen: &mut a,
        object: &mut b,
    };
    let step = Vec3::new(3e-4, -3e-4, 2.5e-4);
    let servo = |i: usize, st: &mut PenState, now: &mut ServoScratch<'_>| {
        let (p, q, pens, objs) = &held[i];
        let h = HeldContact {
            position: *p,
            rotation: *q,
            pen: pens,
            object: objs,
        };
        pen_servo_force(scene, &h, now, *p + step, *q, &traced, st)
    };
    let mut st = PenState::default();
    report(
        &format!("pen_servo/{label}"),
        worst(held.len(), 20, |i| {
            black_box(servo(i, &mut st, &mut now));
        }),
    );
    let mut i = 0usize;
    c.bench_function(&format!("pen_servo/{label}"), |bch| {
        bch.iter(|| {
            i += 1;
            black_box(servo(i % held.len(), &mut st, &mut now))
        })
    });

    // Collision queries only: our hash vs parry3d's BVH over the same tet boxes, the same
    // points (the pen's nodes at each pose), smallest containing tet per point.
    let tet_pts: Vec<[Vec3; 4]> = (0..obj.tet_count())
        .map(|t| obj.tet_positions(TetId::from_idx(t)))
        .collect();
    let pv = |v: Vec3| PVec::new(v.x, v.y, v.z);
    let leaves: Vec<PAabb> = tet_pts
        .iter()
        .map(|p| {
            let lo = p.iter().fold(p[0], |a, &b| a.min(b));
            let hi = p.iter().fold(p[0], |a, &b| a.max(b));
            PAabb::new(pv(lo), pv(hi))
        })
        .collect();
    let tets: Vec<Tetrahedron> = tet_pts
        .iter()
        .map(|p| Tetrahedron::new(pv(p[0]), pv(p[1]), pv(p[2]), pv(p[3])))
        .collect();
    let bvh = Bvh::from_leaves(BvhBuildStrategy::Binned, &leaves);
    let np = pen.node_count();
    let mut out = vec![Collision::default(); np];
    let mut found = vec![TetId::NONE; np];
    let mut scratch = Vec::new();
    // parry3d: per point, the smallest leaf whose tet holds it (the answer our queries give).
    let parry_query = |pts: &[Vec3], hits: &mut Vec<(u32, u32)>| -> usize {
        let mut n = 0;
        for (i, &x) in pts.iter().enumerate() {
            let px = pv(x);
            let mut best = u32::MAX;
            for leaf in bvh.intersect_aabb(&PAabb::new(px, px)) {
                if leaf < best && tets[leaf as usize].contains_local_point(px) {
                    best = leaf;
                }
            }
            if best != u32::MAX {
                n += 1;
                hits.push((i as u32, best));
            }
        }
        n
    };
    // Ours, three ways over the same hash: every point looked up in its cell
    // (`points_in_tets`); culled by the object's occupancy grid and tet boxes
    // (`points_in_tets_occupied`); and walking from a neighbouring pen node's tet before the
    // look-up (`points_in_tets_walked`, the pen pass's query; exact on these meshes).
    let walks = if walks_exact(&ob) { 8 } else { 0 };
    let pen_graph = &pg;
    let plain = |pts: &[Vec3], out: &mut [Collision]| points_in_tets(th, &ob, pts, false, out);
    // The hash alone over cells of half an average edge (28 entries a tet on these meshes
    // instead of 8): fewer tets share a cell.
    // Buckets about twice the entries, so a cell rarely shares its bucket.
    let mut fine_store = HashStore::with_buckets(obj.tet_count(), 32, 64);
    let mut fine = fine_store.hash(cell * 0.5).expect("a usable cell");
    assert!(!hash_tets(&mut fine, &ob).saturated);
    let fine = fine;
    let plain_fine =
        |pts: &[Vec3], out: &mut [Collision]| points_in_tets(&fine, &ob, pts, false, out);
    let occupied = |pts: &[Vec3], out: &mut [Collision]| {
        points_in_tets_occupied(th, cells, &ob, pts, false, out, 0, |_| true)
    };
    let walked = |pts: &[Vec3], out: &mut [Collision], found: &mut [TetId]| {
        let starts = WalkStarts {
            found,
            near: |i| pen_graph.neighbours(NodeId::from_idx(i)),
            max_steps: walks,
        };
        points_in_tets_walked(th, cells, &ob, pts, out, 0, starts, |_| true)
    };
    // Touching poses (most pen nodes outside the object) and impaled ones (many inside): the
    // pen's nodes at the first 50 poses of each list.
    for (group, list) in [("query", &ps_list), ("query_impaled", &deep_list)] {
        let pose_pts: Vec<Vec<Vec3>> = list
            .iter()
            .take(50)
            .map(|&(p, q)| pen.positions().iter().map(|&x| q * x + p).collect())
            .collect();
        // Same answers: the same (point, tet) pairs from every query on every pose.
        let pairs = |c: &[Collision]| -> Vec<(u32, u32)> {
            c.iter().map(|c| (c.node.0, c.tet.0)).collect()
        };
        let (mut ours, mut theirs, mut differ) = (0usize, 0usize, 0usize);
        for pts in &pose_pts {
            let mut want = Vec::new();
            theirs += parry_query(pts, &mut want);
            let r = plain(pts, &mut out);
            let got = pairs(&out[..r.count]);
            ours += r.count;
            differ += got.iter().filter(|g| !want.contains(g)).count();
            differ += want.iter().filter(|w| !got.contains(w)).count();
            let r = plain_fine(pts, &mut out);
            assert_eq!(pairs(&out[..r.count]), got, "finer hash differs");
            let r = occupied(pts, &mut out);
            assert_eq!(pairs(&out[..r.count]), got, "occupied query differs");
            let r = walked(pts, &mut out, &mut found);
            assert_eq!(pairs(&out[..r.count]), got, "walked query differs");
        }
        println!(
            "{label}: {group} contacts ours {ours}, parry3d {theirs}, pairs that differ {differ} \
             (walks: {walks} steps)"
        );
        report(
            &format!("{group}/{label}/spatial_hash"),
            worst(pose_pts.len(), 20, |i| {
                black_box(plain(&pose_pts[i], &mut out));
            }),
        );
        report(
            &format!("{group}/{label}/spatial_hash_half_cells"),
            worst(pose_pts.len(), 20, |i| {
                black_box(plain_fine(&pose_pts[i], &mut out));
            }),
        );
        report(
            &format!("{group}/{label}/occupied"),
            worst(pose_pts.len(), 20, |i| {
                black_box(occupied(&pose_pts[i], &mut out));
            }),
        );
        report(
            &format!("{group}/{label}/walked"),
            worst(pose_pts.len(), 20, |i| {
                black_box(walked(&pose_pts[i], &mut out, &mut found));
            }),
        );
        report(
            &format!("{group}/{label}/parry3d_bvh"),
            worst(pose_pts.len(), 20, |i| {
                scratch.clear();
                black_box(parry_query(&pose_pts[i], &mut scratch));
            }),
        );
        let mut g = c.benchmark_group(format!("{group}/{label}"));
        let n = pose_pts.len();
        let mut i = 0usize;
        g.bench_function("spatial_hash", |b| {
            b.iter(|| {
                i += 1;
                black_box(plain(&pose_pts[i % n], &mut out))
            })
        });
        g.bench_function("spatial_hash_half_cells", |b| {
            b.iter(|| {
                i += 1;
                black_box(plain_fine(&pose_pts[i % n], &mut out))
            })
        });
        g.bench_function("occupied", |b| {
            b.iter(|| {
                i += 1;
                black_box(occupied(&pose_pts[i % n], &mut out))
            })
        });
        g.bench_function("walked", |b| {
            b.iter(|| {
                i += 1;
                black_box(walked(&pose_pts[i % n], &mut out, &mut found))
            })
        });
        g.bench_function("parry3d_bvh", |b| {
            b.iter(|| {
                i += 1;
                scratch.clear();
                black_box(parry_query(&pose_pts[i % n], &mut scratch))
            })
        });
        g.finish();
    }

    // Sphere burr: radius 0.03 (about half an edge), centre within the radius of the surface.
    let mut r = Lcg(11);
    let boundary: Vec<usize> = (0..obj.node_count())
        .filter(|&i| obj.nodes()[i].boundary())
        .collect();
    let spheres: Vec<Vec3> = (0..200)
        .map(|_| {
            let b = boundary[(r.unit() * boundary.len() as f32) as usize % boundary.len()];
            obj.positions()[b] + obj.normals()[b] * r.range(-0.03, 0.03)
        })
        .collect();
    report(
        &format!("sphere_burr/{label}"),
        worst(spheres.len(), 20, |i| {
            black_box(mesh_sphere_contact(fh, &ob, spheres[i], 0.03, 512));
        }),
    );
    let mut i = 0usize;
    c.bench_function(&format!("sphere_burr/{label}"), |b| {
        b.iter(|| {
            i += 1;
            black_box(mesh_sphere_contact(
                fh,
                &ob,
                spheres[i % spheres.len()],
                0.03,
                512,
            ))
        })
    });
}

fn contact(c: &mut Criterion) {
    pen_benches(c, "cow", "models/spot_tetgen_q1.414.node");
    pen_benches(c, "teddy", "models/teddy_cgalbear_tetgen_q1.414.node");
}

criterion_group! {
    name = benches;
    config = Criterion::default()
        .warm_up_time(Duration::from_millis(300))
        .measurement_time(Duration::from_secs(1))
        .sample_size(20);
    targets = contact
}
criterion_main!(benches);
