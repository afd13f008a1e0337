//! Mesh file readers: one file per format, all ASCII, all written here (docs/FORMATS.md).
//!
//! | file          | format                                                        |
//! |---------------|---------------------------------------------------------------|
//! | [`tetgen`]    | TetGen `.node` + `.ele`, 0- or 1-based                        |
//! | [`medit`]     | MEDIT `.mesh` (`Vertices`, `Tetrahedra`)                      |
//! | [`gmsh`]      | Gmsh `.msh` 2.2 and 4.1 ASCII (4-node tets; others skipped)   |
//! | [`vtk`]       | VTK legacy `.vtk` 4.2 and 5.1 ASCII, `UNSTRUCTURED_GRID`      |
//! | [`vtu`]       | VTK XML `.vtu`, ASCII data arrays                             |
//!
//! [`read`] gives the file's nodes and tets as they are ([`RawMesh`]); [`load`] scales them,
//! drops unreferenced nodes and builds the core mesh ([`LoadedMesh`]). Both also take the
//! built-in names `builtin:cube12` and `builtin:block:N`. Every bad input is a [`CliError`]
//! with exit status 2 and one line `FILE:LINE: reason`; nothing here panics on input.

pub mod gmsh;
pub mod medit;
pub mod tetgen;
pub(crate) mod text;
pub mod vtk;
pub mod vtu;

use std::path::{Path, PathBuf};

use tetradrill_core::mesh::{BuildError, BuildOptions};
use tetradrill_core::Vec3;

use crate::error::CliError;
use crate::owned::OwnedMesh;

/// The largest `N` accepted in `builtin:block:N` (6 N^3 tets).
pub const MAX_BUILTIN_BLOCK: usize = 64;

/// A mesh as a file lists it: node positions and tets, 0-based node ids.
#[derive(Debug, Clone, PartialEq)]
pub struct RawMesh {
    /// Node positions, in file units.
    pub positions: Vec<[f64; 3]>,
    /// Tets as four 0-based node ids, in file order (elements that are not 4-node tets are
    /// left out).
    pub tets: Vec<[u32; 4]>,
    /// The source line of each tet (1-based), 0 if unknown.
    pub tet_lines: Vec<usize>,
    /// Format name, e.g. `"gmsh 4.1"`.
    pub format: &'static str,
    /// Things the user should know that do not stop the load (one line each).
    pub warnings: Vec<String>,
}

/// A mesh file loaded and built into the core's compact mesh.
#[derive(Debug, Clone)]
pub struct LoadedMesh {
    /// The built mesh (unreferenced nodes dropped, coordinates scaled, f32).
    pub mesh: OwnedMesh,
    /// The path or built-in name it came from.
    pub path: PathBuf,
    /// Format name, as in [`RawMesh::format`].
    pub format: &'static str,
    /// Nodes no tet uses, dropped before building.
    pub dropped_nodes: usize,
    /// Warnings from reading and loading (one line each, without the `tetradrill:` prefix).
    pub warnings: Vec<String>,
}

/// The extensions [`read`] understands.
pub const EXTENSIONS: &str = ".node/.ele, .mesh, .msh, .vtk, .vtu";

/// Reads a mesh file (format from the extension) or a built-in name, without building it.
///
/// # Errors
/// Exit status 2 and one line `FILE:LINE: reason` for unreadable, unknown or bad files.
pub fn read(path: &Path) -> Result<RawMesh, CliError> {
    read_with_source(path).map(|(raw, _)| raw)
}

/// Like [`read`], also giving the file that holds the tets (the `.ele` of a TetGen pair).
fn read_with_source(path: &Path) -> Result<(RawMesh, PathBuf), CliError> {
    if let Some(name) = path.to_str().and_then(|s| s.strip_prefix("builtin:")) {
        return Ok((builtin(name)?, path.to_path_buf()));
    }
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase());
    match ext.as_deref() {
        Some("node") | Some("ele") => tetgen::read(path),
        Some("mesh") => medit::read(path).map(|m| (m, path.to_path_buf())),
        Some("meshb") => Err(CliError::at(
            path,
            None,
            "binary MEDIT (.meshb) files are not supported (write ASCII .mesh)",
        )),
        Some("msh") => gmsh::read(path).map(|m| (m, path.to_path_buf())),
        Some("vtk") => vtk::read(path).map(|m| (m, path.to_path_buf())),
        Some("vtu") => vtu::read(path).map(|m| (m, path.to_path_buf())),
        Some(other) => Err(CliError::at(
            path,
            None,
            format!("unknown mesh file extension '.{other}' (expected {EXTENSIONS}, or builtin:cube12, builtin:block:N)"),
        )),
        None => Err(CliError::at(
            path,
            None,
            format!("mesh file has no extension (expected {EXTENSIONS}, or builtin:cube12, builtin:block:N)"),
        )),
    }
}

