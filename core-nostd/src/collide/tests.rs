use glam::{Quat, Vec3};

use super::test_support::Store;
use super::*;
use crate::hash::{HashEntry, SpatialHash};
use crate::ids::{NodeId, TetId};

fn brute(body: &Body<'_, '_>, points: &[Vec3], own: bool) -> [Option<TetId>; 64] {
    let mut r = [None; 64];
    for (i, &p) in points.iter().enumerate() {
        for t in 0..body.tet_count() {
            let t = TetId::from_idx(t);
            if own && body.tet_nodes(t).unwrap().contains(&NodeId::from_idx(i)) {
                continue;
            }
            if let Some(b) = crate::geom::barycentric(p, body.tet_positions(t).unwrap()) {
                if crate::geom::inside(b, INSIDE_EPS) {
                    r[i] = Some(t);
                    break;
                }
            }
        }
    }
    r
}

#[test]
fn both_directions_match_brute_force() {
    let mut obj = Store::<27, 48>::block(2, 0.5, Vec3::splat(-0.5));
    let obj = obj.mesh();
    let mut tool = Store::<9, 12>::cube12(0.6, Vec3::new(0.45, 0.1, -0.05));
    let tool = tool.mesh();
    let ob = Body::fixed(&obj);
    let tb = Body::fixed(&tool);

    // Tool nodes inside object tets (object hashed once).
    let mut starts = [0u32; 32];
    let mut entries = [HashEntry::default(); 2048];
    let mut h = SpatialHash::new(&mut starts, &mut entries, 0.3).unwrap();
    assert!(!hash_tets(&mut h, &ob).saturated);
    let mut out = [Collision::default(); 16];
    let r = points_in_tets(&h, &ob, tb.positions, false, &mut out);
    let want = brute(&ob, tb.positions, false);
    let n_want = want.iter().filter(|x| x.is_some()).count();
    assert!(
        n_want > 0 && n_want < 9,
        "partial overlap expected, got {n_want}"
    );
    assert_eq!(r.count, n_want);
    for c in &out[..r.count] {
        assert_eq!(want[c.node.idx()], Some(c.tet));
    }

    // Object nodes inside tool tets (object nodes hashed, tool tets walk their boxes).
    let mut starts = [0u32; 32];
    let mut entries = [HashEntry::default(); 64];
    let mut h = SpatialHash::new(&mut starts, &mut entries, 0.3).unwrap();
    h.rebuild_points(ob.positions);
    let mut out = [Collision::default(); 32];
    let r = tets_over_points(&h, ob.positions, &tb, false, &mut out);
    let want = brute(&tb, ob.positions, false);
    let n_want = want.iter().filter(|x| x.is_some()).count();
    assert!(n_want > 0);
    assert_eq!(r.count, n_want);
    for c in &out[..r.count] {
        assert_eq!(want[c.node.idx()], Some(c.tet));
    }
}

#[test]
fn self_collision_excludes_own_tets_by_index() {
    let mut m = Store::<27, 48>::block(2, 0.5, Vec3::ZERO);
    let m = m.mesh();
    let b = Body::fixed(&m);
    let mut starts = [0u32; 32];
    let mut entries = [HashEntry::default(); 512];
    let mut h = SpatialHash::new(&mut starts, &mut entries, 0.5).unwrap();
    hash_tets(&mut h, &b);
    let mut out = [Collision::default(); 8];
    // Every node lies on faces of other tets only through its own tets: no self-collision.
    let r = points_in_tets(&h, &b, b.positions, true, &mut out);
    assert_eq!(r.count, 0, "{:?}", &out[..r.count]);
    // Without exclusion every node touches its own tets.
    let r = points_in_tets(&h, &b, b.positions, false, &mut out);
    assert!(r.saturated && r.count == 8);
}

#[test]
fn tiny_output_saturates_without_panic() {
    let mut obj = Store::<27, 48>::block(2, 0.5, Vec3::splat(-0.5));
    let obj = obj.mesh();
    let ob = Body::fixed(&obj);
    let pts = [
        Vec3::ZERO,
        Vec3::splat(0.1),
        Vec3::splat(-0.1),
        Vec3::splat(9.0),
    ];
    let mut starts = [0u32; 8];
    let mut entries = [HashEntry::default(); 512];
    let mut h = SpatialHash::new(&mut starts, &mut entries, 0.5).unwrap();
    hash_tets(&mut h, &ob);
    let mut out = [Collision::default(); 2];
    let r = points_in_tets(&h, &ob, &pts, false, &mut out);
    assert!(r.saturated);
    assert_eq!(
        (r.count, out[0].node, out[1].node),
        (2, NodeId(0), NodeId(1))
    );
    let mut none: [Collision; 0] = [];
    let r = points_in_tets(&h, &ob, &pts, false, &mut none);
    assert!(r.saturated && r.count == 0);

    let mut ph_s = [0u32; 8];
    let mut ph_e = [HashEntry::default(); 2]; // only two of four points fit
    let mut ph = SpatialHash::new(&mut ph_s, &mut ph_e, 0.5).unwrap();
    assert!(ph.rebuild_points(&pts).saturated);
    let mut out = [Collision::default(); 1];
    let r = tets_over_points(&ph, &pts, &ob, false, &mut out);
    assert!(r.saturated);
    assert_eq!(r.count, 1);
}

#[test]
fn moved_body_uses_its_positions_and_rotation() {
    let mut m = Store::<9, 12>::cube12(1.0, Vec3::ZERO);
    let m = m.mesh();
    let moved: [Vec3; 9] = core::array::from_fn(|i| m.positions()[i] + Vec3::X * 10.0);
    let q = Quat::from_rotation_z(core::f32::consts::FRAC_PI_2);
    let b = Body::moved(&m, &moved, q);
    assert_eq!(b.pos(NodeId(0)), Some(m.positions()[0] + Vec3::X * 10.0));
    assert!((b.normal(NodeId(0)) - q * m.normal(NodeId(0))).length() < 1e-6);
    assert_eq!(b.pos(NodeId(99)), None);
    assert_eq!(b.normal(NodeId(99)), Vec3::ZERO);
}
