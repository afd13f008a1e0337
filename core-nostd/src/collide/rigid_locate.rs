//! The lookups of a [`RigidTets`]: rest-frame points in their rest grid cells, the smallest
//! tet holding each, a batch at a time ([`RigidTets::locate_batch`]).

use glam::Vec3;

use super::entry::{levels, GridEntry};
use super::rigid::{dense_index, RigidTets};
use super::{candidate_holds, Body, CollideReport};
use crate::ids::TetId;

impl RigidTets<'_> {
    /// Rest-frame point `q`'s rest grid cell: where its entries start and end in `grid_tets`
    /// and `q`'s levels in it ([`GridEntry`]); an empty range outside the tets' bounds.
    #[inline]
    fn rest_cell(&self, q: Vec3) -> (usize, usize, u32) {
        if !self.bounds.contains(q) {
            return (0, 0, 0); // no tet holds it
        }
        // `dense_cell`, keeping the grid coordinates for the levels.
        let g = (q - self.bounds.min) * self.grid_inv;
        let c = crate::hash::cell_of(g, 1.0);
        let c = [0, 1, 2].map(|a| c[a].clamp(0, self.grid_dims[a] - 1));
        let i = dense_index(self.grid_dims, c);
        let lo = self.grid_starts.get(i).copied().unwrap_or(0) as usize;
        let hi = self.grid_starts.get(i + 1).copied().unwrap_or(0) as usize;
        (lo, hi.max(lo), levels(g, c))
    }

    /// The tets of rest-frame point `q`'s rest grid cell whose entry admits it, in list
    /// order, then how many the cell lists (for the tests of the filter).
    #[cfg(test)]
    pub(super) fn admitted(&self, q: Vec3, mut f: impl FnMut(TetId)) -> usize {
        let (lo, hi, at) = self.rest_cell(q);
        let list = self.grid_tets.get(lo..hi).unwrap_or(&[]);
        for e in list.iter().filter(|e| e.admits(at)) {
            f(e.tet());
        }
        list.len()
    }

    /// The rest grid's origin, cells per unit and cells per axis (for the tests of the
    /// filter).
    #[cfg(test)]
    pub(super) fn rest_grid(&self) -> (Vec3, Vec3, [i32; 3]) {
        (self.bounds.min, self.grid_inv, self.grid_dims)
    }

    /// The smallest tet holding world point `p` (rest-frame `q`): [`RigidTets::locate_batch`]
    /// of one point.
    pub(super) fn locate(
        &self,
        q: Vec3,
        p: Vec3,
        body: &Body<'_, '_>,
        r: &mut CollideReport,
    ) -> TetId {
        let mut found = [TetId::NONE];
        self.locate_batch(&[Pending { node: 0, p, q }], body, r, &mut found);
        found[0]
    }

    /// For each pending point (world `p`, rest-frame `q`), the smallest tet holding it, in
    /// `found` (`NONE`: none): of its rest grid cell's tets in increasing id order, the first
    /// whose grown box holds `q` and whose moved corners in `body` hold `p` (the barycentric
    /// test); the entries' quantised boxes ([`GridEntry`]) skip tets whose box cannot hold
    /// `q`. Stage by stage over the batch, so that what each point's stage reads is requested
    /// for every point before any is waited for: every point's cell range, then every point's
    /// entry tests on its cell's first [`MASKED`] entries (one bit each, no branch per
    /// entry), then round by round each point's next admitted tet (box and barycentric test),
    /// until each point is found or out of admitted tets; last, for the points not found,
    /// the cell's entries beyond the first [`MASKED`] one by one. Each point meets the same
    /// box and barycentric tests, in the same order, as alone.
    ///
    /// # Bounded work
    /// Per point at most `b` entry tests, `b` box tests and `b` barycentric tests, for `b`
    /// the fullest cell of the rest grid.
    pub(super) fn locate_batch(
        &self,
        batch: &[Pending],
        body: &Body<'_, '_>,
        r: &mut CollideReport,
        found: &mut [TetId],
    ) {
        let mut ranges = [(0usize, 0usize, 0u32); BATCH];
        for (range, pt) in ranges.iter_mut().zip(batch) {
            *range = self.rest_cell(pt.q);
        }
        let mut masks = [0u64; BATCH];
        for (k, &(lo, hi, at)) in ranges.iter().take(batch.len()).enumerate() {
            let head = self.grid_tets.get(lo..hi.min(lo + MASKED)).unwrap_or(&[]);
            let mut mask = 0u64;
            for (j, e) in head.iter().enumerate() {
                mask |= (e.admits(at) as u64) << j;
            }
            masks[k] = mask;
        }
        // The exact test: the tet's grown box, then its moved corners (both read before
        // either is tested, so that their loads overlap).
        let holds = |pt: &Pending, e: &GridEntry, r: &mut CollideReport| {
            let b = self.tet_boxes.get(e.tet().idx());
            let corners = body.tet_positions(e.tet());
            b.is_some_and(|b| b.contains(pt.q))
                && corners.is_some_and(|corners| candidate_holds(pt.p, corners, r))
        };
        let n = batch.len().min(BATCH).min(found.len());
        for slot in found.iter_mut().take(n) {
            *slot = TetId::NONE;
        }
        // Round by round, each point's next admitted tet (its first holder in list order
        // ends its search): the points' tests of a round are independent.
        let mut open = masks.iter().take(n).any(|&m| m != 0);
        while open {
            open = false;
            for k in 0..n {
                let mask = masks[k];
                if mask == 0 {
                    continue;
                }
                let j = mask.trailing_zeros() as usize;
                masks[k] = mask & (mask - 1);
                let (lo, _, _) = ranges[k];
                let e = self.grid_tets.get(lo + j).copied().unwrap_or_default();
                if holds(&batch[k], &e, r) {
                    found[k] = e.tet();
                    masks[k] = 0;
                } else {
                    open |= masks[k] != 0;
                }
            }
        }
        // The tets beyond each cell's first `MASKED`, in order, for the points not found.
        for k in 0..n {
            let (lo, hi, at) = ranges[k];
            if found[k].is_some() || hi - lo <= MASKED {
                continue;
            }
            let rest = self.grid_tets.get(lo + MASKED..hi).unwrap_or(&[]);
            for e in rest {
                if e.admits(at) && holds(&batch[k], e, r) {
                    found[k] = e.tet();
                    break;
                }
            }
        }
    }
}

/// Points a cluster gathers before their lookups (`RigidTets::locate_batch`).
pub(super) const BATCH: usize = 32;

/// A rest grid cell's first entries whose tests [`RigidTets::locate_batch`] gathers into one
/// mask (the bits of a `u64`).
const MASKED: usize = 64;

/// A point waiting for its lookup: its index, world position and rest-frame position.
#[derive(Clone, Copy, Default)]
pub(super) struct Pending {
    pub(super) node: u32,
    pub(super) p: Vec3,
    pub(super) q: Vec3,
}
