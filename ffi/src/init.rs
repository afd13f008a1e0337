//! Setting a world up in the caller's memory: `td_world_init` from arrays, and the body it
//! shares with `td_world_init_blob` (a mesh read in place from a blob).

use super::*;

use tetradrill_core::collide::{ZoneGather, ZONE_MARGIN_RADII};
use tetradrill_core::servo::{carve_rest, SpareStorage};

/// Writes `n` copies of `v` from `base + offset` on and returns them as a slice.
///
/// # Safety
/// `base + offset` is aligned for `T`, and `n` values of `T` from there lie inside memory the
/// caller owns for `'static` and nothing else borrows.
pub(crate) unsafe fn carve<T: Copy>(
    base: *mut u8,
    offset: usize,
    n: usize,
    v: T,
) -> &'static mut [T] {
    // SAFETY: inside the caller's memory (the function's contract); the plan put it there.
    let p = unsafe { base.add(offset) }.cast::<T>();
    for i in 0..n {
        // SAFETY: `i < n`, inside the region; aligned by the plan.
        unsafe { p.add(i).write(v) };
    }
    // SAFETY: every element was just written; the region is the caller's for `'static` and
    // borrowed by nothing else (the plan's regions do not overlap).
    unsafe { core::slice::from_raw_parts_mut(p, n) }
}

/// The index a mesh build error names (a tet, or a node for a non-finite position).
pub(crate) fn bad_index(e: &BuildError) -> u32 {
    match *e {
        BuildError::NodeOutOfRange { tet, .. }
        | BuildError::RepeatedNode { tet }
        | BuildError::ZeroVolume { tet }
        | BuildError::NonManifoldFace { tet }
        | BuildError::InconsistentFace { tet } => tet,
        BuildError::NonFinite { node } => node,
        _ => u32::MAX,
    }
}

/// Writes `v` to `*bad_item` when `bad_item` is not null and aligned.
///
/// # Safety
/// `bad_item` is null or points at a writable `uint32_t`.
pub(crate) unsafe fn report_bad(bad_item: *mut u32, v: u32) {
    if !bad_item.is_null() && bad_item.is_aligned() {
        // SAFETY: not null, aligned; writable by the caller's contract.
        unsafe { bad_item.write(v) };
    }
}

/// The distinct values of the `count` labels `label(0..count)` in ascending order, written to
/// the front of `slots`; their count, or the first index whose value does not fit.
///
/// # Bounded work
/// O(L log S + S^2) for L labels and S slots.
fn distinct_labels(
    count: usize,
    label: impl Fn(usize) -> i32,
    slots: &mut [i32],
) -> Result<usize, usize> {
    let mut n = 0;
    for t in 0..count {
        let l = label(t);
        let at = match slots.get(..n).map(|s| s.binary_search(&l)) {
            Some(Err(at)) => at,
            _ => continue,
        };
        if n == slots.len() {
            return Err(t);
        }
        // Insert at `at`, shifting the larger labels one slot up.
        let mut carry = l;
        for slot in slots.iter_mut().take(n + 1).skip(at) {
            core::mem::swap(slot, &mut carry);
        }
        n += 1;
    }
    Ok(n)
}

/// Where a world's mesh comes from.
pub(crate) enum Source<'a> {
    /// Arrays built into a mesh in the world's memory: x, y, z per node, four node indices and
    /// (or not) a region label per tet.
    Arrays {
        xyz: &'a [f32],
        tets: &'a [[u32; 4]],
        labels: Option<&'a [i32]>,
    },
    /// A blob whose tets are read in place (and its labels with them); the caller keeps it
    /// for as long as the world.
    Blob(MeshBlob<'static>),
}

