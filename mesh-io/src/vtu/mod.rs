//! VTK XML `.vtu` (`UnstructuredGrid`): each `Piece`'s `Points` `DataArray` (3 components),
//! its `Cells` arrays `connectivity`, `offsets`, `types`, and an integer `CellData` array as
//! region labels ([`crate::ReadOptions::region_array`], else the first of
//! [`crate::REGION_ARRAYS`] the file has). Cells of type 10 (`VTK_TETRA`) are kept, others
//! ignored. Several pieces are concatenated.
//!
//! Data arrays may be `format="ascii"`, `"binary"` (inline base64) or `"appended"` (in the
//! `AppendedData` block, `encoding="raw"` or `"base64"`), each binary array a size header
//! (`header_type` `UInt32` or `UInt64`) and the data, or with a `compressor`
//! (`vtkZLibDataCompressor`, `vtkLZ4DataCompressor`, `vtkLZMADataCompressor`) a block table and
//! the compressed blocks; `byte_order` little- or big-endian; any integer or float type.
//!
//! The XML handling is a small tag scanner written for this layout (the appended block is raw
//! bytes, not XML, so no XML parser reads such a file whole): elements, attributes, comments,
//! processing instructions and character data; no entities, no namespaces. The decoders are
//! crates: `base64`, `flate2` (zlib), `lz4_flex` (LZ4 blocks) and `lzma-rs` (xz).

mod data;
mod xml;

use std::path::Path;

use super::text::{line_of, one_line, short, text_from};
use super::RawMesh;
use crate::{MeshError, ReadOptions, REGION_ARRAYS};
use data::{Array, Compressor, Ctx, Values};
use xml::{scan, Kind};

/// VTK cell type of the linear tetrahedron.
const VTK_TETRA: u64 = 10;

/// One `Piece`: declared counts and its arrays.
#[derive(Default, Debug)]
struct Piece<'a> {
    line: usize,
    points: Option<Array<'a>>,
    connectivity: Option<Array<'a>>,
    offsets: Option<Array<'a>>,
    types: Option<Array<'a>>,
    cell_data: Vec<Array<'a>>,
    declared_points: u64,
    declared_cells: u64,
}

/// Reads a VTK XML `.vtu` file, labels from the default cell arrays.
///
/// # Errors
/// As [`read_with`].
pub fn read(path: &Path) -> Result<RawMesh, MeshError> {
    read_with(path, &ReadOptions::default())
}

/// Reads a VTK XML `.vtu` file (decompressed first when its name ends in `.gz`).
///
/// # Errors
/// Bad input ([`crate::MeshErrorKind::Input`]), `FILE:LINE: reason` (`FILE: byte N: reason` inside raw appended data):
/// malformed XML, another file type, missing arrays, bad base64, corrupt or truncated
/// compressed blocks, sizes larger than the data, array lengths that disagree with the
/// declared counts, bad numbers, node indices out of range, tet cells without 4 points, a
/// region array that is missing or not integer.
pub fn read_with(path: &Path, options: &ReadOptions) -> Result<RawMesh, MeshError> {
    let bytes = crate::source::read_file(path)?;
    read_bytes(path, bytes, options)
}

/// Where the appended data starts: the offset of the `_` after `<AppendedData ...>`.
fn appended_start(bytes: &[u8]) -> Option<(usize, usize)> {
    let tag = find(bytes, b"<AppendedData")?;
    let close = tag + bytes[tag..].iter().position(|&b| b == b'>')?;
    let under = close + bytes[close..].iter().position(|&b| b == b'_')?;
    Some((tag, under))
}

/// The first offset of `needle` (non-empty) in `hay`.
fn find(hay: &[u8], needle: &[u8]) -> Option<usize> {
    let mut from = 0;
    while let Some(i) = hay[from..].iter().position(|&b| b == needle[0]) {
        let at = from + i;
        if hay[at..].starts_with(needle) {
            return Some(at);
        }
        from = at + 1;
    }
    None
}

