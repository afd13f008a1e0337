//! Oracles of `update.rs`: the table moved in place against the whole rebuild, refusals,
//! corrupted tables.

use glam::Vec3;

use super::*;
use crate::geom::test_rng::Rng;
use crate::hash::HashStats;

const ITEMS: usize = 60;

/// A box of up to about 3 cells a side somewhere in a 12-cell space, or none.
fn random_box(rng: &mut Rng) -> Option<Aabb> {
    if rng.next() < 0.05 {
        return None;
    }
    let min = Vec3::new(
        rng.range(-6.0, 6.0),
        rng.range(-6.0, 6.0),
        rng.range(-6.0, 6.0),
    );
    let size = Vec3::new(
        rng.range(0.0, 2.5),
        rng.range(0.0, 2.5),
        rng.range(0.0, 2.5),
    );
    Some(Aabb {
        min,
        max: min + size,
    })
}

fn snap(v: f32) -> f32 {
    libm::roundf(v * 2.0) / 2.0
}

/// The box moved a little (most keep their cells), a lot, or into or out of `None`.
fn moved_box(rng: &mut Rng, b: Option<Aabb>, reach: f32) -> Option<Aabb> {
    let u = rng.next();
    if u < 0.03 {
        return random_box(rng);
    }
    let b = b?;
    if u < 0.05 {
        return None;
    }
    let d = Vec3::new(
        rng.range(-reach, reach),
        rng.range(-reach, reach),
        rng.range(-reach, reach),
    );
    let grow = rng.range(-0.05, 0.05);
    let moved = Aabb {
        min: b.min + d,
        max: (b.max + d + Vec3::splat(grow)).max(b.min + d),
    };
    // Now and then onto the half-cell lattice: bounds exactly on cell faces.
    if u > 0.8 {
        let snap = |v: Vec3| Vec3::new(snap(v.x), snap(v.y), snap(v.z));
        return Some(Aabb {
            min: snap(moved.min),
            max: snap(moved.max),
        });
    }
    Some(moved)
}

