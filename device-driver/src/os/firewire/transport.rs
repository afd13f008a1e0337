//! [`CdevFirewire`], the [`FirewireTransport`] over one node: register requests with a
//! deadline, the isochronous streams started on first use, [`CdevOut`] (the second path to
//! the transmit stream, for a supervisor thread), and motors off when it is dropped.

use std::io;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, MutexGuard, TryLockError};

use super::abi::{
    AllocateIsoResource, BusReset, ALLOCATE_ISO_RESOURCE, ISO_CONTEXT_RECEIVE,
    ISO_CONTEXT_TRANSMIT, RCODE_COMPLETE, RCODE_GENERATION, SCODE_100, TCODE_READ_BLOCK_REQUEST,
    TCODE_READ_QUADLET_REQUEST, TCODE_WRITE_BLOCK_REQUEST, TCODE_WRITE_QUADLET_REQUEST,
};
use super::error::{errno_error, rcode_result, OpenError};
use super::event::{
    Event, EventFile, CLOSURE_ALLOC_RX, CLOSURE_ALLOC_TX, CLOSURE_FIRST_REQUEST, CLOSURE_RX,
    CLOSURE_TX,
};
use super::ioctl::{create_context, get_info, ioctl_plain, send_request, start_iso, stop_iso};
use super::iso::{
    bandwidth_units, tx_batch, IsoBuffer, RxStream, TxStream, RX_HEADER_BYTES, RX_SLOTS,
    RX_SLOT_BYTES, TX_SLOTS,
};
use crate::cutoff::{Cut, OutPath, PACKET_LEN};
use crate::device::DeviceError;
use crate::omni::packet::{encode_output, OmniOutput, INPUT_LEN, MOTOR_ZERO, OUTPUT_LEN};
use crate::omni::FirewireTransport;
use crate::os::clock::now_ns;

/// Settings of [`CdevFirewire`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CdevConfig {
    /// Channel the host receives on (the Omni transmits on; written to its 0x1001): `None`,
    /// the default, takes the lowest channel the bus's isochronous resource manager has free.
    pub receive_channel: Option<u8>,
    /// Channel the host transmits on (written to the Omni's 0x1000): `None`, the default,
    /// takes the lowest other free channel.
    pub transmit_channel: Option<u8>,
    /// Transmit speed code ([`SCODE_100`] as public Omni code uses).
    pub speed: u32,
    /// Longest wait for a register read or write, ms.
    pub request_timeout_ms: u32,
    /// Longest wait for the resource manager's answer, ms.
    pub allocate_timeout_ms: u32,
    /// Longest wait for the first input packet after the stream starts, ms.
    pub first_packet_timeout_ms: u32,
    /// Wait for a new input packet once the stream flows, us (two bus cycles by default).
    pub packet_wait_us: u32,
    /// How long the newest input packet may be handed out again when no new one came, ms;
    /// past it, and when the transmit ring stays full that long, the result is `Timeout`.
    pub stall_limit_ms: u32,
    /// Output packets kept queued ahead of the bus (8 per ms at 8000 cycles per second).
    pub tx_depth: usize,
}

impl Default for CdevConfig {
    fn default() -> CdevConfig {
        CdevConfig {
            receive_channel: None,
            transmit_channel: None,
            speed: SCODE_100,
            request_timeout_ms: 1000,
            allocate_timeout_ms: 2000,
            first_packet_timeout_ms: 500,
            packet_wait_us: 250,
            stall_limit_ms: 20,
            tx_depth: 16,
        }
    }
}

/// The `channels` mask of an allocation request: the wanted channel, or every channel but
/// `taken` (the kernel grants the lowest free one in the mask).
fn channel_mask(wanted: Option<u8>, taken: Option<u8>) -> u64 {
    match (wanted, taken) {
        (Some(c), _) => 1u64 << (c & 63),
        (None, Some(t)) => !(1u64 << (t & 63)),
        (None, None) => u64::MAX,
    }
}

