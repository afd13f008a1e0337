//! Worst-case bounds of the servo-path contact operations (issue #9 item 1): the spatial hash,
//! the collision lists, the consistent depth (traced and hashed), the burr's sphere contacts and
//! the pen contact, each driven to the bound its `# Bounded work` / `# Capacity` docs state (most
//! contacts, largest propagation), checking that the work counters it reports stay within that
//! bound and that every capacity saturates, is counted and is never exceeded.
//!
//! The oracles here are written from the documented formulas (cell = floor(x / g)) and brute
//! force over the meshes; none calls the code it checks to compute the expected value. Where an
//! operation reports no work counter, the test bounds its outputs and says why that is the
//! bound. No wall-clock asserts.

use tetradrill::owned::OwnedMesh;
use tetradrill_core::collide::{
    hash_tets, points_in_tets, tets_over_points, Body, Collision, MAX_CELLS_PER_TET,
};
use tetradrill_core::depth::{
    graph_sizes, hash_boundary_faces, penetration_depth, DepthScratch, Method, NodeGraph, NodeSlot,
    Penetration,
};
use tetradrill_core::force::{
    mesh_sphere_contact, pen_contact, sphere_contact, ForceParams, PenOptions, PenState,
};
use tetradrill_core::hash::{Aabb, HashEntry, SpatialHash};
use tetradrill_core::{NodeId, Quat, TetId, Vec3};
use tetradrill_tests::load;
use tetradrill_tests::oracle::{cross, d3, dot, sub, tet_box};

const COW_COARSE: &str = "models/spot_tetgen_coarse.node";
const PEN: &str = "models/pen_tool_gmsh.mesh";

/// The cell of `x` for cells of edge `g`, as the hash module documents it: a true floor of
/// `x / g` per axis (computed through the reciprocal, as the grid is defined by it).
fn cell(x: Vec3, g: f32) -> [i64; 3] {
    let inv = 1.0 / g;
    [
        (x.x * inv).floor() as i64,
        (x.y * inv).floor() as i64,
        (x.z * inv).floor() as i64,
    ]
}

/// Cells an axis-aligned box `[lo, hi]` covers on a grid of edge `g`.
fn cells_of_box(lo: Vec3, hi: Vec3, g: f32) -> u64 {
    let (a, b) = (cell(lo, g), cell(hi, g));
    (0..3).map(|k| (b[k] - a[k] + 1).max(0) as u64).product()
}

/// Brute force: the smallest barycentric coordinate of `x` in tet `p` from signed volumes in
/// f64 (>= 0: inside), `-inf` for a flat tet.
fn min_bary(x: Vec3, p: [Vec3; 4]) -> f64 {
    let vol = |a: Vec3, b: Vec3, c: Vec3, e: Vec3| {
        let a = d3(a);
        dot(cross(sub(d3(b), a), sub(d3(c), a)), sub(d3(e), a))
    };
    let v = vol(p[0], p[1], p[2], p[3]);
    if v.abs() < 1e-30 {
        return f64::NEG_INFINITY;
    }
    [
        vol(x, p[1], p[2], p[3]) / v,
        vol(p[0], x, p[2], p[3]) / v,
        vol(p[0], p[1], x, p[3]) / v,
        vol(p[0], p[1], p[2], x) / v,
    ]
    .into_iter()
    .fold(f64::INFINITY, f64::min)
}

// ------------------------------------------------------------------------------------------
// Hash query
// ------------------------------------------------------------------------------------------

