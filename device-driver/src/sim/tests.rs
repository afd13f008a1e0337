//! The simulated device's tests.

use super::*;

fn line(t: f64) -> PathPoint {
    PathPoint {
        position: [0.05 * t, 0.0, 0.0],
        rotation: QUAT_IDENTITY,
        buttons: 1,
    }
}

fn no_ramp() -> SimConfig {
    let mut c = SimConfig::default();
    c.safety.ramp_ticks = 1;
    c
}

/// A wall at x = 0.02 rendered by a penalty spring: the servo the sim exists to drive.
fn run(ticks: usize, config: SimConfig) -> Vec<DeviceState> {
    let mut dev = SimDevice::new(Scripted(line), config);
    let mut out = Vec::new();
    for _ in 0..ticks {
        let s = dev.read().unwrap();
        let depth = s.position[0] - 0.02;
        let f = if depth > 0.0 {
            [-2000.0 * depth, 0.0, 0.0]
        } else {
            [0.0; 3]
        };
        dev.write(&ForceCommand::force(f)).unwrap();
        out.push(s);
    }
    out
}

#[test]
fn deterministic_bit_for_bit() {
    let a = run(3000, no_ramp());
    let b = run(3000, no_ramp());
    assert_eq!(a.len(), b.len());
    for (x, y) in a.iter().zip(&b) {
        assert_eq!(x.timestamp_s.to_bits(), y.timestamp_s.to_bits());
        assert_eq!(x.position.map(f64::to_bits), y.position.map(f64::to_bits));
    }
    // The clock is the tick count times the period, never wall time.
    assert_eq!(a[1000].timestamp_s, 1000.0 * 1e-3);
    assert_eq!(a[1000].tick, 1000);
}

#[test]
fn stylus_follows_hand_without_force() {
    let mut dev = SimDevice::new(Scripted(line), SimConfig::default());
    let mut last = DeviceState::ZERO;
    for _ in 0..2000 {
        last = dev.read().unwrap();
        dev.write(&ForceCommand::ZERO).unwrap();
    }
    // Hand at 0.1 m after 2 s; a steadily moving hand leads the stylus by about
    // c * v / k = 4 * 0.05 / 300 m.
    assert!(
        (last.position[0] - (0.1 - 4.0 * 0.05 / 300.0)).abs() < 1e-3,
        "{:?}",
        last.position
    );
    assert_eq!(last.buttons, 1);
}

#[test]
fn force_pushes_back_the_stylus() {
    // The hand stops at x = 0.03 m, behind a wall at 0.02 m (2000 N/m). The stylus settles
    // where the hand spring (300 N/m) balances the wall: 300 (0.03 - x) = 2000 (x - 0.02).
    let stop = |t: f64| PathPoint {
        position: [(0.05 * t).min(0.03), 0.0, 0.0],
        rotation: QUAT_IDENTITY,
        buttons: 0,
    };
    let mut dev = SimDevice::new(Scripted(stop), no_ramp());
    let mut s = DeviceState::ZERO;
    for _ in 0..4000 {
        s = dev.read().unwrap();
        let depth = s.position[0] - 0.02;
        let f = if depth > 0.0 {
            [-2000.0 * depth, 0.0, 0.0]
        } else {
            [0.0; 3]
        };
        dev.write(&ForceCommand::force(f)).unwrap();
    }
    let want = (300.0 * 0.03 + 2000.0 * 0.02) / 2300.0;
    assert!(
        (s.position[0] - want).abs() < 1e-5,
        "stylus at {} want {want}",
        s.position[0]
    );
    // Without the wall it reaches the hand.
    let mut dev = SimDevice::new(Scripted(stop), no_ramp());
    for _ in 0..4000 {
        s = dev.read().unwrap();
        dev.write(&ForceCommand::ZERO).unwrap();
    }
    assert!((s.position[0] - 0.03).abs() < 1e-5);
}

