//! Worst-case timing harness (issue #9 item 2): adversarial scenarios run for many ticks each,
//! reporting the host time per tick as max, p99.9, p99 and mean, with the work counters the
//! core reports. Each tick is one call of an `#[inline(never)]` function named `*_tick`, so
//! `scripts/worst-case.sh` can count its instructions under callgrind
//! (`--toggle-collect=worst_case::drill_tick` and `--dump-after` on the same name).
//!
//! Scenarios (`--only NAME` runs one):
//! - `burr-cow`: the burr (sphere r 0.03) dragged along the surface of the sliver-rich
//!   `spot_tetgen_coarse`, half buried, drill on (max depth 5, the default budget), through the same
//!   per-tick step as `replay` (`engine::tick`: `World::simulate` + `servo_force`);
//! - `pen-teddy`: the pen (x10) buried in the teddy at the pose that puts the most of its
//!   nodes inside (searched once before timing), tip circling 5 mm, `pen_contact` per tick;
//! - `pen-teddy-servo`: the pen at the pose (same search) with the most penetrations (a
//!   buried pen has none: no border edge), the same circling path, each tick's pass untimed,
//!   then the servo half (`pen_servo_force`, function `servo_tick`) timed carrying that pass
//!   to the next tick's pose: the servo's work is its penetrations;
//! - `drill-teddy-b1`, `drill-teddy-bdefault`, `drill-teddy-bmax`: the burr r 0.03 dragged along
//!   the teddy's surface at max depth 5 with the smallest budget the scenario accepts (1), the
//!   default (the target row) and the largest (`u32::MAX`, no budget).
//!
//! Run (release, the full 100,000 ticks each; 7 minutes on the quiet 2-core VM, more under load):
//! `cargo run --release -p tetradrill-benches --bin worst_case`
//! Flags: `--ticks N` (default 100000), `--only NAME`, `--pen-scale S` (default 10).

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

use tetradrill::engine::{self, EngineStorage, TickParams};
use tetradrill::owned::OwnedMesh;
use tetradrill::pen::PenRig;
use tetradrill::setup::{Setup, Tool};
use tetradrill::traces::Pose;
use tetradrill_core::depth::Penetration;
use tetradrill_core::force::{
    pen_contact, pen_pass, pen_servo_force, ForceParams, HeldContact, PenBuffers, PenContact,
    PenOptions, PenScene, PenServo, PenState, ServoScratch, ToolState,
};
use tetradrill_core::mesh::Mesh;
use tetradrill_core::servo::{SimReport, World};
use tetradrill_core::{NodeId, Quat, TetId, Vec3};

const COW_COARSE: &str = "models/spot_tetgen_coarse.node";
const TEDDY: &str = "models/teddy_cgalbear_tetgen_q1.414.node";
const PEN: &str = "models/pen_tool_gmsh.mesh";
const SCENARIOS: [&str; 6] = [
    "burr-cow",
    "pen-teddy",
    "pen-teddy-servo",
    "drill-teddy-b1",
    "drill-teddy-bdefault",
    "drill-teddy-bmax",
];

/// Burr radius of the drilling scenarios (mesh units), as in the target.
const RADIUS: f32 = 0.03;
/// Drag speed along the surface, mesh units per tick (0.25 units/s at 1 kHz: a new drill
/// sphere every 15 ticks, `DRILL_SPACING` being an eighth of the radius; every 30 ticks
/// before 2026-11-22, at a quarter).
const SPEED: f32 = 2.5e-4;

struct Args {
    ticks: u64,
    only: Option<String>,
    pen_scale: f64,
    meshes: PathBuf,
}

fn usage_error(msg: &str) -> ExitCode {
    eprintln!("worst_case: {msg} (flags: --ticks N, --only NAME, --pen-scale S)");
    ExitCode::from(2)
}

