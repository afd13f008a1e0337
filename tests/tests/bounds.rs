//! Worst-case bounds of the servo-path operations (issue #9 item 1): each operation driven to
//! the bound its `# Bounded work` / `# Capacity` docs state (full arena, deepest refinement,
//! most contacts, largest propagation, the contact search's node bound, the drill's budget),
//! checking that the work counters it reports stay within that bound and that every capacity
//! saturates, is counted and is never exceeded.
//!
//! The oracles here are written from the documented formulas (cell = floor(x / g), Bey's 1:8
//! split, the per-operation work units of `DrillParams::budget`) and brute force over the
//! meshes; none calls the code it checks to compute the expected value. Where an operation
//! reports no work counter, the test bounds its outputs and says why that is the bound.
//! No wall-clock asserts.

use std::path::Path;

use tetradrill::owned::OwnedMesh;
use tetradrill_core::collide::{
    hash_tets, points_in_tets, tets_over_points, Body, Collision, MAX_CELLS_PER_TET,
};
use tetradrill_core::depth::{
    graph_sizes, hash_boundary_faces, penetration_depth, DepthScratch, Method, NodeGraph, NodeSlot,
    Penetration,
};
use tetradrill_core::drill::{Drill, DrillParams, Pending, Sphere, WorkCost};
use tetradrill_core::force::{
    mesh_sphere_contact, pen_contact, sphere_contact, ForceParams, PenOptions, PenState, ToolState,
};
use tetradrill_core::hash::{Aabb, HashEntry, SpatialHash};
use tetradrill_core::hierarchy::{
    HNode, Hierarchy, HierarchyError, HierarchyStorage, SphereSlot, VEntry, MAX_DEPTH,
};
use tetradrill_core::mesh::Mesh;
use tetradrill_core::servo::{servo_force, ContactState, World, WorldSizes, WorldStorage};
use tetradrill_core::{NodeId, Quat, TetId, Vec3};

const COW_COARSE: &str = "models/spot_tetgen_coarse.node";
const PEN: &str = "models/pen_tool_gmsh.mesh";

fn load(rel: &str, scale: f64) -> OwnedMesh {
    let p = if rel.starts_with("builtin:") {
        Path::new(rel).to_path_buf()
    } else {
        tetradrill_tests::mesh(rel)
    };
    tetradrill::meshio::load(&p, scale)
        .expect("mesh loads")
        .mesh
}

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

fn tet_box(p: [Vec3; 4]) -> (Vec3, Vec3) {
    let lo = p.iter().fold(p[0], |a, &b| a.min(b));
    let hi = p.iter().fold(p[0], |a, &b| a.max(b));
    (lo, hi)
}

/// f64 vectors for the brute-force oracles (glam's f64 types are not enabled).
type D3 = [f64; 3];