#[test]
fn a_reversed_force_pushes_the_stylus_the_other_way() {
    // A 2 N force along +x on a stylus held by the hand at the origin settles where the
    // hand spring (300 N/m) balances it: +2/300 m, and -2/300 m with the fault.
    for (fault, sign) in [(SimFault::None, 1.0), (SimFault::ReversedForce, -1.0)] {
        let c = SimConfig { fault, ..no_ramp() };
        let mut dev = SimDevice::new(Still([0.0; 3]), c);
        let mut s = DeviceState::ZERO;
        for _ in 0..3000 {
            s = dev.read().unwrap();
            dev.write(&ForceCommand::force([2.0, 0.0, 0.0])).unwrap();
        }
        let want = sign * 2.0 / 300.0;
        assert!(
            (s.position[0] - want).abs() < 1e-6,
            "{fault:?}: {:?}",
            s.position
        );
    }
}

#[test]
fn a_mirrored_x_reports_minus_x_while_the_stylus_moves_normally() {
    let c = SimConfig {
        fault: SimFault::MirroredX,
        ..SimConfig::default()
    };
    let mut dev = SimDevice::new(Scripted(line), c);
    let mut plain = SimDevice::new(Scripted(line), SimConfig::default());
    for _ in 0..500 {
        let s = dev.read().unwrap();
        let p = plain.read().unwrap();
        assert_eq!(dev.true_position(), p.position);
        assert_eq!(s.position, [-p.position[0], p.position[1], p.position[2]]);
        dev.write(&ForceCommand::ZERO).unwrap();
        plain.write(&ForceCommand::ZERO).unwrap();
    }
    assert!(plain.true_position()[0] > 0.02);
}

#[test]
fn one_substep_is_the_lockstep_integration_and_more_converge() {
    // The hand steps 1 cm away at t = 0: the undamped part of the stylus's response
    // against the exact solution of m x'' = k (1 cm - x) - c x' (underdamped, f64).
    let step = |_t: f64| PathPoint {
        position: [0.01, 0.0, 0.0],
        rotation: QUAT_IDENTITY,
        buttons: 0,
    };
    let run = |substeps: u32| {
        let c = SimConfig {
            substeps,
            hand_damping_n_s_per_m: 2.0,
            ..no_ramp()
        };
        let mut dev = SimDevice::new(Scripted(step), c);
        dev.position = [0.0; 3];
        dev.hand_prev = [0.01, 0.0, 0.0];
        let mut out = Vec::new();
        for _ in 0..200 {
            out.push(dev.read().unwrap().position[0]);
            dev.write(&ForceCommand::ZERO).unwrap();
        }
        out
    };
    let (m, k, c) = (0.1f64, 300.0f64, 2.0f64);
    let wd = (k / m - (c / (2.0 * m)).powi(2)).sqrt();
    let zeta_w = c / (2.0 * m);
    let exact = |t: f64| {
        0.01 * (1.0 - (-zeta_w * t).exp() * ((wd * t).cos() + zeta_w / wd * (wd * t).sin()))
    };
    let err = |xs: &[f64]| {
        xs.iter()
            .enumerate()
            .map(|(i, x)| (x - exact(i as f64 * 1e-3)).abs())
            .fold(0.0, f64::max)
    };
    let (one, many) = (run(1), run(20));
    assert!(
        err(&many) < 0.2 * err(&one),
        "{} vs {}",
        err(&many),
        err(&one)
    );
    assert!(err(&many) < 2e-4, "{}", err(&many));
}

#[test]
fn a_cut_zeroes_the_motors_at_once_and_holds_them_until_rearmed() {
    let mut c = SimConfig::default();
    c.safety.ramp_ticks = 10;
    let mut dev = SimDevice::new(Still([0.0; 3]), c);
    for _ in 0..20 {
        dev.read().unwrap();
        dev.write(&ForceCommand::force([2.0, 0.0, 0.0])).unwrap();
    }
    assert_eq!(dev.applied_force(), [2.0, 0.0, 0.0]);
    // Another thread cuts through the shared motors: zero at once, without the device.
    let cut = dev.cutoff().expect("the simulated device has a cutoff");
    let seen = std::thread::scope(|s| {
        s.spawn(|| {
            cut.cut().unwrap();
            dev.motors().output()
        })
        .join()
        .unwrap()
    });
    assert_eq!(seen, ForceCommand::OFF);
    assert_eq!(dev.applied_force(), [0.0; 3]);
    // While the latch is set, the servo's writes render zero with the motors off.
    for _ in 0..5 {
        dev.read().unwrap();
        dev.write(&ForceCommand::force([2.0, 0.0, 0.0])).unwrap();
        assert_eq!(dev.motors().output(), ForceCommand::OFF);
    }
    // Rearmed: the next enabled write ramps from zero (1/10 of the force), not a jump.
    cut.rearm();
    dev.read().unwrap();
    dev.write(&ForceCommand::force([2.0, 0.0, 0.0])).unwrap();
    assert!(
        (dev.applied_force()[0] - 0.2).abs() < 1e-12,
        "{:?}",
        dev.applied_force()
    );
}

