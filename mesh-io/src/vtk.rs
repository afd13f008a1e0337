//! VTK legacy `.vtk`, `ASCII` or `BINARY` (big-endian numbers after each text header line),
//! `DATASET UNSTRUCTURED_GRID`: `POINTS`, `CELLS` (the classic `count id...` layout up to 4.2,
//! `OFFSETS`/`CONNECTIVITY` from 5.0), `CELL_TYPES`, and in `CELL_DATA` an integer array
//! (`SCALARS` or a `FIELD` array) as region labels ([`crate::ReadOptions::region_array`], else
//! the first of [`crate::REGION_ARRAYS`] the file has). Cells of type 10 (`VTK_TETRA`) are
//! kept, others ignored; `POINT_DATA` attributes, `FIELD` and `METADATA` blocks are skipped.
//! Errors name the line in ASCII files and the byte offset in binary ones.

use std::path::Path;

use crate::binary::{show, Bytes};
use crate::text::{one_line, short};
use crate::{MeshError, RawMesh, ReadOptions, REGION_ARRAYS};

/// VTK cell type of the linear tetrahedron.
const VTK_TETRA: i64 = 10;

/// A VTK data type: bytes per value in a binary file, and whether it is a float.
fn data_type(t: &str) -> Option<(usize, bool)> {
    Some(match t.to_ascii_lowercase().as_str() {
        "bit" | "char" | "unsigned_char" => (1, false),
        "short" | "unsigned_short" => (2, false),
        "int" | "unsigned_int" | "vtktypeint32" | "vtktypeuint32" => (4, false),
        "long" | "unsigned_long" | "vtktypeint64" | "vtktypeuint64" | "vtkidtype" => (8, false),
        "float" => (4, true),
        "double" => (8, true),
        _ => return None,
    })
}

/// A token and where it starts.
#[derive(Clone, Copy, Debug)]
struct Tok<'a> {
    s: &'a str,
    line: usize,
    off: usize,
}

/// Tokens and binary blocks of a legacy VTK file, with line numbers.
struct Reader<'a> {
    path: &'a Path,
    data: &'a [u8],
    pos: usize,
    /// Line of `pos` (1-based).
    line: usize,
    /// Line of the last token read.
    last_line: usize,
    binary: bool,
}

impl<'a> Reader<'a> {
    fn err_at(&self, line: usize, off: usize, reason: impl std::fmt::Display) -> MeshError {
        let reason = one_line(&reason.to_string());
        if self.binary {
            MeshError::at_byte(self.path, off as u64, reason)
        } else {
            MeshError::at(self.path, Some(line.max(1)), reason)
        }
    }

    fn err(&self, t: Tok<'_>, reason: impl std::fmt::Display) -> MeshError {
        self.err_at(t.line, t.off, reason)
    }

    fn eof(&self, what: &str) -> MeshError {
        self.err_at(
            self.last_line,
            self.pos,
            format!("unexpected end of file (truncated?): expected {what}"),
        )
    }