fn read_bytes(path: &Path, bytes: Vec<u8>, options: &ReadOptions) -> Result<RawMesh, MeshError> {
    // The text up to the appended data's `_` marker, and the bytes after it.
    let (text, appended_bytes, appended) = match appended_start(&bytes) {
        Some((_, under)) => {
            let tail = bytes[under + 1..].to_vec();
            let mut head = bytes;
            head.truncate(under);
            (text_from(path, head, "VTU")?, tail, Some(under + 1))
        }
        None => (text_from(path, bytes, "VTU")?, Vec::new(), None),
    };
    let at = |off: usize, reason: String| {
        MeshError::at(path, Some(line_of(&text, off)), one_line(&reason))
    };
    let tags = scan(&text).map_err(|(off, r)| at(off, format!("malformed XML: {r}")))?;
    let mut stack: Vec<&str> = Vec::new();
    let mut pieces: Vec<Piece> = Vec::new();
    let mut seen_file = false;
    let mut big = false;
    let mut header = 4;
    let mut compressor = Compressor::None;
    let mut appended_base64 = false;
    // The open DataArray: (role, array).
    let mut open: Option<(&'static str, Array)> = None;
    for tag in &tags {
        match tag.kind {
            Kind::Start | Kind::Empty => {
                let line = line_of(&text, tag.start);
                match tag.name {
                    "VTKFile" => {
                        let ty = tag.attr("type").unwrap_or("");
                        if ty != "UnstructuredGrid" {
                            return Err(at(
                                tag.start,
                                format!(
                                    "VTK XML type '{}' is not supported (UnstructuredGrid only)",
                                    short(ty)
                                ),
                            ));
                        }
                        big = match tag.attr("byte_order").unwrap_or("LittleEndian") {
                            "LittleEndian" => false,
                            "BigEndian" => true,
                            o => {
                                return Err(at(
                                    tag.start,
                                    format!(
                                        "byte_order=\"{}\" is not LittleEndian or BigEndian",
                                        short(o)
                                    ),
                                ))
                            }
                        };
                        header = match tag.attr("header_type").unwrap_or("UInt32") {
                            "UInt32" => 4,
                            "UInt64" => 8,
                            h => {
                                return Err(at(
                                    tag.start,
                                    format!("header_type=\"{}\" is not UInt32 or UInt64", short(h)),
                                ))
                            }
                        };
                        compressor = match tag.attr("compressor").unwrap_or("") {
                            "" => Compressor::None,
                            "vtkZLibDataCompressor" => Compressor::Zlib,
                            "vtkLZ4DataCompressor" => Compressor::Lz4,
                            "vtkLZMADataCompressor" => Compressor::Lzma,
                            other => {
                                return Err(at(
                                    tag.start,
                                    format!("compressor \"{}\" is not supported (zlib, lz4 and lzma are read)", short(other)),
                                ))
                            }
                        };
                        seen_file = true;
                    }
                    "AppendedData" => {
                        appended_base64 = match tag.attr("encoding").unwrap_or("raw") {
                            "raw" => false,
                            "base64" => true,
                            e => {
                                return Err(at(
                                    tag.start,
                                    format!(
                                        "AppendedData encoding=\"{}\" is not raw or base64",
                                        short(e)
                                    ),
                                ))
                            }
                        };
                    }
                    "Piece" if stack.last() == Some(&"UnstructuredGrid") => {
                        let num = |k: &str| -> Result<u64, MeshError> {
                            let v = tag.attr(k).unwrap_or("0");
                            v.parse().map_err(|_| {
                                at(tag.start, format!("{k}=\"{}\" is not a count", short(v)))
                            })
                        };
                        pieces.push(Piece {
                            line,
                            declared_points: num("NumberOfPoints")?,
                            declared_cells: num("NumberOfCells")?,
                            ..Piece::default()
                        });
                    }
                    "DataArray" => {
                        let parent = stack.last().copied().unwrap_or("");
                        let role = match (parent, tag.attr("Name")) {
                            ("Points", _) => Some("points"),
                            ("Cells", Some("connectivity")) => Some("connectivity"),
                            ("Cells", Some("offsets")) => Some("offsets"),
                            ("Cells", Some("types")) => Some("types"),
                            ("CellData", Some(_)) => Some("cell data"),
                            _ => None,
                        };
                        if let Some(role) = role {
                            let arr = Array {
                                name: tag.attr("Name").unwrap_or(""),
                                ty: tag.attr("type").unwrap_or(""),
                                format: tag.attr("format").unwrap_or("ascii"),
                                comps: tag.attr("NumberOfComponents").unwrap_or("1"),
                                offset: tag.attr("offset"),
                                tag: tag.start,
                                content: (tag.end, tag.end),
                            };
                            if !matches!(arr.format, "ascii" | "binary" | "appended") {
                                return Err(at(
                                    tag.start,
                                    format!(
                                        "DataArray format=\"{}\" is not ascii, binary or appended",
                                        short(arr.format)
                                    ),
                                ));
                            }
                            if role == "points" && arr.comps != "3" {
                                return Err(at(
                                    tag.start,
                                    format!(
                                        "Points has NumberOfComponents=\"{}\", expected 3",
                                        short(arr.comps)
                                    ),
                                ));
                            }
                            if tag.kind == Kind::Empty {
                                set(&mut pieces, role, arr);
                            } else {
                                open = Some((role, arr));
                            }
                        }
                    }
                    _ => {}
                }
                if tag.kind == Kind::Start {
                    stack.push(tag.name);
                }
            }
            Kind::End => {
                if stack.pop() != Some(tag.name) {
                    return Err(at(
                        tag.start,
                        format!("malformed XML: unexpected </{}>", short(tag.name)),
                    ));
                }
                if tag.name == "DataArray" {
                    if let Some((role, mut arr)) = open.take() {
                        arr.content.1 = tag.start;
                        set(&mut pieces, role, arr);
                    }
                }
            }
        }
    }
    if !seen_file {
        return Err(MeshError::at(
            path,
            None,
            "not a VTK XML file: no <VTKFile type=\"UnstructuredGrid\">",
        ));
    }
    let open_ok = appended.is_some() && stack.last() == Some(&"AppendedData");
    if let (Some(name), false) = (stack.last(), open_ok) {
        return Err(MeshError::at(
            path,
            Some(line_of(&text, text.trim_end().len())),
            format!("truncated file: <{}> is not closed", short(name)),
        ));
    }
    if pieces.is_empty() {
        return Err(MeshError::at(
            path,
            None,
            "no <Piece> in <UnstructuredGrid>",
        ));
    }
    let mut appended_offsets = Vec::new();
    for p in &pieces {
        let arrays = [&p.points, &p.connectivity, &p.offsets, &p.types];
        for a in arrays.into_iter().flatten().chain(&p.cell_data) {
            if a.format == "appended" {
                let off = a.offset.unwrap_or("");
                let Ok(off) = off.parse::<usize>() else {
                    return Err(at(
                        a.tag,
                        format!(
                            "appended DataArray '{}' has offset=\"{}\", not a byte offset",
                            short(a.name),
                            short(off)
                        ),
                    ));
                };
                appended_offsets.push(off);
            }
        }
    }
    appended_offsets.sort_unstable();
    let ctx = Ctx {
        path,
        text: &text,
        big,
        header,
        compressor,
        appended: appended.map(|start| {
            let mut data = &appended_bytes[..];
            if appended_base64 {
                if let Some(end) = find(data, b"</AppendedData") {
                    data = &data[..end];
                }
            }
            (data, start, appended_base64)
        }),
        appended_offsets,
    };
    let label_name = choose_labels(&ctx, &pieces[0], options)?;
    let mut positions = Vec::new();
    let mut tets = Vec::new();
    let mut tet_lines = Vec::new();
    let mut labels = Vec::new();
    for piece in &pieces {
        let base = positions.len();
        read_piece(
            &ctx,
            piece,
            base,
            label_name,
            &mut positions,
            &mut tets,
            &mut tet_lines,
            &mut labels,
        )?;
    }
    if label_name.is_none() {
        labels = vec![0; tets.len()];
    }
    Ok(RawMesh {
        positions,
        labels,
        tets,
        tet_lines,
        label_source: label_name.map(|n| format!("cell data '{n}'")),
        format: "vtu",
        warnings: Vec::new(),
    })
}

/// Whether a VTK type name is an integer type.
fn is_int(ty: &str) -> bool {
    matches!(
        ty,
        "Int8" | "UInt8" | "Int16" | "UInt16" | "Int32" | "UInt32" | "Int64" | "UInt64"
    )
}

/// The cell array that holds the labels: the one asked for (which must exist and be an integer
/// array) or the first of [`REGION_ARRAYS`] that is an integer array.
fn choose_labels<'a>(
    ctx: &Ctx<'_>,
    piece: &Piece<'a>,
    options: &ReadOptions,
) -> Result<Option<&'a str>, MeshError> {
    if let Some(want) = &options.region_array {
        let Some(a) = piece.cell_data.iter().find(|a| a.name == want.as_str()) else {
            let names: Vec<String> = piece.cell_data.iter().map(|a| short(a.name)).collect();
            return Err(MeshError::at(
                ctx.path,
                None,
                format!(
                    "--region-array '{}': the file has no cell array of that name (its cell arrays: {})",
                    short(want),
                    if names.is_empty() { "none".to_string() } else { names.join(", ") }
                ),
            ));
        };
        if !is_int(a.ty) || a.comps != "1" {
            return Err(MeshError::at(
                ctx.path,
                Some(line_of(ctx.text, a.tag)),
                format!(
                    "--region-array '{}': the cell array is {} with {} components, not one integer per cell",
                    short(want),
                    short(a.ty),
                    short(a.comps)
                ),
            ));
        }
        return Ok(Some(a.name));
    }
    Ok(REGION_ARRAYS.iter().find_map(|n| {
        piece
            .cell_data
            .iter()
            .find(|a| a.name == *n && is_int(a.ty) && a.comps == "1")
            .map(|a| a.name)
    }))
}

