//! The compact mesh against brute force: template tables derived geometrically, `vertex_match`
//! against a search over the neighbour's vertices, traversals against scans of every tet,
//! and `validate()` after random relabelling and reflection.

use std::collections::{BTreeMap, BTreeSet};

use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use tetradrill::owned::OwnedMesh;
use tetradrill_core::builtin;
use tetradrill_core::mesh::template::*;
use tetradrill_core::mesh::{BuildError, BuildOptions, Mesh, TET_BYTES};
use tetradrill_core::{NodeId, TetId, Vec3};

/// A positively oriented reference tet.
const REF: [[f64; 3]; 4] = [
    [0.0, 0.0, 0.0],
    [1.0, 0.0, 0.0],
    [0.0, 1.0, 0.0],
    [0.0, 0.0, 1.0],
];

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// The record size the mesh reports is the real one (the bound itself is a compile-time
/// assertion in the core).
#[test]
fn tet_record_size_is_reported() {
    assert_eq!(std::mem::size_of::<tetradrill_core::mesh::Tet>(), TET_BYTES);
}

#[test]
fn face_listings_are_clockwise_from_outside() {
    for f in 0..4 {
        let [a, b, c] = FACE_VERTS[f].map(|k| REF[k as usize]);
        // Clockwise seen from outside = the right-hand normal points into the tet, towards
        // the opposite vertex.
        let n = cross(sub(b, a), sub(c, a));
        assert!(dot(n, sub(REF[f], a)) > 0.0, "face {f}");
        assert!(
            !FACE_VERTS[f].contains(&(f as u8)),
            "face {f} is opposite vertex {f}"
        );
    }
}

#[test]
fn reverse_tables_match_brute_force() {
    for f in 0..4 {
        for v in 0..4u8 {
            let pos = FACE_VERTS[f].iter().position(|&x| x == v);
            match pos {
                Some(p) => {
                    assert_eq!(FACE_VERTEX_NR[f][v as usize] as usize, p);
                    assert_eq!(ELEM_VERTEX_NR[f][p], v);
                }
                None => assert_eq!(FACE_VERTEX_NR[f][v as usize], NOT_ON_FACE),
            }
        }
    }
    for (e, [a, b]) in EDGE_VERTS.iter().enumerate() {
        assert_eq!(EDGE_OF_VERTS[*a as usize][*b as usize] as usize, e);
        assert_eq!(EDGE_OF_VERTS[*b as usize][*a as usize] as usize, e);
        let faces: Vec<u8> = (0..4u8)
            .filter(|f| FACE_VERTS[*f as usize].contains(a) && FACE_VERTS[*f as usize].contains(b))
            .collect();
        assert_eq!(faces, EDGE_FACES[e].to_vec(), "edge {e}");
    }
    for v in 0..4u8 {
        assert_eq!(EDGE_OF_VERTS[v as usize][v as usize], NO_EDGE);
        let faces: Vec<u8> = (0..4u8)
            .filter(|f| FACE_VERTS[*f as usize].contains(&v))
            .collect();
        assert_eq!(faces, VERTEX_FACES[v as usize].to_vec());
        let edges: Vec<u8> = (0..6u8)
            .filter(|e| EDGE_VERTS[*e as usize].contains(&v))
            .collect();
        assert_eq!(edges, VERTEX_EDGES[v as usize].to_vec());
    }
    for f in 0..4 {
        let edges: Vec<u8> = (0..6u8)
            .filter(|e| {
                EDGE_VERTS[*e as usize]
                    .iter()
                    .all(|x| FACE_VERTS[f].contains(x))
            })
            .collect();
        assert_eq!(edges, FACE_EDGES[f].to_vec(), "face {f}");
    }
}

fn block_arrays(n: usize) -> (Vec<Vec3>, Vec<[u32; 4]>) {
    let (nn, nt) = builtin::block_counts(n);
    let mut p = vec![Vec3::ZERO; nn];
    let mut t = vec![[0u32; 4]; nt];
    builtin::block(n, 1.0, Vec3::splat(-(n as f32) / 2.0), &mut p, &mut t).expect("sized");
    (p, t)
}

fn cube12_arrays() -> (Vec<Vec3>, Vec<[u32; 4]>) {
    let (p, t) = builtin::cube12();
    (p.to_vec(), t.to_vec())
}

/// Every check of this file on one mesh.
fn check_mesh(mesh: &Mesh<'_>) {
    mesh.validate().expect("valid");
    check_vertex_match(mesh);
    check_traversals(mesh);
    check_boundary(mesh);
}

