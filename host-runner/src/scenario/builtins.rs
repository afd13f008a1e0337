//! The built-in scenarios (`builtin:NAME`): the demo, the firmware's scenarios and the chips'
//! (their capacities in `chips.rs`), and where their meshes are found.

use std::path::Path;

use super::*;

/// A built-in scenario by name.
pub fn builtin(name: &str) -> Option<Scenario> {
    match name {
        // The demo's block has two regions (`tetradrill_core::builtin::block_labels`): a hard
        // outer shell and a soft core (docs/DRILLING.md, "Materials").
        "demo" => Some(Scenario {
            regions: labelled(demo_regions()),
            ..Scenario::default()
        }),
        // Small enough for the Cortex-M4 firmware's static storage; same path as the demo.
        // The firmware's numbers (ports/mps2-an386/src/scenario.rs and storage.rs): a budget and a
        // contact-search bound sized for a tick of a few hundred thousand instructions on a
        // Cortex-M4 (docs/PORTING.md), a pending deque that never fills on this path.
        "firmware" => Some(Scenario {
            mesh: "builtin:block:4".into(),
            max_depth: 4,
            hierarchy_capacity: Some(20_000),
            budget_per_tick: 300,
            contact_search_nodes: 64,
            pending_capacity: Some(16_384),
            tick_budget: 0,
            servo_lag: 1,
            ..Scenario::default()
        }),
        // The firmware scenario on the shared cow (18,098 tets; `scripts/port-check.sh
        // --scenario cow`): the same path and settings, sized for the firmware's 4 MB of RAM
        // (ports/mps2-an386/src/scenario.rs holds the same numbers).
        "firmware-cow" => Some(Scenario {
            mesh: firmware_cow_mesh(),
            hierarchy_capacity: Some(40_000),
            pending_capacity: Some(8_192),
            candidate_capacity: Some(12_288),
            zone_gather_work: Some(2_000),
            ..builtin("firmware")?
        }),
        // The firmware scenario with the demo's two materials on the block's shell and core
        // (`scripts/port-check.sh --scenario regions`; ports/mps2-an386/src/scenario.rs holds
        // the same numbers).
        "firmware-regions" => Some(Scenario {
            regions: labelled(demo_regions()),
            ..builtin("firmware")?
        }),
        // The firmware scenario on the premolar (`scripts/port-check.sh --scenario tooth`):
        // a 0.7 mm burr (an ISO 014 round burr) cuts an access cavity through the enamel into
        // the dentin and opens the pulp chamber (`script::TOOTH_ACCESS`), with the tooth's
        // three materials (`tooth_regions`); metres and newtons. The capacities hold the whole
        // path (ports/mps2-an386/src/scenario.rs holds the same numbers).
        "firmware-tooth" => Some(Scenario {
            mesh: test_mesh(TOOTH),
            trace: "builtin:tooth-access".into(),
            tool: "sphere:0.0007".into(),
            stiffness: 6_000.0,
            regions: labelled(tooth_regions()),
            hierarchy_capacity: Some(60_000),
            pending_capacity: Some(16_384),
            // The candidates gathered over steps, as on the cow (in thirds of 3,072): a zone
            // query every step left the M4 3 % of its period.
            candidate_capacity: Some(3_072),
            zone_gather_work: Some(2_000),
            ..builtin("firmware")?
        }),
        // The firmware scenario as an STM32F405 runs it (`scripts/port-check.sh --chip f405`;
        // ports/mps2-an386/src/scenario.rs, `chip`, holds the same numbers): sized for its
        // 128 KB of SRAM and 64 KB of CCM from the peaks `replay --json` measures at the
        // default sizes (docs/PORTING.md, "On named chips"). The candidates and the hash hold
        // their peaks (108 and 2,058); the arena (peak 13,944) and the pending deque (16,384
        // entries: peaks 1,159 coarse and 1,483 fine) get what the chip has left, so the
        // drill is coarser and its saturations are counted.
        "f405-block" => Some(Scenario {
            hierarchy_capacity: Some(F405_ARENA),
            pending_capacity: Some(F405_PENDING),
            candidate_capacity: Some(F405_CANDIDATES),
            hash_capacity: Some(F405_HASH_ENTRIES),
            ..builtin("firmware")?
        }),
        // `builtin:f405-block` with the two materials of `builtin:firmware-regions`.
        "f405-regions" => Some(Scenario {
            regions: labelled(demo_regions()),
            ..builtin("f405-block")?
        }),
        // The firmware's tooth as an STM32H743 runs it (`scripts/port-check.sh --chip h743`;
        // ports/mps2-an386/src/scenario.rs, `chip`, holds the same numbers): sized for its
        // regions from the peaks at the default sizes. The hash (23,824 entries) and the
        // candidates (283 a third) hold their peaks, the pending deque (one coarse ring) its
        // peak of 639 at this arena; the arena (peak 57,240) gets what SRAM1-3 has left, so
        // the drill is coarser and its saturations are counted.
        "h743-tooth" => Some(Scenario {
            hierarchy_capacity: Some(H743_ARENA),
            pending_capacity: Some(H743_PENDING),
            candidate_capacity: Some(H743_CANDIDATES),
            hash_capacity: Some(H743_HASH_ENTRIES),
            ..builtin("firmware-tooth")?
        }),
        // The premolar at real size (`scenario/teeth.rs`).
        "tooth" => Some(teeth::real_size_tooth()),
        // The firmware block soft (`scripts/port-check.sh --scenario soft`): its step and the
        // world's update spread over the ticks of each cycle, sized so that a tick's share
        // fits the Cortex-M4's period beside the simulation step (docs/SOFT.md, "On the
        // Cortex-M4"; ports/mps2-an386/src/scenario.rs holds the same numbers).
        "firmware-soft" => Some(Scenario {
            body: BodyKind::Soft,
            young: Some(FIRMWARE_SOFT_YOUNG),
            soft_rate: Some(FIRMWARE_SOFT_RATE),
            soft_substeps: Some(FIRMWARE_SOFT_SUBSTEPS),
            soft_spread: true,
            ..builtin("firmware")?
        }),
        _ => None,
    }
}

/// Young's modulus of `builtin:firmware-soft`, pascal: the demo's `--soft` block's, a dent
/// of several millimetres under the firmware path's force.
pub const FIRMWARE_SOFT_YOUNG: f64 = 2_000.0;
/// Physics steps a second of `builtin:firmware-soft`.
pub const FIRMWARE_SOFT_RATE: f64 = 20.0;
/// XPBD substeps a step of `builtin:firmware-soft`.
pub const FIRMWARE_SOFT_SUBSTEPS: u32 = 4;

/// The tooth of `builtin:firmware-tooth`, in the project's test data folder.
pub const TOOTH: &str = "models/tooth_premolar_gmsh.msh22.msh";

/// `NAME` (a path relative to the test data folder) in the folder `TETRADRILL_MESHES` names
/// when it has one, else in the project's test data.
pub(super) fn test_mesh(name: &str) -> String {
    if let Some(dir) = std::env::var_os("TETRADRILL_MESHES") {
        let p = Path::new(&dir).join(name);
        if p.is_file() {
            return p.to_string_lossy().into_owned();
        }
    }
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../tests/data/meshes")
        .join(name)
        .to_string_lossy()
        .into_owned()
}

/// The cow of `builtin:firmware-cow`: `models/spot_tetgen_q1.414.node` in the folder
/// `TETRADRILL_MESHES` names when it has one, else in the project's test data.
fn firmware_cow_mesh() -> String {
    test_mesh("models/spot_tetgen_q1.414.node")
}
