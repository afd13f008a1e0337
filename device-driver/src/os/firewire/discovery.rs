//! Finding Omnis: the `fw<N>` nodes of `/dev`, their configuration ROMs (IEEE 1212) read
//! through `FW_CDEV_IOC_GET_INFO`, and SensAble's OUI in them; for a node this user cannot
//! open, sysfs's vendor attribute vouches instead.

use std::fmt;
use std::fs::OpenOptions;
use std::os::unix::fs::OpenOptionsExt;
use std::path::{Path, PathBuf};

use super::abi::BusReset;
use super::error::OpenError;
use super::ioctl::get_info;
use crate::device::DeviceError;
use crate::discovery::{is_sensable_vendor, SENSABLE_VENDOR};

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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::os::firewire::scratch;

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
}
