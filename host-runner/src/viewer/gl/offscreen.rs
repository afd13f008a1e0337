//! The headless EGL context and its offscreen framebuffer (no window, no display server).

#![allow(unsafe_code)]

use std::sync::Arc;

use eframe::glow::{self, HasContext};

/// An offscreen OpenGL context (EGL, no window, no display server) with a framebuffer of a
/// fixed size.
#[derive(Debug)]
pub struct Offscreen {
    gl: Arc<glow::Context>,
    fbo: glow::Framebuffer,
    rbos: Vec<glow::Renderbuffer>,
    resolve: Option<(glow::Framebuffer, glow::Renderbuffer)>,
    width: u32,
    height: u32,
    _context: glutin::api::egl::context::PossiblyCurrentContext,
    _display: glutin::api::egl::display::Display,
}

impl Offscreen {
    /// An EGL context without a surface on the first EGL device that gives one (Mesa's
    /// software device on a machine without a GPU), current on this thread, and a `width` x
    /// `height` framebuffer with 4x multisampling when available.
    ///
    /// # Errors
    /// No EGL library, no device, no context, or an incomplete framebuffer.
    pub fn new(width: u32, height: u32) -> Result<Self, String> {
        use glutin::config::{ConfigSurfaceTypes, ConfigTemplateBuilder};
        use glutin::context::{ContextApi, ContextAttributesBuilder, Version};
        use glutin::display::GlDisplay;

        let devices = glutin::api::egl::device::Device::query_devices().map_err(|e| {
            format!("no EGL devices ({e}); install Mesa's EGL (libegl1, libegl-mesa0)")
        })?;
        let mut last = String::from("no EGL device");
        for device in devices {
            // SAFETY: no raw display handle is passed; the display is made from the device.
            let display =
                match unsafe { glutin::api::egl::display::Display::with_device(&device, None) } {
                    Ok(d) => d,
                    Err(e) => {
                        last = format!("EGL display: {e}");
                        continue;
                    }
                };
            let template = ConfigTemplateBuilder::new()
                .with_surface_type(ConfigSurfaceTypes::empty())
                .build();
            // SAFETY: the template holds no raw window handle.
            let config = match unsafe { display.find_configs(template) } {
                Ok(mut c) => match c.next() {
                    Some(c) => c,
                    None => {
                        last = "no EGL config".into();
                        continue;
                    }
                },
                Err(e) => {
                    last = format!("EGL configs: {e}");
                    continue;
                }
            };
            let apis = [
                ContextApi::OpenGl(Some(Version::new(3, 3))),
                ContextApi::Gles(Some(Version::new(3, 0))),
            ];
            for api in apis {
                let attrs = ContextAttributesBuilder::new()
                    .with_context_api(api)
                    .build(None);
                // SAFETY: the attributes hold no raw window handle.
                let ctx = match unsafe { display.create_context(&config, &attrs) } {
                    Ok(c) => c,
                    Err(e) => {
                        last = format!("EGL context: {e}");
                        continue;
                    }
                };
                let ctx = match ctx.make_current_surfaceless() {
                    Ok(c) => c,
                    Err(e) => {
                        last = format!("EGL surfaceless context: {e}");
                        continue;
                    }
                };
                // SAFETY: the context is current on this thread; the loader returns its
                // functions.
                let gl = unsafe {
                    glow::Context::from_loader_function_cstr(|s| display.get_proc_address(s))
                };
                let gl = Arc::new(gl);
                return Self::with_framebuffer(gl, ctx, display, width, height);
            }
        }
        Err(last)
    }

