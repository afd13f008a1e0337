//! Moving items in a built [`SpatialHash`]: the items whose cell range changed leave their
//! old cells and enter their new ones, and the table becomes the one a whole
//! [`SpatialHash::rebuild`] over the new boxes makes, entry for entry.
//!
//! The whole build leaves each bucket in a fixed order: the filling pass writes every bucket
//! from its back, items in increasing order and each item's cells x fastest, so a bucket
//! reads front to back in decreasing item order, and an item's cells in decreasing visiting
//! order. An item whose range is unchanged has the same entries in the same buckets. So the
//! update lists the entries of the changed items (their old ones and their new ones, sorted
//! into that order) and moves the table once: each bucket shifts by its new entries less its
//! old ones below it, the buckets that move up first (from the top down), then those that
//! move down (from the bottom up); a bucket with changes is rewritten merged, a run of
//! unchanged buckets moves as one block.

use super::cell::{bucket_of, cells_in, for_cells, Aabb, Cell};
use super::rebuild::Rebuilt;
use super::shift::MoveSpan;
use super::table::{HashEntry, SpatialHash};

/// Writes `src` to `dst` (the same length) in the order of a bucket's entries: by bucket,
/// then decreasing item, then decreasing visiting order. `src` must be in listing order
/// (items increasing, each item's cells in visiting order, as [`SpatialHash::changes`]
/// lists them), so that the order within a bucket is the decreasing place in `src`: `dst`
/// first holds a key per entry (its bucket, and its place in `src` inverted), sorted as one
/// `u64` each, then the entries.
///
/// # Bounded work
/// O(m log m) for m entries (at most `u32::MAX`, as [`SpatialHash::changes`] lists), one
/// bucket remainder each.
fn sort_into(src: &[HashEntry], dst: &mut [HashEntry], buckets: u32) {
    for (j, (k, e)) in dst.iter_mut().zip(src).enumerate() {
        k.cell = [bucket_of(e.cell, buckets) as i32, !(j as u32) as i32, 0];
    }
    dst.sort_unstable_by_key(|k| (u64::from(k.cell[0] as u32) << 32) | u64::from(k.cell[1] as u32));
    for k in dst.iter_mut() {
        if let Some(&e) = src.get(!(k.cell[1] as u32) as usize) {
            *k = e;
        }
    }
}

/// `entries.copy_within(from, to)`, nothing when either range falls outside (a table
/// inconsistent with the update's lists; never for one built as documented).
///
/// # Bounded work
/// O(`from.len()`).
#[inline]
pub(super) fn move_run(entries: &mut [HashEntry], from: core::ops::Range<usize>, to: usize) {
    let fits = from.start <= from.end
        && from.end <= entries.len()
        && to.saturating_add(from.end - from.start) <= entries.len();
    if fits {
        entries.copy_within(from, to);
    }
}

/// What [`SpatialHash::changes`] listed: the new entries at the front of its scratch, the
/// old ones at its back (from the back), and the new boxes' union.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Changes {
    /// New entries listed.
    added: usize,
    /// Old entries listed.
    removed: usize,
    /// The union of the new boxes.
    bounds: Aabb,
}

/// What [`SpatialHash::changes_sorted`] left: the lists of [`Changes`], sorted, at the back
/// of its scratch.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Sorted(Changes);

