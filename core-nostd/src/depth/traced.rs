//! The traced intersection (Praktikum report, section 4): walk the line through B's tets.

use glam::Vec3;

use super::surface::{hit_at, leaves, SurfaceHit};
use crate::collide::Body;
use crate::ids::{NodeId, TetId};
use crate::mesh::template::FACE_VERTS;
use crate::mesh::FaceUse;

/// Follows the line `p -> q` from tet `start` (which holds `p`) through neighbours until it
/// leaves `body` through a boundary face; returns that crossing if it lies on the segment.
/// `steps` receives the tets crossed.
///
/// # Bounded work
/// At most `max_steps` tets: the first with up to four face tests, each further one with
/// three dot products and one table lookup. A walk that needs more, or that finds no exit
/// face (rounding on a degenerate configuration), returns `None`.
#[cfg(test)]
pub(crate) fn trace_to_surface(
    body: &Body<'_, '_>,
    start: TetId,
    p: Vec3,
    q: Vec3,
    max_steps: u32,
    steps: &mut u32,
) -> Option<SurfaceHit> {
    trace_exit(body, start, p, q, max_steps, steps).filter(super::surface::on_edge)
}

/// Where the line from `p` towards `q` first leaves `body` through a boundary face, walking
/// from `start` (which holds `p`), wherever that is along the line (`s` may exceed 1).
///
/// The line's value against an edge depends only on the edge ([`super::surface`]), so the
/// walk keeps the face it entered the current tet through ([`Tri`]: its three corners and
/// the values of its three sides). The tet's other three faces each hold its fourth corner,
/// so a step computes that corner and the three edges to it (three dot products, where
/// testing each face afresh took up to nine 3x3 determinants), and which faces the line
/// leaves through follows from the signs of those values (the entry face's own are `<= 0`:
/// the line left the last tet through it). With strict signs one face only leaves, found by
/// branches; with zeros the first in the tet's face order is taken ([`EXITS`]). The exit
/// face's values are handed on in its listing order, so the walk crosses the same faces
/// with the same numbers, bit for bit, as testing each face with
/// [`super::surface::exit_values`] on a mesh that passes [`crate::mesh::Mesh::validate`] (a
/// step places the corners of the face it enters through by the reverse index's ring
/// offset; a missing position ends the walk with `None`).
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
    let mut walked = 0;
    let hit = walk(body, start, p, q, max_steps, &mut walked);
    *steps = steps.wrapping_add(walked);
    hit
}

/// [`trace_exit`], counting the tets crossed in `walked`.
#[inline(always)]
fn walk(
    body: &Body<'_, '_>,
    start: TetId,
    p: Vec3,
    q: Vec3,
    max_steps: u32,
    walked: &mut u32,
) -> Option<SurfaceHit> {
    if max_steps == 0 {
        return None;
    }
    let d = q - p;
    let mut t = start;
    let mut tet = body.mesh.get_tet(t)?;
    *walked = 1;
    let (mut f, mut tri) = first_exit(body, tet.nodes, p, d)?;
    // Listing position `k` of face `f` holds slot `(k + rot) % 3` of `tri`.
    let mut rot = 0u8;
    loop {
        let nb = tet.neighbours[f as usize & 3];
        if nb.is_none() {
            return tri.hit(body, FaceUse { tet: t, local: f }, rot, p, q);
        }
        if *walked >= max_steps {
            return None;
        }
        let rev = tet.reverse[f as usize & 3];
        let g = rev.face() as usize;
        let sigma = MOD3[(rot + rev.offset()) as usize & 7] as usize;
        tet = body.mesh.get_tet(nb)?;
        t = nb;
        let n = tet.nodes[g & 3];
        let cn = Corner::new(body.pos(n)?, p, d);
        *walked += 1;
        let m = [
            edge(tri.node[0], tri.corner[0], n, cn),
            edge(tri.node[1], tri.corner[1], n, cn),
            edge(tri.node[2], tri.corner[2], n, cn),
            0.0,
        ];
        // Side `s` of the entry face with the new corner, `(slot s, slot s+1, n)`, has the
        // values `[value_s, m_s+1, -m_s]`, the first `<= 0` already: it leaves when
        // `m_s+1 <= 0 <= m_s` and the three are not all zero. With `m_s+1 < 0 < m_s` it is
        // the only side that leaves (the others would need `m_s+1 >= 0` or `m_s <= 0`); the
        // tests are branches, so that the next tet is looked up while they resolve.
        // Each branch updates the slots with its own constant side.
        let row = g << 5 | sigma << 3;
        let code = if m[0] > 0.0 && m[1] < 0.0 {
            tri.stepped(0, n, cn, m);
            EXITS[(row | 1) & 127]
        } else if m[1] > 0.0 && m[2] < 0.0 {
            tri.stepped(1, n, cn, m);
            EXITS[(row | 2) & 127]
        } else if m[2] > 0.0 && m[0] < 0.0 {
            tri.stepped(2, n, cn, m);
            EXITS[(row | 4) & 127]
        } else {
            let code = exit_with_zeros(row, &tri.value, &m);
            if code == NO_EXIT {
                return None;
            }
            tri.stepped(code as usize & 3, n, cn, m);
            code
        };
        f = (code >> 2) & 3;
        rot = (code >> 4) & 3;
    }
}

