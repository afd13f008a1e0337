//! Mesh files: every shared mesh in every format it comes in gives the same counts, checked
//! against an oracle that shares no code with the core's build (a hash map of sorted faces);
//! inverted meshes are fixed and counted; unreferenced nodes are dropped with a warning; VTK 5's
//! offsets and connectivity layout is read; random relabelling and reflection keep
//! `validate()` true.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use rand::rngs::StdRng;
use rand::seq::SliceRandom;
use rand::{Rng, SeedableRng};
use tetradrill::meshio::{self, RawMesh};
use tetradrill::owned::OwnedMesh;
use tetradrill_core::mesh::BuildOptions;
use tetradrill_core::Vec3;
use tetradrill_tests::mesh;
use tetradrill_tests::scratch_dir;

/// Counts from the oracle: (referenced nodes, tets, boundary faces, boundary nodes).
fn oracle(raw: &RawMesh) -> (usize, usize, usize, usize) {
    let mut faces: HashMap<[u32; 3], usize> = HashMap::new();
    for t in &raw.tets {
        for skip in 0..4 {
            let mut f: Vec<u32> = (0..4).filter(|&k| k != skip).map(|k| t[k]).collect();
            f.sort_unstable();
            *faces.entry([f[0], f[1], f[2]]).or_default() += 1;
        }
    }
    let boundary: Vec<[u32; 3]> = faces
        .iter()
        .filter(|(_, &n)| n == 1)
        .map(|(f, _)| *f)
        .collect();
    let mut bnodes: Vec<u32> = boundary.iter().flatten().copied().collect();
    bnodes.sort_unstable();
    bnodes.dedup();
    let mut used: Vec<u32> = raw.tets.iter().flatten().copied().collect();
    used.sort_unstable();
    used.dedup();
    (used.len(), raw.tets.len(), boundary.len(), bnodes.len())
}

/// Loads a file and checks the core's counts against the oracle; returns the counts.
fn counts(path: &Path) -> (usize, usize, usize, usize) {
    let raw = meshio::read(path).unwrap_or_else(|e| panic!("{e}"));
    let want = oracle(&raw);
    let mut loaded = meshio::load(path, 1.0).unwrap_or_else(|e| panic!("{e}"));
    let stats = loaded.mesh.stats();
    let got = (
        loaded.mesh.positions().len(),
        loaded.mesh.tets().len(),
        stats.boundary_faces as usize,
        stats.boundary_nodes as usize,
    );
    assert_eq!(got, want, "{}: core counts vs oracle", path.display());
    loaded
        .mesh
        .view()
        .validate()
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    got
}

#[test]
fn cube12_in_every_format() {
    for ext in ["node", "ele", "mesh", "msh", "vtk", "vtu"] {
        let p = mesh(&format!("cube12/cube12.{ext}"));
        assert_eq!(counts(&p), (9, 12, 12, 8), "{}", p.display());
    }
    assert_eq!(
        counts(&mesh("formats/sfepy_small3d_cube12.mesh")),
        (9, 12, 12, 8)
    );
}

#[test]
fn the_cow_in_all_seven_files() {
    let files = [
        "node",
        "ele",
        "mesh",
        "msh22.msh",
        "msh41.msh",
        "vtk",
        "vtu",
    ];
    let first = meshio::read(&mesh("models/spot_tetgen_q1.414.node")).unwrap();
    for ext in files {
        let p = mesh(&format!("models/spot_tetgen_q1.414.{ext}"));
        assert_eq!(counts(&p), (4447, 18098, 5856, 2930), "{}", p.display());
        // The same nodes and tets, not only the same counts.
        let raw = meshio::read(&p).unwrap();
        assert_eq!(raw.tets, first.tets, "{}", p.display());
        for (a, b) in raw.positions.iter().zip(&first.positions) {
            for k in 0..3 {
                assert!(
                    (a[k] - b[k]).abs() < 1e-12,
                    "{}: {a:?} vs {b:?}",
                    p.display()
                );
            }
        }
    }
}

