//! The drill tool (`--tool drill:BURR_R:SHAFT_LEN:SHAFT_R`) in the real-time pipeline: `run`
//! with the simulated device and a trace, `demo`, and the shaft handed to the viewer.
//!
//! Oracles: the unit block's geometry (faces at +-0.5), the simulated device's hand spring
//! (a stylus held at the force limit `F` sits `F / k` behind its hand), `replay` of the
//! run's own recorded poses (`--record`), and for the picture the tests' own f64 pinhole
//! model (`tetradrill_tests::viewer`).

use std::path::{Path, PathBuf};
use std::sync::atomic::Ordering;

use tetradrill::engine::TickParams;
use tetradrill::scenario::Scenario;
use tetradrill::tasks::{simulation_task, DrillContact, ShaftLink, Shared, SimStatus, ToolSample};
use tetradrill::viewer::publish::SimViewer;
use tetradrill_core::servo::ContactState;
use tetradrill_core::{Quat, Vec3};
use tetradrill_device::{DeviceSpec, SimConfig};
use tetradrill_tests::{read_json, run_ok, scratch_dir};

const DRILL: &str = "drill:0.1:1.5:0.03";

fn write(dir: &Path, name: &str, rows: &[&str]) -> PathBuf {
    let mut csv = String::from("t,x,y,z,qw,qx,qy,qz,buttons\n");
    for r in rows {
        csv.push_str(r);
        csv.push('\n');
    }
    let path = dir.join(name);
    std::fs::write(&path, csv).expect("write the trace");
    path
}

/// The last row of a trace CSV: position and buttons.
fn last_row(path: &Path) -> [f64; 3] {
    let text = std::fs::read_to_string(path).expect("read the recording");
    let row: Vec<f64> = text
        .lines()
        .last()
        .expect("rows")
        .split(',')
        .map(|x| x.parse().expect("a number"))
        .collect();
    [row[1], row[2], row[3]]
}

/// The same scenario for `run` and `replay`: the unit block, erosion that keeps up with the
/// tool in real time (as `runner.rs`'s comparison).
const SCENE: [&str; 8] = [
    "--mesh",
    "builtin:block:4",
    "--max-depth",
    "3",
    "--budget-per-tick",
    "20000",
    "--tool",
    DRILL,
];

/// `run --device sim --trace FILE --tool drill:...`, recording the stylus's poses.
fn run(trace: &Path, out_json: &Path, record: &Path) -> serde_json::Value {
    let mut args = vec![
        "run",
        "--headless",
        "--no-rt",
        "--quiet",
        "--device",
        "sim",
        "--trace",
        trace.to_str().unwrap(),
    ];
    args.extend(SCENE);
    args.extend([
        "--json",
        out_json.to_str().unwrap(),
        "--record",
        record.to_str().unwrap(),
    ]);
    run_ok(&args);
    read_json(out_json)
}

fn replay(trace: &Path, out_json: &Path) -> serde_json::Value {
    let mut args = vec!["replay", "--quiet", "--trace", trace.to_str().unwrap()];
    args.extend(SCENE);
    args.extend(["--json", out_json.to_str().unwrap()]);
    run_ok(&args);
    read_json(out_json)
}

/// The shaft along +z from a burr below the block (z = -0.75, clear of it), drill on, its
/// hand moved from x = 0.6 to 0.45: the shaft's side 0.08 past the side face `x = 0.5`.
#[test]
fn a_shaft_pressed_sideways_in_a_run_touches_pushes_back_and_removes_nothing() {
    let dir = scratch_dir("drill-run", "wall");
    let trace = write(
        &dir,
        "wall.csv",
        &[
            "0,0.6,0,-0.75,1,0,0,0,1",
            "0.5,0.45,0,-0.75,1,0,0,0,1",
            "1.0,0.45,0,-0.75,1,0,0,0,1",
        ],
    );
    let (out, rec) = (dir.join("run.json"), dir.join("rec.csv"));
    let j = run(&trace, &out, &rec);
    let s = &j["shaft"];
    assert_eq!(s["passive_points"], 32, "{s}");
    // The hand reaches the wall half way through: hundreds of ticks with the shaft pushing.
    let pushing = s["pushing_ticks"].as_u64().expect("pushing_ticks");
    assert!(pushing > 300, "{s}");
    assert!(s["held_ticks"].as_u64().unwrap() > 0, "{s}");
    assert!(s["near_ticks"].as_u64().unwrap() >= pushing, "{s}");
    // Nothing removed, nothing refined: the block's 6 x 64 roots, 192 boundary faces.
    assert_eq!(j["removed_volume"], 0.0);
    assert_eq!(j["hierarchy_nodes"], 384);
    assert_eq!(j["visible_faces"], 192);
    assert_eq!(j["valid"], true);
    // The shaft's springs reached the stylus: at the end the hand rests at x = 0.45 and the
    // stylus at the force limit's distance behind it, F / k along +x (the wall's normal),
    // not at the hand (no force) nor elsewhere in y or z.
    let max_n = j["force_max_n"].as_f64().unwrap();
    let sim = SimConfig::default();
    assert!(
        (max_n - DeviceSpec::SIM.max_force_n).abs() < 1e-3,
        "{max_n}"
    );
    let [x, y, z] = last_row(&rec);
    let behind = DeviceSpec::SIM.max_force_n / sim.hand_stiffness_n_per_m;
    assert!(
        (x - (0.45 + behind)).abs() < 2e-3,
        "stylus at x = {x}: {s}, force max {max_n}"
    );
    assert!(
        y.abs() < 1e-6 && (z + 0.75).abs() < 2e-3,
        "stylus at {y}, {z}"
    );
}

