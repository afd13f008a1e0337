//! The viewer's pictures: headless renders (EGL surfaceless on Mesa) checked against oracles
//! that share no code with the renderer (the f64 pinhole model of `tetradrill_tests::viewer`,
//! convex hulls, colours), partial buffer updates against a full upload, and the snapshot
//! hand-off that refuses instead of blocking and loses nothing when it does.

use tetradrill::engine::{self, TickParams};
use tetradrill::tasks::SimStatus;
use tetradrill::traces::PoseSource;
use tetradrill::viewer::camera::Camera;
use tetradrill::viewer::gl::{DrawOptions, Offscreen, Renderer, PALETTE};
use tetradrill::viewer::handoff::{region_slots, Snapshot, SnapshotQueue, ToolView};
use tetradrill::viewer::headless::{render, Picture};
use tetradrill::viewer::publish::{full_patches, scene_of, SimViewer};
use tetradrill::viewer::scene::{Scene, VERTEX_FLOATS};
use tetradrill::viewer::smooth_live::SmoothStore;
use tetradrill_core::force::ToolState;
use tetradrill_core::Vec3;
use tetradrill_tests::viewer::{
    background, labels_by_centroid, near, pixel, pixel_of, plunge, reddish, storage, H, W,
};

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

fn top_camera() -> Camera {
    Camera {
        target: Vec3::new(0.0, 0.0, 0.2),
        distance: 2.6,
        yaw: -1.2,
        pitch: 1.0,
        fov_y: 0.7,
    }
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
    let poses = PoseSource::new(&tetradrill::setup::Poses::Demo, None).expect("demo path");
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
    // Smooth normals, as the live window has them.
    let mut smooth = SmoothStore::for_world(&world);
    let mut link = SimViewer::new(&queue, None, world.mesh().tet_count());
    link.set_smooth_store(&mut smooth);
    let mut scene = Scene::new();
    assert!(link.publish_now(&world, ToolView::default(), &SimStatus::default(), 0));
    scene.apply(queue.take().expect("first snapshot"));
    off.bind();
    r.sync(gl, &mut scene);
    let whole = r.last_upload_bytes;
    assert_eq!(whole, 4 * scene.data().len());
    let poses = PoseSource::new(&tetradrill::setup::Poses::Demo, None).expect("demo path");
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
    // The normals catch up a bounded step a snapshot.
    for k in 0..1000u64 {
        if scene.status.smooth_pending == 0 {
            break;
        }
        assert!(link.publish_now(&world, ToolView::default(), &SimStatus::default(), k));
        scene.apply(queue.take().expect("snapshot"));
        r.sync(gl, &mut scene);
    }
    assert_eq!(scene.status.smooth_pending, 0);
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
            clip: None,
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
    let labels = labels_by_centroid(&world, |c| if c.x < 0.0 { 7 } else { 11 });
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
    // A scenario's colours replace the palette's: green-blue on the left, magenta-ish on the
    // right (the ratios of the channels are the colours' own).
    let (cl, cr) = ([0.2f32, 0.8, 0.6], [0.9f32, 0.3, 0.6]);
    let mut scene = Scene::new();
    scene.apply(Snapshot {
        seq: 1,
        full: true,
        patches: full_patches(&world),
        regions: region_slots(&labels),
        region_colours: Some(vec![Some(cl), Some(cr)].into()),
        ..Snapshot::default()
    });
    let pic = render(&mut scene, &cam, W, H, false).expect("render");
    let (l, r) = (pic.at(lx, ly), pic.at(rx, ry));
    let green = |px: [u8; 4]| px[1] as f32 / px[0].max(1) as f32;
    assert!((green(l) - cl[1] / cl[0]).abs() < 0.3, "left {l:?}");
    assert!((ratio(l) - cl[2] / cl[0]).abs() < 0.2, "left {l:?}");
    assert!((green(r) - cr[1] / cr[0]).abs() < 0.05, "right {r:?}");
    assert!((ratio(r) - cr[2] / cr[0]).abs() < 0.05, "right {r:?}");
}
