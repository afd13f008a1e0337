//! A soft body in the caller's memory: an elastic tet mesh (the core's XPBD step, linear
//! elasticity, one material) stepped under loads with some nodes held, as Python's
//! `SoftBody` and the host's `--body soft` step it.
//!
//! The memory holds a [`SoftState`] (the core's `SoftBody` and the counts), then the rest
//! positions, the tets and the body's state and scratch (`SoftStorage`), each at its type's
//! alignment. Nothing is allocated; a step's work is bounded by the counts and the params.

use core::alloc::Layout;
use core::mem::size_of;

use tetradrill_core::soft::{
    lane_order, Material, SoftBody, SoftError, SoftMesh, SoftParams, SoftStorage, StepError,
    TetRest,
};

use super::*;

/// Marks a [`SoftState`] that `td_soft_init` finished ("tdsoft01").
const SOFT_MAGIC: u64 = u64::from_le_bytes(*b"tdsoft01");

/// A soft body's settings: its material and its step.
#[repr(C)]
#[derive(Clone, Copy, PartialEq, Debug)]
pub struct TdSoftParams {
    /// Young's modulus, force per area (pascal with metres and newtons), finite and positive.
    pub young: f32,
    /// Poisson ratio, `0 ..= 0.49`.
    pub poisson: f32,
    /// Density, mass per volume, finite and positive.
    pub density: f32,
    /// Velocity damping rate per unit time (each substep scales the velocities by
    /// `1 / (1 + damping h)`), finite, 0 or more.
    pub damping: f32,
    /// Substeps a step, `1 ..= 1000`.
    pub substeps: u32,
    /// Gauss-Seidel sweeps over the tets a substep, `1 ..= 100`.
    pub iterations: u32,
    /// Gravity, an acceleration on every free node.
    pub gravity: TdVec3,
}

/// What a soft body has done and holds.
#[repr(C)]
#[derive(Clone, Copy, PartialEq, Debug, Default)]
pub struct TdSoftCounts {
    /// Steps taken (`td_soft_step` calls that stepped).
    pub steps: u64,
    /// Their time summed, in the unit of `dt`.
    pub time: f64,
    /// Elastic energy now (the strain energy of the linear material).
    pub elastic_energy: f64,
    /// Kinetic energy now.
    pub kinetic_energy: f64,
    /// Nodes held (fixed, or without mass).
    pub fixed_nodes: u32,
}

/// A soft body set up by `td_soft_init` in caller memory. Opaque: C holds a pointer to it (the
/// start of the memory it gave) and never reads it.
#[derive(Debug)]
pub struct TdSoft {
    _opaque: [u8; 0],
}

/// The head of a soft body's memory.
#[derive(Debug)]
#[repr(C)]
pub(crate) struct SoftState {
    /// [`SOFT_MAGIC`] once set up; zero while `td_soft_init` works on the memory.
    magic: u64,
    /// The core's body over the slices that follow this header.
    pub(crate) body: SoftBody<'static>,
    /// Steps taken (`td_soft_step`'s and a link's).
    pub(crate) steps: u64,
    /// Their time summed.
    pub(crate) time: f64,
    /// The body's index of each tet as the caller gave them (its tets are in lane order).
    body_tet: &'static [u32],
    /// The link (its handle's address) whose cycle is stepping the body, from a cycle's first
    /// `td_link_tick` to its commit; 0: none.
    pub(crate) link_cycle: usize,
}

marked!(SoftState, SOFT_MAGIC);

/// Where each part of a soft body's memory starts, and the whole's size and alignment.
struct SoftPlan {
    size: usize,
    align: usize,
    rest: usize,
    tets: usize,
    displacement: usize,
    velocity: usize,
    previous: usize,
    mass: usize,
    inv_mass: usize,
    tet_rest: usize,
    lambdas: usize,
    tet_of: usize,
    body_tet: usize,
}