#[test]
fn the_other_shared_meshes() {
    assert_eq!(counts(&mesh("models/spot_tetgen_coarse.ele")).0, 2930);
    assert_eq!(counts(&mesh("models/spot_tetgen_coarse.node")).1, 9825);
    let teddy = counts(&mesh("models/teddy_cgalbear_tetgen_q1.414.node"));
    assert_eq!((teddy.0, teddy.1), (20089, 80190));
    let pen = counts(&mesh("models/pen_tool_gmsh.mesh"));
    assert_eq!((pen.0, pen.1), (1148, 3812));
    assert_eq!(counts(&mesh("models/pen_tool_gmsh.msh22.msh")), pen);
}

#[test]
fn one_based_tetgen_with_a_region_attribute() {
    for ext in ["node", "ele"] {
        let p = mesh(&format!("formats/sfepy_octahedron.{ext}"));
        let c = counts(&p);
        assert_eq!((c.0, c.1), (330, 1224));
        let raw = meshio::read(&p).unwrap();
        let flat: Vec<u32> = raw.tets.iter().flatten().copied().collect();
        assert_eq!(flat.iter().min(), Some(&0), "1-based ids become 0-based");
        assert_eq!(flat.iter().max(), Some(&329));
        // First tet of the file: `1  20 154 122 258  100` (1-based).
        assert_eq!(raw.tets[0], [19, 153, 121, 257]);
        assert_eq!(raw.tet_lines[0], 2);
    }
}

#[test]
fn gmsh_variants() {
    // Lines, triangles and points mixed in: only the tets are kept.
    let p = mesh("formats/sfepy_msh_tetra.msh");
    let c = counts(&p);
    assert_eq!((c.0, c.1), (66, 127));
    let raw = meshio::read(&p).unwrap();
    assert_eq!(raw.format, "gmsh 2.2");
    let p = mesh("formats/sofa_msh4_cube.msh");
    let c = counts(&p);
    assert_eq!((c.0, c.1), (14, 24));
    let raw = meshio::read(&p).unwrap();
    assert_eq!(raw.format, "gmsh 4.1");
    // Element 45 of the file, `45 11 12 10 13`, is on line 165.
    assert_eq!(raw.tets[0], [10, 11, 9, 12]);
    assert_eq!(raw.tet_lines[0], 165);
    let c = counts(&mesh("formats/sofa_cube_low_res_msh22.msh"));
    assert_eq!((c.0, c.1), (26, 44));
}

#[test]
fn builtin_meshes_load_by_name() {
    assert_eq!(counts(Path::new("builtin:cube12")), (9, 12, 12, 8));
    let c = counts(Path::new("builtin:block:3"));
    assert_eq!((c.0, c.1, c.2), (64, 162, 6 * 9 * 2));
    for bad in [
        "builtin:cube13",
        "builtin:block:0",
        "builtin:block:x",
        "builtin:block:100000",
    ] {
        let e = meshio::load(Path::new(bad), 1.0).unwrap_err();
        assert!(e.is_input(), "{bad}");
    }
}

/// Copies a TetGen pair into `dir` with columns 3 and 4 of every tet swapped.
fn inverted_copy(stem: &str, dir: &Path) -> PathBuf {
    let name = Path::new(stem)
        .file_name()
        .unwrap()
        .to_str()
        .unwrap()
        .to_string();
    std::fs::copy(
        mesh(&format!("{stem}.node")),
        dir.join(format!("{name}.node")),
    )
    .unwrap();
    let ele = std::fs::read_to_string(mesh(&format!("{stem}.ele"))).unwrap();
    let mut out = String::new();
    for (i, line) in ele.lines().enumerate() {
        let mut t: Vec<&str> = line.split_whitespace().collect();
        if i > 0 && t.len() >= 5 && !line.trim_start().starts_with('#') {
            t.swap(3, 4);
        }
        out += &t.join(" ");
        out += "\n";
    }
    let p = dir.join(format!("{name}.ele"));
    std::fs::write(&p, out).unwrap();
    p
}

