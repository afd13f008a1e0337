//! The drill shaft's walk seeded with each point's nearest face of its last step
//! (`DrillState::nearest`): the answers are the walk's without seeds, bit for bit, on every
//! step of a shaft wandering through the block while the burr drills it (so seeds go stale
//! as faces are cut away and refined), and the seeded walk enters no node the seedless one
//! does not.
//!
//! Oracle: the same step from the same state with every seed cleared, the walk that
//! `force/passive_tests.rs` checks against every visible face.
use tetradrill_core::force::MAX_PASSIVE;
use tetradrill_core::servo::DrillState;

use super::shaft_bound::{on_block, REACH, TOOL, WANDER_DRILL};
use super::shaft_zones::wandering_shaft;

#[test]
fn a_seeded_walk_answers_as_the_seedless_one_and_enters_no_more_nodes() {
    on_block(|w| {
        let mut state = DrillState::default();
        let (mut seeded_nodes, mut seedless_nodes, mut seeds_used) = (0u64, 0u64, 0u32);
        for (i, &(c, a)) in wandering_shaft(600, 29).iter().enumerate() {
            w.simulate(c, TOOL.burr_radius, REACH, i % 3 == 0, &WANDER_DRILL);
            let mut seedless = DrillState {
                nearest: [None; MAX_PASSIVE],
                ..state
            };
            let (free, _) = w.track_shaft(&TOOL, c, a, REACH, &mut seedless);
            seeds_used += state.nearest.iter().flatten().count() as u32;
            let before = state;
            let (rep, _) = w.track_shaft(&TOOL, c, a, REACH, &mut state);
            assert_eq!(state.points, seedless.points, "step {i}");
            for k in 0..state.count {
                // A point held and still behind its face is not walked: its seed stays.
                let p = state.positions[k];
                let walked = !before.points[k]
                    .held
                    .is_some_and(|(q, n)| (p - q).dot(n) < 0.0);
                let want = if walked {
                    seedless.nearest[k]
                } else {
                    before.nearest[k]
                };
                assert_eq!(state.nearest[k], want, "step {i}, point {k}");
            }
            assert!(rep.nodes <= free.nodes, "step {i}: {rep:?} {free:?}");
            assert_eq!((rep.held, rep.near), (free.held, free.near), "step {i}");
            seeded_nodes += u64::from(rep.nodes);
            seedless_nodes += u64::from(free.nodes);
        }
        // The path keeps points near the surface: seeds were there to use, and they pruned.
        assert!(seeds_used > 1_000, "{seeds_used} seeds");
        assert!(
            seeded_nodes < seedless_nodes,
            "seeded {seeded_nodes} nodes, seedless {seedless_nodes}"
        );
    });
}
