//! The Falcon tolerant as libnifalcon is: a missed report or a failed kinematics solve holds
//! the last position (counted) and the run stops after a bounded number in a row; a zero
//! frame on stop and on drop; the firmware upload as libnifalcon's loader runs it (62-byte
//! blocks, 1000 ms transfers, a close and reopen between tries). The expected byte streams
//! are written out from libnifalcon's `FalconFirmware.cpp` (`loadFirmware`),
//! `FalconCLIBase.cpp` (`parseOptions`) and `FalconCommLibUSB.cpp` (`open`,
//! `setFirmwareMode`, `setNormalMode`), not from the driver's constants.

use std::sync::{Arc, Mutex};

use tetradrill_device::falcon::frame::{decode_command, FalconCommand, FalconReport};
use tetradrill_device::falcon::ftdi::*;
use tetradrill_device::falcon::kinematics;
use tetradrill_device::falcon::mock::{MockOp, MockTransport};
use tetradrill_device::falcon::{FalconConfig, FalconDevice, Transport};
use tetradrill_device::{DeviceError, ForceCommand, HapticDevice};

fn firmware() -> Vec<u8> {
    // Not a real firmware: 300 deterministic bytes.
    (0..300u32)
        .map(|i| (i.wrapping_mul(29) ^ 0xA5) as u8)
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

fn config() -> FalconConfig {
    let mut c = FalconConfig::default();
    c.safety.ramp_ticks = 1;
    c.homing_ramp_s = 0.0;
    c.max_lost_in_row = 5;
    c.upload_tries = 3;
    c
}

fn report_at(p: [f64; 3]) -> FalconReport {
    FalconReport {
        encoders: counts_for(p),
        buttons: 0,
        homed: 0b111,
    }
}

/// The tool's mechanism-frame position on tick `k` of a slow sweep.
fn sweep(k: usize) -> [f64; 3] {
    [0.002 * k as f64 / 10.0, 0.0, 0.11]
}

const PUSH: ForceCommand = ForceCommand::force([0.0, 0.0, 2.0]);

#[test]
fn a_missed_report_holds_the_last_position_and_the_run_goes_on() {
    let mut mock = MockTransport::running();
    // Command frame 6 gets no answer: the read of tick 4 finds nothing.
    mock.drop_reports = vec![6];
    let mut dev = FalconDevice::new(mock, config());
    dev.start(None).unwrap();
    let mut states = Vec::new();
    for k in 0..10 {
        dev.transport_mut().report = report_at(sweep(k));
        let s = dev
            .read()
            .expect("a missed report is not the end of the run");
        dev.write(&PUSH).unwrap();
        states.push(s);
    }
    let origin = kinematics::WORKSPACE_CENTRE;
    // Frame 1 is the status round trip at start. Tick 0's read sends frame 2 and takes its
    // answer (sweep 0); from tick 1 on, a read takes the answer to the frame written on the
    // tick before (sweep k - 1). Frame 6's answer is missing: tick 4 holds tick 3's
    // position (sweep 2), and tick 5 takes the answer to frame 7 (sweep 4).
    let x: Vec<f64> = states.iter().map(|s| s.position[0] + origin[0]).collect();
    for (k, got) in x.iter().enumerate() {
        let want = if k == 4 {
            sweep(2)[0]
        } else {
            sweep(k.saturating_sub(1))[0]
        };
        assert!((got - want).abs() < 1e-4, "tick {k}: {got} vs {want}");
    }
    assert_eq!(states[4].tick, 5, "the held tick still counts");
    let lost = dev.lost_reports();
    assert_eq!(
        (lost.missed_frames, lost.failed_solves, lost.in_row),
        (1, 0, 0)
    );
    assert_eq!(lost.longest_in_row, 1);
    // The force was not cut: every frame after the first homed report carries the push.
    let cmds = &dev.transport().commands;
    assert!(cmds[2..].iter().all(|c| c.motors != [0; 3]), "{cmds:?}");
}

#[test]
fn a_failed_kinematics_solve_holds_the_last_position() {
    // Counts no pose of the mechanism gives (checked here with the solver from two guesses).
    let bad = [i16::MAX, i16::MIN, i16::MAX];
    let theta = bad.map(kinematics::encoder_to_angle);
    assert!(kinematics::forward(theta, kinematics::WORKSPACE_CENTRE).is_none());
    assert!(kinematics::forward(theta, [0.0, 0.0, 0.13]).is_none());
    let mut mock = MockTransport::running();
    mock.report = report_at([0.005, -0.003, 0.12]);
    let mut dev = FalconDevice::new(mock, config());
    dev.start(None).unwrap();
    let before = dev.read().unwrap();
    dev.transport_mut().report.encoders = bad;
    dev.write(&PUSH).unwrap();
    let held = dev
        .read()
        .expect("a failed solve is not the end of the run");
    assert_eq!(held.position, before.position);
    assert_eq!(dev.lost_reports().failed_solves, 1);
    assert_eq!(dev.lost_reports().missed_frames, 0);
    dev.transport_mut().report = report_at([0.004, -0.003, 0.12]);
    dev.write(&PUSH).unwrap();
    let after = dev.read().unwrap();
    assert!((after.position[0] + kinematics::WORKSPACE_CENTRE[0] - 0.004).abs() < 1e-4);
    assert_eq!(dev.lost_reports().in_row, 0);
}

#[test]
fn reports_lost_in_a_row_stop_the_run_with_the_count_and_a_zero_frame() {
    let mut mock = MockTransport::running();
    mock.report = report_at([0.0, 0.0, 0.11]);
    mock.drop_reports = (3..1000).collect();
    let mut dev = FalconDevice::new(mock, config());
    dev.start(None).unwrap();
    let mut results = Vec::new();
    for _ in 0..20 {
        let r = dev.read();
        let stop = r.is_err();
        results.push(r.map(|_| ()));
        if stop {
            break;
        }
        dev.write(&PUSH).unwrap();
    }
    // Frame 1 (start) and frame 2 (sent by the first read) are answered, none after: the
    // first read takes a report, the next four hold, the sixth is the fifth in a row.
    let mut want = vec![Ok(()); 5];
    want.push(Err(DeviceError::ReportsLost { in_row: 5 }));
    assert_eq!(results, want);
    let line = DeviceError::ReportsLost { in_row: 5 }.to_string();
    assert!(
        line.contains("5 ticks in a row") && !line.contains('\n'),
        "{line}"
    );
    let lost = dev.lost_reports();
    assert_eq!((lost.missed_frames, lost.in_row), (5, 5));
    let last = dev.transport().commands.last().unwrap();
    assert_eq!(last.motors, [0; 3], "the last frame on the wire is a zero");
    assert!(last.homing);
}

/// Every bulk write with its timeout, ms.
type Writes = Arc<Mutex<Vec<(Vec<u8>, u32)>>>;

/// A transport that keeps every frame written, with its timeout, where the test can read it
/// after the device is gone.
#[derive(Debug)]
struct Recorded {
    mock: MockTransport,
    writes: Writes,
    read_timeouts: Arc<Mutex<Vec<u32>>>,
}

impl Recorded {
    fn new(mock: MockTransport) -> Recorded {
        Recorded {
            mock,
            writes: Arc::default(),
            read_timeouts: Arc::default(),
        }
    }
}

impl Transport for Recorded {
    fn control_out(&mut self, request: u8, value: u16, index: u16) -> Result<(), DeviceError> {
        self.mock.control_out(request, value, index)
    }
    fn bulk_write(&mut self, data: &[u8], timeout_ms: u32) -> Result<usize, DeviceError> {
        self.writes
            .lock()
            .unwrap()
            .push((data.to_vec(), timeout_ms));
        self.mock.bulk_write(data, timeout_ms)
    }
    fn bulk_read(&mut self, buf: &mut [u8], timeout_ms: u32) -> Result<usize, DeviceError> {
        self.read_timeouts.lock().unwrap().push(timeout_ms);
        self.mock.bulk_read(buf, timeout_ms)
    }
    fn reopen(&mut self) -> Result<(), DeviceError> {
        self.mock.reopen()
    }
}

fn decoded(writes: &[(Vec<u8>, u32)]) -> Vec<FalconCommand> {
    writes
        .iter()
        .filter_map(|(w, _)| <[u8; 16]>::try_from(w.as_slice()).ok())
        .filter_map(|f| decode_command(&f).ok())
        .collect()
}

#[test]
fn stop_and_drop_each_send_a_zero_frame() {
    let mut mock = MockTransport::running();
    mock.report = report_at([0.01, 0.0, 0.11]);
    let t = Recorded::new(mock);
    let writes = Arc::clone(&t.writes);
    let mut dev = FalconDevice::new(t, config());
    dev.start(None).unwrap();
    for _ in 0..5 {
        dev.read().unwrap();
        dev.write(&PUSH).unwrap();
    }
    assert_ne!(
        decoded(&writes.lock().unwrap()).last().unwrap().motors,
        [0; 3]
    );
    dev.stop();
    let after_stop = decoded(&writes.lock().unwrap());
    assert_eq!(after_stop.last().unwrap().motors, [0; 3]);
    // After a stop the force is off until an enabled write ramps it in again.
    for _ in 0..2 {
        dev.read().unwrap();
        dev.write(&PUSH).unwrap();
    }
    assert_ne!(
        decoded(&writes.lock().unwrap()).last().unwrap().motors,
        [0; 3]
    );
    let before_drop = writes.lock().unwrap().len();
    drop(dev);
    let w = writes.lock().unwrap();
    assert_eq!(w.len(), before_drop + 1, "one frame on drop");
    let last = decoded(&w).pop().unwrap();
    assert_eq!(last.motors, [0; 3]);
    assert!(last.homing);
    drop(w);

    // A device dropped at the loader's baud rate sends nothing: a frame would be taken for
    // firmware.
    let mut mock = MockTransport::new();
    mock.bad_loader_replies = usize::MAX;
    let t = Recorded::new(mock);
    let writes = Arc::clone(&t.writes);
    let mut dev = FalconDevice::new(
        t,
        FalconConfig {
            handshake_tries: 2,
            upload_tries: 1,
            ..config()
        },
    );
    assert_eq!(
        dev.start(Some(&firmware())),
        Err(DeviceError::FirmwareHandshake { step: 5 })
    );
    let n = writes.lock().unwrap().len();
    drop(dev);
    assert_eq!(writes.lock().unwrap().len(), n);
}

/// libnifalcon's `setFirmwareMode` as operations, with `blocks` written after it.
fn loader(ops: &mut Vec<MockOp>, blocks: &[&[u8]]) {
    let c = |request, value| MockOp::Control { request, value };
    ops.extend([
        c(0x00, 1),      // purge RX
        c(0x00, 2),      // purge TX
        c(0x09, 16),     // latency timer 16 ms
        c(0x03, 0x4138), // 9600 baud
        c(0x04, 8),      // 8N1
        c(0x02, 0),      // no flow control
        c(0x01, 0x0200), // RTS low
        c(0x01, 0x0100), // DTR low
        c(0x01, 0x0101), // DTR high
        MockOp::Write(vec![0x0a, 0x43, 0x0d]),
        c(0x01, 0x0100), // DTR low
        c(0x03, 0x0015), // the loader's baud rate
        MockOp::Write(vec![0x41]),
    ]);
    ops.extend(blocks.iter().map(|b| MockOp::Write(b.to_vec())));
}

/// libnifalcon's `setNormalMode`: latency 1 ms, divisor 2, purge RX, purge TX.
fn normal(ops: &mut Vec<MockOp>) {
    let c = |request, value| MockOp::Control { request, value };
    ops.extend([c(0x09, 1), c(0x03, 2), c(0x00, 1), c(0x00, 2)]);
}

#[test]
fn the_upload_runs_as_libnifalcons_loader_with_a_reopen_between_tries() {
    // The FTDI request numbers above are written out from libftdi's names; the driver's
    // constants must agree with them.
    assert_eq!(
        (
            SIO_RESET,
            SIO_SET_LATENCY_TIMER,
            SIO_SET_BAUD_RATE,
            SIO_MODEM_CTRL
        ),
        (0x00, 0x09, 0x03, 0x01)
    );
    assert_eq!(
        (PURGE_RX, PURGE_TX, RTS_LOW, DTR_LOW, DTR_HIGH),
        (1, 2, 0x0200, 0x0100, 0x0101)
    );
    let fw = firmware();
    // The echo of byte 130 is corrupted in the first try: block 124..186 fails, after which
    // libnifalcon closes and reopens the device and starts over.
    let mut mock = MockTransport::new();
    mock.corrupt_echo_at = Some(130);
    let t = Recorded::new(mock);
    let (writes, reads) = (Arc::clone(&t.writes), Arc::clone(&t.read_timeouts));
    let mut dev = FalconDevice::new(t, config());
    dev.upload_firmware(&fw).expect("the second try works");
    let mut want = Vec::new();
    loader(&mut want, &[&fw[0..62], &fw[62..124], &fw[124..186]]);
    want.push(MockOp::Reopen);
    let c = |request, value| MockOp::Control { request, value };
    // `FalconCommLibUSB::open`: purge RX, purge TX, then normal mode.
    want.extend([c(0x00, 1), c(0x00, 2)]);
    normal(&mut want);
    loader(
        &mut want,
        &[
            &fw[0..62],
            &fw[62..124],
            &fw[124..186],
            &fw[186..248],
            &fw[248..300],
        ],
    );
    normal(&mut want);
    assert_eq!(dev.transport().mock.log, want);
    assert!(dev.transport().mock.firmware_running());
    // Every transfer of the loader waits libnifalcon's 1000 ms.
    assert!(writes.lock().unwrap().iter().all(|(_, t)| *t == 1000));
    assert!(reads.lock().unwrap().iter().all(|t| *t == 1000));
    // After the upload, frames use the servo's timeout.
    dev.check_firmware().unwrap();
    assert_eq!(writes.lock().unwrap().last().unwrap().1, 100);
}
