//! A mesh read in place from its blob ([`MeshBlob::mesh`], [`TetView`]): the counts `info`
//! prints for the file, the force digest `replay` prints for the file, every accessor of the
//! view and of the in-place mesh against the built records for every tet of the cow, and a
//! damaged record refused when the view is made (after which no accessor panics).
//!
//! Oracles: the `tetradrill` binary's `info` and `replay` JSON on the mesh file (they never
//! see a blob), and the mesh built from the file, read through its RAM records.

use rand::{Rng, SeedableRng};
use tetradrill::engine::{self, EngineStorage, ShaftState, TickParams};
use tetradrill::meshio::{self, LoadedMesh};
use tetradrill::scenario;
use tetradrill::traces::PoseSource;
use tetradrill_core::blob::{self, BlobError, MeshBlob, HEADER_LEN};
use tetradrill_core::force::{ForceDigest, ToolState};
use tetradrill_core::mesh::{FaceUse, Mesh, Node, TetStore, TetView, TetViewError, TET_RECORD};
use tetradrill_core::{NodeId, TetId, Vec3};
use tetradrill_tests::{meshes_dir, scratch_dir, tetradrill_bin};

const COW: &str = "models/spot_tetgen_q1.414.node";

fn cow() -> LoadedMesh {
    meshio::load(&meshes_dir().join(COW), 1.0).expect("the cow loads")
}

/// The blob of a loaded mesh with its own labels.
fn blob_of(m: &mut LoadedMesh) -> Vec<u8> {
    let labels = m.labels.clone();
    let mesh = m.mesh.view();
    let len = blob::blob_len(mesh.node_count(), mesh.tet_count()).expect("fits");
    let mut out = vec![0u8; len];
    blob::write(&mesh, &labels, &mut out).expect("written");
    out
}

/// RAM for the parts of an in-place mesh that stay in RAM.
struct NodeRam {
    positions: Vec<Vec3>,
    normals: Vec<Vec3>,
    nodes: Vec<Node>,
}

impl NodeRam {
    fn new(n: usize) -> Self {
        Self {
            positions: vec![Vec3::ZERO; n],
            normals: vec![Vec3::ZERO; n],
            nodes: vec![Node::default(); n],
        }
    }
    fn mesh<'a>(&'a mut self, blob: &MeshBlob<'a>) -> Mesh<'a> {
        blob.mesh(&mut self.positions, &mut self.normals, &mut self.nodes)
            .expect("node storage fits")
    }
}

fn run_json(args: &[&str], name: &str) -> serde_json::Value {
    let dir = scratch_dir("in_place", name);
    let out = dir.join("out.json");
    let status = std::process::Command::new(tetradrill_bin())
        .args(args)
        .arg("--json")
        .arg(&out)
        .status()
        .expect("run tetradrill");
    assert!(status.success(), "tetradrill {args:?}");
    serde_json::from_str(&std::fs::read_to_string(&out).expect("json")).expect("parses")
}

#[test]
fn in_place_cow_has_the_counts_info_prints_for_the_file() {
    let path = meshes_dir().join(COW);
    let info = run_json(&["info", "--mesh", path.to_str().unwrap()], "info");
    let mut m = cow();
    let bytes = blob_of(&mut m);
    let blob = MeshBlob::parse(&bytes).expect("parses");
    let mut ram = NodeRam::new(blob.node_count());
    let mesh = ram.mesh(&blob);
    assert!(matches!(mesh.tet_store(), TetStore::InPlace(_)));
    assert_eq!(info["tets"], mesh.tet_count());
    assert_eq!(info["nodes"], mesh.node_count());
    assert_eq!(info["boundary_faces"], mesh.stats().boundary_faces);
    assert_eq!(info["boundary_nodes"], mesh.stats().boundary_nodes);
    assert_eq!(info["unreferenced_nodes"], mesh.stats().unreferenced_nodes);
    let want = info["volume"].as_f64().expect("volume");
    let got = mesh.volume();
    assert!(
        (got - want).abs() <= 1e-6 * want.abs(),
        "volume {got} in place, {want} from info"
    );
    // The labels, counted per label from the blob.
    let mut counts = std::collections::BTreeMap::<String, u64>::new();
    for t in 0..blob.tet_count() {
        let label = blob.label(TetId::from_idx(t)).expect("in range");
        *counts.entry(label.to_string()).or_default() += 1;
    }
    let regions = info["regions"].as_object().expect("regions");
    let want: std::collections::BTreeMap<String, u64> = regions
        .iter()
        .map(|(k, v)| (k.clone(), v.as_u64().expect("count")))
        .collect();
    assert_eq!(counts, want);
    mesh.validate().expect("the in-place mesh validates");
}

