//! The tet-mesh tool (the pen) through the C interface: a pen touching an object, both built
//! from arrays into caller memory, the contact pass (`td_pen_simulate`) and the servo's force
//! and torque (`td_pen_servo_wrench`) apart, sharing only the core's `PenHandoff`, as
//! `tetradrill replay --tool mesh:FILE` runs them.
//!
//! The memory is one block: a header, the hand-off, the servo's state, then the meshes and
//! every structure of the contact scene (node graphs, hashes, the pen's rest grid and
//! clusters, the object's occupancy grid with its lists) and the pass's buffers, each slice
//! at its alignment. The parts whose size the counts give come first (`td_pen_size`); those
//! the meshes' shapes give (the graphs' edges, the grids) follow, measured by `td_pen_init`
//! once the meshes are built in the first part.

use core::alloc::Layout;
use core::mem::{align_of, size_of};
use core::sync::atomic::AtomicU32;

use super::*;

mod init;

pub use init::td_pen_init;
use init::PenPlan;

use tetradrill_core::collide::{
    hash_tets, walks_exact, Body, GridEntry, ListedNode, Occupancy, OccupancyStorage, RigidTets,
    RigidTetsStorage, MAX_NEAR_CLUSTERS,
};
use tetradrill_core::depth::{graph_sizes, hash_boundary_faces, NodeGraph, Penetration};
use tetradrill_core::force::{
    occupancy_words, pen_pass, pen_servo_force, pen_torque, DepthMethod, ForceDigest, HeldContact,
    PenBufferSizes, PenBuffers, PenOptions, PenScene, PenState, ServoScratch, CLUSTER_EDGE,
    OCCUPANCY_LIST_SPLIT, OCCUPANCY_MARGIN, REST_GRID_EDGE, REST_MARGIN,
};
use tetradrill_core::hash::{average_edge_length, prime_at_most, Aabb, HashEntry, SpatialHash};
use tetradrill_core::ids::NodeId;
use tetradrill_core::servo::{PenHandoff, PenPublished};
use tetradrill_core::Quat;

/// Marks a [`PenHeader`] that `td_pen_init` finished ("tdpen001").
const PEN_MAGIC: u64 = u64::from_le_bytes(*b"tdpen001");

/// Marks a [`PenServoState`] that `td_pen_init` finished ("tdpsrv01").
const PEN_SERVO_MAGIC: u64 = u64::from_le_bytes(*b"tdpsrv01");

/// The top bit of `td_pen_init`'s `bad_item`: the item is the pen mesh's.
pub const TD_PEN_ITEM: u32 = 1 << 31;

/// Everything a pen and its object need to know before they are built: the meshes' counts,
/// the capacities of the contact pass and the force settings. `td_pen_params_default` fills
/// it with the host's defaults (`tetradrill replay --tool mesh:FILE` with no flags).
#[repr(C)]
#[derive(Clone, Copy, PartialEq, Debug)]
pub struct TdPenParams {
    /// Object nodes (`object_positions` holds `3 * object_node_count` floats). 1 ..= 2^28.
    pub object_node_count: u32,
    /// Object tets. 1 ..= 2^28.
    pub object_tet_count: u32,
    /// Pen nodes, at rest with its tip at the origin and its axis along +z. 1 ..= 2^28.
    pub pen_node_count: u32,
    /// Pen tets. 1 ..= 2^28.
    pub pen_tet_count: u32,
    /// Nodes of each body the pass keeps inside the other (collisions and penetrations, and
    /// what the hand-off carries); 0: each body's node count, which never fills. A full list
    /// keeps last pass's nodes first and is counted (`contacts_full`).
    pub contact_capacity: u32,
    /// Entries of each depth propagation queue; 0: each body's node count. A short queue
    /// changes no depth (counted, `queue_full`).
    pub queue_capacity: u32,
    /// Entries of the object's tet hash; 0: 16 per tet, and a mesh that fills them is refused
    /// (`TD_ERR_WORLD`); otherwise a full hash keeps the tets that fit (`hash_saturations`).
    pub hash_capacity: u32,
    /// The depth's surface search: 0 walks through tets, 1 the hashed boundary faces.
    pub depth_method: u32,
    /// 1: a border edge takes the face it left the other body through last pass when it still
    /// leaves through it (the host's default); 0: searched every pass.
    pub reuse_crossings: u32,
    /// 1: the entry-plane remedy for the pen's nodes; 0 (the default): none.
    pub entry_remedy: u32,
    /// Longest traced walk, in tets (256).
    pub max_steps: u32,
    /// Most cells a hashed edge query may cover (512).
    pub max_cells: u32,
    /// Most tets a node's walk may test before a lookup (8).
    pub max_walk: u32,
    /// Newtons per mesh unit of depth (at least 0).
    pub stiffness: f32,
    /// Newton-seconds per mesh unit (at least 0).
    pub damping: f32,
    /// Force clamp, newtons (positive).
    pub max_force: f32,
    /// Servo period, seconds (positive).
    pub dt: f32,
}

