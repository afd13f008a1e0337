//! PHANTOM Omni isochronous packets (publicly reverse-engineered layout; little-endian fields
//! as the reverse-engineering notes read them on x86 hosts).
//!
//! Input, 44 bytes: offsets 4/6/8 the three arm encoders (16-bit counts, 15000 per joint
//! revolution); 10/12/14 the gimbal channels (the upper 11 bits carry the value, the low 5 are
//! noise); byte 19 status bits, active low: bit 0 button 1, bit 1 button 2, bit 2 docked;
//! 22/24/26 the second reading of each gimbal potentiometer (the "inverse" channel, same
//! 11-bit layout: each gimbal angle is read from the ratio `a / (a + b)` of its two channels);
//! 32..36 a packet counter. Other fields unknown.
//!
//! Output, 16 bytes: offsets 0/2/4 the three motor values (12-bit DAC in offset binary, 0x07FF =
//! zero torque); offset 6 control bits (bit 0 dock-light flash, bit 1 fast flash, bit 3 motors
//! on; the observed idle pattern is 0x53C0); bytes 8..16 zero.

/// Input packet length.
pub const INPUT_LEN: usize = 44;
/// Output packet length.
pub const OUTPUT_LEN: usize = 16;
/// Motor value of zero torque.
pub const MOTOR_ZERO: u16 = 0x07FF;
/// Largest motor value (12-bit DAC).
pub const MOTOR_MAX: u16 = 0x0FFF;
/// Control bits sent when idle (as observed).
pub const CONTROL_IDLE: u16 = 0x53C0;
/// Control bit: motors on.
pub const CONTROL_MOTORS_ON: u16 = 0x0008;
/// Control bit: dock light flashing.
pub const CONTROL_DOCK_FLASH: u16 = 0x0001;
/// Encoder counts per joint revolution.
pub const COUNTS_PER_REV: f64 = 15000.0;

/// A decoded input packet.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct OmniInput {
    /// Raw arm encoder counts (wrap at 16 bits).
    pub encoders: [u16; 3],
    /// Gimbal channels, 11-bit values (0..2047).
    pub gimbal: [u16; 3],
    /// The second (inverse) channel of each gimbal potentiometer, 11-bit values.
    pub gimbal_inv: [u16; 3],
    /// Button 1 pressed.
    pub button1: bool,
    /// Button 2 pressed.
    pub button2: bool,
    /// Stylus in the inkwell.
    pub docked: bool,
    /// Packet counter.
    pub counter: u32,
}

/// An output packet's content.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct OmniOutput {
    /// Motor DAC values, offset binary around [`MOTOR_ZERO`].
    pub motors: [u16; 3],
    /// Motors on.
    pub motors_on: bool,
    /// Dock light flashing.
    pub dock_flash: bool,
}

fn le16(p: &[u8; INPUT_LEN], at: usize) -> u16 {
    u16::from_le_bytes([
        p.get(at).copied().unwrap_or(0),
        p.get(at + 1).copied().unwrap_or(0),
    ])
}

/// Decodes an input packet.
pub fn decode_input(p: &[u8; INPUT_LEN]) -> OmniInput {
    let status = p[19];
    OmniInput {
        encoders: [le16(p, 4), le16(p, 6), le16(p, 8)],
        gimbal: [le16(p, 10) >> 5, le16(p, 12) >> 5, le16(p, 14) >> 5],
        gimbal_inv: [le16(p, 22) >> 5, le16(p, 24) >> 5, le16(p, 26) >> 5],
        button1: status & 0x01 == 0,
        button2: status & 0x02 == 0,
        docked: status & 0x04 == 0,
        counter: u32::from_le_bytes([p[32], p[33], p[34], p[35]]),
    }
}

/// Encodes an input packet (for mocks and tests); unknown fields zero.
pub fn encode_input(i: &OmniInput) -> [u8; INPUT_LEN] {
    let mut p = [0u8; INPUT_LEN];
    let mut put = |at: usize, v: u16| {
        let b = v.to_le_bytes();
        p[at] = b[0];
        p[at + 1] = b[1];
    };
    put(2, 0x001e);
    for k in 0..3 {
        put(4 + 2 * k, i.encoders[k]);
        put(10 + 2 * k, (i.gimbal[k] & 0x7FF) << 5);
        put(22 + 2 * k, (i.gimbal_inv[k] & 0x7FF) << 5);
    }
    let mut status = 0xF8u8;
    if !i.button1 {
        status |= 0x01;
    }
    if !i.button2 {
        status |= 0x02;
    }
    if !i.docked {
        status |= 0x04;
    }
    p[19] = status;
    p[32..36].copy_from_slice(&i.counter.to_le_bytes());
    p
}

