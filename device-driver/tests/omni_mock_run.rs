//! PHANTOM Omni session against the mock FireWire node.

use tetradrill_device::omni::kinematics;
use tetradrill_device::omni::mock::{MockFirewire, RegOp};
use tetradrill_device::omni::packet::{OmniInput, MOTOR_ZERO};
use tetradrill_device::omni::*;
use tetradrill_device::{Cut, DeviceError, ForceCommand, HapticDevice};

fn config() -> OmniConfig {
    let mut c = OmniConfig::default();
    c.safety.ramp_ticks = 1;
    c
}

/// Every encoder counting up, every motor pushing its joint forward: the plain convention the
/// expected values below are computed in.
fn plain_config() -> OmniConfig {
    let mut c = config();
    c.encoder_sign = [1.0; 3];
    c.dac_per_newton_metre = [4096.0; 3];
    c
}

#[test]
fn start_up_follows_published_register_sequence() {
    let dev = OmniDevice::start(MockFirewire::omni(), config()).unwrap();
    assert_eq!(dev.serial(), 0x0001_e240);
    let log = &dev.transport().log;
    assert_eq!(
        log.as_slice(),
        &[
            RegOp::ReadQuadlet(0x1006_000c),
            RegOp::ReadQuadlet(0x1006_0010),
            RegOp::Write(0x1001, 0),
            RegOp::Read(0x1001),
            RegOp::Write(0x1001, 0x40),
            RegOp::Read(0x1001),
            RegOp::Write(0x1001, 0),
            RegOp::Read(0x1083),
            RegOp::Read(0x1082),
            RegOp::Write(0x1000, 1),
            RegOp::Read(0x1083),
            RegOp::Read(0x1082),
            RegOp::WriteQuadlet(0x2_0010, 0xf80f_0000),
            RegOp::Read(0x1087),
            RegOp::Write(0x1087, 0x08),
        ]
    );
}

#[test]
fn wrong_oui_and_bad_status_are_refused() {
    let mut m = MockFirewire::omni();
    m.vendor = 0x0012_3400;
    assert_eq!(
        OmniDevice::start(m, config()).err(),
        Some(DeviceError::WrongDevice { found: 0x0012_3400 })
    );
    let mut m = MockFirewire::omni();
    m.registers.clear();
    assert_eq!(
        OmniDevice::start(m, config()).err(),
        Some(DeviceError::RegisterCheck {
            address: 0x1083,
            expected: 0xC0,
            found: 0
        })
    );
}

#[test]
fn encoders_give_position_with_wraparound_and_force_maps_through_jt() {
    let mut m = MockFirewire::omni();
    // Calibrated in the dock at zero counts, the dock pose being all zero.
    m.inputs.push_back(OmniInput {
        docked: true,
        ..Default::default()
    });
    // 15000 counts per revolution: 1250 counts = 30 degrees. Joint 1 crosses the 16-bit wrap.
    let seq = [
        [0u16, 65_000, 1250],
        [0, 65_500, 1250],
        [0, 200, 1250], // +236 counts across the wrap
    ];
    for e in seq {
        m.inputs.push_back(OmniInput {
            encoders: e,
            gimbal: [1024; 3],
            docked: false,
            ..Default::default()
        });
    }
    m.current = OmniInput {
        encoders: seq[2],
        gimbal: [1024; 3],
        ..Default::default()
    };
    m.short_every = Some(5);
    let mut dev = OmniDevice::start(m, plain_config()).unwrap();
    dev.read().unwrap();
    dev.calibrate().unwrap();
    dev.write(&ForceCommand::ZERO).unwrap();
    let mut s = dev.read().unwrap();
    dev.write(&ForceCommand::ZERO).unwrap();
    for _ in 0..2 {
        s = dev.read().unwrap();
        dev.write(&ForceCommand::force([0.0, 1.0, 0.0])).unwrap();
    }
    let k = core::f64::consts::TAU / 15000.0;
    let t = [0.0, (65_000i32 - 65_536 + 500 + 236) as f64 * k, 1250.0 * k];
    assert!(
        (s.joint_angles[1] - t[1]).abs() < 1e-12,
        "{:?}",
        s.joint_angles
    );
    assert!((s.joint_angles[2] - 30f64.to_radians()).abs() < 1e-12);
    let p = kinematics::forward(t);
    for (a, b) in s.position.iter().zip(p) {
        assert!((a - b).abs() < 1e-12);
    }
    // Motor values: 0x07FF + 4096 * (J^T F), with J^T F computed here from the documented
    // formulas (dy/dt2 = l1 cos t2, dy/dt3 = l2 sin t3, dy/dt1 = 0).
    let out = dev.transport().sent.last().copied().unwrap();
    assert!(out.motors_on);
    let want = [
        MOTOR_ZERO,
        (f64::from(MOTOR_ZERO) + (4096.0 * kinematics::L1 * t[1].cos())).round() as u16,
        (f64::from(MOTOR_ZERO) + (4096.0 * kinematics::L2 * t[2].sin())).round() as u16,
    ];
    assert_eq!(out.motors, want);
}

