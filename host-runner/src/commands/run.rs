//! `tetradrill run`: the real-time pipeline with a device (the simulated one by default).
//!
//! A run lasts `--duration`, or the length of the simulated device's script or trace; a
//! wander (`--trace wander:SEED`) and the real devices have no end of their own. Any run ends
//! when its window closes, or on SIGINT (Ctrl-C), SIGTERM or SIGHUP: the first signal zeroes
//! the force within a servo tick, then the run stops cleanly (summary, `--json`, device
//! released, exit status 0); a second one exits at once (status 128 + its number), after the
//! zero force.

use std::path::PathBuf;

use tetradrill_core::script::DEMO;
use tetradrill_device::falcon::FalconDevice;
use tetradrill_device::omni::{OmniConfig, OmniDevice};
use tetradrill_device::os::firewire::{discover_omnis, CdevConfig, CdevFirewire, OmniNode};
use tetradrill_device::os::hdapi::{HdApi, HdLoadError};
use tetradrill_device::safety::SafetyConfig;
use tetradrill_device::{
    discovery::OpenOptions, CalibrationStyle, DeviceError, DeviceKind, DeviceSpec, ForceCommand,
    HapticDevice, PathPoint, Scripted, SimConfig, SimDevice, SimFault, SimModel, QUAT_IDENTITY,
};

use super::pipeline::{
    self, DampingCheck, DeviceFactory, PipelineSetup, RunChecks, StiffnessCap, MESH_UNITS,
    UNTIL_STOPPED,
};
use crate::device_config::DeviceConfig;
use crate::error::CliError;
use crate::meshio::LoadedMesh;
use crate::rt::RtConfig;
use crate::scenario::{Scenario, ScenarioFlags};
use crate::setup::Setup;
use crate::tasks::{ServoGate, Workspace};
use crate::traces::PoseSource;
use crate::watchdog::StopRequest;

/// Arguments of `run`.
#[derive(Debug, clap::Args)]
pub struct RunArgs {
    /// The haptic device: sim, falcon, omni or touch.
    #[arg(long, default_value = "sim", value_parser = parse_device)]
    pub device: DeviceKind,
    /// Scenario settings (mesh, trace for the simulated device, tool, stiffness, drilling).
    #[command(flatten)]
    pub scenario: ScenarioFlags,
    /// Seconds to run (default: the script's or trace's length with the simulated device;
    /// a wander and the real devices run until the window closes or a signal).
    #[arg(long, allow_negative_numbers = true, value_parser = crate::scenario::positive_seconds)]
    pub duration: Option<f64>,
    /// No viewer.
    #[arg(long)]
    pub headless: bool,
    /// Write the summary as JSON.
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Record the session's tool samples as a trace CSV (`replay --trace` reads it).
    #[arg(long)]
    pub record: Option<PathBuf>,
    /// The Falcon's firmware file (yours; never bundled). Without it the firmware is assumed
    /// to be running already.
    #[arg(long)]
    pub falcon_firmware: Option<PathBuf>,
    /// Device constants (TOML: `[omni]`, `[falcon]`, `[touch]`); defaults in docs/devices/*.toml.
    #[arg(long, value_name = "FILE")]
    pub device_config: Option<PathBuf>,
    /// Do not ask for SCHED_FIFO, core pinning or memory locking.
    #[arg(long)]
    pub no_rt: bool,
    /// No live status line.
    #[arg(long)]
    pub quiet: bool,
    /// What the run leaves besides its summary: a picture, a clip plane, the burr's sound.
    #[command(flatten)]
    pub outputs: super::pipeline::RunOutputs,
    /// A fault for the simulated device: `reversed-force` (the stylus receives -F) or
    /// `mirrored-x` (the reported x is mirrored); the passivity controller must trip.
    #[arg(long, value_name = "KIND", value_parser = parse_sim_fault)]
    pub sim_fault: Option<SimFault>,
    /// The simulated device as a real one: `omni`, `falcon` or `touch` (its limits, its
    /// workspace over the mesh, how it starts: docked in the inkwell, or the Falcon's homing
    /// stroke; the motor-sign self-test before the run).
    #[arg(long, value_name = "MODEL", value_parser = parse_sim_model)]
    pub sim_model: Option<SimModel>,
}

