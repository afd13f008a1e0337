//! Point location by walking: `inside_tet` against `geom::barycentric`, and walks giving brute
//! force's smallest tet or giving up.

use glam::Vec3;

use super::points::WALK_MARGIN;
use super::test_support::{brute, Rng, Store};
use super::*;
use crate::collide::OccupancyStorage;
use crate::hash::{HashEntry, SpatialHash};
use crate::ids::{NodeId, TetId};

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
