//! `--body soft` on the command line, end to end: a soft block pressed by the burr gives a
//! smaller force than the rigid block at the same press and dents within closed-form bounds;
//! `--body rigid` is the default run bit for bit; drilling a stiff soft block removes the rigid
//! block's volume; bad soft flags and keys exit 2 naming the flag or the file and line.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use glam::Vec3;
use tetradrill::soft::{Fix, SoftDriver, SoftOwned, SoftSpec};
use tetradrill_core::drill::DrillParams;
use tetradrill_core::hash::{Aabb, HashEntry};
use tetradrill_core::servo::{SpareStorage, World, WorldSizes};
use tetradrill_tests::search::{block_mesh, Store};
use tetradrill_tests::{scratch_dir, tetradrill_bin};

fn run(args: &[&str]) -> Output {
    Command::new(tetradrill_bin())
        .args(args)
        .output()
        .expect("run tetradrill")
}

/// Runs a replay that must succeed and returns its JSON.
fn replay_json(dir: &Path, name: &str, args: &[&str]) -> serde_json::Value {
    let out_path = dir.join(format!("{name}.json"));
    let out_s = out_path.to_string_lossy().into_owned();
    let mut all = vec!["replay", "--quiet", "--json", &out_s];
    all.extend_from_slice(args);
    let out = run(&all);
    assert!(
        out.status.success(),
        "{all:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_str(&std::fs::read_to_string(&out_path).expect("read JSON"))
        .expect("parse JSON")
}

/// Asserts exit status 2 and a first stderr line containing every `needle`.
fn refused(args: &[&str], needles: &[&str]) {
    let out = run(args);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
    let first = err.lines().find(|l| !l.trim().is_empty()).unwrap_or("");
    for n in needles {
        assert!(
            first.contains(n),
            "{args:?}: first line {first:?} lacks {n:?}"
        );
    }
}

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).expect("write a scratch file");
    p
}

const RADIUS: f64 = 0.1;
const PRESS: f64 = 0.03;
const STIFFNESS: f64 = 200.0;
const YOUNG: f64 = 5000.0;

/// A burr of radius 0.1 lowered 0.03 into the top (z = 0.5) of the unit block over 0.2 s and
/// held there until 1.5 s, drill off.
fn press_trace(dir: &Path) -> PathBuf {
    let mut text = String::from("t,x,y,z,qw,qx,qy,qz,buttons\n");
    for i in 0..=1500 {
        let t = i as f64 / 1000.0;
        let d = PRESS * (t / 0.2).min(1.0);
        text.push_str(&format!(
            "{t:.3},0.0123,0.0371,{:.6},1,0,0,0,0\n",
            0.5 + RADIUS - d
        ));
    }
    write(dir, "press.csv", &text)
}

