//! The drilled surface through the C interface, called as C calls it: the demo replayed with
//! `td_world_tick`, a surface updated with a small budget every frame into buffers that a
//! mirror follows only through the reported ranges, and at the end the mirror's triangles
//! (corners and labels) equal to the host's `Surface::of` after the host's own replay. Every
//! bad pointer, handle and setting gets its status.

use std::alloc::{alloc_zeroed, dealloc, Layout};
use std::ptr;

use tetradrill::engine::{self, EngineStorage, TickParams, ToolSizing};
use tetradrill::scenario;
use tetradrill::setup::Setup;
use tetradrill::traces::PoseSource;
use tetradrill::Surface;
use tetradrill_core::force::ToolState;
use tetradrill_core::hierarchy::DEBRIS_LEAVES;
use tetradrill_ffi::*;

/// Caller memory, zeroed, freed on drop.
struct Memory {
    ptr: *mut u8,
    layout: Layout,
}

impl Memory {
    fn new(size: usize, align: usize) -> Self {
        let layout = Layout::from_size_align(size.max(1), align).expect("layout");
        // SAFETY: non-zero size.
        let ptr = unsafe { alloc_zeroed(layout) };
        assert!(!ptr.is_null(), "out of memory");
        Self { ptr, layout }
    }
}

impl Drop for Memory {
    fn drop(&mut self) {
        // SAFETY: allocated with this layout in `new`.
        unsafe { dealloc(self.ptr, self.layout) };
    }
}

/// The demo's set-up.
fn demo() -> Setup {
    scenario::builtin("demo")
        .expect("demo")
        .setup()
        .expect("set-up")
}

/// The C parameters of the demo as the host sizes it (what `replay` prints as sizing).
fn params(sc: &Setup, nodes: u32, tets: u32) -> TdParams {
    let loaded = engine::load_mesh(sc).expect("mesh");
    let tick = TickParams::of(sc).expect("tick params");
    let sizing = ToolSizing::of(&loaded.mesh, f64::from(tick.radius), sc.drilling.max_depth);
    let mut store = EngineStorage::new(loaded.mesh, sc).expect("storage");
    let mut p = std::mem::MaybeUninit::<TdParams>::zeroed();
    // SAFETY: a writable TdParams.
    assert_eq!(
        unsafe { td_params_default(nodes, tets, p.as_mut_ptr()) },
        TdStatus::TdOk
    );
    // SAFETY: written by `td_params_default`.
    let mut p = unsafe { p.assume_init() };
    p.hierarchy_capacity = store.hierarchy_capacity() as u32;
    p.pending_capacity = sc.capacities.pending.unwrap_or(sizing.pending) as u32;
    p.candidate_capacity = store.candidate_capacity() as u32;
    p.max_cells = store.world().expect("world").max_cells();
    p.contact_search_nodes = sc.drilling.contact_search_nodes;
    p.tick_budget = sc.drilling.tick_budget;
    p.max_depth = u32::from(tick.drill.max_depth);
    p.budget_per_tick = tick.drill.budget;
    p.radius = tick.radius;
    p.reach = tick.reach;
    p.min_area = tick.drill.min_area;
    p.stiffness = tick.force.stiffness;
    p.damping = tick.force.damping;
    p.max_force = tick.force.max_force;
    p.dt = tick.force.dt;
    p.switch_time = tick.force.switch_time;
    p.servo_lag = tick.servo_lag;
    p
}

/// A triangle as compared: its corners' bits and its label.
type Tri = ([u32; 9], i32);

/// The host's replay of the demo, its debris erased as `replay` erases it once the path
/// ends, then its drilled surface with the mesh's labels.
fn host_surface(sc: &Setup) -> Vec<Tri> {
    let loaded = engine::load_mesh(sc).expect("mesh");
    let params = TickParams::of(sc).expect("params");
    let poses = PoseSource::new(&sc.poses, Some(&loaded.mesh)).expect("poses");
    let mut store = EngineStorage::new(loaded.mesh, sc).expect("storage");
    store.set_labels(&loaded.labels, sc).expect("labels");
    let mut world = store.world().expect("world");
    let mut tool = ToolState::default();
    for i in 0..poses.ticks() {
        engine::tick(&mut world, &mut tool, &params, &poses.at(i));
    }
    let mut scratch = vec![0u32; world.hierarchy().debris_scratch_needed()];
    let debris = world
        .remove_debris(DEBRIS_LEAVES, sc.drilling.max_depth, &mut scratch)
        .expect("debris");
    assert!(debris.pieces > 0, "the demo leaves crumbs");
    let s = Surface::of(&world, &loaded.labels);
    let mut v: Vec<Tri> = s
        .corners
        .iter()
        .zip(&s.labels)
        .map(|(c, &l)| {
            let mut b = [0u32; 9];
            for (k, x) in c.iter().flat_map(|v| v.to_array()).enumerate() {
                b[k] = x.to_bits();
            }
            (b, l)
        })
        .collect();
    v.sort_unstable();
    v
}

