//! Candidate coarse tets near the tool without a spatial hash (tests, small meshes).

use super::sphere::Sphere;
use crate::ids::TetId;
use crate::mesh::Mesh;

/// Writes into `out` every tet whose bounding box overlaps the bounding box of some sphere,
/// in ascending order, and returns how many were written (stops when `out` is full).
///
/// # Bounded work
/// O(T * S) for T tets and S spheres; constant without spheres.
pub fn candidates_brute_force(mesh: &Mesh<'_>, spheres: &[Sphere], out: &mut [TetId]) -> usize {
    if spheres.is_empty() {
        return 0; // no box overlaps nothing (and a step with nothing queued costs no walk)
    }
    let mut n = 0;
    for t in 0..mesh.tet_count() {
        let id = TetId::from_idx(t);
        let p = mesh.tet_positions(id);
        let lo = p[0].min(p[1]).min(p[2]).min(p[3]);
        let hi = p[0].max(p[1]).max(p[2]).max(p[3]);
        let hit = spheres.iter().any(|s| {
            let r = glam::Vec3::splat(s.radius);
            (s.center - r).cmple(hi).all() && (s.center + r).cmpge(lo).all()
        });
        if hit {
            let Some(slot) = out.get_mut(n) else { return n };
            *slot = id;
            n += 1;
        }
    }
    n
}
