//! `tetradrill info`: in-process through `tetradrill::cli::run`, and as the real binary for
//! exit statuses and the one-line error contract.

use std::path::Path;
use std::process::{Command, Output};

use tetradrill::cli::{self, Cli};
use tetradrill::commands::info::{dihedral_angles, InfoArgs};
use tetradrill_tests::{mesh, scratch_dir, tetradrill_bin, Scratch};

fn scratch(name: &str) -> Scratch {
    scratch_dir("info", name)
}

/// Runs `info` in process, writing JSON to a file; returns the parsed JSON.
fn info_json(mesh_path: &Path, scale: f64) -> serde_json::Value {
    let dir = scratch(&format!(
        "json-{}",
        mesh_path.file_name().unwrap().to_string_lossy()
    ));
    let out = dir.join("info.json");
    let cli = Cli {
        command: cli::Command::Info(InfoArgs {
            mesh: mesh_path.to_path_buf(),
            json: Some(out.clone()),
            scale,
            region_array: None,
        }),
    };
    cli::run(cli).unwrap_or_else(|e| panic!("{e}"));
    serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap()
}

#[test]
fn json_has_the_documented_fields() {
    let j = info_json(&mesh("cube12/cube12.vtu"), 1.0);
    for key in [
        "nodes",
        "tets",
        "boundary_faces",
        "boundary_nodes",
        "bytes_per_tet",
        "orientation_fixes",
        "unreferenced_nodes",
        "valid",
        "min_dihedral_deg",
        "max_dihedral_deg",
        "volume",
        "bounding_box",
        "format",
        "file",
    ] {
        assert!(j.get(key).is_some(), "missing {key} in {j}");
    }
    assert_eq!(j["nodes"], 9);
    assert_eq!(j["tets"], 12);
    assert_eq!(j["boundary_faces"], 12);
    assert_eq!(j["boundary_nodes"], 8);
    assert_eq!(j["valid"], true);
    assert_eq!(j["format"], "vtu");
    assert!(j["bytes_per_tet"].as_u64().unwrap() <= 36);
    assert_eq!(
        j["bounding_box"]["min"],
        serde_json::json!([-0.5, -0.5, -0.5])
    );
    assert_eq!(j["bounding_box"]["max"], serde_json::json!([0.5, 0.5, 0.5]));
    assert!((j["volume"].as_f64().unwrap() - 1.0).abs() < 1e-9);
    // cube12's tets: the sharpest dihedral angle is 45 degrees, the widest 120.
    assert!(
        (j["min_dihedral_deg"].as_f64().unwrap() - 45.0).abs() < 1e-4,
        "{j}"
    );
    assert!(
        (j["max_dihedral_deg"].as_f64().unwrap() - 120.0).abs() < 1e-4,
        "{j}"
    );
}

#[test]
fn scale_scales_volume_and_box() {
    let j = info_json(&mesh("cube12/cube12.msh"), 0.01);
    assert!((j["volume"].as_f64().unwrap() - 1e-6).abs() < 1e-12, "{j}");
    let max = j["bounding_box"]["max"][0].as_f64().unwrap();
    assert!((max - 0.005).abs() < 1e-9, "{j}");
    assert_eq!(j["boundary_faces"], 12);
}

#[test]
fn the_same_mesh_gives_the_same_summary_in_every_format() {
    let files = [
        "node",
        "ele",
        "mesh",
        "msh22.msh",
        "msh41.msh",
        "vtk",
        "vtu",
    ];
    let mut first: Option<serde_json::Value> = None;
    for ext in files {
        let j = info_json(&mesh(&format!("models/spot_tetgen_q1.414.{ext}")), 1.0);
        assert_eq!(j["tets"], 18098);
        let keep = |j: &serde_json::Value| {
            serde_json::json!([
                j["nodes"],
                j["tets"],
                j["boundary_faces"],
                j["boundary_nodes"],
                j["orientation_fixes"],
                j["valid"],
                j["min_dihedral_deg"],
                j["volume"],
                j["bounding_box"]
            ])
        };
        match &first {
            None => first = Some(keep(&j)),
            Some(f) => assert_eq!(&keep(&j), f, "{ext}"),
        }
    }
    // The coarse cow has slivers down to about 0.23 degrees (shared meshes README).
    let j = info_json(&mesh("models/spot_tetgen_coarse.node"), 1.0);
    let d = j["min_dihedral_deg"].as_f64().unwrap();
    assert!(d > 0.1 && d < 0.35, "{d}");
    assert_eq!(j["valid"], true);
}

