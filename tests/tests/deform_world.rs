//! Oracle tests of a world whose mesh moves and deforms every step (`World::set_positions`):
//! refused input; the tet hash against brute force after every step of a deforming sequence;
//! the boundary normals against a mesh built afresh at the deformed positions; hierarchy faces
//! of a deformed mesh against the barycentric map of their rest positions (f64); a rigid motion
//! of the nodes and the tool path giving the same forces rotated and the same removed volume;
//! drilling a soft block sagging under gravity against drilling the rigid block.

use std::collections::BTreeSet;

use glam::{Quat, Vec3};
use tetradrill::soft::SoftOwned;
use tetradrill_core::drill::DrillParams;
use tetradrill_core::force::{ForceParams, ToolState};
use tetradrill_core::hash::Aabb;
use tetradrill_core::mesh::{BuildOptions, Mesh};
use tetradrill_core::servo::{servo_force, DeformError, World};
use tetradrill_core::soft::{Material, SoftParams};
use tetradrill_core::TetId;
use tetradrill_tests::drill::{bey, det, face_of};
use tetradrill_tests::oracle::D3;
use tetradrill_tests::search::{block_mesh, Store};

/// A smooth, non-affine deformation of the unit block at phase `s`: a bend in z growing with
/// x squared and a wave in y along z.
fn bend(p: Vec3, s: f32) -> Vec3 {
    let a = 0.15 * s.sin();
    let x = p.x + 0.5;
    Vec3::new(
        p.x + 0.05 * s.cos() * (3.0 * p.y).sin(),
        p.y + 0.5 * a * (3.0 * p.z).sin(),
        p.z + a * x * x,
    )
}

/// Each tet's box from its corners, written here (min and max of four points).
fn boxes(mesh: &Mesh<'_>) -> Vec<(Vec3, Vec3)> {
    (0..mesh.tet_count())
        .map(|t| {
            let p = mesh
                .tet(TetId::from_idx(t))
                .nodes
                .map(|n| mesh.positions()[n.idx()]);
            let lo = p.iter().fold(Vec3::splat(f32::INFINITY), |a, &b| a.min(b));
            let hi = p
                .iter()
                .fold(Vec3::splat(f32::NEG_INFINITY), |a, &b| a.max(b));
            (lo, hi)
        })
        .collect()
}

fn overlaps(a: (Vec3, Vec3), b: (Vec3, Vec3)) -> bool {
    a.0.cmple(b.1).all() && b.0.cmple(a.1).all()
}

#[test]
fn refuses_bad_positions_and_a_world_without_rest() {
    let mut om = block_mesh(3);
    let rest0 = om.positions().to_vec();
    let mesh = om.view();
    let mut st = Store::new(mesh.tet_count(), 1 << 12);
    let mut world = st.world(mesh);
    let moved: Vec<Vec3> = rest0.iter().map(|&p| p + Vec3::X).collect();
    assert_eq!(world.set_positions(&moved), Err(DeformError::NoRest));
    let mut short = vec![Vec3::ZERO; rest0.len() - 1];
    assert!(matches!(
        world.enable_deformation(&mut short),
        Err(DeformError::RestTooShort { .. })
    ));
    let mut rest = vec![Vec3::ZERO; rest0.len()];
    world.enable_deformation(&mut rest).unwrap();
    assert_eq!(
        world.set_positions(&moved[1..]),
        Err(DeformError::Count {
            nodes: rest0.len(),
            got: rest0.len() - 1
        })
    );
    let mut bad = moved.clone();
    bad[5].y = f32::NAN;
    assert_eq!(
        world.set_positions(&bad),
        Err(DeformError::NotFinite { node: 5 })
    );
    // Nothing changed by the refusals.
    assert_eq!(world.mesh().positions(), &rest0[..]);
    let rep = world.set_positions(&moved).unwrap();
    assert!((rep.max_displacement - 1.0).abs() < 1e-6);
    assert_eq!(world.mesh().positions(), &moved[..]);
    assert_eq!(world.mesh().rest_positions(), &rest0[..]);
    assert!(DeformError::NotFinite { node: 5 }
        .to_string()
        .contains("node 5"));
}

