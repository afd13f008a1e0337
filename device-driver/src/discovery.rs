//! What is attached, for `tetradrill devices`, and opening a device by kind.

use std::path::PathBuf;

use rusb::UsbContext;

use crate::device::{DeviceError, DeviceKind, HapticDevice};
use crate::falcon::{FalconConfig, FalconDevice};
use crate::sim::{Path, SimConfig, SimDevice};
use crate::touch::TOUCH_USB_IDS;

/// SensAble's OUI as sysfs shows it in `/sys/bus/firewire/devices/fw*/vendor`.
pub const SENSABLE_VENDOR: u32 = 0x000b99;

/// One device found.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct FoundDevice {
    /// Which kind.
    pub kind: DeviceKind,
    /// Where: `usb BUS:ADDR VID:PID` or a `/dev/fw*` node.
    pub location: String,
    /// Whether this build can open it directly (`false` for the Omni, which needs a
    /// FireWire transport, and the Touch, which needs the vendor library).
    pub openable: bool,
}

/// Kind of a USB device by vendor and product id.
pub fn classify_usb(vendor: u16, product: u16) -> Option<DeviceKind> {
    if (vendor, product) == (crate::falcon::VENDOR_ID, crate::falcon::PRODUCT_ID) {
        Some(DeviceKind::Falcon)
    } else if TOUCH_USB_IDS.contains(&(vendor, product)) {
        Some(DeviceKind::Touch)
    } else {
        None
    }
}

/// Whether a sysfs FireWire `vendor` attribute (e.g. `0x000b99`) names SensAble.
pub fn is_sensable_vendor(text: &str) -> bool {
    let t = text.trim();
    let hex = t
        .strip_prefix("0x")
        .or_else(|| t.strip_prefix("0X"))
        .unwrap_or(t);
    u32::from_str_radix(hex, 16)
        .map(|v| v == SENSABLE_VENDOR)
        .unwrap_or(false)
}

/// Lists the Falcons and Touches on USB and the SensAble nodes on FireWire. Never panics:
/// when libusb cannot be initialised or lists nothing, the USB part is simply empty.
pub fn discover() -> Vec<FoundDevice> {
    let mut found = Vec::new();
    // An explicit context: rusb's global one panics when libusb cannot start.
    if let Ok(list) = rusb::Context::new().and_then(|c| c.devices()) {
        for dev in list.iter() {
            let Ok(desc) = dev.device_descriptor() else {
                continue;
            };
            if let Some(kind) = classify_usb(desc.vendor_id(), desc.product_id()) {
                found.push(FoundDevice {
                    kind,
                    location: format!(
                        "usb {:03}:{:03} {:04x}:{:04x}",
                        dev.bus_number(),
                        dev.address(),
                        desc.vendor_id(),
                        desc.product_id()
                    ),
                    openable: kind == DeviceKind::Falcon,
                });
            }
        }
    }
    found.extend(firewire_nodes().into_iter().map(|node| FoundDevice {
        kind: DeviceKind::Omni,
        location: node,
        openable: false,
    }));
    found
}

/// `/dev/fw*` nodes whose sysfs vendor is SensAble.
fn firewire_nodes() -> Vec<String> {
    let Ok(dir) = std::fs::read_dir("/dev") else {
        return Vec::new();
    };
    let mut nodes: Vec<String> = dir
        .filter_map(|e| e.ok())
        .filter_map(|e| e.file_name().into_string().ok())
        .filter(|n| {
            n.starts_with("fw") && n[2..].chars().all(|c| c.is_ascii_digit()) && n.len() > 2
        })
        .filter(|n| {
            std::fs::read_to_string(format!("/sys/bus/firewire/devices/{n}/vendor"))
                .map(|v| is_sensable_vendor(&v))
                .unwrap_or(false)
        })
        .map(|n| format!("/dev/{n}"))
        .collect();
    nodes.sort();
    nodes
}

