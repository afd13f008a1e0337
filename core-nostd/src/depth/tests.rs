use glam::{Affine3A, Vec3};

use super::surface::SurfaceHit;
use super::traced::trace_to_surface;
use super::*;
use crate::collide::test_support::Store;
use crate::collide::{hash_tets, points_in_tets, Body, Collision};
use crate::hash::{HashEntry, SpatialHash};
use crate::ids::NodeId;

const TOP: f32 = 0.5;

struct Fixture {
    a: Store<125, 384>,
    b: Store<125, 384>,
}

/// B: 4x4x4 block [-0.5, 0.5]^3. A: 4x4x4 block of edge 0.05 with its top level above B.
fn fixture(z0: f32) -> Fixture {
    Fixture {
        a: Store::block(4, 0.05, Vec3::new(-0.1, -0.08, z0)),
        b: Store::block(4, 0.25, Vec3::splat(-0.5)),
    }
}

fn run(
    f: &mut Fixture,
    hashed: bool,
    queue_cap: usize,
    out: &mut [Penetration],
) -> (DepthReport, [Collision; 125], usize) {
    let a = f.a.mesh();
    let b = f.b.mesh();
    let bb = Body::fixed(&b);
    let mut ts = [0u32; 64];
    let mut te = [HashEntry::default(); 8192];
    let mut th = SpatialHash::new(&mut ts, &mut te, 0.25).unwrap();
    hash_tets(&mut th, &bb);
    let mut cols = [Collision::default(); 125];
    let cr = points_in_tets(&th, &bb, a.positions(), false, &mut cols);
    let mut go = [0u32; 126];
    let mut ga = [NodeId::NONE; 1208];
    let g = NodeGraph::build(&a, &mut go, &mut ga).unwrap();
    let mut slots = [NodeSlot::default(); 125];
    let mut queue = [NodeId::NONE; 125];
    let q = &mut queue[..queue_cap];
    let mut sc = DepthScratch::new(&mut slots, q);
    let mut fs = [0u32; 64];
    let mut fe = [HashEntry::default(); 4096];
    let mut fh = SpatialHash::new(&mut fs, &mut fe, 0.25).unwrap();
    assert!(!hash_boundary_faces(&mut fh, &bb).saturated);
    let m = if hashed {
        Method::Hashed {
            faces: &fh,
            world_to_hash: Affine3A::IDENTITY,
            max_cells: 64,
        }
    } else {
        Method::Traced { max_steps: 64 }
    };
    let r = penetration_depth(a.positions(), &g, &bb, &cols[..cr.count], &m, &mut sc, out);
    (r, cols, cr.count)
}

#[test]
fn flat_face_depths_and_layers() {
    let mut f = fixture(TOP - 0.17);
    let mut out = [Penetration::default(); 125];
    let (r, _, n) = run(&mut f, false, 125, &mut out);
    assert_eq!(n, 100, "four of five levels inside");
    assert_eq!(r.written, 100);
    assert_eq!(
        (r.unreached, r.missed_edges, r.out_full, r.queue_full),
        (0, 0, false, false)
    );
    let a = f.a.mesh();
    let mut max_layer = 0;
    for p in &out[..r.written] {
        let z = a.positions()[p.node.idx()].z;
        assert!((p.depth - (TOP - z)).abs() < 1e-5, "{p:?} z {z}");
        assert!((p.dir - Vec3::Z).length() < 1e-5);
        let level = ((z - (TOP - 0.17)) / 0.05 + 0.5) as u32;
        assert_eq!(p.layer, 3 - level, "layer counts edges to the border");
        max_layer = max_layer.max(p.layer);
    }
    assert_eq!(max_layer, 3);
}

