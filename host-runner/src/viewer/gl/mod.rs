//! The viewer's OpenGL: the renderer (one shader, the surface in one vertex buffer updated by
//! chunk runs, the tool sphere, the force arrow) and the headless EGL context with its
//! offscreen framebuffer (`offscreen.rs`). Every `unsafe` block of the viewer is in this
//! module: each is a call into OpenGL or EGL on a context that is current on this thread, with
//! objects this module created on that context.

#![allow(unsafe_code)]

use std::sync::Arc;

use eframe::glow::{self, HasContext};
use tetradrill_core::{Quat, Vec3};

use super::camera::{mul, Camera};
use super::handoff::ToolShape;
use super::handoff::REGION_SLOTS;
use super::scene::{Scene, Updates, CHUNK_FLOATS, VERTEX_FLOATS};

mod offscreen;
pub use offscreen::Offscreen;

/// Colours of the view (linear 0..1 RGB).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Palette {
    /// Background.
    pub background: [f32; 3],
    /// Original surface.
    pub surface: [f32; 3],
    /// Drilled surface.
    pub drilled: [f32; 3],
    /// The tool.
    pub tool: [f32; 3],
    /// The force arrow.
    pub force: [f32; 3],
    /// The original surface of regions 1.. (region 0 has `surface`); a region's drilled
    /// surface is its colour halfway to `drilled`.
    pub regions: [[f32; 3]; REGION_SLOTS as usize - 1],
}

/// The palette in use.
pub const PALETTE: Palette = Palette {
    background: [0.11, 0.12, 0.15],
    surface: [0.86, 0.82, 0.70],
    drilled: [0.85, 0.30, 0.22],
    tool: [0.45, 0.62, 0.95],
    force: [0.35, 0.95, 0.40],
    regions: [
        [0.40, 0.55, 0.80],
        [0.45, 0.75, 0.45],
        [0.70, 0.50, 0.80],
        [0.35, 0.75, 0.75],
        [0.90, 0.65, 0.30],
        [0.85, 0.55, 0.65],
        [0.65, 0.65, 0.35],
    ],
};

/// What to draw besides the surface.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DrawOptions {
    /// Draw the tool and the force arrow.
    pub tool: bool,
    /// Clear the viewport to the background first.
    pub clear: bool,
}

const VS: &str = r#"
in vec3 a_pos;
in vec3 a_normal;
in float a_flag;
uniform mat4 u_vp;
uniform mat4 u_model;
out vec3 v_world;
out vec3 v_normal;
out float v_flag;
void main() {
    vec4 w = u_model * vec4(a_pos, 1.0);
    v_world = w.xyz;
    v_normal = mat3(u_model) * a_normal;
    v_flag = a_flag;
    gl_Position = u_vp * w;
}
"#;

const FS: &str = r#"
in vec3 v_world;
in vec3 v_normal;
in float v_flag;
uniform vec3 u_eye;
uniform vec3 u_color0;
uniform vec3 u_color1;
uniform vec3 u_regions[7];
out vec4 o_color;
void main() {
    vec3 n = normalize(v_normal);
    vec3 l = normalize(u_eye - v_world);
    float d = abs(dot(n, l));
    // The flag is drilled (0 or 1) + 2 x the region's colour slot.
    float slot = floor((v_flag + 0.5) / 2.0);
    float drilled = clamp(v_flag - 2.0 * slot, 0.0, 1.0);
    vec3 c0 = u_color0;
    vec3 c1 = u_color1;
    if (slot > 0.5) {
        c0 = u_regions[int(slot) - 1];
        c1 = mix(c0, u_color1, 0.5);
    }
    vec3 c = mix(c0, c1, drilled);
    o_color = vec4(c * (0.28 + 0.72 * d), 1.0);
}
"#;

/// A vertex array with its buffer.
#[derive(Debug)]
struct Mesh {
    vao: glow::VertexArray,
    vbo: glow::Buffer,
    vertices: i32,
}

/// The renderer: owns its GL objects on one context.
#[derive(Debug)]
pub struct Renderer {
    program: glow::Program,
    surface: Mesh,
    surface_floats: usize,
    sphere: Mesh,
    arrow: Mesh,
    /// A mesh tool's triangles, and the shape they were made from.
    tool: Mesh,
    tool_shape: Option<ToolShape>,
    u_vp: Option<glow::UniformLocation>,
    u_model: Option<glow::UniformLocation>,
    u_eye: Option<glow::UniformLocation>,
    u_color0: Option<glow::UniformLocation>,
    u_color1: Option<glow::UniformLocation>,
    u_regions: Option<glow::UniformLocation>,
    /// Bytes uploaded by the last [`Renderer::sync`].
    pub last_upload_bytes: usize,
}

