//! Gmsh `.msh`, versions 2.x (2.2) and 4.1, ASCII here and binary in `gmsh_binary`. `$Nodes`
//! and `$Elements` are read; 4-node tets (element type 4) are kept with their physical tag as
//! region label (2.2: the first element tag; 4.1: the first physical tag of the volume entity
//! in `$Entities`), other element types are skipped (a warning names the skipped 3-D ones);
//! other sections are skipped. Version 4.0 is refused.

use std::collections::HashMap;
use std::path::Path;

use super::text::{parse_int, parse_uint, parse_xyz, short, text_from, Cursor};
use super::RawMesh;
use crate::MeshError;

/// Gmsh element type of the 4-node tetrahedron.
pub(crate) const TET4: u64 = 4;
/// Gmsh element types with a volume (hexahedra, prisms, pyramids, high-order tets, ...).
pub(crate) const VOLUME_TYPES: &[u64] = &[5, 6, 7, 11, 12, 13, 14, 17, 18, 19, 29, 30, 31, 92, 93];

#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum Version {
    V2,
    V41,
}

/// What is read so far, by the ASCII reader here and the binary one (`gmsh_binary`): `at` is
/// a line for the one and a byte offset for the other.
#[derive(Default)]
pub(crate) struct State {
    /// Node tag -> index into `positions`.
    pub(crate) ids: HashMap<u64, u32>,
    pub(crate) positions: Vec<[f64; 3]>,
    /// Tets as node tags, with where they were read (`at`).
    pub(crate) tets: Vec<([u64; 4], usize)>,
    /// The physical tag of each tet (0 without one).
    pub(crate) labels: Vec<i32>,
    /// Some tet has a physical tag.
    pub(crate) has_physical: bool,
    /// Volume entity tag -> its first physical tag (4.1 `$Entities`).
    pub(crate) volume_physical: HashMap<i64, i32>,
    pub(crate) skipped_volume: usize,
    pub(crate) nodes_seen: bool,
    pub(crate) elements_seen: bool,
}

impl State {
    /// Adds node `tag`; `Err(())` when the tag was listed before.
    pub(crate) fn add_node(&mut self, tag: u64, xyz: [f64; 3]) -> Result<(), ()> {
        let idx = self.positions.len() as u32;
        if self.ids.insert(tag, idx).is_some() {
            return Err(());
        }
        self.positions.push(xyz);
        Ok(())
    }

    /// Keeps an element of type `etype` read at `at` if it is a 4-node tet (`tags`, its
    /// first four node tags), counts it if it is another volume element, and drops the rest.
    pub(crate) fn element(&mut self, etype: u64, tags: [u64; 4], physical: Option<i32>, at: usize) {
        if etype != TET4 {
            if VOLUME_TYPES.contains(&etype) {
                self.skipped_volume += 1;
            }
            return;
        }
        self.tets.push((tags, at));
        self.labels.push(physical.unwrap_or(0));
        self.has_physical |= physical.is_some();
    }

    /// The mesh read: tets by node index (`err(at, reason)` for a tag not in `$Nodes`), each
    /// tet's line when `lines`, a warning for skipped volume elements.
    pub(crate) fn finish(
        self,
        path: &Path,
        format: &'static str,
        lines: bool,
        err: impl Fn(usize, String) -> MeshError,
    ) -> Result<RawMesh, MeshError> {
        if !self.nodes_seen {
            return Err(MeshError::at(path, None, "no $Nodes section"));
        }
        if !self.elements_seen {
            return Err(MeshError::at(path, None, "no $Elements section"));
        }
        let mut tets = Vec::with_capacity(self.tets.len());
        let mut tet_lines = Vec::with_capacity(self.tets.len());
        for (tags, at) in &self.tets {
            let mut ids = [0u32; 4];
            for (id, tag) in ids.iter_mut().zip(tags) {
                *id = *self.ids.get(tag).ok_or_else(|| {
                    err(
                        *at,
                        format!("node {tag} out of range: it is not listed in $Nodes"),
                    )
                })?;
            }
            tets.push(ids);
            tet_lines.push(if lines { *at } else { 0 });
        }
        let mut warnings = Vec::new();
        if self.skipped_volume > 0 {
            warnings.push(format!(
                "{}: {} volume elements that are not 4-node tets skipped",
                path.display(),
                self.skipped_volume
            ));
        }
        Ok(RawMesh {
            labels: self.labels,
            positions: self.positions,
            tets,
            tet_lines,
            label_source: self.has_physical.then(|| "Gmsh physical tags".to_string()),
            format,
            warnings,
        })
    }
}

