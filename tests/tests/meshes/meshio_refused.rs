//! Bad mesh files: every kind (truncated, indices out of range, NaN and infinite coordinates,
//! zero-volume and non-manifold tets, empty and binary files, counts larger than the file, an
//! unknown extension or a missing partner) is refused with exit status 2 and one line naming
//! file, line and reason; randomly mutated files are refused or read, never a panic.

use std::path::Path;

use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use tetradrill::meshio;
use tetradrill_tests::mesh;
use tetradrill_tests::scratch_dir;

/// Writes `files` into a fresh folder, loads the first, and checks the refusal: exit status
/// 2, one line, starting with the file that is wrong (`bad_file`, default the first), the
/// line when given, and a reason containing `reason`.
fn refused(
    name: &str,
    files: &[(&str, &[u8])],
    bad_file: Option<&str>,
    line: Option<usize>,
    reason: &str,
) {
    let dir = scratch_dir("meshio", name);
    for (f, bytes) in files {
        std::fs::write(dir.join(f), bytes).unwrap();
    }
    let path = dir.join(files[0].0);
    let e = match meshio::load(&path, 1.0) {
        Ok(_) => panic!("{name}: loaded a bad file"),
        Err(e) => e,
    };
    let msg = e.message.clone();
    assert!(e.is_input(), "{name}: {msg}");
    assert!(!msg.contains('\n'), "{name}: more than one line: {msg}");
    let file = dir.join(bad_file.unwrap_or(files[0].0));
    let prefix = match line {
        Some(l) => format!("{}:{l}: ", file.display()),
        None => format!("{}: ", file.display()),
    };
    assert!(
        msg.starts_with(&prefix),
        "{name}: expected '{prefix}...', got '{msg}'"
    );
    assert!(
        msg.to_lowercase().contains(&reason.to_lowercase()),
        "{name}: expected '{reason}' in '{msg}'"
    );
}

const NODE4: &str = "4 3 0 0\n0 0 0 0\n1 1 0 0\n2 0 1 0\n3 0 0 1\n";

#[test]
fn truncated_files() {
    // The cow's files cut at a line boundary 50 lines before the end.
    let files = [
        "node",
        "ele",
        "mesh",
        "msh22.msh",
        "msh41.msh",
        "vtk",
        "vtu",
    ];
    for ext in files {
        let text =
            std::fs::read_to_string(mesh(&format!("models/spot_tetgen_q1.414.{ext}"))).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        let keep = lines.len() - 50;
        let cut = lines[..keep].join("\n") + "\n";
        let mut files: Vec<(String, Vec<u8>)> = vec![(format!("a.{ext}"), cut.into_bytes())];
        if ext == "node" || ext == "ele" {
            let other = if ext == "node" { "ele" } else { "node" };
            let partner =
                std::fs::read(mesh(&format!("models/spot_tetgen_q1.414.{other}"))).unwrap();
            files.push((format!("a.{other}"), partner));
        }
        let files: Vec<(&str, &[u8])> = files
            .iter()
            .map(|(n, b)| (n.as_str(), b.as_slice()))
            .collect();
        refused(
            &format!("trunc-{ext}"),
            &files,
            None,
            Some(keep),
            "truncated",
        );
    }
}

