//! Materials per region through the C interface: the pressing force, a region's material and
//! feel, what each region has lost, and the work the feed did on the regions it cuts.

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
/// `tetradrill`'s scenario `[regions.LABEL]` tables. The region's feel
/// (`td_world_set_region_feel`) is kept, whichever of the two calls comes first.
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
        // The material alone: the region's feel (`td_world_set_region_feel`) stays.
        slot.material = Material {
            hardness,
            threshold,
            stiffness,
        };
        Ok(())
    })
}

/// Sets how the region labelled `label` feels while the drill is on (docs/DRILLING.md):
/// the burr's vibration at full cut, `vibration` newtons (with `td_params.vibration_hz`;
/// "Vibration"); its specific cutting energy, `cutting_energy` newtons per square mesh unit
/// (joules per cubic metre for a mesh in metres: the region is then removed only as fast as
/// the work done pushing the burr into it pays for, its hardness unused; "Cutting
/// resistance"); and its friction coefficient with the spinning burr, `friction` (a
/// sideways pull of `friction` times the contact's normal force along `spin x n`, with
/// `td_servo_set_spin`; "Sideways pull"). Zero turns each off (the default). The values of
/// `tetradrill`'s scenario keys `[regions.LABEL] vibration`, `cutting_energy` and
/// `friction`. Allowed from `td_world_init` until the first step, as `td_world_set_region`,
/// whose material it keeps.
///
/// # Bounded work
/// O(log R) for R regions.
///
/// # Errors
/// As `td_world_set_region`: `TD_ERR_PARAMS` for a value that is negative or not finite,
/// `TD_ERR_LABEL` for a label the mesh does not have, `TD_ERR_STARTED` after the first step.
/// An error changes nothing.
///
/// # Safety
/// `world` is a handle from `td_world_init` whose memory is still the caller's.
#[no_mangle]
pub unsafe extern "C" fn td_world_set_region_feel(
    world: *mut TdWorld,
    label: i32,
    vibration: f32,
    cutting_energy: f32,
    friction: f32,
) -> TdStatus {
    status(|| {
        // SAFETY: the caller's contract on `world`; `state` checks it.
        let st = unsafe { state(world) }?;
        if ![vibration, cutting_energy, friction]
            .into_iter()
            .all(non_negative)
        {
            return Err(TdStatus::TdErrParams);
        }
        let i = st.region_index(label).ok_or(TdStatus::TdErrLabel)?;
        let u = st.unstarted.as_mut().ok_or(TdStatus::TdErrStarted)?;
        let slot = u.table.get_mut(i).ok_or(TdStatus::TdErrLabel)?;
        *slot = Region::new(slot.material)
            .with_vibration(vibration)
            .with_cutting_energy(cutting_energy)
            .with_friction(friction);
        Ok(())
    })
}

/// Writes the cutting figures of the regions cut by the feed (`td_world_set_region_feel`'s
/// `cutting_energy`; docs/DRILLING.md, "Cutting resistance") to `*out`: the work done
/// pushing the burr into them, the cutting energy of the leaves it paid for, the work still
/// in the pool and the work the pool dropped, newton mesh units (joules for a mesh in
/// metres). `work` is the other three added up. `tetradrill replay --json`'s `drill`
/// figures (`cutting_work_j`, `cutting_energy_j`, `feed_pool_j`, `feed_dropped_j`); all zero
/// before the first step and in a world without a region cut by the feed.
///
/// # Bounded work
/// Constant.
///
/// # Errors
/// As `td_world_counters`.
///
/// # Safety
/// `world` is a handle from `td_world_init` whose memory is still the caller's; `out` points
/// at a writable `td_cutting`.
#[no_mangle]
pub unsafe extern "C" fn td_world_cutting(world: *mut TdWorld, out: *mut TdCutting) -> TdStatus {
    status(|| {
        check_ptr(out)?;
        // SAFETY: the caller's contract on `world`; `state` checks it.
        let st = unsafe { state(world) }?;
        let c = st
            .world
            .regions()
            .map_or(TdCutting::default(), |r| TdCutting {
                work: r.cutting_work(),
                energy: r.cutting_energy(),
                pool: r.feed_pool(),
                dropped: r.feed_dropped(),
            });
        // SAFETY: checked above; writable by the caller's contract.
        unsafe { out.write(c) };
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
        vibration: r.vibration(),
        cutting_energy: r.cutting_energy(),
        friction: r.friction(),
    };
    // SAFETY: checked by the callers; writable by the caller's contract.
    unsafe { out.write(v) };
    Ok(())
}

/// Writes the region labelled `label` to `*out`: its material, the volume removed from it
/// (`removed_by_region` of `tetradrill replay`) and its feel (`td_world_set_region_feel`).
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
