//! The system calls on a `/dev/fw*` node: every ioctl request the transport issues
//! (`GET_INFO`, `SEND_REQUEST`, `CREATE_ISO_CONTEXT`, `QUEUE_ISO`, `START_ISO`, `STOP_ISO`,
//! `ALLOCATE_ISO_RESOURCE`) and the `ppoll` every wait goes through. `unsafe` is allowed in
//! this file: each block is one system call, with its `// SAFETY:` reason; the argument types
//! and request numbers are [`super::abi`]'s.
#![allow(unsafe_code)]

use std::fs::File;
use std::io;
use std::os::fd::AsRawFd;

use super::abi::{
    AllocateIsoResource, BusReset, CreateIsoContext, GetInfo, QueueIso, Request, SendRequest,
    StartIso, StopIso, ABI_VERSION, CREATE_ISO_CONTEXT, GET_INFO, QUEUE_ISO, SEND_REQUEST,
    START_ISO, STOP_ISO,
};
use super::error::errno_error;
use super::event::CLOSURE_BUS_RESET;
use super::iso::IsoBuffer;
use crate::device::DeviceError;

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
pub(super) trait PlainArg {}
impl PlainArg for CreateIsoContext {}
impl PlainArg for StartIso {}
impl PlainArg for StopIso {}
impl PlainArg for AllocateIsoResource {}

pub(super) fn ioctl_plain<T: PlainArg>(
    file: &File,
    req: Request<T>,
    arg: &mut T,
) -> io::Result<()> {
    // SAFETY: `T: PlainArg` holds no pointers, so there is nothing else for the kernel to
    // read or write.
    unsafe { ioctl(file, req, arg) }.map(|_| ())
}

/// `FW_CDEV_IOC_GET_INFO`: fills `bus` with the current bus state and, when `rom` is given,
/// copies the node's configuration ROM into it (host-endian quadlets: the kernel's cached
/// copy). Returns the number of ROM quadlets copied.
pub(super) fn get_info(
    file: &File,
    rom: Option<&mut [u32]>,
    bus: &mut BusReset,
) -> io::Result<usize> {
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
pub(super) fn send_request(
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
pub(super) fn queue_iso(
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
    if end.is_none_or(|end| end > buffer.len()) {
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

pub(super) fn start_iso(file: &File, handle: u32, tags: u32) -> Result<(), DeviceError> {
    let mut a = StartIso {
        cycle: -1,
        sync: 0,
        tags,
        handle,
    };
    ioctl_plain(file, START_ISO, &mut a).map_err(|e| errno_error(&e))
}

pub(super) fn stop_iso(file: &File, handle: u32) -> Result<(), DeviceError> {
    let mut a = StopIso { handle };
    ioctl_plain(file, STOP_ISO, &mut a).map_err(|e| errno_error(&e))
}

/// Waits until `file` has an event to read or `timeout_ns` passes. `Ok(false)` on timeout
/// (or a signal); a node that went away is [`DeviceError::Disconnected`].
pub(super) fn poll_readable(file: &File, timeout_ns: u64) -> Result<bool, DeviceError> {
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

pub(super) fn create_context(
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