#[test]
fn every_tet_inverted_is_fixed_and_counted() {
    let dir = scratch_dir("meshio", "inverted");
    for stem in ["cube12/cube12", "models/spot_tetgen_q1.414"] {
        let p = inverted_copy(stem, &dir);
        let mut loaded = meshio::load(&p, 1.0).unwrap();
        let t = loaded.mesh.tets().len();
        assert_eq!(loaded.mesh.stats().orientation_fixes as usize, t, "{stem}");
        loaded.mesh.view().validate().unwrap();
        // The original has none.
        let orig = meshio::load(&mesh(&format!("{stem}.ele")), 1.0).unwrap();
        assert_eq!(orig.mesh.stats().orientation_fixes, 0);
        assert_eq!(
            orig.mesh.stats().boundary_faces,
            loaded.mesh.stats().boundary_faces
        );
    }
}

#[test]
fn unreferenced_nodes_are_dropped_with_a_warning() {
    let dir = scratch_dir("meshio", "unreferenced");
    let node = std::fs::read_to_string(mesh("cube12/cube12.node")).unwrap();
    let mut lines: Vec<String> = node.lines().map(str::to_string).collect();
    lines[0] = "11 3 0 0".into();
    lines.insert(3, "2 7 7 7".into()); // a stray node in the middle: renumbering matters
    for (k, l) in lines.iter_mut().enumerate().skip(4) {
        let rest: Vec<&str> = l.split_whitespace().skip(1).collect();
        *l = format!("{} {}", k - 1, rest.join(" "));
    }
    lines.push("10 9 9 9".into());
    std::fs::write(dir.join("c.node"), lines.join("\n") + "\n").unwrap();
    // Tets renumbered to the new node numbers (old ids >= 2 shift by one).
    let ele = std::fs::read_to_string(mesh("cube12/cube12.ele")).unwrap();
    let mut out = String::new();
    for (i, line) in ele.lines().enumerate() {
        let t: Vec<u32> = line
            .split_whitespace()
            .map(|s| s.parse().unwrap())
            .collect();
        if i == 0 {
            out += line;
        } else {
            let ids: Vec<String> = t[1..]
                .iter()
                .map(|&v| (if v >= 2 { v + 1 } else { v }).to_string())
                .collect();
            out += &format!("{} {}", t[0], ids.join(" "));
        }
        out += "\n";
    }
    std::fs::write(dir.join("c.ele"), out).unwrap();
    let mut loaded = meshio::load(&dir.join("c.ele"), 1.0).unwrap();
    assert_eq!(loaded.dropped_nodes, 2);
    assert_eq!(loaded.mesh.positions().len(), 9);
    assert_eq!(loaded.warnings.len(), 1, "{:?}", loaded.warnings);
    assert!(
        loaded.warnings[0].contains("2 unreferenced node"),
        "{}",
        loaded.warnings[0]
    );
    assert!(!loaded.warnings[0].contains('\n'));
    loaded.mesh.view().validate().unwrap();
    assert_eq!(loaded.mesh.stats().boundary_faces, 12);
    assert_eq!(loaded.mesh.stats().unreferenced_nodes, 0);
    // Nothing far away survived.
    assert!(loaded
        .mesh
        .positions()
        .iter()
        .all(|p| p.abs().max_element() <= 0.5));
}

