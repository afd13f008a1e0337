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

use std::io::Read;
use std::path::Path;

use base64::Engine;

use super::text::{line_of, one_line, parse_float, parse_int, short, text_from, Cursor};
use super::RawMesh;
use crate::{MeshError, ReadOptions, REGION_ARRAYS};

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

/// A `DataArray` as declared: its attributes and where its data is.
#[derive(Debug, Clone, Default)]
struct Array<'a> {
    name: &'a str,
    ty: &'a str,
    format: &'a str,
    comps: &'a str,
    /// `offset` attribute (appended arrays).
    offset: Option<&'a str>,
    /// Byte offset of the tag in the text.
    tag: usize,
    /// Byte range of the element's content in the text.
    content: (usize, usize),
}

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

/// The compressor named by the `VTKFile` element.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Compressor {
    None,
    Zlib,
    Lz4,
    Lzma,
}

impl Compressor {
    fn name(self) -> &'static str {
        match self {
            Compressor::None => "uncompressed",
            Compressor::Zlib => "zlib",
            Compressor::Lz4 => "lz4",
            Compressor::Lzma => "lzma",
        }
    }
}

/// What every array of the file shares.
struct Ctx<'a> {
    path: &'a Path,
    /// The file up to the appended data (all of it without one), as text.
    text: &'a str,
    big: bool,
    header: usize,
    compressor: Compressor,
    /// The appended data (after its `_` marker), its file offset and whether it is base64.
    appended: Option<(&'a [u8], usize, bool)>,
    /// Every appended array's offset, sorted (a base64 array ends where the next begins).
    appended_offsets: Vec<usize>,
}

/// Numbers of one array.
enum Values {
    Float(Vec<f64>),
    Int(Vec<i64>),
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
/// Exit status 2, `FILE:LINE: reason` (`FILE: byte N: reason` inside raw appended data):
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

/// Bytes per value of a VTK type name, and whether it is a float.
fn type_size(ty: &str) -> Option<(usize, bool)> {
    Some(match ty {
        "Int8" | "UInt8" => (1, false),
        "Int16" | "UInt16" => (2, false),
        "Int32" | "UInt32" => (4, false),
        "Int64" | "UInt64" => (8, false),
        "Float32" => (4, true),
        "Float64" => (8, true),
        _ => return None,
    })
}

/// Decodes base64 made of one or more padded pieces (VTK encodes a compressed array's
/// header and its data separately), whitespace ignored.
fn base64_pieces(s: &[u8]) -> Result<Vec<u8>, String> {
    let clean: Vec<u8> = s
        .iter()
        .copied()
        .filter(|b| !b.is_ascii_whitespace())
        .collect();
    let mut out = Vec::with_capacity(clean.len() / 4 * 3);
    let mut from = 0;
    let mut k = 0;
    while k < clean.len() {
        // A piece ends after the 4-character group that holds padding, or at the end.
        let group_end = (k + 4).min(clean.len());
        if clean[k..group_end].contains(&b'=') || group_end == clean.len() {
            base64::engine::general_purpose::STANDARD
                .decode_vec(&clean[from..group_end], &mut out)
                .map_err(|e| format!("bad base64 data (character {} of the array): {e}", from))?;
            from = group_end;
        }
        k = group_end;
    }
    Ok(out)
}

impl Ctx<'_> {
    /// An error about array `a`, at its line.
    fn err(&self, a: &Array<'_>, reason: impl std::fmt::Display) -> MeshError {
        MeshError::at(
            self.path,
            Some(line_of(self.text, a.tag)),
            one_line(&format!("DataArray '{}': {reason}", short(a.name))),
        )
    }

    /// The values of array `a`.
    fn values(&self, a: &Array<'_>) -> Result<Values, MeshError> {
        self.values_lines(a, None)
    }

