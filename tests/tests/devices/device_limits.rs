//! The device's own limits on the servo path (docs/SAFETY.md, "Passivity", and docs/DEVICES.md,
//! "A safe start and the device's limits"): the simulated Omni pressed past its saturation
//! trips and its force comes back once the tool has been out of contact for a second; held at
//! its 3.3 N peak it derates toward its 0.88 N continuous rating. The oracles are the Omni's specification numbers and the press's
//! geometry (the paper's cube, the burr of radius 0.1 against its +x face at x = 0.5).

use std::sync::{Arc, Mutex};

use tetradrill::commands::pipeline::{self, PipelineSetup, RunReport};
use tetradrill::commands::run::{calibrate_in_dock, cap_max_force};
use tetradrill::setup::{Setup, Tool};
use tetradrill::tasks::{Workspace, PROBE_FRACTION};
use tetradrill::watchdog::StopRequest;
use tetradrill_core::Vec3;
use tetradrill_device::{
    DeviceKind, DeviceSpec, HapticDevice, PathPoint, Scripted, SimConfig, SimDevice, SimModel,
    QUAT_IDENTITY,
};
use tetradrill_tests::force_log::ForceLog;
use tetradrill_tests::{scratch_dir, unstalled};

/// The device origin (the Omni's inkwell) at x = 0.8, in front of the cube's +x face; a metre
/// is a mesh unit.
const DOCK_X: f64 = 0.8;

/// The hand's x (scene and device: a metre a mesh unit, the device origin at [`DOCK_X`]) at
/// time `t` of the path, linear between `(time, x)` knots.
fn knots(points: &'static [(f64, f64)], t: f64) -> f64 {
    let mut prev = points[0];
    for &(tk, xk) in points {
        if t <= tk {
            let u = if tk > prev.0 {
                (t - prev.0) / (tk - prev.0)
            } else {
                1.0
            };
            return prev.1 + u * (xk - prev.1);
        }
        prev = (tk, xk);
    }
    prev.1
}

/// The simulated Omni (docked, calibrated in its inkwell) on the path through `points`
/// (scene x), the cube's force limit capped at the Omni's peak: the report and the writes, one
/// per servo tick from the start (the path begins after the model's lead-in,
/// [`SimModel::lead_in_s`]).
fn omni_run(points: &'static [(f64, f64)], ticks: u64, name: &str) -> (RunReport, Vec<f64>) {
    unstalled(|| omni_run_once(points, ticks, name), |r| r.0.servo_stalls)
}

/// One run of [`omni_run`].
fn omni_run_once(points: &'static [(f64, f64)], ticks: u64, name: &str) -> (RunReport, Vec<f64>) {
    let writes = Arc::new(Mutex::new(Vec::new()));
    let w = writes.clone();
    let open: pipeline::DeviceFactory = Box::new(move || {
        let path = Scripted(move |t: f64| PathPoint {
            position: [knots(points, t) - DOCK_X, 0.0, 0.0],
            rotation: QUAT_IDENTITY,
            buttons: 0,
        });
        let c = SimConfig::default().model(SimModel::Omni);
        let mut inner: Box<dyn HapticDevice> = Box::new(SimDevice::new(path, c));
        assert!(calibrate_in_dock(
            inner.as_mut(),
            &StopRequest::new(),
            1,
            || {}
        )?);
        Ok(Box::new(ForceLog { inner, writes: w }) as Box<dyn HapticDevice>)
    });
    let mut cube = Setup::new("builtin:cube12", Tool::sphere(0.1));
    assert_eq!(cap_max_force(&mut cube, &DeviceSpec::OMNI), Some(3.3));
    let mut setup = PipelineSetup::plain(DeviceKind::Omni, open, ticks);
    setup.workspace = Workspace {
        scale: 1.0,
        offset: Vec3::new(DOCK_X as f32, 0.0, 0.0),
    };
    let dir = scratch_dir("limits", name);
    let json = dir.join("run.json");
    let rep = pipeline::run(
        &cube,
        tetradrill::engine::load_mesh(&cube).expect("the cube"),
        setup,
        Some(&json),
    )
    .expect("a run");
    let j: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).expect("json")).expect("parse");
    assert_eq!(
        j["safety"]["trip_recoveries"].as_u64(),
        Some(u64::from(rep.safety.trip_recoveries))
    );
    // serde_json reads floats back to within an ulp (without its float_roundtrip feature).
    let json_derated = j["safety"]["derated_s"].as_f64().expect("safety.derated_s");
    assert!(
        (json_derated - rep.safety.derated_s).abs() <= 1e-9 * rep.safety.derated_s.abs().max(1.0),
        "JSON {json_derated}, report {}",
        rep.safety.derated_s
    );
    let log = writes.lock().expect("log").clone();
    (rep, log)
}

/// Ticks of the model's lead-in (the rest in the dock and the move to the path's start).
fn lead() -> usize {
    (SimModel::Omni.lead_in_s() * 1000.0).round() as usize
}

/// A firm press: the hand 5 cm past contact (x = 0.55; contact at x = 0.6) for 5 s. The
/// Omni's 200 N/m wall saturates at 3.3 N, 16.5 mm deep; the 300 N/m hand spring then drives
/// the stylus some 39 mm deep, 74 mJ past the limit: a trip. The hand then leaves contact at
/// 5.5 s, and comes back in gently (x = 0.58) 1.2 s later.
const FIRM: &[(f64, f64)] = &[
    (0.0, 0.8),
    (0.5, 0.55),
    (5.5, 0.55),
    (5.6, 0.8),
    (6.6, 0.8),
    (6.7, 0.58),
    (7.5, 0.58),
];

