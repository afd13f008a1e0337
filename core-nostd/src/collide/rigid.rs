//! Points inside the tets of a rigid body (a tool), with the body's tets listed once at rest.
//!
//! [`tets_over_points`](super::tets_over_points) walks the cells of every tet's box each tick.
//! For a rigid body that is wasted work: its tets never change shape. [`RigidTets`] lists
//! them once in the body's own frame, in a dense rest grid (per cell, the tets whose grown
//! box meets it, in increasing id order, each with its box in the cell quantised outward:
//! [`GridEntry`]), and groups them into clusters (the cells of a coarse rest-frame grid); per
//! tick [`rigid_tets_over_points_coherent`] reads the points only over each cluster's moved
//! box (from the other body's per-cell node lists, [`Occupancy::with_node_lists`], or its
//! points' hash), moves each point met that the box holds into the body's frame, lets only
//! the cluster whose cell holds it go on (so no point is handled twice), and looks the
//! points up in their rest grid cells a batch at a time. [`RigidTets::near`] tells, once a
//! tick, which clusters' moved boxes meet cells another body occupies: the search skips the
//! others, and so can a lookup of the body's own nodes in the other body
//! ([`RigidTets::node_near`]). Rest-frame data only culls, with a margin; the test that
//! decides is the same barycentric test on the moved corners as everywhere else, so the
//! contacts are the ones [`tets_over_points`](super::tets_over_points) and a brute force
//! find.

use glam::{Affine3A, Vec3};

use super::entry::{levels, GridEntry};
use super::teschner::{tets_over_points_coherent, MAX_CELLS_PER_TET};
use super::{candidate_holds, Body, CollideReport, Collision, Occupancy};
use crate::hash::{Aabb, SpatialHash};

/// Cell index of rest point `q` in a dense grid from `min` with `inv` cells per unit, clamped
/// to `dims` (monotonic in `q`, so a point in a box lies in the box's corners' cell range).
#[inline]
fn dense_cell(min: Vec3, inv: Vec3, dims: [i32; 3], q: Vec3) -> [i32; 3] {
    let f = (q - min) * inv;
    let c = crate::hash::cell_of(f, 1.0);
    [0, 1, 2].map(|a| c[a].clamp(0, dims[a] - 1))
}

/// Row-major index of grid cell `c`.
#[inline]
fn dense_index(dims: [i32; 3], c: [i32; 3]) -> usize {
    c[0] as usize + dims[0] as usize * (c[1] as usize + dims[1] as usize * c[2] as usize)
}

/// Cells per axis and their inverse sizes for a grid of cells of about `edge` over
/// `extent`, the edge grown by half until the cells number at most `max_cells`; `None` when
/// the edge is not a finite positive number or grows past finite.
fn dense_dims(extent: Vec3, mut edge: f32, max_cells: usize) -> Option<([i32; 3], Vec3)> {
    if !(edge.is_finite() && edge > 0.0) {
        return None;
    }
    let dims = loop {
        let d = [extent.x, extent.y, extent.z]
            .map(|e| (libm::ceilf(e / edge) as i64).clamp(1, i32::MAX as i64));
        let n = d.iter().fold(1u64, |a, &v| a.saturating_mul(v as u64));
        if n <= max_cells as u64 {
            break d.map(|v| v as i32);
        }
        edge *= 1.5;
        if !edge.is_finite() {
            return None;
        }
    };
    let size = Vec3::new(
        extent.x / dims[0] as f32,
        extent.y / dims[1] as f32,
        extent.z / dims[2] as f32,
    );
    let inv = Vec3::new(
        if size.x > 0.0 { 1.0 / size.x } else { 0.0 },
        if size.y > 0.0 { 1.0 / size.y } else { 0.0 },
        if size.z > 0.0 { 1.0 / size.z } else { 0.0 },
    );
    Some((dims, inv))
}
use crate::ids::{NodeId, TetId};

/// Why [`RigidTets::build`] refused.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum RigidError {
    /// Fewer tet boxes than tets, or no cluster storage.
    Storage,
    /// The rest grid ran out of tet entries (some tets would never be found).
    GridFull,
    /// The cluster edge or the margin is not a finite positive number.
    BadSize,
    /// The body has no tet with finite corners.
    Empty,
}

impl core::fmt::Display for RigidError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::Storage => f.write_str("rigid tets: a box per tet and one cluster at least"),
            Self::GridFull => f.write_str("rigid tets: the rest grid ran out of tet entries"),
            Self::BadSize => f.write_str("rigid tets: cluster edge and margin must be positive"),
            Self::Empty => f.write_str("rigid tets: no tet with finite corners"),
        }
    }
}

/// Caller storage of a [`RigidTets`].
#[derive(Debug)]
pub struct RigidTetsStorage<'s> {
    /// Per cell of the rest grid, where its tets start in `grid_tets`, plus one end: its
    /// length caps the cells (one more than the cells; [`RigidTets::grid_sizes`]).
    pub grid_starts: &'s mut [u32],
    /// The tets of each rest grid cell, each with its box in the cell ([`GridEntry`]): one
    /// entry per tet and cell its grown box meets ([`RigidTets::grid_sizes`]).
    pub grid_tets: &'s mut [GridEntry],
    /// One box per tet.
    pub tet_boxes: &'s mut [Aabb],
    /// One box per cluster cell: its length caps the number of clusters.
    pub clusters: &'s mut [Aabb],
    /// One cluster index per node (nodes beyond its length are never culled); may be empty.
    pub node_clusters: &'s mut [u32],
}

