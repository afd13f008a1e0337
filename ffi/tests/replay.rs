//! The C interface, called as C calls it, against the host's replay engine: the same scenario
//! gives the same force digest, and every bad pointer, size, count and mesh gets its status.

use std::alloc::{alloc_zeroed, dealloc, Layout};
use std::ffi::CStr;
use std::ptr;

use tetradrill::engine::{self, EngineStorage, TickParams, ToolSizing};
use tetradrill::scenario::{self, Scenario};
use tetradrill::traces::PoseSource;
use tetradrill_core::force::{ForceDigest, ToolState};
use tetradrill_core::servo::Saturations;
use tetradrill_ffi::*;

/// Caller memory for one world, freed on drop.
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

/// The `n`-block as the C example writes it: nodes along x, then y, then z; six tets per
/// cube along the six axis paths from its low corner, in any orientation (the build flips).
fn block_arrays(n: usize) -> (Vec<f32>, Vec<u32>) {
    let (nn, nt) = tetradrill_core::builtin::block_counts(n);
    let mut p = vec![tetradrill_core::Vec3::ZERO; nn];
    let mut t = vec![[0u32; 4]; nt];
    let edge = 1.0 / n as f32;
    tetradrill_core::builtin::block(n, edge, tetradrill_core::Vec3::splat(-0.5), &mut p, &mut t)
        .expect("block");
    (
        p.iter().flat_map(|v| [v.x, v.y, v.z]).collect(),
        t.iter().flatten().copied().collect(),
    )
}

/// The C parameters that mirror the host's scenario `sc` (what `replay` prints as sizing
/// included), for a block of `n`.
fn params_of(sc: &Scenario, n: usize) -> TdParams {
    let loaded = engine::load_mesh(sc).expect("scenario mesh");
    let tick = TickParams::of(sc).expect("tick params");
    let mesh = loaded.mesh;
    let sizing = ToolSizing::of(&mesh, f64::from(tick.radius), sc.max_depth);
    let mut store = EngineStorage::try_allocate(mesh.clone(), sc).expect("storage");
    let candidates = store.candidate_capacity();
    let arena = store.hierarchy_capacity();
    let max_cells = store.world().expect("world").max_cells();
    let (nn, nt) = tetradrill_core::builtin::block_counts(n);
    let mut p = TdParams {
        node_count: 0,
        tet_count: 0,
        hierarchy_capacity: 0,
        pending_capacity: 0,
        candidate_capacity: 0,
        hash_capacity: 0,
        sphere_memo_slots: 0,
        max_cells: 0,
        contact_search_nodes: 0,
        tick_budget: 0,
        max_depth: 0,
        budget_per_tick: 0,
        radius: 0.0,
        reach: 0.0,
        min_area: 0.0,
        stiffness: 0.0,
        damping: 0.0,
        max_force: 0.0,
        dt: 0.0,
        switch_time: 0.0,
    };
    // SAFETY: `p` is a valid, aligned TdParams.
    assert_eq!(
        unsafe { td_params_default(nn as u32, nt as u32, &mut p) },
        TdStatus::TdOk
    );
    p.hierarchy_capacity = arena as u32;
    p.pending_capacity = sc.pending_capacity.unwrap_or(sizing.pending) as u32;
    p.candidate_capacity = candidates as u32;
    p.max_cells = max_cells;
    p.contact_search_nodes = sc.contact_search_nodes;
    p.tick_budget = sc.tick_budget;
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
    p
}

/// The host's replay of `sc`: its force digest, removed volume and saturations.
fn host_replay(sc: &Scenario) -> (u64, f64, Saturations) {
    let loaded = engine::load_mesh(sc).expect("scenario mesh");
    let params = TickParams::of(sc).expect("tick params");
    let poses = PoseSource::for_scenario(sc).expect("poses");
    let mut store = EngineStorage::try_allocate(loaded.mesh, sc).expect("storage");
    let mut world = store.world().expect("world");
    let mut tool = ToolState::default();
    let mut digest = ForceDigest::new();
    for i in 0..poses.ticks() {
        let (f, _) = engine::tick(&mut world, &mut tool, &params, &poses.at(i));
        digest.push(f);
    }
    (
        digest.value(),
        world.hierarchy().removed_volume(),
        world.saturations(),
    )
}

/// The counters' saturations as the core's.
fn saturations(c: &TdCounters) -> Saturations {
    Saturations {
        hash: c.sat_hash,
        candidates: c.sat_candidates,
        arena: c.sat_arena,
        pending: c.sat_pending,
        contact: c.sat_contact,
    }
}

