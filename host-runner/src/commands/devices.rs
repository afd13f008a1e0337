//! `tetradrill devices`: the haptic devices found on this machine.

use crate::error::CliError;

/// Arguments of `devices`.
#[derive(Debug, clap::Args)]
pub struct DevicesArgs {}

/// Runs `devices`.
pub fn run(_args: &DevicesArgs) -> Result<(), CliError> {
    // The Omni is found (and opened) by its configuration ROM through firewire-cdev
    // (tetradrill_device::os::firewire), not by the device crate's sysfs scan.
    let found: Vec<_> = tetradrill_device::discover()
        .into_iter()
        .filter(|d| d.kind != tetradrill_device::DeviceKind::Omni)
        .collect();
    let omnis = tetradrill_device::os::firewire::discover_omnis();
    outln!("sim      always available (the simulated device)");
    if found.is_empty() && omnis.is_empty() {
        outln!(
            "(no hardware found: looked for a Falcon on USB 0403:cb48, a Touch on USB \
             0301:2988 or 2988:0302, an Omni among /dev/fw* nodes of vendor 0x000b99)"
        );
    }
    // The Touch opens through the vendor HD library, which discovery cannot see.
    let hd = tetradrill_device::os::hdapi::probe();
    match &hd {
        Ok(path) => outln!("(HD library for the Touch: found, {path})"),
        Err(e) => outln!("(HD library for the Touch: {e})"),
    }
    for d in &found {
        let kind = format!("{:?}", d.kind).to_lowercase();
        let hd_ok = d.kind == tetradrill_device::DeviceKind::Touch && hd.is_ok();
        let how = if d.openable || hd_ok {
            ""
        } else {
            "  (found, but this build cannot open it)"
        };
        outln!("{kind:<8} {}{how}", d.location);
    }
    for o in &omnis {
        outln!("omni     {}", o.describe());
    }
    Ok(())
}