/// The `#version` line for `gl`'s shading language.
fn shader_header(gl: &glow::Context) -> &'static str {
    if gl.version().is_embedded {
        "#version 300 es\nprecision highp float;\n"
    } else {
        "#version 140\n"
    }
}

impl Renderer {
    /// Compiles the shader and creates the buffers on `gl` (current on this thread).
    ///
    /// # Errors
    /// A shader that does not compile or link, or a GL object that cannot be created.
    pub fn new(gl: &glow::Context) -> Result<Self, String> {
        let header = shader_header(gl);
        // SAFETY: `gl` is current on this thread (the caller's contract: eframe's context in
        // its creation callback, or our EGL context); every object is created here.
        unsafe {
            let program = gl.create_program()?;
            let mut shaders = Vec::new();
            for (kind, src) in [(glow::VERTEX_SHADER, VS), (glow::FRAGMENT_SHADER, FS)] {
                let s = gl.create_shader(kind)?;
                gl.shader_source(s, &format!("{header}{src}"));
                gl.compile_shader(s);
                if !gl.get_shader_compile_status(s) {
                    return Err(format!("viewer shader: {}", gl.get_shader_info_log(s)));
                }
                gl.attach_shader(program, s);
                shaders.push(s);
            }
            gl.bind_attrib_location(program, 0, "a_pos");
            gl.bind_attrib_location(program, 1, "a_normal");
            gl.bind_attrib_location(program, 2, "a_flag");
            gl.link_program(program);
            if !gl.get_program_link_status(program) {
                return Err(format!(
                    "viewer shader: {}",
                    gl.get_program_info_log(program)
                ));
            }
            for s in shaders {
                gl.detach_shader(program, s);
                gl.delete_shader(s);
            }
            let surface = new_mesh(gl, &[])?;
            let sphere = new_mesh(gl, &sphere_vertices(12, 20))?;
            let arrow = new_mesh(gl, &arrow_vertices(16))?;
            let tool = new_mesh(gl, &[])?;
            Ok(Self {
                u_vp: gl.get_uniform_location(program, "u_vp"),
                u_model: gl.get_uniform_location(program, "u_model"),
                u_eye: gl.get_uniform_location(program, "u_eye"),
                u_color0: gl.get_uniform_location(program, "u_color0"),
                u_color1: gl.get_uniform_location(program, "u_color1"),
                u_regions: gl.get_uniform_location(program, "u_regions"),
                program,
                surface,
                surface_floats: 0,
                sphere,
                arrow,
                tool,
                tool_shape: None,
                last_upload_bytes: 0,
            })
        }
    }

    /// Brings the GPU copy of the surface up to date with `scene`: the whole buffer after it
    /// grew, else only the runs of changed chunks (`glBufferSubData`).
    pub fn sync(&mut self, gl: &glow::Context, scene: &mut Scene) {
        let mut bytes = 0usize;
        let same = match (&scene.tool_shape, &self.tool_shape) {
            (Some(a), Some(b)) => Arc::ptr_eq(a, b),
            (None, None) => true,
            _ => false,
        };
        if !same {
            let data = scene
                .tool_shape
                .as_deref()
                .map_or(Vec::new(), shape_vertices);
            // SAFETY: `gl` is current; the buffer is ours and is re-specified whole.
            unsafe {
                gl.bind_buffer(glow::ARRAY_BUFFER, Some(self.tool.vbo));
                gl.buffer_data_u8_slice(glow::ARRAY_BUFFER, as_bytes(&data), glow::STATIC_DRAW);
                gl.bind_buffer(glow::ARRAY_BUFFER, None);
            }
            self.tool.vertices = (data.len() / VERTEX_FLOATS) as i32;
            self.tool_shape = scene.tool_shape.clone();
            bytes += 4 * data.len();
        }
        let updates = scene.take_updates();
        // SAFETY: `gl` is current; the buffer is ours; ranges lie within the buffer, whose
        // size is `surface_floats` floats, equal to the scene's data unless it grew (then the
        // whole buffer is re-specified first).
        unsafe {
            gl.bind_buffer(glow::ARRAY_BUFFER, Some(self.surface.vbo));
            let data = scene.data();
            if updates == Updates::Whole || data.len() != self.surface_floats {
                gl.buffer_data_u8_slice(glow::ARRAY_BUFFER, as_bytes(data), glow::DYNAMIC_DRAW);
                self.surface_floats = data.len();
                bytes = 4 * data.len();
            } else if let Updates::Runs(runs) = updates {
                for (first, n) in runs {
                    let lo = first * CHUNK_FLOATS;
                    let hi = (first + n) * CHUNK_FLOATS;
                    gl.buffer_sub_data_u8_slice(
                        glow::ARRAY_BUFFER,
                        (4 * lo) as i32,
                        as_bytes(&data[lo..hi]),
                    );
                    bytes += 4 * (hi - lo);
                }
            }
            gl.bind_buffer(glow::ARRAY_BUFFER, None);
        }
        self.surface.vertices = scene.draw_vertices() as i32;
        self.last_upload_bytes = bytes;
    }

