//! Unit tests: the const tables against a brute-force geometric derivation, the digit walks,
//! and the tiny-capacity branches.

use core::ops::{Add, Mul, Sub};

use glam::Vec3;

use super::table::{invert, then, Across, Path, CHILD_ADJ, CHILD_INVERTED, CHILD_VERTS, FACE_SUB};
use super::visit::neighbour;
use super::*;
use crate::builtin::{cube12, CUBE12_NODES, CUBE12_TETS};
use crate::hierarchy::test_support::cube_hierarchy;
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
    cube_hierarchy!(h, &mesh, 16);
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
            changes: &mut [],
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
            changes: &mut [],
        },
    );
    assert!(matches!(
        r,
        Err(HierarchyError::StorageTooSmall { what: "roots", .. })
    ));
}

/// Everything observable of a hierarchy that must not depend on whether wholly erased
/// subtrees were given back: the visible triangles (by name and corner bits), the v_list as a
/// set, the counters, the removed volume and the number of pieces.
fn observed(h: &Hierarchy<'_>, mesh: &Mesh<'_>) -> ([u64; 6], u32, u64, u32) {
    // Order-independent sums of hashes of each visible triangle and v_list entry.
    let mix = |mut x: u64| {
        x ^= x >> 33;
        x = x.wrapping_mul(0xff51_afd7_ed55_8ccd);
        x ^= x >> 33;
        x = x.wrapping_mul(0xc4ce_b9fe_1a85_ec53);
        x ^ (x >> 33)
    };
    let mut tri = [0u64; 6];
    h.for_each_visible(mesh, |t| {
        let key = ((t.tet.0 as u64) << 40) ^ ((t.index as u64) << 4) ^ t.face as u64;
        tri[0] = tri[0].wrapping_add(mix(key));
        for (k, c) in t.corners.iter().enumerate() {
            let bits = (c.x.to_bits() as u64)
                ^ ((c.y.to_bits() as u64) << 21)
                ^ (c.z.to_bits() as u64) << 42;
            tri[1 + k] = tri[1 + k].wrapping_add(mix(bits ^ key));
        }
        tri[4] += 1;
    });
    for e in h.vlist() {
        tri[5] = tri[5].wrapping_add(mix(((e.tet.0 as u64) << 32) ^ e.index as u64));
    }
    let mut scratch = [0u32; CUBE12_TETS + 64];
    let pieces = h.components(mesh, &mut scratch).unwrap();
    (
        tri,
        h.visible_face_count(),
        h.removed_volume().to_bits(),
        pieces,
    )
}

