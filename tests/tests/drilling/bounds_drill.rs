//! Worst-case bounds of the servo-path drilling operations (issue #9 item 1): refinement, erase,
//! the drill's budget, the simulation step's counters, the contact search's node bound and the
//! servo force, each driven to the bound its `# Bounded work` / `# Capacity` docs state (full
//! arena, deepest refinement), checking that the work counters it reports stay within that
//! bound and that every capacity saturates, is counted and is never exceeded.
//!
//! The oracles here are written from the documented formulas (Bey's 1:8 split, the
//! per-operation work units of `DrillParams::budget`) and brute force over the meshes; none
//! calls the code it checks to compute the expected value. Where an operation reports no work
//! counter, the test bounds its outputs and says why that is the bound. No wall-clock asserts.

use tetradrill_core::drill::{Drill, DrillParams, Pending, Sphere, WorkCost};
use tetradrill_core::force::{ForceParams, ToolState};
use tetradrill_core::hierarchy::{
    Hierarchy, HierarchyError, HierarchySizes, HierarchyStorage, MAX_DEPTH,
};
use tetradrill_core::mesh::Mesh;
use tetradrill_core::owned::{HierarchyBuffers, WorldBuffers};
use tetradrill_core::servo::{servo_force, ContactState, World, WorldSizes};
use tetradrill_core::{TetId, Vec3};
use tetradrill_tests::load;
use tetradrill_tests::oracle::{add, cross, d3, dot, scale, sub, tet_box, D3};

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
        let r = sub(x, add(p, scale(e, s)));
        dot(r, r).sqrt()
    };
    let edges = seg(a, b).min(seg(b, c)).min(seg(c, a));
    let nn = dot(n, n);
    if nn == 0.0 {
        return edges;
    }
    let h = dot(sub(x, a), n) / nn;
    let y = sub(x, scale(n, h));
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
// Refine and erase
// ------------------------------------------------------------------------------------------

/// A hierarchy's storage from the core's owned-storage layer.
struct HierStore(HierarchyBuffers);

impl HierStore {
    fn new(tets: usize, arena: usize) -> Self {
        Self(HierarchyBuffers::new(HierarchySizes::new(tets, arena)).expect("storage"))
    }

    fn storage(&mut self) -> HierarchyStorage<'_> {
        self.0.storage().expect("storage")
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
                WorkCost::TAKEN * (r.taken + r.debris_checked)
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

/// A world's storage from the core's owned-storage layer.
struct WorldStore(WorldBuffers);

impl WorldStore {
    fn new(s: WorldSizes) -> Self {
        Self(WorldBuffers::new(s).expect("storage"))
    }

    fn world<'a>(&'a mut self, mesh: Mesh<'a>) -> World<'a> {
        self.0.world(mesh).expect("world")
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
        stiffness: 0.0,
        vibration: tetradrill_core::servo::VibrationCue::default(),
        friction: 0.0,
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