/// A rigid body's tets at rest: listed in a dense grid in its frame (each tet's box grown by
/// a margin, each entry with that box in its cell quantised outward: [`GridEntry`]), the
/// grown boxes, and a coarse grid of clusters, each with the rest-frame box of what its cell
/// holds. Built once at set-up; read-only afterwards.
#[derive(Debug)]
pub struct RigidTets<'s> {
    /// Rest grid: cell `i`'s tets are `grid_tets[grid_starts[i]..grid_starts[i + 1]]`.
    grid_starts: &'s [u32],
    grid_tets: &'s [GridEntry],
    /// Rest grid cells per axis and their inverse sizes (from `bounds.min`).
    grid_dims: [i32; 3],
    grid_inv: Vec3,
    tet_boxes: &'s [Aabb],
    clusters: &'s [Aabb],
    node_clusters: &'s [u32],
    bounds: Aabb,
    inv: Vec3,
    dims: [i32; 3],
    margin: f32,
    /// Largest |coordinate| of a rest box corner.
    radius: f32,
    /// Largest length of a cluster box's half extent.
    reach: f32,
    /// `true` when `bounds` holds every node of the body (so [`RigidTets::moved_bounds`]
    /// holds every moved node).
    nodes_bounded: bool,
}

impl<'s> RigidTets<'s> {
    /// Prepares `body` (at rest: its positions are the rest frame) with a rest grid of cells
    /// of about `grid_edge` and clusters of about `cluster_edge` (each grid over the tets'
    /// bounds has `ceil(extent / edge)` cells per axis; when the storage cannot hold them the
    /// edge grows by half until it can). Every tet box is grown by `margin`: rest-frame data
    /// only culls, and the margin covers rounding of the moved positions and of the
    /// barycentric test (about a hundredth of an edge; [`rigid_tets_over_points_coherent`]
    /// falls back to the plain walk for poses so far from the origin that rounding could
    /// exceed it).
    ///
    /// # Bounded work
    /// O(T) for the boxes, O(cells + T x cells each box meets) for each grid,
    /// O(`node_clusters.len()`) for the nodes' clusters, O(N) to check that the bounds hold
    /// every node ([`RigidTets::moved_bounds`]). Call it at set-up.
    ///
    /// # Errors
    /// [`RigidError`]: short storage, a full rest grid, a bad size, or no finite tet.
    pub fn build(
        body: &Body<'_, '_>,
        storage: RigidTetsStorage<'s>,
        grid_edge: f32,
        cluster_edge: f32,
        margin: f32,
    ) -> Result<Self, RigidError> {
        let RigidTetsStorage {
            grid_starts,
            grid_tets,
            tet_boxes,
            clusters,
            node_clusters,
        } = storage;
        let nt = body.tet_count();
        if tet_boxes.len() < nt || clusters.is_empty() || grid_starts.len() < 2 {
            return Err(RigidError::Storage);
        }
        if !(margin.is_finite() && margin > 0.0) {
            return Err(RigidError::BadSize);
        }
        let bounds = grown_boxes(body, margin, tet_boxes)?;
        let boxes = &*tet_boxes;
        let usable = |t: usize| boxes.get(t).copied().filter(|b| b.min.x <= b.max.x);
        let extent = bounds.max - bounds.min;

        // The rest grid: count each cell's tets, prefix sums, fill in increasing tet order.
        let (grid_dims, grid_inv) =
            dense_dims(extent, grid_edge, grid_starts.len() - 1).ok_or(RigidError::BadSize)?;
        let cells = grid_dims.iter().map(|&d| d as usize).product::<usize>();
        let cell_range = |b: Aabb| {
            (
                dense_cell(bounds.min, grid_inv, grid_dims, b.min),
                dense_cell(bounds.min, grid_inv, grid_dims, b.max),
            )
        };
        grid_starts.fill(0);
        let mut total = 0usize;
        for t in 0..nt {
            let Some(b) = usable(t) else { continue };
            let (lo, hi) = cell_range(b);
            for_cells(lo, hi, |c| {
                if let Some(s) = grid_starts.get_mut(dense_index(grid_dims, c) + 1) {
                    *s += 1;
                    total += 1;
                }
            });
        }
        if total > grid_tets.len() || total > u32::MAX as usize {
            return Err(RigidError::GridFull);
        }
        for i in 0..cells {
            grid_starts[i + 1] += grid_starts[i];
        }
        // Fill: `grid_starts[i]` is cell i's cursor, ending at cell i + 1's start; each entry
        // with the levels of the box's corners in the cell (grid coordinates computed as a
        // point's are in `locate_batch`, so a point in the box has levels between them)...
        for t in 0..nt {
            let Some(b) = usable(t) else { continue };
            let (lo, hi) = cell_range(b);
            let f_lo = (b.min - bounds.min) * grid_inv;
            let f_hi = (b.max - bounds.min) * grid_inv;
            for_cells(lo, hi, |c| {
                let i = dense_index(grid_dims, c);
                if let Some(s) = grid_starts.get_mut(i) {
                    if let Some(e) = grid_tets.get_mut(*s as usize) {
                        *e = GridEntry::new(t as u32, f_lo, f_hi, c);
                    }
                    *s += 1;
                }
            });
        }
        // ...then shifted back by one cell.
        for i in (1..=cells).rev() {
            grid_starts[i] = grid_starts[i - 1];
        }
        grid_starts[0] = 0;

        // The cluster grid.
        let (dims, inv) =
            dense_dims(extent, cluster_edge, clusters.len()).ok_or(RigidError::BadSize)?;
        let size = Vec3::new(
            extent.x / dims[0] as f32,
            extent.y / dims[1] as f32,
            extent.z / dims[2] as f32,
        );
        let mut rt = Self {
            grid_starts: &[],
            grid_tets: &[],
            grid_dims,
            grid_inv,
            tet_boxes: &[],
            clusters: &[],
            node_clusters: &[],
            bounds,
            inv,
            dims,
            margin,
            radius: 0.0,
            reach: 0.0,
            nodes_bounded: (0..body.mesh.node_count()).all(|n| {
                body.pos(NodeId::from_idx(n))
                    .is_some_and(|q| bounds.contains(q))
            }),
        };
        clusters.fill(Aabb::of::<0>([]));
        for t in 0..nt {
            let Some(b) = usable(t) else { continue };
            let (lo, hi) = (rt.grid_cell(b.min), rt.grid_cell(b.max));
            for k in lo[2]..=hi[2] {
                for j in lo[1]..=hi[1] {
                    for i in lo[0]..=hi[0] {
                        let c = [i, j, k];
                        // The cell's own bounds (the end cells reach the grid's bounds),
                        // grown by the margin: what a point classified into it can be.
                        let mut cell = Aabb {
                            min: bounds.min + size * Vec3::new(i as f32, j as f32, k as f32),
                            max: bounds.min
                                + size * Vec3::new((i + 1) as f32, (j + 1) as f32, (k + 1) as f32),
                        };
                        for a in 0..3 {
                            if c[a] == 0 {
                                cell.min[a] = bounds.min[a];
                            }
                            if c[a] == dims[a] - 1 {
                                cell.max[a] = bounds.max[a];
                            }
                        }
                        let cell = cell.grown(margin);
                        let part = Aabb {
                            min: b.min.max(cell.min),
                            max: b.max.min(cell.max),
                        };
                        if let Some(slot) = clusters.get_mut(rt.index(c)) {
                            *slot = slot.union(part);
                        }
                    }
                }
            }
        }
        for b in clusters.iter() {
            if b.min.x <= b.max.x {
                let h = (b.max - b.min) * 0.5;
                rt.reach = rt.reach.max(h.length());
                rt.radius = rt.radius.max(b.min.abs().max(b.max.abs()).max_element());
            }
        }
        // Each node's cluster, when the cluster's box holds it (else it is never culled).
        for (n, slot) in node_clusters.iter_mut().enumerate() {
            *slot = NO_CLUSTER;
            let Some(q) = body.pos(NodeId::from_idx(n)) else {
                continue;
            };
            if let Some(ci) = rt.cluster_of(q) {
                let b = clusters.get(ci).copied().unwrap_or(Aabb::of::<0>([]));
                if b.contains(q) && ci < NO_CLUSTER as usize {
                    *slot = ci as u32;
                }
            }
        }
        rt.grid_starts = grid_starts;
        rt.grid_tets = grid_tets;
        rt.tet_boxes = tet_boxes;
        rt.clusters = clusters;
        rt.node_clusters = node_clusters;
        Ok(rt)
    }