#[test]
fn in_place_cow_replays_to_the_digest_of_the_file() {
    const TICKS: u64 = 1_500;
    let sc = scenario::builtin("firmware-cow")
        .expect("built-in")
        .setup()
        .expect("a valid set-up");
    let host = run_json(
        &[
            "replay",
            "--scenario",
            "builtin:firmware-cow",
            "--ticks",
            &TICKS.to_string(),
            "--quiet",
        ],
        "replay",
    );
    let want = host["force_digest"].as_str().expect("digest").to_string();

    let params = TickParams::of(&sc).expect("scenario");
    let mut loaded = engine::load_mesh(&sc).expect("the cow");
    let poses = PoseSource::new(&sc.poses, None).expect("poses");
    let bytes = blob_of(&mut loaded);
    let blob = MeshBlob::parse(&bytes).expect("parses");
    let mut ram = NodeRam::new(blob.node_count());
    let mesh = ram.mesh(&blob);
    let mut store = EngineStorage::new(loaded.mesh, &sc).expect("storage");
    store.set_labels(&loaded.labels, &sc).expect("labels");
    let mut world = store.world_with(mesh).expect("world");
    assert!(matches!(world.mesh().tet_store(), TetStore::InPlace(_)));
    let (mut tool, mut shaft) = (ToolState::default(), ShaftState::default());
    let mut digest = ForceDigest::new();
    let mut contact = 0;
    for i in 0..TICKS {
        let (f, _) = engine::tick_tool(&mut world, &mut tool, &mut shaft, &params, &poses.at(i));
        contact += u32::from(f != Vec3::ZERO);
        digest.push(f);
    }
    assert!(contact > 100, "the path touches the cow ({contact} ticks)");
    assert_eq!(format!("{:016x}", digest.value()), want);
}

#[test]
fn every_accessor_matches_the_records_for_every_cow_tet() {
    let mut m = cow();
    let bytes = blob_of(&mut m);
    let blob = MeshBlob::parse(&bytes).expect("parses");
    let view = blob.tets();
    let mut ram = NodeRam::new(blob.node_count());
    let flash = ram.mesh(&blob);
    let built = m.mesh.view();
    assert!(matches!(built.tet_store(), TetStore::Ram(_)));
    let t_count = built.tet_count();
    assert_eq!((view.len(), flash.tet_count()), (t_count, t_count));
    assert_eq!(view.node_count(), built.node_count());
    assert_eq!(flash.positions(), built.positions());
    assert_eq!(flash.normals(), built.normals());
    assert_eq!(flash.nodes(), built.nodes());
    assert_eq!(flash.stats().boundary_faces, built.stats().boundary_faces);
    assert_eq!(flash.stats().boundary_nodes, built.stats().boundary_nodes);
    assert_eq!(flash.volume().to_bits(), built.volume().to_bits());
    assert!(flash.tets().eq(built.tets()), "the iterators agree");
    assert_eq!(flash.tets().len(), t_count);

    for i in 0..t_count {
        let t = TetId::from_idx(i);
        let rec = built.tet(t);
        assert_eq!(view.get(t), Some(rec), "tet {i}");
        assert_eq!(view.nodes(t), Some(rec.nodes), "tet {i}");
        assert_eq!(flash.tet(t), rec, "tet {i}");
        assert_eq!(flash.get_tet(t), Some(rec), "tet {i}");
        assert_eq!(flash.tet_nodes(t), rec.nodes, "tet {i}");
        assert_eq!(flash.get_tet_nodes(t), Some(rec.nodes), "tet {i}");
        assert_eq!(flash.tet_positions(t), built.tet_positions(t), "tet {i}");
        for f in 0..4u8 {
            let k = f as usize;
            assert_eq!(
                view.neighbour(t, f),
                Some(rec.neighbours[k]),
                "tet {i} face {f}"
            );
            assert_eq!(view.reverse(t, f), Some(rec.reverse[k]), "tet {i} face {f}");
            assert_eq!(flash.neighbour(t, f), rec.neighbours[k], "tet {i} face {f}");
            assert_eq!(flash.get_neighbour(t, f), Some(rec.neighbours[k]));
            assert_eq!(flash.reverse(t, f), rec.reverse[k], "tet {i} face {f}");
            assert_eq!(flash.is_boundary_face(t, f), rec.neighbours[k].is_none());
            let face = FaceUse { tet: t, local: f };
            assert_eq!(flash.face_match(face), built.face_match(face));
            assert_eq!(flash.face_nodes(t, f), built.face_nodes(t, f));
            for v in 0..4u8 {
                assert_eq!(flash.vertex_match(t, v, f), built.vertex_match(t, v, f));
            }
        }
        assert_eq!(view.neighbour(t, 4), None);
        assert_eq!(view.reverse(t, 4), None);
        assert_eq!(flash.get_neighbour(t, 4), None);
    }
    // Out of range: `None`, or records of NONE ids; never a panic.
    let past = TetId::from_idx(t_count);
    assert_eq!(view.get(past), None);
    assert_eq!(view.nodes(past), None);
    assert_eq!(view.neighbour(past, 0), None);
    assert_eq!(view.reverse(past, 0), None);
    assert_eq!(flash.get_tet(past), None);
    assert_eq!(flash.tet_nodes(past), [NodeId::NONE; 4]);
    assert_eq!(flash.neighbour(past, 0), TetId::NONE);
    assert_eq!(flash.get_tet(TetId::NONE), None);
    assert_eq!(built.get_tet(past), None);
}