/// Full table: the cow's sliver-rich tets hashed into half the entries they need. The build
/// keeps exactly the leading tets whose cells fit (oracle: cumulative cell counts from the
/// documented floor formula), never writes more entries than the capacity, and counts the
/// saturation. Queries: a box over more than `max_cells` cells visits nothing and is counted;
/// a box within the bound reports each stored (cell, item) pair of its cells once, so its
/// callbacks are at most the entries stored (the documented O(max_cells + entries met)).
#[test]
fn hash_saturates_at_capacity_and_queries_stay_within_max_cells() {
    let mut m = load(COW_COARSE, 1.0);
    let mesh = m.view();
    let nt = mesh.tet_count();
    let g = tetradrill_core::hash::average_edge_length(&mesh);
    let boxes: Vec<(Vec3, Vec3)> = (0..nt)
        .map(|t| tet_box(mesh.tet_positions(TetId::from_idx(t))))
        .collect();
    let need: Vec<u64> = boxes.iter().map(|&(l, h)| cells_of_box(l, h, g)).collect();
    let total: u64 = need.iter().sum();
    let cap = (total / 2) as usize;
    // Oracle: the first items whose cumulative cells fit.
    let (mut kept, mut used) = (0usize, 0u64);
    for &n in &need {
        if used + n > cap as u64 {
            break;
        }
        used += n;
        kept += 1;
    }

    let mut starts = vec![0u32; 2 * nt + 2];
    let mut entries = vec![HashEntry::default(); cap];
    let mut h = SpatialHash::new(&mut starts, &mut entries, g).unwrap();
    let r = h.rebuild(nt, |i| boxes.get(i).map(|&(min, max)| Aabb { min, max }));
    assert!(r.saturated, "half the entries must not hold every tet");
    assert_eq!(r.items, kept, "keeps exactly the leading tets that fit");
    assert_eq!(r.entries as u64, used);
    assert!(h.len() <= h.capacity());
    assert_eq!(h.stats().saturations, 1);
    // The table stays usable: a second saturated build is counted again.
    h.rebuild(nt, |i| boxes.get(i).map(|&(min, max)| Aabb { min, max }));
    assert_eq!(h.stats().saturations, 2);

    // A box just over the cell bound: nothing visited, counted.
    let lo = boxes[0].0;
    let max_cells = 64u32;
    let big = Aabb {
        min: lo,
        max: lo + Vec3::splat(g * 5.5), // 6 or 7 cells per axis: > 64
    };
    assert!(cells_of_box(big.min, big.max, g) > max_cells as u64);
    let mut seen = 0u32;
    assert!(!h.query_box(&big, max_cells, |_, _| seen += 1));
    assert_eq!(seen, 0);
    assert_eq!(h.stats().clipped_queries, 1);

    // Boxes at the bound (4 x 4 x 4 cells when aligned) around every kept tet's corner:
    // callbacks equal the oracle's stored pairs in those cells, at most the entries stored.
    for &(l, _) in boxes.iter().take(kept).step_by(97) {
        let q = Aabb {
            min: l,
            max: l + Vec3::splat(g * 2.9),
        };
        let qc = cells_of_box(q.min, q.max, g);
        assert!(qc <= max_cells as u64);
        let (qa, qb) = (cell(q.min, g), cell(q.max, g));
        let mut expect = 0u64;
        for &(bl, bh) in boxes.iter().take(kept) {
            let (a, b) = (cell(bl, g), cell(bh, g));
            let ov: u64 = (0..3)
                .map(|k| (b[k].min(qb[k]) - a[k].max(qa[k]) + 1).max(0) as u64)
                .product();
            expect += ov;
        }
        let mut calls = 0u64;
        assert!(h.query_box(&q, max_cells, |_, _| calls += 1));
        assert_eq!(calls, expect, "each stored pair of the box's cells once");
        assert!(calls <= h.len() as u64);
    }
    assert_eq!(h.stats().clipped_queries, 1);
}

// ------------------------------------------------------------------------------------------
// Collision
// ------------------------------------------------------------------------------------------

