//! Pen contact on real meshes, the collision lists: the spatial hash against brute force (every
//! point against every tet) at many random pen poses, the point-location queries alone (hash,
//! occupancy, walks) against brute force, full lists keeping the previous nodes then
//! the smallest ids, pen nodes walked along a path against brute force, reused crossings against
//! searched ones, and walks only over well-shaped tets.
//!
//! Meshes: the pen (`pen_tool_gmsh.mesh`, metres) scaled x10 so it is 1.15 units long with a
//! 0.04 radius, next to the cow (about 1.5 units) and the teddy.

use std::collections::HashSet;

use glam::{Quat, Vec3};
use tetradrill::pen::PenRig;
use tetradrill_core::collide::{
    points_in_tets, points_in_tets_occupied, points_in_tets_walked, walks_exact, Body, Collision,
    WalkStarts,
};
use tetradrill_core::force::{pen_contact, DepthMethod, PenOptions, PenState};
use tetradrill_core::ids::{NodeId, TetId};
use tetradrill_tests::contact::{facing, first_tick, poses, rig, COW, TEDDY};
use tetradrill_tests::load;
use tetradrill_tests::oracle::AsD;

/// The sliver-rich cow (tetgen without a quality bound).
const COARSE_COW: &str = "models/spot_tetgen_coarse.node";

/// Brute force: every point against every tet (box test, then barycentric), smallest tet id.
fn brute(body: &Body<'_, '_>, points: &[Vec3], within: Option<(Vec3, Vec3)>) -> Vec<Collision> {
    let boxes: Vec<(Vec3, Vec3)> = (0..body.tet_count())
        .map(|t| {
            let p = body.tet_positions(TetId::from_idx(t)).unwrap();
            (
                p.iter().fold(p[0], |a, &b| a.min(b)),
                p.iter().fold(p[0], |a, &b| a.max(b)),
            )
        })
        .collect();
    let mut out = Vec::new();
    for (i, &x) in points.iter().enumerate() {
        if let Some((lo, hi)) = within {
            if x.cmplt(lo).any() || x.cmpgt(hi).any() {
                continue;
            }
        }
        for (t, (lo, hi)) in boxes.iter().enumerate() {
            if x.cmplt(*lo).any() || x.cmpgt(*hi).any() {
                continue;
            }
            let p = body.tet_positions(TetId::from_idx(t)).unwrap();
            if let Some(b) = tetradrill_core::geom::barycentric(x, p) {
                if b.iter().all(|&c| c >= 0.0) {
                    out.push(Collision {
                        node: NodeId::from_idx(i),
                        tet: TetId::from_idx(t),
                    });
                    break;
                }
            }
        }
    }
    out
}

/// f64 barycentric containment with a tolerance (independent of the f32 kernel).
fn inside_f64(x: Vec3, p: [Vec3; 4], tol: f64) -> bool {
    let d = |a: Vec3, b: Vec3, c: Vec3, e: Vec3| {
        let a = a.to_dvec3();
        let (u, v, w) = (b.to_dvec3() - a, c.to_dvec3() - a, e.to_dvec3() - a);
        u.cross(v).dot(w)
    };
    let v = d(p[0], p[1], p[2], p[3]);
    let b = [
        d(x, p[1], p[2], p[3]),
        d(p[0], x, p[2], p[3]),
        d(p[0], p[1], x, p[3]),
        d(p[0], p[1], p[2], x),
    ];
    b.iter().all(|&c| c / v >= -tol)
}

