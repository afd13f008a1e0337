//! Unit tests: the const tables against a brute-force geometric derivation, the digit walks,
//! and the tiny-capacity branches.

use core::ops::{Add, Mul, Sub};

use glam::Vec3;

use super::table::{invert, then, Across, Path, CHILD_ADJ, CHILD_INVERTED, CHILD_VERTS, FACE_SUB};
use super::visit::neighbour;
use super::*;
use crate::builtin::{cube12, CUBE12_NODES, CUBE12_TETS};
use crate::ids::TetId;
use crate::mesh::template::FACE_VERTS;
use crate::mesh::{BuildOptions, FaceKey, Mesh, MeshStorage, Node, Tet};

/// A small f64 vector for the oracles (glam is built without f64 here).
#[derive(Clone, Copy, Debug, PartialEq)]
struct DVec3 {
    x: f64,
    y: f64,
    z: f64,
}

impl DVec3 {
    const fn new(x: f64, y: f64, z: f64) -> Self {
        Self { x, y, z }
    }
    fn of(v: Vec3) -> Self {
        Self::new(v.x as f64, v.y as f64, v.z as f64)
    }
    fn dot(self, o: Self) -> f64 {
        self.x * o.x + self.y * o.y + self.z * o.z
    }
    fn cross(self, o: Self) -> Self {
        Self::new(
            self.y * o.z - self.z * o.y,
            self.z * o.x - self.x * o.z,
            self.x * o.y - self.y * o.x,
        )
    }
    fn distance(self, o: Self) -> f64 {
        let d = self - o;
        libm::sqrt(d.dot(d))
    }
}

impl Add for DVec3 {
    type Output = Self;
    fn add(self, o: Self) -> Self {
        Self::new(self.x + o.x, self.y + o.y, self.z + o.z)
    }
}

impl Sub for DVec3 {
    type Output = Self;
    fn sub(self, o: Self) -> Self {
        Self::new(self.x - o.x, self.y - o.y, self.z - o.z)
    }
}

impl Mul<f64> for DVec3 {
    type Output = Self;
    fn mul(self, k: f64) -> Self {
        Self::new(self.x * k, self.y * k, self.z * k)
    }
}

/// An irregular positively oriented tet.
fn tet() -> [DVec3; 4] {
    [
        DVec3::new(0.1, -0.2, 0.05),
        DVec3::new(1.3, 0.1, -0.1),
        DVec3::new(0.2, 1.1, 0.3),
        DVec3::new(0.4, 0.3, 1.7),
    ]
}

fn det(p: [DVec3; 4]) -> f64 {
    (p[1] - p[0]).cross(p[2] - p[0]).dot(p[3] - p[0])
}

/// Children by midpoints of the parent's corners, written from Bey's paper independently of
/// `CHILD_VERTS` (as names).
fn children(p: [DVec3; 4]) -> [[DVec3; 4]; 8] {
    let m = |i: usize, j: usize| (p[i] + p[j]) * 0.5;
    [
        [p[0], m(0, 1), m(0, 2), m(0, 3)],
        [m(0, 1), p[1], m(1, 2), m(1, 3)],
        [m(0, 2), m(1, 2), p[2], m(2, 3)],
        [m(0, 3), m(1, 3), m(2, 3), p[3]],
        [m(0, 1), m(0, 2), m(0, 3), m(1, 3)],
        [m(0, 1), m(0, 2), m(1, 2), m(1, 3)],
        [m(0, 2), m(0, 3), m(1, 3), m(2, 3)],
        [m(0, 2), m(1, 2), m(1, 3), m(2, 3)],
    ]
}

fn face(p: [DVec3; 4], f: u8) -> [DVec3; 3] {
    FACE_VERTS[f as usize].map(|k| p[k as usize])
}

fn same(a: DVec3, b: DVec3) -> bool {
    a.distance(b) < 1e-12
}

