//! The viewer's OpenGL: the renderer (one shader, the surface in one vertex buffer updated by
//! chunk runs, the burr with its neck and shank, the force arrow, the clip plane's section)
//! and the headless EGL context with its offscreen framebuffer (`offscreen.rs`).
//!
//! Light: a hemisphere term (brighter facing up, the meshes' +z), a key light from above and
//! beside the camera, and a little headlight; all grey, so a lit colour keeps its hue. Drilled
//! faces are their region's colour, darker, and take less of the hemisphere (a cavity's walls
//! see less of the sky); without regions they are the palette's `drilled` colour.
//!
//! The clip plane (`ClipPlane`) discards the surface on the camera's side. Where the view
//! then looks into the solid, the first face behind the plane is seen from inside (the
//! surface winds counter-clockwise seen from outside): that fragment draws the section
//! instead, at the ray's point on the plane, coloured by region from the label grid
//! (`super::labels`, a 3D texture). The outline of the section is the surface's own, a
//! drilled cavity included; the boundaries between regions are at the grid's resolution.

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
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct DrawOptions {
    /// Draw the tool and the force arrow.
    pub tool: bool,
    /// Clear the viewport to the background first.
    pub clear: bool,
    /// Cut the view open: the surface where `normal . x > d` is not drawn and the section on
    /// the plane is.
    pub clip: Option<ClipPlane>,
}

/// A clip plane: what lies where `normal . x > d` is cut away.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ClipPlane {
    /// Unit normal, pointing into the part cut away.
    pub normal: Vec3,
    /// Offset: the plane is `normal . x = d`.
    pub d: f32,
}

