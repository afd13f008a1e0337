//! Binary, compressed and gzipped mesh files, and region labels: every variant of the sfepy
//! octahedron in `formats/binary/` gives the same nodes, tets and labels as the ASCII originals,
//! read here by a few lines of plain text parsing that share no code with the readers; the cow
//! gives the same counts in every format; truncated and corrupted binary files are one-line
//! exit-2 errors naming the byte offset or block, never a panic.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use tetradrill::meshio::{self, RawMesh, ReadOptions};
use tetradrill_tests::{mesh, scratch_dir, Scratch};

/// The octahedron from the ASCII originals: nodes and 0-based tets from the TetGen pair,
/// labels from the MEDIT file's tet references.
struct Oracle {
    nodes: Vec<[f64; 3]>,
    tets: Vec<[u32; 4]>,
    labels: Vec<i32>,
}

fn numbers(path: &Path) -> Vec<Vec<String>> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .map(|l| {
            l.split('#')
                .next()
                .unwrap()
                .split_whitespace()
                .map(String::from)
                .collect()
        })
        .filter(|t: &Vec<String>| !t.is_empty())
        .collect()
}

fn oracle() -> Oracle {
    let node = numbers(&mesh("formats/sfepy_octahedron.node"));
    let nodes: Vec<[f64; 3]> = node[1..]
        .iter()
        .map(|t| {
            [
                t[1].parse().unwrap(),
                t[2].parse().unwrap(),
                t[3].parse().unwrap(),
            ]
        })
        .collect();
    let ele = numbers(&mesh("formats/sfepy_octahedron.ele"));
    let tets: Vec<[u32; 4]> = ele[1..]
        .iter()
        .map(|t| std::array::from_fn(|k| t[1 + k].parse::<u32>().unwrap() - 1))
        .collect();
    let medit = numbers(&mesh("formats/binary/octa_refs.mesh"));
    let at = medit.iter().position(|t| t[0] == "Tetrahedra").unwrap();
    let n: usize = medit[at + 1][0].parse().unwrap();
    let labels: Vec<i32> = medit[at + 2..at + 2 + n]
        .iter()
        .map(|t| t[4].parse().unwrap())
        .collect();
    assert_eq!((nodes.len(), tets.len(), labels.len()), (330, 1224, 1224));
    Oracle {
        nodes,
        tets,
        labels,
    }
}

fn label_counts(labels: &[i32]) -> BTreeMap<i32, usize> {
    let mut m = BTreeMap::new();
    for &l in labels {
        *m.entry(l).or_default() += 1;
    }
    m
}

/// Checks one variant against the oracle; `f32`: the file stores single precision;
/// `labelled`: the file carries the labels (else they must all be 0, with no source).
fn same_as_oracle(raw: &RawMesh, o: &Oracle, f32: bool, labelled: bool, what: &str) {
    assert_eq!(raw.positions.len(), o.nodes.len(), "{what}: nodes");
    for (k, (p, q)) in raw.positions.iter().zip(&o.nodes).enumerate() {
        for (a, b) in p.iter().zip(q) {
            if f32 {
                assert_eq!(*a as f32, *b as f32, "{what}: node {k}");
            } else {
                assert_eq!(a.to_bits(), b.to_bits(), "{what}: node {k}");
            }
        }
    }
    assert_eq!(raw.tets, o.tets, "{what}: tets");
    if !labelled {
        assert_eq!(raw.labels, vec![0; o.tets.len()], "{what}: labels");
        assert_eq!(raw.label_source, None, "{what}: label source");
        return;
    }
    assert_eq!(raw.labels, o.labels, "{what}: labels");
    assert_eq!(
        label_counts(&raw.labels),
        BTreeMap::from([(1, 612), (2, 612)]),
        "{what}: label counts"
    );
    assert!(raw.label_source.is_some(), "{what}: label source");
}

