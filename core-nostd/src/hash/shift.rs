//! The table's move of [`SpatialHash::update`]: every bucket shifted by the new entries
//! less the old ones below it, the changed buckets rewritten merged; in one part, or in two
//! parts cut at a bucket that may run at once ([`SpatialHash::update_sorted`]).
//!
//! Cut at bucket `K`, which starts at `P`, with `s` its shift (the new entries less the old
//! ones listed below it): the buckets below `K` read only entries `..P` and end in `..P + s`;
//! those from `K` on read only `P..` and end in `P + s..`. Where one part's writes reach into
//! the other's reads (`P..P + s` for `s > 0`, `P + s..P` for `s < 0`), that part writes them
//! to a side buffer instead, copied into place after both ran. Each part has its own buffer
//! for its changed buckets, and its own bucket offsets (the lower part's top is `P`, a
//! value).

use super::cell::bucket_of;
use super::table::{HashEntry, SpatialHash};
use super::update::move_run;
use core::ops::Range;

impl SpatialHash<'_> {
    /// `true` when every bucket with listed entries holds at most `room` entries (the buffer
    /// [`SpatialHash::move_entries`] copies a changed bucket to).
    ///
    /// # Bounded work
    /// O(m) for m listed entries.
    pub(super) fn buckets_fit(&self, ins: &[HashEntry], rem: &[HashEntry], room: usize) -> bool {
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

    /// The moving pass of [`SpatialHash::update`] over the whole table, in one part
    /// ([`MoveSpan::run`]). `false` when an entry of `rem` is not in its bucket (the table
    /// is then undefined).
    ///
    /// # Bounded work
    /// O(buckets + entries + m) for m listed entries.
    pub(super) fn move_entries(
        &mut self,
        ins: &[HashEntry],
        rem: &[HashEntry],
        buf: &mut [HashEntry],
    ) -> bool {
        let nb = self.buckets();
        let top = self.starts.get(nb as usize).map_or(0, |&s| s as usize);
        MoveSpan {
            starts: &mut *self.starts,
            first: 0,
            end: nb as usize,
            top,
            shift: 0,
            ins,
            rem,
            buf,
            room: Room {
                own: &mut *self.entries,
                base: 0,
                side: &mut [],
                side_at: 0,
            },
            nb,
        }
        .run()
    }

    /// Where the move by the sorted lists `ins` and `rem` is cut at bucket `cut` (at most
    /// the bucket count) into two parts that may run at once ([`SpatialHash::halves`]),
    /// with `free` entries for the side buffer and the two parts' buffers; `None` when the
    /// buffers do not fit (or the table does not match the lists): the move then runs in one
    /// part.
    ///
    /// # Bounded work
    /// O(m) for m listed entries (the lists cut by bisection, the buckets' sizes checked).
    pub(super) fn cut_move(
        &self,
        cut: usize,
        ins: &[HashEntry],
        rem: &[HashEntry],
        free: usize,
    ) -> Option<Cut> {
        let nb = self.buckets();
        let bucket = cut.min(nb as usize);
        let below =
            |l: &[HashEntry]| l.partition_point(|e| (bucket_of(e.cell, nb) as usize) < bucket);
        let (ins_below, rem_below) = (below(ins), below(rem));
        let shift = ins_below as i64 - rem_below as i64;
        let at = *self.starts.get(bucket)? as usize;
        let side = shift.unsigned_abs() as usize;
        let buf = free.checked_sub(side)? / 2;
        let (ins_lo, ins_hi) = ins.split_at(ins_below);
        let (rem_lo, rem_hi) = rem.split_at(rem_below);
        // The side lands at `P..P + s` (below the table's end, checked by the caller) or at
        // `P + s..P`.
        let fits = at <= self.entries.len()
            && (shift > 0 || at >= side)
            && self.buckets_fit(ins_lo, rem_lo, buf)
            && self.buckets_fit(ins_hi, rem_hi, buf);
        fits.then_some(Cut {
            bucket,
            at,
            shift,
            ins_below,
            rem_below,
            buf,
        })
    }

    /// The two parts of the move cut as `cut` says ([`SpatialHash::cut_move`] over the same
    /// lists and `free.len()`): the buckets below the cut and those from it on, each with its
    /// own part of the table's entries and offsets and of `free`. After both ran,
    /// [`SpatialHash::join_halves`] with the same `free` puts the side buffer in.
    ///
    /// # Bounded work
    /// Constant.
    pub(super) fn halves<'t>(
        &'t mut self,
        cut: &Cut,
        ins: &'t [HashEntry],
        rem: &'t [HashEntry],
        free: &'t mut [HashEntry],
    ) -> (MoveSpan<'t>, MoveSpan<'t>) {
        let nb = self.buckets();
        let top = self.starts.get(nb as usize).map_or(0, |&s| s as usize);
        let at = cut.at.min(self.entries.len());
        let (own_lo, own_hi) = self.entries.split_at_mut(at);
        let (starts_lo, starts_hi) = self.starts.split_at_mut(cut.bucket.min(nb as usize));
        let side = (cut.shift.unsigned_abs() as usize).min(free.len());
        let (side, bufs) = free.split_at_mut(side);
        let (buf_lo, buf_hi) = bufs.split_at_mut(cut.buf.min(bufs.len()));
        let (ins_lo, ins_hi) = ins.split_at(cut.ins_below.min(ins.len()));
        let (rem_lo, rem_hi) = rem.split_at(cut.rem_below.min(rem.len()));
        // The side buffer stands for the entries one part writes in the other's reach.
        let (side_lo, side_hi): (&mut [HashEntry], &mut [HashEntry]) = if cut.shift > 0 {
            (side, &mut [])
        } else {
            (&mut [], side)
        };
        let lower = MoveSpan {
            starts: starts_lo,
            first: 0,
            end: cut.bucket,
            top: at,
            shift: 0,
            ins: ins_lo,
            rem: rem_lo,
            buf: buf_lo,
            room: Room {
                own: own_lo,
                base: 0,
                side: side_lo,
                side_at: at,
            },
            nb,
        };
        let upper = MoveSpan {
            starts: starts_hi,
            first: cut.bucket,
            end: nb as usize,
            top,
            shift: cut.shift,
            ins: ins_hi,
            rem: rem_hi,
            buf: buf_hi,
            room: Room {
                own: own_hi,
                base: at,
                side: side_hi,
                side_at: shifted(at, cut.shift),
            },
            nb,
        };
        (lower, upper)
    }

    /// After both of [`SpatialHash::halves`]'s parts ran (`ran`: both returned `true`), the
    /// side buffer copied from the front of `free` into its place in the table; `false`
    /// when a part failed or the side does not fit (the table is then undefined).
    ///
    /// # Bounded work
    /// O(the cut's shift).
    pub(super) fn join_halves(&mut self, cut: &Cut, free: &[HashEntry], ran: bool) -> bool {
        let side = cut.shift.unsigned_abs() as usize;
        let to = if cut.shift > 0 {
            cut.at
        } else {
            shifted(cut.at, cut.shift)
        };
        match (
            free.get(..side),
            self.entries.get_mut(to..to.saturating_add(side)),
        ) {
            (Some(from), Some(into)) if ran => {
                into.copy_from_slice(from);
                true
            }
            _ => false,
        }
    }
}

