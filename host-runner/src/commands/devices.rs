//! `tetradrill devices [--check]`: the haptic devices found on this machine; with `--check`,
//! each one opened and read for a moment (firmware, homing, calibration state, live encoder
//! readings), never writing force.

use std::path::PathBuf;

use tetradrill_device::falcon::FalconDevice;
use tetradrill_device::omni::OmniDevice;
use tetradrill_device::os::firewire::{discover_omnis, CdevConfig, CdevFirewire, OmniNode};
use tetradrill_device::os::hdapi::HdApi;
use tetradrill_device::touch::TouchDevice;
use tetradrill_device::{
    DeviceKind, DeviceState, HapticDevice, SimConfig, SimDevice, SimFault, SimModel, Still,
};

use crate::device_config::DeviceConfig;
use crate::error::CliError;

/// Arguments of `devices`.
#[derive(Debug, clap::Args)]
pub struct DevicesArgs {
    /// Open each device found and print its firmware, homing and calibration state and live
    /// encoder readings, writing no force.
    #[arg(long)]
    pub check: bool,
    /// Device constants (TOML: `[omni]`, `[falcon]`, `[touch]`) used to open the devices.
    #[arg(long, value_name = "FILE")]
    pub device_config: Option<PathBuf>,
    /// With `--check`: the motor-sign self-test (at most 0.3 N at the tip for 100 ms, one
    /// joint at a time, the stylus free); a reversed joint is exit status 2 naming it.
    #[arg(long, requires = "check")]
    pub motors: bool,
    /// Check only this device (`sim`: the simulated one, with `--sim-model` and
    /// `--sim-fault`).
    #[arg(long, value_parser = super::run::parse_device)]
    pub device: Option<DeviceKind>,
    /// The simulated device as `omni`, `falcon` or `touch` (`run --sim-model`).
    #[arg(long, value_name = "MODEL", value_parser = super::run::parse_sim_model)]
    pub sim_model: Option<SimModel>,
    /// A fault for the simulated device (`run --sim-fault`), e.g. `motor-sign:2`.
    #[arg(long, value_name = "KIND", value_parser = super::run::parse_sim_fault)]
    pub sim_fault: Option<SimFault>,
}

/// Readings taken per device by `--check`, about 1 ms apart.
pub const CHECK_READS: usize = 50;

/// What was looked for, for the nothing-found lines.
const LOOKED_FOR: &str = "looked for a Falcon on USB 0403:cb48, a Touch on USB 0301:2988, \
                          2988:0302 or 2988:0304, an Omni among /dev/fw* nodes of vendor 0x000b99";

