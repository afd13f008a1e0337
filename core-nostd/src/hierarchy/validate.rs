//! `validate()`: the hierarchy invariants every operation keeps.

use super::geometry::node_positions;
use super::node::{HNode, NO_SLOT};
use super::store::{Hierarchy, HierarchyError, LINK_NEXT, LINK_PARENT, LINK_TET};
use super::table::Path;
use crate::geom::det6_f64;
use crate::ids::TetId;
use crate::mesh::Mesh;

impl Hierarchy<'_> {
    /// Checks the invariants: every child block is referenced by exactly one node and lies in
    /// the used part of the arena; only non-erased leaves carry visible faces; a leaf is on the
    /// v_list iff it has a visible face, with the v_list's back-indices consistent; a node's
    /// surface bit is set iff its subtree holds a v_list leaf; the orientation bits match the
    /// geometry; the visible-face counter matches the bits; an inner node is hollow iff all
    /// its children are wholly erased, with the count of such blocks right; the reclaimable
    /// list holds exactly the blocks of 8 erased leaves, each once, each naming its parent.
    ///
    /// # Bounded work
    /// O(nodes * depth).
    ///
    /// # Errors
    /// [`HierarchyError::Invalid`] naming the first broken invariant.
    pub fn validate(&self, mesh: &Mesh<'_>) -> Result<(), HierarchyError> {
        let bad = HierarchyError::Invalid;
        let mut blocks_seen = 0u32;
        let mut visible = 0u32;
        let mut listed = 0u32;
        let mut hollow = 0u32;
        let mut ready = 0u32;
        for t in 0..self.tet_count() {
            let tet = TetId::from_idx(t);
            let mut err = None;
            let mut stack = [(0u32, 0u32); 7 * Self::MAX_DEPTH + 8];
            stack[0] = (tet.0, 0);
            let mut top = 1usize;
            while top > 0 {
                top -= 1;
                let (r, index) = stack[top];
                let node = self.node(r).ok_or(bad("node reference out of range"))?;
                let path = Path::of_index(index).ok_or(bad("index too deep"))?;
                if node.inverted() != path.inverted() {
                    err = Some("orientation bit");
                }
                let p = node_positions(mesh, tet, &path);
                let det = det6_f64(p[0], p[1], p[2], p[3]);
                if (det < 0.0) != node.inverted() {
                    err = Some("orientation bit disagrees with geometry");
                }
                match node.block() {
                    None if node.erased() => {
                        // Its slot word is spare (the reclaimable list may use it).
                        if node.visible() != 0 {
                            err = Some("erased leaf with visible faces");
                        }
                        if node.surface() || node.hollow() {
                            err = Some("erased leaf marked surface or hollow");
                        }
                    }
                    None => {
                        visible += node.visible().count_ones();
                        if node.hollow() {
                            err = Some("leaf marked hollow");
                        }
                        if (node.visible() != 0) != (node.slot() != NO_SLOT) {
                            err = Some("v_list membership disagrees with visible faces");
                        }
                        if node.surface() != (node.slot() != NO_SLOT) {
                            err = Some("surface bit of a leaf disagrees with the v_list");
                        }
                        if node.slot() != NO_SLOT {
                            listed += 1;
                            match self.vlist().get(node.slot() as usize) {
                                Some(e) if e.node == r && e.tet == tet && e.index == index => {}
                                _ => err = Some("v_list back-index"),
                            }
                        }
                    }
                    Some(b) => {
                        if b >= self.blocks_used {
                            return Err(bad("child block beyond the used arena"));
                        }
                        blocks_seen += 1;
                        if node.erased() || node.visible() != 0 || node.slot() != NO_SLOT {
                            err = Some("inner node erased, visible or listed");
                        }
                        if path.depth as usize >= Self::MAX_DEPTH || top + 8 > stack.len() {
                            return Err(bad("tree deeper than MAX_DEPTH"));
                        }
                        let mut below = false;
                        let (mut all_erased, mut all_leaves) = (true, true);
                        for c in 0..8u8 {
                            let cr = self.block_ref(b) + c as u32;
                            let child = self.node(cr).ok_or(bad("node reference out of range"))?;
                            below |= child.surface();
                            all_erased &= child.all_erased();
                            all_leaves &= child.erased_leaf();
                            stack[top] = (cr, index * 8 + 1 + c as u32);
                            top += 1;
                        }
                        if below != node.surface() {
                            err = Some("surface bit of an inner node disagrees with its children");
                        }
                        if all_erased != node.hollow() {
                            err = Some("hollow bit disagrees with the children");
                        }
                        hollow += all_erased as u32;
                        ready += all_leaves as u32;
                    }
                }
                if let Some(e) = err {
                    return Err(bad(e));
                }
            }
        }
        if blocks_seen != self.blocks_used {
            return Err(bad("child blocks not referenced exactly once"));
        }
        if listed != self.vlen {
            return Err(bad("v_list length"));
        }
        if visible != self.stats.visible_faces {
            return Err(bad("visible face counter"));
        }
        if hollow != self.hollow_blocks {
            return Err(bad("count of wholly erased blocks"));
        }
        // The reclaimable list: each block links to the next through its own spare word, so a
        // block listed twice would make a cycle; the walk stops after `ready` entries.
        let mut at = self.reclaim_head;
        let mut n = 0u32;
        while let Some(b) = at.checked_sub(1) {
            if n >= ready {
                return Err(bad(
                    "reclaimable list longer than the blocks of erased leaves",
                ));
            }
            n += 1;
            if b >= self.blocks_used || !self.block_all(b, HNode::erased_leaf) {
                return Err(bad("reclaimable block not made of erased leaves"));
            }
            let first = self.block_ref(b);
            let word = |k: usize| self.node(first + k as u32).map_or(0, HNode::spare);
            let path = Path::of_index(word(LINK_PARENT)).ok_or(bad("reclaimable parent index"))?;
            let parent = self
                .path_refs(TetId(word(LINK_TET)), &path)
                .and_then(|refs| refs.get(path.depth as usize).copied())
                .and_then(|p| self.node(p));
            if parent.and_then(HNode::block) != Some(b) {
                return Err(bad("reclaimable block does not name its parent"));
            }
            at = word(LINK_NEXT);
        }
        if n != ready {
            return Err(bad(
                "a block of erased leaves is not on the reclaimable list",
            ));
        }
        Ok(())
    }
}
