//! `tetradrill info --mesh FILE [--json OUT] [--scale S]`: loads a mesh file (or a built-in
//! mesh) the way every command does and summarises it: counts, boundary, orientation fixes,
//! validity, dihedral angles, volume, bounding box.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde_json::json;
use tetradrill_core::mesh::TET_BYTES;
use tetradrill_core::Vec3;

use crate::error::CliError;
use crate::meshio::{self, LoadedMesh, ReadOptions};

/// Arguments of `info`.
#[derive(Debug, Clone, clap::Args)]
pub struct InfoArgs {
    /// The mesh: a file (TetGen .node/.ele, MEDIT .mesh, Gmsh .msh, VTK .vtk/.vtu) or
    /// `builtin:cube12`, `builtin:block:N`.
    #[arg(long)]
    pub mesh: PathBuf,
    /// Also write the summary as JSON to this file (`-` or no value: JSON on stdout instead of
    /// the human summary).
    #[arg(long, value_name = "OUT", num_args = 0..=1, default_missing_value = "-")]
    pub json: Option<PathBuf>,
    /// Multiply every coordinate by this factor (file units to metres).
    #[arg(long, default_value_t = 1.0, allow_negative_numbers = true)]
    pub scale: f64,
    /// The integer cell array of a VTK or VTU file that holds the region labels (default:
    /// the first of material, region, gmsh:physical, medit:ref, CellEntityIds).
    #[arg(long, value_name = "NAME")]
    pub region_array: Option<String>,
}

/// Everything `info` reports about one mesh.
#[derive(Debug, Clone, PartialEq)]
pub struct MeshSummary {
    /// The file or built-in name.
    pub file: String,
    /// Format name.
    pub format: &'static str,
    /// Nodes kept (unreferenced ones dropped).
    pub nodes: usize,
    /// Tets.
    pub tets: usize,
    /// Faces with no neighbour.
    pub boundary_faces: u32,
    /// Nodes on the boundary.
    pub boundary_nodes: u32,
    /// Bytes per tet record in the core.
    pub bytes_per_tet: usize,
    /// Tets flipped to positive orientation at load.
    pub orientation_fixes: u32,
    /// Tets relabelled for refinement at load.
    pub relabelled: u32,
    /// Nodes no tet uses, dropped at load.
    pub unreferenced_nodes: usize,
    /// `validate()` held.
    pub valid: bool,
    /// The first broken invariant when not valid.
    pub validation_error: Option<String>,
    /// Smallest dihedral angle over all tets, degrees (f64).
    pub min_dihedral_deg: f64,
    /// Largest dihedral angle over all tets, degrees (f64).
    pub max_dihedral_deg: f64,
    /// Total volume (f64 sum of f64 tet volumes).
    pub volume: f64,
    /// Smallest corner of the bounding box.
    pub bbox_min: [f64; 3],
    /// Largest corner of the bounding box.
    pub bbox_max: [f64; 3],
    /// The scale applied.
    pub scale: f64,
    /// Tets per region label (one entry, label 0, when the file has no labels).
    pub regions: BTreeMap<i32, usize>,
    /// Where the labels came from (`None`: the file has none).
    pub region_source: Option<String>,
    /// Load warnings.
    pub warnings: Vec<String>,
}

impl MeshSummary {
    /// The JSON object `info --json` writes.
    pub fn to_json(&self) -> serde_json::Value {
        json!({
            "file": self.file,
            "format": self.format,
            "nodes": self.nodes,
            "tets": self.tets,
            "boundary_faces": self.boundary_faces,
            "boundary_nodes": self.boundary_nodes,
            "bytes_per_tet": self.bytes_per_tet,
            "orientation_fixes": self.orientation_fixes,
            "relabelled": self.relabelled,
            "unreferenced_nodes": self.unreferenced_nodes,
            "valid": self.valid,
            "validation_error": self.validation_error,
            "min_dihedral_deg": self.min_dihedral_deg,
            "max_dihedral_deg": self.max_dihedral_deg,
            "volume": self.volume,
            "bounding_box": { "min": self.bbox_min, "max": self.bbox_max },
            "scale": self.scale,
            "regions": self
                .regions
                .iter()
                .map(|(label, n)| (label.to_string(), json!(n)))
                .collect::<serde_json::Map<_, _>>(),
            "region_source": self.region_source,
            "warnings": self.warnings,
        })
    }

