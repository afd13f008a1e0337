//! Energy safety on the servo path (docs/SAFETY.md, "Passivity"): the simulated device pressed
//! into a face of the paper's cube with the burr (`sphere:0.1`), fault-free and with each
//! injected fault (a reversed force, a mirrored x axis): the faults trip the passivity
//! controller, which cuts the motors before the tool is twice as deep as the fault-free press,
//! and the fault-free press trips nothing. A wall ten times the default stiffness that
//! oscillates without the controller settles with it. One run goes through the command line.

use std::sync::{Arc, Mutex};

use crossbeam::queue::ArrayQueue;
use tetradrill::commands::pipeline::{self, PipelineSetup, RunReport, MESH_UNITS};
use tetradrill::engine::TickParams;
use tetradrill::setup::{Setup, Tool};
use tetradrill::tasks::{passivity_params, servo_tick, ServoState, SERVO_PERIOD_NS};
use tetradrill_core::force::PassivityParams;
use tetradrill_core::servo::ContactState;
use tetradrill_core::Vec3;
use tetradrill_device::{
    DeviceError, DeviceKind, DeviceSpec, DeviceState, ForceCommand, HapticDevice, PathPoint,
    Scripted, SimConfig, SimDevice, SimFault, QUAT_IDENTITY,
};
use tetradrill_tests::force_log::ForceLog;
use tetradrill_tests::{refused, scratch_dir, tetradrill_bin, unstalled};

/// The press: the burr's centre (radius 0.1) from x = 0.8 to x = 0.55 in 0.5 s, then held:
/// the hand 5 cm past the cube's +x face (x = 0.5), drill off. 1.5 s.
fn press(t: f64) -> PathPoint {
    let x = 0.8 - 0.25 * (t / 0.5).min(1.0);
    PathPoint {
        position: [x, 0.0, 0.0],
        rotation: QUAT_IDENTITY,
        buttons: 0,
    }
}

const PRESS_TICKS: u64 = 1500;

/// The press with the drill on.
fn drill_press(t: f64) -> PathPoint {
    PathPoint {
        buttons: tetradrill_core::script::DRILL_ON,
        ..press(t)
    }
}

/// A gentle press: the hand 1.5 cm past the face at the same speed, then held: a fault-free
/// press stops about 0.9 cm deep at 1.8 N, under half the simulated device's 8 N.
fn gentle_press(t: f64) -> PathPoint {
    let x = 0.8 - 0.215 * (t / 0.43).min(1.0);
    PathPoint {
        position: [x, 0.0, 0.0],
        rotation: QUAT_IDENTITY,
        buttons: 0,
    }
}

fn cube() -> Setup {
    Setup::new("builtin:cube12", Tool::sphere(0.1))
}

/// The press through the real-time pipeline with `fault`, without a servo stall: the report
/// (and its JSON) and the forces the device was given.
fn press_run(fault: SimFault) -> (RunReport, serde_json::Value, Vec<f64>) {
    path_run(press, "press", fault)
}

/// [`press_run`] on another hand path (`name` for the scratch directory).
fn path_run(
    path: fn(f64) -> PathPoint,
    name: &str,
    fault: SimFault,
) -> (RunReport, serde_json::Value, Vec<f64>) {
    unstalled(|| press_run_once(path, name, fault), |r| r.0.servo_stalls)
}

fn press_run_once(
    path: fn(f64) -> PathPoint,
    name: &str,
    fault: SimFault,
) -> (RunReport, serde_json::Value, Vec<f64>) {
    let writes = Arc::new(Mutex::new(Vec::new()));
    let w = writes.clone();
    let open: pipeline::DeviceFactory = Box::new(move || {
        let c = SimConfig {
            fault,
            ..SimConfig::default()
        };
        Ok(Box::new(ForceLog {
            inner: Box::new(SimDevice::new(Scripted(path), c)),
            writes: w,
        }) as Box<dyn HapticDevice>)
    });
    let dir = scratch_dir("passivity", &format!("{name}-{}", fault.name()));
    let json = dir.join("run.json");
    let cube = cube();
    let rep = pipeline::run(
        &cube,
        tetradrill::engine::load_mesh(&cube).expect("the cube"),
        PipelineSetup::plain(DeviceKind::Sim, open, PRESS_TICKS),
        Some(&json),
    )
    .expect("a run");
    let j = serde_json::from_str(&std::fs::read_to_string(&json).expect("json")).expect("parse");
    let log = writes.lock().expect("log").clone();
    (rep, j, log)
}