#[test]
fn a_reversed_motor_reverses_only_its_joints_share() {
    // (1, 1, 1) N on a stylus held at the origin by the 300 N/m hand settles at 1/300 m
    // along each axis; with joint 2 (the y axis) reversed, -1/300 m along y only.
    for (joint, want) in [
        (0u8, [1.0, 1.0, 1.0]),
        (2, [1.0, -1.0, 1.0]),
        (3, [1.0, 1.0, -1.0]),
    ] {
        let fault = if joint == 0 {
            SimFault::None
        } else {
            SimFault::MotorSign(joint)
        };
        let mut dev = SimDevice::new(Still([0.0; 3]), SimConfig { fault, ..no_ramp() });
        let mut s = DeviceState::ZERO;
        for _ in 0..3000 {
            s = dev.read().unwrap();
            dev.write(&ForceCommand::force([1.0, 1.0, 1.0])).unwrap();
        }
        for (p, w) in s.position.iter().zip(want) {
            assert!(
                (p - w / 300.0).abs() < 1e-7,
                "joint {joint}: {:?}",
                s.position
            );
        }
    }
    assert_eq!(
        SimFault::parse("motor-sign:2"),
        Some(SimFault::MotorSign(2))
    );
    assert_eq!(SimFault::MotorSign(2).name(), "motor-sign:2");
    assert_eq!(SimFault::parse("motor-sign:4"), None);
    assert_eq!(SimFault::parse("motor-sign:0"), None);
}

/// A hand path that sits at (0, 0.02, 0) m.
fn away(_t: f64) -> PathPoint {
    PathPoint {
        position: [0.0, 0.02, 0.0],
        rotation: QUAT_IDENTITY,
        buttons: 0,
    }
}

#[test]
fn the_omni_model_starts_docked_and_renders_nothing_until_calibrated_there() {
    let c = SimConfig::default().model(SimModel::Omni);
    assert_eq!(c.spec, DeviceSpec::OMNI);
    assert_eq!(c.safety.max_force_n, 3.3);
    let mut dev = SimDevice::new(Scripted(away), c);
    let s = dev.read().unwrap();
    assert!(s.docked);
    assert_eq!(s.position, [0.0; 3]);
    assert!(!dev.force_ready());
    // Not calibrated: a written force is not rendered.
    dev.write(&ForceCommand::force([1.0, 0.0, 0.0])).unwrap();
    assert_eq!(dev.motors().output(), ForceCommand::OFF);
    dev.calibrate().unwrap();
    assert!(dev.force_ready());
    dev.write(&ForceCommand::force([1.0, 0.0, 0.0])).unwrap();
    assert!(dev.applied_force()[0] > 0.0);
    // Past the lead-in (1 s rest, 1 s move) the hand is at the path's start; the stylus
    // is out of the dock, where calibrating is refused.
    let mut s = DeviceState::ZERO;
    for _ in 0..3000 {
        s = dev.read().unwrap();
        dev.write(&ForceCommand::ZERO).unwrap();
    }
    assert!((s.position[1] - 0.02).abs() < 1e-4, "{:?}", s.position);
    assert!(!s.docked);
    assert_eq!(dev.calibrate(), Err(DeviceError::NotDocked));
    // Halfway through the move (t = 1.5 s) the hand is halfway (smoothstep(1/2) = 1/2).
    let mut dev = SimDevice::new(Scripted(away), SimConfig::default().model(SimModel::Touch));
    assert_eq!(dev.spec(), DeviceSpec::TOUCH);
    assert!((dev.hand_at(1.5).position[1] - 0.01).abs() < 1e-15);
    assert_eq!(dev.hand_at(0.9).position, [0.0; 3]);
    assert_eq!(dev.hand_at(2.0 + 5.0).position, [0.0, 0.02, 0.0]);
}

