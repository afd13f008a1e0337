//! Tiny meshes over fixed arrays for the unit tests of collide, depth and force, and the
//! brute-force point location and random numbers the collide tests share.

use glam::Vec3;

use super::{Body, Collision, INSIDE_EPS};
use crate::ids::{NodeId, TetId};

use crate::builtin;
use crate::mesh::{BuildOptions, FaceKey, Mesh, MeshStorage, Node, Tet};

/// Fixed storage for a mesh of at most `N` nodes and `T` tets.
pub(crate) struct Store<const N: usize, const T: usize> {
    pub positions: [Vec3; N],
    pub tet_nodes: [[u32; 4]; T],
    pub nodes: [Node; N],
    pub normals: [Vec3; N],
    pub tets: [Tet; T],
    pub scratch: [[FaceKey; 4]; T],
    pub n: usize,
    pub t: usize,
}

impl<const N: usize, const T: usize> Store<N, T> {
    pub fn empty() -> Self {
        Self {
            positions: [Vec3::ZERO; N],
            tet_nodes: [[0; 4]; T],
            nodes: [Node::default(); N],
            normals: [Vec3::ZERO; N],
            tets: [Tet::default(); T],
            scratch: [[FaceKey::default(); 4]; T],
            n: 0,
            t: 0,
        }
    }

    /// A block of `k^3` cubes of edge `edge` from `origin`.
    pub fn block(k: usize, edge: f32, origin: Vec3) -> Self {
        let mut s = Self::empty();
        let (n, t) =
            builtin::block(k, edge, origin, &mut s.positions, &mut s.tet_nodes).expect("fits");
        s.n = n;
        s.t = t;
        s
    }

    /// The 12-tet cube, scaled and moved.
    pub fn cube12(scale: f32, origin: Vec3) -> Self {
        let mut s = Self::empty();
        let (p, t) = builtin::cube12();
        for (d, q) in s.positions.iter_mut().zip(p.iter()) {
            *d = *q * scale + origin;
        }
        s.tet_nodes[..t.len()].copy_from_slice(&t);
        s.n = p.len();
        s.t = t.len();
        s
    }

    /// The mesh as collide, depth and force tests use it (tets kept as given).
    pub fn mesh(&mut self) -> Mesh<'_> {
        self.mesh_with(BuildOptions {
            relabel_for_refinement: false,
        })
    }

    /// The mesh as the drill and the hierarchy need it (each tet relabelled for refinement).
    pub fn refinable_mesh(&mut self) -> Mesh<'_> {
        self.mesh_with(BuildOptions::default())
    }

    fn mesh_with(&mut self, options: BuildOptions) -> Mesh<'_> {
        let flat = self.scratch.as_flattened_mut();
        Mesh::build(
            &mut self.positions[..self.n],
            &self.tet_nodes[..self.t],
            MeshStorage {
                nodes: &mut self.nodes,
                normals: &mut self.normals,
                tets: &mut self.tets,
            },
            flat,
            options,
        )
        .expect("test mesh builds")
    }
}

/// Brute force over every tet of `body`: per point (at most 64) the smallest tet that holds it
/// (`geom::barycentric`, `geom::inside`), skipping the point's own tets when `own`.
pub(crate) fn brute(body: &Body<'_, '_>, points: &[Vec3], own: bool) -> [Option<TetId>; 64] {
    let mut r = [None; 64];
    for (i, &p) in points.iter().enumerate() {
        for t in 0..body.tet_count() {
            let t = TetId::from_idx(t);
            if own && body.tet_nodes(t).unwrap().contains(&NodeId::from_idx(i)) {
                continue;
            }
            if let Some(b) = crate::geom::barycentric(p, body.tet_positions(t).unwrap()) {
                if crate::geom::inside(b, INSIDE_EPS) {
                    r[i] = Some(t);
                    break;
                }
            }
        }
    }
    r
}

pub(crate) use crate::geom::test_rng::Rng;

/// Brute force over every tet of `body` in world coordinates: per point the smallest tet
/// that holds it (`geom::barycentric`, `geom::inside`), as sorted collisions.
pub(crate) fn brute_list<const N: usize>(
    body: &Body<'_, '_>,
    points: &[Vec3],
    out: &mut [Collision; N],
) -> usize {
    let mut n = 0;
    for (i, &p) in points.iter().enumerate() {
        for t in 0..body.tet_count() {
            let t = TetId::from_idx(t);
            let b = crate::geom::barycentric(p, body.tet_positions(t).unwrap());
            if b.is_some_and(|b| crate::geom::inside(b, INSIDE_EPS)) {
                out[n] = Collision {
                    node: NodeId::from_idx(i),
                    tet: t,
                };
                n += 1;
                break;
            }
        }
    }
    n
}

/// Calls `f` with every corner of the grid cells `lo..=hi` (cell `[i, j, k]`'s low corner at
/// `corner(i, j, k)`) and each of the 26 floats around it, when the box `b` holds them: the
/// points where a quantised cell box is most likely to be off by one level.
pub(crate) fn nudged_corners(
    b: &crate::hash::Aabb,
    lo: [i32; 3],
    hi: [i32; 3],
    corner: impl Fn(i32, i32, i32) -> Vec3,
    mut f: impl FnMut(Vec3),
) {
    let step = |v: f32, d: usize| match d {
        0 => v.next_down(),
        1 => v,
        _ => v.next_up(),
    };
    for k in lo[2]..=hi[2] {
        for j in lo[1]..=hi[1] {
            for i in lo[0]..=hi[0] {
                let c = corner(i, j, k);
                for nudge in 0..27 {
                    let q = Vec3::new(
                        step(c.x, nudge % 3),
                        step(c.y, nudge / 3 % 3),
                        step(c.z, nudge / 9),
                    );
                    if b.contains(q) {
                        f(q);
                    }
                }
            }
        }
    }
}

/// Calls `f` with points of the box `b` where a conservative filter is tested hardest: its 8
/// corners, the centre of each face with `per_face` random points on that face, then `inside`
/// random points of the box (drawn from `rng` in that order).
pub(crate) fn box_probes(
    b: &crate::hash::Aabb,
    rng: &mut Rng,
    per_face: usize,
    inside: usize,
    mut f: impl FnMut(Vec3),
) {
    let pick = |k: usize, a: usize| if k >> a & 1 == 0 { b.min[a] } else { b.max[a] };
    for k in 0..8 {
        f(Vec3::new(pick(k, 0), pick(k, 1), pick(k, 2)));
    }
    let mid = (b.min + b.max) * 0.5;
    let any = |rng: &mut Rng| {
        Vec3::new(
            rng.range(b.min.x, b.max.x),
            rng.range(b.min.y, b.max.y),
            rng.range(b.min.z, b.max.z),
        )
    };
    for a in 0..3 {
        for side in [b.min[a], b.max[a]] {
            let mut q = mid;
            q[a] = side;
            f(q);
            for _ in 0..per_face {
                let mut q = any(rng);
                q[a] = side;
                f(q);
            }
        }
    }
    for _ in 0..inside {
        f(any(rng));
    }
}