impl SoftPlan {
    /// The plan for `nodes` nodes and `tets` tets: `TdErrParams` for a count of zero, above
    /// `TD_MAX_COUNT`, or a body larger than the address space.
    fn of(nodes: u32, tets: u32) -> Result<Self, TdStatus> {
        if nodes == 0 || tets == 0 || nodes > TD_MAX_COUNT || tets > TD_MAX_COUNT {
            return Err(TdStatus::TdErrParams);
        }
        let (n, t) = (nodes as usize, tets as usize);
        let mut all = Layout::new::<SoftState>();
        let mut at = |part: Result<Layout, core::alloc::LayoutError>| {
            let (grown, offset) = part
                .and_then(|p| all.extend(p))
                .map_err(|_| TdStatus::TdErrParams)?;
            all = grown;
            Ok::<usize, TdStatus>(offset)
        };
        let rest = at(Layout::array::<Vec3>(n))?;
        let tets = at(Layout::array::<[u32; 4]>(t))?;
        let displacement = at(Layout::array::<Vec3>(n))?;
        let velocity = at(Layout::array::<Vec3>(n))?;
        let previous = at(Layout::array::<Vec3>(n))?;
        let mass = at(Layout::array::<f32>(n))?;
        let inv_mass = at(Layout::array::<f32>(n))?;
        let tet_rest = at(Layout::array::<TetRest>(t))?;
        let lambdas = at(Layout::array::<[f32; 2]>(t))?;
        let tet_of = at(Layout::array::<u32>(t))?;
        let body_tet = at(Layout::array::<u32>(t))?;
        let all = all.pad_to_align();
        Ok(Self {
            size: all.size(),
            align: all.align(),
            rest,
            tets,
            displacement,
            velocity,
            previous,
            mass,
            inv_mass,
            tet_rest,
            lambdas,
            tet_of,
            body_tet,
        })
    }
}

/// The core's material and step parameters from C's (`SoftBody::new` checks their ranges),
/// or `TdErrParams` for a gravity that is not finite.
fn soft_params(p: &TdSoftParams) -> Result<(Material, SoftParams), TdStatus> {
    let material = Material {
        young: p.young,
        poisson: p.poisson,
        density: p.density,
    };
    let params = SoftParams {
        gravity: pose(p.gravity).map_err(|_| TdStatus::TdErrParams)?,
        damping: p.damping,
        substeps: p.substeps,
        iterations: p.iterations,
    };
    Ok((material, params))
}

/// The body behind a handle ([`marked_mut`]).
///
/// # Safety
/// As [`marked_mut`], for memory `td_soft_init` was given.
pub(crate) unsafe fn soft_state<'a>(s: *mut TdSoft) -> Result<&'a mut SoftState, TdStatus> {
    // SAFETY: the caller's contract.
    unsafe { marked_mut(s.cast::<SoftState>()) }
}

/// `n` values of `T` from C at `p`, checked for null and alignment.
///
/// # Safety
/// `p`, when not null and aligned, points at `n` initialised values of `T` that stay put and
/// unwritten for `'a`.
pub(crate) unsafe fn c_slice<'a, T>(p: *const T, n: usize) -> Result<&'a [T], TdStatus> {
    check_ptr(p)?;
    // SAFETY: not null, aligned (checked); `n` values (the caller's contract).
    Ok(unsafe { core::slice::from_raw_parts(p, n) })
}

/// Fills `*out` with the defaults Python's `SoftBody` and the host's soft body take: Young's
/// modulus 5,000, Poisson ratio 0.3, density 1,000, no damping, 10 substeps of 1 sweep, no
/// gravity.
///
/// # Bounded work
/// Constant.
///
/// # Errors
/// `TD_ERR_NULL` / `TD_ERR_ALIGN` for `out`.
///
/// # Safety
/// `out` points at writable memory for a `td_soft_params` (or is null: refused).
#[no_mangle]
pub unsafe extern "C" fn td_soft_params_default(out: *mut TdSoftParams) -> TdStatus {
    let d = SoftParams::default();
    let p = TdSoftParams {
        young: 5000.0,
        poisson: 0.3,
        density: 1000.0,
        damping: d.damping,
        substeps: d.substeps,
        iterations: d.iterations,
        gravity: td_vec(d.gravity),
    };
    // SAFETY: the caller's contract on `out`; `put` checks null and alignment.
    status(|| unsafe { put(out, p) })
}