impl SpatialHash<'_> {
    /// Brings the table from the boxes it was built from to new ones: `moved(i)` gives item
    /// `i`'s box at the last build and its new box (`None`: left out, as in
    /// [`SpatialHash::rebuild`]), and is called once for every item `0..count`, in order,
    /// whatever the outcome. Only the items whose cell range changed are touched; the table
    /// (entries, bucket offsets, bounds, length) ends as [`SpatialHash::rebuild`] over the
    /// new boxes leaves it, and the build is counted as one. `scratch` holds the changed
    /// items' entries meanwhile (its contents are left undefined).
    ///
    /// Returns `None` when the update cannot be made, and then the table must be built whole
    /// ([`SpatialHash::rebuild`]): the last build was not a whole build of `count` items
    /// (never built, saturated, or of another count), `scratch` is too short (it needs twice
    /// the m changed entries, old and new, plus the old size of the largest bucket they
    /// fall in), the new entries would not fit in the table (the whole build then
    /// saturates), or the table does not hold an old entry `moved` names (the table's
    /// contents are then undefined).
    ///
    /// The old boxes must be the last build's: an item whose claimed old box and new box
    /// cover the same cells is taken as unchanged without a look at the table.
    ///
    /// # Bounded work
    /// O(count + m log m + buckets + entries) for m changed entries (at most
    /// `scratch.len()`): one pass over the items, two sorts of the changed entries, one
    /// sweep over the buckets each way that moves every entry at most once, the unchanged
    /// runs by block copies. Cheaper than the whole build when few items change cell
    /// range (the whole build hashes every cell of every item twice).
    pub(crate) fn update<F>(
        &mut self,
        count: usize,
        mut moved: F,
        scratch: &mut [HashEntry],
    ) -> Option<Rebuilt>
    where
        F: FnMut(usize) -> (Option<Aabb>, Option<Aabb>),
    {
        let Sorted(listed) = self.changes_sorted(0..count, count, &mut moved, scratch)?;
        // The sorted lists at the back; the front is the buffer every changed bucket
        // passes through.
        let lists = scratch.len().checked_sub(listed.added + listed.removed)?;
        let (buf, sorted) = scratch.split_at_mut(lists);
        let (ins, rem) = sorted.split_at(listed.added);
        self.finish(count, listed.bounds, ins, rem, buf)
    }

    /// [`SpatialHash::update`] from two parts' sorted lists: `first` by
    /// [`SpatialHash::changes_sorted`] over items `0..k` in the front `scratch.len() / 2`
    /// entries of `scratch`, `second` over items `k..count` in the rest (each part's `None`,
    /// a part never listed, or lists that are not in these halves of `scratch` make the
    /// whole update `None`; so does what [`SpatialHash::update`] refuses). The two parts may
    /// be listed and sorted at the same time (each reads the table and writes only its own
    /// half of `scratch`). The table ends as [`SpatialHash::update`] leaves it: the two parts' lists
    /// are merged by bucket and decreasing item, and the parts hold different items.
    ///
    /// With `cut` `Some(k)` the table's move is cut at bucket `k` into two parts that `run`
    /// is given to run (each part's [`MoveSpan::run`], once, in either order or at once on
    /// two threads; `run` returns whether both returned `true`): the buckets below `k` and
    /// those from it on, each with its own entries and offsets of the table and its own
    /// part of `scratch` (docs in `shift.rs`). When the buffers the two parts need do not fit
    /// in `scratch`, or with `cut` `None`, the move is made here in one part and `run` is not
    /// called.
    ///
    /// # Bounded work
    /// O(m + buckets + entries) for the m listed entries: the merge, then the table's move
    /// (in two parts, each over its buckets and entries, and the side buffer of at most m
    /// entries copied in after them).
    pub(crate) fn update_sorted<R>(
        &mut self,
        count: usize,
        first: Option<Sorted>,
        second: Option<Sorted>,
        scratch: &mut [HashEntry],
        cut: Option<usize>,
        run: R,
    ) -> Option<Rebuilt>
    where
        R: FnOnce(MoveSpan<'_>, MoveSpan<'_>) -> bool,
    {
        let (Sorted(a), Sorted(b)) = (first?, second?);
        let (end, half) = (scratch.len(), scratch.len() / 2);
        let (added, removed) = (a.added + b.added, a.removed + b.removed);
        // Each part's runs lie at the back of its half: its new entries, then its old ones.
        // Each merge writes from `to` on while it reads the first part's run from its start,
        // so it stays behind its reads when `to` plus the second part's run ends no later
        // than that start; the merged lists end at `added + removed <= half`, below the
        // second part's runs.
        let a_new = half.checked_sub(a.added + a.removed)?;
        let b_new = end.checked_sub(b.added + b.removed)?;
        let (a_old, b_old) = (a_new + a.added, b_new + b.added);
        if b_new < half || added + b.removed > a_old {
            return None;
        }
        let nb = self.buckets();
        merge_runs(scratch, a_new..a_old, b_new..b_old, 0, nb);
        merge_runs(scratch, a_old..half, b_old..end, added, nb);
        let (ins, rest) = scratch.split_at_mut(added);
        let (rem, buf) = rest.split_at_mut(removed);
        let bounds = a.bounds.union(b.bounds);
        let total = self.used.checked_sub(removed)?.saturating_add(added);
        let (ins, rem) = (&*ins, &*rem);
        let halves = cut.filter(|_| total <= self.entries.len());
        let Some(c) = halves.and_then(|k| self.cut_move(k, ins, rem, buf.len())) else {
            return self.finish(count, bounds, ins, rem, buf);
        };
        let ran = {
            let (lower, upper) = self.halves(&c, ins, rem, buf);
            run(lower, upper)
        };
        if !self.join_halves(&c, buf, ran) {
            self.whole = None;
            return None;
        }
        Some(self.moved(count, bounds, total))
    }

    /// The bucket where the table's entries reach half their number (what
    /// [`SpatialHash::update_sorted`] cuts at for two parts of about the same size).
    ///
    /// # Bounded work
    /// O(log buckets).
    pub(crate) fn middle_bucket(&self) -> usize {
        let half = self.used / 2;
        let nb = self.buckets() as usize;
        self.starts
            .get(..nb)
            .map_or(0, |s| s.partition_point(|&at| (at as usize) < half))
    }

    /// The table moved by the sorted lists `ins` (new entries) and `rem` (old ones), each
    /// in a bucket's order, through `buf`; `None` when the result does not fit in the table
    /// or a changed bucket not in `buf`, or the table does not hold an entry of `rem` (its
    /// contents are then undefined and it must be built whole).
    ///
    /// # Bounded work
    /// O(buckets + entries + m) for the m listed entries.
    fn finish(
        &mut self,
        count: usize,
        bounds: Aabb,
        ins: &[HashEntry],
        rem: &[HashEntry],
        buf: &mut [HashEntry],
    ) -> Option<Rebuilt> {
        let total = self.used.checked_sub(rem.len())?.saturating_add(ins.len());
        if total > self.entries.len() || !self.buckets_fit(ins, rem, buf.len()) {
            return None;
        }
        if !self.move_entries(ins, rem, buf) {
            self.whole = None;
            return None;
        }
        Some(self.moved(count, bounds, total))
    }

    /// A move's end: `total` entries of `count` items within `bounds`, counted as a build.
    ///
    /// # Bounded work
    /// Constant.
    fn moved(&mut self, count: usize, bounds: Aabb, total: usize) -> Rebuilt {
        self.used = total;
        self.bounds = bounds;
        self.stats.builds = self.stats.builds.wrapping_add(1);
        self.stats.updates = self.stats.updates.wrapping_add(1);
        Rebuilt {
            items: count,
            entries: total,
            saturated: false,
        }
    }

    /// [`SpatialHash::changes`], then the lists sorted into a bucket's order at the back of
    /// `scratch`: of the `len` entries, the new ones at `len - added - removed..len -
    /// removed`, the old ones at `len - removed..len` (what [`SpatialHash::update_sorted`]
    /// takes, and [`SpatialHash::update`] over one part). Reads the table only.
    ///
    /// # Bounded work
    /// O(items + `scratch.len()` + m log m) for the m listed entries.
    pub(crate) fn changes_sorted<F>(
        &self,
        items: core::ops::Range<usize>,
        count: usize,
        moved: &mut F,
        scratch: &mut [HashEntry],
    ) -> Option<Sorted>
    where
        F: FnMut(usize) -> (Option<Aabb>, Option<Aabb>),
    {
        let listed = self.changes(items, count, moved, scratch)?;
        let (added, removed, end) = (listed.added, listed.removed, scratch.len());
        // `changes` keeps the lists within half the scratch: room for them sorted.
        if (added + removed).saturating_mul(2) > end {
            return None;
        }
        let nb = self.buckets();
        let (front, old_listed) = scratch.split_at_mut(end.checked_sub(removed)?);
        old_listed.reverse();
        let (new_listed, rest) = front.split_at_mut(added);
        // The old entries sorted just above the new ones as listed, the new ones sorted
        // just below the back, then the old ones moved to the back.
        sort_into(old_listed, rest.get_mut(..removed)?, nb);
        let below = rest.len().checked_sub(added)?;
        sort_into(new_listed, rest.get_mut(below..)?, nb);
        move_run(scratch, added..added + removed, end - removed);
        Some(Sorted(listed))
    }

    /// The first pass of [`SpatialHash::update`], over `items` (a part of `0..count`, the
    /// items of the table's last build): calls `moved` for every item of `items`, in order,
    /// writes the new entries of the items whose cell range changed to the front of `scratch`
    /// and their old entries to its back. Returns how many of each and the new boxes' union;
    /// `None` (the table untouched, `moved` still called for every item) when the table is
    /// not a whole build of `count` items or the entries take more than half the scratch (the
    /// other half is for them sorted). Reads the table only.
    ///
    /// # Bounded work
    /// O(items + `scratch.len()`).
    pub(crate) fn changes<F>(
        &self,
        items: core::ops::Range<usize>,
        count: usize,
        moved: &mut F,
        scratch: &mut [HashEntry],
    ) -> Option<Changes>
    where
        F: FnMut(usize) -> (Option<Aabb>, Option<Aabb>),
    {
        let mut fits = self.whole == Some(count);
        let room = scratch.len();
        // Half the scratch for the lists as listed, half for them sorted (a list's place
        // in its sort key is a `u32`).
        let budget = (room / 2).min(u32::MAX as usize);
        let (mut added, mut removed) = (0usize, 0usize);
        let mut bounds = Aabb::of::<0>([]);
        for i in items {
            let (old, new) = moved(i);
            if let Some(b) = new {
                bounds = bounds.union(b);
            }
            if !fits {
                continue;
            }
            if let (Some(o), Some(n)) = (old, new) {
                if self.same_cells(&o, &n) == Some(true) {
                    continue;
                }
            }
            // Beyond `same_cells`'s reach, or a box that moved cells: the ranges decide.
            let (was, now) = (
                old.map(|b| self.cell_range(&b)),
                new.map(|b| self.cell_range(&b)),
            );
            if was == now {
                continue;
            }
            let cells = |r: Option<(Cell, Cell)>| r.map_or(0, |(lo, hi)| cells_in(lo, hi));
            let free = budget.saturating_sub(added + removed) as u64;
            if cells(was).saturating_add(cells(now)) > free {
                fits = false;
                continue;
            }
            if let Some((lo, hi)) = now {
                for_cells(lo, hi, |c| {
                    if let Some(e) = scratch.get_mut(added) {
                        *e = HashEntry::of(i, c, lo);
                    }
                    added += 1;
                });
            }
            if let Some((lo, hi)) = was {
                for_cells(lo, hi, |c| {
                    removed += 1;
                    if let Some(e) = scratch.get_mut(room - removed) {
                        *e = HashEntry::of(i, c, lo);
                    }
                });
            }
        }
        fits.then_some(Changes {
            added,
            removed,
            bounds,
        })
    }

    /// Whether boxes `a` and `b` cover the same cells, as their `cell_range`s would say,
    /// with floors taken in `f32`: adding and taking away `1.5 * 2^23` rounds `x` to an
    /// integer exactly for `|x| < 2^22`, one less where that rounded up is the floor `f` of
    /// `a`'s bound, and `b`'s bound `y` has the same floor when `f <= y < f + 1`. `None`
    /// when a bound is `2^22` cells or more from the origin, or not finite (the caller finds
    /// the ranges itself).
    ///
    /// # Bounded work
    /// Constant: a product, a rounding and four comparisons a bound.
    #[inline]
    pub(super) fn same_cells(&self, a: &Aabb, b: &Aabb) -> Option<bool> {
        let inv = self.inv_cell;
        let (s0, w0) = same_floor(a.min.x * inv, b.min.x * inv);
        let (s1, w1) = same_floor(a.min.y * inv, b.min.y * inv);
        let (s2, w2) = same_floor(a.min.z * inv, b.min.z * inv);
        let (s3, w3) = same_floor(a.max.x * inv, b.max.x * inv);
        let (s4, w4) = same_floor(a.max.y * inv, b.max.y * inv);
        let (s5, w5) = same_floor(a.max.z * inv, b.max.z * inv);
        (w0 & w1 & w2 & w3 & w4 & w5).then_some(s0 & s1 & s2 & s3 & s4 & s5)
    }
}

