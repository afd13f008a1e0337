//! [`SpatialHash`]: the dense counting-sort table over caller storage.

use glam::Vec3;

use super::cell::{bucket_of, cell_of, same_cell, Aabb, Cell};

/// One stored item in one cell.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C)]
pub struct HashEntry {
    /// The cell the item was put in (checked on every query).
    pub cell: Cell,
    /// The item number in the low [`ITEM_BITS`] bits; bit `ITEM_BITS + a` is set when `cell`
    /// is the lowest cell of the item's box along axis `a` (what lets
    /// [`SpatialHash::query_box_once`] report an item once without looking at its box).
    packed: u32,
}

/// Bits of an item number: items `0..2^29` (a tet id, a node id, `tet * 4 + face`, ...).
pub const ITEM_BITS: u32 = 29;

/// Largest number of items one table holds.
pub const MAX_ITEMS: usize = 1 << ITEM_BITS;

impl HashEntry {
    /// An unused entry (for initialising static storage).
    pub const EMPTY: Self = Self {
        cell: [0; 3],
        packed: 0,
    };

    /// The caller's item number.
    #[inline]
    pub fn item(&self) -> u32 {
        self.packed & (MAX_ITEMS as u32 - 1)
    }
}

/// Why a [`SpatialHash`] cannot be made.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum HashError {
    /// `starts` needs at least two entries (one bucket and its end).
    NoBuckets,
    /// The cell size is not a finite positive number.
    BadCellSize,
}

impl core::fmt::Display for HashError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::NoBuckets => f.write_str("spatial hash needs at least one bucket"),
            Self::BadCellSize => f.write_str("spatial hash cell size must be finite and positive"),
        }
    }
}

/// Counters kept across builds and queries.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default)]
pub struct HashStats {
    /// Builds done.
    pub builds: u32,
    /// Builds that ran out of entry storage (items were left out).
    pub saturations: u32,
    /// Box queries cut short because the box covered more cells than allowed.
    pub clipped_queries: u32,
}

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

/// Units of one item in each item pass of [`SpatialHash::rebuild_part`] (the box's cell
/// range and, per cell, its bucket: about 480 Cortex-M4 instructions for a tet about a cell
/// wide, the units of `soft::Link` being about 37 instructions each).
pub const REBUILD_ITEM_UNITS: u32 = 13;
/// Buckets cleared or summed per unit in [`SpatialHash::rebuild_part`].
pub const REBUILD_BUCKETS_PER_UNIT: usize = 16;

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
pub struct RebuildCursor {
    phase: RebuildPhase,
    at: usize,
    total: usize,
    kept: usize,
    run: u32,
}

impl RebuildCursor {
    /// `true` before the first call of a build (or after its last).
    pub fn is_fresh(&self) -> bool {
        *self == Self::default()
    }
}

/// A spatial hash over caller storage: `starts` (bucket count + 1 offsets, the bucket count
/// should be prime) and `entries` (one per item and cell; its length is the capacity).
#[derive(Debug)]
pub struct SpatialHash<'a> {
    starts: &'a mut [u32],
    entries: &'a mut [HashEntry],
    inv_cell: f32,
    cell: f32,
    used: usize,
    bounds: Aabb,
    stats: HashStats,
}

impl<'a> SpatialHash<'a> {
    /// An empty hash with cells of edge `cell_size` and `starts.len() - 1` buckets.
    ///
    /// # Bounded work
    /// O(buckets) to clear `starts`.
    ///
    /// # Errors
    /// [`HashError`] for fewer than two `starts` or a bad cell size.
    pub fn new(
        starts: &'a mut [u32],
        entries: &'a mut [HashEntry],
        cell_size: f32,
    ) -> Result<Self, HashError> {
        if starts.len() < 2 || starts.len() > u32::MAX as usize {
            return Err(HashError::NoBuckets);
        }
        if !(cell_size.is_finite() && cell_size > 0.0 && (1.0 / cell_size).is_finite()) {
            return Err(HashError::BadCellSize);
        }
        starts.fill(0);
        Ok(Self {
            starts,
            entries,
            inv_cell: 1.0 / cell_size,
            cell: cell_size,
            used: 0,
            bounds: Aabb::of::<0>([]),
            stats: HashStats::default(),
        })
    }

    /// Cell edge length.
    #[inline]
    pub fn cell_size(&self) -> f32 {
        self.cell
    }

    /// Number of buckets.
    #[inline]
    pub fn buckets(&self) -> u32 {
        (self.starts.len() - 1) as u32
    }

    /// Entry capacity.
    #[inline]
    pub fn capacity(&self) -> usize {
        self.entries.len()
    }

    /// Entries stored by the last build.
    #[inline]
    pub fn len(&self) -> usize {
        self.used
    }

