//! What the viewer shows of the work: the clip plane's section coloured by region and open at
//! a drilled cavity, the drilled faces in their region's hue, the burr's neck and shank, and
//! the region grid against the analytic block. Renders are checked with the f64 pinhole model
//! of `tetradrill_tests::viewer` (not the renderer's matrices) and with colours.

use std::sync::Arc;

use tetradrill::viewer::camera::Camera;
use tetradrill::viewer::gl::{ClipPlane, DrawOptions, PALETTE};
use tetradrill::viewer::handoff::{region_slots, Snapshot, ToolView};
use tetradrill::viewer::headless::{render, render_with, Picture};
use tetradrill::viewer::labels::{LabelGrid, GRID_CELLS};
use tetradrill::viewer::publish::full_patches;
use tetradrill::viewer::scene::Scene;
use tetradrill::viewer::ClipSpec;
use tetradrill_core::servo::World;
use tetradrill_core::Vec3;
use tetradrill_tests::viewer::{
    background, labels_by_centroid, near, pixel, plunge, reddish, storage, H, W,
};

/// A camera on the -y side of the plane y = 0, a little above it.
fn side_camera() -> Camera {
    Camera {
        target: Vec3::new(0.0, 0.0, 0.1),
        distance: 2.8,
        yaw: -1.35,
        pitch: 0.35,
        fov_y: 0.7,
    }
}

fn at(pic: &Picture, cam: &Camera, p: [f64; 3]) -> [u8; 4] {
    let (x, y) = pixel(cam, p);
    pic.at(x, y)
}

/// Labels of block:8 by side: left of `x0` region 7, the rest region 11.
fn by_side(world: &World<'_>, x0: f32) -> Vec<i32> {
    labels_by_centroid(world, |c| if c.x < x0 { 7 } else { 11 })
}

fn clipped(scene: &mut Scene, cam: &Camera) -> Picture {
    let clip = ClipPlane::facing(1, 0.0, cam.eye());
    assert_eq!(clip.normal, -Vec3::Y, "the camera's side, -y, is cut away");
    render_with(
        scene,
        cam,
        W,
        H,
        DrawOptions {
            tool: false,
            clear: true,
            clip: Some(clip),
        },
    )
    .expect("a headless GL context (Mesa EGL)")
}

#[test]
fn the_section_shows_each_region_where_the_plane_cuts_it() {
    let (mut store, _) = storage("builtin:block:8");
    let world = store.world().expect("world");
    // Three regions: left and right of x = 0 in front (y < 0.25), and a back slab (y > 0.25)
    // whose inside is what the view would show through the cut without a section.
    let labels = labels_by_centroid(&world, |c| match (c.y < 0.25, c.x < 0.0) {
        (false, _) => 13,
        (true, true) => 7,
        (true, false) => 11,
    });
    let slots = region_slots(&labels).expect("three regions");
    let grid = LabelGrid::of_mesh(world.mesh(), &slots, GRID_CELLS).expect("grid");
    let (cl, cr, back) = ([0.2f32, 0.8, 0.6], [0.9f32, 0.3, 0.6], [0.3f32, 0.3, 0.9]);
    let mut scene = Scene::new();
    scene.apply(Snapshot {
        seq: 1,
        full: true,
        patches: full_patches(&world),
        regions: Some(slots),
        region_colours: Some(vec![Some(cl), Some(cr), Some(back)].into()),
        labels: Some(Arc::new(grid)),
        ..Snapshot::default()
    });
    let cam = side_camera();
    let pic = clipped(&mut scene, &cam);
    let green = |px: [u8; 4]| px[1] as f32 / px[0].max(1) as f32;
    let blue = |px: [u8; 4]| px[2] as f32 / px[0].max(1) as f32;
    // On the plane, inside the block: the left region's colour, then the right one's (the
    // light is grey: the ratios of the channels are the colours' own), not the back slab's
    // seen from inside.
    for (p, c) in [
        ([-0.25, 0.0, 0.0], cl),
        ([-0.3, 0.0, -0.3], cl),
        ([0.25, 0.0, 0.0], cr),
        ([0.3, 0.0, 0.3], cr),
    ] {
        let px = at(&pic, &cam, p);
        assert!(
            (green(px) - c[1] / c[0]).abs() < 0.12 * c[1] / c[0] + 0.05
                && (blue(px) - c[2] / c[0]).abs() < 0.12 * c[2] / c[0] + 0.05,
            "{p:?}: {px:?} is not {c:?}"
        );
    }
    // Above the block, on the plane: nothing.
    assert!(near(at(&pic, &cam, [0.0, 0.0, 0.75]), background(), 2));
}

#[test]
fn the_section_is_open_where_the_drill_took_material() {
    let (mut store, sc) = storage("builtin:block:8");
    let mut world = store.world().expect("world");
    let burr = plunge(&mut world, &sc, 2500);
    assert!(world.hierarchy().removed_volume() > 0.0);
    // The burr went down the z axis from the top face (z = 0.5) to `burr.z`: between the two,
    // on the plane y = 0 and close to the axis, there is no material.
    assert!(burr.z < 0.4, "the plunge went {:.3} deep", 0.5 - burr.z);
    let mut scene = Scene::new();
    scene.apply(Snapshot {
        seq: 1,
        full: true,
        patches: full_patches(&world),
        ..Snapshot::default()
    });
    let cam = side_camera();
    let pic = clipped(&mut scene, &cam);
    let hole = at(&pic, &cam, [0.0, 0.0, 0.5 * (0.5 + burr.z as f64)]);
    assert!(
        reddish(hole),
        "in the hole, the view goes through the section to the drilled wall: {hole:?}"
    );
    // Beside the hole, the section (the surface colour, one region).
    let s = PALETTE.surface;
    for p in [[-0.3, 0.0, 0.0], [0.3, 0.0, -0.2]] {
        let px = at(&pic, &cam, p);
        assert!(!reddish(px) && !near(px, background(), 6), "{p:?}: {px:?}");
        let ratio = px[2] as f32 / px[0].max(1) as f32;
        assert!((ratio - s[2] / s[0]).abs() < 0.06, "{p:?}: {px:?}");
    }
}

