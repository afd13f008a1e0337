//! The firewire-cdev ABI the transport is written against, from the kernel's uapi headers
//! (`linux/firewire-cdev.h`, `linux/firewire-constants.h`; each item names what it mirrors):
//! the event, transaction, response and speed codes, the argument structures of the ioctls
//! and their request numbers, and the field offsets of the events read from a node.
//! Declarations only: the calls are in [`super::ioctl`], the event parser in [`super::event`].

use std::fmt;
use std::marker::PhantomData;

/// The firewire-cdev ABI version this code is written for (`fw_cdev_get_info.version`).
/// Version 5 flushes iso headers on overflow instead of dropping them; version 6 would turn
/// responses into `fw_cdev_event_response2`, which this code does not parse.
pub(super) const ABI_VERSION: u32 = 5;

// FW_CDEV_EVENT_* (firewire-cdev.h).
pub(super) const EVENT_BUS_RESET: u32 = 0x00;
pub(super) const EVENT_RESPONSE: u32 = 0x01;
pub(super) const EVENT_ISO_INTERRUPT: u32 = 0x03;
pub(super) const EVENT_ISO_RESOURCE_ALLOCATED: u32 = 0x04;
pub(super) const EVENT_ISO_RESOURCE_DEALLOCATED: u32 = 0x05;

// TCODE_* (firewire-constants.h).
pub(super) const TCODE_WRITE_QUADLET_REQUEST: u32 = 0x0;
pub(super) const TCODE_WRITE_BLOCK_REQUEST: u32 = 0x1;
pub(super) const TCODE_READ_QUADLET_REQUEST: u32 = 0x4;
pub(super) const TCODE_READ_BLOCK_REQUEST: u32 = 0x5;

// RCODE_* (firewire-constants.h).
pub(super) const RCODE_COMPLETE: u32 = 0x00;
pub(super) const RCODE_CONFLICT_ERROR: u32 = 0x04;
pub(super) const RCODE_DATA_ERROR: u32 = 0x05;
pub(super) const RCODE_TYPE_ERROR: u32 = 0x06;
pub(super) const RCODE_ADDRESS_ERROR: u32 = 0x07;
pub(super) const RCODE_SEND_ERROR: u32 = 0x10;
pub(super) const RCODE_CANCELLED: u32 = 0x11;
pub(super) const RCODE_BUSY: u32 = 0x12;
pub(super) const RCODE_GENERATION: u32 = 0x13;
pub(super) const RCODE_NO_ACK: u32 = 0x14;

/// Speed code S100 (`SCODE_100`, firewire-constants.h): the speed public Omni code transmits
/// at.
pub const SCODE_100: u32 = 0;

// FW_CDEV_ISO_CONTEXT_* and the fw_cdev_iso_packet control bits (firewire-cdev.h).
pub(super) const ISO_CONTEXT_TRANSMIT: u32 = 0;
pub(super) const ISO_CONTEXT_RECEIVE: u32 = 1;
pub(super) const ISO_INTERRUPT: u32 = 1 << 16;
pub(super) const ISO_CONTEXT_MATCH_ALL_TAGS: u32 = 15;

/// `FW_CDEV_ISO_HEADER_LENGTH(v)`.
pub(super) const fn iso_header_length(v: u32) -> u32 {
    v << 24
}

/// `struct fw_cdev_get_info`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct GetInfo {
    pub(super) version: u32,
    pub(super) rom_length: u32,
    pub(super) rom: u64,
    pub(super) bus_reset: u64,
    pub(super) bus_reset_closure: u64,
    pub(super) card: u32,
}

/// `struct fw_cdev_send_request`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct SendRequest {
    pub(super) tcode: u32,
    pub(super) length: u32,
    pub(super) offset: u64,
    pub(super) closure: u64,
    pub(super) data: u64,
    pub(super) generation: u32,
}

/// `struct fw_cdev_create_iso_context`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct CreateIsoContext {
    pub(super) kind: u32,
    pub(super) header_size: u32,
    pub(super) channel: u32,
    pub(super) speed: u32,
    pub(super) closure: u64,
    pub(super) handle: u32,
}

/// `struct fw_cdev_queue_iso`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct QueueIso {
    pub(super) packets: u64,
    pub(super) data: u64,
    pub(super) size: u32,
    pub(super) handle: u32,
}

/// `struct fw_cdev_start_iso`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct StartIso {
    pub(super) cycle: i32,
    pub(super) sync: u32,
    pub(super) tags: u32,
    pub(super) handle: u32,
}

/// `struct fw_cdev_stop_iso`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct StopIso {
    pub(super) handle: u32,
}

/// `struct fw_cdev_allocate_iso_resource`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct AllocateIsoResource {
    pub(super) closure: u64,
    pub(super) channels: u64,
    pub(super) bandwidth: u32,
    pub(super) handle: u32,
}

/// `struct fw_cdev_event_bus_reset` (GET_INFO fills one with the current bus state).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct BusReset {
    pub(super) closure: u64,
    pub(super) kind: u32,
    pub(super) node_id: u32,
    local_node_id: u32,
    bm_node_id: u32,
    irm_node_id: u32,
    root_node_id: u32,
    pub(super) generation: u32,
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
pub(super) struct Request<T> {
    pub(super) code: u32,
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
pub(super) const GET_INFO: Request<GetInfo> = iowr(0x00);
pub(super) const SEND_REQUEST: Request<SendRequest> = iow(0x01);
pub(super) const CREATE_ISO_CONTEXT: Request<CreateIsoContext> = iowr(0x08);
pub(super) const QUEUE_ISO: Request<QueueIso> = iowr(0x09);
pub(super) const START_ISO: Request<StartIso> = iow(0x0a);
pub(super) const STOP_ISO: Request<StopIso> = iow(0x0b);
pub(super) const ALLOCATE_ISO_RESOURCE: Request<AllocateIsoResource> = iowr(0x0d);

// Field offsets of the events (firewire-cdev.h; every event starts with `__u64 closure` at 0
// and `__u32 type` at 8, then 4-byte fields; flexible arrays follow the last field).
pub(super) const EV_CLOSURE: usize = 0;
pub(super) const EV_TYPE: usize = 8;
pub(super) const BUS_RESET_NODE_ID: usize = 12;
pub(super) const BUS_RESET_GENERATION: usize = 32;
pub(super) const RESPONSE_RCODE: usize = 12;
pub(super) const RESPONSE_LENGTH: usize = 16;
pub(super) const RESPONSE_DATA: usize = 20;
pub(super) const ISO_INTERRUPT_CYCLE: usize = 12;
pub(super) const ISO_INTERRUPT_HEADER_LENGTH: usize = 16;
pub(super) const ISO_INTERRUPT_HEADER: usize = 20;
pub(super) const ISO_RESOURCE_CHANNEL: usize = 16;
pub(super) const ISO_RESOURCE_BANDWIDTH: usize = 20;

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashMap;
    use std::io;
    use std::mem::offset_of;
    use std::path::Path;
    use std::process::Command;

    use crate::os::firewire::scratch;

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
    V(TCODE_WRITE_QUADLET_REQUEST);
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
                "value TCODE_WRITE_QUADLET_REQUEST",
                u64::from(TCODE_WRITE_QUADLET_REQUEST),
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
}