/// Writes the bytes (`*out_size`) and the alignment (`*out_align`) a soft body of
/// `node_count` nodes and `tet_count` tets needs. Allocate at least that many bytes at that
/// alignment for `td_soft_init`.
///
/// # Bounded work
/// Constant.
///
/// # Errors
/// `TD_ERR_NULL` / `TD_ERR_ALIGN` for a pointer; `TD_ERR_PARAMS` for a count of zero, above
/// `TD_MAX_COUNT`, or a body larger than the address space.
///
/// # Safety
/// `out_size` and `out_align` point at writable `size_t`s.
#[no_mangle]
pub unsafe extern "C" fn td_soft_size(
    node_count: u32,
    tet_count: u32,
    out_size: *mut usize,
    out_align: *mut usize,
) -> TdStatus {
    // SAFETY: the caller's contract on the outputs (`sized` checks them).
    unsafe {
        sized(out_size, out_align, || {
            let plan = SoftPlan::of(node_count, tet_count)?;
            Ok((plan.size, plan.align))
        })
    }
}

/// Sets a soft body up in `mem` (`len` bytes at the alignment `td_soft_size` gave) from
/// `xyz` (x, y, z of each of `node_count` nodes) and `tets` (four node indices of each of
/// `tet_count` tets, positively oriented: `(b - a) x (c - a) . (d - a) > 0`), at rest, every
/// node free, and writes its handle to `*out`. The arrays are copied: the caller may free
/// them after. The body keeps the nodes in the order given and its tets in groups of four
/// that share no node (the core's `lane_order`), which its sweep solves four at a time on
/// x86-64 and AArch64 (about a third of the time a step); every tet index in and out (`bad_item`,
/// `td_soft_add_point_force`'s `tet`) is the one given.
///
/// # Bounded work
/// O(`node_count + tet_count x 64`).
///
/// # Errors
/// `TD_ERR_NULL` / `TD_ERR_ALIGN` for a pointer (`xyz` and `tets` need 4 bytes),
/// `TD_ERR_TOO_SMALL` for `len`, `TD_ERR_PARAMS` for a count or a parameter out of range,
/// `TD_ERR_MESH` for a node that is not finite or a tet that names a node out of range or is
/// inverted or flat at rest (`*bad_item`, when `bad_item` is not null, names the node or the
/// tet). On an error `*out` is not written; on any error after the checks of the counts and
/// of `mem` (null, alignment, length) the memory holds no body: a handle to it is refused
/// until an init succeeds.
///
/// # Safety
/// `mem` points at `len` writable bytes the caller keeps, untouched, for as long as it uses
/// the body; `xyz` at `3 node_count` floats and `tets` at `4 tet_count` indices; `params` at
/// a `td_soft_params`; `out` at a writable pointer; `bad_item` is null or writable.
#[no_mangle]
#[allow(clippy::too_many_arguments)]
pub unsafe extern "C" fn td_soft_init(
    mem: *mut c_void,
    len: usize,
    xyz: *const f32,
    node_count: u32,
    tets: *const u32,
    tet_count: u32,
    params: *const TdSoftParams,
    out: *mut *mut TdSoft,
    bad_item: *mut u32,
) -> TdStatus {
    status(|| {
        check_ptr(out)?;
        let plan = SoftPlan::of(node_count, tet_count)?;
        let base = caller_memory(mem, len, plan.size, plan.align)?;
        let state = base.cast::<SoftState>();
        // SAFETY: `mem` is aligned for SoftState and at least `plan.size` bytes long: a handle
        // to this memory is refused from here on until the init succeeds.
        unsafe { ptr::addr_of_mut!((*state).magic).write(0) };
        // SAFETY: the caller's contract on `params` (`get` checks it).
        let (material, sp) = soft_params(&unsafe { get(params) }?)?;
        let (n, t) = (node_count as usize, tet_count as usize);
        // SAFETY: `3 n` floats and `4 t` indices at `xyz` and `tets` (the caller's contract;
        // the counts are at most `TD_MAX_COUNT`, so the products fit).
        let (xyz, tet_ix) = unsafe { (c_slice(xyz, 3 * n)?, c_slice(tets, 4 * t)?) };
        // SAFETY: every offset comes from the plan, which places each slice after the header
        // at its type's alignment, apart from the others, inside `plan.size <= len` bytes of
        // `mem`; the caller keeps `mem` for as long as the body is used.
        let (rest, mesh_tets, storage) = unsafe {
            (
                carve(base, plan.rest, n, Vec3::ZERO),
                carve(base, plan.tets, t, [0u32; 4]),
                SoftStorage {
                    displacement: carve(base, plan.displacement, n, Vec3::ZERO),
                    velocity: carve(base, plan.velocity, n, Vec3::ZERO),
                    previous: carve(base, plan.previous, n, Vec3::ZERO),
                    mass: carve(base, plan.mass, n, 0.0f32),
                    inv_mass: carve(base, plan.inv_mass, n, 0.0f32),
                    tet_rest: carve(base, plan.tet_rest, t, TetRest::default()),
                    lambdas: carve(base, plan.lambdas, t, [0.0f32; 2]),
                },
            )
        };
        for (i, (r, c)) in rest.iter_mut().zip(xyz.chunks_exact(3)).enumerate() {
            let v = match *c {
                [x, y, z] => Vec3::new(x, y, z),
                _ => Vec3::NAN,
            };
            if !v.is_finite() {
                // SAFETY: the caller's contract on `bad_item`.
                unsafe { report_bad(bad_item, i as u32) };
                return Err(TdStatus::TdErrMesh);
            }
            *r = v;
        }
        // SAFETY: as above: the plan's two index regions.
        let (tet_of, body_tet) = unsafe {
            (
                carve(base, plan.tet_of, t, 0u32),
                carve(base, plan.body_tet, t, 0u32),
            )
        };
        let given = |i: usize| match tet_ix.get(4 * i..4 * i + 4) {
            Some(&[a, b, c, d]) => [a, b, c, d],
            _ => [u32::MAX; 4],
        };
        for (i, m) in mesh_tets.iter_mut().enumerate() {
            *m = given(i);
        }
        // The tets in groups of four that share no node, which the sweep solves four at a
        // time where the target can (the nodes stay in the given order).
        if lane_order(mesh_tets, tet_of, body_tet) {
            for (m, &g) in mesh_tets.iter_mut().zip(tet_of.iter()) {
                *m = given(g as usize);
            }
        } else {
            for (i, (o, b)) in tet_of.iter_mut().zip(body_tet.iter_mut()).enumerate() {
                (*o, *b) = (i as u32, i as u32);
            }
        }
        let mesh = SoftMesh {
            rest,
            tets: mesh_tets,
            tet_material: &[],
        };
        let body = SoftBody::new(mesh, &[material], sp, storage).map_err(|e| {
            let (status, item) = match e {
                SoftError::NodeOutOfRange { tet }
                | SoftError::DegenerateTet { tet }
                | SoftError::MaterialIndex { tet } => (
                    TdStatus::TdErrMesh,
                    tet_of.get(tet as usize).copied().unwrap_or(tet),
                ),
                _ => (TdStatus::TdErrParams, u32::MAX),
            };
            // SAFETY: the caller's contract on `bad_item`.
            unsafe { report_bad(bad_item, item) };
            status
        })?;
        // SAFETY: the header's region is `mem`'s start, aligned and inside it (above); its
        // magic is zero, so no handle reads it while it is written; the magic goes last.
        unsafe {
            ptr::addr_of_mut!((*state).body).write(body);
            ptr::addr_of_mut!((*state).steps).write(0);
            ptr::addr_of_mut!((*state).time).write(0.0);
            ptr::addr_of_mut!((*state).body_tet).write(body_tet);
            ptr::addr_of_mut!((*state).link_cycle).write(0);
            ptr::addr_of_mut!((*state).magic).write(SOFT_MAGIC);
            out.write(state.cast::<TdSoft>());
        }
        Ok(())
    })
}

