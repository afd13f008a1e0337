//! Meshes into the C interface from outside the program: a mesh file read through
//! `td_mesh_file_read` and the firmware's blob read in place by `td_world_init_blob` give the
//! host's replay of the same scenario, bit for bit; bad files and blobs get their status, line
//! or byte.

use std::collections::BTreeMap;
use std::ffi::{CStr, CString};
use std::ptr;

use tetradrill::engine;
use tetradrill::traces::PoseSource;
use tetradrill_core::blob;
use tetradrill_ffi::*;

mod common;
use common::*;

/// The tooth's access cavity, three materials, from its mesh file, its candidates gathered
/// over steps (`zone_gather_work`).
fn tooth() -> tetradrill::Setup {
    let sc = builtin("firmware-tooth");
    assert!(sc.drilling.zone_gather_work.is_some_and(|w| w > 0));
    sc
}

/// Replays `sc`'s trace through the C world at `world` (materials set first); the servo's
/// digest and each region's removed volume.
fn c_replay(sc: &tetradrill::Setup, world: *mut TdWorld) -> (u64, BTreeMap<i32, f64>) {
    let loaded = engine::load_mesh(sc).expect("mesh");
    let poses = PoseSource::new(&sc.poses, Some(&loaded.mesh)).expect("poses");
    for (label, m) in materials(sc) {
        // SAFETY: a live world.
        let st = unsafe { td_world_set_region(world, label, m.hardness, m.threshold, m.stiffness) };
        assert_eq!(st, TdStatus::TdOk, "region {label}");
    }
    let mut f = TdVec3::default();
    // The C interface's own copy of the trace is the host's, tick for tick.
    assert_eq!(sc.poses.to_string(), "builtin:tooth-access");
    assert_eq!(
        u64::from(td_script_ticks(TD_SCRIPT_TOOTH_ACCESS)),
        poses.ticks()
    );
    for i in 0..poses.ticks() {
        let pose = poses.at(i);
        let (mut at, mut buttons) = (TdVec3::default(), 0u32);
        // SAFETY: writable outputs.
        let tick = u32::try_from(i).expect("ticks fit u32");
        let st = unsafe { td_script_pose(TD_SCRIPT_TOOTH_ACCESS, tick, &mut at, &mut buttons) };
        assert_eq!(st, TdStatus::TdOk);
        assert_eq!(
            ([at.x, at.y, at.z], buttons),
            (pose.position.to_array(), pose.buttons),
            "tick {i}"
        );
        // SAFETY: a live world, a writable output.
        assert_eq!(
            unsafe { td_world_tick(world, at, pose.buttons, &mut f) },
            TdStatus::TdOk
        );
    }
    let (mut c, mut sc_) = (TdCounters::default(), TdServoCounts::default());
    let mut servo: *mut TdServo = ptr::null_mut();
    // SAFETY: a live world and its servo.
    unsafe {
        assert_eq!(td_world_counters(world, &mut c), TdStatus::TdOk);
        assert_eq!(td_world_servo(world, &mut servo), TdStatus::TdOk);
        assert_eq!(td_servo_counters(servo, &mut sc_), TdStatus::TdOk);
    }
    let mut by_region = BTreeMap::new();
    for i in 0..c.region_count {
        let mut r = TdRegion::default();
        // SAFETY: a live world, a writable output.
        unsafe { assert_eq!(td_world_region_at(world, i, &mut r), TdStatus::TdOk) };
        by_region.insert(r.label, r.removed_volume);
    }
    (sc_.force_digest, by_region)
}

/// Reads `path` through the C interface; the handle, or the status and the error.
fn read(path: &str) -> Result<*mut TdMeshFile, Box<(TdStatus, TdFileError)>> {
    let c = CString::new(path).expect("no NUL in the path");
    let mut file: *mut TdMeshFile = ptr::null_mut();
    let mut err = TdFileError {
        line: 7,
        byte: 7,
        message: [0; 512],
    };
    // SAFETY: a NUL-terminated path, writable outputs.
    match unsafe { td_mesh_file_read(c.as_ptr(), 1.0, &mut file, &mut err) } {
        TdStatus::TdOk => Ok(file),
        st => Err(Box::new((st, err))),
    }
}

fn message(e: &TdFileError) -> String {
    // SAFETY: the library writes a NUL-terminated string.
    unsafe { CStr::from_ptr(e.message.as_ptr()) }
        .to_string_lossy()
        .into_owned()
}

