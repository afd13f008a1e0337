use glam::{Quat, Vec3};

use super::test_support::Store;
use super::*;
use crate::collide::{OccupancyError, OccupancyStorage, RigidTetsStorage};
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

/// A xorshift generator for the rigid and occupancy tests.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> f32 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 40) as f32 / (1u64 << 24) as f32
    }
    fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.next()
    }
    fn rotation(&mut self) -> Quat {
        let q = Quat::from_xyzw(
            self.range(-1.0, 1.0),
            self.range(-1.0, 1.0),
            self.range(-1.0, 1.0),
            self.range(-1.0, 1.0),
        );
        if q.length_squared() < 1e-3 {
            Quat::IDENTITY
        } else {
            q.normalize()
        }
    }
}

/// Brute force over every tet of `body` in world coordinates: per point the smallest tet
/// that holds it (`geom::barycentric`, `geom::inside`), as sorted collisions.
fn brute_list<const N: usize>(
    body: &Body<'_, '_>,
    points: &[Vec3],
    out: &mut [Collision; N],
) -> usize {
    let mut n = 0;
    for (i, &p) in points.iter().enumerate() {
        for t in 0..body.tet_count() {
            let t = TetId::from_idx(t);
            let b = crate::geom::barycentric(p, body.tet_positions(t).unwrap());
            if b.is_some_and(|b| crate::geom::inside(b, INSIDE_EPS)) {
                out[n] = Collision {
                    node: NodeId::from_idx(i),
                    tet: t,
                };
                n += 1;
                break;
            }
        }
    }
    n
}

/// The tool block and the object block with their static structures, for the rigid tests:
/// `$rest` the tool's rest data, `$nh` the object's node hash, `$cells` its occupancy.
macro_rules! rigid_scene {
    ($tool:ident, $obj:ident, $rest:ident, $nh:ident, $cells:ident, $obj_origin:expr) => {
        let mut tool_store = Store::<27, 48>::block(2, 0.25, Vec3::new(-0.25, -0.25, 0.0));
        let $tool = tool_store.mesh();
        let mut obj_store = Store::<125, 384>::block(4, 0.25, $obj_origin);
        let $obj = obj_store.mesh();
        let (mut rs, mut re) = ([0u32; 128], [HashEntry::default(); 4096]);
        let empty = crate::hash::Aabb::of::<0>([]);
        let (mut rb, mut rc, mut nc) = ([empty; 48], [empty; 64], [0u32; 27]);
        let $rest = RigidTets::build(
            &Body::fixed(&$tool),
            RigidTetsStorage {
                hash: SpatialHash::new(&mut rs, &mut re, 0.1).unwrap(),
                tet_boxes: &mut rb,
                clusters: &mut rc,
                node_clusters: &mut nc,
            },
            0.08,
            1e-4,
        )
        .unwrap();
        let (mut ns, mut ne) = ([0u32; 64], [HashEntry::default(); 125]);
        let mut nh = SpatialHash::new(&mut ns, &mut ne, 0.25).unwrap();
        assert!(!nh.rebuild_points($obj.positions()).saturated);
        let $nh = nh;
        let (mut ow, mut obx) = ([0u32; 8], [empty; 384]);
        let $cells = Occupancy::build(
            &Body::fixed(&$obj),
            0.1,
            1e-4,
            OccupancyStorage {
                words: &mut ow,
                boxes: &mut obx,
            },
        )
        .unwrap();
    };
}

