//! Camera frames (Praktikum report, section 5): the camera `C = M . T` (model-view times
//! trackball); the device reports the pen in egocentric (camera) coordinates `P_e`; the scene pose
//! is the allocentric `P_a`, the report's row-vector `P_e . C`, which is `C * P_e` with glam's
//! column vectors. Forces computed in the scene go back to the device through `C`'s inverse.
//!
//! ```
//! use glam::Mat4;
//! use tetradrill_core::force::frames::{allocentric, camera, force_to_device};
//! use tetradrill_core::Vec3;
//!
//! // A camera turned a quarter about z, the trackball untouched.
//! let c = camera(Mat4::from_rotation_z(core::f32::consts::FRAC_PI_2), Mat4::IDENTITY);
//! // The pen 0.1 along the device's x is 0.1 along the scene's y ...
//! let pen = allocentric(c, Mat4::from_translation(Vec3::new(0.1, 0.0, 0.0)));
//! assert!((pen.w_axis.truncate() - Vec3::new(0.0, 0.1, 0.0)).length() < 1e-6);
//! // ... and a force along the scene's y is one along the device's x.
//! assert!((force_to_device(c, Vec3::Y) - Vec3::X).length() < 1e-6);
//! ```

use glam::{Mat4, Vec3};

/// The camera `C = M . T` (column-vector order: the trackball acts first).
///
/// # Bounded work
/// Constant.
#[inline]
pub fn camera(model_view: Mat4, trackball: Mat4) -> Mat4 {
    model_view * trackball
}

/// The allocentric (scene) pose of the pen from its egocentric pose.
///
/// # Bounded work
/// Constant.
#[inline]
pub fn allocentric(camera: Mat4, pen_ego: Mat4) -> Mat4 {
    camera * pen_ego
}

/// A scene-frame force mapped into the device's (egocentric) frame: the inverse of `C`'s
/// linear part. A singular camera gives zero.
///
/// # Bounded work
/// Constant (one 4x4 inverse).
#[inline]
pub fn force_to_device(camera: Mat4, force_scene: Vec3) -> Vec3 {
    if camera.determinant().abs() <= f32::MIN_POSITIVE {
        return Vec3::ZERO;
    }
    let v = camera.inverse().transform_vector3(force_scene);
    if v.is_finite() {
        v
    } else {
        Vec3::ZERO
    }
}