/// The exit code of a step ([`EXITS`] at `row`) when no side of the entry face leaves
/// with strict signs (some of the new edges' values `m` are zero or NaN, or none leaves):
/// the first side in face order whose values are `<= 0` and not all zero, `value` being
/// the entry face's.
#[inline(never)]
fn exit_with_zeros(row: usize, value: &[f32; 4], m: &[f32; 4]) -> u8 {
    let bits = |x: [bool; 3]| x[0] as usize | (x[1] as usize) << 1 | (x[2] as usize) << 2;
    let le = bits([m[0] <= 0.0, m[1] <= 0.0, m[2] <= 0.0]);
    let ge = bits([m[0] >= 0.0, m[1] >= 0.0, m[2] >= 0.0]);
    let mut mask = ge & (le >> 1 | (le & 1) << 2);
    loop {
        let code = EXITS[(row | mask) & 127];
        let s = code as usize & 3;
        let s1 = NEXT[s] as usize & 3;
        // The sum of values `<= 0` is `< 0` unless all are zero, in any order.
        if code == NO_EXIT || value[s] + m[s1] - m[s] < 0.0 {
            return code;
        }
        mask &= !(1 << s);
    }
}

/// The exit face of the walk's first tet `nodes` (faces tested in order) and that face as
/// the next tet's entry, slot `k` its listing position `k`. Face 0 needs neither corner 0
/// nor its edges, and face 1 not the edge 0-1: each is computed only when the faces before
/// did not leave.
#[inline(always)]
fn first_exit(body: &Body<'_, '_>, nodes: [NodeId; 4], p: Vec3, d: Vec3) -> Option<(u8, Tri)> {
    let x0 = body.pos(nodes[0])?;
    let c1 = Corner::new(body.pos(nodes[1])?, p, d);
    let c2 = Corner::new(body.pos(nodes[2])?, p, d);
    let c3 = Corner::new(body.pos(nodes[3])?, p, d);
    let [n0, n1, n2, n3] = nodes;
    let (e12, e13, e23) = (
        edge(n1, c1, n2, c2),
        edge(n1, c1, n3, c3),
        edge(n2, c2, n3, c3),
    );
    // Each face as `FACE_VERTS` lists it, with `[e_ab, e_bc, e_ca]`.
    let tri = |node: [NodeId; 3], corner: [Corner; 3], value: [f32; 3]| Tri {
        node: [node[0], node[1], node[2], NodeId::NONE],
        corner: [corner[0], corner[1], corner[2], corner[0]],
        value: [value[0], value[1], value[2], 0.0],
    };
    let v0 = [e13, -e23, -e12];
    if leaves(v0) {
        return Some((0, tri([n1, n3, n2], [c1, c3, c2], v0)));
    }
    let c0 = Corner::new(x0, p, d);
    let (e02, e03) = (edge(n0, c0, n2, c2), edge(n0, c0, n3, c3));
    let v1 = [e02, e23, -e03];
    if leaves(v1) {
        return Some((1, tri([n0, n2, n3], [c0, c2, c3], v1)));
    }
    let e01 = edge(n0, c0, n1, c1);
    let v2 = [e03, -e13, -e01];
    if leaves(v2) {
        return Some((2, tri([n0, n3, n1], [c0, c3, c1], v2)));
    }
    let v3 = [e01, e12, -e02];
    leaves(v3).then(|| (3, tri([n0, n1, n2], [c0, c1, c2], v3)))
}