    fn token(&mut self) -> Option<Tok<'a>> {
        while self.pos < self.data.len() && self.data[self.pos].is_ascii_whitespace() {
            if self.data[self.pos] == b'\n' {
                self.line += 1;
            }
            self.pos += 1;
        }
        if self.pos >= self.data.len() {
            return None;
        }
        let start = self.pos;
        while self.pos < self.data.len() && !self.data[self.pos].is_ascii_whitespace() {
            self.pos += 1;
        }
        let s = std::str::from_utf8(&self.data[start..self.pos]).unwrap_or("\u{fffd}");
        self.last_line = self.line;
        Some(Tok {
            s,
            line: self.line,
            off: start,
        })
    }

    fn need(&mut self, what: &str) -> Result<Tok<'a>, MeshError> {
        self.token().ok_or_else(|| self.eof(what))
    }

    fn uint(&mut self, what: &str) -> Result<(u64, Tok<'a>), MeshError> {
        let t = self.need(what)?;
        match t.s.parse::<u64>() {
            Ok(v) => Ok((v, t)),
            Err(_) => Err(self.err(
                t,
                format!(
                    "expected {what} (a non-negative integer), found '{}'",
                    short(t.s)
                ),
            )),
        }
    }

    /// The next token must be `kw`.
    fn keyword(&mut self, kw: &str) -> Result<(), MeshError> {
        let t = self.need(kw)?;
        if t.s.eq_ignore_ascii_case(kw) {
            Ok(())
        } else {
            Err(self.err(t, format!("expected {kw}, found '{}'", short(t.s))))
        }
    }

    /// A data type token.
    fn dtype(&mut self) -> Result<(usize, bool), MeshError> {
        let t = self.need("a data type")?;
        data_type(t.s).ok_or_else(|| self.err(t, format!("unknown VTK data type '{}'", short(t.s))))
    }

    /// The rest of the current line (after a header).
    fn rest_of_line(&mut self) -> &'a [u8] {
        let start = self.pos;
        while self.pos < self.data.len() && self.data[self.pos] != b'\n' {
            self.pos += 1;
        }
        let s = &self.data[start..self.pos];
        if self.pos < self.data.len() {
            self.pos += 1;
            self.line += 1;
        }
        s
    }

    /// Checks `n` values against what is left, before allocating them: at least two bytes a
    /// value in ASCII, `size` bytes in binary.
    fn check(&self, n: u64, size: usize, what: &str, at: Tok<'_>) -> Result<usize, MeshError> {
        let per = if self.binary { size as u64 } else { 2 };
        let room = (self.data.len() - self.pos) as u64 + 1;
        match n.checked_mul(per) {
            Some(need) if need <= room && n < u32::MAX as u64 => Ok(n as usize),
            _ => Err(self.err(
                at,
                format!(
                    "declares {n} {what}, more than the rest of the file can hold (at most {})",
                    room / per
                ),
            )),
        }
    }

    /// `n` numbers of a type, as f64 (floats) or i64 (integers), with the line of each in an
    /// ASCII file when `lines` is given. A binary block starts after the current line.
    fn values(
        &mut self,
        n: usize,
        (size, float): (usize, bool),
        what: &str,
        mut lines: Option<&mut Vec<usize>>,
    ) -> Result<Vals, MeshError> {
        if self.binary {
            let rest = self.rest_of_line();
            if !rest.iter().all(|b| b.is_ascii_whitespace()) {
                return Err(self.err_at(
                    self.line,
                    self.pos - rest.len(),
                    format!("unexpected '{}' before the binary {what}", show(rest)),
                ));
            }
            let start = self.pos;
            let mut b = Bytes::new(self.path, &self.data[start..], start, true);
            let block = b.take(n * size, what)?;
            let mut b = Bytes::new(self.path, block, start, true);
            self.pos += n * size;
            if float {
                let mut v = Vec::with_capacity(n);
                for _ in 0..n {
                    v.push(b.float(size, what)?);
                }
                return Ok(Vals::F(v));
            }
            let mut v = Vec::with_capacity(n);
            for _ in 0..n {
                v.push(match size {
                    1 => b.take(1, what)?[0] as i64,
                    2 => {
                        let x = b.take(2, what)?;
                        i16::from_be_bytes([x[0], x[1]]) as i64
                    }
                    4 => b.int(4, what)?,
                    _ => b.int(8, what)?,
                });
            }
            return Ok(Vals::I(v));
        }
        let mut f = Vec::with_capacity(if float { n } else { 0 });
        let mut i = Vec::with_capacity(if float { 0 } else { n });
        for k in 0..n {
            let Some(t) = self.token() else {
                return Err(self.eof(&format!("{what} {} of {n}", k + 1)));
            };
            if let Some(l) = lines.as_deref_mut() {
                l.push(t.line);
            }
            if float {
                match t.s.parse::<f64>() {
                    Ok(v) if v.is_finite() => f.push(v),
                    Ok(_) => {
                        return Err(self.err(t, format!("NaN or infinite {what} '{}'", short(t.s))))
                    }
                    Err(_) => {
                        return Err(self.err(
                            t,
                            format!("expected {what} (a number), found '{}'", short(t.s)),
                        ))
                    }
                }
            } else {
                match t.s.parse::<i64>() {
                    Ok(v) => i.push(v),
                    Err(_) => {
                        return Err(self.err(
                            t,
                            format!("expected {what} (an integer), found '{}'", short(t.s)),
                        ))
                    }
                }
            }
        }
        Ok(if float { Vals::F(f) } else { Vals::I(i) })
    }

    fn ints(
        &mut self,
        n: usize,
        ty: (usize, bool),
        what: &str,
        at: Tok<'_>,
    ) -> Result<Vec<i64>, MeshError> {
        match self.values(n, ty, what, None)? {
            Vals::I(v) => Ok(v),
            Vals::F(_) => Err(self.err(at, format!("{what} must have an integer type"))),
        }
    }
}

