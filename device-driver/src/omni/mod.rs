//! SensAble PHANTOM Omni. The original Omni is an IEEE-1394 (FireWire) device, not USB.
//!
//! The protocol is the publicly reverse-engineered one: identification by the vendor OUI in the
//! configuration ROM, a few register writes to start isochronous streaming on two channels the
//! transport holds at the bus's isochronous resource manager, 44-byte input packets and 16-byte
//! output packets ([`packet`]), 15000 encoder counts per joint revolution, and the arm
//! kinematics of [`kinematics`]. Every device constant (encoder signs, the joint-3 coupling,
//! the gimbal's gains and offsets, the DAC scale, link lengths, dock pose) is a field of
//! [`OmniConfig`]; docs/devices/omni.toml ships them with their public sources.
//!
//! Safety specific to the Omni: no force before the inkwell calibration
//! ([`HapticDevice::calibrate`] with the stylus docked); after a bus reset the start-up is
//! redone and the device stays force-free until a complete packet continues the encoder counts
//! (a jump drops the calibration); dropping the device turns the motors off and clears the
//! isochronous-enable bit of [`REG_CONTROL`]. Everything goes through [`FirewireTransport`]:
//! this codec has no `unsafe`; the Linux firewire-cdev transport (ioctls) is
//! `os::firewire::CdevFirewire` (feature `os`); [`mock::MockFirewire`] drives the tests.
//! A transport may offer a second path for output packets ([`FirewireTransport::out_path`]);
//! the device then has a [`MotorCutoff`] that sends a motors-off
//! packet through it.

pub mod kinematics;
pub mod mock;
pub mod packet;

use std::sync::Arc;

use crate::cutoff::{MotorCutoff, OutPath, PacketCutoff};
use crate::device::{DeviceError, DeviceSpec, DeviceState, ForceCommand, HapticDevice, Quat, Vec3};
use crate::safety::{ForceSafety, SafetyConfig};
use packet::{OmniInput, OmniOutput, INPUT_LEN, OUTPUT_LEN};

/// Configuration-ROM quadlet holding the vendor OUI (upper 24 bits).
pub const REG_VENDOR: u64 = 0x1006_000c;
/// Configuration-ROM quadlet holding the serial number.
pub const REG_SERIAL: u64 = 0x1006_0010;
/// SensAble's OUI as it reads from [`REG_VENDOR`] (low byte masked).
pub const SENSABLE_OUI: u32 = 0x000b_9900;
/// Register: the isochronous channel the host transmits on (the Omni listens there for
/// motor packets).
pub const REG_XMIT_CHANNEL: u64 = 0x1000;
/// Register: the isochronous channel the host receives on (the Omni sends its input packets
/// there).
pub const REG_RECV_CHANNEL: u64 = 0x1001;
/// Status register that reads 0xC0 when ready.
pub const REG_STATUS_A: u64 = 0x1083;
/// Status register that reads 0x00 when ready.
pub const REG_STATUS_B: u64 = 0x1082;
/// Control register; bit 3 enables isochronous transfer.
pub const REG_CONTROL: u64 = 0x1087;
/// [`REG_CONTROL`] bit enabling isochronous transfer.
pub const CONTROL_ENABLE_ISO: u8 = 0x08;
/// Quadlet register the public ROS driver writes at start-up (meaning unknown).
pub const REG_STARTUP_QUADLET: u64 = 0x2_0010;
/// The value written to [`REG_STARTUP_QUADLET`].
pub const STARTUP_QUADLET: u32 = 0xf80f_0000;
/// Largest encoder step, counts, accepted between the last packet before a bus reset and the
/// first after it (1/8 revolution); a larger one means the counters restarted and the
/// calibration is dropped.
pub const MAX_RESYNC_STEP: i64 = 1875;
/// Complete input packets after a bus reset during which the motors stay off (the first one
/// is checked against [`MAX_RESYNC_STEP`]); the force ramps up again after them.
pub const RESYNC_PACKETS: u32 = 4;

