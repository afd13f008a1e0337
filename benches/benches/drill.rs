//! Drilling ticks on the cow (18k tets) and the teddy (80k tets): a burr plunges into the
//! surface, runs along it, then is held still until the pending work is done. Prints the
//! worst tick, p99, median, nodes per second of erosion, the hold time to convergence and the
//! memory per node; then criterion times one steady drilling tick.
//!
//! The burr positions go to the drill as `World::simulate` gives them
//! ([`tetradrill_core::drill::Spacing`]: one per eighth of the radius of motion, and the place
//! where the burr settles); one line per mesh also queues a sphere at every tick, a stress
//! case with 8 to 30 times as much work as the path needs, which overflows the pending deque.
//!
//! The convergence case: a burr of 0.03 along the path of `scripts/clinical-drill.sh` (scaled
//! by the radius) with a 0.5 s hold, at max depth 5 and 6, the default budget and no area
//! limit; the removed volume at the end is printed beside a Monte Carlo estimate of the swept
//! volume ([`tetradrill_benches::swept`]) and their ratio.
//!
//! Run: `cargo bench -p tetradrill-benches --bench drill` (set `TETRADRILL_MESHES` when the
//! meshes are not the repository's `tests/data/meshes`; `TETRADRILL_BENCH_HOLD_ONLY=1` runs
//! the convergence case alone).

use std::path::PathBuf;
use std::time::Instant;

use criterion::{criterion_group, Criterion};
use glam::Vec3;
use tetradrill::owned::OwnedMesh;
use tetradrill_benches::swept::{hold_path, swept_volume};
use tetradrill_core::drill::{
    candidates_brute_force, Drill, DrillParams, Pending, Spacing, Sphere, DRILL_HOLD_STEPS,
    MAX_STEP_SPHERES,
};
use tetradrill_core::hierarchy::{HierarchySizes, VEntry, NODE_BYTES};
use tetradrill_core::mesh::{BuildOptions, Mesh};
use tetradrill_core::owned::HierarchyBuffers;
use tetradrill_core::TetId;

const ARENA: usize = 8 << 20;
const QUEUE: usize = 1 << 16;

fn meshes_dir() -> PathBuf {
    std::env::var("TETRADRILL_MESHES")
        .map(PathBuf::from)
        .unwrap_or_else(|_| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../tests/data/meshes"))
}

/// A minimal TetGen reader (the bench's own).
fn tetgen(rel: &str) -> OwnedMesh {
    let node = meshes_dir().join(rel);
    let ele = node.with_extension("ele");
    let rows = |p: &std::path::Path| -> Vec<Vec<f64>> {
        std::fs::read_to_string(p)
            .unwrap_or_else(|e| panic!("{}: {e}", p.display()))
            .lines()
            .map(|l| l.split('#').next().unwrap_or(""))
            .filter(|l| !l.trim().is_empty())
            .map(|l| {
                l.split_whitespace()
                    .map(|w| w.parse::<f64>().unwrap())
                    .collect()
            })
            .collect()
    };
    let (nr, er) = (rows(&node), rows(&ele));
    let n = nr[0][0] as usize;
    let base = nr[1][0] as u32;
    let p: Vec<Vec3> = nr[1..=n]
        .iter()
        .map(|r| Vec3::new(r[1] as f32, r[2] as f32, r[3] as f32))
        .collect();
    let m = er[0][0] as usize;
    let t: Vec<[u32; 4]> = er[1..=m]
        .iter()
        .map(|r| core::array::from_fn(|k| r[k + 1] as u32 - base))
        .collect();
    OwnedMesh::build(p, &t, BuildOptions::default()).unwrap()
}

/// The burr's path: plunge along the inward normal of a boundary node (200 ticks / `speed`),
/// run along the surface (800 ticks / `speed`), hold. Radius from the mesh size: at speed 1
/// the burr moves a hundredth of its radius a tick while plunging and 0.00375 radii along the
/// surface (the demo path: about 0.0026).
fn trace(mesh: &Mesh<'_>, speed: usize) -> (Vec<Vec3>, f32, usize) {
    let p = mesh.positions();
    let lo = p.iter().fold(Vec3::splat(f32::MAX), |a, &b| a.min(b));
    let hi = p.iter().fold(Vec3::splat(f32::MIN), |a, &b| a.max(b));
    let r = 0.02 * (hi - lo).length();
    // The boundary node with the largest z (a top surface).
    let (i, _) = p
        .iter()
        .enumerate()
        .filter(|(i, _)| mesh.nodes()[*i].boundary())
        .max_by(|a, b| a.1.z.total_cmp(&b.1.z))
        .unwrap();
    let n = mesh.normal(tetradrill_core::NodeId::from_idx(i));
    let start = p[i] + n * r;
    let bottom = p[i] - n * r;
    let side = n.any_orthonormal_vector();
    let mut out = Vec::new();
    let (plunge, run) = (200 / speed.max(1), 800 / speed.max(1));
    for k in 0..=plunge {
        out.push(start.lerp(bottom, k as f32 / plunge as f32));
    }
    for k in 1..=run {
        out.push(bottom + side * (3.0 * r * k as f32 / run as f32));
    }
    let moving = out.len();
    (out, r, moving)
}

/// Which burr positions become drill work.
#[derive(Clone, Copy, PartialEq)]
enum Queue {
    /// As `World::simulate` ([`Spacing`]).
    Spaced,
    /// A sphere at every tick (the stress case).
    EveryTick,
}

impl Queue {
    fn label(self) -> &'static str {
        match self {
            Queue::Spaced => "spaced",
            Queue::EveryTick => "every tick",
        }
    }
}