    /// Number of cluster cells (empty ones included).
    #[inline]
    pub fn clusters(&self) -> usize {
        self.dims.iter().map(|&d| d as usize).product()
    }

    /// Cluster cells that hold part of a tet.
    pub fn occupied_clusters(&self) -> usize {
        let n = self.clusters();
        self.clusters
            .iter()
            .take(n)
            .filter(|b| b.min.x <= b.max.x)
            .count()
    }

    /// The margin the rest data was grown by.
    #[inline]
    pub fn margin(&self) -> f32 {
        self.margin
    }

    /// The cluster grid cell of a rest-frame point, clamped to the grid.
    #[inline]
    fn grid_cell(&self, q: Vec3) -> [i32; 3] {
        dense_cell(self.bounds.min, self.inv, self.dims, q)
    }

    #[inline]
    fn index(&self, c: [i32; 3]) -> usize {
        dense_index(self.dims, c)
    }

    /// Storage a rest grid of cells of about `grid_edge` needs for `body` with tet boxes grown
    /// by `margin`: `(grid_starts, grid_tets)` lengths for [`RigidTetsStorage`] (`grid_tets`
    /// entries are [`GridEntry`]s of 8 bytes; `None` for a bad size or no finite tet).
    /// `tet_boxes` is scratch of one box per tet.
    ///
    /// # Bounded work
    /// O(T x cells each box meets). Call it at set-up.
    pub fn grid_sizes(
        body: &Body<'_, '_>,
        grid_edge: f32,
        margin: f32,
        tet_boxes: &mut [Aabb],
    ) -> Option<(usize, usize)> {
        let bounds = grown_boxes(body, margin, tet_boxes).ok()?;
        let extent = bounds.max - bounds.min;
        let (dims, inv) = dense_dims(extent, grid_edge, i32::MAX as usize)?;
        let cells = dims.iter().map(|&d| d as usize).product::<usize>();
        let mut total = 0usize;
        for b in tet_boxes.iter().take(body.tet_count()) {
            if b.min.x > b.max.x {
                continue;
            }
            let lo = dense_cell(bounds.min, inv, dims, b.min);
            let hi = dense_cell(bounds.min, inv, dims, b.max);
            for_cells(lo, hi, |_| total += 1);
        }
        Some((cells + 1, total))
    }

