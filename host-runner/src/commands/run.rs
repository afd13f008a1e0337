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
use tetradrill_device::omni::{OmniConfig, OmniDevice};
use tetradrill_device::os::firewire::{discover_omnis, CdevConfig, CdevFirewire, OmniNode};
use tetradrill_device::os::hdapi::{HdApi, HdLoadError};
use tetradrill_device::{
    discovery::OpenOptions, DeviceError, DeviceKind, DeviceSpec, HapticDevice, PathPoint, Scripted,
    SimDevice, SimFault, QUAT_IDENTITY,
};

use super::pipeline::{self, DeviceFactory, PipelineSetup, MESH_UNITS, UNTIL_STOPPED};
use crate::error::CliError;
use crate::rt::RtConfig;
use crate::scenario::{Scenario, ScenarioFlags};
use crate::tasks::Workspace;
use crate::traces::PoseSource;

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
    /// Do not ask for SCHED_FIFO, core pinning or memory locking.
    #[arg(long)]
    pub no_rt: bool,
    /// No live status line.
    #[arg(long)]
    pub quiet: bool,
    /// Write a PNG of the view at the end of the run (no display needed).
    #[arg(long)]
    pub screenshot: Option<PathBuf>,
    /// A fault for the simulated device: `reversed-force` (the stylus receives -F) or
    /// `mirrored-x` (the reported x is mirrored); the passivity controller must trip.
    #[arg(long, value_name = "KIND", value_parser = parse_sim_fault)]
    pub sim_fault: Option<SimFault>,
}

fn parse_sim_fault(s: &str) -> Result<SimFault, String> {
    SimFault::parse(s)
        .ok_or_else(|| format!("`{s}` is not a fault ({})", SimFault::NAMES.join(", ")))
}

fn parse_device(s: &str) -> Result<DeviceKind, String> {
    DeviceKind::parse(s).ok_or_else(|| format!("`{s}` is not a device (sim, falcon, omni, touch)"))
}

/// Runs `run`.
pub fn run(args: &RunArgs) -> Result<(), CliError> {
    let sc = Scenario::from_flags(&args.scenario)?;
    let view = crate::viewer::ViewOptions::of(args.headless, args.screenshot.clone())?;
    let mut options = OpenOptions {
        falcon_firmware: args.falcon_firmware.clone(),
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
    let (open, default_ticks, workspace) = device_factory(args.device, &sc, options)?;
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
        stop: crate::watchdog::StopRequest::new(),
        record: args.record.clone(),
    };
    run_until_signal(&sc, setup, args.json.as_ref())
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
    sc: &Scenario,
    setup: PipelineSetup,
    json: Option<&PathBuf>,
) -> Result<(), CliError> {
    crate::platform::on_stop_signals(setup.stop.flags()).map_err(|e| {
        CliError::failure(format!("cannot install the stop signals' handlers: {e}"))
    })?;
    let request = setup.stop.clone();
    let r = pipeline::run(sc, setup, json).map(|_| ());
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
/// for `kind`.
pub fn device_factory(
    kind: DeviceKind,
    sc: &Scenario,
    options: OpenOptions,
) -> Result<(DeviceFactory, u64, Workspace), CliError> {
    match kind {
        DeviceKind::Sim => {
            let source = PoseSource::for_scenario(sc)?;
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
            let spec = match real {
                DeviceKind::Falcon => DeviceSpec::FALCON,
                DeviceKind::Omni => DeviceSpec::OMNI,
                _ => DeviceSpec::TOUCH,
            };
            // Map the device's workspace onto the mesh: its radius onto the mesh's half
            // diagonal, its origin onto the mesh's centre.
            let loaded = crate::meshio::load(std::path::Path::new(&sc.mesh), sc.scale)?;
            let p = loaded.mesh.positions();
            let (mut lo, mut hi) = (p[0], p[0]);
            for q in p {
                lo = lo.min(*q);
                hi = hi.max(*q);
            }
            let half = 0.5 * (hi - lo).length();
            let workspace = Workspace {
                scale: (half as f64 / spec.workspace_radius_m.max(1e-6)) as f32,
                offset: 0.5 * (lo + hi),
            };
            let open: DeviceFactory = if real == DeviceKind::Touch {
                touch_factory()?
            } else if real == DeviceKind::Omni {
                omni_factory()?
            } else {
                Box::new(move || tetradrill_device::discovery::open(real, &options))
            };
            Ok((open, UNTIL_STOPPED, workspace))
        }
    }
}

/// The Touch through the vendor HD library: loaded and `hdInitDevice` run here, so a missing
/// library or device is one line and exit status 2; the opened library moves into the servo
/// thread, where the device is built (and made current there).
fn touch_factory() -> Result<DeviceFactory, CliError> {
    let bad = |e: HdLoadError| CliError::input(format!("--device touch: {e}"));
    let mut api = HdApi::load().map_err(bad)?;
    api.open_device(None).map_err(bad)?;
    Ok(Box::new(move || {
        let dev = tetradrill_device::touch::TouchDevice::new(api, None)?;
        Ok(Box::new(dev) as Box<dyn tetradrill_device::HapticDevice>)
    }))
}

/// The device factory of `tetradrill run --device omni`: finds the Omni and opens its node
/// here, on the main thread, so a missing or unreadable node is one line and exit status 2;
/// the start-up register sequence runs in the servo thread when the factory is called.
fn omni_factory() -> Result<DeviceFactory, CliError> {
    let nodes = discover_omnis();
    let Some(node) = nodes.iter().find(|n| n.rom.is_ok()) else {
        return Err(CliError::input(match nodes.first() {
            Some(OmniNode { rom: Err(e), .. }) => format!("--device omni: {e}"),
            _ => format!("--device omni: {}", DeviceError::NotFound(DeviceKind::Omni)),
        }));
    };
    let config = OmniConfig::default();
    let transport = CdevFirewire::open(&node.path, CdevConfig::for_omni(&config))
        .map_err(|e| CliError::input(format!("--device omni: {e}")))?;
    if let Some(w) = transport.warning() {
        errln!("tetradrill: warning: {}: {w}", node.path.display());
    }
    Ok(Box::new(move || {
        let device = OmniDevice::start(transport, config)?;
        Ok(Box::new(device) as Box<dyn HapticDevice>)
    }))
}

/// The demo script's length in ticks.
pub fn demo_ticks() -> u64 {
    DEMO.ticks() as u64
}