#[test]
fn each_fault_trips_the_passivity_controller_and_the_fault_free_press_does_not() {
    let (ok, j, log) = press_run(SimFault::None);
    assert_eq!(ok.stop_reason, "duration");
    assert_eq!(ok.safety.passivity_trips, 0);
    assert_eq!(j["safety"]["passivity_trips"], 0);
    assert_eq!(j["safety"]["probe_trips"], 0);
    assert!(ok.safety.probe_z_min > -2.0, "{:?}", ok.safety);
    // A real press: the hand spring (300 N/m) against the wall (200 N/m) settles 3/5 of the
    // hand's 5 cm deep, 3 cm; the approach overshoots, and more when the simulation task
    // (another thread) publishes the contact plane late on a loaded machine.
    let depth = ok.contact.max_depth_m;
    assert!((0.028..0.05).contains(&depth), "fault-free depth {depth}");
    assert_eq!(j["contact"]["max_depth_m"].as_f64(), Some(depth));
    // Still pressing at the end: the last 300 forces (before the closing zero) were on.
    let held = &log[log.len() - 301..log.len() - 1];
    assert!(held.iter().all(|&f| f > 4.0), "{:?}", &held[..5]);
    assert_eq!(log.last(), Some(&0.0));

    for fault in [SimFault::ReversedForce, SimFault::MirroredX] {
        let (rep, j, log) = press_run(fault);
        let name = fault.name();
        // The force-sign probe trips first, long before energy is stored past the limit.
        assert!(rep.safety.passivity_trips >= 1, "{name}: {:?}", rep.safety);
        assert_eq!(j["safety"]["passivity_trips"], 1, "{name}");
        assert_eq!(j["safety"]["probe_trips"], 1, "{name}");
        assert!(rep.safety.probe_z_min < -6.0, "{name}: {:?}", rep.safety);
        let d = rep.contact.max_depth_m;
        assert!(d <= 2.0 * depth, "{name}: depth {d} against {depth}");
        // With the motors cut the hand pushes the tool to its own depth (5 cm).
        assert!(d > 0.04, "{name}: {d}");
        // Cut: the force was on during the press, zero with the motors off from the trip to
        // the end of the run.
        assert!(log.iter().any(|&f| f > 1.0), "{name}");
        let tail = &log[log.len() - 500..];
        assert!(tail.iter().all(|&f| f == 0.0), "{name}: {:?}", &tail[..5]);
        assert_eq!(rep.force.last_written_n, 0.0);
        assert_eq!(j["force"]["last_written_n"], 0.0);
        assert_eq!(
            rep.stop_reason, "duration",
            "{name}: the run goes on, force off"
        );
    }
}

/// A wall through z = 0.5 facing +z, the burr's centre (radius 0.1) touching it at z = 0.6.
const WALL: ContactState = ContactState {
    valid: true,
    point: Vec3::new(0.0, 0.0, 0.5),
    normal: Vec3::Z,
    depth: 0.0,
    centre: Vec3::new(0.0, 0.0, 0.6),
    triangles: 1,
    stiffness: 0.0,
    vibration: tetradrill_core::servo::VibrationCue {
        hz: 0.0,
        amplitude: 0.0,
        threshold: 0.0,
    },
    friction: 0.0,
};

/// Runs `ticks` servo ticks of `device` against [`WALL`] with the scenario's force law and an
/// observer with `observer` settings; `each` sees the state after every tick.
fn against_the_wall(
    device: &mut dyn HapticDevice,
    sc: &Setup,
    observer: PassivityParams,
    ticks: u64,
    mut each: impl FnMut(&ServoState),
) -> ServoState {
    let params = TickParams::of(sc).expect("params");
    let mut st = ServoState::default();
    st.passivity.set_params(observer);
    let ring = ArrayQueue::new(4);
    for tick in 0..ticks {
        while ring.pop().is_some() {}
        servo_tick(device, &MESH_UNITS, &params, &WALL, &ring, &mut st, tick).expect("tick");
        each(&st);
    }
    st
}

/// The burr pressed down onto a fixed plane (the cube's top face, z = 0.5) by a loosely held
/// stylus (hand damping 0.3 N s/m, the stylus a continuous-time mass: 10 integration steps per
/// tick), the wall `stiffness`: the z force of every tick.
fn hold(stiffness: f64, dissipate: bool) -> (Vec<f32>, ServoState) {
    let mut sc = cube();
    sc.forces.stiffness = stiffness;
    // The hand from 5 cm above contact to 2 cm into the wall in 0.5 s, then held.
    let path = |t: f64| PathPoint {
        position: [0.0, 0.0, 0.65 - 0.07 * (t / 0.5).min(1.0)],
        rotation: QUAT_IDENTITY,
        buttons: 0,
    };
    let c = SimConfig {
        substeps: 10,
        hand_damping_n_s_per_m: 0.3,
        ..SimConfig::default()
    };
    let mut device = SimDevice::new(Scripted(path), c);
    let mut p = passivity_params(&device.spec(), SERVO_PERIOD_NS);
    p.dissipate = dissipate;
    let mut fz = Vec::new();
    let st = against_the_wall(&mut device, &sc, p, 4000, |st| fz.push(st.last_force.z));
    (fz, st)
}

