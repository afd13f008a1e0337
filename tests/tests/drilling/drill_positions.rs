//! Which burr positions `World::simulate` gives the drill: one per `DRILL_SPACING` radii of
//! motion, and the position where a burr settles (stays within `DRILL_SETTLE` of one point
//! for `DRILL_HOLD_STEPS` steps), so the end of a motion is eroded too; never one every
//! `DRILL_HOLD_STEPS` steps of a steady motion.

use glam::Vec3;
use tetradrill::engine::{self, EngineStorage};
use tetradrill::setup::Setup;
use tetradrill_core::drill::DrillParams;
use tetradrill_core::servo::{DRILL_HOLD_STEPS, DRILL_SETTLE, DRILL_SPACING};

const R: f32 = 0.1;

fn storage() -> EngineStorage {
    let sc = Setup::default();
    let loaded = engine::load_mesh(&sc).expect("built-in mesh");
    EngineStorage::new(loaded.mesh, &sc).expect("storage")
}

/// A steady drag at the demo's speed (a 384th of the radius a step, so 16 steps move less
/// than the spacing): positions come by distance only, one per spacing.
#[test]
fn a_steady_motion_is_queued_by_distance_only() {
    let mut store = storage();
    let mut world = store.world().expect("world");
    let params = DrillParams::default();
    let step = R / 384.0;
    let ticks = 960u32; // 2.5 radii
    let start = Vec3::new(-0.15, 0.0, 0.5);
    let mut queued = 0u32;
    for i in 0..ticks {
        let c = start + Vec3::X * (step * i as f32);
        queued += world.simulate(c, R, 0.5 * R, true, &params).queued;
    }
    // The first position, then one each time the burr is a spacing from the last queued
    // (rounding may put a boundary one step later).
    let by_distance = (step * (ticks - 1) as f32 / (DRILL_SPACING * R)) as u32;
    assert!(
        queued == by_distance + 1 || queued == by_distance,
        "{queued} positions for {by_distance} spacings"
    );
    // The rule before 2026-11-22 (any motion re-queued every 16 steps) gave ~3x as many.
    assert!(queued < ticks / DRILL_HOLD_STEPS / 2, "{queued}");
}

/// A short slow motion (less than a spacing) that stops: the resting position is queued once
/// it has settled, once only, and moving on within the settle distance queues nothing.
#[test]
fn the_position_where_a_burr_settles_is_queued_once() {
    let mut store = storage();
    let mut world = store.world().expect("world");
    let params = DrillParams::default();
    let a = Vec3::new(0.0, 0.0, 0.55);
    let mut log = Vec::new();
    // First position, then half a spacing in 40 steps, then still for 60 steps.
    for i in 0..100u32 {
        let u = (i.min(40) as f32) / 40.0;
        let c = a + Vec3::X * (0.5 * DRILL_SPACING * R * u);
        log.push(world.simulate(c, R, 0.5 * R, true, &params).queued);
    }
    assert_eq!(log[0], 1, "the first position");
    assert!(
        log[1..=40].iter().all(|&q| q == 0),
        "moving less than a spacing: {log:?}"
    );
    // At rest from step 40 (already within the settle distance of where it settles a few
    // steps earlier, the steps being small): queued once within DRILL_HOLD_STEPS steps of
    // stopping, then never again.
    let by = 40 + DRILL_HOLD_STEPS as usize;
    assert_eq!(log[41..=by].iter().sum::<u32>(), 1, "{log:?}");
    assert_eq!(log.iter().sum::<u32>(), 2, "{log:?}");
    // A drift within the settle distance after that queues nothing more.
    let rest = a + Vec3::X * (0.5 * DRILL_SPACING * R);
    for i in 0..40u32 {
        let c = rest + Vec3::Y * (0.5 * DRILL_SETTLE * R * (i % 2) as f32);
        let q = world.simulate(c, R, 0.5 * R, true, &params).queued;
        assert!(i < DRILL_HOLD_STEPS || q <= 1, "step {i}: {q}");
    }
}
