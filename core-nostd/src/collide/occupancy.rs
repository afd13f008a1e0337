//! [`Occupancy`]: one bit per cell of a coarse grid over a body, set where a tet's box may be,
//! and each tet's box.

use glam::Vec3;

use super::entry::{levels, GridEntry};
use super::Body;
use crate::hash::{cell_of, Aabb};
use crate::ids::TetId;

/// Why an [`Occupancy`] cannot be built.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
#[non_exhaustive]
pub enum OccupancyError {
    /// No storage words.
    NoStorage,
    /// The cell size or the margin is not a finite positive number (margin: not negative).
    BadCellSize,
    /// The body has no tet with finite corners.
    Empty,
    /// Tet lists ([`Occupancy::with_tet_lists`]) need a box per tet, one start per cell plus
    /// one, and an entry per tet and cell its box meets ([`Occupancy::tet_list_sizes`]); node
    /// lists ([`Occupancy::with_node_lists`]) two starts more than the cells and an entry per
    /// node ([`Occupancy::node_list_sizes`]).
    ListStorage,
}

impl core::fmt::Display for OccupancyError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::NoStorage => f.write_str("occupancy grid needs at least one storage word"),
            Self::BadCellSize => f.write_str("occupancy cell size must be finite and positive"),
            Self::Empty => f.write_str("occupancy grid over a body without finite tets"),
            Self::ListStorage => f.write_str("occupancy tet lists: storage too short"),
        }
    }
}

impl core::error::Error for OccupancyError {}

/// Caller storage of an [`Occupancy`].
#[derive(Debug)]
pub struct OccupancyStorage<'a> {
    /// Grid bits, 32 cells a word (the grid coarsens until they fit).
    pub words: &'a mut [u32],
    /// One grown box per tet (tets beyond its length have none and always pass
    /// `Occupancy::tet_may_hold`); may be empty.
    pub boxes: &'a mut [Aabb],
}

/// One node of a body listed in its [`Occupancy`] cell ([`Occupancy::with_node_lists`]): its
/// id and its position when the lists were built.
#[derive(Clone, Copy, PartialEq, Debug, Default)]
pub struct ListedNode {
    /// Where the node is.
    pub pos: Vec3,
    /// The node's index among the body's nodes.
    pub node: u32,
}