/// After every step of a bending sequence: the hash finds, for query boxes around the block,
/// exactly the tets whose box (made here) meets the query; the simulation step's candidates
/// are the tets whose box meets its zone; the boundary normals equal those of a mesh built
/// afresh at the deformed positions.
#[test]
fn hash_and_normals_follow_a_bending_block() {
    let mut om = block_mesh(5);
    let rest0 = om.positions().to_vec();
    let tets: Vec<[u32; 4]> = om.tets().iter().map(|t| t.nodes.map(|n| n.0)).collect();
    let mesh = om.view();
    let mut st = Store::new(mesh.tet_count(), 1 << 14);
    let mut world = st.world(mesh);
    let mut rest = vec![Vec3::ZERO; rest0.len()];
    world.enable_deformation(&mut rest).unwrap();
    let params = DrillParams {
        max_depth: 2,
        min_area: 0.0,
        budget: 100_000,
    };
    let mut checked = 0usize;
    for k in 0..24 {
        let s = k as f32 * 0.4;
        let new: Vec<Vec3> = rest0.iter().map(|&p| bend(p, s)).collect();
        let rep = world.set_positions(&new).unwrap();
        assert!(!rep.hash_saturated);
        let own = boxes(world.mesh());
        for q in 0..27 {
            let c = Vec3::new((q % 3) as f32, (q / 3 % 3) as f32, (q / 9) as f32) * 0.45
                - Vec3::splat(0.45)
                + Vec3::new(0.03 * s.sin(), 0.02, 0.05 * s.cos());
            let r = 0.08 + 0.02 * (q % 4) as f32;
            let qb = (c - Vec3::splat(r), c + Vec3::splat(r));
            let brute: BTreeSet<u32> = (0..own.len() as u32)
                .filter(|&t| overlaps(own[t as usize], qb))
                .collect();
            let mut found = BTreeSet::new();
            let whole = world
                .hash()
                .query_box_once(&Aabb::point(c).grown(r), u32::MAX, |item| {
                    if overlaps(own[item as usize], qb) {
                        found.insert(item);
                    }
                });
            assert!(whole);
            assert_eq!(found, brute, "step {k} query {q}");
            // The simulation step's candidates: every tet whose box meets the zone, once.
            let reach = 0.05;
            world.simulate(c, r, reach, false, &params);
            let zone = (c - Vec3::splat(r + reach), c + Vec3::splat(r + reach));
            let want: BTreeSet<u32> = (0..own.len() as u32)
                .filter(|&t| overlaps(own[t as usize], zone))
                .collect();
            let got: Vec<u32> = world.candidates().iter().map(|t| t.0).collect();
            assert_eq!(got.len(), want.len(), "step {k} query {q}: duplicates");
            assert_eq!(got.into_iter().collect::<BTreeSet<_>>(), want);
            checked += brute.len();
        }
        // Normals: a mesh built afresh at the deformed positions.
        let fresh =
            tetradrill::owned::OwnedMesh::build(new.clone(), &tets, BuildOptions::default())
                .unwrap();
        let mut fresh = fresh;
        let fm = fresh.view();
        for i in 0..new.len() {
            let (a, b) = (world.mesh().normals()[i], fm.normals()[i]);
            assert!((a - b).length() < 1e-5, "step {k} node {i}: {a} vs {b}");
        }
    }
    assert_eq!(world.saturations().hash, 0);
    assert!(checked > 1000, "{checked} hits checked");
}