/// How to open a device.
#[derive(Debug, Default)]
pub struct OpenOptions {
    /// Falcon: the user's firmware file (never bundled). `None`: no upload; start-up still
    /// sets normal mode and checks that a firmware answers.
    pub falcon_firmware: Option<PathBuf>,
    /// Falcon settings.
    pub falcon: FalconConfig,
    /// Simulated device settings.
    pub sim: SimConfig,
}

/// Opens a real device by kind. `--device sim` is built with [`open_sim`] (it needs a path).
/// Errors: [`DeviceError::NotFound`] when nothing of that kind is attached (the message says
/// what was looked for); [`DeviceError::Unsupported`] for an attached Omni (it opens through
/// its FireWire transport, `os::firewire::CdevFirewire`, with the node found by
/// `os::firewire::discover_omnis`); [`DeviceError::LibraryNotFound`] for an attached Touch
/// (the host must load the HD library, `os::hdapi::HdApi`, and use
/// [`crate::touch::TouchDevice`]).
pub fn open(kind: DeviceKind, options: &OpenOptions) -> Result<Box<dyn HapticDevice>, DeviceError> {
    match kind {
        DeviceKind::Sim | DeviceKind::Custom => Err(DeviceError::Unsupported(kind)),
        DeviceKind::Falcon => {
            let mut dev = FalconDevice::open_usb(options.falcon)?;
            dev.start_with_file(options.falcon_firmware.as_deref())?;
            Ok(Box::new(dev))
        }
        DeviceKind::Omni | DeviceKind::Touch => {
            if discover().iter().any(|d| d.kind == kind) {
                Err(if kind == DeviceKind::Omni {
                    DeviceError::Unsupported(kind)
                } else {
                    DeviceError::LibraryNotFound
                })
            } else {
                Err(DeviceError::NotFound(kind))
            }
        }
    }
}

/// The simulated device on a path (a [`crate::Trace`] or a [`crate::Scripted`] closure).
pub fn open_sim<P: Path + 'static>(path: P, options: &OpenOptions) -> Box<dyn HapticDevice> {
    Box::new(SimDevice::new(path, options.sim))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn classifies_ids() {
        assert_eq!(classify_usb(0x0403, 0xcb48), Some(DeviceKind::Falcon));
        assert_eq!(classify_usb(0x0301, 0x2988), Some(DeviceKind::Touch));
        assert_eq!(classify_usb(0x2988, 0x0302), Some(DeviceKind::Touch));
        assert_eq!(classify_usb(0x2988, 0x0304), Some(DeviceKind::Touch));
        assert_eq!(classify_usb(0x2988, 0x0303), None);
        assert_eq!(classify_usb(0x0403, 0x6001), None);
        assert!(is_sensable_vendor("0x000b99\n"));
        assert!(!is_sensable_vendor("0x00a0b0"));
        assert!(!is_sensable_vendor("garbage"));
    }

    #[test]
    fn discovery_and_open_never_panic_without_hardware() {
        let found = discover();
        // No haptic device is attached to build machines; whatever is found is well-formed.
        for d in &found {
            assert!(!d.location.is_empty());
        }
        if !found.iter().any(|d| d.kind == DeviceKind::Omni) {
            let e = open(DeviceKind::Omni, &OpenOptions::default()).err();
            assert_eq!(e, Some(DeviceError::NotFound(DeviceKind::Omni)));
            assert!(e
                .map(|e| e.to_string())
                .unwrap_or_default()
                .contains("0x000b99"));
        }
        if !found.iter().any(|d| d.kind == DeviceKind::Falcon) {
            let e = open(DeviceKind::Falcon, &OpenOptions::default()).err();
            assert!(matches!(
                e,
                Some(DeviceError::NotFound(DeviceKind::Falcon)) | Some(DeviceError::Transport(_))
            ));
        }
        assert_eq!(DeviceKind::parse("falcon"), Some(DeviceKind::Falcon));
        assert_eq!(DeviceKind::parse("phantom"), None);
    }
}
