//! The drill through the C interface (a burr on a shaft, poses with a rotation, force and
//! torque), called as C calls it, against the host's replay engine on the same trace: the
//! same force digest, removed volume, saturations and shaft figures; the torque against the
//! moment of the shaft's springs computed here, in f64, from the host's passive points.

use std::ptr;

use tetradrill::engine::{self, EngineStorage, ShaftState, TickParams};
use tetradrill::scenario::Scenario;
use tetradrill::setup::Setup;
use tetradrill::traces::{Pose, PoseSource};
use tetradrill_core::force::{DrillTool, ForceDigest, ToolState, MAX_PASSIVE};
use tetradrill_core::{Quat, Vec3};
use tetradrill_ffi::*;

mod common;
use common::*;

const DRILL: &str = "drill:0.1:0.6:0.03";

/// A trace on the unit block with the shaft turned: along +x (a quarter turn about y) with
/// the burr plunging 0.03 under the top face, drilling along +x with the shaft lying on the
/// face; tilted up 30 degrees while drilling on; turned back down onto the drilled face with
/// the drill off; then on again. Written once for the process: the tests run at once, and a
/// file rewritten under another test's reader reads empty.
fn trace() -> String {
    static PATH: std::sync::OnceLock<String> = std::sync::OnceLock::new();
    PATH.get_or_init(write_trace).clone()
}