/// One step of `dt` under `loads` (x, y, z of a force on each node; null for none): the
/// core's XPBD step, its substeps and sweeps as set, the held nodes kept where they are.
///
/// # Bounded work
/// O(substeps x iterations x tets + substeps x nodes).
///
/// # Errors
/// `TD_ERR_NOT_INIT` for a handle `td_soft_init` did not set up (or `TD_ERR_NULL` /
/// `TD_ERR_ALIGN`), `TD_ERR_ALIGN` for `loads`, `TD_ERR_INPUT` for a `dt` that is not finite
/// and positive or a load that is not finite, `TD_ERR_BUSY` while a link's cycle is under way
/// (from its first `td_link_tick` to the commit: the link steps the body); the body is
/// unchanged on an error.
///
/// # Safety
/// `soft` is a handle from `td_soft_init` (or is refused as above); `loads` is null or points
/// at `3 node_count` floats.
#[no_mangle]
pub unsafe extern "C" fn td_soft_step(soft: *mut TdSoft, dt: f32, loads: *const f32) -> TdStatus {
    status(|| {
        // SAFETY: the caller's contract on `soft` (`soft` checks it).
        let s = unsafe { soft_state(soft) }?;
        if s.link_cycle != 0 {
            return Err(TdStatus::TdErrBusy);
        }
        let n = s.body.node_count();
        let loads: &[f32] = if loads.is_null() {
            &[]
        } else {
            // SAFETY: `3 n` floats at `loads` (the caller's contract).
            unsafe { c_slice(loads, 3 * n) }?
        };
        if !(dt.is_finite() && dt > 0.0) || loads.iter().any(|f| !f.is_finite()) {
            return Err(TdStatus::TdErrInput);
        }
        // The core takes a force per node, or none: cast C's floats as vectors.
        let external = vec3s(loads);
        s.body.step(dt, external).map_err(|e| match e {
            StepError::InProgress => TdStatus::TdErrBusy,
            _ => TdStatus::TdErrInput,
        })?;
        s.steps += 1;
        s.time += f64::from(dt);
        Ok(())
    })
}

