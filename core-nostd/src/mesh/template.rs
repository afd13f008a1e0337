//! The tetrahedron template (Praktikum report, section 2.1): fixed numberings of a tet's vertices,
//! faces and edges, so that an entity is named by `(tet, small number)` at no storage cost.
//!
//! Conventions, chosen once for the whole crate:
//! - face `i` is the face opposite vertex `i`;
//! - the three vertices of a face are listed clockwise seen from outside the tet (for a
//!   positively oriented tet, `(b - a) x (c - a)` of a face listing points into the tet);
//! - edges are `E0 = (0,1) E1 = (0,2) E2 = (0,3) E3 = (1,2) E4 = (1,3) E5 = (2,3)`.
//!
//! A tet is positively oriented when `det[x1-x0, x2-x0, x3-x0] > 0`; the mesh builder swaps two
//! nodes of every negative tet so that the clockwise rule holds everywhere.
//!
//! ```
//! use tetradrill_core::mesh::template::{EDGE_VERTS, FACE_VERTS};
//! use tetradrill_core::Vec3;
//!
//! let x = [Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z]; // positively oriented
//! for (i, &[a, b, c]) in FACE_VERTS.iter().enumerate() {
//!     assert!(![a, b, c].contains(&(i as u8))); // face i is opposite vertex i
//!     let [a, b, c] = [a, b, c].map(|k| x[k as usize]);
//!     // Clockwise from outside: the listing's normal points into the tet, towards vertex i.
//!     assert!((b - a).cross(c - a).dot(x[i] - a) > 0.0);
//! }
//! assert_eq!(EDGE_VERTS[5], [2, 3]);
//! ```

/// Face -> its three vertices, clockwise seen from outside (face `i` is opposite vertex `i`).
pub const FACE_VERTS: [[u8; 3]; 4] = [[1, 3, 2], [0, 2, 3], [0, 3, 1], [0, 1, 2]];

/// The marker in [`FACE_VERTEX_NR`] for "this vertex is not on this face".
pub const NOT_ON_FACE: u8 = 3;

/// `faceVertexNr`: (face, element vertex) -> position of the vertex in the face listing
/// (0..=2), or [`NOT_ON_FACE`] for the vertex opposite the face.
pub const FACE_VERTEX_NR: [[u8; 4]; 4] = [[3, 0, 2, 1], [0, 3, 1, 2], [0, 2, 3, 1], [0, 1, 2, 3]];

/// `elemVertexNr`: (face, position in the face listing) -> element vertex. Same as
/// [`FACE_VERTS`]; named for the Praktikum report's Figure 2.
pub const ELEM_VERTEX_NR: [[u8; 3]; 4] = FACE_VERTS;

/// Edge -> its two vertices.
pub const EDGE_VERTS: [[u8; 2]; 6] = [[0, 1], [0, 2], [0, 3], [1, 2], [1, 3], [2, 3]];

/// Edge -> the two faces that contain it (the faces opposite the two vertices not on it).
pub const EDGE_FACES: [[u8; 2]; 6] = [[2, 3], [1, 3], [1, 2], [0, 3], [0, 2], [0, 1]];

/// The marker in [`EDGE_OF_VERTS`] for "no edge" (a vertex paired with itself).
pub const NO_EDGE: u8 = 6;

/// (vertex, vertex) -> the edge joining them, or [`NO_EDGE`] on the diagonal.
pub const EDGE_OF_VERTS: [[u8; 4]; 4] = [[6, 0, 1, 2], [0, 6, 3, 4], [1, 3, 6, 5], [2, 4, 5, 6]];

/// Vertex -> the three faces that contain it (every face but the opposite one).
pub const VERTEX_FACES: [[u8; 3]; 4] = [[1, 2, 3], [0, 2, 3], [0, 1, 3], [0, 1, 2]];

/// Vertex -> the three edges that contain it.
pub const VERTEX_EDGES: [[u8; 3]; 4] = [[0, 1, 2], [0, 3, 4], [1, 3, 5], [2, 4, 5]];

/// Face -> its three edges.
pub const FACE_EDGES: [[u8; 3]; 4] = [[3, 4, 5], [1, 2, 5], [0, 2, 4], [0, 1, 3]];