impl ClipPlane {
    /// The plane across `axis` (0, 1, 2) at `at`, cutting away the side `eye` is on.
    pub fn facing(axis: usize, at: f32, eye: Vec3) -> ClipPlane {
        let mut normal = Vec3::ZERO;
        normal[axis.min(2)] = 1.0;
        if eye[axis.min(2)] < at {
            normal = -normal;
        }
        ClipPlane {
            normal,
            d: normal[axis.min(2)] * at,
        }
    }
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
uniform vec3 u_light;
uniform vec3 u_color0;
uniform vec3 u_color1;
uniform vec3 u_regions[7];
uniform vec4 u_clip;
uniform int u_mode;
uniform int u_regioned;
uniform int u_has_grid;
uniform vec3 u_grid_origin;
uniform float u_grid_cell;
uniform usampler3D u_labels;
out vec4 o_color;

// The colour of mesh slot `slot` (0: the surface's, the smallest label's).
vec3 slot_colour(float slot) {
    return slot > 0.5 ? u_regions[int(slot) - 1] : u_color0;
}

// Grey light: hemisphere (up is +z), key light, a little headlight; `sky` scales the
// hemisphere (less for a cavity's walls).
float light(vec3 n, vec3 to_eye, float sky) {
    if (dot(n, to_eye) < 0.0) n = -n;
    float hemi = mix(0.22, 0.46, 0.5 + 0.5 * n.z);
    float key = max(dot(n, u_light), 0.0);
    float head = abs(dot(n, to_eye));
    return hemi * sky + 0.40 * key + 0.20 * head;
}

void main() {
    bool clipping = any(notEqual(u_clip.xyz, vec3(0.0)));
    if (u_mode == 0 && clipping && dot(u_clip.xyz, v_world) > u_clip.w) discard;
    vec3 to_eye = normalize(u_eye - v_world);
    if (u_mode == 0 && clipping && !gl_FrontFacing) {
        // The inside of the solid seen through the cut (the surface winds counter-clockwise
        // seen from outside): the section. Its point on the plane along this ray, coloured
        // by the region of the grid's cell there, lit as a face towards the camera.
        vec3 ray = v_world - u_eye;
        float t = (u_clip.w - dot(u_clip.xyz, u_eye)) / dot(u_clip.xyz, ray);
        vec3 p = u_eye + clamp(t, 0.0, 1.0) * ray;
        float slot = 0.0;
        if (u_has_grid == 1) {
            ivec3 dims = textureSize(u_labels, 0);
            ivec3 q = clamp(ivec3(floor((p - u_grid_origin) / u_grid_cell)), ivec3(0), dims - 1);
            slot = float(texelFetch(u_labels, q, 0).r);
        }
        vec3 c = slot > 0.5 ? slot_colour(slot - 1.0) : u_color0;
        o_color = vec4(c * light(-u_clip.xyz, to_eye, 1.0), 1.0);
        return;
    }
    vec3 n = normalize(v_normal);
    // The flag is drilled (0 or 1) + 2 x the region's colour slot.
    float slot = floor((v_flag + 0.5) / 2.0);
    float drilled = clamp(v_flag - 2.0 * slot, 0.0, 1.0);
    vec3 c0 = u_color0;
    vec3 c1 = u_color1;
    if (slot > 0.5) {
        c0 = u_regions[int(slot) - 1];
    }
    if (slot > 0.5 || u_regioned == 1) {
        c1 = 0.72 * c0;
    }
    vec3 c = mix(c0, c1, drilled);
    o_color = vec4(c * light(n, to_eye, mix(1.0, 0.75, drilled)), 1.0);
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
    /// A unit cylinder along +z (the burr's neck and shank).
    cylinder: Mesh,
    /// The label grid as a 3D texture, and the grid it was made from.
    labels: Option<glow::Texture>,
    labels_of: Option<super::labels::LabelGridRef>,
    u_vp: Option<glow::UniformLocation>,
    u_model: Option<glow::UniformLocation>,
    u_eye: Option<glow::UniformLocation>,
    u_color0: Option<glow::UniformLocation>,
    u_color1: Option<glow::UniformLocation>,
    u_regions: Option<glow::UniformLocation>,
    u_light: Option<glow::UniformLocation>,
    u_clip: Option<glow::UniformLocation>,
    u_mode: Option<glow::UniformLocation>,
    u_regioned: Option<glow::UniformLocation>,
    u_has_grid: Option<glow::UniformLocation>,
    u_grid_origin: Option<glow::UniformLocation>,
    u_grid_cell: Option<glow::UniformLocation>,
    u_labels: Option<glow::UniformLocation>,
    /// Bytes uploaded by the last [`Renderer::sync`].
    pub last_upload_bytes: usize,
}

/// The `#version` line for `gl`'s shading language.
fn shader_header(gl: &glow::Context) -> &'static str {
    if gl.version().is_embedded {
        "#version 300 es\nprecision highp float;\nprecision highp int;\nprecision highp usampler3D;\n"
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
            let cylinder = new_mesh(gl, &cylinder_vertices(20))?;
            Ok(Self {
                u_vp: gl.get_uniform_location(program, "u_vp"),
                u_model: gl.get_uniform_location(program, "u_model"),
                u_eye: gl.get_uniform_location(program, "u_eye"),
                u_color0: gl.get_uniform_location(program, "u_color0"),
                u_color1: gl.get_uniform_location(program, "u_color1"),
                u_regions: gl.get_uniform_location(program, "u_regions"),
                u_light: gl.get_uniform_location(program, "u_light"),
                u_clip: gl.get_uniform_location(program, "u_clip"),
                u_mode: gl.get_uniform_location(program, "u_mode"),
                u_regioned: gl.get_uniform_location(program, "u_regioned"),
                u_has_grid: gl.get_uniform_location(program, "u_has_grid"),
                u_grid_origin: gl.get_uniform_location(program, "u_grid_origin"),
                u_grid_cell: gl.get_uniform_location(program, "u_grid_cell"),
                u_labels: gl.get_uniform_location(program, "u_labels"),
                program,
                surface,
                surface_floats: 0,
                sphere,
                arrow,
                tool,
                tool_shape: None,
                cylinder,
                labels: None,
                labels_of: None,
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
        let same_labels = match (&scene.labels, &self.labels_of) {
            (Some(a), Some(b)) => Arc::ptr_eq(a, b),
            (None, None) => true,
            _ => false,
        };
        if !same_labels {
            bytes += self.upload_labels(gl, scene.labels.clone());
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

    /// Replaces the label texture with `grid`'s (none: no texture). Returns the bytes sent.
    fn upload_labels(
        &mut self,
        gl: &glow::Context,
        grid: Option<super::labels::LabelGridRef>,
    ) -> usize {
        // SAFETY: `gl` is current; the texture is ours (made here, deleted here or in
        // `destroy`); the data holds `dims` cells, one byte each, rows packed (alignment 1).
        unsafe {
            if let Some(t) = self.labels.take() {
                gl.delete_texture(t);
            }
            self.labels_of = grid.clone();
            let Some(g) = grid else {
                return 0;
            };
            let Ok(t) = gl.create_texture() else {
                return 0;
            };
            gl.bind_texture(glow::TEXTURE_3D, Some(t));
            for p in [glow::TEXTURE_MIN_FILTER, glow::TEXTURE_MAG_FILTER] {
                gl.tex_parameter_i32(glow::TEXTURE_3D, p, glow::NEAREST as i32);
            }
            for p in [
                glow::TEXTURE_WRAP_S,
                glow::TEXTURE_WRAP_T,
                glow::TEXTURE_WRAP_R,
            ] {
                gl.tex_parameter_i32(glow::TEXTURE_3D, p, glow::CLAMP_TO_EDGE as i32);
            }
            gl.pixel_store_i32(glow::UNPACK_ALIGNMENT, 1);
            let [x, y, z] = g.dims.map(|d| d as i32);
            gl.tex_image_3d(
                glow::TEXTURE_3D,
                0,
                glow::R8UI as i32,
                x,
                y,
                z,
                0,
                glow::RED_INTEGER,
                glow::UNSIGNED_BYTE,
                glow::PixelUnpackData::Slice(Some(&g.cells)),
            );
            gl.bind_texture(glow::TEXTURE_3D, None);
            self.labels = Some(t);
            g.cells.len()
        }
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
        // The key light: from above and to the left of the camera.
        let (right, up, fwd) = camera.basis();
        let light = (up * 0.9 - right * 0.5 - fwd * 0.6).normalize_or_zero();
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
        let clip = opts.clip;
        let clip_v = clip.map_or([0.0; 4], |c| [c.normal.x, c.normal.y, c.normal.z, c.d]);
        // SAFETY: `gl` is current; the program, vertex arrays and texture are ours; draw counts
        // are within the buffers (the surface's vertex count is set by `sync` from the data
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
            gl.uniform_3_f32(self.u_light.as_ref(), light.x, light.y, light.z);
            gl.uniform_4_f32_slice(self.u_clip.as_ref(), &clip_v);
            gl.uniform_1_i32(self.u_mode.as_ref(), 0);
            gl.uniform_1_i32(self.u_regioned.as_ref(), i32::from(scene.regions.is_some()));
            let regions: Vec<f32> = p.regions.iter().flatten().copied().collect();
            gl.uniform_3_f32_slice(self.u_regions.as_ref(), &regions);
            let grid = scene.labels.as_ref().filter(|_| self.labels.is_some());
            gl.uniform_1_i32(self.u_has_grid.as_ref(), i32::from(grid.is_some()));
            if let Some(g) = grid {
                gl.active_texture(glow::TEXTURE0);
                gl.bind_texture(glow::TEXTURE_3D, self.labels);
                gl.uniform_1_i32(self.u_labels.as_ref(), 0);
                gl.uniform_3_f32(
                    self.u_grid_origin.as_ref(),
                    g.origin.x,
                    g.origin.y,
                    g.origin.z,
                );
                gl.uniform_1_f32(self.u_grid_cell.as_ref(), g.cell);
            }
            self.draw_mesh(gl, &self.surface, &IDENTITY, p.surface, p.drilled);
            gl.bind_texture(glow::TEXTURE_3D, None);
            // The tool is never clipped.
            gl.uniform_1_i32(self.u_mode.as_ref(), 2);
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
                match t.shaft.filter(|s| s.radius > 0.0 && s.length > s.from) {
                    Some(s) => {
                        // The shaft as its passive points sample it: spheres a radius apart.
                        let n = (((s.length - s.from) / s.radius).ceil() as usize + 1).min(256);
                        for i in 0..n {
                            let c = t.shown
                                + s.axis
                                    * (s.from
                                        + (s.length - s.from) * i as f32 / (n - 1).max(1) as f32);
                            let r = s.radius;
                            let m = [
                                r, 0.0, 0.0, 0.0, 0.0, r, 0.0, 0.0, 0.0, 0.0, r, 0.0, c.x, c.y,
                                c.z, 1.0,
                            ];
                            self.draw_mesh(gl, &self.sphere, &m, p.tool, p.tool);
                        }
                    }
                    None if self.tool_shape.is_none() => {
                        // A round burr's neck and shank along the tool's axis, drawn only (the
                        // burr alone touches): a neck of 0.45 radii for 3 radii, then the shank
                        // of 1.15 radii for 14.
                        let axis = (t.rotation * Vec3::Z).normalize_or_zero();
                        let neck_at = t.shown + axis * (0.8 * r);
                        let m = arrow_model(neck_at, axis, 3.2 * r, 0.45 * r);
                        self.draw_mesh(gl, &self.cylinder, &m, p.tool, p.tool);
                        let shank_at = neck_at + axis * (3.2 * r);
                        let m = arrow_model(shank_at, axis, 14.0 * r, 1.15 * r);
                        self.draw_mesh(gl, &self.cylinder, &m, SHANK, SHANK);
                    }
                    None => {}
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
            if let Some(t) = self.labels {
                gl.delete_texture(t);
            }
            for m in [
                &self.surface,
                &self.sphere,
                &self.arrow,
                &self.tool,
                &self.cylinder,
            ] {
                gl.delete_vertex_array(m.vao);
                gl.delete_buffer(m.vbo);
            }
        }
    }
}

/// The shank's grey.
const SHANK: [f32; 3] = [0.62, 0.64, 0.68];

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
    for j in 0..segments {
        let (u, v) = (ring(j, segments), ring(j + 1, segments));
        let h = 0.7;
        push_side(&mut out, u, v, 0.35, h);
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

/// A cylinder of radius 1 along +z from 0 to 1, open ends, smooth normals.
fn cylinder_vertices(segments: u32) -> Vec<f32> {
    let mut out = Vec::new();
    for j in 0..segments {
        push_side(&mut out, ring(j, segments), ring(j + 1, segments), 1.0, 1.0);
    }
    out
}

/// The unit direction of corner `j` of a ring of `segments` around +z, in the xy plane.
fn ring(j: u32, segments: u32) -> Vec3 {
    let ph = std::f32::consts::TAU * j as f32 / segments as f32;
    Vec3::new(ph.cos(), ph.sin(), 0.0)
}

/// One side quad of a cylinder of `radius` from 0 to `height` along +z between the ring
/// directions `u` and `v` (two triangles, normals outward).
fn push_side(out: &mut Vec<f32>, u: Vec3, v: Vec3, radius: f32, height: f32) {
    let (a, b) = (u * radius, v * radius);
    let (c, d) = (a + Vec3::Z * height, b + Vec3::Z * height);
    for (p, n) in [(a, u), (b, v), (d, v), (a, u), (d, v), (c, u)] {
        push_vertex(out, p, n);
    }
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
