//! Points against tets: both directions and self-collision against brute force, a tiny output
//! saturating without a panic, a moved body, and the coherent lists (previous points first, bad
//! previous entries ignored).

use glam::{Quat, Vec3};

use super::points::points_in_tets_coherent;
use super::teschner::tets_over_points_coherent;
use super::test_support::{brute, Store};
use super::*;
use crate::hash::{HashEntry, SpatialHash};
use crate::ids::{NodeId, TetId};

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

/// Brute force: per point the smallest tet that holds it, and the number of (point, tet)
/// pairs with the point inside.
fn brute_pairs(body: &Body<'_, '_>, points: &[Vec3]) -> ([Option<TetId>; 64], usize) {
    let mut first = [None; 64];
    let mut pairs = 0;
    for (i, &p) in points.iter().enumerate() {
        for t in 0..body.tet_count() {
            let t = TetId::from_idx(t);
            let b = crate::geom::barycentric(p, body.tet_positions(t).unwrap());
            if b.is_some_and(|b| crate::geom::inside(b, INSIDE_EPS)) {
                pairs += 1;
                first[i] = first[i].or(Some(t));
            }
        }
    }
    (first, pairs)
}

/// Checks that `out` is sorted by node without repeats and names each node with its
/// smallest tet; returns the set of nodes.
fn listed_set(out: &[Collision], first: &[Option<TetId>; 64]) -> [bool; 64] {
    let mut set = [false; 64];
    for (i, c) in out.iter().enumerate() {
        assert!(
            i == 0 || out[i - 1].node < c.node,
            "sorted, no repeats: {out:?}"
        );
        assert_eq!(first[c.node.idx()], Some(c.tet), "smallest tet: {c:?}");
        set[c.node.idx()] = true;
    }
    set
}

/// The `_coherent` forms along a path: the tool cube slides through the block while turning,
/// with outputs of 1 to 27 entries, each step's result left in the output for the next.
/// Oracle (brute force and its own selection): for points in tets, the list is last step's
/// points still inside, then the smallest new indices up to the room left; for tets over
/// points, every point of last step still inside is kept and the rest are inside. Both give
/// exactly the brute-force set whenever it fits (for tets over points: whenever the plain
/// walk's hits fit, which needs the second walk when points left and new ones came).
#[test]
fn coherent_lists_keep_the_previous_points_first() {
    let mut obj = Store::<27, 48>::block(2, 0.5, Vec3::splat(-0.5));
    let obj = obj.mesh();
    let ob = Body::fixed(&obj);
    let mut tool = Store::<9, 12>::cube12(0.6, Vec3::ZERO);
    let tool = tool.mesh();
    let mut starts = [0u32; 32];
    let mut entries = [HashEntry::default(); 2048];
    let mut th = SpatialHash::new(&mut starts, &mut entries, 0.3).unwrap();
    assert!(!hash_tets(&mut th, &ob).saturated);
    let mut ns = [0u32; 32];
    let mut ne = [HashEntry::default(); 64];
    let mut nh = SpatialHash::new(&mut ns, &mut ne, 0.3).unwrap();
    assert!(!nh.rebuild_points(ob.positions).saturated);
    let (mut full_steps, mut second_walks) = (0, 0);
    for cap in [1usize, 2, 3, 5, 9, 27] {
        let mut pen_out = [Collision::default(); 27];
        let mut obj_out = [Collision::default(); 27];
        let (mut pen_prev, mut obj_prev) = ([false; 64], [false; 64]);
        let (mut pen_kept, mut obj_kept) = (0, 0);
        for i in 0..90 {
            let q = Quat::from_rotation_z(0.02 * i as f32);
            let at = Vec3::new(-1.0 + 0.024 * i as f32, -0.25 + 0.004 * i as f32, -0.3);
            let moved: [Vec3; 9] = core::array::from_fn(|k| q * tool.positions()[k] + at);
            let ctx = (cap, i);

            // Tool nodes in object tets.
            let (first, _) = brute_pairs(&ob, &moved);
            let r = points_in_tets_coherent(&th, &ob, &moved, false, &mut pen_out[..cap], pen_kept);
            let got = listed_set(&pen_out[..r.count], &first);
            let mut want = [false; 64];
            let mut n = 0;
            for k in 0..9 {
                if pen_prev[k] && first[k].is_some() {
                    want[k] = true;
                    n += 1;
                }
            }
            let mut saturated = false;
            for k in 0..9 {
                if first[k].is_some() && !want[k] {
                    if n == cap {
                        saturated = true;
                        break;
                    }
                    want[k] = true;
                    n += 1;
                }
            }
            assert_eq!((got, r.count, r.saturated), (want, n, saturated), "{ctx:?}");
            full_steps += saturated as u32;
            (pen_prev, pen_kept) = (got, r.count);

            // Object nodes in tool tets.
            let tb = Body::moved(&tool, &moved, q);
            let (first, pairs) = brute_pairs(&tb, ob.positions);
            let kept_prev = obj_kept;
            let r = tets_over_points_coherent(
                &nh,
                ob.positions,
                &tb,
                false,
                &mut obj_out[..cap],
                obj_kept,
            );
            let got = listed_set(&obj_out[..r.count], &first);
            let inside = first.iter().filter(|t| t.is_some()).count();
            let mut stayed_pairs = 0;
            for k in 0..27 {
                if obj_prev[k] && first[k].is_some() {
                    assert!(got[k], "{ctx:?}: point {k} was listed and is still inside");
                    stayed_pairs += (0..tb.tet_count())
                        .filter(|&t| {
                            let c = tb.tet_positions(TetId::from_idx(t)).unwrap();
                            crate::geom::barycentric(ob.positions[k], c)
                                .is_some_and(|b| crate::geom::inside(b, INSIDE_EPS))
                        })
                        .count();
                }
            }
            if pairs <= cap {
                assert_eq!(r.count, inside, "{ctx:?}: everything fits");
                assert!(!r.saturated, "{ctx:?}");
                // The first walk kept room for every listed point, even those that left.
                second_walks += (pairs - stayed_pairs > cap - kept_prev) as u32;
            }
            assert!(
                r.count == inside || r.saturated,
                "{ctx:?}: incomplete but not saturated"
            );
            (obj_prev, obj_kept) = (got, r.count);
        }
    }
    assert!(full_steps > 10, "the pen side filled {full_steps} times");
    assert!(second_walks > 0, "the second walk was never needed");
}

