//! The isochronous streams: the mapped DMA buffer of a context ([`IsoBuffer`]), the receive
//! ring the Omni's 44-byte input packets arrive in, the transmit ring its 16-byte outputs are
//! repeated from, and the arithmetic of both (ring runs, transmit depth, bandwidth units).
//! `unsafe` is allowed in this file: each block is one system call (`sysconf`, `mmap`,
//! `munmap`) or one copy in the mapping, with its `// SAFETY:` reason.
#![allow(unsafe_code)]

use std::fs::File;
use std::io;
use std::os::fd::AsRawFd;
use std::ptr::NonNull;

use super::abi::{iso_header_length, ISO_CONTEXT_MATCH_ALL_TAGS, ISO_INTERRUPT};
use super::event::{iso_payload_length, Event, EventFile};
use super::ioctl::{queue_iso, start_iso};
use super::transport::CdevStats;
use crate::device::DeviceError;
use crate::omni::packet::{INPUT_LEN, OUTPUT_LEN};
use crate::os::clock::now_ns;

/// A shared mapping of a node fd: the payload buffer of its iso context.
#[derive(Debug)]
pub(super) struct IsoBuffer {
    ptr: NonNull<u8>,
    len: usize,
    writable: bool,
}

// SAFETY: the mapping belongs to this value alone (made in `map`, unmapped only in `drop`) and
// is reached only through its methods; moving it to another thread moves that ownership.
unsafe impl Send for IsoBuffer {}

impl IsoBuffer {
    pub(super) fn map(file: &File, min_len: usize, writable: bool) -> io::Result<IsoBuffer> {
        // SAFETY: sysconf takes no pointers.
        let page = unsafe { libc::sysconf(libc::_SC_PAGESIZE) };
        let page = if page > 0 { page as usize } else { 4096 };
        let len = min_len.div_ceil(page).max(1) * page;
        let prot = if writable {
            libc::PROT_READ | libc::PROT_WRITE
        } else {
            libc::PROT_READ
        };
        // SAFETY: a new shared mapping of `len` bytes of this fd at an address the kernel
        // picks (null hint); nothing else refers to that range.
        let p = unsafe {
            libc::mmap(
                std::ptr::null_mut(),
                len,
                prot,
                libc::MAP_SHARED,
                file.as_raw_fd(),
                0,
            )
        };
        if p == libc::MAP_FAILED {
            return Err(io::Error::last_os_error());
        }
        let ptr = NonNull::new(p.cast::<u8>()).ok_or_else(|| io::Error::other("mmap gave null"))?;
        Ok(IsoBuffer { ptr, len, writable })
    }

    /// The mapping's length in bytes (whole pages).
    pub(super) fn len(&self) -> usize {
        self.len
    }

    pub(super) fn addr(&self) -> u64 {
        self.ptr.as_ptr() as u64
    }

    fn fits(&self, offset: usize, n: usize) -> bool {
        offset.checked_add(n).is_some_and(|end| end <= self.len)
    }

    /// Copies `out.len()` bytes from `offset`; `false` (nothing copied) outside the buffer.
    fn read(&self, offset: usize, out: &mut [u8]) -> bool {
        if !self.fits(offset, out.len()) {
            return false;
        }
        // SAFETY: the range lies in the live mapping (checked); it is a completed receive
        // slot, which the controller does not write again until it is queued again.
        unsafe {
            std::ptr::copy_nonoverlapping(
                self.ptr.as_ptr().add(offset),
                out.as_mut_ptr(),
                out.len(),
            )
        };
        true
    }

    /// Copies `src` to `offset`; `false` (nothing written) outside a writable buffer.
    fn write(&mut self, offset: usize, src: &[u8]) -> bool {
        if !self.writable || !self.fits(offset, src.len()) {
            return false;
        }
        // SAFETY: the range lies in the live, writable mapping (checked); it is a transmit
        // slot not queued, which the controller is not reading.
        unsafe {
            std::ptr::copy_nonoverlapping(src.as_ptr(), self.ptr.as_ptr().add(offset), src.len())
        };
        true
    }
}

impl Drop for IsoBuffer {
    fn drop(&mut self) {
        // SAFETY: exactly the mapping made in `map`, unmapped once.
        unsafe { libc::munmap(self.ptr.as_ptr().cast(), self.len) };
    }
}

