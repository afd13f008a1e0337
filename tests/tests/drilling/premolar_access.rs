//! `builtin:tooth`: the real-size premolar's access cavity (`script::PREMOLAR_ACCESS`, a burr
//! of radius 0.7 mm) through `tetradrill replay`: the tissues are cut in the order the
//! model's geometry puts them along the path, nothing that stops removal saturates, and the
//! replay is deterministic.
//!
//! Oracle: where the burr can be, from the path's key poses and the model's surfaces
//! (`premolar.geo`, millimetres): the enamel under the fissure reaches down to z = 19.5 mm and
//! the dentin horns under the cusps (ellipsoids of half-axes 1.7, 1.3 and 1.4 mm centred at
//! y = +-1.6 mm, z = 19.3 mm) nowhere above z = 20.7 mm; the pulp chamber's roof is at
//! z = 17.45 mm on the axis, its horns (half-axes 0.55, 0.5 and 1.3 mm centred at
//! y = +-1.3 mm, z = 17.3 mm) reach up to z = 18.6 mm.

use std::collections::BTreeMap;

/// Runs `tetradrill replay --scenario builtin:tooth` (its first `ticks` ticks, or all) and
/// returns the JSON report.
fn replay(ticks: Option<u32>, name: &str) -> serde_json::Value {
    let mut args = vec!["replay", "--scenario", "builtin:tooth", "--quiet"];
    let ticks = ticks.map(|t| t.to_string());
    if let Some(t) = &ticks {
        args.extend(["--ticks", t]);
    }
    tetradrill_tests::json_of(&args, "premolar", name)
}

/// The removed volume by label, mm^3.
fn removed(j: &serde_json::Value) -> BTreeMap<i32, f64> {
    tetradrill_tests::removed_mm3_by_label(j)
}

/// At tick 3,000 the burr's centre is on the axis at z = 22.5 - 2.9 * 2.5 / 5.8 = 21.25 mm:
/// it reaches down to 20.55 mm, above the enamel's floor (19.5 mm), and within 0.7 mm of
/// the axis no lower than the horns' dentin (20.3 mm at y = 0.7 mm): enamel only. At tick
/// 15,900 it has swept at z = 19.6 mm from y = -1.2 to 1.2 mm: dentin cut, and the pulp
/// horns' tips 1.0 mm from its centre: no pulp. Over the whole path it has been at
/// z = 17.9 mm on the axis, 0.45 mm into the chamber: pulp cut. The removed volumes by label
/// sum to the removed volume, which stays below the volume the burr sweeps with the drill on
/// (12.6 mm of path, at most pi r^2 per mm plus one sphere).
#[test]
fn the_access_cavity_cuts_enamel_then_dentin_then_opens_the_pulp_chamber() {
    let early = removed(&replay(Some(3_000), "early"));
    assert!(early[&1] > 0.1, "{early:?}");
    assert_eq!(early[&2], 0.0, "{early:?}");
    assert_eq!(early[&3], 0.0, "{early:?}");

    let middle = removed(&replay(Some(15_900), "middle"));
    assert!(middle[&2] > 1.0, "{middle:?}");
    assert_eq!(middle[&3], 0.0, "{middle:?}");

    let whole = replay(None, "whole");
    let end = removed(&whole);
    assert!(end[&1] > early[&1] && end[&2] > middle[&2], "{end:?}");
    assert!(end[&3] > 0.1, "{end:?}");
    let total = whole["removed_volume"].as_f64().expect("removed_volume") * 1e9;
    let sum: f64 = end.values().sum();
    assert!((sum - total).abs() < 1e-9 * total, "{sum} against {total}");
    let r: f64 = 0.7;
    let path = 2.9 + 1.2 + 2.4 + 1.2 + 1.7 + 0.8 + 1.6 + 0.8;
    let swept = std::f64::consts::PI * r * r * path + 4.0 / 3.0 * std::f64::consts::PI * r.powi(3);
    assert!(total < swept, "{total} mm^3 removed, {swept} swept");

    // Nothing that stops removal saturated, and every buffer's peak is below its capacity.
    let s = &whole["saturations"];
    for kind in ["hash", "candidates", "arena", "pending"] {
        assert_eq!(s[kind].as_u64(), Some(0), "{kind}: {s}");
    }
    let p = &whole["peaks"];
    for (used, capacity) in [
        ("arena_nodes", "arena_capacity"),
        ("pending_coarse", "pending_coarse_capacity"),
        ("candidates", "candidate_capacity"),
        ("hash_entries", "hash_capacity"),
    ] {
        let (u, c) = (p[used].as_u64(), p[capacity].as_u64());
        assert!(u.is_some() && u < c, "{used} {u:?} of {capacity} {c:?}");
    }
    assert_eq!(whole["valid"].as_bool(), Some(true));

    // The same path again: the same forces, bit for bit.
    let again = replay(None, "again");
    assert_eq!(again["force_digest"], whole["force_digest"]);
    assert_eq!(again["removed_volume"], whole["removed_volume"]);
}