#[test]
fn inkwell_calibration_buttons_and_disconnect() {
    let mut m = MockFirewire::omni();
    m.current = OmniInput {
        encoders: [100, 200, 300],
        gimbal: [1024; 3],
        button1: true,
        button2: false,
        docked: false,
        ..Default::default()
    };
    m.disconnect_after = Some(6);
    let mut dev = OmniDevice::start(m, config()).unwrap();
    let s = dev.read().unwrap();
    assert_eq!(s.buttons, 0b01);
    assert_eq!(dev.calibrate(), Err(DeviceError::NotDocked));
    // NaN refused, motors off.
    assert_eq!(
        dev.write(&ForceCommand::force([f64::NAN, 0.0, 0.0])),
        Err(DeviceError::NonFiniteCommand)
    );
    let last = dev.transport().sent.last().copied().unwrap();
    assert!(!last.motors_on);
    assert_eq!(last.motors, [MOTOR_ZERO; 3]);
    let mut errors = 0;
    for _ in 0..10 {
        match dev.read() {
            Ok(_) => {
                let _ = dev.write(&ForceCommand::force([1.0, 0.0, 0.0]));
            }
            Err(e) => {
                assert_eq!(e, DeviceError::Disconnected);
                errors += 1;
            }
        }
    }
    assert!(errors > 0);
    assert!(!dev.safety().is_enabled());
}

#[test]
fn docked_calibration_sets_dock_pose() {
    let mut m = MockFirewire::omni();
    m.current = OmniInput {
        encoders: [500, 65_036, 7],
        gimbal: [1024; 3],
        docked: true,
        ..Default::default()
    };
    let mut c = config();
    c.dock_angles = [0.0, 0.1, -0.2];
    let mut dev = OmniDevice::start(m, c).unwrap();
    let s = dev.read().unwrap();
    assert!(s.docked);
    dev.calibrate().unwrap();
    dev.write(&ForceCommand::ZERO).unwrap();
    let s = dev.read().unwrap();
    for (a, b) in s.joint_angles[..3].iter().zip([0.0, 0.1, -0.2]) {
        assert!((a - b).abs() < 1e-12);
    }
}

#[test]
fn a_cut_from_another_thread_sends_motors_off_and_holds_until_rearmed() {
    let mut m = MockFirewire::omni();
    m.current.docked = true;
    let second_path = std::sync::Arc::clone(&m.out_log);
    let mut dev = OmniDevice::start(m, config()).unwrap();
    dev.read().unwrap();
    dev.calibrate().unwrap();
    for _ in 0..5 {
        dev.read().unwrap();
        dev.write(&ForceCommand::force([0.0, 1.0, 0.0])).unwrap();
    }
    assert!(dev.transport().sent.last().unwrap().motors_on);
    let cutoff = dev.cutoff().expect("the mock has a second path");
    std::thread::scope(|s| {
        s.spawn(|| assert_eq!(cutoff.cut(), Ok(Cut::Done)));
    });
    let sent = second_path.lock().unwrap().clone();
    assert_eq!(sent.len(), 1);
    assert!(!sent[0].motors_on);
    assert_eq!(sent[0].motors, [MOTOR_ZERO; 3]);
    // Latched: the servo's packets are motors off too.
    let before = dev.transport().sent.len();
    for _ in 0..3 {
        dev.read().unwrap();
        dev.write(&ForceCommand::force([0.0, 1.0, 0.0])).unwrap();
    }
    let latched = &dev.transport().sent[before..];
    assert!(!latched.is_empty());
    assert!(latched
        .iter()
        .all(|p| !p.motors_on && p.motors == [MOTOR_ZERO; 3]));
    cutoff.rearm();
    dev.read().unwrap();
    dev.write(&ForceCommand::force([0.0, 1.0, 0.0])).unwrap();
    assert!(dev.transport().sent.last().unwrap().motors_on);
}