/// `rigid_tets_over_points_coherent` against brute force over all moved tool tets: identical
/// lists at random poses (tilted, partly in, impaled through the object), at axis-aligned
/// poses whose object nodes sit exactly on the tool's corners and faces, and at poses so far
/// from the origin, or scaled by a quaternion off unit length, that it falls back to the plain
/// walk; and the tool nodes in the object tets, culled by the clusters near the object.
#[test]
fn rigid_tool_matches_brute_force() {
    for far in [false, true] {
        let origin = if far {
            Vec3::splat(2000.0)
        } else {
            Vec3::splat(-0.5)
        };
        rigid_scene!(tool, obj, rest, nh, cells, origin);
        assert!(rest.clusters() > 8 && rest.occupied_clusters() > 8);
        let centre = origin + Vec3::splat(0.5);
        let mut rng = Rng(0x1234_5678_9abc_def1);
        let (mut hits, mut full_in, mut tool_hits, mut culled) = (0usize, 0usize, 0usize, 0usize);
        let (mut th_s, mut th_e) = ([0u32; 64], [HashEntry::default(); 4096]);
        let mut th = SpatialHash::new(&mut th_s, &mut th_e, 0.25).unwrap();
        assert!(!hash_tets(&mut th, &Body::fixed(&obj)).saturated);
        for i in 0..400 {
            let (pos, rot) = if i % 17 == 5 {
                // Not a unit quaternion: a scaled tool, handled by the fallback walk.
                let p = centre + Vec3::new(rng.range(-0.5, 0.5), rng.range(-0.5, 0.5), 0.0);
                (p, rng.rotation() * 1.1)
            } else if i % 10 == 0 {
                // Grid-aligned: tool corners on object nodes.
                let k = |r: &mut Rng| (r.range(-2.0, 2.0) as i32) as f32 * 0.25;
                let p = centre + Vec3::new(k(&mut rng), k(&mut rng), k(&mut rng));
                (p, Quat::IDENTITY)
            } else {
                let p = centre
                    + Vec3::new(
                        rng.range(-0.7, 0.7),
                        rng.range(-0.7, 0.7),
                        rng.range(-0.7, 0.7),
                    );
                (p, rng.rotation())
            };
            let pose = glam::Affine3A::from_rotation_translation(rot, pos);
            let moved: [Vec3; 27] =
                core::array::from_fn(|k| pose.transform_point3(tool.positions()[k]));
            let tb = Body::moved(&tool, &moved, rot);
            let mut want = [Collision::default(); 125];
            let n_want = brute_list(&tb, obj.positions(), &mut want);
            for use_cells in [false, true] {
                // Room for every (point, tet) pair: the fallback walk lists pairs before it
                // keeps each point's smallest tet.
                let mut out = [Collision::default(); 1024];
                let near = match use_cells {
                    true => rest.near(pose, &cells),
                    false => NearClusters::ALL,
                };
                let r = rigid_tets_over_points_coherent(
                    &nh,
                    obj.positions(),
                    &rest,
                    &tb,
                    pose,
                    &near,
                    &mut out,
                    0,
                    0,
                );
                assert!(!r.saturated, "pose {i} far {far}");
                assert_eq!(
                    &out[..r.count],
                    &want[..n_want],
                    "pose {i} far {far} cells {use_cells}"
                );
            }
            // The other direction: tool nodes in object tets, culled by the tool's clusters
            // that are near the object (`node_near`) and by the object's occupancy.
            let ob = Body::fixed(&obj);
            let mut want_tool = [Collision::default(); 27];
            let n_tool = brute_list(&ob, &moved, &mut want_tool);
            let near = rest.near(pose, &cells);
            let mut out = [Collision::default(); 27];
            let r = points_in_tets_occupied(&th, &cells, &ob, &moved, false, &mut out, 0, |k| {
                rest.node_near(k, &near)
            });
            assert_eq!(
                &out[..r.count],
                &want_tool[..n_tool],
                "tool nodes, pose {i} far {far}"
            );
            culled += (0..27).filter(|&k| !rest.node_near(k, &near)).count();
            tool_hits += n_tool;
            hits += n_want;
            full_in += (n_want >= 4) as usize;
        }
        assert!(
            hits > 400 && full_in > 10,
            "poses must touch: {hits} hits, {full_in} deep"
        );
        assert!(tool_hits > 400, "tool nodes inside: {tool_hits}");
        if !far {
            assert!(
                culled > 400,
                "tool nodes culled by their clusters: {culled}"
            );
        }
    }
}