#[test]
fn traced_and_hashed_are_bit_identical() {
    for z0 in [TOP - 0.17, TOP - 0.12, TOP - 0.031] {
        let mut f = fixture(z0);
        let mut o1 = [Penetration::default(); 125];
        let mut o2 = [Penetration::default(); 125];
        let (r1, _, _) = run(&mut f, false, 125, &mut o1);
        let (r2, _, _) = run(&mut f, true, 125, &mut o2);
        assert!(r1.written > 0);
        assert_eq!(r1.written, r2.written);
        assert_eq!(r1.hits, r2.hits);
        for (x, y) in o1[..r1.written].iter().zip(&o2[..r2.written]) {
            assert_eq!(x.node, y.node);
            assert_eq!(x.depth.to_bits(), y.depth.to_bits());
            assert_eq!(
                x.dir.to_array().map(f32::to_bits),
                y.dir.to_array().map(f32::to_bits)
            );
        }
    }
}

#[test]
fn region_without_border_is_reported_not_invented() {
    let mut f = Fixture {
        a: Store::block(4, 0.05, Vec3::new(-0.1, -0.08, -0.1)),
        b: Store::block(4, 0.25, Vec3::splat(-0.5)),
    };
    let mut out = [Penetration::default(); 125];
    let (r, _, n) = run(&mut f, false, 125, &mut out);
    assert_eq!(n, 125);
    assert_eq!((r.written, r.unreached, r.border_points), (0, 125, 0));
}

#[test]
fn tiny_queue_and_output_saturate() {
    let mut f = fixture(TOP - 0.17);
    let mut out = [Penetration::default(); 10];
    let (r, _, n) = run(&mut f, false, 30, &mut out);
    assert_eq!(n, 100);
    assert!(r.queue_full && r.out_full);
    assert_eq!(r.written, 10);
    assert_eq!(
        r.unreached, 0,
        "the queue's overflow is chained, nothing is dropped"
    );
    let mut none: [Penetration; 0] = [];
    let (r, _, _) = run(&mut f, true, 0, &mut none);
    assert!(r.queue_full && r.out_full);
    assert_eq!((r.written, r.unreached), (0, 0));
}

/// Any queue length, down to none, gives every node its depth: the analytic depth below the
/// flat top face (`TOP - z` along +z, layer = levels to the border) and, bit for bit, the
/// unbounded queue's result, for both surface searches.
#[test]
fn a_short_queue_changes_no_depth() {
    for z0 in [TOP - 0.17, TOP - 0.12] {
        for hashed in [false, true] {
            let mut f = fixture(z0);
            let mut full = [Penetration::default(); 125];
            let (r0, _, n) = run(&mut f, hashed, 125, &mut full);
            assert!(!r0.queue_full && r0.written == n && r0.unreached == 0);
            for cap in [0, 1, 2, 7, 30, n - 1] {
                let mut out = [Penetration::default(); 125];
                let (r, _, _) = run(&mut f, hashed, cap, &mut out);
                assert!(r.queue_full, "queue {cap}");
                assert_eq!((r.written, r.unreached), (n, 0), "queue {cap}");
                let a = f.a.mesh();
                for (x, y) in out[..n].iter().zip(&full[..n]) {
                    let z = a.positions()[x.node.idx()].z;
                    assert!((x.depth - (TOP - z)).abs() < 1e-5, "queue {cap}: {x:?}");
                    assert!((x.dir - Vec3::Z).length() < 1e-5, "queue {cap}: {x:?}");
                    let level = ((z - z0) / 0.05 + 0.5) as u32;
                    let border = ((TOP - z0) / 0.05) as u32; // the highest level inside
                    assert_eq!(x.layer, border - level, "queue {cap}: {x:?}");
                    assert_eq!((x.node, x.tet, x.layer), (y.node, y.tet, y.layer));
                    assert_eq!(x.depth.to_bits(), y.depth.to_bits(), "queue {cap}");
                    assert_eq!(
                        x.dir.to_array().map(f32::to_bits),
                        y.dir.to_array().map(f32::to_bits)
                    );
                }
            }
        }
    }
}