#[test]
fn builtin_names_work_in_info() {
    let j = info_json(Path::new("builtin:block:2"), 1.0);
    assert_eq!(j["tets"], 48);
    assert_eq!(j["nodes"], 27);
    assert_eq!(j["boundary_faces"], 48);
    assert_eq!(j["valid"], true);
    assert_eq!(j["format"], "builtin");
}

#[test]
fn dihedral_angles_of_known_tets() {
    // The regular tet: all six are acos(1/3).
    let s = 1.0 / 2f64.sqrt();
    let reg = [
        [1.0, 0.0, -s],
        [-1.0, 0.0, -s],
        [0.0, 1.0, s],
        [0.0, -1.0, s],
    ];
    for a in dihedral_angles(reg) {
        assert!(
            (a.to_degrees() - 70.528_779_365_509_3).abs() < 1e-9,
            "{}",
            a.to_degrees()
        );
    }
    // The corner tet: right angles at the three edges through the origin, and
    // acos(1/sqrt 3) = 54.7356 degrees between the slanted face and each axis plane.
    let corner = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 1.0],
    ];
    let mut a: Vec<f64> = dihedral_angles(corner)
        .iter()
        .map(|a| a.to_degrees())
        .collect();
    a.sort_by(|x, y| x.partial_cmp(y).unwrap());
    for k in 0..3 {
        assert!((a[k] - 54.735_610_317_245_35).abs() < 1e-9, "{a:?}");
        assert!((a[k + 3] - 90.0).abs() < 1e-9, "{a:?}");
    }
}

fn run_bin(args: &[&str]) -> Output {
    Command::new(tetradrill_bin()).args(args).output().unwrap()
}

