//! The drilling tests' shared pieces: the brute-force visible-face oracle and hierarchy
//! storage.
//!
//! The brute force shares no code with the hierarchy: it takes only the tree shape and the face
//! bits (`for_each_leaf`), rebuilds every leaf's corners in f64 by its own midpoint descent, and
//! decides visibility by locating nudged sample points among the leaves.

use std::collections::{HashMap, HashSet};

use glam::Vec3;
use tetradrill::owned::OwnedMesh;
use tetradrill_core::builtin::{block, block_counts};
use tetradrill_core::hierarchy::{Hierarchy, HierarchySizes};
use tetradrill_core::mesh::{BuildOptions, Mesh};
use tetradrill_core::owned::HierarchyBuffers;
use tetradrill_core::TetId;

use crate::oracle::{add, cross, dot, scale, sub, D3};

/// Six times the signed volume of tet `p`.
pub fn det(p: &[D3; 4]) -> f64 {
    dot(cross(sub(p[1], p[0]), sub(p[2], p[0])), sub(p[3], p[0]))
}
/// The midpoint of `a` and `b`.
pub fn mid(a: D3, b: D3) -> D3 {
    scale(add(a, b), 0.5)
}

/// Bey's eight children by name (the test's own copy of the paper's list).
pub fn bey(p: &[D3; 4]) -> [[D3; 4]; 8] {
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
pub fn face_of(p: &[D3; 4], f: usize) -> [D3; 3] {
    let o: Vec<usize> = (0..4).filter(|&k| k != f).collect();
    [p[o[0]], p[o[1]], p[o[2]]]
}

/// The corners of node `index` of `tet`'s tree in f64 (by the test's own midpoint descent from
/// the tet's corners) and its depth.
pub fn corners(mesh: &Mesh<'_>, tet: TetId, index: u32) -> ([D3; 4], u32) {
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

/// One leaf of a tree with its own geometry.
#[derive(Clone, Debug)]
pub struct LeafG {
    /// The tree's root tet.
    pub tet: TetId,
    /// The leaf's index in its tree (0 the root, children of i at 8i+1..8i+8).
    pub index: u32,
    /// Whether the leaf is erased.
    pub erased: bool,
    /// The leaf's visible-face bits as the hierarchy keeps them.
    pub visible: u8,
    /// The leaf's corners in f64.
    pub p: [D3; 4],
    /// The leaf's depth below its root.
    pub depth: u32,
}

/// Every leaf of the trees of `tets`, in tree order.
pub fn leaves(mesh: &Mesh<'_>, h: &Hierarchy<'_>, tets: impl Iterator<Item = usize>) -> Vec<LeafG> {
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

/// Whether `x` lies in tet `p` (barycentric coordinates in f64, tolerance 1e-12).
pub fn contains(p: &[D3; 4], x: D3) -> bool {
    let d = det(p);
    let b1 = det(&[p[0], x, p[2], p[3]]) / d;
    let b2 = det(&[p[0], p[1], x, p[3]]) / d;
    let b3 = det(&[p[0], p[1], p[2], x]) / d;
    let b0 = 1.0 - b1 - b2 - b3;
    let e = -1e-12;
    b0 >= e && b1 >= e && b2 >= e && b3 >= e
}

/// Centroids of the `4^k` sub-triangles of a triangle.
pub fn samples(t: [D3; 3], k: u32, out: &mut Vec<D3>) {
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
pub fn check_visible(mesh: &Mesh<'_>, h: &Hierarchy<'_>, check: &HashSet<usize>) -> usize {
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
pub fn material_volume(mesh: &Mesh<'_>, h: &Hierarchy<'_>) -> f64 {
    leaves(mesh, h, 0..mesh.tet_count())
        .iter()
        .filter(|l| !l.erased)
        .map(|l| det(&l.p).abs() / 6.0)
        .sum()
}

/// Storage for one hierarchy: the core's owned-storage layer.
#[derive(Debug)]
pub struct Store(HierarchyBuffers);

impl Store {
    /// Storage for `tets` roots and an arena of `arena` nodes.
    pub fn new(tets: usize, arena: usize) -> Self {
        Self(HierarchyBuffers::new(HierarchySizes::new(tets, arena)).expect("storage"))
    }

    /// A hierarchy over `mesh` in this storage.
    pub fn hierarchy<'a>(&'a mut self, mesh: &Mesh<'_>) -> Hierarchy<'a> {
        self.0.hierarchy(mesh).expect("hierarchy")
    }
}

/// The generated block of `n` cubes a side, of edge `edge`, from the origin.
pub fn block_mesh(n: usize, edge: f32) -> OwnedMesh {
    let (nn, nt) = block_counts(n);
    let mut p = vec![Vec3::ZERO; nn];
    let mut t = vec![[0u32; 4]; nt];
    block(n, edge, Vec3::ZERO, &mut p, &mut t).unwrap();
    OwnedMesh::build(p, &t, BuildOptions::default()).unwrap()
}