/// A partial list: A's lowest two levels listed, the two above them inside B but unlisted
/// (a full collision buffer), the top level outside. The upward edges of the listed level
/// end inside B; followed on, their lines leave through B's flat top (vertex normals +z
/// there), so the listed nodes get the analytic depth `TOP - z` along +z: the upper listed
/// level directly (layer 0), the lower one by propagation (layer 1). The same list taken as
/// complete finds no crossing on any edge and gives no depth.
#[test]
fn a_partial_list_follows_edges_past_unlisted_nodes() {
    let z0 = TOP - 0.17;
    let mut f = fixture(z0);
    let mut out = [Penetration::default(); 125];
    // The collisions of the two lowest levels (z < z0 + 0.075).
    let (_, cols, n) = run(&mut f, false, 125, &mut out);
    assert_eq!(n, 100);
    let a = f.a.mesh();
    let mut list = [Collision::default(); 125];
    let mut m = 0;
    for c in &cols[..n] {
        if a.positions()[c.node.idx()].z < z0 + 0.075 {
            list[m] = *c;
            m += 1;
        }
    }
    assert_eq!(m, 50);
    let b = f.b.mesh();
    let bb = Body::fixed(&b);
    let mut go = [0u32; 126];
    let mut ga = [NodeId::NONE; 1208];
    let g = NodeGraph::build(&a, &mut go, &mut ga).unwrap();
    let mut fs = [0u32; 64];
    let mut fe = [HashEntry::default(); 4096];
    let mut fh = SpatialHash::new(&mut fs, &mut fe, 0.25).unwrap();
    assert!(!hash_boundary_faces(&mut fh, &bb).saturated);
    let traced = Method::Traced { max_steps: 64 };
    let hashed = Method::Hashed {
        faces: &fh,
        world_to_hash: Affine3A::IDENTITY,
        max_cells: 64,
    };
    let mut results = [[Penetration::default(); 125]; 2];
    for (k, m_) in [traced, hashed].iter().enumerate() {
        for queue_cap in [125, 3] {
            let mut slots = [NodeSlot::default(); 125];
            let mut queue = [NodeId::NONE; 125];
            let mut sc = DepthScratch::new(&mut slots, &mut queue[..queue_cap]);
            let listed = Listed::Partial {
                list: &list[..m],
                max_steps: 64,
            };
            let out = &mut results[k];
            let r = penetration_depth_of(a.positions(), &g, &bb, listed, m_, &mut sc, out);
            assert_eq!(
                (r.written, r.unreached, r.missed_edges),
                (50, 0, 0),
                "{r:?}"
            );
            assert!(r.beyond > 0 && r.beyond == r.hits, "{r:?}");
            for p in &out[..r.written] {
                let z = a.positions()[p.node.idx()].z;
                assert!((p.depth - (TOP - z)).abs() < 1e-5, "{p:?} z {z}");
                assert!((p.dir - Vec3::Z).length() < 1e-5, "{p:?}");
                let level = ((z - z0) / 0.05 + 0.5) as u32;
                assert_eq!(p.layer, 1 - level, "{p:?}");
            }
            // Taken as complete: the upward edges end inside B, so nothing has a depth.
            let mut sc = DepthScratch::new(&mut slots, &mut queue[..queue_cap]);
            let mut none = [Penetration::default(); 125];
            let listed = Listed::All(&list[..m]);
            let r = penetration_depth_of(a.positions(), &g, &bb, listed, m_, &mut sc, &mut none);
            assert_eq!((r.written, r.unreached, r.hits, r.beyond), (0, 50, 0, 0));
        }
    }
    for (x, y) in results[0][..50].iter().zip(&results[1][..50]) {
        assert_eq!(x.node, y.node);
        assert_eq!(x.depth.to_bits(), y.depth.to_bits(), "traced = hashed");
    }
}

