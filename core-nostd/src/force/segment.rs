//! Passive points: the segment between two consecutive positions against the surface.
//!
//! ```
//! use tetradrill_core::force::segment_first_hit;
//! use tetradrill_core::Vec3;
//!
//! // Floors at z = 0 and z = -1 (outward +z) and a segment from above through both.
//! let floor = |z| [Vec3::new(-1.0, -1.0, z), Vec3::new(1.0, -1.0, z), Vec3::new(0.0, 1.0, z)];
//! let (from, to) = (Vec3::new(0.0, 0.0, 1.0), Vec3::new(0.0, 0.0, -2.0));
//! let hit = segment_first_hit(from, to, [floor(-1.0), floor(0.0)]).unwrap();
//!
//! // It enters the upper floor first, a third of the way; its end is 2 behind that floor.
//! assert_eq!((hit.index, hit.normal), (1, Vec3::Z));
//! assert!((hit.s - 1.0 / 3.0).abs() < 1e-6 && (hit.depth - 2.0).abs() < 1e-6);
//!
//! // Leaving through a face is no hit.
//! assert!(segment_first_hit(Vec3::new(0.0, 0.0, -0.5), from, [floor(0.0)]).is_none());
//! ```

use glam::Vec3;

/// Where a moving passive point first entered the surface.
#[derive(Clone, Copy, PartialEq, Debug, Default)]
pub struct SegmentHit {
    /// Index of the triangle in the input.
    pub index: u32,
    /// Fraction of the way from `from` to `to`.
    pub s: f32,
    /// The entry point on the surface.
    pub point: Vec3,
    /// Outward unit normal of the triangle.
    pub normal: Vec3,
    /// How far `to` lies behind the entered triangle's plane (`>= 0`).
    pub depth: f32,
}

/// The first triangle the segment `from -> to` enters (crossing from the outer side to the
/// inner side of an outward counter-clockwise triangle), nearest to `from`; ties go to the
/// smaller index. Exiting crossings are ignored.
///
/// # Bounded work
/// One constant-time segment-triangle test per triangle yielded.
pub fn segment_first_hit<I>(from: Vec3, to: Vec3, tris: I) -> Option<SegmentHit>
where
    I: IntoIterator<Item = [Vec3; 3]>,
{
    let d = to - from;
    let mut best: Option<SegmentHit> = None;
    for (i, [a, b, c]) in tris.into_iter().enumerate() {
        let n = (b - a).cross(c - a);
        let den = n.dot(d);
        if den.is_nan() || den >= 0.0 {
            continue; // parallel or leaving
        }
        let s = n.dot(a - from) / den;
        if !(0.0..=1.0).contains(&s) {
            continue;
        }
        let x = from + d * s;
        // Inside test by the three edge half-planes.
        let inside = (b - a).cross(x - a).dot(n) >= 0.0
            && (c - b).cross(x - b).dot(n) >= 0.0
            && (a - c).cross(x - c).dot(n) >= 0.0;
        if !inside {
            continue;
        }
        if best.is_some_and(|h| h.s <= s) {
            continue;
        }
        let normal = n.normalize_or_zero();
        let depth = (x - to).dot(normal).max(0.0);
        best = Some(SegmentHit {
            index: i as u32,
            s,
            point: x,
            normal,
            depth,
        });
    }
    best
}