/// Most contacts: the cow's own nodes, shrunk towards its centre so nearly all are inside,
/// against a collision buffer of 100. `points_in_tets` writes at most the capacity, flags the
/// saturation, keeps the smallest point indices (documented) and examines at most
/// `P x b` candidates for `b` the fullest cell met (its O(P x b) bound; `b` counted by brute
/// force over the stored tet boxes).
#[test]
fn collisions_saturate_at_capacity_and_stay_within_p_times_bucket() {
    let mut m = load(COW_COARSE, 1.0);
    let mesh = m.view();
    let body = Body::fixed(&mesh);
    let nt = mesh.tet_count();
    let g = tetradrill_core::hash::average_edge_length(&mesh);
    let centre = mesh.positions().iter().fold(Vec3::ZERO, |a, &b| a + b) / mesh.node_count() as f32;
    let pts: Vec<Vec3> = mesh
        .positions()
        .iter()
        .map(|&p| centre + (p - centre) * 0.97)
        .collect();
    let mut starts = vec![0u32; 2 * nt + 2];
    let mut entries = vec![HashEntry::default(); 32 * nt];
    let mut h = SpatialHash::new(&mut starts, &mut entries, g).unwrap();
    assert!(!hash_tets(&mut h, &body).saturated);

    // Brute force: how deep each point is inside its best tet; "surely" inside beyond a
    // tolerance, "possibly" inside within it (the hash's own tolerance decides those).
    let boxes: Vec<(Vec3, Vec3)> = (0..nt)
        .map(|t| tet_box(mesh.tet_positions(TetId::from_idx(t))))
        .collect();
    let best: Vec<f64> = pts
        .iter()
        .map(|&x| {
            (0..nt)
                .filter(|&t| x.cmpge(boxes[t].0).all() && x.cmple(boxes[t].1).all())
                .map(|t| min_bary(x, mesh.tet_positions(TetId::from_idx(t))))
                .fold(f64::NEG_INFINITY, f64::max)
        })
        .collect();
    let surely: Vec<usize> = (0..pts.len()).filter(|&i| best[i] >= 1e-4).collect();
    let possibly = |i: usize| best[i] >= -1e-4;
    assert!(
        surely.len() > 1000,
        "most shrunk nodes are inside ({})",
        surely.len()
    );

    // The fullest cell a point meets: tets whose box covers it (brute force).
    let b_max = pts
        .iter()
        .map(|&x| {
            let c = cell(x, g);
            boxes
                .iter()
                .filter(|&&(l, hh)| {
                    let (a, b) = (cell(l, g), cell(hh, g));
                    (0..3).all(|k| a[k] <= c[k] && c[k] <= b[k])
                })
                .count() as u64
        })
        .max()
        .unwrap();

    let cap = 100;
    let mut out = vec![Collision::default(); cap];
    let r = points_in_tets(&h, &body, &pts, false, &mut out);
    assert!(r.saturated);
    assert_eq!(r.count, cap, "fills the buffer, never more");
    assert!((r.candidates as u64) <= pts.len() as u64 * b_max);
    // The kept points are the smallest indices of the inside ones: all inside, sorted, and
    // no surely-inside point below the last kept one is missing.
    let got: Vec<usize> = out[..r.count].iter().map(|c| c.node.idx()).collect();
    assert!(got.windows(2).all(|w| w[0] < w[1]));
    assert!(got.iter().all(|&i| possibly(i)));
    let last = *got.last().unwrap();
    assert!(surely
        .iter()
        .filter(|&&i| i <= last)
        .all(|i| got.contains(i)));

    // Unsaturated: every inside point once, still within P x b.
    let mut out = vec![Collision::default(); pts.len()];
    let r = points_in_tets(&h, &body, &pts, false, &mut out);
    assert!(!r.saturated);
    let got: Vec<usize> = out[..r.count].iter().map(|c| c.node.idx()).collect();
    assert!(got.iter().all(|&i| possibly(i)));
    assert!(surely.iter().all(|i| got.binary_search(i).is_ok()));
    assert!((r.candidates as u64) <= pts.len() as u64 * b_max);
}

/// `tets_over_points`: a tet whose box covers more than [`MAX_CELLS_PER_TET`] cells of the
/// point grid is skipped and counted in `clipped` (the cap on its per-tet work); a buffer of
/// 10 for hundreds of hits saturates at 10.
#[test]
fn tets_over_points_clips_huge_boxes_and_saturates() {
    let mut cube = load("builtin:cube12", 1.0);
    let mesh = cube.view();
    let body = Body::fixed(&mesh);
    // A 12^3 lattice of points in the cube.
    let mut pts = Vec::new();
    for k in 0..12 {
        for j in 0..12 {
            for i in 0..12 {
                pts.push(Vec3::new(i as f32, j as f32, k as f32) / 12.0 - Vec3::splat(0.46));
            }
        }
    }
    // Fine grid: each tet's box (at least half the cube per axis) covers > 4096 cells.
    let fine = 0.02f32;
    for t in 0..mesh.tet_count() {
        let (l, h) = tet_box(mesh.tet_positions(TetId::from_idx(t)));
        assert!(cells_of_box(l, h, fine) > MAX_CELLS_PER_TET as u64);
    }
    let mut starts = vec![0u32; 4001];
    let mut entries = vec![HashEntry::default(); pts.len()];
    let mut h = SpatialHash::new(&mut starts, &mut entries, fine).unwrap();
    h.rebuild_points(&pts);
    let mut out = vec![Collision::default(); pts.len()];
    let r = tets_over_points(&h, &pts, &body, false, &mut out);
    assert_eq!(r.clipped as usize, mesh.tet_count());
    assert_eq!(r.count, 0);

    // Coarse grid: hits everywhere; a buffer of 10 fills and is flagged.
    let mut starts = vec![0u32; 4001];
    let mut entries = vec![HashEntry::default(); pts.len()];
    let mut h = SpatialHash::new(&mut starts, &mut entries, 0.25).unwrap();
    h.rebuild_points(&pts);
    let mut out = vec![Collision::default(); 10];
    let r = tets_over_points(&h, &pts, &body, false, &mut out);
    assert_eq!(r.clipped, 0);
    assert!(r.saturated);
    assert_eq!(r.count, 10);
}

