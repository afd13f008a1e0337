//! `tetradrill demo`: the main job with nothing attached: the built-in block, the simulated
//! device drilling the scripted path through the real-time pipeline, a live status line and a
//! summary.

use std::path::PathBuf;

use tetradrill_device::{discovery::OpenOptions, DeviceKind};

use super::pipeline::{self, PipelineSetup};
use super::run::{device_factory, viewer_note};
use crate::error::CliError;
use crate::rt::RtConfig;
use crate::scenario::Scenario;
use crate::viewer::ViewOptions;

/// Arguments of `demo`.
#[derive(Debug, clap::Args)]
pub struct DemoArgs {
    /// No viewer.
    #[arg(long)]
    pub headless: bool,
    /// Seconds to run (default: the scripted path, 6 s).
    #[arg(long, allow_negative_numbers = true, value_parser = crate::cli::positive_seconds)]
    pub duration: Option<f64>,
    /// Write the summary as JSON.
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Do not ask for SCHED_FIFO, core pinning or memory locking.
    #[arg(long)]
    pub no_rt: bool,
    /// Write a PNG of the view at the end of the run (no display needed).
    #[arg(long)]
    pub screenshot: Option<PathBuf>,
}

/// Runs `demo`.
pub fn run(args: &DemoArgs) -> Result<(), CliError> {
    let sc = Scenario::default();
    let view = ViewOptions::of(args.headless, args.screenshot.clone())?;
    errln!(
        "tetradrill demo: {} drilled by a {} burr on the simulated device ({} s scripted path)",
        sc.mesh,
        sc.tool,
        super::run::demo_ticks() as f64 / 1000.0
    );
    let (open, default_ticks, workspace) =
        device_factory(DeviceKind::Sim, &sc, OpenOptions::default())?;
    let ticks = args
        .duration
        .map_or(default_ticks, |d| (d * 1000.0).round() as u64)
        .max(1);
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
    };
    pipeline::run(&sc, setup, args.json.as_ref()).map(|_| ())
}
