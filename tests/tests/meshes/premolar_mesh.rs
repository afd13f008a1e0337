//! The real-size premolar (`tests/data/meshes/models/premolar_gmsh.msh22.msh`, made from
//! `premolar.geo` by `scripts/make-premolar.sh`): its size and labels, and its anatomy checked
//! on the tets as read, in f64 and with nothing from the mesher: the volume of each tissue,
//! the tooth's bounding box against the dental-anatomy tables the model follows, the pulp
//! closed inside the dentin, and the enamel's thickness where a probe line crosses it.

use std::collections::{BTreeMap, HashMap};
use std::path::PathBuf;

use tetradrill::meshio;
use tetradrill_tests::workspace_root;

const ENAMEL: i32 = 1;
const DENTIN: i32 = 2;
const PULP: i32 = 3;

fn premolar() -> PathBuf {
    workspace_root().join("tests/data/meshes/models/premolar_gmsh.msh22.msh")
}

/// The mesh as read, in millimetres: positions, tets and labels.
struct Tooth {
    positions: Vec<[f64; 3]>,
    tets: Vec<[u32; 4]>,
    labels: Vec<i32>,
}

fn read() -> Tooth {
    let raw = meshio::read(&premolar()).expect("the premolar reads");
    assert_eq!(raw.format, "gmsh 2.2");
    Tooth {
        positions: raw
            .positions
            .iter()
            .map(|p| p.map(|c| c * 1000.0))
            .collect(),
        tets: raw.tets,
        labels: raw.labels,
    }
}

impl Tooth {
    fn corners(&self, t: usize) -> [[f64; 3]; 4] {
        self.tets[t].map(|n| self.positions[n as usize])
    }

    /// Each tet's bounding box, lowest and highest corner.
    fn boxes(&self) -> Vec<[[f64; 3]; 2]> {
        (0..self.tets.len())
            .map(|t| {
                let p = self.corners(t);
                let lo = [0, 1, 2].map(|k| p.iter().map(|c| c[k]).fold(f64::INFINITY, f64::min));
                let hi =
                    [0, 1, 2].map(|k| p.iter().map(|c| c[k]).fold(f64::NEG_INFINITY, f64::max));
                [lo, hi]
            })
            .collect()
    }

    /// The label of the tet holding `q` (0 outside), by barycentric coordinates over every
    /// tet whose box holds it.
    fn label_at(&self, boxes: &[[[f64; 3]; 2]], q: [f64; 3]) -> i32 {
        for (t, [lo, hi]) in boxes.iter().enumerate() {
            if (0..3).any(|k| q[k] < lo[k] - 1e-9 || q[k] > hi[k] + 1e-9) {
                continue;
            }
            let p = self.corners(t);
            let whole = det(p);
            let inside = (0..4).all(|i| {
                let mut r = p;
                r[i] = q;
                det(r) / whole >= -1e-9
            });
            if inside {
                return self.labels[t];
            }
        }
        0
    }

    /// Runs of labels along the segment from `a` to `b` sampled every `step` mm: each run's
    /// label and its length.
    fn runs(&self, a: [f64; 3], b: [f64; 3], step: f64) -> Vec<(i32, f64)> {
        let boxes = self.boxes();
        let len = (0..3).map(|k| (b[k] - a[k]).powi(2)).sum::<f64>().sqrt();
        let n = (len / step).round() as usize;
        let mut runs: Vec<(i32, f64)> = Vec::new();
        for i in 0..=n {
            let u = i as f64 / n as f64;
            let q = [0, 1, 2].map(|k| a[k] + (b[k] - a[k]) * u);
            let l = self.label_at(&boxes, q);
            match runs.last_mut() {
                Some((last, length)) if *last == l => *length += step,
                _ => runs.push((l, 0.0)),
            }
        }
        runs
    }
}

/// `det[b-a, c-a, d-a]` in f64: six times the signed volume.
fn det(p: [[f64; 3]; 4]) -> f64 {
    let d = |i: usize| [0, 1, 2].map(|k| p[i][k] - p[0][k]);
    let (u, v, w) = (d(1), d(2), d(3));
    u[0] * (v[1] * w[2] - v[2] * w[1]) - u[1] * (v[0] * w[2] - v[2] * w[0])
        + u[2] * (v[0] * w[1] - v[1] * w[0])
}

