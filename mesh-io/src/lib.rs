//! tetradrill mesh files: one reader per format (docs/FORMATS.md), and the host's storage for
//! a built core mesh ([`owned::OwnedMesh`]). Usable by any tool that wants the core's compact
//! mesh from a file; the command line (`tetradrill`) is one such tool.
//!
//! | file          | format                                                                  |
//! |---------------|-------------------------------------------------------------------------|
//! | [`tetgen`]    | TetGen `.node` + `.ele`, 0- or 1-based, region attribute                |
//! | [`medit`]     | MEDIT `.mesh` (`Vertices`, `Tetrahedra` with references)                |
//! | [`meshb`]     | MEDIT binary `.meshb`, versions 1 to 4, either byte order               |
//! | [`gmsh`]      | Gmsh `.msh` 2.2 and 4.1, ASCII and binary (4-node tets; others skipped) |
//! | [`vtk`]       | VTK legacy `.vtk` 4.2 and 5.1, ASCII and BINARY, `UNSTRUCTURED_GRID`    |
//! | [`vtu`]       | VTK XML `.vtu`: ASCII, base64 and appended arrays, zlib/LZ4/LZMA        |
//! | [`source`]    | a file's bytes, gunzipped when its name ends in `.gz`                   |
//!
//! [`read`] gives the file's nodes, tets and region labels as they are ([`RawMesh`]); [`load`]
//! scales them, drops unreferenced nodes and builds the core mesh ([`LoadedMesh`]). Both also
//! take the built-in names `builtin:cube12` and `builtin:block:N`. Every bad input is a
//! [`MeshError`] of kind [`MeshErrorKind::Input`] with one line `FILE:LINE: reason` (`FILE:
//! byte N: reason` in binary data); nothing here panics on input, and declared counts are
//! checked against the bytes left before anything is allocated.

#![forbid(unsafe_code)]

pub(crate) mod binary;
mod error;
pub mod gmsh;
pub(crate) mod gmsh_binary;
pub mod medit;
pub mod meshb;
pub mod order;
pub mod owned;
pub mod source;
pub mod tetgen;
pub(crate) mod text;
pub mod vtk;
pub mod vtu;

use std::path::{Path, PathBuf};

use tetradrill_core::mesh::{BuildError, BuildOptions};
use tetradrill_core::Vec3;

pub use crate::error::{Location, MeshError, MeshErrorKind};
use crate::owned::OwnedMesh;

/// The largest `N` accepted in `builtin:block:N` (6 N^3 tets).
pub const MAX_BUILTIN_BLOCK: usize = 128;

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
    /// The region label of each tet (MEDIT reference, Gmsh physical tag, VTK cell data, TetGen
    /// region attribute), 0 for every tet of a file that has none.
    pub labels: Vec<i32>,
    /// Where the labels came from (e.g. `"cell data 'material'"`), `None` when the file has
    /// none.
    pub label_source: Option<String>,
    /// Format name, e.g. `"gmsh 4.1"`.
    pub format: &'static str,
    /// Things the user should know that do not stop the load (one line each).
    pub warnings: Vec<String>,
}

/// How to read a file, beyond what its name and contents say.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct ReadOptions {
    /// The integer cell array that holds the region labels of a VTK or VTU file; `None` takes
    /// the first of [`REGION_ARRAYS`] the file has.
    pub region_array: Option<String>,
    /// [`load_with`] keeps the file's node and tet order (default: renumbered along a
    /// space-filling curve, which makes every pass over a large mesh cache-friendly; the file's
    /// numbering is in [`LoadedMesh::file_nodes`] and [`LoadedMesh::file_tets`] either way).
    /// Built-in meshes are always in their generator's order.
    pub file_order: bool,
}

/// The cell arrays taken as region labels when [`ReadOptions::region_array`] is `None`, in
/// order of preference.
pub const REGION_ARRAYS: [&str; 5] = [
    "material",
    "region",
    "gmsh:physical",
    "medit:ref",
    "CellEntityIds",
];

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
    /// The file's index (counting from 0) of each node of the built mesh. Files are loaded in
    /// spatial order (`order.rs`) unless [`ReadOptions::file_order`] is set.
    pub file_nodes: Vec<u32>,
    /// The file's index (counting from 0) of each tet of the built mesh.
    pub file_tets: Vec<u32>,
    /// The region label of each tet of the built mesh (same order as its tets), 0 when the
    /// file has none (see [`RawMesh::labels`]).
    pub labels: Vec<i32>,
    /// Where the labels came from, `None` when the file has none.
    pub label_source: Option<String>,
    /// Warnings from reading and loading (one line each, without the `tetradrill:` prefix).
    pub warnings: Vec<String>,
}

