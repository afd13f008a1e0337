//! MEDIT binary `.meshb` (INRIA libMeshb), versions 1 to 4, either byte order: the integer 1
//! (byte order), the version, then keywords, each `code` (32-bit), the file position of the
//! next keyword, and its records. Version 1 stores 32-bit floats, 2 and up 64-bit floats;
//! versions 1-2 32-bit positions, 3-4 64-bit; version 4 64-bit integers. `Vertices`
//! (`x y z ref`) and `Tetrahedra` (`n1 n2 n3 n4 ref`, 1-based; the reference is the tet's
//! region label) are read; every other keyword is stepped over through its next-position
//! field; the `End` keyword (code 54) closes the file. Errors name the byte offset.

use std::path::Path;

use crate::binary::Bytes;
use crate::{MeshError, RawMesh};

const DIMENSION: i32 = 3;
const VERTICES: i32 = 4;
const TETRAHEDRA: i32 = 8;
const END: i32 = 54;

/// Reads a `.meshb` file (decompressed first when its name ends in `.gz`).
///
/// # Errors
/// Bad input ([`crate::MeshErrorKind::Input`]), `FILE: byte N: reason`: a bad byte-order word or version, 2-D meshes,
/// missing `Vertices` or `Tetrahedra`, truncated records, counts larger than the file, next
/// positions that do not move forward, NaN coordinates, node indices out of range.
pub fn read(path: &Path) -> Result<RawMesh, MeshError> {
    let data = crate::source::read_file(path)?;
    read_bytes(path, &data)
}