#[test]
fn the_premolar_loads_with_over_thirty_thousand_tets_in_three_labels() {
    let tooth = read();
    assert!(tooth.tets.len() >= 30_000, "{} tets", tooth.tets.len());
    let mut count: BTreeMap<i32, usize> = BTreeMap::new();
    for &l in &tooth.labels {
        *count.entry(l).or_default() += 1;
    }
    assert_eq!(
        count.keys().copied().collect::<Vec<_>>(),
        [ENAMEL, DENTIN, PULP]
    );
    assert!(count.values().all(|&n| n >= 1_000), "{count:?}");
    for t in 0..tooth.tets.len() {
        assert!(det(tooth.corners(t)) > 0.0, "tet {t} is not positive");
    }

    // The loader and the core's mesh take it whole, the labels following their tets.
    let mut loaded = meshio::load(&premolar(), 1.0).expect("the premolar loads");
    assert_eq!(loaded.labels.len(), tooth.tets.len());
    assert_eq!(loaded.mesh.view().tet_count(), tooth.tets.len());
    let mut sorted = loaded.labels.clone();
    sorted.sort_unstable();
    let mut expected = tooth.labels.clone();
    expected.sort_unstable();
    assert_eq!(sorted, expected);
}

/// The volumes of the three tissues from the tets' own volumes, and the tooth's size against
/// Wheeler's table for a maxillary second premolar (crown 8.5 mm and root 14 mm long, crown
/// 7 mm mesio-distally and 9 mm bucco-lingually): 20-24 mm long, the crown's widths within
/// 0.5 mm of the table's. The fractions are what a real-size premolar's tissues take: the
/// enamel a quarter to two fifths (a cap 1-2 mm thick over a crown of about half the tooth's
/// volume), the pulp 2-7 %, the dentin the rest; the whole between 350 and 700 mm^3.
#[test]
fn the_premolars_tissues_and_size_are_a_real_premolars() {
    let tooth = read();
    let mut volume: BTreeMap<i32, f64> = BTreeMap::new();
    for t in 0..tooth.tets.len() {
        *volume.entry(tooth.labels[t]).or_default() += det(tooth.corners(t)) / 6.0;
    }
    let total: f64 = volume.values().sum();
    assert!(total > 350.0 && total < 700.0, "{total} mm^3");
    let fraction = |l: i32| volume[&l] / total;
    assert!(
        (0.25..0.40).contains(&fraction(ENAMEL)),
        "enamel {}",
        fraction(ENAMEL)
    );
    assert!(
        (0.55..0.72).contains(&fraction(DENTIN)),
        "dentin {}",
        fraction(DENTIN)
    );
    assert!(
        (0.02..0.07).contains(&fraction(PULP)),
        "pulp {}",
        fraction(PULP)
    );

    let lo = |k: usize| {
        tooth
            .positions
            .iter()
            .map(|p| p[k])
            .fold(f64::INFINITY, f64::min)
    };
    let hi = |k: usize| {
        tooth
            .positions
            .iter()
            .map(|p| p[k])
            .fold(f64::NEG_INFINITY, f64::max)
    };
    let (length, md, bl) = (hi(2) - lo(2), hi(0) - lo(0), hi(1) - lo(1));
    assert!((20.0..24.0).contains(&length), "{length} mm long");
    assert!((md - 7.0).abs() < 0.5, "{md} mm mesio-distally");
    assert!((bl - 9.0).abs() < 0.5, "{bl} mm bucco-lingually");

    // The enamel covers the crown only: none lower than the cemento-enamel junction, 8.5 mm
    // (the crown's length) below the cusp tips, give or take 0.5 mm.
    let enamel_low = (0..tooth.tets.len())
        .filter(|&t| tooth.labels[t] == ENAMEL)
        .flat_map(|t| tooth.corners(t))
        .map(|p| p[2])
        .fold(f64::INFINITY, f64::min);
    let cej = hi(2) - enamel_low;
    assert!((cej - 8.5).abs() < 0.5, "the crown is {cej} mm long");
}