#[test]
fn wholly_erased_blocks_are_taken_back_when_the_arena_is_full() {
    let (mut c, t) = cube();
    let mesh = build(&mut c, &t);
    // `h`: two blocks; `twin`: room for everything, never takes a block back.
    cube_hierarchy!(h, &mesh, 16);
    cube_hierarchy!(twin, &mesh, 64);
    let t0 = TetId(0);
    let both = |op: &dyn Fn(&mut Hierarchy<'_>) -> Result<OpReport, HierarchyError>,
                h: &mut Hierarchy<'_>,
                twin: &mut Hierarchy<'_>| {
        let a = op(h).map(|_| ());
        let b = op(twin).map(|_| ());
        assert_eq!(a, b);
        h.validate(&mesh).unwrap();
        twin.validate(&mesh).unwrap();
        assert_eq!(observed(h, &mesh), observed(twin, &mesh));
    };
    both(&|x| x.refine(&mesh, t0, 0), &mut h, &mut twin);
    both(&|x| x.refine(&mesh, t0, 1), &mut h, &mut twin);
    assert_eq!(
        (h.arena_used(), h.arena_live(), h.arena_reclaimable()),
        (16, 16, 0)
    );
    // Full, and nothing to take back: refused and counted.
    assert_eq!(h.refine(&mesh, t0, 2), Err(HierarchyError::Full));
    assert_eq!(h.saturations(), 1);
    h.validate(&mesh).unwrap();
    // Erase the eight children of node 1 (tree indices 9..=16): their block is wholly
    // erased, node 1 is hollow; nothing is freed yet (references stay valid).
    for i in 9..=16 {
        both(&|x| x.erase(&mesh, t0, i), &mut h, &mut twin);
    }
    assert_eq!(
        (h.arena_used(), h.arena_live(), h.arena_reclaimable()),
        (16, 8, 8)
    );
    assert_eq!(h.reclaimed(), 0);
    assert!(h.find(t0, 9).is_some());
    // Refining node 2 takes that block back: node 1 becomes an erased leaf.
    both(&|x| x.refine(&mesh, t0, 2), &mut h, &mut twin);
    assert_eq!(h.reclaimed(), 1);
    assert_eq!(
        (h.arena_used(), h.arena_live(), h.arena_reclaimable()),
        (16, 16, 0)
    );
    let n1 = h.node(h.find(t0, 1).unwrap()).unwrap();
    assert!(n1.is_leaf() && n1.erased());
    assert_eq!(h.find(t0, 9), None);
    assert_eq!(h.erase(&mesh, t0, 9), Err(HierarchyError::NotFound));
    assert_eq!(h.erase(&mesh, t0, 1), Err(HierarchyError::Erased));
    assert_eq!(h.refine(&mesh, t0, 1), Err(HierarchyError::Erased));
    // Erase the rest of tet 0: node 2's children (17..=24), then nodes 3..=8. Both blocks
    // are wholly erased, the root is hollow, and nothing of the arena holds material.
    for i in (17..=24).chain(3..=8) {
        both(&|x| x.erase(&mesh, t0, i), &mut h, &mut twin);
    }
    assert_eq!(
        (h.arena_used(), h.arena_live(), h.arena_reclaimable()),
        (16, 0, 16)
    );
    // Two more refinements elsewhere take the two blocks back, deepest first; then tet 0's
    // root is an erased leaf and the arena is full of the new material.
    both(&|x| x.refine(&mesh, TetId(5), 0), &mut h, &mut twin);
    assert_eq!(h.find(t0, 17), None);
    assert!(h.find(t0, 3).is_some());
    both(&|x| x.refine(&mesh, TetId(6), 0), &mut h, &mut twin);
    assert_eq!(h.reclaimed(), 3);
    assert_eq!(h.find(t0, 1), None);
    let root = h.node(t0.0).unwrap();
    assert!(root.is_leaf() && root.erased());
    assert_eq!(
        (h.arena_used(), h.arena_live(), h.arena_reclaimable()),
        (16, 16, 0)
    );
    assert_eq!(h.refine(&mesh, TetId(7), 0), Err(HierarchyError::Full));
    assert_eq!(h.saturations(), 2);
    // Erasing into a collapsed region and across it still gives the twin's faces.
    both(&|x| x.erase(&mesh, TetId(5), 3), &mut h, &mut twin);
    for c in 1..=8 {
        both(&|x| x.erase(&mesh, TetId(6), c), &mut h, &mut twin);
    }
    assert_eq!(h.arena_reclaimable(), 8);
    // A reset forgets the list too.
    h.reset(&mesh);
    h.validate(&mesh).unwrap();
    assert_eq!((h.arena_used(), h.arena_live(), h.reclaimed()), (0, 0, 0));
}

/// The ten points of a refinement, shared by the eight children (the drill's queue and the
/// contact walk use them), are each child's own packed corners and positions bit for bit:
/// every child of every node down to depth 5 along random paths of every cube tet, against
/// `child_packed` (the children's rows one by one), `positions_packed` of those rows and
/// `node_positions` of the child's path (unpacked weights in the corners' canonical order).
#[test]
fn shared_refinement_points_are_each_childs_own_bits() {
    use super::geometry::{
        child_of_refinement, child_packed, refinement_points, refinement_points_masked, RootFrame,
        CHILD_POINTS,
    };
    let (mut c, t) = cube();
    let mesh = build(&mut c, &t);
    let mut seed = 7u32;
    for tet in 0..CUBE12_TETS {
        let frame = RootFrame::of(&mesh, TetId::from_idx(tet)).unwrap();
        for _ in 0..20 {
            let mut bary = frame.root_packed();
            let mut path = Path::ROOT;
            for depth in 0..5u8 {
                let (rows, pts) = refinement_points(&frame, &bary, depth);
                // Only the corners of some children (the contact walk's masked form): those
                // children's entries are the full evaluation's, bit for bit.
                let kids = (seed >> 8) as u8 | 1;
                let need = (0..8)
                    .filter(|c| kids & (1 << c) != 0)
                    .fold(0u16, |m, c| m | CHILD_POINTS[c]);
                let (mut mrows, mut mpts) = ([u64::MAX; 10], [Vec3::NAN; 10]);
                refinement_points_masked(&frame, &bary, depth, need, &mut mrows, &mut mpts);
                for ch in (0..8u8).filter(|c| kids & (1 << c) != 0) {
                    let (b, p) = child_of_refinement(&mrows, &mpts, ch);
                    let (fb, fp) = child_of_refinement(&rows, &pts, ch);
                    assert_eq!(b, fb);
                    assert_eq!(
                        p.map(|v| v.to_array().map(f32::to_bits)),
                        fp.map(|v| v.to_array().map(f32::to_bits))
                    );
                }
                for ch in 0..8u8 {
                    let own = child_packed(&bary, ch);
                    let (b, p) = child_of_refinement(&rows, &pts, ch);
                    assert_eq!(b, own);
                    // The packed lanes against the path's own coordinates, unpacked through
                    // the corner order (`node_positions`).
                    let q = frame.positions_packed(&own, depth + 1);
                    let child = path.child(ch).unwrap();
                    let r = node_positions(&mesh, TetId::from_idx(tet), &child);
                    for k in 0..4 {
                        let bits = |v: Vec3| v.to_array().map(f32::to_bits);
                        assert_eq!(bits(p[k]), bits(q[k]));
                        assert_eq!(bits(p[k]), bits(r[k]));
                    }
                }
                seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
                let ch = (seed >> 29) as u8;
                bary = child_packed(&bary, ch);
                path = path.child(ch).unwrap();
            }
        }
    }
}

