//! The viewer: headless renders (EGL surfaceless on Mesa) checked against oracles that share no
//! code with the renderer, partial buffer updates against a full upload, and the snapshot
//! hand-off that refuses instead of blocking and loses nothing when it does; the egocentric
//! device frame the camera drives (screen directions, power, the turn's centre, the hand-off the
//! servo reads it through), and the controls reaching the simulation and the servo.

use std::sync::atomic::{AtomicBool, Ordering};

use rand::{Rng, SeedableRng};
use tetradrill::engine::{self, EngineStorage, TickParams};
use tetradrill::rt::RtConfig;
use tetradrill::scenario::Scenario;
use tetradrill::tasks::{
    camera_handoff, servo_task, simulation_task, BurrLaw, DeviceFrame, Shared, SimEnd, SimStatus,
    ToolSample, Workspace, IDENTITY,
};
use tetradrill::traces::PoseSource;
use tetradrill::viewer::camera::{project, Camera};
use tetradrill::viewer::gl::{DrawOptions, Offscreen, Renderer, PALETTE};
use tetradrill::viewer::handoff::{
    controls, region_slots, Controls, Snapshot, SnapshotQueue, ToolView,
};
use tetradrill::viewer::headless::{render, Picture};
use tetradrill::viewer::publish::{full_patches, scene_of, SimViewer};
use tetradrill::viewer::scene::{Scene, VERTEX_FLOATS};
use tetradrill_core::force::ToolState;
use tetradrill_core::script::DRILL_ON;
use tetradrill_core::servo::ContactState;
use tetradrill_core::Vec3;
use tetradrill_device::{DeviceError, DeviceSpec, DeviceState, ForceCommand, HapticDevice};

const W: u32 = 240;
const H: u32 = 180;

fn storage(mesh: &str) -> (EngineStorage, Scenario) {
    let sc = Scenario {
        mesh: mesh.into(),
        ..Scenario::default()
    };
    let loaded = engine::load_mesh(&sc).expect("built-in mesh");
    (EngineStorage::allocate(loaded.mesh, &sc), sc)
}

fn background() -> [u8; 3] {
    PALETTE.background.map(|c| (c * 255.0).round() as u8)
}

fn near(a: [u8; 4], b: [u8; 3], tol: i32) -> bool {
    (0..3).all(|i| (a[i] as i32 - b[i] as i32).abs() <= tol)
}

