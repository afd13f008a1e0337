//! The one face test both depth methods use: does the line `p -> q` leave a body through a
//! given boundary face, where, and with which interpolated normal.
//!
//! For a face listed `(a, b, c)` clockwise from outside, the edge values
//! `e_ab = det6(p, q, a, b)` (and so on) are the line's orientation against each edge; they sum
//! to `(q - p) . N` with `N = (b - a) x (c - a)` the inward normal, so the line leaves through
//! the face exactly when all three are `<= 0` (and not all zero). Each value is computed in a
//! canonical order (smaller node id first, sign flipped), so the two faces beside an edge see
//! the exact same number: a line cannot slip between them, and the traced walk and the hashed
//! search agree on every crossing. The crossing's barycentric coordinates on the face are the
//! edge values opposite each corner, normalised.

use glam::{Quat, Vec3};

use crate::collide::Body;
use crate::geom;
use crate::ids::{NodeId, TetId};
use crate::mesh::template::FACE_VERTS;
use crate::mesh::FaceUse;

/// Where a border edge leaves the other body's surface.
#[derive(Clone, Copy, PartialEq, Debug)]
pub(crate) struct SurfaceHit {
    /// The boundary face crossed.
    pub(crate) face: FaceUse,
    /// The crossing point `x_i`.
    pub(crate) point: Vec3,
    /// Unit surface normal at `x_i`, interpolated from the face's vertex normals (the face
    /// normal when they cancel).
    pub(crate) normal: Vec3,
    /// Position along the edge: `x_i = p + s (q - p)` (up to rounding).
    pub(crate) s: f32,
}

/// Canonical orientation of the line `p -> q` against the edge `u -> v`.
#[inline]
fn edge_value(pu: Vec3, pv: Vec3, u: NodeId, v: NodeId, p: Vec3, q: Vec3) -> f32 {
    if u < v {
        geom::det6(p, q, pu, pv)
    } else {
        -geom::det6(p, q, pv, pu)
    }
}

/// The edge values of face `f` of `t` as listed `(a, b, c)`: `[e_ab, e_bc, e_ca]`, or `None`
/// when the line does not leave `t` through that face (or an id is out of range).
///
/// # Bounded work
/// Constant: three 3x3 determinants.
#[inline]
pub(crate) fn exit_values(
    body: &Body<'_, '_>,
    t: TetId,
    f: u8,
    p: Vec3,
    q: Vec3,
) -> Option<[f32; 3]> {
    let nodes = body.tet_nodes(t)?;
    let lv = FACE_VERTS.get(f as usize)?;
    let ids = lv.map(|k| nodes[k as usize]);
    let pa = body.pos(ids[0])?;
    let pb = body.pos(ids[1])?;
    let pc = body.pos(ids[2])?;
    // Most faces tested fail on their first edge: the other two are computed only when
    // needed (the same answer as computing all three first).
    let ab = edge_value(pa, pb, ids[0], ids[1], p, q);
    let may_leave = ab <= 0.0; // false for NaN too, as in `leaves`
    if !may_leave {
        return None;
    }
    let e = [
        ab,
        edge_value(pb, pc, ids[1], ids[2], p, q),
        edge_value(pc, pa, ids[2], ids[0], p, q),
    ];
    leaves(e).then_some(e)
}

/// `true` when a face's edge values say the line leaves through it: all `<= 0`, not all zero.
#[inline]
pub(crate) fn leaves(e: [f32; 3]) -> bool {
    e[0] <= 0.0 && e[1] <= 0.0 && e[2] <= 0.0 && (e[0] + e[1] + e[2]) < 0.0
}

/// The hit on boundary face `f` of `t` for edge values from [`exit_values`].
///
/// # Bounded work
/// Constant.
#[inline]
pub(crate) fn hit_on_face(
    body: &Body<'_, '_>,
    t: TetId,
    f: u8,
    e: [f32; 3],
    p: Vec3,
    q: Vec3,
) -> Option<SurfaceHit> {
    let nodes = body.tet_nodes(t)?;
    let lv = FACE_VERTS.get(f as usize)?;
    let ids = lv.map(|k| nodes[k as usize]);
    hit_at(body, FaceUse { tet: t, local: f }, ids, e, p, q)
}

