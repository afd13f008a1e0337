//! The live window: eframe/egui on glow. The 3D view is drawn by our renderer in a paint
//! callback; an overlay shows the rates, the latencies and the drilling figures, two small
//! plots (force, wake-up latency) and the controls.
//!
//! Each frame (about 60 Hz) drains the snapshot queue into the [`Scene`] and uploads only the
//! chunks that changed. The queue is never waited on; nothing here can hold up the servo or
//! the simulation. The scene and the renderer sit behind one mutex that only this thread (the
//! UI pass and the paint callback within it) takes.

use std::collections::VecDeque;
use std::sync::atomic::Ordering;
use std::sync::{Arc, Mutex};
use std::time::Instant;

use eframe::egui;
use eframe::egui_glow;

use super::camera::Camera;
use super::gl::{DrawOptions, Renderer};
use super::handoff::Controls;
use super::scene::Scene;
use super::LiveLink;
use crate::error::CliError;

pub use super::CLOSE_AT_END;

/// Samples the live plots keep (about 5 s at 60 Hz).
const PLOT_SAMPLES: usize = 300;

struct GlSide {
    scene: Scene,
    renderer: Option<Renderer>,
    error: Option<String>,
    frame_ms: f64,
    draws: u64,
    draw_ms_sum: f64,
    draw_ms_max: f64,
}

struct ViewerApp<'a> {
    link: LiveLink<'a>,
    side: Arc<Mutex<GlSide>>,
    camera: Camera,
    /// The start view's orientation: the device frame is the scene frame as it shows it.
    home: Camera,
    /// The camera `C` last handed to the servo.
    published: [f32; 16],
    fitted: bool,
    /// The tool is a mesh (the pen): no drilling controls.
    mesh_tool: bool,
    controls: Controls,
    force_plot: VecDeque<f32>,
    latency_plot: VecDeque<f32>,
    rates_at: Instant,
    last_ticks: u64,
    last_steps: u64,
    frames: u64,
    servo_hz: f64,
    sim_hz: f64,
    fps: f64,
    close_at_end: bool,
    /// The clip plane: on, its axis, where it crosses (`None`: through the work area's
    /// centre), and the scene's bounds and work area as the last frame saw them.
    clip_on: bool,
    clip_axis: usize,
    clip_at: Option<f32>,
    bounds: Option<(tetradrill_core::Vec3, tetradrill_core::Vec3)>,
    work: Option<(tetradrill_core::Vec3, tetradrill_core::Vec3)>,
}

/// Runs the window until it is closed; returns the last scene.
///
/// # Errors
/// The window or its GL context could not be made (exit 1).
pub fn run(link: LiveLink<'_>) -> Result<Scene, CliError> {
    let side = Arc::new(Mutex::new(GlSide {
        scene: Scene::new(),
        renderer: None,
        error: None,
        frame_ms: 0.0,
        draws: 0,
        draw_ms_sum: 0.0,
        draw_ms_max: 0.0,
    }));
    let opened = Instant::now();
    let options = eframe::NativeOptions {
        viewport: egui::ViewportBuilder::default()
            .with_title("tetradrill")
            .with_inner_size([1200.0, 780.0]),
        renderer: eframe::Renderer::Glow,
        depth_buffer: 24,
        multisampling: 0,
        ..Default::default()
    };
    let app_side = Arc::clone(&side);
    let initial = link.initial;
    let clip = link.clip;
    eframe::run_native(
        "tetradrill",
        options,
        Box::new(move |cc| {
            if let Some(gl) = cc.gl.as_ref() {
                let mut s = lock(&app_side);
                match Renderer::new(gl) {
                    Ok(r) => s.renderer = Some(r),
                    Err(e) => s.error = Some(e),
                }
            }
            Ok(Box::new(ViewerApp {
                link,
                side: app_side,
                camera: Camera::default(),
                home: Camera::default(),
                published: crate::tasks::IDENTITY,
                fitted: false,
                mesh_tool: false,
                controls: initial,
                force_plot: VecDeque::with_capacity(PLOT_SAMPLES),
                latency_plot: VecDeque::with_capacity(PLOT_SAMPLES),
                rates_at: Instant::now(),
                last_ticks: 0,
                last_steps: 0,
                frames: 0,
                servo_hz: 0.0,
                sim_hz: 0.0,
                fps: 0.0,
                close_at_end: std::env::var_os(CLOSE_AT_END).is_some_and(|v| v == "1"),
                clip_on: clip.is_some(),
                clip_axis: clip.map_or(0, |c| c.axis),
                clip_at: clip.and_then(|c| c.at),
                bounds: None,
                work: None,
            }))
        }),
    )
    .map_err(|e| CliError::failure(format!("cannot open the viewer window: {e}")))?;
    let mut s = lock(&side);
    let secs = opened.elapsed().as_secs_f64();
    errln!(
        "tetradrill: viewer: {} frames in {:.1} s ({:.1} Hz), 3D view draw mean {:.2} ms, max {:.2} ms, {} triangles",
        s.draws,
        secs,
        s.draws as f64 / secs.max(1e-9),
        s.draw_ms_sum / (s.draws.max(1)) as f64,
        s.draw_ms_max,
        s.scene.triangle_count()
    );
    Ok(std::mem::take(&mut s.scene))
}