/// `visit_across_from` (sibling faces start at the block's entry) meets the same leaves, in
/// the same order, with the same records and work, as `visit_across` (through the tree table
/// and a descent from the root), for every node and face of a randomly refined and eroded
/// cube.
#[test]
fn visits_from_a_known_node_match_the_table_walk() {
    use super::visit::{visit_across, visit_across_from, Met, Side};
    let (mut c, t) = cube();
    let mesh = build(&mut c, &t);
    cube_hierarchy!(h, &mesh, 8192);
    let mut seed = 0x2545_f491_4f6c_dd1du64;
    let mut next = |n: u32| {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        (seed >> 33) as u32 % n
    };
    // Refine random leaves down to depth 4, then erase about a third of the leaves.
    for _ in 0..300 {
        let tet = TetId(next(CUBE12_TETS as u32));
        let mut index = 0u32;
        while let Some(r) = h.find(tet, index) {
            let n = h.node(r).unwrap();
            if n.is_leaf() {
                if Path::depth_of(index).unwrap() < 4 && !n.erased() {
                    let _ = h.refine(&mesh, tet, index);
                }
                break;
            }
            index = index * 8 + 1 + next(8);
        }
    }
    // Every node of every tree (depth first, explicit stack).
    let mut nodes = [(TetId(0), 0u32, 0u32); CUBE12_TETS + 8192];
    let mut count = 0usize;
    for ti in 0..CUBE12_TETS as u32 {
        let mut stack = [0u32; 64];
        let mut top = 1usize;
        while top > 0 {
            top -= 1;
            let index = stack[top];
            let Some(r) = h.find(TetId(ti), index) else {
                continue;
            };
            if !h.node(r).unwrap().is_leaf() {
                for c in 1..=8 {
                    stack[top] = index * 8 + c;
                    top += 1;
                }
            }
            nodes[count] = (TetId(ti), index, r);
            count += 1;
        }
    }
    let nodes = &nodes[..count];
    for &(tet, index, r) in nodes {
        if h.node(r).unwrap().is_leaf() && next(3) == 0 {
            let _ = h.erase(&mesh, tet, index);
        }
    }
    h.validate(&mesh).unwrap();
    let mut siblings = 0;
    for &(tet, index, r) in nodes {
        let path = Path::of_index(index).unwrap();
        for f in 0..4u8 {
            // The leaves met, in order (at most 4^4 across one face down to depth 4).
            let mut a = [None::<Met>; 300];
            let mut b = [None::<Met>; 300];
            let (mut na, mut nb, mut wa, mut wb) = (0usize, 0usize, 0u32, 0u32);
            let sa = visit_across(&mut &h, &mesh, tet, &path, f, &mut wa, |_, m| {
                a[na] = Some(m);
                na += 1;
                true
            });
            let sb = visit_across_from(&mut &h, &mesh, tet, (&path, r), f, &mut wb, |_, m| {
                b[nb] = Some(m);
                nb += 1;
                true
            });
            assert_eq!(
                (sa, na, a),
                (sb, nb, b),
                "tet {} index {index} face {f}",
                tet.0
            );
            assert!(wb <= wa);
            if wb < wa {
                siblings += 1;
                assert_ne!(sa, Side::Boundary);
            }
        }
    }
    // The shortcut was taken (a sibling face at depth >= 1 skips the descent).
    assert!(siblings > 100, "{siblings}");
}