#[test]
fn a_mesh_file_read_through_c_drills_as_the_host_does() {
    let sc = tooth();
    let host = host_replay(&sc);
    let file =
        read(&sc.mesh.to_string()).unwrap_or_else(|e| panic!("{:?}: {}", e.0, message(&e.1)));
    let mut a = TdMeshArrays {
        node_count: 0,
        tet_count: 0,
        positions: ptr::null(),
        tets: ptr::null(),
        labels: ptr::null(),
    };
    // SAFETY: a live handle, a writable output.
    assert_eq!(unsafe { td_mesh_file_arrays(file, &mut a) }, TdStatus::TdOk);
    let p = params_of_mesh(&sc);
    assert_eq!((a.node_count, a.tet_count), (p.node_count, p.tet_count));
    assert!(!a.labels.is_null(), "the tooth's file has its labels");
    let (mut size, mut align) = (0usize, 0usize);
    let mut world: *mut TdWorld = ptr::null_mut();
    // SAFETY: the file's arrays, of the counts in `p`; memory of the size asked for.
    let mem = unsafe {
        assert_eq!(td_world_size(&p, &mut size, &mut align), TdStatus::TdOk);
        let mem = Memory::new(size, align);
        let st = td_world_init(
            mem.ptr.cast(),
            size,
            &p,
            a.positions,
            a.tets,
            a.labels,
            &mut world,
            ptr::null_mut(),
        );
        assert_eq!(st, TdStatus::TdOk);
        // The world copied what it needs: the file's arrays may go.
        td_mesh_file_free(file);
        mem
    };
    let (digest, by_region) = c_replay(&sc, world);
    assert_eq!(format!("{digest:016x}"), format!("{:016x}", host.digest));
    assert_eq!(by_region, host.by_region);
    assert_eq!(by_region.len(), 3, "enamel, dentin and pulp");
    assert!(by_region.values().filter(|&&v| v > 0.0).count() >= 2);
    drop(mem);
}

#[test]
fn a_blob_read_in_place_drills_as_the_host_does_in_less_memory() {
    let sc = tooth();
    let host = host_replay(&sc);
    let mut loaded = engine::load_mesh(&sc).expect("mesh");
    let labels = loaded.labels.clone();
    let view = loaded.mesh.view();
    let (nn, nt) = (view.node_count(), view.tet_count());
    let mut bytes = vec![0u8; blob::blob_len(nn, nt).expect("blob length")];
    blob::write(&view, &labels, &mut bytes).expect("blob");
    let bytes: &'static [u8] = Box::leak(bytes.into_boxed_slice());

    let (mut nodes, mut tets, mut bad) = (0u32, 0u32, 0u32);
    // SAFETY: the blob's bytes, writable outputs.
    unsafe {
        assert_eq!(
            td_blob_counts(bytes.as_ptr(), bytes.len(), &mut nodes, &mut tets, &mut bad),
            TdStatus::TdOk
        );
    }
    assert_eq!((nodes as usize, tets as usize), (nn, nt));
    let p = params_of_mesh(&sc);
    let (mut size, mut align, mut built_size) = (0usize, 0usize, 0usize);
    let mut world: *mut TdWorld = ptr::null_mut();
    // SAFETY: valid outputs; memory of the size asked for; the blob kept for the world's life.
    let mem = unsafe {
        assert_eq!(
            td_world_size(&p, &mut built_size, &mut align),
            TdStatus::TdOk
        );
        assert_eq!(
            td_world_size_blob(&p, &mut size, &mut align),
            TdStatus::TdOk
        );
        let mem = Memory::new(size, align);
        let mut q = p;
        q.tet_count += 1;
        assert_eq!(
            td_world_init_blob(
                mem.ptr.cast(),
                size,
                &q,
                bytes.as_ptr(),
                bytes.len(),
                &mut world,
                &mut bad
            ),
            TdStatus::TdErrParams,
            "counts other than the blob's"
        );
        let st = td_world_init_blob(
            mem.ptr.cast(),
            size,
            &p,
            bytes.as_ptr(),
            bytes.len(),
            &mut world,
            &mut bad,
        );
        assert_eq!(st, TdStatus::TdOk);
        mem
    };
    // No tet records, no build scratch: 36 + 64 bytes a tet less (to the line).
    assert!(
        built_size - size >= 100 * nt - 64 * 4,
        "{built_size} - {size}"
    );
    let (digest, by_region) = c_replay(&sc, world);
    assert_eq!(format!("{digest:016x}"), format!("{:016x}", host.digest));
    assert_eq!(by_region, host.by_region);
    drop(mem);
}

