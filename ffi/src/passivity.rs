//! The servo loop's time-domain passivity through the C interface: the core's
//! `PassivityObserver` (Hannaford and Ryu 2002), which watches the energy the loop exchanges
//! with the user, dissipates what the rendered environment generates with a variable damper,
//! and trips (zero force, latched) on the energy a faulty device puts past the force limit. A
//! program that drives a device from its own servo feeds it each tick's position, the force
//! the world gave, and what the world's spring holds there (`td_servo_storage`), and writes the
//! force it returns, as the host's servo task does.

use core::alloc::Layout;

use tetradrill_core::force::{penalty_storage, PassivityObserver, PassivityParams, Storage};

use super::*;
use crate::servo::servo_state;

/// Marks a [`PassivityState`] that `td_passivity_init` finished ("tdpass01").
const PASSIVITY_MAGIC: u64 = u64::from_le_bytes(*b"tdpass01");

/// A passivity observer's settings, SI units (it is fed metres, newtons and joules).
#[repr(C)]
#[derive(Clone, Copy, PartialEq, Debug)]
pub struct TdPassivityParams {
    /// Servo period, seconds, finite and positive.
    pub dt: f32,
    /// Largest damping the controller adds, N s/m (the device's own damping limit), 0 or more.
    pub max_damping: f32,
    /// Largest force magnitude the output may have, newtons, positive (infinity: none).
    pub max_force: f32,
    /// Generated energy left alone, joules, 0 or more: below it the force passes unchanged.
    pub slack_j: f32,
    /// Energy stored past the force limit (for a force without a storage: generated energy)
    /// that trips the observer, joules, positive.
    pub trip_j: f32,
    /// 1: the controller's damper acts; 0: the observer only observes (the trip stays armed).
    pub dissipate: u32,
    /// Ticks after a restart or a recovery (`td_passivity_reset`) during which the energy past
    /// the force limit is not counted (a device ramping its force in again).
    pub regrip_ticks: u32,
    /// 1: the damper and the trip also act for a force given without a storage (the classic
    /// form); 0: such forces are observed only.
    pub act_without_storage: u32,
}

/// What a force law's spring holds at the tool's pose: `td_servo_storage` for the world's burr
/// (newton mesh units: times `1 / scale` for joules with a mesh in scaled units),
/// `td_penalty_storage` for any penalty spring.
#[repr(C)]
#[derive(Clone, Copy, PartialEq, Debug, Default)]
pub struct TdStorage {
    /// Energy the spring holds.
    pub stored_j: f32,
    /// The part of it stored past the force limit.
    pub past_limit_j: f32,
}

/// What a passivity observer has seen.
#[repr(C)]
#[derive(Clone, Copy, PartialEq, Debug, Default)]
pub struct TdPassivityCounts {
    /// 1 while tripped (the output is zero until a recovery, `td_passivity_reset`).
    pub tripped: u32,
    /// Trips so far.
    pub trips: u32,
    /// The largest generated energy seen up to the trip, joules.
    pub generated_j_max: f32,
    /// The largest value of the trip's measure seen up to the trip, joules.
    pub trip_measure_j_max: f32,
    /// Energy the damper dissipated so far, joules.
    pub dissipated_j: f64,
}

/// A passivity observer set up by `td_passivity_init` in caller memory. Opaque.
#[derive(Debug)]
pub struct TdPassivity {
    _opaque: [u8; 0],
}

/// The observer's memory.
#[derive(Debug)]
#[repr(C)]
struct PassivityState {
    /// [`PASSIVITY_MAGIC`] once set up; zero while `td_passivity_init` works on the memory.
    magic: u64,
    observer: PassivityObserver,
}

marked!(PassivityState, PASSIVITY_MAGIC);

/// The observer behind a handle ([`marked_mut`]).
///
/// # Safety
/// As [`marked_mut`], for memory `td_passivity_init` was given.
unsafe fn observer<'a>(p: *mut TdPassivity) -> Result<&'a mut PassivityObserver, TdStatus> {
    // SAFETY: the caller's contract.
    Ok(&mut unsafe { marked_mut(p.cast::<PassivityState>()) }?.observer)
}

