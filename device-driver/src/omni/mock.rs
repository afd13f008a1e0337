//! [`MockFirewire`]: a scripted Omni node for tests (registers, input stream, faults, a bus
//! reset, an isochronous resource manager that grants the lowest free channels). Its
//! second path ([`FirewireTransport::out_path`]) records the packets another thread sends in
//! [`MockFirewire::out_log`], shared, so a test reads it while the device runs elsewhere.

use std::collections::VecDeque;
use std::sync::{Arc, Mutex};

use super::packet::{decode_output, encode_input, OmniInput, OmniOutput, INPUT_LEN, OUTPUT_LEN};
use super::{FirewireTransport, REG_CONTROL, REG_SERIAL, REG_STATUS_A, REG_VENDOR};
use crate::cutoff::{Cut, OutPath, PACKET_LEN};
use crate::device::DeviceError;

/// A register access the host made.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RegOp {
    /// Quadlet read.
    ReadQuadlet(u64),
    /// Byte read.
    Read(u64),
    /// Byte write.
    Write(u64, u8),
    /// Quadlet write.
    WriteQuadlet(u64, u32),
}

/// A scripted Omni. Registers are a small map; reads of unknown registers return 0.
#[derive(Debug)]
pub struct MockFirewire {
    /// Vendor quadlet the ROM returns.
    pub vendor: u32,
    /// Serial quadlet.
    pub serial: u32,
    /// Byte registers.
    pub registers: Vec<(u64, u8)>,
    /// Register accesses in order.
    pub log: Vec<RegOp>,
    /// Input packets to deliver, then `current` repeated.
    pub inputs: VecDeque<OmniInput>,
    /// Input delivered when the queue is empty.
    pub current: OmniInput,
    /// Deliver a truncated packet before every `n`-th packet.
    pub short_every: Option<usize>,
    /// Output packets the host sent, decoded.
    pub sent: Vec<OmniOutput>,
    /// Fail with `Disconnected` after this many received packets.
    pub disconnect_after: Option<usize>,
    /// Output packets sent through the second path, from any thread, decoded.
    pub out_log: Arc<Mutex<Vec<OmniOutput>>>,
    /// The resource manager's free channels (bit `c` set: channel `c` is free). The first
    /// [`FirewireTransport::channels`] call takes the two lowest and clears their bits.
    pub free_channels: u64,
    /// The channels taken, once taken.
    pub held: Option<(u8, u8)>,
    /// Reset the bus after this many received packets: the node forgets its byte registers
    /// (channels and control read 0 again) and the next `take_bus_reset` reports it.
    pub bus_reset_after: Option<usize>,
    reset_pending: bool,
    received: usize,
}

/// The mock's second path: decodes each packet into the shared log.
#[derive(Debug)]
struct MockOut(Arc<Mutex<Vec<OmniOutput>>>);

impl OutPath for MockOut {
    fn send(&self, packet: &[u8; PACKET_LEN]) -> Result<Cut, DeviceError> {
        self.0
            .lock()
            .map_err(|_| DeviceError::Transport("mock log poisoned"))?
            .push(decode_output(packet));
        Ok(Cut::Done)
    }
}

impl MockFirewire {
    /// An Omni that answers the start-up sequence as published.
    pub fn omni() -> MockFirewire {
        MockFirewire {
            vendor: 0x000b_9901,
            serial: 0x0001_e240,
            registers: vec![(REG_STATUS_A, 0xC0)],
            log: Vec::new(),
            inputs: VecDeque::new(),
            current: OmniInput::default(),
            short_every: None,
            sent: Vec::new(),
            disconnect_after: None,
            out_log: Arc::default(),
            free_channels: u64::MAX,
            held: None,
            bus_reset_after: None,
            reset_pending: false,
            received: 0,
        }
    }

    fn gone(&self) -> bool {
        matches!(self.disconnect_after, Some(n) if self.received >= n)
    }

    fn reg(&self, address: u64) -> u8 {
        self.registers
            .iter()
            .rev()
            .find(|(a, _)| *a == address)
            .map(|(_, v)| *v)
            .unwrap_or(0)
    }
}

impl FirewireTransport for MockFirewire {
    fn read_quadlet(&mut self, address: u64) -> Result<u32, DeviceError> {
        self.log.push(RegOp::ReadQuadlet(address));
        Ok(match address {
            REG_VENDOR => self.vendor,
            REG_SERIAL => self.serial,
            _ => 0,
        })
    }

    fn write_quadlet(&mut self, address: u64, value: u32) -> Result<(), DeviceError> {
        self.log.push(RegOp::WriteQuadlet(address, value));
        Ok(())
    }

    fn read_byte(&mut self, address: u64) -> Result<u8, DeviceError> {
        self.log.push(RegOp::Read(address));
        Ok(self.reg(address))
    }

    fn write_byte(&mut self, address: u64, value: u8) -> Result<(), DeviceError> {
        self.log.push(RegOp::Write(address, value));
        self.registers.push((address, value));
        Ok(())
    }

    fn channels(&mut self) -> Result<(u8, u8), DeviceError> {
        if let Some(held) = self.held {
            return Ok(held);
        }
        let mut take = || {
            let c = self.free_channels.trailing_zeros();
            if c >= 64 {
                return None;
            }
            self.free_channels &= !(1u64 << c);
            Some(c as u8)
        };
        match (take(), take()) {
            (Some(rx), Some(tx)) => {
                self.held = Some((rx, tx));
                Ok((rx, tx))
            }
            _ => Err(DeviceError::Transport(
                "the isochronous resource manager has no free channel",
            )),
        }
    }

    fn take_bus_reset(&mut self) -> bool {
        std::mem::take(&mut self.reset_pending)
    }

    fn receive(&mut self, packet: &mut [u8; INPUT_LEN]) -> Result<usize, DeviceError> {
        if self.gone() {
            return Err(DeviceError::Disconnected);
        }
        if self.bus_reset_after == Some(self.received) {
            self.bus_reset_after = None;
            self.reset_pending = true;
            // The node comes back from the reset with its registers at their power-on values.
            self.registers.retain(|(a, _)| *a == REG_STATUS_A);
            self.registers.push((REG_CONTROL, 0));
        }
        self.received += 1;
        let input = self.inputs.pop_front().unwrap_or(self.current);
        *packet = encode_input(&input);
        if matches!(self.short_every, Some(n) if n > 0 && self.received.is_multiple_of(n)) {
            self.inputs.push_front(input);
            return Ok(20);
        }
        Ok(INPUT_LEN)
    }

    fn transmit(&mut self, packet: &[u8; OUTPUT_LEN]) -> Result<(), DeviceError> {
        if self.gone() {
            return Err(DeviceError::Disconnected);
        }
        self.sent.push(decode_output(packet));
        Ok(())
    }

    fn out_path(&self) -> Option<Arc<dyn OutPath>> {
        Some(Arc::new(MockOut(Arc::clone(&self.out_log))))
    }
}
