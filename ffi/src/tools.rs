//! Tools with an orientation through the C interface: the drill (a burr on a shaft of
//! passive points, the host's `--tool drill:BURR_R:SHAFT_LEN:SHAFT_R`), poses with a
//! rotation, and the force and torque on the tool.
//!
//! A world is a sphere's until `td_world_set_drill` makes it a drill's (the burr's radius is
//! `td_params.radius`). A drill world's step is the core's `World::simulate_drill` (the burr
//! drilled as a sphere's, then the shaft's passive points tracked against the drilled
//! surface); it publishes the burr's contact and the shaft's planes together through the
//! core's `DrillHandoff`, and its servo (the core's `DrillServo`) renders `drill_force` and
//! `drill_torque` from them, reporting the burr's own force as the next step's pressing force
//! through the world's `ContactHandoff`, as `tetradrill replay --tool drill:...` runs a tick.
//! A pose without a rotation (`td_world_simulate`, `td_servo_force`, `td_world_tick`) is the
//! identity: the shaft along +z.

use super::*;

use tetradrill_core::force::DrillTool;
use tetradrill_core::servo::{DrillHandoff, DrillServo, DrillState, PassiveReport, SimReport};
use tetradrill_core::Quat;

/// A drill world's simulation side: the drill's shape, its shaft's passive points and the
/// figures `td_world_shaft` reports.
#[derive(Clone, Copy, Debug)]
pub struct DrillSim {
    /// The drill's shape.
    pub tool: DrillTool,
    /// The shaft's passive points, carried from step to step.
    pub state: DrillState,
    /// The last step's passive-point report.
    pub last: PassiveReport,
    /// Steps in which a passive point had a contact plane.
    pub near_ticks: u64,
    /// Steps in which a passive point was held.
    pub held_ticks: u64,
    /// Most points held at one step.
    pub held_max: u32,
}

impl DrillSim {
    /// One drill step: `World::simulate_drill` with the burr at `at` and the shaft along
    /// `axis`, its figures counted, its contact and shaft published to the servo.
    ///
    /// # Bounded work
    /// `World::simulate_drill`'s, then the hand-off's constant publish.
    #[allow(clippy::too_many_arguments)]
    pub fn step(
        &mut self,
        world: &mut World<'static>,
        at: Vec3,
        axis: Vec3,
        reach: f32,
        drill_on: bool,
        params: &DrillParams,
        handoff: &DrillHandoff,
    ) -> SimReport {
        let (rep, prep) = world.simulate_drill(
            &self.tool,
            at,
            axis,
            reach,
            drill_on,
            params,
            &mut self.state,
        );
        self.last = prep;
        self.near_ticks += u64::from(prep.near > 0);
        self.held_ticks += u64::from(prep.held > 0);
        self.held_max = self.held_max.max(prep.held);
        handoff.publish(world.contact(), &self.state);
        rep
    }
}

/// The tool's axis for `rotation` (`None`: the identity, +z), as the host takes it from a
/// pose's rotation (`DrillTool::axis`: +z turned, normalised; +z for a zero quaternion), or
/// `TdErrInput` for a non-finite one.
pub(crate) fn axis(rotation: Option<TdQuat>) -> Result<Vec3, TdStatus> {
    let q = match rotation {
        None => Quat::IDENTITY,
        Some(r) => Quat::from_xyzw(r.x, r.y, r.z, r.w),
    };
    if q.is_finite() {
        Ok(DrillTool::axis(q))
    } else {
        Err(TdStatus::TdErrInput)
    }
}

/// One servo tick of the world's tool at `at` with its axis `axis`: the drill's force and
/// torque, or the sphere's force and no torque.
///
/// # Bounded work
/// Constant (`DrillServo::tick` or `Servo::tick`).
pub(crate) fn wrench(sv: &mut ServoState, at: Vec3, axis: Vec3) -> (Vec3, Vec3) {
    match sv.drill.as_mut() {
        Some(d) => d.tick(sv.drill_handoff, sv.handoff, at, axis),
        None => (sv.servo.tick(sv.handoff, at), Vec3::ZERO),
    }
}