/// Where [`SpatialHash::cut_move`] cuts the table's move.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Cut {
    /// The upper part's first bucket.
    bucket: usize,
    /// Where that bucket starts (the upper part reads from here on).
    at: usize,
    /// That bucket's shift: the new entries less the old ones below it.
    shift: i64,
    /// New entries listed below the cut.
    ins_below: usize,
    /// Old entries listed below the cut.
    rem_below: usize,
    /// Each part's buffer for its changed buckets.
    buf: usize,
}

/// The table's entries a part of the move reads and writes: `own` is the table from `base`
/// on (everything the part reads, and where it writes), `side` stands for the table's
/// entries from `side_at` on that the other part still reads (copied in after both ran).
struct Room<'t> {
    own: &'t mut [HashEntry],
    base: usize,
    side: &'t mut [HashEntry],
    side_at: usize,
}

impl Room<'_> {
    /// The table's entries `r`, when they are the part's own.
    #[inline]
    fn read(&self, r: Range<usize>) -> Option<&[HashEntry]> {
        let base = self.base;
        self.own
            .get(r.start.checked_sub(base)?..r.end.checked_sub(base)?)
    }

    /// Where the table's entries `to..to + len` are written, when they lie all in `own` or
    /// all in `side`.
    #[inline]
    fn dest(&mut self, to: usize, len: usize) -> Option<&mut [HashEntry]> {
        let end = to.checked_add(len)?;
        if to >= self.base && end - self.base <= self.own.len() {
            return self.own.get_mut(to - self.base..end - self.base);
        }
        let at = to.checked_sub(self.side_at)?;
        self.side.get_mut(at..at.checked_add(len)?)
    }

    /// Where the table's entry `w` is written.
    #[inline]
    fn slot(&mut self, w: usize) -> Option<&mut HashEntry> {
        self.dest(w, 1)?.first_mut()
    }

    /// The table's entries `from` (the part's own) copied to `to..`: what lands in the side
    /// buffer first (its sources may lie where the rest lands), then the rest within `own`.
    /// Nothing when `from` is not the part's own; what would land outside both is dropped
    /// (only for a table inconsistent with the lists).
    ///
    /// # Bounded work
    /// O(`from.len()`).
    fn shift_run(&mut self, from: Range<usize>, to: usize) {
        let (Some(a), Some(b)) = (
            from.start.checked_sub(self.base),
            from.end.checked_sub(self.base),
        ) else {
            return;
        };
        if a > b || b > self.own.len() {
            return;
        }
        let end = to.saturating_add(b - a);
        let (lo, hi) = (
            to.max(self.side_at),
            end.min(self.side_at.saturating_add(self.side.len())),
        );
        if lo < hi {
            let s = a + (lo - to);
            let dst = self.side.get_mut(lo - self.side_at..hi - self.side_at);
            if let (Some(dst), Some(src)) = (dst, self.own.get(s..s + (hi - lo))) {
                dst.copy_from_slice(src);
            }
        }
        let (lo, hi) = (to.max(self.base), end.min(self.base + self.own.len()));
        if lo < hi {
            let s = a + (lo - to);
            move_run(self.own, s..s + (hi - lo), lo - self.base);
        }
    }
}

