//! Camera frames (Praktikum report, section 5): the camera `C = M . T` (model-view times
//! trackball); the device reports the pen in egocentric (camera) coordinates `P_e`; the scene pose
//! is the allocentric `P_a`, the report's row-vector `P_e . C`, which is `C * P_e` with glam's
//! column vectors. Forces computed in the scene go back to the device through `C`'s inverse.

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
