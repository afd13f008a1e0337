//! Points inside the tets of a rigid body (a tool), with the body's tets listed once at rest.
//!
//! [`tets_over_points`](super::tets_over_points) walks the cells of every tet's box each tick.
//! For a rigid body that is wasted work: its tets never change shape. [`RigidTets`] lists
//! them once in the body's own frame, in a dense rest grid (per cell, the tets whose grown
//! box meets it, in increasing id order), and groups them into clusters (the cells of a
//! coarse rest-frame grid); per tick [`rigid_tets_over_points_coherent`] queries the points'
//! hash only over each cluster's moved box, moves each point met that the box holds into the
//! body's frame, lets only the cluster whose cell holds it go on (so no point is handled
//! twice), and looks it up in its rest grid cell. [`RigidTets::near`] tells, once a tick, which clusters' moved boxes
//! meet cells another body occupies: the search skips the others, and so can a lookup of the
//! body's own nodes in the other body ([`RigidTets::node_near`]). Rest-frame data only culls,
//! with a margin; the test that decides is the same barycentric test on the moved corners as
//! everywhere else, so the contacts are the ones [`tets_over_points`](super::tets_over_points)
//! and a brute force find.

use glam::{Affine3A, Vec3};

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
    /// The tets of each rest grid cell: one entry per tet and cell its grown box meets
    /// ([`RigidTets::grid_sizes`]).
    pub grid_tets: &'s mut [u32],
    /// One box per tet.
    pub tet_boxes: &'s mut [Aabb],
    /// One box per cluster cell: its length caps the number of clusters.
    pub clusters: &'s mut [Aabb],
    /// One cluster index per node (nodes beyond its length are never culled); may be empty.
    pub node_clusters: &'s mut [u32],
}