/// The extensions [`read`] understands.
pub const EXTENSIONS: &str = ".node/.ele, .mesh, .meshb, .msh, .vtk, .vtu, each also .gz";

/// Reads a mesh file (format from the extension) or a built-in name, without building it.
///
/// # Errors
/// Bad input ([`MeshErrorKind::Input`]): one line `FILE:LINE: reason` for unreadable, unknown or bad files.
pub fn read(path: &Path) -> Result<RawMesh, MeshError> {
    read_with(path, &ReadOptions::default())
}

/// [`read`] with [`ReadOptions`].
///
/// # Errors
/// As [`read`]; also a [`ReadOptions::region_array`] the file does not have, or that is not
/// an integer cell array.
pub fn read_with(path: &Path, options: &ReadOptions) -> Result<RawMesh, MeshError> {
    read_with_source(path, options).map(|(raw, _)| raw)
}

/// Like [`read`], also giving the file that holds the tets (the `.ele` of a TetGen pair).
fn read_with_source(path: &Path, options: &ReadOptions) -> Result<(RawMesh, PathBuf), MeshError> {
    if let Some(name) = path.to_str().and_then(|s| s.strip_prefix("builtin:")) {
        no_region_array(path, options, "built-in")?;
        return Ok((builtin(name)?, path.to_path_buf()));
    }
    let (plain, _) = source::strip_gz(path);
    let ext = plain
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase());
    let (raw, tet_path) = match ext.as_deref() {
        Some("node") | Some("ele") => tetgen::read(path),
        Some("mesh") => medit::read(path).map(|m| (m, path.to_path_buf())),
        Some("meshb") => meshb::read(path).map(|m| (m, path.to_path_buf())),
        Some("msh") => gmsh::read(path).map(|m| (m, path.to_path_buf())),
        Some("vtk") => vtk::read_with(path, options).map(|m| (m, path.to_path_buf())),
        Some("vtu") => vtu::read_with(path, options).map(|m| (m, path.to_path_buf())),
        Some(other) => Err(MeshError::at(
            path,
            None,
            format!("unknown mesh file extension '.{other}' (expected {EXTENSIONS}, or builtin:cube12, builtin:block:N)"),
        )),
        None => Err(MeshError::at(
            path,
            None,
            format!("mesh file has no extension (expected {EXTENSIONS}, or builtin:cube12, builtin:block:N)"),
        )),
    }?;
    if !matches!(ext.as_deref(), Some("vtk") | Some("vtu")) {
        no_region_array(path, options, raw.format)?;
    }
    Ok((raw, tet_path))
}

/// Refuses a [`ReadOptions::region_array`] for a file without named cell arrays.
fn no_region_array(path: &Path, options: &ReadOptions, what: &str) -> Result<(), MeshError> {
    match &options.region_array {
        Some(name) => Err(MeshError::at(
            path,
            None,
            format!(
                "--region-array '{}': only VTK and VTU files have named cell arrays, not this \
                 {what} mesh (its labels are read without the flag)",
                text::short(name)
            ),
        )),
        None => Ok(()),
    }
}

/// The built-in meshes: `cube12` and `block:N` (the unit cube `[-0.5, 0.5]^3` in `N^3` cubes).
fn builtin(name: &str) -> Result<RawMesh, MeshError> {
    let bad = || {
        MeshError::input(format!(
            "unknown built-in mesh 'builtin:{name}' (expected builtin:cube12 or builtin:block:N, \
             N in 1..={MAX_BUILTIN_BLOCK})"
        ))
    };
    let (positions, tets, labels): (Vec<Vec3>, Vec<[u32; 4]>, Vec<i32>) = if name == "cube12" {
        let (p, t) = tetradrill_core::builtin::cube12();
        (p.to_vec(), t.to_vec(), vec![0; t.len()])
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
        // Two regions made here: the outer shell of cubes and the core inside it.
        let mut l = vec![0; nt];
        tetradrill_core::builtin::block_labels(n, &mut l).ok_or_else(bad)?;
        (p, t, l)
    } else {
        return Err(bad());
    };
    Ok(RawMesh {
        positions: positions
            .iter()
            .map(|p| [p.x as f64, p.y as f64, p.z as f64])
            .collect(),
        tet_lines: vec![0; tets.len()],
        label_source: (labels.iter().any(|&l| l != 0))
            .then(|| "the built-in block's shell (1) and core (2)".to_string()),
        labels,
        tets,
        format: "builtin",
        warnings: Vec::new(),
    })
}