/// `--sim-model`'s parser.
pub fn parse_sim_model(s: &str) -> Result<SimModel, String> {
    SimModel::parse(s).ok_or_else(|| {
        format!(
            "`{s}` is not a device model ({})",
            SimModel::NAMES.join(", ")
        )
    })
}

/// `--sim-fault`'s parser.
pub fn parse_sim_fault(s: &str) -> Result<SimFault, String> {
    SimFault::parse(s)
        .ok_or_else(|| format!("`{s}` is not a fault ({})", SimFault::NAMES.join(", ")))
}

/// `--device`'s parser.
pub fn parse_device(s: &str) -> Result<DeviceKind, String> {
    DeviceKind::parse(s).ok_or_else(|| format!("`{s}` is not a device (sim, falcon, omni, touch)"))
}

/// Runs `run`.
pub fn run(args: &RunArgs) -> Result<(), CliError> {
    let sc = Scenario::from_flags(&args.scenario)?.setup()?;
    let view = args.outputs.view(args.headless)?;
    // The mesh, read once: the world's, the wander's waypoints, the device's workspace.
    let loaded = crate::engine::load_mesh(&sc)?;
    let devices = DeviceConfig::from_flag(args.device_config.as_deref())?;
    let mut options = OpenOptions {
        falcon_firmware: args.falcon_firmware.clone(),
        falcon: devices.falcon,
        ..OpenOptions::default()
    };
    if let Some(fault) = args.sim_fault {
        if args.device != DeviceKind::Sim {
            return Err(CliError::input(format!(
                "--sim-fault {}: only the simulated device takes a fault (--device sim)",
                fault.name()
            )));
        }
        options.sim.fault = fault;
    }
    let mut sc = sc;
    let mut checks = RunChecks::default();
    let stop = StopRequest::new();
    let (open, default_ticks, workspace) = match args.sim_model {
        Some(model) => {
            if args.device != DeviceKind::Sim {
                return Err(CliError::input(format!(
                    "--sim-model {}: only the simulated device takes a model (--device sim)",
                    model.name()
                )));
            }
            options.sim = options.sim.model(model);
            sim_model_factory(model, &sc, &loaded, options.sim, &devices, &checks)?
        }
        None => device_factory_with(args.device, &sc, &loaded, options, &devices, &stop)?,
    };
    let real = args.device != DeviceKind::Sim || args.sim_model.is_some();
    if real {
        let spec = match args.sim_model {
            Some(m) => m.spec(),
            None => spec_of(args.device),
        };
        checks.stiffness_capped = cap_stiffness(&mut sc, &spec, &workspace);
        if let Some(c) = checks.stiffness_capped {
            errln!(
                "tetradrill: warning: --stiffness {} is {:.0} N/m at the {}, past its maximum \
                 stable stiffness {:.0} N/m: using {:.0} N/m (stiffness {})",
                c.scene_stiffness * c.asked_n_per_m / c.used_n_per_m,
                c.asked_n_per_m,
                spec.name,
                spec.max_stiffness_n_per_m,
                c.used_n_per_m,
                c.scene_stiffness
            );
        }
        checks.max_force_capped_n = cap_max_force(&mut sc, &spec);
        if let Some(peak) = checks.max_force_capped_n {
            errln!(
                "tetradrill: the {}'s peak force is {peak} N: the scene's force limit is capped \
                 there",
                spec.name
            );
        }
        let damping = check_damping(&mut sc, &spec, &workspace);
        if let Some(d) = damping.filter(|d| d.used_n_s_per_m < d.asked_n_s_per_m) {
            errln!(
                "tetradrill: warning: --damping {} is {:.2} N s/m at the {}, past its maximum \
                 stable damping {:.2} N s/m: using {:.2} N s/m (damping {})",
                d.asked_n_s_per_m / f64::from(workspace.scale),
                d.asked_n_s_per_m,
                spec.name,
                d.max_n_s_per_m,
                d.used_n_s_per_m,
                sc.forces.damping
            );
        }
        checks.damping = damping;
        errln!("tetradrill: no force until the tool has been outside the solid once (it is armed on leaving it)");
    }
    let ticks = run_ticks(args.duration, default_ticks);
    let rt = if args.no_rt {
        RtConfig {
            fifo_priority: None,
            core: None,
            lock_memory: false,
        }
    } else {
        RtConfig::default()
    };
    viewer_note(args.headless);
    let setup = PipelineSetup {
        kind: args.device,
        open,
        ticks,
        workspace,
        rt,
        status_line: !args.quiet,
        summary: true,
        view,
        stop,
        record: args.record.clone(),
        gate: ServoGate {
            arm_on_exit: real,
            sign_probe: true,
        },
        checks,
        audio_out: args.outputs.audio_out.clone(),
        sound: args.outputs.sound,
    };
    run_until_signal(&sc, loaded, setup, args.json.as_ref())
}

