//! The viewer tests' shared pieces: the render size, engine storage for a scenario, the f64
//! pinhole model the renders are checked against (written here, not the renderer's matrices),
//! and the device workspace in mesh units.

use tetradrill::engine::{self, EngineStorage};
use tetradrill::setup::{MeshSpec, Setup};
use tetradrill::tasks::Workspace;
use tetradrill_core::Vec3;

/// The width of the test renders, in pixels.
pub const W: u32 = 240;

/// The height of the test renders, in pixels.
pub const H: u32 = 180;

/// Engine storage for the set-up that loads `mesh` (a file or a `builtin:` name), and that
/// set-up.
pub fn storage(mesh: &str) -> (EngineStorage, Setup) {
    let sc = Setup {
        mesh: MeshSpec::new(mesh),
        ..Setup::default()
    };
    let loaded = engine::load_mesh(&sc).expect("built-in mesh");
    let store = EngineStorage::new(loaded.mesh, &sc).expect("storage");
    (store, sc)
}

/// The pixel (column, row from the top) where `p` lands for a camera at `eye` looking at
/// `target` with z up and vertical field of view `fov`: an f64 pinhole model written here,
/// not the renderer's matrices.
pub fn pixel_of(eye: [f64; 3], target: [f64; 3], fov: f64, p: [f64; 3]) -> (f64, f64) {
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

/// The device workspace in mesh units: scale 1, no offset.
pub const MESH_UNITS: Workspace = Workspace {
    scale: 1.0,
    offset: Vec3::ZERO,
};

/// An f32 vector as f64 components.
pub fn f64s(v: Vec3) -> [f64; 3] {
    [v.x as f64, v.y as f64, v.z as f64]
}

/// The palette's background as 8-bit RGB.
pub fn background() -> [u8; 3] {
    tetradrill::viewer::gl::PALETTE
        .background
        .map(|c| (c * 255.0).round() as u8)
}

/// Whether pixel `a` is within `tol` of `b` on every channel.
pub fn near(a: [u8; 4], b: [u8; 3], tol: i32) -> bool {
    (0..3).all(|i| (a[i] as i32 - b[i] as i32).abs() <= tol)
}

/// Red well over green: the drilled colour of a mesh with one region.
pub fn reddish(px: [u8; 4]) -> bool {
    px[0] as f32 > 1.8 * px[1] as f32
}

/// The pixel (column, row) where `p` lands for `cam`, by [`pixel_of`] (not the renderer's
/// matrices).
pub fn pixel(cam: &tetradrill::viewer::camera::Camera, p: [f64; 3]) -> (u32, u32) {
    let (x, y) = pixel_of(f64s(cam.eye()), f64s(cam.target), cam.fov_y as f64, p);
    (x as u32, y as u32)
}

/// Plunges the demo burr into `world` (the demo path: down the z axis from the top face's
/// centre) for `ticks` ticks; returns the burr's last centre.
pub fn plunge(world: &mut tetradrill_core::servo::World<'_>, sc: &Setup, ticks: u64) -> Vec3 {
    let params = engine::TickParams::of(sc).expect("params");
    let poses = tetradrill::traces::PoseSource::new(&tetradrill::setup::Poses::Demo, None)
        .expect("demo path");
    let mut tool = tetradrill_core::force::ToolState::default();
    let mut last = Vec3::ZERO;
    for i in 0..ticks {
        let pose = poses.at(i);
        engine::tick(world, &mut tool, &params, &pose);
        last = pose.position;
    }
    last
}

/// A label for each tet of `world`'s mesh: `f` of the tet's centroid.
pub fn labels_by_centroid(
    world: &tetradrill_core::servo::World<'_>,
    f: impl Fn(Vec3) -> i32,
) -> Vec<i32> {
    let mesh = world.mesh();
    (0..mesh.tet_count())
        .map(|t| {
            let p = mesh.tet_positions(tetradrill_core::TetId::from_idx(t));
            f(p.iter().copied().sum::<Vec3>() / 4.0)
        })
        .collect()
}
