//! The viewer: the device frame its camera drives, its controls reaching the real-time tasks,
//! and its headless renders; one test binary, a module per file.

mod viewer_controls;
mod viewer_frame;
mod viewer_render;
mod viewer_section;
mod viewer_smooth;
