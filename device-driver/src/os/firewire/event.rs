//! Events read from a node's file descriptor (the C structs the kernel writes, one per
//! `read(2)`), parsed without copying, the closures that tag the transport's requests and
//! contexts in them, and [`EventFile`], an open node with its event buffer.

use std::fmt;
use std::fs::{File, OpenOptions};
use std::io::{self, Read};
use std::os::fd::AsRawFd;
use std::os::unix::fs::OpenOptionsExt;
use std::path::Path;

use super::abi::{
    BUS_RESET_GENERATION, BUS_RESET_NODE_ID, EVENT_BUS_RESET, EVENT_ISO_INTERRUPT,
    EVENT_ISO_RESOURCE_ALLOCATED, EVENT_ISO_RESOURCE_DEALLOCATED, EVENT_RESPONSE, EV_CLOSURE,
    EV_TYPE, ISO_INTERRUPT_CYCLE, ISO_INTERRUPT_HEADER, ISO_INTERRUPT_HEADER_LENGTH,
    ISO_RESOURCE_BANDWIDTH, ISO_RESOURCE_CHANNEL, RESPONSE_DATA, RESPONSE_LENGTH, RESPONSE_RCODE,
};
use super::error::errno_error;
use super::ioctl::poll_readable;
use crate::device::DeviceError;

/// One event, parsed from the bytes `read(2)` returned. Fields are native-endian (the kernel
/// writes C structs); payloads keep bus (big-endian) byte order.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Event<'a> {
    /// `fw_cdev_event_bus_reset`.
    BusReset { node_id: u32, generation: u32 },
    /// `fw_cdev_event_response`: closure at 0, rcode at 12, length at 16, data at 20.
    Response {
        closure: u64,
        rcode: u32,
        data: &'a [u8],
    },
    /// `fw_cdev_event_iso_interrupt`: cycle at 12, header_length at 16, headers at 20.
    IsoInterrupt {
        closure: u64,
        cycle: u32,
        headers: &'a [u8],
    },
    /// `fw_cdev_event_iso_resource`: handle at 12, channel at 16, bandwidth at 20.
    IsoResource {
        closure: u64,
        allocated: bool,
        channel: i32,
        bandwidth: i32,
    },
    /// Any other type.
    Other { kind: u32 },
}

fn ne_u32(b: &[u8], at: usize) -> Option<u32> {
    let s = b.get(at..at.checked_add(4)?)?;
    Some(u32::from_ne_bytes([s[0], s[1], s[2], s[3]]))
}

fn ne_u64(b: &[u8], at: usize) -> Option<u64> {
    let s = b.get(at..at.checked_add(8)?)?;
    let mut a = [0u8; 8];
    a.copy_from_slice(s);
    Some(u64::from_ne_bytes(a))
}

/// Parses one event; `None` when the bytes are shorter than the event's fixed part.
fn parse_event(b: &[u8]) -> Option<Event<'_>> {
    let closure = ne_u64(b, EV_CLOSURE)?;
    let kind = ne_u32(b, EV_TYPE)?;
    Some(match kind {
        EVENT_BUS_RESET => Event::BusReset {
            node_id: ne_u32(b, BUS_RESET_NODE_ID)?,
            generation: ne_u32(b, BUS_RESET_GENERATION)?,
        },
        EVENT_RESPONSE => {
            let rcode = ne_u32(b, RESPONSE_RCODE)?;
            let length = ne_u32(b, RESPONSE_LENGTH)? as usize;
            let data = b.get(RESPONSE_DATA..)?;
            Event::Response {
                closure,
                rcode,
                data: &data[..length.min(data.len())],
            }
        }
        EVENT_ISO_INTERRUPT => {
            let cycle = ne_u32(b, ISO_INTERRUPT_CYCLE)?;
            let length = ne_u32(b, ISO_INTERRUPT_HEADER_LENGTH)? as usize;
            let headers = b.get(ISO_INTERRUPT_HEADER..)?;
            Event::IsoInterrupt {
                closure,
                cycle,
                headers: &headers[..length.min(headers.len())],
            }
        }
        EVENT_ISO_RESOURCE_ALLOCATED | EVENT_ISO_RESOURCE_DEALLOCATED => Event::IsoResource {
            closure,
            allocated: kind == EVENT_ISO_RESOURCE_ALLOCATED,
            channel: ne_u32(b, ISO_RESOURCE_CHANNEL)? as i32,
            bandwidth: ne_u32(b, ISO_RESOURCE_BANDWIDTH)? as i32,
        },
        kind => Event::Other { kind },
    })
}

