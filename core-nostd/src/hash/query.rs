//! Reading a [`SpatialHash`]: the items of one cell, and those of the cells a box covers
//! (per cell, or each item once, whole or in parts of bounded work).

use super::cell::{bucket_of, cells_in, for_cells, same_cell, Aabb, Cell};
use super::table::{SpatialHash, ITEM_BITS};

impl SpatialHash<'_> {
    /// The items stored in cell `c` (other cells sharing its bucket are filtered out).
    ///
    /// # Bounded work
    /// O(size of the bucket), at most the entry count.
    #[inline]
    pub(crate) fn items_in_cell(&self, c: Cell) -> impl Iterator<Item = u32> + '_ {
        let k = bucket_of(c, self.buckets()) as usize;
        let lo = self.starts.get(k).copied().unwrap_or(0) as usize;
        let hi = self.starts.get(k + 1).copied().unwrap_or(0) as usize;
        let slice = self.entries.get(lo..hi.min(self.used)).unwrap_or(&[]);
        slice
            .iter()
            .filter(move |e| same_cell(&e.cell, &c))
            .map(|e| e.item())
    }

    /// The items stored in cell `c` in increasing item order, as `SpatialHash::items_in_cell`
    /// (the filling pass writes each bucket from its back in item order, so this reads the
    /// bucket backwards). Lets a search for the smallest item that passes a test stop at the
    /// first one.
    ///
    /// # Bounded work
    /// O(size of the bucket), at most the entry count.
    #[inline]
    pub fn items_in_cell_ascending(&self, c: Cell) -> impl Iterator<Item = u32> + '_ {
        let k = bucket_of(c, self.buckets()) as usize;
        let lo = self.starts.get(k).copied().unwrap_or(0) as usize;
        let hi = self.starts.get(k + 1).copied().unwrap_or(0) as usize;
        let slice = self.entries.get(lo..hi.min(self.used)).unwrap_or(&[]);
        slice
            .iter()
            .rev()
            .filter(move |e| same_cell(&e.cell, &c))
            .map(|e| e.item())
    }

    /// Calls `f(cell, item)` for every item stored in a cell the box `b` covers; an item
    /// stored in several of those cells is reported once per cell. Boxes covering more than
    /// `max_cells` cells are not visited at all (counted in [`HashStats::clipped_queries`],
    /// returns `false`).
    ///
    /// # Bounded work
    /// O(max_cells + entries met).
    ///
    /// [`HashStats::clipped_queries`]: super::HashStats::clipped_queries
    pub fn query_box<F: FnMut(Cell, u32)>(&mut self, b: &Aabb, max_cells: u32, f: F) -> bool {
        let (lo, hi) = self.cell_range(b);
        if cells_in(lo, hi) > max_cells as u64 {
            self.stats.clipped_queries = self.stats.clipped_queries.wrapping_add(1);
            return false;
        }
        self.visit_box(lo, hi, f);
        true
    }

    /// Like [`SpatialHash::query_box`] without counting (for shared, read-only use);
    /// returns `false` and visits nothing when the box covers more than `max_cells` cells.
    ///
    /// # Bounded work
    /// O(max_cells + entries met).
    pub(crate) fn query_box_ro<F: FnMut(Cell, u32)>(&self, b: &Aabb, max_cells: u32, f: F) -> bool {
        let (lo, hi) = self.cell_range(b);
        if cells_in(lo, hi) > max_cells as u64 {
            return false;
        }
        self.visit_box(lo, hi, f);
        true
    }

    /// Calls `f(item)` once for every item stored in a cell the box `b` covers (in the first
    /// of those cells that holds it, x fastest): the entry of cell `c` is an item's first in
    /// the query when, along each axis, `c` is the query's lowest cell or the item's lowest
    /// one, which the entry records, so no item box is recomputed. Returns `false` and visits
    /// nothing when the box covers more than `max_cells` cells.
    ///
    /// # Bounded work
    /// O(max_cells + entries met), three flag tests per entry.
    pub fn query_box_once<F: FnMut(u32)>(&self, b: &Aabb, max_cells: u32, mut f: F) -> bool {
        let (lo, hi) = self.cell_range(b);
        if cells_in(lo, hi) > max_cells as u64 {
            return false;
        }
        let nb = self.buckets();
        // The bucket scan of `items_in_cell`, written out: through that iterator the
        // replay's candidate queries cost 0.7 % more instructions (callgrind, 2,500 ticks).
        for_cells(lo, hi, |c| {
            let k = bucket_of(c, nb) as usize;
            let start = self.starts.get(k).copied().unwrap_or(0) as usize;
            let end = self.starts.get(k + 1).copied().unwrap_or(0) as usize;
            // The "lowest cell" bits an entry of this cell needs: along every axis where the
            // cell is not the query's lowest. One mask test per entry, then the cell.
            let need = (0..3)
                .filter(|&a| c[a] != lo[a])
                .fold(0u32, |m, a| m | 1 << (ITEM_BITS as usize + a));
            for e in self.entries.get(start..end.min(self.used)).unwrap_or(&[]) {
                if e.packed & need == need && same_cell(&e.cell, &c) {
                    f(e.item());
                }
            }
        });
        true
    }

    /// [`SpatialHash::query_box_once`] over the cells `lo..=hi` (a [`SpatialHash::cell_range`])
    /// in parts: starts at the `from`-th cell of the range (x fastest) and stops before the
    /// cell that would take the work past `max_work` (one unit per cell and per entry
    /// scanned; the first cell is always scanned). Returns the index of the next cell to
    /// scan, the range's cell count when it is done. The parts of one range, run in turn,
    /// report every item exactly as one [`SpatialHash::query_box_once`] of the range does,
    /// in the same order.
    ///
    /// # Bounded work
    /// At most `max_work` units plus the entries of one bucket.
    pub(crate) fn query_cells_once_from<F: FnMut(u32)>(
        &self,
        (lo, hi): (Cell, Cell),
        from: u64,
        max_work: u32,
        mut f: F,
    ) -> u64 {
        let total = cells_in(lo, hi);
        let nb = self.buckets();
        let dx = (hi[0] as i64 - lo[0] as i64 + 1).max(1) as u64;
        let dy = (hi[1] as i64 - lo[1] as i64 + 1).max(1) as u64;
        let mut k = from;
        let mut work = 0u32;
        // The cell of index `from`, then stepped x fastest (one division per call).
        let mut at = [
            lo[0] as i64 + (k % dx) as i64,
            lo[1] as i64 + ((k / dx) % dy) as i64,
            lo[2] as i64 + k.checked_div(dx.saturating_mul(dy)).unwrap_or(0) as i64,
        ];
        while k < total && (work < max_work || k == from) {
            let c = [at[0] as i32, at[1] as i32, at[2] as i32];
            let b = bucket_of(c, nb) as usize;
            let start = self.starts.get(b).copied().unwrap_or(0) as usize;
            let end = self.starts.get(b + 1).copied().unwrap_or(0) as usize;
            let need = (0..3)
                .filter(|&a| c[a] != lo[a])
                .fold(0u32, |m, a| m | 1 << (ITEM_BITS as usize + a));
            let entries = self.entries.get(start..end.min(self.used)).unwrap_or(&[]);
            for e in entries {
                if e.packed & need == need && same_cell(&e.cell, &c) {
                    f(e.item());
                }
            }
            work = work.saturating_add(1 + entries.len() as u32);
            k += 1;
            at[0] += 1;
            if at[0] > hi[0] as i64 {
                at[0] = lo[0] as i64;
                at[1] += 1;
                if at[1] > hi[1] as i64 {
                    at[1] = lo[1] as i64;
                    at[2] += 1;
                }
            }
        }
        k
    }

    fn visit_box<F: FnMut(Cell, u32)>(&self, lo: Cell, hi: Cell, mut f: F) {
        for_cells(lo, hi, |c| {
            for item in self.items_in_cell(c) {
                f(c, item);
            }
        });
    }
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::*;
    use crate::hash::HashEntry;

    /// Random boxes hashed with few buckets (many cells share one), queried by random boxes:
    /// `query_box_once` reports exactly the items whose box's cells meet the query's cells
    /// (brute force over integer cell ranges computed here with `floor`), each once, and in
    /// the first query cell (x fastest) that holds it, as `query_box_ro` visits them.
    #[test]
    fn query_box_once_reports_each_item_once() {
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        let mut rnd = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 40) as f32 / (1u64 << 24) as f32
        };
        let boxes: [Aabb; 60] = core::array::from_fn(|_| {
            let c = Vec3::new(rnd(), rnd(), rnd()) * 8.0 - 4.0;
            let h = Vec3::new(rnd(), rnd(), rnd()) * 1.5;
            Aabb::of([c - h, c + h])
        });
        let mut starts = [0u32; 8]; // 7 buckets
        let mut entries = [HashEntry::EMPTY; 4096];
        let mut h = SpatialHash::new(&mut starts, &mut entries, 0.7).unwrap();
        assert!(!h.rebuild(boxes.len(), |i| boxes.get(i).copied()).saturated);
        let cells = |b: &Aabb| {
            let f = |x: f32| libm::floorf(x * (1.0 / 0.7)) as i32;
            (
                [f(b.min.x), f(b.min.y), f(b.min.z)],
                [f(b.max.x), f(b.max.y), f(b.max.z)],
            )
        };
        for _ in 0..200 {
            let c = Vec3::new(rnd(), rnd(), rnd()) * 8.0 - 4.0;
            let q = Aabb::of([c, c + Vec3::new(rnd(), rnd(), rnd()) * 3.0]);
            let (qlo, qhi) = cells(&q);
            let mut got = [0u32; 60];
            let mut order = [0u32; 60];
            let mut n = 0;
            assert!(h.query_box_once(&q, 10_000, |item| {
                got[item as usize] += 1;
                order[n] = item;
                n += 1;
            }));
            let mut first = [0u32; 60];
            let mut m = 0;
            h.query_box_ro(&q, 10_000, |_, item| {
                if first[..m].iter().all(|&x| x != item) {
                    first[m] = item;
                    m += 1;
                }
            });
            assert_eq!(&order[..n], &first[..m], "order of first sightings");
            // The same query in parts of a few cells' work each: the same items, same order.
            let range = h.cell_range(&q);
            for budget in [1u32, 3, 17] {
                let mut parts = [0u32; 60];
                let mut np = 0;
                let mut at = 0u64;
                let mut calls = 0;
                while at < cells_in(range.0, range.1) {
                    let next = h.query_cells_once_from(range, at, budget, |item| {
                        parts[np] = item;
                        np += 1;
                    });
                    assert!(next > at, "every part scans a cell");
                    at = next;
                    calls += 1;
                }
                assert_eq!(&parts[..np], &order[..n], "parts of {budget} units");
                assert!(budget > 1 || calls as u64 == cells_in(range.0, range.1));
            }
            for (i, b) in boxes.iter().enumerate() {
                let (lo, hi) = cells(b);
                let meets = (0..3).all(|a| lo[a] <= qhi[a] && qlo[a] <= hi[a]);
                assert_eq!(got[i], u32::from(meets), "item {i}");
            }
        }
    }

    /// Random boxes in few buckets: `items_in_cell_ascending` gives, for every cell, the items
    /// whose box covers that cell (brute force with `floor`) in increasing order.
    #[test]
    fn items_in_cell_ascending_is_sorted_and_complete() {
        let mut seed = 0x9e37_79b9_7f4a_7c15u64;
        let mut rnd = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 40) as f32 / (1u64 << 24) as f32
        };
        let boxes: [Aabb; 80] = core::array::from_fn(|_| {
            let c = Vec3::new(rnd(), rnd(), rnd()) * 4.0 - 2.0;
            let h = Vec3::new(rnd(), rnd(), rnd()) * 0.8;
            Aabb::of([c - h, c + h])
        });
        let mut starts = [0u32; 6]; // 5 buckets
        let mut entries = [HashEntry::EMPTY; 4096];
        let mut h = SpatialHash::new(&mut starts, &mut entries, 0.5).unwrap();
        assert!(!h.rebuild(boxes.len(), |i| boxes.get(i).copied()).saturated);
        let f = |x: f32| libm::floorf(x * 2.0) as i32;
        let mut nonempty = 0;
        for i in -6..6 {
            for j in -6..6 {
                for k in -6..6 {
                    let mut want = [0u32; 80];
                    let mut n = 0;
                    for (b, bx) in boxes.iter().enumerate() {
                        let lo = [f(bx.min.x), f(bx.min.y), f(bx.min.z)];
                        let hi = [f(bx.max.x), f(bx.max.y), f(bx.max.z)];
                        let c = [i, j, k];
                        if (0..3).all(|a| lo[a] <= c[a] && c[a] <= hi[a]) {
                            want[n] = b as u32;
                            n += 1;
                        }
                    }
                    let mut got = [0u32; 80];
                    let mut m = 0;
                    for item in h.items_in_cell_ascending([i, j, k]) {
                        got[m] = item;
                        m += 1;
                    }
                    assert_eq!(&got[..m], &want[..n], "cell {i} {j} {k}");
                    nonempty += (n > 1) as u32;
                }
            }
        }
        assert!(nonempty > 100, "cells holding several items: {nonempty}");
    }
}