fn read_bytes(path: &Path, data: &[u8]) -> Result<RawMesh, MeshError> {
    let mut b = Bytes::new(path, data, 0, false);
    let code = b.take(4, "the byte-order word")?;
    b.big = match code {
        [1, 0, 0, 0] => false,
        [0, 0, 0, 1] => true,
        _ => {
            return Err(b.err_at(
                0,
                format!("not a binary MEDIT file: expected the integer 1, found bytes {code:02x?}"),
            ))
        }
    };
    let vat = b.offset();
    let version = b.i32("the version")?;
    if !(1..=4).contains(&version) {
        return Err(b.err_at(
            vat,
            format!("unknown .meshb version {version} (1 to 4 are read)"),
        ));
    }
    let real = if version == 1 { 4 } else { 8 };
    let pos_size = if version >= 3 { 8 } else { 4 };
    let int = if version == 4 { 8 } else { 4 };
    let mut dim = 3;
    let mut positions: Option<Vec<[f64; 3]>> = None;
    let mut raw_tets: Option<(Vec<[i64; 4]>, Vec<i32>, usize)> = None;
    loop {
        if b.at_end() {
            return Err(b.err("unexpected end of file (truncated?): no End keyword"));
        }
        let kat = b.offset();
        let kw = b.i32("a keyword code")?;
        if kw == END {
            break;
        }
        let next = b.uint(pos_size, "the next keyword's position")?;
        match kw {
            DIMENSION => {
                let d = b.i32("the dimension")?;
                if d != 3 {
                    return Err(b.err_at(
                        kat,
                        format!("Dimension {d}: only 3-D MEDIT meshes are read"),
                    ));
                }
                dim = 3;
            }
            VERTICES => {
                if positions.is_some() {
                    return Err(b.err_at(kat, "a second Vertices keyword"));
                }
                let n = b.uint(int, "the number of vertices")?;
                let n = b.count(n, dim * real + int, "vertices")?;
                let mut p = Vec::with_capacity(n);
                for _ in 0..n {
                    let xyz = [
                        b.float(real, "vertex coordinate")?,
                        b.float(real, "vertex coordinate")?,
                        b.float(real, "vertex coordinate")?,
                    ];
                    b.int(int, "a vertex reference")?;
                    p.push(xyz);
                }
                positions = Some(p);
            }
            TETRAHEDRA => {
                if raw_tets.is_some() {
                    return Err(b.err_at(kat, "a second Tetrahedra keyword"));
                }
                let n = b.uint(int, "the number of tetrahedra")?;
                let n = b.count(n, 5 * int, "tetrahedra")?;
                let first = b.offset();
                let mut t = Vec::with_capacity(n);
                let mut refs = Vec::with_capacity(n);
                for _ in 0..n {
                    let mut ids = [0i64; 4];
                    for id in ids.iter_mut() {
                        *id = b.int(int, "a node index")?;
                    }
                    let at = b.offset();
                    let r = b.int(int, "a tetrahedron reference")?;
                    refs.push(i32::try_from(r).map_err(|_| {
                        b.err_at(
                            at,
                            format!("tetrahedron reference {r} does not fit 32 bits"),
                        )
                    })?);
                    t.push(ids);
                }
                raw_tets = Some((t, refs, first));
            }
            _ => {
                // Any other keyword: go to the next one.
                if next <= kat as u64 || next > data.len() as u64 {
                    return Err(b.err_at(
                        kat,
                        format!(
                            "keyword {kw}: next position {next} does not move forward within the file ({} bytes)",
                            data.len()
                        ),
                    ));
                }
                b.seek(next as usize)?;
            }
        }
    }
    let Some(positions) = positions else {
        return Err(MeshError::at(path, None, "no Vertices keyword"));
    };
    let Some((raw, labels, first)) = raw_tets else {
        return Err(MeshError::at(
            path,
            None,
            "no Tetrahedra keyword (no tets to read)",
        ));
    };
    let mut tets = Vec::with_capacity(raw.len());
    for (k, r) in raw.iter().enumerate() {
        let mut ids = [0u32; 4];
        for (o, &v) in ids.iter_mut().zip(r) {
            if v < 1 || v as u64 > positions.len() as u64 {
                return Err(b.err_at(
                    first + k * 5 * int,
                    format!(
                        "tetrahedron {}: node index {v} out of range (nodes are numbered 1..{})",
                        k + 1,
                        positions.len()
                    ),
                ));
            }
            *o = (v - 1) as u32;
        }
        tets.push(ids);
    }
    Ok(RawMesh {
        positions,
        tet_lines: vec![0; tets.len()],
        tets,
        labels,
        label_source: Some("MEDIT references".into()),
        format: "medit binary",
        warnings: Vec::new(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A version-2 file by hand: one tet, references 7.
    fn one_tet(big: bool) -> Vec<u8> {
        let i = |v: i32| {
            if big {
                v.to_be_bytes()
            } else {
                v.to_le_bytes()
            }
        };
        let r = |v: f64| {
            if big {
                v.to_be_bytes()
            } else {
                v.to_le_bytes()
            }
        };
        let mut f = Vec::new();
        f.extend(i(1));
        f.extend(i(2));
        f.extend(i(DIMENSION));
        f.extend(i(20));
        f.extend(i(3));
        f.extend(i(VERTICES));
        f.extend(i(0));
        f.extend(i(4));
        for p in [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
        ] {
            for c in p {
                f.extend(r(c));
            }
            f.extend(i(0));
        }
        f.extend(i(TETRAHEDRA));
        f.extend(i(0));
        f.extend(i(1));
        for v in [1, 2, 3, 4, 7] {
            f.extend(i(v));
        }
        f.extend(i(END));
        f
    }

    #[test]
    fn both_byte_orders() {
        for big in [false, true] {
            let m = read_bytes(Path::new("t.meshb"), &one_tet(big)).unwrap();
            assert_eq!(m.tets, vec![[0, 1, 2, 3]]);
            assert_eq!(m.labels, vec![7]);
            assert_eq!(m.positions[1], [1.0, 0.0, 0.0]);
        }
    }

    #[test]
    fn every_cut_is_an_error_naming_a_byte() {
        let f = one_tet(false);
        for cut in 0..f.len() {
            let e = read_bytes(Path::new("t.meshb"), &f[..cut]).unwrap_err();
            assert!(e.is_input());
            assert!(
                e.message.starts_with("t.meshb: byte ") || e.message.starts_with("t.meshb: no "),
                "{cut}: {}",
                e.message
            );
        }
    }
}
