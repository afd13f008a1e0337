//! TetGen `.node` + `.ele` (either may be named; the other is found beside it).
//!
//! `.node`: header `<points> <dim = 3> <attributes> <boundary marker 0|1>`, then one line per
//! point `<index> <x> <y> <z> [attributes] [marker]`. The first index (0 or 1) sets the
//! numbering base for both files; indices must then be consecutive.
//! `.ele`: header `<tets> <nodes per tet: 4 or 10> <region attribute 0|1>`, then one line per
//! tet `<index> <n1> .. <n4> [n5 .. n10] [attribute]`; only the four corners are kept, and the
//! first attribute is the tet's region label. Either file may be gzipped (`.node.gz`).
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
    let (stem, _) = crate::source::strip_gz(path);
    let partner = |ext: &str| {
        let plain = stem.with_extension(ext);
        let gz = stem.with_extension(format!("{ext}.gz"));
        if !plain.is_file() && gz.is_file() {
            gz
        } else {
            plain
        }
    };
    let node_path = partner("node");
    let ele_path = partner("ele");
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
    let (tets, tet_lines, labels) = read_tets(&ele_path, &ele_text, base, positions.len())?;
    let label_source = labels
        .is_some()
        .then(|| "TetGen region attribute".to_string());
    Ok((
        RawMesh {
            positions,
            labels: labels.unwrap_or_else(|| vec![0; tets.len()]),
            tets,
            tet_lines,
            label_source,
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
        let point = c.with_line(|c, line, t| {
            if t.len() < 4 {
                return Err(c.err(line, "expected a point index and three coordinates"));
            }
            let idx = parse_int(c, t[0], line, "a point index")?;
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
            parse_xyz(c, &t[1..4], line)
        });
        match point {
            Some(p) => positions.push(p?),
            None => return Err(c.eof(&format!("point {} of {n}", k + 1))),
        }
    }
    Ok((positions, base))
}

/// The tets, their lines, and their region attributes when the header declares them.
#[allow(clippy::type_complexity)]
fn read_tets(
    path: &Path,
    text: &str,
    base: i64,
    nodes: usize,
) -> Result<(Vec<[u32; 4]>, Vec<usize>, Option<Vec<i32>>), MeshError> {
    let mut c = Cursor::new(path, text, 1, Some('#'));
    let (hline, [t, per, attr]) = header::<3>(&mut c, "the .ele header")?;
    if per != 4 && per != 10 {
        return Err(c.err(hline, format!("{per} nodes per tet: only 4 or 10 are read")));
    }
    if t == 0 {
        return Err(c.err(hline, "the .ele file declares no tets"));
    }
    let has_attr = attr > 0;
    let per_line = 1 + per as usize + usize::from(has_attr);
    let t = c.count(t, per_line, "tets", hline)?;
    let mut tets = Vec::with_capacity(t);
    let mut lines = Vec::with_capacity(t);
    let mut labels = Vec::with_capacity(if has_attr { t } else { 0 });
    for k in 0..t {
        let tet = c.with_line(|c, line, tok| {
            if tok.len() < per_line {
                return Err(c.err(
                    line,
                    if has_attr {
                        format!("expected a tet index, {per} node indices and a region attribute")
                    } else {
                        format!("expected a tet index and {per} node indices")
                    },
                ));
            }
            if has_attr {
                labels.push(region(c, tok[1 + per as usize], line)?);
            }
            let _ = parse_int(c, tok[0], line, "a tet index")?;
            let mut raw = [0i64; 4];
            for (r, s) in raw.iter_mut().zip(&tok[1..5]) {
                *r = parse_int(c, s, line, "a node index")?;
            }
            Ok((node_ids(c, raw, base, nodes, line)?, line))
        });
        match tet {
            Some(Ok((ids, line))) => {
                tets.push(ids);
                lines.push(line);
            }
            Some(Err(e)) => return Err(e),
            None => return Err(c.eof(&format!("tet {} of {t}", k + 1))),
        }
    }
    Ok((tets, lines, has_attr.then_some(labels)))
}

/// A region attribute: an integer (TetGen writes it as a number that may carry a fraction
/// part of zero, `2` or `2.0`) that fits 32 bits.
fn region(c: &Cursor<'_>, t: &str, line: usize) -> Result<i32, MeshError> {
    if let Ok(v) = t.parse::<i32>() {
        return Ok(v);
    }
    match t.parse::<f64>() {
        Ok(v) if v.fract() == 0.0 && v >= i32::MIN as f64 && v <= i32::MAX as f64 => Ok(v as i32),
        _ => Err(c.err(
            line,
            format!(
                "region attribute '{}' is not an integer that fits 32 bits",
                crate::text::short(t)
            ),
        )),
    }
}
