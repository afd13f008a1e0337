//! Novint Falcon over USB: FTDI set-up, firmware upload, 16-byte frames, kinematics.
//!
//! The Falcon is an FTDI FT232 (USB 0403:cb48, bulk OUT 0x02, IN 0x81) in front of a
//! microcontroller that runs no firmware until the host uploads one. The firmware file comes
//! from the user (Novint's `novint.bin` or libnifalcon's test firmware); none is bundled.
//!
//! Everything goes through [`Transport`], so the whole session is testable with
//! [`mock::MockTransport`]; [`usb::RusbTransport`] is the real one. A transport may offer a
//! second path to the OUT endpoint ([`Transport::out_path`]: the USB handle is shared, libusb's
//! synchronous transfers are thread-safe); the device then has a
//! [`MotorCutoff`](crate::cutoff::MotorCutoff) that sends a zero-motor frame through it.

pub mod frame;
pub mod ftdi;
pub mod kinematics;
pub mod mock;
pub mod usb;

use std::sync::Arc;

use crate::cutoff::{MotorCutoff, OutPath, PacketCutoff};
use crate::device::{
    DeviceError, DeviceKind, DeviceSpec, DeviceState, ForceCommand, HapticDevice, Vec3,
    QUAT_IDENTITY,
};
use crate::safety::{ForceSafety, SafetyConfig};
use frame::{encode_command, FalconCommand, FrameAssembler};
use ftdi::*;

/// USB vendor id (FTDI).
pub const VENDOR_ID: u16 = 0x0403;
/// USB product id (Novint Falcon).
pub const PRODUCT_ID: u16 = 0xcb48;
/// Firmware upload chunk size, bytes.
pub const FIRMWARE_CHUNK: usize = 128;

/// A byte pipe to an FTDI chip: vendor control requests and bulk transfers.
pub trait Transport {
    /// A vendor OUT control request (bmRequestType 0x40) with no data stage.
    fn control_out(&mut self, request: u8, value: u16, index: u16) -> Result<(), DeviceError>;
    /// Writes to bulk endpoint 0x02; returns bytes written.
    fn bulk_write(&mut self, data: &[u8], timeout_ms: u32) -> Result<usize, DeviceError>;
    /// Reads one packet from bulk endpoint 0x81 (at most 64 bytes, starting with the FT232's
    /// two modem-status bytes); returns bytes read.
    fn bulk_read(&mut self, buf: &mut [u8], timeout_ms: u32) -> Result<usize, DeviceError>;
    /// A second way to bulk endpoint 0x02 that another thread may use while this transport is
    /// in a call on the servo thread (`None`, the default: there is none).
    fn out_path(&self) -> Option<Arc<dyn OutPath>> {
        None
    }
}

/// Falcon settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FalconConfig {
    /// Motor command units per N m (libnifalcon uses 10 000, sign inverted).
    pub command_per_newton_metre: f64,
    /// Largest motor command magnitude sent (direction-preserving scaling above it).
    pub max_command: i16,
    /// Safety settings (clamp to the Falcon's 8 N).
    pub safety: SafetyConfig,
    /// Servo period used for timestamps, s.
    pub period_s: f64,
    /// Transfer timeout, ms.
    pub timeout_ms: u32,
    /// Bulk reads tried per tick before giving up on a frame.
    pub reads_per_tick: u32,
    /// Origin of reported positions in the mechanism frame (subtracted), m.
    pub origin: Vec3,
}

impl Default for FalconConfig {
    fn default() -> FalconConfig {
        FalconConfig {
            command_per_newton_metre: 10_000.0,
            max_command: 4096,
            safety: SafetyConfig::for_max_force(DeviceSpec::FALCON.max_force_n),
            period_s: 1e-3,
            timeout_ms: 100,
            reads_per_tick: 4,
            origin: kinematics::WORKSPACE_CENTRE,
        }
    }
}

/// A Novint Falcon. Open with [`FalconDevice::open_usb`] or over any [`Transport`].
#[derive(Debug)]
pub struct FalconDevice<T> {
    transport: T,
    config: FalconConfig,
    safety: ForceSafety,
    assembler: FrameAssembler,
    tick: u64,
    leds: u8,
    homing: bool,
    homed: u8,
    buttons: u8,
    theta: Vec3,
    position: Vec3,
    sent_since_read: bool,
    connected: bool,
    cut: Option<Arc<PacketCutoff>>,
    cut_look: (u8, bool),
}

