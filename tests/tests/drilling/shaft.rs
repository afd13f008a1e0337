//! The drill tool: a burr on a shaft of passive points (`--tool drill:BURR_R:SHAFT_LEN:SHAFT_R`).
//! The shaft collides and pushes back but never erodes; a point that crosses a face is held
//! there, so the shaft never passes the material's surface, however fast it is moved.
//!
//! Oracles: the unit block's geometry (its faces at +-0.5), and for the erosion a run of the
//! same trace with the plain burr (`sphere:R`) and the tests' own f64 leaf geometry.

use std::path::Path;

use glam::Vec3;
use tetradrill::engine::{self, EngineStorage, ShaftState, TickParams};
use tetradrill::scenario::Scenario;
use tetradrill::traces::PoseSource;
use tetradrill_core::force::ToolState;
use tetradrill_tests::drill::leaves;
use tetradrill_tests::scratch_dir;

const BURR: f64 = 0.1;
const SHAFT_R: f32 = 0.03;

fn write(dir: &Path, name: &str, rows: &[&str]) -> String {
    let mut csv = String::from("t,x,y,z,qw,qx,qy,qz,buttons\n");
    for r in rows {
        csv.push_str(r);
        csv.push('\n');
    }
    let path = dir.join(name);
    std::fs::write(&path, csv).expect("write the trace");
    path.to_string_lossy().into_owned()
}

/// `true` when `p` lies inside the unit block `[-0.5, 0.5]^3` by more than `eps`.
fn inside_block(p: Vec3, eps: f32) -> bool {
    p.abs().max_element() < 0.5 - eps
}

/// One tick's passive points: each one's proxy and whether it is held.
type Points = Vec<(Option<Vec3>, bool)>;

/// What a replay of `trace` with `tool` did, tick by tick.
struct Run {
    forces: Vec<Vec3>,
    /// Per tick: (device position, every passive point's proxy, held flags).
    points: Vec<(Vec3, Points)>,
    removed: f64,
    visible: u32,
    nodes: usize,
    erased_centroids: Vec<[f64; 3]>,
    leaf_size: f64,
    path: Vec<Vec3>,
}

fn replay(trace: &str, tool: &str) -> Run {
    let sc = Scenario {
        mesh: "builtin:block:4".into(),
        trace: trace.into(),
        tool: tool.into(),
        max_depth: 3,
        ..Scenario::default()
    }
    .setup()
    .expect("a valid set-up");
    let params = TickParams::of(&sc).expect("scenario");
    let poses = PoseSource::new(&sc.poses, None).expect("trace");
    let loaded = engine::load_mesh(&sc).expect("mesh");
    let mut store = EngineStorage::new(loaded.mesh, &sc).expect("storage");
    let mut world = store.world().expect("world");
    let (mut tool, mut shaft) = (ToolState::default(), ShaftState::default());
    let (mut forces, mut points, mut path) = (Vec::new(), Vec::new(), Vec::new());
    for i in 0..poses.ticks() {
        let pose = poses.at(i);
        let (f, _) = engine::tick_tool(&mut world, &mut tool, &mut shaft, &params, &pose);
        assert!(f.is_finite() && f.length() <= sc.forces.max_force as f32 * 1.0001);
        forces.push(f);
        path.push(pose.position);
        points.push((
            pose.position,
            shaft
                .drill
                .points()
                .iter()
                .map(|p| (p.proxy, p.is_held()))
                .collect(),
        ));
    }
    engine::validate(&world).expect("valid");
    let h = world.hierarchy();
    let erased_centroids = leaves(world.mesh(), h, 0..world.mesh().tet_count())
        .iter()
        .filter(|l| l.erased)
        .map(|l| {
            let mut c = [0.0; 3];
            for p in &l.p {
                for a in 0..3 {
                    c[a] += p[a] / 4.0;
                }
            }
            c
        })
        .collect();
    Run {
        forces,
        points,
        removed: h.removed_volume(),
        visible: h.visible_face_count(),
        nodes: h.node_count(),
        erased_centroids,
        // The block's tets have edges up to 0.25 * sqrt(3); a depth-3 leaf an eighth of that.
        leaf_size: 0.25 * 3f64.sqrt() / 8.0,
        path,
    }
}