/// The channel an `FW_CDEV_EVENT_ISO_RESOURCE_*` event grants, or why it grants none (the
/// kernel puts a negative errno in the channel or bandwidth field).
fn granted(allocated: bool, channel: i32, bandwidth: i32) -> Result<u8, String> {
    if !allocated {
        return Err("the isochronous resource manager took the channel back".into());
    }
    if channel < 0 || bandwidth < 0 || channel > 63 {
        let errno = if channel < 0 { -channel } else { -bandwidth };
        return Err(format!(
            "the isochronous resource manager granted no channel ({})",
            io::Error::from_raw_os_error(errno.max(0))
        ));
    }
    Ok(channel as u8)
}

/// Allocates one channel in `mask` with `bandwidth` units for the life of the control file
/// (the kernel reallocates it after bus resets and frees it on close) and waits, up to
/// `timeout_ms`, for the resource manager's answer. Bus resets met are counted in `resets`
/// and their generation kept in `generation`.
fn allocate_one(
    ctl: &mut EventFile,
    closure: u64,
    mask: u64,
    bandwidth: u32,
    timeout_ms: u32,
    resets: &mut u64,
    generation: &mut u32,
) -> Result<u8, String> {
    let mut a = AllocateIsoResource {
        closure,
        channels: mask,
        bandwidth,
        handle: 0,
    };
    ioctl_plain(&ctl.file, ALLOCATE_ISO_RESOURCE, &mut a)
        .map_err(|e| format!("FW_CDEV_IOC_ALLOCATE_ISO_RESOURCE: {e}"))?;
    let deadline = now_ns() + u64::from(timeout_ms) * 1_000_000;
    loop {
        let Some(n) = ctl.read_one().map_err(|e| e.to_string())? else {
            let left = deadline.saturating_sub(now_ns());
            if left == 0 {
                return Err(format!(
                    "no answer from the isochronous resource manager in {timeout_ms} ms"
                ));
            }
            ctl.wait(left).map_err(|e| e.to_string())?;
            continue;
        };
        match ctl.event(n) {
            Some(Event::IsoResource {
                closure: c,
                allocated,
                channel,
                bandwidth,
            }) if c == closure => return granted(allocated, channel, bandwidth),
            Some(Event::BusReset { generation: g, .. }) => {
                *resets += 1;
                *generation = g;
            }
            _ => {}
        }
    }
}

/// Counters of a [`CdevFirewire`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CdevStats {
    /// Bus resets seen on the receive stream.
    pub bus_resets: u64,
    /// Input packets received.
    pub rx_packets: u64,
    /// Input packets shorter than 44 bytes.
    pub rx_short: u64,
    /// Times the newest input packet was handed out again because no new one had come.
    pub rx_reused: u64,
    /// Output packets queued (each output is repeated over several bus cycles).
    pub tx_packets: u64,
    /// Outputs that found nothing left in flight (the bus had run out of output packets).
    pub tx_starved: u64,
    /// Outputs not queued because a cut held the transmit stream ([`CdevOut`] queuing
    /// motors-off packets; the device's latch turns its own outputs to motors off meanwhile).
    pub tx_yielded: u64,
}

/// [`FirewireTransport`] over a Linux `/dev/fw*` node (firewire-cdev).
///
/// Register access is synchronous with a deadline. The isochronous streams start lazily: the
/// receive stream at the first [`FirewireTransport::receive`], the transmit stream at the
/// first [`FirewireTransport::transmit`], so they begin after `OmniDevice::start` has written
/// the start-up registers, in the order public Omni code uses. Dropping the transport sends
/// motors-off packets, then stops both streams; closing the files frees the contexts and the
/// channels.
#[derive(Debug)]
pub struct CdevFirewire {
    path: PathBuf,
    config: CdevConfig,
    ctl: EventFile,
    generation: u32,
    next_closure: u64,
    rx: RxStream,
    tx: Arc<Mutex<TxStream>>,
    stats: CdevStats,
    channels: (u8, u8),
    ctl_resets: u64,
    resets_taken: u64,
}

