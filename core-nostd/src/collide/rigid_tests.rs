//! The rigid tool's tets over the object's points against brute force, and its coherent lists
//! at every capacity.

use glam::{Quat, Vec3};

use super::test_support::{box_probes, brute_list, nudged_corners, Rng, Store};
use super::*;
use crate::collide::{ListedNode, OccupancyStorage, RigidTetsStorage};
use crate::hash::{HashEntry, SpatialHash};

/// The tool block and the object block with their static structures, for the rigid tests:
/// `$rest` the tool's rest data, `$nh` the object's node hash, `$cells` its occupancy and
/// `$listed` the same occupancy listing the object's nodes per cell.
macro_rules! rigid_scene {
    ($tool:ident, $obj:ident, $rest:ident, $nh:ident, $cells:ident, $listed:ident, $obj_origin:expr) => {
        let mut tool_store = Store::<27, 48>::block(2, 0.25, Vec3::new(-0.25, -0.25, 0.0));
        let $tool = tool_store.mesh();
        let mut obj_store = Store::<125, 384>::block(4, 0.25, $obj_origin);
        let $obj = obj_store.mesh();
        let (mut rs, mut re) = ([0u32; 128], [GridEntry::default(); 4096]);
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
        let (mut lw, mut lbx) = ([0u32; 8], [empty; 384]);
        let (mut lns, mut lnn) = ([0u32; 256], [ListedNode::default(); 125]);
        let $listed = Occupancy::build(
            &Body::fixed(&$obj),
            0.1,
            1e-4,
            OccupancyStorage {
                words: &mut lw,
                boxes: &mut lbx,
            },
        )
        .unwrap()
        .with_node_lists(&Body::fixed(&$obj), &mut lns, &mut lnn)
        .unwrap();
    };
}

