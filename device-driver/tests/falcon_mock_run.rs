//! A whole Falcon session against the mock transport: a failed firmware upload, a good one,
//! running with short reads and garbage, the safety rules, a disconnect, and the cutoff (a
//! zero frame from another thread, the latch, a cut racing with the servo's frame).

use std::sync::{Arc, OnceLock};

use tetradrill_device::cutoff::OutPath;
use tetradrill_device::falcon::frame::{FalconReport, LED_GREEN};
use tetradrill_device::falcon::ftdi::*;
use tetradrill_device::falcon::kinematics;
use tetradrill_device::falcon::mock::{MockOp, MockTransport};
use tetradrill_device::falcon::{FalconConfig, FalconDevice, Transport};
use tetradrill_device::{Cut, DeviceError, ForceCommand, HapticDevice, MotorCutoff};

fn firmware() -> Vec<u8> {
    // Not a real firmware: 300 deterministic bytes, so the upload takes 5 blocks.
    (0..300u32)
        .map(|i| (i.wrapping_mul(37) ^ 0x5A) as u8)
        .collect()
}

/// Encoder counts that put the tool at `p` (mechanism frame), from the published scale.
fn counts_for(p: [f64; 3]) -> [i16; 3] {
    let t = kinematics::inverse(p).unwrap();
    t.map(|a| {
        let deg = a.to_degrees() - kinematics::THETA_OFFSET_DEG;
        (deg * 4.0 * 320.0 * 0.110 / (360.0 * 0.01425)).round() as i16
    })
}

/// No ramps: the motor commands are checked against full force (the homing gate's ramp has
/// its own tests in `falcon_homing.rs`).
fn config() -> FalconConfig {
    let mut c = FalconConfig::default();
    c.safety.ramp_ticks = 1;
    c.homing_ramp_s = 0.0;
    c
}

#[test]
fn failed_upload_then_good_upload_follows_documented_sequence() {
    let mut mock = MockTransport::new();
    mock.corrupt_echo_at = Some(200);
    let mut dev = FalconDevice::new(mock, config());
    // The corrupted byte is in the fourth 62-byte block (bytes 186..248).
    assert_eq!(
        dev.load_firmware(&firmware()),
        Err(DeviceError::FirmwareMismatch { offset: 186 })
    );
    assert_eq!(dev.load_firmware(&[]), Err(DeviceError::FirmwareFile));
    // Second try succeeds (the fault was one-shot).
    dev.load_firmware(&firmware()).unwrap();
    let log = &dev.transport().log;
    let controls: Vec<(u8, u16)> = log
        .iter()
        .filter_map(|op| match op {
            MockOp::Control { request, value } => Some((*request, *value)),
            MockOp::Write(_) | MockOp::Reopen => None,
        })
        .collect();
    let loader = [
        (SIO_RESET, PURGE_RX),
        (SIO_RESET, PURGE_TX),
        (SIO_SET_LATENCY_TIMER, 16),
        (SIO_SET_BAUD_RATE, 0x4138),
        (SIO_SET_DATA, 8),
        (SIO_SET_FLOW_CTRL, 0),
        (SIO_MODEM_CTRL, RTS_LOW),
        (SIO_MODEM_CTRL, DTR_LOW),
        (SIO_MODEM_CTRL, DTR_HIGH),
        (SIO_MODEM_CTRL, DTR_LOW),
        (SIO_SET_BAUD_RATE, 0x0015),
    ];
    // First attempt: loader sequence only; second: loader then normal mode.
    assert_eq!(&controls[..11], &loader);
    assert_eq!(&controls[11..22], &loader);
    assert_eq!(
        &controls[22..],
        &[
            (SIO_SET_LATENCY_TIMER, 1),
            (SIO_SET_BAUD_RATE, 0x0002),
            (SIO_RESET, PURGE_RX),
            (SIO_RESET, PURGE_TX)
        ]
    );
    // The second upload wrote the whole file in 62-byte blocks after the two handshakes.
    let writes: Vec<&Vec<u8>> = log
        .iter()
        .filter_map(|op| {
            if let MockOp::Write(w) = op {
                Some(w)
            } else {
                None
            }
        })
        .collect();
    let second: Vec<&Vec<u8>> = writes.iter().rev().take(7).rev().copied().collect();
    assert_eq!(second[0], &vec![0x0a, 0x43, 0x0d]);
    assert_eq!(second[1], &vec![0x41]);
    assert!(second[2..6].iter().all(|w| w.len() == 62));
    assert_eq!(second[6].len(), 300 - 4 * 62);
    let joined: Vec<u8> = second[2..].iter().flat_map(|w| w.iter().copied()).collect();
    assert_eq!(joined, firmware());
}

