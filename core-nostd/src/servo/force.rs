//! The servo's force from the last contact plane: [`servo_force`].

use glam::Vec3;

use super::{ContactState, VibrationCue};
use crate::force::{clamp_force, damping_force, ForceParams, ToolState};

/// The force on a spherical burr of `radius` at `centre` from the contact plane `contact`,
/// with `tool` carrying what the force needs from the last tick.
///
/// The spring of a plane `(point, normal)` is `s = clamp(stiffness * depth * normal)` with
/// `depth = radius - (centre - point) . normal` (zero when not positive): first order in
/// the position, so a plane kept from an older simulation step extrapolates the surface
/// (Turini et al. 2006, section 3.3). The force is `clamp(E + damping)`, damping only while the
/// plane's depth is positive, with the elastic part `E = clamp(s + residual)`.
///
/// Plane switches. When the contact plane changes (another face became the closest, the
/// drill removed the one under the burr), `s` jumps; a burr buried in half-eroded material,
/// nearly equidistant from walls that face each other, would see the force reverse from one
/// tick to the next. So the residual takes up the difference at the switch,
/// `residual = E_old - s_new` with `E_old` the old plane's elastic force at `centre`, and
/// shrinks towards zero by `2 max_force dt / switch_time` every tick, that one included: a
/// switch is rendered as a ramp of at most `switch_time`. A plane that appears already
/// penetrated (no plane before) ramps in from zero the same way. Per tick the force changes by at most
/// `stiffness |dc| + damping (|v| + |v_prev|) + 2 max_force dt / switch_time`, plane change
/// or not (`|dc|` the tool's motion, `v` its velocities). A `switch_time` of zero (or not
/// finite) switches at once.
///
/// Materials. The stiffness is the contact's ([`ContactState::stiffness`], the material under
/// it) when positive, else `params.stiffness`. A change of stiffness under an unchanged plane
/// is a switch too: the spring felt with the old stiffness is carried by the residual and
/// ramped out, so crossing from one material into another never makes the force jump.
///
/// Vibration. While the contact carries a [`VibrationCue`] (the drill on, over a region that
/// vibrates), the force `F` above is modulated along its own direction:
/// `F + F / |F| * min(|F|, amplitude * s) * sin(2 pi phase)` with
/// `s = min(1, (|F| - threshold) / (max_force - threshold))` while `|F|` exceeds the region's
/// threshold (no vibration below it), and the phase advanced by `hz * dt` cycles each tick
/// the cue has a frequency, in contact or not (`libm::sinf`, the same bits on every target). The modulation never
/// reverses the force, is not clamped again (the force reaches at most
/// `max_force + amplitude`), and without a cue the force is the one above, bit for bit
/// (docs/DRILLING.md, "Vibration").
///
/// Sideways pull. While the contact carries a friction coefficient `mu` (the drill on, over
/// a region with [`crate::drill::Region::friction`]) and the burr spins
/// ([`ToolState::set_spin`], unit `w`), the spinning burr's surface drags on the material at
/// the contact point, and the material pushes back along `w x n`: the force gains
/// `mu |s| (w x n)` (`s` the spring above, the material's normal reaction), added before the
/// vibration and clamped with the rest. Its size is `mu |s| sin(a)` for an angle `a` between
/// the spin and the normal: full when the burr's side presses, none at its tip, where the
/// surface does not slide (a regularised Coulomb friction, continuous as the burr tilts).
/// Without a friction or a spin the force is the one above, bit for bit (docs/DRILLING.md,
/// "Sideways pull").
///
/// # Bounded work
/// Constant. Never allocates, locks or panics; non-finite input gives zero force (and
/// forgets the plane and the residual).
pub fn servo_force(
    contact: &ContactState,
    centre: Vec3,
    radius: f32,
    tool: &mut ToolState,
    params: &ForceParams,
) -> Vec3 {
    let plane = contact.valid.then_some((contact.point, contact.normal));
    // The material under the contact sets the stiffness (zero: the parameters').
    let k = if contact.stiffness > 0.0 && contact.stiffness.is_finite() {
        contact.stiffness
    } else {
        params.stiffness
    };
    let spring = |plane: Option<(Vec3, Vec3)>, k: f32| match plane {
        Some((p, n)) => {
            let depth = radius - (centre - p).dot(n);
            if depth > 0.0 {
                clamp_force(n * (k * depth), params.max_force)
            } else {
                Vec3::ZERO
            }
        }
        None => Vec3::ZERO,
    };
    let s = spring(plane, k);
    let damping = damping_force(tool, centre, s != Vec3::ZERO, params);
    if !(centre.is_finite() && radius.is_finite()) {
        tool.plane = None;
        tool.residual = Vec3::ZERO;
        return Vec3::ZERO;
    }
    let step = 2.0 * params.max_force * params.dt / params.switch_time;
    let mut residual = tool.residual;
    if tool.plane != plane || (plane.is_some() && tool.stiffness != k) {
        residual = clamp_force(
            spring(tool.plane, tool.stiffness) + residual,
            params.max_force,
        ) - s;
        tool.plane = plane;
        tool.stiffness = k;
    }
    let residual = shrink(residual, step);
    tool.residual = residual;
    let force = clamp_force(
        clamp_force(s + residual, params.max_force) + damping,
        params.max_force,
    );
    let force = pull(force, s, contact, tool, params);
    vibrate(force, &contact.vibration, tool, params)
}

