//! [`Body`]: a mesh's topology with its current node positions and orientation.

use glam::{Quat, Vec3};

use crate::ids::{NodeId, TetId};
use crate::mesh::Mesh;

/// A mesh as it is placed now: topology from `mesh`, node positions from `positions`
/// (the mesh's own for a static object, a caller buffer of moved positions for a tool), and
/// the rotation that turns the mesh's stored boundary normals into current ones.
#[derive(Clone, Copy, Debug)]
pub struct Body<'m, 'a> {
    /// Topology and rest boundary normals.
    pub mesh: &'m Mesh<'a>,
    /// Current node positions (one per node of `mesh`).
    pub positions: &'m [Vec3],
    /// Rotation from the mesh's frame to the current one (applies to normals).
    pub rotation: Quat,
}

impl<'m, 'a> Body<'m, 'a> {
    /// The mesh where it is stored.
    pub fn fixed(mesh: &'m Mesh<'a>) -> Self {
        Self {
            mesh,
            positions: mesh.positions(),
            rotation: Quat::IDENTITY,
        }
    }

    /// The mesh moved rigidly: `positions` holds the moved nodes, `rotation` the rotation part.
    pub fn moved(mesh: &'m Mesh<'a>, positions: &'m [Vec3], rotation: Quat) -> Self {
        Self {
            mesh,
            positions,
            rotation,
        }
    }

    /// Number of tets.
    #[inline]
    pub fn tet_count(&self) -> usize {
        self.mesh.tet_count()
    }

    /// Current position of a node (`None` for an id out of range).
    #[inline]
    pub(crate) fn pos(&self, n: NodeId) -> Option<Vec3> {
        self.positions.get(n.idx()).copied()
    }

    /// Node ids of a tet (`None` out of range).
    #[inline]
    pub(crate) fn tet_nodes(&self, t: TetId) -> Option<[NodeId; 4]> {
        self.mesh.get_tet_nodes(t)
    }

    /// Current corner positions of a tet (`None` out of range).
    #[inline]
    pub fn tet_positions(&self, t: TetId) -> Option<[Vec3; 4]> {
        let n = self.tet_nodes(t)?;
        Some([
            self.pos(n[0])?,
            self.pos(n[1])?,
            self.pos(n[2])?,
            self.pos(n[3])?,
        ])
    }

    /// Current averaged outward normal of a boundary node (zero inside or out of range).
    #[inline]
    #[cfg(test)]
    pub(crate) fn normal(&self, n: NodeId) -> Vec3 {
        match self.mesh.normals().get(n.idx()) {
            Some(&v) if self.rotation == Quat::IDENTITY => v,
            Some(&v) => self.rotation * v,
            None => Vec3::ZERO,
        }
    }

    /// The tet across face `f` of `t`, `NONE` on the boundary or out of range.
    #[inline]
    pub(crate) fn neighbour(&self, t: TetId, f: u8) -> TetId {
        self.mesh.get_neighbour(t, f).unwrap_or(TetId::NONE)
    }
}