/// Peak-to-peak over the last 0.5 s, and the mean.
fn last_half_second(f: &[f32]) -> (f32, f32) {
    let tail = &f[f.len() - 500..];
    let hi = tail.iter().copied().fold(f32::MIN, f32::max);
    let lo = tail.iter().copied().fold(f32::MAX, f32::min);
    (hi - lo, tail.iter().sum::<f32>() / tail.len() as f32)
}

#[test]
fn a_stiff_wall_that_oscillates_without_the_controller_settles_with_it() {
    // Ten times the default stiffness: 2000 N/m, K T / 2 = 1 N s/m above the grip's 0.3 and
    // the wall's 0.5 together (Colgate's bound broken).
    let (free, st) = hold(2000.0, false);
    let (pp, mean) = last_half_second(&free);
    assert!(
        pp > 0.5 * mean,
        "without the controller: p-p {pp} N, mean {mean} N"
    );
    assert_eq!(st.passivity.dissipated_j(), 0.0);
    let (held, st) = hold(2000.0, true);
    let (pp, mean) = last_half_second(&held);
    assert!(
        pp < 0.05 * mean,
        "with the controller: p-p {pp} N, mean {mean} N"
    );
    // Settled where the hand spring balances the wall: 300 (0.02 - d) = 2000 d.
    let want = 2000.0 * 300.0 * 0.02 / 2300.0;
    assert!((mean - want).abs() < 0.05, "mean {mean} want {want}");
    assert!(st.passivity.dissipated_j() > 0.0);
    assert!(!st.passivity.tripped());
    // The default stiffness neither oscillates nor needs the controller: the forces are
    // those of the law, bit for bit.
    let (plain, _) = hold(200.0, false);
    let (with, st) = hold(200.0, true);
    assert_eq!(st.passivity.dissipated_j(), 0.0);
    assert_eq!(
        plain.iter().map(|f| f.to_bits()).collect::<Vec<_>>(),
        with.iter().map(|f| f.to_bits()).collect::<Vec<_>>()
    );
}

/// The deepest penetration, the trips and the forces of a run on `path` with each fault.
fn faulty_runs(path: fn(f64) -> PathPoint, name: &str) -> [(SimFault, RunReport, Vec<f64>); 2] {
    [SimFault::ReversedForce, SimFault::MirroredX].map(|fault| {
        let (rep, _, log) = path_run(path, name, fault);
        (fault, rep, log)
    })
}

#[test]
fn a_drilling_press_trips_on_each_fault_and_not_without_one() {
    // With the drill on the contact plane follows the removal: nothing is stored past the
    // force limit, so only the force-sign probe can tell.
    let (ok, j, log) = path_run(drill_press, "drill", SimFault::None);
    assert_eq!(ok.safety.passivity_trips, 0, "{:?}", ok.safety);
    assert_eq!(j["safety"]["probe_trips"], 0);
    assert!(ok.safety.probe_z_min > -2.0, "{:?}", ok.safety);
    assert!(ok.removed_volume > 0.0, "the drill removed nothing");
    let held = &log[log.len() - 301..log.len() - 1];
    assert!(held.iter().all(|&f| f > 1.0), "{:?}", &held[..5]);
    for (fault, rep, log) in faulty_runs(drill_press, "drill") {
        let name = fault.name();
        assert_eq!(rep.safety.passivity_trips, 1, "{name}: {:?}", rep.safety);
        assert_eq!(rep.safety.probe_trips, 1, "{name}: {:?}", rep.safety);
        assert_eq!(rep.safety.past_limit_j_max, 0.0, "{name}: {:?}", rep.safety);
        let tail = &log[log.len() - 500..];
        assert!(tail.iter().all(|&f| f == 0.0), "{name}: {:?}", &tail[..5]);
    }
}

