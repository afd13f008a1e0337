//! The premolar mesh (`tests/data/meshes/models/tooth_premolar_gmsh.msh22.msh`, made from
//! `tooth_premolar.geo` by `scripts/make-tooth.sh`): its three region labels, every tet
//! positive, a closed boundary, and the volume of each label, all computed here in f64 from
//! the file as read and checked against the loader, the core's mesh and the Gmsh model.

use std::collections::{BTreeMap, HashMap};
use std::path::PathBuf;

use tetradrill::meshio;
use tetradrill_core::TetId;
use tetradrill_tests::workspace_root;

/// Enamel, dentin and pulp: the physical volumes of `tooth_premolar.geo`.
const LABELS: [i32; 3] = [1, 2, 3];

fn tooth() -> PathBuf {
    workspace_root().join("tests/data/meshes/models/tooth_premolar_gmsh.msh22.msh")
}

/// `det[b-a, c-a, d-a]` in f64: six times the signed volume.
fn det(p: [[f64; 3]; 4]) -> f64 {
    let d = |i: usize| [0, 1, 2].map(|k| p[i][k] - p[0][k]);
    let (u, v, w) = (d(1), d(2), d(3));
    u[0] * (v[1] * w[2] - v[2] * w[1]) - u[1] * (v[0] * w[2] - v[2] * w[0])
        + u[2] * (v[0] * w[1] - v[1] * w[0])
}

/// Sum of `|det| / 6` by label.
fn volumes_by_label(
    positions: &[[f64; 3]],
    tets: &[[u32; 4]],
    labels: &[i32],
) -> BTreeMap<i32, f64> {
    let mut v = BTreeMap::new();
    for (t, &l) in tets.iter().zip(labels) {
        let p = t.map(|i| positions[i as usize]);
        *v.entry(l).or_insert(0.0) += det(p).abs() / 6.0;
    }
    v
}

#[test]
fn the_tooth_has_three_labels_positive_tets_and_a_closed_boundary() {
    let raw = meshio::read(&tooth()).expect("the tooth reads");
    assert_eq!(raw.format, "gmsh 2.2");
    assert_eq!(raw.labels.len(), raw.tets.len());
    let mut count: BTreeMap<i32, usize> = BTreeMap::new();
    for &l in &raw.labels {
        *count.entry(l).or_default() += 1;
    }
    assert_eq!(count.keys().copied().collect::<Vec<_>>(), LABELS);
    assert!(count.values().all(|&n| n >= 100), "{count:?}");

    // Every tet positive, far from degenerate against its own size.
    for (i, t) in raw.tets.iter().enumerate() {
        let p = t.map(|n| raw.positions[n as usize]);
        let longest = (0..4)
            .flat_map(|a| (a + 1..4).map(move |b| (a, b)))
            .map(|(a, b)| {
                (0..3)
                    .map(|k| (p[a][k] - p[b][k]).powi(2))
                    .sum::<f64>()
                    .sqrt()
            })
            .fold(0.0, f64::max);
        assert!(det(p) > 1e-6 * longest.powi(3), "tet {i} is not positive");
    }

    // Faces: none in more than two tets; the boundary (faces of one tet) is closed, every
    // boundary edge on exactly two boundary faces, and one sphere (V - E + F = 2).
    let mut faces: HashMap<[u32; 3], Vec<usize>> = HashMap::new();
    for (i, t) in raw.tets.iter().enumerate() {
        for skip in 0..4 {
            let mut f = [0u32; 3];
            let mut k = 0;
            for (j, &n) in t.iter().enumerate() {
                if j != skip {
                    f[k] = n;
                    k += 1;
                }
            }
            f.sort_unstable();
            faces.entry(f).or_default().push(i);
        }
    }
    assert!(faces.values().all(|ts| ts.len() <= 2));
    let boundary: Vec<[u32; 3]> = faces
        .iter()
        .filter(|(_, ts)| ts.len() == 1)
        .map(|(f, _)| *f)
        .collect();
    let mut edges: HashMap<[u32; 2], usize> = HashMap::new();
    for f in &boundary {
        for (a, b) in [(0, 1), (0, 2), (1, 2)] {
            *edges.entry([f[a], f[b]]).or_default() += 1;
        }
    }
    assert!(edges.values().all(|&n| n == 2), "an open boundary edge");
    let mut vertices: Vec<u32> = boundary.iter().flatten().copied().collect();
    vertices.sort_unstable();
    vertices.dedup();
    let euler = vertices.len() as i64 - edges.len() as i64 + boundary.len() as i64;
    assert_eq!(euler, 2, "the boundary is one closed sphere");

    // Anatomy: the pulp is closed inside (no boundary face) and touches the dentin only.
    for (f, ts) in &faces {
        let ls: Vec<i32> = ts.iter().map(|&t| raw.labels[t]).collect();
        if ls.len() == 1 {
            assert_ne!(ls[0], 3, "pulp on the boundary at face {f:?}");
        } else {
            assert!(
                !(ls.contains(&1) && ls.contains(&3)),
                "enamel against pulp at face {f:?}"
            );
        }
    }

    // The core's mesh finds the same boundary.
    let mut loaded = meshio::load(&tooth(), 1.0).expect("the tooth loads");
    let mesh = loaded.mesh.view();
    assert_eq!(mesh.stats().boundary_faces as usize, boundary.len());
    assert_eq!(mesh.tet_count(), raw.tets.len());
}