/// The caller's buffers for `n` slots and their mirror.
struct Buffers {
    pos: Vec<f32>,
    nrm: Vec<f32>,
    lab: Vec<i32>,
    idx: Vec<u32>,
    ranges: Vec<TdSlotRange>,
    mirror: (Vec<f32>, Vec<f32>, Vec<i32>, Vec<u32>),
}

impl Buffers {
    fn new(n: usize, ranges: usize) -> Self {
        Self {
            pos: vec![0.0; 9 * n],
            nrm: vec![0.0; 9 * n],
            lab: vec![0; 3 * n],
            idx: vec![0; 3 * n],
            ranges: vec![TdSlotRange::default(); ranges],
            mirror: (
                vec![0.0; 9 * n],
                vec![0.0; 9 * n],
                vec![0; 3 * n],
                vec![0; 3 * n],
            ),
        }
    }

    fn c(&mut self) -> TdSurfaceBuffers {
        TdSurfaceBuffers {
            positions: self.pos.as_mut_ptr(),
            normals: self.nrm.as_mut_ptr(),
            labels: self.lab.as_mut_ptr(),
            indices: self.idx.as_mut_ptr(),
            ranges: self.ranges.as_mut_ptr(),
            range_capacity: self.ranges.len() as u32,
        }
    }

    /// One update, the mirror fed from its ranges and compared with the buffers.
    fn update(&mut self, s: *mut TdSurface, w: *mut TdWorld, budget: u32) -> TdSurfaceReport {
        let b = self.c();
        let mut rep = TdSurfaceReport::default();
        // SAFETY: live handles, buffers of the surface's slots, a writable report.
        let st = unsafe { td_surface_update(s, w, budget, &b, &mut rep) };
        assert_eq!(st, TdStatus::TdOk);
        let m = &mut self.mirror;
        for r in &self.ranges[..rep.ranges as usize] {
            let (a, e) = (3 * r.first as usize, 3 * (r.first + r.count) as usize);
            m.0[3 * a..3 * e].copy_from_slice(&self.pos[3 * a..3 * e]);
            m.1[3 * a..3 * e].copy_from_slice(&self.nrm[3 * a..3 * e]);
            m.2[a..e].copy_from_slice(&self.lab[a..e]);
            m.3[a..e].copy_from_slice(&self.idx[a..e]);
        }
        assert!(m.0 == self.pos && m.1 == self.nrm, "the mirror differs");
        assert!(m.2 == self.lab && m.3 == self.idx, "the mirror differs");
        rep
    }

    /// The mirror's live triangles, sorted.
    fn live(&self) -> Vec<Tri> {
        let (pos, _, lab, idx) = &self.mirror;
        let mut v: Vec<Tri> = (0..idx.len() / 3)
            .filter(|&s| idx[3 * s..3 * s + 3] != [0, 0, 0])
            .map(|s| {
                let mut b = [0u32; 9];
                for (k, x) in pos[9 * s..9 * s + 9].iter().enumerate() {
                    b[k] = x.to_bits();
                }
                (b, lab[3 * s])
            })
            .collect();
        v.sort_unstable();
        v
    }
}

