//! The contact search of `World::simulate` (`Hierarchy::nearest_visible`: branch and bound over
//! the nodes holding surface) against the exhaustive search over every visible triangle near
//! the tool (`tetradrill_tests::search`) and the v_list's triangles, after random drilling on
//! the block and on the cow: the same triangle, hence the same contact plane bit for bit, at
//! every pose; hints never change the answer; the node bound keeps the previous plane and
//! counts it; the candidate tets are those whose box meets the zone.

use glam::Vec3;
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use tetradrill_core::drill::DrillParams;
use tetradrill_core::force::{closest_point_on_triangle, sphere_contact};
use tetradrill_core::hash::Aabb;
use tetradrill_core::hierarchy::{FaceRef, Hierarchy, NearestQuery, SphereMemo, SphereSlot};
use tetradrill_core::mesh::Mesh;
use tetradrill_core::servo::{World, WorldSizes};
use tetradrill_core::TetId;
use tetradrill_tests::search::{
    block_mesh, exhaustive, exhaustive_uncut, on_block4, skipped, Store,
};
use tetradrill_tests::tetgen_reader::tetgen;

/// An oracle sharing no walk with the hierarchy's: the v_list's triangles of the candidate
/// trees, closest within reach. Returns the squared distance.
fn from_vlist(h: &Hierarchy<'_>, mesh: &Mesh<'_>, cands: &[TetId], c: Vec3, reach: f32) -> f32 {
    from_vlist_uncut(h, mesh, cands, c, reach, None)
}

/// [`from_vlist`] for a burr cutting with radius `cut`.
fn from_vlist_uncut(
    h: &Hierarchy<'_>,
    mesh: &Mesh<'_>,
    cands: &[TetId],
    c: Vec3,
    reach: f32,
    cut: Option<f32>,
) -> f32 {
    let mut best = f32::INFINITY;
    h.for_each_visible(mesh, |vt| {
        if cands.binary_search(&vt.tet).is_err() || skipped(vt.corners, c, cut) {
            return;
        }
        let d2 = (c - closest_point_on_triangle(c, vt.corners)).length_squared();
        if d2 <= reach * reach && d2 < best {
            best = d2;
        }
    });
    best
}

/// Checks the world's contact after a `simulate` at `c` against the exhaustive search.
/// `cutting`: the step ran with the drill on (the burr's cutting rule applies).
fn check_contact(
    world: &World<'_>,
    c: Vec3,
    radius: f32,
    reach: f32,
    cutting: bool,
    rng: &mut StdRng,
) {
    let (h, mesh) = (world.hierarchy(), world.mesh());
    let mut cands = world.candidates().to_vec();
    cands.sort_unstable();
    let cut = cutting.then_some(radius);
    let want = exhaustive_uncut(h, mesh, &cands, c, radius + reach, cut);
    let got = world.contact();
    if cutting && got.valid {
        // A cutting burr is never pushed through material: it is not behind its contact
        // face, so the depth stays within the radius.
        assert!(
            got.depth <= radius * (1.0 + 1e-5),
            "depth {} at {c}",
            got.depth
        );
    }
    match want {
        None => assert!(!got.valid, "contact found where there is none at {c}"),
        Some((d2, _, tri)) => {
            let sc = sphere_contact(c, radius, [tri]);
            assert_eq!(got.valid, sc.normal != Vec3::ZERO, "at {c}");
            assert_eq!(got.point.to_array(), sc.point.to_array(), "point at {c}");
            assert_eq!(got.normal.to_array(), sc.normal.to_array(), "normal at {c}");
            assert_eq!(got.depth.to_bits(), sc.depth.to_bits(), "depth at {c}");
            assert_eq!(
                from_vlist_uncut(h, mesh, &cands, c, radius + reach, cut),
                d2,
                "v_list at {c}"
            );
        }
    }
    // Hints (any visible face, or a stale one) never change the answer.
    let plain = h.nearest_uncut(mesh, &cands, c, radius + reach, cut, None, u32::MAX);
    assert!(plain.complete);
    assert_eq!(plain.d2, want.map_or(f32::INFINITY, |w| w.0));
    let key =
        |t: Option<tetradrill_core::hierarchy::VisibleTri>| t.map(|v| (v.tet, v.index, v.face));
    assert_eq!(key(plain.tri), want.map(|w| (w.1.tet, w.1.index, w.1.face)));
    // Any starting tree gives the same answer when the search completes.
    let start = rng.gen_range(0..=cands.len());
    let from = h.nearest_uncut_from(mesh, &cands, start, c, radius + reach, cut, None, u32::MAX);
    assert!(from.complete);
    assert_eq!(key(from.tri), key(plain.tri), "start {start} at {c}");
    assert_eq!(from.d2.to_bits(), plain.d2.to_bits());
    let vl = h.vlist();
    if !vl.is_empty() {
        let e = vl[rng.gen_range(0..vl.len())];
        let hint = FaceRef {
            tet: e.tet,
            index: e.index,
            face: rng.gen_range(0..4),
        };
        let hinted = h.nearest_uncut(mesh, &cands, c, radius + reach, cut, Some(hint), u32::MAX);
        assert_eq!(key(hinted.tri), key(plain.tri), "hint {hint:?} at {c}");
        assert_eq!(hinted.d2.to_bits(), plain.d2.to_bits());
    }
    // A sphere memo changes nothing: not the answer, the counts or the resume place, bounded
    // or not, whether tiny (keys evict each other) or not; filled by a first search, read by
    // a second (deterministic seeds: the big one is read whenever a node is tested).
    for size in [5, 1 << 12] {
        let mut slots = vec![SphereSlot::EMPTY; size];
        let mut memo = SphereMemo::new(&mut slots);
        for max_nodes in [u32::MAX, rng.gen_range(1..64)] {
            let q = NearestQuery {
                tets: &cands,
                start,
                centre: c,
                reach: radius + reach,
                cut,
                hints: &[],
                max_nodes,
            };
            let bare =
                h.nearest_uncut_from(mesh, &cands, start, c, radius + reach, cut, None, max_nodes);
            for pass in 0..2 {
                let got = h.nearest(mesh, &q, &mut memo);
                assert_eq!(got, bare, "memo {size}, pass {pass} at {c}");
            }
        }
        assert!(
            size < 1 << 12 || memo.hits() > 0 || plain.nodes == 0,
            "the memo was never read at {c}"
        );
    }
}