/// The ticks of a run: `--duration` (seconds), else the device's own length
/// ([`UNTIL_STOPPED`] for none).
pub fn run_ticks(duration: Option<f64>, default_ticks: u64) -> u64 {
    duration
        .map_or(default_ticks, |d| (d * 1000.0).round() as u64)
        .max(1)
}

/// [`pipeline::run`] with the stop signals (SIGINT, SIGTERM, SIGHUP) raising the setup's stop
/// request while it runs; after it, a signal ends the process at once.
pub fn run_until_signal(
    sc: &Setup,
    loaded: LoadedMesh,
    setup: PipelineSetup,
    json: Option<&PathBuf>,
) -> Result<(), CliError> {
    let flags = std::sync::Arc::clone(setup.stop.flags());
    crate::platform::on_stop_signals(move |sig| flags.raise(sig)).map_err(|e| {
        CliError::failure(format!("cannot install the stop signals' handlers: {e}"))
    })?;
    let request = setup.stop.clone();
    let r = pipeline::run(sc, loaded, setup, json).map(|_| ());
    // The device is released: a signal from now on ends the process at once.
    request.run_over();
    r
}

/// Says once that the viewer is not part of this build when a display exists.
pub fn viewer_note(headless: bool) {
    if cfg!(feature = "viewer") {
        return;
    }
    if crate::viewer::has_display() && !headless {
        errln!("tetradrill: note: this build has no viewer yet; running headless");
    }
}

/// The device factory, the default number of ticks (the simulated device's script or trace
/// length; [`UNTIL_STOPPED`] for a wander and the real devices), and the device-to-mesh map
/// for `kind`, over the set-up's mesh `loaded`.
pub fn device_factory(
    kind: DeviceKind,
    sc: &Setup,
    loaded: &LoadedMesh,
    options: OpenOptions,
) -> Result<(DeviceFactory, u64, Workspace), CliError> {
    device_factory_with(
        kind,
        sc,
        loaded,
        options,
        &DeviceConfig::default(),
        &StopRequest::new(),
    )
}

/// [`device_factory`] with the device file's constants; `stop` ends the Omni's wait for its
/// stylus in the dock.
pub fn device_factory_with(
    kind: DeviceKind,
    sc: &Setup,
    loaded: &LoadedMesh,
    options: OpenOptions,
    devices: &DeviceConfig,
    stop: &StopRequest,
) -> Result<(DeviceFactory, u64, Workspace), CliError> {
    match kind {
        DeviceKind::Sim => {
            let source = PoseSource::new(&sc.poses, Some(&loaded.mesh))?;
            let ticks = match source {
                PoseSource::Wander { .. } => UNTIL_STOPPED,
                _ => source.ticks(),
            };
            let sim = options.sim;
            let open: DeviceFactory = match source {
                wander @ PoseSource::Wander { .. } => Box::new(move || {
                    let path = Scripted(move |t: f64| wander.path_point(t));
                    Ok(Box::new(SimDevice::new(path, sim)) as Box<_>)
                }),
                PoseSource::Script(script) => Box::new(move || {
                    let path = Scripted(move |t: f64| {
                        let (p, buttons) = script.at((t * 1000.0).round().max(0.0) as u32);
                        PathPoint {
                            position: [p.x as f64, p.y as f64, p.z as f64],
                            rotation: QUAT_IDENTITY,
                            buttons,
                        }
                    });
                    Ok(Box::new(SimDevice::new(path, sim)) as Box<_>)
                }),
                PoseSource::Trace { trace, .. } => {
                    Box::new(move || Ok(Box::new(SimDevice::new(trace, sim)) as Box<_>))
                }
            };
            Ok((open, ticks, MESH_UNITS))
        }
        real => {
            let workspace = device_workspace(&spec_of(real), sc, loaded);
            let open: DeviceFactory = if real == DeviceKind::Touch {
                touch_factory(devices.touch)?
            } else if real == DeviceKind::Omni {
                omni_factory(devices.omni, stop.clone())?
            } else if real == DeviceKind::Falcon {
                falcon_factory(&options)?
            } else {
                Box::new(move || tetradrill_device::discovery::open(real, &options))
            };
            Ok((open, UNTIL_STOPPED, workspace))
        }
    }
}

