//! [`Hierarchy`]: the forest of subdivision trees over caller storage.

use super::node::{HNode, VEntry, MAX_BLOCKS, NO_SLOT};
use super::table::{Path, MAX_DEPTH};
use crate::ids::TetId;
use crate::mesh::Mesh;
use crate::storage::{carve, lines_of, Memory, Part, PartSet, Slots, StorageError};

/// Storage for a [`Hierarchy`], handed in by the caller. Lengths are capacities.
#[derive(Debug)]
pub struct HierarchyStorage<'a> {
    /// One root slot per coarse tet (the root node itself: an untouched tet costs 8 bytes and
    /// nothing else).
    pub roots: &'a mut [HNode],
    /// The node arena; children are allocated in blocks of 8 contiguous nodes, so its usable
    /// length is a multiple of 8 (at most `8 * (2^24 - 1)` nodes). Once every block has been
    /// handed out, blocks of wholly erased subtrees are reused (see [`Hierarchy`]).
    pub arena: &'a mut [HNode],
    /// The v_list; needs [`HierarchyStorage::vlist_needed`] entries.
    pub vlist: &'a mut [VEntry],
    /// The change log: the coarse tets whose visible faces changed, newest last, as a ring
    /// (any length, zero included; see [`Hierarchy::change_at`]).
    pub changes: &'a mut [TetId],
}

impl<'a> HierarchyStorage<'a> {
    /// v_list entries needed for `tets` coarse tets and an arena of `arena` nodes: the most
    /// non-erased leaves there can be (each block of 8 turns one leaf into eight).
    pub const fn vlist_needed(tets: usize, arena: usize) -> usize {
        tets + 7 * (arena / 8)
    }

    /// Carves the roots, arena and v_list of `sizes` from `mem`, every node a fresh leaf:
    /// the one way a hierarchy's storage is made (inside a world's too).
    ///
    /// # Bounded work
    /// O(bytes of `sizes`): every slot is written.
    ///
    /// # Errors
    /// [`StorageError`] naming the first part the memory could not hold.
    pub fn carve(sizes: &HierarchySizes, mem: &mut impl Memory<'a>) -> Result<Self, StorageError> {
        Ok(Self {
            roots: carve(mem, Part::Roots, sizes.roots, HNode::default())?,
            arena: carve(mem, Part::Arena, sizes.arena, HNode::default())?,
            vlist: carve(mem, Part::VList, sizes.vlist, VEntry::default())?,
            changes: carve(mem, Part::Changes, sizes.changes, TetId::NONE)?,
        })
    }
}

/// Storage sizes of a [`Hierarchy`]: root slots, arena nodes, v_list entries, change log
/// entries.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct HierarchySizes {
    /// Root slots (one per coarse tet).
    pub roots: usize,
    /// Arena nodes (a multiple of 8).
    pub arena: usize,
    /// v_list entries ([`HierarchyStorage::vlist_needed`]).
    pub vlist: usize,
    /// Change log entries ([`DEFAULT_CHANGES`] by default; any number, zero included).
    pub changes: usize,
}

/// Default length of a hierarchy's change log ([`Hierarchy::change_at`]): 8,192 entries (32
/// KB). The demo path (`builtin:demo`) logs at most 232 entries a simulation step and 3,284 a
/// 60 Hz frame (17 steps at 1 kHz), so a surface exporter read once a frame at 30 Hz or
/// faster keeps up; one that falls further behind sweeps every coarse tet instead
/// ([`crate::hierarchy::SurfaceExport`]).
pub const DEFAULT_CHANGES: usize = 1 << 13;

impl HierarchySizes {
    /// Sizes for `tets` coarse tets and an arena of about `arena` nodes (rounded down to a
    /// block of 8), with the v_list they need and a change log of [`DEFAULT_CHANGES`].
    pub const fn new(tets: usize, arena: usize) -> Self {
        let arena = arena / 8 * 8;
        Self {
            roots: tets,
            arena,
            vlist: HierarchyStorage::vlist_needed(tets, arena),
            changes: DEFAULT_CHANGES,
        }
    }

    /// The same sizes with a change log of `entries` entries.
    pub const fn with_changes(self, entries: usize) -> Self {
        Self {
            changes: entries,
            ..self
        }
    }

    /// The slices of a [`HierarchyStorage`], in the order [`HierarchyStorage::carve`] takes
    /// them.
    pub const fn parts(&self) -> [Slots; 4] {
        [
            Slots::of::<HNode>(Part::Roots, self.roots),
            Slots::of::<HNode>(Part::Arena, self.arena),
            Slots::of::<VEntry>(Part::VList, self.vlist),
            Slots::of::<TetId>(Part::Changes, self.changes),
        ]
    }