/// The soft block (E = 5 kPa, nu = 0, fixed at its base z = -0.5) held 0.03 under the burr:
/// - the force is smaller than the rigid block's spring force `k * press` (the body gives);
/// - the kinematics: settled, the surface under the burr moved down by what the burr no
///   longer penetrates, `press - F / k`, so the largest displacement is at least that;
/// - a closed-form lower bound (p L / E): by Betti's reciprocal theorem between this load
///   (the final force `F` spread over the touched tet's top corners) and a uniform pressure
///   `F / A` over the whole top face (A = 1 m^2), whose solution with nu = 0 and a clamped
///   base is the uniform compression `F L / (E A)` (L = 1 m; exact in linear tets), the
///   load-weighted mean of the top's displacement under the press equals `F L / (E A)`, so
///   the largest displacement is at least that;
/// - an upper bound: the burr is the only load, and at rest it cannot have pushed the surface
///   further than it went in (the press).
#[test]
fn a_pressed_soft_block_gives_and_dents_within_closed_form_bounds() {
    let dir = scratch_dir("softcli", "press");
    let trace = press_trace(&dir);
    let trace = trace.to_string_lossy().into_owned();
    let common = [
        "--mesh",
        "builtin:block:4",
        "--trace",
        &trace,
        "--tool",
        "sphere:0.1",
    ];
    let rigid = replay_json(&dir, "rigid", &common);
    let mut soft_args = common.to_vec();
    soft_args.extend_from_slice(&[
        "--body",
        "soft",
        "--young",
        "5000",
        "--poisson",
        "0",
        "--fix-below",
        "z:-0.49",
    ]);
    let obj = dir.join("surface.obj");
    let obj_s = obj.to_string_lossy().into_owned();
    let mut with_surface = soft_args.clone();
    with_surface.extend_from_slice(&["--surface", &obj_s]);
    let soft = replay_json(&dir, "soft", &with_surface);
    assert!(rigid.get("deform").is_none());
    let fz = |r: &serde_json::Value| r["force"]["final"][2].as_f64().unwrap();
    let (f_rigid, f_soft) = (fz(&rigid), fz(&soft));
    assert!(
        (f_rigid - STIFFNESS * PRESS).abs() < 1e-3 * f_rigid,
        "{f_rigid}"
    );
    let d = &soft["deform"];
    let max_disp = d["max_displacement"].as_f64().unwrap();
    let lower = f_soft * 1.0 / (YOUNG * 1.0);
    let kinematic = PRESS - f_soft / STIFFNESS;
    eprintln!(
        "force rigid {f_rigid} soft {f_soft}; max displacement {max_disp}, p L / E {lower}, \
         press - F/k {kinematic}"
    );
    assert!(f_soft < 0.95 * f_rigid, "{f_soft} against {f_rigid}");
    assert!(f_soft > 0.0);
    assert!(max_disp >= lower, "{max_disp} < p L / E = {lower}");
    assert!(max_disp >= 0.95 * kinematic, "{max_disp} < {kinematic}");
    assert!(max_disp < PRESS, "{max_disp}");
    assert_eq!(d["rate_hz"].as_f64(), Some(250.0));
    assert_eq!(d["steps"].as_u64(), Some(375));
    // Only the base layer of the 5 x 5 x 5 nodes is fixed.
    assert_eq!(d["fixed_nodes"].as_u64(), Some(25));
    for k in ["mean", "p99", "max"] {
        assert!(d["step_us"][k].as_f64().unwrap() > 0.0, "{k}");
    }
    assert_eq!(soft["scenario"]["body"].as_str(), Some("soft"));
    // The drilled-surface export writes the deformed positions: the top face (z = 0.5 at
    // rest) is pressed down under the burr by the dent.
    let text = std::fs::read_to_string(&obj).expect("read the surface");
    let top_min = text
        .lines()
        .filter_map(|l| l.strip_prefix("v "))
        .filter_map(|l| l.split_whitespace().nth(2)?.parse::<f64>().ok())
        .filter(|&z| z > 0.4)
        .fold(f64::INFINITY, f64::min);
    assert!(top_min < 0.5 - 0.5 * kinematic, "top {top_min}");
    assert!(top_min > 0.5 - PRESS, "top {top_min}");
    // The same soft replay again: the same forces bit for bit.
    let again = replay_json(&dir, "again", &soft_args);
    assert_eq!(again["force_digest"], soft["force_digest"]);
    assert_ne!(soft["force_digest"], rigid["force_digest"]);
}

/// `--body rigid` is the default: the same force digest and no `deform` object or `body` key.
#[test]
fn body_rigid_is_the_default_bit_for_bit() {
    let dir = scratch_dir("softcli", "rigid");
    let a = replay_json(&dir, "default", &["--ticks", "1500"]);
    let b = replay_json(&dir, "rigid", &["--ticks", "1500", "--body", "rigid"]);
    assert_eq!(a["force_digest"], b["force_digest"]);
    assert!(a.get("deform").is_none() && b.get("deform").is_none());
    assert!(b["scenario"].get("body").is_none());
}

/// The demo's path drilled into a stiff soft block (E = 10 MPa: the burr's few newtons move
/// it by micrometres) removes within 5 % of the rigid block's volume (removed volumes are
/// measured in the rest state).
#[test]
fn a_stiff_soft_block_loses_the_rigid_volume() {
    let dir = scratch_dir("softcli", "volume");
    let common = ["--ticks", "3000", "--max-depth", "3"];
    let rigid = replay_json(&dir, "rigid", &common);
    let mut soft_args = common.to_vec();
    soft_args.extend_from_slice(&["--body", "soft", "--young", "1e7", "--soft-rate", "100"]);
    let soft = replay_json(&dir, "soft", &soft_args);
    let v = |r: &serde_json::Value| r["removed_volume"].as_f64().unwrap();
    let (vr, vs) = (v(&rigid), v(&soft));
    eprintln!("removed: rigid {vr}, soft {vs}");
    assert!(vr > 1e-3, "{vr}");
    assert!((vs - vr).abs() < 0.05 * vr, "{vs} against {vr}");
    let d = &soft["deform"];
    assert_eq!(d["rate_hz"].as_f64(), Some(100.0));
    assert_eq!(d["steps"].as_u64(), Some(300));
    let m = d["max_displacement"].as_f64().unwrap();
    assert!(m > 0.0 && m < 1e-3, "{m}");
}

