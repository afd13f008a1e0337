//! Pen contact, the servo's half (`pen_servo_force` on a held pass): at the pass's own pose it
//! gives `pen_contact`'s force bit for bit along a path into the cow, and it carries a flat
//! contact exactly to other poses (oracles: the analytic `9 k D n` and a fresh pass).
//!
//! Meshes: the pen (`pen_tool_gmsh.mesh`, metres) scaled x10 so it is 1.15 units long with a
//! 0.04 radius, next to the cow (about 1.5 units), and built-in blocks.

use glam::{Quat, Vec3};
use tetradrill::pen::PenRig;
use tetradrill_core::depth::Penetration;
use tetradrill_core::force::{
    pen_contact, pen_pass, pen_servo_force, ForceParams, HeldContact, PenBuffers, PenOptions,
    PenScene, PenServo, PenState, ServoScratch,
};
use tetradrill_tests::contact::{facing, rig, COW};
use tetradrill_tests::load;

/// The force from a held pass at the current pose (`pen_servo_force`), with scratch as long
/// as the pass's buffers.
fn servo_tick(
    scene: &PenScene<'_, '_, '_>,
    bufs: &PenBuffers<'_>,
    held: (Vec3, Quat, (usize, usize)),
    pos: Vec3,
    rot: Quat,
    opts: &PenOptions,
    state: &mut PenState,
) -> PenServo {
    let mut a = vec![Penetration::default(); bufs.pen_pens.len()];
    let mut b = vec![Penetration::default(); bufs.object_pens.len()];
    let contact = HeldContact {
        position: held.0,
        rotation: held.1,
        pen: &bufs.pen_pens[..held.2 .0],
        object: &bufs.object_pens[..held.2 .1],
    };
    let mut now = ServoScratch {
        pen: &mut a,
        object: &mut b,
    };
    pen_servo_force(scene, &contact, &mut now, pos, rot, opts, state)
}

/// At the pass's own pose the servo half gives `pen_contact`'s force bit for bit, tick after
/// tick along a path into the cow, with and without the entry-plane remedy (which keeps
/// state across ticks, as damping does).
#[test]
fn servo_half_at_the_pass_pose_is_pen_contact() {
    let mut rig = rig(10.0, COW, 1.0);
    let (start, normal) = facing(&mut rig, Vec3::X);
    for entry_remedy in [false, true] {
        let opts = PenOptions {
            entry_remedy,
            reuse_crossings: true,
            ..PenOptions::default()
        };
        let bits = |v: Vec3| v.to_array().map(f32::to_bits);
        let contacts = rig
            .with(|scene, bufs| {
                let (mut whole, mut split) = (PenState::default(), PenState::default());
                let mut touching = 0;
                for i in 0..200 {
                    let t = i as f32;
                    let rot = Quat::from_rotation_arc(Vec3::Z, normal)
                        * Quat::from_rotation_y(0.3 + 0.002 * t);
                    let pos = start - normal * (0.0006 * t) + Vec3::Y * (0.0002 * t);
                    let c = pen_contact(scene, bufs, pos, rot, &opts, &mut whole);
                    let pass = pen_pass(scene, bufs, pos, rot, &opts, &mut split);
                    assert_eq!(pass.penetrations, c.penetrations, "tick {i}");
                    let s = servo_tick(
                        scene,
                        bufs,
                        (pos, rot, pass.penetrations),
                        pos,
                        rot,
                        &opts,
                        &mut split,
                    );
                    assert_eq!(s.carried, c.penetrations);
                    assert!(!s.short);
                    assert_eq!(bits(s.force.raw), bits(c.raw), "tick {i}");
                    assert_eq!(bits(s.force.force), bits(c.force), "tick {i}");
                    assert_eq!(bits(s.force.display_offset), bits(c.display_offset));
                    assert_eq!(s.force.clamped, c.clamped);
                    touching += (c.raw != Vec3::ZERO) as u32;
                }
                touching
            })
            .expect("pen scene");
        assert!(contacts > 100, "the path must touch: {contacts} ticks");
    }
}