    /// `true` when nothing is stored.
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.used == 0
    }

    /// The box around everything stored by the last build.
    #[inline]
    pub fn bounds(&self) -> Aabb {
        self.bounds
    }

    /// Counters.
    #[inline]
    pub fn stats(&self) -> HashStats {
        self.stats
    }

    /// The cell of a point in this hash's grid.
    #[inline]
    pub fn cell_of(&self, p: Vec3) -> Cell {
        cell_of(p, self.inv_cell)
    }

    /// The inclusive cell range a box covers.
    #[inline]
    pub fn cell_range(&self, b: &Aabb) -> (Cell, Cell) {
        (self.cell_of(b.min), self.cell_of(b.max))
    }

    /// Replaces the contents with items `0..count`, item `i` stored in every cell its box
    /// `bounds(i)` overlaps (`None`: item left out, e.g. a degenerate one). Counting sort: one
    /// counting pass, one prefix sum, one filling pass. At most [`MAX_ITEMS`] items: the rest
    /// are left out as if the storage were full.
    ///
    /// # Bounded work
    /// O(buckets + count + capacity): each pass stops once the entries would exceed the
    /// capacity, so a huge box costs at most the capacity.
    ///
    /// When the entries would overflow the capacity, the table keeps the first items that fit
    /// completely, reports `saturated` and counts it in [`HashStats::saturations`].
    pub fn rebuild<F>(&mut self, count: usize, bounds: F) -> Rebuilt
    where
        F: Fn(usize) -> Option<Aabb>,
    {
        self.stats.builds = self.stats.builds.wrapping_add(1);
        let nb = self.buckets();
        let cap = self.entries.len();
        self.starts.fill(0);
        self.bounds = Aabb::of::<0>([]);

        // Pass 1: count entries per bucket, stop at the first item that does not fit (or
        // whose number does not fit in ITEM_BITS).
        let mut total = 0usize;
        let mut kept = count.min(MAX_ITEMS);
        for i in 0..kept {
            let Some(b) = bounds(i) else { continue };
            match self.count_item(&b, cap - total, nb) {
                Some(n) => total += n,
                None => {
                    kept = i;
                    break;
                }
            }
        }
        // Prefix sum: starts[k] = end of bucket k; starts[nb] = total.
        let mut run = 0u32;
        for s in self.starts.iter_mut() {
            run += *s;
            *s = run;
        }
        // Pass 2: fill from the back of each bucket.
        for i in 0..kept {
            let Some(b) = bounds(i) else { continue };
            self.fill_item(i, &b, nb);
        }
        self.used = total;
        let saturated = kept < count;
        if saturated {
            self.stats.saturations = self.stats.saturations.wrapping_add(1);
        }
        Rebuilt {
            items: kept,
            entries: total,
            saturated,
        }
    }

    /// [`SpatialHash::rebuild`] spread over calls, into this table while another one
    /// answers the queries: each call goes on from `cursor` (a fresh
    /// [`RebuildCursor::default`] starts a build) and does at most `max_units` units
    /// ([`REBUILD_ITEM_UNITS`] per item in each of the two item passes, one per
    /// [`REBUILD_BUCKETS_PER_UNIT`] buckets in each of the two bucket passes; a step is
    /// taken only while it fits). Returns the units done and, once the build is complete,
    /// what it stored. `count` and `bounds` must be the same for every call of one build.
    /// The finished table holds the same entries in the same places as one
    /// [`SpatialHash::rebuild`]; the counters are not touched here:
    /// [`SpatialHash::adopt`] counts the build when the table is taken into use.
    ///
    /// # Bounded work
    /// At most `max_units` units plus the cells of one item's box (at most the capacity).
    pub fn rebuild_part<F>(
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
    pub fn rebuild_units(&self, count: usize) -> u64 {
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
    pub fn adopt(&mut self, other: &mut SpatialHash<'a>, built: Rebuilt) -> bool {
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
                    let mut packed = i as u32;
                    for a in 0..3 {
                        packed |= u32::from(c[a] == lo[a]) << (ITEM_BITS as usize + a);
                    }
                    *e = HashEntry { cell: c, packed };
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

    /// The items stored in cell `c` (other cells sharing its bucket are filtered out).
    ///
    /// # Bounded work
    /// O(size of the bucket), at most the entry count.
    #[inline]
    pub fn items_in_cell(&self, c: Cell) -> impl Iterator<Item = u32> + '_ {
        let k = bucket_of(c, self.buckets()) as usize;
        let lo = self.starts.get(k).copied().unwrap_or(0) as usize;
        let hi = self.starts.get(k + 1).copied().unwrap_or(0) as usize;
        let slice = self.entries.get(lo..hi.min(self.used)).unwrap_or(&[]);
        slice
            .iter()
            .filter(move |e| same_cell(&e.cell, &c))
            .map(|e| e.item())
    }

    /// The items stored in cell `c` in increasing item order, as [`SpatialHash::items_in_cell`]
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
    pub fn query_box_ro<F: FnMut(Cell, u32)>(&self, b: &Aabb, max_cells: u32, f: F) -> bool {
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
    pub fn query_cells_once_from<F: FnMut(u32)>(
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

/// Number of cells in an inclusive range (0 for an inverted one).
#[inline]
pub(crate) fn cells_in(lo: Cell, hi: Cell) -> u64 {
    let mut n = 1u64;
    for a in 0..3 {
        let d = hi[a] as i64 - lo[a] as i64 + 1;
        if d <= 0 {
            return 0;
        }
        n = n.saturating_mul(d as u64);
    }
    n
}

/// Visits every cell of an inclusive range, x fastest.
#[inline]
pub(crate) fn for_cells<F: FnMut(Cell)>(lo: Cell, hi: Cell, mut f: F) {
    let mut k = lo[2] as i64;
    while k <= hi[2] as i64 {
        let mut j = lo[1] as i64;
        while j <= hi[1] as i64 {
            let mut i = lo[0] as i64;
            while i <= hi[0] as i64 {
                f([i as i32, j as i32, k as i32]);
                i += 1;
            }
            j += 1;
        }
        k += 1;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
    /// starts, bounds and report of one `rebuild`, full tables and missing items included;
    /// `adopt` then counts it as `rebuild` does.
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

    #[test]
    fn bad_parameters() {
        let mut starts = [0u32; 1];
        let mut entries = [HashEntry::default(); 3];
        assert_eq!(
            SpatialHash::new(&mut starts, &mut entries, 1.0).unwrap_err(),
            HashError::NoBuckets
        );
        let mut starts = [0u32; 3];
        assert_eq!(
            SpatialHash::new(&mut starts, &mut entries, 0.0).unwrap_err(),
            HashError::BadCellSize
        );
    }
}