struct Run {
    ticks_us: Vec<f64>,
    created: u64,
    erased: u64,
    hold_ticks: usize,
    nodes: usize,
    removed: f64,
    visible: u32,
    saturations: u32,
}

fn run(mesh: &Mesh<'_>, params: &DrillParams, queue_rule: Queue, speed: usize) -> Run {
    let t = mesh.tet_count();
    let mut store = HierarchyBuffers::new(HierarchySizes::new(t, ARENA)).unwrap();
    let mut h = store.hierarchy(mesh).unwrap();
    let mut queue = vec![Pending::default(); QUEUE];
    let mut drill = Drill::new(&mut queue);
    let (path, r, moving) = trace(mesh, speed);
    let mut cand = vec![TetId::NONE; t];
    let mut out = Run {
        ticks_us: Vec::new(),
        created: 0,
        erased: 0,
        hold_ticks: 0,
        nodes: 0,
        removed: 0.0,
        visible: 0,
        saturations: 0,
    };
    let mut spacing = Spacing::new();
    let mut kept = [Sphere::default(); MAX_STEP_SPHERES];
    let mut k = 0;
    loop {
        let c = path[k.min(path.len() - 1)];
        let s = [Sphere {
            center: c,
            radius: r,
        }];
        let nk = match queue_rule {
            Queue::Spaced => spacing.admit(c, r, &s, &mut kept),
            Queue::EveryTick => {
                kept[0] = s[0];
                1
            }
        };
        let spheres = &kept[..nk];
        let n = candidates_brute_force(mesh, spheres, &mut cand);
        let t0 = Instant::now();
        let rep = drill.step(&mut h, mesh, &cand[..n], spheres, params);
        out.ticks_us.push(t0.elapsed().as_secs_f64() * 1e6);
        out.created += rep.created as u64;
        out.erased += rep.erased as u64;
        k += 1;
        // Held until nothing is pending, and (spaced) the resting place was queued: a burr
        // that settles is queued again after `DRILL_HOLD_STEPS` steps.
        let settled = queue_rule == Queue::EveryTick || k > moving + DRILL_HOLD_STEPS as usize;
        if k >= moving && settled && rep.pending == 0 {
            break;
        }
        if k > moving + 20_000 {
            break;
        }
    }
    out.hold_ticks = k - moving;
    out.nodes = h.node_count();
    out.removed = h.removed_volume();
    out.visible = h.visible_face_count();
    out.saturations = h.saturations() + drill.saturations();
    out
}

fn report(name: &str, mesh: &Mesh<'_>, params: &DrillParams, queue_rule: Queue, speed: usize) {
    // The machine is shared: a tick preempted by another process shows up as a multiple of the
    // 4 ms scheduler quantum. The runs are deterministic, so the same trace is run three times
    // and each tick keeps its fastest time; the raw worst tick is printed as well.
    let r = run(mesh, params, queue_rule, speed);
    let raw_worst = r.ticks_us.iter().copied().fold(0.0, f64::max);
    let mut best = r.ticks_us.clone();
    for _ in 0..2 {
        let again = run(mesh, params, queue_rule, speed);
        assert_eq!(again.ticks_us.len(), best.len(), "runs must be identical");
        for (b, t) in best.iter_mut().zip(again.ticks_us) {
            *b = b.min(t);
        }
    }
    let mut s = best.clone();
    s.sort_by(f64::total_cmp);
    let pct = |q: f64| s[((s.len() - 1) as f64 * q) as usize];
    let total_s: f64 = best.iter().sum::<f64>() * 1e-6;
    println!(
        "drill {name} ({}, speed {speed}): tets {} budget {} max_depth {} min_area {:.2e}: ticks {} worst {:.1} us (raw {:.0} us) p99 {:.1} us \
         median {:.1} us; created {} erased {} ({:.0} nodes/s of erosion); hold to converge \
         {} ticks; nodes {} visible faces {} removed volume {:.6} saturations {}",
        queue_rule.label(),
        mesh.tet_count(),
        params.budget,
        params.max_depth,
        params.min_area,
        s.len(),
        s[s.len() - 1],
        raw_worst,
        pct(0.99),
        pct(0.5),
        r.created,
        r.erased,
        (r.created + r.erased) as f64 / total_s.max(1e-12),
        r.hold_ticks,
        r.nodes,
        r.visible,
        r.removed,
        r.saturations,
    );
}