#[test]
fn the_volume_of_each_label_matches_the_loader_the_core_and_the_model() {
    let raw = meshio::read(&tooth()).expect("the tooth reads");
    let file = volumes_by_label(&raw.positions, &raw.tets, &raw.labels);

    // The loader renumbers nodes and tets: its labels must follow their tets.
    let mut loaded = meshio::load(&tooth(), 1.0).expect("the tooth loads");
    assert_eq!(loaded.labels.len(), raw.tets.len());
    let mesh = loaded.mesh.view();
    let mut core: BTreeMap<i32, f64> = BTreeMap::new();
    for (t, &l) in loaded.labels.iter().enumerate() {
        let p = mesh.tet_positions(TetId(t as u32));
        *core.entry(l).or_insert(0.0) += f64::from(tetradrill_core::geom::tet_volume(p));
    }
    let total: f64 = file.values().sum();
    assert!((mesh.volume() - total).abs() < 1e-5 * total);
    for l in LABELS {
        let (a, b) = (file[&l], core[&l]);
        assert!(
            (a - b).abs() < 1e-5 * a,
            "label {l}: file {a:e}, core {b:e}"
        );
    }

    // The Gmsh model's own volumes (OpenCASCADE's, mm^3): the mesh's flat faces cut the
    // curved surfaces inside, so each label is a little smaller; the pulp's thin canal, a few
    // tets across, loses most.
    let model = [(1, 128.658, 0.03), (2, 263.081, 0.06), (3, 17.218, 0.25)];
    for (l, mm3, tolerance) in model {
        let v = file[&l] * 1e9;
        assert!(
            v < mm3 && v > mm3 * (1.0 - tolerance),
            "label {l}: {v:.3} mm^3 against the model's {mm3}"
        );
    }
    // Within the tooth: the enamel about a third, the pulp a few per cent.
    assert!(file[&1] > 0.25 * total && file[&1] < 0.40 * total);
    assert!(file[&3] > 0.02 * total && file[&3] < 0.06 * total);
}

/// Runs `tetradrill replay --scenario builtin:firmware-tooth --ticks TICKS` and returns the
/// removed volume by label (mm^3) and in all (mm^3).
fn access_cavity(ticks: u32) -> (BTreeMap<i32, f64>, f64) {
    let ticks = ticks.to_string();
    let j = tetradrill_tests::json_of(
        &[
            "replay",
            "--scenario",
            "builtin:firmware-tooth",
            "--quiet",
            "--ticks",
            &ticks,
        ],
        "tooth",
        &ticks,
    );
    let by_label = tetradrill_tests::removed_mm3_by_label(&j);
    (
        by_label,
        j["removed_volume"].as_f64().expect("removed_volume") * 1e9,
    )
}

/// The access cavity meets the tissues in the order the model's geometry puts them, checked
/// from where the burr is (`script::TOOTH_ACCESS`, a 0.7 mm sphere) against the model's
/// surfaces: at tick 2,000 its centre is at z = 21.71 mm on the axis, so it reaches down to
/// 21.01 mm and, 0.7 mm off the axis, no deeper than 21.01 mm either, all above the
/// dentin-enamel junction (its top 20.5 mm, 20.33 mm at 0.7 mm off the axis): enamel only.
/// At tick 14,000 the centre is at 19.6 mm, the burr 0.8 mm above the pulp chamber's roof
/// (18.1 mm): no pulp. At the end the centre has been at 18.4 mm, 0.4 mm into the pulp: some
/// pulp. Removed volumes by label sum to the removed volume, and the whole stays below the
/// volume the burr sweeps with the drill on (13.2 mm of path, at most pi r^2 per mm plus one
/// sphere: 21.8 mm^3).
#[test]
fn the_access_cavity_cuts_enamel_then_dentin_then_opens_the_pulp() {
    let (early, _) = access_cavity(2_000);
    assert!(early[&1] > 0.1, "{early:?}");
    assert_eq!(early[&2], 0.0, "{early:?}");
    assert_eq!(early[&3], 0.0, "{early:?}");

    let (middle, _) = access_cavity(14_000);
    assert!(middle[&2] > middle[&1], "{middle:?}");
    assert_eq!(middle[&3], 0.0, "{middle:?}");

    let (end, total) = access_cavity(17_601);
    assert!(end[&3] > 0.0, "{end:?}");
    let sum: f64 = end.values().sum();
    assert!((sum - total).abs() < 1e-9 * total, "{sum} against {total}");
    let r: f64 = 0.7;
    let swept = std::f64::consts::PI * r * r * 13.2 + 4.0 / 3.0 * std::f64::consts::PI * r.powi(3);
    assert!(total < swept, "{total} mm^3 removed, {swept} swept");
}
