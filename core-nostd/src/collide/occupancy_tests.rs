//! `Occupancy`: conservative against brute force, and culling far points and boxes.

use glam::Vec3;

use super::test_support::{box_probes, brute_list, nudged_corners, Rng, Store};
use super::*;
use crate::collide::{GridEntry, ListedNode, OccupancyError, OccupancyStorage};
use crate::hash::{HashEntry, SpatialHash};

/// `Occupancy`: every point that brute force puts inside a tet is in a set cell, and every
/// box around such a point meets one; far points and boxes are culled; a grid too big for its
/// storage coarsens and stays conservative; the tet boxes hold their tets' inside points.
/// `points_in_tets_occupied` gives the brute-force lists, with and without the grid's tet lists
/// (each ascending and holding every tet whose grown box holds the point).
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
        let split = match words {
            1 => 2,
            8 => 3,
            _ => 1,
        };
        assert_eq!(cells.tet_list_sizes(0), None);
        let (n_starts, n_tets) = cells.tet_list_sizes(split).unwrap();
        let (mut ls, mut lt) = ([0u32; 8192], [GridEntry::default(); 65536]);
        assert!(
            n_starts <= ls.len() && n_tets <= lt.len(),
            "{n_starts} {n_tets}"
        );
        assert_eq!(
            cells
                .with_tet_lists(&ob, split, &mut ls[..n_starts - 1], &mut lt)
                .unwrap_err(),
            OccupancyError::ListStorage
        );
        assert_eq!(
            cells
                .with_tet_lists(&ob, split, &mut ls, &mut lt[..n_tets - 1])
                .unwrap_err(),
            OccupancyError::ListStorage
        );
        assert!(cells.tets_at(Vec3::ZERO).is_none(), "no lists yet");
        let listed = cells.with_tet_lists(&ob, split, &mut ls, &mut lt).unwrap();
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
            // The cell lists: ascending, holding every tet whose grown box (computed here)
            // holds the point; the query over them gives the brute-force lists too.
            for &p in &pts {
                let list = listed.tets_at(p).unwrap();
                let ids = list.entries;
                assert!(ids.windows(2).all(|w| w[0].tet() < w[1].tet()), "{ids:?}");
                for t in 0..ob.tet_count() {
                    let tb = crate::hash::Aabb::of(ob.tet_positions(TetId::from_idx(t)).unwrap())
                        .grown(1e-4);
                    if tb.contains(p) {
                        let e = ids.iter().find(|e| e.tet().idx() == t);
                        assert!(e.is_some_and(|e| list.admits(e)), "tet {t} at {p:?}");
                    }
                }
            }
            let mut out = [Collision::default(); 64];
            let r = points_in_tets_occupied(&th, &listed, &ob, &pts, false, &mut out, 0, |_| true);
            assert_eq!(
                &out[..r.count],
                &want[..n],
                "lists, words {words} round {round}"
            );
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

/// A point's cell in a grid of up to `i32::MAX` cells a side is its coordinate's floor when
/// the coordinate is in `[0, cells as f32)`, else none, and that floor is below the cell
/// count (checked in i64): also where the count is not a float (beyond 2^24) and `cells as
/// f32` rounds up or down, for the floats on both sides of the count.
#[test]
fn cells_of_huge_grids_stay_below_the_count() {
    let up = |x: f32| f32::from_bits(x.to_bits() + 1);
    let down = |x: f32| f32::from_bits(x.to_bits() - 1);
    let mut checked = 0;
    for d in [
        1,
        7,
        (1 << 24) - 1,
        1 << 24,
        (1 << 24) + 1,
        (1 << 24) + 3,
        (1 << 25) + 1,
        (1 << 25) + 3,
        (1 << 30) + 7,
        (1 << 30) + 64,
        i32::MAX - 64,
        i32::MAX,
    ] {
        let r = d as f32;
        let near = [r, up(r), down(r), down(down(r)), up(up(r))];
        let far = [0.0f32, -0.0, -1e-30, 0.5, f32::NAN, f32::INFINITY];
        for x in near.into_iter().chain(far) {
            let want = (x >= 0.0 && x < d as f32).then(|| [x.floor() as i32, 0, 0]);
            let got = super::occupancy::cell(Vec3::ZERO, 1.0, [d, 1, 1], Vec3::new(x, 0.0, 0.0));
            assert_eq!(got, want, "{x} in {d} cells");
            if let Some(c) = got {
                assert!(
                    (x.floor() as i64) < d as i64 && c[0] < d,
                    "{x} in {d} cells"
                );
            }
            checked += 1;
        }
    }
    assert!(checked > 100);
}