/// The variants in `formats/binary/`, whether they store f32 coordinates, and whether they
/// carry the labels (meshio's Gmsh 4.1 binary writer leaves out `$Entities`, so
/// `octa_41bin.msh` has no physical tags: its tets are all labelled 0).
const VARIANTS: &[(&str, bool, bool)] = &[
    ("octa_refs.mesh", false, true),
    ("octa_refs.mesh.gz", false, true),
    ("octa_zlib.vtu", false, true),
    ("octa_raw.vtu", false, true),
    ("octa_bin.vtk", false, true),
    ("octa_22bin.msh", false, true),
    ("octa_41bin.msh", false, false),
    ("octa.meshb", false, true),
    ("octa_lz4.vtu", false, true),
    ("octa_lzma_u64.vtu", false, true),
    ("octa_zlib_u64_i32.vtu", false, true),
    ("octa_be_f32.vtu", true, true),
    ("octa_appended_raw_zlib.vtu", false, true),
    ("octa_appended_raw.vtu.gz", false, true),
    ("octa_appended_b64.vtu.gz", false, true),
    ("octa_appended_b64_lz4.vtu", false, true),
    ("octa_42bin.vtk.gz", false, true),
    ("octa_22bin_be.msh.gz", false, true),
    ("octa_41bin_be.msh.gz", false, true),
    ("octa_v1.meshb.gz", true, true),
    ("octa_v2_be.meshb.gz", false, true),
    ("octa_v3.meshb.gz", false, true),
];

#[test]
fn every_variant_gives_the_ascii_original() {
    let o = oracle();
    for &(name, f32, labelled) in VARIANTS {
        let p = mesh(&format!("formats/binary/{name}"));
        let raw = meshio::read(&p).unwrap_or_else(|e| panic!("{name}: {e}"));
        eprintln!("{name}: {} ({:?})", raw.format, raw.label_source);
        same_as_oracle(&raw, &o, f32, labelled, name);
        let loaded = meshio::load(&p, 1.0).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(loaded.mesh.tets().len(), 1224, "{name}");
        assert_eq!(loaded.labels.len(), 1224, "{name}");
        if labelled {
            assert_eq!(
                label_counts(&loaded.labels),
                BTreeMap::from([(1, 612), (2, 612)]),
                "{name}"
            );
        }
    }
}

/// A scratch copy of a file.
fn scratch(name: &str) -> Scratch {
    scratch_dir("meshio-binary", name)
}

#[test]
fn tetgen_region_attribute_is_the_label() {
    let p = mesh("formats/sfepy_octahedron.ele");
    let raw = meshio::read(&p).unwrap();
    assert_eq!(label_counts(&raw.labels), BTreeMap::from([(100, 1224)]));
    assert_eq!(raw.label_source.as_deref(), Some("TetGen region attribute"));
    let cow = meshio::read(&mesh("models/spot_tetgen_q1.414.ele")).unwrap();
    assert!(cow.label_source.is_none() || cow.labels.len() == cow.tets.len());
    let _ = scratch;
}

#[test]
fn region_array_names_a_missing_or_float_array() {
    let p = mesh("formats/binary/octa_zlib.vtu");
    let opts = ReadOptions {
        region_array: Some("nope".into()),
        ..ReadOptions::default()
    };
    let e = meshio::read_with(&p, &opts).unwrap_err();
    assert!(e.is_input());
    assert!(
        e.message.contains("'nope'") && e.message.contains(&p.display().to_string()),
        "{}",
        e.message
    );
    let opts = ReadOptions {
        region_array: Some("material".into()),
        ..ReadOptions::default()
    };
    let raw = meshio::read_with(&p, &opts).unwrap();
    assert_eq!(raw.label_source.as_deref(), Some("cell data 'material'"));
}

