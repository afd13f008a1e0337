//! [`SpatialHash`]: the dense counting-sort table over caller storage.
//!
//! Files: this one holds the table, its entries, errors, counters and accessors;
//! `rebuild.rs` fills it (the counting sort, whole or spread over calls), `query.rs` reads it
//! (the items of a cell, of the cells a box covers); the cell ranges both walk are in
//! `cell.rs`.

use glam::Vec3;

use super::cell::{cell_of, Aabb, Cell};

/// One stored item in one cell.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C)]
pub struct HashEntry {
    /// The cell the item was put in (checked on every query).
    pub cell: Cell,
    /// The item number in the low [`ITEM_BITS`] bits; bit `ITEM_BITS + a` is set when `cell`
    /// is the lowest cell of the item's box along axis `a` (what lets
    /// [`SpatialHash::query_box_once`] report an item once without looking at its box).
    pub(super) packed: u32,
}

/// Bits of an item number: items `0..2^29` (a tet id, a node id, `tet * 4 + face`, ...).
pub(crate) const ITEM_BITS: u32 = 29;

/// Largest number of items one table holds.
pub(crate) const MAX_ITEMS: usize = 1 << ITEM_BITS;

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

    /// Item `i`'s entry in cell `c` of the cell range starting at `lo`.
    #[inline]
    pub(super) fn of(i: usize, c: Cell, lo: Cell) -> Self {
        let mut packed = i as u32;
        for a in 0..3 {
            packed |= u32::from(c[a] == lo[a]) << (ITEM_BITS as usize + a);
        }
        Self { cell: c, packed }
    }
}

/// Why a [`SpatialHash`] cannot be made.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
#[non_exhaustive]
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

impl core::error::Error for HashError {}

/// Counters kept across builds and queries.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default)]
#[non_exhaustive]
pub struct HashStats {
    /// Builds done.
    pub builds: u32,
    /// Builds that ran out of entry storage (items were left out).
    pub saturations: u32,
    /// Box queries cut short because the box covered more cells than allowed.
    pub clipped_queries: u32,
    /// Builds made by moving only the items whose cells changed (`SpatialHash::update`;
    /// counted in `builds` too).
    pub updates: u32,
}

/// A spatial hash over caller storage: `starts` (bucket count + 1 offsets, the bucket count
/// should be prime) and `entries` (one per item and cell; its length is the capacity).
#[derive(Debug)]
pub struct SpatialHash<'a> {
    pub(super) starts: &'a mut [u32],
    pub(super) entries: &'a mut [HashEntry],
    pub(super) inv_cell: f32,
    pub(super) cell: f32,
    pub(super) used: usize,
    pub(super) bounds: Aabb,
    pub(super) stats: HashStats,
    /// `Some(count)` when the table holds exactly what a whole build of items `0..count`
    /// stores (the last build stored every item): what [`SpatialHash::update`] starts from.
    pub(super) whole: Option<usize>,
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
            whole: None,
        })
    }

    /// Cell edge length.
    #[inline]
    pub(crate) fn cell_size(&self) -> f32 {
        self.cell
    }

    /// Number of buckets.
    #[inline]
    pub(crate) fn buckets(&self) -> u32 {
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

    /// The entry storage as scratch for another table's [`SpatialHash::update`] (a spare
    /// table between builds): the table answers as empty (its length is 0), and its
    /// contents are undefined until its next build.
    ///
    /// # Bounded work
    /// Constant.
    #[inline]
    pub(crate) fn scratch(&mut self) -> &mut [HashEntry] {
        self.used = 0;
        self.whole = None;
        &mut *self.entries
    }

    /// The box around everything stored by the last build.
    #[inline]
    pub(crate) fn bounds(&self) -> Aabb {
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
    pub(crate) fn cell_range(&self, b: &Aabb) -> (Cell, Cell) {
        (self.cell_of(b.min), self.cell_of(b.max))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