fn check_hash_vs_brute(obj_rel: &str, n_poses: usize, seed: u64) {
    let mut rig = rig(10.0, obj_rel, 1.0);
    let ps = {
        let obj_view = rig.obj.view();
        poses(&obj_view, n_poses, 0.3, seed)
    };
    let (mut total_pen, mut total_obj) = (0usize, 0usize);
    rig.with(|scene, bufs| {
        for &(pos, rot) in &ps {
            let c = first_tick(scene, bufs, pos, rot);
            assert!(!c.saturated());
            let world = &bufs.world[..];
            let got: Vec<Collision> = bufs.pen_hits[..c.pen_collisions.count].to_vec();
            let want = brute(&scene.object, world, None);
            assert_eq!(got, want, "pen nodes in object differ at pose {pos:?}");
            for h in &got {
                let p = scene.object.tet_positions(h.tet).unwrap();
                assert!(inside_f64(world[h.node.idx()], p, 1e-5));
            }
            total_pen += got.len();
            let pen_body = Body::moved(scene.pen, world, rot);
            let lo = world.iter().fold(world[0], |a, &b| a.min(b));
            let hi = world.iter().fold(world[0], |a, &b| a.max(b));
            let got: Vec<Collision> = bufs.object_hits[..c.object_collisions.count].to_vec();
            let want = brute(&pen_body, scene.object.positions, Some((lo, hi)));
            assert_eq!(got, want, "object nodes in pen differ at pose {pos:?}");
            total_obj += got.len();
        }
    })
    .expect("pen scene");
    println!(
        "{obj_rel}: {n_poses} poses, {total_pen} pen-node and {total_obj} object-node contacts"
    );
    assert!(total_pen > n_poses, "poses must really touch");
    assert!(total_obj > 0);
}

#[test]
fn hash_matches_brute_force_cow() {
    check_hash_vs_brute(COW, 60, 1);
}

#[test]
fn hash_matches_brute_force_teddy() {
    check_hash_vs_brute(TEDDY, 12, 2);
}

/// The three point-location queries the contact bench sets against parry3d's BVH, each call
/// from scratch (no previous list): the hash alone (`points_in_tets`), culled by the
/// object's occupancy grid and tet boxes (`points_in_tets_occupied`), and walking from a
/// neighbouring pen node's tet first (`points_in_tets_walked`), at touching and impaled pen
/// poses: each gives brute force's list (every pen node inside with the smallest tet that
/// holds it). Oracle: brute force over every tet.
fn check_point_queries_vs_brute(obj_rel: &str, n_poses: usize, seed: u64) {
    let mut rig = rig(10.0, obj_rel, 1.0);
    let ps = {
        let obj_view = rig.obj.view();
        let mut ps = poses(&obj_view, n_poses, 0.05, seed);
        ps.extend(poses(&obj_view, n_poses, 0.3, seed + 1));
        ps
    };
    let pen_rest: Vec<Vec3> = rig.pen.view().positions().to_vec();
    let n = pen_rest.len();
    let mut inside = 0usize;
    rig.with(|scene, _| {
        assert!(scene.object_walks, "{obj_rel} passes walks_exact");
        let mut out = vec![Collision::default(); n];
        let mut found = vec![TetId::NONE; n];
        for &(pos, rot) in &ps {
            let pts: Vec<Vec3> = pen_rest.iter().map(|&x| rot * x + pos).collect();
            let want = brute(&scene.object, &pts, None);
            let r = points_in_tets(scene.object_tets, &scene.object, &pts, false, &mut out);
            assert_eq!(&out[..r.count], &want[..], "hash alone at {pos}");
            let r = points_in_tets_occupied(
                scene.object_tets,
                scene.object_cells,
                &scene.object,
                &pts,
                false,
                &mut out,
                0,
                |_| true,
            );
            assert_eq!(&out[..r.count], &want[..], "occupied at {pos}");
            let starts = WalkStarts {
                found: &mut found,
                near: |i| scene.pen_graph.neighbours(NodeId::from_idx(i)),
                max_steps: PenOptions::default().max_walk,
            };
            let r = points_in_tets_walked(
                scene.object_tets,
                scene.object_cells,
                &scene.object,
                &pts,
                &mut out,
                0,
                starts,
                |_| true,
            );
            assert_eq!(&out[..r.count], &want[..], "walked at {pos}");
            inside += want.len();
        }
    })
    .expect("pen scene");
    println!("{obj_rel}: {} poses, {inside} pen nodes inside", ps.len());
    assert!(inside > 10 * ps.len(), "poses must go in: {inside}");
}

#[test]
fn point_queries_match_brute_force_cow() {
    check_point_queries_vs_brute(COW, 15, 3);
}

#[test]
fn point_queries_match_brute_force_teddy() {
    check_point_queries_vs_brute(TEDDY, 6, 4);
}