#[test]
fn traced_walk_gives_up_after_max_steps() {
    let mut b = Store::<125, 384>::block(4, 0.25, Vec3::splat(-0.5));
    let b = b.mesh();
    let bb = Body::fixed(&b);
    let p = Vec3::new(0.01, 0.02, -0.3);
    let q = Vec3::new(0.03, 0.01, 0.9);
    let t = (0..b.tet_count())
        .map(crate::ids::TetId::from_idx)
        .find(|&t| {
            crate::geom::barycentric(p, bb.tet_positions(t).unwrap())
                .is_some_and(|x| crate::geom::inside(x, 0.0))
        })
        .unwrap();
    let mut steps = 0;
    let h = trace_to_surface(&bb, t, p, q, 64, &mut steps).unwrap();
    assert!((h.point.z - 0.5).abs() < 1e-6 && (h.normal - Vec3::Z).length() < 1e-6);
    assert!(steps > 2);
    let mut s2 = 0;
    assert!(trace_to_surface(&bb, t, p, q, 2, &mut s2).is_none());
    assert_eq!(s2, 2);
}

/// The walk as the Praktikum report (section 4) describes it, each face tested afresh with
/// [`surface::exit_values`]: the oracle for the walk that keeps its edge values from tet to tet
/// (also in `traced`'s tests).
pub(super) fn walk_testing_every_face(
    b: &Body<'_, '_>,
    start: crate::ids::TetId,
    p: Vec3,
    q: Vec3,
    max_steps: u32,
) -> (Option<SurfaceHit>, u32) {
    let (mut t, mut entry, mut steps) = (start, 4u8, 0u32);
    while steps < max_steps {
        steps += 1;
        let Some((f, e)) = (0..4u8)
            .filter(|&f| f != entry)
            .find_map(|f| surface::exit_values(b, t, f, p, q).map(|e| (f, e)))
        else {
            return (None, steps);
        };
        let tet = b.mesh.tet(t);
        if tet.neighbours[f as usize].is_none() {
            return (surface::hit_on_face(b, t, f, e, p, q), steps);
        }
        entry = tet.reverse[f as usize].face();
        t = tet.neighbours[f as usize];
    }
    (None, steps)
}

#[test]
fn the_walk_keeping_edge_values_crosses_the_faces_testing_each_face_does() {
    let mut b = Store::<125, 384>::block(4, 0.25, Vec3::splat(-0.5));
    let b = b.mesh();
    let bb = Body::fixed(&b);
    // Lines from points inside the block in many directions, some through nodes and edges
    // of the grid (where faces tie), walked to the surface and cut short.
    let mut seed = 0x2545_f491_4f6c_dd1du64;
    let mut next = || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        (seed >> 40) as f32 / (1u64 << 24) as f32 - 0.5
    };
    let (mut walked, mut long) = (0, 0);
    for k in 0..400 {
        let p = match k % 4 {
            0 => Vec3::new(next(), next(), next()) * 0.98,
            // On a grid plane, a grid line and a grid node.
            1 => Vec3::new(0.25, next(), next()) * 0.98,
            2 => Vec3::new(0.0, 0.25, next() * 0.98),
            _ => Vec3::new(-0.25, 0.0, 0.25),
        };
        let q = p + Vec3::new(next(), next(), next()) * 3.0;
        let Some(t) = (0..b.tet_count())
            .map(crate::ids::TetId::from_idx)
            .find(|&t| {
                crate::geom::barycentric(p, bb.tet_positions(t).unwrap())
                    .is_some_and(|x| crate::geom::inside(x, 0.0))
            })
        else {
            continue;
        };
        for max_steps in [1, 3, 64] {
            let mut steps = 0;
            let got = traced::trace_exit(&bb, t, p, q, max_steps, &mut steps);
            let want = walk_testing_every_face(&bb, t, p, q, max_steps);
            assert_eq!((got, steps), want, "line {p} -> {q}, {max_steps} steps");
            walked += 1;
            long += (steps > 3) as u32;
        }
    }
    assert!(
        walked > 1000 && long > 100,
        "{walked} walks, {long} longer than 3 tets"
    );
}

