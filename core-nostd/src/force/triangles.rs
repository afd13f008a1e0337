//! Sphere tools and active sample points: penetration = radius - signed distance to the
//! surface, from the triangles near the point.

use glam::Vec3;

use crate::collide::Body;
use crate::hash::{Aabb, SpatialHash};
use crate::ids::TetId;
use crate::mesh::template::FACE_VERTS;

pub use crate::geom::closest_point_on_triangle;

/// Contact of a sphere with a surface.
#[derive(Clone, Copy, PartialEq, Debug, Default)]
pub struct SphereContact {
    /// `radius - signed distance` from the centre to the surface (`> 0`: in contact; the
    /// distance is negative when the centre is inside).
    pub depth: f32,
    /// Unit direction pushing the sphere out of the object (zero when no triangle was seen).
    pub normal: Vec3,
    /// The closest surface point.
    pub point: Vec3,
    /// Triangles examined.
    pub triangles: u32,
}

impl SphereContact {
    /// `true` when the sphere penetrates.
    #[inline]
    pub fn touching(&self) -> bool {
        self.depth > 0.0 && self.normal != Vec3::ZERO
    }
}

/// Penetration of the sphere `(centre, radius)` into the surface made of `tris` (outward
/// counter-clockwise triangles): the closest triangle decides (ties: the first); the centre
/// counts as inside when it lies behind that triangle's plane. Triangles farther than
/// `radius` only matter when no nearer one exists.
///
/// # Bounded work
/// One constant-time closest-point test per triangle yielded.
pub fn sphere_contact<I>(centre: Vec3, radius: f32, tris: I) -> SphereContact
where
    I: IntoIterator<Item = [Vec3; 3]>,
{
    let mut best_d2 = f32::INFINITY;
    let mut best = SphereContact::default();
    let mut best_n = Vec3::ZERO;
    for t in tris {
        best.triangles = best.triangles.wrapping_add(1);
        let x = closest_point_on_triangle(centre, t);
        let d2 = (centre - x).length_squared();
        if d2 < best_d2 {
            best_d2 = d2;
            best.point = x;
            best_n = (t[1] - t[0]).cross(t[2] - t[0]).normalize_or_zero();
        }
    }
    if best.triangles == 0 || !best_d2.is_finite() {
        return SphereContact {
            triangles: best.triangles,
            ..SphereContact::default()
        };
    }
    let v = centre - best.point;
    let dist = libm::sqrtf(best_d2);
    let inside = v.dot(best_n) < 0.0;
    let (signed, normal) = if dist > 0.0 {
        if inside {
            (-dist, -v / dist)
        } else {
            (dist, v / dist)
        }
    } else {
        (0.0, best_n)
    };
    SphereContact {
        depth: radius - signed,
        normal,
        ..best
    }
}

/// Boundary face `f` of `t` as an outward counter-clockwise triangle at `body`'s positions.
#[inline]
pub(crate) fn boundary_triangle(body: &Body<'_, '_>, t: TetId, f: u8) -> Option<[Vec3; 3]> {
    let n = body.tet_nodes(t)?;
    let lv = FACE_VERTS.get(f as usize)?;
    // Mesh listings are clockwise from outside: reverse them.
    Some([
        body.pos(n[lv[0] as usize])?,
        body.pos(n[lv[2] as usize])?,
        body.pos(n[lv[1] as usize])?,
    ])
}

/// [`sphere_contact`] against the boundary faces of `body` found in `faces` (items
/// `tet * 4 + face`, [`crate::depth::hash_boundary_faces`]) in the cells the sphere's box
/// covers. Returns a contact with `triangles == 0` when no face is near (or the box covers
/// more than `max_cells` cells). Each face is tested once however many cells it shares with
/// the box ([`SpatialHash::query_box_once`]).
///
/// # Bounded work
/// O(max_cells + entries met), one closest-point test per face.
pub fn mesh_sphere_contact(
    faces: &SpatialHash<'_>,
    body: &Body<'_, '_>,
    centre: Vec3,
    radius: f32,
    max_cells: u32,
) -> SphereContact {
    let b = Aabb::point(centre).grown(radius);
    let mut best_d2 = f32::INFINITY;
    let mut best = SphereContact::default();
    let mut best_item = u32::MAX;
    faces.query_box_once(&b, max_cells, |item| {
        let Some(t) = boundary_triangle(body, TetId(item / 4), (item % 4) as u8) else {
            return;
        };
        best.triangles = best.triangles.wrapping_add(1);
        let x = closest_point_on_triangle(centre, t);
        let d2 = (centre - x).length_squared();
        // Ties to the smaller face id, so the result never depends on bucket order.
        if d2 < best_d2 || (d2 == best_d2 && item < best_item) {
            best_d2 = d2;
            best_item = item;
            best.point = x;
        }
    });
    if best.triangles == 0 {
        return best;
    }
    // Reuse the decision of `sphere_contact` on the one winning triangle.
    let Some(t) = boundary_triangle(body, TetId(best_item / 4), (best_item % 4) as u8) else {
        return SphereContact::default();
    };
    SphereContact {
        triangles: best.triangles,
        ..sphere_contact(centre, radius, [t])
    }
}
