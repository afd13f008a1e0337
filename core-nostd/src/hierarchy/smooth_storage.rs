//! The storage, counters and errors of [`super::SmoothNormals`]: [`SmoothSizes`],
//! [`SmoothStorage`] (carved like every other part), [`SmoothStats`], [`SmoothError`].

use super::smooth::{SmoothSlot, SmoothVertex, NO};
use crate::storage::{carve, lines_of, Memory, Part, PartSet, Slots, StorageError, LINE};

/// Sizes of a [`SmoothStorage`]: as many slot records as the exporter's triangle slots, the
/// shared vertices, and the queue of vertices to recompute; the hash table is the next power
/// of two at or above twice the vertices.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct SmoothSizes {
    /// Triangle slots (the exporter's [`super::SurfaceSizes`]).
    pub slots: usize,
    /// Shared vertices.
    pub vertices: usize,
    /// Queue entries.
    pub queue: usize,
}

impl SmoothSizes {
    /// Sizes for `slots` triangle slots, `vertices` shared vertices and `queue` queue entries
    /// (at least one).
    pub const fn new(slots: usize, vertices: usize, queue: usize) -> Self {
        Self {
            slots,
            vertices,
            queue: if queue == 0 { 1 } else { queue },
        }
    }

    /// Sizes for `slots` triangle slots with room for the drilled surfaces seen: as many
    /// vertices as slots (a drilled surface of `F` faces has about `0.6 F`; a closed one
    /// `F / 2`) and a queue of an eighth of them (at least 64).
    pub const fn for_slots(slots: usize) -> Self {
        let q = slots / 8;
        Self::new(slots, slots, if q < 64 { 64 } else { q })
    }

    /// Hash table entries: the next power of two at or above twice the vertices (at least
    /// one; `usize::MAX` on overflow, which no memory holds).
    pub const fn table(&self) -> usize {
        match self.vertices.checked_mul(2) {
            Some(t) => match t.checked_next_power_of_two() {
                Some(p) => p,
                None => usize::MAX,
            },
            None => usize::MAX,
        }
    }

    /// The slices of a [`SmoothStorage`], in the order [`SmoothStorage::carve`] takes them.
    pub const fn parts(&self) -> [Slots; 4] {
        [
            Slots::of::<SmoothSlot>(Part::SmoothSlots, self.slots),
            Slots::of::<SmoothVertex>(Part::SmoothVertices, self.vertices),
            Slots::of::<u32>(Part::SmoothTable, self.table()),
            Slots::of::<u32>(Part::SmoothQueue, self.queue),
        ]
    }

    /// The [`crate::storage::Line`]s a block starting on a line needs for these sizes.
    pub const fn lines(&self) -> Option<usize> {
        lines_of(&self.parts(), PartSet::EMPTY, false)
    }

    /// Bytes of a block for these sizes (`None` on overflow).
    pub const fn bytes(&self) -> Option<usize> {
        match self.lines() {
            Some(l) => l.checked_mul(LINE),
            None => None,
        }
    }
}

/// Caller storage for [`super::SmoothNormals`]: one [`SmoothSlot`] a triangle slot of the exporter
/// (exactly as many), the vertices, a hash table of vertex indices (a power of two, at least
/// twice the vertices) and the queue of vertices to recompute. [`SmoothStorage::carve`] takes
/// them from a [`Memory`] in the sizes of a [`SmoothSizes`].
#[derive(Debug)]
pub struct SmoothStorage<'a> {
    /// One record a triangle slot of the exporter, [`SmoothSlot::FREE`].
    pub slots: &'a mut [SmoothSlot],
    /// Vertices, [`SmoothVertex::EMPTY`]: a surface of `F` faces has about `F / 2` of them.
    pub vertices: &'a mut [SmoothVertex],
    /// The hash table, any contents (it is cleared).
    pub table: &'a mut [u32],
    /// The queue of vertices to recompute, any contents.
    pub queue: &'a mut [u32],
}

impl<'a> SmoothStorage<'a> {
    /// Carves the slices of `sizes` from `mem`, in their starting values.
    ///
    /// # Bounded work
    /// O(bytes of `sizes`).
    ///
    /// # Errors
    /// [`StorageError`] naming the first part the memory could not hold.
    pub fn carve(sizes: &SmoothSizes, mem: &mut impl Memory<'a>) -> Result<Self, StorageError> {
        Ok(Self {
            slots: carve(mem, Part::SmoothSlots, sizes.slots, SmoothSlot::FREE)?,
            vertices: carve(
                mem,
                Part::SmoothVertices,
                sizes.vertices,
                SmoothVertex::EMPTY,
            )?,
            table: carve(mem, Part::SmoothTable, sizes.table(), NO)?,
            queue: carve(mem, Part::SmoothQueue, sizes.queue, NO)?,
        })
    }
}

/// What went short in a [`super::SmoothNormals`], counted since it was made.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default)]
pub struct SmoothStats {
    /// Live shared vertices.
    pub vertices: u32,
    /// Face corners that found no free vertex (the vertices are full): such a corner keeps
    /// its face's own normal and shares with no other face until its face is listed again.
    pub vertices_full: u32,
    /// Times the queue was full: every vertex is then recomputed, a bounded amount a call.
    pub queue_full: u32,
    /// Corners recomputed.
    pub corners: u64,
}

/// Why a [`super::SmoothNormals`] could not be made.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum SmoothError {
    /// The table is not a power of two at least twice the vertices, the queue is empty, or
    /// the slots do not match the exporter's.
    Storage,
}

impl core::fmt::Display for SmoothError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "smooth normal storage does not fit")
    }
}