/// One part of the table's move: buckets `first..end`, their offsets from `starts` on (with
/// the end sentinel when `end` is the last), their sorted lists, and the table's entries
/// through a [`Room`]; `top` is where bucket `end` starts and `shift` bucket `first`'s shift.
pub(crate) struct MoveSpan<'t> {
    starts: &'t mut [u32],
    first: usize,
    end: usize,
    top: usize,
    shift: i64,
    ins: &'t [HashEntry],
    rem: &'t [HashEntry],
    buf: &'t mut [HashEntry],
    room: Room<'t>,
    nb: u32,
}

impl core::fmt::Debug for MoveSpan<'_> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("MoveSpan")
            .field("buckets", &(self.first..self.end))
            .field("shift", &self.shift)
            .finish()
    }
}

impl MoveSpan<'_> {
    /// Its buckets and its first bucket's shift (for the oracles).
    #[cfg(test)]
    pub(crate) fn cut_of(&self) -> (core::ops::Range<usize>, i64) {
        (self.first..self.end, self.shift)
    }

    /// Moves its buckets, in one sweep each way. Bucket `k`'s entries move by `d(k)`, the
    /// new entries less the old ones of the buckets below it. Where `d(k) > 0` the buckets
    /// move up, and a run of such buckets lands inside its own old place (it starts higher
    /// and ends no higher, as the next bucket's shift is `<= 0`), so these runs are moved
    /// first, each from its top down; the other buckets then move down from the bottom up,
    /// into places no longer read. A bucket with changes is copied to `buf` first and
    /// written merged (old entries less `rem`, plus `ins`, in decreasing item order); a run
    /// of unchanged buckets moves as one block. `false` when an entry of `rem` is not in its
    /// bucket (the table is then undefined).
    ///
    /// # Bounded work
    /// O(its buckets + its entries + its m listed entries).
    pub(crate) fn run(self) -> bool {
        let MoveSpan {
            starts,
            first: k0,
            end: k1,
            top,
            shift,
            ins,
            rem,
            buf,
            mut room,
            nb,
        } = self;
        // Bucket `k`'s old start; `top` for `end` (and for a bucket outside the part, which
        // only lists inconsistent with the table give).
        let start = |s: &[u32], k: usize| match k.checked_sub(k0).filter(|_| k < k1) {
            Some(i) => s.get(i).map_or(0, |&v| v as usize),
            None => top,
        };
        // Up: from the top bucket down, `d` the shift of the bucket above the one at hand.
        let net = ins.len() as i64 - rem.len() as i64;
        let (mut d, mut ie, mut re, mut upper) = (shift + net, ins.len(), rem.len(), k1);
        loop {
            let g = group_below(ins, rem, ie, re, nb);
            let k_next = g.map_or(k0, |(k, _, _)| k + 1);
            if d > 0 {
                let (lo, hi) = (start(starts, k_next), start(starts, upper));
                room.shift_run(lo..hi, shifted(lo, d));
            }
            let Some((k, is, rs)) = g else { break };
            let dk = d - (ie - is) as i64 + (re - rs) as i64;
            if dk > 0 {
                let src = start(starts, k)..start(starts, k + 1);
                let to = shifted(src.start, dk);
                if !rewrite(&mut room, src, to, &ins[is..ie], &rem[rs..re], buf) {
                    return false;
                }
            }
            (d, ie, re, upper) = (dk, is, rs, k);
        }
        // Down: from the bottom bucket up, each bucket's offset moved as it is passed.
        let (mut d, mut i, mut r, mut lower) = (shift, 0usize, 0usize, k0);
        loop {
            let g = group_above(ins, rem, i, r, nb);
            let k_end = g.map_or(k1, |(k, _, _)| k);
            if d < 0 {
                let (lo, hi) = (start(starts, lower), start(starts, k_end));
                room.shift_run(lo..hi, shifted(lo, d));
            }
            let own = lower.saturating_sub(k0)..k_end.saturating_sub(k0);
            for off in starts.get_mut(own).unwrap_or(&mut []) {
                *off = shifted(*off as usize, d) as u32;
            }
            let Some((k, ie, re)) = g else { break };
            let src = start(starts, k)..start(starts, k + 1);
            if d <= 0
                && !rewrite(
                    &mut room,
                    src.clone(),
                    shifted(src.start, d),
                    &ins[i..ie],
                    &rem[r..re],
                    buf,
                )
            {
                return false;
            }
            if let Some(s) = k.checked_sub(k0).and_then(|i| starts.get_mut(i)) {
                *s = shifted(src.start, d) as u32;
            }
            d += (ie - i) as i64 - (re - r) as i64;
            (i, r, lower) = (ie, re, k + 1);
        }
        // The end sentinel, when the part holds it.
        if let Some(s) = k1.checked_sub(k0).and_then(|i| starts.get_mut(i)) {
            *s = shifted(top, d) as u32;
        }
        true
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
    room: &mut Room<'_>,
    src: Range<usize>,
    to: usize,
    ins: &[HashEntry],
    rem: &[HashEntry],
    buf: &mut [HashEntry],
) -> bool {
    let n = src.end.saturating_sub(src.start);
    let (Some(old), Some(buf)) = (room.read(src), buf.get_mut(..n)) else {
        return false;
    };
    buf.copy_from_slice(old);
    let put = |slot: Option<&mut HashEntry>, e| slot.map(|s| *s = e).is_some();
    // Into one slice where the bucket lands within the part's own entries or the side
    // buffer; entry by entry where it lands across both.
    let len = (n + ins.len()).saturating_sub(rem.len());
    match room.dest(to, len) {
        Some(dst) => merge_bucket(buf, ins, rem, |w, e| put(dst.get_mut(w), e)),
        None => merge_bucket(buf, ins, rem, |w, e| put(room.slot(to + w), e)),
    }
}

/// The merge of [`rewrite`]: the entries of `old` less `rem`, plus `ins`, in decreasing item
/// order, handed to `put` with their places from 0; `false` when `put` refuses one or an
/// entry of `rem` is not in `old`.
///
/// # Bounded work
/// O(`old.len() + ins.len() + rem.len()`).
#[inline(always)]
fn merge_bucket<P>(old: &[HashEntry], ins: &[HashEntry], rem: &[HashEntry], mut put: P) -> bool
where
    P: FnMut(usize, HashEntry) -> bool,
{
    let (mut o, mut x, mut r, mut w) = (0usize, 0usize, 0usize, 0usize);
    loop {
        // The old entry next, once the removed ones are passed.
        while let (Some(e), Some(gone)) = (old.get(o), rem.get(r)) {
            if e != gone {
                break;
            }
            (o, r) = (o + 1, r + 1);
        }
        let next = match (old.get(o), ins.get(x)) {
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
        if !put(w, next) {
            return false;
        }
        w += 1;
    }
    r == rem.len()
}