/// Oracle: after every update the table is the whole rebuild over the new boxes, entry
/// for entry, bucket offsets, bounds, length and counters, over random moves of 60 boxes
/// in tables of 1 to 97 buckets (many cells to a bucket), small moves and large ones,
/// boxes appearing and vanishing, half of them listed and sorted in two parts split
/// anywhere (`SpatialHash::update_sorted`). A whole rebuild over separate storage is the
/// reference.
#[test]
fn an_update_is_the_whole_rebuild_entry_for_entry() {
    let mut rng = Rng(0x5eed_1234_abcd_0001);
    let (mut updated, mut refused, mut saturated, mut parted) = (0, 0, 0, 0);
    let (mut one_sided, mut halved) = (0, 0);
    // Cuts whose side buffer is the lower part's, the upper part's; at bucket 0, at the end.
    let mut cuts = [0u32; 4];
    for round in 0..300 {
        let buckets = [2usize, 3, 8, 30, 98][round % 5];
        let (mut s1, mut e1) = ([0u32; 98], [HashEntry::EMPTY; 1_500]);
        let (mut s2, mut e2) = ([0u32; 98], [HashEntry::EMPTY; 1_500]);
        let mut scratch = [HashEntry::EMPTY; 3_000];
        let mut boxes = [None; ITEMS];
        for b in boxes.iter_mut() {
            *b = random_box(&mut rng);
        }
        // Every fourth table is sized to its first build and a few entries more: moves
        // that grow it past its capacity, a saturated whole build, then none to update.
        let cap = if round % 4 == 3 {
            let mut first = SpatialHash::new(&mut s2[..buckets], &mut e2, 1.0).unwrap();
            let need = first.rebuild(ITEMS, |i| boxes[i]).entries;
            (need + round % 7).min(1_500)
        } else {
            1_500
        };
        let mut live = SpatialHash::new(&mut s1[..buckets], &mut e1[..cap], 1.0).unwrap();
        live.rebuild(ITEMS, |i| boxes[i]);
        let reach = [0.02f32, 0.2, 1.5][round % 3];
        let room = match (round / 3) % 4 {
            0 => 3_000,
            1 => 800,
            2 => 120,
            _ => (rng.next() * 400.0) as usize,
        };
        let mut refused_here = 0;
        for _ in 0..6 {
            let mut next = boxes;
            for b in next.iter_mut() {
                *b = moved_box(&mut rng, *b, reach);
            }
            let mut calls = 0;
            let mut moved = |i: usize| {
                assert_eq!(i, calls, "items in order");
                calls += 1;
                (boxes[i], next[i])
            };
            // Every other update from two parts' listings, split anywhere, a quarter of
            // them at or next to either end.
            let got = if rng.next() < 0.5 {
                live.update(ITEMS, moved, &mut scratch[..room])
            } else {
                let k = ((rng.next() * (ITEMS + 1) as f32) as usize).min(ITEMS);
                let k = match rng.next() {
                    u if u < 0.25 => [0, 1, ITEMS - 1, ITEMS][k % 4],
                    _ => k,
                };
                let (lo, hi) = scratch[..room].split_at_mut(room / 2);
                let first = live.changes_sorted(0..k, ITEMS, &mut moved, lo);
                let second = live.changes_sorted(k..ITEMS, ITEMS, &mut moved, hi);
                one_sided += u32::from(first.is_some() != second.is_some());
                // The table's move in one part, or cut at the middle or at any bucket
                // (the ends too), its two parts run in either order.
                let cut = match rng.next() {
                    u if u < 0.25 => None,
                    u if u < 0.5 => Some(live.middle_bucket()),
                    _ => Some(((rng.next() * (buckets + 1) as f32) as usize).min(buckets)),
                };
                let flip = rng.next() < 0.5;
                let run = |a: MoveSpan<'_>, b: MoveSpan<'_>| {
                    halved += 1;
                    let (below, s) = (a.cut_of().0, b.cut_of().1);
                    cuts[0] += u32::from(s > 0);
                    cuts[1] += u32::from(s < 0);
                    cuts[2] += u32::from(below.end == 0);
                    // `buckets` offsets: one bucket fewer.
                    cuts[3] += u32::from(below.end == buckets - 1);
                    if flip {
                        let later = b.run();
                        a.run() && later
                    } else {
                        let later = a.run();
                        b.run() && later
                    }
                };
                let got = live.update_sorted(ITEMS, first, second, &mut scratch[..room], cut, run);
                parted += u32::from(got.is_some());
                got
            };
            assert_eq!(calls, ITEMS, "every item once");
            let got = match got {
                Some(g) => {
                    updated += 1;
                    g
                }
                None => {
                    refused += 1;
                    refused_here += 1;
                    live.rebuild(ITEMS, |i| next[i])
                }
            };
            boxes = next;
            let mut whole = SpatialHash::new(&mut s2[..buckets], &mut e2[..cap], 1.0).unwrap();
            let want = whole.rebuild(ITEMS, |i| boxes[i]);
            assert_eq!(got, want, "round {round}");
            assert_eq!(live.starts, whole.starts, "round {round}");
            assert_eq!(live.entries[..live.used], whole.entries[..whole.used]);
            assert_eq!(live.bounds, whole.bounds);
            assert_eq!(live.whole, (!want.saturated).then_some(ITEMS));
            saturated += u32::from(want.saturated);
        }
        assert_eq!(live.stats().builds, 7);
        assert_eq!(live.stats().updates, 6 - refused_here);
    }
    // Both ways taken: most updates fit; the small scratch refuses the large moves and
    // the tables of two or three buckets (a changed bucket passes through the scratch).
    assert!(
        updated > 350 && refused > 50,
        "{updated} updated, {refused} refused"
    );
    assert!(saturated > 20, "{saturated} saturated builds");
    assert!(parted > 120, "{parted} updates made from two parts");
    assert!(halved > 50, "{halved} table moves in two parts");
    assert!(
        cuts.iter().all(|&c| c > 5),
        "{cuts:?} cuts: s > 0, s < 0, at 0, at the end"
    );
    assert!(
        one_sided > 100,
        "{one_sided} updates refused by one part only"
    );
}

