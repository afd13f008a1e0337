//! Filling a [`SpatialHash`]: the counting sort of items' boxes into their cells, whole
//! ([`SpatialHash::rebuild`]) or spread over calls into a second table that is then taken
//! into use ([`SpatialHash::rebuild_part`], [`SpatialHash::adopt`]).

use glam::Vec3;

use super::cell::{bucket_of, cells_in, for_cells, Aabb};
use super::table::{HashEntry, SpatialHash, MAX_ITEMS};

/// What one build stored.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default)]
pub struct Rebuilt {
    /// Items stored (always the first `items` of the input, each in all its cells).
    pub items: usize,
    /// Entries used.
    pub entries: usize,
    /// `true` when the entry storage filled up and later items were left out.
    pub saturated: bool,
}

/// Units of one item in each item pass of `SpatialHash::rebuild_part` (the box's cell
/// range and, per cell, its bucket: about 480 Cortex-M4 instructions for a tet about a cell
/// wide, the units of `soft::Link` being about 37 instructions each).
pub const REBUILD_ITEM_UNITS: u32 = 13;
/// Buckets cleared or summed per unit in [`SpatialHash::rebuild_part`].
pub(crate) const REBUILD_BUCKETS_PER_UNIT: usize = 16;

/// The passes of a spread rebuild.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default)]
enum RebuildPhase {
    /// Clearing the bucket counts.
    #[default]
    Clear,
    /// Counting each item's cells per bucket.
    Count,
    /// The prefix sum over the buckets.
    Prefix,
    /// Writing the entries.
    Fill,
}

/// Where a rebuild spread over calls stands ([`SpatialHash::rebuild_part`]); the default is
/// a build not started.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default)]
pub(crate) struct RebuildCursor {
    phase: RebuildPhase,
    at: usize,
    total: usize,
    kept: usize,
    run: u32,
}

impl RebuildCursor {
    /// `true` before the first call of a build (or after its last).
    #[cfg(test)]
    pub(crate) fn is_fresh(&self) -> bool {
        *self == Self::default()
    }
}

impl<'a> SpatialHash<'a> {
    /// Replaces the contents with items `0..count`, item `i` stored in every cell its box
    /// `bounds(i)` overlaps (`None`: item left out, e.g. a degenerate one). Counting sort: one
    /// counting pass, one prefix sum, one filling pass. At most `MAX_ITEMS` items: the rest
    /// are left out as if the storage were full.
    ///
    /// # Bounded work
    /// O(buckets + count + capacity): each pass stops once the entries would exceed the
    /// capacity, so a huge box costs at most the capacity.
    ///
    /// When the entries would overflow the capacity, the table keeps the first items that fit
    /// completely, reports `saturated` and counts it in [`HashStats::saturations`].
    ///
    /// [`HashStats::saturations`]: super::HashStats::saturations
    pub fn rebuild<F>(&mut self, count: usize, bounds: F) -> Rebuilt
    where
        F: Fn(usize) -> Option<Aabb>,
    {
        // The spread build run to its end: one pass of calls of the most units a call takes
        // (a build of more than `u32::MAX` units takes a few).
        let mut cursor = RebuildCursor::default();
        let built = loop {
            if let (_, Some(built)) = self.rebuild_part(&mut cursor, count, &bounds, u32::MAX) {
                break built;
            }
        };
        self.stats.builds = self.stats.builds.wrapping_add(1);
        if built.saturated {
            self.stats.saturations = self.stats.saturations.wrapping_add(1);
        }
        built
    }