#[test]
fn the_falcon_model_homes_on_its_stroke() {
    let c = SimConfig::default().model(SimModel::Falcon);
    assert_eq!(c.spec, DeviceSpec::FALCON);
    let mut dev = SimDevice::new(Scripted(away), c);
    // Before homing: the reported position is off by the unhomed offset, no force.
    let s = dev.read().unwrap();
    assert_eq!(s.position, UNHOMED_OFFSET_M);
    assert!(!s.docked);
    assert!(!dev.force_ready());
    // The stroke's deepest point is 0.5 s into it (t = 1.5 s), 3.5 cm down.
    assert_eq!(dev.hand_at(1.5).position, [0.0, 0.0, -0.035]);
    let mut homed_at = None;
    let mut deepest: f64 = 0.0;
    for _ in 0..4000 {
        let s = dev.read().unwrap();
        deepest = deepest.min(dev.true_position()[2]);
        if dev.force_ready() && homed_at.is_none() {
            homed_at = Some(s.tick);
            // Homed: the reported position is the true one, and the reset is counted.
            assert_eq!(s.position, dev.true_position());
            assert_eq!(dev.position_resets(), 1);
            assert!(dev.true_position()[2] <= -HOMING_INDEX_M);
        }
        if homed_at.is_none() {
            dev.write(&ForceCommand::force([0.0, 0.0, 1.0])).unwrap();
            assert_eq!(dev.motors().output(), ForceCommand::OFF);
            assert_eq!(dev.position_resets(), 0);
        } else {
            dev.write(&ForceCommand::ZERO).unwrap();
        }
    }
    let at = homed_at.expect("homed on the stroke");
    assert!(at > 1000 && at < 1500, "homed at tick {at}");
    assert!(deepest < -0.03, "{deepest}");
    assert_eq!(dev.position_resets(), 1);
    // After the stroke (1 + 1 s) and the move (1 s), the path's start.
    assert!((dev.true_position()[1] - 0.02).abs() < 1e-4);
}

#[test]
fn joint_forces_are_the_axes() {
    let dev = SimDevice::new(Still([0.0; 3]), SimConfig::default());
    assert_eq!(dev.joint_force(1, 0.3), Some([0.0, 0.3, 0.0]));
    assert_eq!(dev.joint_force(3, 0.3), None);
}

#[test]
fn disconnect_is_an_error_and_zeroes_force() {
    let mut c = no_ramp();
    c.disconnect_at_tick = Some(10);
    let mut dev = SimDevice::new(Still([0.0; 3]), c);
    for _ in 0..10 {
        dev.read().unwrap();
        dev.write(&ForceCommand::force([1.0, 0.0, 0.0])).unwrap();
    }
    assert_eq!(dev.read(), Err(DeviceError::Disconnected));
    assert_eq!(
        dev.write(&ForceCommand::force([1.0, 0.0, 0.0])),
        Err(DeviceError::Disconnected)
    );
    assert_eq!(dev.applied_force(), [0.0; 3]);
}

#[test]
fn plays_back_a_trace() {
    let text = "t,x,y,z,qw,qx,qy,qz,buttons\n0,0,0,0,1,0,0,0,0\n1,0,0.01,0,1,0,0,0,1\n";
    let trace = Trace::parse(text, "p").unwrap();
    let mut dev = SimDevice::new(trace, SimConfig::default());
    let mut s = DeviceState::ZERO;
    for _ in 0..=1500 {
        s = dev.read().unwrap();
        dev.write(&ForceCommand::ZERO).unwrap();
    }
    assert!((s.position[1] - 0.01).abs() < 1e-4);
    assert_eq!(s.buttons, 1);
}