/// Reused crossings ([`DepthScratch::with_crossings`]) against searching every edge every
/// call, over a small block (A) moved in 400 small steps through the top of a convex block
/// (B), tilting, across its edge and corner and back out. B being convex, a line from inside
/// leaves it once, so the remembered face, when the edge still leaves through it, is the
/// crossing the search finds: the depths must agree bit for bit, while most border edges skip
/// the search. Then `forget_crossings` and `set_reuse(false)` must make the next call search
/// every edge again.
#[test]
fn reused_crossings_are_the_searched_ones_on_a_convex_body() {
    let mut f = fixture(TOP - 0.17);
    let a = f.a.mesh();
    let b = f.b.mesh();
    let bb = Body::fixed(&b);
    let rest: [Vec3; 125] = core::array::from_fn(|i| a.positions()[i]);
    let mut go = [0u32; 126];
    let mut ga = [NodeId::NONE; 1208];
    let g = NodeGraph::build(&a, &mut go, &mut ga).unwrap();
    let (mut s1, mut q1) = ([NodeSlot::default(); 125], [NodeId::NONE; 125]);
    let (mut s2, mut q2) = ([NodeSlot::default(); 125], [NodeId::NONE; 125]);
    let mut memo = [Crossing::default(); 1208];
    let mut search = DepthScratch::new(&mut s1, &mut q1);
    let mut reuse = DepthScratch::with_crossings(&mut s2, &mut q2, &mut memo);
    reuse.set_reuse(true);
    let m = Method::Traced { max_steps: 64 };
    let (mut border, mut reused, mut compared) = (0u32, 0u32, 0usize);
    let mut moved = [Vec3::ZERO; 125];
    for step in 0..400 {
        // Out to the top edge and corner (x, y up to 0.5) and back, tilting about two axes.
        let u = step as f32 / 399.0;
        let w = 1.0 - (2.0 * u - 1.0).abs();
        let pose = Affine3A::from_rotation_translation(
            glam::Quat::from_euler(glam::EulerRot::XYZ, 0.4 * w, -0.3 * w, 0.2 * u),
            Vec3::new(0.55 * w, 0.5 * w, 0.1 * (6.0 * u).sin()),
        );
        for (m, r) in moved.iter_mut().zip(&rest) {
            *m = pose.transform_point3(*r);
        }
        let (cols, n) = brute_force_inside(&bb, &moved);
        let (mut o1, mut o2) = ([Penetration::default(); 125], [Penetration::default(); 125]);
        let r1 = penetration_depth(&moved, &g, &bb, &cols[..n], &m, &mut search, &mut o1);
        let r2 = penetration_depth(&moved, &g, &bb, &cols[..n], &m, &mut reuse, &mut o2);
        assert_eq!(r1.reused, 0);
        assert_eq!((r1.written, r1.hits), (r2.written, r2.hits), "step {step}");
        for (x, y) in o1[..r1.written].iter().zip(&o2[..r2.written]) {
            assert_eq!((x.node, x.layer), (y.node, y.layer), "step {step}");
            assert_eq!(
                x.depth.to_bits(),
                y.depth.to_bits(),
                "step {step} {x:?} {y:?}"
            );
            assert_eq!(
                x.dir.to_array().map(f32::to_bits),
                y.dir.to_array().map(f32::to_bits),
                "step {step}"
            );
        }
        compared += r1.written;
        border += r2.border_edges;
        reused += r2.reused;
    }
    assert!(compared > 10_000, "the block went in: {compared}");
    assert!(
        reused * 10 > border * 8,
        "most edges reuse: {reused} of {border}"
    );
    // Forgotten, or turned off: every border edge searches again.
    let mut o1 = [Penetration::default(); 125];
    let (cols, n) = brute_force_inside(&bb, &moved);
    let again = penetration_depth(&moved, &g, &bb, &cols[..n], &m, &mut reuse, &mut o1);
    assert!(
        again.border_edges > 0 && again.reused == again.hits,
        "{again:?}"
    );
    reuse.set_reuse(false);
    let off = penetration_depth(&moved, &g, &bb, &cols[..n], &m, &mut reuse, &mut o1);
    assert_eq!(off.reused, 0);
    reuse.set_reuse(true);
    reuse.forget_crossings();
    let forgot = penetration_depth(&moved, &g, &bb, &cols[..n], &m, &mut reuse, &mut o1);
    assert_eq!((forgot.reused, forgot.hits), (0, again.hits));
}