/// The frame a cut sends: zero motors with these LED and homing bits.
fn zero_frame(leds: u8, homing: bool) -> [u8; frame::FRAME_LEN] {
    encode_command(&FalconCommand {
        motors: [0; 3],
        leds,
        homing,
    })
}

impl FalconDevice<usb::RusbTransport> {
    /// Opens the first Falcon on USB; [`DeviceError::NotFound`] when none is attached.
    pub fn open_usb(config: FalconConfig) -> Result<Self, DeviceError> {
        Ok(FalconDevice::new(usb::RusbTransport::open()?, config))
    }
}

impl<T: Transport> FalconDevice<T> {
    /// Wraps a transport. Call [`load_firmware`](Self::load_firmware) before the first read
    /// unless the firmware is already running.
    pub fn new(transport: T, config: FalconConfig) -> FalconDevice<T> {
        let cut = transport
            .out_path()
            .map(|out| Arc::new(PacketCutoff::new(out, &zero_frame(frame::LED_RED, true))));
        FalconDevice {
            cut,
            cut_look: (frame::LED_RED, true),
            transport,
            safety: ForceSafety::new(config.safety),
            config,
            assembler: FrameAssembler::new(),
            tick: 0,
            leds: frame::LED_RED,
            homing: true,
            homed: 0,
            buttons: 0,
            theta: [0.0; 3],
            position: [0.0; 3],
            sent_since_read: false,
            connected: true,
        }
    }

    /// The transport (e.g. to inspect a mock).
    pub fn transport(&self) -> &T {
        &self.transport
    }

    /// Sets the LED bits (`frame::LED_*`), sent with the next frame.
    pub fn set_leds(&mut self, leds: u8) {
        self.leds = leds;
    }

    /// Homed flags from the last report (bit i = axis i).
    pub fn homed(&self) -> u8 {
        self.homed
    }

    /// The safety filter (counters).
    pub fn safety(&self) -> &ForceSafety {
        &self.safety
    }

    fn fail(&mut self, e: DeviceError) -> DeviceError {
        if e == DeviceError::Disconnected {
            self.connected = false;
        }
        self.safety.disable();
        e
    }

    fn control(&mut self, step: u8, request: u8, value: u16) -> Result<(), DeviceError> {
        match self.transport.control_out(request, value, 0) {
            Ok(()) => Ok(()),
            Err(DeviceError::Disconnected) => Err(self.fail(DeviceError::Disconnected)),
            Err(_) => Err(DeviceError::FirmwareHandshake { step }),
        }
    }

    /// Reads until `want` data bytes arrived (status bytes stripped) or `tries` reads passed.
    fn read_data(&mut self, out: &mut [u8], tries: u32) -> Result<usize, DeviceError> {
        let mut got = 0;
        let mut packet = [0u8; MAX_PACKET];
        for _ in 0..tries {
            if got >= out.len() {
                break;
            }
            let n = self
                .transport
                .bulk_read(&mut packet, self.config.timeout_ms)?;
            let data = packet.get(STATUS_BYTES..n.min(MAX_PACKET)).unwrap_or(&[]);
            for &b in data {
                if let Some(slot) = out.get_mut(got) {
                    *slot = b;
                    got += 1;
                }
            }
        }
        Ok(got)
    }

    /// Puts the FTDI into loader mode and runs the two-step handshake.
    fn firmware_mode(&mut self) -> Result<(), DeviceError> {
        self.control(1, SIO_RESET, PURGE_RX)?;
        self.control(1, SIO_RESET, PURGE_TX)?;
        self.control(2, SIO_SET_LATENCY_TIMER, 16)?;
        self.control(3, SIO_SET_BAUD_RATE, BAUD_9600)?;
        self.control(3, SIO_SET_DATA, DATA_8N1)?;
        self.control(3, SIO_SET_FLOW_CTRL, 0)?;
        self.control(4, SIO_MODEM_CTRL, RTS_LOW)?;
        self.control(4, SIO_MODEM_CTRL, DTR_LOW)?;
        self.control(4, SIO_MODEM_CTRL, DTR_HIGH)?;
        // Step 5: 0x0a 0x43 0x0d; the loader answers (0x0a 0x44 0x2c 0x0d).
        self.handshake(5, &[0x0a, 0x43, 0x0d])?;
        self.control(6, SIO_MODEM_CTRL, DTR_LOW)?;
        self.control(6, SIO_SET_BAUD_RATE, BAUD_LOADER)?;
        // Step 7: 'A'; the loader answers (0x13 0x41).
        self.handshake(7, &[0x41])
    }