/// Full outputs along a path through the object (the tool turning as it goes): the previous
/// call's points still inside stay, the room left goes to the smallest new indices, and the
/// list is the brute-force one whenever it fits, with or without walks from the previous
/// tets (the tool's tets are well shaped). Oracle: brute force plus its own selection.
#[test]
fn rigid_tool_coherent_capacity() {
    rigid_scene!(tool, obj, rest, nh, cells, Vec3::splat(-0.5));
    assert!(walks_exact(&Body::fixed(&tool)));
    let mut full = 0;
    for (cap, max_walk) in [0usize, 1, 2, 3, 5, 8, 125]
        .into_iter()
        .flat_map(|c| [(c, 0u32), (c, 8)])
    {
        let mut out = [Collision::default(); 125];
        let mut prev = [false; 125];
        let mut kept = 0;
        for i in 0..120 {
            let rot = Quat::from_rotation_z(0.03 * i as f32) * Quat::from_rotation_x(0.4);
            let pos = Vec3::new(-0.9 + 0.015 * i as f32, 0.05 - 0.002 * i as f32, -0.2);
            let pose = glam::Affine3A::from_rotation_translation(rot, pos);
            let moved: [Vec3; 27] =
                core::array::from_fn(|k| pose.transform_point3(tool.positions()[k]));
            let tb = Body::moved(&tool, &moved, rot);
            let mut all = [Collision::default(); 125];
            let n_all = brute_list(&tb, obj.positions(), &mut all);
            let r = rigid_tets_over_points_coherent(
                &nh,
                obj.positions(),
                &rest,
                &tb,
                pose,
                &rest.near(pose, &cells),
                &mut out[..cap],
                kept,
                max_walk,
            );
            // Oracle selection: previous points still inside, then the smallest new ones.
            let mut want = [false; 125];
            let mut n = 0;
            for c in &all[..n_all] {
                if prev[c.node.idx()] {
                    want[c.node.idx()] = true;
                    n += 1;
                }
            }
            for c in &all[..n_all] {
                if !want[c.node.idx()] && n < cap {
                    want[c.node.idx()] = true;
                    n += 1;
                }
            }
            let ctx = (cap, max_walk, i);
            assert_eq!(r.count, n, "{ctx:?}");
            assert_eq!(r.saturated, n_all > cap, "{ctx:?}");
            let mut got = [false; 125];
            for (k, c) in out[..r.count].iter().enumerate() {
                assert!(k == 0 || out[k - 1].node < c.node, "{ctx:?}: sorted");
                assert!(
                    all[..n_all].contains(c),
                    "{ctx:?}: {c:?} with its smallest tet"
                );
                got[c.node.idx()] = true;
            }
            assert_eq!(got, want, "{ctx:?}");
            full += r.saturated as u32;
            (prev, kept) = (got, r.count);
        }
    }
    assert!(full > 100, "the output filled {full} times");
}

/// `Occupancy`: every point that brute force puts inside a tet is in a set cell, and every
/// box around such a point meets one; far points and boxes are culled; a grid too big for its
/// storage coarsens and stays conservative; the tet boxes hold their tets' inside points.
/// `points_in_tets_occupied` gives the brute-force lists.
#[test]
fn occupancy_is_conservative_and_culls() {
    let mut obj_store = Store::<125, 384>::block(4, 0.25, Vec3::splat(-0.5));
    let obj = obj_store.mesh();
    let ob = Body::fixed(&obj);
    let empty = crate::hash::Aabb::of::<0>([]);
    let (mut th_s, mut th_e) = ([0u32; 64], [HashEntry::default(); 4096]);
    let mut th = SpatialHash::new(&mut th_s, &mut th_e, 0.25).unwrap();
    assert!(!hash_tets(&mut th, &ob).saturated);
    for words in [1usize, 8, 64] {
        let (mut w, mut bx) = ([0u32; 64], [empty; 384]);
        let cells = Occupancy::build(
            &ob,
            0.05,
            1e-4,
            OccupancyStorage {
                words: &mut w[..words],
                boxes: &mut bx,
            },
        )
        .unwrap();
        let d = cells.dims();
        assert!(
            (d[0] * d[1] * d[2]) as usize <= 32 * words,
            "coarsened to fit"
        );
        let mut rng = Rng(0xdead_beef_cafe_f00d ^ words as u64);
        let mut pts = [Vec3::ZERO; 64];
        let (mut inside, mut culled) = (0, 0);
        for round in 0..40 {
            for p in pts.iter_mut() {
                *p = Vec3::new(
                    rng.range(-0.9, 0.9),
                    rng.range(-0.9, 0.9),
                    rng.range(-0.9, 0.9),
                );
            }
            if round % 4 == 0 {
                // Exactly on the object's nodes and faces.
                for (k, p) in pts.iter_mut().enumerate().take(20) {
                    *p = obj.positions()[(k * 7 + round) % 125];
                }
            }
            let mut want = [Collision::default(); 64];
            let n = brute_list(&ob, &pts, &mut want);
            for c in &want[..n] {
                let p = pts[c.node.idx()];
                assert!(cells.may_hold(p), "{p:?} inside tet {:?}", c.tet);
                assert!(cells.tet_may_hold(c.tet, p));
                assert!(cells.may_meet(&crate::hash::Aabb::point(p)));
            }
            inside += n;
            culled += pts.iter().filter(|&&p| !cells.may_hold(p)).count();
            let mut out = [Collision::default(); 64];
            let r = points_in_tets_occupied(&th, &cells, &ob, &pts, false, &mut out, 0, |_| true);
            assert!(!r.saturated);
            assert_eq!(&out[..r.count], &want[..n], "words {words} round {round}");
        }
        assert!(
            inside > 500 && culled > 200,
            "inside {inside}, culled {culled}"
        );
        let far = crate::hash::Aabb::of([Vec3::splat(3.0), Vec3::splat(4.0)]);
        assert!(!cells.may_meet(&far) && !cells.may_hold(Vec3::splat(3.5)));
        assert!(!cells.may_hold(Vec3::splat(f32::NAN)));
    }
    // Bad storage and sizes are refused.
    let mut w = [0u32; 4];
    let err = |w: &mut [u32], cell: f32| {
        Occupancy::build(
            &ob,
            cell,
            0.0,
            OccupancyStorage {
                words: w,
                boxes: &mut [],
            },
        )
        .unwrap_err()
    };
    assert_eq!(err(&mut [], 0.1), OccupancyError::NoStorage);
    assert_eq!(err(&mut w, 0.0), OccupancyError::BadCellSize);
    assert_eq!(err(&mut w, f32::NAN), OccupancyError::BadCellSize);
}

