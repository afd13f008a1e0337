//! Small f64 vector math for the reference computations of the tests (the workspace's glam is
//! f32 only). It shares no code with the crates under test.

/// A minimal f64 vector for the reference computations (the workspace's glam is f32 only).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DVec3 {
    /// The x coordinate.
    pub x: f64,
    /// The y coordinate.
    pub y: f64,
    /// The z coordinate.
    pub z: f64,
}

impl DVec3 {
    /// The zero vector.
    pub const ZERO: Self = Self {
        x: 0.0,
        y: 0.0,
        z: 0.0,
    };
    /// The dot product.
    pub fn dot(self, o: Self) -> f64 {
        self.x * o.x + self.y * o.y + self.z * o.z
    }
    /// The cross product.
    pub fn cross(self, o: Self) -> Self {
        Self {
            x: self.y * o.z - self.z * o.y,
            y: self.z * o.x - self.x * o.z,
            z: self.x * o.y - self.y * o.x,
        }
    }
    /// The squared length.
    pub fn length_squared(self) -> f64 {
        self.dot(self)
    }
    /// The length.
    pub fn length(self) -> f64 {
        self.length_squared().sqrt()
    }
    /// The vector divided by its length.
    pub fn normalize(self) -> Self {
        self / self.length()
    }
}

impl std::ops::Add for DVec3 {
    type Output = Self;
    fn add(self, o: Self) -> Self {
        Self {
            x: self.x + o.x,
            y: self.y + o.y,
            z: self.z + o.z,
        }
    }
}
impl std::ops::AddAssign for DVec3 {
    fn add_assign(&mut self, o: Self) {
        *self = *self + o;
    }
}
impl std::ops::Sub for DVec3 {
    type Output = Self;
    fn sub(self, o: Self) -> Self {
        Self {
            x: self.x - o.x,
            y: self.y - o.y,
            z: self.z - o.z,
        }
    }
}
impl std::ops::Neg for DVec3 {
    type Output = Self;
    fn neg(self) -> Self {
        Self {
            x: -self.x,
            y: -self.y,
            z: -self.z,
        }
    }
}
impl std::ops::Mul<f64> for DVec3 {
    type Output = Self;
    fn mul(self, s: f64) -> Self {
        Self {
            x: self.x * s,
            y: self.y * s,
            z: self.z * s,
        }
    }
}
impl std::ops::Div<f64> for DVec3 {
    type Output = Self;
    fn div(self, s: f64) -> Self {
        Self {
            x: self.x / s,
            y: self.y / s,
            z: self.z / s,
        }
    }
}

/// Widening of an f32 vector to [`DVec3`].
pub trait AsD {
    /// The same vector in f64.
    fn to_dvec3(self) -> DVec3;
}
impl AsD for glam::Vec3 {
    fn to_dvec3(self) -> DVec3 {
        DVec3 {
            x: self.x as f64,
            y: self.y as f64,
            z: self.z as f64,
        }
    }
}

/// An f64 vector as an array, for the brute-force oracles written with free functions.
pub type D3 = [f64; 3];

/// An f32 vector widened to [`D3`].
pub fn d3(v: glam::Vec3) -> D3 {
    [v.x as f64, v.y as f64, v.z as f64]
}
/// `a - b`.
pub fn sub(a: D3, b: D3) -> D3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
/// `a + b`.
pub fn add(a: D3, b: D3) -> D3 {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}
/// `a * k`.
pub fn scale(a: D3, k: f64) -> D3 {
    [a[0] * k, a[1] * k, a[2] * k]
}
/// The dot product.
pub fn dot(a: D3, b: D3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
/// The cross product.
pub fn cross(a: D3, b: D3) -> D3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// The axis-aligned box `(lo, hi)` of a tet's four corners.
pub fn tet_box(p: [glam::Vec3; 4]) -> (glam::Vec3, glam::Vec3) {
    let lo = p.iter().fold(p[0], |a, &b| a.min(b));
    let hi = p.iter().fold(p[0], |a, &b| a.max(b));
    (lo, hi)
}
