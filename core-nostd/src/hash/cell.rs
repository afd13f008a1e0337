//! Cells and cell ranges, the hash function, bounding boxes and the cell-size helper.

use glam::Vec3;

use crate::ids::TetId;
use crate::mesh::Mesh;

/// A grid cell `(i, j, k)`.
pub(crate) type Cell = [i32; 3];

/// `a == b`, written so that it stays three register compares: LLVM merges the array
/// comparison `a == b` into a call to `memcmp`, which the Cortex-M4 target does not expand
/// inline (about 40 instructions a call instead of 6; the hash compares one cell per entry
/// it scans).
///
/// # Bounded work
/// Constant.
#[inline(always)]
pub(crate) fn same_cell(a: &Cell, b: &Cell) -> bool {
    ((a[0] ^ b[0]) | (a[1] ^ b[1]) | (a[2] ^ b[2])) == 0
}

/// The three hash primes of Teschner et al. 2003.
const P1: i32 = 73_856_093;
const P2: i32 = 19_349_663;
const P3: i32 = 83_492_791;

/// The cell that holds `p` for cells of edge `1 / inv_cell`: a true floor per axis.
/// NaN maps to 0 and values beyond the `i32` range saturate (Rust's `as` cast).
///
/// # Bounded work
/// Constant.
#[inline]
pub(crate) fn cell_of(p: Vec3, inv_cell: f32) -> Cell {
    [
        floor_i32(p.x * inv_cell),
        floor_i32(p.y * inv_cell),
        floor_i32(p.z * inv_cell),
    ]
}

/// `floor(v) as i32`, exactly as `libm::floorf(v) as i32` (NaN gives 0, out-of-range values
/// saturate) without a floating-point rounding call: the truncating cast, one less when it
/// rounded a negative non-integer up. Neither x86-64's baseline nor the Cortex-M4's FPv4 has
/// a floor instruction, so this is a few instructions instead of a library routine.
///
/// # Bounded work
/// Constant.
#[inline]
pub(crate) fn floor_i32(v: f32) -> i32 {
    let i = v as i32;
    if (i as f32) > v {
        i.saturating_sub(1)
    } else {
        i
    }
}

/// Number of cells in an inclusive range (0 for an inverted one).
#[inline]
pub(crate) fn cells_in(lo: Cell, hi: Cell) -> u64 {
    let mut n = 1u64;
    for a in 0..3 {
        let d = hi[a] as i64 - lo[a] as i64 + 1;
        if d <= 0 {
            return 0;
        }
        n = n.saturating_mul(d as u64);
    }
    n
}

/// Visits every cell of an inclusive range, x fastest.
#[inline]
pub(crate) fn for_cells<F: FnMut(Cell)>(lo: Cell, hi: Cell, mut f: F) {
    let mut k = lo[2] as i64;
    while k <= hi[2] as i64 {
        let mut j = lo[1] as i64;
        while j <= hi[1] as i64 {
            let mut i = lo[0] as i64;
            while i <= hi[0] as i64 {
                f([i as i32, j as i32, k as i32]);
                i += 1;
            }
            j += 1;
        }
        k += 1;
    }
}

/// The bucket of cell `c` in a table of `buckets` buckets (0 when `buckets` is 0).
///
/// # Bounded work
/// Constant.
#[inline]
pub(crate) fn bucket_of(c: Cell, buckets: u32) -> u32 {
    let h = c[0].wrapping_mul(P1) ^ c[1].wrapping_mul(P2) ^ c[2].wrapping_mul(P3);
    (h as u32).checked_rem(buckets).unwrap_or(0)
}

/// The largest prime `<= n` (2 for `n < 3`): pick a table size from the storage at hand.
///
/// # Bounded work
/// O(gap * sqrt(n)) by trial division; prime gaps below 2^32 are under 400. Call it at set-up.
pub fn prime_at_most(n: u32) -> u32 {
    let mut c = n.max(2);
    while c > 2 {
        if is_prime(c) {
            return c;
        }
        c -= 1;
    }
    2
}

fn is_prime(n: u32) -> bool {
    if n < 2 {
        return false;
    }
    if n.is_multiple_of(2) {
        return n == 2;
    }
    let mut d = 3u32;
    while (d as u64) * (d as u64) <= n as u64 {
        if n.is_multiple_of(d) {
            return false;
        }
        d += 2;
    }
    true
}