/// A C world over the demo (labels and materials as `replay` sets them) in `mem`.
fn c_world(sc: &Setup, mem: &mut Option<Memory>) -> *mut TdWorld {
    let n = 8;
    let (nn, nt) = tetradrill_core::builtin::block_counts(n);
    let mut pos = vec![tetradrill_core::Vec3::ZERO; nn];
    let mut tets = vec![[0u32; 4]; nt];
    tetradrill_core::builtin::block(
        n,
        1.0 / n as f32,
        tetradrill_core::Vec3::splat(-0.5),
        &mut pos,
        &mut tets,
    )
    .expect("block");
    let xyz: Vec<f32> = pos.iter().flat_map(|v| v.to_array()).collect();
    let tets: Vec<u32> = tets.iter().flatten().copied().collect();
    let mut labels = vec![0; nt];
    tetradrill_core::builtin::block_labels(n, &mut labels).expect("labels");
    let p = params(sc, nn as u32, nt as u32);
    let (mut size, mut align) = (0usize, 0usize);
    // SAFETY: valid pointers.
    assert_eq!(
        unsafe { td_world_size(&p, &mut size, &mut align) },
        TdStatus::TdOk
    );
    let m = mem.insert(Memory::new(size, align));
    let mut world: *mut TdWorld = ptr::null_mut();
    let mut bad = 0;
    // SAFETY: memory of the size asked for, arrays of the counts in `p`.
    let st = unsafe {
        td_world_init(
            m.ptr.cast(),
            size,
            &p,
            xyz.as_ptr(),
            tets.as_ptr(),
            labels.as_ptr(),
            &mut world,
            &mut bad,
        )
    };
    assert_eq!(st, TdStatus::TdOk);
    for (&label, r) in &sc.materials.regions {
        let m = r.material();
        // SAFETY: a live world.
        let st = unsafe { td_world_set_region(world, label, m.hardness, m.threshold, m.stiffness) };
        assert_eq!(st, TdStatus::TdOk);
    }
    world
}

/// A surface of `slots` slots over `world` in `mem`.
fn c_surface(world: *mut TdWorld, slots: u32, mem: &mut Option<Memory>) -> *mut TdSurface {
    let (mut size, mut align) = (0usize, 0usize);
    // SAFETY: a live world, writable outputs.
    let st = unsafe { td_surface_size(world, slots, &mut size, &mut align) };
    assert_eq!((st, align), (TdStatus::TdOk, 64));
    let m = mem.insert(Memory::new(size, align));
    let mut s: *mut TdSurface = ptr::null_mut();
    // Too short a memory is refused.
    // SAFETY: memory of `size` bytes, a live world.
    let st = unsafe { td_surface_init(m.ptr.cast(), size - 1, world, slots, &mut s) };
    assert_eq!(st, TdStatus::TdErrTooSmall);
    // SAFETY: as above.
    let st = unsafe { td_surface_init(m.ptr.cast(), size, world, slots, &mut s) };
    assert_eq!(st, TdStatus::TdOk);
    assert_eq!(s.cast::<u8>(), m.ptr);
    s
}

/// Servo ticks a frame (60 Hz at 1 kHz) and work units a frame.
const FRAME: u32 = 17;
const BUDGET: u32 = 8192;
const SLOTS: u32 = 1 << 18;

