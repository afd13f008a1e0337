//! The orbit camera (z up, as the meshes and the demo path are) and the little matrix algebra
//! it needs. Matrices are column-major `[f32; 16]`, as OpenGL takes them.

use tetradrill_core::Vec3;

use crate::tasks::frame_mat;

/// A camera orbiting `target` at `distance`, `yaw` radians around z (0 = looking along -x
/// from +x) and `pitch` radians above the xy plane.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Camera {
    /// The point looked at.
    pub target: Vec3,
    /// Distance from the target.
    pub distance: f32,
    /// Azimuth around z, radians.
    pub yaw: f32,
    /// Elevation, radians (kept within +-89 degrees).
    pub pitch: f32,
    /// Vertical field of view, radians.
    pub fov_y: f32,
}

impl Default for Camera {
    fn default() -> Self {
        Self {
            target: Vec3::ZERO,
            distance: 3.0,
            yaw: (-60f32).to_radians(),
            pitch: 35f32.to_radians(),
            fov_y: 40f32.to_radians(),
        }
    }
}

impl Camera {
    /// The default view direction, framing the box `lo..hi`.
    pub fn framing(lo: Vec3, hi: Vec3) -> Self {
        let mut c = Self::default();
        c.fit(lo, hi);
        c
    }

    /// Looks at the centre of `lo..hi` from far enough to see all of it.
    pub fn fit(&mut self, lo: Vec3, hi: Vec3) {
        self.target = 0.5 * (lo + hi);
        let r = (0.5 * (hi - lo).length()).max(1e-6);
        self.distance = 1.15 * r / (0.5 * self.fov_y).sin();
    }

    /// The eye position.
    pub fn eye(&self) -> Vec3 {
        let (sp, cp) = self.pitch.sin_cos();
        let (sy, cy) = self.yaw.sin_cos();
        self.target + self.distance * Vec3::new(cp * cy, cp * sy, sp)
    }

    /// Orbits by `dx`, `dy` radians.
    pub fn orbit(&mut self, dx: f32, dy: f32) {
        self.yaw -= dx;
        let lim = 89f32.to_radians();
        self.pitch = (self.pitch + dy).clamp(-lim, lim);
    }

    /// Moves the target within the view plane by `dx`, `dy` (fractions of the view height).
    pub fn pan(&mut self, dx: f32, dy: f32) {
        let (right, up, _) = self.basis();
        let h = 2.0 * self.distance * (0.5 * self.fov_y).tan();
        self.target += (-dx * right + dy * up) * h;
    }

    /// Zooms by `factor` (< 1 comes closer).
    pub fn zoom(&mut self, factor: f32) {
        self.distance = (self.distance * factor).clamp(1e-4, 1e6);
    }

    /// Right, up and forward unit vectors of the view.
    pub fn basis(&self) -> (Vec3, Vec3, Vec3) {
        let f = (self.target - self.eye()).normalize_or_zero();
        let r = f.cross(Vec3::Z).normalize_or_zero();
        let r = if r == Vec3::ZERO { Vec3::X } else { r };
        (r, r.cross(f), f)
    }

    /// The view matrix.
    pub fn view(&self) -> [f32; 16] {
        let (r, u, f) = self.basis();
        let e = self.eye();
        [
            r.x,
            u.x,
            -f.x,
            0.0,
            r.y,
            u.y,
            -f.y,
            0.0,
            r.z,
            u.z,
            -f.z,
            0.0,
            -r.dot(e),
            -u.dot(e),
            f.dot(e),
            1.0,
        ]
    }

    /// The projection for a viewport of `aspect` = width / height.
    pub fn projection(&self, aspect: f32) -> [f32; 16] {
        let near = (self.distance * 0.01).max(1e-5);
        let far = self.distance * 10.0 + 10.0;
        let t = 1.0 / (0.5 * self.fov_y).tan();
        let a = aspect.max(1e-6);
        let mut m = [0.0; 16];
        m[0] = t / a;
        m[5] = t;
        m[10] = (far + near) / (near - far);
        m[11] = -1.0;
        m[14] = 2.0 * far * near / (near - far);
        m
    }

    /// The view's rotation from eye to scene coordinates, column-major, no translation: its
    /// columns are the screen's right, the screen's up, and the direction towards the viewer
    /// (the inverse, and transpose, of the view matrix's rotation).
    pub fn eye_to_scene(&self) -> [f32; 16] {
        let (r, u, f) = self.basis();
        [
            r.x, r.y, r.z, 0.0, u.x, u.y, u.z, 0.0, -f.x, -f.y, -f.z, 0.0, 0.0, 0.0, 0.0, 1.0,
        ]
    }