/// Runs `demo --soft` headless for 2 s with `extra` flags (must succeed); its standard output
/// and its JSON.
fn demo_soft(name: &str, extra: &[&str]) -> (String, serde_json::Value) {
    let dir = scratch_dir("softcli", name);
    let json = dir.join("demo.json");
    let json_s = json.to_string_lossy().into_owned();
    let mut args = vec!["demo", "--soft", "--headless", "--no-rt", "--duration", "2"];
    args.extend_from_slice(extra);
    args.extend_from_slice(&["--json", &json_s]);
    let out = run(&args);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{args:?}: {err}");
    let r =
        serde_json::from_str(&std::fs::read_to_string(&json).expect("read JSON")).expect("JSON");
    (String::from_utf8_lossy(&out.stdout).into_owned(), r)
}

/// `demo --soft` headless through the real-time pipeline: the JSON's `deform` has steps, a
/// displacement (the burr presses the block) and its timing; the same run rigid has none.
#[test]
fn demo_soft_reports_the_deformation() {
    let (stdout, r) = demo_soft("demo", &[]);
    // The demo's regions' moduli: the shell (label 1) and the core (label 2).
    assert!(
        stdout.contains("soft body (region 1: E 3000 Pa, nu 0.3")
            && stdout.contains("region 2: E 1000 Pa, nu 0.3"),
        "{stdout}"
    );
    let d = &r["deform"];
    assert!(d["steps"].as_u64().unwrap() > 0, "{d}");
    let labels: Vec<_> = d["materials"]
        .as_array()
        .expect("materials")
        .iter()
        .map(|m| m["label"].as_i64())
        .collect();
    assert_eq!(labels, [Some(1), Some(2)], "{d}");
    assert!(d["rate_hz"].as_f64().unwrap() > 0.0, "{d}");
    // The path presses the block within its first 2 s (force up to the 8 N clamp).
    assert!(d["max_displacement"].as_f64().unwrap() > 1e-4, "{d}");
    assert!(d["step_us"]["max"].as_f64().unwrap() > 0.0, "{d}");
    refused(
        &[
            "run",
            "--device",
            "sim",
            "--body",
            "soft",
            "--tool",
            "mesh:x.node",
        ],
        &["--body soft", "mesh tool"],
    );
}

/// `demo --soft --soft-spread`: each step spread over its cycle's ticks through the real-time
/// pipeline; every cycle done by its last tick, the block dented; without `--soft` refused.
#[test]
fn demo_soft_spread_spreads_the_steps() {
    let (_, r) = demo_soft("demo-spread", &["--soft-spread"]);
    let d = &r["deform"];
    let s = &d["spread"];
    // 250 steps a second at 1 kHz: four ticks a cycle.
    assert_eq!(s["ticks"].as_u64(), Some(4), "{d}");
    assert_eq!(s["late"].as_u64(), Some(0), "{d}");
    assert!(s["units_max"].as_u64().unwrap() > 0, "{d}");
    assert!(d["steps"].as_u64().unwrap() > 100, "{d}");
    assert!(d["max_displacement"].as_f64().unwrap() > 1e-4, "{d}");
    refused(
        &["demo", "--soft-spread", "--headless"],
        &["--soft-spread", "--soft"],
    );
}