impl CdevFirewire {
    /// Opens `path` three times (control, receive, transmit), allocates the two channels at
    /// the bus's isochronous resource manager, creates both isochronous contexts on them and
    /// maps their buffers. A channel the manager does not grant fails the open (step
    /// `channels`). Nothing is sent on the bus except the allocation; streams start on first
    /// use.
    pub fn open(path: &Path, config: CdevConfig) -> Result<CdevFirewire, OpenError> {
        let io_err = |step: &'static str| move |e: io::Error| OpenError::io(path, step, &e);
        for channel in [config.receive_channel, config.transmit_channel]
            .into_iter()
            .flatten()
        {
            if channel > 63 {
                return Err(OpenError {
                    path: path.to_path_buf(),
                    step: "channels",
                    reason: format!("isochronous channel {channel} is not in 0..=63"),
                    device: DeviceError::Transport("isochronous channel out of range"),
                });
            }
        }
        let mut ctl = EventFile::open(path, true).map_err(io_err("open"))?;
        let mut bus = BusReset::default();
        get_info(&ctl.file, None, &mut bus).map_err(io_err("FW_CDEV_IOC_GET_INFO"))?;
        let refused = |reason: String| OpenError {
            path: path.to_path_buf(),
            step: "channels",
            reason,
            device: DeviceError::Transport("no isochronous channel granted"),
        };
        let mut ctl_resets = 0;
        let rx_channel = allocate_one(
            &mut ctl,
            CLOSURE_ALLOC_RX,
            channel_mask(config.receive_channel, None),
            bandwidth_units(RX_SLOT_BYTES, config.speed),
            config.allocate_timeout_ms,
            &mut ctl_resets,
            &mut bus.generation,
        )
        .map_err(refused)?;
        let tx_channel = allocate_one(
            &mut ctl,
            CLOSURE_ALLOC_TX,
            channel_mask(config.transmit_channel, Some(rx_channel)),
            bandwidth_units(OUTPUT_LEN, config.speed),
            config.allocate_timeout_ms,
            &mut ctl_resets,
            &mut bus.generation,
        )
        .map_err(refused)?;

        let rx_ev = EventFile::open(path, true).map_err(io_err("open"))?;
        get_info(&rx_ev.file, None, &mut BusReset::default())
            .map_err(io_err("FW_CDEV_IOC_GET_INFO"))?;
        let rx_handle = create_context(
            &rx_ev.file,
            ISO_CONTEXT_RECEIVE,
            RX_HEADER_BYTES as u32,
            rx_channel,
            0,
            CLOSURE_RX,
        )
        .map_err(io_err("FW_CDEV_IOC_CREATE_ISO_CONTEXT (receive)"))?;
        let rx_buf = IsoBuffer::map(&rx_ev.file, RX_SLOTS * RX_SLOT_BYTES, false)
            .map_err(io_err("mmap (receive buffer)"))?;

        let tx_ev = EventFile::open(path, true).map_err(io_err("open"))?;
        get_info(&tx_ev.file, None, &mut BusReset::default())
            .map_err(io_err("FW_CDEV_IOC_GET_INFO"))?;
        let tx_handle = create_context(
            &tx_ev.file,
            ISO_CONTEXT_TRANSMIT,
            0,
            tx_channel,
            config.speed,
            CLOSURE_TX,
        )
        .map_err(io_err("FW_CDEV_IOC_CREATE_ISO_CONTEXT (transmit)"))?;
        let tx_buf = IsoBuffer::map(&tx_ev.file, TX_SLOTS * OUTPUT_LEN, true)
            .map_err(io_err("mmap (transmit buffer)"))?;

        let t = CdevFirewire {
            path: path.to_path_buf(),
            config,
            ctl,
            generation: bus.generation,
            next_closure: CLOSURE_FIRST_REQUEST,
            rx: RxStream {
                ev: rx_ev,
                handle: rx_handle,
                buf: rx_buf,
                started: false,
                started_ns: 0,
                next: 0,
                last: [0; INPUT_LEN],
                last_ns: None,
                short: [0; INPUT_LEN],
            },
            tx: Arc::new(Mutex::new(TxStream {
                ev: tx_ev,
                handle: tx_handle,
                buf: tx_buf,
                started: false,
                head: 0,
                queued: 0,
                completed: 0,
            })),
            stats: CdevStats::default(),
            channels: (rx_channel, tx_channel),
            ctl_resets,
            resets_taken: 0,
        };
        Ok(t)
    }

    /// The node.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Counters.
    pub fn stats(&self) -> CdevStats {
        self.stats
    }

    fn refresh_generation(&mut self) -> Result<(), DeviceError> {
        let mut bus = BusReset::default();
        get_info(&self.ctl.file, None, &mut bus).map_err(|e| errno_error(&e))?;
        self.generation = bus.generation;
        Ok(())
    }

