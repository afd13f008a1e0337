//! The traced intersection (seed 000 section 4): walk the line through B's tets.

use glam::Vec3;

use super::surface::{hit_on_face, leaves, on_edge, SurfaceHit};
use crate::collide::Body;
use crate::ids::{NodeId, TetId};
use crate::mesh::template::{EDGE_VERTS, FACE_VERTS};

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
/// walk keeps the values of the tet it is in ([`Walker`]): the tet it steps into shares three
/// corners and their three edges with the last one, and only its new corner and the three
/// edges to it are computed (three dot products a step, where testing each face afresh took
/// up to nine 3x3 determinants). The faces are tested in the same order with the same
/// numbers [`super::surface::exit_values`] gives, so the walk crosses the same faces, bit for
/// bit, on a mesh that passes [`crate::mesh::Mesh::validate`] with every node's position
/// given (a missing position or a neighbour that does not share the face ends the walk with
/// `None`).
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
    let mut t = start;
    let mut tet = body.mesh.get_tet(t)?;
    let d = q - p;
    let mut w = Walker::enter(body, tet.nodes, p, d)?;
    let mut entry = 4u8;
    for _ in 0..max_steps {
        *steps = steps.wrapping_add(1);
        let mut exit = None;
        for f in 0..4u8 {
            if f == entry {
                continue;
            }
            let e = w.face_values(f);
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
        let next = body.mesh.get_tet(nb)?;
        w.step(body, f, next.nodes, entry, p, d)?;
        (t, tet) = (nb, next);
    }
    None
}

/// The walk's working set: the four corners of the tet it is in, each in a fixed slot (a
/// step puts the corner it arrives at in the slot of the corner it leaves behind), which
/// slot holds each of the tet's vertices, and the line's value along each ordered pair of
/// slots.
struct Walker {
    /// Per slot: the node and its [`Corner`].
    node: [NodeId; 4],
    corner: [Corner; 4],
    /// Per vertex of the tet: its slot.
    slot: [u8; 4],
    /// `value[a][b]`: the line against the edge from slot `a` to slot `b`
    /// (`value[b][a] = -value[a][b]`, exactly).
    value: [[f32; 4]; 4],
}

impl Walker {
    /// The walk's first tet, `nodes` (`None` for a node out of range).
    fn enter(body: &Body<'_, '_>, nodes: [NodeId; 4], p: Vec3, d: Vec3) -> Option<Self> {
        let mut w = Self {
            node: nodes,
            corner: [Corner::default(); 4],
            slot: [0, 1, 2, 3],
            value: [[0.0; 4]; 4],
        };
        for (c, &n) in w.corner.iter_mut().zip(nodes.iter()) {
            *c = Corner::new(body.pos(n)?, p, d);
        }
        for [a, b] in EDGE_VERTS {
            w.set_edge(a as usize, b as usize);
        }
        Some(w)
    }

    /// Steps out of the current tet through its face `f` into the tet `nodes`, entered
    /// through its face `entry` (`None` when the two do not share that face's corners).
    fn step(
        &mut self,
        body: &Body<'_, '_>,
        f: u8,
        nodes: [NodeId; 4],
        entry: u8,
        p: Vec3,
        d: Vec3,
    ) -> Option<()> {
        // The corner opposite `f` is left behind; its slot takes the new corner.
        let free = *self.slot.get(f as usize)? as usize & 3;
        let mut slot = [0u8; 4];
        for (k, (&n, s)) in nodes.iter().zip(slot.iter_mut()).enumerate() {
            *s = if k as u8 == entry {
                free as u8
            } else {
                let s = self.node.iter().position(|&m| m == n)?;
                if s == free {
                    return None;
                }
                s as u8
            };
        }
        let n = *nodes.get(entry as usize)?;
        self.node[free] = n;
        self.corner[free] = Corner::new(body.pos(n)?, p, d);
        self.slot = slot;
        for other in 1..4 {
            self.set_edge(free, (free + other) & 3);
        }
        Some(())
    }

    /// Computes the edge between slots `a` and `b`: [`super::surface`]'s canonical value (the
    /// determinant over the smaller node id first), the same bits.
    #[inline]
    fn set_edge(&mut self, a: usize, b: usize) {
        let (a, b) = (a & 3, b & 3);
        let (ca, cb) = (self.corner[a], self.corner[b]);
        let ab = if self.node[a] < self.node[b] {
            ca.c.dot(cb.r)
        } else {
            -cb.c.dot(ca.r)
        };
        self.value[a][b] = ab;
        self.value[b][a] = -ab;
    }

    /// The values of face `f` of the tet as listed `(a, b, c)`: `[e_ab, e_bc, e_ca]`.
    #[inline]
    fn face_values(&self, f: u8) -> [f32; 3] {
        let [a, b, c] = FACE_VERTS[f as usize & 3].map(|v| self.slot[v as usize] as usize & 3);
        [self.value[a][b], self.value[b][c], self.value[c][a]]
    }
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