    /// The [`crate::storage::Line`]s a block starting on a line needs for these sizes.
    pub const fn lines(&self) -> Option<usize> {
        lines_of(&self.parts(), PartSet::EMPTY, false)
    }
}

/// Why a hierarchy could not be created, or an operation was refused.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
#[non_exhaustive]
pub enum HierarchyError {
    /// A storage slice is too short: `what` names it.
    StorageTooSmall {
        /// "roots" or "vlist".
        what: &'static str,
        /// Entries needed.
        needed: usize,
    },
    /// No such node in the tree (not instantiated, or the tet is out of range).
    NotFound,
    /// The node has children.
    NotLeaf,
    /// The node is erased.
    Erased,
    /// The node is at [`MAX_DEPTH`].
    TooDeep,
    /// The arena is full: the refinement was not done (counted in `saturations`).
    Full,
    /// [`Hierarchy::validate`] found a broken invariant (named).
    Invalid(&'static str),
    /// The memory could not hold the hierarchy's storage ([`HierarchyStorage::carve`]).
    Storage(StorageError),
}

impl core::fmt::Display for HierarchyError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match *self {
            Self::StorageTooSmall { what, needed } => {
                write!(
                    f,
                    "hierarchy {what} storage too small: {needed} entries needed"
                )
            }
            Self::NotFound => write!(f, "no such hierarchy node"),
            Self::NotLeaf => write!(f, "the node is not a leaf"),
            Self::Erased => write!(f, "the node is erased"),
            Self::TooDeep => write!(f, "the node is at the deepest level"),
            Self::Full => write!(f, "the hierarchy arena is full"),
            Self::Invalid(what) => write!(f, "hierarchy invariant broken: {what}"),
            Self::Storage(e) => write!(f, "{e}"),
        }
    }
}

impl core::error::Error for HierarchyError {}

/// Counters kept by a [`Hierarchy`].
#[derive(Clone, Copy, PartialEq, Debug, Default)]
pub struct HierarchyStats {
    /// Visible faces of non-erased leaves (the rendered triangles).
    pub visible_faces: u32,
    /// Leaves erased by Erase (a parent that becomes an erased leaf when its block is taken
    /// back is not counted again).
    pub erased: u32,
    /// Refinements done.
    pub refines: u32,
    /// Refinements refused because the arena was full (no fresh block and none to take back).
    pub saturations: u32,
    /// Blocks taken back from wholly erased subtrees and reused (0 while the arena has fresh
    /// blocks: until then every node reference stays valid).
    pub reclaimed: u32,
    /// Sum of the erased leaves' volumes (each `root volume / 8^depth`, Bey's children having
    /// equal volumes), at the positions of the moment they were erased.
    pub removed_volume: f64,
}

/// The forest of 1:8 subdivision trees, one per coarse tet, instantiated from each root to its
/// frontier, with the visible faces kept exact by Erase and Refine (Turini et al. 2006,
/// section 2.1).
///
/// A node is named two ways: by `(tet, tree index)` (stable, geometric), and by a node
/// reference `r` (`r < tets`: the root of tet `r`; otherwise arena node `r - tets`).
///
/// # Arena: fresh blocks first, then blocks of wholly erased subtrees
/// Children come in blocks of 8 arena nodes. A refinement takes the next fresh block while
/// there is one (a bump allocator). Once every block has been handed out, it takes back a
/// block whose 8 nodes are all erased leaves: their parent becomes an erased leaf itself
/// (nothing visible changes: every leaf below it was erased) and the block is reused. Such
/// blocks wait on a list threaded through their own erased leaves' spare words, so taking
/// one is O(depth); a parent that becomes an erased leaf may complete its own block, which
/// then joins the list (the cascade is one level per block taken, at most
/// [`MAX_DEPTH`] levels for a subtree). Only when no fresh and no reclaimable block is left
/// is a refinement refused (and counted).
///
/// Blocks are taken back only when the fresh ones are used up, never earlier: collapsing a
/// subtree changes what the NTree visits walk through (fewer erased nodes), hence the work
/// units the drill's budget counts, so a run that never fills the arena gives the same
/// results, bit for bit, as if nothing were ever given back.
///
/// References of nodes in a wholly erased subtree stop being valid once its block is taken
/// back (the block then holds other nodes); root references never change. A holder of
/// references across operations notes [`Hierarchy::reclaimed`] when it takes one: while the
/// count is unchanged (and below `u32::MAX`, where it saturates) no block has been taken back
/// and the reference is valid; otherwise it looks the node up again with `Hierarchy::find`
/// (the drill's pending items do). `(tet, tree index)` names stay valid: the nodes of a
/// collapsed subtree simply answer `None`. No result depends on reference values, so reused
/// arena slots change nothing: ties are broken by `(tet, index, face)`, walks go in child
/// digit order, and the union-find of [`Hierarchy::components`] only counts its classes.
#[derive(Debug)]
pub struct Hierarchy<'a> {
    pub(super) roots: &'a mut [HNode],
    pub(super) arena: &'a mut [HNode],
    pub(super) vlist: &'a mut [VEntry],
    /// Blocks handed out by the bump allocator (fresh ones: `blocks_used..`).
    pub(super) blocks_used: u32,
    pub(super) vlen: u32,
    /// Head of the list of reclaimable blocks (all 8 nodes erased leaves), as block + 1; 0
    /// when empty.
    pub(super) reclaim_head: u32,
    /// Blocks whose 8 nodes are all wholly erased (erased leaves or hollow inner nodes).
    pub(super) hollow_blocks: u32,
    pub(super) stats: HierarchyStats,
    /// The coarse tets' volume when the trees were last reset.
    pub(super) volume0: f64,
    /// The change log's ring: entry `seq` at `seq % len`.
    pub(super) changes: &'a mut [TetId],
    /// Change log entries written so far (the next entry's sequence number).
    pub(super) logged: u64,
    /// The log's length just after the last change of every face at once (a reset, a move
    /// of the nodes): entries before it no longer describe the surface.
    pub(super) all_at: u64,
}

