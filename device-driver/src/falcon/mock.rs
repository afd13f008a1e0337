//! [`MockTransport`]: a scripted Falcon behind the [`Transport`] trait, for tests.
//!
//! It models the device side of the protocol: the loader handshake replies, the echo of each
//! firmware chunk, and, once a firmware runs (uploaded, or [`MockTransport::running`]), a
//! report frame for every command frame in normal mode. A purge of the receive buffer drops
//! what was waiting. Fault knobs inject wrong loader replies, corrupted firmware echoes, short
//! (split) reads, garbage between frames and a disconnect. Every operation is logged for the test to check against the documented
//! sequence. Its second path ([`Transport::out_path`]) records the frames another thread sends
//! in [`MockTransport::out_log`], shared, so a test reads it while the device runs elsewhere
//! (the mock does not answer those frames).

use std::collections::VecDeque;
use std::sync::{Arc, Mutex};

use super::frame::{decode_command, encode_report, FalconCommand, FalconReport, FRAME_LEN};
use super::ftdi::{BAUD_LOADER, BAUD_NORMAL, PURGE_RX, SIO_RESET, SIO_SET_BAUD_RATE};
use super::Transport;
use crate::cutoff::{Cut, OutPath, PACKET_LEN};
use crate::device::DeviceError;

/// One logged host operation.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum MockOp {
    /// A vendor control request.
    Control {
        /// bRequest.
        request: u8,
        /// wValue.
        value: u16,
    },
    /// A bulk write.
    Write(Vec<u8>),
    /// A close and reopen of the device ([`Transport::reopen`]).
    Reopen,
}

/// The FT232's two modem-status bytes as a real chip sends them.
pub const MODEM_STATUS: [u8; 2] = [0x31, 0x60];

/// A scripted Falcon. See the module docs.
#[derive(Debug, Default)]
pub struct MockTransport {
    /// Everything the host did, in order.
    pub log: Vec<MockOp>,
    /// Packets waiting to be read (data only; status bytes are added on read).
    pub pending: VecDeque<Vec<u8>>,
    /// The report answered to each command frame (normal mode).
    pub report: FalconReport,
    /// Corrupt the firmware echo at this byte (counted from the start of an upload), once.
    pub corrupt_echo_at: Option<usize>,
    /// Uploads after the first that get the same corruption (`corrupt_echo_at`), count.
    pub corrupt_echo_repeats: usize,
    /// Answer this many `0a 43 0d` handshakes with a wrong reply (`0a 44 2c 0e`) first.
    pub bad_loader_replies: usize,
    /// Answer the loader's `41` with `13 41` (a wrong reply) instead of `41`.
    pub bad_ready_reply: bool,
    /// Answer `0a 43 0d` with a leading zero byte (`00 0a 44 2c 0d`), the other form
    /// libnifalcon accepts.
    pub long_loader_reply: bool,
    /// Split every report into two reads (short reads).
    pub short_reads: bool,
    /// Put this many garbage bytes before each report.
    pub garbage_before_report: usize,
    /// Answer no report to these command frames (1-based, counted over the session): a
    /// missed frame.
    pub drop_reports: Vec<usize>,
    /// Every call fails with `Disconnected` after this many command frames.
    pub disconnect_after_frames: Option<usize>,
    /// Commands decoded from the frames the host sent in normal mode.
    pub commands: Vec<FalconCommand>,
    /// Commands decoded from the frames sent through the second path, from any thread.
    pub out_log: Arc<Mutex<Vec<FalconCommand>>>,
    loader_ready: bool,
    normal: bool,
    firmware: bool,
    echoed: usize,
    gone: bool,
}

impl MockTransport {
    /// A Falcon with no firmware loaded yet.
    pub fn new() -> MockTransport {
        MockTransport::default()
    }

    /// A Falcon whose firmware is already running (normal mode).
    pub fn running() -> MockTransport {
        MockTransport {
            normal: true,
            firmware: true,
            ..MockTransport::default()
        }
    }

    /// Whether a firmware runs (it answers command frames in normal mode).
    pub fn firmware_running(&self) -> bool {
        self.firmware
    }

    /// Firmware bytes echoed in the current or last upload.
    pub fn echoed(&self) -> usize {
        self.echoed
    }

    fn check(&self) -> Result<(), DeviceError> {
        if self.gone {
            Err(DeviceError::Disconnected)
        } else {
            Ok(())
        }
    }
}

/// The mock's second path: decodes each frame into the shared log.
#[derive(Debug)]
struct MockOut(Arc<Mutex<Vec<FalconCommand>>>);

