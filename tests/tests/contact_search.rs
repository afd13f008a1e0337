//! The contact search of `World::simulate` (`Hierarchy::nearest_visible`: branch and bound over
//! the nodes holding surface) against the exhaustive search over every visible triangle near
//! the tool, after random drilling on the block and on the cow: the same triangle, hence the
//! same contact plane bit for bit, at every pose; hints never change the answer; the node
//! bound keeps the previous plane and counts it.

use glam::Vec3;
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use tetradrill::owned::OwnedMesh;
use tetradrill_core::builtin::{block, block_counts};
use tetradrill_core::drill::{DrillParams, Pending};
use tetradrill_core::force::{closest_point_on_triangle, sphere_contact};
use tetradrill_core::hash::{Aabb, HashEntry};
use tetradrill_core::hierarchy::{
    FaceRef, HNode, Hierarchy, HierarchyStorage, Kept, Nearest, NearestCursor, NearestQuery,
    SphereMemo, SphereSlot, VEntry, VisibleTri,
};
use tetradrill_core::mesh::{BuildOptions, Mesh};
use tetradrill_core::servo::{World, WorldSizes, WorldStorage};
use tetradrill_core::TetId;

/// Storage for one world.
struct Store {
    hash_starts: Vec<u32>,
    hash_entries: Vec<HashEntry>,
    tet_boxes: Vec<Aabb>,
    roots: Vec<HNode>,
    arena: Vec<HNode>,
    vlist: Vec<VEntry>,
    pending: Vec<Pending>,
    candidates: Vec<TetId>,
    sphere_memo: Vec<SphereSlot>,
}

impl Store {
    fn new(tets: usize, arena: usize) -> Self {
        let s = WorldSizes::new(tets, arena);
        Self {
            hash_starts: vec![0; s.hash_starts],
            hash_entries: vec![HashEntry::default(); s.hash_entries],
            tet_boxes: vec![Aabb::point(Vec3::ZERO); s.tet_boxes],
            roots: vec![HNode::default(); s.roots],
            arena: vec![HNode::default(); s.arena],
            vlist: vec![VEntry::default(); s.vlist],
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
                hierarchy: HierarchyStorage {
                    roots: &mut self.roots,
                    arena: &mut self.arena,
                    vlist: &mut self.vlist,
                },
                pending: &mut self.pending,
                candidates: &mut self.candidates,
                sphere_memo: &mut self.sphere_memo,
            },
        )
        .unwrap()
    }
}

fn block_mesh(n: usize) -> OwnedMesh {
    let (nn, nt) = block_counts(n);
    let mut p = vec![Vec3::ZERO; nn];
    let mut t = vec![[0u32; 4]; nt];
    block(n, 1.0 / n as f32, Vec3::splat(-0.5), &mut p, &mut t).unwrap();
    OwnedMesh::build(p, &t, BuildOptions::default()).unwrap()
}

/// A minimal TetGen `.node`/`.ele` reader (the test's own).
fn tetgen(rel: &str) -> OwnedMesh {
    let node = tetradrill_tests::mesh(rel);
    let ele = node.with_extension("ele");
    let nums = |path: &std::path::Path| -> Vec<Vec<f64>> {
        std::fs::read_to_string(path)
            .unwrap()
            .lines()
            .map(|l| l.split('#').next().unwrap_or(""))
            .filter(|l| !l.trim().is_empty())
            .map(|l| {
                l.split_whitespace()
                    .map(|w| w.parse::<f64>().unwrap())
                    .collect()
            })
            .collect()
    };
    let (nr, er) = (nums(&node), nums(&ele));
    let n = nr[0][0] as usize;
    let base = nr[1][0] as u32;
    let p: Vec<Vec3> = nr[1..=n]
        .iter()
        .map(|r| Vec3::new(r[1] as f32, r[2] as f32, r[3] as f32))
        .collect();
    let m = er[0][0] as usize;
    let t: Vec<[u32; 4]> = er[1..=m]
        .iter()
        .map(|r| std::array::from_fn(|k| r[k + 1] as u32 - base))
        .collect();
    OwnedMesh::build(p, &t, BuildOptions::default()).unwrap()
}