/// `force` with the spinning burr's sideways pull of the contact's friction added
/// ([`servo_force`], "Sideways pull"): `mu |s| (spin x n)` for the spring `s`, then clamped;
/// `force` itself without a friction, a spin or a spring.
///
/// # Bounded work
/// Constant.
fn pull(
    force: Vec3,
    s: Vec3,
    contact: &ContactState,
    tool: &ToolState,
    params: &ForceParams,
) -> Vec3 {
    let mu = contact.friction;
    if !(mu > 0.0 && mu.is_finite()) || tool.spin == Vec3::ZERO || s == Vec3::ZERO {
        return force;
    }
    let drag = tool.spin.cross(contact.normal) * (mu * s.length());
    if drag.is_finite() {
        clamp_force(force + drag, params.max_force)
    } else {
        force
    }
}

/// `force` with the burr's vibration of `cue` added along it ([`servo_force`], "Vibration"),
/// the phase in `tool` advanced whenever the cue has a frequency; `force` itself when the cue
/// has no frequency or no amplitude (phase untouched without a frequency).
///
/// # Bounded work
/// Constant.
fn vibrate(force: Vec3, cue: &VibrationCue, tool: &mut ToolState, params: &ForceParams) -> Vec3 {
    let (hz, a) = (cue.hz, cue.amplitude);
    if !(hz > 0.0 && hz.is_finite()) {
        return force;
    }
    let p = tool.phase + hz * params.dt;
    tool.phase = if p.is_finite() {
        p - libm::floorf(p)
    } else {
        0.0
    };
    if !(a > 0.0 && a.is_finite()) {
        return force;
    }
    let m = force.length();
    let threshold = if cue.threshold > 0.0 {
        cue.threshold
    } else {
        0.0
    };
    if !(m > threshold && m.is_finite()) {
        return force;
    }
    let span = params.max_force - threshold;
    let share = if span > 0.0 {
        ((m - threshold) / span).min(1.0)
    } else {
        1.0
    };
    let v = (a * share).min(m) * libm::sinf(core::f32::consts::TAU * tool.phase);
    if v.is_finite() {
        force + force * (v / m)
    } else {
        force
    }
}

/// `v` shortened by `step` (zero when no longer than `step`, or when `v` or `step` is NaN or
/// infinite).
fn shrink(v: Vec3, step: f32) -> Vec3 {
    let l = v.length();
    if l.is_finite() && step.is_finite() && step >= 0.0 && l > step {
        v * ((l - step) / l)
    } else {
        Vec3::ZERO
    }
}