/// The smallest-id tet of `b` holding `p`, by testing every tet.
fn brute_force_holder(b: &Body<'_, '_>, p: Vec3) -> Option<crate::ids::TetId> {
    (0..b.tet_count())
        .map(crate::ids::TetId::from_idx)
        .find(|&t| {
            let c = b.tet_positions(t).unwrap();
            crate::geom::barycentric(p, c).is_some_and(|w| w.iter().all(|&x| x >= 0.0))
        })
}

/// The points inside `b`, each with the smallest-id tet holding it, by testing every tet.
fn brute_force_inside(b: &Body<'_, '_>, points: &[Vec3; 125]) -> ([Collision; 125], usize) {
    let mut cols = [Collision::default(); 125];
    let mut n = 0;
    for (i, &p) in points.iter().enumerate() {
        if let Some(tet) = brute_force_holder(b, p) {
            cols[n] = Collision {
                node: NodeId::from_idx(i),
                tet,
            };
            n += 1;
        }
    }
    (cols, n)
}

/// Where reuse is not exact, and where its `on_edge` check keeps it exact: B is a block with
/// a slot cut into its top (a U: walls at x < -0.25 and x > 0.25 above z = 0), A one long tet
/// lying along x through the walls. The first call puts A's node 0 in the right wall with
/// its other nodes outside to the right: its border edges leave through the right wall's
/// outer face. Then node 0 jumps into the left wall:
/// - with the other nodes in the slot, the remembered face is crossed only past them, is not
///   taken, and the search gives the left wall's inner face: the exact depth;
/// - with the other nodes past the right wall, the edges still cross the remembered face, on
///   the edge, so it is taken, though the line first leaves B at the left wall's inner face:
///   reuse gives a real crossing of the edge with B's surface, not the first one (the fold
///   [`DepthScratch::with_crossings`] warns of).
#[test]
fn reuse_keeps_a_face_past_a_fold_only_when_the_edge_still_crosses_it() {
    let mut b = Store::<125, 384>::block(4, 0.25, Vec3::splat(-0.5));
    let mut kept = 0;
    for k in 0..b.t {
        let c = b.tet_nodes[k]
            .iter()
            .fold(Vec3::ZERO, |s, &i| s + b.positions[i as usize])
            / 4.0;
        if !(c.x.abs() < 0.25 && c.z > 0.0) {
            b.tet_nodes[kept] = b.tet_nodes[k];
            kept += 1;
        }
    }
    b.t = kept;
    let bm = b.mesh();
    let bb = Body::fixed(&bm);
    let mut a = Store::<4, 1>::empty();
    a.tet_nodes[0] = [0, 1, 2, 3];
    (a.n, a.t) = (4, 1);
    a.positions = [
        Vec3::new(0.4, 0.1, 0.3),
        Vec3::new(0.7, 0.1, 0.3),
        Vec3::new(0.7, 0.12, 0.3),
        Vec3::new(0.7, 0.1, 0.32),
    ];
    let am = a.mesh();
    let mut go = [0u32; 5];
    let mut ga = [NodeId::NONE; 12];
    let g = NodeGraph::build(&am, &mut go, &mut ga).unwrap();
    let (mut s1, mut q1) = ([NodeSlot::default(); 4], [NodeId::NONE; 4]);
    let (mut s2, mut q2) = ([NodeSlot::default(); 4], [NodeId::NONE; 4]);
    let mut memo = [Crossing::default(); 12];
    let m = Method::Traced { max_steps: 64 };
    // Node 0's depth searched and reused, after a first call at the right wall.
    let depths = |s1: &mut [NodeSlot; 4], q1: &mut [NodeId; 4], s2, q2, memo, moved: [Vec3; 4]| {
        let mut search = DepthScratch::new(s1, q1);
        let mut reuse = DepthScratch::with_crossings(s2, q2, memo);
        reuse.set_reuse(true);
        let mut out = [Penetration::default(); 4];
        let held = |p: Vec3| brute_force_holder(&bb, p).expect("inside the U");
        let first = [Collision {
            node: NodeId(0),
            tet: held(a.positions[0]),
        }];
        let r = penetration_depth(&a.positions, &g, &bb, &first, &m, &mut reuse, &mut out);
        assert_eq!((r.hits, r.reused), (3, 0));
        // 0.1 to the right wall's outer face (its vertex normals lean up near the top).
        assert!(
            (out[0].depth - 0.1).abs() < 0.01 && out[0].dir.x > 0.95,
            "{:?}",
            out[0]
        );
        let now = [Collision {
            node: NodeId(0),
            tet: held(moved[0]),
        }];
        let r = penetration_depth(&moved, &g, &bb, &now, &m, &mut search, &mut out);
        assert_eq!(r.hits, 3);
        let searched = out[0];
        let r = penetration_depth(&moved, &g, &bb, &now, &m, &mut reuse, &mut out);
        (searched, out[0], r.reused)
    };
    let left = Vec3::new(-0.4, 0.1, 0.3);
    let in_slot = [
        left,
        Vec3::new(0.1, 0.1, 0.3),
        a.positions[2] - Vec3::X * 0.6,
        a.positions[3] - Vec3::X * 0.6,
    ];
    let (s, r, reused) = depths(&mut s1, &mut q1, &mut s2, &mut q2, &mut memo, in_slot);
    assert_eq!(reused, 0);
    assert_eq!((s.depth.to_bits(), s.dir), (r.depth.to_bits(), r.dir));
    assert!(
        (s.depth - 0.15).abs() < 0.02,
        "the left wall's inner face: {s:?}"
    );
    let past = [left, a.positions[1], a.positions[2], a.positions[3]];
    let (mut s1, mut q1) = ([NodeSlot::default(); 4], [NodeId::NONE; 4]);
    let (mut s2, mut q2) = ([NodeSlot::default(); 4], [NodeId::NONE; 4]);
    let mut memo = [Crossing::default(); 12];
    let (s, r, reused) = depths(&mut s1, &mut q1, &mut s2, &mut q2, &mut memo, past);
    assert!(
        (s.depth - 0.15).abs() < 0.02,
        "search: the left wall's inner face: {s:?}"
    );
    assert!(reused > 0, "the remembered face is still crossed");
    assert!(
        r.depth > 0.85,
        "reuse: the right wall's outer face, 0.9 away: {r:?}"
    );
}

