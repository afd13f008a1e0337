//! The drill's pending work: two rings in the caller's deque storage, one for the coarse pass
//! of every sphere and one for the fine pass that refines the last level (see
//! [`super::Drill::step`]).

use super::step::Pending;
use crate::hierarchy::MAX_DEPTH;

/// A ring of pending items over caller storage: items are taken from the front; a sphere's
/// new roots go to the back, a node's children to the front (so one tree is finished depth
/// first).
#[derive(Debug)]
pub(super) struct Ring<'a> {
    slots: &'a mut [Pending],
    head: usize,
    len: usize,
    /// The most items it has held at once (the high-water mark).
    peak: usize,
}

impl<'a> Ring<'a> {
    /// An empty ring over `slots` (its length is the capacity).
    pub(super) fn new(slots: &'a mut [Pending]) -> Self {
        Self {
            slots,
            head: 0,
            len: 0,
            peak: 0,
        }
    }

    /// Items waiting.
    #[inline]
    pub(super) fn len(&self) -> usize {
        self.len
    }

    /// The most items it has held at once since it was made.
    #[inline]
    pub(super) fn peak(&self) -> usize {
        self.peak
    }

    /// Its capacity.
    #[inline]
    pub(super) fn capacity(&self) -> usize {
        self.slots.len()
    }

    /// Free slots.
    #[inline]
    pub(super) fn free(&self) -> usize {
        self.slots.len() - self.len
    }

    /// The item at the back (the last one pushed there), if any.
    pub(super) fn back(&self) -> Option<&Pending> {
        let cap = self.slots.len();
        if self.len == 0 {
            return None;
        }
        self.slots.get((self.head + self.len - 1).checked_rem(cap)?)
    }

    /// Appends `p`; `false` when the ring is full.
    pub(super) fn push_back(&mut self, p: Pending) -> bool {
        let cap = self.slots.len();
        if self.len >= cap {
            return false;
        }
        let at = (self.head + self.len) % cap;
        if let Some(slot) = self.slots.get_mut(at) {
            *slot = p;
            self.len += 1;
            self.peak = self.peak.max(self.len);
            true
        } else {
            false
        }
    }

    /// Prepends `p`; `false` when the ring is full.
    pub(super) fn push_front(&mut self, p: Pending) -> bool {
        let cap = self.slots.len();
        if self.len >= cap {
            return false;
        }
        let at = (self.head + cap - 1) % cap;
        if let Some(slot) = self.slots.get_mut(at) {
            *slot = p;
            self.head = at;
            self.len += 1;
            self.peak = self.peak.max(self.len);
            true
        } else {
            false
        }
    }

    /// Takes the front item.
    pub(super) fn pop_front(&mut self) -> Option<Pending> {
        if self.len == 0 {
            return None;
        }
        let p = self.slots.get(self.head).copied()?;
        self.head = (self.head + 1) % self.slots.len().max(1);
        self.len -= 1;
        Some(p)
    }
}

/// Below this many entries the deque keeps no fine ring: every refinement is done in the
/// coarse pass (a small deque is a test's or a tiny target's, where the pass order does not
/// matter and every entry is wanted for the one pass).
pub(crate) const FINE_MIN_DEQUE: usize = 1024;

/// Free slots the fine ring keeps for a depth-first descent (at most 7 children waiting per
/// level, plus the item itself): a root is deferred only while more than this many are free.
pub(super) const FINE_DESCENT: usize = 8 * MAX_DEPTH + 1;

/// Splits the caller's deque storage: the coarse ring gets the first half, the fine ring the
/// second; a deque under [`FINE_MIN_DEQUE`] entries is all coarse.
pub(super) fn split(queue: &mut [Pending]) -> (Ring<'_>, Ring<'_>) {
    let fine = if queue.len() < FINE_MIN_DEQUE {
        0
    } else {
        queue.len() / 2
    };
    let (coarse, fine) = queue.split_at_mut(queue.len() - fine);
    (Ring::new(coarse), Ring::new(fine))
}