    /// Draws the scene into the current framebuffer's viewport of `width` x `height` pixels
    /// (the caller set `glViewport`).
    pub fn draw(
        &self,
        gl: &glow::Context,
        scene: &Scene,
        camera: &Camera,
        width: u32,
        height: u32,
        opts: DrawOptions,
    ) {
        let vp = camera.view_projection(width as f32 / height.max(1) as f32);
        let eye = camera.eye();
        // The scenario's region colours replace the palette's slots (slot 0 is the surface).
        let mut p = PALETTE;
        if let Some(colours) = &scene.region_colours {
            for (i, c) in colours.iter().enumerate().take(REGION_SLOTS as usize) {
                match (i, c) {
                    (0, Some(c)) => p.surface = *c,
                    (i, Some(c)) => p.regions[i - 1] = *c,
                    _ => {}
                }
            }
        }
        // SAFETY: `gl` is current; the program and vertex arrays are ours; draw counts are
        // within the buffers (the surface's vertex count is set by `sync` from the data
        // uploaded).
        unsafe {
            if opts.clear {
                let b = p.background;
                gl.clear_color(b[0], b[1], b[2], 1.0);
                gl.depth_mask(true);
                gl.clear(glow::COLOR_BUFFER_BIT | glow::DEPTH_BUFFER_BIT);
            }
            gl.enable(glow::DEPTH_TEST);
            gl.depth_func(glow::LESS);
            gl.depth_mask(true);
            gl.disable(glow::CULL_FACE);
            gl.disable(glow::BLEND);
            gl.use_program(Some(self.program));
            gl.uniform_matrix_4_f32_slice(self.u_vp.as_ref(), false, &vp);
            gl.uniform_3_f32(self.u_eye.as_ref(), eye.x, eye.y, eye.z);
            let regions: Vec<f32> = p.regions.iter().flatten().copied().collect();
            gl.uniform_3_f32_slice(self.u_regions.as_ref(), &regions);
            self.draw_mesh(gl, &self.surface, &IDENTITY, p.surface, p.drilled);
            if let Some(t) = scene.tool.filter(|_| opts.tool) {
                let r = t.radius;
                if self.tool_shape.is_some() {
                    let m = pose_model(t.rotation, t.shown);
                    self.draw_mesh(gl, &self.tool, &m, p.tool, p.tool);
                } else {
                    let m = [
                        r, 0.0, 0.0, 0.0, 0.0, r, 0.0, 0.0, 0.0, 0.0, r, 0.0, t.shown.x, t.shown.y,
                        t.shown.z, 1.0,
                    ];
                    self.draw_mesh(gl, &self.sphere, &m, p.tool, p.tool);
                }
                if let Some(s) = t.shaft.filter(|s| s.radius > 0.0 && s.length > s.from) {
                    // The shaft as its passive points sample it: spheres a radius apart.
                    let n = (((s.length - s.from) / s.radius).ceil() as usize + 1).min(256);
                    for i in 0..n {
                        let c = t.shown
                            + s.axis
                                * (s.from + (s.length - s.from) * i as f32 / (n - 1).max(1) as f32);
                        let r = s.radius;
                        let m = [
                            r, 0.0, 0.0, 0.0, 0.0, r, 0.0, 0.0, 0.0, 0.0, r, 0.0, c.x, c.y, c.z,
                            1.0,
                        ];
                        self.draw_mesh(gl, &self.sphere, &m, p.tool, p.tool);
                    }
                }
                let f = t.force.length();
                if f > 1e-6 {
                    let diag = scene.bounds.map_or(1.0, |(lo, hi)| (hi - lo).length());
                    let len = 0.3 * diag * f / (f + 3.0);
                    let dir = t.force / f;
                    let m = arrow_model(t.shown + dir * r, dir, len, 0.1 * r.max(0.01 * diag));
                    self.draw_mesh(gl, &self.arrow, &m, p.force, p.force);
                }
            }
            gl.bind_vertex_array(None);
            gl.use_program(None);
            gl.disable(glow::DEPTH_TEST);
        }
    }