/// A grid over a static body's bounds with one bit per cell, set when the cell meets the box
/// of one of its tets grown by a margin: a point in a clear cell (or outside the grid) is in
/// no tet, and a box that meets no set cell holds no point of the body's tets. It also keeps
/// each tet's grown box, a cheap test before a barycentric one, and optionally, per cell, the
/// tets whose grown box meets it in increasing id order, each with that box in the cell
/// quantised outward ([`Occupancy::with_tet_lists`]: a point's candidate tets without a
/// hash, most ruled out by the list's entries alone) and the body's nodes in it in increasing id order
/// with their positions ([`Occupancy::with_node_lists`]: the nodes in a box as one contiguous
/// run per row of cells, without a hash). Built once at set-up over caller storage; the
/// queries are read-only.
#[derive(Clone, Copy, Debug)]
pub struct Occupancy<'a> {
    words: &'a [u32],
    boxes: &'a [Aabb],
    /// Cell `i`'s tets are `cell_tets[cell_starts[i]..cell_starts[i + 1]]`, each with its
    /// box in the cell (both empty without lists).
    cell_starts: &'a [u32],
    cell_tets: &'a [GridEntry],
    /// Cell `i`'s nodes are `nodes[node_starts[i]..node_starts[i + 1]]`, those outside the
    /// grid after the last cell's (both empty without node lists).
    node_starts: &'a [u32],
    nodes: &'a [ListedNode],
    /// The lists' grid: the bits' cells split `split` times along each axis.
    list_inv: f32,
    list_dims: [i32; 3],
    origin: Vec3,
    inv_cell: f32,
    #[cfg(test)]
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
        let (origin, cell, dims) = frame(body, cell, margin, words.len())?;
        let boxed = |t: usize| grown_box(body, t, margin);
        for (t, slot) in boxes.iter_mut().enumerate().take(body.tet_count()) {
            *slot = boxed(t).unwrap_or(Aabb::of::<0>([]));
        }
        words.fill(0);
        let mut grid = Self {
            words: &[],
            boxes: &[],
            cell_starts: &[],
            cell_tets: &[],
            node_starts: &[],
            nodes: &[],
            list_inv: 1.0 / cell,
            list_dims: dims,
            origin,
            inv_cell: 1.0 / cell,
            #[cfg(test)]
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
    #[cfg(test)]
    pub(crate) fn cell_size(&self) -> f32 {
        self.cell
    }

    /// Cells along x, y and z.
    #[inline]
    #[cfg(test)]
    pub(crate) fn dims(&self) -> [u32; 3] {
        self.dims.map(|d| d as u32)
    }

    /// Storage [`Occupancy::with_tet_lists`] needs for lists over the cells split `split`
    /// times along each axis: `(starts, tets)` lengths, one more than the list cells and one
    /// entry ([`GridEntry`], 8 bytes) per stored box and list cell it meets (`None` when
    /// `split` is 0 or the cells overflow).
    ///
    /// # Bounded work
    /// O(cells each stored box meets). Call it at set-up.
    pub fn tet_list_sizes(&self, split: u32) -> Option<(usize, usize)> {
        self.list_sizes_of(split, self.boxes.iter().copied())
    }

    /// [`Occupancy::tet_list_sizes`] over the stored boxes `boxes`.
    fn list_sizes_of(
        &self,
        split: u32,
        boxes: impl Iterator<Item = Aabb>,
    ) -> Option<(usize, usize)> {
        let (inv, dims) = self.split_grid(split)?;
        let cells = dims.iter().map(|&d| d as usize).product::<usize>();
        let mut total = 0usize;
        for b in boxes {
            if let Some((lo, hi)) = range(self.origin, inv, dims, &b) {
                total += (0..3)
                    .map(|a| (hi[a] - lo[a] + 1) as usize)
                    .product::<usize>();
            }
        }
        Some((cells + 1, total))
    }

    /// What the grid [`Occupancy::build`] makes of `body` with `cell`, `margin` and `words`
    /// storage words needs for its lists, without the storage: `(list_starts, list_tets,
    /// node_starts)`, [`Occupancy::tet_list_sizes`] for `split` (with a box stored for every
    /// tet) and the starts of [`Occupancy::node_list_sizes`]. A caller sizes the whole grid
    /// in one piece from it before building it.
    ///
    /// # Bounded work
    /// O(T) twice and O(cells each box meets). Call it at set-up.
    ///
    /// # Errors
    /// As [`Occupancy::build`]; [`OccupancyError::ListStorage`] when `split` is 0 or the list
    /// cells overflow.
    pub fn list_sizes(
        body: &Body<'_, '_>,
        cell: f32,
        margin: f32,
        words: usize,
        split: u32,
    ) -> Result<(usize, usize, usize), OccupancyError> {
        let (origin, cell, dims) = frame(body, cell, margin, words)?;
        let grid = Self {
            words: &[],
            boxes: &[],
            cell_starts: &[],
            cell_tets: &[],
            node_starts: &[],
            nodes: &[],
            list_inv: 1.0 / cell,
            list_dims: dims,
            origin,
            inv_cell: 1.0 / cell,
            #[cfg(test)]
            cell,
            dims,
        };
        let boxes =
            (0..body.tet_count()).map(|t| grown_box(body, t, margin).unwrap_or(Aabb::of::<0>([])));
        let (starts, tets) = grid
            .list_sizes_of(split, boxes)
            .ok_or(OccupancyError::ListStorage)?;
        Ok((starts, tets, grid.node_list_sizes(0).0))
    }

    /// The list grid's inverse cell size and cells per axis for `split`.
    fn split_grid(&self, split: u32) -> Option<(f32, [i32; 3])> {
        let k = i32::try_from(split).ok().filter(|&k| k > 0)?;
        let mut dims = [0i32; 3];
        for (d, &g) in dims.iter_mut().zip(self.dims.iter()) {
            *d = g.checked_mul(k)?;
        }
        dims.iter()
            .try_fold(1usize, |a, &d| a.checked_mul(d as usize))?;
        Some((self.inv_cell * split as f32, dims))
    }

    /// This grid with, per cell of the grid's cells split `split` times along each axis, the
    /// tets whose grown box meets it, in increasing id order, each entry with the box clipped
    /// to the cell and quantised outward ([`GridEntry`], `Occupancy::tets_at`): a point's
    /// candidates are then its cell's list, read in order, with no hash bucket shared with
    /// other cells (a split of 2 lists about a third of the tets a whole cell would), and the
    /// entries alone rule out most of the tets whose box misses the point, without loading
    /// the box.
    /// Every one of `body`'s tets needs its box (the boxes storage at least as long as the
    /// tets).
    ///
    /// # Bounded work
    /// O(cells + cells each box meets). Call it at set-up.
    ///
    /// # Errors
    /// [`OccupancyError::ListStorage`] when a tet has no stored box or the storage is shorter
    /// than [`Occupancy::tet_list_sizes`].
    pub fn with_tet_lists(
        self,
        body: &Body<'_, '_>,
        split: u32,
        starts: &'a mut [u32],
        tets: &'a mut [GridEntry],
    ) -> Result<Self, OccupancyError> {
        let (inv, dims) = self.split_grid(split).ok_or(OccupancyError::ListStorage)?;
        let (n_starts, n_tets) = self
            .tet_list_sizes(split)
            .ok_or(OccupancyError::ListStorage)?;
        let short = self.boxes.len() < body.tet_count()
            || starts.len() < n_starts
            || tets.len() < n_tets
            || n_tets > u32::MAX as usize;
        if short {
            return Err(OccupancyError::ListStorage);
        }
        let starts = &mut starts[..n_starts];
        starts.fill(0);
        // Each tet, cell its box meets, and the entry there: the box corners' grid
        // coordinates computed as a point's are in `tets_at`, so a point in the box has
        // levels between theirs.
        let origin = self.origin;
        let each_cell = |f: &mut dyn FnMut(usize, GridEntry)| {
            for (t, b) in self.boxes.iter().enumerate() {
                let Some((lo, hi)) = range(origin, inv, dims, b) else {
                    continue;
                };
                let f_lo = (b.min - origin) * inv;
                let f_hi = (b.max - origin) * inv;
                for k in lo[2]..=hi[2] {
                    for j in lo[1]..=hi[1] {
                        for i in lo[0]..=hi[0] {
                            let c = [i, j, k];
                            f(index(dims, c), GridEntry::new(t as u32, f_lo, f_hi, c));
                        }
                    }
                }
            }
        };
        // Count per cell, prefix sums, fill in increasing tet order with each cell's start
        // as its cursor, then shift the starts back by one cell.
        each_cell(&mut |c, _| {
            if let Some(s) = starts.get_mut(c + 1) {
                *s += 1;
            }
        });
        for i in 1..n_starts {
            starts[i] += starts[i - 1];
        }
        each_cell(&mut |c, entry| {
            if let Some(s) = starts.get_mut(c) {
                if let Some(e) = tets.get_mut(*s as usize) {
                    *e = entry;
                }
                *s += 1;
            }
        });
        for i in (1..n_starts).rev() {
            starts[i] = starts[i - 1];
        }
        starts[0] = 0;
        Ok(Self {
            cell_starts: starts,
            cell_tets: &tets[..n_tets],
            list_inv: inv,
            list_dims: dims,
            ..self
        })
    }

    /// Storage [`Occupancy::with_node_lists`] needs for a body of `nodes` nodes: `(starts,
    /// nodes)` lengths, two more than the grid's cells and one entry per node.
    ///
    /// # Bounded work
    /// Constant.
    pub fn node_list_sizes(&self, nodes: usize) -> (usize, usize) {
        let cells = self.dims.iter().map(|&d| d as usize).product::<usize>();
        (cells + 2, nodes)
    }

    /// This grid with, per cell, the nodes of `body` (the body it was built over) in it, in
    /// increasing id order with their positions, and after the last cell's the nodes outside
    /// the grid (`Occupancy::nodes_in`).
    ///
    /// # Bounded work
    /// O(cells + N). Call it at set-up.
    ///
    /// # Errors
    /// [`OccupancyError::ListStorage`] when the storage is shorter than
    /// [`Occupancy::node_list_sizes`] or the body has more than `u32::MAX` nodes.
    pub fn with_node_lists(
        self,
        body: &Body<'_, '_>,
        starts: &'a mut [u32],
        nodes: &'a mut [ListedNode],
    ) -> Result<Self, OccupancyError> {
        let (n_starts, n_nodes) = self.node_list_sizes(body.positions.len());
        if starts.len() < n_starts || nodes.len() < n_nodes || n_nodes > u32::MAX as usize {
            return Err(OccupancyError::ListStorage);
        }
        let starts = &mut starts[..n_starts];
        starts.fill(0);
        // The nodes outside the grid (or not finite) go in the slot after the last cell.
        let outside = n_starts - 2;
        let slot = |p: Vec3| {
            cell(self.origin, self.inv_cell, self.dims, p).map_or(outside, |c| self.index(c))
        };
        // Count per slot, prefix sums, fill in increasing node order with each slot's start
        // as its cursor, then shift the starts back by one slot.
        for &p in body.positions {
            if let Some(s) = starts.get_mut(slot(p) + 1) {
                *s += 1;
            }
        }
        for i in 1..n_starts {
            starts[i] += starts[i - 1];
        }
        for (n, &p) in body.positions.iter().enumerate() {
            if let Some(s) = starts.get_mut(slot(p)) {
                if let Some(e) = nodes.get_mut(*s as usize) {
                    *e = ListedNode {
                        pos: p,
                        node: n as u32,
                    };
                }
                *s += 1;
            }
        }
        for i in (1..n_starts).rev() {
            starts[i] = starts[i - 1];
        }
        starts[0] = 0;
        Ok(Self {
            node_starts: starts,
            nodes: &nodes[..n_nodes],
            ..self
        })
    }

    /// The number of nodes listed ([`Occupancy::with_node_lists`]), `None` without node lists.
    #[inline]
    pub(crate) fn listed_nodes(&self) -> Option<usize> {
        (!self.node_starts.is_empty()).then_some(self.nodes.len())
    }

    /// Calls `f` on runs of listed nodes that together hold every listed node inside box `b`,
    /// each node once: per row of cells the box covers, the row's nodes (one contiguous run,
    /// x fastest), then the nodes outside the grid. Returns `false` and visits nothing when
    /// the grid has no node lists ([`Occupancy::with_node_lists`]) or the box covers more than
    /// `max_cells` cells.
    ///
    /// # Bounded work
    /// O(rows of cells the box covers + nodes in them + nodes outside the grid), at most
    /// `max_cells` cells.
    pub(crate) fn nodes_in<F: FnMut(&'a [ListedNode])>(
        &self,
        b: &Aabb,
        max_cells: u32,
        mut f: F,
    ) -> bool {
        if self.node_starts.is_empty() {
            return false;
        }
        let run = |i: usize, j: usize| {
            let lo = self.node_starts.get(i).copied().unwrap_or(0) as usize;
            let hi = self.node_starts.get(j).copied().unwrap_or(0) as usize;
            self.nodes.get(lo..hi).unwrap_or(&[])
        };
        if let Some((lo, hi)) = self.range(b) {
            let cells = (0..3).fold(1u64, |a, k| a * (hi[k] - lo[k] + 1) as u64);
            if cells > max_cells as u64 {
                return false;
            }
            for k in lo[2]..=hi[2] {
                for j in lo[1]..=hi[1] {
                    let first = self.index([lo[0], j, k]);
                    let last = self.index([hi[0], j, k]);
                    f(run(first, last + 1));
                }
            }
        }
        let outside = self.node_starts.len() - 2;
        let tail = run(outside, outside + 1);
        if !tail.is_empty() {
            f(tail);
        }
        true
    }

    /// The entries listed in `p`'s cell, in increasing tet id order (empty outside the
    /// grid), with `p`'s levels in the cell, or `None` when the grid has no lists
    /// ([`Occupancy::with_tet_lists`]). Every tet whose grown box holds `p` is in the list
    /// with an entry that admits `p`'s levels ([`CellTets::admits`]).
    ///
    /// # Bounded work
    /// Constant.
    #[inline]
    pub(crate) fn tets_at(&self, p: Vec3) -> Option<CellTets<'a>> {
        if self.cell_starts.is_empty() {
            return None;
        }
        let empty = CellTets {
            entries: &[],
            at: 0,
        };
        // `cell`, keeping the grid coordinates for the levels.
        let f = (p - self.origin) * self.list_inv;
        let Some(c) = cell(self.origin, self.list_inv, self.list_dims, p) else {
            return Some(empty);
        };
        let i = index(self.list_dims, c);
        let lo = self.cell_starts.get(i).copied().unwrap_or(0) as usize;
        let hi = self.cell_starts.get(i + 1).copied().unwrap_or(0) as usize;
        Some(CellTets {
            entries: self.cell_tets.get(lo..hi).unwrap_or(&[]),
            at: levels(f, c),
        })
    }

    /// `false` when no tet of the body can hold `p` (its cell is clear or outside the grid).
    ///
    /// # Bounded work
    /// Constant.
    #[inline]
    pub(crate) fn may_hold(&self, p: Vec3) -> bool {
        cell(self.origin, self.inv_cell, self.dims, p).is_some_and(|c| self.bit(self.index(c)))
    }

    /// `false` when tet `t` cannot hold `p` (outside its grown box; a tet with non-finite
    /// corners has an empty box). `true` for a tet without a stored box.
    ///
    /// # Bounded work
    /// Constant.
    #[inline]
    pub(crate) fn tet_may_hold(&self, t: TetId, p: Vec3) -> bool {
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
    pub(crate) fn may_meet(&self, b: &Aabb) -> bool {
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
    /// grid or is inverted).
    fn range(&self, b: &Aabb) -> Option<([i32; 3], [i32; 3])> {
        range(self.origin, self.inv_cell, self.dims, b)
    }

    #[inline]
    fn index(&self, c: [i32; 3]) -> usize {
        index(self.dims, c)
    }

    #[inline]
    fn bit(&self, n: usize) -> bool {
        self.words
            .get(n / 32)
            .is_some_and(|w| w & (1 << (n % 32)) != 0)
    }
}

/// A point's cell's list of tets ([`Occupancy::tets_at`]): the cell's entries in increasing
/// tet id order and the point's levels in the cell.
#[derive(Clone, Copy, Debug)]
pub(crate) struct CellTets<'a> {
    /// The cell's entries, in increasing tet id order.
    pub(crate) entries: &'a [GridEntry],
    /// The point's packed levels in the cell.
    at: u32,
}

