//! Drilling oracles: visible faces against a brute-force recomputation after random
//! Erase/Refine sequences (12-tet cube, generated block, the cow), volume conservation,
//! analytic removed volumes (plunge, pass, held sphere), determinism, and cut-off pieces.
//!
//! The brute force shares no code with the hierarchy: it takes only the tree shape and the
//! face bits (`for_each_leaf`), rebuilds every leaf's corners in f64 by its own midpoint
//! descent, and decides visibility by locating nudged sample points among the leaves.

use std::collections::{HashMap, HashSet};

use glam::Vec3;
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use tetradrill::owned::OwnedMesh;
use tetradrill_core::builtin::{block, block_counts, cube12};
use tetradrill_core::drill::{candidates_brute_force, Drill, DrillParams, Pending, Sphere};
use tetradrill_core::hierarchy::{HNode, Hierarchy, HierarchyStorage, VEntry};
use tetradrill_core::mesh::{BuildOptions, Mesh};
use tetradrill_core::TetId;

type D3 = [f64; 3];

fn sub(a: D3, b: D3) -> D3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
fn add(a: D3, b: D3) -> D3 {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}
fn scale(a: D3, k: f64) -> D3 {
    [a[0] * k, a[1] * k, a[2] * k]
}
fn dot(a: D3, b: D3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
fn cross(a: D3, b: D3) -> D3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
fn det(p: &[D3; 4]) -> f64 {
    dot(cross(sub(p[1], p[0]), sub(p[2], p[0])), sub(p[3], p[0]))
}
fn mid(a: D3, b: D3) -> D3 {
    scale(add(a, b), 0.5)
}

/// Bey's eight children by name (the test's own copy of the paper's list).
fn bey(p: &[D3; 4]) -> [[D3; 4]; 8] {
    let m = |i: usize, j: usize| mid(p[i], p[j]);
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

/// Face `i` opposite vertex `i`, as three corners (order irrelevant for the oracle).
fn face_of(p: &[D3; 4], f: usize) -> [D3; 3] {
    let o: Vec<usize> = (0..4).filter(|&k| k != f).collect();
    [p[o[0]], p[o[1]], p[o[2]]]
}

fn corners(mesh: &Mesh<'_>, tet: TetId, index: u32) -> ([D3; 4], u32) {
    let mut digits = Vec::new();
    let mut i = index;
    while i > 0 {
        digits.push(((i - 1) % 8) as usize);
        i = (i - 1) / 8;
    }
    let mut p = mesh
        .tet_positions(tet)
        .map(|v| [v.x as f64, v.y as f64, v.z as f64]);
    for &c in digits.iter().rev() {
        p = bey(&p)[c];
    }
    (p, digits.len() as u32)
}

struct LeafG {
    tet: TetId,
    index: u32,
    erased: bool,
    visible: u8,
    p: [D3; 4],
    depth: u32,
}

fn leaves(mesh: &Mesh<'_>, h: &Hierarchy<'_>, tets: impl Iterator<Item = usize>) -> Vec<LeafG> {
    let mut out = Vec::new();
    for t in tets {
        let tet = TetId::from_idx(t);
        h.for_each_leaf(tet, |l| {
            let (p, depth) = corners(mesh, tet, l.index);
            out.push(LeafG {
                tet,
                index: l.index,
                erased: l.record.erased(),
                visible: l.record.visible(),
                p,
                depth,
            });
        });
    }
    out
}

fn contains(p: &[D3; 4], x: D3) -> bool {
    let d = det(p);
    let b1 = det(&[p[0], x, p[2], p[3]]) / d;
    let b2 = det(&[p[0], p[1], x, p[3]]) / d;
    let b3 = det(&[p[0], p[1], p[2], x]) / d;
    let b0 = 1.0 - b1 - b2 - b3;
    let e = -1e-12;
    b0 >= e && b1 >= e && b2 >= e && b3 >= e
}

/// Centroids of the `4^k` sub-triangles of a triangle.
fn samples(t: [D3; 3], k: u32, out: &mut Vec<D3>) {
    if k == 0 {
        out.push(scale(add(add(t[0], t[1]), t[2]), 1.0 / 3.0));
        return;
    }
    let [a, b, c] = t;
    let (ab, bc, ca) = (mid(a, b), mid(b, c), mid(c, a));
    for s in [[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]] {
        samples(s, k - 1, out);
    }
}

/// Checks every non-erased leaf face of the trees `check` against the brute force; returns
/// the number of faces checked.
fn check_visible(mesh: &Mesh<'_>, h: &Hierarchy<'_>, check: &HashSet<usize>) -> usize {
    // Material to search: the checked trees and their coarse neighbours.
    let mut search: HashSet<usize> = check.clone();
    for &t in check {
        for f in 0..4 {
            let n = mesh.neighbour(TetId::from_idx(t), f);
            if n.is_some() {
                search.insert(n.idx());
            }
        }
    }
    let mut ids: Vec<usize> = search.into_iter().collect();
    ids.sort();
    let all = leaves(mesh, h, ids.into_iter());
    let finest = all.iter().map(|l| l.depth).max().unwrap_or(0);
    let mut by_tet: HashMap<usize, Vec<usize>> = HashMap::new();
    for (i, l) in all.iter().enumerate() {
        if !l.erased {
            by_tet.entry(l.tet.idx()).or_default().push(i);
        }
    }
    let mut checked = 0;
    let mut pts = Vec::new();
    for l in all
        .iter()
        .filter(|l| !l.erased && check.contains(&l.tet.idx()))
    {
        let t = l.tet;
        let mut near: Vec<usize> = by_tet.get(&t.idx()).cloned().unwrap_or_default();
        for f in 0..4 {
            let n = mesh.neighbour(t, f);
            if n.is_some() {
                near.extend(by_tet.get(&n.idx()).cloned().unwrap_or_default());
            }
        }
        for f in 0..4 {
            let tri = face_of(&l.p, f);
            let mut n = cross(sub(tri[1], tri[0]), sub(tri[2], tri[0]));
            if dot(n, sub(l.p[f], tri[0])) > 0.0 {
                n = scale(n, -1.0);
            }
            let len = dot(n, n).sqrt();
            let edge = dot(sub(tri[1], tri[0]), sub(tri[1], tri[0])).sqrt();
            let eps = 1e-4 * edge / (1u64 << (finest - l.depth)) as f64;
            pts.clear();
            samples(tri, finest - l.depth, &mut pts);
            let exposed = pts.iter().any(|&x| {
                let y = add(x, scale(n, eps / len));
                !near.iter().any(|&j| contains(&all[j].p, y))
            });
            let bit = l.visible & (1 << f) != 0;
            assert_eq!(
                bit, exposed,
                "tet {} index {} face {f}: hierarchy says {bit}, brute force {exposed}",
                t.0, l.index
            );
            checked += 1;
        }
    }
    checked
}

/// Sum of non-erased leaf volumes in f64 (own geometry).
fn material_volume(mesh: &Mesh<'_>, h: &Hierarchy<'_>) -> f64 {
    leaves(mesh, h, 0..mesh.tet_count())
        .iter()
        .filter(|l| !l.erased)
        .map(|l| det(&l.p).abs() / 6.0)
        .sum()
}

struct Store {
    roots: Vec<HNode>,
    arena: Vec<HNode>,
    vlist: Vec<VEntry>,
}

impl Store {
    fn new(tets: usize, arena: usize) -> Self {
        Self {
            roots: vec![HNode::LEAF; tets],
            arena: vec![HNode::LEAF; arena],
            vlist: vec![VEntry::default(); HierarchyStorage::vlist_needed(tets, arena)],
        }
    }
    fn hierarchy<'a>(&'a mut self, mesh: &Mesh<'_>) -> Hierarchy<'a> {
        Hierarchy::new(
            mesh,
            HierarchyStorage {
                roots: &mut self.roots,
                arena: &mut self.arena,
                vlist: &mut self.vlist,
            },
        )
        .unwrap()
    }
}

fn cube_mesh() -> OwnedMesh {
    let (p, t) = cube12();
    OwnedMesh::build(p.to_vec(), &t, BuildOptions::default()).unwrap()
}

fn block_mesh(n: usize, edge: f32) -> OwnedMesh {
    let (nn, nt) = block_counts(n);
    let mut p = vec![Vec3::ZERO; nn];
    let mut t = vec![[0u32; 4]; nt];
    block(n, edge, Vec3::ZERO, &mut p, &mut t).unwrap();
    OwnedMesh::build(p, &t, BuildOptions::default()).unwrap()
}

/// A minimal TetGen `.node`/`.ele` reader (the test's own, so it does not depend on the host's
/// mesh readers).
fn tetgen(rel: &str) -> OwnedMesh {
    let node = tetradrill_tests::mesh(rel);
    let ele = node.with_extension("ele");
    let nums = |path: &std::path::Path| -> Vec<Vec<f64>> {
        std::fs::read_to_string(path)
            .unwrap()
            .lines()
            .map(|l| l.split('#').next().unwrap_or(""))
            .filter(|l| !l.trim().is_empty())
            .map(|l| {
                l.split_whitespace()
                    .map(|w| w.parse::<f64>().unwrap())
                    .collect()
            })
            .collect()
    };
    let nrows = nums(&node);
    let erows = nums(&ele);
    let n = nrows[0][0] as usize;
    let base = nrows[1][0] as u32;
    let p: Vec<Vec3> = nrows[1..=n]
        .iter()
        .map(|r| Vec3::new(r[1] as f32, r[2] as f32, r[3] as f32))
        .collect();
    let m = erows[0][0] as usize;
    let t: Vec<[u32; 4]> = erows[1..=m]
        .iter()
        .map(|r| {
            [
                r[1] as u32 - base,
                r[2] as u32 - base,
                r[3] as u32 - base,
                r[4] as u32 - base,
            ]
        })
        .collect();
    OwnedMesh::build(p, &t, BuildOptions::default()).unwrap()
}

/// The tets of `pool` and their face neighbours: where an operation on a pool tree can change
/// the visible faces.
fn with_neighbours(mesh: &Mesh<'_>, pool: &[usize]) -> HashSet<usize> {
    let mut check: HashSet<usize> = pool.iter().copied().collect();
    for &t in pool {
        for f in 0..4 {
            let n = mesh.neighbour(TetId::from_idx(t), f);
            if n.is_some() {
                check.insert(n.idx());
            }
        }
    }
    check
}
/// Random Erase/Refine on the leaves of the trees in `pool`, checking `validate` after every
/// operation and the brute force every `every` operations.
fn random_ops(
    mesh: &Mesh<'_>,
    h: &mut Hierarchy<'_>,
    pool: &[usize],
    ops: usize,
    max_depth: u32,
    every: usize,
    seed: u64,
) {
    let mut rng = StdRng::seed_from_u64(seed);
    let vol0 = mesh.volume();
    let check = with_neighbours(mesh, pool);
    let mut checked = 0;
    for op in 0..ops {
        let live: Vec<LeafG> = leaves(mesh, h, pool.iter().copied())
            .into_iter()
            .filter(|l| !l.erased)
            .collect();
        if live.is_empty() {
            break;
        }
        let l = &live[rng.gen_range(0..live.len())];
        if l.depth < max_depth && rng.gen_bool(0.6) {
            h.refine(mesh, l.tet, l.index).unwrap();
        } else {
            h.erase(mesh, l.tet, l.index).unwrap();
        }
        h.validate(mesh).unwrap();
        if op % every == every - 1 {
            checked += check_visible(mesh, h, &check);
            // Refinement conserves volume; erasure removes exactly the erased leaves.
            let left = material_volume(mesh, h);
            assert!((left + h.removed_volume() - vol0).abs() < 1e-6 * vol0.max(1.0));
        }
    }
    assert!(checked > 0);
}

#[test]
fn visible_faces_match_brute_force_on_the_cube() {
    let mut om = cube_mesh();
    let mesh = om.view();
    for seed in 0..4 {
        let mut st = Store::new(mesh.tet_count(), 8 * 400);
        let mut h = st.hierarchy(&mesh);
        let pool: Vec<usize> = (0..mesh.tet_count()).collect();
        random_ops(&mesh, &mut h, &pool, 80, 3, 8, seed);
    }
}

#[test]
fn visible_faces_match_brute_force_on_a_block() {
    let mut om = block_mesh(2, 0.5);
    let mesh = om.view();
    let mut st = Store::new(mesh.tet_count(), 8 * 600);
    let mut h = st.hierarchy(&mesh);
    let pool: Vec<usize> = (0..mesh.tet_count()).collect();
    random_ops(&mesh, &mut h, &pool, 150, 2, 10, 7);
}

#[test]
fn visible_faces_match_brute_force_on_the_cow() {
    let mut om = tetgen("models/spot_tetgen_q1.414.node");
    let mesh = om.view();
    let mut st = Store::new(mesh.tet_count(), 8 * 600);
    let mut h = st.hierarchy(&mesh);
    // A cluster of tets at the surface: a boundary tet and its neighbours' neighbours.
    let start = (0..mesh.tet_count())
        .find(|&t| (0..4).any(|f| mesh.is_boundary_face(TetId::from_idx(t), f)))
        .unwrap();
    let mut pool = vec![start];
    for _ in 0..2 {
        let mut next = pool.clone();
        for &t in &pool {
            for f in 0..4 {
                let n = mesh.neighbour(TetId::from_idx(t), f);
                if n.is_some() && !next.contains(&n.idx()) {
                    next.push(n.idx());
                }
            }
        }
        pool = next;
    }
    random_ops(&mesh, &mut h, &pool, 120, 2, 12, 3);
}

/// Drills a sequence of sphere positions (one per tick), then holds the last one until the
/// pending work is done. Returns the hierarchy's removed volume and a digest of the state.
fn drill_path(
    mesh: &Mesh<'_>,
    centres: &[Vec3],
    radius: f32,
    max_depth: u8,
    budget: u32,
) -> (f64, u64) {
    let mut st = Store::new(mesh.tet_count(), 8 << 20);
    let mut h = st.hierarchy(mesh);
    let mut queue = vec![Pending::default(); 1 << 16];
    let mut drill = Drill::new(&mut queue);
    let params = DrillParams {
        max_depth,
        min_area: 0.0,
        budget,
    };
    let mut cand = vec![TetId::NONE; mesh.tet_count()];
    let mut sum = 0.0;
    let mut i = 0;
    loop {
        let c = centres[i.min(centres.len() - 1)];
        let s = [Sphere { center: c, radius }];
        let n = candidates_brute_force(mesh, &s, &mut cand);
        let r = drill.step(&mut h, mesh, &cand[..n], &s, &params);
        sum += r.removed_volume;
        i += 1;
        if i >= centres.len() && r.pending == 0 {
            break;
        }
        assert!(i < centres.len() + 100_000, "the hold must finish the work");
    }
    assert_eq!(h.saturations(), 0);
    assert_eq!(drill.saturations(), 0);
    assert!((sum - h.removed_volume()).abs() < 1e-9);
    // Digest: counts and the bits of every visible triangle.
    let mut d: u64 = 0xcbf2_9ce4_8422_2325;
    let mut mix = |x: u64| d = (d ^ x).wrapping_mul(0x0100_0000_01b3);
    mix(h.node_count() as u64);
    mix(h.visible_face_count() as u64);
    mix(h.removed_volume().to_bits());
    h.for_each_visible(mesh, |t| {
        for c in t.corners {
            mix(c.x.to_bits() as u64);
            mix(c.y.to_bits() as u64);
            mix(c.z.to_bits() as u64);
        }
    });
    (h.removed_volume(), d)
}

fn line(a: Vec3, b: Vec3, step: f32) -> Vec<Vec3> {
    let n = ((b - a).length() / step).ceil().max(1.0) as usize;
    (0..=n)
        .map(|k| a + (b - a) * (k as f32 / n as f32))
        .collect()
}

#[test]
fn plunge_removes_cylinder_plus_hemisphere() {
    let mut om = block_mesh(4, 0.25); // the unit cube [0,1]^3
    let mesh = om.view();
    let (r, depth) = (0.2f32, 0.3f32);
    let path = line(
        Vec3::new(0.5, 0.5, 1.0 + r),
        Vec3::new(0.5, 0.5, 1.0 - depth),
        r / 20.0,
    );
    let pi = std::f64::consts::PI;
    let (r64, l64) = (r as f64, depth as f64);
    let exact = pi * r64 * r64 * l64 + 2.0 / 3.0 * pi * r64.powi(3);
    let mut errs = Vec::new();
    for max_depth in [3u8, 4, 6] {
        let (v, _) = drill_path(&mesh, &path, r, max_depth, 20_000);
        errs.push(((v - exact) / exact).abs());
    }
    eprintln!("plunge: exact {exact:.6}, relative errors at depths 3, 4, 6: {errs:?}");
    assert!(errs[2] <= 0.05, "depth 6 error {errs:?}");
    assert!(errs[2] < errs[0], "error must shrink with depth: {errs:?}");
}

#[test]
fn pass_along_a_face_removes_the_swept_half_capsule() {
    let mut om = block_mesh(4, 0.25);
    let mesh = om.view();
    // Sphere centre a = r/2 below the face z = 1, moving 0.4 along x.
    let (r, a, len) = (0.15f32, 0.075f32, 0.4f32);
    let z = 1.0 - a;
    let path = line(
        Vec3::new(0.3, 0.5, z),
        Vec3::new(0.3 + len, 0.5, z),
        r / 20.0,
    );
    let (r, a, l) = (r as f64, a as f64, len as f64);
    let pi = std::f64::consts::PI;
    let h = r - a;
    let segment = r * r * (a / r).acos() - a * (r * r - a * a).sqrt();
    let exact =
        l * (pi * r * r - segment) + 4.0 / 3.0 * pi * r.powi(3) - pi * h * h * (3.0 * r - h) / 3.0;
    let mut errs = Vec::new();
    for max_depth in [3u8, 6] {
        let (v, _) = drill_path(&mesh, &path, r as f32, max_depth, 20_000);
        errs.push(((v - exact) / exact).abs());
    }
    eprintln!("pass: exact {exact:.6}, relative errors at depths 3, 6: {errs:?}");
    assert!(errs[1] <= 0.05, "depth 6 error {errs:?}");
    assert!(errs[1] < errs[0], "error must shrink with depth: {errs:?}");
}

#[test]
fn held_sphere_removes_a_ball_and_runs_are_identical() {
    let mut om = block_mesh(4, 0.25);
    let mesh = om.view();
    let r = 0.2f32;
    let path = [Vec3::new(0.45, 0.52, 0.48)];
    let exact = 4.0 / 3.0 * std::f64::consts::PI * (r as f64).powi(3);
    let (v1, d1) = drill_path(&mesh, &path, r, 6, 5_000);
    let (v2, d2) = drill_path(&mesh, &path, r, 6, 5_000);
    eprintln!("held ball: removed {v1:.6}, exact {exact:.6}");
    assert!(((v1 - exact) / exact).abs() <= 0.05, "{v1} vs {exact}");
    assert_eq!(v1.to_bits(), v2.to_bits());
    assert_eq!(
        d1, d2,
        "the same sequence twice must give identical results"
    );
}

#[test]
fn drilled_surface_is_outward_and_near_query_is_a_subset() {
    let mut om = block_mesh(2, 0.5);
    let mesh = om.view();
    let mut st = Store::new(mesh.tet_count(), 8 << 14);
    let mut h = st.hierarchy(&mesh);
    let mut queue = vec![Pending::default(); 4096];
    let mut drill = Drill::new(&mut queue);
    let s = [Sphere {
        center: Vec3::new(0.5, 0.5, 1.0),
        radius: 0.3,
    }];
    let mut cand = vec![TetId::NONE; mesh.tet_count()];
    let n = candidates_brute_force(&mesh, &s, &mut cand);
    let params = DrillParams {
        max_depth: 3,
        min_area: 0.0,
        budget: u32::MAX,
    };
    drill.step(&mut h, &mesh, &cand[..n], &s, &params);
    h.validate(&mesh).unwrap();
    let check: HashSet<usize> = (0..mesh.tet_count()).collect();
    check_visible(&mesh, &h, &check);
    let mut all = HashSet::new();
    let mut count = 0;
    h.for_each_visible(&mesh, |t| {
        count += 1;
        let (p, _) = corners(&mesh, t.tet, t.index);
        let c: Vec<D3> = t
            .corners
            .iter()
            .map(|v| [v.x as f64, v.y as f64, v.z as f64])
            .collect();
        let n = cross(sub(c[1], c[0]), sub(c[2], c[0]));
        // The opposite corner lies behind the right-hand normal: it points out of the leaf.
        assert!(dot(n, sub(p[t.face as usize], c[0])) < 0.0);
        all.insert((t.tet, t.index, t.face));
    });
    assert_eq!(count, h.visible_face_count() as usize);
    let mut near = 0;
    h.for_each_visible_in(&mesh, &cand[..n], Some((s[0].center, s[0].radius)), |t| {
        assert!(all.contains(&(t.tet, t.index, t.face)));
        near += 1;
    });
    assert!(near > 0 && near < count);
    // Drilling removed material and exposed the inside of the crater.
    assert!(h.removed_volume() > 0.0 && h.visible_face_count() > 24);
}

#[test]
fn a_piece_cut_off_is_counted() {
    let mut om = block_mesh(2, 0.5); // [0,1]^3
    let mesh = om.view();
    let mut st = Store::new(mesh.tet_count(), 8 * 48 * 9);
    let mut h = st.hierarchy(&mesh);
    let mut scratch = vec![0u32; 48 + 8 * 48 * 9];
    assert_eq!(h.components(&mesh, &mut scratch).unwrap(), 1);
    // Refine everything to depth 2.
    for t in 0..mesh.tet_count() {
        let tet = TetId::from_idx(t);
        h.refine(&mesh, tet, 0).unwrap();
        for c in 1..=8 {
            h.refine(&mesh, tet, c).unwrap();
        }
    }
    h.validate(&mesh).unwrap();
    assert_eq!(h.components(&mesh, &mut scratch).unwrap(), 1);
    // Erase a slab 0.35 < x < 0.65 of leaves (by centroid): two pieces remain.
    let slab: Vec<LeafG> = leaves(&mesh, &h, 0..mesh.tet_count())
        .into_iter()
        .filter(|l| {
            let x = (l.p[0][0] + l.p[1][0] + l.p[2][0] + l.p[3][0]) / 4.0;
            x > 0.35 && x < 0.65
        })
        .collect();
    for l in &slab {
        h.erase(&mesh, l.tet, l.index).unwrap();
    }
    h.validate(&mesh).unwrap();
    assert_eq!(h.components(&mesh, &mut scratch).unwrap(), 2);
    let check: HashSet<usize> = (0..mesh.tet_count()).collect();
    check_visible(&mesh, &h, &check);
}

/// Drills `spheres` queued together in one step (as the runner does when the simulation lags
/// the servo), then empty steps until the work is done; returns the removed volume and the
/// nodes created.
fn drill_together(
    mesh: &Mesh<'_>,
    h: &mut Hierarchy<'_>,
    spheres: &[Sphere],
    max_depth: u8,
    budget: u32,
) -> (f64, u64) {
    let mut queue = vec![Pending::default(); 1 << 16];
    let mut drill = Drill::new(&mut queue);
    let params = DrillParams {
        max_depth,
        min_area: 0.0,
        budget,
    };
    let mut cand = vec![TetId::NONE; mesh.tet_count()];
    let n = candidates_brute_force(mesh, spheres, &mut cand);
    let mut created = 0u64;
    let mut r = drill.step(h, mesh, &cand[..n], spheres, &params);
    created += r.created as u64;
    let mut ticks = 0;
    while r.pending > 0 {
        r = drill.step(h, mesh, &cand[..n], &[], &params);
        created += r.created as u64;
        ticks += 1;
        assert!(ticks < 100_000, "the work must finish");
    }
    assert_eq!(h.saturations(), 0);
    assert_eq!(drill.saturations(), 0);
    (h.removed_volume(), created)
}

/// Spheres queued together erode their union and refine only its boundary: no refined node
/// lies inside any one sphere (each is erased whole, whichever sphere's work reaches it
/// first); the visible faces match the brute force; the removed volume matches a Monte Carlo
/// estimate of the union; and the shared work costs fewer nodes than the same spheres drilled
/// one after the other.
#[test]
fn spheres_queued_together_refine_only_the_union_boundary() {
    let mut om = block_mesh(4, 0.25); // the unit cube
    let mesh = om.view();
    let r = 0.15f32;
    let spheres: Vec<Sphere> = (0..6)
        .map(|k| Sphere {
            center: Vec3::new(0.3 + 0.25 * r * k as f32, 0.47, 0.52),
            radius: r,
        })
        .collect();
    let mut st = Store::new(mesh.tet_count(), 4 << 20);
    let mut h = st.hierarchy(&mesh);
    let (removed, created) = drill_together(&mesh, &mut h, &spheres, 4, 300);

    let union = check_drilled_union(&mesh, &h, &spheres, removed, 11);

    // 4. Drilled one after the other (each sphere's work done before the next is queued),
    //    every sphere refines its own shell: more nodes for the same union.
    let created_apart = drilled_one_at_a_time(&mesh, &spheres, union);
    eprintln!("nodes created: together {created}, one after the other {created_apart}");
    assert!(
        created * 4 < created_apart * 3,
        "together {created} vs apart {created_apart}"
    );
}

/// The nodes created drilling `spheres` at depth 4 one after the other (each sphere's work
/// done before the next is queued: every one refines its own shell); the removed volume is
/// checked against `union` (within 5 %).
fn drilled_one_at_a_time(mesh: &Mesh<'_>, spheres: &[Sphere], union: f64) -> u64 {
    let mut st = Store::new(mesh.tet_count(), 4 << 20);
    let mut h = st.hierarchy(mesh);
    let mut created = 0;
    for s in spheres {
        created += drill_together(mesh, &mut h, std::slice::from_ref(s), 4, 300).1;
    }
    assert!((h.removed_volume() - union).abs() / union < 0.05);
    created
}

/// What drilling the union of `spheres` (inside the unit cube) must leave, checked against
/// oracles of their own: 1. no inner node lies entirely inside one sphere (f64 corners, a
/// margin for f32 rounding), 2. the visible faces equal the brute force, 3. `removed` is
/// within 5 % of a Monte Carlo estimate of the union (sampled with `seed`), which is returned.
fn check_drilled_union(
    mesh: &Mesh<'_>,
    h: &Hierarchy<'_>,
    spheres: &[Sphere],
    removed: f64,
    seed: u64,
) -> f64 {
    // 1. No inner node entirely inside one sphere (f64 corners, a margin for f32 rounding).
    let mut inner: HashSet<(usize, u32)> = HashSet::new();
    for l in leaves(mesh, h, 0..mesh.tet_count()) {
        let mut i = l.index;
        while i > 0 {
            i = (i - 1) / 8;
            inner.insert((l.tet.idx(), i));
        }
    }
    assert!(
        inner.len() > 100,
        "the spheres must refine: {}",
        inner.len()
    );
    for &(t, i) in &inner {
        let (p, _) = corners(mesh, TetId::from_idx(t), i);
        for s in spheres {
            let c = [s.center.x as f64, s.center.y as f64, s.center.z as f64];
            let far = p
                .iter()
                .map(|q| dot(sub(*q, c), sub(*q, c)).sqrt())
                .fold(0.0, f64::max);
            assert!(
                far > s.radius as f64 - 1e-5,
                "node {i} of tet {t} was refined although it lies inside a sphere"
            );
        }
    }

    // 2. Visible faces against the brute force.
    let all: HashSet<usize> = (0..mesh.tet_count()).collect();
    check_visible(mesh, h, &all);

    // 3. Removed volume against a Monte Carlo estimate of the union (all inside the cube).
    let mut rng = StdRng::seed_from_u64(seed);
    let samples = 400_000;
    let hits = (0..samples)
        .filter(|_| {
            let x = Vec3::new(rng.gen(), rng.gen(), rng.gen());
            spheres.iter().any(|s| x.distance(s.center) <= s.radius)
        })
        .count();
    let union = hits as f64 / samples as f64;
    let rel = (removed - union).abs() / union;
    eprintln!(
        "union of {} spheres: removed {removed:.6}, Monte Carlo {union:.6} ({rel:.4})",
        spheres.len()
    );
    assert!(rel < 0.05, "removed {removed} vs union {union}");
    union
}

/// A drill far behind the burr (one sphere queued a tick on a path of 40, an eighth of the
/// radius apart, and a budget of 150 units that does a few spheres' work in those 40 ticks,
/// so most of them wait): the
/// spheres queued after an item's are its swept volume however far behind it is. No refined
/// node lies inside a sphere, the visible faces are exact, the union's volume is removed,
/// and it costs at most two thirds of the nodes of a drill that keeps up (each sphere finished
/// before the next: every one refines its own front shell, which the next erases; 68,288
/// against 138,216 nodes; the old rule: 95,400). Before 2026-11-24
/// the drill tested the last 16 spheres queued, and nodes inside the spheres right after the
/// one being worked were refined once it was more than 16 behind.
#[test]
fn a_drill_far_behind_erases_what_the_later_spheres_hold() {
    let mut om = block_mesh(4, 0.25); // the unit cube
    let mesh = om.view();
    let r = 0.15f32;
    let spheres: Vec<Sphere> = (0..40)
        .map(|k| Sphere {
            center: Vec3::new(0.16 + r / 8.0 * k as f32, 0.47, 0.52),
            radius: r,
        })
        .collect();
    let params = DrillParams {
        max_depth: 4,
        min_area: 0.0,
        budget: 150,
    };
    let mut cand = vec![TetId::NONE; mesh.tet_count()];
    let mut st = Store::new(mesh.tet_count(), 4 << 20);
    let mut h = st.hierarchy(&mesh);
    let mut queue = vec![Pending::default(); 1 << 16];
    let mut drill = Drill::new(&mut queue);
    let (mut created, mut most_pending) = (0u64, 0u32);
    for s in &spheres {
        let n = candidates_brute_force(&mesh, std::slice::from_ref(s), &mut cand);
        let r = drill.step(&mut h, &mesh, &cand[..n], std::slice::from_ref(s), &params);
        created += r.created as u64;
        most_pending = most_pending.max(r.pending);
    }
    let mut ticks = 0;
    loop {
        let r = drill.step(&mut h, &mesh, &[], &[], &params);
        created += r.created as u64;
        if r.pending == 0 {
            break;
        }
        ticks += 1;
        assert!(ticks < 1_000_000, "the work must finish");
    }
    assert_eq!(h.saturations() + drill.saturations(), 0);
    eprintln!(
        "lagging drill: {created} nodes, {ticks} ticks after the path, deque peak {most_pending}"
    );

    let union = check_drilled_union(&mesh, &h, &spheres, h.removed_volume(), 12);

    // 4. The same spheres, each finished before the next is queued.
    let created_apart = drilled_one_at_a_time(&mesh, &spheres, union);
    eprintln!("nodes created: lagging {created}, keeping up {created_apart}");
    assert!(
        created * 3 < created_apart * 2,
        "lagging {created} vs keeping up {created_apart}"
    );
}

/// What must not depend on whether wholly erased subtrees were given back: the visible
/// triangles (by name and corner bits), the v_list as a set, the counters, the removed
/// volume, the pieces.
#[derive(Debug, PartialEq)]
struct Observed {
    /// (tet, index, face, corner bits), sorted.
    tris: Vec<(u32, u32, u8, [u32; 9])>,
    /// (tet, index), sorted.
    vlist: Vec<(u32, u32)>,
    faces: u32,
    removed: u64,
    pieces: u32,
}

fn observed(mesh: &Mesh<'_>, h: &Hierarchy<'_>) -> Observed {
    let mut tris = Vec::new();
    h.for_each_visible(mesh, |t| {
        let c = t.corners;
        let bits = [
            c[0].x, c[0].y, c[0].z, c[1].x, c[1].y, c[1].z, c[2].x, c[2].y, c[2].z,
        ]
        .map(f32::to_bits);
        tris.push((t.tet.0, t.index, t.face, bits));
    });
    tris.sort_unstable();
    let mut vl: Vec<(u32, u32)> = h.vlist().iter().map(|e| (e.tet.0, e.index)).collect();
    vl.sort_unstable();
    let mut scratch = vec![0u32; h.components_scratch_needed()];
    let pieces = h.components(mesh, &mut scratch).unwrap();
    Observed {
        tris,
        vlist: vl,
        faces: h.visible_face_count(),
        removed: h.removed_volume().to_bits(),
        pieces,
    }
}

/// The arena's accounting from the tree shape alone (`for_each_leaf`): every inner node owns
/// one block of 8; a block holds material iff a non-erased leaf lies below its parent.
/// Returns (inner nodes, inner nodes with a non-erased leaf below).
fn inner_nodes(mesh: &Mesh<'_>, h: &Hierarchy<'_>) -> (usize, usize) {
    let (mut all, mut live) = (HashSet::new(), HashSet::new());
    for t in 0..mesh.tet_count() {
        h.for_each_leaf(TetId::from_idx(t), |l| {
            let mut i = l.index;
            while i > 0 {
                i = (i - 1) / 8;
                all.insert((t, i));
                if !l.record.erased() {
                    live.insert((t, i));
                }
            }
        });
    }
    (all.len(), live.len())
}

/// Random Erase/Refine on the trees of `pool`, applied to `h` (a small arena: once its fresh
/// blocks are used up it takes back blocks of wholly erased subtrees) and to `twin` (room for
/// everything: never takes anything back). Erasures often take a leaf's live siblings too,
/// so blocks are wholly erased. After every operation: both validate, everything observable
/// is identical, and the arena's counts match the tree shape; every `every` operations the
/// small one's visible faces are checked against the brute force. At the end every leaf of
/// the pool is erased: the arena holds no material. Returns (blocks taken back, refusals).
#[allow(clippy::too_many_arguments)]
fn random_ops_reclaiming(
    mesh: &Mesh<'_>,
    h: &mut Hierarchy<'_>,
    twin: &mut Hierarchy<'_>,
    pool: &[usize],
    ops: usize,
    max_depth: u32,
    every: usize,
    seed: u64,
) -> (u32, u32) {
    let mut rng = StdRng::seed_from_u64(seed);
    let check = with_neighbours(mesh, pool);
    let mut refused = 0;
    let mut checked = 0;
    let same = |h: &Hierarchy<'_>, twin: &Hierarchy<'_>| {
        h.validate(mesh).unwrap();
        twin.validate(mesh).unwrap();
        assert_eq!(observed(mesh, h), observed(mesh, twin));
        let (all, live) = inner_nodes(mesh, h);
        assert_eq!(h.arena_used(), 8 * all);
        assert_eq!(h.arena_live(), 8 * live);
        assert_eq!(h.arena_reclaimable(), 8 * (all - live));
    };
    for op in 0..ops {
        let live: Vec<LeafG> = leaves(mesh, h, pool.iter().copied())
            .into_iter()
            .filter(|l| !l.erased)
            .collect();
        if live.is_empty() {
            break;
        }
        let l = &live[rng.gen_range(0..live.len())];
        if l.depth < max_depth && rng.gen_bool(0.55) {
            match h.refine(mesh, l.tet, l.index) {
                Ok(_) => {
                    twin.refine(mesh, l.tet, l.index).unwrap();
                }
                Err(e) => {
                    assert_eq!(e, tetradrill_core::hierarchy::HierarchyError::Full);
                    refused += 1;
                }
            }
        } else {
            let mut targets = vec![(l.tet, l.index)];
            if l.index > 0 && rng.gen_bool(0.5) {
                let parent = (l.index - 1) / 8;
                targets.extend(
                    live.iter()
                        .filter(|m| m.tet == l.tet && m.index != l.index && m.depth == l.depth)
                        .filter(|m| (m.index - 1) / 8 == parent)
                        .map(|m| (m.tet, m.index)),
                );
            }
            for (t, i) in targets {
                h.erase(mesh, t, i).unwrap();
                twin.erase(mesh, t, i).unwrap();
            }
        }
        same(h, twin);
        if op % every == every - 1 {
            checked += check_visible(mesh, h, &check);
        }
    }
    assert!(checked > 0);
    // Erase the rest: every block of the pool's trees is wholly erased.
    for l in leaves(mesh, h, pool.iter().copied()) {
        if !l.erased {
            h.erase(mesh, l.tet, l.index).unwrap();
            twin.erase(mesh, l.tet, l.index).unwrap();
        }
    }
    same(h, twin);
    check_visible(mesh, h, &check);
    assert_eq!(h.arena_live(), 0);
    (h.reclaimed(), refused)
}

#[test]
fn taking_back_erased_blocks_changes_no_visible_face_on_the_cube() {
    let mut om = cube_mesh();
    let mesh = om.view();
    let pool: Vec<usize> = (0..mesh.tet_count()).collect();
    let mut total = (0, 0);
    for seed in 0..4 {
        // 5 blocks: the random sequence needs more, so blocks are taken back many times.
        let mut st = Store::new(mesh.tet_count(), 8 * 5);
        let mut h = st.hierarchy(&mesh);
        let mut st2 = Store::new(mesh.tet_count(), 8 * 400);
        let mut twin = st2.hierarchy(&mesh);
        let (reclaimed, refused) =
            random_ops_reclaiming(&mesh, &mut h, &mut twin, &pool, 120, 3, 10, seed);
        total.0 += reclaimed;
        total.1 += refused;
    }
    eprintln!(
        "cube: {} blocks taken back, {} refinements refused",
        total.0, total.1
    );
    assert!(total.0 >= 20, "the test must take blocks back: {total:?}");
}

#[test]
fn taking_back_erased_blocks_changes_no_visible_face_on_a_block() {
    let mut om = block_mesh(2, 0.5);
    let mesh = om.view();
    let pool: Vec<usize> = (0..mesh.tet_count()).collect();
    let mut st = Store::new(mesh.tet_count(), 8 * 12);
    let mut h = st.hierarchy(&mesh);
    let mut st2 = Store::new(mesh.tet_count(), 8 * 600);
    let mut twin = st2.hierarchy(&mesh);
    let (reclaimed, refused) =
        random_ops_reclaiming(&mesh, &mut h, &mut twin, &pool, 250, 3, 25, 5);
    eprintln!("block: {reclaimed} blocks taken back, {refused} refinements refused");
    assert!(
        reclaimed >= 20,
        "the test must take blocks back: {reclaimed}"
    );
    // The whole block is erased: nothing of the arena holds material, and the next
    // refinements would reuse it.
    assert_eq!(h.arena_live(), 0);
    assert_eq!(h.arena_reclaimable(), h.arena_used());
}
