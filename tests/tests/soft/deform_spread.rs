//! The world's position update spread over calls (`World::set_spare`,
//! `World::prepare_positions`, `World::commit_positions`) against the whole update
//! (`World::set_positions`, the same pieces on the live storage in one call), so that the
//! slicing and the swap of the spare storage change nothing: while a preparation runs the
//! world still answers on the old positions; once committed, the two worlds hold the same
//! positions, normals, boundary marks and hash (the same answers, in the same order, and the
//! brute-force answer over boxes computed here), and `simulate` gives the same bits on a
//! drilling path, move after move, through a move that overflows the hash. The update itself
//! is checked against oracles in `deform_world` (the hash and the normals by brute force).

use std::collections::BTreeSet;

use glam::Vec3;
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use tetradrill_core::drill::DrillParams;
use tetradrill_core::hash::{Aabb, HashEntry, REBUILD_ITEM_UNITS};
use tetradrill_core::servo::{DeformError, MovePart, SpareStorage, World, WorldSizes};
use tetradrill_tests::brute::{overlaps, tet_boxes};
use tetradrill_tests::search::{block_mesh, Store};

/// A smooth, non-affine deformation of the unit block at phase `s`, stretched by `grow`.
fn bend(p: Vec3, s: f32, grow: f32) -> Vec3 {
    let a = 0.15 * s.sin();
    let x = p.x + 0.5;
    Vec3::new(
        p.x + 0.05 * s.cos() * (3.0 * p.y).sin(),
        p.y + 0.5 * a * (3.0 * p.z).sin(),
        p.z + a * x * x,
    ) * grow
}

/// The hash's answer for a box around `c`: items in the order met, and the brute-force set
/// over the mesh's own boxes (only when the hash is not saturated: a full table leaves tets
/// out).
fn answer(world: &World<'_>, c: Vec3, r: f32) -> (Vec<u32>, BTreeSet<u32>) {
    let own = tet_boxes(world.mesh());
    let qb = (c - Vec3::splat(r), c + Vec3::splat(r));
    let mut met = Vec::new();
    assert!(world
        .hash()
        .query_box_once(&Aabb::point(c).grown(r), u32::MAX, |item| met.push(item)));
    let found: BTreeSet<u32> = met
        .iter()
        .copied()
        .filter(|&t| overlaps(own[t as usize], qb))
        .collect();
    let brute: BTreeSet<u32> = (0..own.len() as u32)
        .filter(|&t| overlaps(own[t as usize], qb))
        .collect();
    (met, if found == brute { brute } else { found })
}

fn bits(v: &[Vec3]) -> Vec<u32> {
    v.iter()
        .flat_map(|x| x.to_array().map(f32::to_bits))
        .collect()
}

/// Spare storage of a world's sizes over `nodes` nodes (`World::set_spare`).
struct Spare {
    starts: Vec<u32>,
    entries: Vec<HashEntry>,
    boxes: Vec<Aabb>,
    normals: Vec<Vec3>,
}

impl Spare {
    fn new(sizes: &WorldSizes, nodes: usize) -> Self {
        Self {
            starts: vec![0; sizes.hash_starts],
            entries: vec![HashEntry::default(); sizes.hash_entries],
            boxes: vec![Aabb::point(Vec3::ZERO); sizes.tet_boxes],
            normals: vec![Vec3::ZERO; nodes],
        }
    }

    fn storage(&mut self) -> SpareStorage<'_> {
        SpareStorage {
            hash_starts: &mut self.starts,
            hash_entries: &mut self.entries,
            tet_boxes: &mut self.boxes,
            normals: &mut self.normals,
        }
    }
}