/// Receive ring: slots of 64 bytes (the Omni's 44-byte packet rounded up to what public Omni
/// code reserves; payloads must be whole quadlets).
pub(super) const RX_SLOTS: usize = 64;
pub(super) const RX_SLOT_BYTES: usize = 64;
/// Header bytes the receive context strips per packet: the isochronous header only.
pub(super) const RX_HEADER_BYTES: usize = 4;
/// Each receive slot: up to 64 payload bytes, one stripped header, an event when it fills.
const RX_CONTROL: u32 =
    RX_SLOT_BYTES as u32 | iso_header_length(RX_HEADER_BYTES as u32) | ISO_INTERRUPT;
/// Transmit ring of 16-byte packets (tag 0, sy 0, no header quadlets).
pub(super) const TX_SLOTS: usize = 64;
const TX_CONTROL: u32 = OUTPUT_LEN as u32;

/// The one or two contiguous runs of `count` ring slots from `start` (the second empty unless
/// the run wraps). `count` is capped at the ring size.
fn ring_runs(start: usize, count: usize, slots: usize) -> [(usize, usize); 2] {
    if slots == 0 {
        return [(0, 0); 2];
    }
    let start = start % slots;
    let count = count.min(slots);
    let first = count.min(slots - start);
    [(start, first), (0, count - first)]
}

/// How many copies of an output packet to queue: enough to bring the packets in flight back
/// to `depth` (at least one, so the newest force always goes out), `depth` to start.
pub(super) fn tx_batch(inflight: usize, depth: usize, started: bool) -> usize {
    let depth = depth.max(1);
    if started {
        depth.saturating_sub(inflight).clamp(1, depth)
    } else {
        depth
    }
}

/// Isochronous bandwidth for one packet of `payload` bytes per cycle, in allocation units
/// (one quadlet at S1600): payload quadlets plus the iso header, header CRC and data CRC at the
/// stream's speed, plus 512 units for arbitration and gaps (the pessimistic constant Linux
/// drivers use when the gap count is not optimised).
pub(super) fn bandwidth_units(payload: usize, speed: u32) -> u32 {
    let quadlets = payload.div_ceil(4) as u32 + 3;
    quadlets * (16 >> speed.min(4)) + 512
}

#[derive(Debug)]
pub(super) struct RxStream {
    pub(super) ev: EventFile,
    pub(super) handle: u32,
    pub(super) buf: IsoBuffer,
    pub(super) started: bool,
    pub(super) started_ns: u64,
    pub(super) next: usize,
    pub(super) last: [u8; INPUT_LEN],
    pub(super) last_ns: Option<u64>,
    pub(super) short: [u8; INPUT_LEN],
}

impl RxStream {
    fn queue(&mut self, start: usize, count: usize) -> Result<(), DeviceError> {
        let controls = [RX_CONTROL; RX_SLOTS];
        for (slot, n) in ring_runs(start, count, RX_SLOTS) {
            if n > 0 {
                queue_iso(
                    &self.ev.file,
                    self.handle,
                    &controls[..n],
                    &self.buf,
                    slot * RX_SLOT_BYTES,
                    RX_SLOT_BYTES,
                )?;
            }
        }
        Ok(())
    }

    pub(super) fn start(&mut self) -> Result<(), DeviceError> {
        self.queue(0, RX_SLOTS)?;
        start_iso(&self.ev.file, self.handle, ISO_CONTEXT_MATCH_ALL_TAGS)?;
        self.started = true;
        self.started_ns = now_ns();
        self.next = 0;
        Ok(())
    }