/// Where the list of reclaimable blocks keeps its data in a block's erased leaves (their
/// spare words): the next block + 1, the tree's coarse tet, the parent's tree index.
pub(super) const LINK_NEXT: usize = 0;
pub(super) const LINK_TET: usize = 1;
pub(super) const LINK_PARENT: usize = 2;

impl<'a> Hierarchy<'a> {
    /// Creates the forest for `mesh`: every root a non-erased leaf whose visible faces are the
    /// mesh's boundary faces, on the v_list when it has one.
    ///
    /// # Bounded work
    /// O(T) for T tets.
    ///
    /// # Errors
    /// [`HierarchyError::StorageTooSmall`] when `roots` has fewer than T entries or `vlist`
    /// fewer than [`HierarchyStorage::vlist_needed`]; nothing is kept then.
    pub fn new(mesh: &Mesh<'_>, storage: HierarchyStorage<'a>) -> Result<Self, HierarchyError> {
        let t = mesh.tet_count();
        let HierarchyStorage {
            roots,
            arena,
            vlist,
            changes,
        } = storage;
        if roots.len() < t || t >= u32::MAX as usize / 2 {
            return Err(HierarchyError::StorageTooSmall {
                what: "roots",
                needed: t,
            });
        }
        let blocks = (arena.len() / 8)
            .min(MAX_BLOCKS)
            .min((u32::MAX as usize / 2 - t) / 8);
        let need = HierarchyStorage::vlist_needed(t, blocks * 8);
        if vlist.len() < need {
            return Err(HierarchyError::StorageTooSmall {
                what: "vlist",
                needed: need,
            });
        }
        let (roots, _) = roots.split_at_mut(t);
        let (arena, _) = arena.split_at_mut((blocks * 8).min(arena.len()));
        let mut me = Self {
            roots,
            arena,
            vlist,
            blocks_used: 0,
            vlen: 0,
            reclaim_head: 0,
            hollow_blocks: 0,
            stats: Default::default(),
            volume0: 0.0,
            changes,
            logged: 0,
            all_at: 0,
        };
        me.reset(mesh);
        Ok(me)
    }

    /// Forgets all drilling: every tree back to its root, boundary faces visible.
    ///
    /// # Bounded work
    /// O(T).
    pub(crate) fn reset(&mut self, mesh: &Mesh<'_>) {
        self.note_all_changed();
        self.blocks_used = 0;
        self.vlen = 0;
        self.reclaim_head = 0;
        self.hollow_blocks = 0;
        self.stats = HierarchyStats::default();
        self.volume0 = (0..self.roots.len().min(mesh.tet_count()))
            .map(|t| super::geometry::node_volume(mesh, TetId::from_idx(t), 0))
            .sum();
        for (i, root) in self.roots.iter_mut().enumerate() {
            *root = HNode::LEAF;
            let t = TetId::from_idx(i);
            let mut bits = 0u8;
            for f in 0..4u8 {
                if i < mesh.tet_count() && mesh.is_boundary_face(t, f) {
                    bits |= 1 << f;
                }
            }
            root.set_visible(bits);
            if bits != 0 {
                if let Some(e) = self.vlist.get_mut(self.vlen as usize) {
                    *e = VEntry {
                        tet: t,
                        index: 0,
                        node: i as u32,
                    };
                    root.set_slot(self.vlen);
                    root.set_surface(true);
                    self.vlen += 1;
                    self.stats.visible_faces += bits.count_ones();
                }
            }
        }
    }

