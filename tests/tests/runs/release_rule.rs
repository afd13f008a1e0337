//! The RTIC firmware's release rule on the host (`servo_lag = 1`, `builtin:firmware`): the
//! force of tick `i` comes from the contact of the simulation step released at tick `i - 1`.
//!
//! Oracle: the simulation never reads a force, so a same-tick run (`servo_lag = 0`) steps
//! the world through the same states; its contacts, shifted by one tick and fed to a fresh
//! `servo_force` loop written here, give the forces the lagged tick must give.

use tetradrill::engine::{self, EngineStorage, TickParams};
use tetradrill::scenario::{self, Scenario};
use tetradrill::setup::Setup;
use tetradrill::traces::PoseSource;
use tetradrill_core::force::ToolState;
use tetradrill_core::servo::{servo_force, ContactState};
use tetradrill_core::Vec3;

/// Ticks of the demo path replayed: the approach, the plunge and some of the drag.
const TICKS: u32 = 2_500;

/// Runs `sc` for [`TICKS`], returning each tick's force and the contact after its step.
fn run(sc: &Setup) -> (Vec<Vec3>, Vec<ContactState>) {
    let params = TickParams::of(sc).expect("scenario");
    let poses = PoseSource::new(&sc.poses, None).expect("trace");
    let loaded = engine::load_mesh(sc).expect("mesh");
    let mut store = EngineStorage::new(loaded.mesh, sc).expect("storage");
    let mut world = store.world().expect("world");
    let mut tool = ToolState::default();
    let (mut forces, mut contacts) = (Vec::new(), Vec::new());
    for i in 0..TICKS as u64 {
        let (f, _) = engine::tick(&mut world, &mut tool, &params, &poses.at(i));
        forces.push(f);
        contacts.push(*world.contact());
    }
    (forces, contacts)
}

#[test]
fn firmware_scenario_uses_the_previous_steps_contact() {
    let lagged_scenario = scenario::builtin("firmware").expect("builtin:firmware");
    let lagged = lagged_scenario.setup().expect("a valid set-up");
    assert_eq!(
        lagged.drilling.servo_lag, 1,
        "builtin:firmware models the RTIC release rule"
    );
    let same_tick = Scenario {
        servo_lag: 0,
        ..lagged_scenario.clone()
    }
    .setup()
    .expect("a valid set-up");
    let (lag_forces, lag_contacts) = run(&lagged);
    let (same_forces, same_contacts) = run(&same_tick);
    // The world goes through the same states whatever the servo does.
    assert_eq!(lag_contacts, same_contacts);

    let params = TickParams::of(&lagged).expect("scenario");
    let poses = PoseSource::new(&lagged.poses, None).expect("trace");
    let mut tool = ToolState::default();
    let mut contact_ticks = 0;
    for i in 0..TICKS as usize {
        let due = if i == 0 {
            ContactState::default()
        } else {
            same_contacts[i - 1]
        };
        let pose = poses.at(i as u64);
        let want = servo_force(&due, pose.position, params.radius, &mut tool, &params.force);
        assert_eq!(lag_forces[i], want, "tick {i}");
        contact_ticks += usize::from(want != Vec3::ZERO);
    }
    // The scenario reaches the surface, and the lag changes some forces.
    assert!(contact_ticks > 100, "{contact_ticks} ticks in contact");
    assert_ne!(lag_forces, same_forces);
}

#[test]
fn servo_lag_above_one_is_refused() {
    let sc = Scenario {
        servo_lag: 2,
        ..Scenario::default()
    };
    let err = sc.check().expect_err("servo_lag 2");
    assert!(err.contains("servo_lag"), "{err}");
}

/// `builtin:firmware-cow` finds the shared cow (in `TETRADRILL_MESHES` or the project's test
/// data) and keeps the firmware's release rule, sizes and candidate gather.
#[test]
fn firmware_cow_scenario_names_the_cow() {
    let sc = scenario::builtin("firmware-cow").expect("builtin:firmware-cow");
    assert!(std::path::Path::new(&sc.mesh).is_file(), "{}", sc.mesh);
    assert!(sc.mesh.ends_with("spot_tetgen_q1.414.node"), "{}", sc.mesh);
    assert_eq!(sc.servo_lag, 1);
    assert_eq!(
        (
            sc.hierarchy_capacity,
            sc.pending_capacity,
            sc.candidate_capacity
        ),
        (Some(40_000), Some(8_192), Some(12_288))
    );
    assert_eq!(sc.zone_gather_work, Some(2_000));
}
