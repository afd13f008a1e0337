//! The rigid tool's tets over the object's points against brute force, and its coherent lists
//! at every capacity.

use glam::{Quat, Vec3};

use super::test_support::{brute_list, Rng, Store};
use super::*;
use crate::collide::{OccupancyStorage, RigidTetsStorage};
use crate::hash::{HashEntry, SpatialHash};

/// The tool block and the object block with their static structures, for the rigid tests:
/// `$rest` the tool's rest data, `$nh` the object's node hash, `$cells` its occupancy.
macro_rules! rigid_scene {
    ($tool:ident, $obj:ident, $rest:ident, $nh:ident, $cells:ident, $obj_origin:expr) => {
        let mut tool_store = Store::<27, 48>::block(2, 0.25, Vec3::new(-0.25, -0.25, 0.0));
        let $tool = tool_store.mesh();
        let mut obj_store = Store::<125, 384>::block(4, 0.25, $obj_origin);
        let $obj = obj_store.mesh();
        let (mut rs, mut re) = ([0u32; 128], [0u32; 4096]);
        let empty = crate::hash::Aabb::of::<0>([]);
        let (mut rb, mut rc, mut nc) = ([empty; 48], [empty; 64], [0u32; 27]);
        let $rest = RigidTets::build(
            &Body::fixed(&$tool),
            RigidTetsStorage {
                grid_starts: &mut rs,
                grid_tets: &mut re,
                tet_boxes: &mut rb,
                clusters: &mut rc,
                node_clusters: &mut nc,
            },
            0.1,
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

/// `moved_bounds` holds every moved node at random poses near the origin (so the pen pass may
/// skip the nodes' own box) and refuses poses past the margin and scaled ones.
#[test]
fn moved_bounds_hold_every_moved_node() {
    rigid_scene!(tool, obj, rest, nh, cells, Vec3::splat(-0.5));
    let _ = (&obj, &nh, &cells);
    let mut rng = Rng(0x0bad_cafe_f00d_1234);
    for _ in 0..500 {
        let t = Vec3::new(
            rng.range(-3.0, 3.0),
            rng.range(-3.0, 3.0),
            rng.range(-3.0, 3.0),
        );
        let pose = glam::Affine3A::from_rotation_translation(rng.rotation(), t);
        let b = rest.moved_bounds(&pose).expect("a pose near the origin");
        for &p in tool.positions() {
            assert!(b.contains(pose.transform_point3(p)), "{p:?} at {pose:?}");
        }
        // Not much larger than the moved nodes' own box (the rest box turned).
        let own = tool
            .positions()
            .iter()
            .fold(crate::hash::Aabb::of::<0>([]), |a, &p| {
                a.union(crate::hash::Aabb::point(pose.transform_point3(p)))
            });
        assert!((b.max - b.min).max_element() <= 2.0 * (own.max - own.min).max_element());
    }
    let far = glam::Affine3A::from_translation(Vec3::splat(1e6));
    assert!(rest.moved_bounds(&far).is_none());
    let scaled = glam::Affine3A::from_rotation_translation(rng.rotation() * 1.1, Vec3::ZERO);
    assert!(rest.moved_bounds(&scaled).is_none());
}