    /// Draws inside an egui paint callback: clears the view's rectangle (`viewport` and
    /// `clip` as `[left, from_bottom, width, height]` pixels), then draws.
    #[allow(clippy::too_many_arguments)]
    pub fn paint_callback(
        &self,
        gl: &glow::Context,
        scene: &Scene,
        camera: &Camera,
        viewport: [i32; 4],
        clip: [i32; 4],
        opts: DrawOptions,
    ) {
        // SAFETY: eframe's context is current during its paint callbacks; egui restores its
        // own state after the callback.
        unsafe {
            gl.viewport(viewport[0], viewport[1], viewport[2], viewport[3]);
            gl.enable(glow::SCISSOR_TEST);
            gl.scissor(clip[0], clip[1], clip[2], clip[3]);
        }
        let (w, h) = (viewport[2].max(1) as u32, viewport[3].max(1) as u32);
        self.draw(gl, scene, camera, w, h, opts);
    }

    /// # Safety
    /// `gl` is current and the program is in use.
    unsafe fn draw_mesh(
        &self,
        gl: &glow::Context,
        mesh: &Mesh,
        model: &[f32; 16],
        c0: [f32; 3],
        c1: [f32; 3],
    ) {
        if mesh.vertices <= 0 {
            return;
        }
        // SAFETY: the caller's contract; the vertex array is ours and holds `vertices`.
        unsafe {
            gl.uniform_matrix_4_f32_slice(self.u_model.as_ref(), false, model);
            gl.uniform_3_f32(self.u_color0.as_ref(), c0[0], c0[1], c0[2]);
            gl.uniform_3_f32(self.u_color1.as_ref(), c1[0], c1[1], c1[2]);
            gl.bind_vertex_array(Some(mesh.vao));
            gl.draw_arrays(glow::TRIANGLES, 0, mesh.vertices);
        }
    }

    /// Deletes the GL objects (on the context that made them).
    pub fn destroy(&self, gl: &glow::Context) {
        // SAFETY: `gl` is current; the objects are ours and not used afterwards.
        unsafe {
            gl.delete_program(self.program);
            for m in [&self.surface, &self.sphere, &self.arrow, &self.tool] {
                gl.delete_vertex_array(m.vao);
                gl.delete_buffer(m.vbo);
            }
        }
    }
}

const IDENTITY: [f32; 16] = [
    1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0,
];

/// # Safety
/// `gl` is current on this thread.
unsafe fn new_mesh(gl: &glow::Context, data: &[f32]) -> Result<Mesh, String> {
    // SAFETY: the caller's contract; the objects are created and configured here.
    unsafe {
        let vao = gl.create_vertex_array()?;
        let vbo = gl.create_buffer()?;
        gl.bind_vertex_array(Some(vao));
        gl.bind_buffer(glow::ARRAY_BUFFER, Some(vbo));
        gl.buffer_data_u8_slice(glow::ARRAY_BUFFER, as_bytes(data), glow::STATIC_DRAW);
        let stride = (VERTEX_FLOATS * 4) as i32;
        gl.vertex_attrib_pointer_f32(0, 3, glow::FLOAT, false, stride, 0);
        gl.vertex_attrib_pointer_f32(1, 3, glow::FLOAT, false, stride, 12);
        gl.vertex_attrib_pointer_f32(2, 1, glow::FLOAT, false, stride, 24);
        for i in 0..3 {
            gl.enable_vertex_attrib_array(i);
        }
        gl.bind_vertex_array(None);
        gl.bind_buffer(glow::ARRAY_BUFFER, None);
        Ok(Mesh {
            vao,
            vbo,
            vertices: (data.len() / VERTEX_FLOATS) as i32,
        })
    }
}