/// The core's settings from C's, or `TdErrParams` for one out of range.
fn core_params(p: &TdPassivityParams) -> Result<PassivityParams, TdStatus> {
    let ok = p.dt.is_finite()
        && p.dt > 0.0
        && non_negative(p.max_damping)
        && p.max_force > 0.0
        && non_negative(p.slack_j)
        && p.trip_j > 0.0
        && p.dissipate <= 1
        && p.act_without_storage <= 1;
    if !ok {
        return Err(TdStatus::TdErrParams);
    }
    Ok(PassivityParams {
        dt: p.dt,
        max_damping: p.max_damping,
        max_force: p.max_force,
        slack_j: p.slack_j,
        trip_j: p.trip_j,
        dissipate: p.dissipate == 1,
        regrip_ticks: p.regrip_ticks,
        act_without_storage: p.act_without_storage == 1,
    })
}

/// Fills `*out` with the core's defaults, as the host's servo runs them: 1 kHz, 20 N s/m
/// (the simulated device's and the Falcon's damping limit), no force limit, a slack of 0.1 mJ,
/// a trip at 50 mJ, the damper on, 500 ticks to regrip, a force without a storage observed
/// only.
///
/// # Bounded work
/// Constant.
///
/// # Errors
/// `TD_ERR_NULL` / `TD_ERR_ALIGN` for `out`.
///
/// # Safety
/// `out` points at a writable `td_passivity_params`.
#[no_mangle]
pub unsafe extern "C" fn td_passivity_params_default(out: *mut TdPassivityParams) -> TdStatus {
    let d = PassivityParams::default();
    let p = TdPassivityParams {
        dt: d.dt,
        max_damping: d.max_damping,
        max_force: d.max_force,
        slack_j: d.slack_j,
        trip_j: d.trip_j,
        dissipate: u32::from(d.dissipate),
        regrip_ticks: d.regrip_ticks,
        act_without_storage: u32::from(d.act_without_storage),
    };
    // SAFETY: the caller's contract on `out`; `put` checks null and alignment.
    status(|| unsafe { put(out, p) })
}

/// Writes the bytes and the alignment an observer needs.
///
/// # Bounded work
/// Constant.
///
/// # Errors
/// `TD_ERR_NULL` / `TD_ERR_ALIGN` for a pointer.
///
/// # Safety
/// `out_size` and `out_align` point at writable `size_t`s.
#[no_mangle]
pub unsafe extern "C" fn td_passivity_size(
    out_size: *mut usize,
    out_align: *mut usize,
) -> TdStatus {
    let l = Layout::new::<PassivityState>();
    // SAFETY: the caller's contract on the outputs (`sized` checks them).
    unsafe { sized(out_size, out_align, || Ok((l.size(), l.align()))) }
}

/// Sets up an observer with `params` in `mem` (`len` bytes at the alignment
/// `td_passivity_size` gave): no energy exchanged yet, not tripped; writes its handle to
/// `*out`.
///
/// # Bounded work
/// Constant.
///
/// # Errors
/// `TD_ERR_NULL` / `TD_ERR_ALIGN` / `TD_ERR_TOO_SMALL` for `mem`, `TD_ERR_NULL` /
/// `TD_ERR_ALIGN` for `params` or `out`, `TD_ERR_PARAMS` for a setting out of range (a `dt`
/// not finite and positive, a negative damping or slack, a force limit or trip energy not
/// positive, a flag other than 0 or 1). On an error after the checks of `mem` the memory holds
/// no observer.
///
/// # Safety
/// `mem` points at `len` writable bytes the caller keeps for as long as it uses the observer;
/// `params` at a `td_passivity_params`; `out` at a writable pointer.
#[no_mangle]
pub unsafe extern "C" fn td_passivity_init(
    mem: *mut c_void,
    len: usize,
    params: *const TdPassivityParams,
    out: *mut *mut TdPassivity,
) -> TdStatus {
    status(|| {
        check_ptr(out)?;
        let l = Layout::new::<PassivityState>();
        let head = caller_memory(mem, len, l.size(), l.align())?.cast::<PassivityState>();
        // SAFETY: aligned and long enough for the header (checked): a handle to this memory is
        // refused from here on until the init succeeds.
        unsafe { ptr::addr_of_mut!((*head).magic).write(0) };
        // SAFETY: the caller's contract on `params` (`get` checks it).
        let p = core_params(&unsafe { get(params) }?)?;
        let mut observer = PassivityObserver::default();
        observer.set_params(p);
        // SAFETY: the header's memory (checked above); its magic is zero while it is written,
        // and goes last.
        unsafe {
            ptr::addr_of_mut!((*head).observer).write(observer);
            ptr::addr_of_mut!((*head).magic).write(PASSIVITY_MAGIC);
            out.write(head.cast::<TdPassivity>());
        }
        Ok(())
    })
}

