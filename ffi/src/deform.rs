//! A world whose mesh moves (`td_params.deformable`): new node positions after each step of
//! whatever physics the caller runs (`td_world_set_positions`, the core's
//! `World::set_positions`), and where the tool touches it (`td_world_contact_at`), so that
//! the tool's reaction can load that physics (a soft body's `td_soft_add_point_force`).

use super::*;

use crate::soft::c_slice;
use crate::types::{TdContactAt, TdDeformReport};
use tetradrill_core::servo::DeformError;

/// `TdContactAt::tet` when the last step found no contact.
pub const TD_NO_TET: u32 = u32::MAX;

/// Moves the world's nodes to `xyz` (x, y, z of each of the mesh's `node_count` nodes, in the
/// order `td_world_init` was given them) and brings everything that depends on them up to
/// date: each tet's box, the hash (only the tets whose cells changed move, in the spare
/// storage `td_params.deformable` set aside), the boundary normals and the contact search's
/// caches. The drilled faces follow (they are barycentric in their coarse tets); removed
/// volumes stay measured at rest. The contact plane stays the last step's until the next
/// `td_world_simulate`, which finds it on the new positions. `*out`, when not null, gets what
/// the update did.
///
/// Call it between simulation steps, from the thread that runs them; the servo's force call
/// may run beside it (it reads only the published contact).
///
/// # Bounded work
/// O(nodes + tets) for the boxes and normals, plus the hash's entries of the tets that changed
/// cells (a full rebuild, O(hash entries), when too many did): not for the servo's tick.
///
/// # Errors
/// `TD_ERR_NULL` / `TD_ERR_ALIGN` for a pointer, `TD_ERR_NOT_INIT` for a world not set up,
/// `TD_ERR_RIGID` for a world set up with `deformable` 0, `TD_ERR_PARAMS` for `node_count`
/// other than the mesh's, `TD_ERR_INPUT` for a position that is not finite, `TD_ERR_BUSY`
/// while a link's cycle is under way (from its first `td_link_tick` to the commit: the link
/// moves the world) (`*out` is not written and the world is unchanged).
///
/// # Safety
/// `world` is a handle from `td_world_init` whose memory is still the caller's; `xyz` points
/// at `3 node_count` floats outside the world's memory; `out` at a writable
/// `td_deform_report` or is null.
#[no_mangle]
pub unsafe extern "C" fn td_world_set_positions(
    world: *mut TdWorld,
    xyz: *const f32,
    node_count: u32,
    out: *mut TdDeformReport,
) -> TdStatus {
    status(|| {
        if !out.is_null() {
            check_ptr(out)?;
        }
        // SAFETY: the caller's contract on `world`; `state` checks it.
        let st = unsafe { state(world) }?;
        if !st.deformable {
            return Err(TdStatus::TdErrRigid);
        }
        if st.link_cycle != 0 || st.world.preparing() {
            return Err(TdStatus::TdErrBusy);
        }
        let n = st.world.mesh().node_count();
        if node_count as usize != n {
            return Err(TdStatus::TdErrParams);
        }
        // SAFETY: `3 n` floats at `xyz` (the caller's contract; `n` is at most `TD_MAX_COUNT`).
        let xyz = unsafe { c_slice(xyz, 3 * n) }?;
        // The core checks every position before it changes anything (`NotFinite`).
        let rep = st
            .world
            .set_positions(crate::soft::vec3s(xyz))
            .map_err(|e| match e {
                DeformError::NoRest => TdStatus::TdErrRigid,
                DeformError::Count { .. } => TdStatus::TdErrParams,
                DeformError::NotFinite { .. } => TdStatus::TdErrInput,
                _ => TdStatus::TdErrWorld,
            })?;
        if out.is_null() {
            return Ok(());
        }
        let r = TdDeformReport {
            max_displacement: rep.max_displacement,
            hash_entries: rep.hash_entries,
            hash_saturated: u32::from(rep.hash_saturated),
            kept: rep.kept,
        };
        // SAFETY: checked above; the caller's contract makes it writable.
        unsafe { put(out, r) }
    })
}

/// Where the last simulation step's contact is: its coarse tet (an index into the tets
/// `td_world_init` was given) and its point on the visible surface, or `tet` = `TD_NO_TET`
/// when the tool touched nothing. A soft body built from the same arrays takes the tool's
/// reaction there (`td_soft_add_point_force`). Call it from the thread that runs the steps,
/// between them (it reads the world's own state; the servo's handle is apart).
///
/// # Bounded work
/// Constant.
///
/// # Errors
/// `TD_ERR_NULL` / `TD_ERR_ALIGN` for a pointer, `TD_ERR_NOT_INIT` for a world not set up.
///
/// # Safety
/// `world` is a handle from `td_world_init` whose memory is still the caller's; `out` points
/// at a writable `td_contact_at`.
#[no_mangle]
pub unsafe extern "C" fn td_world_contact_at(
    world: *mut TdWorld,
    out: *mut TdContactAt,
) -> TdStatus {
    status(|| {
        check_ptr(out)?;
        // SAFETY: the caller's contract on `world`; `state` checks it.
        let st = unsafe { state(world) }?;
        let at = match st.world.contact_tet() {
            Some(t) => TdContactAt {
                tet: t.idx() as u32,
                point: td_vec(st.world.contact().point),
            },
            None => TdContactAt {
                tet: TD_NO_TET,
                point: TdVec3::default(),
            },
        };
        // SAFETY: checked above; the caller's contract makes it writable.
        unsafe { put(out, at) }
    })
}
