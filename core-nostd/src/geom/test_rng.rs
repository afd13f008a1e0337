//! A small random generator for the core's tests (no `std` in them).

use glam::Quat;

/// A xorshift generator for the tests of every layer (the hash's, the contact search's).
pub(crate) struct Rng(pub u64);

impl Rng {
    /// The next number in `[0, 1)`.
    pub fn next(&mut self) -> f32 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 40) as f32 / (1u64 << 24) as f32
    }
    /// The next number in `[lo, hi)`.
    pub fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.next()
    }
    /// A random rotation (the identity when the drawn quaternion is too short to normalise).
    pub fn rotation(&mut self) -> Quat {
        let q = Quat::from_xyzw(
            self.range(-1.0, 1.0),
            self.range(-1.0, 1.0),
            self.range(-1.0, 1.0),
            self.range(-1.0, 1.0),
        );
        if q.length_squared() < 1e-3 {
            Quat::IDENTITY
        } else {
            q.normalize()
        }
    }
}