/// The exhaustive search: every visible triangle `for_each_visible_in` yields near the tool,
/// the closest within reach, ties to the smallest (tet, index, face).
fn exhaustive(
    h: &Hierarchy<'_>,
    mesh: &Mesh<'_>,
    cands: &[TetId],
    c: Vec3,
    reach: f32,
) -> Option<(f32, FaceRef, [Vec3; 3])> {
    exhaustive_uncut(h, mesh, cands, c, reach, None)
}

/// The rule of a cutting burr of radius `cut`, written out here: a triangle is skipped when
/// its three corners are within `cut` of `c`, or when `c` is behind its outward plane at its
/// closest point.
fn skipped(corners: [Vec3; 3], c: Vec3, cut: Option<f32>) -> bool {
    let Some(r) = cut else { return false };
    let all_in = corners.iter().all(|q| (*q - c).length() <= r);
    let x = closest_point_on_triangle(c, corners);
    let n = (corners[1] - corners[0]).cross(corners[2] - corners[0]);
    all_in || (c - x).dot(n) < 0.0
}

/// [`exhaustive`] for a burr cutting with radius `cut`.
fn exhaustive_uncut(
    h: &Hierarchy<'_>,
    mesh: &Mesh<'_>,
    cands: &[TetId],
    c: Vec3,
    reach: f32,
    cut: Option<f32>,
) -> Option<(f32, FaceRef, [Vec3; 3])> {
    let mut best: Option<(f32, FaceRef, [Vec3; 3])> = None;
    h.for_each_visible_in(mesh, cands, Some((c, reach)), |vt| {
        if skipped(vt.corners, c, cut) {
            return;
        }
        let d2 = (c - closest_point_on_triangle(c, vt.corners)).length_squared();
        let within = d2 <= reach * reach; // false for NaN too
        if !within {
            return;
        }
        let key = FaceRef {
            tet: vt.tet,
            index: vt.index,
            face: vt.face,
        };
        if best.is_none_or(|(bd, bk, _)| d2 < bd || (d2 == bd && key < bk)) {
            best = Some((d2, key, vt.corners));
        }
    });
    best
}

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
        .filter(|&i| mesh.nodes()[i].boundary)
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