/// The shaft along +z from a burr below the block, pressed sideways into the side face
/// `x = 0.5` (0.05 past it, the burr clear of the block), drill on; then jumped 0.6 further
/// in within one tick.
#[test]
fn a_shaft_pressed_sideways_against_a_wall_stops_there_and_removes_nothing() {
    let dir = scratch_dir("shaft", "wall");
    let trace = write(
        &dir,
        "wall.csv",
        &[
            "0,0.6,0,-0.75,1,0,0,0,1",
            "0.5,0.45,0,-0.75,1,0,0,0,1",
            "0.8,0.45,0,-0.75,1,0,0,0,1",
            "0.801,-0.15,0,-0.75,1,0,0,0,1",
            "1.0,-0.15,0,-0.75,1,0,0,0,1",
        ],
    );
    let run = replay(&trace, &format!("drill:{BURR}:1.5:{SHAFT_R}"));
    let mut pushed = 0;
    for (i, ((device, pts), f)) in run.points.iter().zip(&run.forces).enumerate() {
        assert!(!pts.is_empty());
        // No point's proxy (where the shaft is shown and tracked) is ever inside the block.
        for (k, (proxy, held)) in pts.iter().enumerate() {
            let q = proxy.expect("tracked");
            assert!(
                !inside_block(q, 1e-5),
                "tick {i} point {k}: proxy {q} inside"
            );
            if *held {
                assert!((q.x - 0.5).abs() < 1e-5, "tick {i} point {k}: held at {q}");
            }
        }
        // The shaft's side reaches past the face: the force pushes back along +x.
        if device.x < 0.5 + SHAFT_R - 1e-3 {
            pushed += 1;
            let l = f.length();
            assert!(l > 0.0, "tick {i}: no force at {device}");
            assert!(
                f.x > 0.99 * l,
                "tick {i}: force {f} not along the wall normal"
            );
        }
    }
    assert!(pushed > 300, "{pushed}");
    // Held at the wall after the jump: the last force is the clamp, along +x.
    let last = *run.forces.last().unwrap();
    assert!((last - Vec3::new(8.0, 0.0, 0.0)).length() < 0.05, "{last}");
    assert!(run.points.last().unwrap().1.iter().filter(|p| p.1).count() > 10);
    // The shaft never removed material, nor refined any.
    assert_eq!(run.removed, 0.0);
    assert_eq!(run.nodes, 384);
    assert_eq!(run.visible, 192);
}

/// The shaft horizontal (+z turned onto +x), the burr plunging 0.03 below the top face
/// (z = 0.5) and moving along +x, under the shaft: the shaft lies on the uncut top face.
#[test]
fn with_the_burr_drilling_and_the_shaft_touching_only_the_burr_erodes() {
    let dir = scratch_dir("shaft", "both");
    // (w, y) = (cos 45, sin 45): a quarter turn about y, +z onto +x.
    let q = "0.70710678,0,0.70710678,0";
    let rows = [
        format!("0,-0.3,0,0.7,{q},1"),
        format!("0.3,-0.3,0,0.47,{q},1"),
        format!("0.8,-0.1,0,0.47,{q},1"),
        format!("1.1,-0.1,0,0.47,{q},1"),
    ];
    let rows: Vec<&str> = rows.iter().map(String::as_str).collect();
    let trace = write(&dir, "both.csv", &rows);
    let drill = replay(&trace, &format!("drill:{BURR}:0.6:{SHAFT_R}"));
    let burr = replay(&trace, &format!("sphere:{BURR}"));
    // The shaft was held on the top face and pushed up while the burr drilled.
    let held_ticks = drill
        .points
        .iter()
        .filter(|(_, p)| p.iter().any(|x| x.1))
        .count();
    assert!(held_ticks > 500, "{held_ticks}");
    // Held on the top face, or on a face the burr cut (within a radius and a leaf of its
    // path); never inside the material elsewhere.
    let near_path = |x: Vec3| {
        let d = drill
            .path
            .iter()
            .map(|p| p.distance(x))
            .fold(f32::MAX, f32::min);
        f64::from(d) <= BURR + drill.leaf_size
    };
    for (i, (_, pts)) in drill.points.iter().enumerate() {
        for (proxy, held) in pts {
            let p = proxy.unwrap();
            assert!(
                !inside_block(p, 1e-5) || near_path(p),
                "tick {i}: proxy at {p}"
            );
            if *held {
                assert!(
                    (p.z - 0.5).abs() < 1e-5 || near_path(p),
                    "tick {i}: held at {p}"
                );
            }
        }
    }
    let up = drill
        .forces
        .iter()
        .zip(&burr.forces)
        .filter(|(d, b)| d.z > b.z + 0.5)
        .count();
    assert!(up > 500, "{up}");
    // Exactly the burr's material went: the same removed volume and surface as the plain
    // burr, and every erased leaf within a radius and a leaf of the burr's path.
    assert!(drill.removed > 0.0);
    assert!(
        (drill.removed - burr.removed).abs() <= 1e-9 * burr.removed,
        "{} vs {}",
        drill.removed,
        burr.removed
    );
    assert_eq!(drill.visible, burr.visible);
    for c in &drill.erased_centroids {
        let x = Vec3::new(c[0] as f32, c[1] as f32, c[2] as f32);
        assert!(near_path(x), "an erased leaf at {x} is off the burr's path");
    }
}