/// One scratch through calls with different collision lists gives every call the result of a
/// fresh scratch (report and penetrations, bit for bit): no mark of an earlier call counts,
/// also when the stamp wraps and comes back to the value of an earlier call whose marks are
/// still in the slots (the wrap clears them). Lists: all 100 nodes inside B; the lowest two
/// levels (their upward edges end inside B: no depth); the highest two; all, with one
/// collision repeated and one beyond the slots.
#[test]
fn marks_of_earlier_calls_never_count() {
    let z0 = TOP - 0.17;
    let mut f = fixture(z0);
    let mut out = [Penetration::default(); 125];
    let (_, cols, n) = run(&mut f, false, 125, &mut out);
    assert_eq!(n, 100);
    let a = f.a.mesh();
    let b = f.b.mesh();
    let bb = Body::fixed(&b);
    let mut go = [0u32; 126];
    let mut ga = [NodeId::NONE; 1208];
    let g = NodeGraph::build(&a, &mut go, &mut ga).unwrap();
    let mut lists = [[Collision::default(); 102]; 4];
    let mut lens = [0usize; 4];
    for c in &cols[..n] {
        let low = a.positions()[c.node.idx()].z < z0 + 0.075;
        for (l, keep) in [true, low, !low, true].into_iter().enumerate() {
            if keep {
                lists[l][lens[l]] = *c;
                lens[l] += 1;
            }
        }
    }
    lists[3][lens[3]] = cols[7];
    lists[3][lens[3] + 1] = Collision {
        node: NodeId(500),
        tet: cols[0].tet,
    };
    lens[3] += 2;
    assert_eq!(lens, [100, 50, 50, 102]);
    let m = Method::Traced { max_steps: 64 };
    let (mut s, mut q) = ([NodeSlot::default(); 125], [NodeId::NONE; 125]);
    let mut kept = DepthScratch::new(&mut s, &mut q);
    for (call, l) in [0, 1, 1, 2, 0, 3, 1, 0].into_iter().enumerate() {
        if call == 2 {
            // The next call wraps to the first call's stamp; that call marked the upper
            // levels, which the calls since have not touched.
            kept.set_stamp(u32::MAX);
        }
        let list = &lists[l][..lens[l]];
        let mut o1 = [Penetration::default(); 125];
        let r1 = penetration_depth(a.positions(), &g, &bb, list, &m, &mut kept, &mut o1);
        let (mut s2, mut q2) = ([NodeSlot::default(); 125], [NodeId::NONE; 125]);
        let mut fresh = DepthScratch::new(&mut s2, &mut q2);
        let mut o2 = [Penetration::default(); 125];
        let r2 = penetration_depth(a.positions(), &g, &bb, list, &m, &mut fresh, &mut o2);
        assert_eq!(r1, r2, "call {call}");
        let expect = [(100, 0, 0), (0, 50, 0), (50, 0, 0), (101, 0, 1)][l];
        assert_eq!(
            (r1.written, r1.unreached, r1.out_of_range),
            expect,
            "call {call}"
        );
        for (x, y) in o1[..r1.written].iter().zip(&o2[..r2.written]) {
            assert_eq!(
                (x.node, x.tet, x.layer),
                (y.node, y.tet, y.layer),
                "call {call}"
            );
            assert_eq!(x.depth.to_bits(), y.depth.to_bits(), "call {call}");
            assert_eq!(
                x.dir.to_array().map(f32::to_bits),
                y.dir.to_array().map(f32::to_bits),
                "call {call}"
            );
            let z = a.positions()[x.node.idx()].z;
            assert!((x.depth - (TOP - z)).abs() < 1e-5, "call {call}: {x:?}");
        }
    }
}