/// Every face of a pulp tet is shared with a pulp or dentin tet: no pulp on the boundary and
/// none against the enamel. The canal narrows towards the apex: the pulp's tets in the root's
/// apical third (below 5 mm from the apex) lie within 1 mm of the long axis, and it ends
/// short of the apex.
#[test]
fn the_pulp_is_closed_inside_the_dentin_and_narrows_to_the_apex() {
    let tooth = read();
    let mut faces: HashMap<[u32; 3], Vec<usize>> = HashMap::new();
    for (i, t) in tooth.tets.iter().enumerate() {
        for skip in 0..4 {
            let mut f: Vec<u32> = (0..4).filter(|&j| j != skip).map(|j| t[j]).collect();
            f.sort_unstable();
            faces.entry([f[0], f[1], f[2]]).or_default().push(i);
        }
    }
    let mut pulp_faces = 0;
    for (f, ts) in &faces {
        let ls: Vec<i32> = ts.iter().map(|&t| tooth.labels[t]).collect();
        if !ls.contains(&PULP) {
            continue;
        }
        pulp_faces += 1;
        assert_eq!(ls.len(), 2, "pulp on the boundary at face {f:?}");
        assert!(!ls.contains(&ENAMEL), "pulp against enamel at face {f:?}");
    }
    assert!(pulp_faces > 10_000, "{pulp_faces} pulp faces");

    let apex = tooth
        .positions
        .iter()
        .map(|p| p[2])
        .fold(f64::INFINITY, f64::min);
    let pulp_points = || {
        (0..tooth.tets.len())
            .filter(|&t| tooth.labels[t] == PULP)
            .flat_map(|t| tooth.corners(t))
    };
    let pulp_low = pulp_points().map(|p| p[2]).fold(f64::INFINITY, f64::min);
    assert!(
        pulp_low - apex > 0.5 && pulp_low - apex < 3.0,
        "the canal ends {} mm above the apex",
        pulp_low - apex
    );
    let apical_width = pulp_points()
        .filter(|p| p[2] < apex + 5.0)
        .map(|p| p[0].hypot(p[1]))
        .fold(0.0, f64::max);
    assert!(apical_width < 1.0, "{apical_width} mm off the axis");
    let coronal_width = pulp_points()
        .filter(|p| p[2] > apex + 15.0)
        .map(|p| p[1].abs())
        .fold(0.0, f64::max);
    assert!(
        coronal_width > 1.5,
        "the chamber is {coronal_width} mm wide"
    );
}

/// Probe lines through the crown, from above or outside inwards (0.02 mm steps): over each
/// cusp tip the enamel is 1.5-2.2 mm thick over dentin, then the dentin over a pulp horn
/// 2-5 mm below the tip; under the fissure the enamel is 0.8-1.6 mm thick; on the buccal side
/// at the height of contour about 1 mm (0.7-1.3), and 0.2 mm above the cemento-enamel
/// junction a thin edge (under 0.4 mm).
#[test]
fn the_enamel_is_thick_over_the_cusps_and_thin_at_the_junction() {
    let tooth = read();
    let top = tooth
        .positions
        .iter()
        .map(|p| p[2])
        .fold(f64::NEG_INFINITY, f64::max);
    let step = 0.02;
    let inside = |runs: &[(i32, f64)]| -> Vec<(i32, f64)> {
        runs.iter().copied().filter(|&(l, _)| l != 0).collect()
    };
    for y in [1.85, -1.85] {
        let runs = inside(&tooth.runs([0.0, y, top + 0.5], [0.0, y, top - 8.0], step));
        assert_eq!(runs[0].0, ENAMEL, "{y}: {runs:?}");
        assert!((1.5..2.2).contains(&runs[0].1), "{y}: {runs:?}");
        assert_eq!(runs[1].0, DENTIN, "{y}: {runs:?}");
    }
    for y in [1.3, -1.3] {
        let runs = inside(&tooth.runs([0.0, y, top + 0.5], [0.0, y, top - 8.0], step));
        let to_pulp: f64 = runs.iter().take_while(|r| r.0 != PULP).map(|r| r.1).sum();
        assert!(runs.iter().any(|r| r.0 == PULP), "{y}: {runs:?}");
        assert!((2.0..5.0).contains(&to_pulp), "{y}: {runs:?}");
    }
    let fissure = inside(&tooth.runs([0.0, 0.0, top + 0.5], [0.0, 0.0, top - 8.0], step));
    assert_eq!(fissure[0].0, ENAMEL, "{fissure:?}");
    assert!((0.8..1.6).contains(&fissure[0].1), "{fissure:?}");

    let enamel_low = (0..tooth.tets.len())
        .filter(|&t| tooth.labels[t] == ENAMEL)
        .flat_map(|t| tooth.corners(t))
        .map(|p| p[2])
        .fold(f64::INFINITY, f64::min);
    let contour = top - 4.5;
    let side = inside(&tooth.runs([0.0, 6.0, contour], [0.0, 0.0, contour], step));
    assert_eq!(side[0].0, ENAMEL, "{side:?}");
    assert!((0.7..1.3).contains(&side[0].1), "{side:?}");
    let edge = enamel_low + 0.2;
    let side = inside(&tooth.runs([0.0, 6.0, edge], [0.0, 0.0, edge], step));
    assert_eq!(side[0].0, ENAMEL, "{side:?}");
    assert!(side[0].1 < 0.4, "{side:?}");
}
