//! Unit tests of the regions' materials: the hardness law's credit and the feed's pool.

use super::material::*;
use crate::ids::TetId;

fn soft() -> Material {
    Material {
        hardness: 100.0,
        threshold: 1.0,
        stiffness: 0.0,
    }
}

#[test]
fn the_rate_is_the_force_above_the_threshold_over_the_hardness() {
    let m = soft();
    assert_eq!(m.rate(3.0), 0.02);
    assert_eq!(m.rate(1.0), 0.0);
    assert_eq!(m.rate(0.5), 0.0);
    assert_eq!(m.rate(f32::NAN), 0.0);
    assert!(Material::DEFAULT.admits(0.0));
    assert_eq!(Material::DEFAULT.rate(0.0), f64::INFINITY);
    let gate = Material {
        threshold: 2.0,
        ..Material::DEFAULT
    };
    assert!(!gate.admits(1.9) && gate.admits(2.0));
}

#[test]
fn a_leaf_waits_until_its_region_has_earned_its_volume() {
    let mut table = [Region::new(Material::DEFAULT), Region::new(soft())];
    let of_tet = [0u8, 1];
    let mut r = Regions::new(&mut table, &of_tet).expect("valid");
    // 0.02 per second at 3 N: 0.00002 a millisecond; a leaf of 0.000099 needs 5 grants.
    for k in 0..5 {
        r.grant(3.0, 0.001, true, 0.0, None, false);
        let expect = if k < 4 { Spend::Wait } else { Spend::Erase };
        assert_eq!(r.spend(TetId(1), 0.000099), expect, "grant {k}");
    }
    assert!((r.table()[1].credit() - 0.000001).abs() < 1e-10);
    // Region 0 erases at once; below the threshold nothing is earned.
    assert_eq!(r.spend(TetId(0), 1.0), Spend::Erase);
    r.grant(0.5, 0.001, true, 0.0, None, false);
    assert!(!r.admits(TetId(1)) && r.admits(TetId(0)));
    assert_eq!(r.table()[1].credit(), 0.0);
}

#[test]
fn credit_without_a_waiting_leaf_is_kept_to_a_few_steps() {
    let mut table = [Region::new(soft())];
    let mut r = Regions::new(&mut table, &[]).expect("valid");
    for _ in 0..1000 {
        r.grant(3.0, 0.001, true, 0.0, None, false);
    }
    let g = 0.02 * f64::from(0.001f32);
    assert!((r.table()[0].credit() - g * CREDIT_STEPS).abs() < 1e-12);
    // A waiting leaf lets the credit grow to what it needs.
    assert_eq!(r.spend(TetId(0), 1e-3), Spend::Wait);
    for _ in 0..50 {
        r.grant(3.0, 0.001, true, 0.0, None, false);
    }
    assert_eq!(r.spend(TetId(0), 1e-3), Spend::Erase);
    r.grant(3.0, 0.001, false, 0.0, None, false);
    assert_eq!(
        r.table()[0].credit(),
        0.0,
        "a burr that does not spin earns nothing"
    );
}

#[test]
fn a_region_cut_by_the_feed_is_paid_from_the_work_done_pushing_into_it() {
    // Region 0 removed at once, region 1 cut by the feed at 2,000 per cubic unit
    // (threshold 1 N), region 2 rate-limited.
    let feed = Region::new(Material {
        threshold: 1.0,
        ..Material::DEFAULT
    })
    .with_cutting_energy(2_000.0);
    let mut table = [Region::default(), feed, Region::new(soft())];
    let of_tet = [0u8, 1, 2];
    let mut r = Regions::new(&mut table, &of_tet).expect("valid");
    let under = Some(TetId(1));
    assert!(r.limits(TetId(1)) && r.limits(TetId(2)) && !r.limits(TetId(0)));
    // A leaf of 1e-6 takes 0.002 of work: 2 N over 0.0005 pays for half of it.
    r.grant(2.0, 0.001, true, 0.0005, under, false);
    assert_eq!(r.spend(TetId(1), 1e-6), Spend::Wait);
    r.grant(2.0, 0.001, true, 0.0005, under, true);
    assert_eq!(r.spend(TetId(1), 1e-6), Spend::Erase);
    assert!((r.cutting_work() - 0.002).abs() < 1e-9);
    assert!((r.cutting_energy() - 0.002).abs() < 1e-9);
    assert!(r.feed_pool().abs() < 1e-9);
    // No work: below the threshold, over a region not cut by the feed, moving back out.
    r.grant(0.9, 0.001, true, 0.0005, under, false);
    r.grant(2.0, 0.001, true, 0.0005, Some(TetId(2)), false);
    r.grant(2.0, 0.001, true, 0.0, under, false);
    assert!((r.cutting_work() - 0.002).abs() < 1e-9);
    // The force earns the feed's region no credit of the hardness law.
    assert_eq!(r.table()[1].credit(), 0.0);
    // Work left is kept while the drill has work queued after the burr stops, dropped
    // once it has none.
    r.grant(2.0, 0.001, true, 0.0001, under, false);
    r.grant(2.0, 0.001, false, 0.0, under, true);
    assert!((r.feed_pool() - 0.0002).abs() < 1e-9);
    r.grant(2.0, 0.001, false, 0.0, under, false);
    assert_eq!(r.feed_pool(), 0.0);
    assert!((r.feed_dropped() - 0.0002).abs() < 1e-9);
    let balance = r.cutting_energy() + r.feed_pool() + r.feed_dropped();
    assert!((r.cutting_work() - balance).abs() < 1e-9);
    // Settings survive a fresh start; state does not.
    let again = r.table()[1].fresh();
    assert_eq!(again.cutting_energy(), 2_000.0);
    assert_eq!(again.removed(), 0.0);
    assert!(!Region::default()
        .with_cutting_energy(f32::NAN)
        .feed_limited());
}

#[test]
fn bad_tables_are_refused() {
    let mut none: [Region; 0] = [];
    assert_eq!(Regions::new(&mut none, &[]).err(), Some(RegionError::Empty));
    let mut one = [Region::default()];
    assert_eq!(
        Regions::new(&mut one, &[0, 1]).err(),
        Some(RegionError::Unknown {
            tet: 1,
            region: 1,
            regions: 1
        })
    );
}