    /// One asynchronous transaction at `address`: sends `payload`, waits for the response
    /// (bounded by `request_timeout_ms`), copies its data into `out`. A request that meets a
    /// bus reset is sent once more with the new generation.
    fn request(
        &mut self,
        tcode: u32,
        address: u64,
        payload: &[u8],
        out: &mut [u8],
    ) -> Result<(), DeviceError> {
        if address >> 48 != 0 {
            return Err(DeviceError::Transport(
                "address beyond the 48-bit node space",
            ));
        }
        let timeout_ns = u64::from(self.config.request_timeout_ms) * 1_000_000;
        for attempt in 0..2 {
            let closure = self.next_closure;
            self.next_closure = self.next_closure.wrapping_add(1);
            send_request(
                &self.ctl.file,
                tcode,
                address,
                payload,
                closure,
                self.generation,
            )
            .map_err(|e| errno_error(&e))?;
            let deadline = now_ns() + timeout_ns;
            let rcode = loop {
                let Some(n) = self.ctl.read_one()? else {
                    let left = deadline.saturating_sub(now_ns());
                    if left == 0 {
                        return Err(DeviceError::Timeout);
                    }
                    self.ctl.wait(left)?;
                    continue;
                };
                match self.ctl.event(n) {
                    Some(Event::Response {
                        closure: c,
                        rcode,
                        data,
                    }) if c == closure => {
                        if rcode == RCODE_COMPLETE {
                            let Some(d) = data.get(..out.len()) else {
                                return Err(DeviceError::Transport("short response from the node"));
                            };
                            out.copy_from_slice(d);
                        }
                        break rcode;
                    }
                    Some(Event::BusReset { generation, .. }) => {
                        self.generation = generation;
                        self.ctl_resets += 1;
                    }
                    _ => {}
                }
            };
            if rcode == RCODE_GENERATION && attempt == 0 {
                self.refresh_generation()?;
                continue;
            }
            return rcode_result(rcode);
        }
        rcode_result(RCODE_GENERATION)
    }
}

impl FirewireTransport for CdevFirewire {
    /// A quadlet read request; the response's four bytes are big-endian (bus order).
    fn read_quadlet(&mut self, address: u64) -> Result<u32, DeviceError> {
        let mut q = [0u8; 4];
        self.request(TCODE_READ_QUADLET_REQUEST, address, &[0; 4], &mut q)?;
        Ok(u32::from_be_bytes(q))
    }

    /// A quadlet write request; the value goes out big-endian (bus order).
    fn write_quadlet(&mut self, address: u64, value: u32) -> Result<(), DeviceError> {
        self.request(
            TCODE_WRITE_QUADLET_REQUEST,
            address,
            &value.to_be_bytes(),
            &mut [],
        )
    }

    /// The channels granted at [`CdevFirewire::open`]; the kernel keeps them across bus
    /// resets.
    fn channels(&mut self) -> Result<(u8, u8), DeviceError> {
        Ok(self.channels)
    }

    /// Bus resets seen on the control file (during requests) or the receive stream.
    fn take_bus_reset(&mut self) -> bool {
        let seen = self.ctl_resets + self.stats.bus_resets;
        let new = seen != self.resets_taken;
        self.resets_taken = seen;
        new
    }

    /// A one-byte block read request.
    fn read_byte(&mut self, address: u64) -> Result<u8, DeviceError> {
        let mut b = [0u8; 1];
        self.request(TCODE_READ_BLOCK_REQUEST, address, &[0; 1], &mut b)?;
        Ok(b[0])
    }

    /// A one-byte block write request.
    fn write_byte(&mut self, address: u64, value: u8) -> Result<(), DeviceError> {
        self.request(TCODE_WRITE_BLOCK_REQUEST, address, &[value], &mut [])
    }

