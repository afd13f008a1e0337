//! A [`World`](super::World)'s storage: the slices it borrows ([`WorldStorage`]), how many of each
//! ([`WorldSizes`]) and the one place both are carved from memory
//! ([`WorldStorage::carve`], [`SpareStorage::carve`]; see [`crate::storage`]).

use glam::Vec3;

use super::SpareStorage;
use crate::drill::Pending;
use crate::hash::{Aabb, HashEntry};
use crate::hierarchy::{HierarchySizes, HierarchyStorage, SphereSlot, DEFAULT_CHANGES};
use crate::ids::TetId;
use crate::storage::{carve, lines_of, Memory, Part, PartSet, Slots, StorageError, LINE};

/// Storage for a [`World`](super::World), handed in by the caller; [`WorldSizes`] says how much.
#[derive(Debug)]
pub struct WorldStorage<'a> {
    /// Bucket offsets of the tet hash (`buckets + 1`, the bucket count prime).
    pub hash_starts: &'a mut [u32],
    /// Entries of the tet hash (one per tet and overlapped cell).
    pub hash_entries: &'a mut [HashEntry],
    /// Each tet's bounding box, filled by [`World::new`](super::World::new) and [`World::set_positions`](super::World::set_positions) (one per
    /// tet; a tet beyond the slice has its box made from its corners each time it is needed,
    /// the same box).
    pub tet_boxes: &'a mut [Aabb],
    /// The hierarchy's roots, arena, v_list and change log.
    pub hierarchy: HierarchyStorage<'a>,
    /// The drill's pending-work deque.
    pub pending: &'a mut [Pending],
    /// Candidate coarse tets near the tool, refilled each simulation step.
    pub candidates: &'a mut [TetId],
    /// The contact search's memo of node bounding spheres ([`SphereMemo`](crate::hierarchy::SphereMemo), 24 bytes a slot;
    /// empty: none). It saves work, never changes a result.
    pub sphere_memo: &'a mut [SphereSlot],
}

/// Storage sizes for a [`World`](super::World) over a mesh of `tets` tets.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct WorldSizes {
    /// `hash_starts` length.
    pub hash_starts: usize,
    /// `hash_entries` length.
    pub hash_entries: usize,
    /// `tet_boxes` length (24 bytes each).
    pub tet_boxes: usize,
    /// Hierarchy root slots.
    pub roots: usize,
    /// Hierarchy arena nodes.
    pub arena: usize,
    /// v_list entries.
    pub vlist: usize,
    /// Hierarchy change log entries ([`crate::hierarchy::DEFAULT_CHANGES`] by default).
    pub changes: usize,
    /// Pending drill work items.
    pub pending: usize,
    /// Candidate tets near the tool.
    pub candidates: usize,
    /// `sphere_memo` slots.
    pub sphere_memo: usize,
}

/// Default capacity of the drill's pending deque: the demo path (`builtin:demo`, burr 0.1 on
/// `builtin:block:8`, max depth 5) peaked at about 22,400 items with the budget of the time
/// (docs/DRILLING.md), and runs free of saturations at today's default and at every budget
/// from 4,000 to 32,000 units, so 32,768 (64 bytes each, 2.0 MB). A board with little RAM
/// sizes it with [`WorldSizes::with_pending`] (the firmware's scenario peaks under 2,000).
pub const DEFAULT_PENDING: usize = 1 << 15;

/// Default size of the contact search's [`SphereMemo`](crate::hierarchy::SphereMemo): 4,096 slots (96 KB).
pub const DEFAULT_SPHERE_MEMO: usize = 1 << 12;

impl WorldSizes {
    /// Sizes for `tets` coarse tets and an arena of `arena` hierarchy nodes. The hash gets about
    /// two buckets per tet and eight entries per tet (a tet's box covers one to eight cells of
    /// an average edge length; slivers more, and a full table is counted, not fatal); the
    /// pending deque gets [`DEFAULT_PENDING`] entries.
    pub const fn new(tets: usize, arena: usize) -> Self {
        let arena = arena / 8 * 8;
        Self {
            hash_starts: 2 * tets + 2,
            hash_entries: 8 * tets,
            tet_boxes: tets,
            roots: tets,
            arena,
            vlist: HierarchyStorage::vlist_needed(tets, arena),
            changes: DEFAULT_CHANGES,
            pending: DEFAULT_PENDING,
            candidates: 1024,
            sphere_memo: DEFAULT_SPHERE_MEMO,
        }
    }

    /// The same sizes with a pending deque of `pending` entries. A deque that never fills
    /// gives the same results whatever its capacity.
    pub const fn with_pending(self, pending: usize) -> Self {
        Self { pending, ..self }
    }

    /// The same sizes with a hierarchy change log of `entries` entries (zero: a surface
    /// exporter sweeps every coarse tet after each change; a world without one needs none).
    pub const fn with_changes(self, entries: usize) -> Self {
        Self {
            changes: entries,
            ..self
        }
    }

    /// The same sizes with a sphere memo of `slots` slots (any size, zero included, gives the
    /// same results).
    pub const fn with_sphere_memo(self, slots: usize) -> Self {
        Self {
            sphere_memo: slots,
            ..self
        }
    }
}

impl WorldSizes {
    /// The hierarchy's part of these sizes.
    pub const fn hierarchy(&self) -> HierarchySizes {
        HierarchySizes {
            roots: self.roots,
            arena: self.arena,
            vlist: self.vlist,
            changes: self.changes,
        }
    }