#[test]
fn the_demo_surface_through_c_equals_the_hosts() {
    let sc = demo();
    let (mut wmem, mut smem) = (None, None);
    let world = c_world(&sc, &mut wmem);
    let surface = c_surface(world, SLOTS, &mut smem);
    let mut b = Buffers::new(SLOTS as usize, 32);
    let mut force = TdVec3::default();
    let mut up_to_date = 0;
    for i in 0..td_demo_ticks() {
        let (mut pose, mut buttons) = (TdVec3::default(), 0u32);
        // SAFETY: a live world and writable outputs.
        unsafe {
            assert_eq!(td_demo_pose(i, &mut pose, &mut buttons), TdStatus::TdOk);
            assert_eq!(
                td_world_tick(world, pose, buttons, &mut force),
                TdStatus::TdOk
            );
        }
        if (i + 1) % FRAME == 0 {
            let rep = b.update(surface, world, BUDGET);
            assert_eq!(rep.dropped, 0);
            up_to_date += u32::from(rep.pending == 0);
        }
    }
    // The debris, as `replay` erases it: a scratch too short is refused, then the one asked
    // for.
    let mut len = 0usize;
    let mut pieces = 0u32;
    // SAFETY: a live world, writable outputs, a scratch of the lengths given.
    unsafe {
        assert_eq!(td_world_debris_scratch(world, &mut len), TdStatus::TdOk);
        let mut scratch = vec![0u32; len];
        assert_eq!(
            td_world_remove_debris(world, scratch.as_mut_ptr(), len - 1, &mut pieces),
            TdStatus::TdErrTooSmall
        );
        assert_eq!(
            td_world_remove_debris(world, ptr::null_mut(), len, &mut pieces),
            TdStatus::TdErrNull
        );
        assert_eq!(pieces, 0);
        assert_eq!(
            td_world_remove_debris(world, scratch.as_mut_ptr(), len, &mut pieces),
            TdStatus::TdOk
        );
    }
    assert!(pieces > 0);
    let mut rep = b.update(surface, world, BUDGET);
    for _ in 0..100 {
        if rep.pending == 0 {
            break;
        }
        rep = b.update(surface, world, BUDGET);
    }
    assert_eq!(rep.pending, 0);
    let live = b.live();
    assert_eq!(live.len(), rep.live as usize);
    let mut c = TdCounters::default();
    // SAFETY: a live world.
    assert_eq!(unsafe { td_world_counters(world, &mut c) }, TdStatus::TdOk);
    assert_eq!(live.len(), c.visible_faces as usize);
    // Both regions' labels appear (the shell and the core).
    assert!(live.iter().any(|t| t.1 == 1) && live.iter().any(|t| t.1 == 2));
    assert!(up_to_date > 0);
    assert!(
        live == host_surface(&sc),
        "the C surface differs from the host's"
    );
}

#[test]
fn every_bad_argument_gets_its_status() {
    let sc = demo();
    let mut wmem = None;
    let world = c_world(&sc, &mut wmem);
    let (mut size, mut align) = (0usize, 0usize);
    // SAFETY (every call below): pointers that are valid, null, misaligned or to memory with
    // no world or surface, as each check needs; nothing is written through a bad one.
    unsafe {
        assert_eq!(
            td_surface_size(world, 0, &mut size, &mut align),
            TdStatus::TdErrParams
        );
        assert_eq!(
            td_surface_size(world, TD_MAX_TRIANGLES + 1, &mut size, &mut align),
            TdStatus::TdErrParams
        );
        assert_eq!(
            td_surface_size(ptr::null_mut(), 8, &mut size, &mut align),
            TdStatus::TdErrNull
        );
        assert_eq!(
            td_surface_size(world, 8, ptr::null_mut(), &mut align),
            TdStatus::TdErrNull
        );
        let mut junk = [0u64; 64];
        assert_eq!(
            td_surface_size(junk.as_mut_ptr().cast(), 8, &mut size, &mut align),
            TdStatus::TdErrNotInit
        );
        assert_eq!(
            td_surface_size(world, 8, &mut size, &mut align),
            TdStatus::TdOk
        );
        let mem = Memory::new(size + 64, 64);
        let mut s: *mut TdSurface = ptr::null_mut();
        assert_eq!(
            td_surface_init(mem.ptr.add(8).cast(), size, world, 8, &mut s),
            TdStatus::TdErrAlign
        );
        assert_eq!(
            td_surface_init(ptr::null_mut(), size, world, 8, &mut s),
            TdStatus::TdErrNull
        );
        assert_eq!(
            td_surface_update(mem.ptr.cast(), world, 10, ptr::null(), ptr::null_mut()),
            TdStatus::TdErrNull
        );
        let mut rep = TdSurfaceReport::default();
        let mut b = Buffers::new(8, 2);
        let cb = b.c();
        assert_eq!(
            td_surface_update(mem.ptr.cast(), world, 10, &cb, &mut rep),
            TdStatus::TdErrNotInit,
            "no surface in the memory yet"
        );
        assert_eq!(
            td_surface_init(mem.ptr.cast(), size, world, 8, &mut s),
            TdStatus::TdOk
        );
        assert_eq!(
            td_surface_update(s, world, 0, &cb, &mut rep),
            TdStatus::TdErrParams,
            "a budget of 0"
        );
        let mut no_ranges = cb;
        no_ranges.range_capacity = 0;
        assert_eq!(
            td_surface_update(s, world, 10, &no_ranges, &mut rep),
            TdStatus::TdErrParams
        );
        let mut null = cb;
        null.normals = ptr::null_mut();
        assert_eq!(
            td_surface_update(s, world, 10, &null, &mut rep),
            TdStatus::TdErrNull
        );
        let mut odd = cb;
        odd.labels = odd.labels.cast::<u8>().add(1).cast();
        assert_eq!(
            td_surface_update(s, world, 10, &odd, &mut rep),
            TdStatus::TdErrAlign
        );
        let mut overlap = cb;
        overlap.normals = overlap.positions.add(3);
        assert_eq!(
            td_surface_update(s, world, 10, &overlap, &mut rep),
            TdStatus::TdErrParams,
            "overlapping buffers"
        );
        let mut inside = cb;
        inside.ranges = s.cast::<u8>().add(size - 64).cast();
        assert_eq!(
            td_surface_update(s, world, 10, &inside, &mut rep),
            TdStatus::TdErrParams,
            "a buffer inside the surface's memory"
        );
        // Another world: not the surface's.
        let mut wmem2 = None;
        let other = c_world(&sc, &mut wmem2);
        assert_eq!(
            td_surface_update(s, other, 10, &cb, &mut rep),
            TdStatus::TdErrParams
        );
        assert_eq!(rep, TdSurfaceReport::default(), "an error writes nothing");
        // 8 slots for the block's 768 faces: the faces that do not fit are counted, the
        // buffers stay valid.
        let rep = b.update(s, world, 100_000);
        assert_eq!((rep.live, rep.used), (8, 8));
        assert!(rep.dropped > 0 && rep.pending > 0);
        assert_eq!(b.live().len(), 8);
    }
}