/// An axis-aligned box.
#[derive(Clone, Copy, PartialEq, Debug, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C)]
pub struct Aabb {
    /// Smallest corner.
    pub min: Vec3,
    /// Largest corner.
    pub max: Vec3,
}

impl Aabb {
    /// The box around a point.
    #[inline]
    pub fn point(p: Vec3) -> Self {
        Self { min: p, max: p }
    }

    /// The box around a set of points (`[p; 0]` gives an inverted box that overlaps nothing).
    #[inline]
    pub fn of<const N: usize>(p: [Vec3; N]) -> Self {
        let mut b = Self {
            min: Vec3::splat(f32::INFINITY),
            max: Vec3::splat(f32::NEG_INFINITY),
        };
        for q in p {
            b.min = b.min.min(q);
            b.max = b.max.max(q);
        }
        b
    }

    /// The smallest box holding both.
    #[inline]
    pub fn union(self, o: Self) -> Self {
        Self {
            min: self.min.min(o.min),
            max: self.max.max(o.max),
        }
    }

    /// `true` when the boxes share at least one point.
    #[inline]
    pub fn overlaps(&self, o: &Self) -> bool {
        self.min.x <= o.max.x
            && o.min.x <= self.max.x
            && self.min.y <= o.max.y
            && o.min.y <= self.max.y
            && self.min.z <= o.max.z
            && o.min.z <= self.max.z
    }

    /// `Aabb::of(p).overlaps(self)` for finite points and a box with finite bounds, without
    /// building the box: along each axis some point is not below the box and some point is
    /// not above it. A NaN coordinate passes no comparison: it is skipped (the box of the
    /// other points decides), where [`Aabb::of`] would carry it depending on its place. Stops at the first axis that
    /// separates, so a far box costs one axis of compares (on a Cortex-M4 a floating-point
    /// min or max is a compare, a flag transfer and a conditional move: building the box of
    /// four points is 24 of them).
    ///
    /// # Bounded work
    /// Constant: at most `6 N` compares.
    #[inline]
    pub fn overlaps_points<const N: usize>(&self, p: &[Vec3; N]) -> bool {
        #[inline(always)]
        fn axis<const N: usize>(p: &[Vec3; N], lo: f32, hi: f32, f: fn(&Vec3) -> f32) -> bool {
            p.iter().any(|q| f(q) <= hi) && p.iter().any(|q| f(q) >= lo)
        }
        axis(p, self.min.x, self.max.x, |q| q.x)
            && axis(p, self.min.y, self.max.y, |q| q.y)
            && axis(p, self.min.z, self.max.z, |q| q.z)
    }

    /// `true` when `p` lies in the box (faces included; never for a NaN coordinate).
    #[inline]
    pub fn contains(&self, p: Vec3) -> bool {
        p.cmpge(self.min).all() && p.cmple(self.max).all()
    }

    /// The box grown by `r` on every side.
    #[inline]
    pub fn grown(self, r: f32) -> Self {
        Self {
            min: self.min - Vec3::splat(r),
            max: self.max + Vec3::splat(r),
        }
    }
}