fn parse_args() -> Result<Args, ExitCode> {
    let mut a = Args {
        ticks: 100_000,
        only: None,
        pen_scale: 10.0,
        meshes: std::env::var("TETRADRILL_MESHES")
            .map(PathBuf::from)
            .unwrap_or_else(|_| {
                PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../tests/data/meshes")
            }),
    };
    let mut it = std::env::args().skip(1);
    while let Some(flag) = it.next() {
        // Cargo passes `--bench` to benches; accept and ignore it.
        if flag == "--bench" {
            continue;
        }
        let Some(value) = it.next() else {
            return Err(usage_error(&format!("flag {flag} needs a value")));
        };
        match flag.as_str() {
            "--ticks" => match value.parse::<u64>() {
                Ok(n) if n > 0 => a.ticks = n,
                _ => return Err(usage_error(&format!("--ticks {value}: a whole number > 0"))),
            },
            "--only" => {
                if !SCENARIOS.contains(&value.as_str()) {
                    return Err(usage_error(&format!(
                        "--only {value}: one of {}",
                        SCENARIOS.join(", ")
                    )));
                }
                a.only = Some(value);
            }
            "--pen-scale" => match value.parse::<f64>() {
                Ok(s) if s.is_finite() && s > 0.0 => a.pen_scale = s,
                _ => return Err(usage_error(&format!("--pen-scale {value}: a number > 0"))),
            },
            _ => return Err(usage_error(&format!("unknown flag {flag}"))),
        }
    }
    if !a.meshes.is_dir() {
        return Err(usage_error(&format!(
            "no meshes folder at {} (set TETRADRILL_MESHES)",
            a.meshes.display()
        )));
    }
    Ok(a)
}

fn load(path: &Path, scale: f64) -> Result<OwnedMesh, ExitCode> {
    tetradrill::meshio::load(path, scale)
        .map(|l| l.mesh)
        .map_err(|e| {
            eprintln!("worst_case: {e}");
            ExitCode::from(2)
        })
}

/// Tick times in nanoseconds, summarised.
struct Summary {
    ticks: usize,
    mean_us: f64,
    p99_us: f64,
    p999_us: f64,
    max_us: f64,
    max_at: usize,
}

fn summarise(ns: &[u64]) -> Summary {
    let mut s: Vec<u64> = ns.to_vec();
    s.sort_unstable();
    let n = s.len().max(1);
    // Nearest-rank percentile: the smallest value with at least q of the samples at or below.
    let pct = |q: f64| s[((q * n as f64).ceil() as usize).clamp(1, n) - 1] as f64 / 1e3;
    let (max_at, _) = ns
        .iter()
        .enumerate()
        .max_by_key(|(_, v)| **v)
        .unwrap_or((0, &0));
    Summary {
        ticks: ns.len(),
        mean_us: ns.iter().sum::<u64>() as f64 / n as f64 / 1e3,
        p99_us: pct(0.99),
        p999_us: pct(0.999),
        max_us: s.last().copied().unwrap_or(0) as f64 / 1e3,
        max_at,
    }
}

fn print_summary(name: &str, s: &Summary, notes: &str) {
    println!(
        "| {name} | {} | {:.1} | {:.1} | {:.1} | {:.1} (tick {}) | {notes} |",
        s.ticks, s.mean_us, s.p99_us, s.p999_us, s.max_us, s.max_at
    );
}

/// A seeded walk over the mesh's surface: from a boundary node to a random neighbour along
/// boundary edges, each waypoint the node pushed in by half the radius along its inward
/// normal (the burr half buried). Deterministic for a seed.
struct SurfaceWalk {
    points: Vec<Vec3>,
}

impl SurfaceWalk {
    fn new(mesh: &Mesh<'_>, radius: f32, length: f32, seed: u64) -> Self {
        let n = mesh.node_count();
        let mut adj: Vec<Vec<u32>> = vec![Vec::new(); n];
        for t in 0..mesh.tet_count() {
            let t = TetId::from_idx(t);
            for f in 0..4u8 {
                if !mesh.is_boundary_face(t, f) {
                    continue;
                }
                let v = mesh.face_nodes(t, f);
                for k in 0..3 {
                    let (a, b) = (v[k].0, v[(k + 1) % 3].0);
                    adj[a as usize].push(b);
                    adj[b as usize].push(a);
                }
            }
        }
        for l in &mut adj {
            l.sort_unstable();
            l.dedup();
        }
        let mut rng = seed | 1;
        let mut next = || {
            rng ^= rng << 13;
            rng ^= rng >> 7;
            rng ^= rng << 17;
            rng
        };
        let start = (0..n)
            .filter(|&i| !adj[i].is_empty())
            .max_by(|&a, &b| mesh.positions()[a].y.total_cmp(&mesh.positions()[b].y))
            .unwrap_or(0);
        let place =
            |i: usize| mesh.positions()[i] - mesh.normal(NodeId::from_idx(i)) * (0.5 * radius);
        let mut points = vec![place(start)];
        let (mut cur, mut prev) = (start, usize::MAX);
        let mut walked = 0.0f32;
        while walked <= length && points.len() < 50_000_000 {
            let l = &adj[cur];
            if l.is_empty() {
                break;
            }
            // Prefer not to turn straight back, so the walk moves on.
            let mut pick = l[(next() % l.len() as u64) as usize] as usize;
            if pick == prev && l.len() > 1 {
                pick = l[(next() % l.len() as u64) as usize] as usize;
            }
            prev = cur;
            cur = pick;
            let p = place(cur);
            walked += points.last().map_or(0.0, |q| q.distance(p));
            points.push(p);
        }
        Self { points }
    }

