//! [`GridEntry`]: a tet id with the tet's box clipped to one grid cell and quantised outward,
//! the compact entry of a per-cell tet list ([`super::RigidTets`]' rest grid and
//! [`super::Occupancy::with_tet_lists`]).

use glam::Vec3;

use crate::ids::TetId;

/// Levels per axis of a [`GridEntry`]'s box inside its cell.
const LEVELS: f32 = 16.0;
/// Bits of one level field with its guard bit above.
const FIELD: u32 = 5;
/// The guard bits of three level fields (bits 4, 9 and 14).
const GUARDS: u32 = 0x10 | (0x10 << FIELD) | (0x10 << (2 * FIELD));

/// The level (0 to 15) of grid coordinate `f` (a point's offset from the grid's origin in
/// cells) within cell `c` along one axis, clamped: monotonic in `f`, so a point in a box has
/// a level between the box's corners' levels in every cell the box meets.
#[inline]
fn level(f: f32, c: i32) -> u32 {
    crate::hash::floor_i32((f - c as f32) * LEVELS).clamp(0, LEVELS as i32 - 1) as u32
}

/// The three levels of grid coordinates `f` in cell `c`, packed five bits a field (the
/// argument of [`GridEntry::admits`]).
#[inline]
pub(super) fn levels(f: Vec3, c: [i32; 3]) -> u32 {
    level(f.x, c[0]) | level(f.y, c[1]) << FIELD | level(f.z, c[2]) << (2 * FIELD)
}

/// One entry of a per-cell tet list: a tet id and the tet's grown box clipped to the cell,
/// quantised outward to 16 levels per axis. A point of the cell whose levels lie outside the
/// entry's is outside the tet's box, so most candidates are ruled out by the entries of the
/// cell's contiguous list alone; those left face the box itself and the barycentric test.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default)]
pub struct GridEntry {
    tet: u32,
    /// Lowest levels in bits 0-14, highest in bits 15-29 (five bits a field, guard bits 0).
    levels: u32,
}

impl GridEntry {
    /// The entry of tet `tet` in cell `c` for a box whose corners have grid coordinates
    /// `f_lo` and `f_hi` (computed as a point's are before [`levels`]).
    #[inline]
    pub(super) fn new(tet: u32, f_lo: Vec3, f_hi: Vec3, c: [i32; 3]) -> Self {
        Self {
            tet,
            levels: levels(f_lo, c) | levels(f_hi, c) << 15,
        }
    }

    /// The tet listed.
    #[inline]
    pub(crate) fn tet(&self) -> TetId {
        TetId(self.tet)
    }

    /// `true` unless a point with packed levels `at` ([`levels`], in this entry's cell) is
    /// outside the entry's box: per field `lo <= at <= hi`, all three at once (each field's
    /// guard bit survives the subtraction exactly when it holds).
    #[inline]
    pub(super) fn admits(&self, at: u32) -> bool {
        let lo = self.levels & 0x7fff;
        let hi = self.levels >> 15;
        ((at | GUARDS).wrapping_sub(lo) & (hi | GUARDS).wrapping_sub(at) & GUARDS) == GUARDS
    }
}
