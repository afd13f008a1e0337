//! The device frame and the workspace map: where the device's positions land in the scene, how
//! scene forces go back to the device, and the camera hand-off that turns the frame with the view.

use tetradrill_core::{Quat, Vec3};

/// The identity, column-major: the camera `C` when no viewer turns the device frame.
pub const IDENTITY: [f32; 16] = [
    1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0,
];

/// How far a published camera may be from a rotation (`|C^T C - I|` per entry, and the
/// translation and the last row) before the servo refuses it.
pub const ROTATION_TOLERANCE: f32 = 1e-3;

/// A column-major 4x4 matrix as the glam matrix core's `force::frames` functions take (this
/// crate does not name glam; the layout is the one OpenGL and [`crate::viewer::camera`] use).
pub(crate) fn frame_mat<M: Default + AsMut<[f32; 16]>>(cols: &[f32; 16]) -> M {
    let mut m = M::default();
    m.as_mut().copy_from_slice(cols);
    m
}

/// The egocentric frame of the device (Praktikum report, section 5): the device reports the
/// pen in egocentric coordinates, the scene pose is `P_a = C * P_e` (core's
/// [`allocentric`](tetradrill_core::force::frames::allocentric)), and a scene force goes back
/// through `C`'s inverse ([`force_to_device`](tetradrill_core::force::frames::force_to_device)).
///
/// `C` is a pure rotation (the viewer's orbit relative to its start view; pan and zoom do not
/// enter it): the device frame is the scene frame as the start view shows it, so without a
/// viewer `C` is the identity and the map is exactly [`Workspace::to_mesh`]. `C` turns the
/// device's displacement about `pivot`, the workspace centre (the mesh's centre, which the
/// camera orbits), so the tool stays at the same place on screen while the view turns, and
/// never swings away from the mesh as a turn about the mesh origin would.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DeviceFrame {
    camera: [f32; 16],
    identity: bool,
    /// The point `C` turns about, mesh units.
    pub pivot: Vec3,
}

impl Default for DeviceFrame {
    fn default() -> Self {
        Self::new(Vec3::ZERO)
    }
}

impl DeviceFrame {
    /// The identity frame turning about `pivot`.
    pub fn new(pivot: Vec3) -> Self {
        Self {
            camera: IDENTITY,
            identity: true,
            pivot,
        }
    }

    /// The camera `C` in use, column-major.
    pub fn camera(&self) -> [f32; 16] {
        self.camera
    }

    /// `C` is the identity: positions and forces pass unchanged.
    pub fn is_identity(&self) -> bool {
        self.identity
    }

    /// Takes `c` as the camera when it is a finite proper rotation (columns orthonormal within
    /// [`ROTATION_TOLERANCE`], determinant +1, no translation); otherwise keeps the camera it
    /// had and returns `false`. A rotation keeps `C`'s inverse equal to its transpose, so the
    /// frame neither adds nor takes power: `F_device . v_device == F_scene . v_scene`.
    ///
    /// # Bounded work
    /// Constant (about 60 flops).
    pub fn set_camera(&mut self, c: &[f32; 16]) -> bool {
        if !is_rotation(c) {
            return false;
        }
        self.camera = *c;
        self.identity = *c == IDENTITY;
        true
    }

    /// A device position (metres, device frame) to the scene: `pivot + C (to_mesh(p) - pivot)`.
    ///
    /// # Bounded work
    /// Constant.
    pub fn to_scene(&self, workspace: &Workspace, p: [f64; 3]) -> Vec3 {
        let m = workspace.to_mesh(p);
        if self.identity {
            return m;
        }
        let t = m - self.pivot;
        let mut pen = IDENTITY;
        pen[12] = t.x;
        pen[13] = t.y;
        pen[14] = t.z;
        let a =
            tetradrill_core::force::frames::allocentric(frame_mat(&self.camera), frame_mat(&pen));
        let a: &[f32; 16] = a.as_ref();
        let q = self.pivot + Vec3::new(a[12], a[13], a[14]);
        if q.is_finite() {
            q
        } else {
            m
        }
    }

    /// A device rotation (unit quaternion `[w, x, y, z]`, device frame) to the scene: `C q`, the
    /// rotation part of `P_a = C P_e`. A quaternion that is not finite or has length zero gives
    /// [`Quat::NAN`] (a mesh tool's law then gives zero force); others are normalised.
    ///
    /// # Bounded work
    /// Constant.
    pub fn rotation_to_scene(&self, q: [f64; 4]) -> Quat {
        let [w, x, y, z] = q.map(|v| v as f32);
        let q = Quat::from_xyzw(x, y, z, w);
        let len = q.length();
        if !(len.is_finite() && len > 0.0) {
            return Quat::NAN;
        }
        let q = q / len;
        if self.identity {
            return q;
        }
        (Quat::from_mat4(&frame_mat(&self.camera)) * q).normalize()
    }

    /// A scene force (newtons) to the device frame: `C^-1 F` (zero for a singular `C`, which
    /// [`set_camera`](Self::set_camera) never takes).
    ///
    /// # Bounded work
    /// Constant (one 4x4 inverse).
    pub fn force_to_device(&self, f: Vec3) -> Vec3 {
        if self.identity {
            return f;
        }
        tetradrill_core::force::frames::force_to_device(frame_mat(&self.camera), f)
    }
}