    /// Every slice of a [`WorldStorage`], in the order [`WorldStorage::carve`] takes them.
    pub const fn parts(&self) -> [Slots; 10] {
        let h = self.hierarchy().parts();
        [
            Slots::of::<u32>(Part::HashStarts, self.hash_starts),
            Slots::of::<HashEntry>(Part::HashEntries, self.hash_entries),
            Slots::of::<Aabb>(Part::TetBoxes, self.tet_boxes),
            h[0],
            h[1],
            h[2],
            h[3],
            Slots::of::<Pending>(Part::Pending, self.pending),
            Slots::of::<TetId>(Part::Candidates, self.candidates),
            Slots::of::<SphereSlot>(Part::SphereMemo, self.sphere_memo),
        ]
    }

    /// The [`crate::storage::Line`]s a [`crate::storage::Block`] starting on a line needs for a
    /// [`WorldStorage`] (`None` when the sizes overflow the address space).
    pub const fn lines(&self) -> Option<usize> {
        lines_of(&self.parts(), PartSet::EMPTY, false)
    }

    /// The bytes of [`WorldSizes::lines`].
    pub const fn bytes(&self) -> Option<usize> {
        match self.lines() {
            Some(l) => l.checked_mul(LINE),
            None => None,
        }
    }

    /// The lines of the parts in `set` (`in_set`) or of the others (`!in_set`): the two runs
    /// of a [`crate::storage::Split`].
    pub const fn lines_in(&self, set: PartSet, in_set: bool) -> Option<usize> {
        lines_of(&self.parts(), set, in_set)
    }

    /// The slices of a deforming world's [`SpareStorage`] over a mesh of `nodes` nodes, then
    /// its rest positions ([`World::enable_deformation`](super::World::enable_deformation)), in the order
    /// [`SpareStorage::carve`] and [`carve_rest`] take them.
    pub const fn deform_parts(&self, nodes: usize) -> [Slots; 5] {
        [
            Slots::of::<u32>(Part::SpareHashStarts, self.hash_starts),
            Slots::of::<HashEntry>(Part::SpareHashEntries, self.hash_entries),
            Slots::of::<Aabb>(Part::SpareTetBoxes, self.tet_boxes),
            Slots::of::<Vec3>(Part::SpareNormals, nodes),
            Slots::of::<Vec3>(Part::RestPositions, nodes),
        ]
    }

    /// The lines of [`WorldSizes::deform_parts`].
    pub const fn deform_lines(&self, nodes: usize) -> Option<usize> {
        lines_of(&self.deform_parts(nodes), PartSet::EMPTY, false)
    }
}

impl<'a> WorldStorage<'a> {
    /// Carves every slice of `sizes` from `mem`, each slot at its starting value: the one
    /// way a world's storage is made, whatever the memory (a [`crate::storage::Block`], a
    /// board's [`crate::storage::Split`], the heap's `owned::WorldBuffers`).
    ///
    /// # Bounded work
    /// O(bytes of `sizes`): every slot is written.
    ///
    /// # Errors
    /// [`StorageError`] naming the first part the memory could not hold.
    pub fn carve(sizes: &WorldSizes, mem: &mut impl Memory<'a>) -> Result<Self, StorageError> {
        Ok(Self {
            hash_starts: carve(mem, Part::HashStarts, sizes.hash_starts, 0u32)?,
            hash_entries: carve(
                mem,
                Part::HashEntries,
                sizes.hash_entries,
                HashEntry::default(),
            )?,
            tet_boxes: carve(
                mem,
                Part::TetBoxes,
                sizes.tet_boxes,
                Aabb::point(Vec3::ZERO),
            )?,
            hierarchy: HierarchyStorage::carve(&sizes.hierarchy(), mem)?,
            pending: carve(mem, Part::Pending, sizes.pending, Pending::default())?,
            candidates: carve(mem, Part::Candidates, sizes.candidates, TetId::NONE)?,
            sphere_memo: carve(mem, Part::SphereMemo, sizes.sphere_memo, SphereSlot::EMPTY)?,
        })
    }
}

impl<'a> SpareStorage<'a> {
    /// Carves the spare tables of a deforming world with storage `sizes` over a mesh of
    /// `nodes` nodes ([`World::set_spare`](super::World::set_spare)).
    ///
    /// # Bounded work
    /// O(bytes): every slot is written.
    ///
    /// # Errors
    /// [`StorageError`] naming the first part the memory could not hold.
    pub fn carve(
        sizes: &WorldSizes,
        nodes: usize,
        mem: &mut impl Memory<'a>,
    ) -> Result<Self, StorageError> {
        Ok(Self {
            hash_starts: carve(mem, Part::SpareHashStarts, sizes.hash_starts, 0u32)?,
            hash_entries: carve(
                mem,
                Part::SpareHashEntries,
                sizes.hash_entries,
                HashEntry::default(),
            )?,
            tet_boxes: carve(
                mem,
                Part::SpareTetBoxes,
                sizes.tet_boxes,
                Aabb::point(Vec3::ZERO),
            )?,
            normals: carve(mem, Part::SpareNormals, nodes, Vec3::ZERO)?,
        })
    }
}

/// Carves a deforming world's rest positions for `nodes` nodes
/// ([`World::enable_deformation`](super::World::enable_deformation)).
///
/// # Bounded work
/// O(`nodes`).
///
/// # Errors
/// [`StorageError`] when the memory cannot hold them.
pub fn carve_rest<'a>(
    nodes: usize,
    mem: &mut impl Memory<'a>,
) -> Result<&'a mut [Vec3], StorageError> {
    carve(mem, Part::RestPositions, nodes, Vec3::ZERO)
}