#[test]
fn gzipped_tetgen_pair_found_by_either_name() {
    let o = oracle();
    for name in ["octa_tetgen.ele.gz", "octa_tetgen.node.gz"] {
        let raw = meshio::read(&mesh(&format!("formats/binary/{name}"))).unwrap();
        assert_eq!(raw.tets, o.tets, "{name}");
        assert_eq!(raw.positions, o.nodes, "{name}");
        assert_eq!(label_counts(&raw.labels), BTreeMap::from([(100, 1224)]));
    }
}

/// The error contract for a bad binary file: exit 2, one line, the file named, and a byte
/// offset, a line, a data array (with its block) or a missing section named.
fn clean_refusal(path: &Path, what: &str) -> String {
    let e = match meshio::load(path, 1.0) {
        Ok(_) => panic!("{what}: a bad file loaded"),
        Err(e) => e,
    };
    let m = e.message.clone();
    assert!(e.is_input(), "{what}: {m}");
    assert!(!m.contains(['\n', '\r']), "{what}: {m:?}");
    let file = path.display().to_string();
    let rest = m
        .strip_prefix(&file)
        .unwrap_or_else(|| panic!("{what}: {m}"));
    let placed = rest.starts_with(": byte ")
        || rest.starts_with(": no ")
        || rest[1..]
            .split(':')
            .next()
            .is_some_and(|l| l.parse::<usize>().is_ok())
        || rest.contains("DataArray")
        || rest.contains("no tetrahedra")
        || rest == ": empty file"
        || rest.contains("gzip");
    assert!(placed, "{what}: no byte offset, line or block in '{m}'");
    m
}

/// Where the sections of a binary file start and end: Gmsh `$` lines, VTK keyword lines,
/// VTU `DataArray` tags and the appended data's `_`, MEDIT keywords (followed through their
/// next-position fields); each boundary and the bytes just before and after it.
fn section_boundaries(name: &str, data: &[u8]) -> Vec<usize> {
    let mut at = Vec::new();
    if name.ends_with(".meshb") {
        // Version 4: code (4 bytes), next position (8 bytes).
        let mut p = 8usize;
        while p + 12 <= data.len() {
            at.push(p);
            at.push(p + 4);
            at.push(p + 12);
            let next = u64::from_le_bytes(data[p + 4..p + 12].try_into().unwrap()) as usize;
            if next <= p || next >= data.len() {
                break;
            }
            p = next;
        }
    } else {
        let marks: &[&[u8]] = &[
            b"\n$",
            b"\nPOINTS",
            b"\nCELLS",
            b"\nOFFSETS",
            b"\nCONNECTIVITY",
            b"\nCELL_TYPES",
            b"\nCELL_DATA",
            b"\nFIELD",
            b"\nmaterial",
            b"<DataArray",
            b"</DataArray",
            b"<CellData",
            b"\n_",
        ];
        for p in 0..data.len() {
            if marks.iter().any(|m| data[p..].starts_with(m)) {
                at.push(p);
            }
        }
    }
    at.iter()
        .flat_map(|&p| [p.saturating_sub(1), p, p + 1, p + 2])
        .filter(|&p| p > 0 && p < data.len())
        .collect()
}

/// The binary variants, cut every 97 bytes, at every section boundary and at the last byte:
/// every cut is a clean refusal, never a panic.
#[test]
fn truncated_binary_files_are_refused_with_their_offset() {
    let dir = scratch("cuts");
    for name in [
        "octa.meshb",
        "octa_22bin.msh",
        "octa_41bin.msh",
        "octa_bin.vtk",
        "octa_raw.vtu",
        "octa_zlib.vtu",
        "octa_lz4.vtu",
        "octa_lzma_u64.vtu",
        "octa_appended_raw_zlib.vtu",
        "octa_appended_b64_lz4.vtu",
    ] {
        let data = std::fs::read(mesh(&format!("formats/binary/{name}"))).unwrap();
        let p = dir.join(name);
        let mut cuts: Vec<usize> = (1..data.len()).step_by(97).collect();
        cuts.push(data.len() - 1);
        cuts.extend(section_boundaries(name, &data));
        for cut in cuts {
            // Cutting only trailing whitespace, or the position word after MEDIT's End
            // keyword (its last 8 bytes), leaves a whole file.
            let after_end = name.ends_with(".meshb") && cut >= data.len() - 8;
            if after_end || data[cut..].iter().all(|b| b.is_ascii_whitespace()) {
                continue;
            }
            std::fs::write(&p, &data[..cut]).unwrap();
            // A cut right after a whole section can leave a whole file: VTK's cell data
            // block is optional, so a cut just after `CELL_DATA 1224` gives the mesh without
            // labels.
            if let Ok(raw) = meshio::read(&p) {
                if name.ends_with(".vtk") && raw.tets.len() == 1224 && raw.label_source.is_none() {
                    continue;
                }
            }
            clean_refusal(&p, &format!("{name} cut at {cut}"));
        }
    }
}

