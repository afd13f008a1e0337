//! The drill shaft's walk under a node bound (`World::set_shaft_max_nodes`): each step it
//! enters at most the bound; the points it tracks answer as the unbounded walk does from the
//! same state, the others keep their last state exactly; the groups follow the documented
//! rule (whole: on past it, twice as large; cut: half as large, one point alone: the next);
//! no point waits long; and under a tick budget the drill and the contact search share what
//! the shaft's share leaves.
use tetradrill_core::drill::DrillParams;
use tetradrill_core::force::{DrillTool, MAX_PASSIVE};
use tetradrill_core::servo::{
    DrillState, ShaftWalk, World, WorldSizes, CONTACT_MAX_NODES, CONTACT_NODE_UNITS,
    SHAFT_NODE_UNITS,
};
use tetradrill_tests::search::{block_mesh, Store};

use super::shaft_zones::wandering_shaft;

pub(crate) const REACH: f32 = 0.02;
pub(crate) const TOOL: DrillTool = DrillTool {
    burr_radius: 0.05,
    shaft_length: 0.9,
    shaft_radius: 0.04,
};
const BOUND: u32 = 48;

/// The points of a group of `n` as the documentation states it: `span` points from `next`
/// on, round the ring; span zero (or at least `n`): all.
fn group(w: ShaftWalk, n: usize) -> Vec<bool> {
    let span = match usize::from(w.span) {
        0 => n,
        s => s.min(n),
    };
    let mut g = vec![false; n];
    for i in 0..span {
        g[(usize::from(w.next) + i) % n] = true;
    }
    g
}

/// The next group as the documentation states it: on past a group walked whole, twice as
/// large if the walk took at most half the bound; half as large after a cut.
fn after(w: ShaftWalk, n: usize, cut: bool, nodes: u32, bound: u32) -> ShaftWalk {
    let span = match usize::from(w.span) {
        0 => n,
        s => s.min(n),
    };
    let next = usize::from(w.next) % n;
    let (next, span) = if !cut && nodes <= bound / 2 {
        ((next + span) % n, (2 * span).min(n))
    } else if !cut {
        ((next + span) % n, span)
    } else if span == 1 {
        ((next + 1) % n, 1)
    } else {
        (next, span / 2)
    };
    ShaftWalk {
        next: next as u8,
        span: if span == n { 0 } else { span as u8 },
    }
}

/// What one bounded run of the shaft along the wandering path gave.
struct Run {
    /// The largest unbounded walk of a step.
    most: u32,
    /// Steps whose walk was cut.
    cuts: u32,
    /// Steps that walked a group short of the shaft whole.
    parts: u32,
    /// Point-steps left on an earlier step's state.
    stale: u32,
    /// The most steps in a row a point's answer differed from the unbounded walk's.
    longest: u32,
}

