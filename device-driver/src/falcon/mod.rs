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
//! [`MotorCutoff`] that sends a zero-motor frame through it.

pub mod frame;
pub mod ftdi;
pub mod homing;
pub mod kinematics;
pub mod mock;
pub mod usb;

use std::sync::Arc;

use crate::cutoff::{MotorCutoff, OutPath, PacketCutoff};
use crate::device::{
    v3, DeviceError, DeviceKind, DeviceSpec, DeviceState, ForceCommand, HapticDevice, Vec3,
    QUAT_IDENTITY,
};
use crate::safety::{ForceSafety, SafetyConfig};
use frame::{encode_command, FalconCommand, FalconReport, FrameAssembler};
use ftdi::*;
use homing::HomingGate;

/// USB vendor id (FTDI).
pub const VENDOR_ID: u16 = 0x0403;
/// USB product id (Novint Falcon).
pub const PRODUCT_ID: u16 = 0xcb48;
/// Firmware upload block size, bytes: libnifalcon's `FalconFirmware::loadFirmware` writes the
/// file in blocks of `READ_SIZE = 62` (a full-speed packet's 64 bytes less the FT232's two
/// status bytes), whatever its comments and `FalconComm.h` say (58, 128).
pub const FIRMWARE_CHUNK: usize = 62;
/// Reads gathered for one block's echo before the try is given up (libnifalcon reads until
/// the block is all back, without a bound).
pub const ECHO_READS: u32 = 8;
/// What the loader sends to `0a 43 0d` (handshake step 5), after the FT232's status bytes:
/// the Linux reading of libnifalcon's `FalconCommLibUSB::setFirmwareMode`.
pub const LOADER_REPLY: [u8; 4] = [0x0a, 0x44, 0x2c, 0x0d];
/// The same reply with the leading zero byte libnifalcon accepts too (its "Apple case").
pub const LOADER_REPLY_LONG: [u8; 5] = [0x00, 0x0a, 0x44, 0x2c, 0x0d];
/// What the loader sends to `41` (handshake step 7): `41` alone (libnifalcon reads 3 bytes,
/// two of them the FT232's status).
pub const LOADER_READY_REPLY: [u8; 1] = [0x41];
/// Bulk reads gathered into one handshake reply before it is compared.
const HANDSHAKE_READS: u32 = 2;

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
    /// Closes the device and opens it again, as libnifalcon's `FalconCLIBase::parseOptions`
    /// does between firmware uploads (`FalconCommLibUSB::close`: release the interface,
    /// close; `open`: open, claim the interface). The FTDI controls that follow an open are
    /// the caller's. The default does nothing (a transport with nothing to reopen).
    fn reopen(&mut self) -> Result<(), DeviceError> {
        Ok(())
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
    /// Time over which the force ramps from zero once all three axes report homed, s
    /// ([`homing::HomingGate`]). Default 0.5 s: the same length as the enable ramp
    /// ([`SafetyConfig::for_max_force`]), so the Falcon's 8 N grows by at most 16 mN per
    /// 1 ms tick after the coordinate jump of homing (libnifalcon `FalconFirmware.h` asks for
    /// no torque before homing; the ramp length is ours). 0: no ramp.
    pub homing_ramp_s: f64,
    /// Tries of the loader's first handshake (send `0a 43 0d`, expect exactly
    /// [`LOADER_REPLY`]), count. Default 100, libnifalcon's
    /// `FalconCommLibUSB::setFirmwareMode`.
    pub handshake_tries: u32,
    /// Whole firmware uploads tried before giving up, count. Default 10, libnifalcon's
    /// `FalconCLIBase::parseOptions`, which closes and reopens the device between tries
    /// ([`Transport::reopen`], then the open's purges and normal mode).
    pub upload_tries: u32,
    /// Timeout of each transfer of the loader (handshakes, firmware blocks and their
    /// echoes), ms. Default 1000, libnifalcon's `FalconCommLibUSB` (`setFirmwareMode`,
    /// `readBlocking`, `writeBlocking`).
    pub loader_timeout_ms: u32,
    /// Ticks in a row without a usable report (no complete frame, or a kinematics solve that
    /// failed) after which [`HapticDevice::read`] gives
    /// [`DeviceError::ReportsLost`]; before that each such tick holds the last position,
    /// counted. Default 20 (20 ms at 1 kHz): ours (libnifalcon holds without a bound).
    pub max_lost_in_row: u32,
    /// Zero-torque frames sent at start-up, each followed by up to `reads_per_tick` reads,
    /// before concluding that no firmware answers, count. Default 10, the outer loop of
    /// libnifalcon's `FalconFirmware::isFirmwareLoaded`.
    pub status_tries: u32,
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
            homing_ramp_s: 0.5,
            handshake_tries: 100,
            upload_tries: 10,
            status_tries: 10,
            loader_timeout_ms: 1000,
            max_lost_in_row: 20,
        }
    }
}