/// Whatever the output held, the `_coherent` forms write a valid list: unsorted, repeated and
/// out-of-range entries are ignored.
#[test]
fn coherent_lists_ignore_bad_previous_entries() {
    let mut obj = Store::<27, 48>::block(2, 0.5, Vec3::splat(-0.5));
    let obj = obj.mesh();
    let ob = Body::fixed(&obj);
    let pts = [
        Vec3::ZERO,
        Vec3::splat(0.1),
        Vec3::splat(-0.1),
        Vec3::splat(9.0),
        Vec3::new(0.2, -0.3, 0.1),
    ];
    let mut starts = [0u32; 8];
    let mut entries = [HashEntry::default(); 512];
    let mut h = SpatialHash::new(&mut starts, &mut entries, 0.5).unwrap();
    hash_tets(&mut h, &ob);
    let (first, _) = brute_pairs(&ob, &pts);
    let bad = |n: u32| Collision {
        node: NodeId(n),
        tet: TetId(7),
    };
    // 4, then 1 (out of order), 4 again, 3 (outside every tet), 77 (no such point), 0 (out of
    // order): only 4 counts as listed before.
    let mut out = [bad(4), bad(1), bad(4), bad(3), bad(77), bad(0)];
    let r = points_in_tets_coherent(&h, &ob, &pts, false, &mut out, 6);
    let got = listed_set(&out[..r.count], &first);
    assert!(!r.saturated && r.count == 4, "{r:?}");
    assert!(got[0] && got[1] && got[2] && got[4]);
    // With room for 2: 4 stays, then the smallest new index.
    let mut out = [bad(4), bad(1)];
    let r = points_in_tets_coherent(&h, &ob, &pts, false, &mut out, 2);
    let got = listed_set(&out[..r.count], &first);
    assert!(r.saturated && r.count == 2);
    assert!(got[4] && got[0], "{out:?}");

    let mut ns = [0u32; 8];
    let mut ne = [HashEntry::default(); 27];
    let mut nh = SpatialHash::new(&mut ns, &mut ne, 0.5).unwrap();
    nh.rebuild_points(ob.positions);
    let mut tool = Store::<9, 12>::cube12(0.6, Vec3::splat(-0.1));
    let tool = tool.mesh();
    let tb = Body::fixed(&tool);
    let (first, _) = brute_pairs(&tb, ob.positions);
    let mut out = [bad(0); 27];
    out[..6].copy_from_slice(&[bad(26), bad(13), bad(13), bad(500), bad(2), bad(1)]);
    let r = tets_over_points_coherent(&nh, ob.positions, &tb, false, &mut out, 6);
    let got = listed_set(&out[..r.count], &first);
    assert!(!r.saturated);
    assert_eq!(
        got.iter().filter(|&&x| x).count(),
        first.iter().flatten().count()
    );
}