#[test]
fn a_bad_blob_names_its_byte() {
    let sc = tooth();
    let mut loaded = engine::load_mesh(&sc).expect("mesh");
    let labels = loaded.labels.clone();
    let view = loaded.mesh.view();
    let mut bytes = vec![0u8; blob::blob_len(view.node_count(), view.tet_count()).expect("len")];
    blob::write(&view, &labels, &mut bytes).expect("blob");
    let (mut n, mut t, mut bad) = (0u32, 0u32, 0u32);
    let counts = |b: &[u8], bad: &mut u32| {
        let (mut n, mut t) = (0u32, 0u32);
        // SAFETY: readable bytes, writable outputs.
        unsafe { td_blob_counts(b.as_ptr(), b.len(), &mut n, &mut t, bad) }
    };
    let mut magic = bytes.clone();
    magic[1] ^= 0xff;
    assert_eq!(counts(&magic, &mut bad), TdStatus::TdErrBlob);
    assert_eq!(bad, 0);
    let mut version = bytes.clone();
    version[4] = 9;
    assert_eq!(counts(&version, &mut bad), TdStatus::TdErrBlob);
    assert_eq!(bad, 4);
    let mut payload = bytes.clone();
    payload[100] ^= 1;
    assert_eq!(counts(&payload, &mut bad), TdStatus::TdErrBlob);
    assert_eq!(bad, 20, "the checksum's field");
    assert_eq!(
        counts(&bytes[..bytes.len() - 1], &mut bad),
        TdStatus::TdErrBlob
    );
    // SAFETY: null blob, writable outputs.
    unsafe {
        assert_eq!(
            td_blob_counts(ptr::null(), 0, &mut n, &mut t, &mut bad),
            TdStatus::TdErrNull
        );
    }
}

/// A scratch folder of this test's, removed at the end.
struct Scratch(std::path::PathBuf);

impl Scratch {
    fn new(name: &str) -> Self {
        let d = std::env::temp_dir().join(format!("tetradrill-ffi-{name}-{}", std::process::id()));
        std::fs::create_dir_all(&d).expect("scratch folder");
        Self(d)
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

#[test]
fn a_bad_mesh_file_names_its_file_and_line() {
    let dir = Scratch::new("files");
    // A one-tet TetGen pair whose .ele names node 9 on its line 2.
    let node = dir.0.join("one.node");
    std::fs::write(&node, "4 3 0 0\n0 0 0 0\n1 1 0 0\n2 0 1 0\n3 0 0 1\n").expect("write");
    std::fs::write(dir.0.join("one.ele"), "1 4 0\n0 0 1 2 9\n").expect("write");
    let (st, e) = *read(&node.to_string_lossy()).expect_err("refused");
    assert_eq!(st, TdStatus::TdErrFile);
    let m = message(&e);
    assert!(m.contains("one.ele:2:"), "{m}");
    assert_eq!((e.line, e.byte), (2, u64::MAX));
    // A missing file: the file named, no line.
    let gone = dir.0.join("gone.node");
    let (st, e) = *read(&gone.to_string_lossy()).expect_err("refused");
    assert_eq!(st, TdStatus::TdErrFile);
    assert!(message(&e).contains("gone.node"), "{}", message(&e));
    assert_eq!(e.line, 0);
    // A good file reads; null and a bad scale are refused before any reading.
    std::fs::write(dir.0.join("one.ele"), "1 4 0\n0 0 1 2 3\n").expect("write");
    let file = read(&node.to_string_lossy()).expect("a good file");
    let mut a = std::mem::MaybeUninit::<TdMeshArrays>::uninit();
    // SAFETY: a live handle, a writable output; freed once.
    unsafe {
        assert_eq!(td_mesh_file_arrays(file, a.as_mut_ptr()), TdStatus::TdOk);
        let a = a.assume_init();
        assert_eq!((a.node_count, a.tet_count), (4, 1));
        assert!(a.labels.is_null(), "no labels in the file");
        td_mesh_file_free(file);
        td_mesh_file_free(ptr::null_mut());
        let mut out: *mut TdMeshFile = ptr::null_mut();
        assert_eq!(
            td_mesh_file_read(ptr::null(), 1.0, &mut out, ptr::null_mut()),
            TdStatus::TdErrNull
        );
        let c = CString::new(node.to_string_lossy().into_owned()).expect("path");
        assert_eq!(
            td_mesh_file_read(c.as_ptr(), -1.0, &mut out, ptr::null_mut()),
            TdStatus::TdErrParams
        );
    }
}