/// Whether `x` and `y` have the same floor, and whether both lie within `2^22` of zero (the
/// answer holds only then): `x` rounded to an integer `r` by adding and taking away
/// `1.5 * 2^23` (exact for `|x| < 2^22`), its floor `f` one less where that rounded up, and
/// `f <= y < f + 1`.
///
/// # Bounded work
/// Constant.
#[inline(always)]
fn same_floor(x: f32, y: f32) -> (bool, bool) {
    const ROUND: f32 = 12_582_912.0;
    const LIMIT: f32 = 4_194_304.0;
    let within = (x.abs() < LIMIT) & (y.abs() < LIMIT);
    let r = (x + ROUND) - ROUND;
    let f = if r > x { r - 1.0 } else { r };
    ((f <= y) & (y < f + 1.0), within)
}

/// Merges the runs `a` and `b` of `s` (each in a bucket's order, of different items) into
/// `s[to..]` in a bucket's order, from the front: by bucket, then decreasing item. The
/// writes must stay behind the reads: `to + b.len() <= a.start`, and `b` above all that is
/// written (entries outside `s` are skipped).
///
/// # Bounded work
/// O(`a.len() + b.len()`), one bucket remainder an entry.
fn merge_runs(
    s: &mut [HashEntry],
    a: core::ops::Range<usize>,
    b: core::ops::Range<usize>,
    to: usize,
    nb: u32,
) {
    let head = |s: &[HashEntry], r: &core::ops::Range<usize>, i: usize| {
        let e = s.get(i).filter(|_| i < r.end).copied();
        e.map(|e| (e, bucket_of(e.cell, nb)))
    };
    let (mut i, mut j, mut w) = (a.start, b.start, to);
    let (mut x, mut y) = (head(s, &a, i), head(s, &b, j));
    loop {
        let first = match (x, y) {
            (Some((e, k)), Some((f, l))) => k < l || (k == l && e.item() > f.item()),
            (Some(_), None) => true,
            (None, Some(_)) => false,
            (None, None) => break,
        };
        let put = if first {
            i += 1;
            core::mem::replace(&mut x, head(s, &a, i))
        } else {
            j += 1;
            core::mem::replace(&mut y, head(s, &b, j))
        };
        if let (Some(slot), Some((e, _))) = (s.get_mut(w), put) {
            *slot = e;
        }
        w += 1;
    }
}

#[cfg(test)]
#[path = "update_tests.rs"]
mod tests;
