//! What a program that touches and drills a mesh uses most, in one import:
//! `use tetradrill_core::prelude::*;`.
//!
//! - the world and its storage: [`World`], [`WorldSizes`], [`WorldStorage`], memory to carve
//!   it from ([`Block`], [`Line`]) and, with the `alloc` feature, the heap's
//!   `WorldBuffers`, `HierarchyBuffers` and `OwnedMesh` (`crate::owned`);
//! - the mesh and its build: [`Mesh`], [`MeshStorage`], [`BuildOptions`], [`FaceKey`],
//!   [`Node`], [`Tet`], and the ids [`NodeId`], [`TetId`];
//! - the servo: [`servo_force`], [`ForceParams`], [`ToolState`], [`DrillParams`];
//! - glam's [`Vec3`] and [`Quat`].
//!
//! ```
//! use tetradrill_core::builtin;
//! use tetradrill_core::prelude::*;
//!
//! // A world's storage for 12 tets, carved from memory the program holds ...
//! let sizes = WorldSizes::new(12, 4096);
//! let mut lines = vec![Line::ZERO; sizes.lines().unwrap()];
//! let storage = WorldStorage::carve(&sizes, &mut Block::from_lines(&mut lines))?;
//! assert_eq!(storage.tet_boxes.len(), 12);
//!
//! // ... or, with the `alloc` feature, a mesh and a world on the heap.
//! #[cfg(feature = "alloc")]
//! {
//!     let (pos, tets) = builtin::cube12();
//!     let mut mesh = OwnedMesh::build(pos.to_vec(), &tets, BuildOptions::default())?;
//!     let mut buffers = WorldBuffers::new(sizes)?;
//!     let world = buffers.world(mesh.view())?;
//!     assert_eq!(world.mesh().tet_count(), 12);
//! }
//! # Ok::<(), tetradrill_core::Error>(())
//! ```

pub use crate::drill::DrillParams;
pub use crate::force::{ForceParams, ToolState};
pub use crate::ids::{NodeId, TetId};
pub use crate::mesh::{BuildOptions, FaceKey, Mesh, MeshStorage, Node, Tet};
#[cfg(feature = "alloc")]
pub use crate::owned::{HierarchyBuffers, OwnedMesh, WorldBuffers};
pub use crate::servo::{servo_force, World, WorldSizes, WorldStorage};
pub use crate::storage::{Block, Line};
pub use glam::{Quat, Vec3};