/// A flat face, carried: a small block tool pressed into the middle of the unit block's top
/// face (only tool nodes inside: its nine bottom nodes), and the unit block as a tool pressed
/// onto a small block's top (only object nodes inside: the small block's nine top nodes). A
/// node's consistent depth is then its distance to the flat face, which the first-order carry
/// follows exactly under any rigid motion that keeps the same nodes inside: the servo carries
/// a pass at one (tilted) pose to poses pushed further in, turned, tilted otherwise and slid,
/// and its force is the analytic `9 k D n` (D the depth of the nine nodes' centre, n the
/// face's normal, which turns with the tool in the second case) and a fresh pass's.
#[test]
fn servo_carries_a_flat_contact_exactly() {
    let k = 200.0f32;
    let opts = PenOptions {
        params: ForceParams {
            stiffness: k,
            damping: 0.0,
            max_force: 1e6,
            ..ForceParams::default()
        },
        ..PenOptions::default()
    };
    // (tool and scale, object and scale, whether the tool's nodes are the ones inside)
    let small_in_big = (("builtin:block:2", 0.1), ("builtin:block:8", 1.0), true);
    let big_over_small = (("builtin:block:8", 1.0), ("builtin:block:2", 0.1), false);
    for ((tool, ts), (obj, os), tool_inside) in [small_in_big, big_over_small] {
        let mut rig = PenRig {
            pen: load(tool, ts),
            obj: load(obj, os),
        };
        let half_tool = 0.5 * ts as f32;
        let obj_top = 0.5 * os as f32;
        // A pose by the centre of the tool's bottom face: (0.0625, 0.0625) lies between the
        // nodes of the unit block, so neither body has a node inside the other's side faces.
        let pose = |depth: f32, slide: Vec3, rot: Quat| {
            let bottom = Vec3::new(0.0625, 0.0625, obj_top - depth) + slide;
            (bottom + rot * Vec3::new(0.0, 0.0, half_tool), rot)
        };
        // 9 k D n: the tool's nodes in the object face +z; the object's nodes in the tool
        // face the tool's bottom normal, and push the tool along minus it.
        let analytic = |(pos, rot): (Vec3, Quat)| {
            let bottom = pos + rot * Vec3::new(0.0, 0.0, -half_tool);
            if tool_inside {
                Vec3::Z * (9.0 * k * (obj_top - bottom.z))
            } else {
                let n = rot * Vec3::Z;
                n * (9.0 * k * (Vec3::new(0.0, 0.0, obj_top) - bottom).dot(n))
            }
        };
        let tilt0 = Quat::from_rotation_z(0.1) * Quat::from_rotation_x(0.05);
        let at = pose(0.02, Vec3::ZERO, tilt0);
        let moves = [
            ("pushed in", pose(0.025, Vec3::ZERO, tilt0)),
            (
                "turned",
                pose(
                    0.02,
                    Vec3::ZERO,
                    Quat::from_rotation_z(0.25) * Quat::from_rotation_x(0.05),
                ),
            ),
            (
                "tilted",
                pose(
                    0.02,
                    Vec3::ZERO,
                    Quat::from_rotation_z(0.1) * Quat::from_rotation_y(-0.06),
                ),
            ),
            ("slid", pose(0.02, Vec3::new(0.004, -0.003, 0.0), tilt0)),
            (
                "all at once",
                pose(
                    0.03,
                    Vec3::new(-0.003, 0.002, 0.0),
                    Quat::from_rotation_z(0.2) * Quat::from_rotation_y(0.04),
                ),
            ),
        ];
        let close = |got: Vec3, want: Vec3| (got - want).length() <= 2e-4 * want.length();
        rig.with(|scene, bufs| {
            let mut st = PenState::default();
            let pass = pen_pass(scene, bufs, at.0, at.1, &opts, &mut st);
            let nine = if tool_inside { (9, 0) } else { (0, 9) };
            assert_eq!(pass.penetrations, nine, "{tool} in {obj}");
            let held = (at.0, at.1, pass.penetrations);
            let here = servo_tick(
                scene,
                bufs,
                held,
                at.0,
                at.1,
                &opts,
                &mut PenState::default(),
            );
            assert!(
                close(here.force.raw, analytic(at)),
                "{tool} in {obj}: {} vs {}",
                here.force.raw,
                analytic(at)
            );
            for (what, (pos, rot)) in moves {
                // The pass again: the fresh pass below writes over its penetrations.
                let again = pen_pass(scene, bufs, at.0, at.1, &opts, &mut st);
                assert_eq!(again.penetrations, nine);
                let carried =
                    servo_tick(scene, bufs, held, pos, rot, &opts, &mut PenState::default());
                assert_eq!(carried.carried, nine);
                let want = analytic((pos, rot));
                let got = carried.force.raw;
                assert!(
                    close(got, want),
                    "{tool} in {obj}, {what}: carried {got}, analytic {want}"
                );
                if !close(want, analytic(at)) {
                    assert!(
                        !close(got, here.force.raw),
                        "{what}: the carry moved nothing"
                    );
                }
                // A fresh pass at the new pose: the same nodes, the same force.
                let fresh = pen_contact(scene, bufs, pos, rot, &opts, &mut PenState::default());
                assert_eq!(fresh.penetrations, nine, "{tool} in {obj}, {what}");
                assert!(
                    close(fresh.raw, want),
                    "{tool} in {obj}, {what}: pass {}, analytic {want}",
                    fresh.raw
                );
            }
        })
        .expect("pen scene");
    }
}
