//! The zone memo of `World::simulate` (a small mesh's tets gathered near the burr over steps,
//! `core-nostd/src/servo/zone_memo.rs`) against two oracles along a wandering burr: the
//! spatial hash's one-shot query of the zone, and a brute force over every tet sorted by the
//! cell the query reports it in. The candidate list is the same tets in the same order on
//! every step, whether the memo served the step or the hash did, before and after the mesh
//! moves.

use std::cmp::Reverse;

use tetradrill_benches::Lcg;
use tetradrill_core::drill::DrillParams;
use tetradrill_core::hash::Aabb;
use tetradrill_core::servo::World;
use tetradrill_core::{TetId, Vec3};
use tetradrill_tests::search::{block_mesh, Store};

const R: f32 = 0.1;
const REACH: f32 = 0.05;

/// Every tet whose box meets `zone`, in the order of the hash's query: by the query's first
/// cell holding the tet (along each axis the larger of the zone's lowest cell and the tet
/// box's lowest cell; z, then y, then x), then by descending tet.
fn brute_force(w: &World<'_>, zone: &Aabb) -> Vec<TetId> {
    let mesh = w.mesh();
    let lo_q = w.hash().cell_of(zone.min);
    let mut v: Vec<(i32, i32, i32, Reverse<u32>)> = (0..mesh.tet_count())
        .map(TetId::from_idx)
        .filter_map(|t| {
            let b = Aabb::of(mesh.tet_positions(t));
            if !b.overlaps(zone) {
                return None;
            }
            let lo_t = w.hash().cell_of(b.min);
            let c = |a: usize| lo_q[a].max(lo_t[a]);
            Some((c(2), c(1), c(0), Reverse(t.0)))
        })
        .collect();
    v.sort_unstable();
    v.into_iter()
        .map(|(_, _, _, Reverse(t))| TetId(t))
        .collect()
}

/// The hash's one-shot query of `zone`, each tet once, those whose boxes meet it.
fn hash_query(w: &World<'_>, zone: &Aabb) -> Vec<TetId> {
    let mesh = w.mesh();
    let mut v = Vec::new();
    assert!(w.hash().query_box_once(zone, w.max_cells(), |item| {
        let t = TetId(item);
        if Aabb::of(mesh.tet_positions(t)).overlaps(zone) {
            v.push(t);
        }
    }));
    v
}

/// A seeded wander through the block: small steps (the memo's gathers keep up), now and
/// then a jump (the step queries the hash while the next list is gathered).
fn wander(n: usize, seed: u64) -> Vec<Vec3> {
    let mut rng = Lcg(seed);
    let mut next = || rng.signed();
    let mut p = Vec3::ZERO;
    let mut v = Vec::with_capacity(n);
    for i in 0..n {
        let jump = i % 700 == 350;
        let d = Vec3::new(next(), next(), next()) * if jump { 0.3 } else { 0.002 };
        p = (p + d).clamp(Vec3::splat(-0.6), Vec3::splat(0.6));
        v.push(p);
    }
    v
}

/// Runs the wander over the block of `n` cubes a side, drill off, checking every step's
/// candidate list against both oracles, and moving the mesh by `shift` halfway (the burr
/// moved with it when `follows`, so the zone meets the same tets, or left where it is, so it
/// meets others); returns how many steps the memo served.
fn check_block(n: usize, shift: Vec3, follows: bool) -> (usize, usize) {
    let mut om = block_mesh(n);
    let mesh = om.view();
    let mut rest = mesh.positions().to_vec();
    let mut st = Store::new(mesh.tet_count(), 1 << 14);
    let mut w = st.world(mesh);
    w.enable_deformation(&mut rest).unwrap();
    let params = DrillParams {
        max_depth: 3,
        min_area: 0.0,
        budget: 300,
    };
    let path = wander(2_800, 7 + n as u64);
    let (mut served, mut steps) = (0, 0);
    let mut offset = Vec3::ZERO;
    for (i, &p) in path.iter().enumerate() {
        if i == path.len() / 2 {
            let moved: Vec<Vec3> = w.mesh().positions().iter().map(|&q| q + shift).collect();
            w.set_positions(&moved).unwrap();
            if follows {
                offset = shift;
            }
        }
        let c = p + offset;
        let rep = w.simulate(c, R, REACH, false, &params);
        let zone = Aabb::point(c).grown(R + REACH);
        let expected = brute_force(&w, &zone);
        assert_eq!(
            hash_query(&w, &zone),
            expected,
            "step {i}: the oracles differ"
        );
        assert_eq!(
            w.candidates(),
            &expected[..],
            "step {i} (memo {})",
            rep.candidates_memo
        );
        served += rep.candidates_memo as usize;
        steps += 1;
    }
    (served, steps)
}

/// The firmware's block (384 tets) and a finer one (1,296 tets): every list is the
/// oracles'. The memo serves most of the block's steps (all but the first ones, those after
/// a jump and those after the mesh moved, while the next list is gathered) and a third of the
/// finer block's or more (its boxes half a radius wider than the zone hold about as many tets
/// as a list does: a gather that finds more is dropped).
#[test]
fn memo_lists_are_the_hash_querys() {
    for (n, tenths) in [(4, 8), (6, 3)] {
        let (served, steps) = check_block(n, Vec3::new(0.013, -0.021, 0.008), true);
        assert!(
            served * 10 > steps * tenths,
            "block {n}: the memo served {served} of {steps} steps"
        );
    }
}

/// The mesh moves under a burr that stays (a third of a cube of the block along x and y):
/// the zone now meets tets the memo's lists were not cut from, so the move must drop them.
#[test]
fn a_mesh_moved_under_the_burr_drops_the_memo() {
    let (served, steps) = check_block(4, Vec3::new(0.083, 0.083, 0.0), false);
    assert!(
        served * 10 > steps * 8,
        "the memo served {served} of {steps} steps"
    );
}

/// A mesh over the memo's size (the block of 8 cubes a side, 3,072 tets) is never served
/// from it, and its lists are the oracles' too.
#[test]
fn a_larger_mesh_queries_the_hash() {
    let (served, _) = check_block(8, Vec3::ZERO, true);
    assert_eq!(served, 0);
}
