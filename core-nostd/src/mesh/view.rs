//! Where a mesh's tets live: in RAM as [`Tet`] records ([`Mesh::build`] fills them), or read in
//! place from the bytes of a mesh blob by a [`TetView`] (a firmware keeps the blob in flash
//! and copies none of its 36 bytes a tet into RAM).
//!
//! A [`TetView`] decodes fixed-width little-endian fields on each access (no `unsafe`, no
//! alignment needed). It checks every record once, when it is made: node ids below the node
//! count, neighbour ids below the tet count (or `NONE`), reverse indices within their values
//! and every neighbour pointing back through its reverse index. After that no access can
//! lead outside the mesh, and no accessor panics: an id out of range gives `None`.
//!
//! [`Mesh::build`]: super::Mesh::build

use super::record::{le32, Reverse, Tet, TET_RECORD};
use crate::ids::{NodeId, TetId};

/// Why bytes were refused as tet records.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum TetViewError {
    /// The length is not a whole number of records, or the tets or nodes do not fit `u32`
    /// ids.
    Length {
        /// Bytes handed in.
        len: usize,
    },
    /// A record refers outside the mesh or disagrees with its neighbour.
    BadRecord {
        /// What is wrong.
        what: &'static str,
        /// Byte offset of the field in the bytes handed in.
        offset: usize,
    },
}

impl core::fmt::Display for TetViewError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match *self {
            Self::Length { len } => write!(
                f,
                "{len} bytes are not a whole number of {TET_RECORD}-byte tet records"
            ),
            Self::BadRecord { what, offset } => write!(f, "byte {offset}: {what}"),
        }
    }
}

impl core::error::Error for TetViewError {}

/// Checked tet records read in place: record `t` is bytes `36 t .. 36 t + 36`, laid out as
/// [`Tet::to_le_bytes`] writes it.
#[derive(Clone, Copy, Debug)]
pub struct TetView<'a> {
    recs: &'a [[u8; TET_RECORD]],
    nodes: usize,
}

impl TetView<'static> {
    /// No tets.
    pub(crate) const EMPTY: Self = Self {
        recs: &[],
        nodes: 0,
    };
}

impl<'a> TetView<'a> {
    /// Checks `bytes` as the records of a mesh with `node_count` nodes and gives the view.
    ///
    /// # Bounded work
    /// O(T) for T records: each record read once, and each neighbour's record once more for
    /// the back-pointer.
    ///
    /// # Errors
    /// The first bad field, with its byte offset in `bytes`.
    pub fn new(bytes: &'a [u8], node_count: usize) -> Result<Self, TetViewError> {
        let (recs, rest) = bytes.as_chunks::<TET_RECORD>();
        let fits = |n: usize| u32::try_from(n).is_ok_and(|n| n != u32::MAX);
        if !rest.is_empty() || !fits(recs.len()) || !fits(node_count) {
            return Err(TetViewError::Length { len: bytes.len() });
        }
        let bad = |what, offset| Err(TetViewError::BadRecord { what, offset });
        for (t, rec) in recs.iter().enumerate() {
            let at = TET_RECORD * t;
            for k in 0..4 {
                if le32(rec, 4 * k) as usize >= node_count {
                    return bad("tet: node id out of range", at + 4 * k);
                }
                let r = Reverse(rec[32 + k]);
                if r.0 >= 16 || r.offset() > 2 {
                    return bad("tet: reverse index out of range", at + 32 + k);
                }
                let nb = le32(rec, 16 + 4 * k);
                if nb == TetId::NONE.0 {
                    continue;
                }
                let Some(other) = recs.get(nb as usize) else {
                    return bad("tet: neighbour id out of range", at + 16 + 4 * k);
                };
                if le32(other, 16 + 4 * r.face() as usize) as usize != t {
                    return bad(
                        "tet: the neighbour does not point back through the reverse index",
                        at + 32 + k,
                    );
                }
            }
        }
        Ok(Self {
            recs,
            nodes: node_count,
        })
    }

    /// Number of tets.
    #[inline]
    pub fn len(&self) -> usize {
        self.recs.len()
    }

    /// `true` when there are no tets.
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.recs.is_empty()
    }

    /// The node count the node ids were checked against.
    #[inline]
    pub fn node_count(&self) -> usize {
        self.nodes
    }

    /// Tet `t` decoded; `None` out of range.
    ///
    /// # Bounded work
    /// O(1).
    #[inline]
    pub fn get(&self, t: TetId) -> Option<Tet> {
        self.recs.get(t.idx()).map(Tet::from_le_bytes)
    }

    /// The four node ids of tet `t`; `None` out of range.
    ///
    /// # Bounded work
    /// O(1).
    #[inline]
    pub fn nodes(&self, t: TetId) -> Option<[NodeId; 4]> {
        let rec = self.recs.get(t.idx())?;
        Some([0, 4, 8, 12].map(|at| NodeId(le32(rec, at))))
    }

    /// The tet across face `f` of `t` (`NONE` on the boundary); `None` when `t` or `f` is out
    /// of range.
    ///
    /// # Bounded work
    /// O(1).
    #[inline]
    pub fn neighbour(&self, t: TetId, f: u8) -> Option<TetId> {
        let rec = self.recs.get(t.idx())?;
        (f < 4).then(|| TetId(le32(rec, 16 + 4 * (f as usize & 3))))
    }

    /// The reverse index of face `f` of `t`; `None` when `t` or `f` is out of range.
    ///
    /// # Bounded work
    /// O(1).
    #[inline]
    pub fn reverse(&self, t: TetId, f: u8) -> Option<Reverse> {
        let rec = self.recs.get(t.idx())?;
        rec.get(32 + f as usize)
            .filter(|_| f < 4)
            .map(|&b| Reverse(b))
    }
}

/// A mesh's tet storage: RAM records or a checked in-place view. Copying it copies a
/// reference.
#[derive(Clone, Copy, Debug)]
pub enum TetStore<'a> {
    /// Records in RAM, as [`super::Mesh::build`] wrote them.
    Ram(&'a [Tet]),
    /// Records read in place from a blob's bytes.
    InPlace(TetView<'a>),
}

impl TetStore<'_> {
    /// Number of tets.
    #[inline]
    pub(crate) fn len(&self) -> usize {
        match self {
            Self::Ram(s) => s.len(),
            Self::InPlace(v) => v.len(),
        }
    }

    /// Tet `t`; `None` out of range.
    ///
    /// # Bounded work
    /// O(1).
    #[inline]
    pub(crate) fn get(&self, t: TetId) -> Option<Tet> {
        match self {
            Self::Ram(s) => s.get(t.idx()).copied(),
            Self::InPlace(v) => v.get(t),
        }
    }
}

/// Every tet of a mesh in id order, by value ([`super::Mesh::tets`]).
#[derive(Clone, Debug)]
pub struct TetIter<'a> {
    store: TetStore<'a>,
    next: usize,
    end: usize,
}

impl<'a> TetIter<'a> {
    pub(super) fn new(store: TetStore<'a>) -> Self {
        Self {
            end: store.len(),
            store,
            next: 0,
        }
    }
}

impl Iterator for TetIter<'_> {
    type Item = Tet;

    #[inline]
    fn next(&mut self) -> Option<Tet> {
        if self.next >= self.end {
            return None;
        }
        let t = self.store.get(TetId::from_idx(self.next));
        self.next += 1;
        t
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        let n = self.end - self.next;
        (n, Some(n))
    }
}

impl ExactSizeIterator for TetIter<'_> {}