// ------------------------------------------------------------------------------------------
// Depth
// ------------------------------------------------------------------------------------------

/// Body A (an 8-block, 729 nodes) pushed 0.3 into body B (a 4-block), both unit cubes:
/// hundreds of colliding nodes in several layers, the largest propagation these meshes allow.
struct DepthCase {
    a: OwnedMesh,
    b: OwnedMesh,
}

impl DepthCase {
    fn new() -> Self {
        Self {
            a: load("builtin:block:8", 1.0),
            b: load("builtin:block:4", 1.0),
        }
    }
}

/// Traced and hashed depth at their step / cell bounds and with small queues and outputs:
/// traced work <= border edges x `max_steps` (each walk crosses at most `max_steps` tets);
/// hashed work <= border edges x entries stored (a query reports each entry of its cells at
/// most once, and boxes over `max_cells` are skipped); a queue shorter than the nodes to
/// propagate to sets `queue_full` and changes nothing (the rest of the breadth-first order is
/// chained through the slots: the same depths as the longest queue, bit for bit); at most
/// `out.len()` written (`out_full`); every collision is accounted for (written or unreached)
/// when the output does not fill.
#[test]
fn depth_traced_and_hashed_stay_within_steps_cells_and_queue() {
    let mut case = DepthCase::new();
    let b_mesh = case.b.view();
    let bb = Body::fixed(&b_mesh);
    let a_mesh = case.a.view();
    let shift = Vec3::new(0.3, 0.2, 0.1);
    let a_pos: Vec<Vec3> = a_mesh.positions().iter().map(|&p| p + shift).collect();
    let (go, ga) = graph_sizes(&a_mesh);
    let (mut off, mut adj) = (vec![0u32; go], vec![NodeId::NONE; ga]);
    let graph = NodeGraph::build(&a_mesh, &mut off, &mut adj).unwrap();
    let nt = b_mesh.tet_count();
    let g = tetradrill_core::hash::average_edge_length(&b_mesh);
    let mut ts = vec![0u32; 2 * nt + 2];
    let mut te = vec![HashEntry::default(); 16 * nt];
    let mut th = SpatialHash::new(&mut ts, &mut te, g).unwrap();
    assert!(!hash_tets(&mut th, &bb).saturated);
    let mut hits = vec![Collision::default(); a_pos.len()];
    let c = points_in_tets(&th, &bb, &a_pos, false, &mut hits);
    assert!(!c.saturated);
    let coll = &hits[..c.count];
    // Brute force: the colliding nodes are those inside B's cube (B is [-0.5, 0.5]^3).
    let brute = a_pos
        .iter()
        .filter(|p| p.cmpge(Vec3::splat(-0.5)).all() && p.cmple(Vec3::splat(0.5)).all())
        .count();
    assert!(
        coll.len() > 200 && coll.len() <= brute,
        "{} of {brute}",
        coll.len()
    );

    let mut fs = vec![0u32; 8 * nt + 2];
    let mut fe = vec![HashEntry::default(); 16 * nt];
    let mut fh = SpatialHash::new(&mut fs, &mut fe, g).unwrap();
    assert!(!hash_boundary_faces(&mut fh, &bb).saturated);
    let face_entries = fh.len() as u64;

    let n = a_pos.len();
    for (label, method, per_edge) in [
        ("traced 1 step", Method::Traced { max_steps: 1 }, 1u64),
        ("traced 256 steps", Method::Traced { max_steps: 256 }, 256),
        (
            "hashed 8 cells",
            Method::Hashed {
                faces: &fh,
                world_to_hash: glam::Affine3A::IDENTITY,
                max_cells: 8,
            },
            face_entries,
        ),
        (
            "hashed 4096 cells",
            Method::Hashed {
                faces: &fh,
                world_to_hash: glam::Affine3A::IDENTITY,
                max_cells: 4096,
            },
            face_entries,
        ),
    ] {
        let mut longest: Option<(u32, Vec<Penetration>)> = None;
        for (queue_len, out_len) in [(n, n), (7, n), (n, 5)] {
            let mut slots = vec![NodeSlot::default(); n];
            let mut queue = vec![NodeId::NONE; queue_len];
            let mut scratch = DepthScratch::new(&mut slots, &mut queue);
            let mut out = vec![Penetration::default(); out_len];
            let r = penetration_depth(&a_pos, &graph, &bb, coll, &method, &mut scratch, &mut out);
            let ctx = format!("{label}, queue {queue_len}, out {out_len}: {r:?}");
            assert!(r.border_edges > 0, "{ctx}");
            assert!(r.work as u64 <= r.border_edges as u64 * per_edge, "{ctx}");
            assert_eq!(r.hits + r.missed_edges, r.border_edges, "{ctx}");
            assert!(r.written <= out_len, "{ctx}");
            match &longest {
                None => longest = Some((r.unreached, out[..r.written].to_vec())),
                Some((unreached, all)) if queue_len < n => {
                    assert!(r.queue_full, "{ctx}");
                    assert_eq!(r.unreached, *unreached, "{ctx}");
                    assert_eq!(&out[..r.written], &all[..], "{ctx}");
                }
                Some(_) => {}
            }
            if out_len < coll.len() && queue_len >= coll.len() {
                assert!(r.out_full, "{ctx}");
                assert_eq!(r.written, out_len, "{ctx}");
            }
            if !r.out_full {
                assert_eq!(r.written + r.unreached as usize, coll.len(), "{ctx}");
            }
            // Layers deeper than 0 were propagated (the largest propagation was exercised).
            if queue_len == n && out_len == n && per_edge > 1 {
                assert!(out[..r.written].iter().any(|p| p.layer >= 2), "{ctx}");
            }
        }
    }
}