/// Drills random strokes starting at `starts` (burr entering along `-inward`), checking the
/// contact at every step, then probes random poses around the drilled region.
fn drill_and_probe(mesh: Mesh<'_>, starts: &[(Vec3, Vec3)], radius: f32, depth: u8, seed: u64) {
    let mut st = Store::new(mesh.tet_count(), 1 << 19);
    let mut world = st.world(mesh);
    let params = DrillParams {
        max_depth: depth,
        min_area: 0.0,
        budget: 20_000,
    };
    let reach = 0.5 * radius;
    let mut rng = StdRng::seed_from_u64(seed);
    let mut max_nodes = 0u32;
    let mut visited = Vec::new();
    for &(s, inward) in starts {
        let side = inward.any_orthonormal_vector();
        let mut c = s - inward * radius;
        let mut dir = (inward + side * rng.gen_range(-1.0..1.0f32)).normalize();
        for step in 0..60 {
            let on = step < 45;
            let rep = world.simulate(c, radius, reach, on, &params);
            check_contact(&world, c, radius, reach, on, &mut rng);
            max_nodes = max_nodes.max(rep.contact_nodes);
            visited.push(c);
            c += dir * (radius * rng.gen_range(0.05..0.4f32));
            if rng.gen_bool(0.2) {
                let turn = Vec3::new(
                    rng.gen_range(-1.0..1.0),
                    rng.gen_range(-1.0..1.0),
                    rng.gen_range(-1.0..1.0),
                );
                dir = (dir + turn * 0.7).normalize_or(dir);
            }
        }
    }
    while world.pending() > 0 {
        world.simulate(visited[0], radius, reach, false, &params);
    }
    world.hierarchy().validate(world.mesh()).unwrap();
    for _ in 0..400 {
        let base = visited[rng.gen_range(0..visited.len())];
        let off = Vec3::new(
            rng.gen_range(-1.0..1.0),
            rng.gen_range(-1.0..1.0),
            rng.gen_range(-1.0..1.0),
        ) * (2.0 * radius);
        let c = base + off;
        let rep = world.simulate(c, radius, reach, false, &params);
        check_contact(&world, c, radius, reach, false, &mut rng);
        max_nodes = max_nodes.max(rep.contact_nodes);
    }
    assert_eq!(world.saturations().contact, 0, "the node bound was reached");
    eprintln!("most nodes tested by one contact search: {max_nodes}");
}