/// A Novint Falcon. Open with [`FalconDevice::open_usb`] or over any [`Transport`], then
/// call [`start`](Self::start). Dropped (or [`stop`](Self::stop)ped) in normal mode, it sends
/// one zero-motor frame.
#[derive(Debug)]
pub struct FalconDevice<T: Transport> {
    transport: T,
    config: FalconConfig,
    safety: ForceSafety,
    gate: HomingGate,
    assembler: FrameAssembler,
    tick: u64,
    leds: u8,
    buttons: u8,
    theta: Vec3,
    position: Vec3,
    sent_since_read: bool,
    connected: bool,
    cut: Option<Arc<PacketCutoff>>,
    cut_leds: u8,
    normal: bool,
    lost: LostReports,
}

/// Counts of ticks that held the last position for want of a usable report.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LostReports {
    /// Ticks with no complete report (a missed frame), in all.
    pub missed_frames: u64,
    /// Ticks whose report gave no position (forward kinematics failed), in all.
    pub failed_solves: u64,
    /// Ticks without a usable report in the current run of them (0 after a good one).
    pub in_row: u32,
    /// The longest such run seen.
    pub longest_in_row: u32,
}

/// The frame a cut sends: zero motors with these LED bits and the homing bit.
fn zero_frame(leds: u8) -> [u8; frame::FRAME_LEN] {
    encode_command(&FalconCommand {
        motors: [0; 3],
        leds,
        homing: true,
    })
}

impl FalconDevice<usb::RusbTransport> {
    /// Opens the first Falcon on USB; [`DeviceError::NotFound`] when none is attached.
    /// Call [`start`](Self::start) before the first read.
    pub fn open_usb(config: FalconConfig) -> Result<Self, DeviceError> {
        Ok(FalconDevice::new(usb::RusbTransport::open()?, config))
    }
}

impl<T: Transport> FalconDevice<T> {
    /// Wraps a transport. Call [`start`](Self::start) (normal mode, the firmware upload when
    /// one is given, a status round trip) before the first read.
    pub fn new(transport: T, config: FalconConfig) -> FalconDevice<T> {
        let cut = transport
            .out_path()
            .map(|out| Arc::new(PacketCutoff::new(out, &zero_frame(frame::LED_RED))));
        FalconDevice {
            cut,
            cut_leds: frame::LED_RED,
            transport,
            safety: ForceSafety::new(config.safety),
            gate: HomingGate::new(HomingGate::ramp_ticks_for(
                config.homing_ramp_s,
                config.period_s,
            )),
            config,
            assembler: FrameAssembler::new(),
            tick: 0,
            leds: frame::LED_RED,
            buttons: 0,
            theta: [0.0; 3],
            position: [0.0; 3],
            sent_since_read: false,
            connected: true,
            normal: false,
            lost: LostReports::default(),
        }
    }

    /// Ticks that held the last position for want of a usable report (missed frames,
    /// failed kinematics solves).
    pub fn lost_reports(&self) -> LostReports {
        self.lost
    }

