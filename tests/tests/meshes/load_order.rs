//! Loading renumbers a file's nodes and tets along a space-filling curve. Checked against the
//! file as read (no build, no renumbering): every built tet is the file tet `file_tets` names,
//! with the same positions and label; both maps are permutations; a broken tet deep in a
//! shuffled file is still reported at its own line; and the new order is local (neighbours
//! close in memory), measured against the file's order.

use std::path::Path;

use rand::rngs::StdRng;
use rand::seq::SliceRandom;
use rand::SeedableRng;
use tetradrill::meshio::{self, ReadOptions};
use tetradrill_tests::{mesh, scratch_dir};

/// Every built tet against the file: same four points (as a set: orientation may be fixed at
/// load) and the same label; `file_tets` and `file_nodes` are permutations of what is used.
fn check_against_file(path: &Path, scale: f64) {
    let raw = meshio::read(path).unwrap();
    let loaded = meshio::load(path, scale).unwrap();
    let positions = loaded.mesh.positions();
    let tets = loaded.mesh.tets();
    assert_eq!(tets.len(), raw.tets.len());
    assert_eq!(loaded.file_tets.len(), tets.len());
    assert_eq!(loaded.file_nodes.len(), positions.len());

    let mut seen = vec![false; raw.tets.len()];
    for &f in &loaded.file_tets {
        assert!(
            !std::mem::replace(&mut seen[f as usize], true),
            "file tet {f} twice"
        );
    }
    let mut used = vec![false; raw.positions.len()];
    for t in &raw.tets {
        for &v in t {
            used[v as usize] = true;
        }
    }
    let mut seen = vec![false; raw.positions.len()];
    for &f in &loaded.file_nodes {
        assert!(used[f as usize], "node {f} kept but unused");
        assert!(
            !std::mem::replace(&mut seen[f as usize], true),
            "node {f} twice"
        );
    }
    assert_eq!(seen, used, "every used node is kept");

    let file_point = |v: u32| {
        let p = raw.positions[v as usize];
        [
            (p[0] * scale) as f32,
            (p[1] * scale) as f32,
            (p[2] * scale) as f32,
        ]
    };
    for (t, tet) in tets.iter().enumerate() {
        let f = loaded.file_tets[t] as usize;
        let mut built: Vec<[f32; 3]> = tet
            .nodes
            .iter()
            .map(|n| {
                assert_eq!(
                    file_point(loaded.file_nodes[n.idx()]),
                    positions[n.idx()].to_array()
                );
                positions[n.idx()].to_array()
            })
            .collect();
        let mut want: Vec<[f32; 3]> = raw.tets[f].iter().map(|&v| file_point(v)).collect();
        built.sort_by(|a, b| a.partial_cmp(b).unwrap());
        want.sort_by(|a, b| a.partial_cmp(b).unwrap());
        assert_eq!(built, want, "built tet {t} is file tet {f}");
        let label = raw.labels.get(f).copied().unwrap_or(0);
        assert_eq!(
            loaded.labels.get(t).copied().unwrap_or(0),
            label,
            "label of tet {t}"
        );
    }
}

#[test]
fn loaded_tets_are_the_file_tets() {
    check_against_file(&mesh("models/spot_tetgen_q1.414.ele"), 1.0);
    check_against_file(&mesh("models/teddy_cgalbear_tetgen_q1.414.ele"), 0.5);
    check_against_file(&mesh("formats/binary/octa_refs.mesh"), 1.0);
}

#[test]
fn file_order_keeps_the_file_numbering() {
    let path = mesh("models/spot_tetgen_q1.414.ele");
    let opts = ReadOptions {
        file_order: true,
        ..ReadOptions::default()
    };
    let loaded = meshio::load_with(&path, 1.0, &opts).unwrap();
    let n = loaded.file_tets.len() as u32;
    assert!(loaded.file_tets.iter().copied().eq(0..n));
    assert!(loaded.file_nodes.windows(2).all(|w| w[0] < w[1]));
    let spatial = meshio::load(&path, 1.0).unwrap();
    assert_ne!(spatial.file_tets, loaded.file_tets, "the default renumbers");
    assert_eq!(spatial.mesh.stats(), loaded.mesh.stats());
}

/// Mean distance in memory (tet index) between face neighbours.
fn mean_neighbour_gap(loaded: &meshio::LoadedMesh) -> f64 {
    let (mut sum, mut n) = (0f64, 0f64);
    for (t, tet) in loaded.mesh.tets().iter().enumerate() {
        for nb in tet.neighbours.iter().filter(|nb| !nb.is_none()) {
            sum += (nb.idx() as f64 - t as f64).abs();
            n += 1.0;
        }
    }
    sum / n
}

