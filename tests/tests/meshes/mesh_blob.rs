//! The mesh blob (`tetradrill_core::blob`): a round trip against the built mesh, every field
//! of every record; any corrupted byte, a wrong version, a truncated or lengthened blob is an
//! error, never a panic.
//!
//! Oracles: the built mesh itself (its records read through `Mesh`, not through the blob),
//! and the layout table of the module's docs, decoded here by hand for the header.

use tetradrill::meshio::{self, LoadedMesh};
use tetradrill_core::blob::{self, BlobError, MeshBlob, HEADER_LEN, VERSION};
use tetradrill_core::{NodeId, TetId};
use tetradrill_tests::{meshes_dir, refused, scratch_dir, tetradrill_bin};

fn cow() -> LoadedMesh {
    let path = meshes_dir().join("models/spot_tetgen_q1.414.node");
    meshio::load(&path, 1.0).expect("the cow loads")
}

fn small() -> LoadedMesh {
    meshio::load(std::path::Path::new("builtin:block:2"), 1.0).expect("block")
}

/// The blob of `m`, with labels `labels` (the loaded ones when `None`).
fn blob_of(m: &mut LoadedMesh, labels: Option<Vec<i32>>) -> Vec<u8> {
    let labels = labels.unwrap_or_else(|| m.labels.clone());
    let mesh = m.mesh.view();
    let len = blob::blob_len(mesh.node_count(), mesh.tet_count()).expect("fits");
    let mut out = vec![0u8; len];
    assert_eq!(blob::write(&mesh, &labels, &mut out), Ok(len));
    out
}

fn le32(b: &[u8], at: usize) -> u32 {
    u32::from_le_bytes(b[at..at + 4].try_into().unwrap())
}

#[test]
fn round_trip_of_the_cow_every_field() {
    let mut m = cow();
    // Labels that differ per tet, so a shifted or swapped label shows.
    let t = m.mesh.view().tet_count();
    let labels: Vec<i32> = (0..t as i32).map(|i| i * 7 - 1000).collect();
    let bytes = blob_of(&mut m, Some(labels.clone()));
    let mesh = m.mesh.view();
    assert!(
        mesh.tet_count() > 15_000,
        "the cow has {} tets",
        mesh.tet_count()
    );

    // The header by hand, from the documented layout.
    assert_eq!(&bytes[0..4], b"TDMB");
    assert_eq!(u16::from_le_bytes([bytes[4], bytes[5]]), VERSION);
    assert_eq!(
        u16::from_le_bytes([bytes[6], bytes[7]]) as usize,
        HEADER_LEN
    );
    assert_eq!(le32(&bytes, 8) as usize, mesh.node_count());
    assert_eq!(le32(&bytes, 12) as usize, mesh.tet_count());
    let payload = 32 * mesh.node_count() + 40 * mesh.tet_count();
    assert_eq!(le32(&bytes, 16) as usize, payload);
    assert_eq!(bytes.len(), HEADER_LEN + payload);

    let view = MeshBlob::parse(&bytes).expect("parses");
    assert_eq!(view.node_count(), mesh.node_count());
    assert_eq!(view.tet_count(), mesh.tet_count());
    for i in 0..mesh.node_count() {
        let n = NodeId(i as u32);
        assert_eq!(
            view.position(n).unwrap().to_array().map(f32::to_bits),
            mesh.position(n).to_array().map(f32::to_bits),
            "position {i}"
        );
        assert_eq!(
            view.normal(n).unwrap().to_array().map(f32::to_bits),
            mesh.normal(n).to_array().map(f32::to_bits),
            "normal {i}"
        );
        assert_eq!(view.node(n), Some(mesh.node(n)), "node {i}");
    }
    let mut boundary_faces = 0;
    assert_eq!(labels.len(), mesh.tet_count());
    for (i, &label) in labels.iter().enumerate() {
        let t = TetId(i as u32);
        let rec = view.tet(t).unwrap();
        assert_eq!(rec, mesh.tet(t), "tet {i}");
        assert_eq!(view.label(t), Some(label), "label {i}");
        boundary_faces += rec.neighbours.iter().filter(|n| **n == TetId::NONE).count();
    }
    assert_eq!(boundary_faces, mesh.stats().boundary_faces as usize);
    // Out of range is None, not a panic.
    assert_eq!(view.position(NodeId(mesh.node_count() as u32)), None);
    assert_eq!(view.tet(TetId(mesh.tet_count() as u32)), None);
    assert_eq!(view.label(TetId::NONE), None);
}

#[test]
fn every_corrupted_byte_is_an_error() {
    let mut m = small();
    let bytes = blob_of(&mut m, None);
    assert!(MeshBlob::parse(&bytes).is_ok());
    for at in 0..bytes.len() {
        for flip in [0x01u8, 0x80, 0xff] {
            let mut bad = bytes.clone();
            bad[at] ^= flip;
            assert!(
                MeshBlob::parse(&bad).is_err(),
                "byte {at} ^ {flip:#x} accepted"
            );
        }
    }
}

#[test]
fn corrupted_bytes_of_the_cow_are_errors() {
    let mut m = cow();
    let bytes = blob_of(&mut m, None);
    // A spread of offsets through every section (a prime stride).
    for at in (0..bytes.len()).step_by(997) {
        let mut bad = bytes.clone();
        bad[at] = bad[at].wrapping_add(1);
        assert!(MeshBlob::parse(&bad).is_err(), "byte {at} accepted");
    }
}