    /// Sends one zero-motor frame (the current LEDs, the homing bit) and turns the force off
    /// until the next enabled write ramps it in again. Only in normal mode (at the loader's
    /// baud rate a frame would be taken for firmware); a transfer error is ignored (the
    /// device may be gone). Also run on drop.
    pub fn stop(&mut self) {
        self.safety.disable();
        if self.connected && self.normal {
            let zero = zero_frame(self.leds);
            if self
                .transport
                .bulk_write(&zero, self.config.timeout_ms)
                .is_ok()
            {
                self.sent_since_read = true;
            }
        }
    }

    /// The transport (e.g. to inspect a mock).
    pub fn transport(&self) -> &T {
        &self.transport
    }

    /// The transport, mutable (e.g. to change what a mock reports between ticks).
    pub fn transport_mut(&mut self) -> &mut T {
        &mut self.transport
    }

    /// Sets the LED bits (`frame::LED_*`), sent with the next frame. The device sets red
    /// itself when homing is lost and green when it completes.
    pub fn set_leds(&mut self, leds: u8) {
        self.leds = leds;
    }

    /// Homed flags from the last report (bit i = axis i).
    pub fn homed(&self) -> u8 {
        self.gate.homed()
    }

    /// The homing gate: the factor applied to the force, the position resets.
    pub fn homing_gate(&self) -> &HomingGate {
        &self.gate
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

    /// Puts the FTDI into loader mode and runs the two-step handshake.
    fn firmware_mode(&mut self) -> Result<(), DeviceError> {
        self.normal = false;
        self.control(1, SIO_RESET, PURGE_RX)?;
        self.control(1, SIO_RESET, PURGE_TX)?;
        self.control(2, SIO_SET_LATENCY_TIMER, 16)?;
        self.control(3, SIO_SET_BAUD_RATE, BAUD_9600)?;
        self.control(3, SIO_SET_DATA, DATA_8N1)?;
        self.control(3, SIO_SET_FLOW_CTRL, 0)?;
        self.control(4, SIO_MODEM_CTRL, RTS_LOW)?;
        self.control(4, SIO_MODEM_CTRL, DTR_LOW)?;
        self.control(4, SIO_MODEM_CTRL, DTR_HIGH)?;
        // Step 5: 0a 43 0d until the loader answers exactly 0a 44 2c 0d (or with a leading 00).
        let tries = self.config.handshake_tries.max(1);
        self.handshake(
            5,
            &[0x0a, 0x43, 0x0d],
            &[&LOADER_REPLY, &LOADER_REPLY_LONG],
            tries,
        )?;
        self.control(6, SIO_MODEM_CTRL, DTR_LOW)?;
        self.control(6, SIO_SET_BAUD_RATE, BAUD_LOADER)?;
        // Step 7: 'A', answered by 41 alone. One try, as libnifalcon: at the loader's baud
        // rate a second 'A' could be taken for firmware; the whole upload is retried instead.
        self.handshake(7, &[0x41], &[&LOADER_READY_REPLY], 1)
    }

    /// Sends `send` and compares the reply exactly with each of `accept`, up to `tries`
    /// times. A reply is the data of up to [`HANDSHAKE_READS`] reads, stopping at an empty
    /// read or as soon as it matches.
    fn handshake(
        &mut self,
        step: u8,
        send: &[u8],
        accept: &[&[u8]],
        tries: u32,
    ) -> Result<(), DeviceError> {
        let timeout = self.config.loader_timeout_ms;
        let longest = accept.iter().map(|a| a.len()).max().unwrap_or(0);
        for _ in 0..tries {
            match self.transport.bulk_write(send, timeout) {
                Ok(n) if n == send.len() => {}
                Ok(_) => continue,
                Err(e) => return Err(self.map_handshake(step, e)),
            }
            let mut reply = [0u8; MAX_PACKET];
            let mut len = 0;
            let mut packet = [0u8; MAX_PACKET];
            for _ in 0..HANDSHAKE_READS {
                let n = match self.transport.bulk_read(&mut packet, timeout) {
                    Ok(n) => n,
                    Err(e) => return Err(self.map_handshake(step, e)),
                };
                let data = packet.get(STATUS_BYTES..n.min(MAX_PACKET)).unwrap_or(&[]);
                for (slot, b) in reply.iter_mut().skip(len).zip(data) {
                    *slot = *b;
                }
                len = (len + data.len()).min(MAX_PACKET);
                let got = reply.get(..len).unwrap_or(&[]);
                if data.is_empty() || len >= longest || accept.contains(&got) {
                    break;
                }
            }
            if accept.contains(&reply.get(..len).unwrap_or(&[])) {
                return Ok(());
            }
        }
        Err(DeviceError::FirmwareHandshake { step })
    }

    fn map_handshake(&mut self, step: u8, e: DeviceError) -> DeviceError {
        if e == DeviceError::Disconnected {
            self.fail(e)
        } else {
            DeviceError::FirmwareHandshake { step }
        }
    }

    /// Normal mode, as libnifalcon's `FalconCommLibUSB::setNormalMode` sets it after an
    /// upload and on every open: latency timer 1 ms, divisor 2 (1.5 Mbaud nominal), purge RX
    /// and TX. Part of [`start`](Self::start); needed also when no firmware is uploaded (the
    /// chip may still be at the loader's settings).
    pub fn normal_mode(&mut self) -> Result<(), DeviceError> {
        self.control(8, SIO_SET_LATENCY_TIMER, 1)?;
        self.control(8, SIO_SET_BAUD_RATE, BAUD_NORMAL)?;
        self.control(8, SIO_RESET, PURGE_RX)?;
        self.control(8, SIO_RESET, PURGE_TX)?;
        self.assembler = FrameAssembler::new();
        self.sent_since_read = false;
        self.normal = true;
        Ok(())
    }

    /// Closes and reopens the device, then what libnifalcon's `FalconCommLibUSB::open` sends
    /// on every open: purge RX, purge TX, then [`normal_mode`](Self::normal_mode). The second
    /// path to the motors is taken again from the reopened transport.
    fn reopen(&mut self) -> Result<(), DeviceError> {
        self.normal = false;
        // The cutoff's path may share the transport's handle: let go of it first.
        self.cut = None;
        let reopened = self.transport.reopen();
        self.cut = self
            .transport
            .out_path()
            .map(|out| Arc::new(PacketCutoff::new(out, &zero_frame(self.cut_leds))));
        reopened.map_err(|e| self.fail(e))?;
        self.control(1, SIO_RESET, PURGE_RX)?;
        self.control(1, SIO_RESET, PURGE_TX)?;
        self.normal_mode()
    }

    /// One firmware upload (the bytes of the user's firmware file), as libnifalcon's
    /// `FalconFirmware::loadFirmware` runs it: loader handshake, then blocks of
    /// [`FIRMWARE_CHUNK`] (62) bytes, each written once and read back until all of it came
    /// (at most [`ECHO_READS`] reads), every read compared byte for byte with the file at its
    /// place, then [`normal_mode`](Self::normal_mode). Every transfer of it waits up to
    /// `loader_timeout_ms`. [`upload_firmware`](Self::upload_firmware) retries it.
    pub fn load_firmware(&mut self, firmware: &[u8]) -> Result<(), DeviceError> {
        if firmware.is_empty() {
            return Err(DeviceError::FirmwareFile);
        }
        self.firmware_mode()?;
        let timeout = self.config.loader_timeout_ms;
        let mut packet = [0u8; MAX_PACKET];
        for (k, block) in firmware.chunks(FIRMWARE_CHUNK).enumerate() {
            let offset = (k * FIRMWARE_CHUNK) as u32;
            let mismatch = DeviceError::FirmwareMismatch { offset };
            let n = self
                .transport
                .bulk_write(block, timeout)
                .map_err(|e| self.fail(e))?;
            if n != block.len() {
                return Err(mismatch);
            }
            let mut back = 0;
            for _ in 0..ECHO_READS {
                if back >= block.len() {
                    break;
                }
                let n = self
                    .transport
                    .bulk_read(&mut packet, timeout)
                    .map_err(|e| self.fail(e))?;
                let data = packet.get(STATUS_BYTES..n.min(MAX_PACKET)).unwrap_or(&[]);
                let want = block.get(back..).unwrap_or(&[]);
                if data.len() > want.len() || want.get(..data.len()) != Some(data) {
                    return Err(mismatch);
                }
                back += data.len();
            }
            if back != block.len() {
                return Err(mismatch);
            }
        }
        self.normal_mode()
    }

    /// [`load_firmware`](Self::load_firmware) up to `upload_tries` times; the last error
    /// when every try failed. Between tries the device is closed and reopened, with the
    /// open's purges and normal mode, as libnifalcon's `FalconCLIBase::parseOptions` does
    /// after a failed try. A disconnect or an empty file ends the tries at once.
    ///
    /// # Bounded work
    /// At most `upload_tries` uploads, each at most `handshake_tries` + 1 handshakes and one
    /// write and [`ECHO_READS`] reads per 62-byte block.
    pub fn upload_firmware(&mut self, firmware: &[u8]) -> Result<(), DeviceError> {
        let mut last = DeviceError::FirmwareFile;
        for k in 0..self.config.upload_tries.max(1) {
            if k > 0 {
                self.reopen()?;
            }
            match self.load_firmware(firmware) {
                Ok(()) => return Ok(()),
                Err(e @ (DeviceError::Disconnected | DeviceError::FirmwareFile)) => return Err(e),
                Err(e) => last = e,
            }
        }
        Err(last)
    }

    /// Checks that a firmware answers: sends a zero-torque frame (red LED, homing bit) and
    /// reads up to `reads_per_tick` times for a valid report, up to `status_tries` frames.
    /// [`DeviceError::FirmwareNotRunning`] when none came back. The report's homed bits feed
    /// the homing gate.
    ///
    /// # Bounded work
    /// At most `status_tries` frames and `status_tries * reads_per_tick` reads.
    pub fn check_firmware(&mut self) -> Result<(), DeviceError> {
        let zero = zero_frame(self.leds);
        for _ in 0..self.config.status_tries.max(1) {
            match self.transport.bulk_write(&zero, self.config.timeout_ms) {
                Ok(_) => {}
                Err(DeviceError::Disconnected) => return Err(self.fail(DeviceError::Disconnected)),
                // A frame that did not go out (a timeout): the next try sends it again.
                Err(_) => continue,
            }
            if let Some(report) = self.read_report()? {
                self.take_homing(&report);
                self.sent_since_read = false;
                return Ok(());
            }
        }
        Err(DeviceError::FirmwareNotRunning)
    }

    /// Reads up to `reads_per_tick` packets until the assembler completes a report; `None`
    /// when none completed. A transfer error fails the device (and is returned).
    ///
    /// # Bounded work
    /// At most `reads_per_tick` bulk reads.
    fn read_report(&mut self) -> Result<Option<FalconReport>, DeviceError> {
        let mut packet = [0u8; MAX_PACKET];
        for _ in 0..self.config.reads_per_tick.max(1) {
            let n = self
                .transport
                .bulk_read(&mut packet, self.config.timeout_ms)
                .map_err(|e| self.fail(e))?;
            let data = packet.get(STATUS_BYTES..n.min(MAX_PACKET)).unwrap_or(&[]);
            if let Some(report) = self.assembler.push(data) {
                return Ok(Some(report));
            }
        }
        Ok(None)
    }

    /// Start-up: with `firmware`, [`upload_firmware`](Self::upload_firmware) (which ends in
    /// normal mode); without, [`normal_mode`](Self::normal_mode) alone. Then
    /// [`check_firmware`](Self::check_firmware): the status round trip.
    pub fn start(&mut self, firmware: Option<&[u8]>) -> Result<(), DeviceError> {
        match firmware {
            Some(bytes) => self.upload_firmware(bytes)?,
            None => self.normal_mode()?,
        }
        self.check_firmware()
    }

    /// [`start`](Self::start) with the user's firmware file, when given
    /// ([`DeviceError::FirmwareFile`] if unreadable).
    pub fn start_with_file(
        &mut self,
        firmware: Option<&std::path::Path>,
    ) -> Result<(), DeviceError> {
        match firmware {
            Some(path) => {
                let bytes = std::fs::read(path).map_err(|_| DeviceError::FirmwareFile)?;
                self.start(Some(&bytes))
            }
            None => self.start(None),
        }
    }

    /// Reads the user's firmware file and uploads it once ([`DeviceError::FirmwareFile`] if
    /// unreadable).
    pub fn load_firmware_file(&mut self, path: &std::path::Path) -> Result<(), DeviceError> {
        let bytes = std::fs::read(path).map_err(|_| DeviceError::FirmwareFile)?;
        self.load_firmware(&bytes)
    }

    /// Feeds a report's homed bits to the gate; the LEDs follow: red while not homed, green
    /// once homed.
    fn take_homing(&mut self, report: &FalconReport) {
        let was = self.gate.all_homed();
        self.gate.update(report.homed);
        match (was, self.gate.all_homed()) {
            (false, true) => self.leds = frame::LED_GREEN,
            (true, false) => self.leds = frame::LED_RED,
            _ => {}
        }
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
        // The homing gate: zero until all three axes are homed, then the ramp.
        let gated = ForceCommand {
            force: v3::scale(out.force, self.gate.scale()),
            ..*out
        };
        let cmd = FalconCommand {
            motors: self.motor_commands(&gated),
            leds: self.leds,
            // libnifalcon `FalconFirmware.h`: the homing bit "must be set in each input packet
            // sent in order for the falcon to stay homed".
            homing: true,
        };
        if let Some(c) = &self.cut {
            if self.cut_leds != cmd.leds {
                self.cut_leds = cmd.leds;
                c.set_zero_packet(&zero_frame(cmd.leds));
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
        self.tick += 1;
        let held = match self.read_report()? {
            Some(report) => {
                self.buttons = report.buttons;
                self.take_homing(&report);
                let theta = report.encoders.map(kinematics::encoder_to_angle);
                let guess = [
                    self.position[0] + self.config.origin[0],
                    self.position[1] + self.config.origin[1],
                    self.position[2] + self.config.origin[2],
                ];
                match kinematics::forward(theta, guess)
                    .or_else(|| kinematics::forward(theta, kinematics::WORKSPACE_CENTRE))
                {
                    Some(mech) => {
                        self.theta = theta;
                        self.position = [
                            mech[0] - self.config.origin[0],
                            mech[1] - self.config.origin[1],
                            mech[2] - self.config.origin[2],
                        ];
                        false
                    }
                    None => {
                        self.lost.failed_solves += 1;
                        true
                    }
                }
            }
            None => {
                self.lost.missed_frames += 1;
                true
            }
        };
        if held {
            // libnifalcon's `FalconDevice::runIOLoop` keeps the last position when a frame is
            // missing or the kinematics fail; here only for a bounded run of ticks.
            self.lost.in_row = self.lost.in_row.saturating_add(1);
            self.lost.longest_in_row = self.lost.longest_in_row.max(self.lost.in_row);
            if self.lost.in_row >= self.config.max_lost_in_row.max(1) {
                let in_row = self.lost.in_row;
                self.stop();
                return Err(self.fail(DeviceError::ReportsLost { in_row }));
            }
        } else {
            self.lost.in_row = 0;
        }
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
        // Homing: every frame carries the homing bit, and the firmware homes each axis as the
        // user pulls the grip all the way out and pushes it in; progress shows in `homed()`,
        // the LED turns green when all three are done. Nothing more to ask for.
        if !self.gate.all_homed() {
            self.leds = frame::LED_RED;
        }
        Ok(())
    }

    fn cutoff(&self) -> Option<Arc<dyn MotorCutoff>> {
        self.cut.clone().map(|c| c as Arc<dyn MotorCutoff>)
    }

    fn position_resets(&self) -> u64 {
        self.gate.position_resets()
    }

    fn force_ready(&self) -> bool {
        self.gate.all_homed()
    }
}

impl<T: Transport> FalconDevice<T> {
    /// The device kind.
    pub const KIND: DeviceKind = DeviceKind::Falcon;
}

impl<T: Transport> Drop for FalconDevice<T> {
    fn drop(&mut self) {
        self.stop();
    }
}