    fn handshake(&mut self, step: u8, send: &[u8]) -> Result<(), DeviceError> {
        let timeout = self.config.timeout_ms;
        match self.transport.bulk_write(send, timeout) {
            Ok(n) if n == send.len() => {}
            Ok(_) => return Err(DeviceError::FirmwareHandshake { step }),
            Err(e) => return Err(self.map_handshake(step, e)),
        }
        let mut reply = [0u8; 4];
        match self.read_data(&mut reply, 4) {
            Ok(n) if n > 0 => Ok(()),
            Ok(_) => Err(DeviceError::FirmwareHandshake { step }),
            Err(e) => Err(self.map_handshake(step, e)),
        }
    }

    fn map_handshake(&mut self, step: u8, e: DeviceError) -> DeviceError {
        if e == DeviceError::Disconnected {
            self.fail(e)
        } else {
            DeviceError::FirmwareHandshake { step }
        }
    }

    /// Uploads `firmware` (the bytes of the user's firmware file): loader handshake, then
    /// 128-byte chunks each echoed back and compared, then normal mode (latency 1 ms,
    /// 1.5 Mbaud).
    pub fn load_firmware(&mut self, firmware: &[u8]) -> Result<(), DeviceError> {
        if firmware.is_empty() {
            return Err(DeviceError::FirmwareFile);
        }
        self.firmware_mode()?;
        let mut echo = [0u8; FIRMWARE_CHUNK];
        for (k, chunk) in firmware.chunks(FIRMWARE_CHUNK).enumerate() {
            let offset = (k * FIRMWARE_CHUNK) as u32;
            let n = self
                .transport
                .bulk_write(chunk, self.config.timeout_ms)
                .map_err(|e| self.fail(e))?;
            if n != chunk.len() {
                return Err(DeviceError::FirmwareMismatch { offset });
            }
            let want = echo
                .get_mut(..chunk.len())
                .ok_or(DeviceError::FirmwareMismatch { offset })?;
            let got = self.read_data(want, 8).map_err(|e| self.fail(e))?;
            if got != chunk.len() || echo.get(..chunk.len()) != Some(chunk) {
                return Err(DeviceError::FirmwareMismatch { offset });
            }
        }
        self.control(8, SIO_SET_LATENCY_TIMER, 1)?;
        self.control(8, SIO_SET_BAUD_RATE, BAUD_NORMAL)?;
        Ok(())
    }

    /// Reads the user's firmware file and uploads it ([`DeviceError::FirmwareFile`] if
    /// unreadable).
    pub fn load_firmware_file(&mut self, path: &std::path::Path) -> Result<(), DeviceError> {
        let bytes = std::fs::read(path).map_err(|_| DeviceError::FirmwareFile)?;
        self.load_firmware(&bytes)
    }

    fn motor_commands(&self, out: &ForceCommand) -> [i16; 3] {
        if !out.enable {
            return [0; 3];
        }
        let mech = [
            self.position[0] + self.config.origin[0],
            self.position[1] + self.config.origin[1],
            self.position[2] + self.config.origin[2],
        ];
        let Some(tau) = kinematics::motor_torques(mech, out.force) else {
            return [0; 3];
        };
        let raw = tau.map(|t| -t * self.config.command_per_newton_metre);
        let limit = f64::from(self.config.max_command.max(0));
        let big = raw.iter().fold(0.0f64, |m, r| m.max(r.abs()));
        let scale = if big > limit && big > 0.0 {
            limit / big
        } else {
            1.0
        };
        raw.map(|r| {
            let v = (r * scale).round();
            if v.is_finite() {
                v.clamp(-limit, limit) as i16
            } else {
                0
            }
        })
    }

    fn latched(&self) -> bool {
        self.cut.as_ref().is_some_and(|c| c.is_cut())
    }

    /// Sends `out`, or zero with the motors off while the cutoff's latch is set. The latch is
    /// looked at again after the frame went out: when a cut came in between, a zero frame
    /// follows, so the last frame the Falcon gets is a zero.
    fn send(&mut self, out: &ForceCommand) -> Result<(), DeviceError> {
        let out = if self.latched() {
            self.safety.disable();
            ForceCommand::OFF
        } else {
            *out
        };
        self.send_frame(&out)?;
        if out.enable && self.latched() {
            self.safety.disable();
            self.send_frame(&ForceCommand::OFF)?;
        }
        Ok(())
    }