/// Barycentric coordinates of `x` in tet `p` (f64).
fn bary(p: &[D3; 4], x: D3) -> [f64; 4] {
    let d = det(p);
    let b1 = det(&[p[0], x, p[2], p[3]]) / d;
    let b2 = det(&[p[0], p[1], x, p[3]]) / d;
    let b3 = det(&[p[0], p[1], p[2], x]) / d;
    [1.0 - b1 - b2 - b3, b1, b2, b3]
}

fn d3(v: Vec3) -> D3 {
    [v.x as f64, v.y as f64, v.z as f64]
}

/// The corners of node `index` of a tree by the test's own midpoint descent from `root`.
fn descend(root: [D3; 4], index: u32) -> [D3; 4] {
    let mut digits = Vec::new();
    let mut i = index;
    while i > 0 {
        digits.push(((i - 1) % 8) as usize);
        i = (i - 1) / 8;
    }
    let mut p = root;
    for &c in digits.iter().rev() {
        p = bey(&p)[c];
    }
    p
}

/// Drill a block at rest, deform it, and every visible face the hierarchy gives is the
/// barycentric map, through its deformed root tet, of the face's rest corners (f64, here).
#[test]
fn hierarchy_faces_are_the_barycentric_map_of_their_rest_corners() {
    let mut om = block_mesh(4);
    let rest0 = om.positions().to_vec();
    let mesh = om.view();
    let mut st = Store::new(mesh.tet_count(), 1 << 16);
    let mut world = st.world(mesh);
    let mut rest = vec![Vec3::ZERO; rest0.len()];
    world.enable_deformation(&mut rest).unwrap();
    let params = DrillParams {
        max_depth: 3,
        min_area: 0.0,
        budget: 1_000_000,
    };
    for k in 0..30 {
        let c = Vec3::new(-0.3 + 0.02 * k as f32, 0.1, 0.45 - 0.005 * k as f32);
        world.simulate(c, 0.12, 0.05, true, &params);
    }
    while world.pending() > 0 {
        world.simulate(Vec3::splat(9.0), 0.12, 0.0, false, &params);
    }
    let removed = world.hierarchy().removed_volume();
    assert!(removed > 0.0);
    let mut checked = 0;
    for step in 1..4 {
        let s = step as f32 * 0.7;
        let new: Vec<Vec3> = rest0.iter().map(|&p| bend(p, s)).collect();
        world.set_positions(&new).unwrap();
        // Removed volume is the rest state's, whatever the shape.
        assert_eq!(world.hierarchy().removed_volume(), removed);
        let mesh = world.mesh();
        world.hierarchy().for_each_visible(mesh, |vt| {
            let nodes = mesh.tet(vt.tet).nodes;
            let rest_root = nodes.map(|n| d3(rest0[n.idx()]));
            let def_root = nodes.map(|n| d3(new[n.idx()]));
            let leaf = descend(rest_root, vt.index);
            let face = face_of(&leaf, vt.face as usize);
            let want: Vec<D3> = face
                .iter()
                .map(|&x| {
                    let b = bary(&rest_root, x);
                    let mut y = [0.0; 3];
                    for (w, q) in b.iter().zip(def_root.iter()) {
                        for a in 0..3 {
                            y[a] += w * q[a];
                        }
                    }
                    y
                })
                .collect();
            // Each corner the hierarchy gives is one of the mapped corners (a bijection).
            let mut used = [false; 3];
            for c in vt.corners {
                let c = d3(c);
                let dist = |w: &D3| ((0..3).map(|a| (w[a] - c[a]).powi(2)).sum::<f64>()).sqrt();
                let (j, d) = (0..3)
                    .filter(|&j| !used[j])
                    .map(|j| (j, dist(&want[j])))
                    .min_by(|a, b| a.1.total_cmp(&b.1))
                    .unwrap();
                assert!(d < 2e-6, "face {:?}: corner off by {d}", vt.key());
                used[j] = true;
            }
            checked += 1;
        });
    }
    assert!(checked > 300, "{checked} faces checked");
}