/// A table that does not hold what `moved` says (offsets, entries or length corrupted,
/// old boxes of another build) gives `None` or some table, never a panic, and the queries
/// after it do not panic either; so do two parts' lists joined over a shorter scratch
/// than the one they were listed in.
#[test]
fn an_update_over_a_corrupted_table_does_not_panic() {
    let mut rng = Rng(0xdead_beef_0bad_f00d);
    let mut spans = 0u32;
    for round in 0..3_000 {
        let buckets = [2usize, 3, 4, 8, 14][round % 5];
        let cap = [0usize, 5, 30, 300][(round / 5) % 4];
        let (mut starts, mut entries) = ([0u32; 14], [HashEntry::EMPTY; 300]);
        let mut h = SpatialHash::new(&mut starts[..buckets], &mut entries[..cap], 1.0).unwrap();
        let (mut a, mut b, mut c) = ([None; 20], [None; 20], [None; 20]);
        for i in 0..20 {
            a[i] = random_box(&mut rng);
            b[i] = if rng.next() < 0.7 {
                a[i]
            } else {
                random_box(&mut rng)
            };
            c[i] = random_box(&mut rng);
        }
        h.rebuild(20, |i| a[i]);
        match round % 6 {
            1 => h
                .starts
                .iter_mut()
                .for_each(|s| *s = (rng.next() * 310.0) as u32),
            2 => h.entries.iter_mut().for_each(|e| e.cell[0] += 1),
            3 => h.used = (rng.next() * 350.0) as usize,
            4 => h.starts.reverse(),
            5 => h.entries.iter_mut().for_each(|e| e.packed ^= 1),
            _ => {}
        }
        h.whole = Some(20);
        let mut scratch = [HashEntry::EMPTY; 400];
        let room = (rng.next() * 400.0) as usize;
        let _ = h.update(20, |i| (b[i], c[i]), &mut scratch[..room]);
        let _ = h.update(20, |i| (c[i], a[i]), &mut scratch[..room]);
        // In two parts, joined over the scratch they were listed in or over a shorter one.
        h.whole = Some(20);
        let k = (rng.next() * 21.0) as usize;
        let mut moved = |i: usize| (a[i], b[i]);
        let (lo, hi) = scratch[..room].split_at_mut(room / 2);
        let first = h.changes_sorted(0..k.min(20), 20, &mut moved, lo);
        let second = h.changes_sorted(k.min(20)..20, 20, &mut moved, hi);
        let shorter = match rng.next() {
            u if u < 0.5 => ((rng.next() * (room + 1) as f32) as usize).min(room),
            _ => room,
        };
        let cut = Some((rng.next() * 16.0) as usize);
        let run = |a: MoveSpan<'_>, b: MoveSpan<'_>| {
            spans += 1;
            a.run() & b.run()
        };
        let _ = h.update_sorted(20, first, second, &mut scratch[..shorter], cut, run);
        let all = Aabb {
            min: Vec3::splat(-8.0),
            max: Vec3::splat(8.0),
        };
        h.query_box(&all, 10_000, |_, _| {});
    }
    // The table's move in two parts ran over some of these tables.
    assert!(spans > 30, "{spans} moves in two parts");
}

/// Refusals leave the table as it was (a scratch too small, a table that is not a
/// whole build of the count, entries past the capacity), or flag it for a whole build
/// (old boxes other than the last build's).
#[test]
fn an_update_refuses_what_it_cannot_match() {
    let a = Aabb {
        min: Vec3::new(0.1, 0.1, 0.1),
        max: Vec3::new(1.2, 0.2, 0.2),
    };
    let b = Aabb {
        min: Vec3::new(3.1, 0.1, 0.1),
        max: Vec3::new(3.2, 0.2, 0.2),
    };
    let far = Aabb {
        min: Vec3::new(5.1, 0.1, 0.1),
        max: Vec3::new(7.2, 0.2, 0.2),
    };
    let (mut starts, mut entries) = ([0u32; 8], [HashEntry::EMPTY; 4]);
    let mut scratch = [HashEntry::EMPTY; 16];
    let mut h = SpatialHash::new(&mut starts, &mut entries, 1.0).unwrap();
    // Never built.
    assert!(h.update(0, |_| (None, None), &mut scratch).is_none());
    assert!(!h.rebuild(2, |i| [Some(a), Some(b)][i]).saturated);
    let before = (*h.starts).to_vec();
    // Another count.
    assert!(h.update(1, |_| (Some(a), Some(a)), &mut scratch).is_none());
    // Scratch too small for item 1's one old and one new entry.
    let moves = |i: usize| [(Some(a), Some(a)), (Some(b), Some(a))][i];
    assert!(h.update(2, moves, &mut scratch[..1]).is_none());
    // Three new cells for one old: five entries in a table of four.
    let moves = |i: usize| [(Some(a), Some(a)), (Some(b), Some(far))][i];
    assert!(h.update(2, moves, &mut scratch).is_none());
    assert_eq!(&*h.starts, &before[..]);
    assert_eq!(h.stats().builds, 1);
    // Old boxes the table was not built from: refused, a whole build needed.
    let moves = |i: usize| [(Some(a), Some(a)), (Some(far), Some(b))][i];
    assert!(h.update(2, moves, &mut scratch).is_none());
    assert_eq!(h.whole, None);
    assert!(h
        .update(
            2,
            |i| [(Some(a), Some(a)), (Some(b), Some(b))][i],
            &mut scratch
        )
        .is_none());
    // A saturated build is not a whole one either.
    assert!(h.rebuild(3, |i| [Some(a), Some(b), Some(far)][i]).saturated);
    assert!(h.update(3, |_| (None, None), &mut scratch).is_none());
    assert_eq!(
        h.stats(),
        HashStats {
            builds: 2,
            saturations: 1,
            clipped_queries: 0,
            updates: 0,
        }
    );
}

