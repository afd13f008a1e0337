//! The drill shaft's walk under a node bound (`World::set_shaft_max_nodes`): each step it
//! enters at most the bound; the points it tracks answer as the unbounded walk does from the
//! same state, the others keep their last state exactly; the groups follow the documented
//! rule (whole: on past it, twice as large; cut: half as large, one point alone: the next);
//! no point waits long; and under a tick budget the shaft gets what the burr's drill and
//! contact search left of it, at least a hold taken from the drill's share.
use tetradrill_core::drill::DrillParams;
use tetradrill_core::force::{DrillTool, MAX_PASSIVE};
use tetradrill_core::servo::{
    ContactState, DrillState, PassiveReport, ShaftWalk, SimReport, World, WorldSizes,
    CONTACT_MAX_NODES, CONTACT_NODE_UNITS, SHAFT_NODE_UNITS, SHAFT_RESERVE_MIN,
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

/// The hold for the next walk as the documentation states it (`World::shaft_reserve`).
fn hold_after(hold: u32, given: u32, cut: bool, nodes: u32, bound: u32, budget: u32) -> u32 {
    let next = if cut {
        (2 * given).max(SHAFT_RESERVE_MIN)
    } else {
        nodes.max(hold - hold / 8)
    };
    next.min(bound).min(budget / 3 / SHAFT_NODE_UNITS)
}

/// One step of a drill under a tick budget, as the world reported it, with the hold it
/// started from and the bound its shaft walk was given.
struct Paid {
    rep: SimReport,
    contact: ContactState,
    walk: PassiveReport,
    hold: u32,
    given: Option<u32>,
}

/// Under a tick budget the shaft's walk gets what the burr's step left, at least the nodes
/// held for it out of the drill's share: the drill gets `min(budget, its own) - 6 hold`, the
/// contact search `(budget - 6 hold - drill work) / 6` nodes, the walk
/// `(budget - drill work - 6 contact nodes) / 6` (and at most its bound), so the step's
/// counted work keeps to the budget but for the drill's last operation; the hold follows the
/// walks as documented. Without a tick budget the bound touches only the shaft, and with no
/// bound the burr's step is the one without a shaft, with or without a budget.
#[test]
fn under_a_tick_budget_the_shaft_gets_what_the_step_left_and_a_hold() {
    const BUDGET: u32 = 3_000;
    const OWN: u32 = 2_000;
    let params = DrillParams {
        budget: OWN,
        ..WANDER_DRILL
    };
    let path = wandering_shaft(400, 5);
    let run = |budget: Option<u32>, shaft: Option<u32>| {
        on_block(|w| {
            w.set_tick_budget(budget);
            w.set_shaft_max_nodes(shaft);
            assert_eq!(w.shaft_max_nodes(), shaft);
            let mut state = DrillState::default();
            let mut steps = Vec::new();
            for (i, &(c, a)) in path.iter().enumerate() {
                let hold = w.shaft_reserve();
                let rep = w.simulate(c, TOOL.burr_radius, REACH, i % 3 == 0, &params);
                let given = w.shaft_bound();
                let (walk, _) = w.track_shaft(&TOOL, c, a, REACH, &mut state);
                assert!(walk.nodes <= given.unwrap_or(u32::MAX), "step {i}");
                let next = match (budget, shaft, given) {
                    (Some(t), Some(n), Some(g)) => hold_after(hold, g, walk.cut, walk.nodes, n, t),
                    _ => 0,
                };
                assert_eq!(w.shaft_reserve(), next, "step {i}");
                steps.push(Paid {
                    rep,
                    contact: *w.contact(),
                    walk,
                    hold,
                    given,
                });
            }
            steps
        })
    };
    let burr = |s: &Paid| (s.rep, s.contact);
    let plain = run(None, None);
    let bounded = run(None, Some(BOUND));
    for (i, (p, b)) in plain.iter().zip(&bounded).enumerate() {
        assert_eq!(burr(p), burr(b), "step {i}");
        assert_eq!(b.given, Some(BOUND), "step {i}");
    }
    assert!(
        bounded.iter().any(|s| s.walk.cut),
        "the shaft's bound never bit"
    );
    let free = run(Some(BUDGET), None);
    for (i, s) in free.iter().enumerate() {
        let want =
            (BUDGET.saturating_sub(s.rep.drill.work) / CONTACT_NODE_UNITS).min(CONTACT_MAX_NODES);
        assert_eq!(
            (s.rep.contact_bound, s.given, s.hold),
            (want, None, 0),
            "step {i}"
        );
    }
    let paid = run(Some(BUDGET), Some(4 * BOUND));
    let (mut over, mut held, mut cut, mut lent) = (0u32, 0u32, 0u32, 0u32);
    let mut diverged = false;
    for (i, (f, s)) in free.iter().zip(&paid).enumerate() {
        // The same burr step until the first hold takes from the drill.
        diverged |= s.hold > 0;
        if !diverged {
            assert_eq!(burr(f), burr(s), "step {i}");
        }
        let units = s.hold * SHAFT_NODE_UNITS;
        let drill = BUDGET.min(OWN).saturating_sub(units);
        // The drill stops at its budget but for its last operation.
        assert!(
            s.rep.drill.work < drill + 256,
            "step {i}: {:?}",
            s.rep.drill
        );
        let want = (BUDGET
            .saturating_sub(units)
            .saturating_sub(s.rep.drill.work)
            / CONTACT_NODE_UNITS)
            .min(CONTACT_MAX_NODES);
        assert_eq!(s.rep.contact_bound, want, "step {i}");
        let used = s.rep.drill.work + s.rep.contact_nodes * CONTACT_NODE_UNITS;
        let left = BUDGET.saturating_sub(used) / SHAFT_NODE_UNITS;
        assert_eq!(s.given, Some(left.min(4 * BOUND)), "step {i}");
        if s.rep.drill.work <= drill {
            // The walk gets the hold at least, and the step keeps to the budget.
            assert!(left >= s.hold, "step {i}: {left} < {}", s.hold);
            assert!(used + s.walk.nodes * SHAFT_NODE_UNITS <= BUDGET, "step {i}");
        } else {
            over = over.max(s.rep.drill.work - drill);
        }
        held += u32::from(s.hold > 0);
        cut += u32::from(s.walk.cut);
        lent += u32::from(s.walk.nodes > s.hold && s.walk.nodes > 0);
    }
    assert!(over < 256, "the drill overshot its share by {over} units");
    assert!(
        held > 100 && cut > 5 && lent > 20,
        "{held} steps held nodes, {cut} walks cut, {lent} walks took more than the hold"
    );
}