    /// The build, spread over calls (into this table while another one answers the queries;
    /// [`SpatialHash::rebuild`] runs it to its end at once): a counting sort, one counting
    /// pass, one prefix sum, one filling pass. Each call goes on from `cursor` (a fresh
    /// [`RebuildCursor::default`] starts a build) and does at most `max_units` units
    /// ([`REBUILD_ITEM_UNITS`] per item in each of the two item passes, one per
    /// [`REBUILD_BUCKETS_PER_UNIT`] buckets in each of the two bucket passes; a step is
    /// taken only while it fits). Returns the units done and, once the build is complete,
    /// what it stored. `count` and `bounds` must be the same for every call of one build.
    /// The counters are not touched here: [`SpatialHash::rebuild`] counts its build, and
    /// [`SpatialHash::adopt`] counts a spread one when the table is taken into use.
    ///
    /// # Bounded work
    /// At most `max_units` units plus the cells of one item's box (at most the capacity).
    pub(crate) fn rebuild_part<F>(
        &mut self,
        cursor: &mut RebuildCursor,
        count: usize,
        bounds: F,
        max_units: u32,
    ) -> (u32, Option<Rebuilt>)
    where
        F: Fn(usize) -> Option<Aabb>,
    {
        let nb = self.buckets();
        let cap = self.entries.len();
        let mut left = max_units;
        let c = cursor;
        loop {
            match c.phase {
                RebuildPhase::Clear => {
                    if c.at == 0 {
                        self.bounds = Aabb::of::<0>([]);
                        self.whole = None;
                        c.total = 0;
                        c.kept = count.min(MAX_ITEMS);
                        c.run = 0;
                    }
                    if c.at >= self.starts.len() {
                        c.phase = RebuildPhase::Count;
                        c.at = 0;
                        continue;
                    }
                    if left < 1 {
                        break;
                    }
                    left -= 1;
                    let end = (c.at + REBUILD_BUCKETS_PER_UNIT).min(self.starts.len());
                    if let Some(part) = self.starts.get_mut(c.at..end) {
                        part.fill(0);
                    }
                    c.at = end;
                }
                RebuildPhase::Count => {
                    if c.at >= c.kept {
                        c.phase = RebuildPhase::Prefix;
                        c.at = 0;
                        continue;
                    }
                    if left < REBUILD_ITEM_UNITS {
                        break;
                    }
                    left -= REBUILD_ITEM_UNITS;
                    let i = c.at;
                    c.at += 1;
                    let Some(b) = bounds(i) else { continue };
                    match self.count_item(&b, cap - c.total, nb) {
                        Some(n) => c.total += n,
                        None => c.kept = i,
                    }
                }
                RebuildPhase::Prefix => {
                    if c.at >= self.starts.len() {
                        c.phase = RebuildPhase::Fill;
                        c.at = 0;
                        continue;
                    }
                    if left < 1 {
                        break;
                    }
                    left -= 1;
                    let end = (c.at + REBUILD_BUCKETS_PER_UNIT).min(self.starts.len());
                    for s in self.starts.get_mut(c.at..end).unwrap_or(&mut []) {
                        c.run += *s;
                        *s = c.run;
                    }
                    c.at = end;
                }
                RebuildPhase::Fill => {
                    if c.at >= c.kept {
                        self.used = c.total;
                        self.whole = (c.kept == count).then_some(count);
                        let built = Rebuilt {
                            items: c.kept,
                            entries: c.total,
                            saturated: c.kept < count,
                        };
                        *c = RebuildCursor::default();
                        return (max_units - left, Some(built));
                    }
                    if left < REBUILD_ITEM_UNITS {
                        break;
                    }
                    left -= REBUILD_ITEM_UNITS;
                    let i = c.at;
                    c.at += 1;
                    let Some(b) = bounds(i) else { continue };
                    self.fill_item(i, &b, nb);
                }
            }
        }
        (max_units - left, None)
    }

    /// Units of a whole [`SpatialHash::rebuild_part`] build of `count` items (fewer when the
    /// entries run out: the items left out are not filled).
    ///
    /// # Bounded work
    /// Constant.
    pub(crate) fn rebuild_units(&self, count: usize) -> u64 {
        let chunks = self.starts.len().div_ceil(REBUILD_BUCKETS_PER_UNIT) as u64;
        2 * chunks + 2 * count.min(MAX_ITEMS) as u64 * u64::from(REBUILD_ITEM_UNITS)
    }

    /// Takes the table `other` built ([`SpatialHash::rebuild_part`], reporting `built`) into
    /// use: the two tables' storage and contents are swapped (`other` gets this one's old
    /// table, to build the next one in), and this table's counters count the build as
    /// [`SpatialHash::rebuild`] does. Refused (`false`, nothing changed) when the two
    /// tables differ in bucket count, capacity or cell size.
    ///
    /// # Bounded work
    /// Constant.
    pub(crate) fn adopt(&mut self, other: &mut SpatialHash<'a>, built: Rebuilt) -> bool {
        if other.buckets() != self.buckets()
            || other.capacity() != self.capacity()
            || other.cell.to_bits() != self.cell.to_bits()
        {
            return false;
        }
        core::mem::swap(&mut self.starts, &mut other.starts);
        core::mem::swap(&mut self.entries, &mut other.entries);
        core::mem::swap(&mut self.used, &mut other.used);
        core::mem::swap(&mut self.bounds, &mut other.bounds);
        core::mem::swap(&mut self.whole, &mut other.whole);
        self.stats.builds = self.stats.builds.wrapping_add(1);
        if built.saturated {
            self.stats.saturations = self.stats.saturations.wrapping_add(1);
        }
        true
    }

