//! The PHANTOM Omni's IEEE-1394 transport on Linux: [`CdevFirewire`] implements
//! [`FirewireTransport`] over one `/dev/fw*` node with the kernel's firewire-cdev ABI, and
//! [`discover_omnis`] finds Omnis by the vendor OUI in their configuration ROM.
//!
//! No vendor code is involved. The structures, event layouts and request numbers below are
//! written from the kernel's uapi headers (`linux/firewire-cdev.h`,
//! `linux/firewire-constants.h`; each item names what it mirrors); the register addresses and
//! packet layouts are the Omni codec's ([`crate::omni`]).
//!
//! | what the Omni protocol needs | kernel interface used here |
//! |------------------------------|----------------------------|
//! | quadlet and byte register reads, byte writes | `FW_CDEV_IOC_SEND_REQUEST` (quadlet read, 1-byte block read/write), answered by `FW_CDEV_EVENT_RESPONSE` read from the fd |
//! | 44-byte input packets        | an isochronous receive context (`CREATE_ISO_CONTEXT`, `QUEUE_ISO`, `START_ISO`) filling a ring of 64 slots in an mmapped buffer |
//! | 16-byte output packets       | an isochronous transmit context from an mmapped ring; each output is repeated every bus cycle (8 kHz) until the next one, as public Omni code does |
//! | channel bookkeeping          | `FW_CDEV_IOC_ALLOCATE_ISO_RESOURCE` at the bus's isochronous resource manager |
//! | identification               | the configuration ROM copy of `FW_CDEV_IOC_GET_INFO` |
//!
//! The kernel allows one isochronous context per open file, so a transport opens its node
//! three times: control (requests, channel allocation), receive, transmit.
//!
//! The transmit stream is shared, behind a mutex, with [`CdevOut`]: the second path a
//! supervisor thread uses to queue motors-off packets while the servo thread is stalled
//! ([`crate::MotorCutoff`]). The servo only `try_lock`s it and never waits on it.
//!
//! Every wait is a `ppoll` with a deadline: a dead bus or an unplugged node becomes
//! [`DeviceError::Timeout`] or [`DeviceError::Disconnected`], never a hang or a panic. After
//! [`CdevFirewire::open`] nothing allocates: the event buffers, rings and control arrays are
//! fixed.
//!
//! Nothing here has run against a FireWire bus (none is attached to the build machines); see
//! docs/DEVICES.md for exactly what is untested. As in [`super::hdapi`] and [`super::clock`],
//! `unsafe` is allowed in this module only: each block is one system call or one copy in a
//! mapped buffer, with its `// SAFETY:` reason.
#![allow(unsafe_code)]

use std::fmt;
use std::fs::{File, OpenOptions};
use std::io::{self, Read};
use std::marker::PhantomData;
use std::os::fd::AsRawFd;
use std::os::unix::fs::OpenOptionsExt;
use std::path::{Path, PathBuf};
use std::ptr::NonNull;
use std::sync::{Arc, Mutex, MutexGuard, TryLockError};

use crate::cutoff::{Cut, OutPath, PACKET_LEN};
use crate::device::DeviceError;
use crate::discovery::{is_sensable_vendor, SENSABLE_VENDOR};
use crate::omni::packet::{encode_output, OmniOutput, INPUT_LEN, MOTOR_ZERO, OUTPUT_LEN};
use crate::omni::{FirewireTransport, OmniConfig};
use crate::os::clock::now_ns;

// ---------------------------------------------------------------------------------------------
// The ABI, from linux/firewire-cdev.h and linux/firewire-constants.h.
// ---------------------------------------------------------------------------------------------

/// The firewire-cdev ABI version this code is written for (`fw_cdev_get_info.version`).
/// Version 5 flushes iso headers on overflow instead of dropping them; version 6 would turn
/// responses into `fw_cdev_event_response2`, which this code does not parse.
const ABI_VERSION: u32 = 5;

// FW_CDEV_EVENT_* (firewire-cdev.h).
const EVENT_BUS_RESET: u32 = 0x00;
const EVENT_RESPONSE: u32 = 0x01;
const EVENT_ISO_INTERRUPT: u32 = 0x03;
const EVENT_ISO_RESOURCE_ALLOCATED: u32 = 0x04;
const EVENT_ISO_RESOURCE_DEALLOCATED: u32 = 0x05;

// TCODE_* (firewire-constants.h).
const TCODE_WRITE_BLOCK_REQUEST: u32 = 0x1;
const TCODE_READ_QUADLET_REQUEST: u32 = 0x4;
const TCODE_READ_BLOCK_REQUEST: u32 = 0x5;

// RCODE_* (firewire-constants.h).
const RCODE_COMPLETE: u32 = 0x00;
const RCODE_CONFLICT_ERROR: u32 = 0x04;
const RCODE_DATA_ERROR: u32 = 0x05;
const RCODE_TYPE_ERROR: u32 = 0x06;
const RCODE_ADDRESS_ERROR: u32 = 0x07;
const RCODE_SEND_ERROR: u32 = 0x10;
const RCODE_CANCELLED: u32 = 0x11;
const RCODE_BUSY: u32 = 0x12;
const RCODE_GENERATION: u32 = 0x13;
const RCODE_NO_ACK: u32 = 0x14;

/// Speed code S100 (`SCODE_100`, firewire-constants.h): the speed public Omni code transmits
/// at.
pub const SCODE_100: u32 = 0;

// FW_CDEV_ISO_CONTEXT_* and the fw_cdev_iso_packet control bits (firewire-cdev.h).
const ISO_CONTEXT_TRANSMIT: u32 = 0;
const ISO_CONTEXT_RECEIVE: u32 = 1;
const ISO_INTERRUPT: u32 = 1 << 16;
const ISO_CONTEXT_MATCH_ALL_TAGS: u32 = 15;

/// `FW_CDEV_ISO_HEADER_LENGTH(v)`.
const fn iso_header_length(v: u32) -> u32 {
    v << 24
}

/// `struct fw_cdev_get_info`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default)]
struct GetInfo {
    version: u32,
    rom_length: u32,
    rom: u64,
    bus_reset: u64,
    bus_reset_closure: u64,
    card: u32,
}

/// `struct fw_cdev_send_request`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default)]
struct SendRequest {
    tcode: u32,
    length: u32,
    offset: u64,
    closure: u64,
    data: u64,
    generation: u32,
}

/// `struct fw_cdev_create_iso_context`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default)]
struct CreateIsoContext {
    kind: u32,
    header_size: u32,
    channel: u32,
    speed: u32,
    closure: u64,
    handle: u32,
}

/// `struct fw_cdev_queue_iso`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default)]
struct QueueIso {
    packets: u64,
    data: u64,
    size: u32,
    handle: u32,
}

/// `struct fw_cdev_start_iso`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default)]
struct StartIso {
    cycle: i32,
    sync: u32,
    tags: u32,
    handle: u32,
}

/// `struct fw_cdev_stop_iso`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default)]
struct StopIso {
    handle: u32,
}

/// `struct fw_cdev_allocate_iso_resource`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default)]
struct AllocateIsoResource {
    closure: u64,
    channels: u64,
    bandwidth: u32,
    handle: u32,
}

/// `struct fw_cdev_event_bus_reset` (GET_INFO fills one with the current bus state).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default)]
struct BusReset {
    closure: u64,
    kind: u32,
    node_id: u32,
    local_node_id: u32,
    bm_node_id: u32,
    irm_node_id: u32,
    root_node_id: u32,
    generation: u32,
}

// On every 64-bit Linux target a u64 is 8-aligned, so these are the sizes of the C structs
// (the tests derive each from the header field by field).
#[cfg(target_pointer_width = "64")]
const _: () = {
    assert!(size_of::<GetInfo>() == 40);
    assert!(size_of::<SendRequest>() == 40);
    assert!(size_of::<CreateIsoContext>() == 32);
    assert!(size_of::<QueueIso>() == 24);
    assert!(size_of::<StartIso>() == 16);
    assert!(size_of::<StopIso>() == 4);
    assert!(size_of::<AllocateIsoResource>() == 24);
    assert!(size_of::<BusReset>() == 40);
};

