//! The PHANTOM Omni's start-up, calibration gate, stop and bus reset against the mock FireWire
//! node, with expected values taken from the public reverse-engineered drivers' formulas
//! (docs/DEVICES.md names them), not from the codec.

use tetradrill_device::omni::mock::{MockFirewire, RegOp};
use tetradrill_device::omni::packet::{OmniInput, MOTOR_ZERO};
use tetradrill_device::omni::{OmniConfig, OmniDevice};
use tetradrill_device::{DeviceError, ForceCommand, HapticDevice};

fn config() -> OmniConfig {
    let mut c = OmniConfig::default();
    c.safety.ramp_ticks = 1;
    c
}

/// An input packet: encoders, stylus docked or not, gimbal channels at mid range.
fn input(encoders: [u16; 3], docked: bool) -> OmniInput {
    OmniInput {
        encoders,
        gimbal: [1024; 3],
        gimbal_inv: [1023; 3],
        docked,
        ..Default::default()
    }
}

/// A pose away from every singularity, so a force gives a torque on every joint.
const POSE: [u16; 3] = [400, 65_136, 900];

#[test]
fn no_force_reaches_the_motors_before_the_inkwell_calibration() {
    let mut m = MockFirewire::omni();
    m.current = input(POSE, false);
    let mut dev = OmniDevice::start(m, config()).unwrap();
    for _ in 0..20 {
        dev.read().unwrap();
        dev.write(&ForceCommand::force([1.0, -2.0, 0.5])).unwrap();
    }
    assert!(!dev.is_calibrated());
    let sent = &dev.transport().sent;
    assert!(sent.len() >= 20);
    assert!(
        sent.iter()
            .all(|p| !p.motors_on && p.motors == [MOTOR_ZERO; 3]),
        "{sent:?}"
    );
    // The dock light flashes while the calibration is missing.
    assert!(sent.iter().all(|p| p.dock_flash));
    // Not docked: the calibration is refused and force stays off.
    assert_eq!(dev.calibrate(), Err(DeviceError::NotDocked));
}

#[test]
fn calibration_in_the_dock_lets_force_through() {
    let mut m = MockFirewire::omni();
    m.inputs.push_back(input(POSE, true));
    m.current = input(POSE, false);
    let mut dev = OmniDevice::start(m, config()).unwrap();
    let s = dev.read().unwrap();
    assert!(s.docked, "status bit 2 clear reads as docked");
    dev.calibrate().unwrap();
    assert!(dev.is_calibrated());
    for _ in 0..3 {
        dev.read().unwrap();
        dev.write(&ForceCommand::force([0.0, 1.0, 0.5])).unwrap();
    }
    let last = *dev.transport().sent.last().unwrap();
    assert!(last.motors_on && !last.dock_flash);
    assert_ne!(last.motors, [MOTOR_ZERO; 3]);
}

#[test]
fn signs_and_joint_3_follow_the_public_driver() {
    // The ROS driver (omnifirewire.cpp) after its dock calibration: q1 = k dx, q2 = -k dy, and
    // the elbow angle relative to the upper arm q3 = k dz - q2, k = 2 pi / 15000. The forearm's
    // angle from the vertical, which these kinematics take, is q2 + q3.
    let dock = [1000u16, 2000, 3000];
    let moved = [1000u16 + 750, 2000 - 1500, 3000 + 300];
    let mut m = MockFirewire::omni();
    m.inputs.push_back(input(dock, true));
    m.current = input(moved, false);
    let mut dev = OmniDevice::start(m, config()).unwrap();
    dev.read().unwrap();
    dev.calibrate().unwrap();
    let s = dev.read().unwrap();
    let k = std::f64::consts::TAU / 15000.0;
    let d = |i: usize| f64::from(moved[i]) - f64::from(dock[i]);
    let q1 = k * d(0);
    let q2 = -k * d(1);
    let q3 = k * d(2) - q2;
    let want = [q1, q2, q2 + q3];
    for (got, want) in s.joint_angles[..3].iter().zip(want) {
        assert!(
            (got - want).abs() < 1e-12,
            "{:?} vs {want:?}",
            s.joint_angles
        );
    }
    // Raising the upper arm alone (joint 2 up) leaves the forearm's direction as it was: the
    // tip moves up by l1 sin(q2) and back by l1 (1 - cos q2), with l1 = 133.35 mm.
    let l1 = 0.13335;
    let p = s.position;
    let r = l1 * q2.cos() + l1 * (q2 + q3).sin();
    assert!((p[0] + q1.sin() * r).abs() < 1e-12);
    assert!((p[1] - (l1 * q2.sin() - l1 * (q2 + q3).cos() + l1)).abs() < 1e-12);
}

