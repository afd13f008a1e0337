//! The removal law (docs/DRILLING.md, "Materials"): a burr plunged into the paper's cube
//! removes `(F - threshold) / hardness` cubic units a second, `F` the force each tick presses
//! it with, while the drill lags behind it (a leaf waits for its region's credit); and
//! `replay --forces` writes each tick's force.
//!
//! Oracles: the integral of `(F - threshold) / hardness` over the ticks, summed here (the
//! test's own f64 arithmetic on the forces the ticks returned), against the volume the burr
//! cut (the removed volume less the debris the drill's checks erased, which is not cut at the
//! material's rate); the tolerance, 2 %, covers the removal's quantisation (a leaf is erased
//! whole once its region has earned its volume: at the cube's depth 5 a leaf is at most a
//! coarse tet's `1 / 12` over `8^5`). The forces file against FNV-1a of its rows, written here
//! from the digest's definition.

use glam::Vec3;
use tetradrill::engine::{self, EngineStorage, TickParams};
use tetradrill::setup::{Setup, Tool};
use tetradrill::traces::Pose;
use tetradrill_core::force::ToolState;
use tetradrill_tests::{json_of, refused, scratch_dir};

/// What one plunge gave, tick by tick.
struct Plunge {
    /// The volume cut after each tick (removed less the debris the drill's checks erased).
    cut: Vec<f64>,
    /// The law's integral after each tick: `(F - threshold) / hardness * dt` summed, `F` the
    /// force of the tick before (the one each step is granted).
    law: Vec<f64>,
    /// Whether a leaf waited for its region's credit at each tick's step.
    waited: Vec<bool>,
}

/// The plunge in process (the same ticks as `replay`): the cube, burr 0.15, threshold 0.5 N,
/// `hardness`, the hand from touching the top face straight down at `speed` for `seconds`.
fn plunge_in_process(hardness: f64, speed: f32, seconds: f32) -> Plunge {
    let mut sc = Setup::new("builtin:cube12", Tool::sphere(0.15));
    sc.materials.hardness = hardness;
    sc.materials.pressure_threshold = 0.5;
    let params = TickParams::of(&sc).expect("params");
    let loaded = engine::load_mesh(&sc).expect("the cube");
    let mut store = EngineStorage::new(loaded.mesh, &sc).expect("storage");
    store.set_labels(&loaded.labels, &sc).expect("labels");
    let mut world = store.world().expect("world");
    let mut tool = ToolState::default();
    let ticks = (seconds * 1000.0).round() as usize;
    let mut p = Plunge {
        cut: Vec::with_capacity(ticks),
        law: Vec::with_capacity(ticks),
        waited: Vec::with_capacity(ticks),
    };
    let (mut law, mut grant) = (0.0f64, 0.0f64);
    for i in 0..ticks {
        let z = 0.65 - speed * (i as f32 * 0.001);
        let pose = Pose::drilling(Vec3::new(0.03, -0.02, z));
        let (f, rep) = engine::tick(&mut world, &mut tool, &params, &pose);
        // This step was granted the previous tick's force.
        law += grant;
        let n = f64::from(f.length());
        grant = if n > 0.5 {
            (n - 0.5) / hardness * f64::from(0.001f32)
        } else {
            0.0
        };
        p.cut
            .push(world.hierarchy().removed_volume() - world.debris().volume);
        p.law.push(law);
        p.waited.push(rep.drill.waited == 1);
    }
    p
}

/// The law holds while the drill lags behind the burr: over the steps at which a leaf of the
/// region waited for credit (and waited at the step before, so the credit was not capped in
/// between), the volume cut follows the law's integral. Over the whole plunge it falls short:
/// whenever the drill catches up with the burr's queued positions, the credit beyond
/// `CREDIT_STEPS` grants is dropped though the burr presses material not queued yet
/// (docs/DRILLING.md, "Materials", "The law that holds").
#[test]
fn a_plunge_cuts_at_the_laws_rate_while_a_leaf_waits() {
    for hardness in [1000.0, 3200.0] {
        let (speed, seconds) = (0.1, 3.0);
        let p = plunge_in_process(hardness, speed, seconds);
        let (mut cut, mut law, mut steps) = (0.0, 0.0, 0usize);
        for i in 1..p.cut.len() {
            if p.waited[i] && p.waited[i - 1] {
                cut += p.cut[i] - p.cut[i - 1];
                law += p.law[i] - p.law[i - 1];
                steps += 1;
            }
        }
        let last = p.cut.len() - 1;
        println!(
            "hardness {hardness}, {speed} units/s: {steps} of {} steps with a leaf waiting: cut \
             {cut:.6} against the law's {law:.6} ({:.4}); whole plunge: cut {:.6} against \
             {:.6} ({:.4})",
            last + 1,
            cut / law,
            p.cut[last],
            p.law[last],
            p.cut[last] / p.law[last],
        );
        assert!(law > 0.002, "the burr pressed: {law}");
        assert!(
            (cut / law - 1.0).abs() < 0.02,
            "hardness {hardness}: cut {cut} while a leaf waits, the law's integral {law}"
        );
        // The whole plunge never cuts more than the law, and here falls short of it.
        assert!(p.cut[last] < p.law[last], "{} {}", p.cut[last], p.law[last]);
    }
}

#[test]
fn forces_to_a_path_that_cannot_be_written_is_bad_input() {
    let dir = scratch_dir("removal_law", "bad-forces");
    let bad = dir.join("no-such-folder").join("f.csv");
    refused(
        &[
            "replay",
            "--quiet",
            "--mesh",
            "builtin:cube12",
            "--tool",
            "sphere:0.1",
            "--trace",
            "wander:1",
            "--ticks",
            "10",
            "--forces",
            bad.to_str().expect("utf8"),
        ],
        &["--forces", "no-such-folder"],
    );
}

/// FNV-1a 64 over the little-endian bits of each force's x, y and z, as docs/PORTING.md
/// defines `force_digest` (written here from that definition).
fn fnv1a(forces: &[[f32; 3]]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for f in forces {
        for c in f {
            for b in c.to_bits().to_le_bytes() {
                h ^= u64::from(b);
                h = h.wrapping_mul(0x0100_0000_01b3);
            }
        }
    }
    h
}

/// `--forces` holds every tick's force exactly: its rows, read back as f32, give the run's
/// `force_digest` (the firmware scenario's path with its two materials, 6,001 ticks).
#[test]
fn the_forces_csv_gives_the_runs_force_digest() {
    let dir = scratch_dir("removal_law", "digest");
    let forces = dir.join("forces.csv");
    let j = json_of(
        &[
            "replay",
            "--quiet",
            "--scenario",
            "builtin:firmware-regions",
            "--forces",
            forces.to_str().expect("utf8"),
        ],
        "removal_law",
        "digest-json",
    );
    let rows = tetradrill_tests::read_forces(&forces);
    assert_eq!(rows.len(), 6001);
    assert!(rows.iter().any(|f| f.iter().any(|&c| c != 0.0)));
    assert_eq!(
        format!("{:016x}", fnv1a(&rows)),
        j["force_digest"].as_str().expect("digest")
    );
}