    /// The human summary `info` prints.
    pub fn to_text(&self) -> String {
        let [a, b, c] = self.bbox_min;
        let [d, e, f] = self.bbox_max;
        let validity = match &self.validation_error {
            None => "valid".to_string(),
            Some(err) => format!("INVALID: {err}"),
        };
        format!(
            "mesh               {} ({})\n\
             nodes              {}\n\
             tets               {}\n\
             boundary faces     {}\n\
             boundary nodes     {}\n\
             bytes per tet      {}\n\
             orientation fixes  {}\n\
             relabelled         {}\n\
             unreferenced nodes {} (dropped)\n\
             validation         {validity}\n\
             dihedral angles    {:.3} .. {:.3} deg\n\
             volume             {:.6e}\n\
             bounding box       [{a:.6}, {b:.6}, {c:.6}] .. [{d:.6}, {e:.6}, {f:.6}]\n\
             scale              {}\n\
             regions            {}\n",
            self.file,
            self.format,
            self.nodes,
            self.tets,
            self.boundary_faces,
            self.boundary_nodes,
            self.bytes_per_tet,
            self.orientation_fixes,
            self.relabelled,
            self.unreferenced_nodes,
            self.min_dihedral_deg,
            self.max_dihedral_deg,
            self.volume,
            self.scale,
            self.regions_text(),
        )
    }

    /// `1: 612 tets, 2: 612 tets (MEDIT references)`, or `none (all N tets in region 0)`.
    fn regions_text(&self) -> String {
        let Some(source) = &self.region_source else {
            return format!("none (all {} tets in region 0)", self.tets);
        };
        let list: Vec<String> = self
            .regions
            .iter()
            .map(|(label, n)| format!("{label}: {n} tets"))
            .collect();
        format!("{} ({source})", list.join(", "))
    }
}

/// The six dihedral angles of a tet, radians, computed in f64.
pub fn dihedral_angles(p: [[f64; 3]; 4]) -> [f64; 6] {
    dihedral_cosines(p).map(angle_of_cosine)
}

/// The dihedral angle whose [`dihedral_cosines`] entry is `c` (the angle grows with `c`).
fn angle_of_cosine(c: f64) -> f64 {
    std::f64::consts::PI - c.acos()
}

