//! Giving back the arena blocks of wholly erased subtrees (see [`Hierarchy`]'s notes on the
//! arena): the bookkeeping Erase does, and the block a refinement takes.
//!
//! Two facts are kept exact by every operation and checked by [`Hierarchy::validate`]:
//! - an inner node is *hollow* ([`HNode::all_erased`]) iff each of its 8 children is an erased
//!   leaf or hollow; `hollow_blocks` counts the blocks whose 8 nodes are all so;
//! - a block whose 8 nodes are erased leaves is on the reclaimable list exactly once, with its
//!   parent's `(tet, tree index)` in its own spare words.
//!
//! Both change only when a leaf is erased (the leaf may complete its block, whose parent turns
//! hollow, which may complete the block above, and so on up to the root) and when a block is
//! taken back (its parent becomes an erased leaf, which may complete the parent's own block of
//! erased leaves: that block joins the list).

use super::node::HNode;
use super::store::{Hierarchy, LINK_NEXT, LINK_PARENT, LINK_TET};
use super::table::{Path, MAX_DEPTH};
use crate::ids::TetId;

impl Hierarchy<'_> {
    /// The references of the nodes on `path` in the tree of `tet`, root first (entry `k` for
    /// depth `k`, up to `path.depth`), or `None` when one is not instantiated.
    ///
    /// # Bounded work
    /// O(depth).
    pub(super) fn path_refs(&self, tet: TetId, path: &Path) -> Option<[u32; MAX_DEPTH + 1]> {
        if tet.idx() >= self.roots.len() {
            return None;
        }
        let mut refs = [0u32; MAX_DEPTH + 1];
        let mut r = tet.0;
        refs[0] = r;
        for (k, slot) in refs
            .iter_mut()
            .enumerate()
            .take(path.depth as usize + 1)
            .skip(1)
        {
            r = self.child(r, path.digit(k))?;
            *slot = r;
        }
        Some(refs)
    }

    /// The arena block holding node `r`, or `None` for a root.
    #[inline]
    pub(super) fn block_of(&self, r: u32) -> Option<u32> {
        r.checked_sub(self.roots.len() as u32).map(|a| a / 8)
    }

    /// `true` when all 8 nodes of block `b` pass `f`.
    #[inline]
    pub(super) fn block_all(&self, b: u32, f: fn(HNode) -> bool) -> bool {
        let base = b as usize * 8;
        self.arena
            .get(base..base + 8)
            .is_some_and(|n| n.iter().all(|&x| f(x)))
    }

    /// Puts block `b` (8 erased leaves, children of node `parent_index` of `tet`) on the
    /// reclaimable list.
    fn push_reclaimable(&mut self, b: u32, tet: TetId, parent_index: u32) {
        let base = b as usize * 8;
        let next = self.reclaim_head;
        let words = [
            (LINK_NEXT, next),
            (LINK_TET, tet.0),
            (LINK_PARENT, parent_index),
        ];
        for (k, w) in words {
            if let Some(n) = self.arena.get_mut(base + k) {
                n.set_spare(w);
            }
        }
        self.reclaim_head = b + 1;
    }

    /// The bookkeeping after leaf `r` = `(tet, path)` was erased: when that completes its
    /// block (all 8 nodes wholly erased), the parent turns hollow, which may complete the
    /// block above, and so on; a completed block of erased leaves joins the reclaimable list.
    /// Nothing else changes (no node is freed here).
    ///
    /// # Bounded work
    /// 8 node reads; when the block is completed, O(depth) to find the ancestors plus 8 reads
    /// per level climbed, at most [`MAX_DEPTH`] levels.
    pub(super) fn note_erased(&mut self, tet: TetId, path: &Path, r: u32) {
        let Some(b) = self.block_of(r) else { return };
        if !self.block_all(b, HNode::all_erased) {
            return;
        }
        let d = path.depth as usize;
        let Some(refs) = self.path_refs(tet, path) else {
            return;
        };
        if d == 0 || refs.get(d) != Some(&r) {
            return;
        }
        if self.block_all(b, HNode::erased_leaf) {
            self.push_reclaimable(b, tet, path.prefix_index(d - 1));
        }
        // The ancestors from the parent up, while each has just had its block of children
        // completed (a root has no block above it).
        for &a in refs.iter().take(d).rev() {
            self.hollow_blocks += 1;
            if let Some(n) = self.node_mut(a) {
                n.set_hollow();
            }
            match self.block_of(a) {
                Some(up) if self.block_all(up, HNode::all_erased) => {}
                _ => break,
            }
        }
    }

    /// A block of 8 arena nodes for a refinement: the next fresh one while there is one,
    /// otherwise one taken back from the reclaimable list (its parent becomes an erased leaf,
    /// which may complete the parent's own block: that block joins the list). `None` when
    /// there is neither (the arena is full).
    ///
    /// # Bounded work
    /// O(1) for a fresh block; O(depth) + 8 node reads for a reclaimed one.
    pub(super) fn take_block(&mut self) -> Option<u32> {
        if (self.blocks_used as usize + 1) * 8 <= self.arena.len() {
            let b = self.blocks_used;
            self.blocks_used += 1;
            return Some(b);
        }
        self.reclaim()
    }

    fn reclaim(&mut self) -> Option<u32> {
        let b = self.reclaim_head.checked_sub(1)?;
        let base = b as usize * 8;
        let word = |k: usize| self.arena.get(base + k).map(|n| n.spare());
        let next = word(LINK_NEXT)?;
        let tet = TetId(word(LINK_TET)?);
        let path = Path::of_index(word(LINK_PARENT)?)?;
        let d = path.depth as usize;
        let p = *self.path_refs(tet, &path)?.get(d)?;
        // The list names the block's parent (validate() checks it); anything else would be a
        // broken invariant: refuse rather than reuse a block that may be live.
        if self.node(p)?.block() != Some(b) || !self.block_all(b, HNode::erased_leaf) {
            return None;
        }
        self.reclaim_head = next;
        if let Some(n) = self.node_mut(p) {
            n.collapse();
        }
        self.hollow_blocks = self.hollow_blocks.saturating_sub(1);
        self.stats.reclaimed = self.stats.reclaimed.saturating_add(1);
        if d > 0 {
            if let Some(up) = self.block_of(p) {
                if self.block_all(up, HNode::erased_leaf) {
                    self.push_reclaimable(up, tet, path.prefix_index(d - 1));
                }
            }
        }
        Some(b)
    }
}
