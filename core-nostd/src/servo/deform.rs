//! A [`World`] whose mesh moves and deforms: new node positions every simulation step, from
//! whatever physics the caller runs ([`World::set_positions`]), and everything that depends on
//! positions brought up to date within bounded work.
//!
//! What follows the positions, and how:
//! - each tet's box and the Teschner hash of the tets: rebuilt (counting sort, the cell size
//!   of [`World::new`]);
//! - the boundary normals ([`Mesh::update_boundary`]);
//! - the hierarchy's faces: nothing to do, they are barycentric in their root tet and are
//!   evaluated at the current positions whenever they are needed;
//! - the contact search's caches: the sphere memo is emptied, the resume place forgets the
//!   nodes it measured (its tree starts again from the root), the kept faces are measured
//!   again at the new positions (those no longer visible are dropped); a candidate gather
//!   spread over steps ([`World::set_zone_gather`]) forgets its lists and gathers afresh;
//! - the contact plane and the candidate list stay the last step's until the next
//!   [`World::simulate`], which finds both again on the new positions;
//! - removed volumes are measured in the rest state ([`Mesh::set_rest`]): a leaf's volume is
//!   its root's rest volume over `8^depth`, whatever the current shape.
//!
//! [`Mesh::update_boundary`]: crate::mesh::Mesh::update_boundary
//! [`Mesh::set_rest`]: crate::mesh::Mesh::set_rest

use glam::Vec3;

use super::World;
use crate::hash::{Aabb, Rebuilt};
use crate::hierarchy::{keep_face, Kept};
use crate::ids::TetId;

/// Why [`World::set_positions`] or [`World::enable_deformation`] refused (nothing changed).
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum DeformError {
    /// [`World::enable_deformation`] was not called: there is no rest state to measure
    /// removed volumes in.
    NoRest,
    /// The rest storage holds fewer entries than the mesh has nodes.
    RestTooShort {
        /// Nodes in the mesh.
        nodes: usize,
        /// Entries handed in.
        got: usize,
    },
    /// The new positions are not one per node.
    Count {
        /// Nodes in the mesh.
        nodes: usize,
        /// Positions handed in.
        got: usize,
    },
    /// A new position is not finite.
    NotFinite {
        /// The node.
        node: usize,
    },
}

impl core::fmt::Display for DeformError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match *self {
            Self::NoRest => write!(f, "the world has no rest state (deformation not enabled)"),
            Self::RestTooShort { nodes, got } => {
                write!(f, "rest storage of {got} positions for {nodes} nodes")
            }
            Self::Count { nodes, got } => write!(f, "{got} positions for {nodes} nodes"),
            Self::NotFinite { node } => write!(f, "position of node {node} is not finite"),
        }
    }
}

/// What one [`World::set_positions`] did.
#[derive(Clone, Copy, PartialEq, Debug, Default)]
pub struct DeformReport {
    /// The largest distance of a node from its rest position.
    pub max_displacement: f32,
    /// Entries in the rebuilt hash.
    pub hash_entries: u32,
    /// The hash ran out of entries: the first tets that fit are hashed, the others are not
    /// found by the zone queries until a rebuild fits (counted in `saturations().hash`).
    pub hash_saturated: bool,
    /// Kept contact faces measured again at the new positions (still visible).
    pub kept: u32,
}

impl<'a> World<'a> {
    /// Keeps the current positions in `rest` (one entry per node at least) as the rest state,
    /// so that [`World::set_positions`] may move the nodes: removed volumes are measured
    /// there. Call it before drilling, once.
    ///
    /// # Bounded work
    /// O(N) for N nodes.
    ///
    /// # Errors
    /// [`DeformError::RestTooShort`] (nothing changed).
    pub fn enable_deformation(&mut self, rest: &'a mut [Vec3]) -> Result<(), DeformError> {
        let nodes = self.mesh.node_count();
        self.mesh
            .set_rest(rest)
            .map_err(|r| DeformError::RestTooShort {
                nodes,
                got: r.len(),
            })
    }

    /// Moves every node to `new` (one position per node, the caller's physics' output) and
    /// brings up to date what depends on positions: the boundary normals, each tet's box, the
    /// tet hash (rebuilt with the cell size of [`World::new`]), the contact search's sphere
    /// memo (emptied), its resume place (its tree from the root) and its kept faces (measured
    /// again from the last contact's centre), a candidate gather's lists (forgotten). The
    /// hierarchy follows by itself (barycentric
    /// in its roots). The contact plane stays the last step's until the next
    /// [`World::simulate`].
    ///
    /// # Bounded work
    /// O(N + T + buckets + hash entries + memo slots) for N nodes and T tets, plus
    /// O([`crate::hierarchy::KEEP`] x depth) for the kept faces. The hash's part dominates:
    /// docs/TIMING.md gives it for the cow and the teddy.
    ///
    /// # Capacity
    /// A hash whose entries run out keeps the first tets that fit and counts
    /// `saturations().hash` (a deformed tet whose box covers more cells takes more entries).
    ///
    /// # Errors
    /// [`DeformError::NoRest`] before [`World::enable_deformation`], [`DeformError::Count`]
    /// when `new` is not one position per node, [`DeformError::NotFinite`] for a non-finite
    /// position; nothing changed.
    pub fn set_positions(&mut self, new: &[Vec3]) -> Result<DeformReport, DeformError> {
        if !self.mesh.has_rest() {
            return Err(DeformError::NoRest);
        }
        let nodes = self.mesh.node_count();
        if new.len() != nodes {
            return Err(DeformError::Count {
                nodes,
                got: new.len(),
            });
        }
        if let Some(node) = new.iter().position(|p| !p.is_finite()) {
            return Err(DeformError::NotFinite { node });
        }
        let mut rep = DeformReport::default();
        let mut max2 = 0.0f32;
        for (p, r) in new.iter().zip(self.mesh.rest_positions()) {
            max2 = max2.max(p.distance_squared(*r));
        }
        rep.max_displacement = libm::sqrtf(max2);
        self.mesh.positions_mut().copy_from_slice(new);
        self.mesh.update_boundary();
        let built = self.rehash();
        rep.hash_entries = built.entries as u32;
        rep.hash_saturated = built.saturated;
        self.memo.clear();
        self.cursor.restart_tree();
        // A gathered candidate list holds the tets whose old boxes met its box: gather afresh.
        if let Some(z) = self.zone.as_mut() {
            z.forget();
        }
        let centre = self.contact.centre;
        let mut kept = Kept::new();
        for &(_, t) in &self.kept {
            if let Some((d2, vt)) = self
                .hier
                .visible_face_distance2(&self.mesh, t.key(), centre)
            {
                keep_face(&mut kept, d2, vt);
            }
        }
        rep.kept = kept.len() as u32;
        self.kept = kept;
        Ok(rep)
    }

    /// Each tet's box from its corners and the hash rebuilt from them; counts a saturation.
    ///
    /// # Bounded work
    /// O(T + buckets + hash entries).
    fn rehash(&mut self) -> Rebuilt {
        let mesh = &self.mesh;
        let box_of = |t: usize| Aabb::of(mesh.tet_positions(TetId::from_idx(t)));
        for (t, b) in self.boxes.iter_mut().enumerate().take(mesh.tet_count()) {
            *b = box_of(t);
        }
        let boxes = &*self.boxes;
        let built = self.hash.rebuild(mesh.tet_count(), |t| {
            Some(boxes.get(t).copied().unwrap_or_else(|| box_of(t)))
        });
        if built.saturated {
            self.sat.hash += 1;
        }
        self.zone_memo.forget();
        built
    }
}
