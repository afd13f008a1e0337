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
/// Bad input ([`crate::MeshErrorKind::Input`]), `FILE:LINE: reason`, for a missing partner file and every bad record.
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
    // The two files at the same time: the `.ele` file (the larger) on a second thread.
    let (nodes, ele) = std::thread::scope(|s| {
        let ele = s.spawn(|| {
            read_text(&ele_path, "TetGen").map(|text| {
                let parsed = parse_tets(&ele_path, &text);
                (text, parsed)
            })
        });
        let nodes = read_text(&node_path, "TetGen").and_then(|text| read_nodes(&node_path, &text));
        let ele = ele.join().unwrap_or_else(|_| {
            Err(MeshError::failure(
                "internal error: the .ele reader stopped",
            ))
        });
        (nodes, ele)
    });
    let (positions, base) = nodes?;
    let (ele_text, parsed) = ele?;
    let (tets, tet_lines, labels) =
        resolve_tets(&ele_path, &ele_text, parsed, base, positions.len())?;
    drop(ele_text);
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

/// The `.ele` file as parsed before the node count is known: node ids as written (each fits
/// 32 bits), their lines, the region attributes, and why parsing stopped early if it did.
#[derive(Debug)]
struct ParsedTets {
    ids: Vec<[u32; 4]>,
    lines: Vec<usize>,
    labels: Option<Vec<i32>>,
    stop: Option<Stop>,
}

/// Why [`parse_tets`] stopped before the last tet.
#[derive(Debug)]
enum Stop {
    /// A bad line (or a bad header).
    Bad(MeshError),
    /// A node id that fits no 32-bit index, at this line: out of range whatever the node count.
    Range(usize, [i64; 4]),
}

/// Parses the tets of an `.ele` file up to the first bad line (the node range is checked by
/// [`resolve_tets`] once the `.node` file is read; the two files are read at the same time).
fn parse_tets(path: &Path, text: &str) -> ParsedTets {
    let mut out = ParsedTets {
        ids: Vec::new(),
        lines: Vec::new(),
        labels: None,
        stop: None,
    };
    let mut c = Cursor::new(path, text, 1, Some('#'));
    let header = header::<3>(&mut c, "the .ele header").and_then(|(hline, [t, per, attr])| {
        if per != 4 && per != 10 {
            return Err(c.err(hline, format!("{per} nodes per tet: only 4 or 10 are read")));
        }
        if t == 0 {
            return Err(c.err(hline, "the .ele file declares no tets"));
        }
        let per_line = 1 + per as usize + usize::from(attr > 0);
        Ok((c.count(t, per_line, "tets", hline)?, per, attr > 0))
    });
    let (t, per, has_attr) = match header {
        Ok(h) => h,
        Err(e) => {
            out.stop = Some(Stop::Bad(e));
            return out;
        }
    };
    let per_line = 1 + per as usize + usize::from(has_attr);
    out.ids.reserve_exact(t);
    out.lines.reserve_exact(t);
    let mut labels = Vec::with_capacity(if has_attr { t } else { 0 });
    for k in 0..t {
        let tet = c.with_line(|c, line, tok| {
            if tok.len() < per_line {
                return Err(Stop::Bad(c.err(
                    line,
                    if has_attr {
                        format!("expected a tet index, {per} node indices and a region attribute")
                    } else {
                        format!("expected a tet index and {per} node indices")
                    },
                )));
            }
            if has_attr {
                labels.push(region(c, tok[1 + per as usize], line).map_err(Stop::Bad)?);
            }
            let _ = parse_int(c, tok[0], line, "a tet index").map_err(Stop::Bad)?;
            let mut raw = [0i64; 4];
            for (r, s) in raw.iter_mut().zip(&tok[1..5]) {
                *r = parse_int(c, s, line, "a node index").map_err(Stop::Bad)?;
            }
            match raw.map(u32::try_from) {
                [Ok(a), Ok(b), Ok(c), Ok(d)] => Ok(([a, b, c, d], line)),
                _ => Err(Stop::Range(line, raw)),
            }
        });
        match tet {
            Some(Ok((ids, line))) => {
                out.ids.push(ids);
                out.lines.push(line);
            }
            Some(Err(stop)) => {
                out.stop = Some(stop);
                break;
            }
            None => {
                out.stop = Some(Stop::Bad(c.eof(&format!("tet {} of {t}", k + 1))));
                break;
            }
        }
    }
    out.labels = has_attr.then_some(labels);
    out
}

/// The tets with node ids counted from 0, checked against the node count; the first bad line
/// of the file is the error, as if the file were read line by line.
#[allow(clippy::type_complexity)]
fn resolve_tets(
    path: &Path,
    text: &str,
    parsed: ParsedTets,
    base: i64,
    nodes: usize,
) -> Result<(Vec<[u32; 4]>, Vec<usize>, Option<Vec<i32>>), MeshError> {
    let c = Cursor::new(path, text, 1, Some('#'));
    let ParsedTets {
        mut ids,
        lines,
        labels,
        stop,
    } = parsed;
    for (tet, &line) in ids.iter_mut().zip(&lines) {
        *tet = node_ids(&c, tet.map(i64::from), base, nodes, line)?;
    }
    match stop {
        None => Ok((ids, lines, labels)),
        Some(Stop::Bad(e)) => Err(e),
        Some(Stop::Range(line, raw)) => match node_ids(&c, raw, base, nodes, line) {
            Err(e) => Err(e),
            Ok(_) => Err(c.err(line, "node index out of range")),
        },
    }
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
