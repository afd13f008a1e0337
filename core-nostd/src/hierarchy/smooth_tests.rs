//! Unit tests of the smooth normals: canonical lattice keys, storage carved from its sizes,
//! and short vertices or queue on the 12-tet cube under random erasures and refinements
//! (saturated, counted, and, for the queue, the same normals in the end as a roomy one).
//! No heap: the storage is fixed arrays at least as long as the sizes ask (checked).

use glam::Vec3;

use super::test_support::{mesh, random_op, Cube, Rng};
use super::*;
use crate::builtin::CUBE12_TETS;
use crate::ids::TetId;
use crate::storage::{Block, Line, Part, StorageError};

#[test]
fn a_point_has_one_key_whatever_the_tet_and_depth() {
    // The midpoint of nodes 5 and 9, from two tets listing their nodes in other orders, at
    // depth 1 and at depth 3.
    let a = VertexKey::of([5, 2, 9, 7], [1, 0, 1, 0], 1);
    let b = VertexKey::of([9, 3, 8, 5], [1, 0, 0, 1], 1);
    let c = VertexKey::of([7, 9, 5, 1], [0, 4, 4, 0], 3);
    assert_eq!(a, b);
    assert_eq!(a, c);
    assert_eq!(a.nodes, [5, 9, u32::MAX, u32::MAX]);
    assert_eq!(a.weights, [512, 512, 0, 0]);
    // Another point of the same edge, and the same weights on another edge, differ.
    assert_ne!(a, VertexKey::of([5, 2, 9, 7], [3, 0, 1, 0], 2));
    assert_ne!(a, VertexKey::of([5, 2, 9, 7], [1, 1, 0, 0], 1));
}

#[test]
fn storage_is_carved_from_its_sizes_and_refused_short() {
    let sizes = SmoothSizes::for_slots(100);
    assert_eq!((sizes.vertices, sizes.queue, sizes.table()), (100, 64, 256));
    let lines = sizes.lines().unwrap();
    assert_eq!(sizes.bytes(), Some(lines * 64));
    let mut mem = [Line([0xa5; 64]); 256];
    assert!(lines <= mem.len());
    let st = SmoothStorage::carve(&sizes, &mut Block::from_lines(&mut mem[..lines])).unwrap();
    assert_eq!(
        (st.slots.len(), st.vertices.len(), st.table.len()),
        (100, 100, 256)
    );
    assert!(SmoothNormals::new(st, SmoothNormals::CREASE_DEGREES).is_ok());
    let mut short = [Line::ZERO; 256];
    match SmoothStorage::carve(&sizes, &mut Block::from_lines(&mut short[..lines - 1])) {
        Err(StorageError::TooSmall { part, .. }) => assert_eq!(part, Part::SmoothQueue),
        other => panic!("one line short must be refused, got {other:?}"),
    }
    // A table that is not a power of two at least twice the vertices.
    let (mut sl, mut vs, mut q) = ([SmoothSlot::FREE; 4], [SmoothVertex::EMPTY; 4], [0u32; 4]);
    let mut table = [0u32; 6];
    let st = SmoothStorage {
        slots: &mut sl,
        vertices: &mut vs,
        table: &mut table,
        queue: &mut q,
    };
    assert_eq!(
        SmoothNormals::new(st, 75.0).err(),
        Some(SmoothError::Storage)
    );
}

/// Room for the cube's surfaces in these runs.
const SLOTS: usize = 600;
/// Corners of the slots.
const CORNERS: usize = 3 * SLOTS;
/// Lines the surface's storage takes at most in these runs.
const SURFACE_LINES: usize = 160;
/// Lines the smooth normals' storage takes at most in these runs.
const SMOOTH_LINES: usize = 1_200;

/// A face as the reset check compares it: its corners' position bits and normals.
type Face = ([u32; 9], [[f32; 3]; 3]);