    /// Number of coarse tets (trees).
    #[inline]
    pub fn tet_count(&self) -> usize {
        self.roots.len()
    }

    /// Arena capacity in nodes.
    #[inline]
    pub fn capacity(&self) -> usize {
        self.arena.len()
    }

    /// Arena nodes handed out so far (8 per fresh block; reused blocks are not counted
    /// again): the high-water mark, which stays at the capacity once the fresh blocks are
    /// used up. [`Hierarchy::arena_live`] is what the material needs.
    #[inline]
    pub fn arena_used(&self) -> usize {
        self.blocks_used as usize * 8
    }

    /// Arena nodes in wholly erased subtrees (blocks whose 8 nodes are erased leaves or
    /// hollow inner nodes): refinements take them back once the fresh blocks are used up.
    #[inline]
    pub fn arena_reclaimable(&self) -> usize {
        self.hollow_blocks as usize * 8
    }

    /// Arena nodes holding material: [`Hierarchy::arena_used`] minus
    /// [`Hierarchy::arena_reclaimable`]. A refinement is refused only when this reaches the
    /// capacity.
    #[inline]
    pub fn arena_live(&self) -> usize {
        self.arena_used().saturating_sub(self.arena_reclaimable())
    }

    /// Node references in use: every root slot plus the arena nodes handed out (references
    /// are below this; see [`Hierarchy::components_scratch_needed`]).
    #[inline]
    pub fn node_count(&self) -> usize {
        self.roots.len() + self.arena_used()
    }

    /// Counters.
    #[inline]
    pub fn stats(&self) -> HierarchyStats {
        self.stats
    }

    /// Number of visible faces (triangles to render).
    #[inline]
    pub fn visible_face_count(&self) -> u32 {
        self.stats.visible_faces
    }

    /// Refinements refused because the arena was full.
    #[inline]
    pub fn saturations(&self) -> u32 {
        self.stats.saturations
    }

    /// Blocks taken back from wholly erased subtrees so far ([`HierarchyStats::reclaimed`]):
    /// while it is 0, every node reference ever handed out is still valid.
    #[inline]
    pub fn reclaimed(&self) -> u32 {
        self.stats.reclaimed
    }

    /// Sum of the erased leaves' volumes.
    #[inline]
    pub fn removed_volume(&self) -> f64 {
        self.stats.removed_volume
    }

    /// The coarse tets' volume when the trees were created or last reset (the material
    /// left is this minus [`Hierarchy::removed_volume`]).
    #[inline]
    pub(crate) fn initial_volume(&self) -> f64 {
        self.volume0
    }

    /// The v_list: non-erased leaves with at least one visible face.
    #[inline]
    pub fn vlist(&self) -> &[VEntry] {
        self.vlist.get(..self.vlen as usize).unwrap_or(&[])
    }

    /// The node behind a reference, or `None` when out of range.
    #[inline]
    pub(crate) fn node(&self, r: u32) -> Option<HNode> {
        let t = self.roots.len();
        let r = r as usize;
        if r < t {
            self.roots.get(r).copied()
        } else {
            self.arena.get(r - t).copied()
        }
    }

    #[inline]
    pub(super) fn node_mut(&mut self, r: u32) -> Option<&mut HNode> {
        let t = self.roots.len();
        let r = r as usize;
        if r < t {
            self.roots.get_mut(r)
        } else {
            self.arena.get_mut(r - t)
        }
    }

    /// Reference of the first child of a node with child block `b`.
    #[inline]
    pub(super) fn block_ref(&self, b: u32) -> u32 {
        self.roots.len() as u32 + b * 8
    }

    /// The eight nodes of child block `b` (`None` past the arena's end).
    #[inline]
    pub(super) fn block_nodes(&self, b: u32) -> Option<&[HNode; 8]> {
        let i = b as usize * 8;
        self.arena.get(i..i + 8)?.try_into().ok()
    }

    /// The reference of child `c` of node `r`, or `None` for a leaf.
    #[inline]
    pub(crate) fn child(&self, r: u32, c: u8) -> Option<u32> {
        let b = self.node(r)?.block()?;
        Some(self.block_ref(b) + (c & 7) as u32)
    }