/// Per-corner normals by face: the corners' bits rotated to start at the smallest, and the
/// normal of each corner in that order.
type Normals = std::collections::HashMap<[[u32; 3]; 3], [[f32; 3]; 3]>;

fn put_face(map: &mut Normals, p: [[f32; 3]; 3], n: [[f32; 3]; 3]) {
    let b = p.map(|c| c.map(f32::to_bits));
    let first = (0..3).min_by_key(|&k| b[k]).expect("three corners");
    let r = [first, (first + 1) % 3, (first + 2) % 3];
    map.insert(r.map(|k| b[k]), r.map(|k| n[k]));
}

/// The host's `replay --surface` OBJ of the demo (its debris erased as `replay` does), read
/// back: each face's corners' normals.
fn host_obj_normals(sc: &Setup) -> Normals {
    let loaded = engine::load_mesh(sc).expect("mesh");
    let params = TickParams::of(sc).expect("params");
    let poses = PoseSource::new(&sc.poses, Some(&loaded.mesh)).expect("poses");
    let mut store = EngineStorage::new(loaded.mesh, sc).expect("storage");
    store.set_labels(&loaded.labels, sc).expect("labels");
    let mut world = store.world().expect("world");
    let mut tool = ToolState::default();
    for i in 0..poses.ticks() {
        engine::tick(&mut world, &mut tool, &params, &poses.at(i));
    }
    let mut scratch = vec![0u32; world.hierarchy().debris_scratch_needed()];
    world
        .remove_debris(DEBRIS_LEAVES, sc.drilling.max_depth, &mut scratch)
        .expect("debris");
    let obj = tetradrill::smooth_surface::SmoothSurface::of(
        &world,
        &loaded.labels,
        tetradrill_core::hierarchy::SmoothNormals::CREASE_DEGREES,
    )
    .to_obj();
    let (mut v, mut vn, mut map) = (Vec::new(), Vec::new(), Normals::new());
    let three =
        |w: &[&str]| -> [f32; 3] { [0, 1, 2].map(|k| w[k].parse().expect("a number in the OBJ")) };
    for line in obj.lines() {
        let w: Vec<&str> = line.split_whitespace().collect();
        match w.first() {
            Some(&"v") => v.push(three(&w[1..])),
            Some(&"vn") => vn.push(three(&w[1..])),
            Some(&"f") => {
                let ix = [1, 2, 3].map(|k| {
                    let (a, b) = w[k].split_once("//").expect("f a//na");
                    let i = |s: &str| s.parse::<usize>().expect("an index") - 1;
                    (i(a), i(b))
                });
                put_face(&mut map, ix.map(|(a, _)| v[a]), ix.map(|(_, b)| vn[b]));
            }
            _ => {}
        }
    }
    map
}