    fn with_framebuffer(
        gl: Arc<glow::Context>,
        context: glutin::api::egl::context::PossiblyCurrentContext,
        display: glutin::api::egl::display::Display,
        width: u32,
        height: u32,
    ) -> Result<Self, String> {
        let (w, h) = (width as i32, height as i32);
        // SAFETY: the context is current on this thread; the objects are created here.
        unsafe {
            let make =
                |samples: i32| -> Result<(glow::Framebuffer, Vec<glow::Renderbuffer>), String> {
                    let fbo = gl.create_framebuffer()?;
                    gl.bind_framebuffer(glow::FRAMEBUFFER, Some(fbo));
                    let mut rbos = Vec::new();
                    for (format, attach) in [
                        (glow::RGBA8, glow::COLOR_ATTACHMENT0),
                        (glow::DEPTH_COMPONENT24, glow::DEPTH_ATTACHMENT),
                    ] {
                        let rb = gl.create_renderbuffer()?;
                        gl.bind_renderbuffer(glow::RENDERBUFFER, Some(rb));
                        if samples > 0 {
                            gl.renderbuffer_storage_multisample(
                                glow::RENDERBUFFER,
                                samples,
                                format,
                                w,
                                h,
                            );
                        } else {
                            gl.renderbuffer_storage(glow::RENDERBUFFER, format, w, h);
                        }
                        gl.framebuffer_renderbuffer(
                            glow::FRAMEBUFFER,
                            attach,
                            glow::RENDERBUFFER,
                            Some(rb),
                        );
                        rbos.push(rb);
                    }
                    if gl.check_framebuffer_status(glow::FRAMEBUFFER) != glow::FRAMEBUFFER_COMPLETE
                    {
                        gl.bind_framebuffer(glow::FRAMEBUFFER, None);
                        gl.delete_framebuffer(fbo);
                        for rb in rbos {
                            gl.delete_renderbuffer(rb);
                        }
                        return Err("incomplete offscreen framebuffer".into());
                    }
                    Ok((fbo, rbos))
                };
            let (fbo, rbos, resolve) = match make(4) {
                Ok((fbo, rbos)) => {
                    let (rfbo, rrb) = match make(0) {
                        Ok((f, mut r)) => {
                            // Only the colour buffer is needed to resolve into.
                            let depth = r.pop();
                            if let Some(d) = depth {
                                gl.bind_framebuffer(glow::FRAMEBUFFER, Some(f));
                                gl.framebuffer_renderbuffer(
                                    glow::FRAMEBUFFER,
                                    glow::DEPTH_ATTACHMENT,
                                    glow::RENDERBUFFER,
                                    None,
                                );
                                gl.delete_renderbuffer(d);
                            }
                            (f, r[0])
                        }
                        Err(e) => return Err(e),
                    };
                    (fbo, rbos, Some((rfbo, rrb)))
                }
                Err(_) => {
                    let (fbo, rbos) = make(0)?;
                    (fbo, rbos, None)
                }
            };
            gl.bind_framebuffer(glow::FRAMEBUFFER, Some(fbo));
            gl.viewport(0, 0, w, h);
            Ok(Self {
                gl,
                fbo,
                rbos,
                resolve,
                width,
                height,
                _context: context,
                _display: display,
            })
        }
    }

    /// The GL context (current on this thread).
    pub fn gl(&self) -> &glow::Context {
        &self.gl
    }

    /// Size in pixels.
    pub fn size(&self) -> (u32, u32) {
        (self.width, self.height)
    }

    /// The renderer's output: binds the framebuffer and sets the viewport.
    pub fn bind(&self) {
        // SAFETY: the context is current; the framebuffer is ours.
        unsafe {
            self.gl.bind_framebuffer(glow::FRAMEBUFFER, Some(self.fbo));
            self.gl
                .viewport(0, 0, self.width as i32, self.height as i32);
        }
    }

    /// The framebuffer's pixels, RGBA, top row first.
    pub fn read_rgba(&self) -> Vec<u8> {
        let (w, h) = (self.width as i32, self.height as i32);
        let mut buf = vec![0u8; (4 * self.width * self.height) as usize];
        // SAFETY: the context is current; the framebuffers are ours; `buf` holds w*h RGBA
        // bytes, and PACK_ALIGNMENT 1 makes rows tightly packed.
        unsafe {
            let gl = &self.gl;
            gl.finish();
            let src = if let Some((rfbo, _)) = self.resolve {
                gl.bind_framebuffer(glow::READ_FRAMEBUFFER, Some(self.fbo));
                gl.bind_framebuffer(glow::DRAW_FRAMEBUFFER, Some(rfbo));
                gl.blit_framebuffer(
                    0,
                    0,
                    w,
                    h,
                    0,
                    0,
                    w,
                    h,
                    glow::COLOR_BUFFER_BIT,
                    glow::NEAREST,
                );
                rfbo
            } else {
                self.fbo
            };
            gl.bind_framebuffer(glow::FRAMEBUFFER, Some(src));
            gl.pixel_store_i32(glow::PACK_ALIGNMENT, 1);
            gl.read_pixels(
                0,
                0,
                w,
                h,
                glow::RGBA,
                glow::UNSIGNED_BYTE,
                glow::PixelPackData::Slice(Some(&mut buf)),
            );
            gl.bind_framebuffer(glow::FRAMEBUFFER, Some(self.fbo));
        }
        // GL's rows go bottom-up.
        let row = 4 * self.width as usize;
        let mut out = Vec::with_capacity(buf.len());
        for r in buf.chunks_exact(row).rev() {
            out.extend_from_slice(r);
        }
        out
    }
}

impl Drop for Offscreen {
    fn drop(&mut self) {
        // SAFETY: the context is still current on this thread (it is dropped after this);
        // the objects are ours.
        unsafe {
            self.gl.bind_framebuffer(glow::FRAMEBUFFER, None);
            self.gl.delete_framebuffer(self.fbo);
            for rb in &self.rbos {
                self.gl.delete_renderbuffer(*rb);
            }
            if let Some((f, r)) = self.resolve {
                self.gl.delete_framebuffer(f);
                self.gl.delete_renderbuffer(r);
            }
        }
    }
}