#[test]
fn indices_out_of_range() {
    refused(
        "range-ele",
        &[
            ("a.ele", b"1 4 0\n# a comment line\n0 0 1 2 4\n"),
            ("a.node", NODE4.as_bytes()),
        ],
        None,
        Some(3),
        "node index 4 out of range",
    );
    // 1-based node file: node 0 does not exist.
    let node1 = "4 3 0 0\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n";
    refused(
        "zero-in-1-based",
        &[
            ("a.node", node1.as_bytes()),
            ("a.ele", b"1 4 0\n1 0 1 2 3\n"),
        ],
        Some("a.ele"),
        Some(2),
        "node index 0 in a 1-based file",
    );
    let medit = "MeshVersionFormatted 2\nDimension 3\nVertices\n4\n0 0 0 1\n1 0 0 1\n0 1 0 1\n\
                 0 0 1 1\nTetrahedra\n1\n0 1 2 3 1\nEnd\n";
    refused(
        "zero-medit",
        &[("a.mesh", medit.as_bytes())],
        None,
        Some(11),
        "node index 0",
    );
    let msh = std::fs::read_to_string(mesh("cube12/cube12.msh")).unwrap();
    let bad = msh.replace("5 4 2 0 0 9 1 5 6", "5 4 2 0 0 9 1 5 60");
    refused(
        "range-msh",
        &[("a.msh", bad.as_bytes())],
        None,
        Some(22),
        "node 60 out of range",
    );
    let vtk = std::fs::read_to_string(mesh("cube12/cube12.vtk")).unwrap();
    let bad = vtk.replace("4 8 2 3 7", "4 8 2 3 9");
    refused(
        "range-vtk",
        &[("a.vtk", bad.as_bytes())],
        None,
        Some(22),
        "out of range",
    );
    let vtu = std::fs::read_to_string(mesh("cube12/cube12.vtu")).unwrap();
    let bad = vtu.replace("8 2 3 7", "8 2 3 -1");
    refused(
        "range-vtu",
        &[("a.vtu", bad.as_bytes())],
        None,
        Some(26),
        "out of range",
    );
}

#[test]
fn nan_and_infinite_coordinates() {
    let node = NODE4.replace("2 0 1 0", "2 0 nan 0");
    refused(
        "nan-node",
        &[
            ("a.node", node.as_bytes()),
            ("a.ele", b"1 4 0\n0 0 1 2 3\n"),
        ],
        None,
        Some(4),
        "NaN or infinite",
    );
    let vtk = std::fs::read_to_string(mesh("cube12/cube12.vtk")).unwrap();
    let bad = vtk.replacen("\n0 0 0\n", "\n0 0 inf\n", 1);
    refused(
        "inf-vtk",
        &[("a.vtk", bad.as_bytes())],
        None,
        Some(14),
        "NaN or infinite",
    );
    let msh = std::fs::read_to_string(mesh("cube12/cube12.msh")).unwrap();
    let bad = msh.replace("9 0.0000000000000000e+00", "9 1e999");
    refused(
        "inf-msh",
        &[("a.msh", bad.as_bytes())],
        None,
        Some(14),
        "NaN or infinite",
    );
}

#[test]
fn zero_volume_and_non_manifold_tets() {
    let flat = "4 3 0 0\n0 0 0 0\n1 1 0 0\n2 0 1 0\n3 1 1 0\n";
    refused(
        "zero-volume",
        &[
            ("a.ele", b"1 4 0\n\n0 0 1 2 3\n"),
            ("a.node", flat.as_bytes()),
        ],
        None,
        Some(3),
        "zero volume",
    );
    // Three tets on the face (0, 1, 2).
    let fan = "6 3 0 0\n0 0 0 0\n1 1 0 0\n2 0 1 0\n3 0 0 1\n4 0 0 -1\n5 0.2 0.2 2\n";
    // Any of the three tets may be named (files load in spatial order): one of lines 2 to 4.
    let dir = scratch_dir("meshio", "three-on-a-face");
    std::fs::write(
        dir.join("a.ele"),
        "3 4 0\n0 0 1 2 3\n1 0 2 1 4\n2 0 1 2 5\n",
    )
    .unwrap();
    std::fs::write(dir.join("a.node"), fan).unwrap();
    let p = dir.join("a.ele");
    let e = meshio::load(&p, 1.0).unwrap_err();
    assert!(e.is_input());
    let ok = (2..=4).any(|l| e.message.starts_with(&format!("{}:{l}: ", p.display())));
    assert!(
        ok && e.message.contains("more than two tets") && !e.message.contains('\n'),
        "{}",
        e.message
    );
    // The same, through Gmsh, with the line of one of the three tets.
    let msh = "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n6\n1 0 0 0\n2 1 0 0\n3 0 1 0\n\
               4 0 0 1\n5 0 0 -1\n6 0.2 0.2 2\n$EndNodes\n$Elements\n3\n1 4 0 1 2 3 4\n\
               2 4 0 1 3 2 5\n3 4 0 1 2 3 6\n$EndElements\n";
    let dir = scratch_dir("meshio", "three-on-a-face-msh");
    let p = dir.join("a.msh");
    std::fs::write(&p, msh).unwrap();
    let e = meshio::load(&p, 1.0).unwrap_err();
    assert!(e.is_input());
    let ok = (15..=17).any(|l| e.message.starts_with(&format!("{}:{l}: ", p.display())));
    assert!(
        ok && e.message.contains("more than two tets"),
        "{}",
        e.message
    );
}

