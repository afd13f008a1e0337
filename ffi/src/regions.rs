//! Materials per region through the C interface: the pressing force, a region's material, and
//! what each region has lost.

use super::*;

/// Sets the force pressing the burr against the material, `newtons`, held for `seconds`: the
/// next `td_world_simulate` earns each region's erosion from them. Without this call the
/// world takes them from its servo (the magnitude of its last force, for the periods since the
/// previous step); once called, the world keeps the caller's value until set again and no
/// longer takes the servo's (for a force that reaches the drill another way, or a test).
/// Without materials it changes nothing.
///
/// # Bounded work
/// Constant.
///
/// # Errors
/// As `td_world_simulate` for the world; `TD_ERR_INPUT` for a force or duration that is
/// negative or not finite (nothing is set).
///
/// # Safety
/// `world` is a handle from `td_world_init` whose memory is still the caller's.
#[no_mangle]
pub unsafe extern "C" fn td_world_set_pressing(
    world: *mut TdWorld,
    newtons: f32,
    seconds: f32,
) -> TdStatus {
    status(|| {
        // SAFETY: the caller's contract on `world`; `state` checks it.
        let st = unsafe { state(world) }?;
        if !(non_negative(newtons) && non_negative(seconds)) {
            return Err(TdStatus::TdErrInput);
        }
        st.manual_pressing = true;
        st.world.set_pressing(newtons, seconds);
        Ok(())
    })
}

/// Sets the material of the region labelled `label` (docs/DRILLING.md, "Materials"): the
/// burr removes it only while pressing harder than `threshold` newtons, at `(F - threshold)
/// / hardness` cubic mesh units a second (`hardness` 0: at once), and its contact has
/// `stiffness` newtons per mesh unit (0: `td_params.stiffness`). Allowed from
/// `td_world_init` until the first `td_world_simulate` (or `td_world_tick`); the values of
/// `tetradrill`'s scenario `[regions.LABEL]` tables.
///
/// # Bounded work
/// O(log R) for R regions.
///
/// # Errors
/// As `td_world_simulate` for the world; `TD_ERR_PARAMS` for a value that is negative or not
/// finite, `TD_ERR_LABEL` for a label the mesh does not have, `TD_ERR_STARTED` after the
/// first step. An error changes nothing.
///
/// # Safety
/// `world` is a handle from `td_world_init` whose memory is still the caller's.
#[no_mangle]
pub unsafe extern "C" fn td_world_set_region(
    world: *mut TdWorld,
    label: i32,
    hardness: f32,
    threshold: f32,
    stiffness: f32,
) -> TdStatus {
    status(|| {
        // SAFETY: the caller's contract on `world`; `state` checks it.
        let st = unsafe { state(world) }?;
        if !(non_negative(hardness) && non_negative(threshold) && non_negative(stiffness)) {
            return Err(TdStatus::TdErrParams);
        }
        let i = st.region_index(label).ok_or(TdStatus::TdErrLabel)?;
        let u = st.unstarted.as_mut().ok_or(TdStatus::TdErrStarted)?;
        let slot = u.table.get_mut(i).ok_or(TdStatus::TdErrLabel)?;
        *slot = Region::new(Material {
            hardness,
            threshold,
            stiffness,
        });
        Ok(())
    })
}

/// Writes the region at `index` (0 .. `region_count`, in ascending label order) to `*out`.
///
/// # Safety
/// As `td_world_region`.
unsafe fn write_region(st: &State, index: usize, out: *mut TdRegion) -> Status {
    let (Some(r), Some(&label)) = (st.regions().get(index), st.labels.get(index)) else {
        return Err(TdStatus::TdErrLabel);
    };
    let m = r.material;
    let v = TdRegion {
        label,
        hardness: m.hardness,
        threshold: m.threshold,
        stiffness: m.stiffness,
        removed_volume: r.removed(),
    };
    // SAFETY: checked by the callers; writable by the caller's contract.
    unsafe { out.write(v) };
    Ok(())
}

/// Writes the region labelled `label` to `*out`: its material and the volume removed from it
/// (`removed_by_region` of `tetradrill replay`).
///
/// # Bounded work
/// O(log R) for R regions.
///
/// # Errors
/// As `td_world_simulate` for the world; `TD_ERR_NULL` / `TD_ERR_ALIGN` for `out`,
/// `TD_ERR_LABEL` for a label the mesh does not have.
///
/// # Safety
/// `world` is a handle from `td_world_init` whose memory is still the caller's; `out` points
/// at a writable `td_region`.
#[no_mangle]
pub unsafe extern "C" fn td_world_region(
    world: *mut TdWorld,
    label: i32,
    out: *mut TdRegion,
) -> TdStatus {
    status(|| {
        check_ptr(out)?;
        // SAFETY: the caller's contract on `world`; `state` checks it.
        let st = unsafe { state(world) }?;
        let i = st.region_index(label).ok_or(TdStatus::TdErrLabel)?;
        // SAFETY: `out` checked; the caller's contract.
        unsafe { write_region(st, i, out) }
    })
}

/// Writes region number `index` (0 .. `td_counters.region_count`, in ascending label order)
/// to `*out`, its label included: to list a world's regions.
///
/// # Bounded work
/// Constant.
///
/// # Errors
/// As `td_world_region`, with `TD_ERR_LABEL` for an index past the last region.
///
/// # Safety
/// As `td_world_region`.
#[no_mangle]
pub unsafe extern "C" fn td_world_region_at(
    world: *mut TdWorld,
    index: u32,
    out: *mut TdRegion,
) -> TdStatus {
    status(|| {
        check_ptr(out)?;
        // SAFETY: the caller's contract on `world`; `state` checks it.
        let st = unsafe { state(world) }?;
        let i = usize::try_from(index).map_err(|_| TdStatus::TdErrLabel)?;
        // SAFETY: `out` checked; the caller's contract.
        unsafe { write_region(st, i, out) }
    })
}
