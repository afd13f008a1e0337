//! The spinning burr's sideways pull (docs/DRILLING.md, "Sideways pull"): a burr lying on its
//! side on a region with a friction coefficient, the drill on, is pushed along `w x n` by
//! `mu` times the contact's normal force, the other way when it spins the other way, and not
//! at all without a friction.
//!
//! Oracle: the geometry of the pose, worked by hand. The tool's axis (burr to handle) is
//! turned from +z to +x (a quarter turn about +y); clockwise seen from the handle, the
//! angular velocity is -x; the paper's cube's top face has the outward normal +z, so the pull
//! is along `-x cross z = +y`. Nothing is removed (the region's threshold is above the force
//! clamp), so the plane stays and the normal force is the spring's.

use tetradrill_tests::{read_forces, run_ok, scratch_dir};

/// The forces of a press on the cube's top face with `regions` appended to the scenario and
/// `extra` flags.
fn press(name: &str, region: &str, extra: &[&str]) -> Vec<[f32; 3]> {
    let dir = scratch_dir("pull", name);
    let trace = dir.join("press.csv");
    // In the air, then the burr (radius 0.15) 0.03 into the top face (z = 0.5), held; the
    // axis along +x all along, the drill on.
    let (w, y) = (
        std::f32::consts::FRAC_1_SQRT_2,
        std::f32::consts::FRAC_1_SQRT_2,
    );
    std::fs::write(
        &trace,
        format!(
            "t,x,y,z,qw,qx,qy,qz,buttons\n0.0,0,0,0.8,{w},0,{y},0,1\n0.3,0,0,0.8,{w},0,{y},0,1\n\
             0.8,0,0,0.62,{w},0,{y},0,1\n2.0,0,0,0.62,{w},0,{y},0,1\n"
        ),
    )
    .expect("trace");
    let scenario = dir.join("press.toml");
    std::fs::write(
        &scenario,
        format!("mesh = \"builtin:cube12\"\ntool = \"sphere:0.15\"\n[regions.0]\nthreshold = 100.0\n{region}"),
    )
    .expect("scenario");
    let forces = dir.join("forces.csv");
    let mut args: Vec<std::ffi::OsString> = vec![
        "replay".into(),
        "--scenario".into(),
        scenario.into(),
        "--trace".into(),
        trace.into(),
        "--quiet".into(),
        "--forces".into(),
        forces.clone().into(),
    ];
    args.extend(extra.iter().map(Into::into));
    run_ok(args);
    read_forces(&forces)
}

#[test]
fn a_burr_on_its_side_is_pulled_along_spin_cross_normal() {
    let mu = 0.2;
    let plain = press("plain", "", &[]);
    let cw = press("cw", &format!("friction = {mu}\n"), &[]);
    let ccw = press("ccw", &format!("friction = {mu}\n"), &["--spin", "ccw"]);
    // Held from 0.8 s: the last second, the spring settled (the switch ramp is 16 ms).
    for t in 1000..2000 {
        let (p, a, b) = (plain[t], cw[t], ccw[t]);
        assert!(p[2] > 5.0 && p[0] == 0.0 && p[1] == 0.0, "tick {t}: {p:?}");
        for (f, sign) in [(a, 1.0), (b, -1.0)] {
            assert!(
                (f[1] - sign * mu * f[2]).abs() < 1e-3 * f[2],
                "tick {t}: {f:?}, not {sign} * {mu} * fz"
            );
            assert!(
                f[0].abs() < 1e-4 && (f[2] - p[2]).abs() < 1e-4,
                "tick {t}: {f:?}"
            );
        }
    }
    // In the air, nothing; without a friction the forces are the plain run's, bit for bit.
    assert!(cw[..300].iter().all(|f| *f == [0.0; 3]));
    let none = press("none", "friction = 0.0\n", &["--spin", "ccw"]);
    assert_eq!(none, plain);
}
