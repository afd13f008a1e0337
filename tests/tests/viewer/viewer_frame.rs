//! The egocentric device frame the viewer's camera drives (the device-to-scene map): screen
//! directions after turns and orbits (against the camera's own projection and the f64 pinhole
//! model of `tetradrill_tests::viewer`), power conserved under random rotations, the turn's
//! centre, and the camera hand-off the servo reads it through, which never waits.

use std::sync::atomic::{AtomicBool, Ordering};

use rand::{Rng, SeedableRng};
use tetradrill::tasks::{camera_handoff, DeviceFrame, IDENTITY};
use tetradrill::viewer::camera::{project, Camera};
use tetradrill_core::Vec3;
use tetradrill_tests::oracle::add;
use tetradrill_tests::viewer::{f64s, pixel_of, H, MESH_UNITS, W};

/// Normalised device coordinates of `p` through the camera's own matrices.
fn ndc(cam: &Camera, p: Vec3) -> Vec3 {
    project(&cam.view_projection(W as f32 / H as f32), p).expect("in front of the camera")
}

/// The pixel of `p` by the f64 pinhole model written in this file (x right, y down).
fn pinhole(cam: &Camera, p: Vec3) -> (f64, f64) {
    pixel_of(f64s(cam.eye()), f64s(cam.target), cam.fov_y as f64, f64s(p))
}

#[test]
fn after_a_quarter_turn_about_the_view_up_axis_the_stylus_still_moves_the_tool_as_on_screen() {
    let pivot = Vec3::new(2.0, -1.0, 0.5);
    // The start view is level and looks along +y: device +x shows as screen-right, +z as
    // screen-up, +y as away from the viewer.
    let home = Camera {
        target: pivot,
        distance: 3.0,
        yaw: -std::f32::consts::FRAC_PI_2,
        pitch: 0.0,
        fov_y: 0.7,
    };
    // Turned a quarter about the view-up axis (z: the view is level); now the screen's right
    // is the scene's +y.
    let turned = Camera { yaw: 0.0, ..home };
    let p0 = [2.1, -0.9, 0.45];
    let step = 0.05;
    for cam in [home, turned] {
        let mut frame = DeviceFrame::new(pivot);
        assert!(frame.set_camera(&cam.egocentric(&home)));
        let s0 = frame.to_scene(&MESH_UNITS, p0);
        let sx = frame.to_scene(&MESH_UNITS, add(p0, [step, 0.0, 0.0]));
        let sy = frame.to_scene(&MESH_UNITS, add(p0, [0.0, step, 0.0]));
        let sz = frame.to_scene(&MESH_UNITS, add(p0, [0.0, 0.0, step]));
        // The camera's own view and projection.
        let (a, x, y, z) = (ndc(&cam, s0), ndc(&cam, sx), ndc(&cam, sy), ndc(&cam, sz));
        assert!(
            x.x > a.x + 1e-3 && (x.y - a.y).abs() < 1e-4,
            "+x: {a} -> {x}"
        );
        assert!(
            z.y > a.y + 1e-3 && (z.x - a.x).abs() < 1e-4,
            "+z: {a} -> {z}"
        );
        assert!(y.z > a.z, "+y goes away from the viewer: {a} -> {y}");
        // The pinhole model of this file agrees (pixel rows grow downwards).
        let (pa, px, pz) = (pinhole(&cam, s0), pinhole(&cam, sx), pinhole(&cam, sz));
        assert!(
            px.0 > pa.0 + 0.5 && (px.1 - pa.1).abs() < 0.01,
            "{pa:?} -> {px:?}"
        );
        assert!(
            pz.1 < pa.1 - 0.5 && (pz.0 - pa.0).abs() < 0.01,
            "{pa:?} -> {pz:?}"
        );
    }
    // The turned view's right is the scene's +y: that is where device +x goes.
    let mut frame = DeviceFrame::new(pivot);
    assert!(frame.set_camera(&turned.egocentric(&home)));
    let d =
        frame.to_scene(&MESH_UNITS, add(p0, [step, 0.0, 0.0])) - frame.to_scene(&MESH_UNITS, p0);
    assert!(
        (d - Vec3::new(0.0, step as f32, 0.0)).length() < 1e-5,
        "{d}"
    );
    // Without the frame the same stylus motion runs along the view's line of sight.
    let still = DeviceFrame::new(pivot);
    let a = ndc(&turned, still.to_scene(&MESH_UNITS, p0));
    let b = ndc(
        &turned,
        still.to_scene(&MESH_UNITS, add(p0, [step, 0.0, 0.0])),
    );
    assert!(
        (b.x - a.x).abs() < 0.2 * (x_shift(&turned, &frame, p0, step)),
        "{a} -> {b}"
    );
}