/// Makes the world's tool a drill: a burr of `td_params.radius` at the pose's position on a
/// shaft of `shaft_radius` reaching `shaft_length` from the burr's centre along the tool's
/// axis (its local +z turned by the pose's rotation), the host's `--tool
/// drill:RADIUS:SHAFT_LENGTH:SHAFT_RADIUS`. The shaft's passive points (at most 32, spaced at
/// most a shaft radius apart from the burr's surface to the handle) collide and push back
/// but never erode; a point that crosses a face is held there.
///
/// From then on each step is the drill's (the burr drilled as a sphere's, then the shaft
/// tracked), and the servo renders the force of the burr and the shaft together and the
/// shaft's torque (`td_servo_wrench`). Call it after `td_world_init`, before the first step
/// and before the servo starts (it sets up the servo's part too); calling it again replaces
/// the shaft.
///
/// # Bounded work
/// Constant.
///
/// # Errors
/// As `td_world_simulate` for the world; `TD_ERR_STARTED` after the first step;
/// `TD_ERR_PARAMS` for a shaft radius that is not positive or exceeds the burr's radius, a
/// shaft length not longer than the burr's radius, a non-finite value, or a world with
/// `servo_lag` 1 (the drill steps before its servo force, as the host's replay runs it).
///
/// # Safety
/// `world` is a handle from `td_world_init` whose memory is still the caller's, with no
/// other call on the world or its servo meanwhile.
#[no_mangle]
pub unsafe extern "C" fn td_world_set_drill(
    world: *mut TdWorld,
    shaft_length: f32,
    shaft_radius: f32,
) -> TdStatus {
    status(|| {
        // SAFETY: the caller's contract on `world`; `state` checks it.
        let st = unsafe { state(world) }?;
        if st.unstarted.is_none() {
            return Err(TdStatus::TdErrStarted);
        }
        let burr = st.radius;
        let radius_ok = shaft_radius.is_finite() && shaft_radius > 0.0 && shaft_radius <= burr;
        let length_ok = shaft_length.is_finite() && shaft_length > burr;
        if !(radius_ok && length_ok) || st.servo_lag {
            return Err(TdStatus::TdErrParams);
        }
        let tool = DrillTool {
            burr_radius: burr,
            shaft_length,
            shaft_radius,
        };
        st.shaft = Some(DrillSim {
            tool,
            state: DrillState::default(),
            last: PassiveReport::default(),
            near_ticks: 0,
            held_ticks: 0,
            held_max: 0,
        });
        // SAFETY: the world's own servo, set up with it by `td_world_init`; the servo does
        // not run yet and no servo call is made meanwhile (the caller's contract).
        unsafe { (*st.servo).drill = Some(DrillServo::new(tool, st.force)) };
        Ok(())
    })
}

/// `td_world_simulate` at a pose with a rotation: a drill world's shaft lies along the
/// rotated +z; a sphere's world uses the position alone (the same step as
/// `td_world_simulate`).
///
/// # Bounded work
/// `td_world_simulate`'s; a drill world's adds `World::simulate_drill`'s shaft: one more zone
/// query (at most `max_cells` cells and `candidate_capacity` tets) and, per passive point
/// (at most 32), the visible faces of the candidates near its path, then a publish of 239
/// words.
///
/// # Errors
/// As `td_world_simulate`; `TD_ERR_INPUT` for a non-finite rotation too (nothing is done).
///
/// # Safety
/// As `td_world_simulate`.
#[no_mangle]
pub unsafe extern "C" fn td_world_simulate_pose(
    world: *mut TdWorld,
    pose: TdPose,
    buttons: u32,
    report: *mut TdSimReport,
) -> TdStatus {
    // SAFETY: the caller's contract, passed on.
    unsafe { simulate(world, pose.position, Some(pose.rotation), buttons, report) }
}

/// The force (`*force`) and torque (`*torque`) on the tool at `pose` from the newest contact
/// a step published. A drill: the burr's spring and the shaft's passive points' springs with
/// damping, clamped to `max_force` (the force `tetradrill replay --tool drill:...` renders),
/// and the moment of the shaft's springs about the burr's centre (the pose's position),
/// scaled as their clamp scales their sum (the core's `drill_torque`; about the handle `h`
/// add `(position - h) x force`). A sphere: `td_servo_force`'s force and a zero torque. The
/// force enters the servo's digest, the torque its torque digest
/// (`td_servo_tool_counters`), and the burr's own force presses it at the world's next step.
///
/// May preempt the world's step or run beside it on another thread, as `td_servo_force`.
///
/// # Bounded work
/// Constant: at most 4 reads of the hand-off (a drill's: 239 words), then O(32) for the
/// drill's force and torque. Never waits.
///
/// # Errors
/// As `td_servo_force`; `TD_ERR_NULL` / `TD_ERR_ALIGN` for `torque`; `TD_ERR_INPUT` for a
/// non-finite pose. On an error neither output is written and nothing is counted.
///
/// # Safety
/// As `td_servo_force`; `force` and `torque` point at writable `td_vec3`s.
#[no_mangle]
pub unsafe extern "C" fn td_servo_wrench(
    servo: *mut TdServo,
    pose: TdPose,
    force: *mut TdVec3,
    torque: *mut TdVec3,
) -> TdStatus {
    status(|| {
        check_ptr(force)?;
        check_ptr(torque)?;
        // SAFETY: the caller's contract on `servo`; `servo_state` checks it.
        let sv = unsafe { servo::servo_state(servo) }?;
        let at = crate::pose(pose.position)?;
        let ax = axis(Some(pose.rotation))?;
        let (f, t) = wrench(sv, at, ax);
        // SAFETY: checked above; writable by the caller's contract.
        unsafe {
            force.write(td_vec(f));
            torque.write(td_vec(t));
        }
        Ok(())
    })
}