/// `inside_tet` answers as `geom::inside(geom::barycentric(..))` on random tets and points,
/// near-flat and flat tets, points on corners and faces, NaN and infinite points, for
/// tolerances 0 and 0.1.
#[test]
fn inside_tet_answers_as_barycentric() {
    let mut rng = Rng(0x0bad_5eed_1234_5678);
    let mut seen = [0u32; 3]; // degenerate, inside, outside
    for i in 0..20_000 {
        let mut p: [Vec3; 4] = core::array::from_fn(|_| {
            Vec3::new(
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
            )
        });
        match i % 5 {
            0 => p[3] = (p[0] + p[1] + p[2]) / 3.0,  // flat
            1 => p[3] = p[2] + (p[2] - p[1]) * 1e-4, // nearly flat
            _ => {}
        }
        let w = [rng.next(), rng.next(), rng.next(), rng.next()];
        let s = w.iter().sum::<f32>();
        let mut x = match i % 7 {
            0 => p[i % 4],                   // a corner
            1 => (p[0] + p[1] + p[2]) / 3.0, // a face
            2 => Vec3::splat(f32::NAN),
            3 => Vec3::new(f32::INFINITY, 0.0, 0.0),
            _ => (p[0] * w[0] + p[1] * w[1] + p[2] * w[2] + p[3] * w[3]) / s * 1.3,
        };
        if i % 11 == 0 {
            x += Vec3::splat(1e-7);
        }
        for eps in [0.0, 0.1] {
            let want = crate::geom::barycentric(x, p).map(|b| crate::geom::inside(b, eps));
            assert_eq!(inside_tet(x, p, eps), want, "{x:?} in {p:?}, eps {eps}");
            seen[match want {
                None => 0,
                Some(true) => 1,
                Some(false) => 2,
            }] += 1;
        }
    }
    assert!(seen.iter().all(|&n| n > 500), "cases met: {seen:?}");
}