    /// The values of array `a`, and for an ASCII array the line of each when `lines` is given.
    fn values_lines(
        &self,
        a: &Array<'_>,
        lines: Option<&mut Vec<usize>>,
    ) -> Result<Values, MeshError> {
        let Some((size, float)) = type_size(a.ty) else {
            return Err(self.err(
                a,
                format!("type \"{}\" is not a VTK number type", short(a.ty)),
            ));
        };
        if a.format == "ascii" {
            return self.ascii(a, float, lines);
        }
        let (bytes, base) = match a.format {
            "binary" => {
                let s = &self.text.as_bytes()[a.content.0..a.content.1];
                (base64_pieces(s).map_err(|e| self.err(a, e))?, None)
            }
            _ => {
                let Some((data, start, b64)) = self.appended else {
                    return Err(
                        self.err(a, "format=\"appended\" but the file has no <AppendedData>")
                    );
                };
                let off: usize = a.offset.and_then(|o| o.parse().ok()).unwrap_or(0);
                if off > data.len() {
                    return Err(self.err(
                        a,
                        format!(
                            "offset {off} is past the end of the appended data ({} bytes)",
                            data.len()
                        ),
                    ));
                }
                if b64 {
                    let end = self
                        .appended_offsets
                        .iter()
                        .find(|&&o| o > off)
                        .copied()
                        .unwrap_or(data.len())
                        .min(data.len());
                    (
                        base64_pieces(&data[off..end]).map_err(|e| self.err(a, e))?,
                        None,
                    )
                } else {
                    (data[off..].to_vec(), Some(start + off))
                }
            }
        };
        let raw = self.block(a, &bytes, base)?;
        if raw.len() % size != 0 {
            return Err(self.err(
                a,
                format!(
                    "{} bytes of data is not a whole number of {size}-byte values",
                    raw.len()
                ),
            ));
        }
        let mut r = crate::binary::Bytes::new(self.path, &raw, 0, self.big);
        let n = raw.len() / size;
        if float {
            let mut v = Vec::with_capacity(n);
            for _ in 0..n {
                v.push(
                    r.float(size, "value")
                        .map_err(|_| self.err(a, "NaN or infinite value"))?,
                );
            }
            Ok(Values::Float(v))
        } else {
            let unsigned = a.ty.starts_with('U');
            let mut v = Vec::with_capacity(n);
            for _ in 0..n {
                let x = match (size, unsigned) {
                    (1, false) => r.take(1, "value")?[0] as i8 as i64,
                    (1, true) => r.take(1, "value")?[0] as i64,
                    (2, _) => {
                        let b = r.take(2, "value")?;
                        let b = [b[0], b[1]];
                        match (self.big, unsigned) {
                            (false, false) => i16::from_le_bytes(b) as i64,
                            (false, true) => u16::from_le_bytes(b) as i64,
                            (true, false) => i16::from_be_bytes(b) as i64,
                            (true, true) => u16::from_be_bytes(b) as i64,
                        }
                    }
                    (4, true) => r.uint(4, "value")? as i64,
                    (4, false) => r.int(4, "value")?,
                    (_, true) => {
                        let u = r.uint(8, "value")?;
                        i64::try_from(u).map_err(|_| self.err(a, format!("value {u} too large")))?
                    }
                    _ => r.int(8, "value")?,
                };
                v.push(x);
            }
            Ok(Values::Int(v))
        }
    }

    /// An ASCII array, and the line of each value when `lines` is given.
    fn ascii(
        &self,
        a: &Array<'_>,
        float: bool,
        mut lines: Option<&mut Vec<usize>>,
    ) -> Result<Values, MeshError> {
        let (s, e) = a.content;
        let mut c = Cursor::new(self.path, &self.text[s..e], line_of(self.text, s), None);
        if float {
            let mut v = Vec::new();
            while let Some((t, l)) = c.token() {
                v.push(parse_float(&c, t, l, "a number")?);
            }
            Ok(Values::Float(v))
        } else {
            let mut v = Vec::new();
            while let Some((t, l)) = c.token() {
                v.push(parse_int(&c, t, l, "an integer")?);
                if let Some(lines) = lines.as_deref_mut() {
                    lines.push(l);
                }
            }
            Ok(Values::Int(v))
        }
    }

