//! Novint Falcon frames and the session that reads them.
//!
//! 1. The first 16 bytes as a report and as a command frame: a frame that decodes re-encodes
//!    to the same bytes except byte 14 (unused, not checked) and decodes to the same value.
//! 2. All the bytes through the `FrameAssembler`, whole and in pieces (sizes taken from the
//!    input): the same last report and the same count of dropped frames either way.
//! 3. A `FalconDevice` over a transport whose reads come from the input (packet lengths 0..=64,
//!    timeouts, a disconnect) with force commands from the input (including NaN, infinities,
//!    huge values): no panic, finite states, every frame sent decodes, motor commands within
//!    `max_command`, zero motors after a refused command, `Disconnected` stays disconnected.

#![no_main]

use libfuzzer_sys::fuzz_target;
use tetradrill_device::falcon::frame::{
    decode_command, decode_report, encode_command, encode_report, FrameAssembler, FRAME_LEN,
    NIBBLE_BASE,
};
use tetradrill_device::falcon::{FalconConfig, FalconDevice, Transport};
use tetradrill_device::{DeviceError, ForceCommand, HapticDevice};
use tetradrill_fuzz::Input;

fn frames(data: &[u8]) {
    let Some(f) = data.get(..FRAME_LEN) else {
        return;
    };
    let f: [u8; FRAME_LEN] = f.try_into().expect("16 bytes");
    let mut same = f;
    same[14] = NIBBLE_BASE;
    if let Ok(r) = decode_report(&f) {
        assert_eq!(encode_report(&r), same, "report {r:?}");
        assert_eq!(decode_report(&encode_report(&r)), Ok(r));
    }
    if let Ok(c) = decode_command(&f) {
        assert_eq!(encode_command(&c), same, "command {c:?}");
        assert_eq!(decode_command(&encode_command(&c)), Ok(c));
    }
}

fn assembler(data: &[u8]) {
    let mut whole = FrameAssembler::new();
    let one_go = whole.push(data);
    let mut pieces = FrameAssembler::new();
    let mut last = None;
    let mut rest = data;
    let mut k = 0;
    while !rest.is_empty() {
        let n = 1 + usize::from(data[k % data.len()]) % 23;
        let (head, tail) = rest.split_at(n.min(rest.len()));
        if let Some(r) = pieces.push(head) {
            let again = decode_report(&encode_report(&r));
            assert_eq!(again, Ok(r), "an assembled report round-trips");
            last = Some(r);
        }
        rest = tail;
        k += 1;
    }
    assert_eq!(one_go, last, "split reads change the last report");
    assert_eq!(
        whole.dropped(),
        pieces.dropped(),
        "split reads change the drop count"
    );
}

/// The device side: packets and errors scripted by the fuzz input; commands recorded.
struct FuzzUsb<'a> {
    input: Input<'a>,
    sent: Vec<[u8; FRAME_LEN]>,
}

impl Transport for FuzzUsb<'_> {
    fn control_out(&mut self, _request: u8, _value: u16, _index: u16) -> Result<(), DeviceError> {
        Ok(())
    }

    fn bulk_write(&mut self, data: &[u8], _timeout_ms: u32) -> Result<usize, DeviceError> {
        if let Ok(f) = <[u8; FRAME_LEN]>::try_from(data) {
            self.sent.push(f);
        }
        Ok(data.len())
    }

    fn bulk_read(&mut self, buf: &mut [u8], _timeout_ms: u32) -> Result<usize, DeviceError> {
        match self.input.byte() {
            None | Some(0xFE) => Err(DeviceError::Disconnected),
            Some(0xFF) => Err(DeviceError::Timeout),
            Some(s) => {
                let n = (usize::from(s) % 65).min(buf.len());
                self.input.fill(&mut buf[..n]);
                Ok(n)
            }
        }
    }
}

fn session(data: &[u8]) {
    let config = FalconConfig::default();
    let Some((&mode, rest)) = data.split_first() else {
        return;
    };
    // The last 4 * (mode >> 1) bytes script the commands, the others the device.
    let split = rest.len() - rest.len().min(4 * usize::from(mode >> 1));
    let (reads, commands) = rest.split_at(split);
    let mut commands = Input::new(commands);
    let mut dev = FalconDevice::new(
        FuzzUsb {
            input: Input::new(reads),
            sent: Vec::new(),
        },
        config,
    );
    if mode & 1 != 0 {
        // The echo comes from the input: almost always a mismatch, which must be an error.
        let _ = dev.load_firmware(&[0x55; 300]);
    }
    let mut gone = false;
    for _ in 0..64 {
        match dev.read() {
            Ok(s) => {
                assert!(!gone, "a read after Disconnected succeeded");
                assert!(s.position.iter().all(|v| v.is_finite()), "{s:?}");
                assert!(s.joint_angles.iter().all(|v| v.is_finite()), "{s:?}");
                assert!(s.timestamp_s.is_finite());
            }
            Err(DeviceError::Disconnected) => gone = true,
            Err(_) => {}
        }
        if gone {
            assert_eq!(dev.read().err(), Some(DeviceError::Disconnected));
            break;
        }
        let cmd = ForceCommand {
            force: [commands.force(), commands.force(), commands.force()],
            torque: [0.0; 3],
            enable: commands.byte().unwrap_or(0) & 1 != 0,
        };
        let before = dev.transport().sent.len();
        let result = dev.write(&cmd);
        if result == Err(DeviceError::NonFiniteCommand) {
            let sent = &dev.transport().sent;
            assert!(sent.len() > before, "a refused command sent no frame");
            let last = decode_command(&sent[sent.len() - 1]).expect("own frame decodes");
            assert_eq!(
                last.motors, [0; 3],
                "motors not zero after a refused command"
            );
        }
        if result == Err(DeviceError::Disconnected) {
            break;
        }
    }
    let limit = i32::from(config.max_command);
    for f in &dev.transport().sent {
        let c = decode_command(f).expect("every frame sent decodes");
        assert!(
            c.motors.iter().all(|&m| i32::from(m).abs() <= limit),
            "{c:?}"
        );
    }
}

fuzz_target!(|data: &[u8]| {
    frames(data);
    assembler(data);
    session(data);
});