/// Reads a Gmsh `.msh` file (ASCII 2.x or 4.1).
///
/// # Errors
/// Bad input ([`crate::MeshErrorKind::Input`]), `FILE:LINE: reason`: binary files, unsupported versions, truncated sections,
/// counts larger than the file, bad numbers, unknown or duplicated node tags, no tets.
pub fn read(path: &Path) -> Result<RawMesh, MeshError> {
    let bytes = crate::source::read_file(path)?;
    if let Some((v41, size, start)) = binary_header(path, &bytes)? {
        return crate::gmsh_binary::read(path, &bytes, v41, size, start);
    }
    let text = text_from(path, bytes, "Gmsh")?;
    let mut c = Cursor::new(path, &text, 1, None);
    let mut version = None;
    let mut st = State::default();
    while let Some((line, t)) = c.line() {
        let Some(section) = t[0].strip_prefix('$') else {
            return Err(c.err(
                line,
                format!("expected a $Section, found '{}'", short(t[0])),
            ));
        };
        if version.is_none() && section != "MeshFormat" {
            return Err(c.err(
                line,
                "not a Gmsh 2.2 or 4.1 file: $MeshFormat must come first (Gmsh 1 files are not read)",
            ));
        }
        match section {
            "MeshFormat" => {
                let (l, f) = c.need_line("the mesh format line")?;
                if f.len() < 3 {
                    return Err(c.err(l, "expected 'version file-type data-size'"));
                }
                if f[1] != "0" {
                    return Err(c.err(
                        l,
                        format!("file-type {} is not 0 (ASCII) or 1 (binary)", short(f[1])),
                    ));
                }
                version = Some(match f[0] {
                    "2" | "2.0" | "2.1" | "2.2" => Version::V2,
                    "4.1" => Version::V41,
                    v => {
                        return Err(c.err(
                            l,
                            format!(
                                "Gmsh version {} is not supported (2.2 and 4.1 are read)",
                                short(v)
                            ),
                        ))
                    }
                });
                skip_to_end(&mut c, section)?;
            }
            "Nodes" | "Elements" => {
                let Some(v) = version else {
                    return Err(c.err(
                        line,
                        "no $MeshFormat before this section (Gmsh 1 files are not read)",
                    ));
                };
                match (section, v) {
                    ("Nodes", Version::V2) => nodes_v2(&mut c, &mut st)?,
                    ("Nodes", Version::V41) => nodes_v41(&mut c, &mut st)?,
                    (_, Version::V2) => elements_v2(&mut c, &mut st)?,
                    (_, Version::V41) => elements_v41(&mut c, &mut st)?,
                }
                let (l, end) = c.need_line(&format!("$End{section}"))?;
                if end[0] != format!("$End{section}") {
                    return Err(c.err(
                        l,
                        format!(
                            "expected $End{section}, found '{}' (more records than declared?)",
                            short(end[0])
                        ),
                    ));
                }
            }
            "Entities" if version == Some(Version::V41) => {
                entities_v41(&mut c, &mut st)?;
                skip_to_end(&mut c, section)?;
            }
            _ => skip_to_end(&mut c, section)?,
        }
    }
    if version.is_none() {
        return Err(MeshError::at(
            path,
            None,
            "not a Gmsh file: no $MeshFormat section",
        ));
    }
    let format = match version {
        Some(Version::V41) => "gmsh 4.1",
        _ => "gmsh 2.2",
    };
    st.finish(path, format, true, |line, reason| c.err(line, reason))
}

/// For a binary file (file-type 1 on the format line): whether it is 4.1, its data size and
/// the offset after the format line. `None` for a text file.
fn binary_header(path: &Path, bytes: &[u8]) -> Result<Option<(bool, usize, usize)>, MeshError> {
    let mut b = crate::binary::Bytes::new(path, bytes, 0, false);
    b.skip_space();
    if b.line().map(|l| l.trim_ascii()) != Some(b"$MeshFormat") {
        return Ok(None);
    }
    let at = b.offset();
    let Some(line) = b.line() else {
        return Ok(None);
    };
    let f: Vec<&[u8]> = line
        .split(|c| c.is_ascii_whitespace())
        .filter(|t| !t.is_empty())
        .collect();
    if f.len() < 3 || f[1] != b"1" {
        return Ok(None);
    }
    let v41 = match f[0] {
        b"2" | b"2.0" | b"2.1" | b"2.2" => false,
        b"4.1" => true,
        v => {
            return Err(b.err_at(
                at,
                format!(
                    "Gmsh version {} is not supported (2.2 and 4.1 are read)",
                    crate::binary::show(v)
                ),
            ))
        }
    };
    let size = match (v41, f[2]) {
        (true, b"8") => 8,
        (true, b"4") => 4,
        (false, b"8") => 8,
        (_, s) => {
            return Err(b.err_at(
                at,
                format!(
                    "data size {} is not supported (8, or 4 for 4.1 size_t)",
                    crate::binary::show(s)
                ),
            ))
        }
    };
    Ok(Some((v41, size, b.offset())))
}