/// Access to one FireWire node: asynchronous register reads/writes, the isochronous channels
/// and the two isochronous streams.
pub trait FirewireTransport {
    /// Reads a 32-bit quadlet at a node address.
    fn read_quadlet(&mut self, address: u64) -> Result<u32, DeviceError>;
    /// Writes a 32-bit quadlet at a node address.
    fn write_quadlet(&mut self, address: u64, value: u32) -> Result<(), DeviceError>;
    /// Reads one byte register.
    fn read_byte(&mut self, address: u64) -> Result<u8, DeviceError>;
    /// Writes one byte register.
    fn write_byte(&mut self, address: u64, value: u8) -> Result<(), DeviceError>;
    /// The isochronous channels `(host receives, host transmits)` this transport holds at the
    /// bus's isochronous resource manager (allocated there, never assumed free); an error when
    /// the manager granted none.
    fn channels(&mut self) -> Result<(u8, u8), DeviceError>;
    /// Whether the bus was reset since the last call (each reset is reported once).
    fn take_bus_reset(&mut self) -> bool;
    /// Receives one isochronous input packet; returns its length (44 when complete).
    fn receive(&mut self, packet: &mut [u8; INPUT_LEN]) -> Result<usize, DeviceError>;
    /// Transmits one isochronous output packet.
    fn transmit(&mut self, packet: &[u8; OUTPUT_LEN]) -> Result<(), DeviceError>;
    /// A second way to transmit output packets that another thread may use while this
    /// transport is in a call on the servo thread (`None`, the default: there is none).
    fn out_path(&self) -> Option<Arc<dyn OutPath>> {
        None
    }
}

/// The output packet of a cut: zero torque, motors off.
pub fn motors_off_packet() -> [u8; OUTPUT_LEN] {
    packet::encode_output(&OmniOutput {
        motors: [packet::MOTOR_ZERO; 3],
        motors_on: false,
        dock_flash: false,
    })
}

/// Omni constants and settings. docs/devices/omni.toml holds every default with its public
/// source (or says there is none and why the value was chosen); `--device-config FILE` reads
/// another.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OmniConfig {
    /// Joint angles at the inkwell (dock) pose, rad, in the convention of [`kinematics`].
    pub dock_angles: Vec3,
    /// Encoder direction per arm joint (+1 or -1).
    pub encoder_sign: Vec3,
    /// Joint 3 is `encoder_sign[2] * raw3 + joint3_coupling * t2 + offset`: how much of joint
    /// 2's angle the third encoder's reading must be corrected by to give the forearm angle of
    /// [`kinematics`] (which is measured from the vertical, not from the upper arm).
    pub joint3_coupling: f64,
    /// Encoder counts per joint revolution.
    pub counts_per_rev: f64,
    /// DAC counts per N m per motor, sign included.
    pub dac_per_newton_metre: Vec3,
    /// Gimbal angle per unit of the ratio `a / (a + b)` of its two channels, rad.
    pub gimbal_gain: Vec3,
    /// Gimbal angle at a ratio of zero, rad.
    pub gimbal_offset: Vec3,
    /// Upper-arm and forearm lengths `[l1, l2]`, m.
    pub link_lengths_m: [f64; 2],
    /// Write [`STARTUP_QUADLET`] to [`REG_STARTUP_QUADLET`] at start-up.
    pub startup_quadlet: bool,
    /// Servo period for timestamps, s.
    pub period_s: f64,
    /// Safety settings (clamp to the Omni's 3.3 N).
    pub safety: SafetyConfig,
}

impl Default for OmniConfig {
    fn default() -> OmniConfig {
        OmniConfig {
            dock_angles: [0.0; 3],
            encoder_sign: [1.0, -1.0, 1.0],
            joint3_coupling: 0.0,
            counts_per_rev: packet::COUNTS_PER_REV,
            dac_per_newton_metre: [4096.0, -4096.0, 4096.0],
            gimbal_gain: [-5.48, -10.032, 4.76],
            gimbal_offset: [2.785_367_101_673_835, 6.122_318_371_585_03, -2.385],
            link_lengths_m: [kinematics::L1, kinematics::L2],
            startup_quadlet: true,
            period_s: 1e-3,
            safety: SafetyConfig::for_max_force(DeviceSpec::OMNI.max_force_n),
        }
    }
}

/// A PHANTOM Omni over a [`FirewireTransport`].
#[derive(Debug)]
pub struct OmniDevice<T: FirewireTransport> {
    transport: T,
    config: OmniConfig,
    safety: ForceSafety,
    serial: u32,
    channels: (u8, u8),
    tick: u64,
    raw: [u16; 3],
    counts: [i64; 3],
    started: bool,
    calibrated: bool,
    resync: u32,
    bus_resets: u64,
    offsets: Vec3,
    joints: Vec3,
    gimbal: Vec3,
    input: OmniInput,
    sent_since_read: bool,
    connected: bool,
    cut: Option<Arc<PacketCutoff>>,
}