/// Average edge length over the six edges of every tet (an inner edge counts once per tet
/// that uses it, which weights it like the volume around it): the cell size Teschner
/// recommends. Returns 0 for an empty mesh.
///
/// # Bounded work
/// O(T).
pub fn average_edge_length(mesh: &Mesh<'_>) -> f32 {
    let mut sum = 0.0f64;
    for t in 0..mesh.tet_count() {
        let p = mesh.tet_positions(TetId::from_idx(t));
        for a in 0..4 {
            for b in a + 1..4 {
                sum += (p[a] - p[b]).length() as f64;
            }
        }
    }
    let n = 6 * mesh.tet_count();
    if n == 0 {
        0.0
    } else {
        (sum / n as f64) as f32
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn floor_is_true_floor() {
        assert_eq!(cell_of(Vec3::new(-0.5, 0.5, -1.0), 1.0), [-1, 0, -1]);
        assert_eq!(cell_of(Vec3::new(-0.0, 2.0, -2.01), 1.0), [0, 2, -3]);
        assert_eq!(cell_of(Vec3::splat(f32::NAN), 1.0), [0, 0, 0]);
        assert_eq!(cell_of(Vec3::splat(f32::INFINITY), 1.0), [i32::MAX; 3]);
    }

    #[test]
    fn fast_floor_equals_libm_floor() {
        // Oracle: libm's floorf, cast the same way. Edge cases, then a sweep of bit patterns
        // over every exponent (both signs), which covers integers, halves, subnormals, the
        // i32 range boundary, infinities and NaNs.
        let edge = [
            0.0f32,
            -0.0,
            0.5,
            -0.5,
            1.0,
            -1.0,
            -1.0e-30,
            2_147_483_520.0,
            2_147_483_648.0,
            -2_147_483_648.0,
            -2_147_483_904.0,
            3.0e9,
            -3.0e9,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
            f32::MIN_POSITIVE,
            -f32::MIN_POSITIVE,
        ];
        for v in edge {
            assert_eq!(floor_i32(v), libm::floorf(v) as i32, "{v}");
        }
        let mut bits = 0u32;
        loop {
            let v = f32::from_bits(bits);
            assert_eq!(floor_i32(v), libm::floorf(v) as i32, "{v} ({bits:#x})");
            match bits.checked_add(65_521) {
                Some(b) => bits = b,
                None => break,
            }
        }
    }

    /// `overlaps_points` against an oracle written here: per axis, the extent of the
    /// coordinates that are not NaN, then the interval test; random points on a coarse grid
    /// (so touching boxes and equal coordinates are common), with NaN and signed zeros mixed
    /// in, against random finite boxes, some of them flat.
    #[test]
    fn overlaps_points_equals_the_extent_test() {
        let mut seed = 0x9e37_79b9_7f4a_7c15u64;
        let mut rnd = move |n: u64| {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            seed % n
        };
        let coord = |r: &mut dyn FnMut(u64) -> u64| match r(12) {
            0 => f32::NAN,
            1 => -0.0,
            _ => r(9) as f32 * 0.5 - 2.0,
        };
        let (mut hits, mut misses) = (0, 0);
        for _ in 0..20_000 {
            let p: [Vec3; 4] = core::array::from_fn(|_| {
                Vec3::new(coord(&mut rnd), coord(&mut rnd), coord(&mut rnd))
            });
            let a = Vec3::new(coord(&mut rnd), coord(&mut rnd), coord(&mut rnd));
            let d = Vec3::new(rnd(3) as f32, rnd(3) as f32, rnd(3) as f32) * 0.5;
            if !a.is_finite() {
                continue;
            }
            let b = Aabb { min: a, max: a + d };
            let want = (0..3).all(|ax| {
                let vals = p
                    .iter()
                    .map(|q| [q.x, q.y, q.z][ax])
                    .filter(|v| !v.is_nan());
                let (mut lo, mut hi, mut any) = (0.0f32, 0.0f32, false);
                for v in vals {
                    if !any || v < lo {
                        lo = v;
                    }
                    if !any || v > hi {
                        hi = v;
                    }
                    any = true;
                }
                let (bmin, bmax) = (
                    [b.min.x, b.min.y, b.min.z][ax],
                    [b.max.x, b.max.y, b.max.z][ax],
                );
                any && lo <= bmax && hi >= bmin
            });
            assert_eq!(b.overlaps_points(&p), want, "{p:?} {b:?}");
            if p.iter().all(|q| q.is_finite()) {
                assert_eq!(Aabb::of(p).overlaps(&b), want, "{p:?} {b:?}");
            }
            if want {
                hits += 1;
            } else {
                misses += 1;
            }
        }
        assert!(hits > 1000 && misses > 1000, "{hits} {misses}");
    }

    #[test]
    fn same_cell_is_equality() {
        let cells = [
            [0, 0, 0],
            [0, 0, 1],
            [-1, 0, 0],
            [i32::MIN, i32::MAX, 5],
            [5, 5, 5],
        ];
        for a in cells {
            for b in cells {
                assert_eq!(same_cell(&a, &b), a == b, "{a:?} {b:?}");
            }
        }
    }

    #[test]
    fn bucket_matches_formula() {
        let c = [-3, 7, 1_000_000];
        let h = (-3i32).wrapping_mul(73_856_093)
            ^ 7i32.wrapping_mul(19_349_663)
            ^ 1_000_000i32.wrapping_mul(83_492_791);
        assert_eq!(bucket_of(c, 101), (h as u32) % 101);
        assert_eq!(bucket_of(c, 0), 0);
    }

    #[test]
    fn primes() {
        assert_eq!(prime_at_most(100), 97);
        assert_eq!(prime_at_most(97), 97);
        assert_eq!(prime_at_most(0), 2);
        assert_eq!(prime_at_most(4), 3);
        assert_eq!(prime_at_most(65_536), 65_521);
    }
}