/// Every byte of each binary header region flipped in turn: never a panic; a refusal is clean.
#[test]
fn flipped_bytes_never_panic() {
    let dir = scratch("flips");
    for name in [
        "octa.meshb",
        "octa_22bin.msh",
        "octa_41bin.msh",
        "octa_bin.vtk",
        "octa_zlib.vtu",
        "octa_appended_raw_zlib.vtu",
    ] {
        let data = std::fs::read(mesh(&format!("formats/binary/{name}"))).unwrap();
        let p = dir.join(name);
        // The start (headers, counts, the first records) and the tail (last sections).
        let tail = data.len().saturating_sub(300);
        for k in (0..600.min(data.len())).chain(tail..data.len()) {
            let mut d = data.clone();
            d[k] ^= 0xff;
            std::fs::write(&p, &d).unwrap();
            // A flip can also make a valid file with other numbers, or one the build
            // refuses (a huge coordinate, a degenerate tet): then the error names the tet's
            // line or the node, not a byte.
            if let Err(e) = meshio::load(&p, 1.0) {
                assert!(e.is_input(), "{name} byte {k}: {}", e.message);
                assert!(!e.message.contains(['\n', '\r']), "{name} byte {k}");
                assert!(
                    e.message.starts_with(&p.display().to_string()),
                    "{}",
                    e.message
                );
            }
        }
    }
}

/// Writes `data` with bytes `at..at + new.len()` replaced.
fn patched(dir: &Path, name: &str, data: &[u8], at: usize, new: &[u8]) -> PathBuf {
    let mut d = data.to_vec();
    d[at..at + new.len()].copy_from_slice(new);
    let p = dir.join(name);
    std::fs::write(&p, d).unwrap();
    p
}

fn find(hay: &[u8], needle: &[u8]) -> usize {
    hay.windows(needle.len())
        .position(|w| w == needle)
        .unwrap_or_else(|| panic!("{:?} not found", String::from_utf8_lossy(needle)))
}

