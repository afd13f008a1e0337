//! A minimal TetGen `.node`/`.ele` reader, the tests' own, so the tests that load real meshes
//! through it do not depend on the host's mesh readers.

use glam::Vec3;
use tetradrill::owned::OwnedMesh;
use tetradrill_core::mesh::BuildOptions;

/// The mesh of a TetGen `.node` file below the meshes folder and its `.ele` partner, read by
/// the minimal reader here (the counts on the first lines, then one row per node and per tet;
/// markers and attributes ignored, `#` comments skipped).
pub fn tetgen(rel: &str) -> OwnedMesh {
    let node = crate::mesh(rel);
    let ele = node.with_extension("ele");
    let nums = |path: &std::path::Path| -> Vec<Vec<f64>> {
        std::fs::read_to_string(path)
            .unwrap()
            .lines()
            .map(|l| l.split('#').next().unwrap_or(""))
            .filter(|l| !l.trim().is_empty())
            .map(|l| {
                l.split_whitespace()
                    .map(|w| w.parse::<f64>().unwrap())
                    .collect()
            })
            .collect()
    };
    let nrows = nums(&node);
    let erows = nums(&ele);
    let n = nrows[0][0] as usize;
    let base = nrows[1][0] as u32;
    let p: Vec<Vec3> = nrows[1..=n]
        .iter()
        .map(|r| Vec3::new(r[1] as f32, r[2] as f32, r[3] as f32))
        .collect();
    let m = erows[0][0] as usize;
    let t: Vec<[u32; 4]> = erows[1..=m]
        .iter()
        .map(|r| {
            [
                r[1] as u32 - base,
                r[2] as u32 - base,
                r[3] as u32 - base,
                r[4] as u32 - base,
            ]
        })
        .collect();
    OwnedMesh::build(p, &t, BuildOptions::default()).unwrap()
}