/// C's floats, three a vector, as the core's vectors (`Vec3` is three `f32`s, `repr(C)`).
pub(crate) fn vec3s(f: &[f32]) -> &[Vec3] {
    const _: () = assert!(size_of::<Vec3>() == 3 * size_of::<f32>());
    const _: () = assert!(core::mem::align_of::<Vec3>() == core::mem::align_of::<f32>());
    let n = f.len() / 3;
    // SAFETY: `Vec3` is `repr(C)` of three `f32`s (size and alignment asserted above), and
    // `3 n <= f.len()` floats are in `f`, borrowed for the result's lifetime.
    unsafe { core::slice::from_raw_parts(f.as_ptr().cast::<Vec3>(), n) }
}

/// Which of a body's per-node vectors `td_soft_nodes` writes.
#[repr(C)]
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum TdSoftField {
    /// Current positions: rest plus displacement.
    TdSoftPositions = 0,
    /// Displacements from rest.
    TdSoftDisplacements = 1,
    /// Velocities.
    TdSoftVelocities = 2,
    /// Rest positions.
    TdSoftRest = 3,
}

impl TdSoftField {
    /// The field a `td_soft_field` value from C names, if any.
    fn of(v: u32) -> Option<Self> {
        [
            Self::TdSoftPositions,
            Self::TdSoftDisplacements,
            Self::TdSoftVelocities,
            Self::TdSoftRest,
        ]
        .into_iter()
        .find(|f| *f as u32 == v)
    }
}

/// Writes `field` (a `td_soft_field` value) of every node, x, y, z each, to `out`,
/// `3 node_count` floats.
///
/// # Bounded work
/// O(nodes).
///
/// # Errors
/// `TD_ERR_NOT_INIT` (or `TD_ERR_NULL` / `TD_ERR_ALIGN`) for `soft`, `TD_ERR_NULL` /
/// `TD_ERR_ALIGN` for `out`, `TD_ERR_PARAMS` when `node_count` is not the body's or `field`
/// names no field.
///
/// # Safety
/// `soft` is a handle from `td_soft_init`; `out` points at `3 node_count` writable floats.
#[no_mangle]
pub unsafe extern "C" fn td_soft_nodes(
    soft: *mut TdSoft,
    field: u32,
    out: *mut f32,
    node_count: u32,
) -> TdStatus {
    status(|| {
        // SAFETY: the caller's contract on `soft`.
        let s = unsafe { soft_state(soft) }?;
        let b = &s.body;
        let field = TdSoftField::of(field).ok_or(TdStatus::TdErrParams)?;
        if node_count as usize != b.node_count() {
            return Err(TdStatus::TdErrParams);
        }
        check_ptr(out)?;
        // SAFETY: `3 node_count` writable floats at `out`, not null and aligned (checked),
        // apart from the body's memory (the caller's contract).
        let out = unsafe { core::slice::from_raw_parts_mut(out, 3 * b.node_count()) };
        for (i, o) in out.chunks_exact_mut(3).enumerate() {
            let v = match field {
                TdSoftField::TdSoftPositions => b.position(i),
                TdSoftField::TdSoftDisplacements => b.displacements().get(i).copied(),
                TdSoftField::TdSoftVelocities => b.velocities().get(i).copied(),
                TdSoftField::TdSoftRest => b.rest().get(i).copied(),
            }
            .unwrap_or(Vec3::ZERO);
            o.copy_from_slice(&v.to_array());
        }
        Ok(())
    })
}