/// `walk_to_holder` from any tet either gives up or names a tet that holds the point by the
/// margin in every coordinate, which is then brute force's (smallest-id) tet; and
/// `points_in_tets_walked`, with any walk length and any start (neighbours' tets, last
/// call's tets), gives `points_in_tets_occupied`'s lists, bit for bit.
#[test]
fn walks_find_the_smallest_tet_or_give_up() {
    let mut obj_store = Store::<125, 384>::block(4, 0.25, Vec3::splat(-0.5));
    let obj = obj_store.mesh();
    let ob = Body::fixed(&obj);
    let (mut th_s, mut th_e) = ([0u32; 64], [HashEntry::default(); 4096]);
    let mut th = SpatialHash::new(&mut th_s, &mut th_e, 0.25).unwrap();
    assert!(!hash_tets(&mut th, &ob).saturated);
    let empty = crate::hash::Aabb::of::<0>([]);
    let (mut w, mut bx) = ([0u32; 64], [empty; 384]);
    let storage = OccupancyStorage {
        words: &mut w,
        boxes: &mut bx,
    };
    let cells = Occupancy::build(&ob, 0.05, 1e-4, storage).unwrap();
    let mut rng = Rng(0x0123_4567_89ab_cdef);
    let (mut found, mut gave_up) = (0, 0);
    for _ in 0..2000 {
        let p = Vec3::new(
            rng.range(-0.6, 0.6),
            rng.range(-0.6, 0.6),
            rng.range(-0.6, 0.6),
        );
        let from = TetId::from_idx((rng.next() * 384.0) as usize % 384);
        let mut tests = 0;
        let steps = 1 + (rng.next() * 12.0) as u32;
        let t = walk_to_holder(&ob, from, p, steps, &mut tests);
        assert!(tests >= 1 && tests <= steps);
        if t.is_none() {
            gave_up += 1;
            continue;
        }
        found += 1;
        let b = crate::geom::barycentric(p, ob.tet_positions(t).unwrap()).unwrap();
        assert!(b.iter().all(|&c| c >= WALK_MARGIN), "{p} in {t:?}: {b:?}");
        assert_eq!(Some(t), brute(&ob, &[p], false)[0], "{p}");
    }
    assert!(
        found > 300 && gave_up > 300,
        "found {found}, gave up {gave_up}"
    );
    // Points that are not finite are never found by a walk.
    for p in [
        Vec3::new(f32::NAN, 0.1, 0.1),
        Vec3::new(f32::INFINITY, 0.1, 0.1),
        Vec3::new(0.1, f32::NEG_INFINITY, f32::NAN),
    ] {
        for from in [0, 100, 383] {
            assert!(
                walk_to_holder(&ob, TetId::from_idx(from), p, 16, &mut 0).is_none(),
                "{p}"
            );
        }
    }

    // A cloud of points, each near the one before (a tool's nodes), moved a little per call.
    let mut pts = [Vec3::ZERO; 64];
    let mut near = [[NodeId::NONE; 2]; 64];
    for (i, nb) in near.iter_mut().enumerate() {
        *nb = [
            NodeId::from_idx(i.saturating_sub(1)),
            NodeId::from_idx((i + 7) % 64),
        ];
    }
    let (mut prev, mut kept) = ([Collision::default(); 64], 0usize);
    let mut walked = 0;
    for round in 0..60 {
        let mut x = Vec3::new(rng.range(-0.7, 0.7), rng.range(-0.7, 0.7), 0.0);
        for (k, p) in pts.iter_mut().enumerate() {
            x += Vec3::new(rng.range(-0.04, 0.04), rng.range(-0.04, 0.04), 0.02);
            *p = if round % 5 == 0 && k % 4 == 0 {
                obj.positions()[(k * 3 + round) % 125] // exactly on nodes and faces
            } else {
                x
            };
        }
        let mut want = [Collision::default(); 64];
        let r0 = points_in_tets_occupied(&th, &cells, &ob, &pts, false, &mut want, 0, |_| true);
        for max_steps in [0u32, 1, 3, 16] {
            let mut out = [Collision::default(); 64];
            // Last call's list as it was left, for the walks from last call's tets.
            out[..kept].copy_from_slice(&prev[..kept]);
            let mut f = [TetId::NONE; 64];
            let starts = WalkStarts {
                found: &mut f,
                near: |i: usize| &near[i][..],
                max_steps,
            };
            let r = points_in_tets_walked(&th, &cells, &ob, &pts, &mut out, kept, starts, |_| true);
            assert_eq!(
                &out[..r.count],
                &want[..r0.count],
                "round {round}, {max_steps}"
            );
            for c in &out[..r.count] {
                assert_eq!(f[c.node.idx()], c.tet, "found records the tet");
            }
            walked += (max_steps > 0 && r.candidates != r0.candidates) as u32;
        }
        prev = want;
        kept = r0.count;
    }
    assert!(
        walked > 100,
        "the walks changed the work in {walked} of 180 calls"
    );
}