#[test]
fn a_spread_update_commits_the_world_set_positions_makes() {
    let mut om_a = block_mesh(5);
    let mut om_b = block_mesh(5);
    let rest0 = om_a.positions().to_vec();
    let n = rest0.len();
    let (mesh_a, mesh_b) = (om_a.view(), om_b.view());
    let tets = mesh_a.tet_count();
    let mut st_a = Store::new(tets, 1 << 15);
    let mut st_b = Store::new(tets, 1 << 15);
    let sizes = WorldSizes::new(tets, 0);
    let mut spare = Spare::new(&sizes, n);
    let mut a = st_a.world(mesh_a);
    let mut b = st_b.world(mesh_b);
    let (mut rest_a, mut rest_b) = (vec![Vec3::ZERO; n], vec![Vec3::ZERO; n]);
    a.enable_deformation(&mut rest_a).unwrap();
    b.enable_deformation(&mut rest_b).unwrap();
    // Refusals first: no spare, a short spare.
    assert_eq!(b.prepare_positions(&rest0, 100), Err(DeformError::NoSpare));
    assert_eq!(b.commit_positions(&rest0), Err(DeformError::NoSpare));
    let mut short = Spare::new(&sizes, n - 1);
    assert_eq!(
        b.set_spare(short.storage()),
        Err(DeformError::SpareSize("normals"))
    );
    b.set_spare(spare.storage()).unwrap();
    assert_eq!(b.commit_positions(&rest0), Err(DeformError::NotPrepared));
    let whole = b.prepare_units().unwrap();
    let params = DrillParams {
        max_depth: 3,
        min_area: 0.0,
        budget: 2_000,
    };
    let mut rng = StdRng::seed_from_u64(5);
    let (mut compared, mut saturated, mut drilled) = (0usize, 0u32, 0u32);
    for k in 0..14 {
        let s = k as f32 * 0.45;
        // Move 9 stretches the block so far that its hash overflows.
        let grow = if k == 9 { 3.0 } else { 1.0 };
        let new: Vec<Vec3> = rest0.iter().map(|&p| bend(p, s, grow)).collect();
        let old = b.mesh().positions().to_vec();
        let probe = Vec3::new(0.1, -0.2, 0.3);
        let before = answer(&b, probe, 0.2);
        let rep_a = a.set_positions(&new).unwrap();
        let (mut units, mut calls) = (0u64, 0);
        loop {
            let w = rng.gen_range(REBUILD_ITEM_UNITS..=[REBUILD_ITEM_UNITS, 50, 400, 5000][k % 4]);
            let p = b.prepare_positions(&new, w).unwrap();
            assert!(p.units <= w);
            units += u64::from(p.units);
            calls += 1;
            if p.ready {
                break;
            }
            // Still the old world.
            if calls % 7 == 0 {
                assert_eq!(bits(b.mesh().positions()), bits(&old));
                assert_eq!(answer(&b, probe, 0.2), before, "move {k}");
            }
        }
        assert!(b.preparing());
        let rep_b = b.commit_positions(&new).unwrap();
        // The whole count; less when the hash fills up (the later tets are not hashed).
        if rep_b.hash_saturated {
            assert!(units < whole, "move {k}");
        } else {
            assert_eq!(units, whole, "move {k}");
        }
        assert!(!b.preparing());
        assert_eq!(rep_a, rep_b, "move {k}");
        saturated += u32::from(rep_b.hash_saturated);
        assert_eq!(bits(a.mesh().positions()), bits(b.mesh().positions()));
        assert_eq!(
            bits(a.mesh().normals()),
            bits(b.mesh().normals()),
            "move {k}"
        );
        for i in 0..n {
            let id = tetradrill_core::NodeId::from_idx(i);
            assert_eq!(a.mesh().node(id).boundary(), b.mesh().node(id).boundary());
        }
        assert_eq!(a.hash().len(), b.hash().len());
        assert_eq!(a.hash().stats(), b.hash().stats());
        assert_eq!(a.saturations(), b.saturations());
        for q in 0..20 {
            let c = Vec3::new(
                rng.gen_range(-0.6..0.6),
                rng.gen_range(-0.6..0.6),
                rng.gen_range(-0.6..0.6),
            ) * grow;
            let r = rng.gen_range(0.02..0.25);
            let (ha, sa) = answer(&a, c, r);
            let (hb, sb) = answer(&b, c, r);
            assert_eq!(ha, hb, "move {k} query {q}");
            assert_eq!(sa, sb);
            compared += sa.len();
        }
        // A drilling stroke over the top between moves: the same bits from both worlds.
        for i in 0..40 {
            let t = (k * 40 + i) as f32 * 0.01;
            let centre = Vec3::new(
                0.3 * t.sin(),
                0.25 * (1.3 * t).cos(),
                0.52 - 0.002 * i as f32,
            );
            let ra = a.simulate(centre, 0.1, 0.05, true, &params);
            let rb = b.simulate(centre, 0.1, 0.05, true, &params);
            assert_eq!(ra, rb, "move {k} tick {i}");
            assert_eq!(a.contact(), b.contact(), "move {k} tick {i}");
            assert_eq!(a.candidates(), b.candidates());
            drilled += ra.drill.erased;
        }
        assert_eq!(
            a.hierarchy().removed_volume().to_bits(),
            b.hierarchy().removed_volume().to_bits()
        );
    }
    assert_eq!(saturated, 1, "the stretched move overflows the hash");
    assert!(compared > 500, "{compared} hits compared");
    assert!(drilled > 0, "the path drills");
    // A non-finite position is refused and the next preparation starts afresh.
    let mut bad = rest0.clone();
    bad[7].x = f32::NAN;
    assert!(b.prepare_positions(&rest0, u32::MAX).unwrap().ready);
    b.commit_positions(&rest0).unwrap();
    assert!(matches!(
        b.prepare_positions(&bad[1..], 30),
        Err(DeformError::Count { .. })
    ));
    assert_eq!(
        b.prepare_positions(&bad, u32::MAX),
        Err(DeformError::NotFinite { node: 7 })
    );
    assert!(!b.preparing());
}