/// For each of the six edges, the cosine of the angle between the two face normals that
/// meet there (each normal pointing away from the opposite vertex); 1 for a degenerate face,
/// which [`angle_of_cosine`] turns into an angle of 0.
fn dihedral_cosines(p: [[f64; 3]; 4]) -> [f64; 6] {
    let sub = |a: [f64; 3], b: [f64; 3]| [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    let cross = |a: [f64; 3], b: [f64; 3]| {
        [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ]
    };
    let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    // Outward-or-inward (consistently) normal of the face opposite vertex k.
    let normal = |k: usize| {
        let [i, j, l] = [(k + 1) % 4, (k + 2) % 4, (k + 3) % 4];
        let n = cross(sub(p[j], p[i]), sub(p[l], p[i]));
        // Orient away from vertex k.
        if dot(n, sub(p[k], p[i])) > 0.0 {
            [-n[0], -n[1], -n[2]]
        } else {
            n
        }
    };
    let n = [normal(0), normal(1), normal(2), normal(3)];
    // Edge (a, b) lies between the faces opposite the two other vertices (c, d).
    const EDGES: [[usize; 4]; 6] = [
        [0, 1, 2, 3],
        [0, 2, 1, 3],
        [0, 3, 1, 2],
        [1, 2, 0, 3],
        [1, 3, 0, 2],
        [2, 3, 0, 1],
    ];
    EDGES.map(|[_, _, c, d]| {
        let (u, v) = (n[c], n[d]);
        let denom = (dot(u, u) * dot(v, v)).sqrt();
        if denom > 0.0 {
            (dot(u, v) / denom).clamp(-1.0, 1.0)
        } else {
            1.0
        }
    })
}

/// Computes the summary of a loaded mesh.
pub fn summarise(loaded: &mut LoadedMesh, scale: f64) -> MeshSummary {
    let stats = loaded.mesh.stats();
    let pos: Vec<[f64; 3]> = loaded
        .mesh
        .positions()
        .iter()
        .map(|p: &Vec3| [p.x as f64, p.y as f64, p.z as f64])
        .collect();
    let corners: Vec<[u32; 4]> = loaded
        .mesh
        .tets()
        .iter()
        .map(|t| t.nodes.map(|n| n.0))
        .collect();
    // `validate` and the f64 measures share nothing: one on each core.
    let (validation_error, (min_cos, max_cos, volume)) = std::thread::scope(|s| {
        let measures = s.spawn(|| measure(&pos, &corners));
        let error = loaded.mesh.view().validate().err().map(|e| e.to_string());
        let measures = measures.join().unwrap_or((f64::NAN, f64::NAN, f64::NAN));
        (error, measures)
    });
    let mut bbox_min = [f64::INFINITY; 3];
    let mut bbox_max = [f64::NEG_INFINITY; 3];
    for p in &pos {
        for k in 0..3 {
            bbox_min[k] = bbox_min[k].min(p[k]);
            bbox_max[k] = bbox_max[k].max(p[k]);
        }
    }
    MeshSummary {
        file: loaded.path.display().to_string(),
        format: loaded.format,
        nodes: pos.len(),
        tets: loaded.mesh.tets().len(),
        boundary_faces: stats.boundary_faces,
        boundary_nodes: stats.boundary_nodes,
        bytes_per_tet: TET_BYTES,
        orientation_fixes: stats.orientation_fixes,
        relabelled: stats.relabelled,
        unreferenced_nodes: loaded.dropped_nodes,
        valid: validation_error.is_none(),
        validation_error,
        min_dihedral_deg: angle_of_cosine(min_cos).to_degrees(),
        max_dihedral_deg: angle_of_cosine(max_cos).to_degrees(),
        volume,
        bbox_min,
        bbox_max,
        scale,
        regions: region_counts(&loaded.labels),
        region_source: loaded.label_source.clone(),
        warnings: loaded.warnings.clone(),
    }
}

/// The extremes of the dihedral cosines (one arc cosine each at the end: the angle is monotone
/// in them) and the total volume, all in f64.
fn measure(pos: &[[f64; 3]], corners: &[[u32; 4]]) -> (f64, f64, f64) {
    let mut max_cos = f64::NEG_INFINITY;
    let mut min_cos = f64::INFINITY;
    let mut volume = 0.0f64;
    for tet in corners {
        let q = tet.map(|n| pos[n as usize]);
        for c in dihedral_cosines(q) {
            max_cos = max_cos.max(c);
            min_cos = min_cos.min(c);
        }
        let u = [q[1][0] - q[0][0], q[1][1] - q[0][1], q[1][2] - q[0][2]];
        let v = [q[2][0] - q[0][0], q[2][1] - q[0][1], q[2][2] - q[0][2]];
        let w = [q[3][0] - q[0][0], q[3][1] - q[0][1], q[3][2] - q[0][2]];
        let det = u[0] * (v[1] * w[2] - v[2] * w[1]) - u[1] * (v[0] * w[2] - v[2] * w[0])
            + u[2] * (v[0] * w[1] - v[1] * w[0]);
        volume += det / 6.0;
    }
    (min_cos, max_cos, volume)
}

/// Tets per label.
pub fn region_counts(labels: &[i32]) -> BTreeMap<i32, usize> {
    let mut counts = BTreeMap::new();
    for &l in labels {
        *counts.entry(l).or_insert(0) += 1;
    }
    counts
}

/// Loads the mesh and computes the summary, printing load warnings to stderr.
///
/// # Errors
/// What [`meshio::load`] refuses (exit status 2).
pub fn summary(mesh: &Path, scale: f64) -> Result<MeshSummary, CliError> {
    summary_with(mesh, scale, &ReadOptions::default())
}

/// [`summary`] with [`ReadOptions`] (the region array).
///
/// # Errors
/// What [`meshio::load_with`] refuses (exit status 2).
pub fn summary_with(
    mesh: &Path,
    scale: f64,
    options: &ReadOptions,
) -> Result<MeshSummary, CliError> {
    let mut loaded = meshio::load_with(mesh, scale, options)?;
    for w in &loaded.warnings {
        errln!("tetradrill: warning: {w}");
    }
    Ok(summarise(&mut loaded, scale))
}

/// Runs `info`.
///
/// # Errors
/// Exit status 2 for a bad mesh, 1 when the JSON cannot be written.
pub fn run(args: &InfoArgs) -> Result<(), CliError> {
    let options = ReadOptions {
        region_array: args.region_array.clone(),
        ..ReadOptions::default()
    };
    let s = summary_with(&args.mesh, args.scale, &options)?;
    let to_stdout = args.json.as_deref() == Some(Path::new("-"));
    if !to_stdout {
        out!("{}", s.to_text());
    }
    match &args.json {
        Some(_) if to_stdout => {
            let text = serde_json::to_string_pretty(&s.to_json())
                .map_err(|e| CliError::failure(format!("cannot encode JSON: {e}")))?;
            // The JSON is the command's product: a failed write is an error (exit 1).
            use std::io::Write as _;
            writeln!(std::io::stdout(), "{text}")
                .map_err(|e| CliError::failure(format!("stdout: cannot write the JSON: {e}")))?;
        }
        Some(out) => crate::report::write_json(out, &s.to_json())?,
        None => {}
    }
    Ok(())
}