fn set<'a>(pieces: &mut [Piece<'a>], role: &str, arr: Array<'a>) {
    if let Some(p) = pieces.last_mut() {
        match role {
            "points" => p.points = Some(arr),
            "connectivity" => p.connectivity = Some(arr),
            "offsets" => p.offsets = Some(arr),
            "types" => p.types = Some(arr),
            _ => p.cell_data.push(arr),
        }
    }
}

fn ints(ctx: &Ctx<'_>, a: &Array<'_>, what: &str) -> Result<Vec<i64>, MeshError> {
    match ctx.values(a)? {
        Values::Int(v) => Ok(v),
        Values::Float(_) => Err(ctx.err(
            a,
            format!("{what} must be an integer array, not {}", short(a.ty)),
        )),
    }
}

/// The array of a role, which the piece must have.
fn need<'p, 'a>(
    ctx: &Ctx<'_>,
    arr: &'p Option<Array<'a>>,
    what: &str,
    piece_line: usize,
) -> Result<&'p Array<'a>, MeshError> {
    arr.as_ref().ok_or_else(|| {
        MeshError::at(
            ctx.path,
            Some(piece_line),
            format!("this <Piece> has no {what} DataArray"),
        )
    })
}

#[allow(clippy::too_many_arguments)]
fn read_piece(
    ctx: &Ctx<'_>,
    piece: &Piece<'_>,
    base: usize,
    label_name: Option<&str>,
    positions: &mut Vec<[f64; 3]>,
    tets: &mut Vec<[u32; 4]>,
    tet_lines: &mut Vec<usize>,
    labels: &mut Vec<i32>,
) -> Result<(), MeshError> {
    let pl = piece.line;
    let pa = need(ctx, &piece.points, "Points", pl)?;
    let coords = match ctx.values(pa)? {
        Values::Float(v) => v,
        Values::Int(v) => v.into_iter().map(|x| x as f64).collect(),
    };
    let piece_err = |reason: String| MeshError::at(ctx.path, Some(pl), reason);
    if coords.len() as u64 != piece.declared_points.saturating_mul(3) {
        return Err(piece_err(format!(
            "NumberOfPoints=\"{}\" needs {} coordinates, the Points array has {}",
            piece.declared_points,
            piece.declared_points.saturating_mul(3),
            coords.len()
        )));
    }
    let nodes = coords.len() / 3;
    positions.extend(coords.chunks_exact(3).map(|p| [p[0], p[1], p[2]]));

    let oa = need(ctx, &piece.offsets, "offsets", pl)?;
    let offsets = ints(ctx, oa, "offsets")?;
    let ta = need(ctx, &piece.types, "types", pl)?;
    let types = ints(ctx, ta, "types")?;
    let ca = need(ctx, &piece.connectivity, "connectivity", pl)?;
    // ASCII: the line of each index, for the tets' lines and errors.
    let mut value_lines = Vec::new();
    let conn = match ctx.values_lines(ca, Some(&mut value_lines))? {
        Values::Int(v) => v,
        Values::Float(_) => {
            return Err(ctx.err(
                ca,
                format!(
                    "connectivity must be an integer array, not {}",
                    short(ca.ty)
                ),
            ))
        }
    };
    let cells = piece.declared_cells;
    if offsets.len() as u64 != cells || types.len() as u64 != cells {
        return Err(piece_err(format!(
            "NumberOfCells=\"{cells}\" but {} offsets and {} types",
            offsets.len(),
            types.len()
        )));
    }
    let cell_labels = match label_name {
        Some(name) => {
            let Some(la) = piece.cell_data.iter().find(|a| a.name == name) else {
                return Err(piece_err(format!(
                    "this <Piece> has no cell array '{}'",
                    short(name)
                )));
            };
            let v = ints(ctx, la, "a region array")?;
            if v.len() as u64 != cells {
                return Err(ctx.err(
                    la,
                    format!("{} values for NumberOfCells=\"{cells}\"", v.len()),
                ));
            }
            Some((la, v))
        }
        None => None,
    };
    if offsets.last().is_some_and(|&o| o != conn.len() as i64) {
        return Err(ctx.err(
            oa,
            format!(
                "the last offset is not the connectivity length {}",
                conn.len()
            ),
        ));
    }
    let conn_line = line_of(ctx.text, ca.tag);
    let mut start = 0usize;
    for (k, (&end, &ty)) in offsets.iter().zip(&types).enumerate() {
        if end < start as i64 || end > conn.len() as i64 {
            return Err(ctx.err(
                oa,
                format!(
                    "offset {end} out of order or past the connectivity length {}",
                    conn.len()
                ),
            ));
        }
        let end = end as usize;
        let ids = &conn[start..end];
        start = end;
        if ty != VTK_TETRA as i64 {
            continue;
        }
        // ASCII: the line of the cell's first index; binary: the array's line.
        let line = value_lines.get(end - ids.len()).copied();
        let cell_err = |reason: String| match line {
            Some(l) => MeshError::at(ctx.path, Some(l), one_line(&reason)),
            None => ctx.err(ca, format!("cell {k}: {reason}")),
        };
        if ids.len() != 4 {
            return Err(cell_err(format!(
                "a tet cell (type 10) with {} points",
                ids.len()
            )));
        }
        let mut out = [0u32; 4];
        for (o, &v) in out.iter_mut().zip(ids) {
            if v < 0 || v as u64 >= nodes as u64 {
                return Err(cell_err(format!(
                    "point index {v} out of range (points are numbered 0..{})",
                    nodes as i64 - 1
                )));
            }
            *o = (v as usize + base) as u32;
        }
        tets.push(out);
        tet_lines.push(line.unwrap_or(conn_line));
        if let Some((la, v)) = &cell_labels {
            let x = v[k];
            labels.push(i32::try_from(x).map_err(|_| {
                ctx.err(
                    la,
                    format!("cell {k}: region label {x} does not fit 32 bits"),
                )
            })?);
        }
    }
    Ok(())
}