/// Counts far larger than the file (2^60: allocating them would abort the test) are refused
/// before anything is allocated, naming the byte where the count is.
#[test]
fn oversized_counts_are_refused_before_allocating() {
    let dir = scratch("huge");
    let huge = (1u64 << 60).to_le_bytes();
    // MEDIT version 4: the vertex count (64-bit) after `4`, next position.
    let meshb = std::fs::read(mesh("formats/binary/octa.meshb")).unwrap();
    let p = patched(&dir, "a.meshb", &meshb, 36, &huge);
    let m = clean_refusal(&p, "meshb vertices");
    assert!(
        m.contains("byte 44: declares 1152921504606846976 vertices, more than the rest"),
        "{m}"
    );
    // Gmsh 4.1: the node count in the $Nodes header.
    let msh = std::fs::read(mesh("formats/binary/octa_41bin.msh")).unwrap();
    let at = find(&msh, b"$Nodes\n") + 7 + 8;
    let p = patched(&dir, "a.msh", &msh, at, &huge);
    let m = clean_refusal(&p, "msh 4.1 nodes");
    assert!(m.contains("more than the rest of the file can hold"), "{m}");
    // Gmsh 2.2: the element block's count of elements that follow.
    let msh = std::fs::read(mesh("formats/binary/octa_22bin.msh")).unwrap();
    let at = find(&msh, b"$Elements\n1224\n") + 15 + 4;
    let p = patched(&dir, "b.msh", &msh, at, &i32::MAX.to_le_bytes());
    let m = clean_refusal(&p, "msh 2.2 elements");
    assert!(m.contains(&format!("byte {}", at - 4)), "{m}");
    // VTK: POINTS with a count past the file.
    let vtk = std::fs::read(mesh("formats/binary/octa_bin.vtk")).unwrap();
    let at = find(&vtk, b"POINTS 330 ");
    let mut big = vtk[..at].to_vec();
    big.extend(b"POINTS 99999999 ");
    big.extend(&vtk[at + 11..]);
    let p = dir.join("a.vtk");
    std::fs::write(&p, big).unwrap();
    let m = clean_refusal(&p, "vtk points");
    assert!(m.contains("more than the rest of the file can hold"), "{m}");
    // VTU appended raw: the first array's block count.
    let vtu = std::fs::read(mesh("formats/binary/octa_appended_raw_zlib.vtu")).unwrap();
    let at = find(&vtu, b"\n_") + 2;
    let p = patched(&dir, "a.vtu", &vtu, at, &0x7fff_ffffu32.to_le_bytes());
    let m = clean_refusal(&p, "vtu blocks");
    assert!(
        m.contains(&format!("byte {}", at + 12)) && m.contains("compressed blocks"),
        "{m}"
    );
}

/// The plain nodes and tets of a MEDIT file (0-based tets).
fn medit_plain(path: &Path) -> (Vec<[f64; 3]>, Vec<[u32; 4]>) {
    let t = numbers(path);
    let v = t.iter().position(|l| l[0] == "Vertices").unwrap();
    let n: usize = t[v + 1][0].parse().unwrap();
    let nodes = t[v + 2..v + 2 + n]
        .iter()
        .map(|l| std::array::from_fn(|k| l[k].parse().unwrap()))
        .collect();
    let e = t.iter().position(|l| l[0] == "Tetrahedra").unwrap();
    let m: usize = t[e + 1][0].parse().unwrap();
    let tets = t[e + 2..e + 2 + m]
        .iter()
        .map(|l| std::array::from_fn(|k| l[k].parse::<u32>().unwrap() - 1))
        .collect();
    (nodes, tets)
}

