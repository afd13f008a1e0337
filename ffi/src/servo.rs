//! The servo through the C interface: the world's servo handle, its force call and its
//! counters, and the one-task tick that runs the servo and the step in turn.
//!
//! The servo's memory ([`ServoState`]) is its own: `td_servo_force` reads the newest contact
//! the simulation published into the hand-off and touches nothing of the world's, so it may
//! run in a timer interrupt over `td_world_simulate` or on another thread beside it.

use super::*;

/// The servo behind a handle ([`marked_mut`]).
///
/// # Safety
/// As [`marked_mut`], for a world's servo (from `td_world_servo`) whose memory is still the
/// caller's.
pub(crate) unsafe fn servo_state<'a>(s: *mut TdServo) -> Result<&'a mut ServoState, TdStatus> {
    // SAFETY: the caller's contract.
    unsafe { marked_mut(s.cast::<ServoState>()) }
}

/// Writes the world's servo handle to `*out`: the part of the world's memory the servo's force
/// call uses alone. Take it once, before the servo's task or interrupt starts; it stays valid
/// as long as the world.
///
/// # Bounded work
/// Constant.
///
/// # Errors
/// As `td_world_simulate` for the world; `TD_ERR_NULL` / `TD_ERR_ALIGN` for `out`.
///
/// # Safety
/// `world` is a handle from `td_world_init` whose memory is still the caller's, not in use by
/// another world call meanwhile; `out` points at a writable `td_servo *`.
#[no_mangle]
pub unsafe extern "C" fn td_world_servo(world: *mut TdWorld, out: *mut *mut TdServo) -> TdStatus {
    status(|| {
        check_ptr(out)?;
        // SAFETY: the caller's contract on `world`; `state` checks it.
        let servo = unsafe { state(world) }?.servo;
        // SAFETY: checked above; writable by the caller's contract.
        unsafe { put(out, servo.cast::<TdServo>()) }
    })
}

/// The force on the tool at `position` from the newest contact a step published (stiffness
/// times depth, damping, a bounded switch between planes, clamped to `max_force`), written
/// to `*force`; it enters the servo's digest and counters, and its magnitude presses the burr
/// at the world's next step. A drill's world renders the drill's force (`td_servo_wrench`)
/// with the identity rotation, the shaft along +z.
///
/// May preempt `td_world_simulate` (a timer interrupt over the simulation's loop) or run
/// beside it on another thread: the two share only the hand-off's atomics. With the two on
/// different cores a read overtaken by the steps published meanwhile is tried again, at most
/// 4 times, then the contact before is kept (`stale_reads`).
///
/// # Bounded work
/// Constant: at most 4 reads of 18 words and the force (a drill's: `td_servo_wrench`'s).
/// Never waits.
///
/// # Errors
/// `TD_ERR_NULL` / `TD_ERR_ALIGN` / `TD_ERR_NOT_INIT` for the servo, `TD_ERR_NULL` /
/// `TD_ERR_ALIGN` for `force`, `TD_ERR_INPUT` for a non-finite position. On an error the force
/// is not written (render zero) and nothing is counted.
///
/// # Safety
/// `servo` is a handle from `td_world_servo` whose world's memory is still the caller's, with
/// one servo call at a time (this one or `td_world_tick`); `force` points at a writable
/// `td_vec3`.
#[no_mangle]
pub unsafe extern "C" fn td_servo_force(
    servo: *mut TdServo,
    position: TdVec3,
    force: *mut TdVec3,
) -> TdStatus {
    status(|| {
        check_ptr(force)?;
        // SAFETY: the caller's contract on `servo`; `servo_state` checks it.
        let sv = unsafe { servo_state(servo) }?;
        let at = pose(position)?;
        let (f, _) = tools::wrench(sv, at, tools::axis(None)?);
        // SAFETY: checked above; writable by the caller's contract.
        unsafe { force.write(td_vec(f)) };
        Ok(())
    })
}

