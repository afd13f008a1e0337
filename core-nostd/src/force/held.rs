//! The servo half of the pen: the force at the pen's current pose from the last contact pass.
//!
//! A contact pass ([`pen_pass`](super::pen_pass): collisions both ways and their consistent
//! depths) may take longer than a servo tick; the host runs it in its simulation task
//! and leaves the servo only the force. [`pen_servo_force`] holds the pass's penetrations and
//! carries each one to the current pose to first order, as the sphere burr's servo carries its
//! contact plane (Turini et al. 2006, section 3.3):
//!
//! - a pen node inside the object moved by `m` along its direction since the pass (the pen
//!   moved, the object did not): its depth is `d - m`;
//! - an object node inside the pen moved by `m` along its direction *in the pen's frame*: its
//!   depth is `d - m`, and its direction turns with the pen.
//!
//! A depth that was not negative is never carried below zero (the node left the other body).
//! This is exact for a flat surface while no node enters or leaves the other body; the next
//! pass brings the nodes that did. At the pass's own pose every depth and direction is the
//! pass's, bit for bit, so [`pen_servo_force`] then gives [`pen_contact`](super::pen_contact)'s
//! force.

use glam::{Affine3A, Mat3A, Quat, Vec3};

use super::pen::{respond, PenForce, PenOptions, PenScene, PenState};
use super::ForceParams;
use crate::depth::Penetration;

/// One contact pass's penetrations, as the servo holds them: the pose the pass was made at
/// and what it wrote ([`super::PenBuffers::pen_pens`] and
/// [`super::PenBuffers::object_pens`], up to [`super::PenPass::penetrations`]).
#[derive(Clone, Copy, Debug)]
pub struct HeldContact<'h> {
    /// The pen's tip at the pass.
    pub position: Vec3,
    /// The pen's rotation at the pass.
    pub rotation: Quat,
    /// Pen nodes inside the object (directions out of the object).
    pub pen: &'h [Penetration],
    /// Object nodes inside the pen (directions out of the pen).
    pub object: &'h [Penetration],
}

impl HeldContact<'_> {
    /// No pass yet: no penetration, so no force (damping acts only in contact).
    pub const NONE: HeldContact<'static> = HeldContact {
        position: Vec3::ZERO,
        rotation: Quat::IDENTITY,
        pen: &[],
        object: &[],
    };
}

/// The servo's storage for the carried penetrations; the lengths are the capacities.
#[derive(Debug)]
pub struct ServoScratch<'b> {
    /// The pen nodes' penetrations at the current pose.
    pub pen: &'b mut [Penetration],
    /// The object nodes' penetrations at the current pose.
    pub object: &'b mut [Penetration],
}

/// What one servo tick gives.
#[derive(Clone, Copy, PartialEq, Debug, Default)]
pub struct PenServo {
    /// The force (as [`pen_contact`](super::pen_contact) gives it from the carried
    /// penetrations).
    pub force: PenForce,
    /// Penetrations carried (pen nodes, object nodes).
    pub carried: (usize, usize),
    /// `true` when the scratch could not hold every held penetration (those beyond are left
    /// out of the force) or a held node is beyond its mesh (left out).
    pub short: bool,
}