/// The line against the edge `u -> v`: [`super::surface`]'s canonical value (the
/// determinant over the smaller node id first, its sign flipped), the same bits.
#[inline(always)]
fn edge(u: NodeId, cu: Corner, v: NodeId, cv: Corner) -> f32 {
    if u < v {
        cu.c.dot(cv.r)
    } else {
        -cv.c.dot(cu.r)
    }
}

/// The face the walk entered its tet through: three corners in slots 0 to 2, in their order
/// around the face as the last tet listed it (up to rotation), and the line's values along
/// its sides: `value[s]` against the edge from slot `s` to slot `s + 1` (mod 3). Slot 3 is
/// never read (the arrays are four long so that a slot masked with 3 needs no bounds check).
#[derive(Clone, Copy)]
struct Tri {
    node: [NodeId; 4],
    corner: [Corner; 4],
    value: [f32; 4],
}

impl Tri {
    /// The side from slot `s` and the new corner `n` as the next entry face: `n` takes the
    /// slot of the corner left behind, `m[k]` being the line against `slot k -> n`.
    #[inline(always)]
    fn stepped(&mut self, s: usize, n: NodeId, cn: Corner, m: [f32; 4]) {
        let s = s & 3;
        let s1 = NEXT[s] as usize & 3;
        let s2 = NEXT[s1] as usize & 3;
        self.value[s1] = m[s1];
        self.value[s2] = -m[s];
        self.node[s2] = n;
        self.corner[s2] = cn;
    }

    /// The crossing of boundary face `face`, whose listing position `k` holds slot
    /// `(k + rot) % 3`.
    #[inline(always)]
    fn hit(
        &self,
        body: &Body<'_, '_>,
        face: FaceUse,
        rot: u8,
        p: Vec3,
        q: Vec3,
    ) -> Option<SurfaceHit> {
        let [a, b, c] = ROT3[rot as usize & 3];
        let ids = [self.node[a & 3], self.node[b & 3], self.node[c & 3]];
        let e = [self.value[a & 3], self.value[b & 3], self.value[c & 3]];
        hit_at(body, face, ids, e, p, q)
    }
}

/// The slots of listing positions 0 to 2 for `rot` 0 to 2 (`ROT3[3]` unused).
const ROT3: [[usize; 3]; 4] = [[0, 1, 2], [1, 2, 0], [2, 0, 1], [0, 1, 2]];

/// `k % 3` for `k < 8`.
const MOD3: [u8; 8] = [0, 1, 2, 0, 1, 2, 0, 1];

/// The next slot around the face (`NEXT[3]` unused).
const NEXT: [u8; 4] = [1, 2, 0, 0];

/// [`EXITS`] where no face leaves.
const NO_EXIT: u8 = 0xff;

/// The tet vertex in slot `s` of the walk's entry face, in a tet entered through its face `g`
/// with the combined offset `sigma` (the reverse index's ring offset plus the rotation of
/// the slots against the last tet's listing of the face): the rule of
/// [`crate::mesh::Mesh::vertex_match`].
const fn local(g: usize, sigma: usize, s: usize) -> u8 {
    FACE_VERTS[g][(3 - s + sigma) % 3]
}

