//! A deterministic digest of a force series: FNV-1a 64 over the little-endian bit patterns of
//! each force's x, y, z. Equal digests on host and firmware mean bit-identical forces.
//!
//! ```
//! use tetradrill_core::force::{force_digest, ForceDigest};
//! use tetradrill_core::Vec3;
//!
//! let forces = [Vec3::ZERO, Vec3::new(0.0, 0.0, 1.5), Vec3::new(0.1, -0.2, 3.3)];
//! let mut running = ForceDigest::new();
//! for f in forces {
//!     running.push(f);
//! }
//! assert_eq!(running.value(), force_digest(&forces));
//! assert_eq!(force_digest(&[]), 0xcbf2_9ce4_8422_2325); // FNV-1a 64 of nothing
//!
//! // Bit patterns, not values: -0.0 == 0.0, but their digests differ.
//! assert_ne!(force_digest(&[Vec3::ZERO]), force_digest(&[-Vec3::ZERO]));
//! ```

use glam::Vec3;

const OFFSET: u64 = 0xcbf2_9ce4_8422_2325;
const PRIME: u64 = 0x0000_0100_0000_01b3;

/// Running FNV-1a 64 digest of forces.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct ForceDigest(u64);

impl Default for ForceDigest {
    fn default() -> Self {
        Self(OFFSET)
    }
}

impl ForceDigest {
    /// A fresh digest.
    pub const fn new() -> Self {
        Self(OFFSET)
    }

    /// Feeds one tick's force.
    ///
    /// # Bounded work
    /// Constant: 12 bytes.
    #[inline]
    pub fn push(&mut self, f: Vec3) {
        for c in [f.x, f.y, f.z] {
            for b in c.to_bits().to_le_bytes() {
                self.0 ^= b as u64;
                self.0 = self.0.wrapping_mul(PRIME);
            }
        }
    }

    /// The digest so far.
    #[inline]
    pub const fn value(&self) -> u64 {
        self.0
    }
}

/// The digest of a whole series.
///
/// # Bounded work
/// O(forces.len()).
pub fn force_digest(forces: &[Vec3]) -> u64 {
    let mut d = ForceDigest::new();
    for &f in forces {
        d.push(f);
    }
    d.value()
}
