//! Gmsh `.msh` ASCII, versions 2.x (2.2) and 4.1. `$Nodes` and `$Elements` are read; 4-node
//! tets (element type 4) are kept, other element types are skipped (a warning names the
//! skipped 3-D ones); other sections are skipped. Binary files and version 4.0 are refused.

use std::collections::HashMap;
use std::path::Path;

use super::text::{parse_uint, parse_xyz, read_text, short, Cursor};
use super::RawMesh;
use crate::MeshError;

/// Gmsh element type of the 4-node tetrahedron.
const TET4: u64 = 4;
/// Gmsh element types with a volume (hexahedra, prisms, pyramids, high-order tets, ...).
const VOLUME_TYPES: &[u64] = &[5, 6, 7, 11, 12, 13, 14, 17, 18, 19, 29, 30, 31, 92, 93];

#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum Version {
    V2,
    V41,
}

/// What is read so far.
#[derive(Default)]
struct State {
    /// Node tag -> index into `positions`.
    ids: HashMap<u64, u32>,
    positions: Vec<[f64; 3]>,
    /// Tets as node tags, with their lines.
    tets: Vec<([u64; 4], usize)>,
    skipped_volume: usize,
    nodes_seen: bool,
    elements_seen: bool,
}

/// Reads a Gmsh `.msh` file (ASCII 2.x or 4.1).
///
/// # Errors
/// Exit status 2, `FILE:LINE: reason`: binary files, unsupported versions, truncated sections,
/// counts larger than the file, bad numbers, unknown or duplicated node tags, no tets.
pub fn read(path: &Path) -> Result<RawMesh, MeshError> {
    let text = read_text(path, "Gmsh")?;
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
                    return Err(c.err(l, "binary Gmsh files are not supported (save as ASCII)"));
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
    if !st.nodes_seen {
        return Err(MeshError::at(path, None, "no $Nodes section"));
    }
    if !st.elements_seen {
        return Err(MeshError::at(path, None, "no $Elements section"));
    }
    let mut tets = Vec::with_capacity(st.tets.len());
    let mut tet_lines = Vec::with_capacity(st.tets.len());
    for (tags, line) in &st.tets {
        let mut ids = [0u32; 4];
        for (id, tag) in ids.iter_mut().zip(tags) {
            *id = *st.ids.get(tag).ok_or_else(|| {
                c.err(
                    *line,
                    format!("node {tag} out of range: it is not listed in $Nodes"),
                )
            })?;
        }
        tets.push(ids);
        tet_lines.push(*line);
    }
    let mut warnings = Vec::new();
    if st.skipped_volume > 0 {
        warnings.push(format!(
            "{}: {} volume elements that are not 4-node tets skipped",
            path.display(),
            st.skipped_volume
        ));
    }
    let format = match version {
        Some(Version::V41) => "gmsh 4.1",
        _ => "gmsh 2.2",
    };
    Ok(RawMesh {
        labels: vec![0; tets.len()],
        positions: st.positions,
        tets,
        tet_lines,
        label_source: None,
        format,
        warnings,
    })
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
    let idx = st.positions.len() as u32;
    if st.ids.insert(tag, idx).is_some() {
        return Err(c.err(line, format!("node {tag} is listed twice")));
    }
    st.positions.push(xyz);
    Ok(())
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

/// Keeps one element if it is a 4-node tet: `nodes` are its node tags.
fn element(
    c: &Cursor<'_>,
    st: &mut State,
    etype: u64,
    nodes: &[&str],
    line: usize,
) -> Result<(), MeshError> {
    if etype != TET4 {
        if VOLUME_TYPES.contains(&etype) {
            st.skipped_volume += 1;
        }
        return Ok(());
    }
    if nodes.len() < 4 {
        return Err(c.err(line, "a tet (type 4) needs 4 node tags"));
    }
    let mut tags = [0u64; 4];
    for (tag, s) in tags.iter_mut().zip(nodes) {
        *tag = parse_uint(c, s, line, "a node tag")?;
    }
    st.tets.push((tags, line));
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
        element(c, st, etype, &t[first..], l)?;
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
        let (bl, [_dim, _tag, etype, m]) = header::<4>(c, "an element block header")?;
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
            element(c, st, etype, &t[1..], l)?;
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