/// The convergence case on `mesh`: the removed volume after the hold path at `max_depth`
/// against the swept volume.
fn hold_report(name: &str, mesh: &Mesh<'_>, max_depth: u8) {
    let r = 0.03;
    let path = hold_path(mesh, r, 500);
    let (reference, se) = swept_volume(mesh, &path, r, 1_000_000);
    let t = mesh.tet_count();
    let mut store = HierarchyBuffers::new(HierarchySizes::new(t, ARENA)).unwrap();
    let mut h = store.hierarchy(mesh).unwrap();
    let mut queue = vec![Pending::default(); QUEUE];
    let mut drill = Drill::new(&mut queue);
    let params = DrillParams {
        max_depth,
        min_area: 0.0,
        budget: DrillParams::default().budget,
    };
    let mut cand = vec![TetId::NONE; t];
    let mut spacing = Spacing::new();
    let mut kept = [Sphere::default(); MAX_STEP_SPHERES];
    let (mut worst, mut worst_work, mut pending) = (0.0f64, 0u32, 0u32);
    for &c in &path {
        let s = [Sphere {
            center: c,
            radius: r,
        }];
        let nk = spacing.admit(c, r, &s, &mut kept);
        let n = candidates_brute_force(mesh, &kept[..nk], &mut cand);
        let t0 = Instant::now();
        let rep = drill.step(&mut h, mesh, &cand[..n], &kept[..nk], &params);
        worst = worst.max(t0.elapsed().as_secs_f64() * 1e6);
        worst_work = worst_work.max(rep.work);
        pending = rep.pending;
    }
    let removed = h.removed_volume();
    println!(
        "drill {name} hold 0.5 s, burr {r}, max_depth {max_depth}, budget {}: removed {removed:.6e}, \
         swept (Monte Carlo, 1e6 samples) {reference:.6e} (se {:.2} %), ratio {:.4}; pending at \
         the end {pending}; worst tick {worst:.0} us (raw), {worst_work} units; saturations {}",
        params.budget,
        se * 100.0,
        removed / reference,
        h.saturations() + drill.saturations(),
    );
}

fn bench(c: &mut Criterion) {
    let hold_only = std::env::var_os("TETRADRILL_BENCH_HOLD_ONLY").is_some();
    println!(
        "memory: {NODE_BYTES} bytes per hierarchy node, {} bytes per v_list entry \
         ({:.1} bytes per arena node with the v_list sized for every leaf), {} bytes per \
         pending item",
        std::mem::size_of::<VEntry>(),
        NODE_BYTES as f64 + 12.0 * 7.0 / 8.0,
        std::mem::size_of::<Pending>()
    );
    for (name, rel) in [
        ("cow", "models/spot_tetgen_q1.414.node"),
        ("teddy", "models/teddy_cgalbear_tetgen_q1.414.node"),
    ] {
        let mut om = tetgen(rel);
        let mesh = om.view();
        for depth in [5, 6] {
            hold_report(name, &mesh, depth);
        }
        if hold_only {
            continue;
        }
        // Leaves down to about r/8..r/16: refine while the smallest face is at least that of
        // an equilateral triangle of edge r/8.
        let (_, r_tool, _) = trace(&mesh, 1);
        let min_area = 0.433 * (r_tool / 8.0) * (r_tool / 8.0);
        for (budget, queue_rule, speed) in [
            (11_000u32, Queue::Spaced, 1),
            (u32::MAX, Queue::Spaced, 1),
            (11_000, Queue::Spaced, 4),
            (u32::MAX, Queue::Spaced, 4),
            (11_000, Queue::Spaced, 16),
            (u32::MAX, Queue::Spaced, 16),
            (11_000, Queue::EveryTick, 1),
        ] {
            report(
                name,
                &mesh,
                &DrillParams {
                    max_depth: 6,
                    min_area,
                    budget,
                },
                queue_rule,
                speed,
            );
        }
        // Criterion: one tick of a sphere moving through fresh material each iteration.
        let t = mesh.tet_count();
        let mut store = HierarchyBuffers::new(HierarchySizes::new(t, ARENA)).unwrap();
        let mut h = store.hierarchy(&mesh).unwrap();
        let mut queue = vec![Pending::default(); QUEUE];
        let mut drill = Drill::new(&mut queue);
        let (path, _, _) = trace(&mesh, 1);
        let params = DrillParams {
            max_depth: 6,
            min_area,
            budget: DrillParams::default().budget,
        };
        let mut cand = vec![TetId::NONE; t];
        let mut k = 0usize;
        c.bench_function(&format!("drill_tick_{name}_default_budget"), |b| {
            b.iter(|| {
                let s = [Sphere {
                    center: path[k % path.len()],
                    radius: r_tool,
                }];
                k += 1;
                let n = candidates_brute_force(&mesh, &s, &mut cand);
                drill.step(&mut h, &mesh, &cand[..n], &s, &params)
            })
        });
    }
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(10);
    targets = bench
}

fn main() {
    benches();
    Criterion::default().configure_from_args().final_summary();
}
