//! Fuzzing regressions (docs/FUZZING.md): every input a fuzz target (`fuzz/`) ever crashed on,
//! through the same entry point, now refused with an error instead of a panic; and the
//! hand-written seeds in `fuzz/seeds/`, so a plain `cargo test` replays them without cargo-fuzz.

use std::path::{Path, PathBuf};

use tetradrill::error::{CliError, EXIT_BAD_INPUT};
use tetradrill::meshio;
use tetradrill::scenario::Scenario;
use tetradrill_device::falcon::frame::{decode_command, decode_report, FrameAssembler};
use tetradrill_device::omni::packet::{decode_input, decode_output, INPUT_LEN, OUTPUT_LEN};
use tetradrill_device::Trace;
use tetradrill_tests::workspace_root;

/// A scratch directory for this test binary.
fn scratch() -> PathBuf {
    let d = std::env::temp_dir().join(format!("tdfuzzreg-{}", std::process::id()));
    std::fs::create_dir_all(&d).expect("scratch dir");
    d
}

/// Writes `bytes` to a scratch file `name` (a test-unique name) and returns its path.
fn write(name: &str, bytes: &[u8]) -> PathBuf {
    let p = scratch().join(name);
    std::fs::write(&p, bytes).expect("write scratch file");
    p
}

/// The error contract: exit status 2 and one line.
fn assert_one_line(e: &CliError) {
    assert_eq!(e.code, EXIT_BAD_INPUT, "{}", e.message);
    assert!(!e.message.contains(['\n', '\r']), "{:?}", e.message);
}

/// What the mesh fuzz targets check: `read` and `load` return (no panic), refusals are one
/// line with exit status 2, a loaded mesh is valid.
fn check_mesh(path: &Path) -> Result<(), CliError> {
    match meshio::read(path) {
        Ok(raw) => assert_eq!(raw.labels.len(), raw.tets.len(), "one label per tet"),
        Err(e) => assert_one_line(&e.into()),
    }
    match meshio::load(path, 1.0) {
        Ok(mut m) => {
            m.mesh.view().validate().expect("a loaded mesh is valid");
            Ok(())
        }
        Err(e) => {
            let e = CliError::from(e);
            assert_one_line(&e);
            Err(e)
        }
    }
}

/// A mesh blob input as the `mesh_blob` target sees it: the first byte picks a whole blob
/// (even) or a node count (two bytes) and bare tet records (odd). No panic; a refusal is one
/// line; an accepted view's records stay in range.
fn blob_input(data: &[u8]) {
    use tetradrill_core::blob::MeshBlob;
    use tetradrill_core::mesh::TetView;
    let Some((&mode, rest)) = data.split_first() else {
        return;
    };
    let view = if mode % 2 == 0 {
        MeshBlob::parse(rest)
            .map(|b| b.tets())
            .map_err(|e| e.to_string())
    } else {
        let Some((n, recs)) = rest.split_first_chunk::<2>() else {
            return;
        };
        TetView::new(recs, usize::from(u16::from_le_bytes(*n))).map_err(|e| e.to_string())
    };
    match view {
        Ok(v) => {
            for i in 0..v.len() {
                let t = v
                    .get(tetradrill_core::TetId::from_idx(i))
                    .expect("in range");
                assert!(t.nodes.iter().all(|n| n.idx() < v.node_count()));
                assert!(t
                    .neighbours
                    .iter()
                    .all(|n| n.is_none() || n.idx() < v.len()));
            }
        }
        Err(e) => assert!(!e.is_empty() && !e.contains(['\n', '\r']), "{e:?}"),
    }
}

/// A mesh input as the fuzz target sees it: one file, or for TetGen `.node`, NUL, `.ele`.
fn mesh_input(target: &str, name: &str, data: &[u8]) -> Result<(), CliError> {
    let ext = match target {
        "mesh_medit" => "mesh",
        "mesh_gmsh" => "msh",
        "mesh_vtk" => "vtk",
        "mesh_vtu" => "vtu",
        "mesh_meshb" => "meshb",
        "mesh_gz" => {
            // As the target: the first byte picks the format inside the gzip file.
            let names = ["mesh.gz", "msh.gz", "vtk.gz", "vtu.gz", "meshb.gz"];
            let Some((&pick, gz)) = data.split_first() else {
                return Ok(());
            };
            let ext = names[pick as usize % names.len()];
            return check_mesh(&write(&format!("{name}.{ext}"), gz));
        }
        "mesh_tetgen" => {
            let (node, ele) = match data.iter().position(|&b| b == 0) {
                Some(i) => (&data[..i], &data[i + 1..]),
                None => (data, &[][..]),
            };
            write(&format!("{name}.node"), node);
            let ele = write(&format!("{name}.ele"), ele);
            return check_mesh(&ele);
        }
        other => panic!("not a mesh target: {other}"),
    };
    check_mesh(&write(&format!("{name}.{ext}"), data))
}

#[test]
fn hand_written_seeds_go_through_their_entry_points() {
    let seeds = workspace_root().join("fuzz").join("seeds");
    let mut n = 0;
    for dir in std::fs::read_dir(&seeds).expect("fuzz/seeds") {
        let dir = dir.expect("entry").path();
        let target = dir
            .file_name()
            .and_then(|s| s.to_str())
            .expect("name")
            .to_owned();
        for f in std::fs::read_dir(&dir).expect("seed dir") {
            let f = f.expect("entry").path();
            let data = std::fs::read(&f).expect("seed");
            let name = format!("seed-{target}-{n}");
            n += 1;
            match target.as_str() {
                "mesh_blob" => blob_input(&data),
                t if t.starts_with("mesh_") => {
                    mesh_input(t, &name, &data).unwrap_or_else(|e| panic!("{f:?}: {e}"));
                }
                "trace" => {
                    let text = std::str::from_utf8(&data).expect("UTF-8 seed");
                    Trace::parse(text, "seed").unwrap_or_else(|e| panic!("{f:?}: {e}"));
                }
                "scenario" => {
                    let p = write(&format!("{name}.toml"), &data);
                    // The unknown-table seed is refused on purpose; the others load.
                    match Scenario::load(p.to_str().expect("UTF-8 path")) {
                        Ok(_) => assert!(!f.ends_with("unknown_table.toml")),
                        Err(e) => {
                            assert_one_line(&e);
                            assert!(f.ends_with("unknown_table.toml"), "{f:?}: {e}");
                        }
                    }
                }
                "falcon" => {
                    let mut asm = FrameAssembler::new();
                    let _ = asm.push(&data);
                    if let Ok(frame) = <[u8; 16]>::try_from(&data[..]) {
                        assert!(decode_report(&frame).is_ok() || decode_command(&frame).is_ok());
                    }
                }
                "omni" => {
                    if let Some(p) = data.get(..INPUT_LEN) {
                        let _ = decode_input(p.try_into().expect("44 bytes"));
                    }
                    if let Some(p) = data.get(..OUTPUT_LEN) {
                        let _ = decode_output(p.try_into().expect("16 bytes"));
                    }
                }
                other => panic!("seeds for an unknown target: {other}"),
            }
        }
    }
    assert!(n >= 9, "only {n} seeds");
}
