//! What the C interface's tests share: caller memory, the block as C writes it, the C
//! parameters of a host scenario, and the host's replay of it.

#![allow(dead_code)] // each test binary uses its own share of these.

pub mod soft;

use std::alloc::{alloc_zeroed, dealloc, Layout};
use std::collections::BTreeMap;

use tetradrill::engine::{self, EngineStorage, TickParams, ToolSizing};
use tetradrill::scenario;
use tetradrill::setup::Setup;
use tetradrill::traces::{Pose, PoseSource};
use tetradrill_core::drill::Material;
use tetradrill_core::force::{ForceDigest, ToolState};
use tetradrill_core::servo::Saturations;
use tetradrill_ffi::*;

/// Caller memory for one world, freed on drop.
pub struct Memory {
    pub ptr: *mut u8,
    layout: Layout,
}

impl Memory {
    pub fn new(size: usize, align: usize) -> Self {
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
pub fn block_arrays(n: usize) -> (Vec<f32>, Vec<u32>) {
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
pub fn params_of(sc: &Setup, n: usize) -> TdParams {
    let p = params_of_mesh(sc);
    let (nn, nt) = tetradrill_core::builtin::block_counts(n);
    assert_eq!((p.node_count, p.tet_count), (nn as u32, nt as u32));
    p
}

/// The C parameters that mirror the host's scenario `sc`, for its own mesh.
pub fn params_of_mesh(sc: &Setup) -> TdParams {
    let loaded = engine::load_mesh(sc).expect("scenario mesh");
    let tick = TickParams::of(sc).expect("tick params");
    let mesh = loaded.mesh;
    let sizing = ToolSizing::of(&mesh, f64::from(tick.radius), sc.drilling.max_depth);
    let mut store = EngineStorage::new(mesh.clone(), sc).expect("storage");
    let candidates = store.candidate_capacity();
    let arena = store.hierarchy_capacity();
    let max_cells = store.world().expect("world").max_cells();
    let (nn, nt) = (mesh.positions().len(), mesh.tets().len());
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
        region_capacity: 0,
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
        servo_lag: 0,
        zone_gather_work: 0,
        vibration_hz: 0.0,
        shaft_nodes: 0,
        deformable: 0,
    };
    // SAFETY: `p` is a valid, aligned TdParams.
    assert_eq!(
        unsafe { td_params_default(nn as u32, nt as u32, &mut p) },
        TdStatus::TdOk
    );
    p.hierarchy_capacity = arena as u32;
    p.pending_capacity = sc.capacities.pending.unwrap_or(sizing.pending) as u32;
    p.candidate_capacity = candidates as u32;
    p.max_cells = max_cells;
    p.contact_search_nodes = sc.drilling.contact_search_nodes;
    p.tick_budget = sc.drilling.tick_budget;
    // The host bounds a drill tool's shaft walk only.
    if matches!(sc.tool, tetradrill::setup::Tool::Drill { .. }) {
        p.shaft_nodes = sc.drilling.shaft_nodes;
    }
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
    p.zone_gather_work = sc.drilling.zone_gather_work.unwrap_or(0);
    p
}

/// What a replay ended with: the force digest, the removed volume, the saturations and the
/// volume removed from each region by label.
pub struct Outcome {
    pub digest: u64,
    pub removed: f64,
    pub sat: Saturations,
    pub by_region: BTreeMap<i32, f64>,
}

/// The host's replay of `sc`, its mesh's labels and materials set as `replay` sets them.
pub fn host_replay(sc: &Setup) -> Outcome {
    let loaded = engine::load_mesh(sc).expect("scenario mesh");
    let params = TickParams::of(sc).expect("tick params");
    let poses = PoseSource::new(&sc.poses, Some(&loaded.mesh)).expect("poses");
    let mut store = EngineStorage::new(loaded.mesh, sc).expect("storage");
    store.set_labels(&loaded.labels, sc).expect("labels");
    let labels = store.region_labels().to_vec();
    let mut world = store.world().expect("world");
    let mut tool = ToolState::default();
    let mut digest = ForceDigest::new();
    for i in 0..poses.ticks() {
        let (f, _) = engine::tick(&mut world, &mut tool, &params, &poses.at(i));
        digest.push(f);
    }
    let by_region = engine::removed_by_region(&world, &labels)
        .expect("the host's world has regions")
        .into_iter()
        .map(|(l, v)| (l.parse::<i32>().expect("integer label"), v))
        .collect();
    Outcome {
        digest: digest.value(),
        removed: world.hierarchy().removed_volume(),
        sat: world.saturations(),
        by_region,
    }
}

/// The materials of `sc`'s regions, by label.
pub fn materials(sc: &Setup) -> Vec<(i32, Material)> {
    sc.materials
        .regions
        .iter()
        .map(|(&l, r)| (l, r.material()))
        .collect()
}

/// The built-in scenario `name`'s set-up.
pub fn builtin(name: &str) -> Setup {
    scenario::builtin(name)
        .expect("a built-in scenario")
        .setup()
        .expect("a valid set-up")
}

/// The labels of the `n`-block: the rule of `builtin::block_labels`.
pub fn block_labels(n: usize) -> Vec<i32> {
    let mut l = vec![0; tetradrill_core::builtin::block_counts(n).1];
    tetradrill_core::builtin::block_labels(n, &mut l).expect("labels");
    l
}

/// The counters' saturations as the core's.
pub fn saturations(c: &TdCounters) -> Saturations {
    Saturations {
        hash: c.sat_hash,
        candidates: c.sat_candidates,
        arena: c.sat_arena,
        pending: c.sat_pending,
        contact: c.sat_contact,
    }
}

/// A world for the `n`-block with `p`'s parameters in fresh memory, with `labels` (or none)
/// and `materials` set: the memory (keep it while the world is used) and the handle.
pub fn c_world(
    p: &TdParams,
    n: usize,
    labels: Option<&[i32]>,
    materials: &[(i32, Material)],
) -> (Memory, *mut TdWorld) {
    let (xyz, tets) = block_arrays(n);
    let (mut size, mut align) = (0usize, 0usize);
    // SAFETY: valid pointers to initialised or writable values.
    unsafe { assert_eq!(td_world_size(p, &mut size, &mut align), TdStatus::TdOk) };
    let mem = Memory::new(size, align);
    let mut world: *mut TdWorld = std::ptr::null_mut();
    let mut bad = 0u32;
    // SAFETY: memory of the size and alignment asked for, arrays of the counts in `p`.
    let st = unsafe {
        td_world_init(
            mem.ptr.cast(),
            size,
            p,
            xyz.as_ptr(),
            tets.as_ptr(),
            labels.map_or(std::ptr::null(), <[i32]>::as_ptr),
            &mut world,
            &mut bad,
        )
    };
    assert_eq!(st, TdStatus::TdOk);
    for &(label, m) in materials {
        // SAFETY: a live world.
        let st = unsafe { td_world_set_region(world, label, m.hardness, m.threshold, m.stiffness) };
        assert_eq!(st, TdStatus::TdOk, "region {label}");
    }
    (mem, world)
}

/// The C pose of a host pose.
pub fn td_pose(p: &Pose) -> TdPose {
    let [w, x, y, z] = p.rotation;
    TdPose {
        position: TdVec3 {
            x: p.position.x,
            y: p.position.y,
            z: p.position.z,
        },
        rotation: TdQuat { w, x, y, z },
    }
}