    /// Positions at constant speed along the polyline, one per tick.
    fn ticks(&self, count: u64, speed: f32) -> Vec<Vec3> {
        let mut out = Vec::with_capacity(count as usize);
        let (mut seg, mut s) = (0usize, 0.0f32);
        while (out.len() as u64) < count {
            // The walk is longer than the path; hold the last point if it ever runs out.
            let last = self.points.len() - 1;
            let a = self.points[seg.min(last)];
            let b = self.points[(seg + 1).min(last)];
            if seg >= last {
                out.push(a);
                continue;
            }
            let len = a.distance(b);
            if s >= len {
                s -= len;
                seg += 1;
                continue;
            }
            out.push(a.lerp(b, s / len.max(1e-12)));
            s += speed;
        }
        out
    }
}

/// One drilling tick, exactly as `replay` runs it (`engine::tick`).
#[inline(never)]
fn drill_tick(
    world: &mut World<'_>,
    tool: &mut ToolState,
    p: &TickParams,
    pose: &Pose,
) -> SimReport {
    engine::tick(world, tool, p, pose).1
}

/// Running maxima of the counters the core reports.
#[derive(Default)]
struct DrillMax {
    work: u32,
    contact_nodes: u32,
    candidates: u32,
    pending: u32,
    contact_saturated: u64,
    arena_full_at: Option<usize>,
    fresh_used_up_at: Option<usize>,
    live_max: usize,
    created: u64,
    erased: u64,
}

fn drill_scenario(name: &str, mesh_path: &Path, budget: u32, ticks: u64) -> Result<(), ExitCode> {
    let mut sc = Setup::new(mesh_path, Tool::sphere(f64::from(RADIUS)));
    sc.drilling.max_depth = 5;
    sc.drilling.budget_per_tick = budget;
    let mut owned = load(mesh_path, 1.0)?;
    let path = {
        let m = owned.view();
        let length = ticks as f32 * SPEED + 1.0;
        SurfaceWalk::new(&m, RADIUS, length, 0x9e37_79b9_7f4a_7c15).ticks(ticks, SPEED)
    };
    let mut store = EngineStorage::new(owned, &sc).map_err(|e| {
        eprintln!("worst_case: {e}");
        ExitCode::from(2)
    })?;
    let mut world = store.world().map_err(|e| {
        eprintln!("worst_case: {e}");
        ExitCode::from(2)
    })?;
    let tp = TickParams::of(&sc).map_err(|e| {
        eprintln!("worst_case: {e}");
        ExitCode::from(2)
    })?;
    let mut tool = ToolState::default();
    let mut ns = Vec::with_capacity(ticks as usize);
    let mut mx = DrillMax::default();
    for (i, &position) in path.iter().enumerate() {
        let pose = Pose {
            position,
            rotation: [1.0, 0.0, 0.0, 0.0],
            buttons: tetradrill_core::script::DRILL_ON,
        };
        let t0 = Instant::now();
        let r = drill_tick(&mut world, &mut tool, &tp, &pose);
        ns.push(t0.elapsed().as_nanos() as u64);
        mx.work = mx.work.max(r.drill.work);
        mx.contact_nodes = mx.contact_nodes.max(r.contact_nodes);
        mx.candidates = mx.candidates.max(r.candidates);
        mx.pending = mx.pending.max(r.drill.pending);
        mx.contact_saturated += r.contact_saturated as u64;
        mx.created += r.drill.created as u64;
        mx.erased += r.drill.erased as u64;
        if mx.arena_full_at.is_none() && world.saturations().arena > 0 {
            mx.arena_full_at = Some(i);
        }
        let h = world.hierarchy();
        if mx.fresh_used_up_at.is_none() && h.arena_used() == h.capacity() {
            mx.fresh_used_up_at = Some(i);
        }
        mx.live_max = mx.live_max.max(h.arena_live());
    }
    let s = world.saturations();
    let h = world.hierarchy();
    let budget_note = if budget == u32::MAX {
        "none".to_string()
    } else {
        budget.to_string()
    };
    let notes = format!(
        "budget {budget_note}; max drill work {}, max contact nodes {} (bound {}), max candidates {}, max pending {}; \
         contact-bound ticks {}; created {}, erased {}; arena {}/{} nodes (fresh blocks used up at tick {}, then {} taken back; at most {} holding material), first refusal at tick {}; saturations: arena {}, pending {}, contact {}, candidates {}, hash {}",
        mx.work,
        mx.contact_nodes,
        world.contact_max_nodes(),
        mx.candidates,
        mx.pending,
        mx.contact_saturated,
        mx.created,
        mx.erased,
        h.arena_used(),
        h.capacity(),
        mx.fresh_used_up_at
            .map_or_else(|| "never".to_string(), |t| t.to_string()),
        h.reclaimed(),
        mx.live_max,
        mx.arena_full_at
            .map_or_else(|| "never".to_string(), |t| t.to_string()),
        s.arena,
        s.pending,
        s.contact,
        s.candidates,
        s.hash
    );
    print_summary(name, &summarise(&ns), &notes);
    Ok(())
}