/// The `_IOC` encoding of `asm-generic/ioctl.h`, or the one of the architectures that
/// override it (powerpc, mips, sparc: 13 size bits, a 3-bit direction field).
mod ioc {
    #[cfg(not(any(
        target_arch = "powerpc",
        target_arch = "powerpc64",
        target_arch = "mips",
        target_arch = "mips32r6",
        target_arch = "mips64",
        target_arch = "mips64r6",
        target_arch = "sparc",
        target_arch = "sparc64"
    )))]
    mod arch {
        pub const WRITE: u32 = 1;
        pub const READ: u32 = 2;
        pub const SIZEBITS: u32 = 14;
    }
    #[cfg(any(
        target_arch = "powerpc",
        target_arch = "powerpc64",
        target_arch = "mips",
        target_arch = "mips32r6",
        target_arch = "mips64",
        target_arch = "mips64r6",
        target_arch = "sparc",
        target_arch = "sparc64"
    ))]
    mod arch {
        pub const WRITE: u32 = 4;
        pub const READ: u32 = 2;
        pub const SIZEBITS: u32 = 13;
    }
    pub use arch::{READ, SIZEBITS, WRITE};
    /// `_IOC_NRSHIFT` is 0, `_IOC_TYPESHIFT` 8, `_IOC_SIZESHIFT` 16, `_IOC_DIRSHIFT` after
    /// the size field.
    pub const fn ioc(dir: u32, kind: u8, nr: u8, size: usize) -> u32 {
        (dir << (16 + SIZEBITS)) | ((size as u32) << 16) | ((kind as u32) << 8) | nr as u32
    }
}

/// One ioctl request number, tied to the type of its argument so the size encoded in the
/// number is always the size of what is passed.
struct Request<T> {
    code: u32,
    arg: PhantomData<fn(&mut T)>,
}

impl<T> Clone for Request<T> {
    fn clone(&self) -> Self {
        *self
    }
}
impl<T> Copy for Request<T> {}

impl<T> fmt::Debug for Request<T> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "Request({:#010x})", self.code)
    }
}

/// `_IOW('#', nr, T)`.
const fn iow<T>(nr: u8) -> Request<T> {
    Request {
        code: ioc::ioc(ioc::WRITE, b'#', nr, size_of::<T>()),
        arg: PhantomData,
    }
}

/// `_IOWR('#', nr, T)`.
const fn iowr<T>(nr: u8) -> Request<T> {
    Request {
        code: ioc::ioc(ioc::READ | ioc::WRITE, b'#', nr, size_of::<T>()),
        arg: PhantomData,
    }
}

// The request numbers of firewire-cdev.h.
const GET_INFO: Request<GetInfo> = iowr(0x00);
const SEND_REQUEST: Request<SendRequest> = iow(0x01);
const CREATE_ISO_CONTEXT: Request<CreateIsoContext> = iowr(0x08);
const QUEUE_ISO: Request<QueueIso> = iowr(0x09);
const START_ISO: Request<StartIso> = iow(0x0a);
const STOP_ISO: Request<StopIso> = iow(0x0b);
const ALLOCATE_ISO_RESOURCE: Request<AllocateIsoResource> = iowr(0x0d);

/// Issues one ioctl, again after a signal.
///
/// # Safety
/// Every pointer stored inside `arg` must be null or valid, for the whole call, for the
/// kernel to read or write as many bytes as that request's documentation says.
unsafe fn ioctl<T>(file: &File, req: Request<T>, arg: &mut T) -> io::Result<libc::c_int> {
    loop {
        // SAFETY: `arg` is an exclusive borrow of a `T`, and `req.code` encodes
        // `size_of::<T>()` (both come from the same `T`), so the kernel copies exactly that
        // object in and out; the caller vouches for the pointers inside it.
        let rc = unsafe { libc::ioctl(file.as_raw_fd(), req.code as libc::Ioctl, arg as *mut T) };
        if rc >= 0 {
            return Ok(rc);
        }
        let e = io::Error::last_os_error();
        if e.raw_os_error() != Some(libc::EINTR) {
            return Err(e);
        }
    }
}

/// Arguments that hold no pointers: passing them cannot make the kernel touch other memory.
trait PlainArg {}
impl PlainArg for CreateIsoContext {}
impl PlainArg for StartIso {}
impl PlainArg for StopIso {}
impl PlainArg for AllocateIsoResource {}

fn ioctl_plain<T: PlainArg>(file: &File, req: Request<T>, arg: &mut T) -> io::Result<()> {
    // SAFETY: `T: PlainArg` holds no pointers, so there is nothing else for the kernel to
    // read or write.
    unsafe { ioctl(file, req, arg) }.map(|_| ())
}

/// `FW_CDEV_IOC_GET_INFO`: fills `bus` with the current bus state and, when `rom` is given,
/// copies the node's configuration ROM into it (host-endian quadlets: the kernel's cached
/// copy). Returns the number of ROM quadlets copied.
fn get_info(file: &File, rom: Option<&mut [u32]>, bus: &mut BusReset) -> io::Result<usize> {
    let capacity = rom.as_ref().map_or(0, |r| r.len());
    let rom_ptr = rom.map_or(0, |r| r.as_mut_ptr() as u64);
    let mut a = GetInfo {
        version: ABI_VERSION,
        rom_length: (capacity * 4) as u32,
        rom: rom_ptr,
        bus_reset: bus as *mut BusReset as u64,
        bus_reset_closure: CLOSURE_BUS_RESET,
        card: 0,
    };
    // SAFETY: `rom` (when given) is an exclusive borrow of `rom_length` bytes and `bus` one
    // of a whole `fw_cdev_event_bus_reset`; the kernel writes at most those during the call.
    unsafe { ioctl(file, GET_INFO, &mut a) }?;
    Ok((a.rom_length as usize / 4).min(capacity))
}

/// `FW_CDEV_IOC_SEND_REQUEST` to the node of `file`; the outcome arrives later as an event.
fn send_request(
    file: &File,
    tcode: u32,
    offset: u64,
    payload: &[u8],
    closure: u64,
    generation: u32,
) -> io::Result<()> {
    let mut a = SendRequest {
        tcode,
        length: payload.len() as u32,
        offset,
        closure,
        data: payload.as_ptr() as u64,
        generation,
    };
    // SAFETY: `data` points at `payload`, `length` bytes alive for the call; the kernel only
    // reads it (into its own request) before the ioctl returns.
    unsafe { ioctl(file, SEND_REQUEST, &mut a) }.map(|_| ())
}

/// `FW_CDEV_IOC_QUEUE_ISO` of one packet per control word, their payloads consecutive in
/// `buffer` from `offset`, `payload` bytes each. The kernel may queue part of a request and
/// say so; this repeats until all are queued (bounded: each round queues one or fails).
fn queue_iso(
    file: &File,
    handle: u32,
    controls: &[u32],
    buffer: &IsoBuffer,
    offset: usize,
    payload: usize,
) -> Result<(), DeviceError> {
    let end = controls
        .len()
        .checked_mul(payload)
        .and_then(|n| n.checked_add(offset));
    if end.is_none_or(|end| end > buffer.len) {
        return Err(DeviceError::Transport(
            "isochronous packets outside the mapped buffer",
        ));
    }
    let mut a = QueueIso {
        packets: controls.as_ptr() as u64,
        data: buffer.addr() + offset as u64,
        size: (controls.len() * 4) as u32,
        handle,
    };
    for _ in 0..=controls.len() {
        if a.size == 0 {
            return Ok(());
        }
        let before = a.size;
        // SAFETY: `packets` points into `controls`, `size` bytes of header-less
        // `fw_cdev_iso_packet`s (control words only), alive for the call; `data` lies in this
        // fd's mapped buffer (checked above; the kernel checks it again against its own
        // mapping) and is only read or written by DMA for the packets queued.
        unsafe { ioctl(file, QUEUE_ISO, &mut a) }.map_err(|e| errno_error(&e))?;
        if a.size >= before {
            break;
        }
    }
    if a.size == 0 {
        Ok(())
    } else {
        Err(DeviceError::Transport(
            "the kernel did not queue the isochronous packets",
        ))
    }
}

fn start_iso(file: &File, handle: u32, tags: u32) -> Result<(), DeviceError> {
    let mut a = StartIso {
        cycle: -1,
        sync: 0,
        tags,
        handle,
    };
    ioctl_plain(file, START_ISO, &mut a).map_err(|e| errno_error(&e))
}

fn stop_iso(file: &File, handle: u32) -> Result<(), DeviceError> {
    let mut a = StopIso { handle };
    ioctl_plain(file, STOP_ISO, &mut a).map_err(|e| errno_error(&e))
}

/// Waits until `file` has an event to read or `timeout_ns` passes. `Ok(false)` on timeout
/// (or a signal); a node that went away is [`DeviceError::Disconnected`].
fn poll_readable(file: &File, timeout_ns: u64) -> Result<bool, DeviceError> {
    let mut pfd = libc::pollfd {
        fd: file.as_raw_fd(),
        events: libc::POLLIN,
        revents: 0,
    };
    let ts = libc::timespec {
        tv_sec: (timeout_ns / 1_000_000_000) as libc::time_t,
        tv_nsec: (timeout_ns % 1_000_000_000) as libc::c_long,
    };
    // SAFETY: one valid pollfd and a valid timespec for the call; a null signal mask leaves
    // the mask unchanged.
    let rc = unsafe { libc::ppoll(&mut pfd, 1, &ts, std::ptr::null()) };
    if rc < 0 {
        let e = io::Error::last_os_error();
        return if e.raw_os_error() == Some(libc::EINTR) {
            Ok(false)
        } else {
            Err(errno_error(&e))
        };
    }
    if pfd.revents & (libc::POLLERR | libc::POLLHUP) != 0 {
        return Err(DeviceError::Disconnected);
    }
    if pfd.revents & libc::POLLNVAL != 0 {
        return Err(DeviceError::Transport("poll on a closed descriptor"));
    }
    Ok(rc > 0 && pfd.revents & libc::POLLIN != 0)
}