/// The same press with the burr inside the block (z = -0.35): the burr cuts a groove into
/// the side face while the shaft above it is pressed against the face.
///
/// The run is real time: the simulation steps when it can (not once per servo tick) and
/// erodes along the swept path in spheres a fraction of a radius apart, and the stylus is a
/// mass on a spring that the rendered force pushes back. So the run is compared with a replay
/// of its own recorded poses (the stylus where it really was), within 10 % as `runner.rs`
/// compares the burr; the replay of the hand's trace drills deeper, since there nothing
/// holds the tool back.
#[test]
fn with_the_burr_drilling_a_run_removes_what_the_replay_of_its_poses_removes() {
    let dir = scratch_dir("drill-run", "cut");
    let trace = write(
        &dir,
        "cut.csv",
        &[
            "0,0.6,0,-0.35,1,0,0,0,1",
            "0.5,0.45,0,-0.35,1,0,0,0,1",
            "1.0,0.45,0,-0.35,1,0,0,0,1",
        ],
    );
    let (out, rec) = (dir.join("run.json"), dir.join("rec.csv"));
    let r = run(&trace, &out, &rec);
    assert!(r["shaft"]["pushing_ticks"].as_u64().unwrap() > 300, "{r}");
    assert_eq!(r["valid"], true);
    let of_poses = replay(&rec, &dir.join("poses.json"));
    let of_hand = replay(&trace, &dir.join("hand.json"));
    let (vr, vp, vh) = (
        r["removed_volume"].as_f64().unwrap(),
        of_poses["removed_volume"].as_f64().unwrap(),
        of_hand["removed_volume"].as_f64().unwrap(),
    );
    assert!(vp > 0.0, "the replay drilled");
    assert!(
        (vr - vp).abs() <= 0.10 * vp,
        "the run removed {vr}, the replay of its poses {vp}"
    );
    assert!(vh > vr, "held back by the shaft: {vr} vs the hand's {vh}");
    // Both saw the shaft held at the face.
    assert!(of_poses["shaft"]["held_ticks"].as_u64().unwrap() > 0);
}

/// `demo --tool drill:...` runs the scripted path with the drill and writes the shaft.
#[test]
fn the_demo_runs_with_the_drill_and_reports_its_shaft() {
    let dir = scratch_dir("drill-run", "demo");
    let out = dir.join("demo.json");
    run_ok([
        "demo",
        "--headless",
        "--no-rt",
        "--duration",
        "2",
        "--tool",
        "drill:0.1:0.6:0.03",
        "--json",
        out.to_str().unwrap(),
    ]);
    let j = read_json(&out);
    assert_eq!(j["ticks"], 2000);
    assert_eq!(j["valid"], true);
    // 0.5 / 0.03: 17 gaps, 18 points.
    assert_eq!(j["shaft"]["passive_points"], 18);
    assert!(j["removed_volume"].as_f64().unwrap() > 0.0);
    // A bad spec: one line with the reason, exit 2.
    tetradrill_tests::refused(
        &["demo", "--headless", "--tool", "drill:0.1:0.6"],
        &["drill:0.1:0.6", "three numbers"],
    );
}