    /// Takes every completed packet, keeps the newest complete one, queues the slots again.
    /// Returns the length of the newest packet: 44 when a complete one came, a shorter length
    /// when only short ones came, `None` when none came.
    pub(super) fn drain(&mut self, stats: &mut CdevStats) -> Result<Option<usize>, DeviceError> {
        let mut newest = None;
        while let Some(n) = self.ev.read_one()? {
            let mut lengths = [0usize; RX_SLOTS];
            let mut count = 0;
            match self.ev.event(n) {
                Some(Event::IsoInterrupt { headers, .. }) => {
                    for (len, h) in lengths
                        .iter_mut()
                        .zip(headers.chunks_exact(RX_HEADER_BYTES))
                    {
                        *len = iso_payload_length(h);
                        count += 1;
                    }
                }
                Some(Event::BusReset { .. }) => stats.bus_resets += 1,
                _ => {}
            }
            for (i, &len) in lengths[..count].iter().enumerate() {
                let slot = (self.next + i) % RX_SLOTS;
                stats.rx_packets += 1;
                if len >= INPUT_LEN {
                    // Longer packets carry zeros after the known 44 bytes.
                    if self.buf.read(slot * RX_SLOT_BYTES, &mut self.last) {
                        self.last_ns = Some(now_ns());
                        newest = Some(INPUT_LEN);
                    }
                } else {
                    stats.rx_short += 1;
                    if newest != Some(INPUT_LEN) {
                        self.short = [0; INPUT_LEN];
                        if let Some(part) = self.short.get_mut(..len) {
                            self.buf.read(slot * RX_SLOT_BYTES, part);
                        }
                        newest = Some(len);
                    }
                }
            }
            if count > 0 {
                self.queue(self.next, count)?;
                self.next = (self.next + count) % RX_SLOTS;
            }
        }
        Ok(newest)
    }
}

#[derive(Debug)]
pub(super) struct TxStream {
    pub(super) ev: EventFile,
    pub(super) handle: u32,
    pub(super) buf: IsoBuffer,
    pub(super) started: bool,
    pub(super) head: usize,
    pub(super) queued: u64,
    pub(super) completed: u64,
}

impl TxStream {
    pub(super) fn inflight(&self) -> usize {
        self.queued.saturating_sub(self.completed) as usize
    }

    /// Counts the packets the controller has sent (one timestamp quadlet each in the
    /// interrupt event's headers).
    pub(super) fn collect(&mut self) -> Result<(), DeviceError> {
        while let Some(n) = self.ev.read_one()? {
            if let Some(Event::IsoInterrupt { headers, .. }) = self.ev.event(n) {
                self.completed = (self.completed + (headers.len() / 4) as u64).min(self.queued);
            }
        }
        Ok(())
    }

