//! The one-shot zone query of [`World::simulate_spheres`](super::World::simulate_spheres)
//! made cheap on a small mesh without changing its answer: the tets near the burr are
//! gathered over steps into a memo, and each step takes the tets whose boxes meet its zone
//! from the memo, put in the order the hash query reports them.
//!
//! The hash query ([`SpatialHash::query_box_once`]) scans every entry of every cell the zone
//! covers; on the firmware's block (384 tets, cells of the average edge) the zone's cells
//! hold about 1,300 entries and report about 250 tets, of which about 70 meet the zone: the
//! scan and the box tests of tets that do not meet the zone were a fifth of the worst step's
//! Cortex-M4 instructions. The query's order is a function of the tets' boxes: a tet is
//! reported in the first cell of the query (x fastest) that holds it, which is the cell
//! `max(lo_Q, lo_t)` along each axis (`lo_Q` the zone's lowest cell, `lo_t` the lowest cell
//! of the tet's box), and within a cell in descending tet order (the hash fills each bucket
//! from its back in tet order). A gather tests the tets' boxes in descending tet order
//! against a box half a radius wider than the zone and keeps each tet that meets it with
//! that lowest cell, clamped to the box's lowest cell (a tet met there is reported by any
//! zone inside the box in the cell `max(lo_Q, clamped lo_t)`); a step keeps the tets whose
//! boxes meet its zone and sorts them by that cell (a stable counting sort over the zone's
//! cells), which puts them in the query's order. The next list is gathered, 128 tets a step,
//! when the zone comes within a quarter of a radius of the serving box's edge; a zone that
//! is not inside a complete list's box queries the hash (the first steps, a burr faster
//! than the gather).

use crate::hash::{Aabb, Cell, SpatialHash};

/// How many tets one gathered list holds (the block's zone grown by half a radius meets
/// about 130); a gather that finds more is dropped and the step queries the hash.
pub(super) const MEMO_TETS: usize = 256;

/// The most hash cells a zone served from the memo may cover (the counting sort's buckets);
/// a larger zone queries the hash.
pub(super) const ORDER_CELLS: usize = 64;

/// Tets whose boxes are tested per step while the next list is gathered.
pub(super) const GATHER_TETS: u32 = 128;

/// The memo serves meshes of at most this many tets (a gather tests every tet's box, so it
/// takes `tets / GATHER_TETS` steps); larger meshes query the hash every step, or gather
/// their candidates over steps ([`crate::collide::ZoneGather`]).
pub(super) const MEMO_MAX_TETS: usize = 2048;

/// One gathered list's box and progress.
#[derive(Clone, Copy, Debug)]
struct Side {
    /// The tets whose boxes meet this box are gathered.
    bx: Aabb,
    /// The box's cells.
    range: (Cell, Cell),
    /// Tets below this one are still to be tested (0: the gather is complete).
    next: u64,
    /// Tets gathered.
    len: usize,
}

impl Side {
    const EMPTY: Self = Self {
        bx: Aabb {
            min: glam::Vec3::ZERO,
            max: glam::Vec3::ZERO,
        },
        range: ([0; 3], [0; 3]),
        next: 0,
        len: 0,
    };
}

/// Two gathered lists (one serves while the other is gathered) and the scratch of the sort;
/// 6 KB.
#[derive(Clone, Debug)]
pub(super) struct ZoneMemo {
    sides: [Side; 2],
    /// Per side, the tets gathered, in descending order.
    tets: [[u32; MEMO_TETS]; 2],
    /// Per side, the lowest cell of each tet's box clamped to the side's lowest cell,
    /// relative to it: one byte an axis (x lowest).
    cells: [[u32; MEMO_TETS]; 2],
    /// The side that serves, if any.
    serve: Option<usize>,
    /// The side being gathered, if any.
    building: Option<usize>,
    /// The box of a gather that was dropped (too many tets or cells): not tried again while
    /// the zone stays inside it.
    failed: Option<Aabb>,
    /// The tets that meet a step's zone as met, each with its cell index in the top byte.
    met: [u32; MEMO_TETS],
    /// The same tets sorted by cell.
    sorted: [u32; MEMO_TETS],
}