/// `vertex_match` against a search over the neighbour's four vertices, for every
/// (tet, vertex, face).
fn check_vertex_match(mesh: &Mesh<'_>) {
    for ti in 0..mesh.tet_count() {
        let t = TetId::from_idx(ti);
        let tet = mesh.tet(t);
        for f in 0..4u8 {
            for v in 0..4u8 {
                let got = mesh.vertex_match(t, v, f);
                let nb = tet.neighbours[f as usize];
                if nb.is_none() || v == f {
                    assert!(got.is_none());
                    continue;
                }
                let want = mesh
                    .tet(nb)
                    .nodes
                    .iter()
                    .position(|&n| n == tet.nodes[v as usize]);
                let got = got.expect("neighbour across an inner face");
                assert_eq!(got.tet, nb);
                assert_eq!(Some(got.local as usize), want, "tet {ti} v {v} f {f}");
            }
        }
    }
}

fn check_traversals(mesh: &Mesh<'_>) {
    // Brute force: every tet's nodes, faces and edges.
    let mut tets_of: BTreeMap<NodeId, BTreeSet<TetId>> = BTreeMap::new();
    let mut faces: BTreeSet<[u32; 3]> = BTreeSet::new();
    let mut edges: BTreeSet<[u32; 2]> = BTreeSet::new();
    for ti in 0..mesh.tet_count() {
        let t = TetId::from_idx(ti);
        let nodes = mesh.tet(t).nodes;
        for n in nodes {
            tets_of.entry(n).or_default().insert(t);
        }
        for skip in 0..4 {
            let mut f: Vec<u32> = (0..4).filter(|&k| k != skip).map(|k| nodes[k].0).collect();
            f.sort();
            faces.insert([f[0], f[1], f[2]]);
        }
        for a in 0..4 {
            for b in a + 1..4 {
                let (x, y) = (nodes[a].0.min(nodes[b].0), nodes[a].0.max(nodes[b].0));
                edges.insert([x, y]);
            }
        }
    }
    let mut scratch = vec![TetId::NONE; 256];
    let mut uses = vec![Default::default(); 256];
    let mut fout = vec![Default::default(); 1024];
    let mut eout = vec![Default::default(); 1024];
    for (&n, want) in &tets_of {
        let k = mesh
            .tets_around_vertex(n, &mut scratch)
            .expect("scratch large enough");
        let got: BTreeSet<TetId> = scratch[..k].iter().copied().collect();
        assert_eq!(got.len(), k, "no duplicates around node {}", n.0);
        assert_eq!(&got, want, "tets around node {}", n.0);

        let k = mesh.vertex_uses(n, &mut uses).expect("scratch");
        for u in &uses[..k] {
            assert_eq!(mesh.tet(u.tet).nodes[u.local as usize], n);
        }
        assert_eq!(k, want.len());

        let k = mesh
            .faces_around_vertex(n, &mut scratch, &mut fout)
            .expect("scratch");
        let mut got_faces = BTreeSet::new();
        for fu in &fout[..k] {
            let mut f: Vec<u32> = mesh
                .face_nodes(fu.tet, fu.local)
                .iter()
                .map(|x| x.0)
                .collect();
            assert!(f.contains(&n.0));
            f.sort();
            assert!(got_faces.insert([f[0], f[1], f[2]]), "face reported twice");
        }
        let want_faces: BTreeSet<[u32; 3]> =
            faces.iter().filter(|f| f.contains(&n.0)).copied().collect();
        assert_eq!(got_faces, want_faces, "faces around node {}", n.0);

        let k = mesh
            .edges_at_vertex(n, &mut scratch, &mut eout)
            .expect("scratch");
        let mut got_edges = BTreeSet::new();
        for eu in &eout[..k] {
            let [a, b] = mesh.edge_nodes(*eu);
            assert!(a == n || b == n);
            assert!(
                got_edges.insert([a.0.min(b.0), a.0.max(b.0)]),
                "edge reported twice"
            );
        }
        let want_edges: BTreeSet<[u32; 2]> =
            edges.iter().filter(|e| e.contains(&n.0)).copied().collect();
        assert_eq!(got_edges, want_edges, "edges at node {}", n.0);
    }
    let mut once = BTreeSet::new();
    for e in mesh.edges() {
        let [a, b] = mesh.edge_nodes(e);
        assert!(once.insert([a.0.min(b.0), a.0.max(b.0)]), "edge twice");
    }
    assert_eq!(once, edges);
}