/// One pen tick.
#[inline(never)]
fn pen_tick(
    scene: &PenScene<'_, '_, '_>,
    bufs: &mut PenBuffers<'_>,
    tip: Vec3,
    rot: Quat,
    opts: &PenOptions,
    state: &mut PenState,
) -> PenContact {
    pen_contact(scene, bufs, tip, rot, opts, state)
}

/// One servo half of the pen: the force carried from a held pass.
#[inline(never)]
#[allow(clippy::too_many_arguments)]
fn servo_tick(
    scene: &PenScene<'_, '_, '_>,
    held: &HeldContact<'_>,
    now: &mut ServoScratch<'_>,
    tip: Vec3,
    rot: Quat,
    opts: &PenOptions,
    state: &mut PenState,
) -> PenServo {
    pen_servo_force(scene, held, now, tip, rot, opts, state)
}

/// `pen-teddy` (`servo` false: the whole tick, [`pen_tick`]) or `pen-teddy-servo` (`servo`
/// true: each tick's pass untimed, then the servo half timed at the next tick's pose,
/// carrying the most penetrations the buried pen gives).
fn pen_scenario(meshes: &Path, pen_scale: f64, ticks: u64, servo: bool) -> Result<(), ExitCode> {
    let mut rig = PenRig {
        pen: load(&meshes.join(PEN), pen_scale)?,
        obj: load(&meshes.join(TEDDY), 1.0)?,
    };
    let pen_nodes = rig.pen.positions().len();
    // Candidate poses: tips at tet centroids of the teddy (every 97th), axis along 13
    // directions; keep the one with the most pen nodes inside.
    let obj = rig.obj.clone();
    let centroids: Vec<Vec3> = obj
        .tets()
        .iter()
        .step_by(97)
        .map(|t| {
            t.nodes
                .iter()
                .fold(Vec3::ZERO, |a, n| a + obj.positions()[n.idx()])
                * 0.25
        })
        .collect();
    let mut dirs = Vec::new();
    for x in -1i32..=1 {
        for y in -1i32..=1 {
            for z in -1i32..=1 {
                let d = Vec3::new(x as f32, y as f32, z as f32);
                if d != Vec3::ZERO && (x, y, z) > (0, 0, 0) {
                    dirs.push(d.normalize());
                }
            }
        }
    }
    let opts = PenOptions {
        params: ForceParams {
            stiffness: 200.0,
            damping: 0.5,
            max_force: 8.0,
            dt: 1e-3,
            ..ForceParams::default()
        },
        ..PenOptions::default()
    };
    let res = rig.with(|scene, bufs| {
        let mut best = (0usize, Vec3::ZERO, Quat::IDENTITY);
        let mut state = PenState::default();
        'search: for &c in &centroids {
            for &d in &dirs {
                for sign in [1.0f32, -1.0] {
                    let rot = Quat::from_rotation_arc(Vec3::Z, d * sign);
                    let c2 = pen_contact(scene, bufs, c, rot, &opts, &mut state);
                    // The servo's work is its penetrations; the pass's, the nodes inside.
                    let n = if servo {
                        c2.penetrations.0 + c2.penetrations.1
                    } else {
                        c2.pen_collisions.count
                    };
                    if n > best.0 {
                        best = (n, c, rot);
                        if n == pen_nodes && !servo {
                            break 'search;
                        }
                    }
                }
            }
        }
        let (inside, tip, rot) = best;
        let mut state = PenState::default();
        let mut ns = Vec::with_capacity(ticks as usize);
        let (mut most_pen, mut most_obj, mut sat, mut work) = (0usize, 0usize, 0u64, 0u32);
        let mut now_pen = vec![Penetration::default(); bufs.pen_pens.len()];
        let mut now_obj = vec![Penetration::default(); bufs.object_pens.len()];
        let mut carried = 0usize;
        let at = |i: u64| {
            let a = i as f32 * std::f32::consts::TAU / 1000.0;
            tip + Vec3::new(a.cos(), a.sin(), 0.0) * 0.005
        };
        for i in 0..ticks {
            let p = at(i);
            let t0 = Instant::now();
            let c = if servo {
                let c = pen_pass(scene, bufs, p, rot, &opts, &mut state);
                let (np, no) = c.penetrations;
                let held = HeldContact {
                    position: p,
                    rotation: rot,
                    pen: &bufs.pen_pens[..np],
                    object: &bufs.object_pens[..no],
                };
                let mut now = ServoScratch {
                    pen: &mut now_pen,
                    object: &mut now_obj,
                };
                let t1 = Instant::now();
                let s = servo_tick(scene, &held, &mut now, at(i + 1), rot, &opts, &mut state);
                ns.push(t1.elapsed().as_nanos() as u64);
                carried = carried.max(s.carried.0 + s.carried.1);
                c
            } else {
                let c = pen_tick(scene, bufs, p, rot, &opts, &mut state);
                ns.push(t0.elapsed().as_nanos() as u64);
                c.pass()
            };
            most_pen = most_pen.max(c.pen_collisions.count);
            most_obj = most_obj.max(c.object_collisions.count);
            sat += c.saturated() as u64;
            work = work.max(c.pen_depth.work + c.object_depth.work);
        }
        (ns, inside, tip, rot, most_pen, most_obj, sat, work, carried)
    });
    let (ns, inside, tip, rot, most_pen, most_obj, sat, work, carried) = res.map_err(|e| {
        eprintln!("worst_case: pen rig: {e}");
        ExitCode::from(2)
    })?;
    let axis = rot * Vec3::Z;
    let notes = format!(
        "pen x{pen_scale}, traced depth; {inside} {} at the chosen pose \
         (tip {:.3} {:.3} {:.3}, axis {:.2} {:.2} {:.2}); max pen nodes in {most_pen}, teddy nodes in pen {most_obj}; \
         max depth work {work}; saturated ticks {sat}{}",
        if servo {
            "penetrations (pen and teddy nodes)".to_string()
        } else {
            format!("of {pen_nodes} pen nodes inside")
        },
        tip.x,
        tip.y,
        tip.z,
        axis.x,
        axis.y,
        axis.z,
        if servo {
            format!("; servo half only: most penetrations carried {carried}")
        } else {
            String::new()
        }
    );
    let name = if servo {
        "pen-teddy-servo"
    } else {
        "pen-teddy"
    };
    print_summary(name, &summarise(&ns), &notes);
    Ok(())
}

