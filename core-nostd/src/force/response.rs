//! From contact to the force a device may render: stiffness, damping, clamping, and where to
//! draw the tool so it never visibly penetrates.

use glam::Vec3;

use crate::depth::Penetration;

/// Force parameters (SI when the mesh is in metres: N/m, N s/m, N).
#[derive(Clone, Copy, PartialEq, Debug)]
pub struct ForceParams {
    /// Newtons per mesh unit of depth (per node for a mesh tool).
    pub stiffness: f32,
    /// Newtons per (mesh unit per second), applied only while in contact.
    pub damping: f32,
    /// Largest force magnitude sent to the device.
    pub max_force: f32,
    /// Servo period in seconds (for velocities from consecutive positions).
    pub dt: f32,
    /// Seconds over which the sphere burr's force moves from one contact plane to the next
    /// (see [`crate::servo::servo_force`]); zero switches at once. Not used by the pen.
    pub switch_time: f32,
}

impl Default for ForceParams {
    /// The PHANTOM Omni's limits (CHAI3D): 700 N/m, 5 N s/m... scaled down for damping, 3.3 N.
    fn default() -> Self {
        Self {
            stiffness: 700.0,
            damping: 1.0,
            max_force: 3.3,
            dt: 1e-3,
            switch_time: DEFAULT_SWITCH_TIME,
        }
    }
}

/// Default [`ForceParams::switch_time`]: 16 ms, so a full reversal of a clamped force is
/// spread over 16 servo ticks at 1 kHz (an eighth of the clamp per tick), well under the
/// time a hand notices (tens of milliseconds) and well over one tick.
pub(crate) const DEFAULT_SWITCH_TIME: f32 = 0.016;

/// The tool's state carried from tick to tick.
#[derive(Clone, Copy, PartialEq, Debug, Default)]
pub struct ToolState {
    /// Reference position at the previous tick (none before the first).
    pub(crate) previous: Option<Vec3>,
    /// The contact plane (point, unit normal) the last force came from, if any.
    pub(crate) plane: Option<(Vec3, Vec3)>,
    /// What the force still owes the last plane switch: added to the spring force and
    /// shrunk to zero at a bounded rate (see [`crate::servo::servo_force`]).
    pub(crate) residual: Vec3,
    /// The stiffness `plane` was felt with, newtons per mesh unit (a change of the material
    /// under the contact is a switch, rendered as a ramp like a change of plane).
    pub(crate) stiffness: f32,
    /// The burr's vibration phase, cycles in `[0, 1)`: advanced by `hz * dt` each tick a
    /// [`crate::servo::VibrationCue`] is active (see [`crate::servo::servo_force`]).
    pub(crate) phase: f32,
    /// The burr's spin: the unit direction of its angular velocity, zero while it does not
    /// spin ([`ToolState::set_spin`]).
    pub(crate) spin: Vec3,
}

impl ToolState {
    /// Sets the burr's spin for the next ticks: the direction of its angular velocity
    /// (normalised here; zero, or not finite: the burr does not spin). With a contact whose
    /// material has a friction coefficient, [`crate::servo::servo_force`] pulls the burr
    /// sideways along `spin x n` ("Sideways pull").
    ///
    /// # Bounded work
    /// Constant.
    pub fn set_spin(&mut self, omega: Vec3) {
        let u = omega.normalize_or_zero();
        self.spin = if u.is_finite() { u } else { Vec3::ZERO };
    }

    /// The burr's spin direction (zero: none).
    pub fn spin(&self) -> Vec3 {
        self.spin
    }
}

/// Damping force `-b v` with `v` from two consecutive positions; zero without a previous
/// position, with a non-positive `dt` or when not in contact.
///
/// # Bounded work
/// Constant.
pub(crate) fn damping_force(
    state: &mut ToolState,
    now: Vec3,
    in_contact: bool,
    params: &ForceParams,
) -> Vec3 {
    let prev = state.previous.replace(now);
    match prev {
        Some(p) if in_contact && params.dt > 0.0 => {
            let v = (now - p) / params.dt;
            -v * params.damping
        }
        _ => Vec3::ZERO,
    }
}

/// `f` scaled down to at most `max` in magnitude (NaN or infinite input gives zero; a
/// non-positive `max` gives zero).
///
/// # Bounded work
/// Constant.
pub fn clamp_force(f: Vec3, max: f32) -> Vec3 {
    if !f.is_finite() || max.is_nan() || max <= 0.0 {
        return Vec3::ZERO;
    }
    let l = f.length();
    if l > max {
        f * (max / l)
    } else {
        f
    }
}

/// How far to draw the tool moved along the force so none of its colliding nodes stays
/// inside (Praktikum report, section 5): the largest depth projected on the force direction, over
/// the tool's nodes in the object (`tool_in_object`, directions out of the object) and the object's
/// nodes in the tool (`object_in_tool`, directions out of the tool, which the tool relieves by
/// moving the other way).
///
/// # Bounded work
/// O(penetrations).
pub fn display_offset(
    force: Vec3,
    tool_in_object: &[Penetration],
    object_in_tool: &[Penetration],
) -> Vec3 {
    let dir = force.normalize_or_zero();
    if dir == Vec3::ZERO {
        return Vec3::ZERO;
    }
    let mut m = 0.0f32;
    for p in tool_in_object {
        m = m.max(p.depth * p.dir.dot(dir));
    }
    for p in object_in_tool {
        m = m.max(-p.depth * p.dir.dot(dir));
    }
    dir * m
}