#[test]
fn bad_soft_flags_exit_2_naming_the_flag() {
    refused(&["replay", "--body", "jelly"], &["--body"]);
    refused(&["replay", "--body", "soft", "--young", "0"], &["--young"]);
    refused(&["replay", "--body", "soft", "--young", "-5"], &["--young"]);
    refused(
        &["replay", "--body", "soft", "--young", "nan"],
        &["--young"],
    );
    refused(
        &["replay", "--body", "soft", "--poisson", "0.5"],
        &["--poisson"],
    );
    refused(
        &["replay", "--body", "soft", "--poisson", "-0.1"],
        &["--poisson"],
    );
    refused(
        &["replay", "--body", "soft", "--fix-below", "w:1"],
        &["--fix-below", "axis"],
    );
    refused(
        &["replay", "--body", "soft", "--fix-below", "z"],
        &["--fix-below", "AXIS:VALUE"],
    );
    refused(
        &["replay", "--body", "soft", "--fix-below", "z:abc"],
        &["--fix-below"],
    );
    refused(
        &["replay", "--body", "soft", "--soft-rate", "0"],
        &["--soft-rate"],
    );
    refused(
        &["replay", "--body", "soft", "--soft-rate", "300"],
        &["--soft-rate", "1 ms"],
    );
    refused(
        &["replay", "--body", "soft", "--soft-rate", "2000"],
        &["--soft-rate"],
    );
    refused(
        &["replay", "--body", "soft", "--tool", "mesh:whatever.node"],
        &["--body soft", "mesh tool"],
    );
    let dir = scratch_dir("softcli", "keys");
    for (name, text, key) in [
        (
            "young.toml",
            "body = \"soft\"\nyoung = -1.0\n",
            "young.toml:2:",
        ),
        ("nu.toml", "poisson = 0.7\n", "nu.toml:1:"),
        ("fix.toml", "\nfix_below = \"q:1\"\n", "fix.toml:2:"),
        ("rate.toml", "soft_rate = 3.0\n", "rate.toml:1:"),
        ("body.toml", "body = \"jelly\"\n", "body.toml:1:"),
    ] {
        let p = write(&dir, name, text);
        refused(&["replay", "--scenario", &p.to_string_lossy()], &[key]);
    }
}