    /// The cluster whose cell holds rest-frame point `q` (`None` outside the tets' bounds:
    /// no tet holds it).
    #[inline]
    fn cluster_of(&self, q: Vec3) -> Option<usize> {
        self.bounds
            .contains(q)
            .then(|| self.index(self.grid_cell(q)))
    }

    /// `true` when cluster `ci`'s cell holds rest-frame point `q` ([`RigidTets::cluster_of`]
    /// is `Some(ci)`), without a branch.
    #[inline]
    fn in_cluster(&self, q: Vec3, ci: usize) -> bool {
        holds_point(&self.bounds, q) & (self.index(self.grid_cell(q)) == ci)
    }

    /// Rest-frame point `q`'s rest grid cell: where its entries start and end in `grid_tets`
    /// and `q`'s levels in it ([`GridEntry`]); an empty range outside the tets' bounds.
    #[inline]
    fn rest_cell(&self, q: Vec3) -> (usize, usize, u32) {
        if !self.bounds.contains(q) {
            return (0, 0, 0); // no tet holds it
        }
        // `dense_cell`, keeping the grid coordinates for the levels.
        let g = (q - self.bounds.min) * self.grid_inv;
        let c = crate::hash::cell_of(g, 1.0);
        let c = [0, 1, 2].map(|a| c[a].clamp(0, self.grid_dims[a] - 1));
        let i = dense_index(self.grid_dims, c);
        let lo = self.grid_starts.get(i).copied().unwrap_or(0) as usize;
        let hi = self.grid_starts.get(i + 1).copied().unwrap_or(0) as usize;
        (lo, hi.max(lo), levels(g, c))
    }

    /// The tets of rest-frame point `q`'s rest grid cell whose entry admits it, in list
    /// order, then how many the cell lists (for the tests of the filter).
    #[cfg(test)]
    pub(super) fn admitted(&self, q: Vec3, mut f: impl FnMut(TetId)) -> usize {
        let (lo, hi, at) = self.rest_cell(q);
        let list = self.grid_tets.get(lo..hi).unwrap_or(&[]);
        for e in list.iter().filter(|e| e.admits(at)) {
            f(e.tet());
        }
        list.len()
    }

    /// The rest grid's origin, cells per unit and cells per axis (for the tests of the
    /// filter).
    #[cfg(test)]
    pub(super) fn rest_grid(&self) -> (Vec3, Vec3, [i32; 3]) {
        (self.bounds.min, self.grid_inv, self.grid_dims)
    }

    /// The smallest tet holding world point `p` (rest-frame `q`): [`RigidTets::locate_batch`]
    /// of one point.
    fn locate(&self, q: Vec3, p: Vec3, body: &Body<'_, '_>, r: &mut CollideReport) -> TetId {
        let mut found = [TetId::NONE];
        self.locate_batch(&[Pending { node: 0, p, q }], body, r, &mut found);
        found[0]
    }