/// `c` (column-major) is a finite proper rotation without translation.
fn is_rotation(c: &[f32; 16]) -> bool {
    if !c.iter().all(|v| v.is_finite()) {
        return false;
    }
    let tol = ROTATION_TOLERANCE;
    // No translation, last row (0, 0, 0, 1).
    if [c[3], c[7], c[11], c[12], c[13], c[14]]
        .iter()
        .any(|v| v.abs() > tol)
        || (c[15] - 1.0).abs() > tol
    {
        return false;
    }
    let col = |j: usize| Vec3::new(c[4 * j], c[4 * j + 1], c[4 * j + 2]);
    let (x, y, z) = (col(0), col(1), col(2));
    let gram = [
        (x.dot(x), 1.0),
        (y.dot(y), 1.0),
        (z.dot(z), 1.0),
        (x.dot(y), 0.0),
        (x.dot(z), 0.0),
        (y.dot(z), 0.0),
    ];
    gram.iter().all(|(g, want)| (g - want).abs() <= tol) && x.cross(y).dot(z) > 0.0
}

/// Where the device's positions land in the mesh: `mesh = device * scale + offset`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Workspace {
    /// Mesh units per device unit (metre).
    pub scale: f32,
    /// Mesh-space position of the device origin.
    pub offset: Vec3,
}

impl Workspace {
    /// Device position (metres, f64) to mesh units.
    pub fn to_mesh(&self, p: [f64; 3]) -> Vec3 {
        Vec3::new(p[0] as f32, p[1] as f32, p[2] as f32) * self.scale + self.offset
    }
}

/// The servo's end of the camera hand-off: the latest camera `C` the viewer published
/// (column-major), read without waiting.
pub type CameraOut = triple_buffer::Output<[f32; 16]>;
/// The viewer's end of the camera hand-off.
pub type CameraIn = triple_buffer::Input<[f32; 16]>;

/// A camera hand-off starting at the identity (a triple buffer: the last write wins, neither
/// side ever waits).
pub fn camera_handoff() -> (CameraIn, CameraOut) {
    triple_buffer::TripleBuffer::new(&IDENTITY).split()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rot_z(a: f32) -> [f32; 16] {
        let (s, c) = a.sin_cos();
        let mut m = IDENTITY;
        m[0] = c;
        m[1] = s;
        m[4] = -s;
        m[5] = c;
        m
    }

    #[test]
    fn the_default_frame_is_exactly_the_workspace_map() {
        let ws = Workspace {
            scale: 2.5,
            offset: Vec3::new(1.0, -2.0, 0.25),
        };
        let f = DeviceFrame::new(Vec3::new(7.0, 8.0, 9.0));
        assert!(f.is_identity());
        for p in [[0.0, 0.0, 0.0], [-0.0, 0.1, -0.3], [1e-3, -7.0, 2.0]] {
            let a = f.to_scene(&ws, p);
            let b = ws.to_mesh(p);
            assert_eq!(
                a.to_array().map(f32::to_bits),
                b.to_array().map(f32::to_bits)
            );
        }
        let force = Vec3::new(-0.0, 1.5, -2.0);
        assert_eq!(f.force_to_device(force), force);
    }

    #[test]
    fn only_finite_proper_rotations_are_taken() {
        let mut f = DeviceFrame::default();
        let turn = rot_z(0.5);
        assert!(f.set_camera(&turn));
        let mut zoom = turn;
        for v in &mut zoom[..11] {
            *v *= 1.5;
        }
        let mut shifted = turn;
        shifted[12] = 0.5;
        let mut mirror = turn;
        mirror[10] = -1.0;
        let mut nan = turn;
        nan[5] = f32::NAN;
        for bad in [zoom, shifted, mirror, nan, [0.0; 16]] {
            assert!(!f.set_camera(&bad), "{bad:?}");
            assert_eq!(f.camera(), turn, "the old camera stays");
        }
        assert!(f.set_camera(&IDENTITY));
        assert!(f.is_identity());
    }

    #[test]
    fn the_frame_turns_about_its_pivot() {
        let pivot = Vec3::new(10.0, -4.0, 3.0);
        let mut f = DeviceFrame::new(pivot);
        assert!(f.set_camera(&rot_z(std::f32::consts::FRAC_PI_2)));
        let ws = Workspace {
            scale: 1.0,
            offset: Vec3::ZERO,
        };
        // The pivot stays; a point 1 along +x from it goes 1 along +y from it.
        let p = f.to_scene(&ws, [10.0, -4.0, 3.0]);
        assert!((p - pivot).length() < 1e-5, "{p}");
        let q = f.to_scene(&ws, [11.0, -4.0, 3.0]);
        assert!((q - (pivot + Vec3::Y)).length() < 1e-5, "{q}");
        // A force along +y in the scene is a force along +x at the device.
        let d = f.force_to_device(Vec3::Y);
        assert!((d - Vec3::X).length() < 1e-6, "{d}");
    }
}
