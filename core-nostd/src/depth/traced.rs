//! The traced intersection (seed 000 section 4): walk the line through B's tets.

use glam::Vec3;

use super::surface::{hit_on_face, leaves, on_edge, SurfaceHit};
use crate::collide::Body;
use crate::ids::{NodeId, TetId};
use crate::mesh::template::{EDGE_OF_VERTS, EDGE_VERTS, FACE_VERTS};

/// Follows the line `p -> q` from tet `start` (which holds `p`) through neighbours until it
/// leaves `body` through a boundary face; returns that crossing if it lies on the segment.
/// `steps` receives the tets crossed.
///
/// # Bounded work
/// At most `max_steps` tets, four face tests each. A walk that needs more, or that finds no
/// exit face (rounding on a degenerate configuration), returns `None`.
pub fn trace_to_surface(
    body: &Body<'_, '_>,
    start: TetId,
    p: Vec3,
    q: Vec3,
    max_steps: u32,
    steps: &mut u32,
) -> Option<SurfaceHit> {
    trace_exit(body, start, p, q, max_steps, steps).filter(on_edge)
}

/// Where the line from `p` towards `q` first leaves `body` through a boundary face, walking
/// from `start` (which holds `p`), wherever that is along the line (`s` may exceed 1).
///
/// The line's value against an edge depends only on the edge ([`super::surface`]), so the
/// walk keeps the six values of the tet it is in: the tet it steps into shares three edges
/// with the last one, and only the three edges to its new corner are computed (three 3x3
/// determinants a step, where testing each face afresh took up to nine, each from scratch:
/// see [`Corner`]). The faces are tested
/// in the same order with the same numbers [`super::surface::exit_values`] gives, so the walk
/// crosses the same faces, bit for bit.
///
/// # Bounded work
/// As [`trace_to_surface`].
pub(crate) fn trace_exit(
    body: &Body<'_, '_>,
    start: TetId,
    p: Vec3,
    q: Vec3,
    max_steps: u32,
    steps: &mut u32,
) -> Option<SurfaceHit> {
    let tets = body.mesh.tets();
    let mut t = start;
    let mut tet = tets.get(t.idx())?;
    let d = q - p;
    let mut corners = [Corner::default(); 4];
    for (c, &n) in corners.iter_mut().zip(tet.nodes.iter()) {
        *c = Corner::new(body.pos(n)?, p, d);
    }
    let mut value = [0.0f32; 6];
    for (v, &[i, j]) in value.iter_mut().zip(EDGE_VERTS.iter()) {
        *v = edge_value(&tet.nodes, &corners, i, j);
    }
    let mut entry = 4u8;
    for _ in 0..max_steps {
        *steps = steps.wrapping_add(1);
        let mut exit = None;
        for f in 0..4u8 {
            if f == entry {
                continue;
            }
            let e = face_values(&value, f);
            if leaves(e) {
                exit = Some((f, e));
                break;
            }
        }
        let (f, e) = exit?;
        let nb = *tet.neighbours.get(f as usize)?;
        if nb.is_none() {
            return hit_on_face(body, t, f, e, p, q);
        }
        entry = tet.reverse.get(f as usize)?.face();
        let next = tets.get(nb.idx())?;
        // Where each corner of the next tet is in this one (`entry`: the new corner).
        let mut from = [0u8; 4];
        let mut next_corners = [Corner::default(); 4];
        for (k, &n) in next.nodes.iter().enumerate() {
            if k as u8 == entry {
                next_corners[k] = Corner::new(body.pos(n)?, p, d);
            } else {
                let j = tet.nodes.iter().position(|&m| m == n)?;
                from[k] = j as u8;
                next_corners[k] = corners[j];
            }
        }
        let mut next_value = [0.0f32; 6];
        for (v, &[a, b]) in next_value.iter_mut().zip(EDGE_VERTS.iter()) {
            *v = if a == entry || b == entry {
                edge_value(&next.nodes, &next_corners, a, b)
            } else {
                let (ja, jb) = (from[a as usize], from[b as usize]);
                signed(&value, ja, jb)
            };
        }
        (t, tet, corners, value) = (nb, next, next_corners, next_value);
    }
    None
}

/// A corner `x` of the walk's tet as the line's determinants use it: `r = x - p` and
/// `c = (q - p) x r`. The line against the edge `u -> v` is then `c_u . r_v`, the very
/// operations [`crate::geom::det6`]`(p, q, u, v)` performs, in the same order: the same bits, with
/// the differences and the cross product done once per corner instead of once per edge.
#[derive(Clone, Copy, Default)]
struct Corner {
    r: Vec3,
    c: Vec3,
}

impl Corner {
    #[inline]
    fn new(x: Vec3, p: Vec3, d: Vec3) -> Self {
        let r = x - p;
        Self { r, c: d.cross(r) }
    }
}

/// The line against the edge from local corner `i` to `j` (`i < j`): [`super::surface`]'s
/// canonical value, the same bits (the determinant over the smaller node id first).
#[inline]
fn edge_value(nodes: &[NodeId; 4], corners: &[Corner; 4], i: u8, j: u8) -> f32 {
    let (i, j) = (i as usize & 3, j as usize & 3);
    if nodes[i] < nodes[j] {
        corners[i].c.dot(corners[j].r)
    } else {
        -corners[j].c.dot(corners[i].r)
    }
}

/// The line against the edge from local corner `a` to `b`, from the values kept per edge in
/// [`EDGE_VERTS`] order (each from its lower corner to its higher): exact, a sign flip.
#[inline]
fn signed(value: &[f32; 6], a: u8, b: u8) -> f32 {
    let e = EDGE_OF_VERTS[a as usize & 3][b as usize & 3] as usize % 6;
    if a < b {
        value[e]
    } else {
        -value[e]
    }
}

/// The values of face `f` as listed `(a, b, c)`: `[e_ab, e_bc, e_ca]`.
#[inline]
fn face_values(value: &[f32; 6], f: u8) -> [f32; 3] {
    let [a, b, c] = FACE_VERTS[f as usize & 3];
    [
        signed(value, a, b),
        signed(value, b, c),
        signed(value, c, a),
    ]
}