/// The cow written here in three binary formats (writers of a few lines each, from the
/// MEDIT file's numbers) loads with the same counts as its ASCII files.
#[test]
fn the_cow_in_binary_formats_gives_the_same_counts() {
    let (nodes, tets) = medit_plain(&mesh("models/spot_tetgen_q1.414.mesh"));
    let dir = scratch("cow");
    // MEDIT binary version 2, little-endian.
    let mut b = Vec::new();
    let i = |b: &mut Vec<u8>, v: i32| b.extend(v.to_le_bytes());
    i(&mut b, 1);
    i(&mut b, 2);
    i(&mut b, 3);
    i(&mut b, 20);
    i(&mut b, 3);
    i(&mut b, 4);
    i(&mut b, 0);
    i(&mut b, nodes.len() as i32);
    for p in &nodes {
        p.iter().for_each(|c| b.extend(c.to_le_bytes()));
        i(&mut b, 0);
    }
    i(&mut b, 8);
    i(&mut b, 0);
    i(&mut b, tets.len() as i32);
    for t in &tets {
        t.iter().for_each(|&v| i(&mut b, v as i32 + 1));
        i(&mut b, 0);
    }
    i(&mut b, 54);
    std::fs::write(dir.join("cow.meshb"), &b).unwrap();
    // Gmsh 2.2 binary, big-endian, no tags.
    let mut g = b"$MeshFormat\n2.2 1 8\n".to_vec();
    g.extend(1i32.to_be_bytes());
    g.extend(format!("\n$EndMeshFormat\n$Nodes\n{}\n", nodes.len()).bytes());
    for (k, p) in nodes.iter().enumerate() {
        g.extend((k as i32 + 1).to_be_bytes());
        p.iter().for_each(|c| g.extend(c.to_be_bytes()));
    }
    g.extend(format!("\n$EndNodes\n$Elements\n{}\n", tets.len()).bytes());
    for v in [4, tets.len() as i32, 0] {
        g.extend(v.to_be_bytes());
    }
    for (k, t) in tets.iter().enumerate() {
        g.extend((k as i32 + 1).to_be_bytes());
        t.iter()
            .for_each(|&v| g.extend((v as i32 + 1).to_be_bytes()));
    }
    g.extend(b"\n$EndElements\n");
    std::fs::write(dir.join("cow.msh"), &g).unwrap();
    // VTU appended raw, uncompressed, UInt32 headers.
    let mut data = Vec::new();
    let mut offsets = Vec::new();
    let mut block = |bytes: Vec<u8>| {
        offsets.push(data.len());
        data.extend((bytes.len() as u32).to_le_bytes());
        data.extend(bytes);
    };
    block(
        nodes
            .iter()
            .flatten()
            .flat_map(|c| c.to_le_bytes())
            .collect(),
    );
    block(
        tets.iter()
            .flatten()
            .flat_map(|&v| (v as i64).to_le_bytes())
            .collect(),
    );
    block(
        (1..=tets.len() as i64)
            .flat_map(|k| (4 * k).to_le_bytes())
            .collect(),
    );
    block(vec![10u8; tets.len()]);
    let mut x = format!(
        "<VTKFile type=\"UnstructuredGrid\" byte_order=\"LittleEndian\">\n<UnstructuredGrid>\n\
         <Piece NumberOfPoints=\"{}\" NumberOfCells=\"{}\">\n<Points>\n\
         <DataArray type=\"Float64\" NumberOfComponents=\"3\" format=\"appended\" offset=\"{}\"/>\n\
         </Points>\n<Cells>\n\
         <DataArray type=\"Int64\" Name=\"connectivity\" format=\"appended\" offset=\"{}\"/>\n\
         <DataArray type=\"Int64\" Name=\"offsets\" format=\"appended\" offset=\"{}\"/>\n\
         <DataArray type=\"UInt8\" Name=\"types\" format=\"appended\" offset=\"{}\"/>\n\
         </Cells>\n</Piece>\n</UnstructuredGrid>\n<AppendedData encoding=\"raw\">\n_",
        nodes.len(),
        tets.len(),
        offsets[0],
        offsets[1],
        offsets[2],
        offsets[3]
    )
    .into_bytes();
    x.extend(data);
    x.extend(b"\n</AppendedData>\n</VTKFile>\n");
    std::fs::write(dir.join("cow.vtu"), &x).unwrap();

    let counts = |p: &Path| {
        let mut m = meshio::load(p, 1.0).unwrap_or_else(|e| panic!("{e}"));
        let s = m.mesh.stats();
        m.mesh.view().validate().expect("valid");
        (
            m.mesh.positions().len(),
            m.mesh.tets().len(),
            s.boundary_faces,
            s.boundary_nodes,
        )
    };
    let want = counts(&mesh("models/spot_tetgen_q1.414.ele"));
    assert_eq!(want.1, 18_098);
    for f in ["cow.meshb", "cow.msh", "cow.vtu"] {
        assert_eq!(counts(&dir.join(f)), want, "{f}");
    }
    for ascii in ["mesh", "msh22.msh", "msh41.msh", "vtk", "vtu"] {
        let p = mesh(&format!("models/spot_tetgen_q1.414.{ascii}"));
        assert_eq!(counts(&p), want, "{ascii}");
    }
}

