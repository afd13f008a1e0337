//! Gmsh `.msh` binary (file-type 1), versions 2.2 and 4.1: the section names and the 2.2
//! counts are text lines, the records binary in the byte order of the writing machine (told
//! by the integer 1 after the format line). 4-node tets are kept with their physical tags
//! (2.2: the first element tag; 4.1: the first physical tag of the volume entity in
//! `$Entities`); other element types are skipped, other sections passed over.

use std::path::Path;

use crate::binary::{show, Bytes};
use crate::gmsh::State;
use crate::{MeshError, RawMesh};

/// Nodes per element of the Gmsh element types (`None`: a type this reader does not know,
/// whose records it cannot step over).
fn nodes_per_element(t: i64) -> Option<usize> {
    Some(match t {
        1 => 2,
        2 => 3,
        3 | 4 => 4,
        5 => 8,
        6 => 6,
        7 => 5,
        8 => 3,
        9 => 6,
        10 => 9,
        11 => 10,
        12 => 27,
        13 => 18,
        14 => 14,
        15 => 1,
        16 => 8,
        17 => 20,
        18 => 15,
        19 => 13,
        20 => 9,
        21 => 10,
        22 => 12,
        23 => 15,
        24 => 15,
        25 => 21,
        26 => 4,
        27 => 5,
        28 => 6,
        29 => 20,
        30 => 35,
        31 => 56,
        92 => 64,
        93 => 125,
        _ => return None,
    })
}

/// Reads a binary Gmsh file; `v41` for 4.1 (else 2.2), `size` the declared data size
/// (`sizeof(size_t)` for 4.1: 4 or 8), `start` the offset after the format line.
pub(crate) fn read(
    path: &Path,
    data: &[u8],
    v41: bool,
    size: usize,
    start: usize,
) -> Result<RawMesh, MeshError> {
    let mut b = Bytes::new(path, &data[start..], start, false);
    // The integer 1, in the writer's byte order.
    let one = b.take(4, "the byte-order integer 1")?;
    b.big = match one {
        [1, 0, 0, 0] => false,
        [0, 0, 0, 1] => true,
        _ => {
            return Err(b.err_at(
                start,
                format!(
                "expected the integer 1 (byte order) after the format line, found bytes {one:02x?}"
            ),
            ))
        }
    };
    end_of(&mut b, "MeshFormat")?;
    let mut st = State::default();
    loop {
        b.skip_space();
        let at = b.offset();
        let Some(line) = b.line() else { break };
        let Some(section) = line.strip_prefix(b"$") else {
            return Err(b.err_at(at, format!("expected a $Section, found '{}'", show(line))));
        };
        let section = String::from_utf8_lossy(section).trim().to_string();
        match section.as_str() {
            "Nodes" if v41 => nodes_v41(&mut b, &mut st, size)?,
            "Nodes" => nodes_v2(&mut b, &mut st)?,
            "Elements" if v41 => elements_v41(&mut b, &mut st, size)?,
            "Elements" => elements_v2(&mut b, &mut st)?,
            "Entities" if v41 => entities_v41(&mut b, &mut st, size)?,
            _ => {
                skip_to_end(&mut b, &section)?;
                continue;
            }
        }
        end_of(&mut b, &section)?;
    }
    let format = if v41 {
        "gmsh 4.1 binary"
    } else {
        "gmsh 2.2 binary"
    };
    st.finish(path, format, false, |at, reason| b.err_at(at, reason))
}

/// Skips whitespace and reads the `$End<section>` line.
fn end_of(b: &mut Bytes<'_>, section: &str) -> Result<(), MeshError> {
    b.skip_space();
    let at = b.offset();
    let want = format!("$End{section}");
    match b.line() {
        Some(l) if l.trim_ascii() == want.as_bytes() => Ok(()),
        Some(l) => Err(b.err_at(
            at,
            format!(
                "expected {want}, found '{}' (more records than declared?)",
                show(l)
            ),
        )),
        None => Err(b.err_at(
            at,
            format!("unexpected end of file (truncated?): expected {want}"),
        )),
    }
}