/// The built-in meshes: `cube12` and `block:N` (the unit cube `[-0.5, 0.5]^3` in `N^3` cubes).
fn builtin(name: &str) -> Result<RawMesh, CliError> {
    let bad = || {
        CliError::input(format!(
            "unknown built-in mesh 'builtin:{name}' (expected builtin:cube12 or builtin:block:N, \
             N in 1..={MAX_BUILTIN_BLOCK})"
        ))
    };
    let (positions, tets): (Vec<Vec3>, Vec<[u32; 4]>) = if name == "cube12" {
        let (p, t) = tetradrill_core::builtin::cube12();
        (p.to_vec(), t.to_vec())
    } else if let Some(n) = name.strip_prefix("block:") {
        let n: usize = n.parse().map_err(|_| bad())?;
        if n == 0 || n > MAX_BUILTIN_BLOCK {
            return Err(bad());
        }
        let (nn, nt) = tetradrill_core::builtin::block_counts(n);
        let mut p = vec![Vec3::ZERO; nn];
        let mut t = vec![[0u32; 4]; nt];
        let edge = 1.0 / n as f32;
        tetradrill_core::builtin::block(n, edge, Vec3::splat(-0.5), &mut p, &mut t)
            .ok_or_else(bad)?;
        (p, t)
    } else {
        return Err(bad());
    };
    Ok(RawMesh {
        positions: positions
            .iter()
            .map(|p| [p.x as f64, p.y as f64, p.z as f64])
            .collect(),
        tet_lines: vec![0; tets.len()],
        tets,
        format: "builtin",
        warnings: Vec::new(),
    })
}

/// Reads a mesh file or built-in name, scales it, drops unreferenced nodes (one warning) and
/// builds the core mesh with [`BuildOptions::default`] (negative tets flipped and counted).
///
/// # Errors
/// Exit status 2: everything [`read`] refuses, a scale that is not positive and finite,
/// coordinates too large for f32 after scaling, and what the build refuses (zero-volume tets,
/// a face shared by more than two tets, overlapping tets), as `FILE:LINE: reason` with the
/// line of the offending tet.
pub fn load(path: &Path, scale: f64) -> Result<LoadedMesh, CliError> {
    if !(scale.is_finite() && scale > 0.0) {
        return Err(CliError::input(format!(
            "--scale must be a positive finite number, not {scale}"
        )));
    }
    let (raw, tet_path) = read_with_source(path)?;
    let RawMesh {
        positions,
        tets,
        tet_lines,
        format,
        mut warnings,
    } = raw;
    if tets.is_empty() {
        return Err(CliError::at(&tet_path, None, "no tetrahedra in the file"));
    }
    let line_of = |t: usize| tet_lines.get(t).copied().filter(|&l| l > 0);

    // Renumber the referenced nodes in file order.
    let mut new_id = vec![u32::MAX; positions.len()];
    for (t, tet) in tets.iter().enumerate() {
        for &v in tet {
            match new_id.get_mut(v as usize) {
                Some(slot) => *slot = 0,
                None => {
                    return Err(CliError::at(
                        &tet_path,
                        line_of(t),
                        format!("node index {v} out of range ({} nodes)", positions.len()),
                    ))
                }
            }
        }
    }
    let mut kept = Vec::new();
    for (i, slot) in new_id.iter_mut().enumerate() {
        if *slot == 0 {
            *slot = kept.len() as u32;
            let [x, y, z] = positions[i].map(|c| c * scale);
            let q = Vec3::new(x as f32, y as f32, z as f32);
            if !q.is_finite() {
                return Err(CliError::at(
                    path,
                    None,
                    format!("node {i}: coordinates too large for 32-bit floats after scaling by {scale:e}"),
                ));
            }
            kept.push(q);
        }
    }
    let dropped = positions.len() - kept.len();
    if dropped > 0 {
        let first = new_id.iter().position(|&s| s == u32::MAX).unwrap_or(0);
        warnings.push(format!(
            "{}: {dropped} unreferenced node(s) dropped (no tet uses them; the first is node {first}, counting from 0)",
            path.display()
        ));
    }
    let tets: Vec<[u32; 4]> = tets.iter().map(|t| t.map(|v| new_id[v as usize])).collect();

    let mesh = OwnedMesh::build(kept, &tets, BuildOptions::default()).map_err(|e| {
        let (tet, reason) = match e {
            BuildError::ZeroVolume { tet } => (
                Some(tet),
                "tet has zero volume (its four nodes are coplanar or nearly so)".into(),
            ),
            BuildError::NonManifoldFace { tet } => (
                Some(tet),
                "a face of this tet is shared by more than two tets".into(),
            ),
            BuildError::InconsistentFace { tet } => (
                Some(tet),
                "tet overlaps a neighbour (they share a face from the same side)".into(),
            ),
            BuildError::RepeatedNode { tet } => (Some(tet), "tet names the same node twice".into()),
            BuildError::NodeOutOfRange { tet, node } => (
                Some(tet),
                format!("tet names node {node}, which does not exist"),
            ),
            BuildError::NonFinite { node } => (
                None,
                format!("node {node} has a NaN or infinite coordinate"),
            ),
            BuildError::TooLarge => (None, "more nodes or tets than 32-bit ids can name".into()),
            BuildError::StorageTooSmall { .. } => {
                return CliError::failure(format!("internal error building the mesh: {e}"))
            }
        };
        match tet {
            Some(t) => CliError::at(&tet_path, line_of(t as usize), reason),
            None => CliError::at(path, None, reason),
        }
    })?;
    Ok(LoadedMesh {
        mesh,
        path: path.to_path_buf(),
        format,
        dropped_nodes: dropped,
        warnings,
    })
}