#[test]
fn empty_and_binary_files() {
    refused("empty-mesh", &[("a.mesh", b"")], None, None, "empty file");
    refused(
        "blank-vtu",
        &[("a.vtu", b"\n \n")],
        None,
        None,
        "empty file",
    );
    refused(
        "empty-ele",
        &[("a.node", NODE4.as_bytes()), ("a.ele", b"")],
        Some("a.ele"),
        None,
        "empty file",
    );
    // Binary bytes in a file whose header says text.
    let mut bin = b"$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n".to_vec();
    bin.extend_from_slice(&[0, 1, 2, 0xff, 0xfe, 0]);
    refused(
        "nul-msh",
        &[("a.msh", &bin)],
        None,
        Some(5),
        "binary data in a text",
    );
    // Binary headers with nothing after them: the reader names the byte where data is missing.
    refused(
        "binary-msh",
        &[("a.msh", b"$MeshFormat\n2.2 1 8\n$EndMeshFormat\n")],
        None,
        None,
        "byte 20: expected the integer 1",
    );
    refused(
        "binary-vtk",
        &[(
            "a.vtk",
            b"# vtk DataFile Version 4.2\ntitle\nBINARY\nDATASET UNSTRUCTURED_GRID\n",
        )],
        None,
        None,
        "no POINTS section",
    );
    let vtu = std::fs::read_to_string(mesh("cube12/cube12.vtu")).unwrap();
    let bad = vtu.replacen("format=\"ascii\"", "format=\"binary\"", 1);
    refused(
        "binary-vtu",
        &[("a.vtu", bad.as_bytes())],
        None,
        Some(6),
        "bad base64",
    );
    refused("appended-vtu", &[("a.vtu", b"<VTKFile type=\"UnstructuredGrid\"><AppendedData encoding=\"raw\">_abc</AppendedData></VTKFile>")], None, None, "no <Piece>");
    refused(
        "meshb",
        &[("a.meshb", &[1, 0, 0, 0, 3, 0])],
        None,
        None,
        "byte 4: unexpected end of file (truncated?): the version needs 4 bytes, 2 left",
    );
}

#[test]
fn declared_counts_larger_than_the_file() {
    refused(
        "huge-node",
        &[
            ("a.node", b"4000000000 3 0 0\n0 0 0 0\n"),
            ("a.ele", b"1 4 0\n0 0 1 2 3\n"),
        ],
        None,
        Some(1),
        "more than the rest of the file can hold",
    );
    refused(
        "huge-ele",
        &[
            ("a.ele", b"# big\n900000 4 0\n0 0 1 2 3\n"),
            ("a.node", NODE4.as_bytes()),
        ],
        None,
        Some(2),
        "more than the rest of the file can hold",
    );
    refused(
        "huge-medit",
        &[(
            "a.mesh",
            b"MeshVersionFormatted 2\nDimension 3\nVertices\n99999999999\n0 0 0 1\n",
        )],
        None,
        Some(4),
        "more than the rest of the file can hold",
    );
    refused(
        "huge-msh",
        &[(
            "a.msh",
            b"$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n18446744073709551615\n1 0 0 0\n",
        )],
        None,
        Some(5),
        "more than the rest of the file can hold",
    );
    refused(
        "huge-msh41",
        &[("a.msh", b"$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Nodes\n1 5000000 1 5000000\n3 1 0 5000000\n1\n0 0 0\n")],
        None,
        Some(5),
        "more than the rest of the file can hold",
    );
    refused(
        "huge-vtk",
        &[("a.vtk", b"# vtk DataFile Version 5.1\nt\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 123456789 double\n0 0 0\n")],
        None,
        Some(5),
        "more than the rest of the file can hold",
    );
}