/// The pen's force at `position` and `rotation` from the held pass `held`: each penetration
/// carried to this pose (module docs), then stiffness, the entry-plane remedy when
/// `opts.entry_remedy`, damping, clamping and the displayed offset as
/// [`pen_contact`](super::pen_contact) does. Uses only `PenState::tool` and
/// `PenState::entry` of `state`.
///
/// # Bounded work
/// O(held penetrations): per pen node one point transform, per object node one point
/// transform and two 3x3 products, then [`pen_contact`](super::pen_contact)'s force. Nothing
/// else: no search, no hash. At most `now`'s lengths are carried ([`PenServo::short`]).
pub fn pen_servo_force(
    scene: &PenScene<'_, '_, '_>,
    held: &HeldContact<'_>,
    now: &mut ServoScratch<'_>,
    position: Vec3,
    rotation: Quat,
    opts: &PenOptions,
    state: &mut PenState,
) -> PenServo {
    let mut out = PenServo::default();
    let pose = Affine3A::from_rotation_translation(rotation, position);
    let then = Affine3A::from_rotation_translation(held.rotation, held.position);
    let rest = scene.pen.positions();
    // How a point fixed to the pen moved since the pass (one transform instead of two, and
    // exactly zero at the pass's pose).
    let step = difference(&pose, &then);

    let mut np = 0usize;
    for q in held.pen {
        let Some(&r) = rest.get(q.node.idx()) else {
            out.short = true;
            continue;
        };
        let Some(slot) = now.pen.get_mut(np) else {
            out.short = true;
            break;
        };
        let moved = step.transform_point3(r);
        *slot = Penetration {
            depth: carried(q.depth, moved.dot(q.dir)),
            ..*q
        };
        np += 1;
    }

    let mut no = 0usize;
    let same_turn = rotation == held.rotation;
    // How a point fixed in the world moved in the pen's frame since the pass, and the turns
    // from the world to the pen's frame at the pass and from there to the world now.
    let seen = difference(&pose.inverse(), &then.inverse());
    let back = Mat3A::from_quat(held.rotation.inverse());
    let turn = Mat3A::from_quat(rotation) * back;
    for q in held.object {
        let Some(&y) = scene.object.positions.get(q.node.idx()) else {
            out.short = true;
            continue;
        };
        let Some(slot) = now.object.get_mut(no) else {
            out.short = true;
            break;
        };
        let moved = seen.transform_point3(y);
        *slot = Penetration {
            depth: carried(q.depth, moved.dot(back * q.dir)),
            dir: if same_turn { q.dir } else { turn * q.dir },
            ..*q
        };
        no += 1;
    }
    out.carried = (np, no);

    let pens = now.pen.get(..np).unwrap_or(&[]);
    let objs = now.object.get(..no).unwrap_or(&[]);
    out.force = respond(
        |n| rest.get(n.idx()).map(|&r| pose.transform_point3(r)),
        pens,
        objs,
        position,
        opts,
        state,
    );
    out
}

/// The moment about the pen's tip at `position` (turned by `rotation`) of the penetrations'
/// springs, `pen` and `object` as [`pen_servo_force`] carried them (its scratch, up to
/// [`PenServo::carried`]): each pen node's `params.stiffness * depth * dir` acting at the node where
/// the pose puts it (`pen_rest`, the pen's nodes at rest), minus each object node's acting at
/// the node (`object_positions`), summed, and scaled by the factor the clamp of the springs'
/// sum to `params.max_force` applies (1 when within it). The damping acts at the tip and adds none;
/// with the entry-plane remedy the force's pen part is the plane's, the moment still the
/// nodes' own. A node beyond its positions is left out.
///
/// # Bounded work
/// O(penetrations): one point transform and a cross product each. Never allocates or
/// panics; non-finite input gives zero.
pub fn pen_torque(
    pen_rest: &[Vec3],
    object_positions: &[Vec3],
    pen: &[Penetration],
    object: &[Penetration],
    position: Vec3,
    rotation: Quat,
    params: &ForceParams,
) -> Vec3 {
    let (stiffness, max_force) = (params.stiffness, params.max_force);
    let pose = Affine3A::from_rotation_translation(rotation, position);
    let (mut sum, mut moment) = (Vec3::ZERO, Vec3::ZERO);
    for q in pen {
        if let Some(&r) = pen_rest.get(q.node.idx()) {
            let f = q.dir * (stiffness * q.depth);
            sum += f;
            moment += (pose.transform_point3(r) - position).cross(f);
        }
    }
    for q in object {
        if let Some(&y) = object_positions.get(q.node.idx()) {
            let f = q.dir * -(stiffness * q.depth);
            sum += f;
            moment += (y - position).cross(f);
        }
    }
    let clamped = super::clamp_force(sum, max_force);
    if !moment.is_finite() || (clamped == Vec3::ZERO && sum != Vec3::ZERO) {
        return Vec3::ZERO;
    }
    if clamped == sum {
        moment
    } else {
        moment * (clamped.length() / sum.length())
    }
}

