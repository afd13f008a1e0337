//! A burr much larger than the mesh's tets (a clinical-size mesh: a 4 mm burr on 0.3 mm
//! tets): the default buffers follow the tool and the mesh (`engine::ToolSizing`), so the
//! burr drills what it touches instead of saturating every step and removing nothing.
//!
//! Oracle: the analytic volume of a sphere held inside the block, `4/3 pi r^3`, against the
//! removed volume once the drill has nothing left to do; the leaves at the sphere's surface
//! (at most `max_depth` levels below tets of edge `1/n`) bound the difference.

use tetradrill::engine::{self, EngineStorage, TickParams};
use tetradrill::scenario::Scenario;
use tetradrill::traces::Pose;
use tetradrill_core::force::ToolState;
use tetradrill_core::script::DRILL_ON;
use tetradrill_core::servo::Saturations;
use tetradrill_core::Vec3;

/// What a burr held at the centre of a block did, and the capacities it had.
struct Held {
    /// Removed volume once the drill's work was done (or the ticks ran out).
    removed: f64,
    /// The world's saturations.
    saturations: Saturations,
    /// Candidate list entries chosen.
    candidates: usize,
    /// Hash cells one step's query may visit.
    cells: u32,
    /// Hierarchy arena nodes chosen.
    arena: usize,
    /// Hierarchy nodes in use at the end.
    nodes: usize,
}

/// Holds a burr of `radius` at the centre of `builtin:block:n` with the drill on until the
/// drill's work is done (or `max_ticks`).
fn hold(n: usize, radius: f64, max_depth: u8, max_ticks: u64) -> Held {
    let sc = Scenario {
        mesh: format!("builtin:block:{n}"),
        tool: format!("sphere:{radius}"),
        max_depth,
        // Depth alone decides here (no drill resolution).
        resolution: Some(0.0),
        ..Scenario::default()
    }
    .setup()
    .expect("a valid set-up");
    let (params, mut store) = tetradrill_tests::engine_storage(&sc);
    let candidates = store.candidate_capacity();
    let arena = store.hierarchy_capacity();
    let mut world = store.world().expect("world");
    let cells = world.max_cells();
    let mut tool = ToolState::default();
    let pose = Pose {
        position: Vec3::ZERO,
        rotation: [1.0, 0.0, 0.0, 0.0],
        buttons: DRILL_ON,
    };
    for i in 0..max_ticks {
        engine::tick(&mut world, &mut tool, &params, &pose);
        if i > 10 && world.pending() == 0 {
            break;
        }
    }
    Held {
        removed: world.hierarchy().removed_volume(),
        saturations: world.saturations(),
        candidates,
        cells,
        arena,
        nodes: world.hierarchy().node_count(),
    }
}

#[test]
fn a_burr_many_tets_wide_drills_its_own_volume_with_the_default_buffers() {
    // 196,608 tets of edge 1/32; a burr of radius 0.15 spans ten of them. Its zone holds
    // about 40,000 tets: the fixed list of 1,024 used to fill on every step.
    let r = 0.15;
    let held = hold(32, r, 2, 4000);
    let (removed, saturated, cands) = (held.removed, held.saturations.candidates, held.candidates);
    let sphere = 4.0 / 3.0 * std::f64::consts::PI * r * r * r;
    assert!(cands > 1024, "the list was not sized for the burr: {cands}");
    assert_eq!(saturated, 0, "steps saturated with {cands} candidates");
    // Leaves of edge 1/128 at the sphere's surface: a shell of half a leaf either way.
    let shell = 4.0 * std::f64::consts::PI * r * r * (0.5 / 128.0);
    assert!(
        (removed - sphere).abs() <= shell,
        "removed {removed:.6}, sphere {sphere:.6}, shell {shell:.6}"
    );
}

#[test]
fn a_zone_wider_than_the_query_may_visit_is_counted_never_silent() {
    // Radius 0.3 on edge 1/40: the burr's zone covers tens of thousands of hash cells. The
    // world sized for it drills; a world whose list (and so query) is held to the core's
    // defaults counts every step it cannot see, instead of drilling nothing quietly.
    let held = hold(40, 0.3, 1, 4000);
    let (removed, saturated, cells) = (held.removed, held.saturations.candidates, held.cells);
    assert!(
        cells > 4096,
        "the query was not sized for the burr: {cells} cells"
    );
    assert_eq!(saturated, 0);
    let sphere = 4.0 / 3.0 * std::f64::consts::PI * 0.027;
    assert!(removed > 0.9 * sphere, "removed {removed}, sphere {sphere}");

    let sc = Scenario {
        mesh: "builtin:block:40".into(),
        tool: "sphere:0.3".into(),
        max_depth: 1,
        candidate_capacity: Some(1024),
        ..Scenario::default()
    }
    .setup()
    .expect("a valid set-up");
    let params = TickParams::of(&sc).expect("scenario");
    let loaded = engine::load_mesh(&sc).expect("mesh");
    let mut store = EngineStorage::new(loaded.mesh, &sc).expect("storage");
    let mut world = store.world().expect("world");
    world.set_max_cells(tetradrill_core::servo::DEFAULT_MAX_CELLS);
    let mut tool = ToolState::default();
    let pose = Pose {
        position: Vec3::ZERO,
        rotation: [1.0, 0.0, 0.0, 0.0],
        buttons: DRILL_ON,
    };
    for _ in 0..50 {
        let (_, rep) = engine::tick(&mut world, &mut tool, &params, &pose);
        assert!(rep.candidates_saturated, "a clipped zone must be reported");
        assert_eq!(rep.candidates, 0, "a clipped zone finds nothing");
    }
    assert_eq!(world.saturations().candidates, 50);
}