/// The payload length in a received packet's 1394 isochronous header (the first quadlet the
/// receive context strips: data_length:16, tag:2, channel:6, tcode:4, sy:4, big-endian).
pub(super) fn iso_payload_length(header: &[u8]) -> usize {
    match header {
        [hi, lo, ..] => usize::from(u16::from_be_bytes([*hi, *lo])),
        _ => 0,
    }
}

/// Bytes read per event: the largest is an iso interrupt carrying a page of headers (the
/// kernel flushes at `PAGE_SIZE`) after its 20-byte fixed part.
const EVENT_BUFFER: usize = 8192;

/// An open node and its event buffer (allocated once).
pub(super) struct EventFile {
    pub(super) file: File,
    buf: Box<[u8]>,
}

impl fmt::Debug for EventFile {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("EventFile")
            .field("fd", &self.file.as_raw_fd())
            .finish()
    }
}

impl EventFile {
    pub(super) fn open(path: &Path, write: bool) -> io::Result<EventFile> {
        let file = OpenOptions::new()
            .read(true)
            .write(write)
            .custom_flags(libc::O_NONBLOCK)
            .open(path)?;
        Ok(EventFile {
            file,
            buf: vec![0u8; EVENT_BUFFER].into_boxed_slice(),
        })
    }

    /// Reads one pending event into the buffer: its length, or `None` when none is pending.
    pub(super) fn read_one(&mut self) -> Result<Option<usize>, DeviceError> {
        loop {
            match self.file.read(&mut self.buf) {
                Ok(0) => return Ok(None),
                Ok(n) => return Ok(Some(n)),
                Err(e) if e.kind() == io::ErrorKind::WouldBlock => return Ok(None),
                Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
                Err(e) => return Err(errno_error(&e)),
            }
        }
    }

    pub(super) fn event(&self, n: usize) -> Option<Event<'_>> {
        parse_event(self.buf.get(..n)?)
    }

    pub(super) fn wait(&self, timeout_ns: u64) -> Result<bool, DeviceError> {
        poll_readable(&self.file, timeout_ns)
    }
}