    /// The reference of node `(tet, index)`, or `None` when it is not instantiated.
    ///
    /// # Bounded work
    /// O(depth) <= [`MAX_DEPTH`] steps.
    pub(crate) fn find(&self, tet: TetId, index: u32) -> Option<u32> {
        // The digits, deepest first, then the walk from the root.
        let mut digits = [0u8; MAX_DEPTH];
        let mut depth = 0usize;
        let mut i = index;
        while i > 0 {
            *digits.get_mut(depth)? = ((i - 1) & 7) as u8;
            i = (i - 1) >> 3;
            depth += 1;
        }
        if tet.idx() >= self.roots.len() {
            return None;
        }
        let mut r = tet.0;
        for &c in digits.iter().take(depth).rev() {
            r = self.child(r, c)?;
        }
        Some(r)
    }

    pub(super) fn find_path(&self, tet: TetId, path: &Path) -> Option<u32> {
        if tet.idx() >= self.roots.len() {
            return None;
        }
        let mut r = tet.0;
        for k in 1..=path.depth as usize {
            r = self.child(r, path.digit(k))?;
        }
        Some(r)
    }

    /// Puts a leaf on the v_list (no-op when already there or out of room) and marks it and
    /// its ancestors as holding surface.
    ///
    /// # Bounded work
    /// O(depth).
    pub(super) fn vlist_insert(&mut self, tet: TetId, index: u32, r: u32) {
        let slot = self.vlen;
        let Some(n) = self.node(r) else { return };
        if n.slot() != NO_SLOT {
            return;
        }
        let Some(e) = self.vlist.get_mut(slot as usize) else {
            return;
        };
        *e = VEntry {
            tet,
            index,
            node: r,
        };
        self.vlen += 1;
        if let Some(n) = self.node_mut(r) {
            n.set_slot(slot);
            n.set_surface(true);
        }
        // The ancestors, root first.
        let Some(path) = Path::of_index(index) else {
            return;
        };
        if tet.idx() >= self.roots.len() {
            return;
        }
        let mut a = tet.0;
        for k in 0..path.depth as usize {
            if let Some(n) = self.node_mut(a) {
                n.set_surface(true);
            }
            match self.child(a, path.digit(k + 1)) {
                Some(c) => a = c,
                None => return,
            }
        }
    }

    /// Takes a node off the v_list by swap-remove (no-op when not there) and clears the
    /// surface bit of the ancestors left with no v_list leaf below them.
    ///
    /// # Bounded work
    /// O(8 * depth).
    pub(super) fn vlist_remove(&mut self, r: u32) {
        let Some(n) = self.node(r) else { return };
        let slot = n.slot();
        if slot == NO_SLOT || slot >= self.vlen {
            return;
        }
        let gone = self.vlist.get(slot as usize).copied();
        let last = self.vlen - 1;
        let moved = self.vlist.get(last as usize).copied();
        if let (Some(moved), Some(dst)) = (moved, self.vlist.get_mut(slot as usize)) {
            *dst = moved;
            if let Some(m) = self.node_mut(moved.node) {
                m.set_slot(slot);
            }
        }
        self.vlen = last;
        if let Some(n) = self.node_mut(r) {
            n.set_slot(NO_SLOT);
            n.set_surface(false);
        }
        if let Some(e) = gone.filter(|e| e.node == r) {
            self.clear_surface_above(e.tet, e.index);
        }
    }

    /// Clears the surface bit of the ancestors of `(tet, index)`, deepest first, while none of
    /// their children holds surface.
    fn clear_surface_above(&mut self, tet: TetId, index: u32) {
        let Some(path) = Path::of_index(index) else {
            return;
        };
        if tet.idx() >= self.roots.len() {
            return;
        }
        let mut refs = [0u32; MAX_DEPTH + 1];
        let mut a = tet.0;
        refs[0] = a;
        let depth = (path.depth as usize).min(MAX_DEPTH);
        for (k, slot) in refs.iter_mut().enumerate().take(depth + 1).skip(1) {
            match self.child(a, path.digit(k)) {
                Some(c) => a = c,
                None => return,
            }
            *slot = a;
        }
        for &p in refs[..depth].iter().rev() {
            let Some(b) = self.node(p).and_then(HNode::block) else {
                return;
            };
            let first = self.block_ref(b);
            if (0..8).any(|c| self.node(first + c).is_some_and(HNode::surface)) {
                return;
            }
            if let Some(n) = self.node_mut(p) {
                n.set_surface(false);
            }
        }
    }

    /// Depth limit of the trees.
    pub(crate) const MAX_DEPTH: usize = MAX_DEPTH;
}