// ------------------------------------------------------------------------------------------
// Force
// ------------------------------------------------------------------------------------------

/// `sphere_contact`: one test per triangle yielded, so `triangles` equals the count handed
/// in (its whole work). `mesh_sphere_contact`: a sphere whose box covers more cells than
/// `max_cells` examines nothing (`triangles == 0`); within the bound it examines each face
/// stored in its cells once, however many of the cells hold it, so `triangles <= entries
/// stored`, and equals the brute-force count of faces whose cell range meets the box's.
#[test]
fn sphere_contacts_examine_at_most_what_their_bounds_allow() {
    let mut m = load(COW_COARSE, 1.0);
    let mesh = m.view();
    let body = Body::fixed(&mesh);
    let nt = mesh.tet_count();
    let g = tetradrill_core::hash::average_edge_length(&mesh);
    let mut fs = vec![0u32; 8 * nt + 2];
    let mut fe = vec![HashEntry::default(); 16 * nt];
    let mut fh = SpatialHash::new(&mut fs, &mut fe, g).unwrap();
    assert!(!hash_boundary_faces(&mut fh, &body).saturated);
    let faces: Vec<(Vec3, Vec3)> = (0..nt)
        .flat_map(|t| (0..4u8).map(move |f| (t, f)))
        .filter(|&(t, f)| mesh.is_boundary_face(TetId::from_idx(t), f))
        .map(|(t, f)| {
            let p = mesh.face_positions(TetId::from_idx(t), f);
            (p[0].min(p[1]).min(p[2]), p[0].max(p[1]).max(p[2]))
        })
        .collect();
    let tris: Vec<[Vec3; 3]> = (0..nt)
        .flat_map(|t| (0..4u8).map(move |f| (t, f)))
        .filter(|&(t, f)| mesh.is_boundary_face(TetId::from_idx(t), f))
        .map(|(t, f)| mesh.face_positions(TetId::from_idx(t), f))
        .collect();
    let boundary: Vec<Vec3> = (0..mesh.node_count())
        .filter(|&i| mesh.nodes()[i].boundary())
        .map(|i| mesh.positions()[i])
        .collect();
    for (k, &c) in boundary.iter().enumerate().step_by(53) {
        let all = sphere_contact(c, 0.03, tris.iter().copied());
        assert_eq!(all.triangles as usize, tris.len());
        let part = sphere_contact(c, 0.03, tris.iter().copied().take(k % 17));
        assert_eq!(part.triangles as usize, k % 17);

        for (r, max_cells) in [(0.03f32, 27u32), (0.03, 1), (0.3, 64), (0.3, 4096)] {
            let (lo, hi) = (c - Vec3::splat(r), c + Vec3::splat(r));
            let qc = cells_of_box(lo, hi, g);
            let s = mesh_sphere_contact(&fh, &body, c, r, max_cells);
            if qc > max_cells as u64 {
                assert_eq!(s.triangles, 0, "box of {qc} cells over {max_cells}");
                continue;
            }
            let (qa, qb) = (cell(lo, g), cell(hi, g));
            // Each face whose cells meet the query's, once (not once per shared cell).
            let expect = faces
                .iter()
                .filter(|&&(fl, fh2)| {
                    let (a, b) = (cell(fl, g), cell(fh2, g));
                    (0..3).all(|k| a[k].max(qa[k]) <= b[k].min(qb[k]))
                })
                .count() as u64;
            assert_eq!(s.triangles as u64, expect);
            assert!(s.triangles as usize <= fh.len());
        }
    }
}