/// What one `td_pen_simulate` (a contact pass) found.
#[repr(C)]
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default)]
pub struct TdPenReport {
    /// Pen nodes inside the object.
    pub pen_collisions: u32,
    /// Object nodes inside the pen.
    pub object_collisions: u32,
    /// Pen penetrations written (handed to the servo).
    pub pen_penetrations: u32,
    /// Object penetrations written.
    pub object_penetrations: u32,
    /// 1 when a buffer filled (the result is valid but incomplete).
    pub saturated: u32,
}

/// A pen's contact passes since `td_pen_init` (`td_pen_counters`): `replay --json`'s `pen`.
#[repr(C)]
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default)]
pub struct TdPenCounts {
    /// Passes made.
    pub passes: u64,
    /// Passes with a buffer full.
    pub saturated_passes: u64,
    /// Passes whose collision list or depth output filled.
    pub contacts_full: u64,
    /// Passes whose depth queue filled.
    pub queue_full: u64,
    /// Colliding nodes whose depth no surface crossing reached, over all passes.
    pub unreached: u64,
    /// Border edges examined, over all passes.
    pub border_edges: u64,
    /// Of them, taken from the face remembered from the pass before.
    pub reused_crossings: u64,
    /// Most pen nodes inside the object in one pass.
    pub pen_collisions_max: u32,
    /// Most object nodes inside the pen in one pass.
    pub object_collisions_max: u32,
    /// Static hashes that ran out of entries at set-up (with `hash_capacity` set).
    pub hash_saturations: u32,
    /// Bytes of the pen's memory in use (what `td_pen_init` measured).
    pub bytes: u64,
}

/// A pen servo's counters (`td_pen_servo_counters`).
#[repr(C)]
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default)]
pub struct TdPenServoCounts {
    /// FNV-1a 64 digest of every force rendered, in order: `replay --json`'s `force_digest`.
    pub force_digest: u64,
    /// The same of every torque.
    pub torque_digest: u64,
    /// Servo ticks.
    pub servo_ticks: u64,
    /// Ticks whose force was not zero.
    pub contact_ticks: u64,
    /// Ticks whose force was clamped.
    pub clamped_ticks: u64,
    /// Ticks whose scratch could not carry every held penetration.
    pub short_ticks: u64,
    /// Ticks that kept the pass before, every read overtaken by a newer pass.
    pub stale_reads: u64,
    /// The number of the pass the last tick rendered from (0: none yet).
    pub step: u32,
}

/// A pen in caller memory (`td_pen_init`). Opaque.
#[derive(Debug)]
pub struct TdPen {
    _opaque: [u8; 0],
}

/// A pen's servo (`td_pen_servo_handle`). Opaque.
#[derive(Debug)]
pub struct TdPenServo {
    _opaque: [u8; 0],
}

/// The pass's side of a pen's memory.
#[derive(Debug)]
#[repr(C, align(64))]
struct PenHeader {
    magic: u64,
    scene: &'static PenScene<'static, 'static, 'static>,
    bufs: PenBuffers<'static>,
    handoff: &'static PenHandoff<'static>,
    servo: *mut PenServoState,
    opts: PenOptions,
    state: PenState,
    counters: TdPenCounts,
}

marked!(PenHeader, PEN_MAGIC);