/// [`hit_on_face`] for a caller that holds the face's node ids `ids` in its listing order.
///
/// # Bounded work
/// Constant.
#[inline]
pub(crate) fn hit_at(
    body: &Body<'_, '_>,
    face: FaceUse,
    ids: [NodeId; 3],
    e: [f32; 3],
    p: Vec3,
    q: Vec3,
) -> Option<SurfaceHit> {
    let pos = [body.pos(ids[0])?, body.pos(ids[1])?, body.pos(ids[2])?];
    let sum = e[0] + e[1] + e[2];
    if sum.is_nan() || sum >= 0.0 {
        return None;
    }
    // Weight of a is e_bc, of b is e_ca, of c is e_ab.
    let w = [e[1] / sum, e[2] / sum, e[0] / sum];
    let point = pos[0] * w[0] + pos[1] * w[1] + pos[2] * w[2];
    // `Body::normal` of the three, with the rotation tested once.
    let normals = body.mesh.normals();
    let nrm = if body.rotation == Quat::IDENTITY {
        let n = |k: usize| normals.get(ids[k].idx()).copied().unwrap_or(Vec3::ZERO);
        n(0) * w[0] + n(1) * w[1] + n(2) * w[2]
    } else {
        let r = Rotor::new(body.rotation);
        let n = |k: usize| {
            normals
                .get(ids[k].idx())
                .map_or(Vec3::ZERO, |&v| r.apply(v))
        };
        n(0) * w[0] + n(1) * w[1] + n(2) * w[2]
    };
    let mut normal = nrm.normalize_or_zero();
    if normal == Vec3::ZERO {
        normal = -geom::tri_normal(pos[0], pos[1], pos[2]);
    }
    let d = q - p;
    let dd = d.length_squared();
    let s = if dd > 0.0 {
        (point - p).dot(d) / dd
    } else {
        0.0
    };
    Some(SurfaceHit {
        face,
        point,
        normal,
        s,
    })
}

/// A rotation applied to several vectors: `Quat * Vec3` as glam computes it, the very
/// operations in the same order, with the terms that depend on the rotation alone computed
/// once.
#[derive(Clone, Copy)]
struct Rotor {
    /// The quaternion's vector part.
    b: Vec3,
    /// `w * w - b . b`.
    k: f32,
    /// `w * 2`.
    w2: f32,
}

impl Rotor {
    #[inline]
    fn new(q: Quat) -> Self {
        let b = Vec3::new(q.x, q.y, q.z);
        Self {
            b,
            k: q.w * q.w - b.dot(b),
            w2: q.w * 2.0,
        }
    }

    /// `q * v`, the same bits.
    #[inline]
    fn apply(&self, v: Vec3) -> Vec3 {
        v * self.k + self.b * (v.dot(self.b) * 2.0) + self.b.cross(v) * self.w2
    }
}

/// Slack on the edge parameter: crossings with `s` in `[-S_SLACK, 1 + S_SLACK]` count.
pub(crate) const S_SLACK: f32 = 1e-4;

/// `true` when a hit lies on the border edge (within [`S_SLACK`]).
#[inline]
pub(crate) fn on_edge(h: &SurfaceHit) -> bool {
    h.s >= -S_SLACK && h.s <= 1.0 + S_SLACK
}

#[cfg(test)]
mod tests {
    use glam::{Quat, Vec3};

    use super::Rotor;

    /// The rotation with its own terms worked out once gives `Quat * Vec3`'s bits (pinned
    /// here, so that a change of glam's formula shows).
    #[test]
    fn a_rotor_rotates_as_the_quaternion_does_bit_for_bit() {
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        let mut next = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 40) as f32 / (1u64 << 24) as f32 * 2.0 - 1.0
        };
        for _ in 0..2000 {
            let q = Quat::from_xyzw(next(), next(), next(), next()).normalize();
            let r = Rotor::new(q);
            for _ in 0..8 {
                let v = Vec3::new(next(), next(), next()) * 3.0;
                let bits = |v: Vec3| v.to_array().map(f32::to_bits);
                assert_eq!(bits(q * v), bits(r.apply(v)), "{q} {v}");
            }
        }
    }
}