/// Runs `f` on a fresh world over the 4 x 4 x 4 block (drill depth 3, a budget that never
/// runs out) with a burr of radius 0.1 and reach 0.05: `f(world, params, r, reach)`.
fn on_block4(f: impl FnOnce(&mut World<'_>, &DrillParams, f32, f32)) {
    let mut om = block_mesh(4);
    let mesh = om.view();
    let mut st = Store::new(mesh.tet_count(), 1 << 16);
    let mut world = st.world(mesh);
    let params = DrillParams {
        max_depth: 3,
        min_area: 0.0,
        budget: 100_000,
    };
    f(&mut world, &params, 0.1, 0.05);
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
    let mut bare = Store::new(mesh.tet_count(), 1 << 16);
    bare.tet_boxes.clear();
    bare.hash_starts.truncate(bare.hash_starts.len() / 3);
    bare.sphere_memo.truncate(5);
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

/// Drills a cavity into `world` (the burr plunged from the top face, then dragged sideways)
/// and returns six poses in and around it, for the held-pose tests.
fn drill_cavity(world: &mut World<'_>, params: &DrillParams, r: f32, reach: f32) -> [Vec3; 6] {
    for k in 0..40 {
        let c = if k < 20 {
            Vec3::new(0.0, 0.0, 0.55 - 0.01 * k as f32)
        } else {
            Vec3::new(0.01 * (k - 20) as f32, 0.0, 0.36)
        };
        world.simulate(c, r, reach, true, params);
    }
    [
        Vec3::new(0.02, 0.0, 0.4),
        Vec3::new(0.1, 0.03, 0.33),
        Vec3::new(-0.03, 0.02, 0.42),
        Vec3::new(0.15, -0.02, 0.37),
        Vec3::new(0.05, -0.05, 0.3),
        Vec3::new(0.12, 0.06, 0.38),
    ]
}

/// One step of a chain of searches at a held pose `c`: its answer becomes the next hint, and
/// it never moves away from the last one nor comes closer than the `exact` squared distance.
fn follow(
    near: &Nearest,
    hint: &mut Option<FaceRef>,
    last: &mut f32,
    exact: f32,
    c: Vec3,
    step: usize,
) {
    if let Some(vt) = near.tri {
        *hint = Some(FaceRef {
            tet: vt.tet,
            index: vt.index,
            face: vt.face,
        });
        assert!(near.d2 <= *last, "{c}: step {step} moved away");
        assert!(near.d2 >= exact, "{c}: closer than the exhaustive answer");
        *last = near.d2;
    }
}

/// Bounded searches at a held pose, each hinted with the last answer: started after the tree
/// where the last one stopped (`Nearest::resume`, as `World::simulate` does), the answer never
/// moves farther away, is never closer than the exhaustive one, and ends at least as close as
/// the same chain always started at the first tree, strictly closer at some poses. (It need
/// not reach the exhaustive answer: a tree whose depth-first prefix within the bound misses
/// the closest face is never finished.)
#[test]
fn bounded_searches_resumed_where_the_last_stopped_get_closer() {
    on_block4(|world, params, r, reach| {
        let (mut better, mut stopped, mut poses) = (0, 0, 0);
        for c in drill_cavity(world, params, r, reach) {
            world.simulate(c, r, reach, false, params);
            let (h, m) = (world.hierarchy(), world.mesh());
            let cands = world.candidates();
            let Some((exact, _, _)) = exhaustive(h, m, cands, c, r + reach) else {
                continue;
            };
            poses += 1;
            // One chain of 40 searches bounded at 32 nodes; `resume` picks the next start.
            let chain = |resume: bool| {
                let (mut start, mut hint, mut last, mut n_stopped) =
                    (0usize, None, f32::INFINITY, 0);
                for step in 0..40 {
                    let near = h.nearest_uncut_from(m, cands, start, c, r + reach, None, hint, 32);
                    n_stopped += u32::from(!near.complete);
                    follow(&near, &mut hint, &mut last, exact, c, step);
                    if resume {
                        start = near.resume as usize;
                    }
                }
                (last, n_stopped)
            };
            let (resumed, n) = chain(true);
            let (first, _) = chain(false);
            stopped += n;
            assert!(
                resumed <= first,
                "{c}: resumed {resumed} farther than {first}"
            );
            better += u32::from(resumed < first);
        }
        assert!(poses >= 4, "{poses} poses with surface in reach");
        assert!(
            stopped > 100,
            "the bound must stop searches here ({stopped})"
        );
        eprintln!("resumed chains closer at {better} of {poses} poses, {stopped} searches stopped");
        assert!(
            better * 2 >= poses,
            "resuming got closer at {better} of {poses} poses only"
        );
    });
}

/// Bounded searches at a held pose that go on from a cursor (`Hierarchy::nearest_continued`,
/// as `World::simulate` does), each hinted with the last answer: no search tests more nodes
/// than its bound (an expansion is never split), the answer never moves away and is never
/// closer than the exhaustive one, and once a round over the trees has ended (the cursor
/// cleared) the answer is the exhaustive triangle, bit for bit: every tree was walked to the
/// end, pruned at distances no nearer than the closest face. A search that went on from a
/// place and ends its round goes on with a fresh one (`complete` when that ends too).
#[test]
fn continued_searches_finish_every_tree_and_reach_the_exhaustive_answer() {
    on_block4(|world, params, r, reach| {
        let (mut poses, mut rounds, mut went_on) = (0, 0, 0);
        for c in drill_cavity(world, params, r, reach) {
            world.simulate(c, r, reach, false, params);
            let (h, m) = (world.hierarchy(), world.mesh());
            let mut cands = world.candidates().to_vec();
            cands.sort_unstable();
            let Some((exact, key, _)) = exhaustive(h, m, &cands, c, r + reach) else {
                continue;
            };
            poses += 1;
            let mut slots = vec![SphereSlot::EMPTY; 64];
            let mut memo = SphereMemo::new(&mut slots);
            let mut cursor = NearestCursor::new();
            let (mut hint, mut last, mut ended) = (None, f32::INFINITY, false);
            let mut hint_tri = None;
            for step in 0..400 {
                let max_nodes = 12;
                let q = NearestQuery {
                    tets: &cands,
                    start: 0,
                    centre: c,
                    reach: r + reach,
                    cut: None,
                    hints: hint_tri.as_slice(),
                    max_nodes,
                };
                let had_place = cursor.tet().is_some();
                let rounds_before = cursor.rounds();
                let near = h.nearest_continued(m, &q, &mut memo, &mut cursor);
                assert!(
                    near.nodes <= max_nodes,
                    "{c}: step {step}: {} nodes",
                    near.nodes
                );
                went_on += u32::from(had_place);
                follow(&near, &mut hint, &mut last, exact, c, step);
                hint_tri = near.tri.or(hint_tri);
                if ended {
                    assert_eq!(near.d2.to_bits(), exact.to_bits(), "{c}: step {step}");
                    assert_eq!(hint, Some(key), "{c}: step {step}");
                }
                if cursor.rounds() > rounds_before {
                    ended = true;
                }
            }
            assert!(ended, "{c}: no round ended in 400 searches of 12 nodes");
            rounds += cursor.rounds();
        }
        assert!(poses >= 4, "{poses} poses with surface in reach");
        assert!(
            went_on > 100,
            "the bound must stop searches here ({went_on})"
        );
        eprintln!("{rounds} rounds at {poses} poses, {went_on} searches went on");
    });
}

/// Every visible face of the candidate trees, from the v_list (no walk shared with the
/// search): face -> corners.
fn visible_faces(
    h: &Hierarchy<'_>,
    mesh: &Mesh<'_>,
    cands: &[TetId],
) -> std::collections::HashMap<FaceRef, [Vec3; 3]> {
    let mut all = std::collections::HashMap::new();
    h.for_each_visible(mesh, |vt| {
        if cands.binary_search(&vt.tet).is_ok() {
            all.insert(
                FaceRef {
                    tet: vt.tet,
                    index: vt.index,
                    face: vt.face,
                },
                vt.corners,
            );
        }
    });
    all
}

/// The faces a search keeps (`Hierarchy::nearest_continued_keeping`), along a path through a
/// drilled cavity with searches bounded at a few nodes: every kept face is a visible face of
/// the candidate trees, within reach and not skipped by the cutting rule, at the squared
/// distance measured here from the v_list; nearest first, no face twice, at most `KEEP`; the
/// answer is the first of them, never closer than the exhaustive answer, and no farther than the
/// nearest hint still in play; a search that completes gives the exhaustive answer whatever
/// the hints (every tenth search is unbounded). Carrying all the kept faces to the next
/// search as hints ends, summed over the path, strictly closer to the exhaustive answers
/// than carrying the answer alone (what `World::simulate` did before 2026-11-24).
#[test]
fn kept_faces_are_true_faces_nearest_first_and_carry_the_answer_closer() {
    on_block4(|world, params, r, reach| {
        drill_cavity(world, params, r, reach);
        let path: Vec<Vec3> = (0..120)
            .map(|k| {
                let u = k as f32 / 119.0;
                Vec3::new(-0.02 + 0.2 * u, 0.03 * (7.0 * u).sin(), 0.42 - 0.1 * u)
            })
            .collect();
        // Each chain runs the same path with its own cursor and memo; `all_kept` chooses
        // what goes on as hints.
        let mut chain = |all_kept: bool| -> (f64, u32, u32) {
            let mut slots = vec![SphereSlot::EMPTY; 64];
            let mut memo = SphereMemo::new(&mut slots);
            let mut cursor = NearestCursor::new();
            let mut hints: Vec<VisibleTri> = Vec::new();
            let (mut shortfall, mut stopped, mut completed) = (0.0f64, 0u32, 0u32);
            for (step, &c) in path.iter().enumerate() {
                let cut = (step % 3 == 0).then_some(r);
                world.simulate(c, r, reach, false, params);
                let (h, m) = (world.hierarchy(), world.mesh());
                let mut cands = world.candidates().to_vec();
                cands.sort_unstable();
                let faces = visible_faces(h, m, &cands);
                let reach2 = (r + reach) * (r + reach);
                let measure = |k: &FaceRef| -> Option<f32> {
                    let q = faces.get(k)?;
                    let d2 = (c - closest_point_on_triangle(c, *q)).length_squared();
                    (d2 <= reach2 && !skipped(*q, c, cut)).then_some(d2)
                };
                let best_hint = hints
                    .iter()
                    .filter_map(|t| measure(&t.key()))
                    .fold(f32::INFINITY, f32::min);
                let q = NearestQuery {
                    tets: &cands,
                    start: 0,
                    centre: c,
                    reach: r + reach,
                    cut,
                    hints: &hints,
                    max_nodes: if step % 10 == 9 { u32::MAX } else { 24 },
                };
                let mut kept = Kept::new();
                let near = h.nearest_continued_keeping(m, &q, &mut memo, &mut cursor, &mut kept);
                let exact = exhaustive_uncut(h, m, &cands, c, r + reach, cut);
                assert!(kept.len() <= tetradrill_core::hierarchy::KEEP);
                for (i, &(d2, t)) in kept.iter().enumerate() {
                    let k = t.key();
                    assert_eq!(faces.get(&k), Some(&t.corners), "{c}: {k:?} corners");
                    assert_eq!(
                        measure(&k).map(f32::to_bits),
                        Some(d2.to_bits()),
                        "{c}: {k:?}"
                    );
                    if i > 0 {
                        let (pd, pk) = (kept[i - 1].0, kept[i - 1].1.key());
                        assert!(pd < d2 || (pd == d2 && pk < k), "{c}: kept out of order");
                    }
                }
                if let Some(vt) = near.tri {
                    let key = FaceRef {
                        tet: vt.tet,
                        index: vt.index,
                        face: vt.face,
                    };
                    assert_eq!(
                        kept.first().map(|(_, t)| t.key()),
                        Some(key),
                        "{c}: the answer is not the first kept face"
                    );
                    assert!(near.d2 <= best_hint, "{c}: farther than a hint in play");
                }
                match exact {
                    Some((e, key, _)) => {
                        assert!(near.d2 >= e, "{c}: closer than the exhaustive answer");
                        if near.complete {
                            completed += 1;
                            assert_eq!(near.d2.to_bits(), e.to_bits(), "{c}");
                            assert_eq!(
                                near.tri.map(|t| (t.tet, t.index, t.face)),
                                Some((key.tet, key.index, key.face))
                            );
                        }
                        if near.tri.is_some() {
                            shortfall += f64::from(near.d2.sqrt() - e.sqrt());
                        }
                    }
                    None => assert!(near.tri.is_none(), "{c}: a face beyond reach"),
                }
                stopped += u32::from(!near.complete);
                hints = if all_kept {
                    kept.iter().map(|&(_, t)| t).collect()
                } else {
                    near.tri.into_iter().collect()
                };
            }
            (shortfall, stopped, completed)
        };
        let (kept_all, stopped, completed) = chain(true);
        let (answer_only, _, _) = chain(false);
        eprintln!(
            "shortfall summed over the path: kept faces {kept_all:.4}, answer only \
             {answer_only:.4} ({stopped} of 120 searches stopped, {completed} complete)"
        );
        assert!(
            stopped > 60,
            "the bound must stop most searches ({stopped})"
        );
        assert!(completed > 0, "no search completed");
        assert!(
            kept_all < answer_only,
            "kept faces {kept_all} not closer than the answer alone {answer_only}"
        );
    });
}

/// One budget for the whole step (`World::set_tick_budget`). Three worlds drill the same path:
/// without a tick budget, with one too large to bind, and with one a third of the first
/// world's busiest step. The second is the first bit for bit (reports and contacts). In the
/// third, at every step the contact search's bound is what the drill left,
/// `min(contact_max_nodes, (budget - drill work) / CONTACT_NODE_UNITS)`, the search keeps to
/// it, the contact face is never nearer than the exhaustive one, and the drill's work stays within
/// the budget plus its last operation's overshoot.
#[test]
fn a_tick_budget_is_shared_by_the_drill_and_the_contact_search() {
    use tetradrill_core::servo::{SimReport, CONTACT_NODE_UNITS};
    let path: Vec<(Vec3, bool)> = (0..160)
        .map(|k| {
            let u = k as f32 / 159.0;
            let c = if k < 60 {
                Vec3::new(0.0, 0.0, 0.58 - 0.004 * k as f32)
            } else {
                Vec3::new(0.25 * (u - 0.375), 0.04 * (9.0 * u).sin(), 0.34)
            };
            (c, k % 40 < 30)
        })
        .collect();
    let run = |budget: Option<u32>, check: &mut dyn FnMut(&World<'_>, &SimReport, Vec3, bool)| {
        let mut reports = Vec::new();
        on_block4(|world, params, r, reach| {
            world.set_tick_budget(budget);
            assert_eq!(world.tick_budget(), budget);
            for &(c, drill) in &path {
                let rep = world.simulate(c, r, reach, drill, params);
                check(world, &rep, c, drill);
                reports.push((rep, *world.contact()));
            }
        });
        reports
    };
    let plain = run(None, &mut |_, _, _, _| {});
    let roomy = run(Some(u32::MAX), &mut |_, _, _, _| {});
    assert_eq!(plain, roomy, "a budget that never binds changed a step");
    let busiest = plain.iter().map(|(r, _)| r.drill.work).max().unwrap();
    let t = busiest / 3;
    assert!(t > 100, "the path must give the drill work ({busiest})");
    let (mut bound_cut, mut over, mut steps_at_budget, mut kept_plane) = (0, 0u32, 0, 0);
    run(Some(t), &mut |world, rep, c, drill| {
        let left = t.saturating_sub(rep.drill.work) / CONTACT_NODE_UNITS;
        assert_eq!(
            rep.contact_bound,
            left.min(world.contact_max_nodes()),
            "at {c}"
        );
        assert!(rep.contact_nodes <= rep.contact_bound, "at {c}");
        bound_cut += u32::from(rep.contact_bound < world.contact_max_nodes());
        if rep.drill.work >= t {
            steps_at_budget += 1;
            over = over.max(rep.drill.work - t);
        }
        let (h, m) = (world.hierarchy(), world.mesh());
        let mut cands = world.candidates().to_vec();
        cands.sort_unstable();
        let r = 0.1;
        let want = exhaustive_uncut(h, m, &cands, c, r + 0.05, drill.then_some(r));
        let got = world.contact();
        kept_plane += u32::from(got.centre != c);
        if let (true, true, Some((d2, _, _))) = (got.valid, got.centre == c, want) {
            // The contact point is on the face the search chose (unless it found none and
            // kept an older step's plane): never nearer than the exhaustive closest face.
            let d = (c - got.point).length();
            assert!(
                d >= d2.sqrt() * (1.0 - 1e-6),
                "{c}: {d} nearer than {}",
                d2.sqrt()
            );
        }
    });
    eprintln!(
        "tick budget {t} (busiest step {busiest}): {steps_at_budget} steps spent it, \
         overshoot at most {over}, contact bound cut at {bound_cut} steps, an older plane \
         kept at {kept_plane}"
    );
    assert!(
        steps_at_budget > 0 && bound_cut > 0,
        "the budget never bound"
    );
    assert!(over < 256, "the drill overshot the budget by {over} units");
}