#[test]
fn child_table_matches_geometry() {
    let p = tet();
    let ch = children(p);
    for c in 0..8 {
        // Vertex table, volume and orientation.
        for k in 0..4 {
            let (a, b) = CHILD_VERTS[c][k];
            assert!(same(ch[c][k], (p[a as usize] + p[b as usize]) * 0.5));
        }
        let ratio = det(ch[c]) / det(p);
        assert!((ratio.abs() - 0.125).abs() < 1e-12, "child {c} volume");
        assert_eq!(ratio < 0.0, CHILD_INVERTED[c], "child {c} orientation");
        for f in 0..4u8 {
            let fc = face(ch[c], f);
            // Does the face lie on a parent face? (All three points off the opposite vertex.)
            let on: [bool; 4] = core::array::from_fn(|pf| {
                let pp = face(p, pf as u8);
                let n = (pp[1] - pp[0]).cross(pp[2] - pp[0]);
                fc.iter().all(|&x| (x - pp[0]).dot(n).abs() < 1e-12)
            });
            match CHILD_ADJ[c][f as usize] {
                Across::Outside {
                    face: pf,
                    pos,
                    sigma,
                } => {
                    assert!(
                        on[pf as usize],
                        "child {c} face {f} not on parent face {pf}"
                    );
                    let pp = face(p, pf);
                    for k in 0..3 {
                        let a = sigma[k] as usize;
                        let expect = if pos == 3 {
                            // Centre: the midpoint opposite parent corner a.
                            (pp[(a + 1) % 3] + pp[(a + 2) % 3]) * 0.5
                        } else {
                            (pp[pos as usize] + pp[a]) * 0.5
                        };
                        assert!(same(fc[k], expect), "child {c} face {f} sigma");
                    }
                    // FACE_SUB is the inverse.
                    let (c2, f2, s2) = FACE_SUB[pf as usize][pos as usize];
                    assert_eq!((c2 as usize, f2, s2), (c, f, sigma));
                }
                Across::Sibling(c2, f2, pi) => {
                    assert!(on.iter().all(|o| !o), "child {c} face {f} is on the parent");
                    let fo = face(ch[c2 as usize], f2);
                    for k in 0..3 {
                        assert!(same(fc[k], fo[pi[k] as usize]), "child {c} face {f} pi");
                    }
                    // Symmetric.
                    assert_eq!(
                        CHILD_ADJ[c2 as usize][f2 as usize],
                        Across::Sibling(c as u8, f, invert(pi))
                    );
                }
            }
        }
    }
}

#[test]
fn perms_compose() {
    let p = [2, 0, 1];
    assert_eq!(then(p, invert(p)), [0, 1, 2]);
    assert_eq!(then(invert(p), p), [0, 1, 2]);
}

#[test]
fn paths_roundtrip() {
    for i in [0u32, 1, 8, 9, 64, 72, 73, 585, 1_227_133_511] {
        let p = Path::of_index(i).unwrap();
        assert_eq!(p.prefix_index(p.depth as usize), i);
        if i > 0 {
            // The parent is (i-1)/8 (not floor(i/8): that is wrong for i = 8k).
            assert_eq!(p.prefix_index(p.depth as usize - 1), (i - 1) / 8);
        }
    }
    assert_eq!(Path::of_index(8).unwrap().depth, 1);
    assert_eq!(Path::of_index(9).unwrap().depth, 2);
    assert!(Path::of_index(u32::MAX).is_none());
}

struct Cube {
    pos: [Vec3; CUBE12_NODES],
    nodes: [Node; CUBE12_NODES],
    normals: [Vec3; CUBE12_NODES],
    tets: [Tet; CUBE12_TETS],
}

fn cube() -> (Cube, [[u32; 4]; CUBE12_TETS]) {
    let (pos, t) = cube12();
    let c = Cube {
        pos,
        nodes: [Node::default(); CUBE12_NODES],
        normals: [Vec3::ZERO; CUBE12_NODES],
        tets: [Tet::default(); CUBE12_TETS],
    };
    (c, t)
}

fn build<'a>(c: &'a mut Cube, t: &[[u32; 4]]) -> Mesh<'a> {
    let mut scratch = [FaceKey::default(); 4 * CUBE12_TETS];
    Mesh::build(
        &mut c.pos,
        t,
        MeshStorage {
            nodes: &mut c.nodes,
            normals: &mut c.normals,
            tets: &mut c.tets,
        },
        &mut scratch,
        BuildOptions::default(),
    )
    .unwrap()
}

/// Node positions by midpoint descent in f64 (independent of `node_positions`).
fn node_f64(mesh: &Mesh<'_>, tet: TetId, path: &Path) -> [DVec3; 4] {
    let mut p = mesh.tet_positions(tet).map(DVec3::of);
    for k in 1..=path.depth as usize {
        p = children(p)[path.digit(k) as usize];
    }
    p
}

#[test]
fn neighbours_by_digits_match_geometry() {
    let (mut c, t) = cube();
    let mesh = build(&mut c, &t);
    let mut checked = 0;
    for tet in 0..CUBE12_TETS {
        let tet = TetId::from_idx(tet);
        // Every node at depths 0..=2.
        for index in 0..(1 + 8 + 64) {
            let path = Path::of_index(index).unwrap();
            let p = node_f64(&mesh, tet, &path);
            for f in 0..4u8 {
                let fc = face(p, f);
                match neighbour(&mesh, tet, &path, f) {
                    None => assert!(mesh.is_boundary_face(tet, FACE_ROOT(&path, f))),
                    Some(nb) => {
                        assert_eq!(nb.path.depth, path.depth);
                        assert!(nb.tet != tet || nb.path.index != path.index);
                        let q = node_f64(&mesh, nb.tet, &nb.path);
                        let fo = face(q, nb.face);
                        for k in 0..3 {
                            assert!(same(fc[k], fo[nb.pi[k] as usize]), "{tet:?} {index} {f}");
                        }
                        // The neighbour lies on the other side.
                        let n = (fc[1] - fc[0]).cross(fc[2] - fc[0]);
                        let side = |x: [DVec3; 4]| {
                            ((x[0] + x[1] + x[2] + x[3]) * 0.25 - fc[0]).dot(n).signum()
                        };
                        assert_eq!(side(p), -side(q));
                        checked += 1;
                    }
                }
            }
        }
    }
    assert!(checked > 3000);
}