/// The node lists: every node inside a box is in exactly one of the runs `nodes_in` hands
/// out (and none is handed out twice), with its own position, for random boxes, boxes from
/// node to node exactly, single nodes, boxes partly or wholly outside the grid, over grids
/// that coarsened to fit their words, with nodes that are in no tet and lie outside the grid
/// (and one that is not finite); too many cells and missing lists visit nothing; short
/// storage is refused. Oracle: every node tested against the box.
#[test]
fn node_lists_hand_out_every_node_in_a_box_once() {
    let mut obj_store = Store::<125, 384>::block(4, 0.25, Vec3::splat(-0.5));
    let obj = obj_store.mesh();
    // The mesh's nodes, then nodes of no tet: outside the grid, and not finite.
    let mut pos = [Vec3::ZERO; 129];
    pos[..125].copy_from_slice(obj.positions());
    pos[125] = Vec3::new(3.0, 0.1, 0.1);
    pos[126] = Vec3::new(-0.2, -2.0, 0.3);
    pos[127] = Vec3::splat(f32::NAN);
    pos[128] = Vec3::new(0.6, 0.6, -0.7);
    let ob = Body::moved(&obj, &pos, glam::Quat::IDENTITY);
    let empty = crate::hash::Aabb::of::<0>([]);
    let mut rng = Rng(0x0dd_ba11_5ca1_ab1e);
    for (words, cell) in [(64usize, 0.1f32), (8, 0.1), (64, 0.3)] {
        let (mut w, mut bx) = ([0u32; 64], [empty; 384]);
        let cells = Occupancy::build(
            &ob,
            cell,
            1e-4,
            OccupancyStorage {
                words: &mut w[..words],
                boxes: &mut bx,
            },
        )
        .unwrap();
        assert_eq!(cells.listed_nodes(), None);
        assert!(!cells.nodes_in(&crate::hash::Aabb::point(Vec3::ZERO), 4096, |_| {}));
        let d = cells.dims();
        let (n_starts, n_nodes) = cells.node_list_sizes(pos.len());
        assert_eq!(
            (n_starts, n_nodes),
            ((d[0] * d[1] * d[2]) as usize + 2, 129)
        );
        let (mut ns, mut nn) = ([0u32; 4096], [ListedNode::default(); 129]);
        assert_eq!(
            cells
                .with_node_lists(&ob, &mut ns[..n_starts - 1], &mut nn)
                .unwrap_err(),
            OccupancyError::ListStorage
        );
        assert_eq!(
            cells
                .with_node_lists(&ob, &mut ns, &mut nn[..128])
                .unwrap_err(),
            OccupancyError::ListStorage
        );
        let listed = cells.with_node_lists(&ob, &mut ns, &mut nn).unwrap();
        assert_eq!(listed.listed_nodes(), Some(129));
        let (mut met, mut visits) = (0usize, 0usize);
        for round in 0..400 {
            let b = match round % 4 {
                // From node to node exactly.
                0 => crate::hash::Aabb::of([
                    pos[rng.range(0.0, 125.0) as usize],
                    pos[rng.range(0.0, 125.0) as usize],
                ]),
                // One node.
                1 => crate::hash::Aabb::point(pos[rng.range(0.0, 129.0) as usize]),
                // Anywhere, partly or wholly outside the grid.
                _ => {
                    let c = Vec3::new(
                        rng.range(-1.5, 3.5),
                        rng.range(-2.5, 1.5),
                        rng.range(-1.5, 1.5),
                    );
                    let h = Vec3::new(
                        rng.range(0.0, 0.6),
                        rng.range(0.0, 0.6),
                        rng.range(0.0, 0.6),
                    );
                    crate::hash::Aabb {
                        min: c - h,
                        max: c + h,
                    }
                }
            };
            let mut seen = [0u32; 129];
            assert!(listed.nodes_in(&b, 4096, |run| {
                for e in run {
                    assert_eq!(
                        e.pos.to_array().map(f32::to_bits),
                        pos[e.node as usize].to_array().map(f32::to_bits)
                    );
                    seen[e.node as usize] += 1;
                    visits += 1;
                }
            }));
            for (n, &p) in pos.iter().enumerate() {
                assert!(seen[n] <= 1, "node {n} handed out {} times", seen[n]);
                if b.contains(p) {
                    assert_eq!(seen[n], 1, "node {n} at {p:?} missed by {b:?}");
                    met += 1;
                }
            }
        }
        assert!(met > 1000, "{met} nodes met");
        // The runs are cells' nodes, not the whole grid's.
        assert!(visits < 400 * 40, "{visits} nodes handed out");
        let wide = crate::hash::Aabb::of([Vec3::splat(-0.6), Vec3::splat(0.6)]);
        assert!(!listed.nodes_in(&wide, 3, |_| panic!("too many cells")));
    }
}