/// Passes over a section this reader does not use, up to and including `$End<section>`.
fn skip_to_end(b: &mut Bytes<'_>, section: &str) -> Result<(), MeshError> {
    let want = format!("\n$End{section}");
    let rest = b.rest();
    match rest.windows(want.len()).position(|w| w == want.as_bytes()) {
        Some(i) => {
            b.take(i + 1, "a skipped section")?;
            end_of(b, section)
        }
        None => Err(b.err(format!(
            "unexpected end of file (truncated?): no $End{section}"
        ))),
    }
}

/// A text line holding one count (2.2 binary sections start with one).
fn count_line(b: &mut Bytes<'_>, what: &str) -> Result<u64, MeshError> {
    b.skip_space();
    let at = b.offset();
    let line = b.line().unwrap_or_default();
    let s = String::from_utf8_lossy(line);
    s.trim()
        .parse::<u64>()
        .map_err(|_| b.err_at(at, format!("expected {what}, found '{}'", show(line))))
}

fn add_node(
    b: &Bytes<'_>,
    st: &mut State,
    tag: u64,
    xyz: [f64; 3],
    at: usize,
) -> Result<(), MeshError> {
    st.add_node(tag, xyz)
        .map_err(|()| b.err_at(at, format!("node {tag} is listed twice")))
}

fn nodes_v2(b: &mut Bytes<'_>, st: &mut State) -> Result<(), MeshError> {
    let n = count_line(b, "the number of nodes")?;
    let n = b.count(n, 28, "nodes")?;
    st.nodes_seen = true;
    st.positions.reserve(n);
    for _ in 0..n {
        let at = b.offset();
        let tag = b.i32("a node tag")?;
        let xyz = [
            b.float(8, "coordinate")?,
            b.float(8, "coordinate")?,
            b.float(8, "coordinate")?,
        ];
        if tag < 0 {
            return Err(b.err_at(at, format!("negative node tag {tag}")));
        }
        add_node(b, st, tag as u64, xyz, at)?;
    }
    Ok(())
}

fn nodes_v41(b: &mut Bytes<'_>, st: &mut State, size: usize) -> Result<(), MeshError> {
    let blocks = b.uint(size, "the number of node blocks")?;
    let n = b.uint(size, "the number of nodes")?;
    b.uint(size, "the smallest node tag")?;
    b.uint(size, "the largest node tag")?;
    let n = b.count(n, size + 24, "nodes")?;
    let blocks = b.count(blocks, 12 + size, "node blocks")?;
    st.nodes_seen = true;
    st.positions.reserve(n);
    let mut total = 0usize;
    for _ in 0..blocks {
        let bat = b.offset();
        let dim = b.i32("an entity dimension")?;
        b.i32("an entity tag")?;
        let parametric = b.i32("the parametric flag")?;
        let m = b.uint(size, "the number of nodes in the block")?;
        // Parametric nodes carry `dim` more coordinates each.
        let extra = if parametric != 0 {
            dim.clamp(0, 3) as usize
        } else {
            0
        };
        let m = b.count(m, size + 24 + 8 * extra, "nodes")?;
        total += m;
        if total > n {
            return Err(b.err_at(
                bat,
                format!("node blocks hold more than the {n} nodes declared"),
            ));
        }
        let tags_at = b.offset();
        let mut tags = Vec::with_capacity(m);
        for _ in 0..m {
            tags.push(b.uint(size, "a node tag")?);
        }
        for (k, &tag) in tags.iter().enumerate() {
            let xyz = [
                b.float(8, "coordinate")?,
                b.float(8, "coordinate")?,
                b.float(8, "coordinate")?,
            ];
            for _ in 0..extra {
                b.float(8, "a parametric coordinate")?;
            }
            add_node(b, st, tag, xyz, tags_at + k * size)?;
        }
    }
    if total != n {
        return Err(b.err(format!("declares {n} nodes, the blocks hold {total}")));
    }
    Ok(())
}

/// Keeps one element if it is a 4-node tet (`State::element`).
fn element(st: &mut State, etype: i64, nodes: &[u64], physical: Option<i32>, at: usize) {
    let tags = match nodes {
        [a, b, c, d, ..] => [*a, *b, *c, *d],
        _ => [0; 4],
    };
    // A negative type is no Gmsh element: counted as nothing, like any unknown type.
    st.element(u64::try_from(etype).unwrap_or(u64::MAX), tags, physical, at);
}

