//! TetGen `.node` + `.ele` (either may be named; the other is found beside it).
//!
//! `.node`: header `<points> <dim = 3> <attributes> <boundary marker 0|1>`, then one line per
//! point `<index> <x> <y> <z> [attributes] [marker]`. The first index (0 or 1) sets the
//! numbering base for both files; indices must then be consecutive.
//! `.ele`: header `<tets> <nodes per tet: 4 or 10> <region attribute 0|1>`, then one line per
//! tet `<index> <n1> .. <n4> [n5 .. n10] [attribute]`; only the four corners are kept.
//! `#` starts a comment to the end of the line in both files.

use std::path::{Path, PathBuf};

use super::text::{node_ids, parse_int, parse_uint, parse_xyz, read_text, Cursor};
use super::RawMesh;
use crate::MeshError;

/// Reads a TetGen pair named by either of its files; returns the mesh and the `.ele` path.
///
/// # Errors
/// Exit status 2, `FILE:LINE: reason`, for a missing partner file and every bad record.
pub fn read(path: &Path) -> Result<(RawMesh, PathBuf), MeshError> {
    let node_path = path.with_extension("node");
    let ele_path = path.with_extension("ele");
    for p in [&node_path, &ele_path] {
        if !p.is_file() {
            return Err(MeshError::at(
                path,
                None,
                format!(
                    "TetGen needs both .node and .ele files: {} not found",
                    p.display()
                ),
            ));
        }
    }
    let node_text = read_text(&node_path, "TetGen")?;
    let (positions, base) = read_nodes(&node_path, &node_text)?;
    let ele_text = read_text(&ele_path, "TetGen")?;
    let (tets, tet_lines) = read_tets(&ele_path, &ele_text, base, positions.len())?;
    Ok((
        RawMesh {
            positions,
            labels: vec![0; tets.len()],
            tets,
            tet_lines,
            label_source: None,
            format: "tetgen",
            warnings: Vec::new(),
        },
        ele_path,
    ))
}

/// Header numbers: the first required, the others 0 when absent.
fn header<const N: usize>(c: &mut Cursor<'_>, what: &str) -> Result<(usize, [u64; N]), MeshError> {
    let (line, toks) = c.need_line(what)?;
    let mut out = [0u64; N];
    for (o, t) in out.iter_mut().zip(toks.iter()) {
        *o = parse_uint(c, t, line, what)?;
    }
    Ok((line, out))
}

fn read_nodes(path: &Path, text: &str) -> Result<(Vec<[f64; 3]>, i64), MeshError> {
    let mut c = Cursor::new(path, text, 1, Some('#'));
    let (hline, [n, dim, attrs, markers]) = header::<4>(&mut c, "the .node header")?;
    if dim != 3 {
        return Err(c.err(
            hline,
            format!("dimension {dim}: only 3-D TetGen meshes are read"),
        ));
    }
    if n == 0 {
        return Err(c.err(hline, "the .node file declares no points"));
    }
    if markers > 1 {
        return Err(c.err(
            hline,
            format!("boundary marker flag must be 0 or 1, not {markers}"),
        ));
    }
    let extra = usize::try_from(attrs.saturating_add(markers)).unwrap_or(usize::MAX);
    let n = c.count(n, 4usize.saturating_add(extra), "points", hline)?;
    let mut positions = Vec::with_capacity(n);
    let mut base = 0i64;
    for k in 0..n {
        let Some((line, t)) = c.line() else {
            return Err(c.eof(&format!("point {} of {n}", k + 1)));
        };
        if t.len() < 4 {
            return Err(c.err(line, "expected a point index and three coordinates"));
        }
        let idx = parse_int(&c, t[0], line, "a point index")?;
        if k == 0 {
            if idx != 0 && idx != 1 {
                return Err(c.err(line, format!("first point index must be 0 or 1, not {idx}")));
            }
            base = idx;
        } else if idx != base + k as i64 {
            return Err(c.err(
                line,
                format!(
                    "point indices must be consecutive: expected {}, found {idx}",
                    base + k as i64
                ),
            ));
        }
        positions.push(parse_xyz(&c, &t[1..4], line)?);
    }
    Ok((positions, base))
}

#[allow(clippy::type_complexity)]
fn read_tets(
    path: &Path,
    text: &str,
    base: i64,
    nodes: usize,
) -> Result<(Vec<[u32; 4]>, Vec<usize>), MeshError> {
    let mut c = Cursor::new(path, text, 1, Some('#'));
    let (hline, [t, per, _attr]) = header::<3>(&mut c, "the .ele header")?;
    if per != 4 && per != 10 {
        return Err(c.err(hline, format!("{per} nodes per tet: only 4 or 10 are read")));
    }
    if t == 0 {
        return Err(c.err(hline, "the .ele file declares no tets"));
    }
    let t = c.count(t, 1 + per as usize, "tets", hline)?;
    let mut tets = Vec::with_capacity(t);
    let mut lines = Vec::with_capacity(t);
    for k in 0..t {
        let Some((line, tok)) = c.line() else {
            return Err(c.eof(&format!("tet {} of {t}", k + 1)));
        };
        if tok.len() < 1 + per as usize {
            return Err(c.err(line, format!("expected a tet index and {per} node indices")));
        }
        let _ = parse_int(&c, tok[0], line, "a tet index")?;
        let mut raw = [0i64; 4];
        for (r, s) in raw.iter_mut().zip(&tok[1..5]) {
            *r = parse_int(&c, s, line, "a node index")?;
        }
        tets.push(node_ids(&c, raw, base, nodes, line)?);
        lines.push(line);
    }
    Ok((tets, lines))
}