#[test]
fn bad_drill_tools_are_refused_with_the_reason() {
    use tetradrill_tests::refused;
    for (tool, why) in [
        ("drill:0.1:0.6", "three numbers"),
        ("drill:0.1:0.6:x", "three numbers"),
        ("drill:0.1:0.6:0.03:1", "three numbers"),
        ("drill:-0.1:0.6:0.03", "positive"),
        ("drill:0.1:inf:0.03", "positive"),
        ("drill:0.1:0.6:0.2", "at most the burr's radius"),
        ("drill:0.1:0.05:0.03", "longer than the burr's radius"),
    ] {
        refused(&["replay", "--tool", tool], &[tool, why]);
    }
    // In a scenario file: the file, the line of the key and the reason.
    let dir = scratch_dir("shaft", "scenario");
    let p = dir.join("drill.toml");
    std::fs::write(&p, "mesh = \"builtin:cube12\"\ntool = \"drill:0.1:0.6\"\n").unwrap();
    refused(
        &["replay", "--scenario", p.to_str().unwrap()],
        &["drill.toml:2:", "three numbers"],
    );
    // The real-time pipeline refuses a bad one the same way.
    refused(
        &["run", "--duration", "0.1", "--tool", "drill:0.1:0.6:0.2"],
        &["drill:0.1:0.6:0.2", "at most the burr's radius"],
    );
}

/// `--shaft-nodes N` bounds the shaft's walk (`World::set_shaft_max_nodes`) and the replay
/// reports it: no walk enters more than N nodes, walks were cut and points left on an old
/// state on the demo's drill path (its walks need thousands of nodes); with separate bounds
/// (`--tick-budget 0`) the drill removes what the unbounded walk's replay removes; a bound that
/// is not a count is refused with the flag named.
#[test]
fn a_bounded_shaft_walk_is_reported_and_leaves_the_drill_alone() {
    use tetradrill_tests::refused;
    let dir = scratch_dir("shaft", "bounded");
    let run = |nodes: &str| {
        let json = dir.join(format!("bound-{nodes}.json"));
        tetradrill_tests::run_ok([
            "replay",
            "--quiet",
            "--scenario",
            "builtin:demo",
            "--tool",
            "drill:0.1:0.6:0.03",
            "--tick-budget",
            "0",
            "--shaft-nodes",
            nodes,
            "--json",
            json.to_str().expect("a UTF-8 path"),
        ]);
        tetradrill_tests::read_json(&json)
    };
    let (free, bound) = (run("0"), run("256"));
    let s = &bound["shaft"];
    assert_eq!(s["nodes_bound"], 256, "{s}");
    assert!(s["nodes_max"].as_u64().expect("nodes") <= 256, "{s}");
    assert!(
        free["shaft"]["nodes_max"].as_u64().expect("nodes") > 1_000,
        "{}",
        free["shaft"]
    );
    assert!(s["cut_ticks"].as_u64().expect("cuts") > 100, "{s}");
    assert!(s["stale_points"].as_u64().expect("stale") > 0, "{s}");
    assert_eq!(free["shaft"]["cut_ticks"], 0);
    assert_eq!(free["shaft"]["stale_points"], 0);
    assert_eq!(bound["removed_volume"], free["removed_volume"]);
    assert_ne!(bound["force_digest"], free["force_digest"]);
    refused(&["replay", "--shaft-nodes", "-1"], &["--shaft-nodes"]);
}