fn lock(m: &Mutex<GlSide>) -> std::sync::MutexGuard<'_, GlSide> {
    m.lock().unwrap_or_else(|p| p.into_inner())
}

impl eframe::App for ViewerApp<'_> {
    fn ui(&mut self, ui: &mut egui::Ui, _frame: &mut eframe::Frame) {
        let sh = self.link.shared;
        // Take what the simulation published; a gap in the sequence means a lost patch.
        {
            let mut s = lock(&self.side);
            while let Some(snap) = sh.snapshots.take() {
                if !snap.full && snap.seq != s.scene.seq + 1 {
                    sh.snapshots.request_full();
                }
                s.scene.apply(snap);
            }
            self.mesh_tool = s.scene.tool_shape.is_some();
            self.bounds = s.scene.bounds;
            self.work = s.scene.work_area();
            if !self.fitted {
                // The start frames the tool's work area; "fit view" the whole scene.
                let area = if s.scene.applied <= 1 {
                    self.work.or(self.bounds)
                } else {
                    self.bounds
                };
                if let Some((lo, hi)) = area {
                    self.camera.fit(lo, hi);
                    self.fitted = true;
                }
            }
        }
        self.update_rates();
        egui::Panel::right("overlay")
            .resizable(false)
            .exact_size(300.0)
            .show(ui, |ui| {
                self.overlay(ui);
            });
        egui::CentralPanel::default().show(ui, |ui| self.view(ui));
        ui.ctx()
            .request_repaint_after(std::time::Duration::from_millis(16));
        if self.close_at_end && sh.stop.load(Ordering::Relaxed) {
            ui.ctx().send_viewport_cmd(egui::ViewportCommand::Close);
        }
    }
}