/// Reads a mesh file or built-in name, scales it, drops unreferenced nodes (one warning) and
/// builds the core mesh with [`BuildOptions::default`] (negative tets flipped and counted).
///
/// # Errors
/// Bad input ([`MeshErrorKind::Input`]): everything [`read`] refuses, a scale that is not positive and finite,
/// coordinates too large for f32 after scaling, and what the build refuses (zero-volume tets,
/// a face shared by more than two tets, overlapping tets), as `FILE:LINE: reason` with the
/// line of the offending tet.
pub fn load(path: &Path, scale: f64) -> Result<LoadedMesh, MeshError> {
    load_with(path, scale, &ReadOptions::default())
}

/// [`load`] with [`ReadOptions`].
///
/// # Errors
/// As [`load`] and [`read_with`].
pub fn load_with(path: &Path, scale: f64, options: &ReadOptions) -> Result<LoadedMesh, MeshError> {
    if !(scale.is_finite() && scale > 0.0) {
        return Err(MeshError::input(format!(
            "--scale must be a positive finite number, not {scale}"
        )));
    }
    let (raw, tet_path) = read_with_source(path, options)?;
    let RawMesh {
        positions,
        tets,
        tet_lines,
        labels,
        label_source,
        format,
        mut warnings,
    } = raw;
    if tets.is_empty() {
        return Err(MeshError::at(&tet_path, None, "no tetrahedra in the file"));
    }
    let file_line = |t: usize| tet_lines.get(t).copied().filter(|&l| l > 0);

    // Renumber the referenced nodes.
    let mut new_id = vec![u32::MAX; positions.len()];
    for (t, tet) in tets.iter().enumerate() {
        for &v in tet {
            match new_id.get_mut(v as usize) {
                Some(slot) => *slot = 0,
                None => {
                    return Err(MeshError::at(
                        &tet_path,
                        file_line(t),
                        format!("node index {v} out of range ({} nodes)", positions.len()),
                    ))
                }
            }
        }
    }
    let mut kept = Vec::new();
    let mut file_nodes = Vec::new();
    for (i, slot) in new_id.iter_mut().enumerate() {
        if *slot == 0 {
            *slot = kept.len() as u32;
            let [x, y, z] = positions[i].map(|c| c * scale);
            let q = Vec3::new(x as f32, y as f32, z as f32);
            if !q.is_finite() {
                return Err(MeshError::at(
                    path,
                    None,
                    format!("node {i}: coordinates too large for 32-bit floats after scaling by {scale:e}"),
                ));
            }
            kept.push(q);
            file_nodes.push(i as u32);
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
    drop(positions);
    let spatial = format != "builtin" && !options.file_order;
    if spatial {
        // Nodes along a Z-order curve, then tets by their first node (order.rs says why).
        let by_curve = order::node_order(&kept);
        let mut rank = vec![0u32; kept.len()];
        for (new, &old) in by_curve.iter().enumerate() {
            rank[old as usize] = new as u32;
        }
        for slot in new_id.iter_mut().filter(|s| **s != u32::MAX) {
            *slot = rank[*slot as usize];
        }
        kept = by_curve.iter().map(|&o| kept[o as usize]).collect();
        file_nodes = by_curve.iter().map(|&o| file_nodes[o as usize]).collect();
    }
    let mut tets: Vec<[u32; 4]> = tets.iter().map(|t| t.map(|v| new_id[v as usize])).collect();
    drop(new_id);
    let file_tets: Vec<u32> = if spatial {
        let by_first = order::tet_order(&tets);
        tets = by_first.iter().map(|&o| tets[o as usize]).collect();
        by_first
    } else {
        (0..tets.len() as u32).collect()
    };
    let labels = if labels.is_empty() {
        labels
    } else {
        file_tets.iter().map(|&o| labels[o as usize]).collect()
    };
    let line_of = |t: usize| {
        let file = file_tets.get(t).map_or(t, |&o| o as usize);
        tet_lines.get(file).copied().filter(|&l| l > 0)
    };

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
                return MeshError::failure(format!("internal error building the mesh: {e}"))
            }
            _ => (None, e.to_string()),
        };
        match tet {
            Some(t) => MeshError::at(&tet_path, line_of(t as usize), reason),
            None => MeshError::at(path, None, reason),
        }
    })?;
    Ok(LoadedMesh {
        mesh,
        path: path.to_path_buf(),
        format,
        dropped_nodes: dropped,
        file_nodes,
        file_tets,
        labels,
        label_source,
        warnings,
    })
}