/// A rigid body's tets at rest: listed in a dense grid in its frame (each tet's box grown by
/// a margin), the grown boxes, and a coarse grid of clusters, each with the rest-frame box of
/// what its cell holds. Built once at set-up; read-only afterwards.
#[derive(Debug)]
pub struct RigidTets<'s> {
    /// Rest grid: cell `i`'s tets are `grid_tets[grid_starts[i]..grid_starts[i + 1]]`.
    grid_starts: &'s [u32],
    grid_tets: &'s [u32],
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
        // Fill: `grid_starts[i]` is cell i's cursor, ending at cell i + 1's start...
        for t in 0..nt {
            let Some(b) = usable(t) else { continue };
            let (lo, hi) = cell_range(b);
            for_cells(lo, hi, |c| {
                let i = dense_index(grid_dims, c);
                if let Some(s) = grid_starts.get_mut(i) {
                    if let Some(e) = grid_tets.get_mut(*s as usize) {
                        *e = t as u32;
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
    /// by `margin`: `(grid_starts, grid_tets)` lengths for [`RigidTetsStorage`] (`None` for a
    /// bad size or no finite tet). `tet_boxes` is scratch of one box per tet.
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

    /// The smallest tet holding world point `p` (rest-frame `q`): rest grid cell (its tets in
    /// increasing id order), grown box, then the barycentric test on the moved corners of
    /// `body`.
    fn locate(&self, q: Vec3, p: Vec3, body: &Body<'_, '_>, r: &mut CollideReport) -> TetId {
        if !self.bounds.contains(q) {
            return TetId::NONE;
        }
        let i = dense_index(
            self.grid_dims,
            dense_cell(self.bounds.min, self.grid_inv, self.grid_dims, q),
        );
        let lo = self.grid_starts.get(i).copied().unwrap_or(0) as usize;
        let hi = self.grid_starts.get(i + 1).copied().unwrap_or(0) as usize;
        for &item in self.grid_tets.get(lo..hi).unwrap_or(&[]) {
            if !self
                .tet_boxes
                .get(item as usize)
                .is_some_and(|b| b.contains(q))
            {
                continue;
            }
            let t = TetId(item);
            if body
                .tet_positions(t)
                .is_some_and(|corners| candidate_holds(p, corners, r))
            {
                return t;
            }
        }
        TetId::NONE
    }
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
/// ([`RigidTets::near`]): one bit per cluster, on the stack (512 bytes).
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct NearClusters {
    bits: [u64; MAX_NEAR_CLUSTERS / 64],
}

impl NearClusters {
    /// Every cluster near (culls nothing).
    pub const ALL: Self = Self {
        bits: [u64::MAX; MAX_NEAR_CLUSTERS / 64],
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
    /// origin for the margin (see [`rigid_tets_over_points_coherent`]).
    ///
    /// # Bounded work
    /// Per cluster one box transform and [`Occupancy::may_meet`]; at most
    /// [`MAX_NEAR_CLUSTERS`] clusters are tested (the others count as near).
    pub fn near(&self, pose: Affine3A, cells: &Occupancy<'_>) -> NearClusters {
        if !self.pose_in_margin(&pose) {
            return NearClusters::ALL;
        }
        let mut n = NearClusters::ALL;
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
    pub fn node_near(&self, n: usize, near: &NearClusters) -> bool {
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
/// nodes the points are, or [`NearClusters::ALL`]).
///
/// With `max_walk` above 0 each previous point first walks from its previous tet through
/// `body` ([`super::walk_to_holder`], at most `max_walk` tets) and keeps the tet it ends in
/// when that holds it by [`super::WALK_MARGIN`]: the same tet when `body` passes
/// [`super::walks_exact`] and `rigid` holds all its tets (pass 0 otherwise).
///
/// Falls back to [`tets_over_points_coherent`] (same result) when the pose is not a rotation
/// (a quaternion far from unit length), or so far from the origin that rounding could exceed
/// `rigid`'s margin (`64 x f32::EPSILON x (|translation| + rest radius) > margin`), or when a
/// cluster's moved box could cover more than
/// [`MAX_CELLS_PER_TET`] cells of `points_hash`.
///
/// # Bounded work
/// O(kept x (max_walk + b)) for the previous points, then per near cluster one box transform and a query
/// of at most
/// [`MAX_CELLS_PER_TET`] cells of `points_hash`; per point met one box test, for those in the
/// cluster's moved box one transform and, for the points in the cluster's own cell, at most
/// `b` candidate tets, for `b` the fullest cell of
/// the rest grid; a binary search over `kept` entries and, once `out` is full, a heap step
/// (O(log out.len())) per new hit; one sort of at most `out.len()` entries.
#[allow(clippy::too_many_arguments)]
pub fn rigid_tets_over_points_coherent(
    points_hash: &SpatialHash<'_>,
    points: &[Vec3],
    rigid: &RigidTets<'_>,
    body: &Body<'_, '_>,
    pose: Affine3A,
    near: &NearClusters,
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

    // New points, cluster by cluster.
    let (kept_part, new_part) = out.split_at_mut(m);
    let mut n = 0usize; // entries of new_part in use
    let mut heap = false; // new_part is a max-heap by node (it is full)
    let bounds = points_hash.bounds();
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
        let visited = points_hash.query_box_ro(&wb, MAX_CELLS_PER_TET, |_, item| {
            let Some(&p) = points.get(item as usize) else {
                return;
            };
            // A point outside the cluster's moved box is in none of its tets (the box holds
            // their moved parts with the margin): only the points in it are moved back.
            if !wb.contains(p) {
                return;
            }
            let q = inv.transform_point3(p);
            if rigid.cluster_of(q) != Some(ci) {
                return;
            }
            let node = NodeId(item);
            if m > 0 && kept_part.binary_search_by_key(&node, |c| c.node).is_ok() {
                return; // tested above
            }
            let tet = rigid.locate(q, p, body, &mut r);
            if tet.is_none() {
                return;
            }
            let c = Collision { node, tet };
            if n < new_part.len() {
                new_part[n] = c;
                n += 1;
                return;
            }
            r.saturated = true;
            if n == 0 {
                return;
            }
            if !heap {
                heapify(new_part);
                heap = true;
            }
            if c.node < new_part[0].node {
                new_part[0] = c;
                sift_down(new_part, 0);
            }
        });
        if !visited {
            r.clipped = r.clipped.wrapping_add(1);
        }
    }
    let all = out.get_mut(..m + n).unwrap_or(&mut []);
    all.sort_unstable();
    r.count = m + n;
    r
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
