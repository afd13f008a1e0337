//! MEDIT `.mesh` (ASCII, INRIA libMesh format): `MeshVersionFormatted`, `Dimension 3`,
//! `Vertices` (`x y z ref`), `Tetrahedra` (`n1 n2 n3 n4 ref`, 1-based; the reference is the
//! tet's region label), `End`. Other sections
//! (triangles, edges, corners, normals, ...) are skipped; `#` starts a comment.

use std::path::Path;

use super::text::{node_ids, parse_int, read_text, short, Cursor};
use super::RawMesh;
use crate::MeshError;

/// Sections this reader skips, with the number of values per record.
const SKIPPED: &[(&str, usize)] = &[
    ("Edges", 3),
    ("Triangles", 4),
    ("Quadrilaterals", 5),
    ("Hexahedra", 9),
    ("Prisms", 7),
    ("Pyramids", 6),
    ("Corners", 1),
    ("Ridges", 1),
    ("RequiredVertices", 1),
    ("RequiredEdges", 1),
    ("RequiredTriangles", 1),
    ("RequiredQuadrilaterals", 1),
    ("RequiredTetrahedra", 1),
    ("Normals", 3),
    ("Tangents", 3),
    ("NormalAtVertices", 2),
    ("NormalAtTriangleVertices", 3),
    ("NormalAtQuadrilateralVertices", 3),
    ("TangentAtEdges", 3),
    ("TangentAtVertices", 2),
    ("TetrahedraP2", 11),
    ("TrianglesP2", 7),
    ("EdgesP2", 4),
];

/// Reads a MEDIT `.mesh` file.
///
/// # Errors
/// Bad input ([`crate::MeshErrorKind::Input`]), `FILE:LINE: reason`: 2-D meshes, missing `Vertices` or `Tetrahedra`,
/// truncated sections, counts larger than the file, bad numbers, node indices out of range.
pub fn read(path: &Path) -> Result<RawMesh, MeshError> {
    let text = read_text(path, "MEDIT")?;
    let mut c = Cursor::new(path, &text, 1, Some('#'));
    let mut positions: Option<Vec<[f64; 3]>> = None;
    let mut raw_tets: Option<(Vec<[i64; 4]>, Vec<usize>)> = None;
    let mut dim = 3u64;
    let mut refs: Vec<i32> = Vec::new();
    while let Some((kw, line)) = c.token() {
        if kw.eq_ignore_ascii_case("End") {
            break;
        } else if kw.eq_ignore_ascii_case("MeshVersionFormatted") {
            let (v, l) = c.uint("the mesh version")?;
            if !(1..=4).contains(&v) {
                return Err(c.err(l, format!("unknown MeshVersionFormatted {v}")));
            }
        } else if kw.eq_ignore_ascii_case("Dimension") {
            let (d, l) = c.uint("the dimension")?;
            if d != 3 {
                return Err(c.err(l, format!("Dimension {d}: only 3-D MEDIT meshes are read")));
            }
            dim = d;
        } else if kw.eq_ignore_ascii_case("Vertices") {
            if positions.is_some() {
                return Err(c.err(line, "a second Vertices section"));
            }
            let (n, l) = c.uint("the number of vertices")?;
            let n = c.count(n, dim as usize + 1, "vertices", l)?;
            let mut p = Vec::with_capacity(n);
            for k in 0..n {
                let what = format!("vertex {} of {n}", k + 1);
                let x = c.float(&what)?;
                let y = c.float(&what)?;
                let z = c.float(&what)?;
                let (r, rl) = c.need(&what)?;
                parse_int(&c, r, rl, "a vertex reference")?;
                p.push([x, y, z]);
            }
            positions = Some(p);
        } else if kw.eq_ignore_ascii_case("Tetrahedra") {
            if raw_tets.is_some() {
                return Err(c.err(line, "a second Tetrahedra section"));
            }
            let (n, l) = c.uint("the number of tetrahedra")?;
            let n = c.count(n, 5, "tetrahedra", l)?;
            let mut t = Vec::with_capacity(n);
            let mut lines = Vec::with_capacity(n);
            refs = Vec::with_capacity(n);
            for k in 0..n {
                let what = format!("tetrahedron {} of {n}", k + 1);
                let mut ids = [0i64; 4];
                let mut first = 0;
                for (j, id) in ids.iter_mut().enumerate() {
                    let (s, sl) = c.need(&what)?;
                    if j == 0 {
                        first = sl;
                    }
                    *id = parse_int(&c, s, sl, "a node index")?;
                }
                let (r, rl) = c.need(&what)?;
                let r = parse_int(&c, r, rl, "a tetrahedron reference")?;
                refs.push(i32::try_from(r).map_err(|_| {
                    c.err(
                        rl,
                        format!("tetrahedron reference {r} does not fit 32 bits"),
                    )
                })?);
                t.push(ids);
                lines.push(first);
            }
            raw_tets = Some((t, lines));
        } else if let Some(&(_, per)) = SKIPPED.iter().find(|(s, _)| s.eq_ignore_ascii_case(kw)) {
            let kw = short(kw);
            let (n, l) = c.uint(&format!("the number of {kw}"))?;
            let n = c.count(n, per, &kw, l)?;
            for _ in 0..n * per {
                c.need(&format!("{kw} data"))?;
            }
        } else if kw.chars().next().is_some_and(|ch| ch.is_ascii_alphabetic()) {
            // An unknown section: a count, then one record per line.
            let kw = short(kw);
            let (n, l) = c.uint(&format!("the number of {kw}"))?;
            let n = c.count(n, 1, &kw, l)?;
            for _ in 0..n {
                c.need_line(&format!("{kw} data"))?;
            }
        } else {
            return Err(c.err(
                line,
                format!("expected a section keyword, found '{}'", short(kw)),
            ));
        }
    }
    let Some(positions) = positions else {
        return Err(MeshError::at(path, None, "no Vertices section"));
    };
    let Some((raw, tet_lines)) = raw_tets else {
        return Err(MeshError::at(
            path,
            None,
            "no Tetrahedra section (no tets to read)",
        ));
    };
    let mut tets = Vec::with_capacity(raw.len());
    for (r, &l) in raw.iter().zip(&tet_lines) {
        tets.push(node_ids(&c, *r, 1, positions.len(), l)?);
    }
    Ok(RawMesh {
        positions,
        labels: refs,
        tets,
        tet_lines,
        label_source: Some("MEDIT references".into()),
        format: "medit",
        warnings: Vec::new(),
    })
}