impl OutPath for MockOut {
    fn send(&self, packet: &[u8; PACKET_LEN]) -> Result<Cut, DeviceError> {
        let cmd = decode_command(packet).map_err(|_| DeviceError::Transport("bad frame"))?;
        self.0
            .lock()
            .map_err(|_| DeviceError::Transport("mock log poisoned"))?
            .push(cmd);
        Ok(Cut::Done)
    }
}

impl Transport for MockTransport {
    fn control_out(&mut self, request: u8, value: u16, _index: u16) -> Result<(), DeviceError> {
        self.check()?;
        self.log.push(MockOp::Control { request, value });
        if request == SIO_RESET && value == PURGE_RX {
            self.pending.clear();
        }
        if request == SIO_SET_BAUD_RATE {
            if value == BAUD_NORMAL {
                // Leaving the loader after a whole upload starts the firmware.
                if self.loader_ready && self.echoed > 0 {
                    self.firmware = true;
                }
                self.normal = true;
                self.loader_ready = false;
            } else if value != BAUD_LOADER {
                // Back to the loader's 9600 baud: the loader starts over.
                self.normal = false;
                self.loader_ready = false;
                self.firmware = false;
            }
        }
        Ok(())
    }

    fn bulk_write(&mut self, data: &[u8], _timeout_ms: u32) -> Result<usize, DeviceError> {
        self.check()?;
        self.log.push(MockOp::Write(data.to_vec()));
        if self.normal {
            if !self.firmware {
                return Ok(data.len());
            }
            let Ok(frame) = <[u8; FRAME_LEN]>::try_from(data) else {
                return Ok(data.len());
            };
            if let Ok(cmd) = decode_command(&frame) {
                self.commands.push(cmd);
                if matches!(self.disconnect_after_frames, Some(n) if self.commands.len() > n) {
                    self.gone = true;
                    return Err(DeviceError::Disconnected);
                }
                if self.drop_reports.contains(&self.commands.len()) {
                    return Ok(data.len());
                }
                let mut bytes = vec![0x13; self.garbage_before_report];
                bytes.extend_from_slice(&encode_report(&self.report));
                if self.short_reads {
                    let cut = bytes.len() / 2;
                    self.pending.push_back(bytes[..cut].to_vec());
                    self.pending.push_back(bytes[cut..].to_vec());
                } else {
                    self.pending.push_back(bytes);
                }
            }
        } else if data == [0x0a, 0x43, 0x0d] && !self.loader_ready {
            if self.bad_loader_replies > 0 {
                self.bad_loader_replies -= 1;
                self.pending.push_back(vec![0x0a, 0x44, 0x2c, 0x0e]);
            } else if self.long_loader_reply {
                self.pending.push_back(vec![0x00, 0x0a, 0x44, 0x2c, 0x0d]);
            } else {
                self.pending.push_back(vec![0x0a, 0x44, 0x2c, 0x0d]);
            }
        } else if data == [0x41] && !self.loader_ready {
            self.loader_ready = true;
            self.echoed = 0;
            if self.bad_ready_reply {
                self.pending.push_back(vec![0x13, 0x41]);
            } else {
                self.pending.push_back(vec![0x41]);
            }
        } else if self.loader_ready {
            let mut echo = data.to_vec();
            if let Some(at) = self.corrupt_echo_at {
                if at >= self.echoed && at < self.echoed + echo.len() {
                    if let Some(b) = echo.get_mut(at - self.echoed) {
                        *b ^= 0xFF;
                    }
                    if self.corrupt_echo_repeats > 0 {
                        self.corrupt_echo_repeats -= 1;
                    } else {
                        self.corrupt_echo_at = None;
                    }
                }
            }
            self.echoed += echo.len();
            // The FT232 returns at most 62 data bytes per packet.
            for part in echo.chunks(62) {
                self.pending.push_back(part.to_vec());
            }
        }
        Ok(data.len())
    }

    fn bulk_read(&mut self, buf: &mut [u8], _timeout_ms: u32) -> Result<usize, DeviceError> {
        self.check()?;
        let data = self.pending.pop_front().unwrap_or_default();
        let mut n = 0;
        for (slot, b) in buf.iter_mut().zip(MODEM_STATUS.iter().chain(data.iter())) {
            *slot = *b;
            n += 1;
        }
        Ok(n)
    }

    fn out_path(&self) -> Option<Arc<dyn OutPath>> {
        Some(Arc::new(MockOut(Arc::clone(&self.out_log))))
    }

    /// Logs [`MockOp::Reopen`]. Closing drops what was waiting to be read; the Falcon keeps
    /// its power, so a loader that had answered `41` waits for a new handshake.
    fn reopen(&mut self) -> Result<(), DeviceError> {
        self.check()?;
        self.log.push(MockOp::Reopen);
        self.pending.clear();
        self.loader_ready = false;
        Ok(())
    }
}