/// One servo tick: the tool at `position` (metres), the force law's `force` (newtons) and,
/// when the law knows it, what its spring holds there (`storage`, joules; null: none).
/// Writes the force to send the device to `*out`: `force` itself while the generated energy is
/// within the slack, plus the controller's damper beyond it (clamped to `max_force`), zero
/// once tripped. `removing` 1 marks an environment that gives way by design (the drill on:
/// its spring is no storage function, so the classic form counts and damps, while the trip
/// still measures `storage`'s energy past the force limit).
///
/// # Bounded work
/// Constant: a few dozen flops. For the servo's task or interrupt.
///
/// # Errors
/// `TD_ERR_NULL` / `TD_ERR_ALIGN` / `TD_ERR_NOT_INIT` for the observer, `TD_ERR_NULL` /
/// `TD_ERR_ALIGN` for `out` or a misaligned `storage` (nothing done), `TD_ERR_INPUT` for a
/// force, position or storage that is not finite, or `removing` other than 0 or 1: nothing is
/// counted and the observer forgets its velocity history and the force it held, as the core
/// does for a pose that is not finite (send zero).
///
/// # Safety
/// `observer` is a handle from `td_passivity_init`, one call at a time; `storage` is null or
/// points at a `td_storage`; `out` at a writable `td_vec3`.
#[no_mangle]
pub unsafe extern "C" fn td_passivity_step(
    observer: *mut TdPassivity,
    position: TdVec3,
    force: TdVec3,
    storage: *const TdStorage,
    removing: u32,
    out: *mut TdVec3,
) -> TdStatus {
    status(|| {
        check_ptr(out)?;
        // SAFETY: the caller's contract on `observer`.
        let o = unsafe { self::observer(observer) }?;
        let stored = if storage.is_null() {
            None
        } else {
            // SAFETY: not null; the caller's contract (`get` checks the alignment).
            Some(unsafe { get(storage) }?)
        };
        let input = (|| {
            let (at, f) = (pose(position)?, pose(force)?);
            let s = match stored {
                Some(s) if !(s.stored_j.is_finite() && s.past_limit_j.is_finite()) => {
                    return Err(TdStatus::TdErrInput)
                }
                s => s.map(|s| Storage {
                    stored_j: s.stored_j,
                    past_limit_j: s.past_limit_j,
                }),
            };
            if removing > 1 {
                return Err(TdStatus::TdErrInput);
            }
            Ok((at, f, s))
        })();
        let sent = match input {
            Ok((at, f, s)) if removing == 1 => o.step_removing(at, f, s),
            Ok((at, f, s)) => o.step(at, f, s),
            Err(e) => {
                // The tick is lost: the observer forgets its velocity history and the force it
                // held (the core's answer to a pose that is not finite), counting nothing.
                o.step(Vec3::NAN, Vec3::ZERO, None);
                return Err(e);
            }
        };
        // SAFETY: checked above; writable by the caller's contract.
        unsafe { out.write(td_vec(sent)) };
        Ok(())
    })
}

/// Restarts the observer (`restart` 1: its velocity history and contact forgotten, the energy
/// past the force limit counted again after `regrip_ticks`: for a force that was off for a
/// while, a watchdog's cut), clears a trip (`recover` 1: the output is the law's force again,
/// which the caller ramps back in; the trips stay counted), or trips it from a check of the
/// caller's own (`trip` 1: latched and counted as its own trips are). Each flag 0 or 1; done in
/// that order.
///
/// # Bounded work
/// Constant.
///
/// # Errors
/// As `td_passivity_step` for the observer; `TD_ERR_PARAMS` for a flag other than 0 or 1
/// (nothing done).
///
/// # Safety
/// `observer` is a handle from `td_passivity_init`, one call at a time.
#[no_mangle]
pub unsafe extern "C" fn td_passivity_reset(
    observer: *mut TdPassivity,
    restart: u32,
    recover: u32,
    trip: u32,
) -> TdStatus {
    status(|| {
        // SAFETY: the caller's contract on `observer`.
        let o = unsafe { self::observer(observer) }?;
        if restart > 1 || recover > 1 || trip > 1 {
            return Err(TdStatus::TdErrParams);
        }
        if restart == 1 {
            o.restart();
        }
        if recover == 1 {
            o.recover();
        }
        if trip == 1 {
            o.trip();
        }
        Ok(())
    })
}