fn check_boundary(mesh: &Mesh<'_>) {
    let mut count = 0;
    let mut bnodes = BTreeSet::new();
    for ti in 0..mesh.tet_count() {
        let t = TetId::from_idx(ti);
        for f in 0..4u8 {
            if mesh.is_boundary_face(t, f) {
                count += 1;
                bnodes.extend(mesh.face_nodes(t, f));
                // The outward normal points away from the opposite vertex.
                let [a, _, _] = mesh.face_positions(t, f);
                let opp = mesh.tet_positions(t)[f as usize];
                assert!(mesh.face_normal(t, f).dot(opp - a) < 0.0);
            }
        }
    }
    assert_eq!(mesh.stats().boundary_faces, count);
    for (i, node) in mesh.nodes().iter().enumerate() {
        let id = NodeId::from_idx(i);
        assert_eq!(node.boundary(), bnodes.contains(&id), "node {i}");
        if node.boundary() {
            assert!((mesh.normal(id).length() - 1.0).abs() < 1e-5);
        }
    }
}

#[test]
fn cube12_is_the_papers_cube() {
    let (p, t) = cube12_arrays();
    let mut m = OwnedMesh::build(p, &t, BuildOptions::default()).expect("builds");
    let mesh = m.view();
    assert_eq!((mesh.node_count(), mesh.tet_count()), (9, 12));
    assert_eq!(mesh.stats().boundary_faces, 12);
    assert_eq!(mesh.stats().orientation_fixes, 0);
    assert!((mesh.volume() - 1.0).abs() < 1e-6);
    check_mesh(&mesh);
    // Cube corner normals are the averaged face normals: along (+-1, +-1, +-1).
    let n = mesh.normal(NodeId(7));
    assert!((n - Vec3::splat(1.0).normalize()).length() < 1e-5, "{n}");
}

#[test]
fn generated_blocks_are_valid_and_exact() {
    for n in 1..=4 {
        let (p, t) = block_arrays(n);
        let mut m = OwnedMesh::build(p, &t, BuildOptions::default()).expect("builds");
        let mesh = m.view();
        assert_eq!(mesh.stats().boundary_faces as usize, 12 * n * n);
        assert!((mesh.volume() - (n * n * n) as f64).abs() < 1e-4);
        assert_eq!(mesh.stats().orientation_fixes, 0);
        check_mesh(&mesh);
    }
}

/// Random node and tet relabelling, vertex order shuffles and a reflection keep the mesh
/// valid with the same counts; a reflection flips every tet.
#[test]
fn relabelling_and_reflection_keep_the_mesh_valid() {
    let mut rng = StdRng::seed_from_u64(7);
    let (p0, t0) = block_arrays(3);
    let mut base = OwnedMesh::build(p0.clone(), &t0, BuildOptions::default()).expect("builds");
    let base_faces = base.view().stats().boundary_faces;
    for round in 0..20 {
        let mut perm: Vec<u32> = (0..p0.len() as u32).collect();
        for i in (1..perm.len()).rev() {
            perm.swap(i, rng.gen_range(0..=i));
        }
        let reflect = round % 2 == 1;
        let mut p = vec![Vec3::ZERO; p0.len()];
        for (old, &new) in perm.iter().enumerate() {
            let mut q = p0[old];
            if reflect {
                q.x = -q.x;
            }
            p[new as usize] = q;
        }
        let mut t: Vec<[u32; 4]> = t0.iter().map(|tet| tet.map(|v| perm[v as usize])).collect();
        for i in (1..t.len()).rev() {
            t.swap(i, rng.gen_range(0..=i));
        }
        let mut expected_fixes = 0;
        for tet in &mut t {
            // An odd shuffle of a positive tet's vertices makes it negative.
            let s = rng.gen_range(0..4);
            tet.swap(s, (s + 1) % 4);
            if !reflect {
                expected_fixes += 1;
            }
        }
        let mut m = OwnedMesh::build(p, &t, BuildOptions::default()).expect("builds");
        let mesh = m.view();
        assert_eq!(mesh.stats().boundary_faces, base_faces);
        assert_eq!(
            mesh.stats().orientation_fixes,
            expected_fixes,
            "round {round}"
        );
        check_mesh(&mesh);
    }
}