/// Sets a world up in `mem` from `source` (the body of `td_world_init` and
/// `td_world_init_blob`): the plan's checks of the memory, then the mesh, its regions, the
/// world, the hand-off and the servo, each part written before it is used, the markers last.
///
/// # Safety
/// `mem` points at `len` writable bytes the caller keeps, untouched, for as long as it uses the
/// world; `out` is checked by the caller; `bad_item` is null or writable.
pub(crate) unsafe fn init(
    mem: *mut c_void,
    len: usize,
    p: &TdParams,
    source: Source<'_>,
    out: *mut *mut TdWorld,
    bad_item: *mut u32,
) -> Status {
    let plan = Plan::of(p, matches!(source, Source::Blob(_)))?;
    let base = caller_memory(mem, len, plan.size, plan.align)?;
    let state = base.cast::<State>();
    // SAFETY: `mem` is aligned for State (the plan's alignment covers it) and at least
    // `plan.size >= size_of::<State>()` bytes long: a handle to this memory is refused from
    // here on until the init succeeds.
    unsafe { ptr::addr_of_mut!((*state).magic).write(0) };
    // SAFETY: the plan's servo region lies inside `mem`, aligned for its type: its handle
    // (from an earlier world in this memory) is refused too until the init succeeds.
    let servo = unsafe { base.add(plan.servo) }.cast::<ServoState>();
    // SAFETY: as above.
    unsafe { ptr::addr_of_mut!((*servo).magic).write(0) };

    // SAFETY: every offset comes from the plan, which places each region after the header at
    // its type's alignment, apart from the others, inside `plan.size <= len` bytes of `mem`;
    // the caller keeps `mem` for as long as the world is used.
    let (pos, mesh_lines, scratch, world_lines) = unsafe {
        (
            carve(base, plan.positions, plan.nodes, Vec3::ZERO),
            carve(base, plan.mesh, plan.mesh_lines, Line::ZERO),
            carve(base, plan.scratch, plan.faces, FaceKey::default()),
            carve(base, plan.world, plan.world_lines, Line::ZERO),
        )
    };
    // The world's parts, from their lines by the core's one layout (the plan sized them).
    let storage = WorldStorage::carve(&plan.sizes, &mut Block::from_lines(world_lines))
        .map_err(|_| TdStatus::TdErrTooSmall)?;
    // The mesh's parts likewise: node records, normals and (built here) tet records.
    let built = if plan.faces == 0 { 0 } else { plan.tets };
    let mesh_storage = MeshStorage::carve(plan.nodes, built, &mut Block::from_lines(mesh_lines))
        .map_err(|_| TdStatus::TdErrTooSmall)?;
    let (mesh, labels) = match source {
        Source::Arrays { xyz, tets, labels } => {
            for (p, c) in pos.iter_mut().zip(xyz.chunks_exact(3)) {
                *p = Vec3::new(c[0], c[1], c[2]);
            }
            let mesh = Mesh::build(pos, tets, mesh_storage, scratch, BuildOptions::default())
                .map_err(|e| {
                    // SAFETY: the caller's contract on `bad_item`.
                    unsafe { report_bad(bad_item, bad_index(&e)) };
                    TdStatus::TdErrMesh
                })?;
            (mesh, labels.map(Labels::Slice))
        }
        Source::Blob(blob) => {
            let MeshStorage { nodes, normals, .. } = mesh_storage;
            let mesh = blob
                .mesh(pos, normals, nodes)
                .map_err(|_| TdStatus::TdErrTooSmall)?;
            (mesh, Some(Labels::Blob(blob)))
        }
    };
    // SAFETY: as the carving above: the plan's label and tet-region regions.
    let (slots, of_tet) = unsafe {
        (
            carve(base, plan.region_labels, plan.region_slots, 0i32),
            carve(base, plan.tet_region, plan.tets, 0u8),
        )
    };
    let count = match labels {
        None => 1,
        Some(ls) => {
            let n = distinct_labels(plan.tets, |t| ls.get(t), slots).map_err(|t| {
                // SAFETY: the caller's contract on `bad_item`.
                unsafe { report_bad(bad_item, t as u32) };
                TdStatus::TdErrLabel
            })?;
            let distinct = slots.get(..n).unwrap_or(&[]);
            for (t, r) in of_tet.iter_mut().enumerate() {
                // At most 256 regions (the plan's check): the index fits a byte.
                *r = distinct.binary_search(&ls.get(t)).unwrap_or(0) as u8;
            }
            n
        }
    };
    let slots: &'static [i32] = slots;
    let region_labels = slots.get(..count).unwrap_or(&[]);
    // SAFETY: as the carving above: the plan's region table, `count <= region_slots`.
    let table = unsafe { carve(base, plan.regions, count, Region::default()) };
    // The core's check of the table, now rather than at the first step.
    Regions::new(&mut *table, of_tet).map_err(|_| TdStatus::TdErrWorld)?;
    // SAFETY: as the carving above: the plan's hand-off region, aligned for its type; nothing
    // else refers to it yet.
    let handoff: &'static ContactHandoff = unsafe {
        let h = base.add(plan.handoff).cast::<SharedHandoff>();
        h.write(SharedHandoff::default());
        &(*h).0
    };
    // SAFETY: as above: the plan's drill hand-off region.
    let drill_handoff: &'static tetradrill_core::servo::DrillHandoff = unsafe {
        let h = base.add(plan.drill_handoff).cast::<SharedDrillHandoff>();
        h.write(SharedDrillHandoff::default());
        &(*h).0
    };
    let force = ForceParams {
        stiffness: p.stiffness,
        damping: p.damping,
        max_force: p.max_force,
        dt: p.dt,
        switch_time: p.switch_time,
    };
    let initial_volume = mesh.volume();
    let mut world = World::new(mesh, storage).map_err(|_| TdStatus::TdErrWorld)?;
    if let Some((at, lines)) = plan.deform {
        // SAFETY: as the carving above: the plan's deformation lines.
        let mut block = Block::from_lines(unsafe { carve(base, at, lines, Line::ZERO) });
        // The core's one layout of them, sized by the plan: it refuses only other sizes.
        let spare = SpareStorage::carve(&plan.sizes, plan.nodes, &mut block)
            .map_err(|_| TdStatus::TdErrTooSmall)?;
        let rest = carve_rest(plan.nodes, &mut block).map_err(|_| TdStatus::TdErrTooSmall)?;
        world
            .enable_deformation(rest)
            .and_then(|()| world.set_spare(spare))
            .map_err(|_| TdStatus::TdErrWorld)?;
    }
    world.set_contact_max_nodes(p.contact_search_nodes);
    world.set_max_cells(p.max_cells);
    world.set_tick_budget((p.tick_budget > 0).then_some(p.tick_budget));
    world.set_shaft_max_nodes((p.shaft_nodes > 0).then_some(p.shaft_nodes));
    world.set_vibration_hz(p.vibration_hz);
    world.set_zone_gather(
        (p.zone_gather_work > 0).then(|| ZoneGather::new(p.zone_gather_work, ZONE_MARGIN_RADII)),
    );
    // SAFETY: as the carving above: the plan's servo region, aligned for its type; its magic
    // comes with it, so its handle is valid from here (the world's from below).
    unsafe {
        servo.write(ServoState {
            magic: SERVO_MAGIC,
            servo: Servo::new(p.radius, force),
            handoff,
            drill: None,
            drill_handoff,
        })
    };
    let st = State {
        magic: MAGIC,
        world,
        handoff,
        servo,
        servo_seen: 0,
        manual_pressing: false,
        radius: p.radius,
        reach: p.reach,
        drill: DrillParams {
            // 1..=9, checked by the plan.
            max_depth: p.max_depth as u8,
            min_area: p.min_area,
            budget: p.budget_per_tick,
        },
        force,
        servo_lag: p.servo_lag == 1,
        steps: 0,
        initial_volume,
        labels: region_labels,
        unstarted: Some(Unstarted { table, of_tet }),
        shaft: None,
        drill_handoff,
        deformable: plan.deform.is_some(),
        link_cycle: 0,
    };
    // SAFETY: aligned, inside `mem` (checked above); the slices the world borrows start after
    // the header. Written whole, the magic last of all in effect: a handle is valid only once
    // this write is done.
    unsafe {
        state.write(st);
        put(out, state.cast::<TdWorld>())
    }
}