/// The simulation task with a drill hands the viewer the shaft along the tool's axis, and
/// the servo the passive points' planes: a tool turned a quarter about y (+z onto +x) with
/// its shaft lying 0.01 into the top face and its burr clear of the block.
#[test]
fn the_simulation_task_publishes_the_shaft_to_the_viewer_and_the_servo() {
    let sc = Scenario {
        mesh: "builtin:block:4".into(),
        tool: "drill:0.1:0.6:0.03".into(),
        max_depth: 3,
        ..Scenario::default()
    }
    .setup()
    .expect("a valid set-up");
    let params = TickParams::of(&sc).expect("params");
    let tool = params.shaft.expect("a drill");
    let loaded = tetradrill::engine::load_mesh(&sc).expect("mesh");
    let mut store = tetradrill::engine::EngineStorage::new(loaded.mesh, &sc).expect("storage");
    let mut world = store.world().expect("world");
    let shared = Shared::new();
    let rotation = Quat::from_rotation_y(std::f32::consts::FRAC_PI_2);
    // The burr beside the block (clear: 0.15 from its edge), the shaft along +x over the top
    // face, its side 0.01 into it; drill off.
    let centre = Vec3::new(-0.65, 0.0, 0.5 + 0.03 - 0.01);
    for i in 0..3 {
        shared
            .ring
            .push(ToolSample {
                tick: i,
                position: centre,
                rotation,
                buttons: 0,
            })
            .expect("room");
    }
    let (mut contact_in, _c) = triple_buffer::TripleBuffer::new(&ContactState::default()).split();
    let (mut status_in, _s) = triple_buffer::TripleBuffer::new(&SimStatus::default()).split();
    let (mut drill_in, mut drill_out) =
        triple_buffer::TripleBuffer::new(&DrillContact::default()).split();
    let mut link = SimViewer::new(&shared.snapshots, None, world.mesh().tet_count());
    shared.stop.store(true, Ordering::Relaxed);
    simulation_task(
        &mut world,
        params,
        &shared.ring,
        &mut contact_in,
        &mut status_in,
        &shared.stop,
        &shared.counters,
        Some(&mut link),
        Some(ShaftLink::new(tool, &mut drill_in)),
    );
    // The servo's side: every passive point over the block has the top face's plane.
    let c = *drill_out.read();
    assert_eq!(c.shaft.count, tool.passive_count());
    let mut over = 0;
    for (pt, p) in c.shaft.points().iter().zip(&c.shaft.positions) {
        if p.x.abs() < 0.5 - 0.03 {
            over += 1;
            let (q, n) = pt.plane.expect("a plane under the shaft");
            assert!(
                (q.z - 0.5).abs() < 1e-5 && (n - Vec3::Z).length() < 1e-4,
                "{pt:?}"
            );
        }
    }
    assert!(over > 10, "{over}");
    // The viewer's side: the last snapshot's tool carries the shaft along +x, drawn out of
    // the face (lifted by the points' depth, 0.01).
    let mut last = None;
    while let Some(s) = shared.snapshots.take() {
        last = Some(s.tool);
    }
    let tv = last.expect("a snapshot");
    let s = tv.shaft.expect("the shaft");
    assert!((s.axis - Vec3::X).length() < 1e-5, "{s:?}");
    assert_eq!((s.from, s.length, s.radius), (0.1, 0.6, 0.03));
    assert!(
        (tv.shown - (centre + Vec3::Z * 0.01)).length() < 1e-4,
        "{tv:?}"
    );
}

/// The shaft as the viewer draws it (headless render, EGL on Mesa): tool-coloured pixels along
/// its axis from the burr to the handle, background past the handle and beside the shaft.
#[test]
fn the_viewer_draws_the_shaft_along_its_axis() {
    use tetradrill::viewer::camera::Camera;
    use tetradrill::viewer::gl::PALETTE;
    use tetradrill::viewer::handoff::{ShaftView, Snapshot, ToolView};
    use tetradrill::viewer::headless::render;
    use tetradrill::viewer::scene::Scene;
    use tetradrill_tests::viewer::{pixel_of, H, W};

    let centre = Vec3::new(0.0, -0.5, 0.0);
    let mut scene = Scene::new();
    scene.apply(Snapshot {
        seq: 1,
        full: true,
        tool: ToolView {
            position: centre,
            shown: centre,
            radius: 0.1,
            shaft: Some(ShaftView {
                axis: Vec3::Y,
                from: 0.1,
                length: 0.8,
                radius: 0.03,
            }),
            ..ToolView::default()
        },
        ..Snapshot::default()
    });
    let camera = Camera {
        target: Vec3::ZERO,
        distance: 3.2,
        yaw: 0.6,
        pitch: 0.45,
        fov_y: 0.7,
    };
    let pic = render(&mut scene, &camera, W, H, true).expect("a headless GL context (Mesa EGL)");
    let (d, y, p) = (3.2f64, 0.6f64, 0.45f64);
    let eye = [d * p.cos() * y.cos(), d * p.cos() * y.sin(), d * p.sin()];
    let at = |q: [f64; 3]| {
        let (col, row) = pixel_of(eye, [0.0; 3], 0.7, q);
        pic.at(col as u32, row as u32)
    };
    let bg = PALETTE.background.map(|c| (c * 255.0).round() as i32);
    let is_bg = |px: [u8; 4], tol: i32| (0..3).all(|i| (i32::from(px[i]) - bg[i]).abs() <= tol);
    // Along the shaft: y from -0.5 + 0.1 to -0.5 + 0.8.
    for y in [-0.3, -0.1, 0.1, 0.25] {
        let px = at([0.0, y, 0.0]);
        let [r, g, b] = [px[0], px[1], px[2]].map(i32::from);
        // PALETTE.tool is blue over green over red; the light only scales it.
        assert!(
            b > g + 20 && g > r + 10 && !is_bg(px, 6),
            "the shaft at y = {y}: {px:?}"
        );
    }
    // Past the handle, and beside the shaft (0.15 off its axis, five radii).
    for q in [
        [0.0, 0.5, 0.0],
        [0.0, 0.7, 0.0],
        [0.0, 0.0, 0.15],
        [0.0, 0.0, -0.15],
    ] {
        let px = at(q);
        assert!(is_bg(px, 2), "no shaft at {q:?}: {px:?}");
    }
}
