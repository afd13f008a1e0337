//! SensAble PHANTOM Omni. The original Omni is an IEEE-1394 (FireWire) device, not USB.
//!
//! The protocol is the publicly reverse-engineered one: identification by the vendor OUI in the
//! configuration ROM, a few register writes to start isochronous streaming, 44-byte input
//! packets and 16-byte output packets ([`packet`]), 15000 encoder counts per joint revolution,
//! and the arm kinematics of [`kinematics`]. Everything goes through [`FirewireTransport`]:
//! this codec has no `unsafe`; the Linux firewire-cdev transport (ioctls) is
//! `os::firewire::CdevFirewire` (feature `os`); [`mock::MockFirewire`] drives the tests.
//! A transport may offer a second path for output packets ([`FirewireTransport::out_path`]);
//! the device then has a [`MotorCutoff`](crate::cutoff::MotorCutoff) that sends a motors-off
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
/// motor packets); [`OmniConfig::transmit_channel`] is written here.
pub const REG_XMIT_CHANNEL: u64 = 0x1000;
/// Register: the isochronous channel the host receives on (the Omni sends its input packets
/// there); [`OmniConfig::receive_channel`] is written here.
pub const REG_RECV_CHANNEL: u64 = 0x1001;
/// Status register that reads 0xC0 when ready.
pub const REG_STATUS_A: u64 = 0x1083;
/// Status register that reads 0x00 when ready.
pub const REG_STATUS_B: u64 = 0x1082;
/// Control register; bit 3 enables isochronous transfer.
pub const REG_CONTROL: u64 = 0x1087;
/// [`REG_CONTROL`] bit enabling isochronous transfer.
pub const CONTROL_ENABLE_ISO: u8 = 0x08;

/// Access to one FireWire node: asynchronous register reads/writes and the two isochronous
/// streams.
pub trait FirewireTransport {
    /// Reads a 32-bit quadlet at a node address.
    fn read_quadlet(&mut self, address: u64) -> Result<u32, DeviceError>;
    /// Reads one byte register.
    fn read_byte(&mut self, address: u64) -> Result<u8, DeviceError>;
    /// Writes one byte register.
    fn write_byte(&mut self, address: u64, value: u8) -> Result<(), DeviceError>;
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

/// Omni settings. Scales marked "unverified" have not been measured on hardware.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OmniConfig {
    /// Isochronous channel the host receives on.
    pub receive_channel: u8,
    /// Isochronous channel the host transmits on.
    pub transmit_channel: u8,
    /// Joint angles at the inkwell (dock) pose, rad (unverified: all zero by default).
    pub dock_angles: Vec3,
    /// Encoder direction per joint (+1 or -1; unverified).
    pub encoder_sign: Vec3,
    /// DAC counts per N m per motor, sign included (unverified).
    pub dac_per_newton_metre: Vec3,
    /// Gimbal radians per 11-bit count (unverified: about 270 degrees over 2048 counts).
    pub gimbal_rad_per_count: f64,
    /// Servo period for timestamps, s.
    pub period_s: f64,
    /// Safety settings (clamp to the Omni's 3.3 N).
    pub safety: SafetyConfig,
}

impl Default for OmniConfig {
    fn default() -> OmniConfig {
        OmniConfig {
            receive_channel: 0,
            transmit_channel: 1,
            dock_angles: [0.0; 3],
            encoder_sign: [1.0; 3],
            dac_per_newton_metre: [4096.0; 3],
            gimbal_rad_per_count: 270f64.to_radians() / 2048.0,
            period_s: 1e-3,
            safety: SafetyConfig::for_max_force(DeviceSpec::OMNI.max_force_n),
        }
    }
}

/// A PHANTOM Omni over a [`FirewireTransport`].
#[derive(Debug)]
pub struct OmniDevice<T> {
    transport: T,
    config: OmniConfig,
    safety: ForceSafety,
    serial: u32,
    tick: u64,
    raw: [u16; 3],
    counts: [i64; 3],
    started: bool,
    offsets: Vec3,
    joints: Vec3,
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

impl<T: FirewireTransport> OmniDevice<T> {
    /// Identifies the node (SensAble OUI) and starts streaming with the published register
    /// sequence.
    pub fn start(mut transport: T, config: OmniConfig) -> Result<OmniDevice<T>, DeviceError> {
        let vendor = transport.read_quadlet(REG_VENDOR)?;
        if vendor & 0xFFFF_FF00 != SENSABLE_OUI {
            return Err(DeviceError::WrongDevice { found: vendor });
        }
        let serial = transport.read_quadlet(REG_SERIAL)?;
        let rc = config.receive_channel;
        // Receive channel: write, read back, test bit 6, restore.
        transport.write_byte(REG_RECV_CHANNEL, rc)?;
        check(&mut transport, REG_RECV_CHANNEL, rc)?;
        transport.write_byte(REG_RECV_CHANNEL, 0x40)?;
        check(&mut transport, REG_RECV_CHANNEL, 0x40)?;
        transport.write_byte(REG_RECV_CHANNEL, rc)?;
        check(&mut transport, REG_STATUS_A, 0xC0)?;
        check(&mut transport, REG_STATUS_B, 0x00)?;
        // Transmit channel.
        transport.write_byte(REG_XMIT_CHANNEL, config.transmit_channel)?;
        check(&mut transport, REG_STATUS_A, 0xC0)?;
        check(&mut transport, REG_STATUS_B, 0x00)?;
        // Enable isochronous transfer.
        let control = transport.read_byte(REG_CONTROL)?;
        if control & CONTROL_ENABLE_ISO == 0 {
            transport.write_byte(REG_CONTROL, control | CONTROL_ENABLE_ISO)?;
        }
        let cut = transport
            .out_path()
            .map(|out| Arc::new(PacketCutoff::new(out, &motors_off_packet())));
        Ok(OmniDevice {
            cut,
            transport,
            safety: ForceSafety::new(config.safety),
            config,
            serial,
            tick: 0,
            raw: [0; 3],
            counts: [0; 3],
            started: false,
            offsets: config.dock_angles,
            joints: [0.0; 3],
            input: OmniInput::default(),
            sent_since_read: false,
            connected: true,
        })
    }

