//! Tool sample spheres and how a tet lies relative to one.

use glam::Vec3;

/// An active sample sphere of the tool (a spherical burr is one sphere at its centre).
#[derive(Clone, Copy, PartialEq, Debug, Default)]
pub struct Sphere {
    /// Centre.
    pub center: Vec3,
    /// Radius of action.
    pub radius: f32,
}

/// Where a tet lies relative to a sphere.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum Class {
    /// No point of the tet is inside the sphere.
    Outside,
    /// The tet crosses the sphere's surface.
    Crossing,
    /// All four corners, hence the whole tet, are inside.
    Inside,
}

/// Closest point to `x` on triangle `(a, b, c)` (Voronoi regions of the vertices, edges and
/// face, after Ericson's *Real-Time Collision Detection* 5.1.5; degenerate triangles fall back
/// to an edge or a vertex without dividing by zero).
///
/// # Bounded work
/// Constant.
pub fn closest_on_triangle(x: Vec3, a: Vec3, b: Vec3, c: Vec3) -> Vec3 {
    let ab = b - a;
    let ac = c - a;
    let ap = x - a;
    let d1 = ab.dot(ap);
    let d2 = ac.dot(ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = x - b;
    let d3 = ab.dot(bp);
    let d4 = ac.dot(bp);
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let den = d1 - d3;
        return if den > 0.0 { a + ab * (d1 / den) } else { a };
    }
    let cp = x - c;
    let d5 = ab.dot(cp);
    let d6 = ac.dot(cp);
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let den = d2 - d6;
        return if den > 0.0 { a + ac * (d2 / den) } else { a };
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let den = (d4 - d3) + (d5 - d6);
        return if den > 0.0 {
            b + (c - b) * ((d4 - d3) / den)
        } else {
            b
        };
    }
    let sum = va + vb + vc;
    if sum > 0.0 {
        let v = vb / sum;
        let w = vc / sum;
        a + ab * v + ac * w
    } else {
        a
    }
}

/// Classifies tet `p` against sphere `s`: inside when all corners are within the radius,
/// outside when the closest point of the tet is farther than the radius, crossing otherwise.
///
/// # Bounded work
/// Constant: 4 distances, at most 4 closest-point-on-triangle queries.
pub fn classify(p: [Vec3; 4], s: &Sphere) -> Class {
    let r2 = s.radius * s.radius;
    let inside = p
        .iter()
        .filter(|q| q.distance_squared(s.center) <= r2)
        .count();
    if inside == 4 {
        return Class::Inside;
    }
    if inside > 0 {
        return Class::Crossing;
    }
    // No corner inside: the tet meets the ball iff the centre is inside the tet or a face
    // comes within the radius.
    if let Some(b) = crate::geom::barycentric(s.center, p) {
        if crate::geom::inside(b, 0.0) {
            return Class::Crossing;
        }
    }
    for [i, j, k] in crate::mesh::template::FACE_VERTS {
        let q = closest_on_triangle(s.center, p[i as usize], p[j as usize], p[k as usize]);
        if q.distance_squared(s.center) <= r2 {
            return Class::Crossing;
        }
    }
    Class::Outside
}