// ---------------------------------------------------------------------------------------------
// Errors.
// ---------------------------------------------------------------------------------------------

/// A system call's error as a device error: the node gone is `Disconnected`, the rest a short
/// reason.
fn errno_error(e: &io::Error) -> DeviceError {
    match e.raw_os_error() {
        Some(libc::ENODEV) | Some(libc::ENXIO) | Some(libc::ESHUTDOWN) => DeviceError::Disconnected,
        Some(libc::ETIMEDOUT) => DeviceError::Timeout,
        Some(libc::EACCES) | Some(libc::EPERM) => {
            DeviceError::Transport("permission denied on the /dev/fw* node")
        }
        Some(libc::ENOENT) => DeviceError::Transport("no such /dev/fw* node"),
        Some(libc::ENOTTY) => DeviceError::Transport("not a firewire-cdev node"),
        Some(libc::EBUSY) => DeviceError::Transport(
            "the controller has no free isochronous context, or the buffer is in use",
        ),
        Some(libc::EINVAL) => DeviceError::Transport("the kernel refused the request (EINVAL)"),
        Some(libc::EIO) => DeviceError::Transport("I/O error on the FireWire node"),
        _ => DeviceError::Transport("a FireWire system call failed"),
    }
}

/// A response code (`RCODE_*`) as a result.
fn rcode_result(rcode: u32) -> Result<(), DeviceError> {
    Err(match rcode {
        RCODE_COMPLETE => return Ok(()),
        RCODE_NO_ACK => DeviceError::Disconnected,
        RCODE_CANCELLED => DeviceError::Timeout,
        RCODE_GENERATION => DeviceError::Transport("a bus reset interrupted the request"),
        RCODE_BUSY => DeviceError::Transport("the node stayed busy"),
        RCODE_ADDRESS_ERROR => DeviceError::Transport("the node has no register at that address"),
        RCODE_TYPE_ERROR => DeviceError::Transport("the node refused that kind of request"),
        RCODE_DATA_ERROR => DeviceError::Transport("the node reported a data error"),
        RCODE_CONFLICT_ERROR => DeviceError::Transport("the node reported a resource conflict"),
        RCODE_SEND_ERROR => DeviceError::Transport("the request could not be sent"),
        _ => DeviceError::Transport("unknown response code from the node"),
    })
}

/// A node that could not be opened or identified: one line naming it, the step and why.
#[derive(Debug)]
pub struct OpenError {
    /// The `/dev/fw*` node.
    pub path: PathBuf,
    /// What was being done (`open`, an ioctl's name, ...).
    pub step: &'static str,
    /// Why, for people (with a hint for permissions).
    pub reason: String,
    /// The same as a device error.
    pub device: DeviceError,
}

impl OpenError {
    fn io(path: &Path, step: &'static str, e: &io::Error) -> OpenError {
        let mut reason = e.to_string();
        match e.raw_os_error() {
            Some(libc::EACCES) | Some(libc::EPERM) => reason.push_str(
                "; give your user read and write access to /dev/fw* (docs/DEVICES.md has a \
                 udev rule)",
            ),
            Some(libc::ENOTTY) => reason.push_str(" (not a firewire-cdev node)"),
            _ => {}
        }
        OpenError {
            path: path.to_path_buf(),
            step,
            reason,
            device: errno_error(e),
        }
    }
}

impl fmt::Display for OpenError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}: {}", self.path.display(), self.step, self.reason)
    }
}

impl std::error::Error for OpenError {}

// ---------------------------------------------------------------------------------------------
// Events read from the fd.
// ---------------------------------------------------------------------------------------------

/// One event, parsed from the bytes `read(2)` returned. Fields are native-endian (the kernel
/// writes C structs); payloads keep bus (big-endian) byte order.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Event<'a> {
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

// Field offsets of the events (firewire-cdev.h; every event starts with `__u64 closure` at 0
// and `__u32 type` at 8, then 4-byte fields; flexible arrays follow the last field).
const EV_CLOSURE: usize = 0;
const EV_TYPE: usize = 8;
const BUS_RESET_NODE_ID: usize = 12;
const BUS_RESET_GENERATION: usize = 32;
const RESPONSE_RCODE: usize = 12;
const RESPONSE_LENGTH: usize = 16;
const RESPONSE_DATA: usize = 20;
const ISO_INTERRUPT_CYCLE: usize = 12;
const ISO_INTERRUPT_HEADER_LENGTH: usize = 16;
const ISO_INTERRUPT_HEADER: usize = 20;
const ISO_RESOURCE_CHANNEL: usize = 16;
const ISO_RESOURCE_BANDWIDTH: usize = 20;

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
fn iso_payload_length(header: &[u8]) -> usize {
    match header {
        [hi, lo, ..] => usize::from(u16::from_be_bytes([*hi, *lo])),
        _ => 0,
    }
}

/// Bytes read per event: the largest is an iso interrupt carrying a page of headers (the
/// kernel flushes at `PAGE_SIZE`) after its 20-byte fixed part.
const EVENT_BUFFER: usize = 8192;

/// An open node and its event buffer (allocated once).
struct EventFile {
    file: File,
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
    fn open(path: &Path, write: bool) -> io::Result<EventFile> {
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
    fn read_one(&mut self) -> Result<Option<usize>, DeviceError> {
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

    fn event(&self, n: usize) -> Option<Event<'_>> {
        parse_event(self.buf.get(..n)?)
    }

    fn wait(&self, timeout_ns: u64) -> Result<bool, DeviceError> {
        poll_readable(&self.file, timeout_ns)
    }
}

// ---------------------------------------------------------------------------------------------
// The mapped DMA buffer of one isochronous context.
// ---------------------------------------------------------------------------------------------

/// A shared mapping of a node fd: the payload buffer of its iso context.
#[derive(Debug)]
struct IsoBuffer {
    ptr: NonNull<u8>,
    len: usize,
    writable: bool,
}

// SAFETY: the mapping belongs to this value alone (made in `map`, unmapped only in `drop`) and
// is reached only through its methods; moving it to another thread moves that ownership.
unsafe impl Send for IsoBuffer {}

impl IsoBuffer {
    fn map(file: &File, min_len: usize, writable: bool) -> io::Result<IsoBuffer> {
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

    fn addr(&self) -> u64 {
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

// ---------------------------------------------------------------------------------------------
// Rings.
// ---------------------------------------------------------------------------------------------

/// Receive ring: slots of 64 bytes (the Omni's 44-byte packet rounded up to what public Omni
/// code reserves; payloads must be whole quadlets).
const RX_SLOTS: usize = 64;
const RX_SLOT_BYTES: usize = 64;
/// Header bytes the receive context strips per packet: the isochronous header only.
const RX_HEADER_BYTES: usize = 4;
/// Each receive slot: up to 64 payload bytes, one stripped header, an event when it fills.
const RX_CONTROL: u32 =
    RX_SLOT_BYTES as u32 | iso_header_length(RX_HEADER_BYTES as u32) | ISO_INTERRUPT;
/// Transmit ring of 16-byte packets (tag 0, sy 0, no header quadlets).
const TX_SLOTS: usize = 64;
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
fn tx_batch(inflight: usize, depth: usize, started: bool) -> usize {
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
fn bandwidth_units(payload: usize, speed: u32) -> u32 {
    let quadlets = payload.div_ceil(4) as u32 + 3;
    quadlets * (16 >> speed.min(4)) + 512
}

// ---------------------------------------------------------------------------------------------
// Configuration ROM and discovery.
// ---------------------------------------------------------------------------------------------

/// Quadlets of the largest configuration ROM (1 KiB, IEEE 1212).
const ROM_QUADLETS: usize = 256;
/// "1394" in the bus information block.
const BUS_NAME_1394: u32 = 0x3133_3934;
/// Root directory keys (IEEE 1212): immediate Module_Vendor_ID and Model_ID.
const KEY_VENDOR: u32 = 0x03;
const KEY_MODEL: u32 = 0x17;

/// What a configuration ROM says about its node.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RomInfo {
    /// Module vendor id (root directory key 0x03, 24 bits), or a minimal ROM's vendor id.
    pub vendor: Option<u32>,
    /// Model id (root directory key 0x17).
    pub model: Option<u32>,
    /// The node's EUI-64 from the bus information block (its upper 24 bits are an OUI).
    pub guid: Option<u64>,
}

impl RomInfo {
    /// The vendor OUI: the root directory's, else the GUID's.
    pub fn oui(&self) -> Option<u32> {
        self.vendor.or(self.guid.map(|g| (g >> 40) as u32))
    }

    /// Whether the node is SensAble's (OUI 0x000b99).
    pub fn is_sensable(&self) -> bool {
        self.oui() == Some(SENSABLE_VENDOR)
    }
}

/// Why a configuration ROM could not be read.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RomError {
    /// No quadlets at all.
    Empty,
    /// The bus information block is shorter than IEEE 1394's four quadlets.
    ShortBusInfo {
        /// `info_length` of the first quadlet.
        info_length: u32,
    },
    /// The bus information block does not start with "1394".
    NotIeee1394 {
        /// The quadlet found instead.
        found: u32,
    },
    /// The ROM ends before quadlet `need` (it has `have`).
    Truncated {
        /// Quadlets needed.
        need: usize,
        /// Quadlets present.
        have: usize,
    },
}

impl fmt::Display for RomError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            RomError::Empty => f.write_str("empty configuration ROM"),
            RomError::ShortBusInfo { info_length } => write!(
                f,
                "bus information block of {info_length} quadlets (IEEE 1394 needs 4)"
            ),
            RomError::NotIeee1394 { found } => {
                write!(f, "bus information block names {found:#010x}, not \"1394\"")
            }
            RomError::Truncated { need, have } => write!(
                f,
                "configuration ROM ends at quadlet {have}, its directory needs {need}"
            ),
        }
    }
}