/// The specification of a real device kind (the Touch's for anything else).
fn spec_of(kind: DeviceKind) -> DeviceSpec {
    match kind {
        DeviceKind::Falcon => DeviceSpec::FALCON,
        DeviceKind::Omni => DeviceSpec::OMNI,
        _ => DeviceSpec::TOUCH,
    }
}

/// The fraction of the mesh's half diagonal between the mesh's top and the tool (its burr's
/// surface) at the device's origin.
pub const SAFE_START_CLEARANCE: f32 = 0.2;

/// A real device's workspace over the mesh (a safe start): its radius onto the mesh's half
/// diagonal; its origin, where the docked stylus or the homed grip is, above the mesh (+z, the
/// top the default camera looks down on) over its centre, the tool clear of the top by
/// [`SAFE_START_CLEARANCE`] of the half diagonal.
pub fn device_workspace(spec: &DeviceSpec, sc: &Setup, loaded: &LoadedMesh) -> Workspace {
    let p = loaded.mesh.positions();
    let (mut lo, mut hi) = (p[0], p[0]);
    for q in p {
        lo = lo.min(*q);
        hi = hi.max(*q);
    }
    let half = 0.5 * (hi - lo).length();
    let centre = 0.5 * (lo + hi);
    let tool = sc.tool.burr_radius().unwrap_or(0.0) as f32;
    Workspace {
        scale: (half as f64 / spec.workspace_radius_m.max(1e-6)) as f32,
        offset: tetradrill_core::Vec3::new(
            centre.x,
            centre.y,
            hi.z + tool + SAFE_START_CLEARANCE * half,
        ),
    }
}

/// Caps the scene's stiffness at the device's maximum stable stiffness: the device feels the
/// scene's stiffness times the workspace's scale (N/m). Returns what was asked and used when
/// it capped.
pub fn cap_stiffness(
    sc: &mut Setup,
    spec: &DeviceSpec,
    workspace: &Workspace,
) -> Option<StiffnessCap> {
    let scale = f64::from(workspace.scale);
    let asked = sc.forces.stiffness * scale;
    let max = spec.max_stiffness_n_per_m;
    if !(asked.is_finite() && max.is_finite() && max > 0.0 && scale > 0.0) || asked <= max {
        return None;
    }
    sc.forces.stiffness = max / scale;
    Some(StiffnessCap {
        asked_n_per_m: asked,
        used_n_per_m: max,
        scene_stiffness: sc.forces.stiffness,
    })
}

/// Caps the scene's force limit at the device's peak force, so the force law's storage (and
/// the passivity trip's measure, the energy stored past that limit) is the device's. Returns the
/// peak used when it capped.
pub fn cap_max_force(sc: &mut Setup, spec: &DeviceSpec) -> Option<f64> {
    let peak = spec.max_force_n;
    if !(peak.is_finite() && peak > 0.0) || sc.forces.max_force <= peak {
        return None;
    }
    sc.forces.max_force = peak;
    Some(peak)
}

/// Checks the scene's damping against the device's range: the device feels the scene's damping
/// times the workspace's scale (N s/m); past its maximum stable damping it is capped there.
/// Returns the check (`None` for a damping or a scale that is not finite and positive, or a
/// device without a damping limit).
pub fn check_damping(
    sc: &mut Setup,
    spec: &DeviceSpec,
    workspace: &Workspace,
) -> Option<DampingCheck> {
    let scale = f64::from(workspace.scale);
    let asked = sc.forces.damping * scale;
    let max = spec.max_damping_n_s_per_m;
    if !(asked.is_finite() && max.is_finite() && max > 0.0 && scale > 0.0) {
        return None;
    }
    let used = asked.min(max);
    if used < asked {
        sc.forces.damping = max / scale;
    }
    Some(DampingCheck {
        asked_n_s_per_m: asked,
        used_n_s_per_m: used,
        max_n_s_per_m: max,
    })
}