/// Skips lines up to and including `$End<section>`.
fn skip_to_end(c: &mut Cursor<'_>, section: &str) -> Result<(), MeshError> {
    let end = format!("$End{section}");
    loop {
        let (_, t) = c.need_line(&end)?;
        if t[0] == end {
            return Ok(());
        }
    }
}

/// Numbers of a header line.
fn header<const N: usize>(c: &mut Cursor<'_>, what: &str) -> Result<(usize, [u64; N]), MeshError> {
    let (l, t) = c.need_line(what)?;
    if t.len() < N {
        return Err(c.err(l, format!("expected {N} numbers in {what}")));
    }
    let mut out = [0u64; N];
    for (o, s) in out.iter_mut().zip(&t) {
        *o = parse_uint(c, s, l, what)?;
    }
    Ok((l, out))
}

fn add_node(
    c: &Cursor<'_>,
    st: &mut State,
    tag: u64,
    xyz: [f64; 3],
    line: usize,
) -> Result<(), MeshError> {
    st.add_node(tag, xyz)
        .map_err(|()| c.err(line, format!("node {tag} is listed twice")))
}

fn nodes_v2(c: &mut Cursor<'_>, st: &mut State) -> Result<(), MeshError> {
    let (hl, [n]) = header::<1>(c, "the number of nodes")?;
    let n = c.count(n, 4, "nodes", hl)?;
    st.nodes_seen = true;
    for k in 0..n {
        let (l, t) = c.need_line(&format!("node {} of {n}", k + 1))?;
        if t.len() < 4 {
            return Err(c.err(l, "expected 'tag x y z'"));
        }
        let tag = parse_uint(c, t[0], l, "a node tag")?;
        let xyz = parse_xyz(c, &t[1..4], l)?;
        add_node(c, st, tag, xyz, l)?;
    }
    Ok(())
}

fn nodes_v41(c: &mut Cursor<'_>, st: &mut State) -> Result<(), MeshError> {
    let (hl, [blocks, n, _, _]) = header::<4>(c, "the $Nodes header")?;
    let n = c.count(n, 4, "nodes", hl)?;
    let blocks = c.count(blocks, 4, "node blocks", hl)?;
    st.nodes_seen = true;
    let mut total = 0usize;
    for _ in 0..blocks {
        let (bl, [_dim, _tag, _param, m]) = header::<4>(c, "a node block header")?;
        let m = c.count(m, 4, "nodes", bl)?;
        total += m;
        if total > n {
            return Err(c.err(
                bl,
                format!("node blocks hold more than the {n} nodes declared"),
            ));
        }
        let mut tags = Vec::with_capacity(m);
        for k in 0..m {
            let (l, t) = c.need_line(&format!("node tag {} of {m}", k + 1))?;
            tags.push((parse_uint(c, t[0], l, "a node tag")?, l));
        }
        for (k, &(tag, tag_line)) in tags.iter().enumerate() {
            let (l, t) = c.need_line(&format!("coordinates of node {} of {m}", k + 1))?;
            if t.len() < 3 {
                return Err(c.err(l, "expected 'x y z'"));
            }
            let xyz = parse_xyz(c, &t[..3], l)?;
            add_node(c, st, tag, xyz, tag_line)?;
        }
    }
    if total != n {
        return Err(c.err(hl, format!("declares {n} nodes, the blocks hold {total}")));
    }
    Ok(())
}

