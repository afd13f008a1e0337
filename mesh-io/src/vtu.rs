//! VTK XML `.vtu` (`UnstructuredGrid`) with ASCII data arrays: each `Piece`'s `Points`
//! `DataArray` (3 components) and its `Cells` arrays `connectivity`, `offsets`, `types`.
//! Cells of type 10 (`VTK_TETRA`) are kept, others ignored. Several pieces are concatenated.
//! `format="binary"`, `format="appended"` and `AppendedData` are refused.
//!
//! The XML handling is a small tag scanner written for this layout: elements, attributes,
//! comments, processing instructions and character data; no entities, no namespaces.

use std::path::Path;

use super::text::{
    line_of, one_line, parse_float, parse_int, parse_uint, read_text, short, Cursor,
};
use super::RawMesh;
use crate::MeshError;

/// VTK cell type of the linear tetrahedron.
const VTK_TETRA: u64 = 10;

#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum Kind {
    Start,
    End,
    Empty,
}

/// One tag: its name, attributes and byte range in the text.
#[derive(Debug)]
struct Tag<'a> {
    name: &'a str,
    attrs: Vec<(&'a str, &'a str)>,
    kind: Kind,
    start: usize,
    end: usize,
}

impl<'a> Tag<'a> {
    fn attr(&self, key: &str) -> Option<&'a str> {
        self.attrs.iter().find(|(k, _)| *k == key).map(|(_, v)| *v)
    }
}

/// Every tag of `text` in order; an error gives the byte offset and the reason.
fn scan(text: &str) -> Result<Vec<Tag<'_>>, (usize, String)> {
    let mut tags = Vec::new();
    let b = text.as_bytes();
    let mut i = 0;
    while let Some(off) = text[i..].find('<') {
        let s = i + off;
        let rest = &text[s..];
        let skip_to = |pat: &str| {
            rest.find(pat).map(|e| s + e + pat.len()).ok_or((
                s,
                format!(
                    "unclosed '{}'",
                    short(&rest.chars().take(9).collect::<String>())
                ),
            ))
        };
        if rest.starts_with("<!--") {
            i = skip_to("-->")?;
            continue;
        }
        if rest.starts_with("<![CDATA[") {
            i = skip_to("]]>")?;
            continue;
        }
        if rest.starts_with("<?") {
            i = skip_to("?>")?;
            continue;
        }
        if rest.starts_with("<!") {
            i = skip_to(">")?;
            continue;
        }
        let (kind0, mut j) = if rest.starts_with("</") {
            (Kind::End, s + 2)
        } else {
            (Kind::Start, s + 1)
        };
        let name_start = j;
        while j < b.len() && !b[j].is_ascii_whitespace() && b[j] != b'>' && b[j] != b'/' {
            j += 1;
        }
        let name = &text[name_start..j];
        if name.is_empty() {
            return Err((s, "a tag without a name".into()));
        }
        let mut attrs = Vec::new();
        let mut kind = kind0;
        loop {
            while j < b.len() && b[j].is_ascii_whitespace() {
                j += 1;
            }
            if j >= b.len() {
                return Err((s, format!("unclosed tag <{}", short(name))));
            }
            if b[j] == b'>' {
                j += 1;
                break;
            }
            if b[j] == b'/' && kind == Kind::Start && b.get(j + 1) == Some(&b'>') {
                kind = Kind::Empty;
                j += 2;
                break;
            }
            let k0 = j;
            while j < b.len() && b[j] != b'=' && !b[j].is_ascii_whitespace() && b[j] != b'>' {
                j += 1;
            }
            let key = &text[k0..j];
            while j < b.len() && b[j].is_ascii_whitespace() {
                j += 1;
            }
            if j >= b.len() || b[j] != b'=' {
                return Err((k0, format!("attribute '{}' without a value", short(key))));
            }
            j += 1;
            while j < b.len() && b[j].is_ascii_whitespace() {
                j += 1;
            }
            let q = match b.get(j) {
                Some(&q) if q == b'"' || q == b'\'' => q,
                _ => return Err((k0, format!("attribute '{}' value not quoted", short(key)))),
            };
            let v0 = j + 1;
            let Some(len) = text[v0..].find(q as char) else {
                return Err((k0, format!("attribute '{}' value not closed", short(key))));
            };
            attrs.push((key, &text[v0..v0 + len]));
            j = v0 + len + 1;
        }
        tags.push(Tag {
            name,
            attrs,
            kind,
            start: s,
            end: j,
        });
        i = j;
    }
    Ok(tags)
}

