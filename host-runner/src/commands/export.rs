//! `tetradrill export --firmware OUT --mesh FILE [--scale S] [--region-array NAME]`: loads a
//! mesh the way every command does, builds it, and writes it as the blob a firmware includes
//! at build time and reads in place (`tetradrill_core::blob`: tets, neighbours, reverse
//! indices, positions, boundary flags and normals, region labels; versioned, checksummed).

use std::path::PathBuf;

use tetradrill_core::blob::{self, MeshBlob};

use crate::error::CliError;
use crate::meshio::{self, ReadOptions};

/// Arguments of `export`.
#[derive(Debug, Clone, clap::Args)]
pub struct ExportArgs {
    /// Write the firmware mesh blob to this file.
    #[arg(long, value_name = "OUT")]
    pub firmware: PathBuf,
    /// The mesh: a file (TetGen .node/.ele, MEDIT .mesh, Gmsh .msh, VTK .vtk/.vtu) or
    /// `builtin:cube12`, `builtin:block:N`.
    #[arg(long)]
    pub mesh: PathBuf,
    /// Multiply every coordinate by this factor.
    #[arg(long, default_value_t = 1.0, allow_negative_numbers = true)]
    pub scale: f64,
    /// The integer cell array of a VTK or VTU file that holds the region labels.
    #[arg(long, value_name = "NAME")]
    pub region_array: Option<String>,
    /// Print nothing on success.
    #[arg(long)]
    pub quiet: bool,
}

/// Runs `export`.
pub fn run(args: &ExportArgs) -> Result<(), CliError> {
    if !(args.scale.is_finite() && args.scale > 0.0) {
        return Err(CliError::input(format!(
            "--scale must be a positive number, got {}",
            args.scale
        )));
    }
    let options = ReadOptions {
        region_array: args.region_array.clone(),
        ..ReadOptions::default()
    };
    let mut loaded = meshio::load_with(&args.mesh, args.scale, &options)?;
    for w in &loaded.warnings {
        errln!("tetradrill: warning: {w}");
    }
    let labels = loaded.labels.clone();
    let mesh = loaded.mesh.view();
    let (nodes, tets) = (mesh.node_count(), mesh.tet_count());
    let len = blob::blob_len(nodes, tets).ok_or_else(|| {
        CliError::input(format!(
            "{}: {nodes} nodes and {tets} tets do not fit a mesh blob (4 GiB)",
            args.mesh.display()
        ))
    })?;
    let mut out = vec![0u8; len];
    blob::write(&mesh, &labels, &mut out)
        .map_err(|e| CliError::failure(format!("cannot lay out the blob: {e}")))?;
    // The reader checks what the writer made before it reaches a firmware.
    MeshBlob::parse(&out)
        .map_err(|e| CliError::failure(format!("the blob does not read back: {e}")))?;
    std::fs::write(&args.firmware, &out)
        .map_err(|e| CliError::at(&args.firmware, None, format!("cannot write: {e}")))?;
    if !args.quiet {
        outln!(
            "exported {} ({nodes} nodes, {tets} tets) to {}: {len} bytes, blob version {}",
            args.mesh.display(),
            args.firmware.display(),
            blob::VERSION
        );
    }
    Ok(())
}
