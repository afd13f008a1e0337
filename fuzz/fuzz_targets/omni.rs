//! PHANTOM Omni packets and the session that reads them.
//!
//! 1. The first 44 bytes as an input packet: decoding is idempotent through `encode_input`
//!    (the unknown fields are dropped, the known ones kept), the gimbal stays in 11 bits.
//! 2. The first 16 bytes as an output packet: a packet whose motor values fit the 12-bit DAC
//!    decodes, re-encodes and decodes to the same value.
//! 3. An `OmniDevice` started on the mock node (registers as published) whose isochronous
//!    packets come from the input (complete, short, timeouts, a disconnect), with force commands
//!    from the input (including NaN, infinities, huge values) and inkwell calibrations: no
//!    panic, finite states and unit rotations, motors at zero torque whenever they are off,
//!    `Disconnected` stays disconnected.

#![no_main]

use libfuzzer_sys::fuzz_target;
use tetradrill_device::omni::mock::MockFirewire;
use tetradrill_device::omni::packet::{
    decode_input, decode_output, encode_input, encode_output, OmniOutput, INPUT_LEN, MOTOR_MAX,
    MOTOR_ZERO, OUTPUT_LEN,
};
use tetradrill_device::omni::{FirewireTransport, OmniConfig, OmniDevice};
use tetradrill_device::{DeviceError, ForceCommand, HapticDevice};
use tetradrill_fuzz::Input;

fn packets(data: &[u8]) {
    if let Some(p) = data.get(..INPUT_LEN) {
        let p: [u8; INPUT_LEN] = p.try_into().expect("44 bytes");
        let i = decode_input(&p);
        assert!(i.gimbal.iter().all(|&g| g < 2048), "{i:?}");
        assert_eq!(decode_input(&encode_input(&i)), i);
    }
    if let Some(p) = data.get(..OUTPUT_LEN) {
        let p: [u8; OUTPUT_LEN] = p.try_into().expect("16 bytes");
        let o = decode_output(&p);
        if o.motors.iter().all(|&m| m <= MOTOR_MAX) {
            assert_eq!(decode_output(&encode_output(&o)), o);
        }
    }
}

/// The mock node answers the registers; the isochronous stream comes from the fuzz input.
struct FuzzNode<'a> {
    regs: MockFirewire,
    input: Input<'a>,
    sent: Vec<OmniOutput>,
}

impl FirewireTransport for FuzzNode<'_> {
    fn read_quadlet(&mut self, address: u64) -> Result<u32, DeviceError> {
        self.regs.read_quadlet(address)
    }

    fn write_quadlet(&mut self, address: u64, value: u32) -> Result<(), DeviceError> {
        self.regs.write_quadlet(address, value)
    }

    fn read_byte(&mut self, address: u64) -> Result<u8, DeviceError> {
        self.regs.read_byte(address)
    }

    fn channels(&mut self) -> Result<(u8, u8), DeviceError> {
        self.regs.channels()
    }

    fn take_bus_reset(&mut self) -> bool {
        self.regs.take_bus_reset()
    }

    fn write_byte(&mut self, address: u64, value: u8) -> Result<(), DeviceError> {
        self.regs.write_byte(address, value)
    }

    fn receive(&mut self, packet: &mut [u8; INPUT_LEN]) -> Result<usize, DeviceError> {
        match self.input.byte() {
            None | Some(0xFE) => Err(DeviceError::Disconnected),
            Some(0xFF) => Err(DeviceError::Timeout),
            Some(s) if s >= 0xF0 => {
                let n = usize::from(s & 0x0F) * 2;
                self.input.fill(&mut packet[..n]);
                Ok(n)
            }
            Some(_) => {
                self.input.fill(packet);
                Ok(INPUT_LEN)
            }
        }
    }

    fn transmit(&mut self, packet: &[u8; OUTPUT_LEN]) -> Result<(), DeviceError> {
        self.sent.push(decode_output(packet));
        Ok(())
    }
}

fn session(data: &[u8]) {
    let Some((&mode, rest)) = data.split_first() else {
        return;
    };
    // The last 4 * mode bytes script the commands, the others the device.
    let split = rest.len() - rest.len().min(4 * usize::from(mode));
    let (stream, commands) = rest.split_at(split);
    let mut commands = Input::new(commands);
    let node = FuzzNode {
        regs: MockFirewire::omni(),
        input: Input::new(stream),
        sent: Vec::new(),
    };
    let mut dev = OmniDevice::start(node, OmniConfig::default()).expect("the mock node starts");
    let mut gone = false;
    for _ in 0..64 {
        match dev.read() {
            Ok(s) => {
                assert!(!gone, "a read after Disconnected succeeded");
                assert!(s.position.iter().all(|v| v.is_finite()), "{s:?}");
                assert!(s.joint_angles.iter().all(|v| v.is_finite()), "{s:?}");
                let n: f64 = s.rotation.iter().map(|v| v * v).sum::<f64>().sqrt();
                assert!((n - 1.0).abs() < 1e-9, "rotation norm {n}: {s:?}");
            }
            Err(DeviceError::Disconnected) => gone = true,
            Err(_) => {}
        }
        if gone {
            assert_eq!(dev.read().err(), Some(DeviceError::Disconnected));
            break;
        }
        let flags = commands.byte().unwrap_or(0);
        if flags & 2 != 0 {
            let _ = dev.calibrate();
        }
        let cmd = ForceCommand {
            force: [commands.force(), commands.force(), commands.force()],
            torque: [0.0; 3],
            enable: flags & 1 != 0,
        };
        let before = dev.transport().sent.len();
        let result = dev.write(&cmd);
        if result == Err(DeviceError::NonFiniteCommand) {
            let sent = &dev.transport().sent;
            assert!(sent.len() > before, "a refused command sent no packet");
            let last = sent[sent.len() - 1];
            assert!(!last.motors_on, "motors on after a refused command");
        }
    }
    for o in &dev.transport().sent {
        assert!(o.motors.iter().all(|&m| m <= MOTOR_MAX), "{o:?}");
        if !o.motors_on {
            assert_eq!(o.motors, [MOTOR_ZERO; 3], "torque with the motors off");
        }
    }
}

fuzz_target!(|data: &[u8]| {
    packets(data);
    session(data);
});
