//! Unit tests: the accessors' neutral results for ids out of range (never a panic), against
//! a two-tet mesh whose answers are known by hand.

use glam::Vec3;

use super::*;

/// Two tets sharing the face {1, 2, 3}: the unit corner tet and the one over its slanted face.
const POSITIONS: [Vec3; 5] = [
    Vec3::new(0.0, 0.0, 0.0),
    Vec3::new(1.0, 0.0, 0.0),
    Vec3::new(0.0, 1.0, 0.0),
    Vec3::new(0.0, 0.0, 1.0),
    Vec3::new(1.0, 1.0, 1.0),
];
const TETS: [[u32; 4]; 2] = [[0, 1, 2, 3], [1, 2, 3, 4]];

fn with_pair(check: impl FnOnce(&mut Mesh<'_>)) {
    let mut positions = POSITIONS;
    let mut nodes = [Node::default(); 5];
    let mut normals = [Vec3::ZERO; 5];
    let mut tets = [Tet::default(); 2];
    let mut scratch = [FaceKey::default(); 8];
    let storage = MeshStorage {
        nodes: &mut nodes,
        normals: &mut normals,
        tets: &mut tets,
    };
    let options = BuildOptions {
        relabel_for_refinement: false,
    };
    let mut mesh =
        Mesh::build(&mut positions, &TETS, storage, &mut scratch, options).expect("builds");
    check(&mut mesh);
}

#[test]
fn a_face_out_of_range_has_no_neighbour() {
    with_pair(|mesh| {
        for t in 0..2u32 {
            let t = TetId(t);
            // In range: exactly one face is shared, and it is the face without the node the
            // other tet does not have.
            assert_eq!(
                (0..4u8).filter(|&f| mesh.neighbour(t, f).is_some()).count(),
                1,
                "{t:?}"
            );
            let f = (0..4u8)
                .find(|&f| mesh.neighbour(t, f).is_some())
                .unwrap_or(9);
            let mut face = mesh.face_nodes(t, f).map(|n| n.0);
            face.sort_unstable();
            assert_eq!(face, [1, 2, 3], "{t:?}");
            assert_eq!(mesh.neighbour(t, f), TetId(1 - t.0));
            assert!(mesh.face_match(FaceUse { tet: t, local: f }).is_some());
            // Out of range: the boundary's answers.
            for f in 4..=u8::MAX {
                assert_eq!(mesh.neighbour(t, f), TetId::NONE, "{t:?} face {f}");
                assert!(mesh.is_boundary_face(t, f));
                assert_eq!(mesh.reverse(t, f), Reverse(0));
                assert_eq!(mesh.face_match(FaceUse { tet: t, local: f }), None);
            }
        }
        // A tet out of range: no neighbour, no positions.
        assert_eq!(mesh.neighbour(TetId(2), 0), TetId::NONE);
        assert_eq!(mesh.neighbour(TetId::NONE, 9), TetId::NONE);
        assert_eq!(mesh.tet_positions(TetId(2)), [Vec3::ZERO; 4]);
        assert_eq!(mesh.tet_positions(TetId::NONE), [Vec3::ZERO; 4]);
        assert_eq!(
            mesh.tet_positions(TetId(1)),
            TETS[1].map(|i| POSITIONS[i as usize])
        );
    });
}

#[test]
fn a_node_id_out_of_range_reads_as_zero_and_is_not_marked() {
    // One tet naming node 99 of a three-node mesh: storage no build would accept, taken as
    // it is by `from_parts`.
    let mut positions = [POSITIONS[1], POSITIONS[2], POSITIONS[3]];
    let mut nodes = [Node::default(); 3];
    let mut normals = [Vec3::ZERO; 3];
    let mut tets = [Tet::new([NodeId(0), NodeId(1), NodeId(2), NodeId(99)])];
    let storage = MeshStorage {
        nodes: &mut nodes,
        normals: &mut normals,
        tets: &mut tets,
    };
    let mut mesh = Mesh::from_parts(&mut positions, storage, 1, BuildStats::default());
    // The tet's corners: all zero, as for a tet out of range.
    assert_eq!(mesh.tet_positions(TetId(0)), [Vec3::ZERO; 4]);
    assert_eq!(mesh.volume(), 0.0);
    // Every face is a boundary face; the three real nodes are marked, node 99 is skipped.
    mesh.update_boundary();
    assert_eq!(mesh.stats().boundary_faces, 4);
    assert_eq!(mesh.stats().boundary_nodes, 3);
    assert!(mesh.nodes().iter().all(|n| n.boundary()));
    // Face 3 (nodes 0, 1, 2: no bad id) adds its outward normal to its nodes; the faces
    // through node 99 add theirs with 99 at the origin. The normals stay unit vectors.
    assert!(mesh
        .normals()
        .iter()
        .all(|n| (n.length() - 1.0).abs() < 1e-5));
}

/// Lines of `n` slots of `bytes` bytes, counted here by hand.
fn lines_of(n: usize, bytes: usize) -> usize {
    (n * bytes).div_ceil(64)
}

#[test]
fn a_node_record_is_eight_bytes_with_its_flag_in_the_sixth() {
    let mut node = Node::new(TetId(7), 2, true);
    let mut want = [0u8; 8];
    want[..4].copy_from_slice(&7u32.to_ne_bytes());
    want[4] = 2;
    want[5] = 1;
    assert_eq!(bytemuck::bytes_of(&node), &want);
    assert!(node.boundary());
    node.set_boundary(false);
    assert!(!node.boundary());
    want[5] = 0;
    assert_eq!(bytemuck::bytes_of(&node), &want);
    assert_eq!(Node::default(), Node::new(TetId::NONE, 0, false));
}

#[test]
fn mesh_storage_carves_every_part_on_a_line_over_garbage() {
    use crate::storage::{Block, Line, Part, StorageError};
    // The two-tet mesh: 5 nodes, 2 tets; Node 8 bytes, Vec3 12, Tet 36.
    const LINES: usize = 1 + 1 + 2;
    assert_eq!(
        MeshStorage::lines(5, 2),
        Some(lines_of(5, 8) + lines_of(5, 12) + lines_of(2, 36))
    );
    assert_eq!(MeshStorage::lines(5, 2), Some(LINES));
    assert_eq!(MeshStorage::lines(usize::MAX, 0), None);
    let mut lines = [Line([0xC3; 64]); LINES];
    let base = lines.as_ptr() as usize;
    let s = MeshStorage::carve(5, 2, &mut Block::from_lines(&mut lines)).unwrap();
    for (i, at) in [
        s.nodes.as_ptr() as usize,
        s.normals.as_ptr() as usize,
        s.tets.as_ptr() as usize,
    ]
    .into_iter()
    .enumerate()
    {
        assert_eq!((at - base) % 64, 0, "part {i} off its line");
    }
    assert_eq!((s.nodes.len(), s.normals.len(), s.tets.len()), (5, 5, 2));
    let unset = Node::new(TetId(u32::MAX), 0, false);
    assert!(s.nodes.iter().all(|n| *n == unset && !n.boundary()));
    assert!(s.normals.iter().all(|&n| n == Vec3::ZERO));
    let fresh = Tet {
        nodes: [NodeId(u32::MAX); 4],
        neighbours: [TetId(u32::MAX); 4],
        reverse: [Reverse(0); 4],
    };
    assert!(s.tets.iter().all(|t| *t == fresh));
    // The carved storage builds the mesh: every node on the boundary.
    let mut positions = POSITIONS;
    let mut scratch = [FaceKey::default(); 8];
    let mesh = Mesh::build(
        &mut positions,
        &TETS,
        s,
        &mut scratch,
        BuildOptions::default(),
    )
    .expect("builds");
    assert_eq!(mesh.tet_count(), 2);
    assert_eq!(mesh.stats().boundary_nodes, 5);
    // One line short: the tets do not fit, and the error names them.
    let err = MeshStorage::carve(5, 2, &mut Block::from_lines(&mut lines[1..])).unwrap_err();
    assert!(
        matches!(
            err,
            StorageError::TooSmall {
                part: Part::MeshTets,
                ..
            }
        ),
        "{err:?}"
    );
}
