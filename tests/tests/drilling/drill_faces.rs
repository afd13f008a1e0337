//! Drilling oracles, the visible faces: against a brute-force recomputation after random
//! Erase/Refine sequences (12-tet cube, generated block, the cow) with volume conservation, and
//! unchanged when erased blocks are taken back.
//!
//! The brute force (`tetradrill_tests::drill`) shares no code with the hierarchy: it takes only
//! the tree shape and the face bits (`for_each_leaf`), rebuilds every leaf's corners in f64 by
//! its own midpoint descent, and decides visibility by locating nudged sample points among the
//! leaves.

use std::collections::HashSet;

use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use tetradrill::owned::OwnedMesh;
use tetradrill_core::builtin::cube12;
use tetradrill_core::hierarchy::Hierarchy;
use tetradrill_core::mesh::{BuildOptions, Mesh};
use tetradrill_core::TetId;
use tetradrill_tests::drill::{block_mesh, check_visible, leaves, material_volume, LeafG, Store};
use tetradrill_tests::tetgen_reader::tetgen;

fn cube_mesh() -> OwnedMesh {
    let (p, t) = cube12();
    OwnedMesh::build(p.to_vec(), &t, BuildOptions::default()).unwrap()
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
