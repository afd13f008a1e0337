//! Cutting resistance (docs/DRILLING.md, "Cutting resistance"): a region cut by the feed
//! (`[regions.LABEL] cutting_energy`) is removed only as fast as the work done pushing the
//! burr into it pays for, at `e` per unit volume.
//!
//! Oracle: the work the hand does, summed here in f64 from the forces `replay --forces`
//! wrote and the trace's own positions (`-F . dx` over each tick, sharing nothing with the
//! core's accounting), against the specific cutting energy times the volume cut (the removed
//! volume less the debris, which is erased whole, not cut); and the feed force a plunge
//! settles at, `e pi r^2` for a burr of radius `r` (the work per unit advance of a cut of
//! the burr's cross-section), less the share of that cross-section the drill's finest
//! leaves leave standing along the wall.

use std::f64::consts::PI;

use tetradrill_tests::{read_forces, read_json, run_ok, scratch_dir};

/// The burr's radius.
const R: f64 = 0.15;

/// The plunge: 0.2 above the paper's cube's top face (z = 0.5) with the drill on, down to
/// 0.05 above it in 0.5 s, then 0.4 into the cube at 0.1 per second, held 0.5 s.
const KEYS: [(f64, f64); 4] = [(0.0, 0.85), (0.5, 0.8), (4.5, 0.4), (5.0, 0.4)];

/// The trace's height at `t` seconds (linear between keys).
fn z(t: f64) -> f64 {
    for w in KEYS.windows(2) {
        let ((t0, z0), (t1, z1)) = (w[0], w[1]);
        if (t0..=t1).contains(&t) {
            return z0 + (z1 - z0) * (t - t0) / (t1 - t0);
        }
    }
    KEYS[KEYS.len() - 1].1
}

/// What one plunge with cutting energy `e` did.
struct Plunge {
    /// The work against the forces, from the forces and the trace.
    work: f64,
    /// The volume cut: removed, less the debris.
    cut: f64,
    /// `replay --json`.
    json: serde_json::Value,
}

fn plunge(e: f64, name: &str) -> Plunge {
    let dir = scratch_dir("cutting", name);
    let trace = dir.join("plunge.csv");
    let mut csv = String::from("t,x,y,z,qw,qx,qy,qz,buttons\n");
    for (t, z) in KEYS {
        csv.push_str(&format!("{t},0,0,{z},1,0,0,0,1\n"));
    }
    std::fs::write(&trace, csv).expect("trace");
    let scenario = dir.join("plunge.toml");
    std::fs::write(
        &scenario,
        format!(
            "mesh = \"builtin:cube12\"\ntool = \"sphere:{R}\"\n[regions.0]\ncutting_energy = {e}\n"
        ),
    )
    .expect("scenario");
    let (json, forces) = (dir.join("out.json"), dir.join("forces.csv"));
    run_ok([
        "replay".as_ref(),
        "--scenario".as_ref(),
        scenario.as_os_str(),
        "--trace".as_ref(),
        trace.as_os_str(),
        "--quiet".as_ref(),
        "--json".as_ref(),
        json.as_os_str(),
        "--forces".as_ref(),
        forces.as_os_str(),
    ]);
    let f = read_forces(&forces);
    assert_eq!(f.len(), 5_001, "one force a tick");
    // The force of tick i acts while the hand moves from tick i's position to tick i+1's.
    let work = (0..f.len() - 1)
        .map(|i| {
            let dz = z((i + 1) as f64 / 1000.0) - z(i as f64 / 1000.0);
            -f64::from(f[i][2]) * dz
        })
        .sum();
    let json = read_json(&json);
    let cut = json["removed_volume"].as_f64().expect("removed")
        - json["debris_erased"]["volume"].as_f64().expect("debris");
    Plunge { work, cut, json }
}

#[test]
fn the_work_against_the_feed_pays_for_the_volume_cut() {
    // 40 J per cubic unit: e pi r^2 = 2.8 N, well above what the leaves left along the
    // wall push back with when the material is removed at once, and below the 8 N clamp.
    let e = 40.0;
    let p = plunge(e, "e40");
    let d = &p.json["drill"];
    let (work_j, energy_j) = (
        d["cutting_work_j"].as_f64().expect("work"),
        d["cutting_energy_j"].as_f64().expect("energy"),
    );
    // The power balance: the hand's work is the energy the cut volume took.
    let energy = e * p.cut;
    assert!(
        (p.work - energy).abs() < 0.05 * energy,
        "work {} against e V {energy}",
        p.work
    );
    // The report's figures: the work it counted, and e times each leaf cut.
    assert!(
        (work_j - p.work).abs() < 0.05 * p.work,
        "{d} against {}",
        p.work
    );
    assert!(
        (energy_j - energy).abs() < 1e-6 * energy,
        "{d} against {energy}"
    );
    let left =
        d["feed_pool_j"].as_f64().expect("pool") + d["feed_dropped_j"].as_f64().expect("dropped");
    assert!((work_j - energy_j - left).abs() < 1e-9 * work_j, "{d}");
    // The cut lies within the burr's swept volume (a cylinder 0.25 long and the lower
    // hemisphere) and fills most of the cylinder.
    let cylinder = PI * R * R * 0.25;
    assert!(
        p.cut < cylinder + 2.0 / 3.0 * PI * R.powi(3) && p.cut > 0.6 * cylinder,
        "cut {} against the cylinder's {cylinder}",
        p.cut
    );
    // The feed force over the plunge, work per unit advance, is e pi r^2 times the share
    // of the cylinder cut (0.76 here).
    let settled = e * PI * R * R;
    let mean = p.work / 0.25;
    let share = p.cut / cylinder;
    assert!(
        (mean - settled * share).abs() < 0.1 * settled * share,
        "mean feed force {mean} N against e pi r^2 = {settled} N times {share}"
    );
}

#[test]
fn a_harder_region_pushes_back_harder_in_proportion() {
    let (soft, hard) = (plunge(30.0, "e30"), plunge(40.0, "e40b"));
    // The same path, the same burr: the force (work per unit advance) grows with the
    // cutting energy, the volume cut stays about the same.
    let ratio = hard.work / soft.work;
    assert!(
        (ratio - 4.0 / 3.0).abs() < 0.1,
        "work {} against {}",
        hard.work,
        soft.work
    );
    assert!(
        (hard.cut / soft.cut - 1.0).abs() < 0.15,
        "{} against {}",
        hard.cut,
        soft.cut
    );
}
