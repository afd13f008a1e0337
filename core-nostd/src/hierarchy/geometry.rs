//! Node geometry from the tree table: the vertices of a node are integer barycentric
//! combinations of its root's corners, evaluated in one canonical order (ascending global node
//! id), so a point shared by several nodes, trees or depths gets the same bits everywhere and
//! the drilled surface is watertight.

use glam::Vec3;

use super::table::Path;
use crate::ids::TetId;
use crate::mesh::Mesh;

/// The four vertex positions of node `path` in the tree of coarse tet `tet` (in the node's own
/// vertex order; see [`Path::inverted`] for its orientation). Zero when `tet` is out of range.
///
/// # Bounded work
/// O(depth) <= [`super::MAX_DEPTH`] steps.
pub fn node_positions(mesh: &Mesh<'_>, tet: TetId, path: &Path) -> [Vec3; 4] {
    match RootFrame::of(mesh, tet) {
        Some(frame) => frame.positions(&path.bary(), path.depth),
        None => [Vec3::ZERO; 4],
    }
}

/// A coarse tet's corners and their canonical order (ascending global node id): everything
/// needed to turn a node's integer barycentric coordinates into positions. Walks that carry
/// the coordinates down the tree use it to get each node's corners in O(1) with the same bits
/// as [`node_positions`].
#[derive(Clone, Copy, Debug)]
pub(crate) struct RootFrame {
    corners: [Vec3; 4],
    order: [usize; 4],
}

impl RootFrame {
    /// The frame of coarse tet `tet`, `None` when it is out of range.
    pub(crate) fn of(mesh: &Mesh<'_>, tet: TetId) -> Option<Self> {
        if tet.idx() >= mesh.tet_count() {
            return None;
        }
        let ids = mesh.tet(tet).nodes;
        let corners = mesh.tet_positions(tet);
        // Canonical order of the four corners by global node id (a 4-element insertion sort).
        let mut order = [0usize, 1, 2, 3];
        for i in 1..4 {
            let mut j = i;
            while j > 0 && ids[order[j - 1]].0 > ids[order[j]].0 {
                order.swap(j - 1, j);
                j -= 1;
            }
        }
        Some(Self { corners, order })
    }

    /// The four vertex positions of the node with integer barycentric coordinates `bary`
    /// (scaled by `2^depth`).
    ///
    /// # Bounded work
    /// Constant.
    #[inline]
    pub(crate) fn positions(&self, bary: &[[u32; 4]; 4], depth: u8) -> [Vec3; 4] {
        let scale = 1.0 / (1u32 << depth.min(31)) as f32;
        bary.map(|w| {
            let mut p = Vec3::ZERO;
            for &k in &self.order {
                p += self.corners[k] * w[k] as f32;
            }
            p * scale
        })
    }
}

/// Volume of node `path` of tet `tet`: the root's volume over `8^depth` (Bey's eight children
/// have equal volumes).
///
/// # Bounded work
/// O(depth).
pub fn node_volume(mesh: &Mesh<'_>, tet: TetId, depth: u8) -> f64 {
    if tet.idx() >= mesh.tet_count() {
        return 0.0;
    }
    let mut v = crate::geom::tet_volume(mesh.tet_positions(tet)) as f64;
    for _ in 0..depth {
        v *= 0.125;
    }
    v
}
