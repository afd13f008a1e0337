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
    if tet.idx() >= mesh.tet_count() {
        return [Vec3::ZERO; 4];
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
    let scale = 1.0 / (1u32 << path.depth.min(31)) as f32;
    path.bary().map(|w| {
        let mut p = Vec3::ZERO;
        for &k in &order {
            p += corners[k] * w[k] as f32;
        }
        p * scale
    })
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