#[test]
fn vtk_5_offsets_connectivity_layout_and_other_cells() {
    // cube12 in VTK 5.1 with a triangle cell and a vertex cell mixed in (ignored).
    let p = meshio::read(&mesh("cube12/cube12.vtk")).unwrap();
    let mut s =
        String::from("# vtk DataFile Version 5.1\ncube12\nASCII\nDATASET UNSTRUCTURED_GRID\n");
    s += &format!("POINTS {} double\n", p.positions.len());
    for q in &p.positions {
        s += &format!("{} {} {}\n", q[0], q[1], q[2]);
    }
    let n = p.tets.len() + 2;
    s += &format!(
        "CELLS {} {}\nOFFSETS vtktypeint64\n0\n",
        n + 1,
        4 * p.tets.len() + 4
    );
    let mut off = 0;
    for k in 0..n {
        off += if k == 3 {
            3
        } else if k == 7 {
            1
        } else {
            4
        };
        s += &format!("{off}\n");
    }
    s += "CONNECTIVITY vtktypeint64\n";
    let mut tets = p.tets.iter();
    for k in 0..n {
        match k {
            3 => s += "0 1 2\n",
            7 => s += "5\n",
            _ => {
                let t = tets.next().unwrap();
                s += &format!("{} {} {} {}\n", t[0], t[1], t[2], t[3]);
            }
        }
    }
    s += &format!("CELL_TYPES {n}\n");
    for k in 0..n {
        s += match k {
            3 => "5\n",
            7 => "1\n",
            _ => "10\n",
        };
    }
    s += "CELL_DATA 14\nSCALARS a float 1\nLOOKUP_TABLE default\n";
    s += &"0.5\n".repeat(14);
    let dir = scratch_dir("meshio", "vtk5");
    let f = dir.join("c.vtk");
    std::fs::write(&f, &s).unwrap();
    let raw = meshio::read(&f).unwrap();
    assert_eq!(raw.format, "vtk 5");
    assert_eq!(raw.tets, p.tets);
    assert_eq!(counts(&f), (9, 12, 12, 8));
    // The tet after the triangle starts on the line after "0 1 2".
    let tri_line = s.lines().position(|l| l == "0 1 2").unwrap() + 1;
    assert_eq!(raw.tet_lines[3], tri_line + 1);
}

#[test]
fn relabelling_and_reflection_keep_the_mesh_valid() {
    let raw = meshio::read(&mesh("models/spot_tetgen_q1.414.node")).unwrap();
    let base = meshio::load(&mesh("models/spot_tetgen_q1.414.node"), 1.0).unwrap();
    let want = base.mesh.stats();
    let mut rng = StdRng::seed_from_u64(0x7e7a);
    for round in 0..4 {
        let reflect = round % 2 == 1;
        let n = raw.positions.len();
        let mut perm: Vec<u32> = (0..n as u32).collect();
        perm.shuffle(&mut rng);
        let mut positions = vec![Vec3::ZERO; n];
        for (old, &new) in perm.iter().enumerate() {
            let [x, y, z] = raw.positions[old];
            let x = if reflect { -x } else { x };
            positions[new as usize] = Vec3::new(x as f32, y as f32, z as f32);
        }
        let mut tets: Vec<[u32; 4]> = raw
            .tets
            .iter()
            .map(|t| t.map(|v| perm[v as usize]))
            .collect();
        tets.shuffle(&mut rng);
        for t in tets.iter_mut() {
            // An even permutation of the corners keeps each tet's orientation.
            match rng.gen_range(0..3) {
                0 => {}
                1 => *t = [t[1], t[2], t[0], t[3]],
                _ => *t = [t[0], t[2], t[3], t[1]],
            }
        }
        let mut m = OwnedMesh::build(positions, &tets, BuildOptions::default()).unwrap();
        m.view()
            .validate()
            .unwrap_or_else(|e| panic!("round {round}: {e}"));
        let s = m.stats();
        assert_eq!(m.tets().len(), 18098);
        assert_eq!(m.positions().len(), 4447);
        assert_eq!(
            (s.boundary_faces, s.boundary_nodes),
            (want.boundary_faces, want.boundary_nodes)
        );
        let fixes = if reflect { 18098 } else { 0 };
        assert_eq!(s.orientation_fixes, fixes, "round {round}");
        let vol: f64 = m.view().volume();
        assert!(
            (vol - base.mesh.clone().view().volume()).abs() < 1e-4,
            "round {round}: {vol}"
        );
    }
}
