//! `tetradrill info --mesh FILE [--json OUT] [--scale S]`. (Being written: see issue 2.)

use std::path::PathBuf;

use crate::error::CliError;

/// Arguments of `info`.
#[derive(Debug, clap::Args)]
pub struct InfoArgs {
    /// The mesh file (TetGen .node/.ele, MEDIT .mesh, Gmsh .msh, VTK .vtk/.vtu).
    #[arg(long)]
    pub mesh: PathBuf,
}

/// Runs `info`.
pub fn run(args: &InfoArgs) -> Result<(), CliError> {
    Err(CliError::failure(format!("info is not written yet ({})", args.mesh.display())))
}