/// Holds (`fixed` non-zero) or frees node `node`: a held node keeps its place and speed.
///
/// # Bounded work
/// Constant.
///
/// # Errors
/// `TD_ERR_NOT_INIT` (or `TD_ERR_NULL` / `TD_ERR_ALIGN`) for `soft`, `TD_ERR_PARAMS` for a
/// node past the end, `TD_ERR_BUSY` while a link's cycle is under way.
///
/// # Safety
/// `soft` is a handle from `td_soft_init`.
#[no_mangle]
pub unsafe extern "C" fn td_soft_set_fixed(soft: *mut TdSoft, node: u32, fixed: u8) -> TdStatus {
    status(|| {
        // SAFETY: the caller's contract on `soft`.
        let s = unsafe { soft_state(soft) }?;
        if s.link_cycle != 0 {
            return Err(TdStatus::TdErrBusy);
        }
        if s.body.set_fixed(node as usize, fixed != 0) {
            Ok(())
        } else {
            Err(TdStatus::TdErrParams)
        }
    })
}

/// Adds a point force `force` at `point` in tet `tet` (the body's current positions) to
/// `loads` (x, y, z of a force on each of its `node_count` nodes, the array a later
/// `td_soft_step` takes), spread over the tet's four nodes by barycentric weights: how a
/// tool's contact pushes the body. With a deformable world built from the same arrays, `tet`
/// and `point` are `td_world_contact_at`'s and `force` the reaction, minus the force the
/// servo gave the hand.
///
/// # Bounded work
/// Constant.
///
/// # Errors
/// `TD_ERR_NOT_INIT` (or `TD_ERR_NULL` / `TD_ERR_ALIGN`) for `soft`, `TD_ERR_NULL` /
/// `TD_ERR_ALIGN` for `loads`, `TD_ERR_INPUT` for a tet past the last, a point or force that
/// is not finite, or a tet flat at its current positions (`loads` unchanged).
///
/// # Safety
/// `soft` is a handle from `td_soft_init`; `loads` points at `3 node_count` writable floats
/// outside the body's memory.
#[no_mangle]
pub unsafe extern "C" fn td_soft_add_point_force(
    soft: *mut TdSoft,
    tet: u32,
    point: TdVec3,
    force: TdVec3,
    loads: *mut f32,
) -> TdStatus {
    status(|| {
        check_ptr(loads)?;
        // SAFETY: the caller's contract on `soft`.
        let s = unsafe { soft_state(soft) }?;
        let n = s.body.node_count();
        // SAFETY: not null and aligned (checked), `3 n` writable floats outside the body's
        // memory (the caller's contract; `n` is at most `TD_MAX_COUNT`).
        let loads = unsafe { core::slice::from_raw_parts_mut(loads, 3 * n) };
        let (at, f) = (pose(point)?, pose(force)?);
        // The caller's tet index (the world's) to the body's (its tets are in lane order).
        let own = *s.body_tet.get(tet as usize).ok_or(TdStatus::TdErrInput)?;
        let (ids, parts) = s
            .body
            .point_force(own as usize, at, f)
            .ok_or(TdStatus::TdErrInput)?;
        // The body's tets name its nodes (checked at init): each has its three floats.
        for (&k, add) in ids.iter().zip(parts) {
            let i = 3 * k as usize;
            if let Some([x, y, z]) = loads.get_mut(i..i + 3) {
                *x += add.x;
                *y += add.y;
                *z += add.z;
            }
        }
        Ok(())
    })
}