/// Reads vendor, model and GUID from a configuration ROM given as host-endian quadlets (as
/// `FW_CDEV_IOC_GET_INFO` copies it). Layout (IEEE 1212 / 1394): quadlet 0 holds
/// `info_length:8 crc_length:8 crc:16`; a minimal ROM (`info_length` 1) has the vendor id in
/// its low 24 bits; otherwise the bus information block follows ("1394", bus options, GUID
/// high, GUID low) and the root directory starts at quadlet `1 + info_length` with
/// `length:16 crc:16`, then `key:8 value:24` entries. CRCs are not checked (devices get them
/// wrong and the kernel does not reject them either).
///
/// # Bounded work
/// One pass over at most the root directory's entries.
pub fn parse_config_rom(rom: &[u32]) -> Result<RomInfo, RomError> {
    let first = *rom.first().ok_or(RomError::Empty)?;
    let info_length = first >> 24;
    if info_length == 1 {
        return Ok(RomInfo {
            vendor: Some(first & 0x00FF_FFFF),
            ..RomInfo::default()
        });
    }
    if info_length < 4 {
        return Err(RomError::ShortBusInfo { info_length });
    }
    let have = rom.len();
    let root = 1 + info_length as usize;
    if have <= root {
        return Err(RomError::Truncated {
            need: root + 1,
            have,
        });
    }
    if rom[1] != BUS_NAME_1394 {
        return Err(RomError::NotIeee1394 { found: rom[1] });
    }
    let guid = (u64::from(rom[3]) << 32) | u64::from(rom[4]);
    let entries = (rom[root] >> 16) as usize;
    let end = root + 1 + entries;
    if end > have {
        return Err(RomError::Truncated { need: end, have });
    }
    let mut info = RomInfo {
        guid: Some(guid),
        ..RomInfo::default()
    };
    for &e in &rom[root + 1..end] {
        let value = e & 0x00FF_FFFF;
        match e >> 24 {
            KEY_VENDOR if info.vendor.is_none() => info.vendor = Some(value),
            KEY_MODEL if info.model.is_none() => info.model = Some(value),
            _ => {}
        }
    }
    Ok(info)
}

/// The `fw<N>` entries of `dir`, in order of `N`.
pub fn fw_nodes(dir: &Path) -> Vec<PathBuf> {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return Vec::new();
    };
    let mut nodes: Vec<(u64, PathBuf)> = entries
        .filter_map(|e| e.ok())
        .filter_map(|e| {
            let name = e.file_name().into_string().ok()?;
            let digits = name.strip_prefix("fw")?;
            if digits.is_empty() || !digits.bytes().all(|c| c.is_ascii_digit()) {
                return None;
            }
            Some((digits.parse().ok()?, e.path()))
        })
        .collect();
    nodes.sort();
    nodes.into_iter().map(|(_, p)| p).collect()
}

/// Reads a node's configuration ROM through `FW_CDEV_IOC_GET_INFO` (read-only open).
pub fn read_config_rom(path: &Path) -> Result<RomInfo, OpenError> {
    let file = OpenOptions::new()
        .read(true)
        .custom_flags(libc::O_NONBLOCK)
        .open(path)
        .map_err(|e| OpenError::io(path, "open", &e))?;
    let mut rom = [0u32; ROM_QUADLETS];
    let mut bus = BusReset::default();
    let n = get_info(&file, Some(&mut rom), &mut bus)
        .map_err(|e| OpenError::io(path, "FW_CDEV_IOC_GET_INFO", &e))?;
    parse_config_rom(&rom[..n]).map_err(|e| OpenError {
        path: path.to_path_buf(),
        step: "configuration ROM",
        reason: e.to_string(),
        device: DeviceError::Transport("unreadable configuration ROM"),
    })
}

/// A `/dev/fw*` node that is, or may be, an Omni.
#[derive(Debug)]
pub struct OmniNode {
    /// The node.
    pub path: PathBuf,
    /// Its ROM (SensAble's), or why it could not be read although sysfs names SensAble.
    pub rom: Result<RomInfo, OpenError>,
}

impl OmniNode {
    /// One line for `tetradrill devices`.
    pub fn describe(&self) -> String {
        match &self.rom {
            Ok(info) => {
                let mut s = self.path.display().to_string();
                if let Some(g) = info.guid {
                    s.push_str(&format!("  GUID {g:016x}"));
                }
                if let Some(m) = info.model {
                    s.push_str(&format!("  model {m:#08x}"));
                }
                s
            }
            Err(e) => format!(
                "{}  (SensAble by sysfs, but this user cannot open it: {})",
                self.path.display(),
                e.reason
            ),
        }
    }
}

/// The Omnis among the `fw*` nodes of `dev`: nodes whose ROM names SensAble, and nodes whose
/// ROM cannot be read (permissions) but whose `sysfs/<node>/vendor` names SensAble. Nodes
/// of other vendors and unreadable nodes sysfs does not vouch for are left out. Never panics.
pub fn discover_omnis_in(dev: &Path, sysfs: &Path) -> Vec<OmniNode> {
    let mut found = Vec::new();
    for path in fw_nodes(dev) {
        match read_config_rom(&path) {
            Ok(info) if info.is_sensable() => found.push(OmniNode {
                path,
                rom: Ok(info),
            }),
            Ok(_) => {}
            Err(e) => {
                let sensable = path
                    .file_name()
                    .and_then(|n| std::fs::read_to_string(sysfs.join(n).join("vendor")).ok())
                    .is_some_and(|v| is_sensable_vendor(&v));
                if sensable {
                    found.push(OmniNode { path, rom: Err(e) });
                }
            }
        }
    }
    found
}

/// [`discover_omnis_in`] `/dev` with `/sys/bus/firewire/devices`.
pub fn discover_omnis() -> Vec<OmniNode> {
    discover_omnis_in(Path::new("/dev"), Path::new("/sys/bus/firewire/devices"))
}

// ---------------------------------------------------------------------------------------------
// The transport.
// ---------------------------------------------------------------------------------------------

const CLOSURE_BUS_RESET: u64 = 0x0b55;
const CLOSURE_RX: u64 = 0x1500;
const CLOSURE_TX: u64 = 0x1501;
const CLOSURE_ALLOC_RX: u64 = 0xa110c0;
const CLOSURE_ALLOC_TX: u64 = 0xa110c1;
const CLOSURE_FIRST_REQUEST: u64 = 0x1_0000;

/// Settings of [`CdevFirewire`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CdevConfig {
    /// Channel the host receives on (the Omni transmits on; written to its 0x1001).
    pub receive_channel: u8,
    /// Channel the host transmits on (written to the Omni's 0x1000).
    pub transmit_channel: u8,
    /// Transmit speed code ([`SCODE_100`] as public Omni code uses).
    pub speed: u32,
    /// Allocate both channels and their bandwidth at the isochronous resource manager.
    /// A refusal does not fail [`CdevFirewire::open`]; it is reported by
    /// [`CdevFirewire::warning`].
    pub allocate_channels: bool,
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
            receive_channel: 0,
            transmit_channel: 1,
            speed: SCODE_100,
            allocate_channels: true,
            request_timeout_ms: 1000,
            allocate_timeout_ms: 2000,
            first_packet_timeout_ms: 500,
            packet_wait_us: 250,
            stall_limit_ms: 20,
            tx_depth: 16,
        }
    }
}