/// The pixel (column, row from the top) where `p` lands for a camera at `eye` looking at
/// `target` with z up and vertical field of view `fov`: an f64 pinhole model written here,
/// not the renderer's matrices.
fn pixel_of(eye: [f64; 3], target: [f64; 3], fov: f64, p: [f64; 3]) -> (f64, f64) {
    let sub = |a: [f64; 3], b: [f64; 3]| [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let cross = |a: [f64; 3], b: [f64; 3]| {
        [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ]
    };
    let unit = |a: [f64; 3]| {
        let l = dot(a, a).sqrt();
        [a[0] / l, a[1] / l, a[2] / l]
    };
    let f = unit(sub(target, eye));
    let r = unit(cross(f, [0.0, 0.0, 1.0]));
    let u = cross(r, f);
    let d = sub(p, eye);
    let (x, y, z) = (dot(d, r), dot(d, u), dot(d, f));
    let t = (fov / 2.0).tan();
    let aspect = W as f64 / H as f64;
    let ndc = (x / (z * t * aspect), y / (z * t));
    (
        (ndc.0 + 1.0) * 0.5 * W as f64,
        (1.0 - ndc.1) * 0.5 * H as f64,
    )
}

/// Signed distance of `q` from the convex hull of `pts` (negative inside), in pixels.
fn hull_distance(pts: &[(f64, f64)], q: (f64, f64)) -> f64 {
    // Gift wrapping: the hull, counter-clockwise in (x, y) with y down.
    let mut hull = Vec::new();
    let start = (0..pts.len())
        .min_by(|&a, &b| pts[a].partial_cmp(&pts[b]).expect("finite"))
        .expect("points");
    let mut cur = start;
    loop {
        hull.push(pts[cur]);
        let mut next = (cur + 1) % pts.len();
        for (i, p) in pts.iter().enumerate() {
            let (a, b) = (pts[cur], pts[next]);
            let c = (b.0 - a.0) * (p.1 - a.1) - (b.1 - a.1) * (p.0 - a.0);
            if c < 0.0 {
                next = i;
            }
        }
        cur = next;
        if cur == start || hull.len() > pts.len() {
            break;
        }
    }
    let mut inside = true;
    let mut dmin = f64::INFINITY;
    for k in 0..hull.len() {
        let (a, b) = (hull[k], hull[(k + 1) % hull.len()]);
        let (ex, ey) = (b.0 - a.0, b.1 - a.1);
        let len = (ex * ex + ey * ey).sqrt();
        let side = (ex * (q.1 - a.1) - ey * (q.0 - a.0)) / len;
        if side < 0.0 {
            inside = false;
        }
        let t = (((q.0 - a.0) * ex + (q.1 - a.1) * ey) / (len * len)).clamp(0.0, 1.0);
        let (px, py) = (a.0 + t * ex - q.0, a.1 + t * ey - q.1);
        dmin = dmin.min((px * px + py * py).sqrt());
    }
    if inside {
        -dmin
    } else {
        dmin
    }
}

#[test]
fn the_cube_renders_with_the_silhouette_of_its_projected_corners() {
    let (mut store, _) = storage("builtin:cube12");
    let world = store.world().expect("world");
    let mut scene = scene_of(&world, None, SimStatus::default());
    assert_eq!(
        scene.triangle_count(),
        12,
        "the cube's boundary: 6 faces of 2 triangles"
    );
    let camera = Camera {
        target: Vec3::ZERO,
        distance: 3.2,
        yaw: 0.6,
        pitch: 0.45,
        fov_y: 0.7,
    };
    let pic = render(&mut scene, &camera, W, H, false).expect("a headless GL context (Mesa EGL)");
    // The camera's documented placement: orbiting the target at `distance`, `yaw` around z,
    // `pitch` above the xy plane.
    let (d, y, p) = (3.2f64, 0.6f64, 0.45f64);
    let eye = [d * p.cos() * y.cos(), d * p.cos() * y.sin(), d * p.sin()];
    let mut corners = Vec::new();
    for i in 0..8 {
        let c = |bit: usize| if i & bit == 0 { -0.5 } else { 0.5 };
        corners.push(pixel_of(eye, [0.0; 3], 0.7, [c(1), c(2), c(4)]));
    }
    let (mut inside, mut outside) = (0, 0);
    for row in (0..H).step_by(3) {
        for col in (0..W).step_by(3) {
            let q = (col as f64 + 0.5, row as f64 + 0.5);
            let s = hull_distance(&corners, q);
            let px = pic.at(col, row);
            if s < -2.0 {
                inside += 1;
                assert!(
                    !near(px, background(), 6),
                    "({col}, {row}) inside the silhouette is background"
                );
            } else if s > 2.0 {
                outside += 1;
                assert!(
                    near(px, background(), 2),
                    "({col}, {row}) outside the silhouette is {px:?}"
                );
            }
        }
    }
    assert!(
        inside > 200 && outside > 200,
        "both sides sampled: {inside} in, {outside} out"
    );
}

/// Plunges the demo burr into the default block for `ticks` ticks.
fn plunge(world: &mut tetradrill_core::servo::World<'_>, sc: &Scenario, ticks: u64) -> Vec3 {
    let params = TickParams::of(sc).expect("params");
    let poses = PoseSource::load("builtin:demo", 1.0).expect("demo path");
    let mut tool = ToolState::default();
    let mut last = Vec3::ZERO;
    for i in 0..ticks {
        let pose = poses.at(i);
        engine::tick(world, &mut tool, &params, &pose);
        last = pose.position;
    }
    last
}

fn top_camera() -> Camera {
    Camera {
        target: Vec3::new(0.0, 0.0, 0.2),
        distance: 2.6,
        yaw: -1.2,
        pitch: 1.0,
        fov_y: 0.7,
    }
}

fn pixel(cam: &Camera, p: [f64; 3]) -> (u32, u32) {
    let e = cam.eye();
    let t = cam.target;
    let (x, y) = pixel_of(
        [e.x as f64, e.y as f64, e.z as f64],
        [t.x as f64, t.y as f64, t.z as f64],
        cam.fov_y as f64,
        p,
    );
    (x as u32, y as u32)
}

fn reddish(px: [u8; 4]) -> bool {
    px[0] as f32 > 1.8 * px[1] as f32
}

#[test]
fn the_drilled_hole_shows_after_a_plunge() {
    let (mut store, sc) = storage("builtin:block:8");
    let cam = top_camera();
    let before = {
        let world = store.world().expect("world");
        render(
            &mut scene_of(&world, None, SimStatus::default()),
            &cam,
            W,
            H,
            false,
        )
        .expect("a headless GL context (Mesa EGL)")
    };
    let mut world = store.world().expect("world");
    plunge(&mut world, &sc, 2500);
    assert!(world.hierarchy().removed_volume() > 0.0);
    let after = render(
        &mut scene_of(&world, None, SimStatus::default()),
        &cam,
        W,
        H,
        false,
    )
    .expect("render");
    // The burr went down the z axis from the top face's centre.
    let (hx, hy) = pixel(&cam, [0.0, 0.0, 0.5]);
    assert!(
        !reddish(before.at(hx, hy)),
        "undrilled top face: {:?}",
        before.at(hx, hy)
    );
    assert!(
        reddish(after.at(hx, hy)),
        "the hole at ({hx}, {hy}): {:?}",
        after.at(hx, hy)
    );
    // Far from the hole nothing changed.
    let (fx, fy) = pixel(&cam, [0.4, -0.4, 0.5]);
    assert_eq!(before.at(fx, fy), after.at(fx, fy));
}

fn triangles(scene: &Scene) -> Vec<[u32; 10]> {
    let mut out: Vec<[u32; 10]> = scene
        .data()
        .chunks_exact(3 * VERTEX_FLOATS)
        .filter(|t| t.iter().any(|x| *x != 0.0))
        .map(|t| {
            let mut k = [0u32; 10];
            for v in 0..3 {
                for c in 0..3 {
                    k[3 * v + c] = t[v * VERTEX_FLOATS + c].to_bits();
                }
            }
            k[9] = t[6].to_bits();
            k
        })
        .collect();
    out.sort_unstable();
    out
}

#[test]
fn a_full_queue_refuses_without_blocking_and_later_snapshots_carry_the_changes() {
    let (mut store, sc) = storage("builtin:block:8");
    let params = TickParams::of(&sc).expect("params");
    let mut world = store.world().expect("world");
    let queue = SnapshotQueue::with_capacity(2);
    let mut link = SimViewer::new(&queue, None, world.mesh().tet_count());
    let poses = PoseSource::load("builtin:demo", 1.0).expect("demo path");
    let mut tool = ToolState::default();
    let mut scene = Scene::new();
    let (mut published, mut refused) = (0, 0);
    for i in 0..3000u64 {
        let pose = poses.at(i);
        let (_, rep) = engine::tick(&mut world, &mut tool, &params, &pose);
        link.note_step(&world, rep.drill.created + rep.drill.erased > 0);
        let tv = ToolView {
            position: pose.position,
            shown: pose.position,
            radius: params.radius,
            ..ToolView::default()
        };
        // A new snapshot is due every tick (the clock moves 20 ms a tick here).
        if link.publish(&world, tv, &SimStatus::default(), i * 20_000_000) {
            published += 1;
        } else {
            refused += 1;
        }
        // The viewer is slow: it drains every 50 ticks only.
        if i % 50 == 49 {
            while let Some(s) = queue.take() {
                scene.apply(s);
            }
        }
    }
    assert!(
        refused > 1000 && published > 50,
        "{published} published, {refused} refused"
    );
    assert_eq!(queue.refused(), refused as u64);
    // One more snapshot after the last step, then the viewer's surface is the world's.
    while let Some(s) = queue.take() {
        scene.apply(s);
    }
    assert!(link.publish_now(&world, ToolView::default(), &SimStatus::default(), u64::MAX));
    scene.apply(queue.take().expect("published"));
    let mut full = Scene::new();
    for p in full_patches(&world) {
        full.set_patch(p);
    }
    assert!(world.hierarchy().removed_volume() > 0.0);
    assert_eq!(
        scene.triangle_count(),
        world.hierarchy().visible_face_count() as usize
    );
    assert_eq!(triangles(&scene), triangles(&full));
}

#[test]
fn partial_buffer_updates_draw_what_a_full_upload_draws() {
    let (mut store, sc) = storage("builtin:block:8");
    let params = TickParams::of(&sc).expect("params");
    let cam = top_camera();
    let off = Offscreen::new(W, H).expect("a headless GL context (Mesa EGL)");
    let gl = off.gl();
    let mut r = Renderer::new(gl).expect("renderer");
    let mut world = store.world().expect("world");
    let queue = SnapshotQueue::with_capacity(4);
    let mut link = SimViewer::new(&queue, None, world.mesh().tet_count());
    let mut scene = Scene::new();
    assert!(link.publish_now(&world, ToolView::default(), &SimStatus::default(), 0));
    scene.apply(queue.take().expect("first snapshot"));
    off.bind();
    r.sync(gl, &mut scene);
    let whole = r.last_upload_bytes;
    assert_eq!(whole, 4 * scene.data().len());
    let poses = PoseSource::load("builtin:demo", 1.0).expect("demo path");
    let mut tool = ToolState::default();
    let mut partial = 0;
    for i in 0..2500u64 {
        let (_, rep) = engine::tick(&mut world, &mut tool, &params, &poses.at(i));
        link.note_step(&world, rep.drill.created + rep.drill.erased > 0);
        if i % 100 == 99 {
            assert!(link.publish_now(&world, ToolView::default(), &SimStatus::default(), i));
            scene.apply(queue.take().expect("snapshot"));
            r.sync(gl, &mut scene);
            partial += (r.last_upload_bytes < 4 * scene.data().len()) as u32;
        }
    }
    assert!(partial > 10, "only {partial} of 25 updates were partial");
    off.bind();
    r.draw(
        gl,
        &scene,
        &cam,
        W,
        H,
        DrawOptions {
            tool: false,
            clear: true,
        },
    );
    let incremental = Picture {
        width: W,
        height: H,
        rgba: off.read_rgba(),
    };
    r.destroy(gl);
    drop(off);
    let fresh = render(
        &mut scene_of(&world, None, SimStatus::default()),
        &cam,
        W,
        H,
        false,
    )
    .expect("render");
    let differing = incremental
        .rgba
        .chunks_exact(4)
        .zip(fresh.rgba.chunks_exact(4))
        .filter(|(a, b)| a != b)
        .count();
    assert_eq!(
        differing, 0,
        "pixels differing between partial and whole uploads"
    );
}

// The egocentric device frame: the viewer's camera `C` drives the device-to-scene map.

const MESH_UNITS: Workspace = Workspace {
    scale: 1.0,
    offset: Vec3::ZERO,
};

fn add(p: [f64; 3], d: [f64; 3]) -> [f64; 3] {
    [p[0] + d[0], p[1] + d[1], p[2] + d[2]]
}

fn f64s(v: Vec3) -> [f64; 3] {
    [v.x as f64, v.y as f64, v.z as f64]
}

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

/// A device held still at one position that records the forces written to it.
struct HeldDevice {
    position: [f64; 3],
    forces: Vec<[f64; 3]>,
}

impl HapticDevice for HeldDevice {
    fn spec(&self) -> DeviceSpec {
        DeviceSpec::SIM
    }
    fn read(&mut self) -> Result<DeviceState, DeviceError> {
        Ok(DeviceState {
            position: self.position,
            buttons: 0,
            ..DeviceState::ZERO
        })
    }
    fn write(&mut self, command: &ForceCommand) -> Result<(), DeviceError> {
        if command.enable {
            self.forces.push(command.force);
        }
        Ok(())
    }
    fn calibrate(&mut self) -> Result<(), DeviceError> {
        Ok(())
    }
}

#[test]
fn the_servo_takes_the_published_camera_and_the_stiffness_control_each_tick() {
    let params = TickParams::of(&Scenario::default()).expect("params");
    let plane = ContactState {
        valid: true,
        point: Vec3::new(0.0, 0.0, 0.5),
        normal: Vec3::Z,
        depth: 0.0,
        centre: Vec3::ZERO,
        triangles: 1,
    };
    // The burr sits a little into the top face, well under the force clamp.
    let depth = 0.2 * params.force.max_force / params.force.stiffness;
    assert!(depth < params.radius);
    let scene = Vec3::new(0.1, -0.2, 0.5 + params.radius - depth);
    let pivot = Vec3::new(0.0, 0.0, 0.25);
    // A camera turned about the scene's x axis: the device holds the burr where that turn
    // takes it to `scene`.
    let q = glam::Quat::from_rotation_x(1.1);
    let device_at = pivot + q.inverse() * (scene - pivot);
    let run = |camera: Option<[f32; 16]>, stiffness: Option<f32>| {
        let shared = Shared::new();
        if let Some(k) = stiffness {
            shared
                .counters
                .stiffness_bits
                .store(k.to_bits(), Ordering::Relaxed);
        }
        let (mut contact_in, mut contact_out) =
            triple_buffer::TripleBuffer::new(&ContactState::default()).split();
        contact_in.write(plane);
        let (mut cam_in, mut cam_out) = camera_handoff();
        if let Some(c) = camera {
            cam_in.write(c);
        }
        let mut dev = HeldDevice {
            position: f64s(device_at),
            forces: Vec::new(),
        };
        let mut law = BurrLaw::new(params, &mut contact_out, &shared.counters);
        let res = servo_task(
            &mut dev,
            RtConfig {
                fifo_priority: None,
                core: None,
                lock_memory: false,
            },
            20,
            MESH_UNITS,
            &mut law,
            &shared.ring,
            &shared.counters,
            &shared.stop,
            &tetradrill::watchdog::StopRequest::new(),
            None,
            DeviceFrame::new(pivot),
            Some(&mut cam_out),
        );
        assert_eq!(res.ticks, 20);
        let mut last = None;
        while let Some(s) = shared.ring.pop() {
            last = Some(s.position);
        }
        let f = dev.forces.last().copied().expect("forces written");
        (
            last.expect("samples"),
            Vec3::new(f[0] as f32, f[1] as f32, f[2] as f32),
            shared.counters.force(),
        )
    };
    let turn = glam::Mat4::from_quat(q).to_cols_array();
    let (at, f_dev, f_scene) = run(Some(turn), None);
    assert!(
        (at - scene).length() < 1e-5,
        "the burr at {at}, not {scene}"
    );
    let want = Vec3::Z * params.force.stiffness * depth;
    assert!(
        (f_scene - want).length() < 1e-3 * want.length(),
        "{f_scene} vs {want}"
    );
    assert!((f_dev - q.inverse() * f_scene).length() < 1e-4, "{f_dev}");
    // Double the stiffness through the control's atomic: the force doubles.
    let (_, f_dev2, _) = run(Some(turn), Some(2.0 * params.force.stiffness));
    assert!(
        (f_dev2 - 2.0 * f_dev).length() < 1e-3 * f_dev.length(),
        "{f_dev2} vs {f_dev}"
    );
    // With no camera published, the device is in the scene frame: the same hand position
    // is elsewhere in the scene.
    let (at, _, _) = run(None, None);
    assert!((at - device_at).length() < 1e-6);
}

#[test]
fn the_controls_reach_the_simulation() {
    let (mut store, sc) = storage("builtin:block:8");
    let mut params = TickParams::of(&sc).expect("params");
    // The step finishes its work (the comparisons below are of whole erosions, not of how
    // much of them one budget buys).
    params.drill.budget = u32::MAX;
    let initial = Controls {
        radius: params.radius,
        stiffness: params.force.stiffness,
        max_depth: params.drill.max_depth,
        paused: false,
        reset: 0,
    };
    // One simulation step over a short plunge into the top face, with `c` set.
    let mut step = |c: Controls| {
        let mut world = store.world().expect("world");
        let shared = Shared::new();
        for i in 0..40 {
            let z = 0.5 + params.radius - 0.01 * i as f32;
            shared
                .ring
                .push(ToolSample {
                    tick: i,
                    position: Vec3::new(0.0, 0.0, z),
                    buttons: DRILL_ON,
                    ..ToolSample::default()
                })
                .expect("room");
        }
        let (mut cin, cout) = controls(initial);
        cin.write(c);
        let mut link = SimViewer::new(&shared.snapshots, Some(cout), world.mesh().tet_count());
        let (mut contact_in, _contact_out) =
            triple_buffer::TripleBuffer::new(&ContactState::default()).split();
        let (mut status_in, _status_out) =
            triple_buffer::TripleBuffer::new(&SimStatus::default()).split();
        shared.stop.store(true, Ordering::Relaxed);
        let end = simulation_task(
            &mut world,
            params,
            &shared.ring,
            &mut contact_in,
            &mut status_in,
            &shared.stop,
            &shared.counters,
            Some(&mut link),
        );
        assert_eq!(end, SimEnd::Stopped);
        let bits = |a: &std::sync::atomic::AtomicU32| f32::from_bits(a.load(Ordering::Relaxed));
        (
            world.hierarchy().removed_volume(),
            bits(&shared.counters.radius_bits),
            bits(&shared.counters.stiffness_bits),
        )
    };
    let (base, r, k) = step(initial);
    assert!(base > 0.0);
    assert_eq!((r, k), (initial.radius, initial.stiffness));
    let (paused, _, _) = step(Controls {
        paused: true,
        ..initial
    });
    assert_eq!(paused, 0.0, "pause removes nothing");
    let (wide, r, k) = step(Controls {
        radius: 2.0 * initial.radius,
        stiffness: 0.5 * initial.stiffness,
        ..initial
    });
    assert!(wide > 2.0 * base, "a burr twice as wide: {wide} vs {base}");
    assert_eq!((r, k), (2.0 * initial.radius, 0.5 * initial.stiffness));
    let (shallow, _, _) = step(Controls {
        max_depth: 0,
        ..initial
    });
    assert!(
        shallow != base,
        "max depth 0 drills whole coarse tets: {shallow} vs {base}"
    );
}

#[test]
fn reset_ends_the_simulation_task_for_a_rebuild() {
    let (mut store, sc) = storage("builtin:block:8");
    let params = TickParams::of(&sc).expect("params");
    let initial = Controls {
        radius: params.radius,
        stiffness: params.force.stiffness,
        max_depth: params.drill.max_depth,
        paused: false,
        reset: 0,
    };
    let mut world = store.world().expect("world");
    let shared = Shared::new();
    let (mut cin, cout) = controls(initial);
    let mut link = SimViewer::new(&shared.snapshots, Some(cout), world.mesh().tet_count());
    let (mut contact_in, _contact_out) =
        triple_buffer::TripleBuffer::new(&ContactState::default()).split();
    let (mut status_in, _status_out) =
        triple_buffer::TripleBuffer::new(&SimStatus::default()).split();
    let end = std::thread::scope(|s| {
        let task = s.spawn(|| {
            simulation_task(
                &mut world,
                params,
                &shared.ring,
                &mut contact_in,
                &mut status_in,
                &shared.stop,
                &shared.counters,
                Some(&mut link),
            )
        });
        // Once the task took the first controls (it stores the radius for the servo), press
        // reset.
        while shared.counters.radius_bits.load(Ordering::Relaxed) == 0 {
            std::thread::yield_now();
        }
        cin.write(Controls {
            reset: 1,
            ..initial
        });
        // No answer in 10 s: stop it, and the assertion below fails.
        for _ in 0..10_000 {
            if task.is_finished() {
                break;
            }
            std::thread::sleep(std::time::Duration::from_millis(1));
        }
        shared.stop.store(true, Ordering::Relaxed);
        task.join().expect("simulation task")
    });
    assert_eq!(end, SimEnd::Reset);
}

/// A mesh tool is drawn as its shape at the view's `shown` and `rotation`: a rod from the
/// origin to +z (0.1 wide, 1 long), turned a quarter about x so it lies along -y from `shown`.
/// Along the turned rod the pixels are the tool's blue (shaded); where the unturned rod would
/// stand, the background shows (the camera's placement is the documented one, projected here
/// independently of the renderer).
#[test]
fn a_mesh_tool_is_drawn_as_its_shape_at_its_pose() {
    let (h, l) = (0.05f32, 1.0f32);
    let c = |x: f32, y: f32, z: f32| Vec3::new(x * h, y * h, z * l);
    let corner = |i: usize| {
        c(
            [-1.0, 1.0][i & 1],
            [-1.0, 1.0][(i >> 1) & 1],
            [0.0, 1.0][i >> 2],
        )
    };
    // The six faces of the box as two triangles each.
    let quads = [
        [0, 1, 3, 2],
        [4, 6, 7, 5],
        [0, 4, 5, 1],
        [2, 3, 7, 6],
        [0, 2, 6, 4],
        [1, 5, 7, 3],
    ];
    let mut tris = Vec::new();
    for q in quads {
        tris.push([corner(q[0]), corner(q[1]), corner(q[2])]);
        tris.push([corner(q[0]), corner(q[2]), corner(q[3])]);
    }
    let shown = Vec3::new(0.0, 0.4, 0.0);
    let mut scene = Scene::new();
    scene.apply(Snapshot {
        seq: 1,
        full: true,
        tool: ToolView {
            position: shown,
            shown,
            rotation: glam::Quat::from_rotation_x(std::f32::consts::FRAC_PI_2),
            ..ToolView::default()
        },
        tool_shape: Some(tris.into()),
        ..Snapshot::default()
    });
    let camera = Camera {
        target: Vec3::ZERO,
        distance: 3.2,
        yaw: 0.6,
        pitch: 0.45,
        fov_y: 0.7,
    };
    let pic = render(&mut scene, &camera, W, H, true).expect("a headless GL context (Mesa EGL)");
    let (d, y, p) = (3.2f64, 0.6f64, 0.45f64);
    let eye = [d * p.cos() * y.cos(), d * p.cos() * y.sin(), d * p.sin()];
    let at = |q: [f64; 3]| {
        let (col, row) = pixel_of(eye, [0.0; 3], 0.7, q);
        pic.at(col as u32, row as u32)
    };
    // Along the turned rod (x = 0, z = 0, y from 0.4 down to -0.6).
    for y in [0.2, 0.0, -0.2, -0.4] {
        let px = at([0.0, y, 0.0]);
        let [r, g, b] = [px[0], px[1], px[2]].map(i32::from);
        // PALETTE.tool is blue over green over red; the light only scales it.
        assert!(
            b > g + 20 && g > r + 10 && !near(px, background(), 6),
            "the rod at y = {y}: {px:?}"
        );
    }
    // Where the unturned rod would be, above `shown`.
    for z in [0.4, 0.6, 0.8] {
        let px = at([0.0, 0.4, z]);
        assert!(near(px, background(), 2), "no rod at z = {z}: {px:?}");
    }
}

#[test]
fn regions_are_coloured_apart() {
    // block:8 labelled by side: tets left of x = 0 are region 7, the others region 11.
    let (mut store, _) = storage("builtin:block:8");
    let world = store.world().expect("world");
    let labels: Vec<i32> = (0..world.mesh().tet_count())
        .map(|t| {
            let p = world
                .mesh()
                .tet_positions(tetradrill_core::TetId::from_idx(t));
            if p.iter().map(|q| q.x).sum::<f32>() < 0.0 {
                7
            } else {
                11
            }
        })
        .collect();
    let slots = region_slots(&labels).expect("two regions");
    // 3,072 tets, none across x = 0.
    assert_eq!(slots.iter().filter(|&&s| s == 0).count(), 1536);
    assert_eq!(slots.iter().filter(|&&s| s == 1).count(), 1536);
    assert!(
        region_slots(&[5; 10]).is_none(),
        "one region needs no colours"
    );
    let mut scene = Scene::new();
    scene.apply(Snapshot {
        seq: 1,
        full: true,
        patches: full_patches(&world),
        regions: Some(slots),
        ..Snapshot::default()
    });
    let cam = top_camera();
    let pic = render(&mut scene, &cam, W, H, false).expect("render");
    // The lit colour of a palette entry is the entry times one light factor: the ratios of
    // its channels are the entry's. Region 7 is the surface colour (red over blue), region
    // 11 the first region colour (blue over red).
    let (lx, ly) = pixel(&cam, [-0.25, 0.0, 0.5]);
    let (rx, ry) = pixel(&cam, [0.25, 0.0, 0.5]);
    let ratio = |px: [u8; 4]| px[2] as f32 / px[0].max(1) as f32;
    let (l, r) = (pic.at(lx, ly), pic.at(rx, ry));
    let want_l = PALETTE.surface[2] / PALETTE.surface[0];
    let want_r = PALETTE.regions[0][2] / PALETTE.regions[0][0];
    assert!((ratio(l) - want_l).abs() < 0.05, "left {l:?}");
    assert!((ratio(r) - want_r).abs() < 0.1, "right {r:?}");
}