/// Oracle of `same_cells`: the floors in `f32` lanes against the integer cell ranges
/// (`cell_range`, `floor_i32`), over boxes with bounds on cell faces and next to them
/// (one ulp either side), at -0.0, near and beyond 2^22 cells, and not finite, with cell
/// sizes of 1, 0.1 and 3. Where it answers it answers as the ranges do; it answers
/// whenever every bound lies within 2^22 cells.
#[test]
fn same_cells_answers_as_the_cell_ranges() {
    let mut rng = Rng(0x0f10_0f10_5eed_0002);
    let (mut answered, mut same, mut differ, mut unsure) = (0u32, 0u32, 0u32, 0u32);
    for cell in [1.0f32, 0.1, 3.0] {
        let (mut starts, mut entries) = ([0u32; 8], [HashEntry::EMPTY; 4]);
        let h = SpatialHash::new(&mut starts, &mut entries, cell).unwrap();
        let coord = |rng: &mut Rng| -> f32 {
            let u = rng.next();
            let on_face = libm::roundf(rng.range(-20.0, 20.0)) * cell;
            match (u * 10.0) as u32 {
                0 => on_face,
                1 => f32::from_bits(on_face.to_bits().wrapping_add(1)),
                2 => f32::from_bits(on_face.to_bits().wrapping_sub(1)),
                3 => -0.0,
                4 => {
                    rng.range(4_194_000.0, 4_194_400.0)
                        * cell
                        * [1.0, -1.0][(u * 100.0) as usize % 2]
                }
                5 if u < 0.51 => [f32::NAN, f32::INFINITY, 1e30][(u * 1000.0) as usize % 3],
                _ => rng.range(-20.0, 20.0) * cell,
            }
        };
        for _ in 0..20_000 {
            let mut v = [0.0f32; 12];
            for x in v.iter_mut() {
                *x = coord(&mut rng);
            }
            // The second box mostly the first one nudged, so that both answers are common.
            if rng.next() < 0.6 {
                for i in 0..6 {
                    v[6 + i] = if rng.next() < 0.7 {
                        v[i]
                    } else {
                        v[i] + rng.range(-0.3, 0.3) * cell
                    };
                }
            }
            let bx = |o: usize| Aabb {
                min: Vec3::new(v[o], v[o + 1], v[o + 2]),
                max: Vec3::new(v[o + 3], v[o + 4], v[o + 5]),
            };
            let (a, b) = (bx(0), bx(6));
            let within = v.iter().all(|&x| (x * h.inv_cell).abs() < 4_194_304.0);
            match h.same_cells(&a, &b) {
                Some(got) => {
                    assert!(within, "{v:?}");
                    assert_eq!(got, h.cell_range(&a) == h.cell_range(&b), "{v:?}");
                    answered += 1;
                    same += u32::from(got);
                    differ += u32::from(!got);
                }
                None => {
                    assert!(!within, "{v:?}");
                    unsure += 1;
                }
            }
        }
    }
    assert!(
        answered > 20_000 && unsure > 5_000,
        "{answered} answered, {unsure} not"
    );
    assert!(
        same > 5_000 && differ > 5_000,
        "{same} same, {differ} differ"
    );
}