#[test]
fn wrong_version_magic_and_header_length_are_named() {
    let mut m = small();
    let bytes = blob_of(&mut m, None);
    let mut v2 = bytes.clone();
    v2[4..6].copy_from_slice(&2u16.to_le_bytes());
    assert_eq!(MeshBlob::parse(&v2).unwrap_err(), BlobError::Version(2));
    assert!(MeshBlob::parse(&v2)
        .unwrap_err()
        .to_string()
        .contains("version 2"));
    let mut magic = bytes.clone();
    magic[0] = b'X';
    assert_eq!(MeshBlob::parse(&magic).unwrap_err(), BlobError::BadMagic);
    let mut header = bytes.clone();
    header[6] = 25;
    assert_eq!(
        MeshBlob::parse(&header).unwrap_err(),
        BlobError::HeaderLength(25)
    );
}

#[test]
fn every_truncation_and_an_extension_are_errors() {
    let mut m = small();
    let bytes = blob_of(&mut m, None);
    for len in 0..bytes.len() {
        let err = MeshBlob::parse(&bytes[..len]).expect_err("truncated blob accepted");
        assert!(
            matches!(err, BlobError::Truncated { .. }),
            "length {len}: {err}"
        );
    }
    let mut longer = bytes.clone();
    longer.push(0);
    assert!(matches!(
        MeshBlob::parse(&longer),
        Err(BlobError::TrailingBytes { .. })
    ));
}

/// A fuzz-style pass: seeded random truncations, corruptions and forged headers (with the
/// checksum recomputed, so the record checks are reached) never panic, and a forged record
/// that points outside the mesh is refused.
#[test]
fn random_damage_never_panics() {
    let mut m = small();
    let bytes = blob_of(&mut m, None);
    let mut state = 0x9e37_79b9_7f4a_7c15u64;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        state
    };
    let mut refused = 0;
    for _ in 0..20_000 {
        let mut bad = bytes.clone();
        for _ in 0..1 + next() % 4 {
            let at = (next() as usize) % bad.len();
            bad[at] = next() as u8;
        }
        if next() % 2 == 0 {
            // Re-seal: only the record checks stand between the damage and the view.
            let sum = blob::checksum(&bad[HEADER_LEN..]);
            bad[20..24].copy_from_slice(&sum.to_le_bytes());
        }
        let cut = if next() % 8 == 0 {
            (next() as usize) % bad.len()
        } else {
            bad.len()
        };
        match MeshBlob::parse(&bad[..cut]) {
            Ok(view) => {
                // Whatever got through reads without panicking and stays in range.
                for t in 0..view.tet_count() {
                    let rec = view.tet(TetId(t as u32)).unwrap();
                    assert!(rec.nodes.iter().all(|n| n.idx() < view.node_count()));
                }
            }
            Err(_) => refused += 1,
        }
    }
    assert!(refused > 10_000, "only {refused} refused");

    // A sealed blob whose first tet names a node past the end.
    let mut forged = bytes.clone();
    let nodes = le32(&bytes, 8) as usize;
    let tet0 = HEADER_LEN + 32 * nodes;
    forged[tet0..tet0 + 4].copy_from_slice(&(nodes as u32).to_le_bytes());
    let sum = blob::checksum(&forged[HEADER_LEN..]);
    forged[20..24].copy_from_slice(&sum.to_le_bytes());
    assert_eq!(
        MeshBlob::parse(&forged).unwrap_err(),
        BlobError::BadRecord {
            what: "tet: node id out of range",
            offset: tet0
        }
    );
}

#[test]
fn write_refuses_wrong_lengths() {
    let mut m = small();
    let labels = m.labels.clone();
    let mesh = m.mesh.view();
    let len = blob::blob_len(mesh.node_count(), mesh.tet_count()).unwrap();
    let mut short = vec![0u8; len - 1];
    assert_eq!(
        blob::write(&mesh, &labels, &mut short),
        Err(BlobError::Buffer)
    );
    let mut out = vec![0u8; len];
    assert_eq!(
        blob::write(&mesh, &labels[1..], &mut out),
        Err(BlobError::Buffer)
    );
    assert_eq!(blob::blob_len(usize::MAX, 1), None);
}

/// `tetradrill export --firmware OUT --mesh FILE` writes the blob of the mesh every command
/// builds: the file parses and holds the cow's counts and records.
#[test]
fn export_command_writes_the_built_mesh() {
    let dir = scratch_dir("blob", "export");
    let out = dir.join("cow.tdb");
    let cow_path = meshes_dir().join("models/spot_tetgen_q1.414.node");
    let status = std::process::Command::new(tetradrill_bin())
        .args(["export", "--quiet", "--firmware"])
        .arg(&out)
        .arg("--mesh")
        .arg(&cow_path)
        .status()
        .expect("run tetradrill");
    assert!(status.success());
    let bytes = std::fs::read(&out).expect("the blob");
    let view = MeshBlob::parse(&bytes).expect("parses");
    let mut m = cow();
    let mesh = m.mesh.view();
    assert_eq!(
        (view.node_count(), view.tet_count()),
        (mesh.node_count(), mesh.tet_count())
    );
    for i in (0..mesh.tet_count()).step_by(101) {
        let t = TetId(i as u32);
        assert_eq!(view.tet(t), Some(mesh.tet(t)), "tet {i}");
    }
    let bad_dir = dir.join("missing").join("x.tdb");
    refused(
        &[
            "export",
            "--firmware",
            bad_dir.to_str().unwrap(),
            "--mesh",
            "builtin:block:2",
        ],
        &["x.tdb", "cannot write"],
    );
    refused(
        &[
            "export",
            "--firmware",
            out.to_str().unwrap(),
            "--mesh",
            "/nonexistent/cow.node",
        ],
        &["/nonexistent/cow.node"],
    );
}
