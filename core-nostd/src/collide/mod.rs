//! Collision detection with the spatial hash (Praktikum report, section 3; Teschner et al. 2003):
//! which points (the nodes of another mesh, tool sample points, or the mesh's own nodes) lie inside
//! which tets.
//!
//! - [`points_in_tets`]: the tets of a [`Body`] are hashed once ([`hash_tets`]); each point
//!   looks in its one cell. Used for a static object and points that move every tick.
//! - [`tets_over_points`]: the points are hashed ([`crate::hash::SpatialHash::rebuild_points`],
//!   again each step if they move) and every tet walks the cells of its bounding box
//!   (Teschner's order). Used for the nodes of a static object against a moving tool's tets.
//!
//! - [`ZoneGather`]: the coarse tets near a moving tool, gathered through the tet hash in
//!   parts of bounded work over several steps around a box wider than the tool's zone, and
//!   kept while the zone stays inside it (the simulation step's candidates on a fine mesh).
//!
//! The first two report each point at most once, with the smallest tet id that contains it,
//! sorted by node id, so the two directions and a brute-force oracle give the same sets. Their
//! `_coherent` forms take the previous call's result, still in the output, and keep those
//! points first when the output cannot hold every hit (temporal coherence): with a full
//! output a point leaves the list only when it leaves the tets. Candidates are
//! checked to be in the queried cell (by the hash) and then by barycentric coordinates;
//! degenerate tets are skipped and counted; a point that is a node of the tet itself is
//! excluded by index when `own` is set (self-collision).
//!
//! ```
//! use tetradrill_core::builtin;
//! use tetradrill_core::collide::{hash_tets, points_in_tets, Body, Collision};
//! use tetradrill_core::hash::{HashEntry, SpatialHash};
//! use tetradrill_core::prelude::*;
//!
//! // The object: the 12-tet cube [-0.5, 0.5]^3, its tets hashed in cells of edge 0.5.
//! let (mut pos, tets) = builtin::cube12();
//! let (mut nodes, mut normals) = ([Node::default(); 9], [Vec3::ZERO; 9]);
//! let (mut recs, mut scratch) = ([Tet::default(); 12], [FaceKey::default(); 48]);
//! let storage = MeshStorage { nodes: &mut nodes, normals: &mut normals, tets: &mut recs };
//! let mesh = Mesh::build(&mut pos, &tets, storage, &mut scratch, BuildOptions::default())?;
//! let object = Body::fixed(&mesh);
//! let (mut starts, mut entries) = ([0u32; 32], [HashEntry::EMPTY; 256]);
//! let mut hashed = SpatialHash::new(&mut starts, &mut entries, 0.5).expect("valid sizes");
//! assert!(!hash_tets(&mut hashed, &object).saturated);
//!
//! // The nodes of a half-size cube centred at x = 0.4: its four corners at x = 0.15 and its
//! // centre are inside the object, its corners at x = 0.65 are not.
//! let other = builtin::cube12().0.map(|p| p * 0.5 + Vec3::new(0.4, 0.0, 0.0));
//! let mut out = [Collision::default(); 9];
//! let found = points_in_tets(&hashed, &object, &other, false, &mut out);
//! let inside: Vec<u32> = out[..found.count].iter().map(|c| c.node.0).collect();
//! assert_eq!(inside, [0, 2, 4, 6, 8]);
//! # Ok::<(), tetradrill_core::Error>(())
//! ```

mod body;
mod entry;
mod occupancy;
#[cfg(test)]
mod occupancy_tests;
mod points;
mod rigid;
mod rigid_locate;
mod rigid_near;
mod rigid_search;
#[cfg(test)]
mod rigid_tests;
mod teschner;
#[cfg(test)]
pub(crate) mod test_support;
#[cfg(test)]
mod tests;
#[cfg(test)]
mod walk_tests;
mod zone;

pub use body::Body;
pub use entry::GridEntry;
pub use occupancy::{ListedNode, Occupancy, OccupancyError, OccupancyStorage};
pub(crate) use points::walk_to_holder;
pub use points::{
    hash_tets, points_in_tets, points_in_tets_occupied, points_in_tets_walked, walks_exact,
    WalkStarts,
};
pub use rigid::{RigidError, RigidTets, RigidTetsStorage};
pub use rigid_near::{NearClusters, MAX_NEAR_CLUSTERS};
pub use rigid_search::rigid_tets_over_points_coherent;
pub use teschner::{tets_over_points, MAX_CELLS_PER_TET};
pub use zone::{ZoneGather, ZONE_MARGIN_RADII};