    fn send_frame(&mut self, out: &ForceCommand) -> Result<(), DeviceError> {
        let cmd = FalconCommand {
            motors: self.motor_commands(out),
            leds: self.leds,
            homing: self.homing,
        };
        if let Some(c) = &self.cut {
            if self.cut_look != (cmd.leds, cmd.homing) {
                self.cut_look = (cmd.leds, cmd.homing);
                c.set_zero_packet(&zero_frame(cmd.leds, cmd.homing));
            }
        }
        let bytes = encode_command(&cmd);
        match self.transport.bulk_write(&bytes, self.config.timeout_ms) {
            Ok(16) => {
                self.sent_since_read = true;
                Ok(())
            }
            Ok(_) => Err(DeviceError::Timeout),
            Err(e) => Err(self.fail(e)),
        }
    }
}

impl<T: Transport> HapticDevice for FalconDevice<T> {
    fn spec(&self) -> DeviceSpec {
        DeviceSpec::FALCON
    }

    fn read(&mut self) -> Result<DeviceState, DeviceError> {
        if !self.connected {
            return Err(DeviceError::Disconnected);
        }
        let out = self.safety.tick();
        if !self.sent_since_read {
            // The firmware answers each frame: keep the exchange going (zero after a watchdog
            // trip).
            self.send(&out)?;
        }
        self.sent_since_read = false;
        let mut packet = [0u8; MAX_PACKET];
        let mut report = None;
        for _ in 0..self.config.reads_per_tick.max(1) {
            let n = self
                .transport
                .bulk_read(&mut packet, self.config.timeout_ms)
                .map_err(|e| self.fail(e))?;
            let data = packet.get(STATUS_BYTES..n.min(MAX_PACKET)).unwrap_or(&[]);
            if let Some(r) = self.assembler.push(data) {
                report = Some(r);
                break;
            }
        }
        let report = report.ok_or(DeviceError::NoFrame)?;
        self.tick += 1;
        self.buttons = report.buttons;
        self.homed = report.homed;
        if self.homed == 0x7 {
            self.homing = false;
            self.leds = frame::LED_GREEN;
        }
        let theta = report.encoders.map(kinematics::encoder_to_angle);
        let guess = [
            self.position[0] + self.config.origin[0],
            self.position[1] + self.config.origin[1],
            self.position[2] + self.config.origin[2],
        ];
        let mech = kinematics::forward(theta, guess)
            .or_else(|| kinematics::forward(theta, kinematics::WORKSPACE_CENTRE))
            .ok_or_else(|| self.fail(DeviceError::Kinematics))?;
        self.theta = theta;
        self.position = [
            mech[0] - self.config.origin[0],
            mech[1] - self.config.origin[1],
            mech[2] - self.config.origin[2],
        ];
        Ok(DeviceState {
            timestamp_s: self.tick as f64 * self.config.period_s,
            tick: self.tick,
            position: self.position,
            rotation: QUAT_IDENTITY,
            joint_angles: [self.theta[0], self.theta[1], self.theta[2], 0.0, 0.0, 0.0],
            buttons: u32::from(self.buttons),
            docked: false,
        })
    }

    fn write(&mut self, command: &ForceCommand) -> Result<(), DeviceError> {
        if !self.connected {
            return Err(DeviceError::Disconnected);
        }
        let command = if self.latched() {
            &ForceCommand::OFF
        } else {
            command
        };
        match self.safety.filter(command) {
            Ok(out) => self.send(&out),
            Err(e) => {
                // Refused: make sure the motors see zero now.
                self.send(&ForceCommand::OFF)?;
                Err(e)
            }
        }
    }

    fn calibrate(&mut self) -> Result<(), DeviceError> {
        // Homing: the firmware homes each axis as the user moves the grip through the
        // workspace; progress shows in `homed()`. The LED turns green when all three are done.
        self.homing = true;
        self.leds = frame::LED_RED;
        Ok(())
    }

    fn cutoff(&self) -> Option<Arc<dyn MotorCutoff>> {
        self.cut.clone().map(|c| c as Arc<dyn MotorCutoff>)
    }
}

impl<T> FalconDevice<T> {
    /// The device kind.
    pub const KIND: DeviceKind = DeviceKind::Falcon;
}