/// Sets the burr's spin for the servo's next ticks: `omega`, the direction of its angular
/// velocity (normalised; its length does not matter), kept until set again; zero: the burr
/// does not spin. While the drill is on over a region with a friction coefficient
/// (`td_world_set_region_feel`), the force gains the spinning burr's sideways pull,
/// `friction * |spring| * (spin x n)` for the contact's outward normal `n` (docs/DRILLING.md,
/// "Sideways pull"); without a friction, or with no spin, the force is the same bits as
/// before. The host sets it each tick to the tool's axis (burr to handle, the pose's rotated
/// +z) times -1 for a burr spinning clockwise seen from the handle (its default, `--spin
/// cw`) or +1 counter-clockwise (`--spin ccw`), zero while the drill is off. A drill's world
/// sets its burr's spin.
///
/// # Bounded work
/// Constant.
///
/// # Errors
/// As `td_servo_force` for the servo; `TD_ERR_INPUT` for a non-finite `omega` (the spin is
/// left as it was).
///
/// # Safety
/// As `td_servo_force`: called from the servo's task, or when the servo is not running.
#[no_mangle]
pub unsafe extern "C" fn td_servo_set_spin(servo: *mut TdServo, omega: TdVec3) -> TdStatus {
    status(|| {
        // SAFETY: the caller's contract on `servo`; `servo_state` checks it.
        let sv = unsafe { servo_state(servo) }?;
        let w = pose(omega)?;
        match sv.drill.as_mut() {
            Some(d) => d.set_spin(w),
            None => sv.servo.set_spin(w),
        }
        Ok(())
    })
}

/// Writes the servo's counters to `*out`: the force digest, its ticks, those in contact, the
/// reads that kept an older contact, and the step it renders from. Call it from the servo's
/// task (or when the servo is not running).
///
/// # Bounded work
/// Constant.
///
/// # Errors
/// As `td_servo_force` for the servo; `TD_ERR_NULL` / `TD_ERR_ALIGN` for `out`.
///
/// # Safety
/// As `td_servo_force`; `out` points at a writable `td_servo_counters`.
#[no_mangle]
pub unsafe extern "C" fn td_servo_counters(
    servo: *mut TdServo,
    out: *mut TdServoCounts,
) -> TdStatus {
    status(|| {
        check_ptr(out)?;
        // SAFETY: the caller's contract on `servo`; `servo_state` checks it.
        let sv = unsafe { servo_state(servo) }?;
        let c = match &sv.drill {
            Some(d) => TdServoCounts {
                force_digest: d.digest(),
                servo_ticks: d.ticks(),
                contact_ticks: d.contact_ticks(),
                stale_reads: d.stale_reads(),
                step: d.step(),
            },
            None => TdServoCounts {
                force_digest: sv.servo.digest(),
                servo_ticks: sv.servo.ticks(),
                contact_ticks: sv.servo.contact_ticks(),
                stale_reads: sv.servo.stale_reads(),
                step: sv.servo.step(),
            },
        };
        // SAFETY: checked above; writable by the caller's contract.
        unsafe { out.write(c) };
        Ok(())
    })
}

/// One whole tick as `tetradrill replay` runs it, in one task. With `td_params.servo_lag` 0:
/// `td_world_simulate` at `position` with `buttons`, then the world's `td_servo_force` at the
/// same position; with 1: the servo force from the previous tick's contact, then
/// `td_world_simulate`. The force goes to `*force`; its magnitude presses the burr for one
/// servo period (`dt`) at the next step.
///
/// # Bounded work
/// `td_world_simulate`'s plus a constant.
///
/// # Errors
/// As the two calls; on an error nothing more is done and the force is not written.
///
/// # Safety
/// As `td_world_simulate`, and no servo call on this world's servo meanwhile; `force` points
/// at a writable `td_vec3`.
#[no_mangle]
pub unsafe extern "C" fn td_world_tick(
    world: *mut TdWorld,
    position: TdVec3,
    buttons: u32,
    force: *mut TdVec3,
) -> TdStatus {
    let step = || {
        // SAFETY: the caller's contract on `world`; `td_world_simulate` checks it.
        match unsafe { td_world_simulate(world, position, buttons, ptr::null_mut()) } {
            TdStatus::TdOk => Ok(()),
            e => Err(e),
        }
    };
    status(|| {
        check_ptr(force)?;
        // SAFETY: the caller's contract on `world`; `state` checks it.
        let (servo, lag) = unsafe { state(world) }.map(|st| (st.servo, st.servo_lag))?;
        pose(position)?;
        if !lag {
            step()?;
        }
        // SAFETY: the world's own servo, set up with it; no other servo call meanwhile (the
        // caller's contract); `force` checked.
        match unsafe { td_servo_force(servo.cast::<TdServo>(), position, force) } {
            TdStatus::TdOk => {}
            e => return Err(e),
        }
        if lag {
            step()?;
        }
        Ok(())
    })
}