    /// For each pending point (world `p`, rest-frame `q`), the smallest tet holding it, in
    /// `found` (`NONE`: none): of its rest grid cell's tets in increasing id order, the first
    /// whose grown box holds `q` and whose moved corners in `body` hold `p` (the barycentric
    /// test); the entries' quantised boxes ([`GridEntry`]) skip tets whose box cannot hold
    /// `q`. Stage by stage over the batch, so that what each point's stage reads is requested
    /// for every point before any is waited for: every point's cell range, then every point's
    /// entry tests on its cell's first [`MASKED`] entries (one bit each, no branch per
    /// entry), then round by round each point's next admitted tet (box and barycentric test),
    /// until each point is found or out of admitted tets; last, for the points not found,
    /// the cell's entries beyond the first [`MASKED`] one by one. Each point meets the same
    /// box and barycentric tests, in the same order, as alone.
    ///
    /// # Bounded work
    /// Per point at most `b` entry tests, `b` box tests and `b` barycentric tests, for `b`
    /// the fullest cell of the rest grid.
    fn locate_batch(
        &self,
        batch: &[Pending],
        body: &Body<'_, '_>,
        r: &mut CollideReport,
        found: &mut [TetId],
    ) {
        let mut ranges = [(0usize, 0usize, 0u32); BATCH];
        for (range, pt) in ranges.iter_mut().zip(batch) {
            *range = self.rest_cell(pt.q);
        }
        let mut masks = [0u64; BATCH];
        for (k, &(lo, hi, at)) in ranges.iter().take(batch.len()).enumerate() {
            let head = self.grid_tets.get(lo..hi.min(lo + MASKED)).unwrap_or(&[]);
            let mut mask = 0u64;
            for (j, e) in head.iter().enumerate() {
                mask |= (e.admits(at) as u64) << j;
            }
            masks[k] = mask;
        }
        // The exact test: the tet's grown box, then its moved corners (both read before
        // either is tested, so that their loads overlap).
        let holds = |pt: &Pending, e: &GridEntry, r: &mut CollideReport| {
            let b = self.tet_boxes.get(e.tet().idx());
            let corners = body.tet_positions(e.tet());
            b.is_some_and(|b| b.contains(pt.q))
                && corners.is_some_and(|corners| candidate_holds(pt.p, corners, r))
        };
        let n = batch.len().min(BATCH).min(found.len());
        for slot in found.iter_mut().take(n) {
            *slot = TetId::NONE;
        }
        // Round by round, each point's next admitted tet (its first holder in list order
        // ends its search): the points' tests of a round are independent.
        let mut open = masks.iter().take(n).any(|&m| m != 0);
        while open {
            open = false;
            for k in 0..n {
                let mask = masks[k];
                if mask == 0 {
                    continue;
                }
                let j = mask.trailing_zeros() as usize;
                masks[k] = mask & (mask - 1);
                let (lo, _, _) = ranges[k];
                let e = self.grid_tets.get(lo + j).copied().unwrap_or_default();
                if holds(&batch[k], &e, r) {
                    found[k] = e.tet();
                    masks[k] = 0;
                } else {
                    open |= masks[k] != 0;
                }
            }
        }
        // The tets beyond each cell's first `MASKED`, in order, for the points not found.
        for k in 0..n {
            let (lo, hi, at) = ranges[k];
            if found[k].is_some() || hi - lo <= MASKED {
                continue;
            }
            let rest = self.grid_tets.get(lo + MASKED..hi).unwrap_or(&[]);
            for e in rest {
                if e.admits(at) && holds(&batch[k], e, r) {
                    found[k] = e.tet();
                    break;
                }
            }
        }
    }
}

/// Points a cluster gathers before their lookups (`RigidTets::locate_batch`).
const BATCH: usize = 32;

/// A rest grid cell's first entries whose tests [`RigidTets::locate_batch`] gathers into one
/// mask (the bits of a `u64`).
const MASKED: usize = 64;

/// A point waiting for its lookup: its index, world position and rest-frame position.
#[derive(Clone, Copy, Default)]
struct Pending {
    node: u32,
    p: Vec3,
    q: Vec3,
}

/// `true` when box `b` holds `q` (its faces included): [`Aabb::contains`] with the six
/// comparisons combined without a branch.
#[inline]
fn holds_point(b: &Aabb, q: Vec3) -> bool {
    (q.cmpge(b.min) & q.cmple(b.max)).all()
}

/// Writes each tet's box grown by `margin` (an inverted box for a tet without finite
/// corners) and returns their union.
fn grown_boxes(
    body: &Body<'_, '_>,
    margin: f32,
    tet_boxes: &mut [Aabb],
) -> Result<Aabb, RigidError> {
    if tet_boxes.len() < body.tet_count() {
        return Err(RigidError::Storage);
    }
    if !(margin.is_finite() && margin > 0.0) {
        return Err(RigidError::BadSize);
    }
    let mut bounds = Aabb::of::<0>([]);
    for (t, slot) in tet_boxes.iter_mut().enumerate().take(body.tet_count()) {
        *slot = match body.tet_positions(TetId::from_idx(t)) {
            Some(c) if c.iter().all(|p| p.is_finite()) => {
                let b = Aabb::of(c).grown(margin);
                bounds = bounds.union(b);
                b
            }
            _ => Aabb::of::<0>([]),
        };
    }
    if !(bounds.min.is_finite() && bounds.max.is_finite()) {
        return Err(RigidError::Empty);
    }
    Ok(bounds)
}

/// Calls `f` on every cell from `lo` to `hi` (inclusive), x fastest.
#[inline]
fn for_cells<F: FnMut([i32; 3])>(lo: [i32; 3], hi: [i32; 3], mut f: F) {
    for k in lo[2]..=hi[2] {
        for j in lo[1]..=hi[1] {
            for i in lo[0]..=hi[0] {
                f([i, j, k]);
            }
        }
    }
}

/// Marks a node that no cluster culls.
const NO_CLUSTER: u32 = u32::MAX;

/// Clusters a [`NearClusters`] tells apart; clusters beyond count as near.
pub const MAX_NEAR_CLUSTERS: usize = 4096;

/// Which clusters of a [`RigidTets`] are near another body this tick
/// ([`RigidTets::near`]): one bit per cluster, on the stack (512 bytes), and the other body's
/// [`Occupancy`] when it lists its nodes per cell ([`Occupancy::with_node_lists`]: then
/// [`rigid_tets_over_points_coherent`] reads the nodes in a cluster's box from those lists).
#[derive(Clone, Copy, Debug)]
pub struct NearClusters<'c> {
    bits: [u64; MAX_NEAR_CLUSTERS / 64],
    cells: Option<Occupancy<'c>>,
}