    /// The counting pass's work for an item with box `b`: when its cells fit in the `room`
    /// entries left, counts them in their buckets, grows the stored bounds and returns how
    /// many; `None` (nothing changed) when they do not fit.
    #[inline]
    fn count_item(&mut self, b: &Aabb, room: usize, nb: u32) -> Option<usize> {
        let (lo, hi) = self.cell_range(b);
        let n = cells_in(lo, hi);
        if n > room as u64 {
            return None;
        }
        self.bounds = self.bounds.union(*b);
        for_cells(lo, hi, |c| {
            let k = bucket_of(c, nb) as usize;
            if let Some(s) = self.starts.get_mut(k) {
                *s += 1;
            }
        });
        Some(n as usize)
    }

    /// The filling pass's work for item `i` with box `b`.
    #[inline]
    fn fill_item(&mut self, i: usize, b: &Aabb, nb: u32) {
        let (lo, hi) = self.cell_range(b);
        let (starts, entries) = (&mut *self.starts, &mut *self.entries);
        for_cells(lo, hi, |c| {
            let k = bucket_of(c, nb) as usize;
            if let Some(s) = starts.get_mut(k) {
                *s = s.saturating_sub(1);
                if let Some(e) = entries.get_mut(*s as usize) {
                    *e = HashEntry::of(i, c, lo);
                }
            }
        });
    }

