//! `tetradrill demo`: the main job with nothing attached: the built-in block, the simulated
//! device drilling the scripted path through the real-time pipeline, a live status line and a
//! summary. Headless it ends after the scripted path (or `--duration`); with a window it runs
//! until the window closes (the device holding the path's last pose), a stop signal or
//! `--duration`, as `run` does.

use std::path::PathBuf;

use tetradrill_device::{discovery::OpenOptions, DeviceKind};

use super::pipeline::{PipelineSetup, UNTIL_STOPPED};
use super::run::{device_factory, run_ticks, run_until_signal, viewer_note};
use crate::error::CliError;
use crate::rt::RtConfig;
use crate::setup::{Body, FixBelow, SoftSettings, Tool};

/// Arguments of `demo`.
#[derive(Debug, clap::Args)]
pub struct DemoArgs {
    /// No viewer.
    #[arg(long)]
    pub headless: bool,
    /// Seconds to run (default: the scripted path, 6 s, headless; until the window closes with
    /// a window).
    #[arg(long, allow_negative_numbers = true, value_parser = crate::scenario::positive_seconds)]
    pub duration: Option<f64>,
    /// Write the summary as JSON.
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Do not ask for SCHED_FIFO, core pinning or memory locking.
    #[arg(long)]
    pub no_rt: bool,
    /// What the run leaves besides its summary: a picture, a clip plane, the burr's sound.
    #[command(flatten)]
    pub outputs: super::pipeline::RunOutputs,
    /// The tool, as `run --tool` takes it (default: the demo's burr, `sphere:0.1`);
    /// `drill:BURR_R:SHAFT_LEN:SHAFT_R` puts the burr on a shaft along the tool's axis (+z
    /// on the scripted path, which plunges from above).
    #[arg(long, value_name = "SPEC")]
    pub tool: Option<String>,
    /// The block as a soft body (its shell E = 3 kPa over a core of 1 kPa, nu = 0.3, the
    /// demo's regions; its base below z = -0.45 fixed, 250 physics steps a second): it dents
    /// under the burr while it is drilled.
    #[arg(long)]
    pub soft: bool,
    /// With `--soft`: each physics step and the world's update spread over the ticks of its
    /// cycle (bounded work a tick, the dent shown a cycle later), as `run --soft-spread`.
    #[arg(long)]
    pub soft_spread: bool,
}

/// Runs `demo`.
pub fn run(args: &DemoArgs) -> Result<(), CliError> {
    let mut sc = crate::scenario::builtin("demo")
        .unwrap_or_default()
        .setup()?;
    if let Some(tool) = &args.tool {
        // A bad spec: one line naming it and the reason, exit 2.
        sc.tool = Tool::parse(tool, 1.0)?;
    }
    if args.soft_spread && !args.soft {
        return Err(CliError::input(
            "--soft-spread: spreads a soft body's steps; add --soft",
        ));
    }
    if args.soft {
        // The moduli are the demo's regions' (`setup::demo_regions`).
        sc.body = Body::Soft(SoftSettings {
            fix_below: Some(FixBelow {
                axis: 2,
                value: -0.45,
            }),
            spread: args.soft_spread,
            ..SoftSettings::default()
        });
    }
    let view = args.outputs.view(args.headless)?;
    let loaded = crate::engine::load_mesh(&sc)?;
    errln!(
        "tetradrill demo: {}{} drilled by a {} {} on the simulated device ({} s scripted path)",
        sc.mesh,
        match (args.soft, args.soft_spread) {
            (true, true) => " (soft, its steps spread over ticks)",
            (true, false) => " (soft)",
            _ => "",
        },
        sc.tool,
        if matches!(sc.tool, Tool::Drill { .. }) {
            "drill (burr on a shaft)"
        } else {
            "burr"
        },
        super::run::demo_ticks() as f64 / 1000.0
    );
    let (open, default_ticks, workspace) =
        device_factory(DeviceKind::Sim, &sc, &loaded, OpenOptions::default())?;
    // With a window the demo is a session: it runs until the window closes (or a signal, or
    // `--duration`); the device holds the path's last pose after it. Scripted runs under Xvfb
    // that ask the window to close by itself (`TETRADRILL_VIEWER_CLOSE=1`) keep the path's
    // length.
    let close_at_end = std::env::var_os(crate::viewer::CLOSE_AT_END).is_some_and(|v| v == "1");
    let ticks = if args.duration.is_none() && view.window && !close_at_end {
        UNTIL_STOPPED
    } else {
        run_ticks(args.duration, default_ticks)
    };
    viewer_note(args.headless);
    let rt = if args.no_rt {
        RtConfig {
            fifo_priority: None,
            core: None,
            lock_memory: false,
        }
    } else {
        RtConfig::default()
    };
    let setup = PipelineSetup {
        kind: DeviceKind::Sim,
        open,
        ticks,
        workspace,
        rt,
        status_line: true,
        summary: true,
        view,
        stop: crate::watchdog::StopRequest::new(),
        record: None,
        gate: crate::tasks::ServoGate {
            arm_on_exit: false,
            sign_probe: true,
        },
        checks: Default::default(),
        audio_out: args.outputs.audio_out.clone(),
        sound: args.outputs.sound,
    };
    run_until_signal(&sc, loaded, setup, args.json.as_ref())
}