use crate::ids::{NodeId, TetId};

/// The `_coherent` searches' first pass: the previous call's entries `out[..kept]` whose
/// point `locate` still finds in a tet (`NONE`: not found, or not to be looked up), compacted
/// in place with their new tets. Entries out of increasing node order or naming a point
/// beyond `points` are dropped, so any contents give a valid result. Returns how many stay.
///
/// # Bounded work
/// At most `kept` calls of `locate`.
fn keep_previous<F: FnMut(NodeId, glam::Vec3, TetId) -> TetId>(
    out: &mut [Collision],
    kept: usize,
    points: &[glam::Vec3],
    mut locate: F,
) -> usize {
    let mut m = 0usize;
    let mut last: Option<NodeId> = None;
    for i in 0..kept.min(out.len()) {
        let node = out[i].node;
        if last.is_some_and(|l| node <= l) {
            continue;
        }
        let Some(&p) = points.get(node.idx()) else {
            continue;
        };
        last = Some(node);
        let tet = locate(node, p, out[i].tet);
        if tet.is_some() {
            out[m] = Collision { node, tet };
            m += 1;
        }
    }
    m
}

/// A point `node` inside tet `tet` of the other body.
#[derive(
    Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Debug, Default, bytemuck::Pod, bytemuck::Zeroable,
)]
#[repr(C)]
pub struct Collision {
    /// The point (node id in its own mesh, or sample-point index).
    pub node: NodeId,
    /// The tet that contains it (in the other body).
    pub tet: TetId,
}

/// What one detection pass found.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default)]
pub struct CollideReport {
    /// Collisions written to the output.
    pub count: usize,
    /// `true` when the output filled up: what is written is valid but incomplete (for
    /// [`points_in_tets`] the points with the smallest indices are kept; the `_coherent`
    /// forms keep the previous call's points first).
    pub saturated: bool,
    /// Candidate tets skipped because they are degenerate (no barycentric coordinates).
    pub degenerate: u32,
    /// Point-tet candidates examined (a cost measure): the hash's candidates tested, plus the
    /// tets of [`points_in_tets_walked`]'s walks.
    pub candidates: u32,
    /// Tets skipped because their box covered too many cells
    /// ([`teschner::MAX_CELLS_PER_TET`]).
    pub clipped: u32,
}

/// Barycentric tolerance: a point counts as inside when every coordinate is `>= -INSIDE_EPS`.
/// Zero: points exactly on a face are inside; nothing further out.
pub(crate) const INSIDE_EPS: f32 = 0.0;

/// `geom::inside(geom::barycentric(x, p)?, eps)` with the same arithmetic, stopping at the
/// first coordinate below `-eps`: `None` for a degenerate tet, else whether `x` is inside.
/// The coordinates are the same bits as [`crate::geom::barycentric`]'s, so the answer is too.
///
/// # Bounded work
/// Constant: at most four 3x3 determinants.
#[inline]
pub(crate) fn inside_tet(x: glam::Vec3, p: [glam::Vec3; 4], eps: f32) -> Option<bool> {
    use crate::geom::det6;
    let d = det6(p[0], p[1], p[2], p[3]);
    let big_enough = libm::fabsf(d) > f32::MIN_POSITIVE;
    if !big_enough {
        return None;
    }
    // `b >= -eps` is false for NaN, which counts as outside, as in `geom::inside`.
    let b1 = det6(p[0], x, p[2], p[3]) / d;
    let ok = b1 >= -eps;
    if !ok {
        return Some(false);
    }
    let b2 = det6(p[0], p[1], x, p[3]) / d;
    let ok = b2 >= -eps;
    if !ok {
        return Some(false);
    }
    let b3 = det6(p[0], p[1], p[2], x) / d;
    let ok = b3 >= -eps;
    if !ok {
        return Some(false);
    }
    Some(1.0 - b1 - b2 - b3 >= -eps)
}

/// A candidate tet with corners `corners` tested for point `p`: counted in `r.candidates`,
/// degenerate ones in `r.degenerate` (they hold nothing); `true` when it holds `p`
/// ([`inside_tet`] with [`INSIDE_EPS`]).
#[inline]
fn candidate_holds(p: glam::Vec3, corners: [glam::Vec3; 4], r: &mut CollideReport) -> bool {
    r.candidates = r.candidates.wrapping_add(1);
    match inside_tet(p, corners, INSIDE_EPS) {
        None => {
            r.degenerate = r.degenerate.wrapping_add(1);
            false
        }
        Some(inside) => inside,
    }
}