    /// Serial number read at start-up.
    pub fn serial(&self) -> u32 {
        self.serial
    }

    /// The transport (e.g. to inspect a mock).
    pub fn transport(&self) -> &T {
        &self.transport
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

    fn latched(&self) -> bool {
        self.cut.as_ref().is_some_and(|c| c.is_cut())
    }

    /// Sends `out`, or motors off while the cutoff's latch is set. The latch is looked at again
    /// after the packet was queued: when a cut came in between, a motors-off packet follows.
    fn send(&mut self, out: &ForceCommand) -> Result<(), DeviceError> {
        let out = if self.latched() {
            self.safety.disable();
            ForceCommand::OFF
        } else {
            *out
        };
        self.send_packet(&out)?;
        if out.enable && self.latched() {
            self.safety.disable();
            self.send_packet(&ForceCommand::OFF)?;
        }
        Ok(())
    }

    fn send_packet(&mut self, out: &ForceCommand) -> Result<(), DeviceError> {
        let tau = kinematics::joint_torques(self.joints, out.force);
        let d = self.config.dac_per_newton_metre;
        let motors = if out.enable {
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
            motors_on: out.enable,
            dock_flash: false,
        });
        self.transport.transmit(&p).map_err(|e| self.fail(e))?;
        self.sent_since_read = true;
        Ok(())
    }

    fn joint_angles(&self) -> Vec3 {
        let k = core::f64::consts::TAU / packet::COUNTS_PER_REV;
        let s = self.config.encoder_sign;
        [
            s[0] * self.counts[0] as f64 * k + self.offsets[0],
            s[1] * self.counts[1] as f64 * k + self.offsets[1],
            s[2] * self.counts[2] as f64 * k + self.offsets[2],
        ]
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
        let input = packet::decode_input(&p);
        // Unwrap the 16-bit counters: joints move far less than half a wrap per tick.
        for k in 0..3 {
            if self.started {
                let step = input.encoders[k].wrapping_sub(self.raw[k]) as i16;
                self.counts[k] += i64::from(step);
            } else {
                self.counts[k] = i64::from(input.encoders[k] as i16);
            }
            self.raw[k] = input.encoders[k];
        }
        self.started = true;
        self.tick += 1;
        self.input = input;
        self.joints = self.joint_angles();
        let g = input
            .gimbal
            .map(|c| (f64::from(c) - 1024.0) * self.config.gimbal_rad_per_count);
        // Stylus rotation: base yaw about y, then the gimbal (y, x, z). Axis order unverified.
        let rotation = quat_mul(
            quat_mul(axis_quat(1, self.joints[0] + g[0]), axis_quat(0, g[1])),
            axis_quat(2, g[2]),
        );
        let buttons = u32::from(input.button1) | (u32::from(input.button2) << 1);
        Ok(DeviceState {
            timestamp_s: self.tick as f64 * self.config.period_s,
            tick: self.tick,
            position: kinematics::forward(self.joints),
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

    /// Inkwell calibration: with the stylus docked, the current counts become the dock pose.
    fn calibrate(&mut self) -> Result<(), DeviceError> {
        if !self.input.docked {
            return Err(DeviceError::NotDocked);
        }
        let k = core::f64::consts::TAU / packet::COUNTS_PER_REV;
        let s = self.config.encoder_sign;
        let dock = self.config.dock_angles;
        for (j, offset) in self.offsets.iter_mut().enumerate() {
            *offset = dock[j] - s[j] * self.counts[j] as f64 * k;
        }
        self.joints = self.joint_angles();
        Ok(())
    }

    fn cutoff(&self) -> Option<Arc<dyn MotorCutoff>> {
        self.cut.clone().map(|c| c as Arc<dyn MotorCutoff>)
    }
}
