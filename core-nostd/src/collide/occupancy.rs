//! [`Occupancy`]: one bit per cell of a coarse grid over a body, set where a tet's box may be,
//! and each tet's box.

use glam::Vec3;

use super::Body;
use crate::hash::{cell_of, Aabb};
use crate::ids::TetId;

/// Why an [`Occupancy`] cannot be built.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum OccupancyError {
    /// No storage words.
    NoStorage,
    /// The cell size or the margin is not a finite positive number (margin: not negative).
    BadCellSize,
    /// The body has no tet with finite corners.
    Empty,
}

impl core::fmt::Display for OccupancyError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::NoStorage => f.write_str("occupancy grid needs at least one storage word"),
            Self::BadCellSize => f.write_str("occupancy cell size must be finite and positive"),
            Self::Empty => f.write_str("occupancy grid over a body without finite tets"),
        }
    }
}

/// Caller storage of an [`Occupancy`].
#[derive(Debug)]
pub struct OccupancyStorage<'a> {
    /// Grid bits, 32 cells a word (the grid coarsens until they fit).
    pub words: &'a mut [u32],
    /// One grown box per tet (tets beyond its length have none and always pass
    /// [`Occupancy::tet_may_hold`]); may be empty.
    pub boxes: &'a mut [Aabb],
}

/// A grid over a static body's bounds with one bit per cell, set when the cell meets the box
/// of one of its tets grown by a margin: a point in a clear cell (or outside the grid) is in
/// no tet, and a box that meets no set cell holds no point of the body's tets. It also keeps
/// each tet's grown box, a cheap test before a barycentric one. Built once at set-up over
/// caller storage; the queries are read-only.
#[derive(Clone, Copy, Debug)]
pub struct Occupancy<'a> {
    words: &'a [u32],
    boxes: &'a [Aabb],
    origin: Vec3,
    inv_cell: f32,
    cell: f32,
    dims: [i32; 3],
}

impl<'a> Occupancy<'a> {
    /// Marks the cells of edge `cell` (or coarser, see below) that each tet's box, grown by
    /// `margin` on every side, meets. The margin covers rounding: a point that
    /// [`crate::geom::barycentric`] puts inside a tet lies within a tiny fraction of an edge of
    /// the tet's box (take about a thousandth of an edge).
    ///
    /// When `storage.words` (32 cells each) cannot hold the grid, the cell size is doubled
    /// until it can: a coarser grid tests the same way, it only culls less. Tets with
    /// non-finite corners are left out (no point is inside them either). The grown box of tet
    /// `t` goes to `storage.boxes[t]` while there is room.
    ///
    /// # Bounded work
    /// O(T) for the bounds and boxes, O(words) to clear, then O(cells each box covers) per tet, at most
    /// the grid's cells per tet. Call it at set-up.
    ///
    /// # Errors
    /// [`OccupancyError`] for empty storage, a bad cell size or margin, or a body with no
    /// finite tet.
    pub fn build(
        body: &Body<'_, '_>,
        cell: f32,
        margin: f32,
        storage: OccupancyStorage<'a>,
    ) -> Result<Self, OccupancyError> {
        let OccupancyStorage { words, boxes } = storage;
        if words.is_empty() {
            return Err(OccupancyError::NoStorage);
        }
        if !(cell.is_finite() && cell > 0.0 && margin.is_finite() && margin >= 0.0) {
            return Err(OccupancyError::BadCellSize);
        }
        let boxed = |t: usize| {
            let c = body.tet_positions(TetId::from_idx(t))?;
            c.iter()
                .all(|p| p.is_finite())
                .then(|| Aabb::of(c).grown(margin))
        };
        let mut bounds = Aabb::of::<0>([]);
        for t in 0..body.tet_count() {
            let b = boxed(t);
            if let Some(b) = b {
                bounds = bounds.union(b);
            }
            if let Some(slot) = boxes.get_mut(t) {
                *slot = b.unwrap_or(Aabb::of::<0>([]));
            }
        }
        if !(bounds.min.is_finite() && bounds.max.is_finite()) {
            return Err(OccupancyError::Empty);
        }
        let capacity = words.len() as u64 * 32;
        let mut cell = cell;
        let dims = loop {
            let inv = 1.0 / cell;
            let e = (bounds.max - bounds.min) * inv;
            let d = [e.x, e.y, e.z].map(|v| libm::floorf(v) as i64 + 1);
            let n = d
                .iter()
                .fold(1u64, |a, &v| a.saturating_mul(v.max(1) as u64));
            if n <= capacity && inv.is_finite() && inv > 0.0 {
                break d.map(|v| v.clamp(1, i32::MAX as i64) as i32);
            }
            cell *= 2.0;
            if !cell.is_finite() {
                // Every extent is finite, so a cell beyond them all fits in one word.
                return Err(OccupancyError::BadCellSize);
            }
        };
        words.fill(0);
        let mut grid = Self {
            words: &[],
            boxes: &[],
            origin: bounds.min,
            inv_cell: 1.0 / cell,
            cell,
            dims,
        };
        for t in 0..body.tet_count() {
            let Some(b) = boxed(t) else { continue };
            if let Some((lo, hi)) = grid.range(&b) {
                for k in lo[2]..=hi[2] {
                    for j in lo[1]..=hi[1] {
                        for i in lo[0]..=hi[0] {
                            let n = grid.index([i, j, k]);
                            if let Some(w) = words.get_mut(n / 32) {
                                *w |= 1 << (n % 32);
                            }
                        }
                    }
                }
            }
        }
        grid.words = words;
        grid.boxes = boxes;
        Ok(grid)
    }