/// The tet bytes of the blob of the 2x2x2 block, with the node count.
fn block_tets() -> (Vec<u8>, usize, usize) {
    let mut m = meshio::load(std::path::Path::new("builtin:block:2"), 1.0).expect("block");
    let bytes = blob_of(&mut m);
    let n = u32::from_le_bytes(bytes[8..12].try_into().unwrap()) as usize;
    let t = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
    let start = HEADER_LEN + 32 * n;
    (bytes[start..start + TET_RECORD * t].to_vec(), n, start)
}

fn put32(b: &mut [u8], at: usize, v: u32) {
    b[at..at + 4].copy_from_slice(&v.to_le_bytes());
}

#[test]
fn a_damaged_record_is_refused_when_the_view_is_made() {
    let (tets, n, _) = block_tets();
    let t = tets.len() / TET_RECORD;
    assert!(TetView::new(&tets, n).is_ok());
    fn bad(what: &'static str, offset: usize) -> impl Fn(TetViewError) {
        move |e| match e {
            TetViewError::BadRecord { what: w, offset: o } => {
                assert!(w.contains(what), "{w}");
                assert_eq!(o, offset);
            }
            other => panic!("{other:?}"),
        }
    }
    // A node id out of range (tet 3, node slot 2).
    let mut b = tets.clone();
    put32(&mut b, 3 * TET_RECORD + 8, n as u32);
    bad("node id out of range", 3 * TET_RECORD + 8)(TetView::new(&b, n).unwrap_err());
    // Tet 0 is checked first, so its damage is the first found: its first inner face.
    let rec0: [u8; TET_RECORD] = tets[..TET_RECORD].try_into().unwrap();
    let neighbours: Vec<u32> = (0..4)
        .map(|k| u32::from_le_bytes(rec0[16 + 4 * k..20 + 4 * k].try_into().unwrap()))
        .collect();
    let f = (0..4)
        .find(|&f| neighbours[f] != u32::MAX)
        .expect("tet 0 has an inner face");
    // A neighbour id out of range.
    let mut b = tets.clone();
    put32(&mut b, 16 + 4 * f, t as u32);
    bad("neighbour id out of range", 16 + 4 * f)(TetView::new(&b, n).unwrap_err());
    // A neighbour that does not point back: the face sent to a tet that is not a neighbour.
    let stranger = (1..t as u32)
        .find(|x| !neighbours.contains(x))
        .expect("a stranger");
    let mut b = tets.clone();
    put32(&mut b, 16 + 4 * f, stranger);
    bad("point back", 32 + f)(TetView::new(&b, n).unwrap_err());
    // A ring offset of 3.
    let mut b = tets.clone();
    b[2 * TET_RECORD + 33] = (b[2 * TET_RECORD + 33] & 3) | (3 << 2);
    bad("reverse index", 2 * TET_RECORD + 33)(TetView::new(&b, n).unwrap_err());
    // Not a whole number of records.
    assert_eq!(
        TetView::new(&tets[..tets.len() - 1], n).unwrap_err(),
        TetViewError::Length {
            len: tets.len() - 1
        }
    );
    // Node ids checked against the count handed in.
    assert!(TetView::new(&tets, n - 1).is_err());
}

/// The same damage inside a blob whose checksum is made right again: `MeshBlob::parse`
/// refuses it at the byte offset in the blob.
#[test]
fn a_blob_with_a_damaged_record_and_a_good_checksum_is_refused() {
    let mut m = meshio::load(std::path::Path::new("builtin:block:2"), 1.0).expect("block");
    let mut bytes = blob_of(&mut m);
    let n = u32::from_le_bytes(bytes[8..12].try_into().unwrap()) as usize;
    let at = HEADER_LEN + 32 * n + 4 * TET_RECORD + 4;
    put32(&mut bytes, at, n as u32 + 7);
    let sum = blob::checksum(&bytes[HEADER_LEN..]);
    put32(&mut bytes, 20, sum);
    match MeshBlob::parse(&bytes) {
        Err(BlobError::BadRecord { offset, what }) => {
            assert_eq!(offset, at, "{what}");
        }
        other => panic!("{other:?}"),
    }
}