/// `rigid_tets_over_points_coherent` against brute force over all moved tool tets: identical
/// lists at random poses (tilted, partly in, impaled through the object), at axis-aligned
/// poses whose object nodes sit exactly on the tool's corners and faces, and at poses so far
/// from the origin, or scaled by a quaternion off unit length, that it falls back to the plain
/// walk; and the tool nodes in the object tets, culled by the clusters near the object. The
/// object's nodes come from its hash, or from its occupancy's node lists.
#[test]
fn rigid_tool_matches_brute_force() {
    for far in [false, true] {
        let origin = if far {
            Vec3::splat(2000.0)
        } else {
            Vec3::splat(-0.5)
        };
        rigid_scene!(tool, obj, rest, nh, cells, listed, origin);
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
            for use_cells in [0, 1, 2] {
                // Room for every (point, tet) pair: the fallback walk lists pairs before it
                // keeps each point's smallest tet.
                let mut out = [Collision::default(); 1024];
                let near = match use_cells {
                    0 => NearClusters::ALL,
                    1 => rest.near(pose, &cells),
                    _ => rest.near(pose, &listed),
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
    rigid_scene!(tool, obj, rest, nh, cells, listed, Vec3::splat(-0.5));
    assert!(walks_exact(&Body::fixed(&tool)));
    let mut full = 0;
    for (cap, max_walk, cells) in [0usize, 1, 2, 3, 5, 8, 40, 125]
        .into_iter()
        .flat_map(|c| [(c, 0u32), (c, 8)])
        .flat_map(|(c, w)| [(c, w, &cells), (c, w, &listed)])
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
                &rest.near(pose, cells),
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
            let ctx = (cap, max_walk, cells.listed_nodes(), i);
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
    assert!(full > 200, "the output filled {full} times");
}

/// `moved_bounds` holds every moved node at random poses near the origin (so the pen pass may
/// skip the nodes' own box) and refuses poses past the margin and scaled ones.
#[test]
fn moved_bounds_hold_every_moved_node() {
    rigid_scene!(tool, obj, rest, nh, cells, listed, Vec3::splat(-0.5));
    let _ = (&obj, &nh, &cells, &listed);
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

/// The rest grid's entries are conservative: at every point of every tet's grown box (its
/// corners, its face centres, points on its faces, random inside points, and the rest grid's
/// cell corners inside it with their neighbouring floats), the tet is among the entries of
/// the point's cell that admit the point, for grids whose cells are much smaller than a tet
/// (a box over many cells), about its size, and larger than the tool (one cell). The admitted
/// entries come in increasing id order, and the levels rule out a share of the cell's
/// entries. Oracle: each tet's box recomputed from its corners, tested with `contains`.
#[test]
fn grid_entries_admit_every_point_of_their_box() {
    let mut tool_store = Store::<27, 48>::block(2, 0.25, Vec3::new(-0.25, -0.25, 0.0));
    let tool = tool_store.mesh();
    let tb = Body::fixed(&tool);
    let empty = crate::hash::Aabb::of::<0>([]);
    let mut rng = Rng(0x5eed_0f1e_5e15_a11e);
    for (edge, margin) in [(0.03f32, 1e-4f32), (0.1, 1e-4), (0.13, 0.02), (2.0, 1e-4)] {
        let (mut rs, mut re) = ([0u32; 8192], [GridEntry::default(); 65536]);
        let (mut rb, mut rc, mut nc) = ([empty; 48], [empty; 64], [0u32; 27]);
        let (cells, entries) = RigidTets::grid_sizes(&tb, edge, margin, &mut rb).unwrap();
        assert!(
            cells <= rs.len() && entries <= re.len(),
            "{cells} {entries}"
        );
        let rest = RigidTets::build(
            &tb,
            RigidTetsStorage {
                grid_starts: &mut rs[..cells],
                grid_tets: &mut re[..entries],
                tet_boxes: &mut rb,
                clusters: &mut rc,
                node_clusters: &mut nc,
            },
            edge,
            0.08,
            margin,
        )
        .unwrap();
        let (origin, inv, dims) = rest.rest_grid();
        if edge < 0.05 {
            assert!(entries > 48 * 27, "tets over many cells: {entries} entries");
        }
        if edge > 1.0 {
            assert_eq!(dims, [1, 1, 1]);
        }
        let (mut listed, mut admitted) = (0usize, 0usize);
        let mut check = |t: usize, q: Vec3| {
            let mut ids = [TetId::NONE; 48];
            let mut n = 0;
            let len = rest.admitted(q, |id| {
                ids[n] = id;
                n += 1;
            });
            assert!(
                ids[..n].contains(&TetId::from_idx(t)),
                "edge {edge}: tet {t} not admitted at {q:?}"
            );
            assert!(ids[..n].windows(2).all(|w| w[0] < w[1]), "in id order");
            listed += len;
            admitted += n;
        };
        for t in 0..tool.tet_count() {
            let b =
                crate::hash::Aabb::of(tb.tet_positions(TetId::from_idx(t)).unwrap()).grown(margin);
            box_probes(&b, &mut rng, 8, 16, |q| check(t, q));
            // The cell corners inside the box, and the floats on either side of them.
            let lo = ((b.min - origin) * inv).floor();
            let hi = ((b.max - origin) * inv).ceil();
            nudged_corners(
                &b,
                [lo.x as i32, lo.y as i32, lo.z as i32],
                [
                    (hi.x as i32).min(dims[0]),
                    (hi.y as i32).min(dims[1]),
                    (hi.z as i32).min(dims[2]),
                ],
                |i, j, k| origin + Vec3::new(i as f32, j as f32, k as f32) / inv,
                |q| check(t, q),
            );
        }
        assert!(
            edge > 1.0 || admitted * 10 < listed * 9,
            "edge {edge}: the levels rule out little: {admitted} of {listed}"
        );
    }
}

/// Many points inside at once (hundreds of object nodes in the tool, more than a batch of
/// lookups holds), some exactly on the tool's corners and faces: the lists from the object's
/// node hash and from its occupancy's node lists (small cells, and cells whose rows hold more
/// than 64 nodes) are the brute-force ones, and a short output keeps the smallest nodes.
/// Oracle: brute force over every tool tet.
#[test]
fn rigid_batches_match_brute_force() {
    let mut tool_store = Store::<27, 48>::block(2, 0.25, Vec3::new(-0.25, -0.25, 0.0));
    let tool = tool_store.mesh();
    let mut obj_store = Store::<729, 3072>::block(8, 0.0625, Vec3::new(-0.25, -0.25, 0.0));
    let obj = obj_store.mesh();
    let ob = Body::fixed(&obj);
    let empty = crate::hash::Aabb::of::<0>([]);
    let (mut rs, mut re) = ([0u32; 128], [GridEntry::default(); 4096]);
    let (mut rb, mut rc, mut nc) = ([empty; 48], [empty; 64], [0u32; 27]);
    let rest = RigidTets::build(
        &Body::fixed(&tool),
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
    let (mut ns, mut ne) = ([0u32; 1024], [HashEntry::default(); 729]);
    let mut nh = SpatialHash::new(&mut ns, &mut ne, 0.0625).unwrap();
    assert!(!nh.rebuild_points(obj.positions()).saturated);
    let (mut ow, mut obx) = ([0u32; 64], [empty; 3072]);
    let cells = Occupancy::build(
        &ob,
        0.0625,
        1e-4,
        OccupancyStorage {
            words: &mut ow,
            boxes: &mut obx,
        },
    )
    .unwrap();
    let (n_starts, n_nodes) = cells.node_list_sizes(729);
    let (mut lns, mut lnn) = ([0u32; 1024], [ListedNode::default(); 729]);
    let listed = cells
        .with_node_lists(&ob, &mut lns[..n_starts], &mut lnn[..n_nodes])
        .unwrap();
    // Cells of 0.3: rows of about 180 nodes (more than one mask of 64 each).
    let (mut cw, mut cbx) = ([0u32; 64], [empty; 3072]);
    let (mut cns, mut cnn) = ([0u32; 64], [ListedNode::default(); 729]);
    let coarse = Occupancy::build(
        &ob,
        0.3,
        1e-4,
        OccupancyStorage {
            words: &mut cw,
            boxes: &mut cbx,
        },
    )
    .unwrap()
    .with_node_lists(&ob, &mut cns, &mut cnn)
    .unwrap();
    assert!(coarse.dims().iter().all(|&d| d <= 3));
    let mut rng = Rng(0xba7c_4e5b_a7c4_e5b1);
    let mut most = 0;
    for i in 0..60 {
        let (pos, rot) = match i % 3 {
            // On the lattice: nodes on the tool's corners and faces.
            0 => (Vec3::ZERO, Quat::IDENTITY),
            1 => (
                Vec3::new(
                    (rng.range(-2.0, 2.0) as i32) as f32 * 0.0625,
                    (rng.range(-2.0, 2.0) as i32) as f32 * 0.0625,
                    (rng.range(-2.0, 2.0) as i32) as f32 * 0.0625,
                ),
                Quat::IDENTITY,
            ),
            _ => (
                Vec3::new(
                    rng.range(-0.1, 0.1),
                    rng.range(-0.1, 0.1),
                    rng.range(-0.1, 0.1),
                ),
                Quat::from_axis_angle(
                    Vec3::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), 1.0).normalize(),
                    rng.range(-0.5, 0.5),
                ),
            ),
        };
        let pose = glam::Affine3A::from_rotation_translation(rot, pos);
        let moved: [Vec3; 27] =
            core::array::from_fn(|k| pose.transform_point3(tool.positions()[k]));
        let tb = Body::moved(&tool, &moved, rot);
        let mut want = [Collision::default(); 729];
        let n_want = brute_list(&tb, obj.positions(), &mut want);
        most = most.max(n_want);
        for (near, cap) in [
            (NearClusters::ALL, 729),
            (rest.near(pose, &listed), 729),
            (rest.near(pose, &coarse), 729),
            (NearClusters::ALL, 50),
            (rest.near(pose, &listed), 50),
            (rest.near(pose, &coarse), 50),
        ] {
            let mut out = [Collision::default(); 729];
            let r = rigid_tets_over_points_coherent(
                &nh,
                obj.positions(),
                &rest,
                &tb,
                pose,
                &near,
                &mut out[..cap],
                0,
                0,
            );
            let n = n_want.min(cap);
            let ctx = (i, cap, near.is_near(0));
            assert_eq!(r.saturated, n_want > cap, "{ctx:?}");
            assert_eq!(&out[..r.count], &want[..n], "{ctx:?}");
        }
    }
    assert!(most > 200, "at most {most} points inside at one pose");
}
