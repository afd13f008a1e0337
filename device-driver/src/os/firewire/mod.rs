//! The PHANTOM Omni's IEEE-1394 transport on Linux: [`CdevFirewire`] implements
//! [`FirewireTransport`](crate::omni::FirewireTransport) over one `/dev/fw*` node with the
//! kernel's firewire-cdev ABI, and [`discover_omnis`] finds Omnis by the vendor OUI in their
//! configuration ROM.
//!
//! No vendor code is involved. The structures, event layouts and request numbers (`abi.rs`)
//! are written from the kernel's uapi headers (`linux/firewire-cdev.h`,
//! `linux/firewire-constants.h`; each item names what it mirrors); the register addresses and
//! packet layouts are the Omni codec's ([`crate::omni`]).
//!
//! | what the Omni protocol needs | kernel interface used here |
//! |------------------------------|----------------------------|
//! | quadlet and byte register reads, byte writes | `FW_CDEV_IOC_SEND_REQUEST` (quadlet read, 1-byte block read/write), answered by `FW_CDEV_EVENT_RESPONSE` read from the fd |
//! | 44-byte input packets        | an isochronous receive context (`CREATE_ISO_CONTEXT`, `QUEUE_ISO`, `START_ISO`) filling a ring of 64 slots in an mmapped buffer |
//! | 16-byte output packets       | an isochronous transmit context from an mmapped ring; each output is repeated every bus cycle (8 kHz) until the next one, as public Omni code does |
//! | the two channels             | `FW_CDEV_IOC_ALLOCATE_ISO_RESOURCE` at the bus's isochronous resource manager, the lowest free channels unless fixed ones are asked for; a refusal fails the open |
//! | 0x20010 quadlet write        | `FW_CDEV_IOC_SEND_REQUEST` (quadlet write)                  |
//! | bus resets                   | `FW_CDEV_EVENT_BUS_RESET` on the control and receive files, reported once by `take_bus_reset` |
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
//! [`DeviceError::Timeout`](crate::DeviceError::Timeout) or
//! [`DeviceError::Disconnected`](crate::DeviceError::Disconnected), never a hang or a panic.
//! After [`CdevFirewire::open`] nothing allocates: the event buffers, rings and control arrays
//! are fixed.
//!
//! Nothing here has run against a FireWire bus (none is attached to the build machines); see
//! docs/DEVICES.md for exactly what is untested.
//!
//! | file             | what                                                              |
//! |------------------|-------------------------------------------------------------------|
//! | `abi.rs`         | the firewire-cdev structures, codes and request numbers (declarations) |
//! | `ioctl.rs`       | the system calls: each ioctl request, and `ppoll` (`unsafe`)      |
//! | `event.rs`       | events read from a node, and the closures that tag them           |
//! | `error.rs`       | errno and response codes as device errors, [`OpenError`]         |
//! | `iso.rs`         | the mapped buffers and the receive and transmit rings (`unsafe`)  |
//! | `discovery.rs`   | configuration ROMs and [`discover_omnis`]                         |
//! | `transport.rs`   | [`CdevFirewire`] and [`CdevOut`]                                  |
//!
//! As in [`super::hdapi`] and [`super::clock`], `unsafe` is allowed only where it is needed
//! (`ioctl.rs`, `iso.rs`): each block is one system call or one copy in a mapped buffer, with
//! its `// SAFETY:` reason.

/// A note on stderr that the test harness does not capture (a skipped part says why).
#[cfg(test)]
macro_rules! note {
    ($($t:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stderr(), $($t)*);
    }};
}

mod abi;
mod discovery;
mod error;
mod event;
mod ioctl;
mod iso;
mod transport;

pub use abi::SCODE_100;
pub use discovery::{
    discover_omnis, discover_omnis_in, fw_nodes, parse_config_rom, read_config_rom, OmniNode,
    RomError, RomInfo,
};
pub use error::OpenError;
pub use transport::{CdevConfig, CdevFirewire, CdevOut, CdevStats};

/// A fresh directory under the system's temporary directory, removed when it drops.
#[cfg(test)]
fn scratch(tag: &str) -> Scratch {
    let dir =
        std::env::temp_dir().join(format!("tetradrill-firewire-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("create a scratch directory");
    Scratch(dir)
}

/// A test's scratch directory ([`scratch`]): a path while it lives, removed when it drops.
#[cfg(test)]
struct Scratch(std::path::PathBuf);

#[cfg(test)]
impl std::ops::Deref for Scratch {
    type Target = std::path::Path;
    fn deref(&self) -> &std::path::Path {
        &self.0
    }
}

#[cfg(test)]
impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}