/// `inner` lies inside `outer` (faces included).
#[inline]
fn inside(inner: &Aabb, outer: &Aabb) -> bool {
    inner.min.cmpge(outer.min).all() && inner.max.cmple(outer.max).all()
}

/// Cells of the inclusive range `lo..=hi` along each axis (0 for an empty axis).
#[inline]
fn extents(lo: Cell, hi: Cell) -> [u64; 3] {
    let e = |a: usize| (i64::from(hi[a]) - i64::from(lo[a]) + 1).max(0) as u64;
    [e(0), e(1), e(2)]
}

impl ZoneMemo {
    /// Nothing gathered.
    pub(super) const fn new() -> Self {
        Self {
            sides: [Side::EMPTY; 2],
            tets: [[0; MEMO_TETS]; 2],
            cells: [[0; MEMO_TETS]; 2],
            serve: None,
            building: None,
            failed: None,
            met: [0; MEMO_TETS],
            sorted: [0; MEMO_TETS],
        }
    }

    /// Drops both lists (the hash or the tets' boxes changed).
    pub(super) fn forget(&mut self) {
        self.serve = None;
        self.building = None;
        self.failed = None;
    }

    /// Gathers the next list while the zone nears the serving list's edge (or none serves),
    /// [`GATHER_TETS`] tets a step; returns the side that serves `zone`, if one does.
    /// `margin`: how much wider than the zone a gathered box is; `tets`: the mesh's tets,
    /// every one with its box in `boxes` and hashed.
    ///
    /// # Bounded work
    /// At most [`GATHER_TETS`] box tests, and one cell computation per tet gathered.
    pub(super) fn prepare(
        &mut self,
        zone: &Aabb,
        margin: f32,
        hash: &SpatialHash<'_>,
        boxes: &[Aabb],
        tets: usize,
        max_cells: u32,
    ) -> Option<usize> {
        let serving = self.serve.filter(|&s| {
            self.sides
                .get(s)
                .is_some_and(|side| side.len > 0 && inside(zone, &side.bx))
        });
        let near_edge = match serving {
            Some(s) => self
                .sides
                .get(s)
                .is_none_or(|side| !inside(zone, &side.bx.grown(-0.5 * margin))),
            None => true,
        };
        if near_edge {
            let other = 1 - self.serve.unwrap_or(1).min(1);
            let current = self
                .building
                .and_then(|b| self.sides.get(b))
                .is_some_and(|side| inside(zone, &side.bx));
            let failed_here = self.failed.as_ref().is_some_and(|f| inside(zone, f));
            if !current && !failed_here {
                self.start(other, zone, margin, hash, tets, max_cells);
            }
            if let Some(b) = self.building {
                self.gather(b, zone, hash, boxes);
            }
        }
        self.serve
            .filter(|&s| self.sides.get(s).is_some_and(|side| inside(zone, &side.bx)))
    }

    /// Starts gathering side `b` around `zone` (or notes the box as failed when it covers too
    /// many cells).
    fn start(
        &mut self,
        b: usize,
        zone: &Aabb,
        margin: f32,
        hash: &SpatialHash<'_>,
        tets: usize,
        max_cells: u32,
    ) {
        self.building = None;
        let bx = zone.grown(margin);
        let range = hash.cell_range(&bx);
        let [ex, ey, ez] = extents(range.0, range.1);
        let total = ex * ey * ez;
        if total > u64::from(max_cells) || ex > 255 || ey > 255 || ez > 255 || total == 0 {
            self.failed = Some(bx);
            return;
        }
        if let Some(side) = self.sides.get_mut(b) {
            *side = Side {
                bx,
                range,
                next: tets as u64,
                len: 0,
            };
            self.building = Some(b);
        }
    }