/// Seeded random damage to the records: the view is refused, or every accessor of the view
/// and of a mesh over it stays in range for every tet and face (no panic, ids inside).
#[test]
fn random_damage_is_refused_or_stays_in_range() {
    let (tets, n, _) = block_tets();
    let t = tets.len() / TET_RECORD;
    let mut rng = rand::rngs::StdRng::seed_from_u64(28);
    let (mut refused, mut accepted) = (0, 0);
    for _ in 0..2_000 {
        let mut b = tets.clone();
        for _ in 0..rng.gen_range(1..4) {
            let i = rng.gen_range(0..b.len());
            b[i] = match rng.gen_range(0..3) {
                0 => rng.gen(),
                1 => b[i] ^ (1 << rng.gen_range(0..8)),
                _ => 0xff,
            };
        }
        let Ok(view) = TetView::new(&b, n) else {
            refused += 1;
            continue;
        };
        accepted += 1;
        let mut ram = NodeRam::new(n);
        ram.positions.iter_mut().enumerate().for_each(|(i, p)| {
            *p = Vec3::splat(i as f32);
        });
        let mesh = Mesh::in_place(
            &mut ram.positions,
            &mut ram.normals,
            &mut ram.nodes,
            view,
            Default::default(),
        )
        .expect("storage fits");
        for i in 0..t {
            let id = TetId::from_idx(i);
            assert!(mesh.tet_nodes(id).iter().all(|v| v.idx() < n));
            mesh.tet_positions(id);
            for f in 0..4u8 {
                let nb = mesh.neighbour(id, f);
                assert!(nb.is_none() || nb.idx() < t);
                mesh.face_match(FaceUse { tet: id, local: f });
                for v in 0..4u8 {
                    if let Some(u) = mesh.vertex_match(id, v, f) {
                        assert!(u.tet.idx() < t && u.local < 4);
                    }
                }
            }
        }
    }
    assert!(refused > 1_000, "{refused} refused, {accepted} accepted");
}

/// `Mesh::in_place` refuses positions of another length than the view's node count.
#[test]
fn in_place_refuses_node_storage_of_the_wrong_length() {
    let (tets, n, _) = block_tets();
    let view = TetView::new(&tets, n).expect("view");
    let mut ram = NodeRam::new(n + 1);
    assert!(Mesh::in_place(
        &mut ram.positions,
        &mut ram.normals,
        &mut ram.nodes,
        view,
        Default::default()
    )
    .is_none());
    let mut ram = NodeRam::new(n);
    assert!(Mesh::in_place(
        &mut ram.positions,
        &mut ram.normals[..n - 1],
        &mut ram.nodes,
        view,
        Default::default()
    )
    .is_none());
    let mut m = meshio::load(std::path::Path::new("builtin:block:2"), 1.0).expect("block");
    let bytes = blob_of(&mut m);
    let blob = MeshBlob::parse(&bytes).expect("parses");
    let mut small = NodeRam::new(n - 1);
    assert_eq!(
        blob.mesh(&mut small.positions, &mut small.normals, &mut small.nodes)
            .err(),
        Some(BlobError::Buffer)
    );
}

/// The record layout, by hand: four node ids, four neighbour ids (`NONE` as `u32::MAX`), each
/// little-endian, then the four reverse-index bytes.
#[test]
fn a_tet_record_has_the_documented_bytes() {
    use tetradrill_core::mesh::{Reverse, Tet};
    let tet = Tet {
        nodes: [
            NodeId(1),
            NodeId(0x0203_0405),
            NodeId(7),
            NodeId(u32::MAX - 1),
        ],
        neighbours: [TetId::NONE, TetId(9), TetId(0x0a0b_0c0d), TetId(0)],
        reverse: [
            Reverse::new(3, 2),
            Reverse(0),
            Reverse::new(1, 1),
            Reverse::new(2, 0),
        ],
    };
    let golden: [u8; TET_RECORD] = [
        1, 0, 0, 0, 5, 4, 3, 2, 7, 0, 0, 0, 0xfe, 0xff, 0xff, 0xff, // nodes
        0xff, 0xff, 0xff, 0xff, 9, 0, 0, 0, 0x0d, 0x0c, 0x0b, 0x0a, 0, 0, 0, 0, // neighbours
        0x0b, 0, 0x05, 0x02, // reverse: face | offset << 2
    ];
    assert_eq!(tet.to_le_bytes(), golden);
    assert_eq!(Tet::from_le_bytes(&golden), tet);
}