#[test]
fn a_press_past_the_omnis_saturation_trips_and_the_force_comes_back_after_contact() {
    let ticks = (lead() + 7500) as u64;
    let (rep, log) = omni_run(FIRM, ticks, "firm");
    assert!(rep.safety.passivity_trips >= 1, "{:?}", rep.safety);
    assert!(rep.safety.trip_recoveries >= 1, "{:?}", rep.safety);
    assert!(!rep.safety.trips_locked_out);
    let start = lead();
    // Off while the tool is held deep, from some time into the press until the hand leaves.
    let held = &log[start + 2000..start + 5500];
    assert!(held.iter().all(|&f| f == 0.0), "the motors stayed on");
    // The hand leaves contact at 5.5 s (out within 0.1 s): force again within 1.5 s.
    let back = log[start + 5500..]
        .iter()
        .position(|&f| f > 0.0)
        .expect("the force came back");
    assert!(back <= 1500, "force back {back} ms after leaving contact");
    // And the gentle touch after it is rendered, ramped back in: about 300 N/m x 2 cm against
    // the wall's 200 N/m settles 1.2 cm deep, 2.4 N, under the peak.
    let last = log[log.len() - 2];
    assert!((2.0..2.8).contains(&last), "last force {last}");
}

/// A steady hold at the Omni's peak: the hand 3.1 cm past contact, where the 300 N/m hand
/// spring balances 3.3 N with the stylus 2 cm deep, 3.5 mm past the limit depth (11 mJ past
/// it: no trip). Held for 8 s.
const HOLD: &[(f64, f64)] = &[(0.0, 0.8), (0.5, 0.569), (8.5, 0.569)];

#[test]
fn a_hold_at_the_omnis_peak_derates_toward_its_continuous_rating() {
    let ticks = (lead() + 8500) as u64;
    let (rep, log) = omni_run(HOLD, ticks, "hold");
    assert_eq!(rep.safety.passivity_trips, 0, "{:?}", rep.safety);
    assert!(rep.safety.derated_s > 1.0, "{:?}", rep.safety);
    let start = lead();
    // At the peak early in the hold, well below it at the end, never below the continuous
    // rating (0.88 N) by more than the force-sign probe's modulation (`PROBE_FRACTION` of
    // the peak, along the force).
    let early = log[start + 600..start + 1000]
        .iter()
        .copied()
        .fold(0.0, f64::max);
    assert!(early > 3.2, "early {early}");
    let late = &log[log.len() - 500..log.len() - 1];
    let late_max = late.iter().copied().fold(0.0, f64::max);
    assert!(late_max < 0.7 * 3.3, "late {late_max}");
    let probe = PROBE_FRACTION * 3.3;
    assert!(
        late.iter().all(|&f| f >= 0.88 - probe - 1e-3),
        "{:?}",
        &late[..5]
    );
}

#[test]
fn the_damping_is_checked_against_the_devices_range() {
    // The default scene damping, 0.5 N s per mesh unit, times the workspace's scale (the
    // device's workspace radius onto the block's half diagonal, sqrt(3) / 2): on the Touch
    // (0.075 m) 5.77 N s/m, past its 4 N s/m, capped with one warning; on the Omni (0.10 m)
    // 4.33 N s/m, within its 5 N s/m.
    let run = |model: &str| {
        let dir = scratch_dir("limits", &format!("damping-{model}"));
        let json = dir.join("out.json");
        let out = std::process::Command::new(tetradrill_tests::tetradrill_bin())
            .args(["run", "--device", "sim", "--sim-model", model])
            .args([
                "--headless",
                "--quiet",
                "--no-rt",
                "--duration",
                "0.5",
                "--json",
            ])
            .arg(&json)
            .output()
            .expect("run tetradrill");
        let err = String::from_utf8_lossy(&out.stderr).into_owned();
        assert!(out.status.success(), "{err}");
        let j: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&json).expect("json")).expect("parse");
        (j["safety"]["damping"].clone(), err)
    };
    let half_diagonal = 3f64.sqrt() / 2.0;
    let (d, err) = run("touch");
    let asked = 0.5 * half_diagonal / 0.075;
    assert!(
        (d["asked_n_s_per_m"].as_f64().unwrap() - asked).abs() < 1e-3,
        "{d}"
    );
    assert_eq!(d["used_n_s_per_m"].as_f64(), Some(4.0), "{d}");
    assert_eq!(d["max_n_s_per_m"].as_f64(), Some(4.0), "{d}");
    let warnings: Vec<_> = err
        .lines()
        .filter(|l| l.contains("maximum stable damping"))
        .collect();
    assert_eq!(warnings.len(), 1, "{err}");
    assert!(warnings[0].contains("using 4.00 N s/m"), "{}", warnings[0]);
    let (d, err) = run("omni");
    let asked = 0.5 * half_diagonal / 0.10;
    assert!(
        (d["used_n_s_per_m"].as_f64().unwrap() - asked).abs() < 1e-3,
        "{d}"
    );
    assert!(!err.contains("maximum stable damping"), "{err}");
}