    /// One step of side `b`'s gather: the next [`GATHER_TETS`] tets in descending order;
    /// when it completes with `zone` inside its box, the side serves.
    fn gather(&mut self, b: usize, zone: &Aabb, hash: &SpatialHash<'_>, boxes: &[Aabb]) {
        let (Some(side), Some(tets), Some(cells)) = (
            self.sides.get_mut(b),
            self.tets.get_mut(b),
            self.cells.get_mut(b),
        ) else {
            return;
        };
        let bx = side.bx;
        let lo = side.range.0;
        let mut len = side.len;
        let mut over = false;
        let stop = side.next.saturating_sub(u64::from(GATHER_TETS));
        while side.next > stop {
            side.next -= 1;
            let item = side.next as u32;
            let Some(tb) = boxes.get(item as usize) else {
                continue;
            };
            if !tb.overlaps(&bx) {
                continue;
            }
            let (Some(t), Some(c)) = (tets.get_mut(len), cells.get_mut(len)) else {
                over = true;
                break;
            };
            // The tet's lowest cell as the hash stored it, clamped to the range's lowest.
            let low = hash.cell_of(tb.min);
            let rel = |a: usize| {
                (i64::from(low[a]).max(i64::from(lo[a])) - i64::from(lo[a])).min(255) as u32
            };
            *t = item;
            *c = rel(0) | rel(1) << 8 | rel(2) << 16;
            len += 1;
        }
        side.len = len;
        if over {
            self.failed = Some(bx);
            self.building = None;
        } else if side.next == 0 {
            self.building = None;
            if inside(zone, &bx) && len > 0 {
                self.serve = Some(b);
            }
        }
    }

    /// The tets of side `s` whose boxes meet `zone`, in the order
    /// [`SpatialHash::query_box_once`] over `zone` reports them (`s` from
    /// [`ZoneMemo::prepare`] for the same zone); `None` when the zone covers more than
    /// [`ORDER_CELLS`] or `max_cells` cells (the caller queries the hash).
    ///
    /// # Bounded work
    /// One box test per tet of the list, a counting sort over at most [`ORDER_CELLS`] cells,
    /// (stable: the tets of a cell stay in descending order).
    pub(super) fn ordered(
        &mut self,
        s: usize,
        zone: &Aabb,
        hash: &SpatialHash<'_>,
        boxes: &[Aabb],
        max_cells: u32,
    ) -> Option<&[u32]> {
        let side = self.sides.get(s)?;
        let (lo, hi) = hash.cell_range(zone);
        let [ex, ey, ez] = extents(lo, hi);
        let n = ex * ey * ez;
        if n > ORDER_CELLS as u64 || n > u64::from(max_cells) || n == 0 {
            return None;
        }
        let (nx, ny) = (ex as u32, ey as u32);
        // The zone's lowest cell relative to the side's (the zone lies inside its box).
        let d = |a: usize| (i64::from(lo[a]) - i64::from(side.range.0[a])).clamp(0, 255) as u32;
        let (dx, dy, dz) = (d(0), d(1), d(2));
        let (mx, my, mz) = (ex as u32 - 1, ey as u32 - 1, ez as u32 - 1);
        let mut counts = [0u16; ORDER_CELLS + 1];
        let mut k = 0usize;
        let tets = self.tets.get(s)?.get(..side.len)?;
        let cells = self.cells.get(s)?.get(..side.len)?;
        for (&t, &c) in tets.iter().zip(cells) {
            let Some(tb) = boxes.get(t as usize) else {
                continue;
            };
            if !tb.overlaps(zone) {
                continue;
            }
            // The reporting cell max(lo_Q, lo_t), relative to lo_Q.
            let x = ((c & 0xff).max(dx) - dx).min(mx);
            let y = ((c >> 8 & 0xff).max(dy) - dy).min(my);
            let z = ((c >> 16 & 0xff).max(dz) - dz).min(mz);
            let ci = (z * ny + y) * nx + x;
            if let Some(m) = self.met.get_mut(k) {
                *m = ci << 24 | t;
                k += 1;
            }
            if let Some(n) = counts.get_mut(ci as usize + 1) {
                *n += 1;
            }
        }
        // Counting sort by cell, stable: the gather kept the tets in descending order.
        for i in 1..counts.len() {
            let prev = counts.get(i - 1).copied().unwrap_or(0);
            if let Some(n) = counts.get_mut(i) {
                *n += prev;
            }
        }
        for &key in self.met.get(..k)? {
            let ci = (key >> 24) as usize;
            if let Some(at) = counts.get_mut(ci) {
                if let Some(slot) = self.sorted.get_mut(*at as usize) {
                    *slot = key & 0x00ff_ffff;
                }
                *at += 1;
            }
        }
        let sorted = self.sorted.get(..k)?;
        Some(sorted)
    }
}
