//! Pictures without a display: the renderer on an EGL surfaceless context (see
//! [`super::gl::Offscreen`]), read back and written as PNG. `--screenshot` and the tests use
//! this.

use std::path::Path;

use super::camera::Camera;
use super::gl::{ClipPlane, DrawOptions, Offscreen, Renderer};
use super::scene::Scene;
use crate::error::CliError;

/// Size of `--screenshot` pictures.
pub const SCREENSHOT_SIZE: (u32, u32) = (800, 600);

/// An RGBA picture, top row first.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Picture {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// `4 * width * height` bytes.
    pub rgba: Vec<u8>,
}

impl Picture {
    /// The pixel at column `x`, row `y` (from the top).
    pub fn at(&self, x: u32, y: u32) -> [u8; 4] {
        let i = 4 * (y * self.width + x) as usize;
        [
            self.rgba[i],
            self.rgba[i + 1],
            self.rgba[i + 2],
            self.rgba[i + 3],
        ]
    }

    /// Writes the picture as an 8-bit RGB PNG.
    ///
    /// # Errors
    /// An I/O or encoding error, as one line naming the file.
    pub fn write_png(&self, path: &Path) -> Result<(), CliError> {
        let fail = |e: &dyn std::fmt::Display| {
            CliError::failure(format!(
                "{}: cannot write the screenshot: {e}",
                path.display()
            ))
        };
        let file = std::fs::File::create(path).map_err(|e| fail(&e))?;
        let mut enc = png::Encoder::new(std::io::BufWriter::new(file), self.width, self.height);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        enc.set_compression(png::Compression::High);
        let mut w = enc.write_header().map_err(|e| fail(&e))?;
        let rgb: Vec<u8> = self
            .rgba
            .chunks_exact(4)
            .flat_map(|p| [p[0], p[1], p[2]])
            .collect();
        w.write_image_data(&rgb).map_err(|e| fail(&e))?;
        w.finish().map_err(|e| fail(&e))
    }
}

/// Renders `scene` from `camera` into a `width` x `height` picture without a display.
///
/// # Errors
/// No EGL/OpenGL context could be made (the message says what to install).
pub fn render(
    scene: &mut Scene,
    camera: &Camera,
    width: u32,
    height: u32,
    tool: bool,
) -> Result<Picture, String> {
    render_with(
        scene,
        camera,
        width,
        height,
        DrawOptions {
            tool,
            clear: true,
            clip: None,
        },
    )
}

/// [`render`] with every drawing option (the clip plane among them).
///
/// # Errors
/// No EGL/OpenGL context could be made (the message says what to install).
pub fn render_with(
    scene: &mut Scene,
    camera: &Camera,
    width: u32,
    height: u32,
    opts: DrawOptions,
) -> Result<Picture, String> {
    let off = Offscreen::new(width, height)?;
    let mut r = Renderer::new(off.gl())?;
    off.bind();
    r.sync(off.gl(), scene);
    r.draw(off.gl(), scene, camera, width, height, opts);
    let rgba = off.read_rgba();
    r.destroy(off.gl());
    Ok(Picture {
        width,
        height,
        rgba,
    })
}

/// The default camera for `scene`: the fixed view direction, framing what it shows.
pub fn default_camera(scene: &Scene) -> Camera {
    match scene.bounds {
        Some((lo, hi)) => Camera::framing(lo, hi),
        None => Camera::default(),
    }
}

/// The camera of `--screenshot`: framing the tool's work area ([`Scene::work_area`]), else
/// the whole scene; with a clip plane across `axis`, turned to look at the section about 30
/// degrees off its normal.
pub fn work_camera(scene: &Scene, clip_axis: Option<usize>) -> Camera {
    let mut c = match scene.work_area().or(scene.bounds) {
        Some((lo, hi)) => Camera::framing(lo, hi),
        None => Camera::default(),
    };
    match clip_axis {
        Some(0) => c.yaw = (-28f32).to_radians(),
        Some(1) => c.yaw = (-62f32).to_radians(),
        Some(_) => c.pitch = 58f32.to_radians(),
        None => {}
    }
    c
}

/// The clip plane `spec` asks for, seen from `camera`: at its coordinate, or through the
/// centre of the tool's work area (else of the scene), cutting away the camera's side.
pub fn clip_plane(scene: &Scene, camera: &Camera, spec: super::ClipSpec) -> Option<ClipPlane> {
    let at = match spec.at {
        Some(a) => a,
        None => {
            let (lo, hi) = scene.work_area().or(scene.bounds)?;
            0.5 * (lo[spec.axis] + hi[spec.axis])
        }
    };
    Some(ClipPlane::facing(spec.axis, at, camera.eye()))
}

/// Renders `scene` at [`SCREENSHOT_SIZE`], framing the tool's work area and cut open by
/// `clip` if given, and writes it to `path` (`--screenshot`, `--clip`).
///
/// # Errors
/// No GL context (exit 1, saying what to install) or an I/O error.
pub fn screenshot(
    scene: &mut Scene,
    path: &Path,
    clip: Option<super::ClipSpec>,
) -> Result<(), CliError> {
    let camera = work_camera(scene, clip.map(|c| c.axis));
    let opts = DrawOptions {
        tool: true,
        clear: true,
        clip: clip.and_then(|c| clip_plane(scene, &camera, c)),
    };
    let (w, h) = SCREENSHOT_SIZE;
    // On a thread of its own: after the live window closed, its GL context can stay current on
    // this thread, and Mesa then refuses the new context (EGL_BAD_ACCESS).
    let pic = std::thread::scope(|s| {
        s.spawn(|| render_with(scene, &camera, w, h, opts))
            .join()
            .unwrap_or_else(|_| Err("the render thread panicked".to_string()))
    })
    .map_err(|e| {
        CliError::failure(format!(
            "{}: cannot render the screenshot: {e}",
            path.display()
        ))
    })?;
    pic.write_png(path)?;
    errln!("tetradrill: screenshot written to {}", path.display());
    Ok(())
}