impl ViewerApp<'_> {
    fn update_rates(&mut self) {
        self.frames += 1;
        let sh = self.link.shared;
        let c = &sh.counters;
        let (force, steps) = {
            let s = lock(&self.side);
            (
                s.scene.tool.map_or(0.0, |t| t.force.length()),
                s.scene.status.steps,
            )
        };
        push(&mut self.force_plot, force);
        push(
            &mut self.latency_plot,
            c.wake_recent_max_ns.load(Ordering::Relaxed) as f32 / 1000.0,
        );
        let dt = self.rates_at.elapsed().as_secs_f64();
        if dt >= 0.5 {
            let ticks = c.ticks.load(Ordering::Relaxed);
            self.servo_hz = (ticks - self.last_ticks.min(ticks)) as f64 / dt;
            self.sim_hz = (steps - self.last_steps.min(steps)) as f64 / dt;
            self.fps = self.frames as f64 / dt;
            self.last_ticks = ticks;
            self.last_steps = steps;
            self.frames = 0;
            self.rates_at = Instant::now();
        }
    }

    fn overlay(&mut self, ui: &mut egui::Ui) {
        let sh = self.link.shared;
        let c = &sh.counters;
        let running = !sh.stop.load(Ordering::Relaxed);
        let (st, iv, tris, drilled, frame_ms, error) = {
            let s = lock(&self.side);
            (
                s.scene.status,
                s.scene.initial_volume,
                s.scene.triangle_count(),
                s.scene.drilled_count(),
                s.frame_ms,
                s.error.clone(),
            )
        };
        ui.heading("tetradrill");
        ui.label(if running {
            "running"
        } else {
            "run finished: close the window for the summary"
        });
        if let Some(e) = error {
            ui.colored_label(egui::Color32::RED, e);
        }
        egui::Grid::new("stats")
            .num_columns(2)
            .striped(true)
            .show(ui, |ui| {
                let mut row = |k: &str, v: String| {
                    ui.label(k);
                    ui.monospace(v);
                    ui.end_row();
                };
                row("servo", format!("{:.0} Hz", self.servo_hz));
                row("simulation", format!("{:.0} Hz", self.sim_hz));
                row(
                    "frames",
                    format!("{:.0} Hz, draw {:.1} ms", self.fps, frame_ms),
                );
                row("overruns", c.overruns.load(Ordering::Relaxed).to_string());
                let p99 = match c.wake_percentile_us(0.99) {
                    None => "-".to_string(),
                    Some(v) => format!("{v:.0} us"),
                };
                row("wake-up p99", p99);
                let max = c.wake.max_ns() as f64 / 1000.0;
                let recent = c.wake_recent_max_ns.load(Ordering::Relaxed) as f64 / 1000.0;
                row("wake-up max", format!("{max:.0} us"));
                row("  last second", format!("{recent:.0} us"));
                let f = f32::from_bits(c.force_bits.load(Ordering::Relaxed) as u32);
                row("force", format!("{f:.2} N"));
                // With materials: the force pressing the burr against the threshold of the
                // material under it.
                if let Some(th) = st.threshold_n {
                    row(
                        "press / threshold",
                        format!("{:.2} / {th:.2} N", st.press_n),
                    );
                }
                let pct = 100.0 * st.removed_volume / iv.max(f64::MIN_POSITIVE);
                row("removed", format!("{:.5} ({pct:.2}%)", st.removed_volume));
                row("hierarchy nodes", st.hierarchy_nodes.to_string());
                row("visible faces", format!("{tris} ({drilled} drilled)"));
                row(
                    "smooth normals",
                    format!(
                        "{} pending, {} saturations",
                        st.smooth_pending, st.smooth_saturations
                    ),
                );
                row("snapshots refused", sh.snapshots.refused().to_string());
                let turn = turn_degrees(&self.published);
                row(
                    "device frame",
                    if turn == 0.0 {
                        "start view".to_string()
                    } else {
                        format!("turned {turn:.0} deg")
                    },
                );
            });
        ui.separator();
        ui.label("force, N (last 5 s)");
        sparkline(ui, &self.force_plot, egui::Color32::from_rgb(90, 240, 100));
        ui.label("wake-up latency max per second, us");
        sparkline(
            ui,
            &self.latency_plot,
            egui::Color32::from_rgb(240, 180, 60),
        );
        ui.separator();
        ui.label("controls");
        let before = self.controls;
        let init = self.link.initial;
        let c = &mut self.controls;
        let drill = !self.mesh_tool;
        if drill {
            ui.add(
                egui::Slider::new(&mut c.radius, 0.25 * init.radius..=3.0 * init.radius)
                    .text("tool radius"),
            )
            .on_hover_text("The burr's radius: the drill spheres and the servo's contact.");
        }
        ui.add(
            egui::Slider::new(
                &mut c.stiffness,
                0.1 * init.stiffness..=2.0 * init.stiffness,
            )
            .text("stiffness"),
        )
        .on_hover_text("The servo's spring constant, N per mesh unit (force stays clamped).");
        if drill {
            ui.add(
                egui::Slider::new(
                    &mut c.max_depth,
                    0..=tetradrill_core::hierarchy::MAX_DEPTH as u8,
                )
                .text("max depth"),
            )
            .on_hover_text("The deepest refinement level the drill uses from now on.");
            ui.checkbox(&mut c.paused, "pause drilling")
                .on_hover_text("The burr still touches (force on); no material is removed.");
        }
        ui.horizontal(|ui| {
            if drill
                && ui
                    .button("reset")
                    .on_hover_text("Rebuild the untouched mesh (the run goes on).")
                    .clicked()
            {
                c.reset = c.reset.wrapping_add(1);
            }
            if ui.button("fit view").clicked() {
                self.fitted = false;
            }
            if ui
                .button("start view")
                .on_hover_text(
                    "Turn back to the start view: the device frame is the scene's again.",
                )
                .clicked()
            {
                self.camera.yaw = self.home.yaw;
                self.camera.pitch = self.home.pitch;
            }
        });
        if *c != before {
            self.link.controls.write(*c);
        }
        ui.separator();
        if ui.input(|i| i.key_pressed(egui::Key::C)) {
            self.clip_on = !self.clip_on;
        }
        ui.checkbox(&mut self.clip_on, "clip plane (C)")
            .on_hover_text("Cut the view open across an axis: the section shows the regions.");
        if self.clip_on {
            ui.horizontal(|ui| {
                for (k, name) in ["x", "y", "z"].into_iter().enumerate() {
                    if ui.radio(self.clip_axis == k, name).clicked() && self.clip_axis != k {
                        self.clip_axis = k;
                        self.clip_at = None;
                    }
                }
            });
            if let Some((lo, hi)) = self.bounds {
                let k = self.clip_axis;
                let mut at = self.clip_at.unwrap_or_else(|| self.work_centre(k));
                if ui
                    .add(egui::Slider::new(&mut at, lo[k]..=hi[k]).text("at"))
                    .changed()
                {
                    self.clip_at = Some(at);
                }
            }
        }
        ui.separator();
        ui.small("drag: orbit   right/middle drag: pan   wheel: zoom");
        ui.small("the stylus moves the tool as it moves on screen: the device frame turns with the orbit");
    }

    /// The centre of the work area (else of the scene) along axis `k`.
    fn work_centre(&self, k: usize) -> f32 {
        self.work
            .or(self.bounds)
            .map_or(0.0, |(lo, hi)| 0.5 * (lo[k] + hi[k]))
    }

    /// The clip plane of this frame, seen from `camera`, when it is on.
    fn clip_plane(&self, camera: &Camera) -> Option<super::gl::ClipPlane> {
        let k = self.clip_axis;
        self.clip_on.then(|| {
            super::gl::ClipPlane::facing(
                k,
                self.clip_at.unwrap_or_else(|| self.work_centre(k)),
                camera.eye(),
            )
        })
    }

    /// Hands the egocentric camera `C` of the current orbit to the servo when it changed
    /// (a triple-buffer write: the servo takes it on its next tick, nobody waits).
    fn publish_camera(&mut self) {
        let Some(out) = self.link.camera.as_mut() else {
            return;
        };
        let c = self.camera.egocentric(&self.home);
        if c != self.published {
            out.write(c);
            self.published = c;
        }
    }

    fn view(&mut self, ui: &mut egui::Ui) {
        let (rect, resp) = ui.allocate_exact_size(ui.available_size(), egui::Sense::drag());
        let h = rect.height().max(1.0);
        if resp.dragged_by(egui::PointerButton::Primary) {
            let d = resp.drag_delta();
            self.camera.orbit(d.x / h * 3.0, d.y / h * 3.0);
        }
        if resp.dragged_by(egui::PointerButton::Secondary)
            || resp.dragged_by(egui::PointerButton::Middle)
        {
            let d = resp.drag_delta();
            self.camera.pan(d.x / h, d.y / h);
        }
        if resp.hovered() {
            let scroll = ui.input(|i| i.smooth_scroll_delta.y);
            if scroll != 0.0 {
                self.camera.zoom((-scroll * 0.002).exp());
            }
        }
        self.publish_camera();
        let side = Arc::clone(&self.side);
        let camera = self.camera;
        let clip_plane = self.clip_plane(&camera);
        let cb = egui_glow::CallbackFn::new(move |info, painter| {
            let t0 = Instant::now();
            let mut guard = lock(&side);
            let s = &mut *guard;
            if let Some(r) = s.renderer.as_mut() {
                let vp = info.viewport_in_pixels();
                let clip = info.clip_rect_in_pixels();
                let gl = painter.gl();
                r.sync(gl, &mut s.scene);
                r.paint_callback(
                    gl,
                    &s.scene,
                    &camera,
                    [vp.left_px, vp.from_bottom_px, vp.width_px, vp.height_px],
                    [
                        clip.left_px,
                        clip.from_bottom_px,
                        clip.width_px,
                        clip.height_px,
                    ],
                    DrawOptions {
                        tool: true,
                        clear: true,
                        clip: clip_plane,
                    },
                );
            }
            let ms = t0.elapsed().as_secs_f64() * 1000.0;
            s.frame_ms = ms;
            s.draws += 1;
            s.draw_ms_sum += ms;
            s.draw_ms_max = s.draw_ms_max.max(ms);
        });
        ui.painter().add(egui::PaintCallback {
            rect,
            callback: Arc::new(cb),
        });
    }
}

