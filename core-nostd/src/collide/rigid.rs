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
//!
//! Files: this one holds [`RigidTets`], its storage, errors and build (the rest grid and the
//! clusters); `rigid_locate.rs` the lookups of rest-frame points in the rest grid, a batch at
//! a time; `rigid_near.rs` the clusters near another body ([`RigidTets::near`],
//! [`NearClusters`]) and the boxes the clusters cover at a pose; `rigid_search.rs`
//! [`rigid_tets_over_points_coherent`] itself. The tests are in `rigid_tests.rs`.
//!
//! [`rigid_tets_over_points_coherent`]: super::rigid_tets_over_points_coherent
//! [`Occupancy::with_node_lists`]: super::Occupancy::with_node_lists
//! [`NearClusters`]: super::NearClusters

use glam::Vec3;

use super::entry::GridEntry;
use super::Body;
use crate::hash::Aabb;
use crate::ids::{NodeId, TetId};

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
pub(super) fn dense_index(dims: [i32; 3], c: [i32; 3]) -> usize {
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

/// Why [`RigidTets::build`] refused.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
#[non_exhaustive]
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

impl core::error::Error for RigidError {}

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
    pub(super) grid_starts: &'s [u32],
    pub(super) grid_tets: &'s [GridEntry],
    /// Rest grid cells per axis and their inverse sizes (from `bounds.min`).
    pub(super) grid_dims: [i32; 3],
    pub(super) grid_inv: Vec3,
    pub(super) tet_boxes: &'s [Aabb],
    pub(super) clusters: &'s [Aabb],
    pub(super) node_clusters: &'s [u32],
    pub(super) bounds: Aabb,
    inv: Vec3,
    dims: [i32; 3],
    pub(super) margin: f32,
    /// Largest |coordinate| of a rest box corner.
    pub(super) radius: f32,
    /// Largest length of a cluster box's half extent.
    pub(super) reach: f32,
    /// `true` when `bounds` holds every node of the body (so [`RigidTets::moved_bounds`]
    /// holds every moved node).
    pub(super) nodes_bounded: bool,
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
    /// every node (`RigidTets::moved_bounds`). Call it at set-up.
    ///
    /// # Errors
    /// [`RigidError`]: short storage, a full rest grid, a bad size, or no finite tet.
    ///
    /// [`rigid_tets_over_points_coherent`]: super::rigid_tets_over_points_coherent
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
    pub(crate) fn clusters(&self) -> usize {
        self.dims.iter().map(|&d| d as usize).product()
    }

    /// Cluster cells that hold part of a tet.
    #[cfg(test)]
    pub(crate) fn occupied_clusters(&self) -> usize {
        let n = self.clusters();
        self.clusters
            .iter()
            .take(n)
            .filter(|b| b.min.x <= b.max.x)
            .count()
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
    pub(super) fn in_cluster(&self, q: Vec3, ci: usize) -> bool {
        holds_point(&self.bounds, q) & (self.index(self.grid_cell(q)) == ci)
    }
}

/// `true` when box `b` holds `q` (its faces included): [`Aabb::contains`] with the six
/// comparisons combined without a branch.
#[inline]
pub(super) fn holds_point(b: &Aabb, q: Vec3) -> bool {
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
pub(super) const NO_CLUSTER: u32 = u32::MAX;