    /// The newest input packet. When none came since the last call it waits `packet_wait_us`
    /// (up to `first_packet_timeout_ms` for the very first), then hands out the previous
    /// packet again while it is younger than `stall_limit_ms`; past that, `Timeout`.
    fn receive(&mut self, packet: &mut [u8; INPUT_LEN]) -> Result<usize, DeviceError> {
        if !self.rx.started {
            self.rx.start()?;
        }
        let mut got = self.rx.drain(&mut self.stats)?;
        if got.is_none() {
            let wait_ns = match self.rx.last_ns {
                Some(_) => u64::from(self.config.packet_wait_us) * 1000,
                None => (self.rx.started_ns
                    + u64::from(self.config.first_packet_timeout_ms) * 1_000_000)
                    .saturating_sub(now_ns()),
            };
            let deadline = now_ns() + wait_ns;
            loop {
                let left = deadline.saturating_sub(now_ns());
                if left == 0 {
                    break;
                }
                if self.rx.ev.wait(left)? {
                    got = self.rx.drain(&mut self.stats)?;
                    if got.is_some() {
                        break;
                    }
                }
            }
        }
        match got {
            Some(INPUT_LEN) => {
                *packet = self.rx.last;
                Ok(INPUT_LEN)
            }
            Some(len) => {
                *packet = self.rx.short;
                Ok(len)
            }
            None => {
                let stall_ns = u64::from(self.config.stall_limit_ms) * 1_000_000;
                match self.rx.last_ns {
                    Some(t) if now_ns().saturating_sub(t) < stall_ns => {
                        self.stats.rx_reused += 1;
                        *packet = self.rx.last;
                        Ok(INPUT_LEN)
                    }
                    _ => Err(DeviceError::Timeout),
                }
            }
        }
    }

    /// Queues the packet as many times as needed to keep `tx_depth` packets ahead of the bus
    /// (at least once); waits up to `stall_limit_ms` when the ring is full, then `Timeout`.
    ///
    /// The stream is only `try_lock`ed: when a cut holds it ([`CdevOut`]), this packet is not
    /// queued (counted in `tx_yielded`) and the call returns at once.
    fn transmit(&mut self, packet: &[u8; OUTPUT_LEN]) -> Result<(), DeviceError> {
        let mut tx = match self.tx.try_lock() {
            Ok(tx) => tx,
            Err(TryLockError::Poisoned(p)) => p.into_inner(),
            Err(TryLockError::WouldBlock) => {
                self.stats.tx_yielded += 1;
                return Ok(());
            }
        };
        tx.collect()?;
        let depth = self.config.tx_depth.clamp(1, TX_SLOTS / 2);
        if tx.started && tx.inflight() == 0 {
            self.stats.tx_starved += 1;
        }
        let copies = tx_batch(tx.inflight(), depth, tx.started);
        if tx.inflight() + copies > TX_SLOTS {
            let deadline = now_ns() + u64::from(self.config.stall_limit_ms) * 1_000_000;
            while tx.inflight() + copies > TX_SLOTS {
                let left = deadline.saturating_sub(now_ns());
                if left == 0 {
                    return Err(DeviceError::Timeout);
                }
                if tx.ev.wait(left)? {
                    tx.collect()?;
                }
            }
        }
        tx.push(packet, copies)?;
        self.stats.tx_packets += copies as u64;
        if !tx.started {
            start_iso(&tx.ev.file, tx.handle, 0)?;
            tx.started = true;
        }
        Ok(())
    }

    fn out_path(&self) -> Option<Arc<dyn OutPath>> {
        Some(Arc::new(CdevOut {
            tx: Arc::clone(&self.tx),
            depth: self.config.tx_depth.clamp(1, TX_SLOTS / 2),
        }))
    }
}

/// The Omni's second path to its transmit stream, for a supervisor thread: queues a packet
/// (motors off) behind what is already in flight, without waiting for anything.
///
/// It only `try_lock`s the stream: while the servo thread is inside
/// [`FirewireTransport::transmit`] (at most `stall_limit_ms` when the ring is full) the answer
/// is [`Cut::Busy`], and the supervisor tries again. The packets already queued (up to
/// `tx_depth`, 2 ms of bus cycles) still go out before the motors-off ones: they cannot be
/// taken back from the controller.
#[derive(Debug)]
pub struct CdevOut {
    tx: Arc<Mutex<TxStream>>,
    depth: usize,
}