/// The line from inside the 12-tet cube straight up leaves it through one face of its top.
#[test]
fn line_up_through_the_cube_leaves_through_one_top_face() {
    use super::surface::{exit_values, hit_on_face, SurfaceHit};
    let mut store = Store::<9, 12>::cube12(1.0, Vec3::ZERO);
    let mesh = store.refinable_mesh();
    let body = Body::fixed(&mesh);

    let (p, q) = (Vec3::new(0.1, 0.2, 0.0), Vec3::new(0.1, 0.2, 1.0));
    let mut hits: [Option<SurfaceHit>; 12] = [None; 12];
    let mut n = 0;
    for t in (0..12).map(crate::ids::TetId) {
        for f in (0..4).filter(|&f| mesh.is_boundary_face(t, f)) {
            if let Some(e) = exit_values(&body, t, f, p, q) {
                if let Some(hit) = hit_on_face(&body, t, f, e, p, q) {
                    hits[n] = Some(hit);
                    n += 1;
                }
            }
        }
    }
    assert_eq!(n, 1);
    let hit = hits[0].unwrap();
    assert!((hit.point - Vec3::new(0.1, 0.2, 0.5)).length() < 1e-6);
    assert!((hit.s - 0.5).abs() < 1e-6 && hit.normal.z > 0.5);
}