#[test]
fn gimbal_angles_come_from_the_ratio_of_two_channels() {
    let mut m = MockFirewire::omni();
    m.current = OmniInput {
        gimbal: [300, 1200, 700],
        gimbal_inv: [900, 600, 700],
        ..Default::default()
    };
    let mut dev = OmniDevice::start(m, config()).unwrap();
    let s = dev.read().unwrap();
    // The ROS driver's expressions (omnifirewire.cpp), ratio r = a / (a + b).
    let r = [300.0 / 1200.0, 1200.0 / 1800.0, 0.5];
    let want = [
        -(5.48 * r[0] - 2.74) + 0.020 + 0.025367101673835286,
        -(5.28 * 1.9 * r[1] + 2.64) + 8.76231837158503,
        (4.76 * r[2] - 2.3) - 0.085,
    ];
    for (got, want) in s.joint_angles[3..].iter().zip(want) {
        assert!(
            (got - want).abs() < 1e-9,
            "{:?} vs {want:?}",
            s.joint_angles
        );
    }
}

#[test]
fn channels_are_the_ones_the_resource_manager_grants() {
    let mut m = MockFirewire::omni();
    // Channels 0..=4 and 6 are taken by other nodes.
    m.free_channels = !0b101_1111;
    let dev = OmniDevice::start(m, config()).unwrap();
    assert_eq!(dev.channels(), (5, 7));
    let log = &dev.transport().log;
    assert!(log.contains(&RegOp::Write(0x1001, 5)), "{log:?}");
    assert!(log.contains(&RegOp::Write(0x1000, 7)), "{log:?}");
    assert!(!log.contains(&RegOp::Write(0x1001, 0)));

    let mut m = MockFirewire::omni();
    m.free_channels = 1 << 9;
    let e = OmniDevice::start(m, config()).err();
    assert!(matches!(e, Some(DeviceError::Transport(_))), "{e:?}");
}

#[test]
fn stop_turns_the_motors_off_and_clears_bit_3_of_0x1087() {
    let mut m = MockFirewire::omni();
    m.current = input(POSE, true);
    // Other bits of the control register are kept.
    m.registers.push((0x1087, 0x41));
    let mut dev = OmniDevice::start(m, config()).unwrap();
    dev.read().unwrap();
    dev.calibrate().unwrap();
    for _ in 0..3 {
        dev.read().unwrap();
        dev.write(&ForceCommand::force([0.0, 1.0, 0.0])).unwrap();
    }
    assert!(dev.transport().sent.last().unwrap().motors_on);
    let before = dev.transport().log.len();
    dev.stop().unwrap();
    let t = dev.transport();
    assert_eq!(
        &t.log[before..],
        &[RegOp::Read(0x1087), RegOp::Write(0x1087, 0x41)]
    );
    let last = t.sent.last().unwrap();
    assert!(!last.motors_on && last.motors == [MOTOR_ZERO; 3]);
    assert_eq!(dev.read().err(), Some(DeviceError::Disconnected));
}