/// The tet lists' compact entries ([`GridEntry`]): every tet whose grown box holds a point is
/// in the point's cell's list with an entry that admits it, for points on the boxes' corners
/// and faces, inside them, at the list cells' corners and the floats on either side of them,
/// over lists whose cells are much smaller than a tet (a box over many cells), about its
/// size, and larger than the body (one cell); the lists stay in increasing id order, the
/// levels rule out a share of the entries, and the lookups over them
/// (`points_in_tets_occupied`) give the brute-force lists, in order with the same tets.
/// Oracles: each tet's box recomputed from its corners, tested with `contains`; brute force
/// over every tet.
#[test]
fn tet_list_entries_admit_every_point_of_their_box() {
    let mut obj_store = Store::<27, 48>::block(2, 0.25, Vec3::new(-0.23, -0.27, 0.01));
    let obj = obj_store.mesh();
    let ob = Body::fixed(&obj);
    let empty = crate::hash::Aabb::of::<0>([]);
    let (mut th_s, mut th_e) = ([0u32; 64], [HashEntry::default(); 4096]);
    let mut th = SpatialHash::new(&mut th_s, &mut th_e, 0.25).unwrap();
    assert!(!hash_tets(&mut th, &ob).saturated);
    let mut rng = Rng(0x0cc0_1157_e57a_b1e5);
    for (cell, split, margin) in [
        (0.06f32, 2u32, 1e-4f32),
        (0.1, 1, 1e-4),
        (0.13, 2, 0.02),
        (0.3, 1, 1e-4),
        (2.0, 1, 1e-4),
    ] {
        let (mut w, mut bx) = ([0u32; 64], [empty; 48]);
        let cells = Occupancy::build(
            &ob,
            cell,
            margin,
            OccupancyStorage {
                words: &mut w,
                boxes: &mut bx,
            },
        )
        .unwrap();
        let (n_starts, n_tets) = cells.tet_list_sizes(split).unwrap();
        let (mut ls, mut lt) = ([0u32; 8192], [GridEntry::default(); 65536]);
        assert!(
            n_starts <= ls.len() && n_tets <= lt.len(),
            "{n_starts} {n_tets}"
        );
        let listed = cells
            .with_tet_lists(&ob, split, &mut ls[..n_starts], &mut lt[..n_tets])
            .unwrap();
        // The list grid, recomputed: from the union of the grown boxes, cells of the
        // occupancy's edge over `split`.
        let grown = |t: usize| {
            crate::hash::Aabb::of(ob.tet_positions(TetId::from_idx(t)).unwrap()).grown(margin)
        };
        let origin = (0..ob.tet_count())
            .fold(empty, |b, t| b.union(grown(t)))
            .min;
        let edge = listed.cell_size() / split as f32;
        let dims = listed.dims().map(|d| (d * split) as i32);
        if cell < 0.1 {
            assert!(n_tets > 48 * 27, "tets over many cells: {n_tets} entries");
        }
        if cell > 1.0 {
            assert_eq!(dims, [1, 1, 1]);
        }
        let (mut seen, mut admitted) = (0usize, 0usize);
        let mut pts = [Vec3::ZERO; 64];
        let mut n_pts = 0usize;
        let flush = |pts: &[Vec3]| {
            let mut want = [Collision::default(); 64];
            let n = brute_list(&ob, pts, &mut want);
            let mut out = [Collision::default(); 64];
            let r = points_in_tets_occupied(&th, &listed, &ob, pts, false, &mut out, 0, |_| true);
            assert_eq!(&out[..r.count], &want[..n], "cell {cell} split {split}");
        };
        let mut check = |q: Vec3| {
            let list = listed.tets_at(q).unwrap();
            let ids = list.entries;
            assert!(ids.windows(2).all(|w| w[0].tet() < w[1].tet()), "{ids:?}");
            for t in 0..ob.tet_count() {
                if grown(t).contains(q) {
                    let e = ids.iter().find(|e| e.tet().idx() == t);
                    assert!(
                        e.is_some_and(|e| list.admits(e)),
                        "cell {cell} split {split}: tet {t} not admitted at {q:?}"
                    );
                }
            }
            seen += ids.len();
            admitted += ids.iter().filter(|e| list.admits(e)).count();
            pts[n_pts] = q;
            n_pts += 1;
            if n_pts == pts.len() {
                flush(&pts);
                n_pts = 0;
            }
        };
        for t in 0..ob.tet_count() {
            let b = grown(t);
            box_probes(&b, &mut rng, 4, 8, &mut check);
            // The list cells' corners inside the box, and the floats on either side of them.
            let lo = ((b.min - origin) / edge).floor();
            let hi = ((b.max - origin) / edge).ceil();
            nudged_corners(
                &b,
                [lo.x as i32, lo.y as i32, lo.z as i32],
                [
                    (hi.x as i32).min(dims[0]),
                    (hi.y as i32).min(dims[1]),
                    (hi.z as i32).min(dims[2]),
                ],
                |i, j, k| origin + Vec3::new(i as f32, j as f32, k as f32) * edge,
                &mut check,
            );
        }
        flush(&pts[..n_pts]);
        assert!(
            cell > 1.0 || admitted * 10 < seen * 9,
            "cell {cell}: the levels rule out little: {admitted} of {seen}"
        );
    }
}