#[test]
fn a_drill_replay_reports_its_shaft() {
    let dir = scratch_dir("shaft", "json");
    let trace = write(
        &dir,
        "wall.csv",
        &["0,0.6,0,-0.75,1,0,0,0,1", "0.3,0.45,0,-0.75,1,0,0,0,1"],
    );
    let json = dir.join("out.json");
    let out = std::process::Command::new(tetradrill_tests::tetradrill_bin())
        .args([
            "replay",
            "--quiet",
            "--mesh",
            "builtin:block:4",
            "--trace",
            &trace,
        ])
        .args([
            "--tool",
            "drill:0.1:1.5:0.03",
            "--json",
            json.to_str().unwrap(),
        ])
        .output()
        .expect("run");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let j: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert_eq!(j["scenario"]["tool"], "drill:0.1:1.5:0.03");
    assert_eq!(j["shaft"]["passive_points"], 32);
    assert!(j["shaft"]["held_ticks"].as_u64().unwrap() > 0);
    assert_eq!(j["removed_volume"], 0.0);
    assert_eq!(j["debris_erased"]["pieces"], 0);
}

/// Each of the shaft's points looks for the surface among the tets near it (`World::track_shaft`:
/// one small query per point, the tets listed once, each tree walked once for every point
/// whose ball it meets) rather than among all the tets of the box around the whole shaft,
/// each walked by every point (a 0.3 shaft in the teddy: a tick's p99 of 650 us against
/// under 300 us). The answers cannot change: a point is only ever offered the faces within
/// its own ball and faces beyond its reach, and ties between faces go to the smallest
/// `(tet, index, face)` whatever the order they come in.
///
/// Oracle: a golden replay made with each point's own query and its own walk of each of its
/// tets (the implementation before the shared walk, with the same tie rule and the shaft's
/// own reach, `DrillTool::shaft_reach`; the force digest `97f4d58e4eef52c0`): a burr of
/// 0.03 on a 0.3 shaft plunged into the teddy's head and swept to and fro across it (the
/// path of `scripts/clinical-drill.sh --moving`, a shaft point within reach of the surface
/// on 219 ticks), every tet to the default depth
/// (`--resolution 0`, as the golden replay drilled), the walk unbounded (`--shaft-nodes 0`,
/// as the golden replay walked; the bound is `shaft_bound.rs`'s).
#[test]
fn the_shaft_points_share_one_walk_and_answer_as_each_points_own() {
    const TEDDY: &str = "models/teddy_cgalbear_tetgen_q1.414.node";
    let mesh = tetradrill_tests::mesh(TEDDY);
    // The highest node, read from the file as the script reads it (f64).
    let text = std::fs::read_to_string(&mesh).expect("the teddy's nodes");
    let rows: Vec<Vec<f64>> = text
        .lines()
        .filter(|l| !l.trim().is_empty() && !l.starts_with('#'))
        .map(|l| {
            l.split_whitespace()
                .map(|w| w.parse().expect("a number"))
                .collect()
        })
        .collect();
    let n = rows[0][0] as usize;
    let top = rows[1..=n]
        .iter()
        .max_by(|a, b| a[3].total_cmp(&b[3]))
        .expect("nodes");
    let (x0, y0, z0, r) = (top[1], top[2], top[3], 0.03f64);
    let mut rows = Vec::new();
    for i in (0..=5000).step_by(5) {
        let t = f64::from(i) / 1000.0;
        let (x, z) = if t < 1.0 {
            (x0, z0 + r * (5.0 / 3.0 - 8.0 / 3.0 * t))
        } else {
            (
                x0 + 10.0 / 3.0 * r * (std::f64::consts::PI * (t - 1.0)).sin(),
                z0 - r,
            )
        };
        rows.push(format!("{t},{x:.6},{y0:.6},{z:.6},1,0,0,0,1"));
    }
    let dir = scratch_dir("shaft", "own-tets");
    let rows: Vec<&str> = rows.iter().map(String::as_str).collect();
    let trace = write(&dir, "moving.csv", &rows);
    let json = dir.join("out.json");
    let mesh = mesh.to_str().expect("a UTF-8 path").to_owned();
    tetradrill_tests::run_ok([
        "replay",
        "--quiet",
        "--mesh",
        &mesh,
        "--trace",
        &trace,
        "--tool",
        "drill:0.03:0.3:0.012",
        "--resolution",
        "0",
        "--shaft-nodes",
        "0",
        "--json",
        json.to_str().expect("a UTF-8 path"),
    ]);
    let j = tetradrill_tests::read_json(&json);
    assert!(
        j["shaft"]["near_ticks"].as_u64().expect("near ticks") > 150,
        "the shaft came near the surface: {}",
        j["shaft"]
    );
    assert_eq!(j["force_digest"], "97f4d58e4eef52c0", "{}", j["shaft"]);
}