fn check(t: &mut impl FirewireTransport, address: u64, expected: u8) -> Result<(), DeviceError> {
    let found = t.read_byte(address)?;
    if found != expected {
        return Err(DeviceError::RegisterCheck {
            address: address as u32,
            expected,
            found,
        });
    }
    Ok(())
}

/// The published start-up sequence on channels `(rx, tx)`: the receive channel written, read
/// back, bit 6 tested and restored; the status registers checked; the transmit channel; the
/// start-up quadlet; the isochronous-enable bit of [`REG_CONTROL`] set.
fn start_up(
    t: &mut impl FirewireTransport,
    (rc, tc): (u8, u8),
    quadlet: bool,
) -> Result<(), DeviceError> {
    t.write_byte(REG_RECV_CHANNEL, rc)?;
    check(t, REG_RECV_CHANNEL, rc)?;
    t.write_byte(REG_RECV_CHANNEL, 0x40)?;
    check(t, REG_RECV_CHANNEL, 0x40)?;
    t.write_byte(REG_RECV_CHANNEL, rc)?;
    check(t, REG_STATUS_A, 0xC0)?;
    check(t, REG_STATUS_B, 0x00)?;
    t.write_byte(REG_XMIT_CHANNEL, tc)?;
    check(t, REG_STATUS_A, 0xC0)?;
    check(t, REG_STATUS_B, 0x00)?;
    if quadlet {
        t.write_quadlet(REG_STARTUP_QUADLET, STARTUP_QUADLET)?;
    }
    let control = t.read_byte(REG_CONTROL)?;
    if control & CONTROL_ENABLE_ISO == 0 {
        t.write_byte(REG_CONTROL, control | CONTROL_ENABLE_ISO)?;
    }
    Ok(())
}

impl<T: FirewireTransport> OmniDevice<T> {
    /// Identifies the node (SensAble OUI), takes the transport's channels and starts streaming
    /// with the published register sequence. The device is uncalibrated: it renders no force
    /// until [`HapticDevice::calibrate`] succeeds with the stylus docked.
    pub fn start(mut transport: T, config: OmniConfig) -> Result<OmniDevice<T>, DeviceError> {
        let vendor = transport.read_quadlet(REG_VENDOR)?;
        if vendor & 0xFFFF_FF00 != SENSABLE_OUI {
            return Err(DeviceError::WrongDevice { found: vendor });
        }
        let serial = transport.read_quadlet(REG_SERIAL)?;
        let channels = transport.channels()?;
        start_up(&mut transport, channels, config.startup_quadlet)?;
        // A reset that came during the start-up is answered by the start-up itself.
        let _ = transport.take_bus_reset();
        let cut = transport
            .out_path()
            .map(|out| Arc::new(PacketCutoff::new(out, &motors_off_packet())));
        Ok(OmniDevice {
            cut,
            transport,
            safety: ForceSafety::new(config.safety),
            config,
            serial,
            channels,
            tick: 0,
            raw: [0; 3],
            counts: [0; 3],
            started: false,
            calibrated: false,
            resync: 0,
            bus_resets: 0,
            offsets: [0.0; 3],
            joints: [0.0; 3],
            gimbal: [0.0; 3],
            input: OmniInput::default(),
            sent_since_read: false,
            connected: true,
        })
    }

    /// Serial number read at start-up.
    pub fn serial(&self) -> u32 {
        self.serial
    }

    /// The isochronous channels `(host receives, host transmits)` written to the Omni.
    pub fn channels(&self) -> (u8, u8) {
        self.channels
    }

    /// Whether the inkwell calibration has been done (force is rendered only then).
    pub fn is_calibrated(&self) -> bool {
        self.calibrated
    }

    /// Bus resets answered by redoing the start-up.
    pub fn bus_resets(&self) -> u64 {
        self.bus_resets
    }

    /// The last input packet, decoded (raw encoder counts, gimbal channels, buttons, dock).
    pub fn last_input(&self) -> OmniInput {
        self.input
    }

    /// The transport (e.g. to inspect a mock).
    pub fn transport(&self) -> &T {
        &self.transport
    }

    /// The safety filter (counters).
    pub fn safety(&self) -> &ForceSafety {
        &self.safety
    }