    /// Hashes points: item `i` is `points[i]`, in one cell each.
    ///
    /// # Bounded work
    /// O(buckets + points.len()); saturates like [`SpatialHash::rebuild`].
    pub fn rebuild_points(&mut self, points: &[Vec3]) -> Rebuilt {
        self.rebuild(points.len(), |i| points.get(i).map(|&p| Aabb::point(p)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::hash::HashStats;

    #[test]
    fn points_round_trip_and_cell_check() {
        let mut starts = [0u32; 4]; // 3 buckets: many cells share one
        let mut entries = [HashEntry::default(); 16];
        let mut h = SpatialHash::new(&mut starts, &mut entries, 1.0).unwrap();
        let pts = [
            Vec3::new(0.5, 0.5, 0.5),
            Vec3::new(-0.5, 0.5, 0.5),
            Vec3::new(0.9, 0.1, 0.2),
            Vec3::new(5.5, -3.5, 2.5),
        ];
        let r = h.rebuild_points(&pts);
        assert_eq!(
            r,
            Rebuilt {
                items: 4,
                entries: 4,
                saturated: false
            }
        );
        let mut got = [u32::MAX; 4];
        let mut n = 0;
        for it in h.items_in_cell([0, 0, 0]) {
            got[n] = it;
            n += 1;
        }
        got[..n].sort_unstable();
        assert_eq!(&got[..n], &[0, 2]);
        assert_eq!(h.items_in_cell([-1, 0, 0]).count(), 1);
        assert_eq!(h.items_in_cell([5, -4, 2]).next(), Some(3));
        assert_eq!(h.items_in_cell([7, 7, 7]).count(), 0);
    }

    /// A rebuild spread over calls of every size, into a second table, gives the entries,
    /// starts, bounds and report of one `rebuild` (the same build in one call: this checks
    /// the slicing), full tables and missing items included; `adopt` then counts it as
    /// `rebuild` does. The entries themselves are checked against brute force by the
    /// queries' tests.
    #[test]
    fn a_spread_rebuild_is_the_whole_rebuild() {
        // Boxes of one to eight cells, one missing, some far apart (buckets shared).
        let boxes = |i: usize| -> Option<Aabb> {
            if i == 5 {
                return None;
            }
            let x = (i * 37 % 11) as f32 * 0.7 - 3.0;
            let y = (i * 13 % 7) as f32 * 0.9 - 2.0;
            let z = (i * 5 % 3) as f32 * 1.3;
            let w = 0.3 + (i % 3) as f32 * 0.5;
            Some(Aabb {
                min: Vec3::new(x, y, z),
                max: Vec3::new(x + w, y + w * 0.5, z + 0.2),
            })
        };
        let mut saturated = 0;
        for cap in [4usize, 20, 200] {
            for units in [REBUILD_ITEM_UNITS, REBUILD_ITEM_UNITS + 5, 40, u32::MAX] {
                let (mut s1, mut e1) = ([0u32; 8], [HashEntry::default(); 200]);
                let (mut s2, mut e2) = ([0u32; 8], [HashEntry::default(); 200]);
                let mut whole = SpatialHash::new(&mut s1, &mut e1[..cap], 1.0).unwrap();
                let mut spare = SpatialHash::new(&mut s2, &mut e2[..cap], 1.0).unwrap();
                let want = whole.rebuild(30, boxes);
                let mut cursor = RebuildCursor::default();
                let mut calls = 0;
                let got = loop {
                    let (done, built) = spare.rebuild_part(&mut cursor, 30, boxes, units);
                    assert!(done <= units);
                    calls += 1;
                    if let Some(b) = built {
                        break b;
                    }
                    assert!(calls < 10_000);
                };
                assert!(cursor.is_fresh());
                assert_eq!(got, want, "capacity {cap}, {units} units");
                assert_eq!(spare.starts, whole.starts);
                assert_eq!(spare.entries[..spare.used], whole.entries[..whole.used]);
                assert_eq!(spare.bounds, whole.bounds);
                assert_eq!(spare.stats, HashStats::default());
                // Taken into use by a third table that was built once before.
                let (mut s3, mut e3) = ([0u32; 8], [HashEntry::default(); 200]);
                let mut main = SpatialHash::new(&mut s3, &mut e3[..cap], 1.0).unwrap();
                main.rebuild(0, |_| None);
                assert!(main.adopt(&mut spare, got));
                let counted = HashStats {
                    builds: 2,
                    saturations: u32::from(got.saturated),
                    clipped_queries: 0,
                    updates: 0,
                };
                assert_eq!(main.stats(), counted);
                saturated += u32::from(got.saturated);
                assert_eq!(main.len(), whole.len());
                for c in [[0, 0, 0], [-3, -2, 0], [1, 0, 1]] {
                    assert!(main.items_in_cell(c).eq(whole.items_in_cell(c)));
                }
            }
        }
        assert!(saturated > 0 && saturated < 12, "{saturated} full builds");
        // Tables of other sizes are not adopted.
        let (mut s1, mut e1) = ([0u32; 8], [HashEntry::default(); 4]);
        let (mut s2, mut e2) = ([0u32; 6], [HashEntry::default(); 4]);
        let mut a = SpatialHash::new(&mut s1, &mut e1, 1.0).unwrap();
        let mut b = SpatialHash::new(&mut s2, &mut e2, 1.0).unwrap();
        assert!(!a.adopt(&mut b, Rebuilt::default()));
    }

    #[test]
    fn full_table_saturates_and_counts() {
        let mut starts = [0u32; 6];
        let mut entries = [HashEntry::default(); 3];
        let mut h = SpatialHash::new(&mut starts, &mut entries, 1.0).unwrap();
        // Item 0 covers 2 cells, item 1 covers 2 cells: only item 0 fits.
        let boxes = [
            Aabb {
                min: Vec3::new(0.1, 0.1, 0.1),
                max: Vec3::new(1.1, 0.2, 0.2),
            },
            Aabb {
                min: Vec3::new(2.1, 0.1, 0.1),
                max: Vec3::new(3.1, 0.2, 0.2),
            },
        ];
        let r = h.rebuild(2, |i| boxes.get(i).copied());
        assert_eq!(
            r,
            Rebuilt {
                items: 1,
                entries: 2,
                saturated: true
            }
        );
        assert_eq!(h.stats().saturations, 1);
        assert_eq!(h.items_in_cell([1, 0, 0]).next(), Some(0));
        assert_eq!(h.items_in_cell([2, 0, 0]).count(), 0);
        // A huge box saturates at once, without walking its cells.
        let huge = Aabb {
            min: Vec3::splat(-1e30),
            max: Vec3::splat(1e30),
        };
        let r = h.rebuild(1, |_| Some(huge));
        assert!(r.saturated);
        assert_eq!(r.items, 0);
        let mut seen = 0;
        assert!(!h.query_box(&huge, 1000, |_, _| seen += 1));
        assert_eq!(h.stats().clipped_queries, 1);
        assert_eq!(seen, 0);
    }
}