fn as_bytes(v: &[f32]) -> &[u8] {
    // `f32` has no padding and any bit pattern is a valid `u8`.
    let len = std::mem::size_of_val(v);
    // SAFETY: the pointer and length cover exactly `v`'s memory, which outlives the result;
    // `u8` has alignment 1.
    unsafe { std::slice::from_raw_parts(v.as_ptr().cast::<u8>(), len) }
}

fn push_vertex(out: &mut Vec<f32>, p: Vec3, n: Vec3) {
    out.extend_from_slice(&[p.x, p.y, p.z, n.x, n.y, n.z, 0.0]);
}

/// A mesh tool's triangles with flat normals.
fn shape_vertices(tris: &[[Vec3; 3]]) -> Vec<f32> {
    let mut out = Vec::with_capacity(tris.len() * 3 * VERTEX_FLOATS);
    for [a, b, c] in tris {
        let n = (*b - *a).cross(*c - *a).normalize_or_zero();
        for p in [a, b, c] {
            push_vertex(&mut out, *p, n);
        }
    }
    out
}

/// Column-major model matrix: `rotation`, then the shift to `at`.
fn pose_model(rotation: Quat, at: Vec3) -> [f32; 16] {
    let (x, y, z) = (rotation * Vec3::X, rotation * Vec3::Y, rotation * Vec3::Z);
    [
        x.x, x.y, x.z, 0.0, y.x, y.y, y.z, 0.0, z.x, z.y, z.z, 0.0, at.x, at.y, at.z, 1.0,
    ]
}

/// A unit UV sphere, smooth normals.
fn sphere_vertices(rings: u32, segments: u32) -> Vec<f32> {
    let at = |i: u32, j: u32| {
        let th = std::f32::consts::PI * i as f32 / rings as f32;
        let ph = std::f32::consts::TAU * j as f32 / segments as f32;
        Vec3::new(th.sin() * ph.cos(), th.sin() * ph.sin(), th.cos())
    };
    let mut out = Vec::new();
    for i in 0..rings {
        for j in 0..segments {
            let (a, b, c, d) = (at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
            for p in [a, b, c, a, c, d] {
                push_vertex(&mut out, p, p);
            }
        }
    }
    out
}

/// An arrow along +z from 0 to 1: a shaft of radius 0.35 up to 0.7 and a cone of radius 1
/// (the model matrix scales x and y to the arrow's width).
fn arrow_vertices(segments: u32) -> Vec<f32> {
    let mut out = Vec::new();
    let ring = |j: u32| {
        let ph = std::f32::consts::TAU * j as f32 / segments as f32;
        Vec3::new(ph.cos(), ph.sin(), 0.0)
    };
    for j in 0..segments {
        let (u, v) = (ring(j), ring(j + 1));
        let (s, h) = (0.35, 0.7);
        let (a, b) = (u * s, v * s);
        let (c, d) = (a + Vec3::Z * h, b + Vec3::Z * h);
        for (p, n) in [(a, u), (b, v), (d, v), (a, u), (d, v), (c, u)] {
            push_vertex(&mut out, p, n);
        }
        let tip = Vec3::Z;
        let (e, f) = (u + Vec3::Z * h, v + Vec3::Z * h);
        for (p, n) in [(e, u), (f, v), (tip, u + v)] {
            push_vertex(&mut out, p, n);
        }
        for p in [e, Vec3::Z * h, f] {
            push_vertex(&mut out, p, -Vec3::Z);
        }
    }
    out
}

/// Model matrix putting the unit arrow at `origin` along unit `dir`, `len` long, `width` wide.
fn arrow_model(origin: Vec3, dir: Vec3, len: f32, width: f32) -> [f32; 16] {
    let helper = if dir.z.abs() < 0.9 { Vec3::Z } else { Vec3::X };
    let x = dir.cross(helper).normalize_or_zero() * width;
    let y = dir.cross(x).normalize_or_zero() * width;
    let z = dir * len;
    let scale = [x.x, x.y, x.z, 0.0, y.x, y.y, y.z, 0.0, z.x, z.y, z.z, 0.0];
    let t = [
        1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, origin.x, origin.y, origin.z,
        1.0,
    ];
    let mut m = [0.0; 16];
    m[..12].copy_from_slice(&scale);
    m[15] = 1.0;
    mul(&t, &m)
}