#[test]
fn a_bus_reset_redoes_the_start_up_and_holds_force_until_packets_continue() {
    let mut m = MockFirewire::omni();
    m.inputs.push_back(input(POSE, true));
    m.current = input(POSE, false);
    m.free_channels = !0b11; // channels 2 and 3
    m.bus_reset_after = Some(6);
    let mut dev = OmniDevice::start(m, config()).unwrap();
    dev.read().unwrap();
    dev.calibrate().unwrap();
    let mut on = Vec::new();
    for _ in 0..16 {
        dev.read().unwrap();
        let before = dev.transport().sent.len();
        dev.write(&ForceCommand::force([0.0, 1.0, 0.5])).unwrap();
        on.push(dev.transport().sent[before..].iter().any(|p| p.motors_on));
    }
    assert_eq!(dev.bus_resets(), 1);
    // Force before the reset, none on the tick that met it, force again after.
    assert!(on[..5].iter().all(|&o| o), "{on:?}");
    assert!(on.contains(&false), "{on:?}");
    assert!(on[12..].iter().all(|&o| o), "{on:?}");
    assert!(
        dev.is_calibrated(),
        "the counts continued: the calibration holds"
    );
    // The whole start-up twice, on the same granted channels.
    let log = &dev.transport().log;
    let count = |op: RegOp| log.iter().filter(|&&o| o == op).count();
    assert_eq!(count(RegOp::Write(0x1001, 2)), 4);
    assert_eq!(count(RegOp::Write(0x1000, 3)), 2);
    assert_eq!(count(RegOp::WriteQuadlet(0x2_0010, 0xf80f_0000)), 2);
    assert_eq!(count(RegOp::Write(0x1087, 0x08)), 2);
}

#[test]
fn counters_that_jump_across_a_bus_reset_drop_the_calibration() {
    let mut m = MockFirewire::omni();
    m.inputs.push_back(input(POSE, true));
    for _ in 0..5 {
        m.inputs.push_back(input(POSE, false));
    }
    // After the reset the counters read elsewhere: steps of more than 1/8 revolution (1875).
    m.current = input([5000, 5000, 5000], false);
    m.bus_reset_after = Some(6);
    let mut dev = OmniDevice::start(m, config()).unwrap();
    dev.read().unwrap();
    dev.calibrate().unwrap();
    for _ in 0..12 {
        dev.read().unwrap();
        dev.write(&ForceCommand::force([0.0, 1.0, 0.5])).unwrap();
    }
    assert_eq!(dev.bus_resets(), 1);
    assert!(!dev.is_calibrated());
    let tail = &dev.transport().sent[dev.transport().sent.len() - 4..];
    assert!(
        tail.iter().all(|p| !p.motors_on && p.dock_flash),
        "{tail:?}"
    );
}

#[test]
fn run_waits_for_the_dock_writing_no_force_then_calibrates() {
    use tetradrill::commands::run::calibrate_in_dock;
    use tetradrill::watchdog::StopRequest;

    let mut m = MockFirewire::omni();
    for _ in 0..4 {
        m.inputs.push_back(input(POSE, false));
    }
    m.current = input(POSE, true);
    let mut dev = OmniDevice::start(m, config()).unwrap();
    let mut asked = 0;
    let done = calibrate_in_dock(&mut dev, &StopRequest::new(), 100, || asked += 1);
    assert_eq!(done, Ok(true));
    assert_eq!(asked, 1, "one line asks for the dock");
    assert!(dev.is_calibrated());
    assert!(dev.transport().sent.iter().all(|p| !p.motors_on));

    // Never docked: bounded, then NotDocked.
    let mut m = MockFirewire::omni();
    m.current = input(POSE, false);
    let mut dev = OmniDevice::start(m, config()).unwrap();
    let r = calibrate_in_dock(&mut dev, &StopRequest::new(), 5, || {});
    assert_eq!(r, Err(DeviceError::NotDocked));
    assert!(!dev.is_calibrated());

    // A stop request (Ctrl-C) ends the wait with the device still force-free.
    let stop = StopRequest::new();
    stop.request();
    let r = calibrate_in_dock(&mut dev, &stop, 1_000_000, || {});
    assert_eq!(r, Ok(false));
    assert!(!dev.is_calibrated());
}