/// The octahedron written here as ASCII Gmsh 2.2 (physical tags), Gmsh 4.1 (`$Entities`),
/// VTK 4.2 (`POINT_DATA` first, then `CELL_DATA` with a float and an integer array) and VTU
/// (`CellData`): the labels come back.
#[test]
fn ascii_files_carry_their_labels() {
    let o = oracle();
    let dir = scratch("ascii-labels");
    let n = o.nodes.len();
    let m = o.tets.len();
    let xyz = |p: &[f64; 3]| format!("{} {} {}", p[0], p[1], p[2]);
    // Gmsh 2.2: tags = physical, elementary.
    let mut g = format!("$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n{n}\n");
    for (k, p) in o.nodes.iter().enumerate() {
        g += &format!("{} {}\n", k + 1, xyz(p));
    }
    g += &format!("$EndNodes\n$Elements\n{m}\n");
    for (k, (t, l)) in o.tets.iter().zip(&o.labels).enumerate() {
        g += &format!(
            "{} 4 2 {l} 7 {} {} {} {}\n",
            k + 1,
            t[0] + 1,
            t[1] + 1,
            t[2] + 1,
            t[3] + 1
        );
    }
    g += "$EndElements\n";
    std::fs::write(dir.join("a.msh"), &g).unwrap();
    // Gmsh 4.1: volume entities 10 and 20 with physical tags 1 and 2; one block per run.
    let mut g = "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Entities\n1 0 0 2\n".to_string();
    g += "5 0 0 0 1 77\n10 0 0 0 1 1 1 1 1 0\n20 0 0 0 1 1 1 1 2 0\n$EndEntities\n";
    g += &format!("$Nodes\n1 {n} 1 {n}\n3 10 0 {n}\n");
    for k in 0..n {
        g += &format!("{}\n", k + 1);
    }
    for p in &o.nodes {
        g += &format!("{}\n", xyz(p));
    }
    g += "$EndNodes\n";
    let mut runs: Vec<(i32, usize, usize)> = Vec::new();
    for (k, &l) in o.labels.iter().enumerate() {
        match runs.last_mut() {
            Some(r) if r.0 == l => r.2 += 1,
            _ => runs.push((l, k, 1)),
        }
    }
    g += &format!("$Elements\n{} {m} 1 {m}\n", runs.len());
    for (l, start, len) in &runs {
        g += &format!("3 {} 4 {len}\n", l * 10);
        for k in *start..start + len {
            let t = o.tets[k];
            g += &format!(
                "{} {} {} {} {}\n",
                k + 1,
                t[0] + 1,
                t[1] + 1,
                t[2] + 1,
                t[3] + 1
            );
        }
    }
    g += "$EndElements\n";
    std::fs::write(dir.join("b.msh"), &g).unwrap();
    // VTK 4.2.
    let mut v = format!(
        "# vtk DataFile Version 4.2\nocta, written by Müller\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS {n} double\n"
    );
    for p in &o.nodes {
        v += &format!("{}\n", xyz(p));
    }
    v += &format!("CELLS {m} {}\n", 5 * m);
    for t in &o.tets {
        v += &format!("4 {} {} {} {}\n", t[0], t[1], t[2], t[3]);
    }
    v += &format!("CELL_TYPES {m}\n{}", "10\n".repeat(m));
    v += &format!(
        "POINT_DATA {n}\nSCALARS temp float 1\nLOOKUP_TABLE default\n{}",
        "0.5\n".repeat(n)
    );
    v += &format!("VECTORS u double\n{}", "0 0 1\n".repeat(n));
    v += &format!(
        "CELL_DATA {m}\nSCALARS density float\nLOOKUP_TABLE default\n{}",
        "1.5\n".repeat(m)
    );
    v += "SCALARS region int 1\nLOOKUP_TABLE default\n";
    for l in &o.labels {
        v += &format!("{l}\n");
    }
    std::fs::write(dir.join("c.vtk"), &v).unwrap();
    // VTU with ASCII arrays.
    let mut u = format!(
        "<VTKFile type=\"UnstructuredGrid\"><UnstructuredGrid><Piece NumberOfPoints=\"{n}\" NumberOfCells=\"{m}\">\n\
         <Points><DataArray type=\"Float64\" NumberOfComponents=\"3\" format=\"ascii\">\n"
    );
    for p in &o.nodes {
        u += &format!("{}\n", xyz(p));
    }
    u += "</DataArray></Points><Cells><DataArray type=\"Int32\" Name=\"connectivity\" format=\"ascii\">\n";
    for t in &o.tets {
        u += &format!("{} {} {} {}\n", t[0], t[1], t[2], t[3]);
    }
    u += "</DataArray><DataArray type=\"Int32\" Name=\"offsets\" format=\"ascii\">\n";
    for k in 1..=m {
        u += &format!("{}\n", 4 * k);
    }
    u += &format!(
        "</DataArray><DataArray type=\"UInt8\" Name=\"types\" format=\"ascii\">\n{}</DataArray></Cells>\n",
        "10\n".repeat(m)
    );
    u += "<CellData><DataArray type=\"Float32\" Name=\"material\" format=\"ascii\">\n";
    u += &"2.5\n".repeat(m);
    u += "</DataArray><DataArray type=\"Int16\" Name=\"CellEntityIds\" format=\"ascii\">\n";
    for l in &o.labels {
        u += &format!("{l}\n");
    }
    u += "</DataArray></CellData></Piece></UnstructuredGrid></VTKFile>\n";
    std::fs::write(dir.join("d.vtu"), &u).unwrap();

    for (f, source) in [
        ("a.msh", "Gmsh physical tags"),
        ("b.msh", "Gmsh physical tags"),
        ("c.vtk", "cell data 'region'"),
        ("d.vtu", "cell data 'CellEntityIds'"),
    ] {
        let raw = meshio::read(&dir.join(f)).unwrap_or_else(|e| panic!("{f}: {e}"));
        same_as_oracle(&raw, &o, false, true, f);
        assert_eq!(raw.label_source.as_deref(), Some(source), "{f}");
    }
    // A float array asked for by name is refused, naming the file and the array.
    for (f, name) in [("c.vtk", "density"), ("d.vtu", "material")] {
        let p = dir.join(f);
        let opts = ReadOptions {
            region_array: Some(name.into()),
            ..ReadOptions::default()
        };
        let e = meshio::load_with(&p, 1.0, &opts).unwrap_err();
        assert!(e.is_input());
        assert!(
            e.message.starts_with(&p.display().to_string()),
            "{}",
            e.message
        );
        assert!(
            e.message.contains(&format!("'{name}'")) && e.message.contains("integer"),
            "{}",
            e.message
        );
    }
    // --region-array on a format without named arrays is refused.
    let opts = ReadOptions {
        region_array: Some("material".into()),
        ..ReadOptions::default()
    };
    let e = meshio::read_with(&dir.join("a.msh"), &opts).unwrap_err();
    assert!(
        e.message.contains("--region-array 'material'"),
        "{}",
        e.message
    );
}

/// A cut gzip file is refused as such (the gzip trailer is missing), naming how much came out;
/// a file named `.gz` that is not gzip is refused too.
#[test]
fn truncated_gzip_files_are_refused() {
    let dir = scratch("gz");
    let data = std::fs::read(mesh("formats/binary/octa_refs.mesh.gz")).unwrap();
    let p = dir.join("a.mesh.gz");
    for cut in (2..data.len()).step_by(211) {
        std::fs::write(&p, &data[..cut]).unwrap();
        let m = clean_refusal(&p, &format!("gz cut at {cut}"));
        assert!(m.contains("corrupt or truncated gzip data after "), "{m}");
    }
    std::fs::write(&p, b"MeshVersionFormatted 2\n").unwrap();
    let m = clean_refusal(&p, "not gzip");
    assert!(m.contains("not a gzip file"), "{m}");
}