/// The demo path through the C interface: a world in fresh memory, `td_world_tick` at every
/// `td_demo_pose`; the counters at the end.
fn c_replay(p: &TdParams, n: usize) -> TdCounters {
    let (xyz, tets) = block_arrays(n);
    let (mut size, mut align) = (0usize, 0usize);
    // SAFETY: valid pointers to initialised or writable values.
    unsafe {
        assert_eq!(td_world_size(p, &mut size, &mut align), TdStatus::TdOk);
    }
    let mem = Memory::new(size, align);
    let mut world: *mut TdWorld = ptr::null_mut();
    let mut bad = 0u32;
    // SAFETY: memory of the size and alignment asked for, arrays of the counts in `p`.
    let st = unsafe {
        td_world_init(
            mem.ptr.cast(),
            size,
            p,
            xyz.as_ptr(),
            tets.as_ptr(),
            &mut world,
            &mut bad,
        )
    };
    assert_eq!(st, TdStatus::TdOk);
    let mut force = TdVec3::default();
    for i in 0..td_demo_ticks() {
        let (mut pos, mut buttons) = (TdVec3::default(), 0u32);
        // SAFETY: a live world and writable outputs.
        unsafe {
            assert_eq!(td_demo_pose(i, &mut pos, &mut buttons), TdStatus::TdOk);
            assert_eq!(
                td_world_tick(world, pos, buttons, &mut force),
                TdStatus::TdOk
            );
        }
    }
    let mut c = TdCounters::default();
    // SAFETY: a live world.
    unsafe { assert_eq!(td_world_counters(world, &mut c), TdStatus::TdOk) };
    c
}

#[test]
fn demo_digest_equals_the_hosts_replay() {
    let sc = scenario::builtin("demo").expect("builtin:demo");
    assert_eq!(sc.mesh, "builtin:block:8");
    let (digest, removed, sat) = host_replay(&sc);
    let c = c_replay(&params_of(&sc, 8), 8);
    assert_eq!(
        format!("{:016x}", c.force_digest),
        format!("{digest:016x}"),
        "the C interface's demo digest differs from the host's replay"
    );
    assert_eq!(c.removed_volume, removed);
    assert_eq!(saturations(&c), sat);
    assert_eq!(c.sat_total, sat.total());
    assert_eq!(c.servo_ticks, 6001);
    assert_eq!(c.simulate_steps, 6001);
    assert!(c.removed_volume > 0.0, "the demo drills");
    assert!((c.initial_volume - 1.0).abs() < 1e-6, "unit block");
}

#[test]
fn firmware_digest_equals_the_hosts_replay() {
    let sc = scenario::builtin("firmware").expect("builtin:firmware");
    assert_eq!(sc.mesh, "builtin:block:4");
    let (digest, removed, sat) = host_replay(&sc);
    let c = c_replay(&params_of(&sc, 4), 4);
    assert_eq!(c.force_digest, digest);
    assert_eq!(c.removed_volume, removed);
    assert_eq!(saturations(&c), sat);
}

fn demo_params() -> TdParams {
    let (nn, nt) = tetradrill_core::builtin::block_counts(2);
    // SAFETY: all-zero is a valid TdParams (integers and floats).
    let mut p: TdParams = unsafe { std::mem::zeroed() };
    // SAFETY: valid pointer.
    unsafe { td_params_default(nn as u32, nt as u32, &mut p) };
    p.hierarchy_capacity = 4096;
    p.pending_capacity = 1024;
    p
}