#[test]
fn running_session_reads_position_maps_force_and_survives_short_reads() {
    let mut mock = MockTransport::new();
    mock.short_reads = true;
    mock.garbage_before_report = 3;
    let target = [0.01, -0.005, 0.115];
    mock.report = FalconReport {
        encoders: counts_for(target),
        buttons: 0b0101,
        homed: 0b111,
    };
    let mut dev = FalconDevice::new(mock, config());
    dev.load_firmware(&firmware()).unwrap();
    let mut last = None;
    for _ in 0..10 {
        let s = dev.read().unwrap();
        dev.write(&ForceCommand::force([0.0, 0.0, 2.0])).unwrap();
        last = Some(s);
    }
    let s = last.unwrap();
    let origin = kinematics::WORKSPACE_CENTRE;
    for k in 0..3 {
        // One encoder count is about 0.012 degrees: well under 0.1 mm at the tip.
        assert!(
            (s.position[k] + origin[k] - target[k]).abs() < 1e-4,
            "{:?}",
            s.position
        );
    }
    assert_eq!(s.buttons, 0b0101);
    assert_eq!(s.tick, 10);
    assert_eq!(dev.homed(), 0b111);
    // Homed: green LED in the frames sent afterwards; the homing bit stays in every frame.
    let cmds = &dev.transport().commands;
    let last_cmd = cmds.last().unwrap();
    assert_eq!(last_cmd.leds, LED_GREEN);
    assert!(cmds.iter().all(|c| c.homing));
    // The motor commands are -10000 x J^T F at the reported position (independent recompute
    // from the Jacobian, not the torque solver).
    let mech = [
        s.position[0] + origin[0],
        s.position[1] + origin[1],
        s.position[2] + origin[2],
    ];
    let j = kinematics::jacobian(mech).unwrap();
    for (i, m) in last_cmd.motors.iter().enumerate() {
        let tau = j[0][i] * 0.0 + j[1][i] * 0.0 + j[2][i] * 2.0;
        assert!(
            (f64::from(*m) + 10_000.0 * tau).abs() <= 1.0,
            "motor {i}: {m} vs {tau}"
        );
    }
}

#[test]
fn nan_and_watchdog_send_zero_motor_commands() {
    let mut mock = MockTransport::running();
    mock.report = FalconReport {
        encoders: counts_for([0.0, 0.0, 0.11]),
        buttons: 0,
        homed: 7,
    };
    let mut dev = FalconDevice::new(mock, config());
    dev.read().unwrap();
    dev.write(&ForceCommand::force([3.0, 0.0, 0.0])).unwrap();
    assert_ne!(dev.transport().commands.last().unwrap().motors, [0; 3]);
    assert_eq!(
        dev.write(&ForceCommand::force([f64::NAN, 0.0, 0.0])),
        Err(DeviceError::NonFiniteCommand)
    );
    assert_eq!(dev.transport().commands.last().unwrap().motors, [0; 3]);
    // Force again, then the servo stops writing: after three missed writes the frames carry 0.
    dev.read().unwrap();
    dev.write(&ForceCommand::force([3.0, 0.0, 0.0])).unwrap();
    for _ in 0..4 {
        dev.read().unwrap();
    }
    assert_eq!(dev.transport().commands.last().unwrap().motors, [0; 3]);
    assert_eq!(dev.safety().watchdog_trips(), 1);
}

#[test]
fn disconnect_mid_session_is_an_error_not_a_panic() {
    let mut mock = MockTransport::running();
    mock.report = FalconReport {
        encoders: counts_for([0.0, 0.0, 0.11]),
        buttons: 0,
        homed: 7,
    };
    mock.disconnect_after_frames = Some(5);
    let mut dev = FalconDevice::new(mock, config());
    let mut errors = Vec::new();
    for _ in 0..10 {
        match dev.read() {
            Ok(_) => {
                if let Err(e) = dev.write(&ForceCommand::force([1.0, 0.0, 0.0])) {
                    errors.push(e);
                }
            }
            Err(e) => errors.push(e),
        }
    }
    assert!(!errors.is_empty());
    assert!(
        errors.iter().all(|e| *e == DeviceError::Disconnected),
        "{errors:?}"
    );
    assert_eq!(dev.safety().output(), ForceCommand::OFF);
}

/// A transport that lets a cut happen while the servo's frame is on its way out: inside the
/// bulk write of command frame `at` (counted from 0), it calls the device's cutoff, as a
/// supervisor thread would between the servo's look at the latch and its frame.
#[derive(Debug)]
struct CutDuringWrite {
    mock: MockTransport,
    at: usize,
    frames: usize,
    cutoff: Arc<OnceLock<Arc<dyn MotorCutoff>>>,
}

