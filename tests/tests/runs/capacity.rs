//! Every capacity of the core made small, from the command line, from a scenario file and
//! in-process: the replay completes (exit 0), the saturation is counted under its kind, the
//! state passes the core's `validate()` after every tick, forces stay finite and within the
//! clamp, and they stay as continuous as the unsaturated run's.
//!
//! Continuity, and why this bound. The sphere burr's force is `clamp(E + damping)` with the
//! elastic part `E = clamp(s + residual)`, `s = clamp(k d n)` the spring of one contact plane
//! (point `p`, normal `n`, `d = r - (c - p).n`), and a residual that takes up the jump when the
//! plane changes and then shrinks by `2 F_max dt / T` per tick (`T` the switch time,
//! `servo_force`). Clamps being 1-Lipschitz, every tick satisfies
//! `|F_i - F_{i-1}| <= k |c_i - c_{i-1}| + b (|v_i| + |v_{i-1}|) + 2 F_max dt / T`
//! for damping `b` and tool velocity `v`, whether the plane changed (the drill erased material
//! under the burr, another face became the closest, a full buffer dropped work) or not. The
//! tests check that bound on every tick, saturated or not, with an oracle of their own (the
//! poses and the forces, nothing of the core's state), and that without the switch ramp
//! (`switch_ms = 0`) the same runs break it: the bound is what the ramp buys, not a given.

use std::path::{Path, PathBuf};
use std::process::Command;

use tetradrill::engine::{self, EngineStorage, TickParams};
use tetradrill::pen::{PenRig, PenSizes};
use tetradrill::scenario::Scenario;
use tetradrill::setup::Setup;
use tetradrill::traces::PoseSource;
use tetradrill_core::force::{pen_contact, ForceParams, PenOptions, PenState, ToolState};
use tetradrill_core::servo::Saturations;
use tetradrill_core::{Quat, Vec3};
use tetradrill_tests::{mesh, refused, scratch_dir, tetradrill_bin};

/// Ticks of the demo path replayed: the approach, the plunge with the drill on and the first
/// half of the drag along x.
const TICKS: u64 = 3500;

/// Block of 4 x 4 x 4 cubes (384 tets), depth 4: small enough to validate every tick.
fn base() -> Scenario {
    Scenario {
        mesh: "builtin:block:4".into(),
        max_depth: 4,
        // Separate bounds: a shared tick budget cuts contact searches short by design (it
        // counts them), and these runs study one capacity at a time.
        tick_budget: 0,
        ..Scenario::default()
    }
}

