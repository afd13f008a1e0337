//! VTK legacy `.vtk`, ASCII, `DATASET UNSTRUCTURED_GRID`: `POINTS`, `CELLS` (the classic
//! `count id...` layout up to 4.2, `OFFSETS`/`CONNECTIVITY` from 5.0), `CELL_TYPES`. Cells of
//! type 10 (`VTK_TETRA`) are kept, others ignored; `FIELD` and `METADATA` blocks are skipped;
//! reading stops at `POINT_DATA`/`CELL_DATA`. `BINARY` files are refused.

use std::path::Path;

use super::text::{node_ids, parse_int, read_text, short, Cursor};
use super::RawMesh;
use crate::MeshError;

/// VTK cell type of the linear tetrahedron.
const VTK_TETRA: u64 = 10;

/// Cells as read: offsets into `conn` (one more than cells) and the line of each cell.
struct Cells {
    offsets: Vec<usize>,
    conn: Vec<i64>,
    lines: Vec<usize>,
}

/// Reads a VTK legacy file.
///
/// # Errors
/// Exit status 2, `FILE:LINE: reason`: binary files, other datasets, truncated sections,
/// counts larger than the file, bad numbers, node indices out of range, tets whose cell does
/// not have 4 points, CELLS and CELL_TYPES disagreeing.
pub fn read(path: &Path) -> Result<RawMesh, MeshError> {
    let text = read_text(path, "VTK")?;
    let mut c = Cursor::new(path, &text, 1, None);
    let (l1, first) = c.need_line("the '# vtk DataFile Version' line")?;
    let joined = first.join(" ");
    let Some(ver) = joined.strip_prefix("# vtk DataFile Version ") else {
        return Err(c.err(
            l1,
            "not a VTK legacy file: no '# vtk DataFile Version' line",
        ));
    };
    let major: u32 = ver
        .split('.')
        .next()
        .and_then(|m| m.trim().parse().ok())
        .unwrap_or(0);
    if major == 0 {
        return Err(c.err(l1, format!("unknown VTK version '{}'", short(ver))));
    }
    let new_layout = major >= 5;
    // Title line (any text, possibly blank: take the raw next line).
    c.raw_line();
    let (l3, enc) = c.need_line("ASCII or BINARY")?;
    if enc[0].eq_ignore_ascii_case("BINARY") {
        return Err(c.err(l3, "binary VTK files are not supported (write ASCII)"));
    }
    if !enc[0].eq_ignore_ascii_case("ASCII") {
        return Err(c.err(
            l3,
            format!("expected ASCII or BINARY, found '{}'", short(enc[0])),
        ));
    }
    let mut positions: Option<Vec<[f64; 3]>> = None;
    let mut cells: Option<Cells> = None;
    let mut types: Option<(Vec<u64>, usize)> = None;
    let mut dataset = false;
    while let Some((kw, line)) = c.token() {
        match kw.to_ascii_uppercase().as_str() {
            "DATASET" => {
                let (d, dl) = c.need("a dataset type")?;
                if !d.eq_ignore_ascii_case("UNSTRUCTURED_GRID") {
                    return Err(c.err(
                        dl,
                        format!(
                            "VTK dataset {} is not supported (UNSTRUCTURED_GRID only)",
                            short(d)
                        ),
                    ));
                }
                dataset = true;
            }
            "POINTS" => {
                let (n, nl) = c.uint("the number of points")?;
                let _ = c.need("the point data type")?;
                let n = c.count(n, 3, "points", nl)?;
                let mut p = Vec::with_capacity(n);
                for k in 0..n {
                    let what = format!("point {} of {n}", k + 1);
                    p.push([c.float(&what)?, c.float(&what)?, c.float(&what)?]);
                }
                positions = Some(p);
            }
            "CELLS" if new_layout => {
                let (no, nl) = c.uint("the number of offsets")?;
                let (nc, _) = c.uint("the connectivity size")?;
                let no = c.count(no, 1, "offsets", nl)?;
                let nc = c.count(nc, 1, "connectivity entries", nl)?;
                let mut offsets = Vec::with_capacity(no);
                let mut lines = Vec::with_capacity(no);
                keyword(&mut c, "OFFSETS")?;
                let _ = c.need("the offsets data type")?;
                for k in 0..no {
                    let (o, ol) = c.uint(&format!("offset {} of {no}", k + 1))?;
                    let o = o as usize;
                    if o > nc || offsets.last().is_some_and(|&p| o < p) || (k == 0 && o != 0) {
                        return Err(c.err(
                            ol,
                            format!("offset {o} out of order or past the connectivity size {nc}"),
                        ));
                    }
                    offsets.push(o);
                }
                if offsets.last().is_some_and(|&o| o != nc) {
                    return Err(c.err(
                        nl,
                        format!("the last offset is not the connectivity size {nc}"),
                    ));
                }
                keyword(&mut c, "CONNECTIVITY")?;
                let _ = c.need("the connectivity data type")?;
                let mut conn = Vec::with_capacity(nc);
                let mut next_cell = 1;
                for k in 0..nc {
                    let (t, tl) = c.need(&format!("connectivity entry {} of {nc}", k + 1))?;
                    while next_cell < offsets.len() && offsets[next_cell - 1] == k {
                        lines.push(tl);
                        next_cell += 1;
                    }
                    conn.push(parse_int(&c, t, tl, "a point index")?);
                }
                while lines.len() + 1 < offsets.len() {
                    lines.push(c.line_no());
                }
                cells = Some(Cells {
                    offsets,
                    conn,
                    lines,
                });
            }
            "CELLS" => {
                let (n, nl) = c.uint("the number of cells")?;
                let (size, _) = c.uint("the cell list size")?;
                let n = c.count(n, 2, "cells", nl)?;
                let size = c.count(size, 1, "cell list entries", nl)?;
                let mut offsets = Vec::with_capacity(n + 1);
                let mut lines = Vec::with_capacity(n);
                let mut conn = Vec::new();
                offsets.push(0);
                let mut used = 0usize;
                for k in 0..n {
                    let (m, ml) = c.uint(&format!("cell {} of {n}", k + 1))?;
                    used = used.saturating_add(1).saturating_add(m as usize);
                    if used > size {
                        return Err(c.err(
                            ml,
                            format!("cells hold more than the {size} entries declared"),
                        ));
                    }
                    for _ in 0..m {
                        let (t, tl) = c.need(&format!("a point index of cell {}", k + 1))?;
                        conn.push(parse_int(&c, t, tl, "a point index")?);
                    }
                    offsets.push(conn.len());
                    lines.push(ml);
                }
                if used != size {
                    return Err(c.err(
                        nl,
                        format!("declares {size} cell list entries, the cells hold {used}"),
                    ));
                }
                cells = Some(Cells {
                    offsets,
                    conn,
                    lines,
                });
            }
            "CELL_TYPES" => {
                let (n, nl) = c.uint("the number of cell types")?;
                let n = c.count(n, 1, "cell types", nl)?;
                let mut t = Vec::with_capacity(n);
                for k in 0..n {
                    t.push(c.uint(&format!("cell type {} of {n}", k + 1))?.0);
                }
                types = Some((t, nl));
            }
            "FIELD" => {
                let _ = c.need("a field name")?;
                let (arrays, al) = c.uint("the number of arrays")?;
                let arrays = c.count(arrays, 4, "field arrays", al)?;
                for _ in 0..arrays {
                    let _ = c.need("an array name")?;
                    let (comp, cl) = c.uint("the number of components")?;
                    let (tuples, _) = c.uint("the number of tuples")?;
                    let _ = c.need("the array data type")?;
                    let values = c.count(comp.saturating_mul(tuples), 1, "array values", cl)?;
                    for _ in 0..values {
                        c.need("array data")?;
                    }
                }
            }
            "METADATA" => {
                // Until the next blank line.
                while let Some(t) = c.raw_line() {
                    if t.trim().is_empty() {
                        break;
                    }
                }
            }
            "POINT_DATA" | "CELL_DATA" => break,
            _ => {
                return Err(c.err(
                    line,
                    format!("unexpected '{}' (not a VTK section keyword)", short(kw)),
                ));
            }
        }
    }
    if !dataset {
        return Err(MeshError::at(
            path,
            None,
            "no 'DATASET UNSTRUCTURED_GRID' line",
        ));
    }
    let Some(positions) = positions else {
        return Err(MeshError::at(path, None, "no POINTS section"));
    };
    let Some(cells) = cells else {
        return Err(MeshError::at(path, None, "no CELLS section"));
    };
    let Some((types, tl)) = types else {
        return Err(MeshError::at(path, None, "no CELL_TYPES section"));
    };
    let ncells = cells.offsets.len().saturating_sub(1);
    if types.len() != ncells {
        return Err(c.err(tl, format!("{} cell types for {ncells} cells", types.len())));
    }
    let mut tets = Vec::new();
    let mut tet_lines = Vec::new();
    for (k, &ty) in types.iter().enumerate() {
        if ty != VTK_TETRA {
            continue;
        }
        let ids = &cells.conn[cells.offsets[k]..cells.offsets[k + 1]];
        let line = cells.lines.get(k).copied().unwrap_or(0);
        if ids.len() != 4 {
            return Err(c.err(
                line,
                format!("a tet cell (type 10) with {} points", ids.len()),
            ));
        }
        let raw = [ids[0], ids[1], ids[2], ids[3]];
        tets.push(node_ids(&c, raw, 0, positions.len(), line)?);
        tet_lines.push(line);
    }
    let format = if new_layout { "vtk 5" } else { "vtk 4" };
    Ok(RawMesh {
        positions,
        labels: vec![0; tets.len()],
        tets,
        tet_lines,
        label_source: None,
        format,
        warnings: Vec::new(),
    })
}

/// The next token must be `kw`.
fn keyword(c: &mut Cursor<'_>, kw: &str) -> Result<(), MeshError> {
    let (t, l) = c.need(kw)?;
    if t.eq_ignore_ascii_case(kw) {
        Ok(())
    } else {
        Err(c.err(l, format!("expected {kw}, found '{}'", short(t))))
    }
}