fn d3(v: Vec3) -> D3 {
    [v.x as f64, v.y as f64, v.z as f64]
}
fn sub(a: D3, b: D3) -> D3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
fn add(a: D3, b: D3) -> D3 {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}
fn mul(a: D3, s: f64) -> D3 {
    [a[0] * s, a[1] * s, a[2] * s]
}
fn dot(a: D3, b: D3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
fn cross(a: D3, b: D3) -> D3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
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

/// Distance from `x` to triangle `t` (own oracle: the plane when the projection falls inside,
/// else the nearest of the three edges), in f64.
fn dist_to_triangle(x: Vec3, t: [Vec3; 3]) -> f64 {
    let (x, a, b, c) = (d3(x), d3(t[0]), d3(t[1]), d3(t[2]));
    let n = cross(sub(b, a), sub(c, a));
    let seg = |p: D3, q: D3| {
        let e = sub(q, p);
        let ee = dot(e, e);
        let s = if ee > 0.0 {
            (dot(sub(x, p), e) / ee).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let r = sub(x, add(p, mul(e, s)));
        dot(r, r).sqrt()
    };
    let edges = seg(a, b).min(seg(b, c)).min(seg(c, a));
    let nn = dot(n, n);
    if nn == 0.0 {
        return edges;
    }
    let h = dot(sub(x, a), n) / nn;
    let y = sub(x, mul(n, h));
    let inside = dot(cross(sub(b, a), sub(y, a)), n) >= 0.0
        && dot(cross(sub(c, b), sub(y, b)), n) >= 0.0
        && dot(cross(sub(a, c), sub(y, c)), n) >= 0.0;
    if inside {
        let r = sub(x, y);
        dot(r, r).sqrt()
    } else {
        edges
    }
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
        .filter(|&i| mesh.nodes()[i].boundary)
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

// ------------------------------------------------------------------------------------------
// Refine and erase
// ------------------------------------------------------------------------------------------

struct HierStore {
    roots: Vec<HNode>,
    arena: Vec<HNode>,
    vlist: Vec<VEntry>,
}

impl HierStore {
    fn new(tets: usize, arena: usize) -> Self {
        Self {
            roots: vec![HNode::LEAF; tets],
            arena: vec![HNode::LEAF; arena],
            vlist: vec![VEntry::default(); HierarchyStorage::vlist_needed(tets, arena)],
        }
    }

    fn storage(&mut self) -> HierarchyStorage<'_> {
        HierarchyStorage {
            roots: &mut self.roots,
            arena: &mut self.arena,
            vlist: &mut self.vlist,
        }
    }
}

/// Nodes of a subtree restricted to one face, `L` levels deep: `(4^(L+1) - 1) / 3`.
fn face_subtree(levels: u32) -> u32 {
    (4u32.pow(levels + 1) - 1) / 3
}

/// Deepest refinement: one path of cube12's tet 0 refined to [`MAX_DEPTH`]; every refinement
/// creates 8 nodes and its NTree work stays within 16 visits of (depth + 1 + the nodes of a
/// neighbour subtree across a face); the next one is refused `TooDeep`. Full arena: refining
/// every leaf until the arena is full fills it exactly, refuses with `Full`, counts each
/// refusal, and never uses more than the capacity.
#[test]
fn refine_to_max_depth_and_to_a_full_arena() {
    let mut cube = load("builtin:cube12", 1.0);
    let mesh = cube.view();
    let mut st = HierStore::new(mesh.tet_count(), 8 * 64);
    let mut h = Hierarchy::new(&mesh, st.storage()).unwrap();
    let t = TetId(0);
    // Erase tet 0's neighbours first: all its faces become visible, so every refinement
    // below does its NTree visits (a visible parent face is visited from each child on it).
    for f in 0..4u8 {
        let nb = mesh.neighbour(t, f);
        if !nb.is_none() {
            h.erase(&mesh, nb, 0).expect("erases a neighbour root");
        }
    }
    let mut index = 0u32;
    let mut visited = 0u32;
    for d in 0..MAX_DEPTH as u32 {
        let r = h.refine(&mesh, t, index).expect("refines");
        assert_eq!(r.created, 8);
        visited += r.work;
        // The other trees are untouched roots: a visit reaches at most depth + 1 nodes of
        // this tree or one root across the coarse face.
        assert!(r.work <= 16 * (d + 2 + face_subtree(0)), "depth {d}: {r:?}");
        index = index * 8 + 1 + (d % 8); // descend through a different child each level
    }
    assert!(visited > 0, "the refinements visited across their faces");
    assert_eq!(h.refine(&mesh, t, index), Err(HierarchyError::TooDeep));
    assert_eq!(h.arena_used(), 8 * MAX_DEPTH);
    h.validate(&mesh)
        .expect("valid after the deepest refinement");

    // Fill the arena: breadth-first refinement of every leaf of a tet left whole.
    let whole = (1..mesh.tet_count())
        .map(TetId::from_idx)
        .find(|&u| (0..4u8).all(|f| mesh.neighbour(t, f) != u))
        .expect("a tet that is not a neighbour of tet 0");
    let cap = h.capacity();
    let mut refused = 0u32;
    'fill: for _ in 0..6 {
        let mut leaves = Vec::new();
        h.for_each_leaf(whole, |l| leaves.push(l.index));
        for i in leaves {
            match h.refine(&mesh, whole, i) {
                Ok(r) => assert_eq!(r.created, 8),
                Err(HierarchyError::Full) => {
                    refused += 1;
                    if refused == 5 {
                        break 'fill;
                    }
                }
                Err(e) => panic!("refine {i}: {e}"),
            }
            assert!(h.arena_used() <= cap);
        }
    }
    assert_eq!(refused, 5);
    assert_eq!(h.arena_used(), cap, "a full arena is used exactly");
    assert_eq!(h.saturations(), 5, "every refusal counted");
    h.validate(&mesh).expect("valid with a full arena");
}

/// Largest propagation of an erasure: cube12's tet 0 refined completely to depth L = 3, then a
/// neighbour root erased. Its visit across the shared face meets every one of the 4^L leaves
/// on that face (the work reaches that many), and the work stays within the documented 4
/// visits of O(depth) plus the `(4^(L+1) - 1) / 3` face-subtree nodes each.
#[test]
fn erase_next_to_a_fully_refined_tree_stays_within_four_face_visits() {
    let mut cube = load("builtin:cube12", 1.0);
    let mesh = cube.view();
    let levels = 3u32;
    let mut st = HierStore::new(mesh.tet_count(), 8 * 100);
    let mut h = Hierarchy::new(&mesh, st.storage()).unwrap();
    for _ in 0..levels {
        let mut leaves = Vec::new();
        h.for_each_leaf(TetId(0), |l| leaves.push(l.index));
        for i in leaves {
            h.refine(&mesh, TetId(0), i).expect("refines");
        }
    }
    let mut leaves = 0;
    h.for_each_leaf(TetId(0), |_| leaves += 1);
    assert_eq!(leaves, 8usize.pow(levels));
    // Erase every neighbour of tet 0 (each shares one face with it).
    let mut erased_any = false;
    for f in 0..4u8 {
        let nb = mesh.neighbour(TetId(0), f);
        if nb.is_none() {
            continue;
        }
        let r = h.erase(&mesh, nb, 0).expect("erases the root");
        let bound = 4 * (MAX_DEPTH as u32 + 1 + face_subtree(levels));
        assert!(r.work <= bound, "face {f}: {r:?} over {bound}");
        assert!(
            r.work >= 4u32.pow(levels),
            "face {f}: the visit met every leaf on the shared face ({r:?})"
        );
        erased_any = true;
    }
    assert!(erased_any);
    h.validate(&mesh).expect("valid");
}

// ------------------------------------------------------------------------------------------
// Drill step
// ------------------------------------------------------------------------------------------

/// What one operation of the drill may cost beyond the budget, in the units of
/// [`WorkCost`]: taking the item, a refinement's 8 nodes created and its 16 NTree visits (each
/// at most `MAX_DEPTH + 1` nodes down to the neighbour plus the `(4^(L+1) - 1) / 3` nodes of a
/// face subtree `L = max_depth` levels deep), then the new children classified (each
/// classification at most one exact test); a leaf's swept test may first look its sphere up.
fn drill_op_cost(max_depth: u8) -> u32 {
    WorkCost::TAKEN
        + WorkCost::LOCATE
        + WorkCost::EXACT_TEST
        + WorkCost::CREATED * 8
        + WorkCost::VISIT * 16 * (MAX_DEPTH as u32 + 1 + face_subtree(max_depth as u32))
        + WorkCost::EXPANDED
        + WorkCost::EXACT_TEST * 8
}

/// The drill's budget: a burr sweeping through a 4-block at depth 5, with budgets from 1 to
/// 4000, a pending deque of 64 items and an arena of 4096 nodes. Each tick's work is at most
/// budget + the cost of one operation; pending items never exceed the deque; dropped items
/// and refused refinements are counted.
#[test]
fn drill_work_stays_within_budget_plus_one_operation() {
    let mut block = load("builtin:block:4", 1.0);
    let mesh = block.view();
    let all: Vec<TetId> = (0..mesh.tet_count()).map(TetId::from_idx).collect();
    for (budget, queue_len, arena) in [
        (1u32, 1 << 14, 1 << 16),
        (50, 64, 1 << 16),
        (4000, 1 << 14, 4096),
    ] {
        let params = DrillParams {
            max_depth: 5,
            min_area: 0.0,
            budget,
        };
        let op = drill_op_cost(params.max_depth);
        let mut st = HierStore::new(mesh.tet_count(), arena);
        let mut h = Hierarchy::new(&mesh, st.storage()).unwrap();
        let mut queue = vec![Pending::default(); queue_len];
        let mut drill = Drill::new(&mut queue);
        let (mut sat, mut max_work, mut created) = (0u32, 0u32, 0u32);
        for i in 0..400 {
            let s = Sphere {
                center: Vec3::new(-0.5 + i as f32 / 400.0, 0.1, 0.45),
                radius: 0.2,
            };
            // The candidates a servo would hand in: tets whose box meets the sphere's box.
            let near: Vec<TetId> = all
                .iter()
                .copied()
                .filter(|&t| {
                    let (l, hi) = tet_box(mesh.tet_positions(t));
                    (l - Vec3::splat(s.radius)).cmple(s.center).all()
                        && (hi + Vec3::splat(s.radius)).cmpge(s.center).all()
                })
                .collect();
            let r = drill.step(&mut h, &mesh, &near, &[s], &params);
            let ctx = format!("budget {budget}, deque {queue_len}, tick {i}: {r:?}");
            assert!(r.work <= budget + op, "{ctx}");
            // The work is exactly what was done, each kind at its weight.
            assert_eq!(
                r.work,
                WorkCost::TAKEN * r.taken
                    + WorkCost::EXPANDED * r.expanded
                    + WorkCost::VISIT * r.visits
                    + WorkCost::CREATED * r.created
                    + WorkCost::EXACT_TEST * r.exact_tests
                    + WorkCost::LOCATE * r.located,
                "{ctx}"
            );
            assert!(r.pending as usize <= queue_len, "{ctx}");
            assert_eq!(r.pending as usize, drill.pending(), "{ctx}");
            assert!(h.arena_used() <= h.capacity(), "{ctx}");
            sat += r.saturations;
            max_work = max_work.max(r.work);
            created += r.created;
        }
        assert_eq!(
            sat,
            drill.saturations() + h.saturations(),
            "every saturation counted"
        );
        assert!(created > 0, "budget {budget}: nothing refined");
        // The budget was the limit: some tick used all of it.
        assert!(
            max_work >= budget,
            "budget {budget} never reached: {max_work}"
        );
        if queue_len == 64 {
            assert!(drill.saturations() > 0, "the small deque fills");
        }
        if arena == 4096 {
            assert!(h.saturations() > 0, "the small arena fills");
            assert_eq!(h.arena_used(), h.capacity());
        }
        h.validate(&mesh).expect("valid");
    }
}

// ------------------------------------------------------------------------------------------
// World::simulate, nearest_visible and servo_force
// ------------------------------------------------------------------------------------------

struct WorldStore {
    hash_starts: Vec<u32>,
    hash_entries: Vec<HashEntry>,
    tet_boxes: Vec<Aabb>,
    hier: HierStore,
    pending: Vec<Pending>,
    candidates: Vec<TetId>,
    sphere_memo: Vec<SphereSlot>,
}

impl WorldStore {
    fn new(s: WorldSizes) -> Self {
        let mut hier = HierStore::new(s.roots, s.arena);
        hier.vlist = vec![VEntry::default(); s.vlist];
        Self {
            hash_starts: vec![0; s.hash_starts],
            hash_entries: vec![HashEntry::default(); s.hash_entries],
            tet_boxes: vec![Aabb::point(Vec3::ZERO); s.tet_boxes],
            hier,
            pending: vec![Pending::default(); s.pending],
            candidates: vec![TetId::NONE; s.candidates],
            sphere_memo: vec![SphereSlot::EMPTY; s.sphere_memo],
        }
    }

    fn world<'a>(&'a mut self, mesh: Mesh<'a>) -> World<'a> {
        World::new(
            mesh,
            WorldStorage {
                hash_starts: &mut self.hash_starts,
                hash_entries: &mut self.hash_entries,
                tet_boxes: &mut self.tet_boxes,
                hierarchy: self.hier.storage(),
                pending: &mut self.pending,
                candidates: &mut self.candidates,
                sphere_memo: &mut self.sphere_memo,
            },
        )
        .expect("world")
    }
}

/// The burr's path for the world tests: in along -z through the top face of the unit block,
/// then across it in x, drill on.
fn burr_path(i: usize) -> Vec3 {
    if i < 100 {
        Vec3::new(-0.3, 0.05, 0.6 - 0.25 * i as f32 / 100.0)
    } else {
        Vec3::new(-0.3 + 0.6 * (i - 100) as f32 / 500.0, 0.05, 0.35)
    }
}

/// `World::simulate` at its bounds: the contact search's node bound from 1 to 4096
/// (`contact_nodes <= contact_max_nodes` every tick, saturated ticks counted one for one), a
/// candidate list of 6 (never more candidates than that, full lists counted), a tiny hash
/// (saturated at build, counted), the drill's budget (its work within budget + one
/// operation), a small deque and arena (counted, never exceeded).
#[test]
fn simulate_counters_stay_within_their_bounds() {
    let mut block = load("builtin:block:6", 1.0);
    let radius = 0.12f32;
    for (max_nodes, candidates, hash_entries, budget) in [
        (1u32, 1024usize, None, 4000u32),
        (32, 6, None, 200),
        (4096, 1024, Some(300usize), 4000),
    ] {
        let tets = block.view().tet_count();
        let mut sizes = WorldSizes::new(tets, 1 << 14).with_pending(256);
        sizes.candidates = candidates;
        if let Some(h) = hash_entries {
            sizes.hash_entries = h;
        }
        let mut store = WorldStore::new(sizes);
        let mut world = store.world(block.view());
        world.set_contact_max_nodes(max_nodes);
        assert_eq!(world.contact_max_nodes(), max_nodes);
        if hash_entries.is_some() {
            assert_eq!(world.saturations().hash, 1, "the tiny hash saturates once");
            assert!(world.hash().len() <= 300);
        }
        let params = DrillParams {
            max_depth: 5,
            min_area: 0.0,
            budget,
        };
        let op = drill_op_cost(5);
        let (mut sat_contact, mut sat_cand, mut saw_sat, mut most_nodes) = (0u32, 0u32, 0u32, 0u32);
        for i in 0..600 {
            let c = burr_path(i);
            let before = world.saturations();
            let r = world.simulate(c, radius, 0.5 * radius, true, &params);
            let after = world.saturations();
            let ctx = format!("max_nodes {max_nodes}, candidates {candidates}, tick {i}: {r:?}");
            assert!(r.contact_nodes <= max_nodes, "{ctx}");
            assert!(r.candidates as usize <= candidates, "{ctx}");
            assert_eq!(world.candidates().len(), r.candidates as usize, "{ctx}");
            assert!(r.drill.work <= budget + op, "{ctx}");
            assert!(world.pending() <= 256, "{ctx}");
            assert!(
                world.hierarchy().arena_used() <= world.hierarchy().capacity(),
                "{ctx}"
            );
            assert_eq!(
                after.contact - before.contact,
                r.contact_saturated as u32,
                "{ctx}"
            );
            assert_eq!(
                after.candidates - before.candidates,
                r.candidates_saturated as u32,
                "{ctx}"
            );
            sat_contact += r.contact_saturated as u32;
            sat_cand += r.candidates_saturated as u32;
            saw_sat += r.drill.saturations;
            most_nodes = most_nodes.max(r.contact_nodes);
            // The servo half on the plane just found stays within the clamp.
            let mut tool = ToolState::default();
            let f = servo_force(
                world.contact(),
                c,
                radius,
                &mut tool,
                &ForceParams::default(),
            );
            assert!(f.is_finite() && f.length() <= ForceParams::default().max_force * (1.0 + 1e-6));
        }
        let s = world.saturations();
        assert_eq!(s.contact, sat_contact);
        assert_eq!(s.candidates, sat_cand);
        if max_nodes < 64 {
            assert!(sat_contact > 0, "a node bound of {max_nodes} is reached");
            assert_eq!(most_nodes, max_nodes, "the search uses its whole bound");
        }
        if candidates == 6 {
            assert!(sat_cand > 0, "the candidate list fills");
        }
        assert!(saw_sat <= s.pending + s.arena);
        world.hierarchy().validate(world.mesh()).expect("valid");
    }
}

/// `Hierarchy::nearest_visible` directly on a drilled groove: `nodes <= max_nodes` for every
/// bound from 0 to the unbounded search, `complete` iff the bound was not reached, and when
/// complete the answer is the brute-force closest visible triangle within reach (the oracle
/// enumerates every visible triangle through the v_list).
#[test]
fn nearest_visible_tests_at_most_max_nodes() {
    let mut block = load("builtin:block:6", 1.0);
    let tets = block.view().tet_count();
    let mut store = WorldStore::new(WorldSizes::new(tets, 1 << 16));
    let mut world = store.world(block.view());
    let params = DrillParams {
        max_depth: 5,
        min_area: 0.0,
        budget: 1 << 20,
    };
    for i in 0..600 {
        world.simulate(burr_path(i), 0.12, 0.06, true, &params);
    }
    let mut all = Vec::new();
    world
        .hierarchy()
        .for_each_visible(world.mesh(), |vt| all.push(vt.corners));
    assert!(
        all.len() > 1000,
        "a drilled groove: {} triangles",
        all.len()
    );
    let every: Vec<TetId> = (0..tets).map(TetId::from_idx).collect();
    for k in 0..20 {
        let c = burr_path(100 + k * 25) + Vec3::new(0.0, 0.0, 0.02);
        let reach = 0.2f32;
        let brute = all
            .iter()
            .map(|t| dist_to_triangle(c, *t))
            .fold(f64::INFINITY, f64::min);
        let brute = (brute * brute) as f32;
        let h = world.hierarchy();
        let full = h.nearest_visible(world.mesh(), &every, c, reach, None, u32::MAX);
        assert!(full.complete);
        if brute <= reach * reach {
            assert!(
                (full.d2 - brute).abs() <= 1e-6 * (1.0 + brute),
                "{} vs {brute}",
                full.d2
            );
        }
        for max_nodes in [0u32, 1, 7, 64, full.nodes / 2, full.nodes, full.nodes + 1] {
            let n = h.nearest_visible(world.mesh(), &every, c, reach, None, max_nodes);
            assert!(n.nodes <= max_nodes, "{} over {max_nodes}", n.nodes);
            if max_nodes < full.nodes {
                assert!(!n.complete, "bound {max_nodes} < {} needed", full.nodes);
                assert!(n.d2 >= full.d2, "an anytime answer is never closer");
            } else {
                assert!(n.complete);
                assert_eq!(n.d2, full.d2);
            }
        }
    }
}

/// `servo_force` reports no work counter: its work is constant (no loop), so the bound to
/// check is on its output: never above the clamp, zero with non-finite input, zero without a
/// valid plane (at once for a tool that never had one, within the switch time for one whose
/// plane was lost), whatever the depth.
#[test]
fn servo_force_output_is_clamped_and_finite() {
    let params = ForceParams {
        stiffness: 1e6,
        damping: 10.0,
        max_force: 3.3,
        dt: 1e-3,
        ..ForceParams::default()
    };
    let plane = ContactState {
        valid: true,
        point: Vec3::ZERO,
        normal: Vec3::Z,
        depth: 0.0,
        centre: Vec3::ZERO,
        triangles: 1,
    };
    let mut tool = ToolState::default();
    for i in 0..2000 {
        let z = -10.0 + i as f32 * 0.01;
        let f = servo_force(&plane, Vec3::new(0.0, 0.0, z), 0.1, &mut tool, &params);
        assert!(
            f.is_finite() && f.length() <= 3.3 * (1.0 + 1e-6),
            "z {z}: {f}"
        );
        if z > 0.1 {
            assert_eq!(f, Vec3::ZERO);
        }
    }
    let invalid = ContactState::default();
    assert_eq!(
        servo_force(
            &invalid,
            Vec3::ZERO,
            0.1,
            &mut ToolState::default(),
            &params
        ),
        Vec3::ZERO
    );
    // The plane lost with the tool 0.1 deep: the clamped 3.3 N fades out within 16 ms.
    let ticks = (params.switch_time / params.dt).ceil() as usize;
    let fading: Vec<Vec3> = (0..ticks)
        .map(|_| servo_force(&invalid, Vec3::ZERO, 0.1, &mut tool, &params))
        .collect();
    assert!(fading[0].length() > 0.0 && fading[0].length() <= 3.3);
    assert_eq!(fading[ticks - 1], Vec3::ZERO, "{fading:?}");
    for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
        let f = servo_force(&plane, Vec3::new(0.0, 0.0, bad), 0.1, &mut tool, &params);
        assert!(f.is_finite() && f.length() <= 3.3 * (1.0 + 1e-6));
    }
}