fn write_trace() -> String {
    let dir = std::env::temp_dir().join(format!("tetradrill-ffi-drill-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("a scratch folder");
    let flat = "0.70710678,0,0.70710678,0";
    let tilted = "0.8660254,0,0.5,0";
    let rows = [
        format!("0,-0.3,0,0.7,{flat},1"),
        format!("0.3,-0.3,0,0.47,{flat},1"),
        format!("0.8,-0.1,0,0.47,{flat},1"),
        format!("1.1,-0.1,0,0.47,{tilted},1"),
        format!("1.4,0.1,0.1,0.40,{tilted},1"),
        format!("1.6,0.1,0.1,0.40,{flat},0"),
        format!("1.8,0.2,-0.1,0.45,{flat},1"),
    ];
    let mut csv = String::from("t,x,y,z,qw,qx,qy,qz,buttons\n");
    for r in rows {
        csv.push_str(&r);
        csv.push('\n');
    }
    let path = dir.join("drill.csv");
    std::fs::write(&path, csv).expect("write the trace");
    path.to_string_lossy().into_owned()
}

fn setup(trace: &str, tool: &str) -> Setup {
    Scenario {
        mesh: "builtin:block:4".into(),
        trace: trace.into(),
        tool: tool.into(),
        max_depth: 3,
        ..Scenario::default()
    }
    .setup()
    .expect("a valid set-up")
}

/// The moment about the burr's centre of the shaft's springs, from the host's passive points
/// after a tick (their planes), in f64: each point's `(p - c) x k d n` for a positive depth
/// `d = r - (p - q) . n`, scaled down with the springs' sum when that exceeds the clamp.
fn moment(tool: &DrillTool, shaft: &ShaftState, pose: &Pose, k: f32, max: f32) -> [f64; 3] {
    let [w, x, y, z] = pose.rotation;
    let axis = DrillTool::axis(Quat::from_xyzw(x, y, z, w));
    let mut pos = [Vec3::ZERO; MAX_PASSIVE];
    let n = tool.passive_positions(pose.position, axis, &mut pos);
    let d = |v: Vec3| [f64::from(v.x), f64::from(v.y), f64::from(v.z)];
    let c = d(pose.position);
    let (mut sum, mut m) = ([0.0f64; 3], [0.0f64; 3]);
    for (pt, &p) in shaft.drill.points().iter().zip(&pos).take(n) {
        let Some((q, nn)) = pt.plane else { continue };
        let (p, q, nn) = (d(p), d(q), d(nn));
        let depth = f64::from(tool.shaft_radius)
            - ((p[0] - q[0]) * nn[0] + (p[1] - q[1]) * nn[1] + (p[2] - q[2]) * nn[2]);
        if depth <= 0.0 {
            continue;
        }
        let s = nn.map(|v| v * f64::from(k) * depth);
        let r = [p[0] - c[0], p[1] - c[1], p[2] - c[2]];
        for a in 0..3 {
            sum[a] += s[a];
        }
        m[0] += r[1] * s[2] - r[2] * s[1];
        m[1] += r[2] * s[0] - r[0] * s[2];
        m[2] += r[0] * s[1] - r[1] * s[0];
    }
    let l = (sum[0] * sum[0] + sum[1] * sum[1] + sum[2] * sum[2]).sqrt();
    let scale = if l > f64::from(max) {
        f64::from(max) / l
    } else {
        1.0
    };
    m.map(|v| v * scale)
}

/// What the host's replay of a drill scenario gave.
struct Host {
    digest: u64,
    removed: f64,
    sat: tetradrill_core::servo::Saturations,
    torques: Vec<[f64; 3]>,
    shaft: TdShaftCounts,
    poses: Vec<Pose>,
}

/// The host's replay of `sc` with its drill, tick by tick as `replay --tool drill:...` runs
/// it (`engine::tick_tool`), the mesh's labels and the scenario's materials set.
fn host_drill(sc: &Setup) -> Host {
    let loaded = engine::load_mesh(sc).expect("scenario mesh");
    let params = TickParams::of(sc).expect("tick params");
    let tool = params.shaft.expect("a drill tool");
    let poses = PoseSource::new(&sc.poses, Some(&loaded.mesh)).expect("poses");
    let mut store = EngineStorage::new(loaded.mesh, sc).expect("storage");
    store.set_labels(&loaded.labels, sc).expect("labels");
    let mut world = store.world().expect("world");
    let (mut burr, mut shaft) = (ToolState::default(), ShaftState::default());
    let mut digest = ForceDigest::new();
    let mut out = Host {
        digest: 0,
        removed: 0.0,
        sat: Default::default(),
        torques: Vec::new(),
        shaft: TdShaftCounts {
            passive_points: tool.passive_count() as u32,
            ..TdShaftCounts::default()
        },
        poses: Vec::new(),
    };
    for i in 0..poses.ticks() {
        let pose = poses.at(i);
        let (f, _) = engine::tick_tool(&mut world, &mut burr, &mut shaft, &params, &pose);
        digest.push(f);
        out.torques.push(moment(
            &tool,
            &shaft,
            &pose,
            params.force.stiffness,
            params.force.max_force,
        ));
        let s = &mut out.shaft;
        s.near_ticks += u64::from(shaft.last.near > 0);
        s.held_ticks += u64::from(shaft.last.held > 0);
        s.held_max = s.held_max.max(shaft.last.held);
        (s.near, s.held) = (shaft.last.near, shaft.last.held);
        out.poses.push(pose);
    }
    out.digest = digest.value();
    out.removed = world.hierarchy().removed_volume();
    out.sat = world.saturations();
    out
}

/// How the C side runs each tick.
#[derive(Clone, Copy, PartialEq, Debug)]
enum Ticks {
    /// `td_world_tick_pose`.
    Whole,
    /// `td_world_simulate_pose`, then `td_servo_wrench`: two tasks' calls, one after the other.
    Halves,
    /// `td_world_tick`, the position alone (the identity rotation).
    Positions,
}

/// What the C side gave.
struct Run {
    counters: TdCounters,
    servo: TdServoCounts,
    tools: TdToolCounts,
    shaft: TdShaftCounts,
    torques: Vec<TdVec3>,
}

/// `poses` through the C interface: a world for the block of `n` with `labels` and `sc`'s
/// materials, made a drill of `shaft` (length, radius) when given.
fn c_drill(sc: &Setup, n: usize, shaft: Option<(f32, f32)>, poses: &[Pose], ticks: Ticks) -> Run {
    let p = params_of(sc, n);
    let labels = block_labels(n);
    let (_mem, world) = c_world(&p, n, Some(&labels), &materials(sc));
    if let Some((length, radius)) = shaft {
        // SAFETY: a live world.
        assert_eq!(
            unsafe { td_world_set_drill(world, length, radius) },
            TdStatus::TdOk
        );
    }
    let mut servo: *mut TdServo = ptr::null_mut();
    // SAFETY: a live world, a writable output.
    unsafe { assert_eq!(td_world_servo(world, &mut servo), TdStatus::TdOk) };
    let mut torques = Vec::new();
    for pose in poses {
        let (mut f, mut t) = (TdVec3::default(), TdVec3::default());
        let at = td_pose(pose);
        // SAFETY: a live world, its servo, writable outputs.
        let st = unsafe {
            match ticks {
                Ticks::Whole => td_world_tick_pose(world, at, pose.buttons, &mut f, &mut t),
                Ticks::Halves => {
                    let s = td_world_simulate_pose(world, at, pose.buttons, ptr::null_mut());
                    assert_eq!(s, TdStatus::TdOk);
                    td_servo_wrench(servo, at, &mut f, &mut t)
                }
                Ticks::Positions => td_world_tick(world, at.position, pose.buttons, &mut f),
            }
        };
        assert_eq!(st, TdStatus::TdOk);
        torques.push(t);
    }
    let mut run = Run {
        counters: TdCounters::default(),
        servo: TdServoCounts::default(),
        tools: TdToolCounts::default(),
        shaft: TdShaftCounts::default(),
        torques,
    };
    // SAFETY: a live world and its servo, writable outputs.
    unsafe {
        assert_eq!(td_world_counters(world, &mut run.counters), TdStatus::TdOk);
        assert_eq!(td_servo_counters(servo, &mut run.servo), TdStatus::TdOk);
        assert_eq!(
            td_servo_tool_counters(servo, &mut run.tools),
            TdStatus::TdOk
        );
        assert_eq!(td_world_shaft(world, &mut run.shaft), TdStatus::TdOk);
    }
    run
}

#[test]
fn a_turned_drill_gives_the_hosts_digest_and_the_shafts_moment() {
    let sc = setup(&trace(), DRILL);
    let host = host_drill(&sc);
    let c = c_drill(&sc, 4, Some((0.6, 0.03)), &host.poses, Ticks::Whole);
    assert_eq!(
        format!("{:016x}", c.servo.force_digest),
        format!("{:016x}", host.digest),
        "the C interface's drill digest differs from the host's replay"
    );
    assert_eq!(c.counters.removed_volume, host.removed);
    assert!(host.removed > 0.0, "the burr drills");
    assert_eq!(saturations(&c.counters), host.sat);
    assert_eq!(c.shaft, host.shaft, "the shaft's figures");
    assert!(host.shaft.held_ticks > 100, "{:?}", host.shaft);
    assert_eq!(c.shaft.passive_points, 18);
    assert_eq!(c.tools.tool, 1);
    // The torque, tick by tick, against the moment computed here.
    let mut pushed = 0;
    for (i, (t, want)) in c.torques.iter().zip(&host.torques).enumerate() {
        let got = [t.x, t.y, t.z].map(f64::from);
        let err = (0..3).map(|a| (got[a] - want[a]).abs()).fold(0.0, f64::max);
        let size = want.iter().map(|v| v.abs()).fold(0.0, f64::max);
        assert!(
            err <= 1e-5 + 1e-4 * size,
            "tick {i}: torque {got:?}, want {want:?}"
        );
        pushed += usize::from(size > 1e-3);
    }
    assert!(
        pushed > 300,
        "the shaft pushed with a moment on {pushed} ticks"
    );
    // The torque digest is the digest of the torques returned.
    let mut digest = ForceDigest::new();
    for t in &c.torques {
        digest.push(Vec3::new(t.x, t.y, t.z));
    }
    assert_eq!(c.tools.torque_digest, digest.value());
}

#[test]
fn the_drills_two_halves_are_its_whole_tick() {
    let sc = setup(&trace(), DRILL);
    let poses: Vec<Pose> = host_drill(&sc).poses;
    let whole = c_drill(&sc, 4, Some((0.6, 0.03)), &poses, Ticks::Whole);
    let halves = c_drill(&sc, 4, Some((0.6, 0.03)), &poses, Ticks::Halves);
    assert_eq!(halves.servo.force_digest, whole.servo.force_digest);
    assert_eq!(halves.tools.torque_digest, whole.tools.torque_digest);
    assert_eq!(
        halves.counters.removed_volume,
        whole.counters.removed_volume
    );
    assert_eq!(halves.shaft, whole.shaft);
    assert_eq!(
        (halves.servo.stale_reads, halves.servo.step),
        (0, poses.len() as u32)
    );
}

/// Poses without a rotation are the identity: the shaft along +z, as the host's scripted
/// paths give it.
#[test]
fn a_drill_on_the_demo_path_gives_the_hosts_digest() {
    let mut sc = builtin("demo");
    sc.tool = "drill:0.1:0.6:0.03".parse().expect("a drill tool");
    let host = host_drill(&sc);
    let c = c_drill(&sc, 8, Some((0.6, 0.03)), &host.poses, Ticks::Positions);
    assert_eq!(c.servo.force_digest, host.digest);
    assert_eq!(c.counters.removed_volume, host.removed);
    assert_eq!(c.shaft, host.shaft);
    assert_eq!(c.servo.servo_ticks, 6001);
}

/// The shaft's walk bounded (`td_params.shaft_nodes`, the host's `--shaft-nodes`): the C world
/// is still the host's bit for bit, and the bound changes the demo's run (its walks need far
/// more nodes than the bound).
#[test]
fn a_bounded_shaft_walk_gives_the_hosts_digest() {
    let mut sc = builtin("demo");
    sc.tool = "drill:0.1:0.6:0.03".parse().expect("a drill tool");
    let free = host_drill(&sc);
    sc.drilling.shaft_nodes = 768;
    let host = host_drill(&sc);
    assert_ne!(host.digest, free.digest, "the bound never bit");
    let c = c_drill(&sc, 8, Some((0.6, 0.03)), &host.poses, Ticks::Positions);
    assert_eq!(c.servo.force_digest, host.digest);
    assert_eq!(c.counters.removed_volume, host.removed);
    assert_eq!(c.shaft, host.shaft);
}

/// A sphere's world through the pose calls: the sphere's own step and force (the rotation
/// unused) and no torque.
#[test]
fn a_spheres_world_through_the_pose_calls_is_the_sphere() {
    let sc = setup(&trace(), "sphere:0.1");
    let poses: Vec<Pose> = host_drill(&setup(&trace(), DRILL)).poses;
    let host = host_replay(&sc);
    let c = c_drill(&sc, 4, None, &poses, Ticks::Whole);
    assert_eq!(c.servo.force_digest, host.digest);
    assert_eq!(c.counters.removed_volume, host.removed);
    assert!(c.torques.iter().all(|t| *t == TdVec3::default()));
    assert_eq!(c.tools, TdToolCounts::default());
    assert_eq!(c.shaft, TdShaftCounts::default());
}

#[test]
fn drill_calls_get_their_status() {
    let sc = setup(&trace(), DRILL);
    let p = params_of(&sc, 4);
    let (_mem, world) = c_world(&p, 4, None, &[]);
    let mut servo: *mut TdServo = ptr::null_mut();
    let pose = TdPose {
        position: TdVec3 {
            x: 0.0,
            y: 0.0,
            z: 0.7,
        },
        rotation: TdQuat {
            w: 1.0,
            x: 0.0,
            y: 0.0,
            z: 0.0,
        },
    };
    let (mut f, mut t) = (TdVec3::default(), TdVec3::default());
    // SAFETY: a live world, its servo, valid or null pointers; the functions check.
    unsafe {
        assert_eq!(td_world_servo(world, &mut servo), TdStatus::TdOk);
        for (length, radius) in [
            (0.6, 0.0),
            (0.6, 0.11),
            (0.6, f32::NAN),
            (0.1, 0.03),
            (f32::INFINITY, 0.03),
        ] {
            assert_eq!(
                td_world_set_drill(world, length, radius),
                TdStatus::TdErrParams,
                "shaft {length} x {radius}"
            );
        }
        assert_eq!(
            td_world_set_drill(ptr::null_mut(), 0.6, 0.03),
            TdStatus::TdErrNull
        );
        assert_eq!(td_world_set_drill(world, 0.6, 0.03), TdStatus::TdOk);
        let mut bad = pose;
        bad.rotation.x = f32::NAN;
        assert_eq!(
            td_world_simulate_pose(world, bad, 0, ptr::null_mut()),
            TdStatus::TdErrInput
        );
        assert_eq!(
            td_servo_wrench(servo, bad, &mut f, &mut t),
            TdStatus::TdErrInput
        );
        assert_eq!(
            td_world_tick_pose(world, bad, 0, &mut f, &mut t),
            TdStatus::TdErrInput
        );
        assert_eq!(
            td_servo_wrench(servo, pose, &mut f, ptr::null_mut()),
            TdStatus::TdErrNull
        );
        assert_eq!(
            td_world_tick_pose(world, pose, 0, ptr::null_mut(), &mut t),
            TdStatus::TdErrNull
        );
        let mut c = TdServoCounts::default();
        assert_eq!(td_servo_counters(servo, &mut c), TdStatus::TdOk);
        assert_eq!(
            (c.servo_ticks, c.step),
            (0, 0),
            "the refused calls did nothing"
        );
        let mut counters = TdCounters::default();
        assert_eq!(td_world_counters(world, &mut counters), TdStatus::TdOk);
        assert_eq!(counters.simulate_steps, 0);
        // A step made, the tool is fixed.
        assert_eq!(
            td_world_tick_pose(world, pose, 0, &mut f, &mut t),
            TdStatus::TdOk
        );
        assert_eq!(td_world_set_drill(world, 0.6, 0.03), TdStatus::TdErrStarted);
        assert_eq!(td_world_shaft(world, ptr::null_mut()), TdStatus::TdErrNull);
        assert_eq!(
            td_servo_tool_counters(ptr::null_mut(), &mut TdToolCounts::default()),
            TdStatus::TdErrNull
        );
    }
    // A world whose servo force comes before its step (`servo_lag` 1) takes no drill.
    let mut lagged = p;
    lagged.servo_lag = 1;
    let (_mem, world) = c_world(&lagged, 4, None, &[]);
    // SAFETY: a live world.
    assert_eq!(
        unsafe { td_world_set_drill(world, 0.6, 0.03) },
        TdStatus::TdErrParams
    );
}
