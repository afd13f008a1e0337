//! Falcon frames: 16 bytes, `<` + 14 payload bytes + `>`, every payload byte a nibble + 0x41.
//!
//! Layout (libnifalcon's published Novint-firmware protocol):
//! - host -> Falcon: bytes 1..=12 three motor commands (i16, four nibbles each, least
//!   significant nibble first); byte 13 = LED bits | homing-mode bit 0x01; byte 14 = 0 (0x41).
//! - Falcon -> host: bytes 1..=12 three encoder counts (i16, same encoding); byte 13: low nibble
//!   grip buttons, high nibble homed bits (bit 4 + axis); byte 14 unused.
//!
//! `<` (0x3C) and `>` (0x3E) never occur as payload bytes (0x41..), so a reader resynchronises
//! on `<` after a short or corrupted read ([`FrameAssembler`]).

/// Frame length, bytes.
pub const FRAME_LEN: usize = 16;
/// Offset added to every payload byte.
pub const NIBBLE_BASE: u8 = 0x41;
/// Homing-mode bit in byte 13 of a command.
pub const HOMING_MODE: u8 = 0x01;
/// LED bit (libnifalcon `FalconFirmware::GREEN_LED`).
pub const LED_GREEN: u8 = 0x02;
/// LED bit (libnifalcon `FalconFirmware::BLUE_LED`).
pub const LED_BLUE: u8 = 0x04;
/// LED bit (libnifalcon `FalconFirmware::RED_LED`).
pub const LED_RED: u8 = 0x08;

/// What the host sends each tick.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FalconCommand {
    /// Motor commands, firmware units (libnifalcon: -10000 x torque in N m).
    pub motors: [i16; 3],
    /// LED bits (`LED_*`).
    pub leds: u8,
    /// Homing mode on.
    pub homing: bool,
}

/// What the Falcon reports each tick.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FalconReport {
    /// Encoder counts of the three motors.
    pub encoders: [i16; 3],
    /// Grip buttons, bit mask (4 bits).
    pub buttons: u8,
    /// Homed flags, bit i = axis i homed (3 bits).
    pub homed: u8,
}

/// Why a 16-byte frame was rejected.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FrameError {
    /// Byte 0 is not `<` or byte 15 is not `>`.
    Delimiters,
    /// A nibble byte is outside 0x41..=0x50 (offset given).
    Nibble(u8),
}

fn put_i16(out: &mut [u8; FRAME_LEN], at: usize, v: i16) {
    let u = v as u16;
    for k in 0..4 {
        if let Some(b) = out.get_mut(at + k) {
            *b = NIBBLE_BASE + ((u >> (4 * k)) & 0xF) as u8;
        }
    }
}

fn get_i16(frame: &[u8; FRAME_LEN], at: usize) -> Result<i16, FrameError> {
    let mut u: u16 = 0;
    for k in 0..4 {
        let b = frame.get(at + k).copied().unwrap_or(0);
        let n = b.wrapping_sub(NIBBLE_BASE);
        if n > 0xF {
            return Err(FrameError::Nibble((at + k) as u8));
        }
        u |= u16::from(n) << (4 * k);
    }
    Ok(u as i16)
}

/// Encodes a command frame.
pub fn encode_command(cmd: &FalconCommand) -> [u8; FRAME_LEN] {
    let mut out = [NIBBLE_BASE; FRAME_LEN];
    out[0] = b'<';
    out[15] = b'>';
    for (i, m) in cmd.motors.iter().enumerate() {
        put_i16(&mut out, 1 + 4 * i, *m);
    }
    let flags =
        (cmd.leds & (LED_GREEN | LED_BLUE | LED_RED)) | if cmd.homing { HOMING_MODE } else { 0 };
    out[13] = NIBBLE_BASE + flags;
    out
}

/// Decodes a command frame (used by mocks and tests to check what the host sent).
pub fn decode_command(frame: &[u8; FRAME_LEN]) -> Result<FalconCommand, FrameError> {
    if frame[0] != b'<' || frame[15] != b'>' {
        return Err(FrameError::Delimiters);
    }
    let motors = [get_i16(frame, 1)?, get_i16(frame, 5)?, get_i16(frame, 9)?];
    let flags = frame[13].wrapping_sub(NIBBLE_BASE);
    if flags > 0xF {
        return Err(FrameError::Nibble(13));
    }
    Ok(FalconCommand {
        motors,
        leds: flags & 0x0E,
        homing: flags & HOMING_MODE != 0,
    })
}

/// Encodes a report frame (for mocks and tests).
pub fn encode_report(report: &FalconReport) -> [u8; FRAME_LEN] {
    let mut out = [NIBBLE_BASE; FRAME_LEN];
    out[0] = b'<';
    out[15] = b'>';
    for (i, e) in report.encoders.iter().enumerate() {
        put_i16(&mut out, 1 + 4 * i, *e);
    }
    out[13] = NIBBLE_BASE + (((report.homed & 0x7) << 4) | (report.buttons & 0xF));
    out
}