impl CellTets<'_> {
    /// `false` when `e`'s box (clipped to the cell, quantised outward) does not hold the
    /// point, so neither does the tet's grown box; `true` for every tet whose grown box holds
    /// it, and for some whose box is near it.
    ///
    /// # Bounded work
    /// Constant.
    #[inline]
    pub(crate) fn admits(&self, e: &GridEntry) -> bool {
        e.admits(self.at)
    }
}

/// `p`'s cell in the grid from `origin` with `inv` cells a unit and `dims` cells, `None`
/// outside it.
#[inline]
pub(super) fn cell(origin: Vec3, inv: f32, dims: [i32; 3], p: Vec3) -> Option<[i32; 3]> {
    // The floor of `range` without its saturating conversions: inside the grid the
    // scaled coordinates are in [0, dims), where truncation is the floor (NaN fails the
    // comparisons).
    let f = (p - origin) * inv;
    let d = dims;
    let inside = f.x >= 0.0
        && f.y >= 0.0
        && f.z >= 0.0
        && f.x < d[0] as f32
        && f.y < d[1] as f32
        && f.z < d[2] as f32;
    if !inside {
        return None;
    }
    // Below `d as f32`, the truncation is below `d` even where `d as f32` rounded up
    // (grids beyond 2^24 cells a side): no float lies between `d` and the float above it.
    Some([f.x as i32, f.y as i32, f.z as i32])
}