#[test]
fn the_demo_smooth_normals_through_c_equal_the_hosts_obj() {
    let sc = demo();
    let mut wmem = None;
    let world = c_world(&sc, &mut wmem);
    let (mut size, mut align, mut plain) = (0usize, 0usize, 0usize);
    // SAFETY: a live world, writable outputs.
    unsafe {
        assert_eq!(
            td_surface_smooth_size(world, SLOTS, &mut size, &mut align),
            TdStatus::TdOk
        );
        assert_eq!(
            td_surface_size(world, SLOTS, &mut plain, &mut align),
            TdStatus::TdOk
        );
    }
    assert!(
        size > plain + 120 * SLOTS as usize,
        "{size} against {plain}"
    );
    let m = Memory::new(size, align);
    let mut s: *mut TdSurface = ptr::null_mut();
    // SAFETY: memory of `size` bytes, a live world.
    unsafe {
        assert_eq!(
            td_surface_init_smooth(m.ptr.cast(), size - 1, world, SLOTS, 0.0, &mut s),
            TdStatus::TdErrTooSmall
        );
        assert_eq!(
            td_surface_init_smooth(m.ptr.cast(), size, world, SLOTS, 0.0, &mut s),
            TdStatus::TdOk
        );
    }
    let mut b = Buffers::new(SLOTS as usize, 32);
    let mut force = TdVec3::default();
    for i in 0..td_demo_ticks() {
        let (mut pose, mut buttons) = (TdVec3::default(), 0u32);
        // SAFETY: a live world and writable outputs.
        unsafe {
            assert_eq!(td_demo_pose(i, &mut pose, &mut buttons), TdStatus::TdOk);
            assert_eq!(
                td_world_tick(world, pose, buttons, &mut force),
                TdStatus::TdOk
            );
        }
        if (i + 1) % FRAME == 0 {
            b.update(s, world, BUDGET);
        }
    }
    let (mut len, mut pieces) = (0usize, 0u32);
    // SAFETY: a live world, writable outputs, a scratch of the length given.
    unsafe {
        assert_eq!(td_world_debris_scratch(world, &mut len), TdStatus::TdOk);
        let mut scratch = vec![0u32; len];
        assert_eq!(
            td_world_remove_debris(world, scratch.as_mut_ptr(), len, &mut pieces),
            TdStatus::TdOk
        );
    }
    let mut rep = b.update(s, world, BUDGET);
    for _ in 0..10_000 {
        if rep.pending == 0 {
            break;
        }
        rep = b.update(s, world, BUDGET);
    }
    assert_eq!(rep.pending, 0);
    let mut stats = TdSmoothStats::default();
    // SAFETY: a live surface, a writable output.
    assert_eq!(
        unsafe { td_surface_smooth_stats(s, &mut stats) },
        TdStatus::TdOk
    );
    // Every corner found a vertex; a full queue (as when the whole surface is listed at
    // once) starts a sweep that leaves no stale normal once it ends.
    assert_eq!(stats.vertices_full, 0);
    assert!(stats.vertices > 0);
    let mut c = Normals::new();
    let (pos, nrm, _, idx) = &b.mirror;
    for slot in (0..idx.len() / 3).filter(|&k| idx[3 * k..3 * k + 3] != [0, 0, 0]) {
        let at = |a: &[f32], k: usize| [0, 1, 2].map(|j| a[9 * slot + 3 * k + j]);
        put_face(
            &mut c,
            [0, 1, 2].map(|k| at(pos, k)),
            [0, 1, 2].map(|k| at(nrm, k)),
        );
    }
    let host = host_obj_normals(&sc);
    assert_eq!(c.len(), host.len());
    let mut smooth = 0usize;
    for (key, n) in &c {
        let h = host.get(key).expect("the C face in the host's OBJ");
        for k in 0..3 {
            let len = n[k].iter().map(|x| x * x).sum::<f32>().sqrt();
            assert!((len - 1.0).abs() < 1e-4, "a unit normal: {n:?}");
            for j in 0..3 {
                assert!((n[k][j] - h[k][j]).abs() < 1e-6, "{n:?} against {h:?}");
            }
        }
        smooth += usize::from(n[0] != n[1] || n[0] != n[2]);
    }
    assert!(
        smooth * 2 > c.len(),
        "{smooth} of {} faces shaded per corner",
        c.len()
    );
}
