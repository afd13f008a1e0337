//! The clusters of a [`RigidTets`] near another body this tick ([`RigidTets::near`],
//! [`NearClusters`]) and the boxes its clusters and nodes cover at a pose.

use glam::{Affine3A, Vec3};

use super::rigid::{RigidTets, NO_CLUSTER};
use super::Occupancy;
use crate::hash::Aabb;

/// Clusters a [`NearClusters`] tells apart; clusters beyond count as near.
pub const MAX_NEAR_CLUSTERS: usize = 4096;

/// Which clusters of a [`RigidTets`] are near another body this tick
/// ([`RigidTets::near`]): one bit per cluster, on the stack (512 bytes), and the other body's
/// [`Occupancy`] when it lists its nodes per cell ([`Occupancy::with_node_lists`]: then
/// [`rigid_tets_over_points_coherent`] reads the nodes in a cluster's box from those lists).
///
/// [`rigid_tets_over_points_coherent`]: super::rigid_tets_over_points_coherent
#[derive(Clone, Copy, Debug)]
pub struct NearClusters<'c> {
    bits: [u64; MAX_NEAR_CLUSTERS / 64],
    pub(super) cells: Option<Occupancy<'c>>,
}

impl NearClusters<'_> {
    /// Every cluster near (culls nothing), no node lists.
    pub(crate) const ALL: Self = Self {
        bits: [u64::MAX; MAX_NEAR_CLUSTERS / 64],
        cells: None,
    };

    /// `true` when cluster `c` is near (or beyond [`MAX_NEAR_CLUSTERS`]).
    #[inline]
    pub(crate) fn is_near(&self, c: usize) -> bool {
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
    pub(super) fn pose_in_margin(&self, pose: &Affine3A) -> bool {
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
    pub(super) fn moved_box(&self, ci: usize, pose: &Affine3A) -> Option<Aabb> {
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
    pub(crate) fn moved_bounds(&self, pose: &Affine3A) -> Option<Aabb> {
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
    /// `cells` was built over (`RigidTets::node_near`); neither is a point of a tet of this
    /// body in such a cluster. Every cluster counts as near when the pose is too far from the
    /// origin for the margin (see [`rigid_tets_over_points_coherent`]). When `cells` lists
    /// its body's nodes ([`Occupancy::with_node_lists`]) the result carries it, for
    /// [`rigid_tets_over_points_coherent`].
    ///
    /// # Bounded work
    /// Per cluster one box transform and `Occupancy::may_meet`; at most
    /// [`MAX_NEAR_CLUSTERS`] clusters are tested (the others count as near).
    ///
    /// [`rigid_tets_over_points_coherent`]: super::rigid_tets_over_points_coherent
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
    pub(crate) fn node_near(&self, n: usize, near: &NearClusters<'_>) -> bool {
        match self.node_clusters.get(n) {
            Some(&c) if c != NO_CLUSTER => near.is_near(c as usize),
            _ => true,
        }
    }
}