impl Transport for CutDuringWrite {
    fn control_out(&mut self, request: u8, value: u16, index: u16) -> Result<(), DeviceError> {
        self.mock.control_out(request, value, index)
    }
    fn bulk_write(&mut self, data: &[u8], timeout_ms: u32) -> Result<usize, DeviceError> {
        let n = self.mock.bulk_write(data, timeout_ms)?;
        if self.frames == self.at {
            let c = self.cutoff.get().expect("cutoff set");
            assert_eq!(c.cut(), Ok(Cut::Done));
        }
        self.frames += 1;
        Ok(n)
    }
    fn bulk_read(&mut self, buf: &mut [u8], timeout_ms: u32) -> Result<usize, DeviceError> {
        self.mock.bulk_read(buf, timeout_ms)
    }
    fn out_path(&self) -> Option<Arc<dyn OutPath>> {
        self.mock.out_path()
    }
}

#[test]
fn a_cut_from_another_thread_puts_zero_on_the_wire_and_holds_it_until_rearmed() {
    let mut mock = MockTransport::running();
    mock.report = FalconReport {
        encoders: counts_for([0.0, 0.0, 0.11]),
        buttons: 0,
        homed: 7,
    };
    let second_path = Arc::clone(&mock.out_log);
    let mut c = FalconConfig::default();
    c.safety.ramp_ticks = 10;
    c.homing_ramp_s = 0.0;
    let mut dev = FalconDevice::new(mock, c);
    let push = [0.0, 0.0, 3.0];
    for _ in 0..20 {
        dev.read().unwrap();
        dev.write(&ForceCommand::force(push)).unwrap();
    }
    let full = dev.transport().commands.last().unwrap().motors;
    assert_ne!(full, [0; 3]);
    // The supervisor's thread cuts: one zero-motor frame on the second path, with the LED and
    // homing bits the servo's frames carry (homed: green; the homing bit is always set).
    let cutoff = dev.cutoff().expect("the mock has a second path");
    std::thread::scope(|s| {
        s.spawn(|| assert_eq!(cutoff.cut(), Ok(Cut::Done)));
    });
    let sent = second_path.lock().unwrap().clone();
    assert_eq!(sent.len(), 1);
    assert_eq!(sent[0].motors, [0; 3]);
    assert_eq!(sent[0].leds, LED_GREEN);
    assert!(sent[0].homing);
    // While the latch is set the servo's own frames carry zero too.
    let before = dev.transport().commands.len();
    for _ in 0..5 {
        dev.read().unwrap();
        dev.write(&ForceCommand::force(push)).unwrap();
    }
    let latched = &dev.transport().commands[before..];
    assert!(!latched.is_empty());
    assert!(latched.iter().all(|c| c.motors == [0; 3]), "{latched:?}");
    // Rearmed by the servo: the force ramps up again from a tenth, not a jump.
    cutoff.rearm();
    dev.read().unwrap();
    dev.write(&ForceCommand::force(push)).unwrap();
    let resumed = dev.transport().commands.last().unwrap().motors;
    let mag = |m: [i16; 3]| m.iter().map(|v| i32::from(*v).abs()).max().unwrap_or(0);
    assert!(
        mag(resumed) > 0 && mag(resumed) * 5 < mag(full),
        "{resumed:?} vs {full:?}"
    );
}

#[test]
fn a_cut_that_lands_during_the_servos_frame_is_followed_by_a_zero_frame() {
    let mut mock = MockTransport::running();
    mock.report = FalconReport {
        encoders: counts_for([0.0, 0.0, 0.11]),
        buttons: 0,
        homed: 7,
    };
    let cell: Arc<OnceLock<Arc<dyn MotorCutoff>>> = Arc::default();
    let t = CutDuringWrite {
        mock,
        at: 10,
        frames: 0,
        cutoff: Arc::clone(&cell),
    };
    let mut dev = FalconDevice::new(t, config());
    cell.set(dev.cutoff().expect("a second path"))
        .expect("set once");
    // The first read sends a frame to start the exchange (frame 0); then each tick's write
    // sends one: frame 10 is the 10th tick's force frame.
    for _ in 0..10 {
        dev.read().unwrap();
        dev.write(&ForceCommand::force([0.0, 0.0, 3.0])).unwrap();
    }
    let cmds = &dev.transport().mock.commands;
    assert_eq!(
        cmds.len(),
        12,
        "the force frame, then a zero frame after it"
    );
    assert_ne!(cmds[10].motors, [0; 3], "the frame the cut raced with");
    assert_eq!(
        cmds[11].motors, [0; 3],
        "the last frame on the wire is a zero"
    );
    assert!(!dev.safety().is_enabled());
}