/// Numbers of one block.
enum Vals {
    F(Vec<f64>),
    I(Vec<i64>),
}

/// A cell data array: name, its integer values when it is one integer per cell, and where it
/// was declared.
struct CellArray<'a> {
    name: &'a str,
    ints: Option<Vec<i64>>,
    at: Tok<'a>,
}

/// Reads a VTK legacy file, labels from the default cell arrays.
///
/// # Errors
/// As [`read_with`].
pub fn read(path: &Path) -> Result<RawMesh, MeshError> {
    read_with(path, &ReadOptions::default())
}

/// Reads a VTK legacy file (decompressed first when its name ends in `.gz`).
///
/// # Errors
/// Bad input ([`crate::MeshErrorKind::Input`]), `FILE:LINE: reason` (`FILE: byte N: reason` in a binary file): other
/// datasets, truncated sections, counts larger than the file, bad numbers, node indices out of
/// range, tets whose cell does not have 4 points, CELLS and CELL_TYPES disagreeing, a region
/// array that is missing or not integer.
pub fn read_with(path: &Path, options: &ReadOptions) -> Result<RawMesh, MeshError> {
    let data = crate::source::read_file(path)?;
    if data.iter().all(|b| b.is_ascii_whitespace()) {
        return Err(MeshError::at(path, None, "empty file"));
    }
    let mut r = Reader {
        path,
        data: &data,
        pos: 0,
        line: 1,
        last_line: 1,
        binary: false,
    };
    let first = r.rest_of_line();
    let first = String::from_utf8_lossy(first);
    let first = first.trim();
    let Some(ver) = first.strip_prefix("# vtk DataFile Version ") else {
        return Err(MeshError::at(
            path,
            Some(1),
            "not a VTK legacy file: no '# vtk DataFile Version' line",
        ));
    };
    let major: u32 = ver
        .split('.')
        .next()
        .and_then(|m| m.trim().parse().ok())
        .unwrap_or(0);
    if major == 0 {
        return Err(MeshError::at(
            path,
            Some(1),
            format!("unknown VTK version '{}'", short(ver)),
        ));
    }
    let new_layout = major >= 5;
    // Title line (any text, possibly blank).
    r.rest_of_line();
    let enc = r.need("ASCII or BINARY")?;
    if enc.s.eq_ignore_ascii_case("BINARY") {
        r.binary = true;
    } else if !enc.s.eq_ignore_ascii_case("ASCII") {
        return Err(r.err(
            enc,
            format!("expected ASCII or BINARY, found '{}'", short(enc.s)),
        ));
    } else if let Some(at) = match std::str::from_utf8(&data) {
        Ok(text) => text.bytes().position(|b| b == 0),
        Err(e) => Some(e.valid_up_to()),
    } {
        let line = 1 + data[..at].iter().filter(|&&b| b == b'\n').count();
        return Err(MeshError::at(
            path,
            Some(line),
            "binary data in a file that says ASCII",
        ));
    }
    let mut positions: Option<Vec<[f64; 3]>> = None;
    // Cells: offsets into conn (one more than cells), conn, the line of each cell.
    let mut cells: Option<(Vec<usize>, Vec<i64>, Vec<usize>)> = None;
    let mut types: Option<(Vec<i64>, Tok)> = None;
    let mut dataset = false;
    // The current attribute block: (is cell data, its count).
    let mut attr: Option<(bool, usize)> = None;
    let mut cell_arrays: Vec<CellArray> = Vec::new();
    let mut cell_data_at: Option<(Tok, usize)> = None;
    while let Some(kw) = r.token() {
        match kw.s.to_ascii_uppercase().as_str() {
            "DATASET" => {
                let d = r.need("a dataset type")?;
                if !d.s.eq_ignore_ascii_case("UNSTRUCTURED_GRID") {
                    return Err(r.err(
                        d,
                        format!(
                            "VTK dataset {} is not supported (UNSTRUCTURED_GRID only)",
                            short(d.s)
                        ),
                    ));
                }
                dataset = true;
            }
            "POINTS" => {
                let (n, nt) = r.uint("the number of points")?;
                let ty = r.dtype()?;
                let n = r.check(n.saturating_mul(3), ty.0, "point coordinates", nt)? / 3;
                let p = match r.values(3 * n, ty, "point coordinate", None)? {
                    Vals::F(v) => v,
                    Vals::I(v) => v.into_iter().map(|x| x as f64).collect(),
                };
                positions = Some(p.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect());
            }
            "CELLS" if new_layout => {
                let (no, nt) = r.uint("the number of offsets")?;
                let (nc, _) = r.uint("the connectivity size")?;
                r.keyword("OFFSETS")?;
                let oty = r.dtype()?;
                let no = r.check(no, oty.0, "offsets", nt)?;
                let offs = r.ints(no, oty, "offset", nt)?;
                r.keyword("CONNECTIVITY")?;
                let cty = r.dtype()?;
                let nc = r.check(nc, cty.0, "connectivity entries", nt)?;
                let mut lines = Vec::new();
                let conn =
                    match r.values(nc, cty, "point index", (!r.binary).then_some(&mut lines))? {
                        Vals::I(v) => v,
                        Vals::F(_) => {
                            return Err(r.err(nt, "connectivity must have an integer type"))
                        }
                    };
                let mut offsets = Vec::with_capacity(no);
                let mut cell_lines = Vec::with_capacity(no);
                for (k, &o) in offs.iter().enumerate() {
                    let bad = o < 0
                        || o as u64 > nc as u64
                        || offsets.last().is_some_and(|&p| (o as usize) < p)
                        || (k == 0 && o != 0);
                    if bad {
                        return Err(r.err(
                            nt,
                            format!(
                                "offset {k} ({o}) out of order or past the connectivity size {nc}"
                            ),
                        ));
                    }
                    offsets.push(o as usize);
                    cell_lines.push(lines.get(o as usize).copied().unwrap_or(nt.line));
                }
                if offsets.last().is_some_and(|&o| o != nc) {
                    return Err(r.err(
                        nt,
                        format!("the last offset is not the connectivity size {nc}"),
                    ));
                }
                cells = Some((offsets, conn, cell_lines));
            }
            "CELLS" => {
                let (n, nt) = r.uint("the number of cells")?;
                let (size, _) = r.uint("the cell list size")?;
                let n = r.check(n, 8, "cells", nt)?;
                let size = r.check(size, 4, "cell list entries", nt)?;
                let mut lines = Vec::new();
                let list = r.ints_lines(size, &mut lines, nt)?;
                let mut offsets = Vec::with_capacity(n + 1);
                let mut conn = Vec::with_capacity(size.saturating_sub(n));
                let mut cell_lines = Vec::with_capacity(n);
                offsets.push(0);
                let mut k = 0usize;
                for c in 0..n {
                    let Some(&m) = list.get(k) else {
                        return Err(r.err(
                            nt,
                            format!("cell {} of {n} is past the {size} entries declared", c + 1),
                        ));
                    };
                    let line = lines.get(k).copied().unwrap_or(nt.line);
                    let end = usize::try_from(m).ok().and_then(|m| m.checked_add(k + 1));
                    let Some(end) = end.filter(|&e| e <= size) else {
                        return Err(r.err_at(
                            line,
                            nt.off,
                            format!(
                                "cell {}: {m} points do not fit the {size} entries declared",
                                c + 1
                            ),
                        ));
                    };
                    conn.extend_from_slice(&list[k + 1..end]);
                    offsets.push(conn.len());
                    cell_lines.push(line);
                    k = end;
                }
                if k != size {
                    return Err(r.err(
                        nt,
                        format!("declares {size} cell list entries, the cells hold {k}"),
                    ));
                }
                cells = Some((offsets, conn, cell_lines));
            }
            "CELL_TYPES" => {
                let (n, nt) = r.uint("the number of cell types")?;
                let n = r.check(n, 4, "cell types", nt)?;
                let t = r.ints(n, (4, false), "cell type", nt)?;
                types = Some((t, nt));
            }
            "POINT_DATA" | "CELL_DATA" => {
                let (n, nt) = r.uint("the number of values")?;
                let n = usize::try_from(n).unwrap_or(usize::MAX);
                let is_cell = kw.s.eq_ignore_ascii_case("CELL_DATA");
                if is_cell {
                    cell_data_at = Some((nt, n));
                }
                attr = Some((is_cell, n));
            }
            "FIELD" => {
                let _ = r.need("a field name")?;
                let (arrays, at) = r.uint("the number of arrays")?;
                let arrays = r.check(arrays, 8, "field arrays", at)?;
                for _ in 0..arrays {
                    let name = r.need("an array name")?;
                    let (comp, ct) = r.uint("the number of components")?;
                    let (tuples, _) = r.uint("the number of tuples")?;
                    let ty = r.dtype()?;
                    let n = r.check(comp.saturating_mul(tuples), ty.0, "array values", ct)?;
                    let v = r.values(n, ty, "array value", None)?;
                    if let Some((true, _)) = attr {
                        cell_arrays.push(CellArray {
                            name: name.s,
                            ints: match v {
                                Vals::I(v) if comp == 1 => Some(v),
                                _ => None,
                            },
                            at: name,
                        });
                    }
                }
            }
            "METADATA" => {
                // Until the next blank line.
                r.rest_of_line();
                loop {
                    if r.pos >= r.data.len() {
                        break;
                    }
                    if r.rest_of_line().iter().all(|b| b.is_ascii_whitespace()) {
                        break;
                    }
                }
            }
            "SCALARS"
            | "VECTORS"
            | "NORMALS"
            | "TENSORS"
            | "TENSORS6"
            | "TEXTURE_COORDINATES"
            | "GLOBAL_IDS"
            | "PEDIGREE_IDS"
            | "COLOR_SCALARS"
            | "LOOKUP_TABLE" => {
                let Some((is_cell, n)) = attr else {
                    return Err(r.err(
                        kw,
                        format!("{} outside POINT_DATA or CELL_DATA", short(kw.s)),
                    ));
                };
                let kind = kw.s.to_ascii_uppercase();
                let name = r.need("an attribute name")?;
                let (per, ty) = match kind.as_str() {
                    "SCALARS" => {
                        let ty = r.dtype()?;
                        // An optional component count, then an optional LOOKUP_TABLE line.
                        let save = (r.pos, r.line);
                        let mut comps = 1u64;
                        let mut next = r.token();
                        if let Some(t) = next {
                            if let Ok(c) = t.s.parse::<u64>() {
                                if !t.s.eq_ignore_ascii_case("LOOKUP_TABLE")
                                    && (1..=4).contains(&c)
                                    && r.binary_or_header(save.1, t)
                                {
                                    comps = c;
                                    next = r.token();
                                }
                            }
                        }
                        match next {
                            Some(t) if t.s.eq_ignore_ascii_case("LOOKUP_TABLE") => {
                                r.need("a lookup table name")?;
                            }
                            _ => {
                                r.pos = save.0;
                                r.line = save.1;
                                if comps != 1 {
                                    r.token();
                                }
                            }
                        }
                        (comps, ty)
                    }
                    "VECTORS" | "NORMALS" => (3, r.dtype()?),
                    "TENSORS" => (9, r.dtype()?),
                    "TENSORS6" => (6, r.dtype()?),
                    "TEXTURE_COORDINATES" => {
                        let (d, _) = r.uint("the number of texture dimensions")?;
                        (d, r.dtype()?)
                    }
                    "COLOR_SCALARS" => {
                        let (m, _) = r.uint("the number of colour values")?;
                        (m, if r.binary { (1, false) } else { (4, true) })
                    }
                    "LOOKUP_TABLE" => {
                        let (size, st) = r.uint("the lookup table size")?;
                        let size = r.check(size.saturating_mul(4), 1, "lookup table values", st)?;
                        r.values(
                            size,
                            if r.binary { (1, false) } else { (4, true) },
                            "lookup table value",
                            None,
                        )?;
                        continue;
                    }
                    _ => (1, r.dtype()?),
                };
                let count = r.check(
                    (n as u64).saturating_mul(per),
                    ty.0,
                    "attribute values",
                    name,
                )?;
                let v = r.values(count, ty, "attribute value", None)?;
                if is_cell && kind == "SCALARS" {
                    cell_arrays.push(CellArray {
                        name: name.s,
                        ints: match v {
                            Vals::I(v) if per == 1 => Some(v),
                            _ => None,
                        },
                        at: name,
                    });
                }
            }
            _ => {
                return Err(r.err(
                    kw,
                    format!("unexpected '{}' (not a VTK section keyword)", short(kw.s)),
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
    let Some((offsets, conn, cell_lines)) = cells else {
        return Err(MeshError::at(path, None, "no CELLS section"));
    };
    let Some((types, tt)) = types else {
        return Err(MeshError::at(path, None, "no CELL_TYPES section"));
    };
    let ncells = offsets.len().saturating_sub(1);
    if types.len() != ncells {
        return Err(r.err(tt, format!("{} cell types for {ncells} cells", types.len())));
    }
    // The label array.
    let chosen: Option<&CellArray> = match &options.region_array {
        Some(want) => {
            let Some(a) = cell_arrays.iter().find(|a| a.name == want.as_str()) else {
                let names: Vec<String> = cell_arrays.iter().map(|a| short(a.name)).collect();
                return Err(MeshError::at(
                    path,
                    None,
                    format!(
                        "--region-array '{}': the file has no cell array of that name (its cell arrays: {})",
                        short(want),
                        if names.is_empty() { "none".to_string() } else { names.join(", ") }
                    ),
                ));
            };
            if a.ints.is_none() {
                return Err(r.err(
                    a.at,
                    format!(
                        "--region-array '{}': the cell array is not one integer per cell",
                        short(want)
                    ),
                ));
            }
            Some(a)
        }
        None => REGION_ARRAYS.iter().find_map(|n| {
            cell_arrays
                .iter()
                .find(|a| a.name == *n && a.ints.is_some())
        }),
    };
    if let (Some(a), Some((at, n))) = (chosen, cell_data_at) {
        if n != ncells {
            return Err(r.err(at, format!("CELL_DATA {n} for {ncells} cells")));
        }
        let _ = a;
    }
    let mut tets = Vec::new();
    let mut tet_lines = Vec::new();
    let mut labels = Vec::new();
    for (k, &ty) in types.iter().enumerate() {
        if ty != VTK_TETRA {
            continue;
        }
        let ids = &conn[offsets[k]..offsets[k + 1]];
        let line = if r.binary {
            0
        } else {
            cell_lines.get(k).copied().unwrap_or(0)
        };
        let cell_err = |reason: String| {
            if r.binary {
                MeshError::at(path, None, format!("cell {k}: {reason}"))
            } else {
                MeshError::at(path, Some(line.max(1)), reason)
            }
        };
        if ids.len() != 4 {
            return Err(cell_err(format!(
                "a tet cell (type 10) with {} points",
                ids.len()
            )));
        }
        let mut out = [0u32; 4];
        for (o, &v) in out.iter_mut().zip(ids) {
            if v < 0 || v as u64 >= positions.len() as u64 {
                return Err(cell_err(format!(
                    "node index {v} out of range (nodes are numbered 0..{})",
                    positions.len() as i64 - 1
                )));
            }
            *o = v as u32;
        }
        tets.push(out);
        tet_lines.push(line);
        if let Some(a) = chosen {
            let x = a.ints.as_ref().and_then(|v| v.get(k)).copied().unwrap_or(0);
            labels.push(i32::try_from(x).map_err(|_| {
                r.err(
                    a.at,
                    format!("cell {k}: region label {x} does not fit 32 bits"),
                )
            })?);
        }
    }
    let format = match (new_layout, r.binary) {
        (true, false) => "vtk 5",
        (false, false) => "vtk 4",
        (true, true) => "vtk 5 binary",
        (false, true) => "vtk 4 binary",
    };
    if chosen.is_none() {
        labels = vec![0; tets.len()];
    }
    Ok(RawMesh {
        positions,
        labels,
        tets,
        tet_lines,
        label_source: chosen.map(|a| format!("cell data '{}'", a.name)),
        format,
        warnings: Vec::new(),
    })
}

impl<'a> Reader<'a> {
    /// `n` integers with the line of each (ASCII) for the classic CELLS list (32-bit in
    /// binary files).
    fn ints_lines(
        &mut self,
        n: usize,
        lines: &mut Vec<usize>,
        at: Tok<'_>,
    ) -> Result<Vec<i64>, MeshError> {
        let keep = !self.binary;
        match self.values(n, (4, false), "cell list entry", keep.then_some(lines))? {
            Vals::I(v) => Ok(v),
            Vals::F(_) => Err(self.err(at, "cell list must be integers")),
        }
    }

    /// Whether a number after `SCALARS name type` is its component count: in an ASCII file it
    /// must be on the same line as the header (a value on the next line is data).
    fn binary_or_header(&self, header_line: usize, t: Tok<'_>) -> bool {
        t.line == header_line
    }
}