fn run() -> Result<(), ExitCode> {
    let a = parse_args()?;
    let want = |n: &str| a.only.as_deref().is_none_or(|o| o == n);
    println!(
        "worst_case: {} ticks per scenario; host time per tick in us",
        a.ticks
    );
    println!("| scenario | ticks | mean | p99 | p99.9 | max | counters |");
    println!("|---|---|---|---|---|---|---|");
    if want("burr-cow") {
        drill_scenario(
            "burr-cow",
            &a.meshes.join(COW_COARSE),
            Setup::default().drilling.budget_per_tick,
            a.ticks,
        )?;
    }
    if want("pen-teddy") {
        pen_scenario(&a.meshes, a.pen_scale, a.ticks, false)?;
    }
    if want("pen-teddy-servo") {
        pen_scenario(&a.meshes, a.pen_scale, a.ticks, true)?;
    }
    let teddy = a.meshes.join(TEDDY);
    for (name, budget) in [
        ("drill-teddy-b1", 1u32),
        (
            "drill-teddy-bdefault",
            Setup::default().drilling.budget_per_tick,
        ),
        ("drill-teddy-bmax", u32::MAX),
    ] {
        if want(name) {
            drill_scenario(name, &teddy, budget, a.ticks)?;
        }
    }
    Ok(())
}

fn main() -> ExitCode {
    match run() {
        Ok(()) => ExitCode::SUCCESS,
        Err(code) => code,
    }
}
