//! Consistent penetration depth (Heidelberger et al. 2004; Praktikum report, section 4).
//!
//! Input: collisions `(node of body A, tet of body B)`. An edge of A that joins a colliding
//! and a non-colliding node is a *border edge*; its colliding end is a *border point* `p`.
//! Each border edge is followed from `p` to where it leaves B's surface, `x_i`, with the
//! surface normal `n_i` interpolated from B's vertex normals at `x_i`:
//!
//! `w_i = 1/|x_i - p|^2`, `d(p) = sum w_i (x_i - p).n_i / sum w_i`,
//! `r(p) = normalize(sum w_i n_i)`.
//!
//! The remaining colliding nodes get their depth breadth-first, layer by layer, from the
//! neighbours of lower layers: `mu_j = 1/|p_j - p|^2`,
//! `d(p) = sum mu_j ((p_j - p).r_j + d_j) / sum mu_j`, `r(p) = normalize(sum mu_j r_j)`.
//! A node's value depends only on lower layers, so it does not depend on the queue order.
//! The caller's queue holds the first nodes of the breadth-first order; the rest are chained
//! through their scratch slots, so a short queue changes no depth (it is only counted).
//!
//! A collision list that filled up (`Listed::Partial`) may leave out nodes inside B. An edge
//! from a listed node to such a node ends inside B; its line is then followed on to where it
//! leaves B, so the listed node keeps the depth its edges give it while its neighbours enter
//! B unlisted (at the moment a neighbour crosses the surface both rules give the same
//! crossing: the depth stays continuous).
//!
//! Two ways to find `x_i`, selected by [`Method`]:
//! - [`Method::Traced`] (Praktikum report, section 4): walk the line from `p` through the tet that
//!   holds `p`, face by face through neighbours, until it leaves through a boundary face. Work
//!   proportional to the tets crossed.
//! - [`Method::Hashed`] (Heidelberger 2004): B's boundary faces are hashed
//!   ([`hash_boundary_faces`]); the cells of the border edge's box give candidate faces; the
//!   outward crossing nearest to `p` along the edge wins (ties: smaller `(tet, face)`).
//!
//! Both use one face test (`surface`): the line's orientation against each face edge,
//! computed once per edge in a canonical node order, so a line crosses exactly one of the two
//! faces beside an edge in both methods, and the hit point and normal are computed by the same
//! function from the same face. They therefore return bit-identical depths.
//!
//! A colliding region whose nodes have no border edge (or whose border edges found no surface)
//! gets no depth: its nodes are counted in [`DepthReport::unreached`] and left out of the
//! output.
//!
//! ```
//! use tetradrill_core::builtin;
//! use tetradrill_core::collide::{Body, Collision};
//! use tetradrill_core::depth::{penetration_depth, DepthScratch, Method, NodeGraph, NodeSlot};
//! use tetradrill_core::depth::Penetration;
//! use tetradrill_core::geom::{barycentric, inside};
//! use tetradrill_core::prelude::*;
//!
//! // B: the cube [-0.5, 0.5]^3 as a 2 x 2 x 2 block (a node at the middle of each face).
//! let (mut pos, mut tets) = ([Vec3::ZERO; 27], [[0u32; 4]; 48]);
//! builtin::block(2, 0.5, Vec3::splat(-0.5), &mut pos, &mut tets).unwrap();
//! let (mut nodes, mut normals) = ([Node::default(); 27], [Vec3::ZERO; 27]);
//! let (mut recs, mut scratch) = ([Tet::default(); 48], [FaceKey::default(); 192]);
//! let storage = MeshStorage { nodes: &mut nodes, normals: &mut normals, tets: &mut recs };
//! let b = Mesh::build(&mut pos, &tets, storage, &mut scratch, BuildOptions::default())?;
//!
//! // A: a 0.2 cube (12 tets) whose four bottom corners are 0.05 below B's top face.
//! let (a_pos, a_tets) = builtin::cube12();
//! let mut a_pos = a_pos.map(|p| p * 0.2 + Vec3::new(0.0, 0.0, 0.55));
//! let (mut nodes, mut normals) = ([Node::default(); 9], [Vec3::ZERO; 9]);
//! let (mut recs, mut scratch) = ([Tet::default(); 12], [FaceKey::default(); 48]);
//! let storage = MeshStorage { nodes: &mut nodes, normals: &mut normals, tets: &mut recs };
//! let a = Mesh::build(&mut a_pos, &a_tets, storage, &mut scratch, BuildOptions::default())?;
//! let (mut offsets, mut adjacency) = ([0u32; 10], [NodeId::NONE; 64]);
//! let graph = NodeGraph::build(&a, &mut offsets, &mut adjacency)?;
//!
//! // A's nodes in B's tets (by brute force here; `collide` finds them with a hash).
//! let mut hits = Vec::new();
//! for (n, &p) in a.positions().iter().enumerate() {
//!     let holds = |t: &TetId| inside(barycentric(p, b.tet_positions(*t)).unwrap(), 0.0);
//!     if let Some(tet) = (0..48).map(TetId).find(holds) {
//!         hits.push(Collision { node: NodeId(n as u32), tet });
//!     }
//! }
//!
//! // Each corner's border edges leave B through its top face: depth 0.05 up, within the
//! // tilt of the vertex normals interpolated over the face.
//! let (mut slots, mut queue) = ([NodeSlot::default(); 9], [NodeId::NONE; 9]);
//! let mut scratch = DepthScratch::new(&mut slots, &mut queue);
//! let (method, mut out) = (Method::Traced { max_steps: 64 }, [Penetration::default(); 9]);
//! let report = penetration_depth(
//!     a.positions(), &graph, &Body::fixed(&b), &hits, &method, &mut scratch, &mut out,
//! );
//! assert_eq!((hits.len(), report.written), (4, 4));
//! for p in &out[..4] {
//!     assert!((p.depth - 0.05).abs() < 0.005 && p.dir.z > 0.98);
//! }
//! # Ok::<(), tetradrill_core::Error>(())
//! ```

mod crossing;
mod graph;
mod hashed;
mod propagate;
mod surface;
mod traced;

pub use crossing::Crossing;
pub use graph::{graph_sizes, GraphError, NodeGraph};
pub use hashed::hash_boundary_faces;
pub use propagate::{penetration_depth, DepthReport, DepthScratch, NodeSlot, Penetration};
pub(crate) use propagate::{penetration_depth_of, Listed};

use glam::Affine3A;

use crate::hash::SpatialHash;

/// How border edges find B's surface.
#[derive(Clone, Copy, Debug)]
pub enum Method<'h> {
    /// Walk through B's tets from the tet holding the border point (Praktikum report, section 4).
    Traced {
        /// Tets a walk may cross before the edge is given up (counted as missed).
        max_steps: u32,
    },
    /// Look up B's boundary faces in a hash (Heidelberger 2004).
    Hashed {
        /// B's boundary faces, item `tet * 4 + face` ([`hash_boundary_faces`]).
        faces: &'h SpatialHash<'h>,
        /// Maps world positions into the frame the faces were hashed in (identity for a
        /// static B; the inverse pose for a moving tool hashed at rest).
        world_to_hash: Affine3A,
        /// Cells one edge's box may cover before the edge is given up (counted as missed).
        max_cells: u32,
    },
}

#[cfg(test)]
mod tests;