/// One small capacity of the sphere-burr world: its name, the scenario, and the saturation
/// kind that must count.
type Case = (&'static str, Setup, fn(&Saturations) -> u32);

/// A case as its scenario writes it.
type ScenarioCase = (&'static str, Scenario, fn(&Saturations) -> u32);

fn world_cases() -> Vec<Case> {
    let cases: Vec<ScenarioCase> = vec![
        (
            "hierarchy_capacity",
            Scenario {
                hierarchy_capacity: Some(64),
                ..base()
            },
            |s| s.arena,
        ),
        (
            "hash_capacity",
            Scenario {
                hash_capacity: Some(1500),
                ..base()
            },
            |s| s.hash,
        ),
        (
            "candidate_capacity",
            Scenario {
                candidate_capacity: Some(4),
                ..base()
            },
            |s| s.candidates,
        ),
        (
            // 384 roots and one block of 8: the arena shrinks to the one block the v_list can
            // list, and what does not fit is counted as refused refinements.
            "vlist_capacity",
            Scenario {
                vlist_capacity: Some(384 + 7),
                ..base()
            },
            |s| s.arena,
        ),
        (
            "pending_capacity",
            Scenario {
                pending_capacity: Some(16),
                ..base()
            },
            |s| s.pending,
        ),
        (
            "contact_search_nodes",
            Scenario {
                contact_search_nodes: 16,
                ..base()
            },
            |s| s.contact,
        ),
    ];
    cases
        .into_iter()
        .map(|(name, sc, kind)| (name, sc.setup().expect("a valid set-up"), kind))
        .collect()
}

/// One tick of a run: the force and the tool centre.
#[derive(Debug, Clone, Copy)]
struct Tick {
    force: Vec3,
    centre: Vec3,
}

/// Replays `sc` in-process for [`TICKS`] ticks, checking the mesh and the hierarchy with the
/// core's `validate()` after every tick when `validate_each`.
fn replay(sc: &Setup, validate_each: bool) -> (Vec<Tick>, Saturations) {
    let params = TickParams::of(sc).expect("scenario");
    let poses = PoseSource::new(&sc.poses, None).expect("poses");
    let loaded = engine::load_mesh(sc).expect("mesh");
    let mut store = EngineStorage::new(loaded.mesh, sc).expect("storage");
    let mut world = store.world().expect("world");
    let mut tool = ToolState::default();
    let mut out = Vec::with_capacity(TICKS as usize);
    for i in 0..TICKS {
        let pose = poses.at(i);
        let (f, _) = engine::tick(&mut world, &mut tool, &params, &pose);
        if validate_each {
            if let Err(e) = world.mesh().validate() {
                panic!("tick {i}: mesh invalid: {e}");
            }
            if let Err(e) = world.hierarchy().validate(world.mesh()) {
                panic!("tick {i}: hierarchy invalid: {e}");
            }
        }
        out.push(Tick {
            force: f,
            centre: pose.position,
        });
    }
    (out, world.saturations())
}

/// `|F_i - F_{i-1}|` allowed (see the module docs), with 1 mN for rounding.
fn smooth_bound(ticks: &[Tick], i: usize, sc: &Setup) -> f64 {
    let (k, b, dt) = (sc.forces.stiffness, sc.forces.damping, 1e-3);
    let d = |j: usize| {
        if j == 0 {
            0.0
        } else {
            f64::from(ticks[j].centre.distance(ticks[j - 1].centre))
        }
    };
    let ramp = if sc.forces.switch_ms > 0.0 {
        2.0 * sc.forces.max_force * dt / (sc.forces.switch_ms * 1e-3)
    } else {
        0.0
    };
    k * d(i) + b * (d(i) + d(i - 1)) / dt + ramp + 1e-3
}

/// Ticks whose force changed by more than [`smooth_bound`].
fn jumps(ticks: &[Tick], sc: &Setup) -> Vec<usize> {
    (1..ticks.len())
        .filter(|&i| {
            f64::from(ticks[i].force.distance(ticks[i - 1].force)) > smooth_bound(ticks, i, sc)
        })
        .collect()
}

/// The world case `name`, replayed (with `validate()` after every tick when `validate_each`):
/// the kind is counted, forces are finite and within the clamp, and no tick breaks the
/// continuity bound.
fn saturated_run(name: &str, validate_each: bool) {
    let (_, sc, kind) = world_cases()
        .into_iter()
        .find(|c| c.0 == name)
        .expect("a case");
    let (ticks, sat) = replay(&sc, validate_each);
    assert!(kind(&sat) > 0, "{name}: not counted: {sat:?}");
    for (i, t) in ticks.iter().enumerate() {
        assert!(
            t.force.is_finite() && t.force.length() <= sc.forces.max_force as f32 * (1.0 + 1e-6),
            "{name}: tick {i}: force {:?}",
            t.force
        );
    }
    assert!(
        ticks.iter().any(|t| t.force != Vec3::ZERO),
        "{name}: no contact"
    );
    let j = jumps(&ticks, &sc);
    assert!(j.is_empty(), "{name}: the force jumps at ticks {j:?}");
}

/// Every capacity made small: valid after every tick, clamped, continuous. Before the switch
/// ramp, a full arena erased crossing leaves by their centroid (461 force changes over 8 N in
/// 3500 ticks against 120 unsaturated; mended: such a leaf now stays whole) and a full pending
/// deque made islands of material come and go under the burr (440 changes over 8 N): the
/// surface under a burr still changes more often when work is dropped, the force does not.
#[test]
fn every_small_world_capacity_saturates_validly_with_continuous_forces() {
    for (name, ..) in world_cases() {
        saturated_run(name, true);
    }
}

/// The unsaturated reference run keeps the bound too; without the switch ramp it breaks it
/// (its contact plane changes under the burr), and so do the runs whose saturation changes
/// the surface or the plane more often: the bound is not one every run keeps anyway.
/// Without the ramp, 2026-11-24 (ticks over the bound of [`jumps`]): reference 308, hash 1500
/// entries 174. The pending deque of 16 items made 429 before the candidates were left in the
/// hash query's order (the drill then dropped the work of other tets, and islands of
/// material came and went under the burr); now 7, so it is no longer one of the runs here.
/// With the ramp, the largest change of every run is about 1 N.
#[test]
fn without_the_switch_ramp_plane_changes_make_the_force_jump() {
    let sc = base().setup().expect("a valid set-up");
    let (ticks, sat) = replay(&sc, false);
    assert_eq!(sat, Saturations::default(), "the reference run saturates");
    assert!(ticks.iter().any(|t| t.force != Vec3::ZERO), "no contact");
    let j = jumps(&ticks, &sc);
    assert!(j.is_empty(), "reference: the force jumps at ticks {j:?}");
    let instant = |mut sc: Setup| {
        sc.forces.switch_ms = 0.0;
        sc
    };
    let mut runs = vec![("reference", instant(base().setup().expect("a set-up")))];
    for (name, sc, _) in world_cases() {
        if name == "hash_capacity" {
            runs.push((name, instant(sc)));
        }
    }
    for (name, sc) in runs {
        let (ticks, _) = replay(&sc, false);
        let n = jumps(&ticks, &sc).len();
        assert!(n > 50, "{name}: {n} jumps without the ramp");
    }
}

/// Ticks of the demo replay `sc` whose force points against the last tick's, both over 1 N.
fn reversals(sc: &Setup) -> Vec<u64> {
    let params = TickParams::of(sc).expect("scenario");
    let poses = PoseSource::new(&sc.poses, None).expect("poses");
    let loaded = engine::load_mesh(sc).expect("mesh");
    let mut store = EngineStorage::new(loaded.mesh, sc).expect("storage");
    let mut world = store.world().expect("world");
    let mut tool = ToolState::default();
    let mut last = Vec3::ZERO;
    let mut out = Vec::new();
    for i in 0..poses.ticks() {
        let (f, _) = engine::tick(&mut world, &mut tool, &params, &poses.at(i));
        if f.dot(last) < 0.0 && f.length() > 1.0 && last.length() > 1.0 {
            out.push(i);
        }
        last = f;
    }
    out
}

/// The unsaturated demo replay (`builtin:demo` on `builtin:block:8`, depth 5) never reverses
/// the burr's force from one tick to the next. Without the switch ramp it does, 11 times
/// (ticks 982-4413): the burr buried in half-eroded material, hundreds of faces within its
/// radius and nearly equidistant walls facing each other, takes one wall's plane one tick and
/// the other's the next (before the cutting rule of `Hierarchy::nearest_uncut`: 44 times).
#[test]
fn unsaturated_drilling_never_reverses_the_force() {
    let r = reversals(&Setup::default());
    assert!(r.is_empty(), "force reversed at ticks {r:?}");
    let sc = Scenario {
        switch_ms: 0.0,
        ..Scenario::default()
    }
    .setup()
    .expect("a valid set-up");
    assert!(!reversals(&sc).is_empty(), "no reversal without the ramp");
}

/// The pen mesh (metres) x10 against the unit block, tip pushed straight down through the top
/// face (z = 0.5) to z = 0.3 over 2000 ticks, then held.
fn pen_rig() -> PenRig {
    let load = |p: &Path, s: f64| tetradrill::meshio::load(p, s).expect("mesh").mesh;
    PenRig {
        pen: load(&mesh("models/pen_tool_gmsh.mesh"), 10.0),
        obj: load(Path::new("builtin:block:8"), 1.0),
    }
}

fn pen_tip(i: u64) -> Vec3 {
    Vec3::new(0.013, -0.007, 0.7 - 0.4 * (i.min(2000) as f32 / 2000.0))
}

const PEN_TICKS: u64 = 2500;

/// What a pen run saw: forces, ticks with a full collision list, ticks with a full queue.
fn pen_run(sizes: PenSizes) -> (Vec<Vec3>, u32, u32) {
    let mut rig = pen_rig();
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
    let (r, _) = rig
        .with_sizes(sizes, |scene, bufs| {
            let mut state = PenState::default();
            let (mut forces, mut full, mut queue) = (Vec::new(), 0, 0);
            for i in 0..PEN_TICKS {
                let c = pen_contact(scene, bufs, pen_tip(i), Quat::IDENTITY, &opts, &mut state);
                let (p, o) = (&c.pen_depth, &c.object_depth);
                full += (c.pen_collisions.saturated
                    || c.object_collisions.saturated
                    || p.out_full
                    || o.out_full) as u32;
                queue += (p.queue_full || o.queue_full) as u32;
                // What was written is well formed: finite depths, unit (or zero) directions,
                // at most what the buffers hold.
                assert!(c.penetrations.0 <= bufs.pen_pens.len());
                assert!(c.penetrations.1 <= bufs.object_pens.len());
                let pens = bufs.pen_pens[..c.penetrations.0]
                    .iter()
                    .chain(&bufs.object_pens[..c.penetrations.1]);
                for q in pens {
                    let l = q.dir.length();
                    assert!(q.depth.is_finite() && (l == 0.0 || (l - 1.0).abs() < 1e-4));
                }
                forces.push(c.force);
            }
            (forces, full, queue)
        })
        .expect("pen rig");
    r
}

/// The largest per-tick force change of a pen run.
fn largest_change(f: &[Vec3]) -> f32 {
    (1..f.len())
        .map(|i| f[i].distance(f[i - 1]))
        .fold(0.0, f32::max)
}

/// The pen with `sizes`: the buffer is counted full, forces stay finite and clamped; returns
/// the largest per-tick force change.
fn pen_saturated(name: &str, sizes: PenSizes, contacts: bool) -> f32 {
    let (f, full, queue) = pen_run(sizes);
    let counted = if contacts { full } else { queue };
    assert!(counted > 0, "{name}: not counted");
    assert!(
        f.iter()
            .all(|f| f.is_finite() && f.length() <= 8.0 * (1.0 + 1e-6)),
        "{name}: force out of bounds"
    );
    assert!(f.iter().any(|f| f.length() > 0.1), "{name}: no force");
    largest_change(&f)
}

fn contacts(n: usize) -> PenSizes {
    PenSizes {
        contacts: Some(n),
        ..PenSizes::default()
    }
}

fn queue(n: usize) -> PenSizes {
    PenSizes {
        queue: Some(n),
        ..PenSizes::default()
    }
}

/// The unsaturated pen run: never saturates, touches, and its largest per-tick change (the
/// tip moves 0.2 mm a tick) is small: 0.12 N today.
fn pen_reference() -> f32 {
    let (f, full, queue) = pen_run(PenSizes::default());
    assert_eq!((full, queue), (0, 0), "the reference pen run saturates");
    assert!(f.iter().any(|f| f.length() > 0.1), "the pen touches");
    largest_change(&f)
}

/// A pen run is as smooth as the reference when its largest per-tick change stays under
/// 1 N (an eighth of the clamp) and under 4 times the reference's.
fn smooth_like(name: &str, j: f32, j0: f32) {
    assert!(
        j <= 1.0 && j <= 4.0 * j0.max(0.05),
        "{name}: force changes by {j:.2} N in one tick; the unsaturated run by {j0:.2} N"
    );
}

#[test]
fn pen_buffers_saturate_with_finite_clamped_forces() {
    for (name, sizes, c) in [
        ("contacts 4", contacts(4), true),
        ("contacts 32", contacts(32), true),
        ("queue 2", queue(2), false),
        ("queue 16", queue(16), false),
    ] {
        pen_saturated(name, sizes, c);
    }
    // The object is never changed by a pen: its mesh stays valid.
    let mut rig = pen_rig();
    rig.obj.view().validate().expect("object mesh valid");
}

#[test]
fn a_pen_contact_list_short_of_a_few_nodes_keeps_forces_smooth() {
    let j0 = pen_reference();
    let j = pen_saturated("contacts 32", contacts(32), true);
    smooth_like("contacts 32", j, j0);
}

/// A full collision list keeps last tick's nodes that still collide first, and their depths
/// follow edges to unlisted nodes on to the object's surface, so a node enters or leaves the
/// list only where its depth is near zero (it used to keep the smallest ids: 7.6 N in one
/// tick with 4 entries); a short propagation queue goes on in a chain through the depth
/// slots and changes no depth (it used to leave the nodes past it without one: 5.3 N and
/// 1.95 N with 2 and 16 entries). Largest change per tick now 0.12 N in all three, like the
/// unsaturated run. See docs/SAFETY.md.
#[test]
fn tiny_pen_buffers_keep_forces_smooth() {
    let j0 = pen_reference();
    for (name, sizes, c) in [
        ("contacts 4", contacts(4), true),
        ("queue 2", queue(2), false),
        ("queue 16", queue(16), false),
    ] {
        let j = pen_saturated(name, sizes, c);
        smooth_like(name, j, j0);
    }
}

fn json(path: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(path).expect("read JSON")).expect("parse JSON")
}

/// Runs the binary; asserts exit 0; returns the JSON summary.
fn replay_json(dir: &Path, name: &str, args: &[&str]) -> serde_json::Value {
    let out_path = dir.join(format!("{name}.json"));
    let mut all = vec!["replay", "--quiet", "--json", out_path.to_str().unwrap()];
    all.extend_from_slice(args);
    let out = Command::new(tetradrill_bin())
        .args(&all)
        .output()
        .expect("run tetradrill");
    assert!(
        out.status.success(),
        "{all:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    json(&out_path)
}

fn check_summary(name: &str, j: &serde_json::Value, kind: &str) {
    let n = j["saturations"][kind].as_u64().expect("a count");
    assert!(
        n > 0,
        "{name}: saturations.{kind} is 0: {}",
        j["saturations"]
    );
    assert_eq!(
        j["saturations"]["total"].as_u64(),
        Some(
            [
                "hash",
                "candidates",
                "arena",
                "pending",
                "contact_search",
                "contacts",
                "queue"
            ]
            .iter()
            .map(|k| j["saturations"][k].as_u64().expect("kind"))
            .sum()
        ),
        "{name}: total is the sum of the kinds"
    );
    assert_eq!(j["valid"], true, "{name}");
    let f = j["force"]["max_n"].as_f64().expect("max force");
    assert!(f.is_finite() && f <= 8.0 + 1e-6, "{name}: {f}");
}

#[test]
fn each_capacity_flag_and_scenario_key_saturates_and_exits_0() {
    let dir = scratch_dir("capacity", "flags");
    let common = [
        "--mesh",
        "builtin:block:4",
        "--max-depth",
        "4",
        "--ticks",
        "3500",
    ];
    let cases = [
        ("--hierarchy-capacity", "64", "arena"),
        ("--hash-capacity", "1500", "hash"),
        ("--candidate-capacity", "4", "candidates"),
        ("--vlist-capacity", "391", "arena"),
        ("--pending-capacity", "16", "pending"),
        ("--contact-search-nodes", "16", "contact_search"),
    ];
    for (flag, value, kind) in cases {
        let mut args = common.to_vec();
        args.extend([flag, value]);
        let j = replay_json(&dir, &flag[2..], &args);
        check_summary(flag, &j, kind);
        // The same capacity from a scenario file.
        let key = flag[2..].replace('-', "_");
        let toml = dir.join(format!("{key}.toml"));
        std::fs::write(
            &toml,
            format!("mesh = \"builtin:block:4\"\nmax_depth = 4\n{key} = {value}\n"),
        )
        .expect("write scenario");
        let j = replay_json(
            &dir,
            &key,
            &["--scenario", toml.to_str().unwrap(), "--ticks", "3500"],
        );
        check_summary(&key, &j, kind);
    }
    // The pen's buffers, on a trace pushing the pen into the block.
    let trace = plunge_trace(&dir);
    let pen = mesh("models/pen_tool_gmsh.mesh");
    let tool = format!("mesh:{}", pen.display());
    for (flag, value, kind) in [
        ("--contact-capacity", "4", "contacts"),
        ("--queue-capacity", "2", "queue"),
        ("--hash-capacity", "2000", "hash"),
    ] {
        let j = replay_json(
            &dir,
            &format!("pen{}", &flag[1..]),
            &[
                "--mesh",
                "builtin:block:8",
                "--tool",
                &tool,
                "--tool-scale",
                "10",
                "--trace",
                trace.to_str().unwrap(),
                flag,
                value,
            ],
        );
        check_summary(flag, &j, kind);
    }
}

/// [`pen_tip`] as a trace file.
fn plunge_trace(dir: &Path) -> PathBuf {
    let mut text = String::from("t,x,y,z,qw,qx,qy,qz,buttons\n");
    for i in (0..PEN_TICKS).step_by(10) {
        let p = pen_tip(i);
        text.push_str(&format!(
            "{:.3},{},{},{},1,0,0,0,0\n",
            i as f64 / 1000.0,
            p.x,
            p.y,
            p.z
        ));
    }
    let p = dir.join("plunge.csv");
    std::fs::write(&p, text).expect("write trace");
    p
}

#[test]
fn zero_and_absurd_capacities_exit_2_naming_the_flag_or_the_line() {
    for flag in [
        "--hierarchy-capacity",
        "--hash-capacity",
        "--candidate-capacity",
        "--vlist-capacity",
        "--pending-capacity",
        "--contact-search-nodes",
        "--contact-capacity",
        "--queue-capacity",
    ] {
        refused(&["replay", flag, "0"], &[flag]);
        refused(&["replay", flag, "-3"], &[flag]);
        refused(&["replay", flag, "lots"], &[flag]);
        if flag != "--contact-search-nodes" {
            // More than 1 GiB for one buffer.
            refused(&["replay", flag, "99999999999"], &[flag, "1024 MiB"]);
        }
    }
    refused(
        &["replay", "--hierarchy-capacity", "7"],
        &["--hierarchy-capacity"],
    );
    // Below what the mesh needs: one v_list entry per coarse tet (block:8 has 3072).
    refused(
        &["replay", "--vlist-capacity", "100"],
        &["--vlist-capacity", "3072"],
    );
    let dir = scratch_dir("capacity", "scenarios");
    let p = dir.join("zero.toml");
    std::fs::write(&p, "mesh = \"builtin:cube12\"\n\npending_capacity = 0\n").expect("write");
    refused(
        &["replay", "--scenario", p.to_str().unwrap()],
        &["zero.toml:3:", "pending_capacity"],
    );
    let p = dir.join("huge.toml");
    std::fs::write(&p, "queue_capacity = 4000000000\n").expect("write");
    refused(
        &["replay", "--scenario", p.to_str().unwrap()],
        &["huge.toml:1:", "queue_capacity"],
    );
}

/// The tick budget on the command line: by default the drill and the contact search share
/// `DEFAULT_TICK_BUDGET` units and `--tick-budget 0` gives back separate bounds, with the same
/// material removed (the drill's own budget is the smaller); a budget below the drill's slows
/// the drill and cuts contact searches short, counted; a negative one is refused.
#[test]
fn the_tick_budget_is_shared_by_default_and_zero_turns_it_off() {
    let dir = scratch_dir("capacity", "tick-budget");
    let common = ["--mesh", "builtin:block:4", "--max-depth", "4"];
    let with = |extra: &[&str], name: &str| {
        let mut a = common.to_vec();
        a.extend_from_slice(extra);
        replay_json(&dir, name, &a)
    };
    let shared = with(&[], "shared");
    let separate = with(&["--tick-budget", "0"], "separate");
    let tight = with(&["--tick-budget", "300"], "tight");
    assert_eq!(
        shared["scenario"]["tick_budget"].as_u64(),
        Some(u64::from(tetradrill::setup::DEFAULT_TICK_BUDGET))
    );
    assert_eq!(separate["scenario"]["tick_budget"].as_u64(), Some(0));
    for k in [
        "removed_volume",
        "hierarchy_nodes",
        "visible_faces",
        "components",
    ] {
        assert_eq!(shared[k], separate[k], "{k}");
    }
    let removed = |j: &serde_json::Value| j["removed_volume"].as_f64().expect("volume");
    assert!(
        removed(&tight) < removed(&separate),
        "300 units must slow the drill"
    );
    assert!(tight["saturations"]["contact_search"].as_u64() > Some(0));
    refused(&["replay", "--tick-budget", "-1"], &["tick-budget"]);
    let _ = std::fs::remove_dir_all(&dir);
}