impl NearClusters<'_> {
    /// Every cluster near (culls nothing), no node lists.
    pub const ALL: Self = Self {
        bits: [u64::MAX; MAX_NEAR_CLUSTERS / 64],
        cells: None,
    };

    /// `true` when cluster `c` is near (or beyond [`MAX_NEAR_CLUSTERS`]).
    #[inline]
    pub fn is_near(&self, c: usize) -> bool {
        self.bits
            .get(c / 64)
            .is_none_or(|w| w & (1 << (c % 64)) != 0)
    }
}

impl RigidTets<'_> {
    /// `true` when the pose is a rotation (columns of length 1 within 1e-4: a quaternion far
    /// from unit length scales the body) near enough to the origin for the rest data's margin
    /// to cover rounding: `64 x f32::EPSILON x (|translation| + rest radius) <= margin`. NaN
    /// fails.
    #[inline]
    fn pose_in_margin(&self, pose: &Affine3A) -> bool {
        let m = &pose.matrix3;
        let unit = |c: glam::Vec3A| (c.length_squared() - 1.0).abs() <= 2e-4;
        let rotation = unit(m.x_axis) && unit(m.y_axis) && unit(m.z_axis);
        let t = Vec3::from(pose.translation);
        let slack = 64.0 * f32::EPSILON * (t.abs().max_element() + self.radius);
        rotation && slack <= self.margin
    }

    /// The box cluster `ci` covers at `pose` (its moved rest box, grown by the margin), or
    /// `None` for an empty cluster.
    #[inline]
    fn moved_box(&self, ci: usize, pose: &Affine3A) -> Option<Aabb> {
        let b = self.clusters.get(ci)?;
        if b.min.x > b.max.x {
            return None; // empty cell (inverted box)
        }
        let m = &pose.matrix3;
        let centre = pose.transform_point3((b.min + b.max) * 0.5);
        let h = (b.max - b.min) * 0.5;
        let half = Vec3::from(m.x_axis.abs()) * h.x
            + Vec3::from(m.y_axis.abs()) * h.y
            + Vec3::from(m.z_axis.abs()) * h.z
            + Vec3::splat(self.margin);
        Some(Aabb {
            min: centre - half,
            max: centre + half,
        })
    }

    /// A box holding every node of the body moved by `pose` (the rest bounds moved, grown by
    /// the margin), or `None` when the pose is too far from the origin for the margin to
    /// cover rounding or some node lies outside every tet box: then the caller bounds the
    /// moved nodes itself.
    ///
    /// # Bounded work
    /// Constant.
    #[inline]
    pub fn moved_bounds(&self, pose: &Affine3A) -> Option<Aabb> {
        if !self.nodes_bounded || !self.pose_in_margin(pose) {
            return None;
        }
        let b = self.bounds;
        let m = &pose.matrix3;
        let centre = pose.transform_point3((b.min + b.max) * 0.5);
        let h = (b.max - b.min) * 0.5;
        let half = Vec3::from(m.x_axis.abs()) * h.x
            + Vec3::from(m.y_axis.abs()) * h.y
            + Vec3::from(m.z_axis.abs()) * h.z
            + Vec3::splat(self.margin);
        Some(Aabb {
            min: centre - half,
            max: centre + half,
        })
    }

    /// The clusters whose box at `pose` meets a cell `cells` marks. A node of the body moved
    /// by `pose` whose cluster is not near is in no marked cell, so in no tet of the body
    /// `cells` was built over ([`RigidTets::node_near`]); neither is a point of a tet of this
    /// body in such a cluster. Every cluster counts as near when the pose is too far from the
    /// origin for the margin (see [`rigid_tets_over_points_coherent`]). When `cells` lists
    /// its body's nodes ([`Occupancy::with_node_lists`]) the result carries it, for
    /// [`rigid_tets_over_points_coherent`].
    ///
    /// # Bounded work
    /// Per cluster one box transform and [`Occupancy::may_meet`]; at most
    /// [`MAX_NEAR_CLUSTERS`] clusters are tested (the others count as near).
    pub fn near<'c>(&self, pose: Affine3A, cells: &Occupancy<'c>) -> NearClusters<'c> {
        let lists = cells.listed_nodes().map(|_| *cells);
        if !self.pose_in_margin(&pose) {
            return NearClusters {
                cells: lists,
                ..NearClusters::ALL
            };
        }
        let mut n = NearClusters {
            cells: lists,
            ..NearClusters::ALL
        };
        for ci in 0..self.clusters().min(MAX_NEAR_CLUSTERS) {
            let near = self
                .moved_box(ci, &pose)
                .is_some_and(|b| cells.may_meet(&b));
            if !near {
                if let Some(w) = n.bits.get_mut(ci / 64) {
                    *w &= !(1 << (ci % 64));
                }
            }
        }
        n
    }

    /// `false` when `near` rules node `n` of the body out: its cluster is not near. Nodes
    /// without a cluster (beyond the storage, or outside every tet box) are never ruled out.
    ///
    /// # Bounded work
    /// Constant.
    #[inline]
    pub fn node_near(&self, n: usize, near: &NearClusters<'_>) -> bool {
        match self.node_clusters.get(n) {
            Some(&c) if c != NO_CLUSTER => near.is_near(c as usize),
            _ => true,
        }
    }
}

