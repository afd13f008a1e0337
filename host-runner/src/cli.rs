//! The command line (DESIGN section 4: a stable contract scripts depend on).

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
    /// Summarise a mesh file: counts, boundary, orientation fixes, validity, quality.
    Info(crate::commands::info::InfoArgs),
}

/// Parses the arguments, runs the command, prints errors as one line; returns the exit status.
pub fn main() -> i32 {
    let cli = match Cli::try_parse() {
        Ok(c) => c,
        Err(e) => {
            let code = if e.use_stderr() { crate::error::EXIT_BAD_INPUT } else { 0 };
            let _ = e.print();
            return code;
        }
    };
    match run(cli) {
        Ok(()) => 0,
        Err(e) => {
            eprintln!("tetradrill: {e}");
            e.code
        }
    }
}

/// Runs one parsed command.
pub fn run(cli: Cli) -> Result<(), CliError> {
    match cli.command {
        Command::Info(args) => crate::commands::info::run(&args),
    }
}
