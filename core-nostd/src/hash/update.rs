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
fn move_run(entries: &mut [HashEntry], from: core::ops::Range<usize>, to: usize) {
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
    /// # Bounded work
    /// O(m + buckets + entries) for the m listed entries: the merge, then the table's move.
    pub(crate) fn update_sorted(
        &mut self,
        count: usize,
        first: Option<Sorted>,
        second: Option<Sorted>,
        scratch: &mut [HashEntry],
    ) -> Option<Rebuilt> {
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
        self.finish(count, a.bounds.union(b.bounds), ins, rem, buf)
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
        self.used = total;
        self.bounds = bounds;
        self.stats.builds = self.stats.builds.wrapping_add(1);
        self.stats.updates = self.stats.updates.wrapping_add(1);
        Some(Rebuilt {
            items: count,
            entries: total,
            saturated: false,
        })
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
            let was = old.map(|b| self.cell_range(&b));
            let now = match (was, new) {
                (Some(r), Some(b)) if self.keeps(r, &b) => continue,
                _ => new.map(|b| self.cell_range(&b)),
            };
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

    /// `true` when box `b` covers the cell range `(lo, hi)`, as `cell_range` would find, by
    /// two comparisons a bound: the floor of `x` is `c` when `c <= x < c + 1`, exact in
    /// `f32` for `|c| < 2^24` (beyond, `false`: the caller finds the range itself).
    ///
    /// # Bounded work
    /// Constant.
    #[inline]
    fn keeps(&self, (lo, hi): (Cell, Cell), b: &Aabb) -> bool {
        let floor_is = |c: i32, v: f32| {
            let (x, f) = (v * self.inv_cell, c as f32);
            c.unsigned_abs() < 1 << 24 && f <= x && x < f + 1.0
        };
        (0..3).all(|a| floor_is(lo[a], b.min[a]) && floor_is(hi[a], b.max[a]))
    }

    /// `true` when every bucket with listed entries holds at most `room` entries (the buffer
    /// [`SpatialHash::move_entries`] copies a changed bucket to).
    ///
    /// # Bounded work
    /// O(m) for m listed entries.
    fn buckets_fit(&self, ins: &[HashEntry], rem: &[HashEntry], room: usize) -> bool {
        let nb = self.buckets();
        let (mut i, mut r) = (0, 0);
        while let Some((k, ie, re)) = group_above(ins, rem, i, r, nb) {
            let at = |k: usize| self.starts.get(k).map_or(0, |&s| s as usize);
            if at(k + 1).saturating_sub(at(k)) > room {
                return false;
            }
            (i, r) = (ie, re);
        }
        true
    }

    /// The moving pass of [`SpatialHash::update`], over the table in one sweep each way.
    /// Bucket `k`'s entries move by `d(k)`, the new entries less the old ones of the buckets
    /// below it. Where `d(k) > 0` the buckets move up, and a run of such buckets lands
    /// inside its own old place (it starts higher and ends no higher, as the next bucket's
    /// shift is `<= 0`), so these runs are moved first, each from its top down; the other
    /// buckets then move down from the bottom up, into places no longer read. A bucket with
    /// changes is copied to `buf` first and written merged (old entries less `rem`, plus
    /// `ins`, in decreasing item order); a run of unchanged buckets moves as one block.
    /// `false` when an entry of `rem` is not in its bucket (the table is then undefined).
    ///
    /// # Bounded work
    /// O(buckets + entries + m) for m listed entries.
    fn move_entries(
        &mut self,
        ins: &[HashEntry],
        rem: &[HashEntry],
        buf: &mut [HashEntry],
    ) -> bool {
        let nb = self.buckets() as usize;
        let net = ins.len() as i64 - rem.len() as i64;
        let start = |s: &[u32], k: usize| s.get(k).map_or(0, |&v| v as usize);
        // Up: from the top bucket down, `d` the shift of the bucket above the one at hand.
        let (mut d, mut ie, mut re, mut upper) = (net, ins.len(), rem.len(), nb);
        loop {
            let g = group_below(ins, rem, ie, re, nb as u32);
            let k_next = g.map_or(0, |(k, _, _)| k + 1);
            if d > 0 {
                let (lo, hi) = (start(self.starts, k_next), start(self.starts, upper));
                move_run(self.entries, lo..hi, shifted(lo, d));
            }
            let Some((k, is, rs)) = g else { break };
            let dk = d - (ie - is) as i64 + (re - rs) as i64;
            if dk > 0 {
                let src = start(self.starts, k)..start(self.starts, k + 1);
                let to = shifted(src.start, dk);
                if !rewrite(self.entries, src, to, &ins[is..ie], &rem[rs..re], buf) {
                    return false;
                }
            }
            (d, ie, re, upper) = (dk, is, rs, k);
        }
        // Down: from the bottom bucket up, each bucket's offset moved as it is passed.
        let (mut d, mut i, mut r, mut lower) = (0i64, 0usize, 0usize, 0usize);
        loop {
            let g = group_above(ins, rem, i, r, nb as u32);
            let k_end = g.map_or(nb, |(k, _, _)| k);
            if d < 0 {
                let (lo, hi) = (start(self.starts, lower), start(self.starts, k_end));
                move_run(self.entries, lo..hi, shifted(lo, d));
            }
            for s in self.starts.get_mut(lower..k_end).unwrap_or(&mut []) {
                *s = shifted(*s as usize, d) as u32;
            }
            let Some((k, ie, re)) = g else { break };
            let src = start(self.starts, k)..start(self.starts, k + 1);
            if d <= 0
                && !rewrite(
                    self.entries,
                    src.clone(),
                    shifted(src.start, d),
                    &ins[i..ie],
                    &rem[r..re],
                    buf,
                )
            {
                return false;
            }
            if let Some(s) = self.starts.get_mut(k) {
                *s = shifted(src.start, d) as u32;
            }
            d += (ie - i) as i64 - (re - r) as i64;
            (i, r, lower) = (ie, re, k + 1);
        }
        if let Some(s) = self.starts.get_mut(nb) {
            *s = shifted(*s as usize, net) as u32;
        }
        true
    }
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

/// `at + d`, clamped at 0 (never below for a table consistent with the update's lists).
#[inline]
fn shifted(at: usize, d: i64) -> usize {
    (at as i64).saturating_add(d).max(0) as usize
}

/// The highest bucket with listed entries among `ins[..ie]` and `rem[..re]` (both sorted
/// by `sort_into`): the bucket and where its entries start in each list.
///
/// # Bounded work
/// O(the bucket's listed entries).
fn group_below(
    ins: &[HashEntry],
    rem: &[HashEntry],
    ie: usize,
    re: usize,
    nb: u32,
) -> Option<(usize, usize, usize)> {
    let bucket = |l: &[HashEntry], e: usize| {
        e.checked_sub(1)
            .and_then(|p| l.get(p))
            .map(|x| bucket_of(x.cell, nb))
    };
    let k = bucket(ins, ie).max(bucket(rem, re))?;
    let (mut is, mut rs) = (ie, re);
    while bucket(ins, is) == Some(k) {
        is -= 1;
    }
    while bucket(rem, rs) == Some(k) {
        rs -= 1;
    }
    Some((k as usize, is, rs))
}

/// The lowest bucket with listed entries among `ins[i..]` and `rem[r..]` (both sorted by
/// `sort_into`): the bucket and where its entries end in each list.
///
/// # Bounded work
/// O(the bucket's listed entries).
fn group_above(
    ins: &[HashEntry],
    rem: &[HashEntry],
    i: usize,
    r: usize,
    nb: u32,
) -> Option<(usize, usize, usize)> {
    let bucket = |l: &[HashEntry], at: usize| l.get(at).map(|x| bucket_of(x.cell, nb));
    let k = match (bucket(ins, i), bucket(rem, r)) {
        (Some(a), Some(b)) => a.min(b),
        (a, b) => a.or(b)?,
    };
    let (mut ie, mut re) = (i, r);
    while bucket(ins, ie) == Some(k) {
        ie += 1;
    }
    while bucket(rem, re) == Some(k) {
        re += 1;
    }
    Some((k as usize, ie, re))
}

/// Writes the bucket at `src` to `to`, through `buf`: its entries less `rem`, plus `ins`,
/// in decreasing item order (both lists in the bucket's order). `false` when the bucket
/// does not fit in `buf`, an entry of `rem` is not in it, or the result would leave the
/// storage.
///
/// # Bounded work
/// O(bucket size + listed entries).
fn rewrite(
    entries: &mut [HashEntry],
    src: core::ops::Range<usize>,
    to: usize,
    ins: &[HashEntry],
    rem: &[HashEntry],
    buf: &mut [HashEntry],
) -> bool {
    let n = src.end.saturating_sub(src.start);
    let (Some(old), Some(buf)) = (entries.get(src), buf.get_mut(..n)) else {
        return false;
    };
    buf.copy_from_slice(old);
    let (mut o, mut x, mut r, mut w) = (0usize, 0usize, 0usize, to);
    loop {
        // The old entry next, once the removed ones are passed.
        while let (Some(e), Some(gone)) = (buf.get(o), rem.get(r)) {
            if e != gone {
                break;
            }
            (o, r) = (o + 1, r + 1);
        }
        let put = match (buf.get(o), ins.get(x)) {
            (Some(&e), Some(&new)) if e.item() > new.item() => {
                o += 1;
                e
            }
            (_, Some(&new)) => {
                x += 1;
                new
            }
            (Some(&e), None) => {
                o += 1;
                e
            }
            (None, None) => break,
        };
        let Some(slot) = entries.get_mut(w) else {
            return false;
        };
        *slot = put;
        w += 1;
    }
    r == rem.len()
}

#[cfg(test)]
#[path = "update_tests.rs"]
mod tests;