#[test]
fn contact_is_the_exhaustive_closest_triangle_on_the_block() {
    let mut om = block_mesh(6);
    let mesh = om.view();
    let starts: Vec<(Vec3, Vec3)> = vec![
        (Vec3::new(0.0, 0.0, 0.5), Vec3::NEG_Z),
        (Vec3::new(0.2, -0.1, 0.5), Vec3::NEG_Z),
        (Vec3::new(0.5, 0.1, 0.0), Vec3::NEG_X),
        (Vec3::new(-0.3, -0.5, -0.2), Vec3::Y),
    ];
    drill_and_probe(mesh, &starts, 0.08, 4, 11);
}

#[test]
fn contact_is_the_exhaustive_closest_triangle_on_the_cow() {
    let mut om = tetgen("models/spot_tetgen_q1.414.node");
    let mesh = om.view();
    let p = mesh.positions();
    let lo = p.iter().fold(Vec3::splat(f32::MAX), |a, &b| a.min(b));
    let hi = p.iter().fold(Vec3::splat(f32::MIN), |a, &b| a.max(b));
    let radius = 0.03 * (hi - lo).length();
    let mut rng = StdRng::seed_from_u64(5);
    let boundary: Vec<usize> = (0..mesh.node_count())
        .filter(|&i| mesh.nodes()[i].boundary())
        .collect();
    let starts: Vec<(Vec3, Vec3)> = (0..4)
        .map(|_| {
            let i = boundary[rng.gen_range(0..boundary.len())];
            let n = mesh.normal(tetradrill_core::NodeId::from_idx(i));
            (p[i], -n)
        })
        .collect();
    drill_and_probe(mesh, &starts, radius, 3, 12);
}

#[test]
fn the_node_bound_gives_a_true_face_never_too_deep_and_counts() {
    on_block4(|world, params, r, reach| {
        // No hint and a bound of zero nodes: nothing found, the previous (empty) contact stays.
        world.set_contact_max_nodes(0);
        let rep = world.simulate(Vec3::new(0.0, 0.0, 0.55), r, reach, false, params);
        assert!(rep.contact_saturated && !world.contact().valid);
        assert_eq!(world.saturations().contact, 1);
        world.set_contact_max_nodes(tetradrill_core::servo::CONTACT_MAX_NODES);
        for k in 0..20 {
            let c = Vec3::new(0.0, 0.0, 0.55 - 0.01 * k as f32);
            world.simulate(c, r, reach, true, params);
        }
        assert!(world.contact().valid);
        let mut saturated = 0;
        for (k, c) in [
            Vec3::new(0.02, 0.0, 0.4),
            Vec3::new(0.03, 0.01, 0.38),
            Vec3::new(-0.02, 0.02, 0.36),
        ]
        .into_iter()
        .enumerate()
        {
            world.set_contact_max_nodes(3);
            let rep = world.simulate(c, r, reach, false, params);
            assert!(rep.contact_nodes <= 3, "{}", rep.contact_nodes);
            saturated += rep.contact_saturated as u32;
            let got = *world.contact();
            assert!(got.valid, "the last step's triangle answers at step {k}");
            assert_eq!(
                got.centre, c,
                "the answer is for this step's position, not a stale plane"
            );
            // Oracle 1 (the v_list's triangles, no walk): the exact closest distance.
            let cands: Vec<TetId> = {
                let mut v = world.candidates().to_vec();
                v.sort();
                v
            };
            let (h, m) = (world.hierarchy(), world.mesh());
            let exact = from_vlist(h, m, &cands, c, r + reach).sqrt();
            // The answer's point lies on a visible triangle (brute force over all of them) ...
            let mut on_visible = false;
            h.for_each_visible(m, |vt| {
                let q = closest_point_on_triangle(got.point, vt.corners);
                on_visible |= q.distance(got.point) < 1e-5;
            });
            assert!(
                on_visible,
                "the contact point must lie on the drilled surface"
            );
            // ... and it is no closer than the exact closest one: the depth is never too deep.
            let d = got.point.distance(c);
            assert!(
                d >= exact - 1e-5,
                "step {k}: {d} closer than the exact {exact}"
            );
            let exact_depth = r - exact;
            assert!(
                got.depth <= exact_depth + 1e-5,
                "{} vs {exact_depth}",
                got.depth
            );
        }
        assert!(saturated > 0, "a bound of 3 nodes must stop some searches");
        assert_eq!(world.saturations().contact, 1 + saturated);
        // Without the bound the search completes and matches the exhaustive walk.
        world.set_contact_max_nodes(tetradrill_core::servo::CONTACT_MAX_NODES);
        let c = Vec3::new(0.02, 0.0, 0.4);
        let rep = world.simulate(c, r, reach, false, params);
        assert!(!rep.contact_saturated);
        assert_eq!(world.saturations().contact, 1 + saturated);
        let best = exhaustive(
            world.hierarchy(),
            world.mesh(),
            world.candidates(),
            c,
            r + reach,
        )
        .unwrap();
        let x = closest_point_on_triangle(c, best.2);
        assert_eq!(world.contact().point, x);
    });
}