impl OutPath for CdevOut {
    fn send(&self, packet: &[u8; PACKET_LEN]) -> Result<Cut, DeviceError> {
        let mut tx = match self.tx.try_lock() {
            Ok(tx) => tx,
            Err(TryLockError::Poisoned(p)) => p.into_inner(),
            Err(TryLockError::WouldBlock) => return Ok(Cut::Busy),
        };
        if !tx.started {
            // Nothing was ever transmitted: the motors were never on.
            return Ok(Cut::Done);
        }
        tx.collect()?;
        let free = TX_SLOTS - tx.inflight().min(TX_SLOTS);
        if free == 0 {
            // The bus has stopped taking packets: nothing queued now would go out sooner.
            return Ok(Cut::Busy);
        }
        tx.push(packet, self.depth.min(free))?;
        Ok(Cut::Done)
    }
}

impl Drop for CdevFirewire {
    fn drop(&mut self) {
        // A cut in progress holds the stream for one non-blocking queue call at most.
        let mut tx: MutexGuard<'_, TxStream> = match self.tx.lock() {
            Ok(tx) => tx,
            Err(p) => p.into_inner(),
        };
        if tx.started {
            // The last packets the Omni receives carry zero torque with the motors off.
            let idle = encode_output(&OmniOutput {
                motors: [MOTOR_ZERO; 3],
                motors_on: false,
                dock_flash: false,
            });
            let _ = tx.collect();
            let copies = self.config.tx_depth.clamp(1, TX_SLOTS / 2);
            if tx.push(&idle, copies).is_ok() {
                let deadline = now_ns() + 20_000_000;
                while tx.inflight() > 0 {
                    let left = deadline.saturating_sub(now_ns());
                    if left == 0 || !matches!(tx.ev.wait(left), Ok(true)) {
                        break;
                    }
                    if tx.collect().is_err() {
                        break;
                    }
                }
            }
            let _ = stop_iso(&tx.ev.file, tx.handle);
        }
        if self.rx.started {
            let _ = stop_iso(&self.rx.ev.file, self.rx.handle);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::os::firewire::discovery::read_config_rom;
    use crate::os::firewire::scratch;

    #[test]
    fn opening_what_is_not_a_node_is_one_clear_error() {
        let dir = scratch("open");
        let absent = dir.join("fw9");
        let e = CdevFirewire::open(&absent, CdevConfig::default()).expect_err("no such node");
        assert_eq!(e.step, "open");
        assert_eq!(e.device, DeviceError::Transport("no such /dev/fw* node"));
        let line = e.to_string();
        assert!(line.starts_with(&absent.display().to_string()), "{line}");
        assert!(!line.contains('\n'));

        // A character device without the firewire-cdev ioctls.
        let null = Path::new("/dev/null");
        if null.exists() {
            let e = CdevFirewire::open(null, CdevConfig::default()).expect_err("not a node");
            assert_eq!(e.step, "FW_CDEV_IOC_GET_INFO");
            assert_eq!(e.device, DeviceError::Transport("not a firewire-cdev node"));
            assert!(e.to_string().contains("not a firewire-cdev node"));
            let e = read_config_rom(null).expect_err("not a node");
            assert_eq!(e.step, "FW_CDEV_IOC_GET_INFO");
        } else {
            note!("note: /dev/null is absent here; its part of the test is skipped");
        }

        let bad = CdevConfig {
            transmit_channel: Some(64),
            ..CdevConfig::default()
        };
        let e = CdevFirewire::open(&absent, bad).expect_err("channel 64");
        assert_eq!(e.step, "channels");
        assert!(e.to_string().contains("64"));
    }

    #[test]
    fn channels_come_from_the_resource_manager() {
        let c = CdevConfig::default();
        assert_eq!((c.receive_channel, c.transmit_channel), (None, None));
        assert_eq!(c.speed, SCODE_100);
        // Any channel for the first; any but the first for the second; or exactly one.
        assert_eq!(channel_mask(None, None), u64::MAX);
        assert_eq!(channel_mask(None, Some(0)), u64::MAX - 1);
        assert_eq!(channel_mask(None, Some(63)), u64::MAX >> 1);
        assert_eq!(channel_mask(Some(5), Some(0)), 0b10_0000);
        // The manager's answer: the channel it granted, or a negative errno.
        assert_eq!(granted(true, 7, 816), Ok(7));
        let busy = granted(true, -libc::EBUSY, 816).expect_err("refused");
        assert!(busy.contains("granted no channel"), "{busy}");
        assert!(granted(true, 3, -libc::EAGAIN).is_err());
        assert!(granted(false, 3, 816).is_err());
    }
}