/// Both collision lists with room for only a few nodes, along a path that drives the pen
/// (tilted, turning) into the cow, each tick's lists left for the next: every list is
/// sorted, names each node with the smallest tet that brute force finds for it, holds last
/// tick's nodes that are still inside, then the smallest new node ids up to its capacity,
/// and is the whole brute-force set whenever that fits. Oracle: brute force over every tet
/// in world coordinates and its own selection.
#[test]
fn full_lists_keep_previous_nodes_then_smallest_ids_cow() {
    let mut rig = rig(10.0, COW, 1.0);
    let cap = 6;
    let sizes = tetradrill::pen::PenSizes {
        contacts: Some(cap),
        ..Default::default()
    };
    let (start, normal) = facing(&mut rig, Vec3::Z);
    let (mut full, mut fitted) = ([0u32; 2], [0u32; 2]);
    rig.with_sizes(sizes, |scene, bufs| {
        let mut state = PenState::default();
        let (mut prev_pen, mut prev_obj) = (HashSet::new(), HashSet::new());
        for i in 0..60 {
            let tilt = Quat::from_rotation_x(0.5 + 0.008 * i as f32);
            let rot = Quat::from_rotation_arc(Vec3::Z, normal)
                * Quat::from_rotation_z(0.1 * i as f32)
                * tilt;
            let pos = start - normal * (0.006 * i as f32);
            let c = pen_contact(scene, bufs, pos, rot, &PenOptions::default(), &mut state);
            let world = &bufs.world[..];
            let pen_body = Body::moved(scene.pen, world, rot);
            // Object nodes near the pen only (the pen's box, grown well beyond rounding).
            let lo = world.iter().fold(world[0], |a, &b| a.min(b)) - Vec3::splat(1e-3);
            let hi = world.iter().fold(world[0], |a, &b| a.max(b)) + Vec3::splat(1e-3);
            let sides = [
                (
                    bufs.pen_hits[..c.pen_collisions.count].to_vec(),
                    brute(&scene.object, world, None),
                    c.pen_collisions.saturated,
                    &mut prev_pen,
                ),
                (
                    bufs.object_hits[..c.object_collisions.count].to_vec(),
                    brute(&pen_body, scene.object.positions, Some((lo, hi))),
                    c.object_collisions.saturated,
                    &mut prev_obj,
                ),
            ];
            for (side, (got, all, saturated, prev)) in sides.into_iter().enumerate() {
                let ctx = (i, side);
                assert!(
                    got.windows(2).all(|w| w[0].node < w[1].node),
                    "{ctx:?}: sorted"
                );
                for g in &got {
                    assert!(all.contains(g), "{ctx:?}: {g:?} not brute force's");
                }
                let mut want: Vec<NodeId> = all
                    .iter()
                    .map(|c| c.node)
                    .filter(|n| prev.contains(n))
                    .collect();
                for c in &all {
                    if want.len() < cap && !prev.contains(&c.node) {
                        want.push(c.node);
                    }
                }
                want.sort();
                let nodes: Vec<NodeId> = got.iter().map(|c| c.node).collect();
                assert_eq!(nodes, want, "{ctx:?}");
                assert_eq!(saturated, all.len() > cap, "{ctx:?}");
                full[side] += saturated as u32;
                fitted[side] += (!saturated && !all.is_empty()) as u32;
                *prev = nodes.into_iter().collect();
            }
        }
    })
    .expect("pen scene");
    println!("full lists (pen, object): {full:?}; complete non-empty lists: {fitted:?}");
    assert!(
        full[0] > 10 && full[1] > 10,
        "both lists must fill: {full:?}"
    );
    assert!(
        fitted[0] > 0 && fitted[1] > 0,
        "and fit sometimes: {fitted:?}"
    );
}