#[test]
fn drilled_faces_keep_their_regions_hue_darker() {
    let (mut store, sc) = storage("builtin:block:8");
    let mut world = store.world().expect("world");
    plunge(&mut world, &sc, 2500);
    // The hole lies wholly in the left region (x < 0.3).
    let labels = by_side(&world, 0.3);
    let cl = [0.2f32, 0.8, 0.6];
    let mut scene = Scene::new();
    scene.apply(Snapshot {
        seq: 1,
        full: true,
        patches: full_patches(&world),
        regions: region_slots(&labels),
        region_colours: Some(vec![Some(cl), Some([0.9, 0.3, 0.6])].into()),
        ..Snapshot::default()
    });
    let cam = Camera {
        target: Vec3::new(0.0, 0.0, 0.2),
        distance: 2.6,
        yaw: -1.2,
        pitch: 1.0,
        fov_y: 0.7,
    };
    let pic = render(&mut scene, &cam, W, H, false).expect("render");
    let hole = at(&pic, &cam, [0.0, 0.0, 0.5]);
    let top = at(&pic, &cam, [-0.3, -0.3, 0.5]);
    let green = |px: [u8; 4]| px[1] as f32 / px[0].max(1) as f32;
    assert!(
        (green(hole) - cl[1] / cl[0]).abs() < 0.6,
        "the hole keeps the region's hue: {hole:?}"
    );
    assert!(!reddish(hole), "not one red for every material: {hole:?}");
    let sum = |px: [u8; 4]| px[0] as u32 + px[1] as u32 + px[2] as u32;
    assert!(
        sum(hole) < sum(top),
        "darker than the top face: {hole:?} {top:?}"
    );
}

#[test]
fn a_round_burr_is_drawn_with_its_neck_and_shank_along_its_axis() {
    let mut scene = Scene::new();
    let r = 0.1f32;
    scene.apply(Snapshot {
        seq: 1,
        full: true,
        tool: ToolView {
            position: Vec3::ZERO,
            shown: Vec3::ZERO,
            radius: r,
            ..ToolView::default()
        },
        ..Snapshot::default()
    });
    let cam = Camera {
        target: Vec3::new(0.0, 0.0, 0.6),
        distance: 4.0,
        yaw: -1.0,
        pitch: 0.1,
        fov_y: 0.7,
    };
    let pic = render(&mut scene, &cam, W, H, true).expect("render");
    // The burr at the origin: the tool's blue.
    let burr = at(&pic, &cam, [0.0, 0.0, 0.0]);
    assert!(burr[2] as i32 > burr[0] as i32 + 20, "{burr:?}");
    // The shank, grey, well above the burr along +z (the tool's axis unturned).
    for z in [0.8, 1.2] {
        let px = at(&pic, &cam, [0.0, 0.0, z]);
        let spread = px[..3].iter().max().unwrap_or(&0) - px[..3].iter().min().unwrap_or(&0);
        assert!(!near(px, background(), 6) && spread < 25, "z = {z}: {px:?}");
    }
    // Beside the shank: nothing.
    assert!(near(at(&pic, &cam, [0.5, 0.0, 1.0]), background(), 2));
}

#[test]
fn the_grid_holds_each_region_where_the_analytic_block_has_it() {
    let (mut store, _) = storage("builtin:block:8");
    let world = store.world().expect("world");
    let labels = by_side(&world, 0.0);
    let slots = region_slots(&labels).expect("two regions");
    let g = LabelGrid::of_mesh(world.mesh(), &slots, 40).expect("grid");
    assert_eq!(g.dims, [40, 40, 40]);
    let (mut checked, mut wrong) = (0, 0);
    for z in 0..40 {
        for y in 0..40 {
            for x in 0..40 {
                let c =
                    g.origin + g.cell * Vec3::new(x as f32 + 0.5, y as f32 + 0.5, z as f32 + 0.5);
                // The block is [-0.5, 0.5]^3, region 7 (slot 0) where x < 0.
                let inside = c.abs().max_element() < 0.5;
                let want = match (inside, c.x < 0.0) {
                    (false, _) => 0,
                    (true, true) => 1,
                    (true, false) => 2,
                };
                if (c.x.abs() < 1e-4) || (c.abs().max_element() - 0.5).abs() < 1e-4 {
                    continue;
                }
                checked += 1;
                wrong += usize::from(g.at(c) != want);
            }
        }
    }
    assert_eq!(wrong, 0, "{wrong} of {checked} cells");
    assert!(checked > 60_000);
    assert_eq!(g.at(Vec3::splat(2.0)), 0, "outside the grid");
}

#[test]
fn clip_specs_parse_and_refuse() {
    assert_eq!(ClipSpec::parse("x"), Ok(ClipSpec { axis: 0, at: None }));
    assert_eq!(
        ClipSpec::parse("z:-0.25"),
        Ok(ClipSpec {
            axis: 2,
            at: Some(-0.25)
        })
    );
    assert!(ClipSpec::parse("w").is_err());
    assert!(ClipSpec::parse("y:nan").is_err());
    assert!(ClipSpec::parse("y:").is_err());
    tetradrill_tests::refused(
        &["replay", "--scenario", "builtin:demo", "--clip", "w"],
        &["--clip", "w"],
    );
}
