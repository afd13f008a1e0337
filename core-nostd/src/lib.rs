//! # tetradrill-core
//!
//! The `no_std`, allocation-free core of tetradrill: everything a 1 kHz haptic servo and a
//! drilling simulation need, computed from plain values and storage the caller hands in.
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
//! | [`owned`]     | heap storage for each structure (feature `alloc`, off by default)      |
//!
//! Rules that hold everywhere: no heap (the opt-in [`owned`] module only allocates a
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

pub use glam::{Quat, Vec3};
pub use ids::{NodeId, TetId};