/// `pen_contact` with the most contacts: the pen (x10) pushed through the unit block so
/// hundreds of its nodes are inside, every buffer sized below what the pose needs. Counts stay
/// at or below each capacity, saturation is reported, and the traced depth's work stays
/// within border edges x `max_steps`.
#[test]
fn pen_contact_saturates_every_buffer_within_capacity() {
    let mut rig = tetradrill::pen::PenRig {
        pen: load(PEN, 10.0),
        obj: load("builtin:block:8", 1.0),
    };
    let opts = PenOptions {
        params: ForceParams {
            stiffness: 200.0,
            damping: 0.5,
            max_force: 8.0,
            dt: 1e-3,
            ..ForceParams::default()
        },
        max_steps: 64,
        ..PenOptions::default()
    };
    for (contacts, queue) in [(None, None), (Some(40), Some(1000)), (Some(2000), Some(6))] {
        let sizes = tetradrill::pen::PenSizes {
            hash: None,
            contacts,
            queue,
        };
        let (res, _) = rig
            .with_sizes(sizes, |scene, bufs| {
                let mut state = PenState::default();
                let mut out = Vec::new();
                for i in 0..40 {
                    // The tip from above the top face (z = 0.5) down to z = -0.4: most of the
                    // pen's length inside.
                    let tip = Vec3::new(0.013, -0.007, 0.6 - 1.0 * i as f32 / 39.0);
                    let c = pen_contact(scene, bufs, tip, Quat::IDENTITY, &opts, &mut state);
                    out.push((c, bufs.pen_hits.len(), bufs.object_hits.len()));
                }
                out
            })
            .expect("rig builds");
        let mut most = 0;
        for (c, pen_cap, obj_cap) in res {
            let ctx = format!("contacts {contacts:?} queue {queue:?}: {c:?}");
            assert!(c.pen_collisions.count <= pen_cap, "{ctx}");
            assert!(c.object_collisions.count <= obj_cap, "{ctx}");
            assert!(
                c.penetrations.0 <= pen_cap && c.penetrations.1 <= obj_cap,
                "{ctx}"
            );
            assert!(
                c.pen_depth.work as u64 <= c.pen_depth.border_edges as u64 * 64,
                "{ctx}"
            );
            assert!(
                c.object_depth.work as u64 <= c.object_depth.border_edges as u64 * 64,
                "{ctx}"
            );
            assert!(c.force.length() <= 8.0 * (1.0 + 1e-6), "{ctx}");
            if c.pen_collisions.count == pen_cap || c.object_collisions.count == obj_cap {
                assert!(c.saturated(), "{ctx}");
            }
            most = most.max(c.pen_collisions.count);
        }
        match contacts {
            None => assert!(most > 300, "most contacts reached: {most}"),
            Some(k) => assert!(most <= k, "capacity {k}: {most}"),
        }
        if contacts == Some(40) {
            assert_eq!(most, 40, "the small collision buffer fills");
        }
    }
}