/// A mesh's region labels, by tet.
#[derive(Clone, Copy)]
enum Labels<'a> {
    /// One `i32` per tet.
    Slice(&'a [i32]),
    /// The blob's, read in place.
    Blob(MeshBlob<'static>),
}

impl Labels<'_> {
    /// Tet `t`'s label (0 past the end: the callers stay below the tet count).
    fn get(&self, t: usize) -> i32 {
        match self {
            Labels::Slice(s) => s.get(t).copied().unwrap_or(0),
            Labels::Blob(b) => b.label(TetId::from_idx(t)).unwrap_or(0),
        }
    }
}

/// Builds the mesh from `positions` (`3 * node_count` floats: x, y, z of each node) and
/// `tets` (`4 * tet_count` node indices from 0, any orientation), then the world over it,
/// all inside `mem` (`len` bytes, aligned as `td_world_size` says), and writes the world's
/// handle to `*out` (it is `mem`). The mesh is built as the host builds a mesh file's (tets
/// flipped to positive orientation and relabelled for refinement), the hash, hierarchy and
/// drill start empty, the digest and counters at zero.
///
/// `labels`, when not null, holds each tet's region label (`tet_count` `int32_t`s, any
/// values: a mesh file's region or physical tags): the world has one region per distinct
/// label, in ascending order, as `tetradrill replay` gives a mesh file's labels. Null: one
/// region, label 0, for every tet. Every region starts with the default material (hardness
/// 0, threshold 0, the parameters' stiffness: removed at once, whatever the force);
/// `td_world_set_region` changes it before the first step.
///
/// # Bounded work
/// O(T log T) for the mesh build's face sort plus O(every capacity) to initialise the storage,
/// and O(T log R + R^2) to find the R distinct labels, for T tets; once, before the servo runs.
///
/// # Errors
/// `TD_ERR_NULL` / `TD_ERR_ALIGN` for a pointer (`mem` at the world's alignment, the arrays at
/// 4 bytes), `TD_ERR_PARAMS` as `td_world_size`, `TD_ERR_TOO_SMALL` when `len` is short,
/// `TD_ERR_MESH` for refused arrays (`*bad_item`, when `bad_item` is not null, gets the tet, or
/// for a non-finite position the node, at fault), `TD_ERR_LABEL` for more distinct labels
/// than `region_capacity` (`*bad_item` gets the first tet whose label does not fit),
/// `TD_ERR_WORLD` when the core refuses the storage. On any error after the checks of `mem`
/// the memory holds no world.
///
/// # Safety
/// `params` points at an initialised `td_params`; `positions` at `3 * node_count` floats,
/// `tets` at `4 * tet_count` `uint32_t`s and `labels` at `tet_count` `int32_t`s or null, none
/// inside `mem`; `mem` at `len` writable bytes that the caller keeps, and does not read or
/// write, for as long as it uses the world (there is nothing to free: stop using the handle,
/// then reuse the memory); `out` at a writable `td_world *`; `bad_item` at a writable
/// `uint32_t` or null.
#[no_mangle]
pub unsafe extern "C" fn td_world_init(
    mem: *mut c_void,
    len: usize,
    params: *const TdParams,
    positions: *const f32,
    tets: *const u32,
    labels: *const i32,
    out: *mut *mut TdWorld,
    bad_item: *mut u32,
) -> TdStatus {
    status(|| {
        check_ptr(out)?;
        check_ptr(positions)?;
        check_ptr(tets)?;
        if !labels.is_null() {
            check_ptr(labels)?;
        }
        // SAFETY: the caller's contract on `params`; `get` checks null and alignment.
        let p = unsafe { get(params) }?;
        let plan = Plan::of(&p, false)?;
        // SAFETY: the caller's contract: `3 * node_count` floats, `4 * tet_count` indices and
        // (when not null) `tet_count` labels, aligned (checked), outside `mem`. The products
        // fit (counts are at most 2^28, checked by the plan).
        let source = unsafe {
            Source::Arrays {
                xyz: core::slice::from_raw_parts(positions, 3 * plan.nodes),
                tets: core::slice::from_raw_parts(tets.cast::<[u32; 4]>(), plan.tets),
                labels: (!labels.is_null()).then(|| core::slice::from_raw_parts(labels, plan.tets)),
            }
        };
        // SAFETY: the caller's contract on `mem`, `len` and `bad_item`; `out` checked.
        unsafe { init(mem, len, &p, source, out, bad_item) }
    })
}