/// Per entry face `g`, offset `sigma` and mask of the sides that leave (bit `s`: the side
/// from slot `s`, [`Tri::stepped`]), at `g << 5 | sigma << 3 | mask`: the side whose face
/// comes first in the tet's face order, packed `s | f << 2 | rot << 4` with `f` that face and
/// `rot` the slot that holds its listing's first vertex after the step; [`NO_EXIT`] for an
/// empty mask.
const EXITS: [u8; 128] = {
    let mut t = [NO_EXIT; 128];
    let mut g = 0;
    while g < 4 {
        let mut sigma = 0;
        while sigma < 3 {
            let mut mask = 1;
            while mask < 8 {
                let mut best = 4u8;
                let mut s = 0;
                while s < 3 {
                    let f = local(g, sigma, (s + 2) % 3);
                    if mask >> s & 1 == 1 && f < best {
                        best = f;
                        let first = FACE_VERTS[f as usize][0];
                        let rot = if first == local(g, sigma, s) {
                            s
                        } else if first == local(g, sigma, (s + 1) % 3) {
                            (s + 1) % 3
                        } else {
                            (s + 2) % 3
                        };
                        t[g << 5 | sigma << 3 | mask] = s as u8 | f << 2 | (rot as u8) << 4;
                    }
                    s += 1;
                }
                mask += 1;
            }
            sigma += 1;
        }
        g += 1;
    }
    t
};

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

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::*;
    use crate::collide::test_support::{Rng, Store};
    // The oracle: the Praktikum report's walk, each face tested afresh.
    use crate::depth::tests::walk_testing_every_face as every_face_walk;
    use crate::mesh::template::FACE_VERTS;

    /// Every entry of [`EXITS`] against a search over the sides of the mask: the slots hold
    /// the entry face's vertices in the order opposite to this tet's listing (the last tet
    /// listed it), the face chosen is the first in face order among the sides that leave, and
    /// its listing, read from slot `rot` on, is its side `(slot s, slot s+1, new corner)`.
    #[test]
    fn the_exit_table_takes_the_first_face_that_leaves_and_its_listing() {
        for g in 0..4 {
            for sigma in 0..3 {
                let slot = |s: usize| local(g, sigma, s % 3) as usize;
                let lv = FACE_VERTS[g].map(|v| v as usize);
                let reversed = (0..3).any(|r| (0..3).all(|k| slot(k) == lv[(r + 3 - k) % 3]));
                assert!(reversed, "g {g} sigma {sigma}");
                assert_eq!(EXITS[g << 5 | sigma << 3], NO_EXIT);
                for mask in 1..8usize {
                    let code = EXITS[g << 5 | sigma << 3 | mask];
                    let (s, f, rot) = (code as usize & 3, (code >> 2) as usize & 3, code >> 4);
                    assert!(s < 3 && rot < 3 && mask >> s & 1 == 1, "{g} {sigma} {mask}");
                    // The face of side `s` is the one opposite the slot it leaves out.
                    let face_of = |s: usize| slot(s + 2);
                    assert_eq!(f, face_of(s));
                    let first = (0..3).filter(|&k| mask >> k & 1 == 1).map(face_of).min();
                    assert_eq!(Some(f), first, "{g} {sigma} {mask}");
                    // After the step the slot left out holds the new corner, vertex `g`.
                    let after = |k: usize| if k % 3 == (s + 2) % 3 { g } else { slot(k) };
                    let listing = FACE_VERTS[f].map(|v| v as usize);
                    for (k, &v) in listing.iter().enumerate() {
                        assert_eq!(v, after(rot as usize + k), "{g} {sigma} {mask}");
                    }
                }
            }
        }
    }

    /// On a block whose nodes are jittered and renumbered and whose tets list their corners
    /// from a random corner (every entry face and ring offset occurs), the walk crosses the
    /// faces the oracle does, with the same bits, the same tet count and the same give-up.
    #[test]
    fn the_walk_matches_testing_every_face_on_a_jittered_renumbered_block() {
        let (walks, long, hits) = compare_walks(0.04, false);
        assert!(
            walks > 2000 && long > 300 && hits > 600,
            "{walks} walks, {long} longer than 4 tets, {hits} hits"
        );
    }

    /// The same without jitter, on lines in the grid's planes: faces in the plane give the
    /// line three zero values, which do not make an exit.
    #[test]
    fn the_walk_matches_testing_every_face_on_lines_in_grid_planes() {
        let (walks, long, hits) = compare_walks(0.0, true);
        assert!(
            walks > 2000 && long > 300 && hits > 600,
            "{walks} walks, {long} longer than 4 tets, {hits} hits"
        );
    }

    /// Walks on the renumbered block jittered by `jitter` (times the edge), compared with
    /// the oracle; lines in the planes `x = 0` and `y = 0.25` with `planar`. Returns the
    /// walks, those longer than 4 tets, and the hits.
    fn compare_walks(jitter: f32, planar: bool) -> (u32, u32, u32) {
        let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
        let mut s = Store::<125, 384>::block(4, 0.25, Vec3::splat(-0.5));
        let (n, t) = (s.n, s.t);
        // A random renumbering of the nodes.
        let mut new_id: [u32; 125] = core::array::from_fn(|i| i as u32);
        for i in (1..n).rev() {
            let j = (rng.next() * (i + 1) as f32) as usize % (i + 1);
            new_id.swap(i, j);
        }
        let old = s.positions;
        for (i, &p) in old.iter().enumerate().take(n) {
            let offset = Vec3::new(rng.next(), rng.next(), rng.next()) - 0.5;
            s.positions[new_id[i] as usize] = p + offset * (jitter * 0.25);
        }
        for tn in s.tet_nodes.iter_mut().take(t) {
            // An even permutation keeps the orientation: a rotation of the last three, then
            // a double swap.
            let r = (rng.next() * 3.0) as usize % 3;
            let mut v = [
                tn[0],
                tn[1 + r % 3],
                tn[1 + (r + 1) % 3],
                tn[1 + (r + 2) % 3],
            ];
            if rng.next() < 0.5 {
                v = [v[1], v[0], v[3], v[2]];
            }
            *tn = v.map(|k| new_id[k as usize]);
        }
        let m = s.mesh();
        let b = Body::fixed(&m);
        let (mut walks, mut long, mut hits) = (0, 0, 0);
        for k in 0..600 {
            let mut p = Vec3::new(rng.next(), rng.next(), rng.next()) * 0.9 - 0.45;
            // Some lines through a node of the mesh, where faces tie.
            let mut q = if k % 5 == 0 {
                p + (m.positions()[k % n] - p) * 4.0
            } else {
                p + (Vec3::new(rng.next(), rng.next(), rng.next()) - 0.5) * 3.0
            };
            if planar && k % 2 == 0 {
                (p.x, q.x) = (0.0, 0.0);
            } else if planar {
                (p.y, q.y) = (0.25, 0.25);
            }
            let Some(start) = (0..t).map(TetId::from_idx).find(|&t| {
                crate::geom::barycentric(p, b.tet_positions(t).unwrap())
                    .is_some_and(|x| crate::geom::inside(x, 0.0))
            }) else {
                continue;
            };
            for max_steps in [0, 1, 2, 5, 64] {
                let mut steps = 3;
                let got = trace_exit(&b, start, p, q, max_steps, &mut steps);
                let (want, want_steps) = every_face_walk(&b, start, p, q, max_steps);
                let bits = |h: Option<SurfaceHit>| {
                    h.map(|h| (h.face, h.point.to_array().map(f32::to_bits), h.s.to_bits()))
                };
                assert_eq!(bits(got), bits(want), "line {p} -> {q}, {max_steps} steps");
                assert_eq!(got, want);
                assert_eq!(steps, 3 + want_steps, "line {p} -> {q}, {max_steps} steps");
                walks += 1;
                long += (want_steps > 4) as u32;
                hits += got.is_some() as u32;
            }
        }
        (walks, long, hits)
    }
}