/// The angle of the rotation `c` (column-major), degrees.
fn turn_degrees(c: &[f32; 16]) -> f32 {
    let trace = c[0] + c[5] + c[10];
    (0.5 * (trace - 1.0)).clamp(-1.0, 1.0).acos().to_degrees()
}

fn push(q: &mut VecDeque<f32>, v: f32) {
    if q.len() == PLOT_SAMPLES {
        q.pop_front();
    }
    q.push_back(v);
}

/// A small line plot of `values`, scaled to their maximum.
fn sparkline(ui: &mut egui::Ui, values: &VecDeque<f32>, color: egui::Color32) {
    let (rect, _) =
        ui.allocate_exact_size(egui::vec2(ui.available_width(), 60.0), egui::Sense::hover());
    let p = ui.painter_at(rect);
    p.rect_filled(rect, 2.0, egui::Color32::from_gray(24));
    let max = values.iter().copied().fold(0.0f32, f32::max).max(1e-6);
    let n = values.len().max(2) as f32 - 1.0;
    let pts: Vec<egui::Pos2> = values
        .iter()
        .enumerate()
        .map(|(i, v)| {
            egui::pos2(
                rect.left() + rect.width() * i as f32 / n,
                rect.bottom() - rect.height() * (v / max).clamp(0.0, 1.0) * 0.9,
            )
        })
        .collect();
    p.add(egui::Shape::line(pts, egui::Stroke::new(1.5, color)));
    p.text(
        rect.left_top() + egui::vec2(4.0, 2.0),
        egui::Align2::LEFT_TOP,
        format!("max {max:.2}"),
        egui::FontId::monospace(11.0),
        egui::Color32::GRAY,
    );
}