    /// The cell edge used (at least the one asked for).
    #[inline]
    pub fn cell_size(&self) -> f32 {
        self.cell
    }

    /// Cells along x, y and z.
    #[inline]
    pub fn dims(&self) -> [u32; 3] {
        self.dims.map(|d| d as u32)
    }

    /// `false` when no tet of the body can hold `p` (its cell is clear or outside the grid).
    ///
    /// # Bounded work
    /// Constant.
    #[inline]
    pub fn may_hold(&self, p: Vec3) -> bool {
        // The floor of `range` without its saturating conversions: inside the grid the
        // scaled coordinates are in [0, dims), where truncation is the floor (NaN fails the
        // comparisons).
        let f = (p - self.origin) * self.inv_cell;
        let d = self.dims;
        let inside = f.x >= 0.0
            && f.y >= 0.0
            && f.z >= 0.0
            && f.x < d[0] as f32
            && f.y < d[1] as f32
            && f.z < d[2] as f32;
        if !inside {
            return false;
        }
        let c = [f.x as i32, f.y as i32, f.z as i32].map(|v| v.min(i32::MAX - 1));
        if (0..3).any(|a| c[a] >= d[a]) {
            return false; // `d as f32` rounded up (grids beyond 2^24 cells a side)
        }
        self.bit(self.index(c))
    }

    /// `false` when tet `t` cannot hold `p` (outside its grown box; a tet with non-finite
    /// corners has an empty box). `true` for a tet without a stored box.
    ///
    /// # Bounded work
    /// Constant.
    #[inline]
    pub fn tet_may_hold(&self, t: TetId, p: Vec3) -> bool {
        match self.boxes.get(t.idx()) {
            Some(b) => b.contains(p),
            None => true,
        }
    }

    /// `false` when no point of the body's tets can be in box `b` (it meets no set cell).
    ///
    /// # Bounded work
    /// O(cells of the grid the box covers), at most the grid's cells; stops at the first set
    /// cell.
    pub fn may_meet(&self, b: &Aabb) -> bool {
        let Some((lo, hi)) = self.range(b) else {
            return false;
        };
        for k in lo[2]..=hi[2] {
            for j in lo[1]..=hi[1] {
                for i in lo[0]..=hi[0] {
                    if self.bit(self.index([i, j, k])) {
                        return true;
                    }
                }
            }
        }
        false
    }

    /// The cells of the grid box `b` covers, clamped to the grid (`None` when it misses the
    /// grid or is inverted). The same floor as [`Occupancy::may_hold`], so a point in `b` is in
    /// a cell of the range.
    fn range(&self, b: &Aabb) -> Option<([i32; 3], [i32; 3])> {
        let lo = cell_of(b.min - self.origin, self.inv_cell);
        let hi = cell_of(b.max - self.origin, self.inv_cell);
        let mut l = [0; 3];
        let mut h = [0; 3];
        for a in 0..3 {
            // NaN corners give cell 0 from `cell_of`; `ordered` is false for them.
            let ordered = b.min[a] <= b.max[a];
            if !ordered || hi[a] < 0 || lo[a] >= self.dims[a] || lo[a] > hi[a] {
                return None;
            }
            l[a] = lo[a].max(0);
            h[a] = hi[a].min(self.dims[a] - 1);
        }
        Some((l, h))
    }

    #[inline]
    fn index(&self, c: [i32; 3]) -> usize {
        (c[0] as usize)
            + self.dims[0] as usize * (c[1] as usize + self.dims[1] as usize * c[2] as usize)
    }

    #[inline]
    fn bit(&self, n: usize) -> bool {
        self.words
            .get(n / 32)
            .is_some_and(|w| w & (1 << (n % 32)) != 0)
    }
}