    /// Writes `copies` copies of `packet` into free slots and queues them, an event after the
    /// last of each run. The caller has made room (`inflight() + copies <= TX_SLOTS`).
    pub(super) fn push(
        &mut self,
        packet: &[u8; OUTPUT_LEN],
        copies: usize,
    ) -> Result<(), DeviceError> {
        let copies = copies.min(TX_SLOTS - self.inflight().min(TX_SLOTS));
        for (slot, n) in ring_runs(self.head, copies, TX_SLOTS) {
            if n == 0 {
                continue;
            }
            for s in slot..slot + n {
                if !self.buf.write(s * OUTPUT_LEN, packet) {
                    return Err(DeviceError::Transport("transmit slot outside the buffer"));
                }
            }
            let mut controls = [TX_CONTROL; TX_SLOTS];
            controls[n - 1] |= ISO_INTERRUPT;
            queue_iso(
                &self.ev.file,
                self.handle,
                &controls[..n],
                &self.buf,
                slot * OUTPUT_LEN,
                OUTPUT_LEN,
            )?;
            self.head = (slot + n) % TX_SLOTS;
            self.queued += n as u64;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::fs::OpenOptions;

    use crate::os::firewire::abi::SCODE_100;

    #[test]
    fn packet_control_words_follow_the_header_macros() {
        // FW_CDEV_ISO_HEADER_LENGTH(4) = 4 << 24, FW_CDEV_ISO_INTERRUPT = 1 << 16,
        // FW_CDEV_ISO_PAYLOAD_LENGTH(64) = 64.
        assert_eq!(RX_CONTROL, 0x0401_0040);
        // Tag 0, sy 0, no header quadlets, 16 payload bytes.
        assert_eq!(TX_CONTROL, 0x0000_0010);
        assert_eq!(TX_CONTROL | ISO_INTERRUPT, 0x0001_0010);
    }

    #[test]
    fn mapped_buffers_check_every_range() {
        let Ok(zero) = OpenOptions::new().read(true).write(true).open("/dev/zero") else {
            note!("note: skipped: /dev/zero cannot be opened here");
            return;
        };
        let mut buf = IsoBuffer::map(&zero, 100, true).expect("map /dev/zero");
        assert!(buf.len >= 100);
        let packet = [0xa5u8; OUTPUT_LEN];
        assert!(buf.write(3 * OUTPUT_LEN, &packet));
        let mut back = [0u8; OUTPUT_LEN];
        assert!(buf.read(3 * OUTPUT_LEN, &mut back));
        assert_eq!(back, packet);
        let end = buf.len;
        assert!(!buf.write(end - 2, &packet));
        assert!(!buf.read(end - 2, &mut back));
        assert!(!buf.read(usize::MAX, &mut back));
        assert!(buf.read(end - OUTPUT_LEN, &mut back));
        let mut ro = IsoBuffer::map(&zero, 10, false).expect("map read-only");
        assert!(!ro.write(0, &packet), "a receive buffer is never written");
        assert!(queue_iso(
            &zero,
            0,
            &[TX_CONTROL; 2],
            &buf,
            end - OUTPUT_LEN,
            OUTPUT_LEN
        )
        .is_err());
    }

    #[test]
    fn ring_runs_split_at_the_wrap() {
        assert_eq!(ring_runs(60, 8, 64), [(60, 4), (0, 4)]);
        assert_eq!(ring_runs(0, 64, 64), [(0, 64), (0, 0)]);
        assert_eq!(ring_runs(63, 1, 64), [(63, 1), (0, 0)]);
        assert_eq!(ring_runs(10, 100, 64), [(10, 54), (0, 10)]);
        assert_eq!(ring_runs(70, 2, 64), [(6, 2), (0, 0)]);
        assert_eq!(ring_runs(5, 0, 64), [(5, 0), (0, 0)]);
        assert_eq!(ring_runs(5, 3, 0), [(0, 0), (0, 0)]);
        // Every slot once, whatever the start.
        for start in 0..64 {
            for count in 0..=64 {
                let mut seen = [0u32; 64];
                for (s, n) in ring_runs(start, count, 64) {
                    assert!(s + n <= 64);
                    for slot in &mut seen[s..s + n] {
                        *slot += 1;
                    }
                }
                let want: Vec<u32> = (0..64)
                    .map(|i| u32::from((i + 64 - start) % 64 < count))
                    .collect();
                assert_eq!(seen.to_vec(), want, "start {start} count {count}");
            }
        }
    }

    #[test]
    fn transmit_depth_is_regulated_without_starving_the_bus() {
        assert_eq!(tx_batch(0, 16, false), 16);
        assert_eq!(tx_batch(8, 16, true), 8);
        assert_eq!(tx_batch(0, 16, true), 16);
        assert_eq!(tx_batch(20, 16, true), 1);
        assert_eq!(tx_batch(3, 0, true), 1);
        // A servo at 1 kHz against a bus taking 8 packets per ms, with the servo's period
        // jittering so that between two outputs the bus takes 4 to 12 packets.
        let consumed = [8, 8, 12, 4, 8, 9, 7, 12, 12, 4, 4, 8, 10, 6];
        let mut inflight = 0usize;
        let mut started = false;
        for round in 0..200 {
            inflight += tx_batch(inflight, 16, started);
            started = true;
            assert!(inflight <= 16 + 1, "round {round}: {inflight} queued");
            let take = consumed[round % consumed.len()];
            assert!(inflight >= take, "round {round}: the bus ran dry");
            inflight -= take;
        }
    }

    #[test]
    fn bandwidth_follows_the_allocation_unit_arithmetic() {
        // (16 bytes = 4 quadlets + header, header CRC, data CRC) x 16 units at S100 + 512.
        assert_eq!(bandwidth_units(OUTPUT_LEN, SCODE_100), 7 * 16 + 512);
        // 64 bytes: 16 + 3 quadlets.
        assert_eq!(bandwidth_units(RX_SLOT_BYTES, SCODE_100), 19 * 16 + 512);
        // 44 bytes round up to 11 quadlets; S400 (code 2) is 4 units a quadlet.
        assert_eq!(bandwidth_units(44, 2), 14 * 4 + 512);
    }
}
