//! The mesh blob a firmware reads in place (`MeshBlob::parse`) and its tet view
//! (`TetView::new`). The first input byte picks: even, the rest is a whole blob (header,
//! lengths, checksum, records); odd, the next two bytes are a node count and the rest are tet
//! records, checked without a checksum in the way, so the record checks get the inputs.
//!
//! Properties: no panic; a refusal prints on one line; an accepted blob's counts match its
//! length; a mesh over an accepted view (`Mesh::in_place`) gives every tet's nodes and
//! neighbours in range, every face match and vertex match inside the mesh, and its
//! `validate()` and `update_boundary()` return.

#![no_main]

use libfuzzer_sys::fuzz_target;
use tetradrill_core::blob::{self, MeshBlob};
use tetradrill_core::mesh::{BuildStats, FaceUse, Mesh, Node, TetView};
use tetradrill_core::{TetId, Vec3};

fuzz_target!(|data: &[u8]| {
    let Some((&mode, rest)) = data.split_first() else {
        return;
    };
    if mode % 2 == 0 {
        match MeshBlob::parse(rest) {
            Ok(b) => {
                assert_eq!(
                    blob::blob_len(b.node_count(), b.tet_count()),
                    Some(rest.len())
                );
                walk(b.tets());
                let n = b.node_count();
                let (mut p, mut q, mut r) = (
                    vec![Vec3::ZERO; n],
                    vec![Vec3::ZERO; n],
                    vec![Node::default(); n],
                );
                let mesh = b
                    .mesh(&mut p, &mut q, &mut r)
                    .expect("storage of the node count");
                let _ = mesh.validate();
            }
            Err(e) => one_line(&e.to_string()),
        }
        return;
    }
    if rest.len() < 2 {
        return;
    }
    let nodes = u16::from_le_bytes([rest[0], rest[1]]) as usize;
    match TetView::new(&rest[2..], nodes) {
        Ok(view) => walk(view),
        Err(e) => one_line(&e.to_string()),
    }
});

fn one_line(msg: &str) {
    assert!(
        !msg.is_empty() && !msg.contains(['\n', '\r']),
        "not one line: {msg:?}"
    );
}

/// A mesh over the view, its nodes at distinct positions: every accessor stays in range.
fn walk(view: TetView<'_>) {
    let (n, t) = (view.node_count(), view.len());
    let mut positions: Vec<Vec3> = (0..n)
        .map(|i| Vec3::new(i as f32, (i % 7) as f32, (i % 3) as f32))
        .collect();
    let mut normals = vec![Vec3::ZERO; n];
    let mut nodes = vec![Node::default(); n];
    let mut mesh = Mesh::in_place(
        &mut positions,
        &mut normals,
        &mut nodes,
        view,
        BuildStats::default(),
    )
    .expect("storage of the view's node count");
    for i in 0..t {
        let id = TetId::from_idx(i);
        assert!(mesh.tet_nodes(id).iter().all(|v| v.idx() < n));
        for f in 0..4u8 {
            let nb = mesh.neighbour(id, f);
            assert!(nb.is_none() || nb.idx() < t);
            if let Some(m) = mesh.face_match(FaceUse { tet: id, local: f }) {
                assert!(m.tet.idx() < t && m.local < 4);
            }
            for v in 0..4u8 {
                if let Some(u) = mesh.vertex_match(id, v, f) {
                    assert!(u.tet.idx() < t && u.local < 4);
                }
            }
        }
    }
    assert!(mesh.get_tet(TetId::from_idx(t)).is_none());
    let _ = mesh.validate();
    mesh.update_boundary();
}
