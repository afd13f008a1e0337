//! Unit tests with tiny capacities: the pending deque and the arena saturate, the hierarchy
//! stays valid, and the work is carried over.

use glam::Vec3;

use super::*;
use crate::builtin::{cube12, CUBE12_NODES, CUBE12_TETS};
use crate::hierarchy::{HNode, Hierarchy, HierarchyStorage, VEntry};
use crate::ids::TetId;
use crate::mesh::{BuildOptions, FaceKey, Mesh, MeshStorage, Node, Tet};

#[test]
fn classify_cases() {
    let p = [Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z];
    let s = |c: Vec3, r: f32| Sphere {
        center: c,
        radius: r,
    };
    assert_eq!(classify(p, &s(Vec3::ZERO, 2.0)), Class::Inside);
    assert_eq!(classify(p, &s(Vec3::splat(0.2), 0.05)), Class::Crossing);
    assert_eq!(
        classify(p, &s(Vec3::new(0.3, 0.3, -0.1), 0.2)),
        Class::Crossing
    );
    assert_eq!(
        classify(p, &s(Vec3::new(0.3, 0.3, -0.3), 0.2)),
        Class::Outside
    );
    assert_eq!(classify(p, &s(Vec3::splat(1.0), 0.5)), Class::Outside);
    let q = crate::geom::closest_point_on_triangle(
        Vec3::new(2.0, -1.0, 0.0),
        [Vec3::ZERO, Vec3::X, Vec3::Y],
    );
    assert!(q.distance(Vec3::X) < 1e-6);
}

#[test]
fn tiny_capacities_saturate_and_carry_over() {
    let (mut pos, t) = cube12();
    let mut nodes = [Node::default(); CUBE12_NODES];
    let mut normals = [Vec3::ZERO; CUBE12_NODES];
    let mut tets = [Tet::default(); CUBE12_TETS];
    let mut scratch = [FaceKey::default(); 4 * CUBE12_TETS];
    let mesh = Mesh::build(
        &mut pos,
        &t,
        MeshStorage {
            nodes: &mut nodes,
            normals: &mut normals,
            tets: &mut tets,
        },
        &mut scratch,
        BuildOptions::default(),
    )
    .unwrap();
    let mut roots = [HNode::LEAF; CUBE12_TETS];
    let mut arena = [HNode::LEAF; 64];
    let mut vlist = [VEntry::default(); CUBE12_TETS + 56];
    let mut h = Hierarchy::new(
        &mesh,
        HierarchyStorage {
            roots: &mut roots,
            arena: &mut arena,
            vlist: &mut vlist,
        },
    )
    .unwrap();
    // A deque that holds the candidates plus one depth-first path (8 + 7 per level) drains:
    // the work is carried over and finished in later ticks.
    let mut queue = [Pending::default(); CUBE12_TETS + 8 + 7 * 3];
    let mut drill = Drill::new(&mut queue);
    let spheres = [Sphere {
        center: Vec3::new(-0.5, 0.0, 0.1),
        radius: 0.3,
    }];
    let mut cand = [TetId::NONE; CUBE12_TETS];
    let n = candidates_brute_force(&mesh, &spheres, &mut cand);
    let params = DrillParams {
        max_depth: 3,
        min_area: 0.0,
        budget: 20,
    };
    let mut ticks = 0;
    loop {
        let r = drill.step(&mut h, &mesh, &cand[..n], &spheres, &params);
        h.validate(&mesh).unwrap();
        assert_eq!(drill.saturations(), 0);
        ticks += 1;
        if r.pending == 0 {
            break;
        }
        assert!(ticks < 200);
    }
    assert!(ticks > 1, "the budget spreads the work over several ticks");
    let again = drill.step(&mut h, &mesh, &cand[..n], &spheres, &params);
    assert_eq!(
        again.work, 0,
        "an unchanged sphere whose work is done costs nothing"
    );
    let mut queue = [Pending::default(); 12];
    let mut drill = Drill::new(&mut queue);
    let spheres = [Sphere {
        center: Vec3::new(0.5, 0.1, 0.0),
        radius: 0.3,
    }];
    let n = candidates_brute_force(&mesh, &spheres, &mut cand);
    assert!(n > 0 && n < CUBE12_TETS);
    let mut total = DrillReport::default();
    let removed0 = h.removed_volume();
    for _ in 0..50 {
        let r = drill.step(&mut h, &mesh, &cand[..n], &spheres, &params);
        h.validate(&mesh).unwrap();
        total.erased += r.erased;
        total.saturations += r.saturations;
        total.removed_volume += r.removed_volume;
        assert!(r.work < params.budget + 200);
    }
    // The arena is full and the sphere lies across coarse leaves only: each stays whole (no
    // centroid erasure of a coarse leaf, which would move the surface past the burr at once).
    assert_eq!(total.erased, 0, "{total:?} {}", h.saturations());
    assert!(total.saturations > 0, "tiny queue and arena must saturate");
    assert!(h.saturations() > 0);
    assert!((total.removed_volume - (h.removed_volume() - removed0)).abs() < 1e-12);
}