/// The relabelling for refinement makes x02-x13 the shortest octahedron diagonal of every tet.
#[test]
fn refinement_relabel_picks_the_shortest_diagonal() {
    let mut rng = StdRng::seed_from_u64(11);
    let mut p = vec![Vec3::ZERO; 300];
    for q in &mut p {
        *q = Vec3::new(rng.gen(), rng.gen(), rng.gen());
    }
    let t: Vec<[u32; 4]> = (0..75)
        .map(|i| [4 * i, 4 * i + 1, 4 * i + 2, 4 * i + 3])
        .collect();
    let mut m = OwnedMesh::build(p, &t, BuildOptions::default()).expect("random tets build");
    let mesh = m.view();
    for ti in 0..mesh.tet_count() {
        let x = mesh.tet_positions(TetId::from_idx(ti));
        let d = |a: usize, b: usize, c: usize, e: usize| ((x[a] + x[b]) - (x[c] + x[e])).length();
        let chosen = d(0, 2, 1, 3);
        assert!(
            chosen <= d(0, 1, 2, 3) + 1e-6 && chosen <= d(0, 3, 1, 2) + 1e-6,
            "tet {ti}"
        );
    }
    mesh.validate().expect("valid");
}

#[test]
fn bad_tet_lists_are_refused() {
    let (p, t) = cube12_arrays();
    let mut bad = t.clone();
    bad[3][1] = 99;
    assert!(matches!(
        OwnedMesh::build(p.clone(), &bad, BuildOptions::default()),
        Err(BuildError::NodeOutOfRange { tet: 3, node: 99 })
    ));
    let mut bad = t.clone();
    bad[5][2] = bad[5][0];
    assert!(matches!(
        OwnedMesh::build(p.clone(), &bad, BuildOptions::default()),
        Err(BuildError::RepeatedNode { tet: 5 })
    ));
    // A flat tet: four corners of one cube face.
    let mut bad = t.clone();
    bad.push([0, 1, 3, 2]);
    assert!(matches!(
        OwnedMesh::build(p.clone(), &bad, BuildOptions::default()),
        Err(BuildError::ZeroVolume { tet: 12 })
    ));
    // A tet listed twice: its inner faces are shared by three tets, its boundary face by two
    // from the same side; whichever the sorted face keys meet first is reported.
    let mut bad = t.clone();
    bad.push(t[0]);
    assert!(matches!(
        OwnedMesh::build(p.clone(), &bad, BuildOptions::default()),
        Err(BuildError::NonManifoldFace { .. } | BuildError::InconsistentFace { .. })
    ));
    // A face shared by three tets: a fan of three tets around one triangle.
    let fan = vec![
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::new(1.0, 0.0, 0.0),
        Vec3::new(0.0, 1.0, 0.0),
        Vec3::new(0.2, 0.2, 1.0),
        Vec3::new(0.2, 0.2, -1.0),
        Vec3::new(0.3, 0.3, 2.0),
    ];
    assert!(matches!(
        OwnedMesh::build(
            fan,
            &[[0, 1, 2, 3], [0, 2, 1, 4], [0, 1, 2, 5]],
            BuildOptions::default()
        ),
        Err(BuildError::NonManifoldFace { .. })
    ));
    let mut q = p.clone();
    q[4].y = f32::NAN;
    assert!(matches!(
        OwnedMesh::build(q, &t, BuildOptions::default()),
        Err(BuildError::NonFinite { node: 4 })
    ));
}

/// Two tets on the same side of a shared face overlap: refused, not linked.
#[test]
fn overlapping_tets_are_refused() {
    let p = vec![
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::new(1.0, 0.0, 0.0),
        Vec3::new(0.0, 1.0, 0.0),
        Vec3::new(0.0, 0.0, 1.0),
        Vec3::new(0.1, 0.1, 2.0),
    ];
    let t = vec![[0, 1, 2, 3], [0, 1, 2, 4]];
    assert!(matches!(
        OwnedMesh::build(p, &t, BuildOptions::default()),
        Err(BuildError::InconsistentFace { .. })
    ));
}

/// Traversal scratch that is too small reports `Full`, never panics.
#[test]
fn small_scratch_reports_full() {
    let (p, t) = cube12_arrays();
    let mut m = OwnedMesh::build(p, &t, BuildOptions::default()).expect("builds");
    let mesh = m.view();
    let centre = NodeId(8); // in all 12 tets
    let mut small = [TetId::NONE; 5];
    assert!(mesh.tets_around_vertex(centre, &mut small).is_err());
    let mut none: [TetId; 0] = [];
    assert!(mesh.tets_around_vertex(centre, &mut none).is_err());
    let mut big = [TetId::NONE; 12];
    assert_eq!(mesh.tets_around_vertex(centre, &mut big), Ok(12));
}