/// Holds every node whose rest position is on or below the plane through `origin` with
/// upward normal `up`; writes how many to `*out_count` (when not null).
///
/// # Bounded work
/// O(nodes).
///
/// # Errors
/// `TD_ERR_NOT_INIT` (or `TD_ERR_NULL` / `TD_ERR_ALIGN`) for `soft`, `TD_ERR_ALIGN` for
/// `out_count`, `TD_ERR_INPUT` for a point or normal that is not finite, `TD_ERR_BUSY` while a
/// link's cycle is under way.
///
/// # Safety
/// `soft` is a handle from `td_soft_init`; `out_count` is null or writable.
#[no_mangle]
pub unsafe extern "C" fn td_soft_fix_below(
    soft: *mut TdSoft,
    origin: TdVec3,
    up: TdVec3,
    out_count: *mut u32,
) -> TdStatus {
    status(|| {
        // SAFETY: the caller's contract on `soft`.
        let s = unsafe { soft_state(soft) }?;
        if s.link_cycle != 0 {
            return Err(TdStatus::TdErrBusy);
        }
        let (o, u) = (pose(origin)?, pose(up)?);
        if !out_count.is_null() && !out_count.is_aligned() {
            return Err(TdStatus::TdErrAlign);
        }
        let held = s.body.fix_below(o, u) as u32;
        if !out_count.is_null() {
            // SAFETY: not null, aligned (checked), writable (the caller's contract).
            unsafe { out_count.write(held) };
        }
        Ok(())
    })
}

/// Writes the body's counts: steps, time, energies, held nodes.
///
/// # Bounded work
/// O(nodes + tets) (the energies).
///
/// # Errors
/// `TD_ERR_NOT_INIT` (or `TD_ERR_NULL` / `TD_ERR_ALIGN`) for `soft`, `TD_ERR_NULL` /
/// `TD_ERR_ALIGN` for `out`.
///
/// # Safety
/// `soft` is a handle from `td_soft_init`; `out` points at a writable `td_soft_counts`.
#[no_mangle]
pub unsafe extern "C" fn td_soft_counters(soft: *mut TdSoft, out: *mut TdSoftCounts) -> TdStatus {
    status(|| {
        // SAFETY: the caller's contract on `soft`.
        let s = unsafe { soft_state(soft) }?;
        let b = &s.body;
        let c = TdSoftCounts {
            steps: s.steps,
            time: s.time,
            elastic_energy: b.elastic_energy(),
            kinetic_energy: b.kinetic_energy(),
            fixed_nodes: (0..b.node_count()).filter(|&i| b.is_fixed(i)).count() as u32,
        };
        // SAFETY: the caller's contract on `out`; `put` checks null and alignment.
        unsafe { put(out, c) }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_plan_places_each_part_after_the_last_at_its_alignment() {
        let p = SoftPlan::of(27, 48).unwrap();
        let parts = [
            (p.rest, 27 * 12, 4),
            (p.tets, 48 * 16, 4),
            (p.displacement, 27 * 12, 4),
            (p.velocity, 27 * 12, 4),
            (p.previous, 27 * 12, 4),
            (p.mass, 27 * 4, 4),
            (p.inv_mass, 27 * 4, 4),
            (
                p.tet_rest,
                48 * size_of::<TetRest>(),
                core::mem::align_of::<TetRest>(),
            ),
            (p.lambdas, 48 * 8, 4),
            (p.tet_of, 48 * 4, 4),
            (p.body_tet, 48 * 4, 4),
        ];
        let mut end = size_of::<SoftState>();
        for (at, bytes, align) in parts {
            assert!(at >= end && at.is_multiple_of(align));
            end = at + bytes;
        }
        assert!(p.size >= end && p.size.is_multiple_of(p.align));
        assert_eq!(SoftPlan::of(0, 1).err(), Some(TdStatus::TdErrParams));
        assert_eq!(
            SoftPlan::of(1, TD_MAX_COUNT + 1).err(),
            Some(TdStatus::TdErrParams)
        );
    }
}