    /// One binary array's data: its size header and data, or its block table and the
    /// decompressed blocks. `base` is the file offset of `bytes` for raw appended data.
    fn block(
        &self,
        a: &Array<'_>,
        bytes: &[u8],
        base: Option<usize>,
    ) -> Result<Vec<u8>, MeshError> {
        let path = self.path;
        let mut r = crate::binary::Bytes::new(path, bytes, base.unwrap_or(0), self.big);
        // Errors inside inline data name the array's line; inside raw appended data, the byte.
        // Errors from the cursor read `FILE: byte N: reason`: inside raw appended data they
        // keep the byte and gain the array's name; inside inline data they name the array's
        // line and the byte of the decoded data.
        let wrap = |e: MeshError, r: &crate::binary::Bytes<'_>| {
            let m = &e.message;
            let (off, reason) = m
                .find(": byte ")
                .and_then(|i| m[i + 7..].split_once(": "))
                .map_or(("", m.as_str()), |(o, r)| (o, r));
            match (base, off.parse::<u64>()) {
                (Some(_), Ok(off)) => MeshError::at_byte(
                    path,
                    off,
                    format!("DataArray '{}': {reason}", short(a.name)),
                ),
                _ => self.err(
                    a,
                    format!("{reason} (at byte {} of the decoded data)", r.offset()),
                ),
            }
        };
        let h = self.header;
        if self.compressor == Compressor::None {
            let n = r.uint(h, "the data size header").map_err(|e| wrap(e, &r))?;
            let n = usize::try_from(n).unwrap_or(usize::MAX);
            return match r.take(n, "the array data") {
                Ok(d) => Ok(d.to_vec()),
                Err(e) => Err(wrap(e, &r)),
            };
        }
        let table = (|| {
            let nb = r.uint(h, "the number of compressed blocks")?;
            let bs = r.uint(h, "the block size")?;
            let last = r.uint(h, "the last block size")?;
            let nb = r.count(nb, h, "compressed blocks")?;
            let mut sizes = Vec::with_capacity(nb);
            for _ in 0..nb {
                sizes.push(r.uint(h, "a compressed block size")?);
            }
            Ok((nb, bs, last, sizes))
        })();
        let (nb, bs, last, sizes) = table.map_err(|e| wrap(e, &r))?;
        let total: u64 = sizes.iter().fold(0u64, |s, &x| s.saturating_add(x));
        if total > r.remaining() as u64 {
            return Err(wrap(
                r.err(format!(
                    "the {nb} compressed blocks claim {total} bytes, {} are left (truncated?)",
                    r.remaining()
                )),
                &r,
            ));
        }
        let mut out = Vec::new();
        for (k, &cs) in sizes.iter().enumerate() {
            let at = r.offset();
            let comp = r
                .take(cs as usize, "a compressed block")
                .map_err(|e| wrap(e, &r))?;
            let want = if k + 1 == nb && last != 0 { last } else { bs };
            let got = decompress(self.compressor, comp, want).map_err(|why| {
                let what = format!(
                    "{} block {} of {nb} (compressed bytes {at}..{}): {why}",
                    self.compressor.name(),
                    k + 1,
                    at + cs as usize
                );
                match base {
                    Some(_) => MeshError::at_byte(
                        path,
                        at as u64,
                        one_line(&format!("DataArray '{}': {what}", short(a.name))),
                    ),
                    None => self.err(a, what),
                }
            })?;
            out.extend_from_slice(&got);
        }
        Ok(out)
    }
}

/// Decompresses one block that must expand to exactly `want` bytes. The output grows with
/// what the block really holds (LZ4, which needs its size first, is checked against the
/// format's largest ratio before anything is allocated).
fn decompress(c: Compressor, comp: &[u8], want: u64) -> Result<Vec<u8>, String> {
    let mut out = Vec::new();
    match c {
        Compressor::None => out.extend_from_slice(comp),
        Compressor::Zlib => {
            flate2::read::ZlibDecoder::new(comp)
                .take(want.saturating_add(1))
                .read_to_end(&mut out)
                .map_err(|e| format!("corrupt zlib data: {e}"))?;
        }
        Compressor::Lz4 => {
            // An LZ4 block expands at most 255 times (plus a little).
            if want > (comp.len() as u64).saturating_mul(255).saturating_add(16) {
                return Err(format!(
                    "claims {want} bytes from {} compressed, more than LZ4 can hold",
                    comp.len()
                ));
            }
            out = lz4_flex::block::decompress(comp, want as usize)
                .map_err(|e| format!("corrupt lz4 data: {e}"))?;
        }
        Compressor::Lzma => {
            // The decoder holds a whole LZMA2 run in memory before handing it on: the sizes
            // the chunk headers declare are checked against the table first.
            match xz_declared_size(comp) {
                Some(n) if n <= want => {}
                Some(n) => {
                    return Err(format!(
                        "its xz chunks declare {n} bytes, the block table says {want}"
                    ))
                }
                None => return Err("not an xz stream of LZMA2 chunks (truncated?)".into()),
            }
            let mut input = comp;
            let mut w = Limited {
                out: &mut out,
                limit: want,
            };
            lzma_rs::xz_decompress(&mut input, &mut w)
                .map_err(|e| format!("corrupt lzma (xz) data: {e}"))?;
        }
    }
    if out.len() as u64 != want {
        return Err(format!(
            "expands to {}{} bytes, the block table says {want}",
            out.len(),
            if out.len() as u64 > want {
                " or more"
            } else {
                ""
            }
        ));
    }
    Ok(out)
}