#[test]
fn a_gentle_press_trips_on_each_fault_before_the_tool_is_twice_as_deep() {
    let (ok, _, log) = path_run(gentle_press, "gentle", SimFault::None);
    assert_eq!(ok.safety.passivity_trips, 0, "{:?}", ok.safety);
    let depth = ok.contact.max_depth_m;
    // Gentle: the force stays under half the device's 8 N.
    let peak = log.iter().copied().fold(0.0, f64::max);
    assert!(peak < 4.0, "fault-free peak {peak} N");
    assert!((0.005..0.015).contains(&depth), "fault-free depth {depth}");
    for (fault, rep, log) in faulty_runs(gentle_press, "gentle") {
        let name = fault.name();
        assert_eq!(rep.safety.probe_trips, 1, "{name}: {:?}", rep.safety);
        let d = rep.contact.max_depth_m;
        assert!(d < 2.0 * depth, "{name}: depth {d} against {depth}");
        let tail = &log[log.len() - 500..];
        assert!(tail.iter().all(|&f| f == 0.0), "{name}");
    }
}

#[test]
fn the_command_line_runs_a_faulty_press_and_refuses_bad_faults() {
    let dir = scratch_dir("passivity", "cli");
    let trace = dir.join("press.csv");
    std::fs::write(
        &trace,
        "t,x,y,z,qw,qx,qy,qz,buttons\n0,0.8,0,0,1,0,0,0,0\n0.5,0.55,0,0,1,0,0,0,0\n\
         1.5,0.55,0,0,1,0,0,0,0\n",
    )
    .expect("trace");
    let json = dir.join("run.json");
    let run = || {
        let out = std::process::Command::new(tetradrill_bin())
            .args(["run", "--headless", "--quiet", "--no-rt"])
            .args(["--mesh", "builtin:cube12", "--tool", "sphere:0.1"])
            .args(["--sim-fault", "mirrored-x", "--trace"])
            .arg(&trace)
            .arg("--json")
            .arg(&json)
            .output()
            .expect("run tetradrill");
        let err = String::from_utf8_lossy(&out.stderr).into_owned();
        assert_eq!(out.status.code(), Some(0), "{err}");
        let j: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&json).expect("json")).expect("parse");
        (j, err)
    };
    let (j, err) = unstalled(run, |(j, _)| j["servo_stalls"].as_u64().unwrap_or(u64::MAX));
    assert!(err.contains("passivity controller tripped"), "{err}");
    assert_eq!(j["safety"]["passivity_trips"], 1);
    assert!(j["safety"]["dissipated_j"].is_number());
    assert!(j["safety"]["generated_j_max"].is_number());
    let d = j["contact"]["max_depth_m"].as_f64().expect("depth");
    assert!((0.04..0.09).contains(&d), "{d}");
    assert_eq!(j["force"]["last_written_n"], 0.0);
    refused(
        &["run", "--headless", "--sim-fault", "sideways"],
        &["sideways", "reversed-force, mirrored-x"],
    );
    refused(
        &["run", "--device", "falcon", "--sim-fault", "reversed-force"],
        &["--sim-fault", "--device sim"],
    );
}

/// A device held still 1 cm into a wall whose reported position then jumps 19 cm deeper, as
/// the Falcon's coordinates move when homing ends (`position_resets` counts it, or does not).
struct Jumping {
    tick: u64,
    counted: bool,
}

impl HapticDevice for Jumping {
    fn spec(&self) -> DeviceSpec {
        DeviceSpec::SIM
    }
    fn read(&mut self) -> Result<DeviceState, DeviceError> {
        self.tick += 1;
        let z = if self.tick <= 200 { 0.59 } else { 0.40 };
        Ok(DeviceState {
            position: [0.0, 0.0, z],
            ..DeviceState::ZERO
        })
    }
    fn write(&mut self, _: &ForceCommand) -> Result<(), DeviceError> {
        Ok(())
    }
    fn calibrate(&mut self) -> Result<(), DeviceError> {
        Ok(())
    }
    fn position_resets(&self) -> u64 {
        u64::from(self.counted && self.tick > 200)
    }
}

/// The jump is no motion of the tool: counted as a position reset it restarts the observer
/// and trips nothing; the same jump uncounted is 19 cm pushed past the force limit in one
/// tick, which trips it (so the restart is what keeps a homing Falcon running).
#[test]
fn a_position_reset_restarts_the_observer() {
    let run = |counted: bool| {
        let mut device = Jumping { tick: 0, counted };
        let p = passivity_params(&device.spec(), SERVO_PERIOD_NS);
        let st = against_the_wall(&mut device, &cube(), p, 1000, |_| {});
        st.passivity.trips()
    };
    assert_eq!(run(true), 0, "a counted reset trips nothing");
    assert!(run(false) >= 1, "the uncounted jump trips the observer");
}