/// Pen nodes found by walking from last tick's tets and from their neighbours' tets
/// (`PenOptions::max_walk`) along a path that drives the pen, turning, into the cow: every
/// tick's list is brute force's (each node with the smallest tet that holds it), and the
/// forces are bit-identical to those of the same path looked up in the hash alone
/// (`max_walk` 0).
#[test]
fn walked_pen_nodes_match_brute_force_along_a_path_cow() {
    let mut rig = rig(10.0, COW, 1.0);
    let (start, normal) = facing(&mut rig, Vec3::X);
    let path: Vec<(Vec3, Quat)> = (0..50)
        .map(|i| {
            let rot = Quat::from_rotation_arc(Vec3::Z, normal)
                * Quat::from_rotation_z(0.07 * i as f32)
                * Quat::from_rotation_x(0.3 + 0.01 * i as f32);
            (start - normal * (0.004 * i as f32), rot)
        })
        .collect();
    let run = |rig: &mut PenRig, max_walk: u32, check: bool| {
        let opts = PenOptions {
            max_walk,
            ..PenOptions::default()
        };
        rig.with(|scene, bufs| {
            let mut state = PenState::default();
            let mut ticks = Vec::new();
            for &(pos, rot) in &path {
                let c = pen_contact(scene, bufs, pos, rot, &opts, &mut state);
                assert!(!c.saturated());
                let got = bufs.pen_hits[..c.pen_collisions.count].to_vec();
                if check {
                    assert_eq!(got, brute(&scene.object, bufs.world, None), "at {pos}");
                }
                ticks.push((
                    got,
                    c.force.to_array().map(f32::to_bits),
                    c.pen_collisions.candidates,
                ));
            }
            ticks
        })
        .expect("pen scene")
    };
    let walked = run(&mut rig, PenOptions::default().max_walk, true);
    let hashed = run(&mut rig, 0, false);
    let (mut inside, mut saved) = (0, 0);
    for (k, (w, h)) in walked.iter().zip(&hashed).enumerate() {
        assert_eq!((&w.0, w.1), (&h.0, h.1), "tick {k}");
        inside += w.0.len();
        saved += h.2.saturating_sub(w.2);
    }
    println!(
        "{inside} pen-node contacts over {} ticks; {saved} candidate tests saved",
        path.len()
    );
    assert!(inside > 500, "the path must go deep: {inside}");
    assert!(
        saved as usize > inside,
        "walks replace most look-ups: {saved} saved"
    );
}

/// Border edges reusing last tick's crossing face (`PenOptions::reuse_crossings`) along a
/// path that drives the pen, turning, into the cow, 0.8 mm of the cow's scale a tick: most
/// border edges skip the search, every tick's depths are the searched ones' but where the
/// cow's surface folds between a border point and its old face, and those few stay within
/// 1 % of the force. The traced and hashed searches find the same first faces, so with reuse
/// they still agree bit for bit.
#[test]
fn reused_crossings_follow_the_searched_ones_into_the_cow() {
    let mut rig = rig(10.0, COW, 1.0);
    let (start, normal) = facing(&mut rig, Vec3::Y);
    let path: Vec<(Vec3, Quat)> = (0..300)
        .map(|i| {
            let t = i as f32;
            let rot = Quat::from_rotation_arc(Vec3::Z, normal)
                * Quat::from_rotation_z(0.004 * t)
                * Quat::from_rotation_x(0.2 + 0.001 * t);
            (start - normal * (0.0008 * t), rot)
        })
        .collect();
    let run = |rig: &mut PenRig, reuse_crossings: bool, method: DepthMethod| {
        let opts = PenOptions {
            reuse_crossings,
            method,
            ..PenOptions::default()
        };
        rig.with(|scene, bufs| {
            let mut state = PenState::default();
            let (mut ticks, mut border, mut reused) = (Vec::new(), 0, 0);
            for &(pos, rot) in &path {
                let c = pen_contact(scene, bufs, pos, rot, &opts, &mut state);
                assert!(!c.saturated() && !c.hashed_unavailable);
                border += c.pen_depth.border_edges + c.object_depth.border_edges;
                reused += c.pen_depth.reused + c.object_depth.reused;
                ticks.push((c.raw, c.penetrations));
            }
            (ticks, border, reused)
        })
        .expect("pen scene")
    };
    let (search, border, none) = run(&mut rig, false, DepthMethod::Traced);
    let (traced, t_border, reused) = run(&mut rig, true, DepthMethod::Traced);
    let (hashed, _, h_reused) = run(&mut rig, true, DepthMethod::Hashed);
    assert_eq!((none, t_border), (0, border));
    // The hashed search may name the other face beside an edge the line crosses exactly
    // (the same crossing, bit for bit): it then reuses a face the traced walk did not.
    assert!(
        h_reused.abs_diff(reused) * 100 <= reused,
        "{h_reused} vs {reused}"
    );
    let (mut differ, mut worst) = (0, 0.0f32);
    for (k, ((s, t), h)) in search.iter().zip(&traced).zip(&hashed).enumerate() {
        assert_eq!(
            t.0.to_array().map(f32::to_bits),
            h.0.to_array().map(f32::to_bits)
        );
        assert_eq!(s.1, t.1, "tick {k}: the same nodes get depths");
        let err = (s.0 - t.0).length() / s.0.length().max(1.0);
        differ += (s.0 != t.0) as usize;
        worst = worst.max(err);
    }
    println!(
        "{reused} of {border} border edges reused; {differ} of {} ticks differ, worst {worst:e}",
        path.len()
    );
    assert!(border > 10_000, "the path must go deep: {border}");
    assert!(
        reused * 10 > border * 8,
        "most edges reuse: {reused} of {border}"
    );
    assert!(worst < 0.01, "forces within 1 %: {worst}");
}