/// The simulated device as `model`: its workspace over the mesh as the real device's
/// ([`device_workspace`]), the scenario's path taken into the device's metres (after the
/// model's start: [`SimModel::lead_in_s`]), the default length the path's plus that start. The
/// factory calibrates the device in its dock and runs the motor-sign self-test
/// ([`crate::motors`]); a reversed joint is written to `checks` and the device renders no force
/// ([`crate::motors::Blocked`]).
pub fn sim_model_factory(
    model: SimModel,
    sc: &Setup,
    loaded: &LoadedMesh,
    sim: SimConfig,
    devices: &DeviceConfig,
    checks: &RunChecks,
) -> Result<(DeviceFactory, u64, Workspace), CliError> {
    let source = PoseSource::new(&sc.poses, Some(&loaded.mesh))?;
    let workspace = device_workspace(&model.spec(), sc, loaded);
    let lead = (model.lead_in_s() * 1000.0).round() as u64;
    let ticks = match source {
        PoseSource::Wander { .. } => UNTIL_STOPPED,
        _ => source.ticks().saturating_add(lead),
    };
    let (offset, scale) = (workspace.offset, f64::from(workspace.scale));
    let omni_dac = devices.omni.dac_per_newton_metre;
    let kind = match model {
        SimModel::Omni => DeviceKind::Omni,
        SimModel::Falcon => DeviceKind::Falcon,
        SimModel::Touch => DeviceKind::Touch,
    };
    let found = std::sync::Arc::clone(&checks.reversed_joints);
    let open: DeviceFactory = Box::new(move || {
        let path = Scripted(move |t: f64| {
            let p = source.path_point(t);
            let o = offset.to_array().map(f64::from);
            PathPoint {
                position: std::array::from_fn(|i| (p.position[i] - o[i]) / scale),
                ..p
            }
        });
        let mut device: Box<dyn HapticDevice> = Box::new(SimDevice::new(path, sim));
        calibrate_in_dock(device.as_mut(), &StopRequest::new(), 1, || {})?;
        match crate::motors::self_test(device.as_mut(), false)? {
            Some(joints) => {
                for j in &joints {
                    errln!(
                        "tetradrill: motor-sign self-test: {}",
                        crate::motors::describe(j, kind, omni_dac)
                    );
                }
                let reversed = crate::motors::reversed(&joints);
                let blocked = !reversed.is_empty();
                let _ = found.set(reversed);
                if blocked {
                    errln!("tetradrill: a reversed joint: the run renders no force");
                    device = Box::new(crate::motors::Blocked(device));
                }
            }
            None => errln!(
                "tetradrill: motor-sign self-test: not run (the {} renders no force before it \
                 is homed)",
                model.name()
            ),
        }
        Ok(device)
    });
    Ok((open, ticks, workspace))
}

/// The Touch through the vendor HD library: loaded and `hdInitDevice` run here, so a missing
/// library or device is one line and exit status 2; the opened library moves into the servo
/// thread, where the device is built (and made current there).
fn touch_factory(safety: SafetyConfig) -> Result<DeviceFactory, CliError> {
    let bad = |e: HdLoadError| CliError::input(format!("--device touch: {e}"));
    let mut api = HdApi::load().map_err(bad)?;
    api.open_device(None).map_err(bad)?;
    Ok(Box::new(move || {
        let dev = tetradrill_device::touch::TouchDevice::new(api, None)?.with_safety(safety);
        Ok(Box::new(dev) as Box<dyn tetradrill_device::HapticDevice>)
    }))
}

/// The Falcon: opened and started here, on the main thread (normal mode, the firmware upload
/// when `--falcon-firmware` is given, a status round trip), so a missing device, a failed
/// upload or a firmware that does not answer is one line saying what to do, and exit status
/// 2; the started device moves into the servo thread.
fn falcon_factory(options: &OpenOptions) -> Result<DeviceFactory, CliError> {
    let mut dev = FalconDevice::open_usb(options.falcon)
        .map_err(|e| CliError::input(format!("--device falcon: {e}")))?;
    dev.start_with_file(options.falcon_firmware.as_deref())
        .map_err(|e| CliError::input(falcon_start_error(e, options.falcon_firmware.as_deref())))?;
    Ok(Box::new(move || Ok(Box::new(dev) as Box<dyn HapticDevice>)))
}