/// `Occupancy::list_sizes` gives, before any storage, the lists' sizes of the grid `build`
/// then makes with that many words (coarsened or not): the tet lists take exactly that
/// storage (one entry less is refused) and the node lists that many starts.
#[test]
fn list_sizes_come_before_the_storage() {
    let mut obj_store = Store::<125, 384>::block(4, 0.25, Vec3::splat(-0.5));
    let obj = obj_store.mesh();
    let ob = Body::fixed(&obj);
    let empty = crate::hash::Aabb::of::<0>([]);
    for words in [1usize, 8, 64] {
        for split in [1u32, 2, 3] {
            let (starts, tets, node_starts) =
                Occupancy::list_sizes(&ob, 0.05, 1e-4, words, split).unwrap();
            let (mut w, mut bx) = ([0u32; 64], [empty; 384]);
            let storage = OccupancyStorage {
                words: &mut w[..words],
                boxes: &mut bx,
            };
            let cells = Occupancy::build(&ob, 0.05, 1e-4, storage).unwrap();
            assert_eq!(cells.tet_list_sizes(split), Some((starts, tets)));
            assert_eq!(cells.node_list_sizes(125).0, node_starts);
            let d = cells.dims();
            assert_eq!(node_starts as u32, d[0] * d[1] * d[2] + 2);
            let (mut ls, mut lt) = ([0u32; 8192], [GridEntry::default(); 65536]);
            assert!(tets > 384, "every tet meets a cell: {tets}");
            if starts > ls.len() || tets > lt.len() {
                continue;
            }
            assert!(cells
                .with_tet_lists(&ob, split, &mut ls[..starts], &mut lt[..tets - 1])
                .is_err());
            assert!(cells
                .with_tet_lists(&ob, split, &mut ls[..starts], &mut lt[..tets])
                .is_ok());
        }
    }
    assert_eq!(
        Occupancy::list_sizes(&ob, 0.05, 1e-4, 0, 2).unwrap_err(),
        OccupancyError::NoStorage
    );
    assert_eq!(
        Occupancy::list_sizes(&ob, 0.05, 1e-4, 8, 0).unwrap_err(),
        OccupancyError::ListStorage
    );
}