    /// The egocentric camera `C` of this view relative to `home` (Praktikum report, section 5, with
    /// core's [`frames::camera`](tetradrill_core::force::frames::camera)): the rotation taking a
    /// device displacement, in the scene frame as `home` shows it, to the scene displacement
    /// that this view shows the same way on screen. `C = E * H^T` with `E` this view's
    /// eye-to-scene rotation and `H^T` the home view's scene-to-eye rotation; exactly the
    /// identity when the orientation is `home`'s. Only the orbit (yaw, pitch) enters it: pan
    /// and zoom do not (see docs/VIEWER.md).
    pub fn egocentric(&self, home: &Camera) -> [f32; 16] {
        if self.yaw == home.yaw && self.pitch == home.pitch {
            return crate::tasks::IDENTITY;
        }
        let e = self.eye_to_scene();
        let h = home.eye_to_scene();
        let mut ht = [0.0f32; 16];
        for c in 0..4 {
            for r in 0..4 {
                ht[c * 4 + r] = h[r * 4 + c];
            }
        }
        let m = tetradrill_core::force::frames::camera(frame_mat(&e), frame_mat(&ht));
        *m.as_ref()
    }

    /// Projection times view.
    pub fn view_projection(&self, aspect: f32) -> [f32; 16] {
        mul(&self.projection(aspect), &self.view())
    }
}

/// `a * b` for column-major 4x4 matrices.
pub fn mul(a: &[f32; 16], b: &[f32; 16]) -> [f32; 16] {
    let mut m = [0.0; 16];
    for c in 0..4 {
        for r in 0..4 {
            m[c * 4 + r] = (0..4).map(|k| a[k * 4 + r] * b[c * 4 + k]).sum();
        }
    }
    m
}

/// `m * (p, 1)` divided by w: normalised device coordinates (`None` behind the eye).
pub fn project(m: &[f32; 16], p: Vec3) -> Option<Vec3> {
    let x = m[0] * p.x + m[4] * p.y + m[8] * p.z + m[12];
    let y = m[1] * p.x + m[5] * p.y + m[9] * p.z + m[13];
    let z = m[2] * p.x + m[6] * p.y + m[10] * p.z + m[14];
    let w = m[3] * p.x + m[7] * p.y + m[11] * p.z + m[15];
    (w > 1e-9).then(|| Vec3::new(x / w, y / w, z / w))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_target_projects_to_the_centre_and_the_eye_looks_at_it() {
        let c = Camera::framing(Vec3::splat(-1.0), Vec3::splat(1.0));
        let m = c.view_projection(1.5);
        let t = project(&m, c.target).expect("in front");
        assert!(t.x.abs() < 1e-5 && t.y.abs() < 1e-5 && t.z > -1.0 && t.z < 1.0);
        // Up in the world is up on the screen.
        let up = project(&m, c.target + 0.1 * Vec3::Z).expect("in front");
        assert!(up.y > 0.0);
        // Every corner of the framed box is on screen.
        for i in 0..8 {
            let p = Vec3::new(
                if i & 1 == 0 { -1.0 } else { 1.0 },
                if i & 2 == 0 { -1.0 } else { 1.0 },
                if i & 4 == 0 { -1.0 } else { 1.0 },
            );
            let q = project(&m, p).expect("in front");
            assert!(q.x.abs() < 1.0 && q.y.abs() < 1.0, "{p} -> {q}");
        }
    }

    #[test]
    fn the_egocentric_camera_is_the_identity_at_home_and_a_rotation_elsewhere() {
        let home = Camera::default();
        let mut c = home;
        c.pan(0.3, -0.2);
        c.zoom(0.5);
        // Pan and zoom do not enter C.
        assert_eq!(c.egocentric(&home), crate::tasks::IDENTITY);
        c.orbit(0.7, -0.4);
        let m = c.egocentric(&home);
        assert_ne!(m, crate::tasks::IDENTITY);
        let mut frame = crate::tasks::DeviceFrame::default();
        assert!(frame.set_camera(&m), "{m:?} is a rotation");
        // The eye-to-scene rotation undoes the view's rotation.
        let v = c.view();
        let e = c.eye_to_scene();
        let mut vr = v;
        vr[12] = 0.0;
        vr[13] = 0.0;
        vr[14] = 0.0;
        let i = mul(&vr, &e);
        for (k, x) in i.iter().enumerate() {
            let want = if k % 5 == 0 { 1.0 } else { 0.0 };
            assert!((x - want).abs() < 1e-6, "{k}: {x}");
        }
    }
}