pub(super) const CLOSURE_BUS_RESET: u64 = 0x0b55;
pub(super) const CLOSURE_RX: u64 = 0x1500;
pub(super) const CLOSURE_TX: u64 = 0x1501;
pub(super) const CLOSURE_ALLOC_RX: u64 = 0xa110c0;
pub(super) const CLOSURE_ALLOC_TX: u64 = 0xa110c1;
pub(super) const CLOSURE_FIRST_REQUEST: u64 = 0x1_0000;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::os::firewire::abi::RCODE_ADDRESS_ERROR;

    /// An event as the kernel writes it: native-endian `closure`, `type`, then 4-byte fields,
    /// then raw bytes.
    fn event_bytes(closure: u64, kind: u32, fields: &[u32], tail: &[u8]) -> Vec<u8> {
        let mut b = closure.to_ne_bytes().to_vec();
        b.extend_from_slice(&kind.to_ne_bytes());
        for f in fields {
            b.extend_from_slice(&f.to_ne_bytes());
        }
        b.extend_from_slice(tail);
        b
    }

    #[test]
    fn events_parse_from_the_header_layout() {
        // A quadlet read response: rcode, length 4, the quadlet in bus (big-endian) order.
        let b = event_bytes(0x1_0005, 1, &[0, 4], &[0x00, 0x0b, 0x99, 0x01, 0, 0, 0, 0]);
        let Some(Event::Response {
            closure,
            rcode,
            data,
        }) = parse_event(&b)
        else {
            panic!("a response");
        };
        assert_eq!(
            (closure, rcode, data),
            (0x1_0005, 0, &[0x00, 0x0b, 0x99, 0x01][..])
        );
        assert_eq!(
            u32::from_be_bytes([data[0], data[1], data[2], data[3]]),
            0x000b_9901
        );
        // A length beyond what was read is clamped.
        let b = event_bytes(7, 1, &[0, 64], &[1, 2]);
        assert!(matches!(
            parse_event(&b),
            Some(Event::Response { data: [1, 2], .. })
        ));
        // Bus reset: node_id 12, local 16, bm 20, irm 24, root 28, generation 32.
        let b = event_bytes(
            CLOSURE_BUS_RESET,
            0,
            &[0xffc1, 0xffc0, 0xffc0, 0xffc0, 0xffc1, 7],
            &[],
        );
        assert_eq!(
            parse_event(&b),
            Some(Event::BusReset {
                node_id: 0xffc1,
                generation: 7
            })
        );
        // Iso interrupt with two stripped headers: data_length 44 and 20 in the upper 16 bits.
        let headers = [0x00, 0x2c, 0x00, 0xa0, 0x00, 0x14, 0x00, 0xa0];
        let b = event_bytes(CLOSURE_RX, 3, &[0x1234, 8], &headers);
        let Some(Event::IsoInterrupt {
            closure,
            cycle,
            headers: h,
        }) = parse_event(&b)
        else {
            panic!("an iso interrupt");
        };
        assert_eq!((closure, cycle, h.len()), (CLOSURE_RX, 0x1234, 8));
        let lengths: Vec<usize> = h.chunks_exact(4).map(iso_payload_length).collect();
        assert_eq!(lengths, [44, 20]);
        // Resource allocation refused: channel holds -EBUSY.
        let b = event_bytes(CLOSURE_ALLOC_RX, 4, &[3, (-libc::EBUSY) as u32, 816], &[]);
        assert_eq!(
            parse_event(&b),
            Some(Event::IsoResource {
                closure: CLOSURE_ALLOC_RX,
                allocated: true,
                channel: -libc::EBUSY,
                bandwidth: 816
            })
        );
        assert!(matches!(
            parse_event(&event_bytes(1, 5, &[3, 0, 0], &[])),
            Some(Event::IsoResource {
                allocated: false,
                ..
            })
        ));
        assert_eq!(
            parse_event(&event_bytes(1, 9, &[], &[])),
            Some(Event::Other { kind: 9 })
        );
        // Too short for any event, or for its own fixed part.
        assert_eq!(parse_event(&[0; 11]), None);
        assert_eq!(parse_event(&event_bytes(1, 0, &[1, 2], &[])), None);
        assert_eq!(parse_event(&event_bytes(1, 1, &[0], &[])), None);
        assert_eq!(iso_payload_length(&[0x01]), 0);
    }

    #[test]
    fn events_arrive_through_a_file_and_a_closed_peer_is_a_disconnect() {
        let (reader, mut writer) = io::pipe().expect("a pipe");
        let mut ev = EventFile {
            file: File::from(std::os::fd::OwnedFd::from(reader)),
            buf: vec![0u8; EVENT_BUFFER].into_boxed_slice(),
        };
        assert_eq!(ev.wait(1_000_000), Ok(false));
        let b = event_bytes(0x1_0000, 1, &[RCODE_ADDRESS_ERROR, 0], &[]);
        io::Write::write_all(&mut writer, &b).expect("write an event");
        assert_eq!(ev.wait(1_000_000_000), Ok(true));
        let n = ev.read_one().expect("read").expect("an event");
        assert_eq!(
            ev.event(n),
            Some(Event::Response {
                closure: 0x1_0000,
                rcode: RCODE_ADDRESS_ERROR,
                data: &[]
            })
        );
        drop(writer);
        assert_eq!(ev.wait(1_000_000_000), Err(DeviceError::Disconnected));
        assert_eq!(ev.read_one(), Ok(None));
    }
}