/// The hierarchy nodes a burr held at the centre of `builtin:block:n` uses once the drill has
/// nothing left to do (neither the arena nor the pending deque ever full), and the arena the
/// scenario's sizing chose.
fn nodes_used(n: usize, radius: f64, max_depth: u8) -> (usize, usize) {
    let held = hold(n, radius, max_depth, 20_000);
    let sat = held.saturations;
    assert_eq!(sat.arena + sat.pending, 0, "depth {max_depth}: {sat:?}");
    (held.nodes, held.arena)
}

/// A finer `--max-depth` needs more hierarchy nodes for the same cut: its leaves are a
/// quarter of the area, so the drilled surface takes about four times the nodes per level
/// (measured here on a held burr, the oracle). The arena sized for the burr grows by the
/// same factor per level past the default depth, so the default capacities drill at depth 6
/// as at depth 5 instead of filling the arena (a 12 s hold on the teddy at depth 6 used to
/// saturate it on 11,230 ticks).
#[test]
fn the_arena_grows_with_max_depth_as_the_drilled_surface_does() {
    let (d3, _) = nodes_used(4, 0.3, 3);
    let (d4, _) = nodes_used(4, 0.3, 4);
    let growth = d4 as f64 / d3 as f64;
    assert!(
        (3.0..=5.0).contains(&growth),
        "nodes {d3} -> {d4}: x{growth:.2}"
    );
    // The sizes chosen at the default depth and deeper, for a burr about one tet wide.
    let (_, a5) = nodes_used(2, 0.05, 5);
    let (_, a6) = nodes_used(2, 0.05, 6);
    let (_, a7) = nodes_used(2, 0.05, 7);
    assert_eq!(a6, 4 * a5, "arena {a5} -> {a6}");
    assert_eq!(
        a7,
        (16 * a5).min(engine::MAX_SIZED_ARENA),
        "arena {a5} -> {a7}"
    );
}

/// Where the burr's zone holds tens of thousands of tets the host gathers its candidates over
/// steps (an exact `ZoneGather`, chosen by `engine::ToolSizing`) instead of querying the hash
/// every step, and drills exactly what the one-shot query drills.
///
/// Oracle: the same burr path on the same block with `zone_gather_work = 0` (the one-shot
/// query every step), each step's drilling finished within it (an unbounded budget), so the
/// removed volume must agree tick for tick (to 1e-9: summed in another order). The path
/// plunges at 1.5 units a second and then sweeps at 0.75, so the burr outruns the gather
/// at times (those steps fall back to the one-shot query, counted) and is served by the
/// gathered lists at others; no step of either run is short of candidates.
#[test]
fn a_large_zone_is_gathered_over_steps_and_drills_as_the_one_shot_query() {
    let run = |gather: Option<u32>| {
        let sc = Scenario {
            mesh: "builtin:block:32".into(),
            tool: "sphere:0.15".into(),
            max_depth: 2,
            budget_per_tick: 100_000_000,
            tick_budget: 0,
            zone_gather_work: gather,
            ..Scenario::default()
        }
        .setup()
        .expect("a valid set-up");
        let (params, mut store) = tetradrill_tests::engine_storage(&sc);
        let chosen = store.zone_gather().copied();
        let mut world = store.world().expect("world");
        let mut tool = ToolState::default();
        let mut removed = Vec::new();
        for i in 0..600u32 {
            let t = i as f32 / 1000.0;
            let position = if i < 200 {
                Vec3::new(0.0, 0.0, 0.7 - 1.5 * t)
            } else {
                Vec3::new(0.75 * (t - 0.2), 0.0, 0.4)
            };
            let pose = Pose {
                position,
                rotation: [1.0, 0.0, 0.0, 0.0],
                buttons: DRILL_ON,
            };
            engine::tick(&mut world, &mut tool, &params, &pose);
            removed.push(world.hierarchy().removed_volume());
        }
        let fallbacks = world.zone_gather().map(|z| (z.fallbacks(), z.gathers()));
        (chosen, removed, fallbacks, world.saturations().candidates)
    };
    let (chosen, gathered, counts, sat_g) = run(None);
    let (none, one_shot, _, sat_o) = run(Some(0));
    let chosen = chosen.expect("a gather chosen for a zone of ~40,000 tets");
    assert!(chosen.is_exact() && chosen.work() >= engine::GATHER_MIN_WORK);
    assert!(none.is_none(), "zone_gather_work = 0 is the one-shot query");
    assert_eq!((sat_g, sat_o), (0, 0), "steps short of candidates");
    let (fallbacks, gathers) = counts.expect("the world's gather");
    assert!(
        fallbacks > 0 && fallbacks < 300 && gathers > 3,
        "{fallbacks} steps fell back, {gathers} gathers"
    );
    assert!(*one_shot.last().unwrap() > 0.01, "the burr drilled");
    for (i, (a, b)) in one_shot.iter().zip(&gathered).enumerate() {
        assert!(
            (a - b).abs() <= 1e-9 * a.max(1e-12),
            "tick {i}: removed {a} with the one-shot query, {b} gathered"
        );
    }
}