/// Walks are trusted only on well-shaped tets (`collide::walks_exact`): the quality meshes
/// pass, the sliver-rich coarse cow fails (some points there are inside two tets by the f32
/// test, and a walk could name the larger-id one), and on it the pen's lists stay brute
/// force's because the rig turns walks off.
#[test]
fn walks_only_over_well_shaped_tets() {
    for (rel, exact) in [(COW, true), (TEDDY, true), (COARSE_COW, false)] {
        let mut obj = load(rel, 1.0);
        let view = obj.view();
        assert_eq!(walks_exact(&Body::fixed(&view)), exact, "{rel}");
    }
    let mut rig = rig(10.0, COARSE_COW, 1.0);
    let ps = {
        let obj_view = rig.obj.view();
        poses(&obj_view, 24, 0.3, 5)
    };
    let mut inside = 0;
    rig.with(|scene, bufs| {
        assert!(!scene.object_walks, "walks off over slivers");
        let mut state = PenState::default();
        for &(pos, rot) in &ps {
            let c = pen_contact(scene, bufs, pos, rot, &PenOptions::default(), &mut state);
            let got = bufs.pen_hits[..c.pen_collisions.count].to_vec();
            assert_eq!(got, brute(&scene.object, bufs.world, None), "at {pos}");
            inside += got.len();
        }
    })
    .expect("pen scene");
    assert!(inside > 100, "the poses must touch: {inside}");
}

/// `PenBuffers::forget` (what a session's reset calls): after a path into the cow the buffers
/// remember crossings (the next pass at the last pose reuses them) and found tets; forgotten,
/// the pass there reuses nothing, starts its walks afresh, and is the first pass of freshly
/// carved buffers bit for bit.
#[test]
fn forgotten_buffers_give_the_first_pass_of_fresh_ones() {
    let mut rig = rig(10.0, COW, 1.0);
    let (start, normal) = facing(&mut rig, Vec3::Y);
    let rot = Quat::from_rotation_arc(Vec3::Z, normal) * Quat::from_rotation_x(0.2);
    let at = |i: usize| start - normal * (0.0008 * i as f32);
    let opts = PenOptions {
        reuse_crossings: true,
        ..PenOptions::default()
    };
    let (carried, forgotten) = rig
        .with(|scene, bufs| {
            let mut state = PenState::default();
            for i in 0..120 {
                pen_contact(scene, bufs, at(i), rot, &opts, &mut state);
            }
            assert!(bufs.pen_found.iter().any(|&t| t != TetId::NONE));
            let carried = pen_contact(scene, bufs, at(120), rot, &opts, &mut PenState::default());
            bufs.forget();
            assert!(bufs.pen_found.iter().all(|&t| t == TetId::NONE));
            let forgotten = pen_contact(scene, bufs, at(120), rot, &opts, &mut PenState::default());
            (carried, forgotten)
        })
        .expect("pen scene");
    let fresh = rig
        .with(|scene, bufs| pen_contact(scene, bufs, at(120), rot, &opts, &mut PenState::default()))
        .expect("pen scene");
    assert!(fresh.pen_depth.border_edges + fresh.object_depth.border_edges > 0);
    assert!(carried.pen_depth.reused + carried.object_depth.reused > 0);
    assert_eq!(
        forgotten.pen_depth.reused + forgotten.object_depth.reused,
        0
    );
    let bits = |c: &tetradrill_core::force::PenContact| {
        (c.raw.to_array().map(f32::to_bits), c.penetrations)
    };
    assert_eq!(bits(&forgotten), bits(&fresh));
}