/// Decodes a report frame.
pub fn decode_report(frame: &[u8; FRAME_LEN]) -> Result<FalconReport, FrameError> {
    if frame[0] != b'<' || frame[15] != b'>' {
        return Err(FrameError::Delimiters);
    }
    let encoders = [get_i16(frame, 1)?, get_i16(frame, 5)?, get_i16(frame, 9)?];
    let status = frame[13].wrapping_sub(NIBBLE_BASE);
    if status > 0x7F {
        return Err(FrameError::Nibble(13));
    }
    Ok(FalconReport {
        encoders,
        buttons: status & 0xF,
        homed: (status >> 4) & 0x7,
    })
}

/// Reassembles report frames from a byte stream split at arbitrary points.
///
/// # Bounded work
/// O(bytes pushed); a fixed 16-byte buffer, no allocation.
#[derive(Clone, Copy, Debug, Default)]
pub struct FrameAssembler {
    buf: [u8; FRAME_LEN],
    len: usize,
    dropped: u32,
}

impl FrameAssembler {
    /// An empty assembler.
    pub fn new() -> FrameAssembler {
        FrameAssembler::default()
    }

    /// Feeds bytes; returns the last complete, valid report among them, if any.
    pub fn push(&mut self, bytes: &[u8]) -> Option<FalconReport> {
        let mut last = None;
        for &b in bytes {
            if b == b'<' {
                if self.len > 0 {
                    self.dropped = self.dropped.saturating_add(1);
                }
                self.buf[0] = b;
                self.len = 1;
                continue;
            }
            if self.len == 0 {
                continue; // between frames: skip until the next '<'
            }
            if let Some(slot) = self.buf.get_mut(self.len) {
                *slot = b;
            }
            self.len += 1;
            if self.len == FRAME_LEN {
                self.len = 0;
                match decode_report(&self.buf) {
                    Ok(r) => last = Some(r),
                    Err(_) => self.dropped = self.dropped.saturating_add(1),
                }
            }
        }
        last
    }

    /// Partial or corrupt frames discarded so far.
    pub fn dropped(&self) -> u32 {
        self.dropped
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn command_matches_documented_layout() {
        // Built from the documented layout: motor 0 = 0x1234 -> nibbles 4,3,2,1 (+0x41),
        // motor 1 = -1 = 0xFFFF -> 'P' x4, motor 2 = 0; byte 13 = red LED | homing.
        let cmd = FalconCommand {
            motors: [0x1234, -1, 0],
            leds: LED_RED,
            homing: true,
        };
        let f = encode_command(&cmd);
        let want: [u8; 16] = [
            b'<',
            0x45,
            0x44,
            0x43,
            0x42,
            0x50,
            0x50,
            0x50,
            0x50,
            0x41,
            0x41,
            0x41,
            0x41,
            0x41 + 0x09,
            0x41,
            b'>',
        ];
        assert_eq!(f, want);
        assert_eq!(decode_command(&f), Ok(cmd));
    }

    #[test]
    fn report_matches_documented_layout_and_round_trips() {
        // Built from the documented layout: encoders -2 (0xFFFE), 0x0100, 0x7FFF;
        // byte 13 = (homed 0b101 << 4 | buttons 0b0010) + 0x41.
        let f: [u8; 16] = [
            b'<',
            0x4F,
            0x50,
            0x50,
            0x50,
            0x41,
            0x41,
            0x42,
            0x41,
            0x50,
            0x50,
            0x50,
            0x48,
            0x41 + 0x52,
            0x41,
            b'>',
        ];
        let r = decode_report(&f).unwrap();
        assert_eq!(
            r,
            FalconReport {
                encoders: [-2, 0x0100, 0x7FFF],
                buttons: 2,
                homed: 5
            }
        );
        assert_eq!(encode_report(&r), f);
        for e in [i16::MIN, -1234, 0, 1, 4321, i16::MAX] {
            let r = FalconReport {
                encoders: [e, e.wrapping_neg(), e / 3],
                buttons: 0xF,
                homed: 7,
            };
            assert_eq!(decode_report(&encode_report(&r)), Ok(r));
        }
    }

    #[test]
    fn bad_frames_are_rejected() {
        let mut f = encode_report(&FalconReport::default());
        f[6] = 0x30;
        assert_eq!(decode_report(&f), Err(FrameError::Nibble(6)));
        let mut g = encode_report(&FalconReport::default());
        g[15] = b'x';
        assert_eq!(decode_report(&g), Err(FrameError::Delimiters));
    }

    #[test]
    fn assembler_resyncs_after_short_and_garbled_reads() {
        let a = encode_report(&FalconReport {
            encoders: [1, 2, 3],
            buttons: 1,
            homed: 0,
        });
        let b = encode_report(&FalconReport {
            encoders: [4, 5, 6],
            buttons: 0,
            homed: 7,
        });
        let mut asm = FrameAssembler::new();
        // A frame split over three reads.
        assert_eq!(asm.push(&a[..5]), None);
        assert_eq!(asm.push(&a[5..11]), None);
        assert_eq!(asm.push(&a[11..]).map(|r| r.encoders), Some([1, 2, 3]));
        // A truncated frame followed by a full one: the truncated one is dropped.
        let mut stream = Vec::new();
        stream.extend_from_slice(&a[..9]);
        stream.extend_from_slice(&[0x00, 0x13]);
        stream.extend_from_slice(&b);
        assert_eq!(asm.push(&stream).map(|r| r.encoders), Some([4, 5, 6]));
        assert_eq!(asm.dropped(), 1);
    }
}