/// Tet `t`'s box grown by `margin` (`None` for a tet without finite corners).
fn grown_box(body: &Body<'_, '_>, t: usize, margin: f32) -> Option<Aabb> {
    let c = body.tet_positions(TetId::from_idx(t))?;
    c.iter()
        .all(|p| p.is_finite())
        .then(|| Aabb::of(c).grown(margin))
}

/// The grid [`Occupancy::build`] lays over `body` with `words` storage words: its origin, the
/// cell edge it settles on (`cell`, doubled until the cells fit the words) and its cells per
/// axis.
///
/// # Bounded work
/// O(T) for the bounds, then one pass a doubling of the cell (at most about 256).
fn frame(
    body: &Body<'_, '_>,
    cell: f32,
    margin: f32,
    words: usize,
) -> Result<(Vec3, f32, [i32; 3]), OccupancyError> {
    if words == 0 {
        return Err(OccupancyError::NoStorage);
    }
    if !(cell.is_finite() && cell > 0.0 && margin.is_finite() && margin >= 0.0) {
        return Err(OccupancyError::BadCellSize);
    }
    let mut bounds = Aabb::of::<0>([]);
    for t in 0..body.tet_count() {
        if let Some(b) = grown_box(body, t, margin) {
            bounds = bounds.union(b);
        }
    }
    if !(bounds.min.is_finite() && bounds.max.is_finite()) {
        return Err(OccupancyError::Empty);
    }
    let capacity = words as u64 * 32;
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
    Ok((bounds.min, cell, dims))
}

/// The cells of the grid box `b` covers, clamped to the grid (`None` when it misses the
/// grid or is inverted). The same floor as [`cell`], so a point in `b` is in
/// a cell of the range.
fn range(origin: Vec3, inv: f32, dims: [i32; 3], b: &Aabb) -> Option<([i32; 3], [i32; 3])> {
    let lo = cell_of(b.min - origin, inv);
    let hi = cell_of(b.max - origin, inv);
    let mut l = [0; 3];
    let mut h = [0; 3];
    for a in 0..3 {
        // NaN corners give cell 0 from `cell_of`; `ordered` is false for them.
        let ordered = b.min[a] <= b.max[a];
        if !ordered || hi[a] < 0 || lo[a] >= dims[a] || lo[a] > hi[a] {
            return None;
        }
        l[a] = lo[a].max(0);
        h[a] = hi[a].min(dims[a] - 1);
    }
    Some((l, h))
}

/// Row-major index of cell `c` in a grid of `dims` cells.
#[inline]
fn index(dims: [i32; 3], c: [i32; 3]) -> usize {
    (c[0] as usize) + dims[0] as usize * (c[1] as usize + dims[1] as usize * c[2] as usize)
}