/// The candidate list of `World::simulate` is the tets whose box meets the box
/// `radius + reach` around the tool, each once, against a brute force over every tet's
/// corners (steps with the drill off, where no burr position adds to the zone); and a world
/// whose tet boxes are stored gives every step the same candidates in the same order, the
/// same contact and report as a twin given no box storage (each box then made from the
/// corners), a hash table of another size (the order depends on the mesh and the zone, not
/// on the bucket count) and a sphere memo of 5 slots instead of 4,096, drilling on and off.
#[test]
fn candidates_are_the_tets_whose_box_meets_the_zone_with_or_without_stored_boxes() {
    let mut om = block_mesh(5);
    let mut twin_mesh = block_mesh(5);
    let mesh = om.view();
    let mut st = Store::new(mesh.tet_count(), 1 << 16);
    let mut bare_sizes = WorldSizes::new(mesh.tet_count(), 1 << 16);
    bare_sizes.tet_boxes = 0;
    bare_sizes.hash_starts /= 3;
    bare_sizes.sphere_memo = 5;
    let mut bare = Store::sized(bare_sizes);
    let positions: Vec<[Vec3; 4]> = (0..mesh.tet_count())
        .map(|t| mesh.tet_positions(TetId::from_idx(t)))
        .collect();
    let mut world = st.world(mesh);
    let mut twin = bare.world(twin_mesh.view());
    let params = DrillParams {
        max_depth: 3,
        min_area: 0.0,
        budget: 3_000,
    };
    let (radius, reach) = (0.09f32, 0.045f32);
    let mut rng = StdRng::seed_from_u64(21);
    let mut c = Vec3::new(0.0, 0.0, 0.6);
    let (mut checked, mut nonempty) = (0, 0);
    for step in 0..400 {
        let on = step % 50 < 30;
        let a = world.simulate(c, radius, reach, on, &params);
        let b = twin.simulate(c, radius, reach, on, &params);
        assert_eq!(world.candidates(), twin.candidates(), "step {step}");
        assert_eq!(world.contact(), twin.contact(), "step {step}");
        // The same report, but for where the candidates came from (the twin has no stored
        // boxes, so no zone memo).
        assert!(!b.candidates_memo);
        let a = tetradrill_core::servo::SimReport {
            candidates_memo: false,
            ..a
        };
        assert_eq!(a, b, "step {step}");
        if !on {
            let zone = Aabb::point(c).grown(radius + reach);
            let want: Vec<TetId> = (0..positions.len())
                .filter(|&t| {
                    let p = &positions[t];
                    (0..3).all(|ax| {
                        let lo = p.iter().map(|q| q[ax]).fold(f32::INFINITY, f32::min);
                        let hi = p.iter().map(|q| q[ax]).fold(f32::NEG_INFINITY, f32::max);
                        lo <= zone.max[ax] && hi >= zone.min[ax]
                    })
                })
                .map(TetId::from_idx)
                .collect();
            let mut got = world.candidates().to_vec();
            got.sort_unstable();
            assert_eq!(got, want, "step {step} at {c}");
            checked += 1;
            nonempty += usize::from(!want.is_empty());
        }
        c += Vec3::new(
            rng.gen_range(-1.0..1.0),
            rng.gen_range(-1.0..1.0),
            rng.gen_range(-1.0..0.6),
        ) * 0.02;
        c = c.clamp(Vec3::splat(-0.7), Vec3::splat(0.7));
    }
    assert!(checked > 100 && nonempty > 50, "{checked} {nonempty}");
}