#[test]
fn unknown_extension_and_missing_partner() {
    refused(
        "ext",
        &[("a.obj", b"v 0 0 0\n")],
        None,
        None,
        "unknown mesh file extension",
    );
    refused(
        "noext",
        &[("mesh", b"v 0 0 0\n")],
        None,
        None,
        "no extension",
    );
    refused(
        "partner",
        &[("a.node", NODE4.as_bytes())],
        None,
        None,
        "a.ele not found",
    );
    let e = meshio::load(Path::new("/nonexistent/x.mesh"), 1.0).unwrap_err();
    assert!(e.is_input());
    assert!(
        e.message.starts_with("/nonexistent/x.mesh: cannot read"),
        "{}",
        e.message
    );
    let e = meshio::load(&mesh("cube12/cube12.mesh"), f64::NAN).unwrap_err();
    assert!(e.is_input());
    assert!(e.message.contains("--scale"), "{}", e.message);
}

/// Small fuzzing: random edits of real files (a cut, a byte changed, a line dropped or
/// repeated, a number blown up) are either read or refused with status 2 and one line; no
/// edit may panic.
#[test]
fn mutated_files_never_panic() {
    let dir = scratch_dir("meshio", "fuzz");
    let mut rng = StdRng::seed_from_u64(0xf022);
    let sources = [
        "cube12/cube12.mesh",
        "cube12/cube12.msh",
        "cube12/cube12.vtk",
        "cube12/cube12.vtu",
        "cube12/cube12.ele",
        "formats/sofa_msh4_cube.msh",
        "formats/sfepy_msh_tetra.msh",
    ];
    let alphabet = b"0123456789 -.\n#$<>/\"=eE+xnaif\t\xc3\xa9";
    let (mut ok, mut refused) = (0, 0);
    for src in sources {
        let path = mesh(src);
        let bytes = std::fs::read(&path).unwrap();
        let ext = path.extension().unwrap().to_str().unwrap();
        let node = std::fs::read(mesh("cube12/cube12.node")).unwrap();
        for round in 0..150 {
            let mut b = bytes.clone();
            for _ in 0..rng.gen_range(1..4) {
                if b.is_empty() {
                    break;
                }
                let at = rng.gen_range(0..b.len());
                match rng.gen_range(0..5) {
                    0 => b.truncate(at),
                    1 => b[at] = alphabet[rng.gen_range(0..alphabet.len())],
                    2 => {
                        let end = b[at..]
                            .iter()
                            .position(|&c| c == b'\n')
                            .map_or(b.len(), |e| at + e + 1);
                        b.drain(at..end);
                    }
                    3 => {
                        let end = b[at..]
                            .iter()
                            .position(|&c| c == b'\n')
                            .map_or(b.len(), |e| at + e + 1);
                        let line = b[at..end].to_vec();
                        b.splice(at..at, line);
                    }
                    _ => b
                        .splice(at..at, b"99999999999".iter().copied())
                        .for_each(drop),
                }
            }
            let f = dir.join(format!("m{round}.{ext}"));
            std::fs::write(&f, &b).unwrap();
            if ext == "ele" {
                std::fs::write(dir.join(format!("m{round}.node")), &node).unwrap();
            }
            match meshio::load(&f, 1.0) {
                Ok(mut m) => {
                    ok += 1;
                    m.mesh.view().validate().unwrap();
                }
                Err(e) => {
                    refused += 1;
                    assert!(e.is_input(), "{}: {}", f.display(), e.message);
                    assert!(!e.message.contains('\n'), "{}", e.message);
                    assert!(
                        e.message.starts_with(dir.to_str().unwrap()),
                        "{}",
                        e.message
                    );
                }
            }
        }
    }
    assert!(ok > 0 && refused > 0, "ok {ok}, refused {refused}");
}