/// Runs `devices`.
pub fn run(args: &DevicesArgs) -> Result<(), CliError> {
    let config = DeviceConfig::from_flag(args.device_config.as_deref())?;
    if (args.sim_model.is_some() || args.sim_fault.is_some())
        && args.device != Some(DeviceKind::Sim)
    {
        return Err(CliError::input(
            "--sim-model and --sim-fault: only with --device sim",
        ));
    }
    if args.device == Some(DeviceKind::Sim) {
        return check_sim(args, &config);
    }
    // The Omni is found (and opened) by its configuration ROM through firewire-cdev
    // (tetradrill_device::os::firewire), not by the device crate's sysfs scan.
    let found: Vec<_> = tetradrill_device::discover()
        .into_iter()
        .filter(|d| d.kind != DeviceKind::Omni)
        .collect();
    let omnis = discover_omnis();
    if args.check {
        return check(&config, &found, &omnis);
    }
    outln!("sim      always available (the simulated device)");
    if found.is_empty() && omnis.is_empty() {
        outln!("(no hardware found: {LOOKED_FOR})");
    }
    // The Touch opens through the vendor HD library, which discovery cannot see.
    let hd = tetradrill_device::os::hdapi::probe();
    match &hd {
        Ok(path) => outln!("(HD library for the Touch: found, {path})"),
        Err(e) => outln!("(HD library for the Touch: {e})"),
    }
    for d in &found {
        let kind = format!("{:?}", d.kind).to_lowercase();
        let hd_ok = d.kind == DeviceKind::Touch && hd.is_ok();
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

/// `devices --check`: every device found, opened, read [`CHECK_READS`] times with the motors
/// off, described; one line when nothing is attached.
fn check(
    config: &DeviceConfig,
    found: &[tetradrill_device::FoundDevice],
    omnis: &[OmniNode],
) -> Result<(), CliError> {
    // The vendor library reaches a Touch (or an Omni through the vendor driver) that the USB
    // scan may not list; it is asked only when it loads.
    let touch = match HdApi::load() {
        Ok(mut api) => match api.open_device(None) {
            Ok(()) => Some(api),
            Err(_) => None,
        },
        Err(_) => None,
    };
    let falcons: Vec<_> = found
        .iter()
        .filter(|d| d.kind == DeviceKind::Falcon)
        .collect();
    if falcons.is_empty() && omnis.is_empty() && touch.is_none() {
        outln!("no haptic device attached ({LOOKED_FOR}, and the vendor HD library for a Touch); no force written");
        return Ok(());
    }
    for f in &falcons {
        outln!("falcon   {}", f.location);
        match FalconDevice::open_usb(config.falcon) {
            Ok(mut dev) => {
                // Normal mode and a status round trip (zero-torque frames), as `run` starts it.
                if let Err(e) = dev.start(None) {
                    outln!("  firmware: not answering ({e}); load it with `run --device falcon --falcon-firmware FILE`");
                    continue;
                }
                let (ok, last) = sample(&mut dev);
                if ok == 0 {
                    outln!("  firmware: not answering ({}); load it with `run --device falcon --falcon-firmware FILE`", last.err().unwrap_or("no frame".into()));
                } else {
                    outln!("  firmware: running ({ok} of {CHECK_READS} readings)");
                    let h = dev.homed();
                    let state = if h & 0b111 == 0b111 {
                        "homed on all three axes".to_string()
                    } else {
                        format!(
                            "not homed (axes homed {h:03b}); move the grip through the workspace"
                        )
                    };
                    outln!("  homing: {state}");
                    if let Ok(s) = last {
                        print_state(&s);
                    }
                }
            }
            Err(e) => outln!("  cannot open: {e}"),
        }
    }
    for o in omnis {
        outln!("omni     {}", o.describe());
        if o.rom.is_err() {
            continue;
        }
        let transport = match CdevFirewire::open(&o.path, CdevConfig::default()) {
            Ok(t) => t,
            Err(e) => {
                outln!("  cannot open: {e}");
                continue;
            }
        };
        match OmniDevice::start(transport, config.omni) {
            Ok(mut dev) => {
                let (rx, tx) = dev.channels();
                outln!(
                    "  started: serial {:#010x}, isochronous channels receive {rx} transmit {tx}",
                    dev.serial()
                );
                let (ok, last) = sample(&mut dev);
                outln!("  packets: {ok} of {CHECK_READS} readings complete");
                let input = dev.last_input();
                let docked = if input.docked { "docked" } else { "not docked" };
                outln!(
                    "  calibration: not calibrated (stylus {docked}); `run --device omni` calibrates in the inkwell"
                );
                outln!(
                    "  encoders (counts): {:?}; gimbal channels {:?} / {:?}; buttons {}{}",
                    input.encoders.map(|c| c as i16),
                    input.gimbal,
                    input.gimbal_inv,
                    u8::from(input.button1),
                    u8::from(input.button2)
                );
                match last {
                    Ok(s) => print_state(&s),
                    Err(e) => outln!("  last reading: {e}"),
                }
            }
            Err(e) => outln!("  start-up failed: {e}"),
        }
    }
    if let Some(api) = touch {
        outln!("touch    through the vendor HD library ({})", api.path());
        match TouchDevice::new(api, None) {
            Ok(mut dev) => {
                let (ok, last) = sample(&mut dev);
                outln!("  readings: {ok} of {CHECK_READS}; calibration: the vendor library's");
                if let Ok(s) = last {
                    print_state(&s);
                }
            }
            Err(e) => outln!("  cannot start: {e}"),
        }
    }
    outln!("(no force written)");
    Ok(())
}

/// `devices --device sim [--check [--motors]]`: the simulated device (as `--sim-model`, with
/// `--sim-fault`), its hand still at the device origin: calibrated in its dock when it has
/// one, read [`CHECK_READS`] times, and with `--motors` the motor-sign self-test
/// ([`crate::motors`]); a reversed joint is exit status 2, one line naming it.
fn check_sim(args: &DevicesArgs, config: &DeviceConfig) -> Result<(), CliError> {
    let mut c = SimConfig::default();
    if let Some(m) = args.sim_model {
        c = c.model(m);
    }
    if let Some(f) = args.sim_fault {
        c.fault = f;
    }
    let model = args.sim_model.map_or("none", SimModel::name);
    outln!(
        "sim      the simulated device (model {model}, fault {})",
        c.fault.name()
    );
    if !args.check {
        return Ok(());
    }
    let mut dev = SimDevice::new(Still([0.0; 3]), c);
    let docked =
        super::run::calibrate_in_dock(&mut dev, &crate::watchdog::StopRequest::new(), 1, || {})
            .map_err(|e| CliError::failure(format!("--device sim: {e}")))?;
    let (ok, last) = sample(&mut dev);
    outln!(
        "  readings: {ok} of {CHECK_READS}; calibrated: {docked}; force ready: {}",
        dev.force_ready()
    );
    if let Ok(s) = last {
        print_state(&s);
    }
    if !args.motors {
        outln!("(no force written)");
        return Ok(());
    }
    let kind = match args.sim_model {
        Some(SimModel::Omni) => DeviceKind::Omni,
        Some(SimModel::Falcon) => DeviceKind::Falcon,
        Some(SimModel::Touch) => DeviceKind::Touch,
        None => DeviceKind::Sim,
    };
    let checks = crate::motors::self_test(&mut dev, false)
        .map_err(|e| CliError::failure(format!("--device sim: motor-sign self-test: {e}")))?;
    let Some(checks) = checks else {
        return Err(CliError::input(
            "--device sim: motor-sign self-test not run: the device renders no force yet (the \
             Falcon before its homing stroke)",
        ));
    };
    for j in &checks {
        outln!(
            "  {}",
            crate::motors::describe(j, kind, config.omni.dac_per_newton_metre)
        );
    }
    outln!(
        "(motor-sign self-test: at most {} N at the tip for {} ms, one joint at a time)",
        crate::motors::TEST_FORCE_N,
        crate::motors::TEST_TICKS
    );
    let bad: Vec<String> = checks
        .iter()
        .filter(|j| j.verdict != crate::motors::Verdict::SignOk)
        .map(|j| crate::motors::describe(j, kind, config.omni.dac_per_newton_metre))
        .collect();
    if bad.is_empty() {
        Ok(())
    } else {
        Err(CliError::input(format!(
            "motor-sign self-test: {}",
            bad.join("; ")
        )))
    }
}

/// Reads `device` [`CHECK_READS`] times about 1 ms apart with the motors off: the complete
/// readings and the last result.
fn sample(device: &mut dyn HapticDevice) -> (usize, Result<DeviceState, String>) {
    let mut ok = 0;
    let mut last = Err("no reading".to_string());
    for _ in 0..CHECK_READS {
        last = device.read().map_err(|e| e.to_string());
        if last.is_ok() {
            ok += 1;
        }
        let _ = device.write(&tetradrill_device::ForceCommand::OFF);
        std::thread::sleep(std::time::Duration::from_millis(1));
    }
    (ok, last)
}

fn print_state(s: &DeviceState) {
    let j = s.joint_angles;
    outln!(
        "  joints (rad): {:.4} {:.4} {:.4}  gimbal {:.4} {:.4} {:.4}; position (m): {:.4} {:.4} {:.4}; docked {}",
        j[0],
        j[1],
        j[2],
        j[3],
        j[4],
        j[5],
        s.position[0],
        s.position[1],
        s.position[2],
        s.docked
    );
}