/// Every item of the hash, cell after cell over a box around everything, in the order met
/// (the order within each cell's bucket included).
fn every_entry(world: &World<'_>, grow: f32) -> Vec<u32> {
    let mut met = Vec::new();
    let all = Aabb::point(Vec3::ZERO).grown(1.5 * grow);
    assert!(world
        .hash()
        .query_box_once(&all, u32::MAX, |item| met.push(item)));
    met
}

/// A world with spare storage moves its hash in place (`SpatialHash::update`: only the tets
/// whose cells changed), one without builds it whole: after every move the two hold the same
/// table (every cell's items in the same order, the same length and counters but the update
/// count) and answer the drill with the same bits; through small moves (the update), large
/// ones, and a stretch that overflows the hash (the whole build, then the update again).
#[test]
fn a_hash_moved_in_place_is_the_hash_built_whole() {
    two_worlds(|a, c, params, moves| {
        // Small steps of the bend, a jump every 10th move, a stretch that overflows at 25.
        let mut saturated = 0;
        for k in 0..60 {
            let (grow, new) = (moves[k].0, &moves[k].1);
            let rep_a = a.set_positions(new).unwrap();
            // World `c` also takes some moves spread over calls (its spare is then its
            // preparation's, not the update's scratch): moves 3, 10, 17, ... whole, and a
            // preparation for move k + 1 begun before move k (5, 12, ...) and ended after it.
            let rep_c = match k % 7 {
                3 => {
                    while !c.prepare_positions(new, 500).unwrap().ready {}
                    c.commit_positions(new).unwrap()
                }
                5 => {
                    c.prepare_positions(&moves[k + 1].1, 500).unwrap();
                    assert!(c.preparing());
                    c.set_positions(new).unwrap()
                }
                6 => {
                    while !c.prepare_positions(new, 500).unwrap().ready {}
                    c.commit_positions(new).unwrap()
                }
                _ => c.set_positions(new).unwrap(),
            };
            assert_eq!(rep_a, rep_c, "move {k}");
            saturated += u32::from(rep_c.hash_saturated);
            same_table(a, c, k, grow);
            assert_eq!(a.saturations(), c.saturations());
            for i in 0..10 {
                let t = (k * 10 + i) as f32 * 0.03;
                let centre = Vec3::new(0.3 * t.sin(), 0.25 * (1.3 * t).cos(), 0.5);
                let ra = a.simulate(centre, 0.1, 0.05, true, params);
                let rc = c.simulate(centre, 0.1, 0.05, true, params);
                assert_eq!(ra, rc, "move {k} tick {i}");
                assert_eq!(a.candidates(), c.candidates());
            }
        }
        assert_eq!(saturated, 1, "the stretched move overflows the hash");
        assert_eq!(a.hash().stats().updates, 0);
        // Every `set_positions` but those during a preparation (8) and the stretch (25; the
        // move after it is one of the 8): 60 less 17 spread, 8 and 1, less the jumps whose
        // changes overflow the scratch (moves 9, 29, 39 and 49 move most tets by cells).
        let updates = c.hash().stats().updates;
        assert!((30..=34).contains(&updates), "{updates} updates in place");
    });
}