    /// Turns the motors off and clears the isochronous-enable bit of [`REG_CONTROL`] (the
    /// public drivers' stop); also done when the device is dropped. Afterwards every read is
    /// `Disconnected`.
    ///
    /// # Bounded work
    /// One output packet and two register requests, each bounded by the transport's timeout.
    pub fn stop(&mut self) -> Result<(), DeviceError> {
        if !self.connected {
            return Ok(());
        }
        self.connected = false;
        self.safety.disable();
        let off = motors_off_packet();
        let sent = self.transport.transmit(&off);
        let control = self.transport.read_byte(REG_CONTROL)?;
        self.transport
            .write_byte(REG_CONTROL, control & !CONTROL_ENABLE_ISO)?;
        sent
    }

    fn fail(&mut self, e: DeviceError) -> DeviceError {
        if e == DeviceError::Disconnected {
            self.connected = false;
        }
        self.safety.disable();
        e
    }

    fn latched(&self) -> bool {
        self.cut.as_ref().is_some_and(|c| c.is_cut())
    }

    /// Whether force may reach the motors: calibrated, and no bus reset waiting for a packet.
    fn force_allowed(&self) -> bool {
        self.calibrated && self.resync == 0 && !self.latched()
    }

    /// Sends `out`, or motors off while force is not allowed (uncalibrated, after a bus reset,
    /// the cutoff's latch set). The latch is looked at again after the packet was queued: when
    /// a cut came in between, a motors-off packet follows.
    fn send(&mut self, out: &ForceCommand) -> Result<(), DeviceError> {
        let out = if self.force_allowed() {
            *out
        } else {
            self.safety.disable();
            ForceCommand::OFF
        };
        self.send_packet(&out)?;
        if out.enable && self.latched() {
            self.safety.disable();
            self.send_packet(&ForceCommand::OFF)?;
        }
        Ok(())
    }

    fn send_packet(&mut self, out: &ForceCommand) -> Result<(), DeviceError> {
        let on = out.enable && self.force_allowed();
        let motors = if on {
            let tau =
                kinematics::joint_torques_with(self.joints, out.force, self.config.link_lengths_m);
            let d = self.config.dac_per_newton_metre;
            [
                packet::motor_value(tau[0] * d[0]),
                packet::motor_value(tau[1] * d[1]),
                packet::motor_value(tau[2] * d[2]),
            ]
        } else {
            [packet::MOTOR_ZERO; 3]
        };
        let p = packet::encode_output(&OmniOutput {
            motors,
            motors_on: on,
            // The dock light flashes until the inkwell calibration is done.
            dock_flash: !self.calibrated,
        });
        self.transport.transmit(&p).map_err(|e| self.fail(e))?;
        self.sent_since_read = true;
        Ok(())
    }

    /// Encoder angles, rad, before the dock offsets: sign times counts.
    fn encoder_angles(&self) -> Vec3 {
        let k = core::f64::consts::TAU / self.config.counts_per_rev;
        let s = self.config.encoder_sign;
        [
            s[0] * self.counts[0] as f64 * k,
            s[1] * self.counts[1] as f64 * k,
            s[2] * self.counts[2] as f64 * k,
        ]
    }

    fn joint_angles(&self) -> Vec3 {
        let a = self.encoder_angles();
        let t1 = a[0] + self.offsets[0];
        let t2 = a[1] + self.offsets[1];
        [
            t1,
            t2,
            a[2] + self.config.joint3_coupling * t2 + self.offsets[2],
        ]
    }

    /// The start-up again after a bus reset: the Omni forgets its channels and its enable bit.
    fn redo_start_up(&mut self) -> Result<(), DeviceError> {
        self.bus_resets += 1;
        self.resync = RESYNC_PACKETS;
        self.safety.disable();
        let channels = self.transport.channels().map_err(|e| self.fail(e))?;
        self.channels = channels;
        start_up(&mut self.transport, channels, self.config.startup_quadlet)
            .map_err(|e| self.fail(e))
    }

    /// Unwraps the 16-bit counters; the first packet after a bus reset continues the counts when
    /// its step is small, and otherwise restarts them and drops the calibration.
    fn take_encoders(&mut self, encoders: [u16; 3]) {
        if self.resync == RESYNC_PACKETS {
            let jump = (0..3).any(|k| {
                let step = encoders[k].wrapping_sub(self.raw[k]) as i16;
                i64::from(step).abs() > MAX_RESYNC_STEP
            });
            if jump {
                self.started = false;
                self.calibrated = false;
                self.offsets = [0.0; 3];
            }
        }
        self.resync = self.resync.saturating_sub(1);
        for (k, &e) in encoders.iter().enumerate() {
            if self.started {
                let step = e.wrapping_sub(self.raw[k]) as i16;
                self.counts[k] += i64::from(step);
            } else {
                self.counts[k] = i64::from(e as i16);
            }
            self.raw[k] = e;
        }
        self.started = true;
    }