/// The live slots' faces of an export (`count` of them first in the array), sorted by their
/// positions.
fn faces(p: &[[f32; 3]], nr: &[[f32; 3]], ix: &[u32]) -> ([Face; SLOTS], usize) {
    let mut v = [([0u32; 9], [[0.0f32; 3]; 3]); SLOTS];
    let mut count = 0;
    for s in (0..SLOTS).filter(|&s| ix[3 * s..3 * s + 3] != [0, 0, 0]) {
        let mut b = [0u32; 9];
        for (k, bits) in b.iter_mut().enumerate() {
            *bits = p[3 * s + k / 3][k % 3].to_bits();
        }
        v[count] = (b, [nr[3 * s], nr[3 * s + 1], nr[3 * s + 2]]);
        count += 1;
    }
    v[..count].sort_unstable_by_key(|f| f.0);
    (v, count)
}

/// The normals and vertices of every live slot after the exporter caught up, after each of
/// `ops` random operations, with `vertices` shared vertices and a queue of `queue`; returns
/// the last normals, the stats and the corners seen without a vertex (each checked to hold
/// its face's normal).
fn run(
    seed: u64,
    ops: usize,
    vertices: usize,
    queue: usize,
) -> ([[f32; 3]; CORNERS], SmoothStats, u32) {
    let mut c = Cube::new();
    let mesh = mesh(&mut c);
    let mut roots = [HNode::LEAF; CUBE12_TETS];
    let mut arena = [HNode::LEAF; 8 * 48];
    let mut vlist = [VEntry::default(); CUBE12_TETS + 7 * 48];
    let mut changes = [TetId::NONE; 16];
    let storage = HierarchyStorage {
        roots: &mut roots,
        arena: &mut arena,
        vlist: &mut vlist,
        changes: &mut changes,
    };
    let mut h = Hierarchy::new(&mesh, storage).unwrap();
    let sizes = SurfaceSizes::new(SLOTS, CUBE12_TETS);
    let nl = sizes.lines().unwrap();
    let mut lines = [Line::ZERO; SURFACE_LINES];
    assert!(nl <= SURFACE_LINES);
    let storage = SurfaceStorage::carve(&sizes, &mut Block::from_lines(&mut lines[..nl])).unwrap();
    let ssizes = SmoothSizes::new(SLOTS, vertices, queue);
    let ns = ssizes.lines().unwrap();
    let mut slines = [Line::ZERO; SMOOTH_LINES];
    assert!(ns <= SMOOTH_LINES);
    let sst = SmoothStorage::carve(&ssizes, &mut Block::from_lines(&mut slines[..ns])).unwrap();
    let smooth = SmoothNormals::new(sst, SmoothNormals::CREASE_DEGREES).unwrap();
    let mut ex = SurfaceExport::new(storage, &h)
        .unwrap()
        .with_smooth(smooth)
        .unwrap();
    let cos = SmoothNormals::CREASE_DEGREES.to_radians().cos();
    let (mut p, mut nr, mut l, mut ix) = (
        [[0.0f32; 3]; CORNERS],
        [[0.0f32; 3]; CORNERS],
        [0; CORNERS],
        [0u32; CORNERS],
    );
    let mut ranges = [SlotRange::default(); 8];
    let mut rng = Rng(seed);
    let mut lonely = 0;
    for op in 0..=ops {
        if op > 0 {
            random_op(&mut h, &mesh, &mut rng);
        }
        let mut out = SurfaceBuffers {
            positions: &mut p,
            normals: &mut nr,
            labels: &mut l,
            indices: &mut ix,
            ranges: &mut ranges,
        };
        let mut calls = 0;
        while ex.update(&h, &mesh, |_| 1, 64, &mut out).unwrap().pending > 0 {
            calls += 1;
            assert!(calls < 10_000, "seed {seed} op {op}: no progress");
        }
        let sm = ex.smooth().unwrap();
        sm.validate().unwrap();
        for s in 0..SLOTS {
            if ix[3 * s..3 * s + 3] == [0, 0, 0] {
                assert!(sm.slot_vertices(s as u32).is_none());
                continue;
            }
            let [a, b, c] = [0, 1, 2].map(|k| Vec3::from(p[3 * s + k]));
            let own = (b - a).cross(c - a).normalize();
            for k in 0..3 {
                let g = Vec3::from(nr[3 * s + k]);
                assert!((g.length() - 1.0).abs() < 1e-5, "not unit");
                if !sm.slot_drilled(s as u32) {
                    assert!(g.dot(own) >= cos - 1e-5, "beyond the crease angle");
                }
                if sm.slot_vertices(s as u32).unwrap()[k] == u32::MAX {
                    lonely += 1;
                    assert!((g - own).length() < 1e-5, "a corner without a vertex");
                }
            }
        }
    }
    let stats = ex.smooth().unwrap().stats();
    // Every live slot is in its tet's chain, once, and names that tet.
    let mut seen = [false; SLOTS];
    for t in 0..CUBE12_TETS as u32 {
        for s in ex.tet_slots(TetId(t)) {
            assert_eq!(ex.slot_tet(s), Some(TetId(t)));
            assert!(
                !core::mem::replace(&mut seen[s as usize], true),
                "slot {s} twice"
            );
        }
    }
    for (s, &seen) in seen.iter().enumerate() {
        assert_eq!(seen, ix[3 * s..3 * s + 3] != [0, 0, 0], "slot {s}");
        assert_eq!(ex.slot_tet(s as u32).is_some(), seen, "slot {s}");
    }
    // Started over in the same storage, the exporter ends with the same faces and normals
    // (which corners find a vertex when the vertices run short depends on the order the faces
    // came in: then the faces alone).
    let (before, nb) = faces(&p, &nr, &ix);
    ex.reset(&h).unwrap();
    assert_eq!(ex.smooth().unwrap().stats(), SmoothStats::default());
    let (mut p2, mut nr2, mut l2, mut ix2) = (
        [[0.0f32; 3]; CORNERS],
        [[0.0f32; 3]; CORNERS],
        [0; CORNERS],
        [0u32; CORNERS],
    );
    let mut out = SurfaceBuffers {
        positions: &mut p2,
        normals: &mut nr2,
        labels: &mut l2,
        indices: &mut ix2,
        ranges: &mut ranges,
    };
    let mut calls = 0;
    while ex.update(&h, &mesh, |_| 1, 64, &mut out).unwrap().pending > 0 {
        calls += 1;
        assert!(calls < 10_000, "seed {seed} after the reset: no progress");
    }
    let (after, na) = faces(&p2, &nr2, &ix2);
    assert_eq!(nb, na);
    for (b, a) in before[..nb].iter().zip(&after[..na]) {
        assert_eq!(b.0, a.0, "seed {seed}: the same faces");
        if stats.vertices_full > 0 {
            continue;
        }
        for k in 0..3 {
            assert!(
                (Vec3::from(b.1[k]) - Vec3::from(a.1[k])).length() < 1e-5,
                "seed {seed}: {:?} against {:?}",
                b.1,
                a.1
            );
        }
    }
    (nr, stats, lonely)
}

#[test]
fn a_short_queue_is_counted_and_ends_with_the_same_normals() {
    for seed in 1..4u64 {
        let (roomy, rs, _) = run(seed, 40, SLOTS, 256);
        assert_eq!((rs.vertices_full, rs.queue_full), (0, 0), "{rs:?}");
        let (short, ss, _) = run(seed, 40, SLOTS, 1);
        assert!(ss.queue_full > 0, "{ss:?}");
        assert_eq!(ss.vertices_full, 0);
        assert_eq!(roomy, short, "seed {seed}");
    }
}

#[test]
fn short_vertices_are_counted_and_their_corners_keep_the_face_normal() {
    let (_, st, lonely) = run(7, 40, 8, 256);
    assert!(st.vertices_full > 0 && lonely > 0, "{st:?}");
    assert!(st.vertices <= 8);
}