/// The servo's side of a pen's memory.
#[derive(Debug)]
#[repr(C, align(64))]
struct PenServoState {
    magic: u64,
    scene: &'static PenScene<'static, 'static, 'static>,
    handoff: &'static PenHandoff<'static>,
    opts: PenOptions,
    state: PenState,
    /// Two copies of a pass's penetrations: the one in use and the one a read fills.
    held_pen: [&'static mut [Penetration]; 2],
    held_object: [&'static mut [Penetration]; 2],
    /// The copy in use and its pass.
    current: usize,
    held: PenPublished,
    /// The penetrations carried to the servo's pose.
    now_pen: &'static mut [Penetration],
    now_object: &'static mut [Penetration],
    digest: ForceDigest,
    torque_digest: ForceDigest,
    counts: TdPenServoCounts,
}

marked!(PenServoState, PEN_SERVO_MAGIC);

/// The hand-off on cache lines of its own.
#[derive(Debug)]
#[repr(C, align(64))]
struct SharedPenHandoff(PenHandoff<'static>);

/// Fills `*out` with the host's defaults for an object of `object_nodes` nodes and
/// `object_tets` tets and a pen of `pen_nodes` and `pen_tets`: contact lists and queues as
/// long as the nodes, the object's tet hash at 16 entries a tet, traced depths with crossings
/// reused, no entry remedy, the walks and searches of the core's `PenOptions`, and the host's
/// default forces (200 N per unit, 0.5 N s per unit, 8 N, 1 kHz).
///
/// # Bounded work
/// Constant.
///
/// # Errors
/// `TD_ERR_NULL` / `TD_ERR_ALIGN` for `out`; the counts are checked by `td_pen_size`.
///
/// # Safety
/// `out` points at writable memory for a `td_pen_params` (or is null: refused).
#[no_mangle]
pub unsafe extern "C" fn td_pen_params_default(
    object_nodes: u32,
    object_tets: u32,
    pen_nodes: u32,
    pen_tets: u32,
    out: *mut TdPenParams,
) -> TdStatus {
    let o = PenOptions::default();
    let p = TdPenParams {
        object_node_count: object_nodes,
        object_tet_count: object_tets,
        pen_node_count: pen_nodes,
        pen_tet_count: pen_tets,
        contact_capacity: 0,
        queue_capacity: 0,
        hash_capacity: 0,
        depth_method: 0,
        reuse_crossings: 1,
        entry_remedy: 0,
        max_steps: o.max_steps,
        max_cells: o.max_cells,
        max_walk: o.max_walk,
        stiffness: 200.0,
        damping: 0.5,
        max_force: 8.0,
        dt: 1e-3,
    };
    // SAFETY: the caller's contract on `out`; `put` checks null and alignment.
    status(|| unsafe { put(out, p) })
}

/// Writes the bytes (`*out_size`) and alignment (`*out_align`) of the part of a pen's memory
/// the counts give: the least `td_pen_init` builds the meshes and measures the rest in. The
/// whole pen needs more, by what the meshes' shapes give (their graphs' edges, the grids over
/// them): `td_pen_init` with this many bytes measures it and, when short, says how many.
///
/// # Bounded work
/// Constant.
///
/// # Errors
/// `TD_ERR_NULL` / `TD_ERR_ALIGN` for a pointer, `TD_ERR_PARAMS` for a parameter out of range
/// or a size beyond the address space.
///
/// # Safety
/// `params` points at an initialised `td_pen_params`; the outputs at writable `size_t`s.
#[no_mangle]
pub unsafe extern "C" fn td_pen_size(
    params: *const TdPenParams,
    out_size: *mut usize,
    out_align: *mut usize,
) -> TdStatus {
    // SAFETY: the caller's contract on the outputs and on `params` (`get` checks it).
    unsafe {
        sized(out_size, out_align, || {
            let plan = PenPlan::of(&get(params)?, None)?;
            Ok((plan.front, plan.align))
        })
    }
}

/// The pen behind a handle: null, misaligned or not set up by `td_pen_init` are refused.
///
/// # Safety
/// `pen`, when not null and aligned, points at memory `td_pen_init` was given.
unsafe fn pen_state<'a>(pen: *mut TdPen) -> Result<&'a mut PenHeader, TdStatus> {
    // SAFETY: the caller's contract.
    unsafe { marked_mut(pen.cast::<PenHeader>()) }
}

/// The pen's servo behind a handle.
///
/// # Safety
/// `servo`, when not null and aligned, points at a pen's servo from `td_pen_servo_handle`.
unsafe fn pen_servo_state<'a>(servo: *mut TdPenServo) -> Result<&'a mut PenServoState, TdStatus> {
    // SAFETY: the caller's contract.
    unsafe { marked_mut(servo.cast::<PenServoState>()) }
}

/// A pen's pose from C: the position and the rotation normalised (as the host's replay
/// normalises a trace's), or `TdErrInput` for a non-finite one.
fn pen_pose(pose: &TdPose) -> Result<(Vec3, Quat), TdStatus> {
    let at = crate::pose(pose.position)?;
    let r = pose.rotation;
    let q = Quat::from_xyzw(r.x, r.y, r.z, r.w);
    if !q.is_finite() {
        return Err(TdStatus::TdErrInput);
    }
    let q = q.normalize();
    if q.is_finite() {
        Ok((at, q))
    } else {
        Err(TdStatus::TdErrInput)
    }
}

/// One contact pass of the pen at `pose` (its tip at the position, its axis +z turned by the
/// rotation, normalised): the pen's nodes inside the object and the object's inside the pen,
/// their consistent penetration depths, published to the pen's servo (`td_pen_servo_handle`,
/// `td_pen_servo_wrench`), which may preempt this call or run beside it. `*report`, when not
/// null, says what it found.
///
/// # Bounded work
/// The core's `pen_pass`: the pen placed (O(pen nodes)), its nodes near the object looked up
/// in the object's cells with walks of at most `max_walk` tets, the object's nodes in the
/// pen's clusters looked up in its rest grid, then each side's depths (at most the contact
/// capacity of nodes, `max_steps` tets a walk); the publish of at most the contact capacities'
/// penetrations, 7 words each.
///
/// # Errors
/// `TD_ERR_NULL` / `TD_ERR_ALIGN` / `TD_ERR_NOT_INIT` for the pen, `TD_ERR_ALIGN` for
/// `report`, `TD_ERR_INPUT` for a non-finite pose or a zero rotation (nothing is done).
///
/// # Safety
/// `pen` is a handle from `td_pen_init` whose memory is still the caller's, one caller at a
/// time; `report` is null or points at a writable `td_pen_report`.
#[no_mangle]
pub unsafe extern "C" fn td_pen_simulate(
    pen: *mut TdPen,
    pose: TdPose,
    report: *mut TdPenReport,
) -> TdStatus {
    status(|| {
        if !report.is_null() && !report.is_aligned() {
            return Err(TdStatus::TdErrAlign);
        }
        // SAFETY: the caller's contract on `pen`; `pen_state` checks it.
        let st = unsafe { pen_state(pen) }?;
        let (at, rot) = pen_pose(&pose)?;
        let pass = pen_pass(st.scene, &mut st.bufs, at, rot, &st.opts, &mut st.state);
        let (np, no) = pass.penetrations;
        let pens = st.bufs.pen_pens.get(..np).unwrap_or(&[]);
        let objs = st.bufs.object_pens.get(..no).unwrap_or(&[]);
        st.handoff.publish(at, rot, pens, objs);
        let c = &mut st.counters;
        c.passes += 1;
        c.saturated_passes += u64::from(pass.saturated());
        c.contacts_full += u64::from(pass.contacts_full());
        c.queue_full += u64::from(pass.queue_full());
        c.unreached += u64::from(pass.pen_depth.unreached + pass.object_depth.unreached);
        c.border_edges += u64::from(pass.pen_depth.border_edges + pass.object_depth.border_edges);
        c.reused_crossings += u64::from(pass.pen_depth.reused + pass.object_depth.reused);
        c.pen_collisions_max = c.pen_collisions_max.max(pass.pen_collisions.count as u32);
        c.object_collisions_max = c
            .object_collisions_max
            .max(pass.object_collisions.count as u32);
        if !report.is_null() {
            let r = TdPenReport {
                pen_collisions: pass.pen_collisions.count as u32,
                object_collisions: pass.object_collisions.count as u32,
                pen_penetrations: np as u32,
                object_penetrations: no as u32,
                saturated: pass.saturated().into(),
            };
            // SAFETY: not null, aligned (checked); writable by the caller's contract.
            unsafe { report.write(r) };
        }
        Ok(())
    })
}

/// Writes the pen's servo handle to `*out`: the part of its memory the force call uses alone.
/// Take it once, before the servo starts.
///
/// # Bounded work
/// Constant.
///
/// # Errors
/// As `td_pen_simulate` for the pen; `TD_ERR_NULL` / `TD_ERR_ALIGN` for `out`.
///
/// # Safety
/// As `td_pen_simulate`; `out` points at a writable `td_pen_servo *`.
#[no_mangle]
pub unsafe extern "C" fn td_pen_servo_handle(
    pen: *mut TdPen,
    out: *mut *mut TdPenServo,
) -> TdStatus {
    status(|| {
        check_ptr(out)?;
        // SAFETY: the caller's contract on `pen`; `pen_state` checks it.
        let servo = unsafe { pen_state(pen) }?.servo;
        // SAFETY: checked above; writable by the caller's contract.
        unsafe { put(out, servo.cast::<TdPenServo>()) }
    })
}

/// The force (`*force`) and torque (`*torque`) on the pen at `pose` from the newest pass:
/// each held penetration carried to this pose to first order (the core's `pen_servo_force`:
/// a pen node's depth less how far the pen moved it along its direction, an object node's
/// seen from the pen's frame), stiffness, the entry remedy when set, damping and the clamp,
/// as `tetradrill replay --tool mesh:FILE` renders it; the torque is the moment of the carried
/// penetrations' springs about the tip (the pose's position), scaled as their clamp scales
/// their sum (the core's `pen_torque`; damping acts at the tip). Both enter the servo's
/// digests. At the pass's own pose the force is the pass's, bit for bit.
///
/// May preempt `td_pen_simulate` or run beside it on another thread: the two share only the
/// hand-off's atomics. A read overtaken by the passes meanwhile is tried again, at most 4
/// times, then the pass before is kept (`stale_reads`).
///
/// # Bounded work
/// At most 4 reads of a pass (the head and at most the contact capacities' penetrations, 7
/// words each), then O(held penetrations) for the force and the torque. Never waits.
///
/// # Errors
/// `TD_ERR_NULL` / `TD_ERR_ALIGN` / `TD_ERR_NOT_INIT` for the servo, `TD_ERR_NULL` /
/// `TD_ERR_ALIGN` for an output, `TD_ERR_INPUT` for a non-finite pose or a zero rotation;
/// nothing is written or counted then.
///
/// # Safety
/// `servo` is a handle from `td_pen_servo_handle` whose pen's memory is still the caller's, one servo
/// call at a time; `force` and `torque` point at writable `td_vec3`s.
#[no_mangle]
pub unsafe extern "C" fn td_pen_servo_wrench(
    servo: *mut TdPenServo,
    pose: TdPose,
    force: *mut TdVec3,
    torque: *mut TdVec3,
) -> TdStatus {
    status(|| {
        check_ptr(force)?;
        check_ptr(torque)?;
        // SAFETY: the caller's contract on `servo`; `pen_servo_state` checks it.
        let sv = unsafe { pen_servo_state(servo) }?;
        let (at, rot) = pen_pose(&pose)?;
        let (f, t) = pen_tick(sv, at, rot);
        // SAFETY: checked above; writable by the caller's contract.
        unsafe {
            force.write(td_vec(f));
            torque.write(td_vec(t));
        }
        Ok(())
    })
}

/// One servo tick: the newest pass into the spare copy (kept on success), the force from the
/// copy in use carried to `at` and `rot`, the torque, the digests and counts.
///
/// # Bounded work
/// As `td_pen_servo_wrench`.
fn pen_tick(sv: &mut PenServoState, at: Vec3, rot: Quat) -> (Vec3, Vec3) {
    let spare = (sv.current + 1) % 2;
    let (sp, so) = match (sv.held_pen.get_mut(spare), sv.held_object.get_mut(spare)) {
        (Some(p), Some(o)) => (&mut **p, &mut **o),
        _ => (&mut [][..], &mut [][..]),
    };
    match sv.handoff.latest(sp, so) {
        Some(p) => {
            sv.current = spare;
            sv.held = p;
        }
        None => sv.counts.stale_reads += 1,
    }
    let h = sv.held;
    let pen = sv
        .held_pen
        .get(sv.current)
        .and_then(|s| s.get(..h.pen))
        .unwrap_or(&[]);
    let object = sv
        .held_object
        .get(sv.current)
        .and_then(|s| s.get(..h.object))
        .unwrap_or(&[]);
    let held = HeldContact {
        position: h.position,
        rotation: h.rotation,
        pen,
        object,
    };
    let mut now = ServoScratch {
        pen: &mut *sv.now_pen,
        object: &mut *sv.now_object,
    };
    let r = pen_servo_force(sv.scene, &held, &mut now, at, rot, &sv.opts, &mut sv.state);
    let t = pen_torque(
        sv.scene.pen.positions(),
        sv.scene.object.positions,
        now.pen.get(..r.carried.0).unwrap_or(&[]),
        now.object.get(..r.carried.1).unwrap_or(&[]),
        at,
        rot,
        &sv.opts.params,
    );
    let f = r.force.force;
    sv.digest.push(f);
    sv.torque_digest.push(t);
    let c = &mut sv.counts;
    c.servo_ticks += 1;
    c.contact_ticks += u64::from(f != Vec3::ZERO);
    c.clamped_ticks += u64::from(r.force.clamped);
    c.short_ticks += u64::from(r.short);
    c.step = h.step;
    (f, t)
}

/// One whole tick in one task, as `tetradrill replay --tool mesh:FILE` runs it: the pass at
/// `pose`, then the pen's servo force and torque at the same pose (the pass's own force).
///
/// # Bounded work
/// `td_pen_simulate`'s plus `td_pen_servo_wrench`'s.
///
/// # Errors
/// As the two calls; on an error nothing more is done and the outputs are not written.
///
/// # Safety
/// As `td_pen_simulate`, with no servo call on this pen's servo meanwhile; `force` and
/// `torque` point at writable `td_vec3`s.
#[no_mangle]
pub unsafe extern "C" fn td_pen_tick(
    pen: *mut TdPen,
    pose: TdPose,
    force: *mut TdVec3,
    torque: *mut TdVec3,
) -> TdStatus {
    status(|| {
        check_ptr(force)?;
        check_ptr(torque)?;
        // SAFETY: the caller's contract on `pen`; `pen_state` checks it.
        let servo = unsafe { pen_state(pen) }?.servo;
        pen_pose(&pose)?;
        // SAFETY: the caller's contract, passed on.
        match unsafe { td_pen_simulate(pen, pose, ptr::null_mut()) } {
            TdStatus::TdOk => {}
            e => return Err(e),
        }
        // SAFETY: the pen's own servo; no other servo call meanwhile (the caller's contract).
        match unsafe { td_pen_servo_wrench(servo.cast::<TdPenServo>(), pose, force, torque) } {
            TdStatus::TdOk => Ok(()),
            e => Err(e),
        }
    })
}

/// Writes the pen's pass counters to `*out`.
///
/// # Bounded work
/// Constant.
///
/// # Errors
/// As `td_pen_simulate` for the pen; `TD_ERR_NULL` / `TD_ERR_ALIGN` for `out`.
///
/// # Safety
/// As `td_pen_simulate`; `out` points at a writable `td_pen_counts`.
#[no_mangle]
pub unsafe extern "C" fn td_pen_counters(pen: *mut TdPen, out: *mut TdPenCounts) -> TdStatus {
    status(|| {
        check_ptr(out)?;
        // SAFETY: the caller's contract on `pen`; `pen_state` checks it.
        let c = unsafe { pen_state(pen) }?.counters;
        // SAFETY: checked above; writable by the caller's contract.
        unsafe { put(out, c) }
    })
}

/// Writes the pen servo's counters to `*out` (from the servo's task, or when it is not
/// running).
///
/// # Bounded work
/// Constant.
///
/// # Errors
/// As `td_pen_servo_wrench` for the servo; `TD_ERR_NULL` / `TD_ERR_ALIGN` for `out`.
///
/// # Safety
/// As `td_pen_servo_wrench`; `out` points at a writable `td_pen_servo_counts`.
#[no_mangle]
pub unsafe extern "C" fn td_pen_servo_counters(
    servo: *mut TdPenServo,
    out: *mut TdPenServoCounts,
) -> TdStatus {
    status(|| {
        check_ptr(out)?;
        // SAFETY: the caller's contract on `servo`; `pen_servo_state` checks it.
        let sv = unsafe { pen_servo_state(servo) }?;
        let c = TdPenServoCounts {
            force_digest: sv.digest.value(),
            torque_digest: sv.torque_digest.value(),
            ..sv.counts
        };
        // SAFETY: checked above; writable by the caller's contract.
        unsafe { put(out, c) }
    })
}

const _: () = assert!(align_of::<PenHeader>() == 64 && align_of::<PenServoState>() == 64);