fn elements_v2(b: &mut Bytes<'_>, st: &mut State) -> Result<(), MeshError> {
    let n = count_line(b, "the number of elements")?;
    let n = b.count(n, 12, "elements")?;
    st.elements_seen = true;
    let mut done = 0usize;
    let mut nodes = Vec::new();
    while done < n {
        let hat = b.offset();
        let etype = b.i32("an element type")? as i64;
        let follow = b.i32("the number of elements that follow")?;
        let ntags = b.i32("the number of tags")?;
        let Some(npe) = nodes_per_element(etype) else {
            return Err(b.err_at(hat, format!("unknown element type {etype}")));
        };
        if follow <= 0 || ntags < 0 || follow as usize > n - done {
            return Err(b.err_at(
                hat,
                format!("element block of {follow} elements with {ntags} tags ({} of {n} elements left)", n - done),
            ));
        }
        let per = 4 * (1 + ntags as usize + npe);
        let follow = b.count(follow as u64, per, "elements")?;
        for _ in 0..follow {
            let at = b.offset();
            b.i32("an element tag")?;
            let mut physical = None;
            for k in 0..ntags {
                let t = b.i32("an element tag")?;
                if k == 0 {
                    physical = Some(t);
                }
            }
            nodes.clear();
            for _ in 0..npe {
                let v = b.i32("a node tag")?;
                nodes.push(
                    u64::try_from(v).map_err(|_| b.err_at(at, format!("negative node tag {v}")))?,
                );
            }
            element(st, etype, &nodes, physical, at);
        }
        done += follow;
    }
    Ok(())
}

fn elements_v41(b: &mut Bytes<'_>, st: &mut State, size: usize) -> Result<(), MeshError> {
    let blocks = b.uint(size, "the number of element blocks")?;
    let n = b.uint(size, "the number of elements")?;
    b.uint(size, "the smallest element tag")?;
    b.uint(size, "the largest element tag")?;
    let n = b.count(n, 2 * size, "elements")?;
    let blocks = b.count(blocks, 12 + size, "element blocks")?;
    st.elements_seen = true;
    let mut total = 0usize;
    let mut nodes = Vec::new();
    for _ in 0..blocks {
        let bat = b.offset();
        let dim = b.i32("an entity dimension")?;
        let tag = b.i32("an entity tag")? as i64;
        let etype = b.i32("an element type")? as i64;
        let m = b.uint(size, "the number of elements in the block")?;
        let Some(npe) = nodes_per_element(etype) else {
            return Err(b.err_at(bat, format!("unknown element type {etype}")));
        };
        let m = b.count(m, size * (1 + npe), "elements")?;
        total += m;
        if total > n {
            return Err(b.err_at(
                bat,
                format!("element blocks hold more than the {n} elements declared"),
            ));
        }
        let physical = if dim == 3 {
            st.volume_physical.get(&tag).copied()
        } else {
            None
        };
        for _ in 0..m {
            let at = b.offset();
            b.uint(size, "an element tag")?;
            nodes.clear();
            for _ in 0..npe {
                nodes.push(b.uint(size, "a node tag")?);
            }
            element(st, etype, &nodes, physical, at);
        }
    }
    if total != n {
        return Err(b.err(format!("declares {n} elements, the blocks hold {total}")));
    }
    Ok(())
}

/// The volume entities' physical tags from a binary 4.1 `$Entities` section.
fn entities_v41(b: &mut Bytes<'_>, st: &mut State, size: usize) -> Result<(), MeshError> {
    let mut counts = [0u64; 4];
    for c in counts.iter_mut() {
        *c = b.uint(size, "the number of entities")?;
    }
    for (dim, &n) in counts.iter().enumerate() {
        let coords = if dim == 0 { 3 } else { 6 };
        let n = b.count(n, 4 + 8 * coords + size, "entities")?;
        for _ in 0..n {
            let tag = b.i32("an entity tag")? as i64;
            b.take(8 * coords, "a bounding box")?;
            let np = b.uint(size, "the number of physical tags")?;
            let np = b.count(np, 4, "physical tags")?;
            for k in 0..np {
                let p = b.i32("a physical tag")?;
                if dim == 3 && k == 0 {
                    st.volume_physical.insert(tag, p);
                }
            }
            if dim > 0 {
                let nb = b.uint(size, "the number of bounding entities")?;
                let nb = b.count(nb, 4, "bounding entities")?;
                b.take(4 * nb, "bounding entity tags")?;
            }
        }
    }
    Ok(())
}
