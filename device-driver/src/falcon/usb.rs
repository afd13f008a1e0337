//! The real Falcon transport over `rusb` (libusb).

use core::fmt;

use rusb::UsbContext;
use std::sync::Arc;
use std::time::Duration;

use super::ftdi::{EP_IN, EP_OUT, REQUEST_TYPE_OUT};
use super::{Transport, PRODUCT_ID, VENDOR_ID};
use crate::cutoff::{Cut, OutPath, PACKET_LEN};
use crate::device::{DeviceError, DeviceKind};

/// Timeout of a frame sent through the [`RusbOut`] second path, ms.
pub const OUT_PATH_TIMEOUT_MS: u64 = 10;

/// An open Falcon: interface 0 claimed, bulk endpoints 0x02 / 0x81. The handle is shared with
/// its [`RusbOut`] second path.
pub struct RusbTransport {
    handle: Arc<rusb::DeviceHandle<rusb::Context>>,
}

/// The Falcon's second path to bulk endpoint 0x02: the same libusb handle, used from another
/// thread (libusb's synchronous transfers are thread-safe; transfers on one endpoint go out in
/// the order they were submitted). Never takes a lock the servo holds.
pub struct RusbOut {
    handle: Arc<rusb::DeviceHandle<rusb::Context>>,
}

impl fmt::Debug for RusbOut {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("RusbOut(0403:cb48, bulk 0x02)")
    }
}

impl OutPath for RusbOut {
    fn send(&self, packet: &[u8; PACKET_LEN]) -> Result<Cut, DeviceError> {
        match self
            .handle
            .write_bulk(EP_OUT, packet, Duration::from_millis(OUT_PATH_TIMEOUT_MS))
        {
            Ok(n) if n == packet.len() => Ok(Cut::Done),
            Ok(_) => Err(DeviceError::Timeout),
            Err(e) => Err(map_usb_error(e)),
        }
    }
}

impl fmt::Debug for RusbTransport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("RusbTransport(0403:cb48)")
    }
}

/// Maps libusb errors to device errors.
pub fn map_usb_error(e: rusb::Error) -> DeviceError {
    match e {
        rusb::Error::NoDevice => DeviceError::Disconnected,
        rusb::Error::Timeout => DeviceError::Timeout,
        rusb::Error::NotFound => DeviceError::NotFound(DeviceKind::Falcon),
        rusb::Error::Access => {
            DeviceError::Transport("permission denied (udev rule for 0403:cb48?)")
        }
        rusb::Error::Busy => DeviceError::Transport("device busy (claimed by another program)"),
        rusb::Error::Pipe => DeviceError::Transport("endpoint stalled"),
        rusb::Error::Overflow => DeviceError::Transport("overflow"),
        rusb::Error::Io => DeviceError::Transport("I/O error"),
        _ => DeviceError::Transport("libusb error"),
    }
}

impl RusbTransport {
    /// Opens the first 0403:cb48 device; [`DeviceError::NotFound`] when there is none.
    pub fn open() -> Result<RusbTransport, DeviceError> {
        // An explicit context: libusb's global one panics in rusb when libusb cannot start
        // (no USB subsystem, containers); a failed init here is just "not found".
        let context =
            rusb::Context::new().map_err(|_| DeviceError::NotFound(DeviceKind::Falcon))?;
        let handle = context
            .open_device_with_vid_pid(VENDOR_ID, PRODUCT_ID)
            .ok_or(DeviceError::NotFound(DeviceKind::Falcon))?;
        // Not supported on every platform; harmless when it fails.
        let _ = handle.set_auto_detach_kernel_driver(true);
        handle.claim_interface(0).map_err(map_usb_error)?;
        Ok(RusbTransport {
            handle: Arc::new(handle),
        })
    }
}

impl Transport for RusbTransport {
    fn control_out(&mut self, request: u8, value: u16, index: u16) -> Result<(), DeviceError> {
        self.handle
            .write_control(
                REQUEST_TYPE_OUT,
                request,
                value,
                index,
                &[],
                Duration::from_millis(1000),
            )
            .map(|_| ())
            .map_err(map_usb_error)
    }

    fn bulk_write(&mut self, data: &[u8], timeout_ms: u32) -> Result<usize, DeviceError> {
        self.handle
            .write_bulk(EP_OUT, data, Duration::from_millis(u64::from(timeout_ms)))
            .map_err(map_usb_error)
    }

    fn bulk_read(&mut self, buf: &mut [u8], timeout_ms: u32) -> Result<usize, DeviceError> {
        match self
            .handle
            .read_bulk(EP_IN, buf, Duration::from_millis(u64::from(timeout_ms)))
        {
            Ok(n) => Ok(n),
            // An empty poll is not an error for the caller: it retries or reports NoFrame.
            Err(rusb::Error::Timeout) => Ok(0),
            Err(e) => Err(map_usb_error(e)),
        }
    }

    fn out_path(&self) -> Option<Arc<dyn OutPath>> {
        Some(Arc::new(RusbOut {
            handle: Arc::clone(&self.handle),
        }))
    }

    /// Releases interface 0 and closes the handle, then opens the first Falcon again and
    /// claims the interface (libnifalcon's `FalconCommLibUSB::close` and `open`). Refused
    /// while a [`RusbOut`] still holds the handle (the device's cutoff lets go of it first).
    fn reopen(&mut self) -> Result<(), DeviceError> {
        let Some(handle) = Arc::get_mut(&mut self.handle) else {
            return Err(DeviceError::Transport(
                "cannot reopen: the second path still holds the USB handle",
            ));
        };
        // Failing to release is harmless: closing the handle releases it too.
        let _ = handle.release_interface(0);
        *self = RusbTransport::open()?;
        Ok(())
    }
}
