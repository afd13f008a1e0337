//! Tool sample spheres and how a tet lies relative to one.

use glam::Vec3;

use crate::geom::closest_point_on_triangle;

/// An active sample sphere of the tool (a spherical burr is one sphere at its centre).
#[derive(Clone, Copy, PartialEq, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C)]
pub struct Sphere {
    /// Centre.
    pub center: Vec3,
    /// Radius of action.
    pub radius: f32,
}

/// Where a tet lies relative to a sphere.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub(crate) enum Class {
    /// No point of the tet is inside the sphere.
    Outside,
    /// The tet crosses the sphere's surface.
    Crossing,
    /// All four corners, hence the whole tet, are inside.
    Inside,
}

/// Classifies tet `p` against sphere `s`: inside when all corners are within the radius,
/// outside when the closest point of the tet is farther than the radius (at once when its
/// bounding box is), crossing otherwise.
///
/// # Bounded work
/// Constant: 4 distances, a box distance, at most 4 closest-point-on-triangle queries.
#[cfg(test)]
pub(crate) fn classify(p: [Vec3; 4], s: &Sphere) -> Class {
    classify_costed(p, s).0
}

/// [`classify`], and whether it needed the exact test (no corner inside, the bounding box
/// within the radius: a barycentric test and up to four closest-point queries, several times
/// the cost of the corner and box tests), so a budget can charge it.
pub(crate) fn classify_costed(p: [Vec3; 4], s: &Sphere) -> (Class, bool) {
    let r2 = s.radius * s.radius;
    let inside = p
        .iter()
        .filter(|q| q.distance_squared(s.center) <= r2)
        .count();
    if inside == 4 {
        return (Class::Inside, false);
    }
    if inside > 0 {
        return (Class::Crossing, false);
    }
    // No corner inside. Quick reject: the tet's bounding box farther than the radius (its
    // squared distance from the centre, axis by axis) means no point of the tet is inside.
    let (lo, hi) = (
        p[0].min(p[1]).min(p[2]).min(p[3]),
        p[0].max(p[1]).max(p[2]).max(p[3]),
    );
    let gap = (lo - s.center).max(s.center - hi).max(Vec3::ZERO);
    if gap.length_squared() > r2 {
        return (Class::Outside, false);
    }
    // No corner inside: the tet meets the ball iff the centre is inside the tet or a face
    // comes within the radius.
    if let Some(b) = crate::geom::barycentric(s.center, p) {
        if crate::geom::inside(b, 0.0) {
            return (Class::Crossing, true);
        }
    }
    for [i, j, k] in crate::mesh::template::FACE_VERTS {
        let q = closest_point_on_triangle(s.center, [p[i as usize], p[j as usize], p[k as usize]]);
        if q.distance_squared(s.center) <= r2 {
            return (Class::Crossing, true);
        }
    }
    (Class::Outside, true)
}