/// `td_world_tick` at a pose with a rotation, writing the force and the torque: with
/// `servo_lag` 0, `td_world_simulate_pose` then `td_servo_wrench` at the same pose (a drill's
/// tick as `tetradrill replay --tool drill:...` runs it); with 1 (a sphere only), the wrench
/// first.
///
/// # Bounded work
/// `td_world_simulate_pose`'s plus `td_servo_wrench`'s.
///
/// # Errors
/// As the two calls; on an error nothing more is done and the outputs are not written.
///
/// # Safety
/// As `td_world_tick`; `force` and `torque` point at writable `td_vec3`s.
#[no_mangle]
pub unsafe extern "C" fn td_world_tick_pose(
    world: *mut TdWorld,
    pose: TdPose,
    buttons: u32,
    force: *mut TdVec3,
    torque: *mut TdVec3,
) -> TdStatus {
    let step = || {
        // SAFETY: the caller's contract on `world`; the step checks it.
        match unsafe { td_world_simulate_pose(world, pose, buttons, ptr::null_mut()) } {
            TdStatus::TdOk => Ok(()),
            e => Err(e),
        }
    };
    status(|| {
        check_ptr(force)?;
        check_ptr(torque)?;
        // SAFETY: the caller's contract on `world`; `state` checks it.
        let (servo, lag) = unsafe { state(world) }.map(|st| (st.servo, st.servo_lag))?;
        crate::pose(pose.position)?;
        axis(Some(pose.rotation))?;
        if !lag {
            step()?;
        }
        // SAFETY: the world's own servo, set up with it; no other servo call meanwhile (the
        // caller's contract); the outputs checked.
        match unsafe { td_servo_wrench(servo.cast::<TdServo>(), pose, force, torque) } {
            TdStatus::TdOk => {}
            e => return Err(e),
        }
        if lag {
            step()?;
        }
        Ok(())
    })
}

/// Writes the drill's shaft figures to `*out`: its passive points, those near a face and
/// held at the last step, and over all steps the most held at once and the steps with a
/// point near or held (`tetradrill replay --json`'s `shaft`). All zero for a sphere's world.
///
/// # Bounded work
/// Constant.
///
/// # Errors
/// As `td_world_counters`.
///
/// # Safety
/// As `td_world_counters`; `out` points at a writable `td_shaft_counts`.
#[no_mangle]
pub unsafe extern "C" fn td_world_shaft(world: *mut TdWorld, out: *mut TdShaftCounts) -> TdStatus {
    status(|| {
        check_ptr(out)?;
        // SAFETY: the caller's contract on `world`; `state` checks it.
        let st = unsafe { state(world) }?;
        let c = st
            .shaft
            .as_ref()
            .map_or(TdShaftCounts::default(), |d| TdShaftCounts {
                passive_points: d.tool.passive_count() as u32,
                near: d.last.near,
                held: d.last.held,
                held_max: d.held_max,
                near_ticks: d.near_ticks,
                held_ticks: d.held_ticks,
            });
        // SAFETY: checked above; writable by the caller's contract.
        unsafe { out.write(c) };
        Ok(())
    })
}

/// Writes the servo's torque figures to `*out`: the digest of every torque rendered (0 for a
/// sphere, which renders none) and the world's tool (0 a sphere, 1 a drill). Call it from the servo's task (or when the servo is
/// not running).
///
/// # Bounded work
/// Constant.
///
/// # Errors
/// As `td_servo_counters`.
///
/// # Safety
/// As `td_servo_counters`; `out` points at a writable `td_tool_counts`.
#[no_mangle]
pub unsafe extern "C" fn td_servo_tool_counters(
    servo: *mut TdServo,
    out: *mut TdToolCounts,
) -> TdStatus {
    status(|| {
        check_ptr(out)?;
        // SAFETY: the caller's contract on `servo`; `servo_state` checks it.
        let sv = unsafe { servo::servo_state(servo) }?;
        let c = match &sv.drill {
            Some(d) => TdToolCounts {
                torque_digest: d.torque_digest(),
                tool: 1,
            },
            None => TdToolCounts {
                torque_digest: 0,
                tool: 0,
            },
        };
        // SAFETY: checked above; writable by the caller's contract.
        unsafe { out.write(c) };
        Ok(())
    })
}