/// How far device +`step` along x moves the tool on screen (NDC x) through `frame`.
fn x_shift(cam: &Camera, frame: &DeviceFrame, p0: [f64; 3], step: f64) -> f32 {
    let a = ndc(cam, frame.to_scene(&MESH_UNITS, p0));
    let b = ndc(cam, frame.to_scene(&MESH_UNITS, add(p0, [step, 0.0, 0.0])));
    b.x - a.x
}

#[test]
fn every_orbit_shows_a_stylus_motion_as_the_start_view_does_and_turns_about_the_workspace_centre() {
    let mut rng = rand::rngs::StdRng::seed_from_u64(7);
    let pivot = Vec3::new(3.0, -2.0, 5.0);
    let home = Camera {
        target: pivot,
        ..Camera::default()
    };
    // The rotation part of a view matrix applied to a direction: eye coordinates.
    let eye_dir = |cam: &Camera, v: Vec3| {
        let m = cam.view();
        Vec3::new(
            m[0] * v.x + m[4] * v.y + m[8] * v.z,
            m[1] * v.x + m[5] * v.y + m[9] * v.z,
            m[2] * v.x + m[6] * v.y + m[10] * v.z,
        )
    };
    let mut swung = 0;
    for _ in 0..200 {
        let mut cam = home;
        cam.orbit(rng.gen_range(-3.0..3.0), rng.gen_range(-1.5..1.5));
        let mut frame = DeviceFrame::new(pivot);
        assert!(frame.set_camera(&cam.egocentric(&home)));
        let p: [f64; 3] = std::array::from_fn(|i| f64s(pivot)[i] + rng.gen_range(-0.5..0.5));
        let d: [f64; 3] = std::array::from_fn(|_| rng.gen_range(-0.1..0.1));
        let moved = frame.to_scene(&MESH_UNITS, add(p, d)) - frame.to_scene(&MESH_UNITS, p);
        let want = eye_dir(&home, Vec3::new(d[0] as f32, d[1] as f32, d[2] as f32));
        let got = eye_dir(&cam, moved);
        assert!((got - want).length() < 1e-5, "{got} vs {want}");
        // About the workspace centre: the tool stays at its pixel while the view orbits it.
        let tool = frame.to_scene(&MESH_UNITS, p);
        let at_home = pinhole(&home, Vec3::new(p[0] as f32, p[1] as f32, p[2] as f32));
        let now = pinhole(&cam, tool);
        assert!(
            (now.0 - at_home.0).abs() < 0.05 && (now.1 - at_home.1).abs() < 0.05,
            "{at_home:?} -> {now:?}"
        );
        assert!(((tool - pivot).length() - (f64s_len(p, pivot))).abs() < 1e-4);
        // A turn about the mesh origin instead would swing the tool away from the mesh.
        let c = glam::Mat4::from_cols_array(&frame.camera());
        let about_origin = c.transform_point3(Vec3::new(p[0] as f32, p[1] as f32, p[2] as f32));
        swung += ((about_origin - tool).length() > 1.0) as u32;
    }
    assert!(
        swung > 100,
        "only {swung} of 200 turns moved the origin-pivot tool"
    );
}