/// `a - b` as maps of points: `(a - b)(x) = a(x) - b(x)` up to rounding, zero when `a == b`.
#[inline]
fn difference(a: &Affine3A, b: &Affine3A) -> Affine3A {
    Affine3A {
        matrix3: a.matrix3 - b.matrix3,
        translation: a.translation - b.translation,
    }
}

/// A held depth `d` after its node moved `m` along its direction: `d - m`, not below zero
/// unless `d` was (then not below `d`). `m == 0` gives `d` exactly.
#[inline]
fn carried(d: f32, m: f32) -> f32 {
    (d - m).max(d.min(0.0))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ids::NodeId;

    /// By hand: the pen's node at rest (0, 0, 1) under a quarter turn about z stays at
    /// (0, 0, 1) above the tip; pushed 0.01 along +x at 100 N per unit, 1 N at arm +z: a
    /// moment of +y. An object node at (1, 0, 0) pushing out of the pen along -y (so the pen
    /// is pushed +y) adds (1, 0, 0) x (0, 2, 0) = 2 z. Over a clamp of 1 N the sum's
    /// sqrt(5) N scales the moment by 1 / sqrt(5).
    #[test]
    fn the_pen_torque_is_the_moment_of_its_springs_about_the_tip() {
        let rest = [Vec3::ZERO, Vec3::Z];
        let object = [Vec3::ZERO, Vec3::new(1.0, 0.0, 0.0)];
        let at = |n, depth, dir| Penetration {
            node: NodeId(n),
            depth,
            dir,
            ..Default::default()
        };
        let turn = Quat::from_rotation_z(core::f32::consts::FRAC_PI_2);
        let k = |max_force| ForceParams {
            stiffness: 100.0,
            max_force,
            ..ForceParams::default()
        };
        let pen = [at(1, 0.01, Vec3::X)];
        let t = pen_torque(&rest, &object, &pen, &[], Vec3::ZERO, turn, &k(8.0));
        assert!((t - Vec3::Y).length() < 1e-5, "{t}");
        // Moved: the arm is the same, the moment too.
        let c = Vec3::new(3.0, -2.0, 5.0);
        let moved = [at(1, 0.01, Vec3::X)];
        let t = pen_torque(&rest, &object, &moved, &[], c, turn, &k(8.0));
        assert!((t - Vec3::Y).length() < 1e-5, "{t}");
        let obj = [at(1, 0.02, -Vec3::Y)];
        let t = pen_torque(&rest, &object, &pen, &obj, Vec3::ZERO, turn, &k(8.0));
        assert!((t - Vec3::new(0.0, 1.0, 2.0)).length() < 1e-5, "{t}");
        let t = pen_torque(&rest, &object, &pen, &obj, Vec3::ZERO, turn, &k(1.0));
        let want = Vec3::new(0.0, 1.0, 2.0) / 5f32.sqrt();
        assert!((t - want).length() < 1e-5, "{t}");
        // A node beyond the positions is left out; NaN gives zero.
        let beyond = [at(9, 0.01, Vec3::X)];
        assert_eq!(
            pen_torque(&rest, &object, &beyond, &[], Vec3::ZERO, turn, &k(8.0)),
            Vec3::ZERO
        );
        assert_eq!(
            pen_torque(&rest, &object, &pen, &[], Vec3::NAN, turn, &k(8.0)),
            Vec3::ZERO
        );
    }
}