/// `f` over a world on the block of 3,072 tets, its candidate storage and hash cell bound
/// never limiting the shaft's lists.
pub(crate) fn on_block<R>(f: impl FnOnce(&mut World<'_>) -> R) -> R {
    let mut om = block_mesh(8);
    let mesh = om.view();
    let mut st = Store::sized(WorldSizes {
        candidates: 1 << 15,
        ..WorldSizes::new(mesh.tet_count(), 1 << 17)
    });
    let mut w = st.world(mesh);
    w.set_max_cells(1 << 20);
    f(&mut w)
}

/// The burr's drilling along the wandering path: the block to depth 4, a step's budget of
/// 2,000 units.
pub(crate) const WANDER_DRILL: DrillParams = DrillParams {
    max_depth: 4,
    min_area: 0.0,
    budget: 2_000,
};

/// The shaft along the wandering path through the drilled block with its walk bounded to
/// `bound` nodes, each step checked against the unbounded walk from the same state.
fn bounded_run(bound: u32) -> Run {
    on_block(|w| {
        let params = WANDER_DRILL;
        let mut state = DrillState::default();
        let mut waited = [0u32; MAX_PASSIVE];
        let mut r = Run {
            most: 0,
            cuts: 0,
            parts: 0,
            stale: 0,
            longest: 0,
        };
        for (i, &(c, a)) in wandering_shaft(600, 23).iter().enumerate() {
            w.simulate(c, TOOL.burr_radius, REACH, i % 3 == 0, &params);
            // The unbounded walk from the same state: the reference.
            let mut want = state;
            w.set_shaft_max_nodes(None);
            let (free, _) = w.track_shaft(&TOOL, c, a, REACH, &mut want);
            assert!(!free.cut && free.stale == 0, "step {i}: {free:?}");
            r.most = r.most.max(free.nodes);
            // The bounded walk from the same state.
            let before = state;
            w.set_shaft_max_nodes(Some(bound));
            let (rep, _) = w.track_shaft(&TOOL, c, a, REACH, &mut state);
            assert!(rep.nodes <= bound, "step {i}: {rep:?}");
            let n = state.count;
            let g = group(before.walk, n);
            let mut left = 0u32;
            for k in 0..n {
                let p = state.positions[k];
                let still_held = before.points[k]
                    .held
                    .is_some_and(|(q, nrm)| (p - q).dot(nrm) < 0.0);
                let needs = !still_held && p.is_finite();
                if !needs || (g[k] && !rep.cut) {
                    assert_eq!(state.points[k], want.points[k], "step {i}, point {k}");
                    waited[k] = 0;
                } else {
                    assert_eq!(state.points[k], before.points[k], "step {i}, point {k}");
                    left += 1;
                    if state.points[k] != want.points[k] {
                        waited[k] += 1;
                        r.longest = r.longest.max(waited[k]);
                    }
                }
            }
            assert_eq!(rep.stale, left, "step {i}");
            let next = after(before.walk, n, rep.cut, rep.nodes, bound);
            assert_eq!(state.walk, next, "step {i}");
            r.cuts += u32::from(rep.cut);
            r.parts += u32::from(!rep.cut && g.iter().any(|x| !x));
            r.stale += left;
        }
        r
    })
}

/// Tight, the bound cuts most busy steps, and every step keeps the contract: at most the
/// bound entered, the group's points exactly as unbounded, the rest untouched, the groups as
/// documented. With room for any one point's walk (not for the whole shaft's), walks are
/// still cut and no point waits long for its answer. Tighter than one point's walk, a point
/// may wait for good: its way from its proxy grows while it waits (the documented limit).
#[test]
fn the_bounded_walk_tracks_its_group_as_the_unbounded_one_and_leaves_the_rest() {
    let tight = bounded_run(48);
    assert!(tight.most > 4 * 48, "the largest walk {}", tight.most);
    assert!(
        tight.cuts > 100 && tight.parts > 20 && tight.stale > 1_000,
        "{} {} {}",
        tight.cuts,
        tight.parts,
        tight.stale
    );
    let roomy = bounded_run(256);
    assert!(
        roomy.most > 256 && roomy.cuts > 5,
        "{} {}",
        roomy.most,
        roomy.cuts
    );
    assert!(
        roomy.longest <= 16,
        "a point waited {} steps",
        roomy.longest
    );
}

/// Under a tick budget the shaft's share comes first: the contact search's bound is what the
/// drill left of the budget less the shaft's nodes' units, and the drill's work stays within
/// that but for its last operation. Without a tick budget the bound touches only the shaft:
/// the drill and the burr's contact are those of a world without it, step for step.
#[test]
fn under_a_tick_budget_the_shaft_is_paid_first() {
    let params = DrillParams {
        max_depth: 4,
        min_area: 0.0,
        budget: 100_000,
    };
    const BUDGET: u32 = 3_000;
    let left = BUDGET - BOUND * SHAFT_NODE_UNITS;
    let path = wandering_shaft(300, 5);
    let run = |budget: Option<u32>, shaft: Option<u32>| {
        on_block(|w| {
            w.set_tick_budget(budget);
            w.set_shaft_max_nodes(shaft);
            assert_eq!(w.shaft_max_nodes(), shaft);
            let mut state = DrillState::default();
            let mut steps = Vec::new();
            for (i, &(c, a)) in path.iter().enumerate() {
                let (rep, prep) =
                    w.simulate_drill(&TOOL, c, a, REACH, i % 3 == 0, &params, &mut state);
                assert!(prep.nodes <= shaft.unwrap_or(u32::MAX), "step {i}");
                steps.push((rep, *w.contact(), prep.cut));
            }
            steps
        })
    };
    let plain = run(None, None);
    let bounded = run(None, Some(BOUND));
    for (i, (p, b)) in plain.iter().zip(&bounded).enumerate() {
        assert_eq!((p.0, p.1), (b.0, b.1), "step {i}");
    }
    assert!(bounded.iter().any(|s| s.2), "the shaft's bound never bit");
    let (mut spent, mut over) = (0u32, 0u32);
    for (i, (rep, _, _)) in run(Some(BUDGET), Some(BOUND)).iter().enumerate() {
        let want =
            (left.saturating_sub(rep.drill.work) / CONTACT_NODE_UNITS).min(CONTACT_MAX_NODES);
        assert_eq!(rep.contact_bound, want, "step {i}");
        if rep.drill.work >= left {
            spent += 1;
            over = over.max(rep.drill.work - left);
        }
    }
    assert!(spent > 10, "{spent} steps spent the drill's share");
    assert!(over < 256, "the drill overshot its share by {over} units");
}