/// The one line for a Falcon that did not start: what failed and what to do.
pub fn falcon_start_error(e: DeviceError, firmware: Option<&std::path::Path>) -> String {
    let what_to_do = match (e, firmware) {
        (DeviceError::FirmwareNotRunning, None) => {
            "run with --falcon-firmware FILE (the Falcon's firmware, e.g. libnifalcon's \
             test_firmware.bin or Novint's; none is shipped)"
        }
        (DeviceError::FirmwareNotRunning, Some(_)) => {
            "the upload went through but the firmware does not run: check the file is a \
             Falcon firmware, then unplug the Falcon's power and USB and try again"
        }
        (DeviceError::FirmwareFile, _) => "check the path given to --falcon-firmware",
        (DeviceError::FirmwareHandshake { .. } | DeviceError::FirmwareMismatch { .. }, _) => {
            "unplug the Falcon's power and USB, plug them back and try again"
        }
        _ => "check the Falcon's power and USB cable",
    };
    let file = firmware.map_or(String::new(), |p| format!(" ({})", p.display()));
    format!("--device falcon: {e}{file}: {what_to_do}")
}

/// The device factory of `tetradrill run --device omni`: finds the Omni and opens its node
/// here, on the main thread, so a missing or unreadable node, or channels the bus's resource
/// manager does not grant, is one line and exit status 2. The start-up register sequence and
/// the inkwell calibration ([`calibrate_in_dock`]) run in the servo thread when the factory
/// is called.
fn omni_factory(config: OmniConfig, stop: StopRequest) -> Result<DeviceFactory, CliError> {
    let nodes = discover_omnis();
    let Some(node) = nodes.iter().find(|n| n.rom.is_ok()) else {
        return Err(CliError::input(match nodes.first() {
            Some(OmniNode { rom: Err(e), .. }) => format!("--device omni: {e}"),
            _ => format!("--device omni: {}", DeviceError::NotFound(DeviceKind::Omni)),
        }));
    };
    let transport = CdevFirewire::open(&node.path, CdevConfig::default())
        .map_err(|e| CliError::input(format!("--device omni: {e}")))?;
    Ok(Box::new(move || {
        let mut device = OmniDevice::start(transport, config)?;
        calibrate_in_dock(&mut device, &stop, DOCK_WAIT_TICKS, || {
            errln!(
                "tetradrill: put the Omni's stylus in its inkwell to calibrate (waiting up to \
                 {} s; Ctrl-C stops)",
                DOCK_WAIT_TICKS / 1000
            );
        })?;
        Ok(Box::new(device) as Box<dyn HapticDevice>)
    }))
}

/// How long `run` waits for the stylus in the dock, in 1 ms ticks.
pub const DOCK_WAIT_TICKS: u64 = 60_000;

/// Waits for the stylus in its inkwell, writing no force, and calibrates there (devices whose
/// [`DeviceSpec::calibration`] is [`CalibrationStyle::Inkwell`]; others return at once).
/// `ask` runs once when the stylus is not docked at the first reading. Returns whether the
/// device was calibrated: `false` when `stop` was raised first (the device stays force-free);
/// [`DeviceError::NotDocked`] after `limit_ticks` readings about 1 ms apart.
///
/// # Bounded work
/// At most `limit_ticks` readings, each followed by a motors-off command and a 1 ms sleep.
pub fn calibrate_in_dock(
    device: &mut dyn HapticDevice,
    stop: &StopRequest,
    limit_ticks: u64,
    ask: impl FnOnce(),
) -> Result<bool, DeviceError> {
    if device.spec().calibration != CalibrationStyle::Inkwell {
        return Ok(true);
    }
    let mut ask = Some(ask);
    for _ in 0..limit_ticks {
        if stop.is_requested() {
            return Ok(false);
        }
        let state = device.read()?;
        if state.docked {
            device.calibrate()?;
            return Ok(true);
        }
        if let Some(ask) = ask.take() {
            ask();
        }
        device.write(&ForceCommand::OFF)?;
        std::thread::sleep(std::time::Duration::from_millis(1));
    }
    Err(DeviceError::NotDocked)
}

/// The demo script's length in ticks.
pub fn demo_ticks() -> u64 {
    DEMO.ticks() as u64
}
