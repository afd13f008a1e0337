//! 1:8 subdivision hierarchies with exact visible faces (Turini et al. 2006, section 2).
//!
//! Every coarse tet is the root of a tree of Bey red refinements (diagonal `x02-x13`, which
//! [`crate::mesh::Mesh::build`] makes the shortest one). Only the part from each root to its
//! frontier is instantiated: roots live in one slot per coarse tet, children in blocks of 8
//! contiguous nodes of a caller arena ([`HNode`], 8 bytes: 24-bit child block, 4 visible-face
//! bits, erased, inverted, surface below, hollow, plus a `u32` v_list slot; all zero for a
//! fresh leaf). The arena hands out fresh blocks first; once they are used up, a refinement
//! takes back a block of 8 erased leaves (their parent becomes an erased leaf: nothing visible
//! changes) from a list threaded through those leaves' spare slot words, and only when there
//! is none either is it refused and counted (see [`Hierarchy`] and `reclaim`). Material is
//! never coarsened: only wholly erased subtrees give their nodes back.
//!
//! - `table`: the tree table (const, one level) and digit walks for deeper levels.
//! - `visit`: same-level adjacency through the digits and the NTree visit.
//! - [`Hierarchy::erase`], [`Hierarchy::refine`]: Turini et al. 2006, section 2.1, across coarse
//!   faces through the mesh's reverse indices.
//! - [`Hierarchy::for_each_visible`], [`Hierarchy::for_each_visible_in`]: the drilled surface.
//! - `changes`: the coarse tets whose visible faces Erase and Refine changed, in a ring of
//!   caller storage that readers read at their own pace ([`Hierarchy::change_at`]).
//! - `export`: the drilled surface kept in a renderer's buffers of stable triangle slots,
//!   only the changed tets' slots written, a bounded amount of work a call
//!   ([`SurfaceExport`]); `export_keys`: a face's place in its tree's listing and its
//!   corners' lattice keys.
//! - `smooth`: the export's faces sharing vertices by their exact lattice keys, with smooth
//!   per-corner normals within a crease angle, kept up to date incrementally
//!   ([`SmoothNormals`], [`SurfaceExport::with_smooth`]).
//! - [`Hierarchy::nearest_visible`]: the closest visible triangle to a point (branch and
//!   bound over the nodes whose *surface* bit says a v_list leaf lies below), for the contact;
//!   [`SphereMemo`] remembers the nodes' bounding spheres across searches.
//! - connected pieces of the remaining material: [`Hierarchy::components`]; the small
//!   detached ones (debris) erased: [`Hierarchy::remove_debris`] over the whole object, or
//!   [`Crumbs`] in bounded work after each erasure (the drill's).
//! - giving back the blocks of wholly erased subtrees: `reclaim` ([`Hierarchy::arena_live`],
//!   [`Hierarchy::arena_reclaimable`], [`Hierarchy::reclaimed`]).
//! - invariants: [`Hierarchy::validate`].
//!
//! Memory: 8 bytes per node in the arena plus 12 bytes per v_list entry (the v_list is sized
//! for every possible leaf: `tets + 7/8 arena`), about 18.5 bytes per arena node in all, 8 +
//! 12 bytes per coarse tet, and 4 bytes per change log entry ([`DEFAULT_CHANGES`]).
//!
//! ```
//! use tetradrill_core::builtin;
//! use tetradrill_core::hierarchy::{Hierarchy, HierarchySizes, HierarchyStorage};
//! use tetradrill_core::prelude::*;
//!
//! let (mut pos, tets) = builtin::cube12();
//! let (mut nodes, mut normals) = ([Node::default(); 9], [Vec3::ZERO; 9]);
//! let (mut recs, mut scratch) = ([Tet::default(); 12], [FaceKey::default(); 48]);
//! let storage = MeshStorage { nodes: &mut nodes, normals: &mut normals, tets: &mut recs };
//! let mesh = Mesh::build(&mut pos, &tets, storage, &mut scratch, BuildOptions::default())?;
//! let sizes = HierarchySizes::new(12, 64);
//! let mut lines = vec![Line::ZERO; sizes.lines().unwrap()];
//! let storage = HierarchyStorage::carve(&sizes, &mut Block::from_lines(&mut lines))?;
//! let mut h = Hierarchy::new(&mesh, storage)?;
//! assert_eq!(h.stats().visible_faces, 12);
//!
//! // Refine tet 0's root (tree index 0) into its 8 children (indices 1 to 8): its face on
//! // the cube's surface becomes four.
//! let t = TetId(0);
//! h.refine(&mesh, t, 0)?;
//! assert_eq!(h.stats().visible_faces, 15);
//!
//! // Erase the child at the cube's centre (child c < 4 is the corner child at vertex c):
//! // the 3 faces of the tets around it and 1 of its siblings' appear, 1/96 of the cube goes.
//! let centre = mesh.local_of(t, NodeId(8)).unwrap() as u32;
//! let erased = h.erase(&mesh, t, 1 + centre)?;
//! assert_eq!(h.stats().visible_faces, 19);
//! assert!((erased.removed - 1.0 / 96.0).abs() < 1e-9);
//! h.validate(&mesh)?;
//! # Ok::<(), tetradrill_core::Error>(())
//! ```

mod changes;
mod components;
mod crumbs;
mod debris;
mod export;
mod export_keys;
mod geometry;
mod memo;
mod nearest;
mod node;
mod ops;
mod reclaim;
mod smooth;
mod smooth_storage;
mod store;
mod surface;
mod table;
mod validate;
mod visit;

pub use changes::Change;
pub use crumbs::{CrumbStats, CrumbWork, Crumbs, CRUMB_SEEDS};
pub use debris::{DebrisReport, DEBRIS_LEAVES};
pub use export::{
    ExportReport, SlotRange, SlotRecord, SurfaceBuffers, SurfaceError, SurfaceExport, SurfaceSizes,
    SurfaceStorage, TetRecord,
};
#[cfg(test)]
pub(crate) use geometry::node_positions;
pub(crate) use geometry::{
    child_of_refinement, child_of_ten, refinement_points, refinement_points_masked, RootFrame,
    ALL_POINTS,
};
pub(crate) use geometry::{depth_limit, node_volume, unit_depth};
pub use memo::{SphereMemo, SphereSlot};
pub(crate) use nearest::keep_face;
pub use nearest::{FaceRef, Kept, Nearest, NearestCursor, NearestQuery, KEEP};
pub use node::{HNode, VEntry, NODE_BYTES};
pub use ops::OpReport;
pub use smooth::{
    SmoothError, SmoothNormals, SmoothSizes, SmoothSlot, SmoothStats, SmoothStorage, SmoothVertex,
    VertexKey,
};
pub use store::{
    Hierarchy, HierarchyError, HierarchySizes, HierarchyStats, HierarchyStorage, DEFAULT_CHANGES,
};
pub(crate) use surface::{bounding_sphere, SurfaceVisit};
pub use surface::{Leaf, VisibleTri};
pub(crate) use table::Path;
pub use table::MAX_DEPTH;

#[cfg(test)]
mod export_tests;
#[cfg(test)]
mod smooth_tests;
#[cfg(test)]
pub(crate) mod test_support;
#[cfg(test)]
mod tests;