/// The volume entities' physical tags from an ASCII 4.1 `$Entities` section: `numPoints
/// numCurves numSurfaces numVolumes`, then per entity `tag`, a bounding box (3 numbers for a
/// point, 6 otherwise), `numPhysicalTags tags...` and, past points, `numBounding tags...`.
fn entities_v41(c: &mut Cursor<'_>, st: &mut State) -> Result<(), MeshError> {
    let (hl, counts) = header::<4>(c, "the $Entities header")?;
    for (dim, &n) in counts.iter().enumerate() {
        let n = c.count(n, 5, "entities", hl)?;
        for _ in 0..n {
            let (t, l) = c.need("an entity tag")?;
            let tag = parse_int(c, t, l, "an entity tag")?;
            for _ in 0..if dim == 0 { 3 } else { 6 } {
                c.float("a bounding box coordinate")?;
            }
            let (np, npl) = c.uint("the number of physical tags")?;
            let np = c.count(np, 1, "physical tags", npl)?;
            for k in 0..np {
                let (t, l) = c.need("a physical tag")?;
                let v = parse_int(c, t, l, "a physical tag")?;
                let v = i32::try_from(v)
                    .map_err(|_| c.err(l, format!("physical tag {v} does not fit 32 bits")))?;
                if dim == 3 && k == 0 {
                    st.volume_physical.insert(tag, v);
                }
            }
            if dim > 0 {
                let (nb, nbl) = c.uint("the number of bounding entities")?;
                let nb = c.count(nb, 1, "bounding entities", nbl)?;
                for _ in 0..nb {
                    let (t, l) = c.need("a bounding entity tag")?;
                    parse_int(c, t, l, "a bounding entity tag")?;
                }
            }
        }
    }
    Ok(())
}

/// Keeps one element if it is a 4-node tet: `nodes` are its node tags, `physical` its
/// physical tag when it has one.
fn element(
    c: &Cursor<'_>,
    st: &mut State,
    etype: u64,
    nodes: &[&str],
    physical: Option<i32>,
    line: usize,
) -> Result<(), MeshError> {
    let mut tags = [0u64; 4];
    if etype == TET4 {
        if nodes.len() < 4 {
            return Err(c.err(line, "a tet (type 4) needs 4 node tags"));
        }
        for (tag, s) in tags.iter_mut().zip(nodes) {
            *tag = parse_uint(c, s, line, "a node tag")?;
        }
    }
    st.element(etype, tags, physical, line);
    Ok(())
}

fn elements_v2(c: &mut Cursor<'_>, st: &mut State) -> Result<(), MeshError> {
    let (hl, [n]) = header::<1>(c, "the number of elements")?;
    let n = c.count(n, 4, "elements", hl)?;
    st.elements_seen = true;
    for k in 0..n {
        let (l, t) = c.need_line(&format!("element {} of {n}", k + 1))?;
        if t.len() < 3 {
            return Err(c.err(l, "expected 'tag type tag-count tags... nodes...'"));
        }
        let etype = parse_uint(c, t[1], l, "an element type")?;
        let ntags = parse_uint(c, t[2], l, "a tag count")?;
        let first = usize::try_from(ntags)
            .unwrap_or(usize::MAX)
            .saturating_add(3);
        if first > t.len() {
            return Err(c.err(
                l,
                format!("element declares {ntags} tags but the line is shorter"),
            ));
        }
        let physical = if ntags > 0 {
            let v = parse_int(c, t[3], l, "a physical tag")?;
            Some(
                i32::try_from(v)
                    .map_err(|_| c.err(l, format!("physical tag {v} does not fit 32 bits")))?,
            )
        } else {
            None
        };
        element(c, st, etype, &t[first..], physical, l)?;
    }
    Ok(())
}

fn elements_v41(c: &mut Cursor<'_>, st: &mut State) -> Result<(), MeshError> {
    let (hl, [blocks, n, _, _]) = header::<4>(c, "the $Elements header")?;
    let n = c.count(n, 2, "elements", hl)?;
    let blocks = c.count(blocks, 4, "element blocks", hl)?;
    st.elements_seen = true;
    let mut total = 0usize;
    for _ in 0..blocks {
        let (bl, t) = c.need_line("an element block header")?;
        if t.len() < 4 {
            return Err(c.err(bl, "expected 4 numbers in an element block header"));
        }
        let dim = parse_uint(c, t[0], bl, "an entity dimension")?;
        let tag = parse_int(c, t[1], bl, "an entity tag")?;
        let etype = parse_uint(c, t[2], bl, "an element type")?;
        let m = parse_uint(c, t[3], bl, "the number of elements")?;
        let physical = if dim == 3 {
            st.volume_physical.get(&tag).copied()
        } else {
            None
        };
        let m = c.count(m, 2, "elements", bl)?;
        total += m;
        if total > n {
            return Err(c.err(
                bl,
                format!("element blocks hold more than the {n} elements declared"),
            ));
        }
        for k in 0..m {
            let (l, t) = c.need_line(&format!("element {} of {m}", k + 1))?;
            if t.len() < 2 {
                return Err(c.err(l, "expected 'tag node-tags...'"));
            }
            element(c, st, etype, &t[1..], physical, l)?;
        }
    }
    if total != n {
        return Err(c.err(
            hl,
            format!("declares {n} elements, the blocks hold {total}"),
        ));
    }
    Ok(())
}