/// A file written in random order: loaded, its neighbours sit close together; the file's own
/// order leaves them a third of the mesh apart on average.
#[test]
fn spatial_order_puts_neighbours_close() {
    let src = mesh("models/teddy_cgalbear_tetgen_q1.414.ele");
    let raw = meshio::read(&src).unwrap();
    let mut rng = StdRng::seed_from_u64(7);
    let mut node_perm: Vec<usize> = (0..raw.positions.len()).collect();
    node_perm.shuffle(&mut rng);
    let mut tet_perm: Vec<usize> = (0..raw.tets.len()).collect();
    tet_perm.shuffle(&mut rng);

    let dir = scratch_dir("load_order", "shuffled");
    let mut node = format!("{} 3 0 0\n", raw.positions.len());
    let mut inverse = vec![0usize; node_perm.len()];
    for (new, &old) in node_perm.iter().enumerate() {
        inverse[old] = new;
        let p = raw.positions[old];
        node += &format!("{new} {:e} {:e} {:e}\n", p[0], p[1], p[2]);
    }
    let mut ele = format!("{} 4 0\n", raw.tets.len());
    for (new, &old) in tet_perm.iter().enumerate() {
        let t = raw.tets[old].map(|v| inverse[v as usize]);
        ele += &format!("{new} {} {} {} {}\n", t[0], t[1], t[2], t[3]);
    }
    std::fs::write(dir.join("s.node"), &node).unwrap();
    std::fs::write(dir.join("s.ele"), &ele).unwrap();
    check_against_file(&dir.join("s.ele"), 1.0);

    let spatial = meshio::load(&dir.join("s.ele"), 1.0).unwrap();
    let opts = ReadOptions {
        file_order: true,
        ..ReadOptions::default()
    };
    let shuffled = meshio::load_with(&dir.join("s.ele"), 1.0, &opts).unwrap();
    let (near, far) = (mean_neighbour_gap(&spatial), mean_neighbour_gap(&shuffled));
    let t = raw.tets.len() as f64;
    assert!(far > t / 4.0, "shuffled file: mean gap {far} of {t} tets");
    assert!(
        near < t / 50.0,
        "spatial order: mean gap {near} of {t} tets"
    );

    // A flat tet deep in the shuffled file is reported at its own line.
    let mut lines: Vec<String> = ele.lines().map(str::to_string).collect();
    let k = lines.len() - 10;
    let f: Vec<&str> = lines[k].split_whitespace().collect();
    lines[k] = format!("{} {} {} {} {}", f[0], f[1], f[2], f[3], f[3]);
    std::fs::write(dir.join("s.ele"), lines.join("\n") + "\n").unwrap();
    let e = meshio::load(&dir.join("s.ele"), 1.0).unwrap_err();
    assert!(e.is_input());
    let msg = e.to_string();
    assert!(msg.contains(&format!("s.ele:{}:", k + 1)), "{msg}");
}

/// The `.node` and `.ele` files are read at the same time; the error is still the first bad
/// line of the file, whatever kind it is: a node id out of range before a bad line, a bad line
/// before an id out of range, an id beyond 32 bits after an id out of range.
#[test]
fn the_first_bad_line_is_reported_when_both_files_are_read_at_once() {
    let node = "5 3 0 0\n0 0 0 0\n1 1 0 0\n2 0 1 0\n3 0 0 1\n4 1 1 1\n";
    let good = "0 0 1 2 3";
    let cases: [(&str, [&str; 4], usize, &str); 4] = [
        (
            "range-then-bad",
            [good, "1 0 1 2 9", "2 0 1 x 3", good],
            3,
            "out of range",
        ),
        (
            "bad-then-range",
            [good, "1 0 1 x 3", "2 0 1 2 9", good],
            3,
            "an integer",
        ),
        (
            "range-then-huge",
            [good, "1 0 1 2 7", "2 0 1 2 99999999999", good],
            3,
            "node index 7",
        ),
        (
            "huge",
            [good, good, "2 0 1 2 -99999999999", good],
            4,
            "node index -99999999999",
        ),
    ];
    for (name, rows, line, needle) in cases {
        let dir = scratch_dir("load_order", name);
        std::fs::write(dir.join("a.node"), node).unwrap();
        std::fs::write(dir.join("a.ele"), format!("4 4 0\n{}\n", rows.join("\n"))).unwrap();
        let p = dir.join("a.ele");
        let e = meshio::load(&p, 1.0).unwrap_err();
        assert!(e.is_input(), "{name}");
        assert!(
            e.message.starts_with(&format!("{}:{line}: ", p.display()))
                && e.message.contains(needle),
            "{name}: {}",
            e.message
        );
    }
    // A bad .node file is reported before anything in the .ele file.
    let dir = scratch_dir("load_order", "bad-node");
    std::fs::write(dir.join("a.node"), node.replace("2 0 1 0", "2 0 one 0")).unwrap();
    std::fs::write(dir.join("a.ele"), "1 4 0\n0 0 1 2 9\n").unwrap();
    let e = meshio::load(&dir.join("a.ele"), 1.0).unwrap_err();
    assert!(e.message.contains("a.node:4:"), "{}", e.message);
}
