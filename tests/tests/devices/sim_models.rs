//! The simulated device as an Omni, a Falcon or a Touch (`--sim-model`): the motor-sign
//! self-test and a reversed joint, the safe start above the mesh and the arming outside the
//! solid, the Falcon's homing stroke, the stiffness cap. Through the binary; the oracles are the
//! device files' and specifications' numbers and the default block's geometry.

use std::process::Command;

use tetradrill_tests::{json_of, scratch_dir, tetradrill_bin};

fn run(args: &[&str]) -> std::process::Output {
    Command::new(tetradrill_bin())
        .args(args)
        .output()
        .expect("run tetradrill")
}

#[test]
fn the_motor_self_test_names_a_reversed_joint_and_exits_2() {
    let out = run(&[
        "devices",
        "--check",
        "--motors",
        "--device",
        "sim",
        "--sim-model",
        "omni",
        "--sim-fault",
        "motor-sign:2",
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_eq!(out.status.code(), Some(2), "{stdout}{err}");
    let first = err.lines().next().unwrap_or("");
    assert!(first.contains("joint 2: reversed"), "{first}");
    // The Omni's joint 2 has -4096 DAC counts per N m in its device file: the fix is +4096.
    assert!(
        first.contains("dac_per_newton_metre[2] = 4096.0"),
        "{first}"
    );
    assert!(
        !first.contains("joint 1") && !first.contains("joint 3"),
        "{first}"
    );
    assert_eq!(stdout.matches("sign ok").count(), 2, "{stdout}");
    for fault in ["motor-sign:1", "motor-sign:3"] {
        let out = run(&[
            "devices",
            "--check",
            "--motors",
            "--device",
            "sim",
            "--sim-model",
            "touch",
            "--sim-fault",
            fault,
        ]);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{err}");
        let joint = &fault[fault.len() - 1..];
        assert!(err.contains(&format!("joint {joint}: reversed")), "{err}");
    }
    // Healthy: three joints ok, exit 0.
    let out = run(&[
        "devices",
        "--check",
        "--motors",
        "--device",
        "sim",
        "--sim-model",
        "omni",
    ]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert_eq!(stdout.matches("sign ok").count(), 3, "{stdout}");
}

#[test]
fn a_run_with_a_reversed_joint_renders_no_force() {
    let _one = tetradrill_tests::one_realtime_run();
    let j = json_of(
        &[
            "run",
            "--device",
            "sim",
            "--sim-model",
            "omni",
            "--sim-fault",
            "motor-sign:2",
            "--headless",
            "--quiet",
            "--no-rt",
            "--duration",
            "4",
        ],
        "simmodel",
        "reversed",
    );
    assert_eq!(j["safety"]["reversed_joints"], serde_json::json!([2]));
    assert_eq!(j["force_max_n"].as_f64(), Some(0.0));
    assert_eq!(j["force"]["last_written_n"].as_f64(), Some(0.0));
    // The same run without the fault renders force.
    let j = json_of(
        &[
            "run",
            "--device",
            "sim",
            "--sim-model",
            "omni",
            "--headless",
            "--quiet",
            "--no-rt",
            "--duration",
            "4",
        ],
        "simmodel",
        "healthy",
    );
    assert!(
        j["safety"].get("reversed_joints").is_none(),
        "{}",
        j["safety"]
    );
    assert!(
        j["force_max_n"].as_f64().unwrap() > 0.5,
        "{}",
        j["force_max_n"]
    );
}

#[test]
fn the_docked_omni_starts_above_the_block_unarmed_and_renders_force_once_moved_in() {
    let _one = tetradrill_tests::one_realtime_run();
    let dir = scratch_dir("simmodel", "docked");
    let rec = dir.join("rec.csv");
    let j = json_of(
        &[
            "run",
            "--device",
            "sim",
            "--sim-model",
            "omni",
            "--headless",
            "--quiet",
            "--no-rt",
            "--duration",
            "4",
            "--record",
            rec.to_str().unwrap(),
        ],
        "simmodel",
        "docked-json",
    );
    // The default block spans [-0.5, 0.5] in each axis; the burr's radius is 0.1. At the
    // first tick (the stylus in its inkwell) the burr's centre is above the top face by more
    // than the radius: outside the solid, and the force is armed there.
    let text = std::fs::read_to_string(&rec).expect("the recording");
    let first = text.lines().nth(1).expect("a row");
    let z: f64 = first.split(',').nth(3).unwrap().parse().unwrap();
    assert!(z > 0.5 + 0.1, "docked tool at z = {z}");
    assert_eq!(j["safety"]["armed_at_tick"].as_u64(), Some(0));
    assert!(
        j["force_max_n"].as_f64().unwrap() > 0.5,
        "{}",
        j["force_max_n"]
    );
}

#[test]
fn the_falcon_homes_without_a_trip_and_renders_force_after() {
    let _one = tetradrill_tests::one_realtime_run();
    let j = json_of(
        &[
            "run",
            "--device",
            "sim",
            "--sim-model",
            "falcon",
            "--headless",
            "--quiet",
            "--no-rt",
            "--duration",
            "5",
        ],
        "simmodel",
        "falcon",
    );
    assert_eq!(j["safety"]["passivity_trips"].as_u64(), Some(0));
    // The stroke starts after a 1 s rest and passes the index half-way down (0.5 s later at
    // most): the force is armed after that, when the tool has left the block it crossed.
    let armed = j["safety"]["armed_at_tick"].as_u64().expect("armed");
    assert!(armed > 1000, "armed at {armed}");
    assert!(
        j["force_max_n"].as_f64().unwrap() > 0.5,
        "{}",
        j["force_max_n"]
    );
}

#[test]
fn a_stiffness_past_the_omnis_maximum_is_capped_with_one_warning() {
    let _one = tetradrill_tests::one_realtime_run();
    // The Omni's 0.10 m workspace radius onto the block's half diagonal (sqrt(3) / 2): 8.66
    // mesh units a metre; ten times its 700 N/m maximum is 7000 N/m, 808.3 N per mesh unit.
    let k = 7000.0 / (3f64.sqrt() / 2.0 / 0.10);
    let ks = format!("{k}");
    let dir = scratch_dir("simmodel", "stiff");
    let json = dir.join("out.json");
    let out = run(&[
        "run",
        "--device",
        "sim",
        "--sim-model",
        "omni",
        "--headless",
        "--quiet",
        "--no-rt",
        "--duration",
        "1",
        "--stiffness",
        &ks,
        "--json",
        json.to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    let warnings: Vec<_> = err
        .lines()
        .filter(|l| l.contains("maximum stable stiffness"))
        .collect();
    assert_eq!(warnings.len(), 1, "{err}");
    assert!(warnings[0].contains("using 700 N/m"), "{}", warnings[0]);
    let j: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let cap = &j["safety"]["stiffness_capped"];
    assert!(
        (cap["asked_n_per_m"].as_f64().unwrap() - 7000.0).abs() < 1.0,
        "{cap}"
    );
    assert_eq!(cap["used_n_per_m"].as_f64(), Some(700.0));
    assert!(
        (cap["scene_stiffness"].as_f64().unwrap() - k / 10.0).abs() < 0.01,
        "{cap}"
    );
    // The plain simulated device is not capped.
    let j = json_of(
        &[
            "run",
            "--headless",
            "--quiet",
            "--no-rt",
            "--duration",
            "1",
            "--stiffness",
            &ks,
        ],
        "simmodel",
        "stiff-plain",
    );
    assert!(
        j["safety"].get("stiffness_capped").is_none(),
        "{}",
        j["safety"]
    );
}

#[test]
fn models_and_faults_are_for_the_simulated_device_only() {
    tetradrill_tests::refused(
        &[
            "run",
            "--device",
            "omni",
            "--sim-model",
            "omni",
            "--headless",
        ],
        &["--sim-model"],
    );
    tetradrill_tests::refused(&["run", "--sim-model", "phantom"], &["phantom"]);
    tetradrill_tests::refused(&["run", "--sim-fault", "motor-sign:4"], &["motor-sign:4"]);
}