#[test]
fn bad_pointers_sizes_and_counts_get_their_status() {
    let p = demo_params();
    let (xyz, tets) = block_arrays(2);
    let (mut size, mut align) = (0usize, 0usize);
    // SAFETY: every pointer below is valid, null, or deliberately misaligned; the functions
    // check before they touch any.
    unsafe {
        assert_eq!(
            td_params_default(1, 1, ptr::null_mut()),
            TdStatus::TdErrNull
        );
        assert_eq!(
            td_world_size(ptr::null(), &mut size, &mut align),
            TdStatus::TdErrNull
        );
        assert_eq!(
            td_world_size(&p, ptr::null_mut(), &mut align),
            TdStatus::TdErrNull
        );
        let mut q = p;
        q.tet_count = 0;
        assert_eq!(
            td_world_size(&q, &mut size, &mut align),
            TdStatus::TdErrParams
        );
        q = p;
        q.radius = f32::NAN;
        assert_eq!(
            td_world_size(&q, &mut size, &mut align),
            TdStatus::TdErrParams
        );
        q = p;
        q.hierarchy_capacity = 7;
        assert_eq!(
            td_world_size(&q, &mut size, &mut align),
            TdStatus::TdErrParams
        );
        q = p;
        q.max_depth = 10;
        assert_eq!(
            td_world_size(&q, &mut size, &mut align),
            TdStatus::TdErrParams
        );
        q = p;
        q.tet_count = TD_MAX_COUNT + 1;
        assert_eq!(
            td_world_size(&q, &mut size, &mut align),
            TdStatus::TdErrParams
        );
        assert_eq!(td_world_size(&p, &mut size, &mut align), TdStatus::TdOk);
        assert!(align.is_power_of_two() && size > STATE_BYTES);

        let mem = Memory::new(size + align, align);
        let mut world: *mut TdWorld = ptr::null_mut();
        let init = |m: *mut u8, len: usize, w: &mut *mut TdWorld| {
            td_world_init(
                m.cast(),
                len,
                &p,
                xyz.as_ptr(),
                tets.as_ptr(),
                w,
                ptr::null_mut(),
            )
        };
        assert_eq!(init(ptr::null_mut(), size, &mut world), TdStatus::TdErrNull);
        assert_eq!(init(mem.ptr.add(1), size, &mut world), TdStatus::TdErrAlign);
        assert_eq!(init(mem.ptr, size - 1, &mut world), TdStatus::TdErrTooSmall);
        assert!(world.is_null(), "no handle from a failed init");
        // A world pointer into memory that holds no world: refused, not read as one.
        let mut f = TdVec3::default();
        let at = TdVec3 {
            x: 0.0,
            y: 0.0,
            z: 0.9,
        };
        assert_eq!(
            td_world_servo_force(mem.ptr.cast(), at, &mut f),
            TdStatus::TdErrNotInit
        );
        assert_eq!(
            td_world_tick(ptr::null_mut(), at, 0, &mut f),
            TdStatus::TdErrNull
        );
        assert_eq!(
            td_world_tick(mem.ptr.add(1).cast(), at, 0, &mut f),
            TdStatus::TdErrAlign
        );

        assert_eq!(init(mem.ptr, size, &mut world), TdStatus::TdOk);
        assert_eq!(world.cast::<u8>(), mem.ptr, "the handle is the memory");
        let nan = TdVec3 { x: f32::NAN, ..at };
        assert_eq!(td_world_tick(world, nan, 1, &mut f), TdStatus::TdErrInput);
        assert_eq!(
            td_world_servo_force(world, at, ptr::null_mut()),
            TdStatus::TdErrNull
        );
        let mut rep = TdSimReport::default();
        assert_eq!(td_world_simulate(world, at, 0, &mut rep), TdStatus::TdOk);
        assert_eq!(
            td_world_simulate(
                world,
                at,
                0,
                (&mut rep as *mut TdSimReport).cast::<u8>().add(1).cast()
            ),
            TdStatus::TdErrAlign
        );
        let mut c = TdCounters::default();
        assert_eq!(td_world_counters(world, &mut c), TdStatus::TdOk);
        assert_eq!(
            (c.simulate_steps, c.servo_ticks),
            (1, 0),
            "refused calls count nothing"
        );

        // A failed init over a live world leaves no world behind.
        let mut q = p;
        q.radius = -1.0;
        assert_eq!(
            td_world_init(
                mem.ptr.cast(),
                size,
                &q,
                xyz.as_ptr(),
                tets.as_ptr(),
                &mut world,
                ptr::null_mut()
            ),
            TdStatus::TdErrParams
        );
        // Parameters are checked before the memory is touched: the world is still there.
        assert_eq!(td_world_counters(world, &mut c), TdStatus::TdOk);
        let mut bad_tets = tets.clone();
        bad_tets[4 * 5 + 2] = 999;
        let mut bad = 0u32;
        assert_eq!(
            td_world_init(
                mem.ptr.cast(),
                size,
                &p,
                xyz.as_ptr(),
                bad_tets.as_ptr(),
                &mut world,
                &mut bad
            ),
            TdStatus::TdErrMesh
        );
        assert_eq!(bad, 5, "the tet naming a node out of range");
        assert_eq!(td_world_counters(world, &mut c), TdStatus::TdErrNotInit);
        let mut flat = xyz.clone();
        flat[3 * 7 + 1] = f32::INFINITY;
        assert_eq!(
            td_world_init(
                mem.ptr.cast(),
                size,
                &p,
                flat.as_ptr(),
                tets.as_ptr(),
                &mut world,
                &mut bad
            ),
            TdStatus::TdErrMesh
        );
        assert_eq!(bad, 7, "the node that is not finite");
    }
}

#[test]
fn every_status_has_its_own_line() {
    let names: Vec<String> = (0..=8)
        .map(|code| {
            // SAFETY: td_status_name returns a static NUL-terminated string.
            unsafe { CStr::from_ptr(td_status_name(code)) }
                .to_str()
                .expect("ASCII")
                .to_owned()
        })
        .collect();
    assert_eq!(names[0], "ok");
    for (i, a) in names.iter().enumerate() {
        assert!(names[i + 1..].iter().all(|b| b != a), "{a} appears twice");
    }
    // SAFETY: as above.
    let unknown = unsafe { CStr::from_ptr(td_status_name(99)) };
    assert_eq!(unknown.to_str(), Ok("unknown status"));
    assert_eq!(TdStatus::TdErrInput as i32, 8);
}

#[test]
fn demo_pose_follows_the_script() {
    let (mut pos, mut buttons) = (TdVec3::default(), 7u32);
    // SAFETY: writable outputs, then null ones.
    unsafe {
        assert_eq!(td_demo_pose(0, &mut pos, &mut buttons), TdStatus::TdOk);
        assert_eq!((pos.z, buttons), (0.9, 0));
        assert_eq!(td_demo_pose(1000, &mut pos, &mut buttons), TdStatus::TdOk);
        assert_eq!(buttons, 1, "drilling at tick 1000");
        assert_eq!(
            td_demo_pose(0, ptr::null_mut(), &mut buttons),
            TdStatus::TdErrNull
        );
    }
    assert_eq!(td_demo_ticks(), 6001);
}