/// One `Piece`: declared counts and the text ranges of its arrays.
#[derive(Default, Debug)]
struct Piece {
    line: usize,
    points: Option<(usize, usize)>,
    connectivity: Option<(usize, usize)>,
    offsets: Option<(usize, usize)>,
    types: Option<(usize, usize)>,
    declared_points: u64,
    declared_cells: u64,
}

/// Reads a VTK XML `.vtu` file with ASCII arrays.
///
/// # Errors
/// Exit status 2, `FILE:LINE: reason`: malformed XML, another file type, binary or appended
/// arrays, missing arrays, array lengths that disagree with the declared counts, bad numbers,
/// node indices out of range, tet cells without 4 points.
pub fn read(path: &Path) -> Result<RawMesh, MeshError> {
    let text = read_text(path, "VTU")?;
    let at = |off: usize, reason: String| {
        MeshError::at(path, Some(line_of(&text, off)), one_line(&reason))
    };
    let tags = scan(&text).map_err(|(off, r)| at(off, format!("malformed XML: {r}")))?;
    let mut stack: Vec<&str> = Vec::new();
    let mut pieces: Vec<Piece> = Vec::new();
    let mut seen_file = false;
    // The open DataArray: (role, content start).
    let mut open: Option<(&'static str, usize)> = None;
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
                        seen_file = true;
                    }
                    "AppendedData" => {
                        return Err(at(
                            tag.start,
                            "appended (binary) VTU data is not supported (write ASCII arrays)"
                                .into(),
                        ));
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
                            _ => None,
                        };
                        if let Some(role) = role {
                            let format = tag.attr("format").unwrap_or("ascii");
                            if format != "ascii" {
                                return Err(at(tag.start, format!("{} VTU data arrays are not supported: binary VTU is not read (write format=\"ascii\")", short(format))));
                            }
                            if role == "points" {
                                let comps = tag.attr("NumberOfComponents").unwrap_or("1");
                                if comps != "3" {
                                    return Err(at(
                                        tag.start,
                                        format!(
                                            "Points has NumberOfComponents=\"{}\", expected 3",
                                            short(comps)
                                        ),
                                    ));
                                }
                            }
                            if tag.kind == Kind::Empty {
                                set(&mut pieces, role, (tag.end, tag.end));
                            } else {
                                open = Some((role, tag.end));
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
                    if let Some((role, from)) = open.take() {
                        set(&mut pieces, role, (from, tag.start));
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
    if let Some(name) = stack.last() {
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
    let mut positions = Vec::new();
    let mut tets = Vec::new();
    let mut tet_lines = Vec::new();
    for piece in &pieces {
        let base = positions.len();
        read_piece(
            path,
            &text,
            piece,
            base,
            &mut positions,
            &mut tets,
            &mut tet_lines,
        )?;
    }
    Ok(RawMesh {
        positions,
        labels: vec![0; tets.len()],
        tets,
        tet_lines,
        label_source: None,
        format: "vtu",
        warnings: Vec::new(),
    })
}

fn set(pieces: &mut [Piece], role: &str, range: (usize, usize)) {
    if let Some(p) = pieces.last_mut() {
        match role {
            "points" => p.points = Some(range),
            "connectivity" => p.connectivity = Some(range),
            "offsets" => p.offsets = Some(range),
            _ => p.types = Some(range),
        }
    }
}

/// A cursor over one array's text, with file line numbers.
fn array<'a>(
    path: &'a Path,
    text: &'a str,
    range: Option<(usize, usize)>,
    what: &str,
    piece_line: usize,
) -> Result<Cursor<'a>, MeshError> {
    let Some((a, b)) = range else {
        return Err(MeshError::at(
            path,
            Some(piece_line),
            format!("this <Piece> has no {what} DataArray"),
        ));
    };
    Ok(Cursor::new(path, &text[a..b], line_of(text, a), None))
}

#[allow(clippy::too_many_arguments)]
fn read_piece(
    path: &Path,
    text: &str,
    piece: &Piece,
    base: usize,
    positions: &mut Vec<[f64; 3]>,
    tets: &mut Vec<[u32; 4]>,
    tet_lines: &mut Vec<usize>,
) -> Result<(), MeshError> {
    let pl = piece.line;
    let mut c = array(path, text, piece.points, "Points", pl)?;
    let mut coords = Vec::new();
    while let Some((t, l)) = c.token() {
        coords.push(parse_float(&c, t, l, "coordinate")?);
    }
    if coords.len() as u64 != piece.declared_points.saturating_mul(3) {
        return Err(c.err(
            pl,
            format!(
                "NumberOfPoints=\"{}\" needs {} coordinates, the Points array has {}",
                piece.declared_points,
                piece.declared_points.saturating_mul(3),
                coords.len()
            ),
        ));
    }
    let nodes = coords.len() / 3;
    positions.extend(coords.chunks_exact(3).map(|p| [p[0], p[1], p[2]]));

    let mut c = array(path, text, piece.offsets, "offsets", pl)?;
    let mut offsets = Vec::new();
    while let Some((t, l)) = c.token() {
        let o = parse_uint(&c, t, l, "an offset")? as usize;
        if offsets.last().is_some_and(|&p| o < p) {
            return Err(c.err(l, "offsets must not decrease"));
        }
        offsets.push(o);
    }
    let mut c = array(path, text, piece.types, "types", pl)?;
    let mut types = Vec::new();
    while let Some((t, l)) = c.token() {
        types.push(parse_uint(&c, t, l, "a cell type")?);
    }
    let mut c = array(path, text, piece.connectivity, "connectivity", pl)?;
    let mut conn = Vec::new();
    while let Some((t, l)) = c.token() {
        conn.push((parse_int(&c, t, l, "a point index")?, l));
    }
    let cells = piece.declared_cells;
    if offsets.len() as u64 != cells || types.len() as u64 != cells {
        return Err(c.err(
            pl,
            format!(
                "NumberOfCells=\"{cells}\" but {} offsets and {} types",
                offsets.len(),
                types.len()
            ),
        ));
    }
    if offsets.last().is_some_and(|&o| o != conn.len()) {
        return Err(c.err(
            pl,
            format!(
                "the last offset is not the connectivity length {}",
                conn.len()
            ),
        ));
    }
    let mut start = 0;
    for (&end, &ty) in offsets.iter().zip(&types) {
        let ids = &conn[start..end];
        start = end;
        if ty != VTK_TETRA {
            continue;
        }
        let line = ids.first().map_or(pl, |x| x.1);
        if ids.len() != 4 {
            return Err(c.err(
                line,
                format!("a tet cell (type 10) with {} points", ids.len()),
            ));
        }
        let mut out = [0u32; 4];
        for (o, &(v, _)) in out.iter_mut().zip(ids) {
            if v < 0 || v as u64 >= nodes as u64 {
                return Err(c.err(
                    line,
                    format!(
                        "point index {v} out of range (points are numbered 0..{})",
                        nodes as i64 - 1
                    ),
                ));
            }
            *o = (v as usize + base) as u32;
        }
        tets.push(out);
        tet_lines.push(line);
    }
    Ok(())
}
