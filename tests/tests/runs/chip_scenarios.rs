//! The chips' built-in scenarios (`builtin:f405-block`, `builtin:f405-regions`,
//! `builtin:h743-tooth`; `scripts/port-check.sh --chip`): their sizes hold the peaks they were
//! chosen from, and what they cannot hold is the exact saturation count they claim.
//!
//! Oracle: the peaks are read from the world after a whole run (the arena's high-water mark,
//! the pending rings' high-water marks, the hash's stored entries) and the longest candidate
//! list seen after any step, and compared with the capacities the scenario claims, with the
//! margins docs/PORTING.md states; the saturation counts and the force digests are the ones
//! the firmware printed under QEMU for the same scenarios (literals here, from those runs).

use tetradrill::engine::{self, EngineStorage, TickParams};
use tetradrill::scenario;
use tetradrill::traces::PoseSource;
use tetradrill_core::force::{ForceDigest, ToolState};
use tetradrill_core::servo::Saturations;

/// What one run used and counted.
struct Run {
    digest: u64,
    saturations: Saturations,
    arena_used: usize,
    arena: usize,
    pending_peaks: [usize; 4],
    hash_used: usize,
    hash_capacity: usize,
    candidates_max: usize,
}

/// Runs the built-in scenario `name` over its whole trace.
fn run(name: &str) -> Run {
    let sc = scenario::builtin(name)
        .unwrap_or_else(|| panic!("builtin:{name}"))
        .setup()
        .expect("a valid set-up");
    let params = TickParams::of(&sc).expect("tick parameters");
    let loaded = engine::load_mesh(&sc).expect("mesh");
    let poses = PoseSource::new(&sc.poses, Some(&loaded.mesh)).expect("trace");
    let mut store = EngineStorage::new(loaded.mesh.clone(), &sc).expect("storage");
    store.set_labels(&loaded.labels, &sc).expect("labels");
    let mut world = store.world().expect("world");
    let mut tool = ToolState::default();
    let mut digest = ForceDigest::new();
    let mut candidates_max = 0;
    for i in 0..poses.ticks() {
        let (f, _) = engine::tick(&mut world, &mut tool, &params, &poses.at(i));
        digest.push(f);
        candidates_max = candidates_max.max(world.candidates().len());
    }
    Run {
        digest: digest.value(),
        saturations: world.saturations(),
        arena_used: world.hierarchy().arena_used(),
        arena: world.hierarchy().capacity(),
        pending_peaks: world.pending_peaks(),
        hash_used: world.hash().len(),
        hash_capacity: world.hash().capacity(),
        candidates_max,
    }
}

/// At least a quarter above `peak`.
fn holds_with_margin(capacity: usize, peak: usize) -> bool {
    capacity * 4 >= peak * 5
}

#[test]
fn f405_block_holds_its_candidates_and_hash_and_counts_the_rest() {
    let r = run("f405-block");
    assert_eq!(r.digest, 0xf1e9_e36c_cce4_3203, "the F405's digest");
    assert_eq!(r.saturations.hash, 0);
    assert_eq!(r.saturations.candidates, 0);
    assert!(r.hash_used <= r.hash_capacity);
    assert!(holds_with_margin(
        scenario::F405_CANDIDATES,
        r.candidates_max
    ));
    // The arena and the deque are what the chip has left: full, and counted.
    assert_eq!(r.arena, scenario::F405_ARENA);
    assert_eq!(r.arena_used, r.arena);
    assert_eq!(r.saturations.arena, 3_544);
    assert_eq!(r.pending_peaks, [128, 128, 0, 0]);
    assert_eq!(r.saturations.pending, 288);
}

#[test]
fn f405_regions_counts_the_same_kinds() {
    let r = run("f405-regions");
    assert_eq!(r.digest, 0xa9e5_433d_4bc7_d12b, "the F405's digest");
    assert_eq!(r.saturations.hash, 0);
    assert_eq!(r.saturations.candidates, 0);
    assert!(holds_with_margin(
        scenario::F405_CANDIDATES,
        r.candidates_max
    ));
    assert_eq!(r.saturations.arena, 2_798);
    assert_eq!(r.saturations.pending, 129);
}

#[test]
fn h743_tooth_holds_its_deque_candidates_and_hash() {
    let r = run("h743-tooth");
    assert_eq!(r.digest, 0x3702_92f9_a896_2330, "the H743's digest");
    assert_eq!(r.saturations.hash, 0);
    assert_eq!(r.saturations.candidates, 0);
    assert_eq!(r.saturations.pending, 0);
    assert_eq!(r.hash_capacity, scenario::H743_HASH_ENTRIES);
    assert!(r.hash_used <= r.hash_capacity);
    // One coarse ring (under 1,024 entries), its peak a quarter below its capacity.
    assert_eq!(r.pending_peaks[3], 0);
    assert!(holds_with_margin(
        scenario::H743_PENDING,
        r.pending_peaks[0]
    ));
    // The candidate storage is used in thirds (the gather); the list in use is one.
    assert!(holds_with_margin(
        scenario::H743_CANDIDATES / 3,
        r.candidates_max
    ));
    assert_eq!(r.arena_used, scenario::H743_ARENA);
    assert_eq!(r.saturations.arena, 7_514);
}