/// The root face a node face lies on, or 4 when interior (test helper).
#[allow(non_snake_case)]
fn FACE_ROOT(path: &Path, f: u8) -> u8 {
    let mut face = f;
    for k in (1..=path.depth as usize).rev() {
        match CHILD_ADJ[path.digit(k) as usize][face as usize] {
            Across::Outside { face: pf, .. } => face = pf,
            Across::Sibling(..) => return 4,
        }
    }
    face
}

#[test]
fn node_positions_are_exact_midpoints() {
    let (mut c, t) = cube();
    let mesh = build(&mut c, &t);
    let path = Path::of_index(8 * 8 + 5).unwrap();
    let a = node_positions(&mesh, TetId(3), &path);
    let b = node_f64(&mesh, TetId(3), &path);
    for k in 0..4 {
        assert!(DVec3::of(a[k]).distance(b[k]) < 1e-7);
    }
}

#[test]
fn tiny_arena_saturates_and_stays_valid() {
    let (mut c, t) = cube();
    let mesh = build(&mut c, &t);
    let mut roots = [HNode::LEAF; CUBE12_TETS];
    let mut arena = [HNode::LEAF; 16];
    let mut vlist = [VEntry::default(); CUBE12_TETS + 14];
    let mut h = Hierarchy::new(
        &mesh,
        HierarchyStorage {
            roots: &mut roots,
            arena: &mut arena,
            vlist: &mut vlist,
        },
    )
    .unwrap();
    assert_eq!(h.visible_face_count(), 12);
    h.validate(&mesh).unwrap();
    h.refine(&mesh, TetId(0), 0).unwrap();
    h.validate(&mesh).unwrap();
    assert_eq!(h.visible_face_count(), 12 - 1 + 4);
    h.refine(&mesh, TetId(0), 1).unwrap();
    h.validate(&mesh).unwrap();
    assert_eq!(h.refine(&mesh, TetId(0), 2), Err(HierarchyError::Full));
    assert_eq!(h.saturations(), 1);
    h.validate(&mesh).unwrap();
    assert_eq!(h.refine(&mesh, TetId(0), 0), Err(HierarchyError::NotLeaf));
    assert_eq!(
        h.refine(&mesh, TetId(0), 100),
        Err(HierarchyError::NotFound)
    );
    // Erasing still works when the arena is full; it never needs storage.
    h.erase(&mesh, TetId(0), 9).unwrap();
    h.validate(&mesh).unwrap();
    assert_eq!(h.erase(&mesh, TetId(0), 9), Err(HierarchyError::Erased));
    assert_eq!(h.refine(&mesh, TetId(0), 9), Err(HierarchyError::Erased));
    let v = crate::geom::tet_volume(mesh.tet_positions(TetId(0))) as f64 / 64.0;
    assert!((h.removed_volume() - v).abs() < 1e-9);
    // Erasing a whole coarse tet exposes the faces of its neighbours.
    h.erase(&mesh, TetId(5), 0).unwrap();
    h.validate(&mesh).unwrap();
    let mut scratch = [0u32; CUBE12_TETS + 16];
    assert_eq!(h.components(&mesh, &mut scratch).unwrap(), 1);
    assert!(h.components(&mesh, &mut scratch[..3]).is_err());
}

#[test]
fn storage_checks() {
    let (mut c, t) = cube();
    let mesh = build(&mut c, &t);
    let mut roots = [HNode::LEAF; CUBE12_TETS];
    let mut arena = [HNode::LEAF; 16];
    let mut vlist = [VEntry::default(); CUBE12_TETS + 13];
    let r = Hierarchy::new(
        &mesh,
        HierarchyStorage {
            roots: &mut roots,
            arena: &mut arena,
            vlist: &mut vlist,
        },
    );
    assert!(matches!(
        r,
        Err(HierarchyError::StorageTooSmall { what: "vlist", .. })
    ));
    let mut roots = [HNode::LEAF; 3];
    let mut vlist = [VEntry::default(); 40];
    let r = Hierarchy::new(
        &mesh,
        HierarchyStorage {
            roots: &mut roots,
            arena: &mut [],
            vlist: &mut vlist,
        },
    );
    assert!(matches!(
        r,
        Err(HierarchyError::StorageTooSmall { what: "roots", .. })
    ));
}