/// The update in two parts (`World::set_positions_two`: each part checks its half of the
/// nodes, makes its half of the boxes and lists its half's hash changes, then each moves its
/// half of the hash table, on two threads here) leaves the world `World::set_positions`
/// leaves, bit for bit: the same report, table
/// (every cell's items in order), normals, boxes' answers and drill answers, move after move;
/// through jumps and a stretch whose changes do not fit (the whole build), moves while a
/// spread preparation holds the spare (the update in one part), parts run in either order or
/// one left to the world, and a refused position (nothing changed).
#[test]
fn an_update_in_two_parts_is_the_update_in_one() {
    two_worlds(|a, c, params, moves| {
        let mut threads = |x: &mut MovePart<'_>, y: &mut MovePart<'_>| {
            std::thread::scope(|s| {
                s.spawn(|| y.run());
                x.run();
            })
        };
        let (mut forks, mut saturated, mut halved) = (0u32, 0, 0);
        for k in 0..60 {
            let (grow, new) = (moves[k].0, &moves[k].1);
            let rep_a = a.set_positions(new).unwrap();
            let (mut calls, before) = (0u32, c.hash().stats().updates);
            let rep_c = match k % 6 {
                // A preparation of the next move holds the spare: this one runs in one part,
                // no fork; the next move is that preparation committed.
                4 => {
                    c.prepare_positions(&moves[k + 1].1, 500).unwrap();
                    assert!(c.preparing());
                    c.set_positions_two(new, &mut |_, _| calls += 1).unwrap()
                }
                5 => {
                    while !c.prepare_positions(new, 500).unwrap().ready {}
                    c.commit_positions(new).unwrap()
                }
                // The second part first, on this thread.
                1 => c
                    .set_positions_two(new, &mut |x, y| {
                        calls += 1;
                        y.run();
                        x.run();
                    })
                    .unwrap(),
                // The second part left for the world to run.
                3 => c
                    .set_positions_two(new, &mut |x, _| {
                        calls += 1;
                        x.run();
                    })
                    .unwrap(),
                _ => c
                    .set_positions_two(new, &mut |x, y| {
                        calls += 1;
                        threads(x, y)
                    })
                    .unwrap(),
            };
            // A fork for the lists, and one for the table's move whenever the hash is moved
            // in place: this world's spare entries always hold the two parts' buffers, so the
            // move is never left to one part here.
            let in_place = c.hash().stats().updates > before;
            let want = u32::from(k % 6 < 4) * (1 + u32::from(in_place));
            assert_eq!(calls, want, "move {k}");
            forks += calls;
            halved += u32::from(k % 6 < 4 && in_place);
            assert_eq!(rep_a, rep_c, "move {k}");
            saturated += u32::from(rep_c.hash_saturated);
            same_table(a, c, k, grow);
            assert_eq!(
                bits(a.mesh().normals()),
                bits(c.mesh().normals()),
                "move {k}"
            );
            assert_eq!(a.saturations(), c.saturations());
            for i in 0..10 {
                let t = (k * 10 + i) as f32 * 0.03;
                let centre = Vec3::new(0.3 * t.sin(), 0.25 * (1.3 * t).cos(), 0.5);
                let (q, r) = (answer(a, centre, 0.2), answer(c, centre, 0.2));
                assert_eq!(q, r, "move {k} tick {i}");
                let ra = a.simulate(centre, 0.1, 0.05, true, params);
                let rc = c.simulate(centre, 0.1, 0.05, true, params);
                assert_eq!(ra, rc, "move {k} tick {i}");
                assert_eq!(a.candidates(), c.candidates());
            }
        }
        assert_eq!(forks, 40 + halved);
        assert!(halved >= 20, "{halved} table moves in two parts");
        assert_eq!(saturated, 1, "the stretched move overflows the hash");
        // The parts moved the table in place on most moves, not by whole builds (the jumps'
        // changes do not fit the scratch, the stretch's not the table).
        let updates = c.hash().stats().updates;
        assert!((30..=40).contains(&updates), "{updates} updates in place");
        // A non-finite position in the second half is refused, the first one named.
        let mut bad = moves[60].1.clone();
        let n = bad.len();
        bad[n - 3].y = f32::INFINITY;
        bad[n - 9].z = f32::NAN;
        let before = every_entry(c, 1.0);
        let normals = bits(c.mesh().normals());
        let pos = bits(c.mesh().positions());
        assert_eq!(
            c.set_positions_two(&bad, &mut threads),
            Err(DeformError::NotFinite { node: n - 9 })
        );
        assert_eq!(
            a.set_positions(&bad),
            Err(DeformError::NotFinite { node: n - 9 })
        );
        assert!(matches!(
            c.set_positions_two(&bad[1..], &mut threads),
            Err(DeformError::Count { .. })
        ));
        assert_eq!(every_entry(c, 1.0), before);
        assert_eq!(bits(c.mesh().normals()), normals);
        assert_eq!(bits(c.mesh().positions()), pos);
        // And the next good move is the one-part update's again.
        let new = &moves[60].1;
        assert_eq!(
            a.set_positions(new).unwrap(),
            c.set_positions_two(new, &mut threads).unwrap()
        );
        assert_eq!(every_entry(a, 1.0), every_entry(c, 1.0));
    });
}