#[test]
fn binary_prints_a_summary_and_exits_0() {
    let out = run_bin(&[
        "info",
        "--mesh",
        mesh("cube12/cube12.mesh").to_str().unwrap(),
    ]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_eq!(out.status.code(), Some(0), "{stdout}");
    assert!(stdout.contains("tets               12"), "{stdout}");
    assert!(stdout.contains("boundary faces     12"), "{stdout}");
    assert!(stdout.contains("validation         valid"), "{stdout}");
    // Bare --json: JSON alone on stdout.
    let out = run_bin(&["info", "--mesh", "builtin:cube12", "--json"]);
    assert_eq!(out.status.code(), Some(0));
    let j: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(j["tets"], 12);
}

/// Runs the binary on a bad file: status 2, nothing on stdout, one line on stderr that
/// starts with `tetradrill: FILE:LINE: ` and contains the reason.
fn bad(file: &Path, line: Option<usize>, reason: &str) {
    bad_as(file, file, line, reason)
}

/// Like [`bad`], when the error names another file than the one given (a TetGen pair).
fn bad_as(arg: &Path, file: &Path, line: Option<usize>, reason: &str) {
    let out = run_bin(&["info", "--mesh", arg.to_str().unwrap()]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{}: {stderr}", file.display());
    assert!(out.stdout.is_empty());
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
    let prefix = match line {
        Some(l) => format!("tetradrill: {}:{l}: ", file.display()),
        None => format!("tetradrill: {}: ", file.display()),
    };
    assert!(
        stderr.starts_with(&prefix),
        "expected '{prefix}', got '{stderr}'"
    );
    assert!(stderr.contains(reason), "expected '{reason}' in '{stderr}'");
}

#[test]
fn binary_refuses_bad_files_with_status_2_and_one_line() {
    let dir = scratch("bad");
    let w = |name: &str, text: &[u8]| {
        let p = dir.join(name);
        std::fs::write(&p, text).unwrap();
        p
    };
    let node = w("a.node", b"4 3 0 0\n0 0 0 0\n1 1 0 0\n2 0 1 0\n3 0 0 1\n");
    w("a.ele", b"1 4 0\n0 0 1 2 7\n");
    bad(&dir.join("a.ele"), Some(2), "node index 7 out of range");
    bad_as(
        &node,
        &dir.join("a.ele"),
        Some(2),
        "node index 7 out of range",
    );
    let p = w("z.node", b"4 3 0 0\n0 0 0 0\n1 1 0 0\n2 0 1 0\n3 1 1 0\n");
    w("z.ele", b"1 4 0\n0 0 1 2 3\n");
    bad_as(&p, &dir.join("z.ele"), Some(2), "zero volume");
    bad(&w("e.vtk", b""), None, "empty file");
    bad(
        &w("b.msh", b"$MeshFormat\n4.1 1 8\n$EndMeshFormat\n"),
        None,
        "byte 20: expected the integer 1",
    );
    bad(&w("x.stl", b"solid\n"), None, "unknown mesh file extension");
    bad(&dir.join("missing.mesh"), None, "cannot read");
    let p = w(
        "n.mesh",
        b"MeshVersionFormatted 2\nDimension 3\nVertices\n1\nnan 0 0 0\n",
    );
    bad(&p, Some(5), "NaN or infinite");
    // A bad flag is bad input too.
    let out = run_bin(&["info", "--mesh", "builtin:cube12", "--scale", "zero"]);
    assert_eq!(out.status.code(), Some(2));
    let out = run_bin(&["info", "--mesh", "builtin:cube12", "--scale", "-1"]);
    assert_eq!(out.status.code(), Some(2));
}

#[test]
fn binary_warns_about_unreferenced_nodes_on_stderr() {
    let dir = scratch("warn");
    std::fs::write(
        dir.join("u.node"),
        "5 3 0 0\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n5 9 9 9\n",
    )
    .unwrap();
    std::fs::write(dir.join("u.ele"), "1 4 0\n1 1 2 3 4\n").unwrap();
    let json = dir.join("u.json");
    let out = run_bin(&[
        "info",
        "--mesh",
        dir.join("u.ele").to_str().unwrap(),
        "--json",
        json.to_str().unwrap(),
    ]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{stderr}");
    assert!(stderr.starts_with("tetradrill: warning: "), "{stderr}");
    assert!(
        stderr.contains("1 unreferenced node(s) dropped"),
        "{stderr}"
    );
    let j: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert_eq!(j["unreferenced_nodes"], 1);
    assert_eq!(j["nodes"], 4);
    assert_eq!(j["tets"], 1);
    assert_eq!(j["boundary_faces"], 4);
    assert!((j["volume"].as_f64().unwrap() - 1.0 / 6.0).abs() < 1e-9);
}

#[test]
fn a_mesh_without_labels_is_one_region_zero() {
    let j = info_json(&mesh("cube12/cube12.node"), 1.0);
    let regions = j["regions"].as_object().expect("regions is an object");
    assert_eq!(regions.len(), 1, "{regions:?}");
    assert_eq!(regions["0"], 12);
    assert!(j["region_source"].is_null());
}

#[test]
fn regions_come_from_refs_physical_tags_cell_data_and_attributes() {
    // The octahedron's variants label the tets below z = 0 as 1 and the others as 2
    // (tests/data/meshes/formats/binary/README.md); TetGen's original gives every tet its
    // region attribute 100.
    let halves = serde_json::json!({"1": 612, "2": 612});
    for (file, source) in [
        ("formats/binary/octa_refs.mesh", "MEDIT"),
        ("formats/binary/octa.meshb", "MEDIT"),
        ("formats/binary/octa_22bin.msh", "Gmsh"),
        ("formats/binary/octa_zlib.vtu", "material"),
        ("formats/binary/octa_bin.vtk", "material"),
    ] {
        let j = info_json(&mesh(file), 1.0);
        assert_eq!(j["regions"], halves, "{file}");
        let s = j["region_source"].as_str().unwrap_or_default();
        assert!(s.contains(source), "{file}: {s}");
    }
    let j = info_json(&mesh("formats/sfepy_octahedron.ele"), 1.0);
    assert_eq!(j["regions"], serde_json::json!({"100": 1224}));
}
