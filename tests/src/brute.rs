//! Brute-force geometry for the soft-body and deforming-world tests, written here and not
//! taken from the crates under test: a block of Kuhn tets, six times a tet's signed volume in
//! f64, each tet's box and the overlap of two boxes, the boundary nodes' averaged normals.

use std::collections::HashMap;

use glam::Vec3;
use tetradrill_core::mesh::Mesh;
use tetradrill_core::TetId;

use crate::oracle::{add, cross, d3, dot, scale, sub, D3};

/// A grid of `nx x ny x nz` cubes of edge `h` from the origin, each cube split into the six
/// tets along the monotone paths from its corner (0,0,0) to (1,1,1), every tet turned to a
/// positive volume; node `i + (nx+1) (j + (ny+1) k)` at `(i, j, k) h`.
pub fn grid(nx: usize, ny: usize, nz: usize, h: f32) -> (Vec<Vec3>, Vec<[u32; 4]>) {
    let id = |i: usize, j: usize, k: usize| (i + (nx + 1) * (j + (ny + 1) * k)) as u32;
    let mut x = vec![Vec3::ZERO; (nx + 1) * (ny + 1) * (nz + 1)];
    for k in 0..=nz {
        for j in 0..=ny {
            for i in 0..=nx {
                x[id(i, j, k) as usize] = Vec3::new(i as f32, j as f32, k as f32) * h;
            }
        }
    }
    let mut tets = Vec::new();
    let paths = [
        [0, 1, 2],
        [0, 2, 1],
        [1, 0, 2],
        [1, 2, 0],
        [2, 0, 1],
        [2, 1, 0],
    ];
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                for p in paths {
                    let mut c = [i, j, k];
                    let mut t = [id(i, j, k); 4];
                    for (s, axis) in p.iter().enumerate() {
                        c[*axis] += 1;
                        t[s + 1] = id(c[0], c[1], c[2]);
                    }
                    if six_volume(t.map(|n| x[n as usize])) < 0.0 {
                        t.swap(2, 3);
                    }
                    tets.push(t);
                }
            }
        }
    }
    (x, tets)
}

/// Six times the signed volume of the tet `p`, in f64.
pub fn six_volume(p: [Vec3; 4]) -> f64 {
    let d = |v: Vec3| [v.x as f64, v.y as f64, v.z as f64];
    let (a, b, c) = (d(p[1] - p[0]), d(p[2] - p[0]), d(p[3] - p[0]));
    a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0])
        + a[2] * (b[0] * c[1] - b[1] * c[0])
}

/// Each tet's box at the mesh's current positions (min and max of its four corners).
pub fn tet_boxes(mesh: &Mesh<'_>) -> Vec<(Vec3, Vec3)> {
    (0..mesh.tet_count())
        .map(|t| {
            crate::oracle::tet_box(
                mesh.tet(TetId::from_idx(t))
                    .nodes
                    .map(|n| mesh.positions()[n.idx()]),
            )
        })
        .collect()
}

/// Whether two boxes (min, max) meet, boundaries included.
pub fn overlaps(a: (Vec3, Vec3), b: (Vec3, Vec3)) -> bool {
    a.0.cmple(b.1).all() && b.0.cmple(a.1).all()
}

/// The boundary nodes' averaged outward normals in f64 (`None` for a node on no boundary
/// face): a boundary face is a node triple that one tet alone has (found by sorting each
/// face's nodes, not from the mesh's neighbours), its normal is the cross product of two edges
/// turned away from its tet's fourth node (not from the mesh's face tables), weighted by its
/// area; a node's normal is the normalised sum over its boundary faces.
pub fn boundary_normals(positions: &[Vec3], tets: &[[u32; 4]]) -> Vec<Option<D3>> {
    let mut faces: HashMap<[u32; 3], (u32, usize, usize)> = HashMap::new();
    for (t, tet) in tets.iter().enumerate() {
        for k in 0..4 {
            let mut key: Vec<u32> = (0..4).filter(|&j| j != k).map(|j| tet[j]).collect();
            key.sort_unstable();
            let e = faces.entry([key[0], key[1], key[2]]).or_insert((0, t, k));
            e.0 += 1;
        }
    }
    let mut sums: Vec<Option<D3>> = vec![None; positions.len()];
    for (key, &(count, t, k)) in &faces {
        if count != 1 {
            continue;
        }
        let [a, b, c] = key.map(|n| d3(positions[n as usize]));
        let apex = d3(positions[tets[t][k] as usize]);
        let mut n = cross(sub(b, a), sub(c, a));
        if dot(n, sub(apex, a)) > 0.0 {
            n = scale(n, -1.0);
        }
        for &node in key {
            let s = sums[node as usize].get_or_insert([0.0; 3]);
            *s = add(*s, n);
        }
    }
    sums.into_iter()
        .map(|s| s.map(|s| scale(s, 1.0 / dot(s, s).sqrt())))
        .collect()
}
