//! The change log: which coarse tets' visible faces changed, for readers that keep a copy of
//! the surface (a [`super::SurfaceExport`]) and bring only those tets up to date.
//!
//! Erase and Refine append the coarse tets whose visible faces they changed (each tet once
//! an operation) to a ring of caller storage; a reader remembers the sequence number it has
//! read up to and asks for the entries after it with [`Hierarchy::change_at`]. Nothing is
//! ever waited for or consumed: any number of readers read the same log, each at its own
//! pace, and a reader that falls more than the ring's length behind (or reads across a
//! change of every face at once: a reset, a move of the nodes) is told the entries are lost
//! and looks at every tet instead. The log changes no result of the drill or the contact.

use super::store::Hierarchy;
use crate::ids::TetId;

/// What the change log holds at a sequence number ([`Hierarchy::change_at`]).
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum Change {
    /// The visible faces of this coarse tet changed.
    Tet(TetId),
    /// The entry is gone (the ring has been written over it since) or a change of every face
    /// at once came after it: every coarse tet may have changed.
    Lost,
    /// No entry yet: nothing changed since.
    End,
}

/// The most coarse tets one operation logs: the tet of the leaf and the tets across its four
/// faces.
const OP_TETS: usize = 5;

/// The coarse tets one operation changed, each once, logged together when it ends.
#[derive(Clone, Copy, Debug)]
pub(super) struct OpTets {
    tets: [TetId; OP_TETS],
    len: usize,
    /// A tet did not fit (never, with at most [`OP_TETS`] tets an operation): log every
    /// face as changed.
    spilled: bool,
}

impl OpTets {
    /// No tet yet.
    pub(super) fn new() -> Self {
        Self {
            tets: [TetId::NONE; OP_TETS],
            len: 0,
            spilled: false,
        }
    }

    /// Adds `tet` unless it is there.
    pub(super) fn add(&mut self, tet: TetId) {
        let seen = self.tets.get(..self.len).unwrap_or(&[]);
        if seen.contains(&tet) {
            return;
        }
        match self.tets.get_mut(self.len) {
            Some(slot) => {
                *slot = tet;
                self.len += 1;
            }
            None => self.spilled = true,
        }
    }
}

impl Hierarchy<'_> {
    /// The change log's entry `seq`: the coarse tet whose visible faces changed then,
    /// [`Change::Lost`] when the ring no longer holds it or every face changed at once since
    /// (a reset, [`crate::servo::World::set_positions`]), [`Change::End`] when there is no
    /// such entry yet (`seq` is [`Hierarchy::change_count`] or beyond). A reader that has
    /// read up to `seq` reads `seq`, `seq + 1`, ... until `End`.
    ///
    /// # Bounded work
    /// Constant.
    pub fn change_at(&self, seq: u64) -> Change {
        if seq >= self.logged {
            return Change::End;
        }
        let len = self.changes.len() as u64;
        if seq < self.all_at || self.logged - seq > len {
            return Change::Lost;
        }
        // `len` is not zero here: `logged - seq >= 1`.
        match self.changes.get((seq % len.max(1)) as usize) {
            Some(&t) => Change::Tet(t),
            None => Change::Lost,
        }
    }

    /// The change log's next sequence number: the entries written so far.
    #[inline]
    pub fn change_count(&self) -> u64 {
        self.logged
    }

    /// The change log's length just after the last change of every face at once (the
    /// creation or a reset of the trees, a move of the mesh's nodes): a reader whose copy was
    /// made before it redoes every face, positions included.
    #[inline]
    pub fn all_changed_at(&self) -> u64 {
        self.all_at
    }

    /// Logs the tets of one operation.
    ///
    /// # Bounded work
    /// At most [`OP_TETS`] entries.
    pub(super) fn log(&mut self, op: &OpTets) {
        if op.spilled {
            self.note_all_changed();
            return;
        }
        for &t in op.tets.iter().take(op.len) {
            let len = self.changes.len() as u64;
            if let Some(slot) = self.changes.get_mut((self.logged % len.max(1)) as usize) {
                *slot = t;
            }
            self.logged += 1;
        }
    }

    /// Notes a change of every visible face at once (the nodes moved, the trees were reset).
    ///
    /// # Bounded work
    /// Constant.
    pub(crate) fn note_all_changed(&mut self) {
        self.logged += 1;
        self.all_at = self.logged;
    }
}