fn f64s_len(p: [f64; 3], q: Vec3) -> f32 {
    let q = f64s(q);
    ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) + (p[2] - q[2]).powi(2)).sqrt() as f32
}

#[test]
fn the_frame_conserves_power_for_random_rotations() {
    let mut rng = rand::rngs::StdRng::seed_from_u64(11);
    let unit = |rng: &mut rand::rngs::StdRng| loop {
        let v = Vec3::new(
            rng.gen_range(-1.0..1.0),
            rng.gen_range(-1.0..1.0),
            rng.gen_range(-1.0..1.0),
        );
        if v.length() > 0.1 && v.length() < 1.0 {
            return v.normalize();
        }
    };
    for _ in 0..1000 {
        let q = glam::Quat::from_axis_angle(unit(&mut rng), rng.gen_range(-3.1..3.1));
        let mut frame = DeviceFrame::new(Vec3::new(0.5, -0.25, 2.0));
        assert!(frame.set_camera(&glam::Mat4::from_quat(q).to_cols_array()));
        let p: [f64; 3] = std::array::from_fn(|_| rng.gen_range(-1.0..1.0));
        let v_dev = 0.1 * unit(&mut rng);
        let v_scene =
            frame.to_scene(&MESH_UNITS, add(p, f64s(v_dev))) - frame.to_scene(&MESH_UNITS, p);
        // The scene motion is the quaternion's turn of the device motion.
        assert!(
            (v_scene - q * v_dev).length() < 1e-5,
            "{v_scene} vs {}",
            q * v_dev
        );
        let f_scene = 3.0 * unit(&mut rng);
        let f_dev = frame.force_to_device(f_scene);
        assert!((f_dev - q.inverse() * f_scene).length() < 1e-4);
        let (pd, ps) = (
            f64s(f_dev)
                .iter()
                .zip(f64s(v_dev))
                .map(|(a, b)| a * b)
                .sum::<f64>(),
            f64s(f_scene)
                .iter()
                .zip(f64s(v_scene))
                .map(|(a, b)| a * b)
                .sum::<f64>(),
        );
        // f32 positions round the motion by about 1e-7 per unit of position: 1e-5 relative.
        let scale = (f_scene.length() * v_dev.length()) as f64;
        assert!(
            (pd - ps).abs() < 1e-4 * scale,
            "device power {pd}, scene power {ps}"
        );
    }
}

#[test]
fn the_camera_handoff_never_waits() {
    const N: u32 = 1_000_000;
    let (mut input, mut output) = camera_handoff();
    let done = AtomicBool::new(false);
    let (reads, distinct) = std::thread::scope(|s| {
        s.spawn(|| {
            for k in 1..=N {
                input.write([k as f32; 16]);
            }
            done.store(true, Ordering::Release);
        });
        let (mut reads, mut distinct, mut last) = (0u64, 0u64, 0f32);
        loop {
            let finished = done.load(Ordering::Acquire);
            let c = *output.read();
            // The initial identity (number 0), or a whole write, never older than one seen
            // before.
            let k = if c == IDENTITY { 0.0 } else { c[0] };
            assert!(k == 0.0 || c.iter().all(|v| *v == k), "torn: {c:?}");
            assert!(k >= last, "{k} after {last}");
            distinct += (k != last) as u64;
            last = k;
            reads += 1;
            if finished {
                break;
            }
        }
        (reads, distinct)
    });
    // The read after the writer finished saw its last write.
    assert_eq!(*output.read(), [N as f32; 16], "the last write wins");
    assert!(
        reads > 0 && distinct > 0,
        "{reads} reads, {distinct} values"
    );
    // Neither side needs the other: a writer with no reader and a reader with no writer both
    // finish their million calls.
    let (mut input, mut output) = camera_handoff();
    for k in 1..=N {
        input.write([k as f32; 16]);
    }
    for _ in 0..N {
        assert_eq!(*output.read(), [N as f32; 16]);
    }
}
