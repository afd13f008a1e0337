//! The transport's errors: a system call's errno or a response code as a [`DeviceError`], and
//! [`OpenError`], one line naming a node that could not be opened or identified, the step and
//! why.

use std::fmt;
use std::io;
use std::path::{Path, PathBuf};

use super::abi::{
    RCODE_ADDRESS_ERROR, RCODE_BUSY, RCODE_CANCELLED, RCODE_COMPLETE, RCODE_CONFLICT_ERROR,
    RCODE_DATA_ERROR, RCODE_GENERATION, RCODE_NO_ACK, RCODE_SEND_ERROR, RCODE_TYPE_ERROR,
};
use crate::device::DeviceError;

/// A system call's error as a device error: the node gone is `Disconnected`, the rest a short
/// reason.
pub(super) fn errno_error(e: &io::Error) -> DeviceError {
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
pub(super) fn rcode_result(rcode: u32) -> Result<(), DeviceError> {
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
    pub(super) fn io(path: &Path, step: &'static str, e: &io::Error) -> OpenError {
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

#[cfg(test)]
mod tests {
    use super::*;

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
}