/// `keep_face` against a brute force: after any stream of offers (repeats, ties, every
/// order), the list holds the `KEEP` smallest distinct faces by (distance, face), in that
/// order. Each face has one distance here (as in a search, which measures a face once).
#[test]
fn keep_face_holds_the_nearest_distinct_faces_in_order() {
    let mut seed = 0x9e37_79b9_7f4a_7c15u64;
    let mut next = |n: u32| {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        (seed >> 33) as u32 % n
    };
    let face = |i: u32| VisibleTri {
        tet: TetId(i / 8),
        index: i % 3,
        face: (i % 4) as u8,
        corners: [Vec3::splat(i as f32); 3],
    };
    // Few distances, so ties between different faces are common.
    let dist = |i: u32| ((i * 7) % 5) as f32 * 0.25;
    for round in 0..200 {
        let mut kept = Kept::new();
        let mut offered = [0u32; 40];
        let n = 1 + next(40) as usize;
        for o in offered.iter_mut().take(n) {
            *o = next(24);
            keep_face(&mut kept, dist(*o), face(*o));
            assert!(kept.len() <= KEEP);
        }
        let mut want = [(0.0f32, face(0)); 40];
        let mut m = 0;
        for &o in offered.iter().take(n) {
            if !want[..m].iter().any(|&(_, k)| k.key() == face(o).key()) {
                want[m] = (dist(o), face(o));
                m += 1;
            }
        }
        let want = &mut want[..m];
        want.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.key().cmp(&b.1.key())));
        let want = &want[..m.min(KEEP)];
        assert_eq!(kept.as_slice(), want, "round {round}");
    }
}

#[test]
fn a_path_deeper_than_the_table_has_no_neighbour() {
    let (mut c, t) = cube();
    let mesh = build(&mut c, &t);
    let tet = TetId(0);
    // The deepest path there is still has its neighbours (an interior face of a corner child
    // is a sibling's), so `None` below is the depth, not the face.
    let mut path = Path::ROOT;
    for _ in 0..MAX_DEPTH {
        path = path.child(0).unwrap();
    }
    assert!((0..4u8).any(|f| neighbour(&mesh, tet, &path, f).is_some()));
    for depth in [MAX_DEPTH as u8 + 1, 12, u8::MAX] {
        let deeper = Path { depth, ..path };
        for f in 0..4u8 {
            assert_eq!(
                neighbour(&mesh, tet, &deeper, f),
                None,
                "depth {depth} face {f}"
            );
        }
    }
}

/// Tree indices and the children's corners in integer barycentric coordinates of the root.
#[test]
fn path_indices_and_corners() {
    // Tree indices: the root is 0, the children of `i` are `8i + 1 ..= 8i + 8`.
    let p = Path::ROOT.child(2).unwrap().child(5).unwrap();
    assert_eq!((p.index, p.depth, &p.digits[..2]), (30, 2, &[2, 5][..]));
    assert_eq!(Path::of_index(30), Some(p));

    // Corners in integer barycentric coordinates of the root, scaled by 2^depth: T1 keeps
    // the root's vertex 0 and halves its edges from it, (x0, x01, x02, x03).
    let t1 = Path::ROOT.child(0).unwrap();
    assert_eq!(
        t1.bary(),
        [[2, 0, 0, 0], [1, 1, 0, 0], [1, 0, 1, 0], [1, 0, 0, 1]]
    );
    assert!(p.bary().iter().all(|row| row.iter().sum::<u32>() == 4));
}

/// Same-level neighbours inside one tet's tree, and a root's neighbours are the mesh's.
#[test]
fn neighbours_inside_a_tree_and_across_roots() {
    let (mut pos, tets) = cube12();
    let (mut nodes, mut normals) = ([Node::default(); CUBE12_NODES], [Vec3::ZERO; CUBE12_NODES]);
    let (mut recs, mut scratch) = ([Tet::default(); CUBE12_TETS], [FaceKey::default(); 48]);
    let storage = MeshStorage {
        nodes: &mut nodes,
        normals: &mut normals,
        tets: &mut recs,
    };
    let mesh = Mesh::build(
        &mut pos,
        &tets,
        storage,
        &mut scratch,
        BuildOptions::default(),
    )
    .unwrap();

    // T1 = (x0, x01, x02, x03) meets T5 = (x01, x02, x03, x13) across its face 0.
    let t = TetId(0);
    let t1 = Path::ROOT.child(0).unwrap();
    let n = neighbour(&mesh, t, &t1, 0).unwrap();
    assert_eq!((n.tet, n.path.index), (t, 5));

    // A root's neighbours are the mesh's: the next tet's root, or none on the boundary.
    for f in 0..4 {
        let across = neighbour(&mesh, t, &Path::ROOT, f).map(|n| n.tet);
        assert_eq!(across, Some(mesh.neighbour(t, f)).filter(|n| n.is_some()));
    }
}
