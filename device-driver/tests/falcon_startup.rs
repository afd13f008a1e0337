//! The Falcon's start-up against the mock: normal mode always, the status round trip, the
//! loader handshake retried with an exact compare, and the whole upload retried a bounded
//! number of times. The expected sequences are written out from libnifalcon's published
//! `FalconCommLibUSB.cpp` (`setFirmwareMode`, `setNormalMode`).

use tetradrill_device::falcon::frame::{decode_command, LED_RED};
use tetradrill_device::falcon::ftdi::*;
use tetradrill_device::falcon::mock::{MockOp, MockTransport};
use tetradrill_device::falcon::{FalconConfig, FalconDevice};
use tetradrill_device::{DeviceError, ForceCommand, HapticDevice};

fn firmware() -> Vec<u8> {
    // Not a real firmware: 300 deterministic bytes, five blocks.
    (0..300u32)
        .map(|i| (i.wrapping_mul(13) ^ 0x3C) as u8)
        .collect()
}

fn config() -> FalconConfig {
    FalconConfig {
        handshake_tries: 5,
        upload_tries: 3,
        status_tries: 4,
        ..FalconConfig::default()
    }
}

fn controls(log: &[MockOp]) -> Vec<(u8, u16)> {
    log.iter()
        .filter_map(|op| match op {
            MockOp::Control { request, value } => Some((*request, *value)),
            MockOp::Write(_) | MockOp::Reopen => None,
        })
        .collect()
}

fn writes_of(log: &[MockOp], bytes: &[u8]) -> usize {
    log.iter()
        .filter(|op| matches!(op, MockOp::Write(w) if w.as_slice() == bytes))
        .count()
}

/// libnifalcon's `setNormalMode`: latency 1 ms, divisor 2, purge RX, purge TX.
const NORMAL: [(u8, u16); 4] = [
    (SIO_SET_LATENCY_TIMER, 1),
    (SIO_SET_BAUD_RATE, 0x0002),
    (SIO_RESET, PURGE_RX),
    (SIO_RESET, PURGE_TX),
];

#[test]
fn without_an_upload_start_sets_normal_mode_and_checks_the_firmware_answers() {
    let mut dev = FalconDevice::new(MockTransport::running(), config());
    dev.start(None).expect("a running firmware answers");
    let log = &dev.transport().log;
    assert_eq!(controls(log), NORMAL);
    // One frame went out after the controls: zero torque, red LED, the homing bit.
    let frames: Vec<&Vec<u8>> = log
        .iter()
        .filter_map(|op| match op {
            MockOp::Write(w) => Some(w),
            MockOp::Control { .. } | MockOp::Reopen => None,
        })
        .collect();
    assert_eq!(frames.len(), 1);
    let f: [u8; 16] = frames[0].as_slice().try_into().expect("16 bytes");
    let cmd = decode_command(&f).expect("a command frame");
    assert_eq!(cmd.motors, [0; 3]);
    assert_eq!(cmd.leds, LED_RED);
    assert!(cmd.homing);
    // The exchange goes on from there.
    dev.read().expect("read after start");
    dev.write(&ForceCommand::ZERO).expect("write");
}

#[test]
fn no_firmware_is_one_clear_error_after_a_bounded_number_of_status_frames() {
    let mut dev = FalconDevice::new(MockTransport::new(), config());
    let e = dev.start(None).expect_err("nothing answers");
    assert_eq!(e, DeviceError::FirmwareNotRunning);
    assert!(e.to_string().contains("no firmware answers"), "{e}");
    // Normal mode was set anyway, then exactly `status_tries` status frames.
    let log = &dev.transport().log;
    assert_eq!(controls(log), NORMAL);
    let frames = log
        .iter()
        .filter(|op| matches!(op, MockOp::Write(w) if w.len() == 16))
        .count();
    assert_eq!(frames, 4);
}