/// The uncompressed size that the LZMA2 chunk headers of an xz stream declare, read without
/// decoding (stream header, then per block: its header, the chunks, padding and check, until
/// the index); `None` when the bytes are not laid out so.
fn xz_declared_size(x: &[u8]) -> Option<u64> {
    if x.len() < 12 || &x[..6] != b"\xFD7zXZ\x00" {
        return None;
    }
    let check = match x[7] & 0x0f {
        0 => 0,
        id => 4usize << ((id - 1) / 3),
    };
    let be16 = |p: usize| Some(u16::from_be_bytes([*x.get(p)?, *x.get(p + 1)?]) as u64);
    let mut p = 12usize;
    let mut total = 0u64;
    loop {
        let block = p;
        let h = *x.get(p)?;
        if h == 0 {
            // The index: no more blocks.
            return Some(total);
        }
        p = p.checked_add((h as usize + 1) * 4)?;
        loop {
            let c = *x.get(p)?;
            p += 1;
            match c {
                0 => break,
                1 | 2 => {
                    let n = be16(p)? + 1;
                    total = total.checked_add(n)?;
                    p = p.checked_add(2 + n as usize)?;
                }
                0x80..=0xff => {
                    let unpacked = (((c & 0x1f) as u64) << 16) + be16(p)? + 1;
                    let packed = be16(p + 2)? as usize + 1;
                    total = total.checked_add(unpacked)?;
                    p = p.checked_add(4 + usize::from(c >= 0xc0) + packed)?;
                }
                _ => return None,
            }
        }
        // Block padding to a multiple of four, then the check.
        p = p
            .checked_add((4 - (p - block) % 4) % 4)?
            .checked_add(check)?;
    }
}

/// A writer that refuses to grow past `limit` bytes.
struct Limited<'a> {
    out: &'a mut Vec<u8>,
    limit: u64,
}

impl std::io::Write for Limited<'_> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        if self.out.len() as u64 + buf.len() as u64 > self.limit {
            return Err(std::io::Error::other("more data than the block table says"));
        }
        self.out.extend_from_slice(buf);
        Ok(buf.len())
    }

    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
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

#[cfg(test)]
mod tests {
    use super::*;

    /// An xz stream as Python's `lzma.compress(bytes(1000), format=lzma.FORMAT_XZ)` writes it
    /// (the framing of VTK's LZMA compressor): 1000 zero bytes.
    const ZEROS_1000: &[u8] = &[
        0xfd, 0x37, 0x7a, 0x58, 0x5a, 0x00, 0x00, 0x04, 0xe6, 0xd6, 0xb4, 0x46, 0x02, 0x00, 0x21,
        0x01, 0x16, 0x00, 0x00, 0x00, 0x74, 0x2f, 0xe5, 0xa3, 0xe0, 0x03, 0xe7, 0x00, 0x0b, 0x5d,
        0x00, 0x00, 0x6f, 0xfd, 0xff, 0xff, 0xa3, 0xb7, 0x5a, 0x0d, 0x5e, 0x00, 0x00, 0x00, 0x4f,
        0x25, 0x8a, 0xec, 0x2b, 0xe2, 0x2a, 0x37, 0x00, 0x01, 0x27, 0xe8, 0x07, 0x00, 0x00, 0x00,
        0xf4, 0x55, 0x8f, 0x5c, 0xb1, 0xc4, 0x67, 0xfb, 0x02, 0x00, 0x00, 0x00, 0x00, 0x04, 0x59,
        0x5a,
    ];

    #[test]
    fn xz_chunk_sizes_are_read_before_decoding() {
        assert_eq!(xz_declared_size(ZEROS_1000), Some(1000));
        let out = decompress(Compressor::Lzma, ZEROS_1000, 1000).unwrap();
        assert_eq!(out, vec![0u8; 1000]);
        // A table that says less than the chunks hold: refused before anything is decoded.
        let e = decompress(Compressor::Lzma, ZEROS_1000, 999).unwrap_err();
        assert!(e.contains("declare 1000 bytes"), "{e}");
        // Cut anywhere: refused, never a panic.
        for cut in 0..ZEROS_1000.len() {
            assert!(decompress(Compressor::Lzma, &ZEROS_1000[..cut], 1000).is_err());
        }
    }
}