/// Two worlds over the unit block of 5 cubes a side, deformation enabled: `a` without spare
/// storage (its hash built whole at every move), `c` with it; the drill's parameters of the
/// comparisons, and the moves: small steps of the bend, a jump every 10th move, a stretch
/// that overflows the hash at 25 (each with its stretch factor).
#[allow(clippy::type_complexity)]
fn two_worlds(f: impl FnOnce(&mut World<'_>, &mut World<'_>, &DrillParams, &[(f32, Vec<Vec3>)])) {
    let mut om_a = block_mesh(5);
    let mut om_c = block_mesh(5);
    let rest0 = om_a.positions().to_vec();
    let n = rest0.len();
    let (mesh_a, mesh_c) = (om_a.view(), om_c.view());
    let tets = mesh_a.tet_count();
    let mut st_a = Store::new(tets, 1 << 15);
    let mut st_c = Store::new(tets, 1 << 15);
    let sizes = WorldSizes::new(tets, 0);
    let mut spare = Spare::new(&sizes, n);
    let mut a = st_a.world(mesh_a);
    let mut c = st_c.world(mesh_c);
    let (mut rest_a, mut rest_c) = (vec![Vec3::ZERO; n], vec![Vec3::ZERO; n]);
    a.enable_deformation(&mut rest_a).unwrap();
    c.enable_deformation(&mut rest_c).unwrap();
    c.set_spare(spare.storage()).unwrap();
    let params = DrillParams {
        max_depth: 3,
        min_area: 0.0,
        budget: 2_000,
    };
    let mut s = 0.0f32;
    let moves: Vec<(f32, Vec<Vec3>)> = (0..61)
        .map(|k| {
            s += if k % 10 == 9 { 0.9 } else { 0.015 };
            let grow = if k == 25 { 3.0 } else { 1.0 };
            (grow, rest0.iter().map(|&p| bend(p, s, grow)).collect())
        })
        .collect();
    f(&mut a, &mut c, &params, &moves);
}

/// After move `k` (stretched by `grow`) the two worlds' tables are the same: length, build
/// and saturation counters, every cell's items in order.
fn same_table(a: &World<'_>, c: &World<'_>, k: usize, grow: f32) {
    let (ha, hc) = (a.hash(), c.hash());
    assert_eq!(ha.len(), hc.len(), "move {k}");
    let (sa, sc) = (ha.stats(), hc.stats());
    assert_eq!(
        (sa.builds, sa.saturations, sa.clipped_queries),
        (sc.builds, sc.saturations, sc.clipped_queries),
        "move {k}"
    );
    assert_eq!(every_entry(a, grow), every_entry(c, grow), "move {k}");
}