/// The points (hashed in `points_hash`, item = index into `points`) inside the tets of
/// `body`, a rigid body moved by `pose` from the rest frame `rigid` was built in
/// (`body.positions` = `pose` applied to the rest positions). Same contract and result as
/// [`tets_over_points_coherent`] with `own` unset: each point once, with the smallest tet
/// that holds it, sorted by point; `out[..kept]` the previous call's result, whose points are
/// tested first and keep their entries while inside. When `out` cannot hold every hit, the
/// remaining room goes to the new points with the smallest indices (the walk's order is not
/// kept), and `saturated` is set.
///
/// Only the clusters `near` names are searched: it must hold every cluster whose moved box
/// may hold one of the points ([`RigidTets::near`] over an [`Occupancy`] of the body whose
/// nodes the points are, or [`NearClusters::ALL`]). When that occupancy lists as many nodes
/// as `points` ([`Occupancy::with_node_lists`]), the points in a cluster's moved box are
/// read from its lists, positions included, instead of `points_hash`: they must be the
/// nodes of the static body the lists were built over, at the same positions.
///
/// With `max_walk` above 0 each previous point first walks from its previous tet through
/// `body` ([`super::walk_to_holder`], at most `max_walk` tets) and keeps the tet it ends in
/// when that holds it by [`super::WALK_MARGIN`]: the same tet when `body` passes
/// [`super::walks_exact`] and `rigid` holds all its tets (pass 0 otherwise).
///
/// Falls back to [`tets_over_points_coherent`] (same result) when the pose is not a rotation
/// (a quaternion far from unit length), or so far from the origin that rounding could exceed
/// `rigid`'s margin (`64 x f32::EPSILON x (|translation| + rest radius) > margin`), or when a
/// cluster's moved box could cover more than [`MAX_CELLS_PER_TET`] cells of `points_hash`. A
/// cluster whose moved box covers more than [`MAX_CELLS_PER_TET`] cells of the node lists
/// reads `points_hash` instead.
///
/// # Bounded work
/// O(kept x (max_walk + b)) for the previous points, then per near cluster one box transform
/// and a read of at most [`MAX_CELLS_PER_TET`] cells (one run per row of cells of the node
/// lists, with the nodes outside their grid, or one bucket per cell of `points_hash`); per
/// point met one box test, for those in the cluster's moved box one transform and, for the
/// points in the cluster's own cell, at most `b` entry tests and `b` candidate tets
/// (`RigidTets::locate_batch`), for `b` the fullest cell of the rest grid; a binary search
/// over `kept` entries and, once `out` is full, a heap step (O(log out.len())) per new hit;
/// one sort of at most `out.len()` entries.
#[allow(clippy::too_many_arguments)]
pub fn rigid_tets_over_points_coherent(
    points_hash: &SpatialHash<'_>,
    points: &[Vec3],
    rigid: &RigidTets<'_>,
    body: &Body<'_, '_>,
    pose: Affine3A,
    near: &NearClusters<'_>,
    out: &mut [Collision],
    kept: usize,
    max_walk: u32,
) -> CollideReport {
    let g = points_hash.cell_size();
    let per_axis = libm::floorf(2.0 * (rigid.reach + 2.0 * rigid.margin) / g) as u64 + 2;
    let fits = per_axis.saturating_mul(per_axis).saturating_mul(per_axis);
    if !rigid.pose_in_margin(&pose) || fits > MAX_CELLS_PER_TET as u64 {
        return tets_over_points_coherent(points_hash, points, body, false, out, kept);
    }
    let inv = pose.inverse();
    let mut r = CollideReport::default();

    // The previous points still inside, compacted in place (in node order).
    let m = super::keep_previous(out, kept, points, |_, p, was| {
        if max_walk > 0 && was.idx() < body.tet_count() {
            let t = super::walk_to_holder(body, was, p, max_walk, &mut r.candidates);
            if t.is_some() {
                return t;
            }
        }
        rigid.locate(inv.transform_point3(p), p, body, &mut r)
    });

    // New points, cluster by cluster: those a cluster keeps wait in a batch for their
    // lookups (the order they are found in does not change the result: it is sorted, and a
    // full list keeps the smallest nodes whatever the order).
    let (kept_part, new_part) = out.split_at_mut(m);
    let search = Search {
        rigid,
        body,
        inv,
        kept: kept_part,
    };
    let mut look = Lookups {
        part: new_part,
        n: 0,
        heap: false,
        batch: [Pending::default(); BATCH],
        waiting: 0,
    };
    let bounds = points_hash.bounds();
    let lists = near
        .cells
        .filter(|c| c.listed_nodes() == Some(points.len()));
    for ci in 0..rigid.clusters() {
        if !near.is_near(ci) {
            continue;
        }
        let Some(wb) = rigid.moved_box(ci, &pose) else {
            continue;
        };
        if !wb.overlaps(&bounds) {
            continue;
        }
        // The nodes in the box from the lists, one run per row of cells; else (no lists, or
        // a box over too many of their cells) from the hash, one bucket per cell.
        let listed = lists.is_some_and(|cells| {
            cells.nodes_in(&wb, MAX_CELLS_PER_TET, |run| {
                // The box test on a run's nodes without a branch each, then the rest of
                // `consider` for those in the box.
                for chunk in run.chunks(64) {
                    let mut inside = 0u64;
                    for (j, e) in chunk.iter().enumerate() {
                        inside |= (holds_point(&wb, e.pos) as u64) << j;
                    }
                    while inside != 0 {
                        let j = inside.trailing_zeros() as usize;
                        inside &= inside - 1;
                        if let Some(e) = chunk.get(j) {
                            look.admit(&search, ci, e.node, e.pos, &mut r);
                        }
                    }
                }
            })
        });
        let visited = listed
            || points_hash.query_box_ro(&wb, MAX_CELLS_PER_TET, |_, item| {
                if let Some(&p) = points.get(item as usize) {
                    look.consider(&search, &wb, ci, item, p, &mut r);
                }
            });
        if !visited {
            r.clipped = r.clipped.wrapping_add(1);
        }
    }
    look.flush(&search, &mut r);
    let n = look.n;
    let all = out.get_mut(..m + n).unwrap_or(&mut []);
    all.sort_unstable();
    r.count = all.len();
    r
}