impl CdevConfig {
    /// Defaults with the channels of an Omni configuration.
    pub fn for_omni(config: &OmniConfig) -> CdevConfig {
        CdevConfig {
            receive_channel: config.receive_channel,
            transmit_channel: config.transmit_channel,
            ..CdevConfig::default()
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

#[derive(Debug)]
struct RxStream {
    ev: EventFile,
    handle: u32,
    buf: IsoBuffer,
    started: bool,
    started_ns: u64,
    next: usize,
    last: [u8; INPUT_LEN],
    last_ns: Option<u64>,
    short: [u8; INPUT_LEN],
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

    fn start(&mut self) -> Result<(), DeviceError> {
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
    fn drain(&mut self, stats: &mut CdevStats) -> Result<Option<usize>, DeviceError> {
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
struct TxStream {
    ev: EventFile,
    handle: u32,
    buf: IsoBuffer,
    started: bool,
    head: usize,
    queued: u64,
    completed: u64,
}

impl TxStream {
    fn inflight(&self) -> usize {
        self.queued.saturating_sub(self.completed) as usize
    }

    /// Counts the packets the controller has sent (one timestamp quadlet each in the
    /// interrupt event's headers).
    fn collect(&mut self) -> Result<(), DeviceError> {
        while let Some(n) = self.ev.read_one()? {
            if let Some(Event::IsoInterrupt { headers, .. }) = self.ev.event(n) {
                self.completed = (self.completed + (headers.len() / 4) as u64).min(self.queued);
            }
        }
        Ok(())
    }

    /// Writes `copies` copies of `packet` into free slots and queues them, an event after the
    /// last of each run. The caller has made room (`inflight() + copies <= TX_SLOTS`).
    fn push(&mut self, packet: &[u8; OUTPUT_LEN], copies: usize) -> Result<(), DeviceError> {
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
    warning: Option<String>,
}

fn create_context(
    file: &File,
    kind: u32,
    header_size: u32,
    channel: u8,
    speed: u32,
    closure: u64,
) -> io::Result<u32> {
    let mut a = CreateIsoContext {
        kind,
        header_size,
        channel: u32::from(channel),
        speed,
        closure,
        handle: 0,
    };
    ioctl_plain(file, CREATE_ISO_CONTEXT, &mut a)?;
    Ok(a.handle)
}

impl CdevFirewire {
    /// Opens `path` three times (control, receive, transmit), creates both isochronous
    /// contexts, maps their buffers and, when configured, allocates the channels. Nothing is
    /// sent on the bus except the allocation; streams start on first use.
    pub fn open(path: &Path, config: CdevConfig) -> Result<CdevFirewire, OpenError> {
        let io_err = |step: &'static str| move |e: io::Error| OpenError::io(path, step, &e);
        for channel in [config.receive_channel, config.transmit_channel] {
            if channel > 63 {
                return Err(OpenError {
                    path: path.to_path_buf(),
                    step: "channels",
                    reason: format!("isochronous channel {channel} is not in 0..=63"),
                    device: DeviceError::Transport("isochronous channel out of range"),
                });
            }
        }
        let ctl = EventFile::open(path, true).map_err(io_err("open"))?;
        let mut bus = BusReset::default();
        get_info(&ctl.file, None, &mut bus).map_err(io_err("FW_CDEV_IOC_GET_INFO"))?;

        let rx_ev = EventFile::open(path, true).map_err(io_err("open"))?;
        get_info(&rx_ev.file, None, &mut BusReset::default())
            .map_err(io_err("FW_CDEV_IOC_GET_INFO"))?;
        let rx_handle = create_context(
            &rx_ev.file,
            ISO_CONTEXT_RECEIVE,
            RX_HEADER_BYTES as u32,
            config.receive_channel,
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
            config.transmit_channel,
            config.speed,
            CLOSURE_TX,
        )
        .map_err(io_err("FW_CDEV_IOC_CREATE_ISO_CONTEXT (transmit)"))?;
        let tx_buf = IsoBuffer::map(&tx_ev.file, TX_SLOTS * OUTPUT_LEN, true)
            .map_err(io_err("mmap (transmit buffer)"))?;

        let mut t = CdevFirewire {
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
            warning: None,
        };
        if config.allocate_channels {
            t.warning = t.allocate().err();
        }
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

    /// Why the channels could not be allocated at the resource manager, if they could not
    /// (the streams are still attempted).
    pub fn warning(&self) -> Option<&str> {
        self.warning.as_deref()
    }

    /// Allocates both channels with their bandwidth for the life of the control file (the
    /// kernel reallocates them after bus resets and frees them on close).
    fn allocate(&mut self) -> Result<(), String> {
        let speed = self.config.speed;
        let wanted = [
            (
                CLOSURE_ALLOC_RX,
                self.config.receive_channel,
                bandwidth_units(RX_SLOT_BYTES, speed),
            ),
            (
                CLOSURE_ALLOC_TX,
                self.config.transmit_channel,
                bandwidth_units(OUTPUT_LEN, speed),
            ),
        ];
        for (closure, channel, bandwidth) in wanted {
            let mut a = AllocateIsoResource {
                closure,
                channels: 1u64 << channel,
                bandwidth,
                handle: 0,
            };
            ioctl_plain(&self.ctl.file, ALLOCATE_ISO_RESOURCE, &mut a)
                .map_err(|e| format!("FW_CDEV_IOC_ALLOCATE_ISO_RESOURCE: {e}"))?;
        }
        let deadline = now_ns() + u64::from(self.config.allocate_timeout_ms) * 1_000_000;
        let mut pending = wanted.len();
        while pending > 0 {
            let Some(n) = self.ctl.read_one().map_err(|e| e.to_string())? else {
                let left = deadline.saturating_sub(now_ns());
                if left == 0 {
                    return Err(format!(
                        "no answer from the isochronous resource manager in {} ms",
                        self.config.allocate_timeout_ms
                    ));
                }
                self.ctl.wait(left).map_err(|e| e.to_string())?;
                continue;
            };
            match self.ctl.event(n) {
                Some(Event::IsoResource {
                    closure,
                    allocated,
                    channel,
                    bandwidth,
                }) => {
                    let Some(&(_, wanted_channel, _)) =
                        wanted.iter().find(|(c, _, _)| *c == closure)
                    else {
                        continue;
                    };
                    pending -= 1;
                    if !allocated || channel < 0 || bandwidth < 0 {
                        let errno = if channel < 0 { -channel } else { -bandwidth };
                        return Err(format!(
                            "isochronous channel {wanted_channel}: the resource manager did not \
                             grant it ({})",
                            io::Error::from_raw_os_error(errno.max(0))
                        ));
                    }
                }
                Some(Event::BusReset { generation, .. }) => self.generation = generation,
                _ => {}
            }
        }
        Ok(())
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
                    Some(Event::BusReset { generation, .. }) => self.generation = generation,
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
    use std::collections::HashMap;
    use std::mem::offset_of;
    use std::process::Command;

    /// A note on stderr that the test harness does not capture (a skipped part says why).
    macro_rules! note {
        ($($t:tt)*) => {{
            use std::io::Write as _;
            let _ = writeln!(std::io::stderr(), $($t)*);
        }};
    }

    /// A fresh directory under the system's temporary directory.
    fn scratch(tag: &str) -> PathBuf {
        let dir =
            std::env::temp_dir().join(format!("tetradrill-firewire-{tag}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).expect("create a scratch directory");
        dir
    }

    // Struct layouts of linux/firewire-cdev.h, derived by hand for a 64-bit Linux target:
    // __u32/__s32 are 4-aligned, __u64 8-aligned, and a struct's size rounds up to a multiple
    // of its largest member alignment (8 for all of these but fw_cdev_stop_iso).
    #[test]
    #[cfg(target_pointer_width = "64")]
    fn structs_match_the_header_layout() {
        // fw_cdev_get_info: version 0, rom_length 4, rom 8, bus_reset 16, bus_reset_closure
        // 24, card 32; 36 bytes round up to 40.
        assert_eq!(offset_of!(GetInfo, rom_length), 4);
        assert_eq!(offset_of!(GetInfo, rom), 8);
        assert_eq!(offset_of!(GetInfo, bus_reset), 16);
        assert_eq!(offset_of!(GetInfo, bus_reset_closure), 24);
        assert_eq!(offset_of!(GetInfo, card), 32);
        assert_eq!(size_of::<GetInfo>(), 40);
        // fw_cdev_send_request: tcode 0, length 4, offset 8, closure 16, data 24,
        // generation 32; 36 -> 40.
        assert_eq!(offset_of!(SendRequest, length), 4);
        assert_eq!(offset_of!(SendRequest, offset), 8);
        assert_eq!(offset_of!(SendRequest, closure), 16);
        assert_eq!(offset_of!(SendRequest, data), 24);
        assert_eq!(offset_of!(SendRequest, generation), 32);
        assert_eq!(size_of::<SendRequest>(), 40);
        // fw_cdev_create_iso_context: type 0, header_size 4, channel 8, speed 12, closure
        // 16, handle 24; 28 -> 32.
        assert_eq!(offset_of!(CreateIsoContext, header_size), 4);
        assert_eq!(offset_of!(CreateIsoContext, channel), 8);
        assert_eq!(offset_of!(CreateIsoContext, speed), 12);
        assert_eq!(offset_of!(CreateIsoContext, closure), 16);
        assert_eq!(offset_of!(CreateIsoContext, handle), 24);
        assert_eq!(size_of::<CreateIsoContext>(), 32);
        // fw_cdev_queue_iso: packets 0, data 8, size 16, handle 20; 24.
        assert_eq!(offset_of!(QueueIso, data), 8);
        assert_eq!(offset_of!(QueueIso, size), 16);
        assert_eq!(offset_of!(QueueIso, handle), 20);
        assert_eq!(size_of::<QueueIso>(), 24);
        // fw_cdev_start_iso: cycle 0, sync 4, tags 8, handle 12; 16. fw_cdev_stop_iso: 4.
        assert_eq!(offset_of!(StartIso, sync), 4);
        assert_eq!(offset_of!(StartIso, tags), 8);
        assert_eq!(offset_of!(StartIso, handle), 12);
        assert_eq!(size_of::<StartIso>(), 16);
        assert_eq!(size_of::<StopIso>(), 4);
        // fw_cdev_allocate_iso_resource: closure 0, channels 8, bandwidth 16, handle 20; 24.
        assert_eq!(offset_of!(AllocateIsoResource, channels), 8);
        assert_eq!(offset_of!(AllocateIsoResource, bandwidth), 16);
        assert_eq!(offset_of!(AllocateIsoResource, handle), 20);
        assert_eq!(size_of::<AllocateIsoResource>(), 24);
        // fw_cdev_event_bus_reset: closure 0, type 8, node_id 12, local 16, bm 20, irm 24,
        // root 28, generation 32; 36 -> 40.
        assert_eq!(offset_of!(BusReset, kind), EV_TYPE);
        assert_eq!(offset_of!(BusReset, node_id), BUS_RESET_NODE_ID);
        assert_eq!(offset_of!(BusReset, generation), BUS_RESET_GENERATION);
        assert_eq!(size_of::<BusReset>(), 40);
    }

    /// The request numbers, each worked out by hand from asm-generic/ioctl.h:
    /// `_IOC(dir, type, nr, size) = dir << 30 | size << 16 | type << 8 | nr`, `_IOC_WRITE` 1,
    /// `_IOC_READ` 2 (so `_IOW` is 0x4..., `_IOWR` 0xC...), type '#' = 0x23, and the sizes
    /// above.
    #[test]
    #[cfg(any(
        target_arch = "x86_64",
        target_arch = "aarch64",
        target_arch = "riscv64"
    ))]
    fn request_numbers_match_the_ioc_encoding() {
        assert_eq!(GET_INFO.code, 0xC028_2300); // _IOWR, 40 = 0x28, nr 0x00
        assert_eq!(SEND_REQUEST.code, 0x4028_2301); // _IOW, 40, nr 0x01
        assert_eq!(CREATE_ISO_CONTEXT.code, 0xC020_2308); // _IOWR, 32 = 0x20, nr 0x08
        assert_eq!(QUEUE_ISO.code, 0xC018_2309); // _IOWR, 24 = 0x18, nr 0x09
        assert_eq!(START_ISO.code, 0x4010_230A); // _IOW, 16 = 0x10, nr 0x0a
        assert_eq!(STOP_ISO.code, 0x4004_230B); // _IOW, 4, nr 0x0b
        assert_eq!(ALLOCATE_ISO_RESOURCE.code, 0xC018_230D); // _IOWR, 24, nr 0x0d
    }

    #[test]
    fn packet_control_words_follow_the_header_macros() {
        // FW_CDEV_ISO_HEADER_LENGTH(4) = 4 << 24, FW_CDEV_ISO_INTERRUPT = 1 << 16,
        // FW_CDEV_ISO_PAYLOAD_LENGTH(64) = 64.
        assert_eq!(RX_CONTROL, 0x0401_0040);
        // Tag 0, sy 0, no header quadlets, 16 payload bytes.
        assert_eq!(TX_CONTROL, 0x0000_0010);
        assert_eq!(TX_CONTROL | ISO_INTERRUPT, 0x0001_0010);
    }

    const C_PROBE: &str = r#"
#include <stdio.h>
#include <stddef.h>
#include <linux/firewire-cdev.h>
#include <linux/firewire-constants.h>
#define S(t) printf("sizeof " #t " %lu\n", (unsigned long)sizeof(struct t))
#define O(t, f) printf("offsetof " #t "." #f " %lu\n", (unsigned long)offsetof(struct t, f))
#define V(n) printf("value " #n " %lu\n", (unsigned long)(n))
int main(void) {
    S(fw_cdev_get_info); O(fw_cdev_get_info, rom); O(fw_cdev_get_info, bus_reset);
    O(fw_cdev_get_info, card);
    S(fw_cdev_send_request); O(fw_cdev_send_request, offset); O(fw_cdev_send_request, data);
    O(fw_cdev_send_request, generation);
    S(fw_cdev_create_iso_context); O(fw_cdev_create_iso_context, closure);
    O(fw_cdev_create_iso_context, handle);
    S(fw_cdev_queue_iso); O(fw_cdev_queue_iso, size); O(fw_cdev_queue_iso, handle);
    S(fw_cdev_start_iso); S(fw_cdev_stop_iso);
    S(fw_cdev_allocate_iso_resource); O(fw_cdev_allocate_iso_resource, bandwidth);
    S(fw_cdev_event_bus_reset); O(fw_cdev_event_bus_reset, node_id);
    O(fw_cdev_event_bus_reset, generation);
    O(fw_cdev_event_response, type); O(fw_cdev_event_response, rcode);
    O(fw_cdev_event_response, length); O(fw_cdev_event_response, data);
    O(fw_cdev_event_iso_interrupt, cycle); O(fw_cdev_event_iso_interrupt, header_length);
    O(fw_cdev_event_iso_interrupt, header);
    O(fw_cdev_event_iso_resource, channel); O(fw_cdev_event_iso_resource, bandwidth);
    V(FW_CDEV_IOC_GET_INFO); V(FW_CDEV_IOC_SEND_REQUEST); V(FW_CDEV_IOC_CREATE_ISO_CONTEXT);
    V(FW_CDEV_IOC_QUEUE_ISO); V(FW_CDEV_IOC_START_ISO); V(FW_CDEV_IOC_STOP_ISO);
    V(FW_CDEV_IOC_ALLOCATE_ISO_RESOURCE);
    V(FW_CDEV_EVENT_BUS_RESET); V(FW_CDEV_EVENT_RESPONSE); V(FW_CDEV_EVENT_ISO_INTERRUPT);
    V(FW_CDEV_EVENT_ISO_RESOURCE_ALLOCATED); V(FW_CDEV_EVENT_ISO_RESOURCE_DEALLOCATED);
    V(FW_CDEV_ISO_CONTEXT_TRANSMIT); V(FW_CDEV_ISO_CONTEXT_RECEIVE);
    V(FW_CDEV_ISO_INTERRUPT); V(FW_CDEV_ISO_HEADER_LENGTH(4));
    V(FW_CDEV_ISO_CONTEXT_MATCH_ALL_TAGS);
    V(TCODE_WRITE_BLOCK_REQUEST); V(TCODE_READ_QUADLET_REQUEST); V(TCODE_READ_BLOCK_REQUEST);
    V(RCODE_COMPLETE); V(RCODE_CONFLICT_ERROR); V(RCODE_DATA_ERROR); V(RCODE_TYPE_ERROR);
    V(RCODE_ADDRESS_ERROR); V(RCODE_SEND_ERROR); V(RCODE_CANCELLED); V(RCODE_BUSY);
    V(RCODE_GENERATION); V(RCODE_NO_ACK); V(SCODE_100);
    return 0;
}
"#;

    /// A second opinion from the C compiler on the installed header. The primary checks are
    /// the hand-derived tests above; this one skips, saying why, without a compiler or header.
    #[test]
    fn layout_and_numbers_agree_with_the_c_compiler() {
        let header = Path::new("/usr/include/linux/firewire-cdev.h");
        if !header.exists() {
            note!("note: skipped: {} is not installed", header.display());
            return;
        }
        let dir = scratch("cprobe");
        let src = dir.join("probe.c");
        let bin = dir.join("probe");
        std::fs::write(&src, C_PROBE).expect("write the C probe");
        let cc = std::env::var("CC").unwrap_or_else(|_| "cc".into());
        let built = match Command::new(&cc).arg("-o").arg(&bin).arg(&src).output() {
            Err(e) if e.kind() == io::ErrorKind::NotFound => {
                note!("note: skipped: no C compiler ({cc})");
                return;
            }
            Err(e) => panic!("{cc} could not run: {e}"),
            Ok(o) => o,
        };
        assert!(
            built.status.success(),
            "{cc} failed: {}",
            String::from_utf8_lossy(&built.stderr)
        );
        let out = Command::new(&bin).output().expect("run the probe");
        let text = String::from_utf8_lossy(&out.stdout);
        let c: HashMap<String, u64> = text
            .lines()
            .filter_map(|l| {
                let (k, v) = l.rsplit_once(' ')?;
                Some((k.to_string(), v.parse().ok()?))
            })
            .collect();
        let rust: Vec<(&str, u64)> = vec![
            ("sizeof fw_cdev_get_info", size_of::<GetInfo>() as u64),
            (
                "offsetof fw_cdev_get_info.rom",
                offset_of!(GetInfo, rom) as u64,
            ),
            (
                "offsetof fw_cdev_get_info.bus_reset",
                offset_of!(GetInfo, bus_reset) as u64,
            ),
            (
                "offsetof fw_cdev_get_info.card",
                offset_of!(GetInfo, card) as u64,
            ),
            (
                "sizeof fw_cdev_send_request",
                size_of::<SendRequest>() as u64,
            ),
            (
                "offsetof fw_cdev_send_request.offset",
                offset_of!(SendRequest, offset) as u64,
            ),
            (
                "offsetof fw_cdev_send_request.data",
                offset_of!(SendRequest, data) as u64,
            ),
            (
                "offsetof fw_cdev_send_request.generation",
                offset_of!(SendRequest, generation) as u64,
            ),
            (
                "sizeof fw_cdev_create_iso_context",
                size_of::<CreateIsoContext>() as u64,
            ),
            (
                "offsetof fw_cdev_create_iso_context.closure",
                offset_of!(CreateIsoContext, closure) as u64,
            ),
            (
                "offsetof fw_cdev_create_iso_context.handle",
                offset_of!(CreateIsoContext, handle) as u64,
            ),
            ("sizeof fw_cdev_queue_iso", size_of::<QueueIso>() as u64),
            (
                "offsetof fw_cdev_queue_iso.size",
                offset_of!(QueueIso, size) as u64,
            ),
            (
                "offsetof fw_cdev_queue_iso.handle",
                offset_of!(QueueIso, handle) as u64,
            ),
            ("sizeof fw_cdev_start_iso", size_of::<StartIso>() as u64),
            ("sizeof fw_cdev_stop_iso", size_of::<StopIso>() as u64),
            (
                "sizeof fw_cdev_allocate_iso_resource",
                size_of::<AllocateIsoResource>() as u64,
            ),
            (
                "offsetof fw_cdev_allocate_iso_resource.bandwidth",
                offset_of!(AllocateIsoResource, bandwidth) as u64,
            ),
            (
                "sizeof fw_cdev_event_bus_reset",
                size_of::<BusReset>() as u64,
            ),
            (
                "offsetof fw_cdev_event_bus_reset.node_id",
                BUS_RESET_NODE_ID as u64,
            ),
            (
                "offsetof fw_cdev_event_bus_reset.generation",
                BUS_RESET_GENERATION as u64,
            ),
            ("offsetof fw_cdev_event_response.type", EV_TYPE as u64),
            (
                "offsetof fw_cdev_event_response.rcode",
                RESPONSE_RCODE as u64,
            ),
            (
                "offsetof fw_cdev_event_response.length",
                RESPONSE_LENGTH as u64,
            ),
            ("offsetof fw_cdev_event_response.data", RESPONSE_DATA as u64),
            (
                "offsetof fw_cdev_event_iso_interrupt.cycle",
                ISO_INTERRUPT_CYCLE as u64,
            ),
            (
                "offsetof fw_cdev_event_iso_interrupt.header_length",
                ISO_INTERRUPT_HEADER_LENGTH as u64,
            ),
            (
                "offsetof fw_cdev_event_iso_interrupt.header",
                ISO_INTERRUPT_HEADER as u64,
            ),
            (
                "offsetof fw_cdev_event_iso_resource.channel",
                ISO_RESOURCE_CHANNEL as u64,
            ),
            (
                "offsetof fw_cdev_event_iso_resource.bandwidth",
                ISO_RESOURCE_BANDWIDTH as u64,
            ),
            ("value FW_CDEV_IOC_GET_INFO", u64::from(GET_INFO.code)),
            (
                "value FW_CDEV_IOC_SEND_REQUEST",
                u64::from(SEND_REQUEST.code),
            ),
            (
                "value FW_CDEV_IOC_CREATE_ISO_CONTEXT",
                u64::from(CREATE_ISO_CONTEXT.code),
            ),
            ("value FW_CDEV_IOC_QUEUE_ISO", u64::from(QUEUE_ISO.code)),
            ("value FW_CDEV_IOC_START_ISO", u64::from(START_ISO.code)),
            ("value FW_CDEV_IOC_STOP_ISO", u64::from(STOP_ISO.code)),
            (
                "value FW_CDEV_IOC_ALLOCATE_ISO_RESOURCE",
                u64::from(ALLOCATE_ISO_RESOURCE.code),
            ),
            ("value FW_CDEV_EVENT_BUS_RESET", u64::from(EVENT_BUS_RESET)),
            ("value FW_CDEV_EVENT_RESPONSE", u64::from(EVENT_RESPONSE)),
            (
                "value FW_CDEV_EVENT_ISO_INTERRUPT",
                u64::from(EVENT_ISO_INTERRUPT),
            ),
            (
                "value FW_CDEV_EVENT_ISO_RESOURCE_ALLOCATED",
                u64::from(EVENT_ISO_RESOURCE_ALLOCATED),
            ),
            (
                "value FW_CDEV_EVENT_ISO_RESOURCE_DEALLOCATED",
                u64::from(EVENT_ISO_RESOURCE_DEALLOCATED),
            ),
            (
                "value FW_CDEV_ISO_CONTEXT_TRANSMIT",
                u64::from(ISO_CONTEXT_TRANSMIT),
            ),
            (
                "value FW_CDEV_ISO_CONTEXT_RECEIVE",
                u64::from(ISO_CONTEXT_RECEIVE),
            ),
            ("value FW_CDEV_ISO_INTERRUPT", u64::from(ISO_INTERRUPT)),
            (
                "value FW_CDEV_ISO_HEADER_LENGTH(4)",
                u64::from(iso_header_length(4)),
            ),
            (
                "value FW_CDEV_ISO_CONTEXT_MATCH_ALL_TAGS",
                u64::from(ISO_CONTEXT_MATCH_ALL_TAGS),
            ),
            (
                "value TCODE_WRITE_BLOCK_REQUEST",
                u64::from(TCODE_WRITE_BLOCK_REQUEST),
            ),
            (
                "value TCODE_READ_QUADLET_REQUEST",
                u64::from(TCODE_READ_QUADLET_REQUEST),
            ),
            (
                "value TCODE_READ_BLOCK_REQUEST",
                u64::from(TCODE_READ_BLOCK_REQUEST),
            ),
            ("value RCODE_COMPLETE", u64::from(RCODE_COMPLETE)),
            (
                "value RCODE_CONFLICT_ERROR",
                u64::from(RCODE_CONFLICT_ERROR),
            ),
            ("value RCODE_DATA_ERROR", u64::from(RCODE_DATA_ERROR)),
            ("value RCODE_TYPE_ERROR", u64::from(RCODE_TYPE_ERROR)),
            ("value RCODE_ADDRESS_ERROR", u64::from(RCODE_ADDRESS_ERROR)),
            ("value RCODE_SEND_ERROR", u64::from(RCODE_SEND_ERROR)),
            ("value RCODE_CANCELLED", u64::from(RCODE_CANCELLED)),
            ("value RCODE_BUSY", u64::from(RCODE_BUSY)),
            ("value RCODE_GENERATION", u64::from(RCODE_GENERATION)),
            ("value RCODE_NO_ACK", u64::from(RCODE_NO_ACK)),
            ("value SCODE_100", u64::from(SCODE_100)),
        ];
        assert_eq!(c.len(), rust.len(), "probe output:\n{text}");
        for (name, value) in rust {
            assert_eq!(c.get(name), Some(&value), "{name}");
        }
    }

    /// A configuration ROM laid out by hand after IEEE 1212 / IEEE 1394: quadlet 0
    /// (info_length 4, crc_length 4, CRC not checked), the bus information block ("1394", bus
    /// options, GUID high, GUID low), a root directory of three entries.
    fn rom_with(guid_hi: u32, root: &[u32]) -> Vec<u32> {
        let mut rom = vec![0x0404_5a5a, 0x3133_3934, 0xe064_a002, guid_hi, 0x1234_5678];
        rom.push((root.len() as u32) << 16 | 0xbeef);
        rom.extend_from_slice(root);
        rom
    }

    #[test]
    fn config_rom_of_a_sensable_node() {
        let rom = rom_with(
            0x000b_9900,
            &[
                0x0300_0b99, // key 0x03: Module_Vendor_ID 0x000b99
                0x0c00_83c0, // key 0x0c: node capabilities
                0x1700_0001, // key 0x17: Model_ID 1
            ],
        );
        let info = parse_config_rom(&rom).expect("a well-formed ROM");
        assert_eq!(info.vendor, Some(0x000b99));
        assert_eq!(info.model, Some(1));
        assert_eq!(info.guid, Some(0x000b_9900_1234_5678));
        assert_eq!(info.oui(), Some(0x000b99));
        assert!(info.is_sensable());
    }

    #[test]
    fn config_rom_vendor_decides_and_the_guid_is_the_fallback() {
        // Another vendor in the root directory, whatever the GUID says.
        let other = parse_config_rom(&rom_with(0x000b_9900, &[0x0300_a0b0])).expect("ROM");
        assert_eq!(other.vendor, Some(0x00a0b0));
        assert!(!other.is_sensable());
        // No vendor entry: the GUID's OUI (its upper 24 bits).
        let by_guid = parse_config_rom(&rom_with(0x000b_99ff, &[0x0c00_83c0])).expect("ROM");
        assert_eq!(by_guid.vendor, None);
        assert_eq!(by_guid.oui(), Some(0x000b99));
        assert!(by_guid.is_sensable());
        // The first vendor entry counts.
        let twice = parse_config_rom(&rom_with(0, &[0x0300_0b99, 0x0300_0001])).expect("ROM");
        assert_eq!(twice.vendor, Some(0x000b99));
        // A minimal ROM: info_length 1, the vendor id in the low 24 bits.
        let minimal = parse_config_rom(&[0x0100_0b99]).expect("minimal ROM");
        assert_eq!(
            minimal,
            RomInfo {
                vendor: Some(0x000b99),
                model: None,
                guid: None
            }
        );
    }

    #[test]
    fn malformed_config_roms_are_errors_not_panics() {
        assert_eq!(parse_config_rom(&[]), Err(RomError::Empty));
        assert_eq!(
            parse_config_rom(&[0x0204_0000, 0x3133_3934, 0]),
            Err(RomError::ShortBusInfo { info_length: 2 })
        );
        assert_eq!(
            parse_config_rom(&[0x0004_0000]),
            Err(RomError::ShortBusInfo { info_length: 0 })
        );
        // The bus information block cut short: the root directory header would be quadlet 5.
        assert_eq!(
            parse_config_rom(&[0x0404_0000, 0x3133_3934, 0]),
            Err(RomError::Truncated { need: 6, have: 3 })
        );
        let mut not_1394 = rom_with(0, &[0x0300_0b99]);
        not_1394[1] = 0x3133_3935;
        assert_eq!(
            parse_config_rom(&not_1394),
            Err(RomError::NotIeee1394 { found: 0x3133_3935 })
        );
        // A root directory claiming 9 entries with 1 present: needs quadlets up to 5 + 1 + 9.
        let mut long_dir = rom_with(0, &[0x0300_0b99]);
        long_dir[5] = 9 << 16;
        assert_eq!(
            parse_config_rom(&long_dir),
            Err(RomError::Truncated { need: 15, have: 7 })
        );
        // An info_length pointing past the end.
        assert_eq!(
            parse_config_rom(&[0xff00_0000, 0x3133_3934]),
            Err(RomError::Truncated { need: 257, have: 2 })
        );
        for e in [
            RomError::Empty,
            RomError::ShortBusInfo { info_length: 2 },
            RomError::NotIeee1394 { found: 1 },
            RomError::Truncated { need: 9, have: 3 },
        ] {
            assert!(!e.to_string().is_empty() && !e.to_string().contains('\n'));
        }
    }

    #[test]
    fn node_names_are_fw_and_digits_in_numeric_order() {
        let dir = scratch("names");
        for name in ["fw12", "fw0", "fw2", "fw", "fwx", "fw3a", "fw+1", "video0"] {
            std::fs::write(dir.join(name), b"").expect("write");
        }
        let names: Vec<String> = fw_nodes(&dir)
            .iter()
            .map(|p| p.file_name().unwrap().to_string_lossy().into_owned())
            .collect();
        assert_eq!(names, ["fw0", "fw2", "fw12"]);
        assert!(fw_nodes(&dir.join("absent")).is_empty());
    }

    #[test]
    fn discovery_without_fw_nodes_finds_nothing() {
        let dir = scratch("empty");
        assert!(discover_omnis_in(&dir, &dir).is_empty());
        assert!(discover_omnis_in(&dir.join("absent"), &dir.join("absent")).is_empty());
    }

    #[test]
    fn unreadable_nodes_are_listed_only_when_sysfs_names_sensable() {
        let dev = scratch("dev");
        let sys = scratch("sys");
        // Regular files: GET_INFO on them fails with ENOTTY, as on a node that is not ours.
        std::fs::write(dev.join("fw0"), b"").expect("write");
        std::fs::write(dev.join("fw1"), b"").expect("write");
        std::fs::create_dir_all(sys.join("fw0")).expect("mkdir");
        std::fs::write(sys.join("fw0").join("vendor"), "0x000b99\n").expect("write");
        std::fs::create_dir_all(sys.join("fw1")).expect("mkdir");
        std::fs::write(sys.join("fw1").join("vendor"), "0x00a0b0\n").expect("write");
        let found = discover_omnis_in(&dev, &sys);
        assert_eq!(found.len(), 1, "{found:?}");
        assert_eq!(found[0].path, dev.join("fw0"));
        let e = found[0].rom.as_ref().expect_err("not a firewire-cdev node");
        assert_eq!(e.step, "FW_CDEV_IOC_GET_INFO");
        assert_eq!(e.device, DeviceError::Transport("not a firewire-cdev node"));
        let line = found[0].describe();
        assert!(
            line.contains("fw0") && line.contains("cannot open"),
            "{line}"
        );
        assert!(!line.contains('\n'));
    }

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
            transmit_channel: 64,
            ..CdevConfig::default()
        };
        let e = CdevFirewire::open(&absent, bad).expect_err("channel 64");
        assert_eq!(e.step, "channels");
        assert!(e.to_string().contains("64"));
    }

    #[test]
    fn system_call_errors_map_to_device_errors() {
        let of = |errno| errno_error(&io::Error::from_raw_os_error(errno));
        assert_eq!(of(libc::ENODEV), DeviceError::Disconnected);
        assert_eq!(of(libc::ETIMEDOUT), DeviceError::Timeout);
        assert_eq!(
            of(libc::EACCES),
            DeviceError::Transport("permission denied on the /dev/fw* node")
        );
        assert_eq!(of(libc::EPERM), of(libc::EACCES));
        assert_eq!(
            of(libc::ENOTTY),
            DeviceError::Transport("not a firewire-cdev node")
        );
        assert!(matches!(of(libc::EBUSY), DeviceError::Transport(_)));
        assert!(matches!(of(libc::E2BIG), DeviceError::Transport(_)));
        let denied = OpenError::io(
            Path::new("/dev/fw1"),
            "open",
            &io::Error::from_raw_os_error(libc::EACCES),
        );
        let line = denied.to_string();
        assert!(line.starts_with("/dev/fw1: open: "), "{line}");
        assert!(line.contains("udev"), "{line}");
    }

    #[test]
    fn response_codes_map_to_device_errors() {
        assert_eq!(rcode_result(RCODE_COMPLETE), Ok(()));
        assert_eq!(rcode_result(RCODE_NO_ACK), Err(DeviceError::Disconnected));
        assert_eq!(rcode_result(RCODE_CANCELLED), Err(DeviceError::Timeout));
        for rcode in [
            RCODE_CONFLICT_ERROR,
            RCODE_DATA_ERROR,
            RCODE_TYPE_ERROR,
            RCODE_ADDRESS_ERROR,
            RCODE_SEND_ERROR,
            RCODE_BUSY,
            RCODE_GENERATION,
            0x0f,
        ] {
            assert!(
                matches!(rcode_result(rcode), Err(DeviceError::Transport(_))),
                "{rcode:#x}"
            );
        }
    }

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

    #[test]
    fn config_takes_the_omni_channels() {
        let omni = OmniConfig {
            receive_channel: 5,
            transmit_channel: 9,
            ..OmniConfig::default()
        };
        let c = CdevConfig::for_omni(&omni);
        assert_eq!((c.receive_channel, c.transmit_channel), (5, 9));
        assert_eq!(c.speed, SCODE_100);
    }
}
