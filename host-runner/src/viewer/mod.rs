//! The viewer task ([`crate::tasks::VIEWER`]): a live 3D view of the drilled surface, the tool and
//! the force, about 60 Hz, fed by snapshots the simulation publishes; and headless screenshots.
//!
//! | file          | what                                                          | feature  |
//! |---------------|---------------------------------------------------------------|----------|
//! | [`handoff`]   | snapshots (queue that refuses when full), controls (triple buffer) | always |
//! | [`publish`]   | the simulation's side: changed tets, patches, the tool's shown pose | always |
//! | [`scene`]     | the viewer's copy of the surface in chunks, runs of changed chunks | always |
//! | [`labels`]    | the regions on a grid, for the clip plane's section             | always |
//! | [`smooth_live`] | the surface's smooth normals, updated a bounded step a snapshot | always |
//! | [`camera`]    | orbit camera, matrices, the egocentric camera `C` it publishes | always  |
//! | `gl`          | the OpenGL renderer and the EGL offscreen context (all `unsafe`) | `viewer` |
//! | `headless`    | screenshots without a display, PNG                             | `viewer` |
//! | `app`         | the eframe window: the view in a paint callback, overlay, controls | `viewer` |
//!
//! Nothing here runs on the servo thread. The simulation publishes without waiting (a full
//! queue keeps its changes for the next snapshot); the viewer drains without waiting.

pub mod camera;
pub mod handoff;
pub mod labels;
pub mod publish;
pub mod scene;
pub mod smooth_live;

#[cfg(feature = "viewer")]
pub mod app;
#[cfg(feature = "viewer")]
pub mod gl;
#[cfg(feature = "viewer")]
pub mod headless;

use std::path::PathBuf;

/// Set to `1`, the window closes by itself when the run ends (scripted runs under Xvfb; the
/// demo then keeps its scripted length).
pub const CLOSE_AT_END: &str = "TETRADRILL_VIEWER_CLOSE";

/// What a command asks of the viewer.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ViewOptions {
    /// Open the live window (a display exists and `--headless` was not given).
    pub window: bool,
    /// Write a PNG of the view at the end of the run.
    pub screenshot: Option<PathBuf>,
    /// The clip plane the view starts with (`--clip`), if any.
    pub clip: Option<ClipSpec>,
}

/// A clip plane across one axis (`--clip x|y|z[:AT]`): the view keeps the half away from the
/// camera and shows the solid's section on the plane, coloured by region.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ClipSpec {
    /// 0, 1, 2: the plane is `x`, `y` or `z` = const.
    pub axis: usize,
    /// Where the plane crosses the axis, mesh units; `None`: through the centre of the tool's
    /// work area (the drilled faces and the tool).
    pub at: Option<f32>,
}

impl ClipSpec {
    /// Parses `x`, `y`, `z`, optionally followed by `:AT` (a coordinate, mesh units).
    ///
    /// # Errors
    /// One line naming what is wrong.
    pub fn parse(s: &str) -> Result<ClipSpec, String> {
        let (axis, at) = match s.split_once(':') {
            Some((a, v)) => (a, Some(v)),
            None => (s, None),
        };
        let axis = match axis {
            "x" => 0,
            "y" => 1,
            "z" => 2,
            other => {
                return Err(format!(
                    "{other:?} is not an axis: x, y or z, then :AT if needed"
                ))
            }
        };
        let at = match at {
            None => None,
            Some(v) => match v.parse::<f32>() {
                Ok(f) if f.is_finite() => Some(f),
                _ => return Err(format!("{v:?} is not a finite coordinate")),
            },
        };
        Ok(ClipSpec { axis, at })
    }
}

impl ViewOptions {
    /// The options of a command: the window when the build has the viewer, a display exists
    /// and `headless` is false; the screenshot as asked.
    ///
    /// # Errors
    /// `--screenshot` in a build without the viewer (exit 2).
    pub fn of(headless: bool, screenshot: Option<PathBuf>) -> Result<Self, crate::error::CliError> {
        if screenshot.is_some() && !cfg!(feature = "viewer") {
            return Err(crate::error::CliError::input(
                "--screenshot: this build has no viewer (build with the `viewer` feature)",
            ));
        }
        Ok(Self {
            window: cfg!(feature = "viewer") && !headless && has_display(),
            screenshot,
            clip: None,
        })
    }

    /// Whether any viewer work is needed.
    pub fn any(&self) -> bool {
        self.window || self.screenshot.is_some()
    }
}

/// A display server is reachable (X11 or Wayland).
pub fn has_display() -> bool {
    std::env::var_os("DISPLAY").is_some_and(|d| !d.is_empty())
        || std::env::var_os("WAYLAND_DISPLAY").is_some_and(|d| !d.is_empty())
}

/// What the live window shares with a real-time run.
#[derive(Debug)]
pub struct LiveLink<'a> {
    /// The run's shared state: snapshot queue, servo counters, stop flag.
    pub shared: &'a crate::tasks::Shared,
    /// The viewer's end of the control hand-off.
    pub controls: handoff::ControlsIn,
    /// The controls as the run started (the scenario's values).
    pub initial: handoff::Controls,
    /// The viewer's end of the camera hand-off: the egocentric camera `C` the servo maps the
    /// device through (`None`: the device frame stays the scene frame).
    pub camera: Option<crate::tasks::CameraIn>,
    /// The clip plane the window starts with (`--clip`; the `C` key toggles it).
    pub clip: Option<ClipSpec>,
}

/// Runs the live window on this thread until it is closed; returns the last scene.
///
/// # Errors
/// The window could not be opened (exit 1), or the build has no viewer (exit 2).
pub fn run_window(link: LiveLink<'_>) -> Result<scene::Scene, crate::error::CliError> {
    #[cfg(feature = "viewer")]
    {
        app::run(link)
    }
    #[cfg(not(feature = "viewer"))]
    {
        let _ = link;
        Err(crate::error::CliError::input("this build has no viewer"))
    }
}

/// Writes a PNG of `scene` from the default camera, framing the tool's work area, cut open by
/// `clip` if given (`--screenshot`, `--clip`).
///
/// # Errors
/// No GL context or an I/O error (exit 1); a build without the viewer (exit 2).
pub fn screenshot(
    scene: &mut scene::Scene,
    path: &std::path::Path,
    clip: Option<ClipSpec>,
) -> Result<(), crate::error::CliError> {
    #[cfg(feature = "viewer")]
    {
        headless::screenshot(scene, path, clip)
    }
    #[cfg(not(feature = "viewer"))]
    {
        let _ = (scene, path, clip);
        Err(crate::error::CliError::input(
            "--screenshot: this build has no viewer (build with the `viewer` feature)",
        ))
    }
}