/// The soft tests' press: the block of `n` cubes a side made deformable in a world (an arena
/// of `arena` nodes) with a 0.1 burr 0.03 into its top face, in contact; `f` gets the body's
/// storage and the world.
fn pressed_block<R>(
    n: usize,
    arena: usize,
    f: impl FnOnce(&mut SoftOwned, &mut World<'_>) -> R,
) -> R {
    let mut om = block_mesh(n);
    let mut owned = SoftOwned::from_mesh(&om.view());
    let mesh = om.view();
    let sizes = WorldSizes::new(mesh.tet_count(), arena);
    // Spare storage, as the host's deforming worlds have it (the hash moved in place).
    let mut starts = vec![0u32; sizes.hash_starts];
    let mut entries = vec![HashEntry::default(); sizes.hash_entries];
    let mut boxes = vec![Aabb::point(Vec3::ZERO); sizes.tet_boxes];
    let mut normals = vec![Vec3::ZERO; owned.rest.len()];
    let mut st = Store::sized(sizes);
    let mut world = st.world(mesh);
    let mut rest = vec![Vec3::ZERO; owned.rest.len()];
    world.enable_deformation(&mut rest).unwrap();
    world
        .set_spare(SpareStorage {
            hash_starts: &mut starts,
            hash_entries: &mut entries,
            tet_boxes: &mut boxes,
            normals: &mut normals,
        })
        .unwrap();
    world.simulate(BURR_AT, 0.1, 0.05, false, &BURR_PARAMS);
    assert!(world.contact_tet().is_some());
    f(&mut owned, &mut world)
}

/// The press's burr centre and drill parameters ([`pressed_block`]).
const BURR_AT: Vec3 = Vec3::new(0.0123, 0.0371, 0.57);
const BURR_PARAMS: DrillParams = DrillParams {
    max_depth: 2,
    min_area: 0.0,
    budget: 100_000,
};

/// The soft tests' body: `YOUNG`, nu 0.3, the bottom face held, a step every tick.
fn spec() -> SoftSpec {
    SoftSpec::uniform(YOUNG, 0.3, Fix::Below(2, -0.49), 1)
}

/// A driver over storage an earlier body left pushed in (a viewer's reset) starts at rest: with
/// no load its steps leave every node where it was at rest.
#[test]
fn a_new_driver_starts_at_rest_over_used_storage() {
    pressed_block(4, 1 << 14, |owned, world| {
        let spec = spec();
        {
            let mut d = SoftDriver::new(owned, &spec).unwrap();
            for _ in 0..50 {
                d.after_tick(world, Vec3::new(0.0, 0.0, 5.0)).unwrap();
            }
            // The first body left the storage pushed in.
            assert!(d.summary().max_displacement > 1e-4);
        }
        world.simulate(Vec3::new(0.0, 0.0, 2.0), 0.1, 0.05, false, &BURR_PARAMS);
        let mut d = SoftDriver::new(owned, &spec).unwrap();
        for _ in 0..5 {
            assert!(d.after_tick(world, Vec3::ZERO).unwrap());
        }
        // Rounding only (rest plus a zero displacement), against the 1e-4 left by the first body.
        assert!(
            d.summary().max_displacement < 1e-9,
            "{}",
            d.summary().max_displacement
        );
        assert_eq!(d.summary().steps, 5);
    });
}

/// A simulation step that covered many servo ticks (the task fell behind) runs at most one
/// physics step's work, whole or spread over ticks: the rate falls instead of the work piling
/// up. A spread step that ran a link tick for every tick covered did ten cycles here.
#[test]
fn a_late_call_runs_at_most_one_steps_work_whole_or_spread() {
    for spread in [false, true] {
        pressed_block(4, 1 << 14, |owned, world| {
            let mut spec = SoftSpec::uniform(YOUNG, 0.3, Fix::Below(2, -0.49), 4);
            spec.spread = spread;
            let mut d = SoftDriver::new(owned, &spec).unwrap();
            let push = Vec3::new(0.0, 0.0, 5.0);
            assert!(d.after_ticks(world, push, 40).unwrap(), "spread {spread}");
            assert_eq!(d.summary().steps, 1, "spread {spread}");
            // Back in time: one tick, then a step every four.
            let mut steps = 0;
            for _ in 0..8 {
                steps += u64::from(d.after_ticks(world, push, 1).unwrap());
            }
            assert_eq!(steps, 2, "spread {spread}");
            assert_eq!(d.summary().steps, 3, "spread {spread}");
        })
    }
}

/// The substep stiffness ratio in `deform.stiffness` is `h^2 (lambda + 2 mu) / (rho l^2)` on
/// the block of 4 cubes a side (shortest edge l = 0.25, the cubes' edges; h = 4 ms / 10
/// substeps; rho 1000), computed here from the Lame constants; a block a million times
/// stiffer is over 1 and the run warns in one line, naming `--soft-substeps`, and still runs.
#[test]
fn the_stiffness_ratio_is_the_courant_number_squared_and_warns_above_one() {
    let dir = scratch_dir("soft-cli", "stiffness");
    let ratio = |young: f64| {
        let nu: f64 = 0.3;
        let (lambda, mu) = (
            young * nu / ((1.0 + nu) * (1.0 - 2.0 * nu)),
            young / (2.0 * (1.0 + nu)),
        );
        let h: f64 = 4e-3 / 10.0;
        h * h * (lambda + 2.0 * mu) / (1000.0 * 0.25 * 0.25)
    };
    for (young, warned) in [("5000", false), ("5e9", true)] {
        let args = [
            "--mesh",
            "builtin:block:4",
            "--body",
            "soft",
            "--young",
            young,
            "--poisson",
            "0.3",
            "--ticks",
            "8",
        ];
        let json = replay_json(&dir, young, &args);
        let s = json["deform"]["stiffness"]["s_max"]
            .as_f64()
            .expect("s_max");
        let want = ratio(young.parse().unwrap());
        assert!(
            (s - want).abs() <= 1e-6 * want,
            "E {young}: s {s} against {want}"
        );
        assert!(json["deform"]["stiffness"]["label"].is_null());
        let out = run(&[&["replay"][..], &args[..]].concat());
        assert!(out.status.success());
        let err = String::from_utf8_lossy(&out.stderr);
        let lines: Vec<&str> = err.lines().filter(|l| l.contains("too stiff")).collect();
        assert_eq!(lines.len(), usize::from(warned), "E {young}: {err}");
        if warned {
            assert!(lines[0].contains("--soft-substeps"), "{}", lines[0]);
            assert!(want > 1.0);
        }
    }
}

/// A whole step on two threads, and the world's update after it (`World::set_positions_two`),
/// move the world as one thread does, bit for bit (positions and normals), and a driver
/// made again over a body an earlier driver reordered (a reset) pushes the same tets as one
/// over a fresh body: the block of 16 cubes a side (24,576 tets, over
/// `TWO_THREADS_FROM_TETS`), pressed at the same contact every tick.
#[test]
fn two_step_threads_and_a_reset_driver_move_the_world_as_one_thread_does() {
    let spec = spec();
    // The world's positions after 40 pressed steps by a driver on `threads` threads; `reset`:
    // over a body a first driver already stepped.
    let run = |threads: usize, reset: bool| -> (Vec<[u32; 3]>, usize) {
        pressed_block(16, 1 << 16, |owned, world| {
            if reset {
                let at_rest = world.mesh().positions().to_vec();
                let mut d = SoftDriver::new(owned, &spec).unwrap();
                d.after_tick(world, Vec3::new(0.0, 0.0, 5.0)).unwrap();
                // Back to rest for the comparison, the tool away and back (the world's positions:
                // the driver numbered the body's nodes its own way).
                world.set_positions(&at_rest).unwrap();
                world.simulate(Vec3::new(0.0, 0.0, 2.0), 0.1, 0.05, false, &BURR_PARAMS);
                world.simulate(BURR_AT, 0.1, 0.05, false, &BURR_PARAMS);
                assert!(world.contact_tet().is_some());
            }
            let mut d = SoftDriver::new(owned, &spec).unwrap().with_threads(threads);
            for k in 0..40 {
                let stepped = d.after_tick(world, Vec3::new(0.0, 0.0, 5.0)).unwrap();
                assert!(stepped && world.contact_tet().is_some(), "tick {k}");
            }
            let threads = d.summary().threads;
            let moved = d.summary().max_displacement;
            assert!(moved > 1e-5, "{moved}");
            // The update moved the hash in place on most steps (one part or two).
            let updates = world.hash().stats().updates;
            assert!(updates >= 30, "{updates} updates in place");
            let mesh = world.mesh();
            let bits = mesh
                .positions()
                .iter()
                .chain(mesh.normals())
                .map(|p| [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()])
                .collect();
            (bits, threads)
        })
    };
    let (one, t1) = run(1, false);
    let (two, t2) = run(2, false);
    let (again, _) = run(1, true);
    assert_eq!((t1, t2), (1, 2));
    assert!(one == two, "two threads moved the world otherwise");
    assert!(one == again, "the reset driver pushed other tets");
}

/// The library's front door (`tetradrill::Drilling`) on a soft scenario drills and dents the
/// block as `tetradrill replay` does: the same force every tick (its digest, which the body's
/// motion feeds through the contact) and the same physics steps.
#[test]
fn the_librarys_drilling_of_a_soft_body_is_the_replays() {
    let dir = scratch_dir("softcli", "library");
    let trace = press_trace(&dir);
    // Drilling on, a softer block, so the burr both cuts and dents it.
    let text = std::fs::read_to_string(&trace)
        .expect("the trace")
        .replace(",1,0,0,0,0\n", ",1,0,0,0,1\n");
    let trace = write(&dir, "drill.csv", &text);
    let scenario = write(
        &dir,
        "soft.toml",
        &format!(
            "mesh = \"builtin:block:4\"\ntool = \"sphere:0.1\"\ntrace = \"{}\"\nbody = \"soft\"\n\
             young = 3000.0\nfix_below = \"z:-0.49\"\n\n[regions.0]\nhardness = 2000.0\n\
             threshold = 1.0\n",
            trace.display()
        ),
    );
    let spec = scenario.to_string_lossy().into_owned();
    let cli = replay_json(&dir, "cli", &["--scenario", &spec]);
    let setup = tetradrill::scenario::Scenario::load(&spec)
        .expect("the scenario")
        .setup()
        .expect("its set-up");
    let loaded = setup.mesh.load().expect("the mesh");
    let poses =
        tetradrill::traces::PoseSource::new(&setup.poses, Some(&loaded.mesh)).expect("the trace");
    let mut drilling = tetradrill::Drilling::with_mesh(&setup, loaded).expect("a drilling");
    let mut run = drilling.start().expect("a run");
    let mut digest = tetradrill_core::force::ForceDigest::new();
    for i in 0..poses.ticks() {
        digest.push(run.tick(&poses.at(i)));
    }
    assert!(run.soft_error().is_none());
    let soft = run.soft().expect("a soft body");
    assert_eq!(
        cli["force_digest"].as_str(),
        Some(format!("{:016x}", digest.value()).as_str())
    );
    assert_eq!(cli["deform"]["steps"].as_u64(), Some(soft.steps));
    assert!(run.removed_volume() > 0.0, "the burr cut");
    assert!(
        soft.max_displacement > 1e-3,
        "and dented: {}",
        soft.max_displacement
    );
}