/// Writes what the observer has seen: tripped, trips, the largest generated energy and trip
/// measure, the damper's dissipated energy.
///
/// # Bounded work
/// Constant.
///
/// # Errors
/// As `td_passivity_step` for the observer; `TD_ERR_NULL` / `TD_ERR_ALIGN` for `out`.
///
/// # Safety
/// `observer` is a handle from `td_passivity_init`, not in another passivity call meanwhile
/// (from the servo's task, or while it does not run); `out` points at a writable
/// `td_passivity_counts`.
#[no_mangle]
pub unsafe extern "C" fn td_passivity_counters(
    observer: *mut TdPassivity,
    out: *mut TdPassivityCounts,
) -> TdStatus {
    status(|| {
        // SAFETY: the caller's contract on `observer`.
        let o = unsafe { self::observer(observer) }?;
        let c = TdPassivityCounts {
            tripped: u32::from(o.tripped()),
            trips: o.trips(),
            generated_j_max: o.generated_j_max(),
            trip_measure_j_max: o.trip_measure_j_max(),
            dissipated_j: o.dissipated_j(),
        };
        // SAFETY: the caller's contract on `out`; `put` checks null and alignment.
        unsafe { put(out, c) }
    })
}

/// The energy a penalty spring of `stiffness` whose force is clamped at `max_force` holds at
/// `depth`: `K d^2 / 2` up to the depth `F / K` where the limit is reached, then `F` a unit
/// of depth beyond it (`past_limit_j`). Zero out of contact (`depth` <= 0), for a `depth` or
/// `stiffness` that is not finite, or a `stiffness` or `max_force` that is not positive
/// (`max_force` infinite: no limit).
///
/// # Bounded work
/// Constant.
///
/// # Errors
/// `TD_ERR_NULL` / `TD_ERR_ALIGN` for `out`.
///
/// # Safety
/// `out` points at a writable `td_storage`.
#[no_mangle]
pub unsafe extern "C" fn td_penalty_storage(
    depth: f32,
    stiffness: f32,
    max_force: f32,
    out: *mut TdStorage,
) -> TdStatus {
    let s = penalty_storage(depth, stiffness, max_force);
    let s = TdStorage {
        stored_j: s.stored_j,
        past_limit_j: s.past_limit_j,
    };
    // SAFETY: the caller's contract on `out`; `put` checks null and alignment.
    status(|| unsafe { put(out, s) })
}

/// The burr's depth at `position` below the plane of the contact the servo's last force call
/// used, to `*out_depth` (when not null), and what its penalty spring holds there (the
/// stiffness the servo rendered: the material's under the contact, else `td_params`'; its
/// force limit), to `*out`, in newton mesh units: zero out of contact. Call it after
/// `td_servo_force` at the same position, from the servo's task, to feed `td_passivity_step`
/// (scaled to joules for a mesh whose unit is not the metre). A drill's world: `TD_ERR_PARAMS`
/// (its force has no single spring).
///
/// # Bounded work
/// Constant.
///
/// # Errors
/// As `td_servo_force` for the servo and the position; `TD_ERR_NULL` / `TD_ERR_ALIGN` for
/// `out`, `TD_ERR_ALIGN` for `out_depth`; `TD_ERR_PARAMS` for a drill's world.
///
/// # Safety
/// `servo` is a handle from `td_world_servo`, used by one servo call at a time; `out` points
/// at a writable `td_storage`; `out_depth` is null or writable.
#[no_mangle]
pub unsafe extern "C" fn td_servo_storage(
    servo: *mut TdServo,
    position: TdVec3,
    out_depth: *mut f32,
    out: *mut TdStorage,
) -> TdStatus {
    status(|| {
        check_ptr(out)?;
        if !out_depth.is_null() {
            check_ptr(out_depth)?;
        }
        // SAFETY: the caller's contract on `servo`; `servo_state` checks it.
        let sv = unsafe { servo_state(servo) }?;
        if sv.drill.is_some() {
            return Err(TdStatus::TdErrParams);
        }
        let (depth, s) = sv.servo.storage(pose(position)?);
        // SAFETY: both checked above; writable by the caller's contract.
        unsafe {
            if !out_depth.is_null() {
                out_depth.write(depth);
            }
            out.write(TdStorage {
                stored_j: s.stored_j,
                past_limit_j: s.past_limit_j,
            });
        }
        Ok(())
    })
}