/// Encodes an output packet.
pub fn encode_output(o: &OmniOutput) -> [u8; OUTPUT_LEN] {
    let mut p = [0u8; OUTPUT_LEN];
    for k in 0..3 {
        let b = o.motors[k].min(MOTOR_MAX).to_le_bytes();
        p[2 * k] = b[0];
        p[2 * k + 1] = b[1];
    }
    let mut control = CONTROL_IDLE;
    if o.motors_on {
        control |= CONTROL_MOTORS_ON;
    }
    if o.dock_flash {
        control |= CONTROL_DOCK_FLASH;
    }
    p[6..8].copy_from_slice(&control.to_le_bytes());
    p
}

/// Decodes an output packet (for mocks and tests).
pub fn decode_output(p: &[u8; OUTPUT_LEN]) -> OmniOutput {
    let w = |at: usize| u16::from_le_bytes([p[at], p[at + 1]]);
    let control = w(6);
    OmniOutput {
        motors: [w(0), w(2), w(4)],
        motors_on: control & CONTROL_MOTORS_ON != 0,
        dock_flash: control & CONTROL_DOCK_FLASH != 0,
    }
}

/// Motor value for a signed DAC offset, saturating to the 12-bit range.
pub fn motor_value(offset: f64) -> u16 {
    if !offset.is_finite() {
        return MOTOR_ZERO;
    }
    let v = (f64::from(MOTOR_ZERO) + offset.round()).clamp(0.0, f64::from(MOTOR_MAX));
    v as u16
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn input_matches_documented_layout() {
        // Built from the documented layout: encoders at 4/6/8, gimbal upper 11 bits at 10/12/14,
        // status byte 19 active low (0xFA: button 1 pressed (bit 0 clear), dock bit 2 clear).
        let mut p = [0u8; INPUT_LEN];
        p[4] = 0x34;
        p[5] = 0x12;
        p[6] = 0xFF;
        p[7] = 0xFF;
        p[8] = 0x98;
        p[9] = 0x3A; // 15000 = 0x3A98
        p[10] = 0x20; // 1 << 5
        p[12] = 0xE0;
        p[13] = 0xFF; // 0xFFE0 >> 5 = 2047
        p[19] = 0xFA;
        p[22] = 0xE0;
        p[23] = 0x0F; // 0x0FE0 >> 5 = 127
        p[26] = 0x40; // 2 << 5
        p[32] = 7;
        let i = decode_input(&p);
        assert_eq!(i.encoders, [0x1234, 0xFFFF, 15000]);
        assert_eq!(i.gimbal, [1, 2047, 0]);
        assert_eq!(i.gimbal_inv, [127, 0, 2]);
        assert!(i.button1 && !i.button2 && i.docked);
        assert_eq!(i.counter, 7);
        assert_eq!(decode_input(&encode_input(&i)), i);
    }

    #[test]
    fn output_matches_documented_layout() {
        // Zero torque, motors off: 0x07FF x3 then the idle control word 0x53C0, zeros.
        let idle = encode_output(&OmniOutput {
            motors: [MOTOR_ZERO; 3],
            motors_on: false,
            dock_flash: false,
        });
        assert_eq!(
            idle,
            [0xFF, 0x07, 0xFF, 0x07, 0xFF, 0x07, 0xC0, 0x53, 0, 0, 0, 0, 0, 0, 0, 0]
        );
        let on = OmniOutput {
            motors: [0x0800, 0x0000, 0x0FFF],
            motors_on: true,
            dock_flash: true,
        };
        let p = encode_output(&on);
        assert_eq!(&p[..8], &[0x00, 0x08, 0x00, 0x00, 0xFF, 0x0F, 0xC9, 0x53]);
        assert_eq!(decode_output(&p), on);
        assert_eq!(motor_value(0.0), 0x07FF);
        assert_eq!(motor_value(1e9), 0x0FFF);
        assert_eq!(motor_value(-1e9), 0);
        assert_eq!(motor_value(f64::NAN), 0x07FF);
    }
}