/// What a call of [`rigid_tets_over_points_coherent`] searches with: the body at rest and
/// moved, the pose's inverse and the previous points kept.
struct Search<'a> {
    rigid: &'a RigidTets<'a>,
    body: &'a Body<'a, 'a>,
    inv: Affine3A,
    kept: &'a [Collision],
}

/// The new points of [`rigid_tets_over_points_coherent`]: those waiting for their lookups,
/// and the hits, `part[..n]` in use; once full, a max-heap by node that keeps the smallest
/// nodes.
struct Lookups<'o> {
    part: &'o mut [Collision],
    n: usize,
    heap: bool,
    batch: [Pending; BATCH],
    waiting: usize,
}

impl Lookups<'_> {
    /// Point `item` at `p`, met in cluster `ci`'s moved box `wb`: a point outside the box is
    /// in none of the cluster's tets (the box holds their moved parts with the margin); one
    /// in it goes on ([`Lookups::admit`]).
    #[inline(always)]
    fn consider(
        &mut self,
        s: &Search<'_>,
        wb: &Aabb,
        ci: usize,
        item: u32,
        p: Vec3,
        r: &mut CollideReport,
    ) {
        if holds_point(wb, p) {
            self.admit(s, ci, item, p, r);
        }
    }

    /// Point `item` at `p`, in cluster `ci`'s moved box: moved back, it waits for its lookup
    /// when the cluster's cell holds it (so no point is looked up twice) and it is not among
    /// the points kept. A full batch is looked up.
    #[inline(always)]
    fn admit(&mut self, s: &Search<'_>, ci: usize, item: u32, p: Vec3, r: &mut CollideReport) {
        let q = s.inv.transform_point3(p);
        if !s.rigid.in_cluster(q, ci) {
            return;
        }
        if !s.kept.is_empty()
            && s.kept
                .binary_search_by_key(&NodeId(item), |c| c.node)
                .is_ok()
        {
            return; // tested above
        }
        if let Some(slot) = self.batch.get_mut(self.waiting) {
            *slot = Pending { node: item, p, q };
            self.waiting += 1;
        }
        if self.waiting == BATCH {
            self.flush(s, r);
        }
    }

    /// Looks the waiting points up (`RigidTets::locate_batch`) and lists those found.
    fn flush(&mut self, s: &Search<'_>, r: &mut CollideReport) {
        let mut found = [TetId::NONE; BATCH];
        let batch = self.batch;
        let waiting = batch.get(..self.waiting).unwrap_or(&[]);
        s.rigid.locate_batch(waiting, s.body, r, &mut found);
        self.waiting = 0;
        for (pt, &tet) in waiting.iter().zip(found.iter()) {
            if tet.is_some()
                && !self.push(Collision {
                    node: NodeId(pt.node),
                    tet,
                })
            {
                r.saturated = true;
            }
        }
    }

    /// Lists `c` (`true`); once full (`false`), keeps it instead of the largest node when its
    /// node is smaller.
    fn push(&mut self, c: Collision) -> bool {
        if self.n < self.part.len() {
            self.part[self.n] = c;
            self.n += 1;
            return true;
        }
        if self.n == 0 {
            return false;
        }
        if !self.heap {
            heapify(self.part);
            self.heap = true;
        }
        if c.node < self.part[0].node {
            self.part[0] = c;
            sift_down(self.part, 0);
        }
        false
    }
}

/// Makes `h` a max-heap by node.
fn heapify(h: &mut [Collision]) {
    for i in (0..h.len() / 2).rev() {
        sift_down(h, i);
    }
}

/// Restores the max-heap (by node) below `i`.
fn sift_down(h: &mut [Collision], mut i: usize) {
    loop {
        let (l, rr) = (2 * i + 1, 2 * i + 2);
        let mut big = i;
        if l < h.len() && h[l].node > h[big].node {
            big = l;
        }
        if rr < h.len() && h[rr].node > h[big].node {
            big = rr;
        }
        if big == i {
            return;
        }
        h.swap(i, big);
        i = big;
    }
}