    /// Gimbal angles from the ratio of each potentiometer's two channels (the previous angle
    /// when both read zero).
    fn take_gimbal(&mut self, input: &OmniInput) {
        for k in 0..3 {
            let a = f64::from(input.gimbal[k]);
            let b = f64::from(input.gimbal_inv[k]);
            if a + b > 0.0 {
                let ratio = a / (a + b);
                self.gimbal[k] = self.config.gimbal_gain[k] * ratio + self.config.gimbal_offset[k];
            }
        }
    }
}

impl<T: FirewireTransport> Drop for OmniDevice<T> {
    fn drop(&mut self) {
        let _ = self.stop();
    }
}

fn quat_mul(a: Quat, b: Quat) -> Quat {
    [
        a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3],
        a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2],
        a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1],
        a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0],
    ]
}

fn axis_quat(axis: usize, angle: f64) -> Quat {
    let (s, c) = (angle / 2.0).sin_cos();
    let mut q = [c, 0.0, 0.0, 0.0];
    if let Some(slot) = q.get_mut(axis + 1) {
        *slot = s;
    }
    q
}

impl<T: FirewireTransport> HapticDevice for OmniDevice<T> {
    fn spec(&self) -> DeviceSpec {
        DeviceSpec::OMNI
    }

    fn read(&mut self) -> Result<DeviceState, DeviceError> {
        if !self.connected {
            return Err(DeviceError::Disconnected);
        }
        let out = self.safety.tick();
        if !self.sent_since_read {
            self.send(&out)?;
        }
        self.sent_since_read = false;
        let mut p = [0u8; INPUT_LEN];
        let mut complete = false;
        for _ in 0..3 {
            let n = self.transport.receive(&mut p).map_err(|e| self.fail(e))?;
            if n == INPUT_LEN {
                complete = true;
                break;
            }
        }
        if !complete {
            return Err(DeviceError::NoFrame);
        }
        // A reset the transport met while receiving: this packet is the first after it.
        if self.transport.take_bus_reset() {
            self.redo_start_up()?;
        }
        let input = packet::decode_input(&p);
        self.take_encoders(input.encoders);
        self.take_gimbal(&input);
        self.tick += 1;
        self.input = input;
        self.joints = self.joint_angles();
        let g = self.gimbal;
        // Stylus rotation: base yaw about y, then the gimbal (y, x, z). Axis order unverified.
        let rotation = quat_mul(
            quat_mul(axis_quat(1, self.joints[0] + g[0]), axis_quat(0, g[1])),
            axis_quat(2, g[2]),
        );
        let buttons = u32::from(input.button1) | (u32::from(input.button2) << 1);
        Ok(DeviceState {
            timestamp_s: self.tick as f64 * self.config.period_s,
            tick: self.tick,
            position: kinematics::forward_with(self.joints, self.config.link_lengths_m),
            rotation,
            joint_angles: [
                self.joints[0],
                self.joints[1],
                self.joints[2],
                g[0],
                g[1],
                g[2],
            ],
            buttons,
            docked: input.docked,
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
                self.send(&ForceCommand::OFF)?;
                Err(e)
            }
        }
    }

    /// Inkwell calibration: with the stylus docked, the current counts become the dock pose
    /// ([`OmniConfig::dock_angles`]); from then on force reaches the motors.
    fn calibrate(&mut self) -> Result<(), DeviceError> {
        if !self.started || !self.input.docked {
            return Err(DeviceError::NotDocked);
        }
        let a = self.encoder_angles();
        let dock = self.config.dock_angles;
        let c = self.config.joint3_coupling;
        self.offsets = [dock[0] - a[0], dock[1] - a[1], dock[2] - a[2] - c * dock[1]];
        self.calibrated = true;
        self.joints = self.joint_angles();
        Ok(())
    }

    fn cutoff(&self) -> Option<Arc<dyn MotorCutoff>> {
        self.cut.clone().map(|c| c as Arc<dyn MotorCutoff>)
    }
}
