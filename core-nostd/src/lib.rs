//! # tetradrill-core
//!
//! The `no_std`, allocation-free core of tetradrill: everything a 1 kHz haptic servo and a
//! drilling simulation need, computed from plain values and storage the caller hands in.
//!
//! The shortest program that drills a mesh: build one, make a [`servo::World`] over it, and
//! each tick run the simulation step ([`servo::World::simulate`]) and the servo's force
//! ([`servo::servo_force`]) at the tool's pose.
//!
//! ```
//! use tetradrill_core::builtin;
//! use tetradrill_core::prelude::*;
//!
//! // The drilling paper's cube [-0.5, 0.5]^3 in 12 tets, built over arrays.
//! let (mut pos, tets) = builtin::cube12();
//! let (mut nodes, mut normals) = ([Node::default(); 9], [Vec3::ZERO; 9]);
//! let (mut recs, mut scratch) = ([Tet::default(); 12], [FaceKey::default(); 48]);
//! let storage = MeshStorage { nodes: &mut nodes, normals: &mut normals, tets: &mut recs };
//! let mesh = Mesh::build(&mut pos, &tets, storage, &mut scratch, BuildOptions::default())?;
//!
//! // Its world (12 tets, 4,096 hierarchy nodes), carved from one block of memory.
//! let sizes = WorldSizes::new(12, 4096);
//! let mut lines = vec![Line::ZERO; sizes.lines().unwrap()];
//! let storage = WorldStorage::carve(&sizes, &mut Block::from_lines(&mut lines))?;
//! let mut world = World::new(mesh, storage)?;
//!
//! // A burr of radius 0.1 over the top face (z = 0.5): pressed in, then drilling.
//! let (params, drill) = (ForceParams::default(), DrillParams::default());
//! let mut tool = ToolState::default();
//! for (z, drill_on) in [(0.65, false), (0.58, false), (0.55, true), (0.5, true), (0.45, true)] {
//!     let centre = Vec3::new(0.1, 0.1, z);
//!     world.simulate(centre, 0.1, 0.1, drill_on, &drill);
//!     let force = servo_force(world.contact(), centre, 0.1, &mut tool, &params);
//!     if z == 0.58 {
//!         assert!(force.z > 0.0); // 0.02 into the face: pushed back out
//!     }
//! }
//! assert!(world.hierarchy().removed_volume() > 0.0);
//! # Ok::<(), tetradrill_core::Error>(())
//! ```
//!
//! With the `alloc` feature, the `owned` module holds the same storage on the heap
//! (`OwnedMesh::build`, then `WorldBuffers::new(sizes)` and `.world(mesh.view())`). Every
//! module below opens with an example of its own ([`servo`] and [`soft`] on their main types,
//! [`servo::World`] and [`soft::SoftBody`]); [`prelude`] re-exports what they use most.
//!
//! Layer map, lowest first (each module is one concept; lower layers never use higher ones: a
//! module uses only the modules listed before it):
//!
//! | module        | what                                                                 |
//! |---------------|----------------------------------------------------------------------|
//! | [`ids`]       | `u32` newtype ids with one `NONE` value                               |
//! | [`storage`]   | sizes turned into each structure's slices, from any memory           |
//! | [`geom`]      | small geometry kernels: volumes, barycentric coordinates, closest points |
//! | [`mesh`]      | compact tetrahedral mesh: templates, reverse indices, traversals     |
//! | [`blob`]      | a built mesh as a checksummed byte blob, read in place (flash)        |
//! | [`builtin`]   | the drilling paper's 12-tet cube and generated blocks, in caller slices |
//! | [`hash`]      | Teschner's spatial hash, counting-sort layout, caller storage        |
//! | [`collide`]   | vertices and sample points inside tets                               |
//! | [`depth`]     | consistent penetration depth (hashed and traced intersections)       |
//! | [`hierarchy`] | 1:8 subdivision trees with exact visible faces (Erase, Refine)       |
//! | [`drill`]     | budgeted erosion by tool sample spheres, materials per region         |
//! | [`force`]     | tool forces, damping, clamping, displayed pose, passivity (energy)   |
//! | [`servo`]     | the per-tick servo step that ties the above together                 |
//! | [`soft`]      | reference soft-body physics (XPBD, Green strain), fixed nodes, loads |
//! | [`script`]    | scripted tool paths shared bit for bit by the host and the firmware  |
//! | `owned`       | heap storage for each structure (feature `alloc`, off by default)      |
//! | [`prelude`]   | what programs use most, in one import                                |
//!
//! Rules that hold everywhere: no heap (the opt-in `owned` module only allocates a
//! structure's storage, once, for programs that have a heap), no `unsafe`, no panics on the
//! servo path; every structure borrows caller slices whose lengths are its capacities; every
//! public function documents its `# Bounded work` and what happens when a capacity is
//! reached.
#![no_std]
#![forbid(unsafe_code)]

#[cfg(feature = "alloc")]
extern crate alloc;

pub mod blob;
pub mod builtin;
pub mod collide;
pub mod depth;
pub mod drill;
mod error;
pub mod force;
pub mod geom;
pub mod hash;
pub mod hierarchy;
pub mod ids;
pub mod mesh;
pub mod script;
pub mod servo;
pub mod soft;
pub mod storage;

#[cfg(feature = "alloc")]
pub mod owned;
pub mod prelude;

pub use error::Error;
pub use glam::{Quat, Vec3};
pub use ids::{NodeId, TetId};
