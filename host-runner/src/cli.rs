//! The command line (README.md, "Commands": a stable contract scripts depend on).

use clap::{Parser, Subcommand};

use crate::error::CliError;

/// tetradrill: a hard-real-time haptic core for touching and drilling tetrahedral meshes.
#[derive(Debug, Parser)]
#[command(name = "tetradrill", version, about, long_about = None)]
pub struct Cli {
    /// The command to run.
    #[command(subcommand)]
    pub command: Command,
}

/// Every command.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// The main job with nothing attached: a built-in block drilled by the simulated device.
    Demo(crate::commands::demo::DemoArgs),
    /// The real-time pipeline with a device (sim, falcon, omni, touch).
    Run(crate::commands::run::RunArgs),
    /// Summarise a mesh file: counts, boundary, orientation fixes, validity, quality.
    Info(crate::commands::info::InfoArgs),
    /// Deterministic offline run of a trace, tick by tick, with a summary JSON.
    Replay(crate::commands::replay::ReplayArgs),
    /// Measure the servo thread's wake-up latency (cyclictest style) and tick compute times.
    Timing(crate::commands::timing::TimingArgs),
    /// List the haptic devices found.
    Devices(crate::commands::devices::DevicesArgs),
    /// Write a built mesh as the blob a firmware includes and reads in place.
    Export(crate::commands::export::ExportArgs),
}

/// Parses the arguments, runs the command, prints errors as one line; returns the exit status.
pub fn main() -> i32 {
    let cli = match Cli::try_parse() {
        Ok(c) => c,
        Err(e) => {
            let code = if e.use_stderr() {
                crate::error::EXIT_BAD_INPUT
            } else {
                0
            };
            let _ = e.print();
            return code;
        }
    };
    match run(cli) {
        Ok(()) => 0,
        Err(e) => {
            errln!("tetradrill: {e}");
            e.code
        }
    }
}

/// Runs one parsed command.
pub fn run(cli: Cli) -> Result<(), CliError> {
    match cli.command {
        Command::Demo(args) => crate::commands::demo::run(&args),
        Command::Run(args) => crate::commands::run::run(&args),
        Command::Devices(args) => crate::commands::devices::run(&args),
        Command::Info(args) => crate::commands::info::run(&args),
        Command::Replay(args) => crate::commands::replay::run(&args),
        Command::Timing(args) => crate::commands::timing::run(&args),
        Command::Export(args) => crate::commands::export::run(&args),
    }
}