#[test]
fn the_loader_handshake_retries_a_bad_echo_then_takes_the_good_one() {
    let mut mock = MockTransport::new();
    mock.bad_loader_replies = 3;
    let mut dev = FalconDevice::new(mock, config());
    dev.start(Some(&firmware()))
        .expect("the fourth reply is right");
    let log = &dev.transport().log;
    // 0a 43 0d sent four times (three wrong replies, 0a 44 2c 0e, refused), 'A' once.
    assert_eq!(writes_of(log, &[0x0a, 0x43, 0x0d]), 4);
    assert_eq!(writes_of(log, &[0x41]), 1);
    // One upload: the loader sequence once, then normal mode.
    let c = controls(log);
    assert_eq!(&c[c.len() - 4..], &NORMAL);
    assert_eq!(
        c.iter()
            .filter(|x| **x == (SIO_SET_BAUD_RATE, 0x4138))
            .count(),
        1
    );
    assert!(dev.transport().firmware_running());
    assert_eq!(dev.transport().echoed(), 300);
    // The reply with a leading zero byte is the other exact form: taken at the first try.
    let mut mock = MockTransport::new();
    mock.long_loader_reply = true;
    let mut dev = FalconDevice::new(mock, config());
    dev.start(Some(&firmware()))
        .expect("00 0a 44 2c 0d is accepted");
    assert_eq!(writes_of(&dev.transport().log, &[0x0a, 0x43, 0x0d]), 1);
}

#[test]
fn a_loader_that_never_answers_right_fails_after_the_bounded_tries() {
    // Wrong replies to the first handshake, forever: handshake_tries (5) per upload, times
    // upload_tries (3) uploads.
    let mut mock = MockTransport::new();
    mock.bad_loader_replies = usize::MAX;
    let mut dev = FalconDevice::new(mock, config());
    assert_eq!(
        dev.start(Some(&firmware())),
        Err(DeviceError::FirmwareHandshake { step: 5 })
    );
    let log = &dev.transport().log;
    assert_eq!(writes_of(log, &[0x0a, 0x43, 0x0d]), 15);
    assert_eq!(writes_of(log, &[0x41]), 0);
    // The second handshake compares exactly too: `13 41` is not `41`.
    let mut mock = MockTransport::new();
    mock.bad_ready_reply = true;
    let mut dev = FalconDevice::new(mock, config());
    assert_eq!(
        dev.start(Some(&firmware())),
        Err(DeviceError::FirmwareHandshake { step: 7 })
    );
    assert_eq!(writes_of(&dev.transport().log, &[0x41]), 3);
    assert!(!dev.transport().firmware_running());
}

#[test]
fn the_whole_upload_is_retried_a_bounded_number_of_times() {
    // The echo of byte 200 (the fourth block) is corrupted in the first two uploads: the third works.
    let mut mock = MockTransport::new();
    mock.corrupt_echo_at = Some(200);
    mock.corrupt_echo_repeats = 1;
    let mut dev = FalconDevice::new(mock, config());
    dev.start(Some(&firmware())).expect("third upload");
    let log = &dev.transport().log;
    assert_eq!(writes_of(log, &[0x41]), 3, "three uploads");
    assert!(dev.transport().firmware_running());
    // Three loader sequences; a reopen (with its normal mode) before the second and the
    // third, and normal mode after the good upload.
    let c = controls(log);
    assert_eq!(
        c.iter()
            .filter(|x| **x == (SIO_SET_BAUD_RATE, 0x4138))
            .count(),
        3
    );
    assert_eq!(
        c.iter()
            .filter(|x| **x == (SIO_SET_BAUD_RATE, 0x0002))
            .count(),
        3
    );
    assert_eq!(log.iter().filter(|op| **op == MockOp::Reopen).count(), 2);
    // Corrupted in all three: the last error, after exactly three uploads.
    let mut mock = MockTransport::new();
    mock.corrupt_echo_at = Some(200);
    mock.corrupt_echo_repeats = 2;
    let mut dev = FalconDevice::new(mock, config());
    assert_eq!(
        dev.start(Some(&firmware())),
        Err(DeviceError::FirmwareMismatch { offset: 186 })
    );
    assert_eq!(writes_of(&dev.transport().log, &[0x41]), 3);
    assert!(dev.transport().commands.is_empty(), "no command frame sent");
    // An empty file is refused before anything is sent.
    let mut dev = FalconDevice::new(MockTransport::new(), config());
    assert_eq!(dev.start(Some(&[])), Err(DeviceError::FirmwareFile));
    assert!(dev.transport().log.is_empty());
}
