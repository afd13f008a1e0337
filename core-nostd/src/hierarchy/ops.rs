//! Erase and Refine (Turini et al. 2006, section 2.1), keeping the visible faces exact.

use super::changes::OpTets;
use super::geometry::node_volume;
use super::node::{HNode, NO_SLOT};
use super::store::{Hierarchy, HierarchyError};
use super::table::{Path, CHILD_INVERTED, FACE_SUB};
use super::visit::{visit_across, visit_across_from, Side};
use crate::ids::TetId;
use crate::mesh::Mesh;

/// What one Erase or Refine did.
#[derive(Clone, Copy, PartialEq, Debug, Default)]
pub struct OpReport {
    /// Nodes touched by the NTree visits (the operation's work).
    pub work: u32,
    /// Nodes created (8 for a refinement).
    pub created: u32,
    /// Volume removed (an erasure).
    pub removed: f64,
}

impl<'a> Hierarchy<'a> {
    /// Splits leaf `(tet, index)` into its eight Bey children. A child face on an invisible
    /// parent face is invisible; a child face on a visible parent face is visible iff the
    /// NTree visit across it meets an erased leaf or the mesh boundary; faces between
    /// siblings are invisible.
    ///
    /// The block of 8 children is the arena's next fresh block, or once those are used up a
    /// block taken back from a wholly erased subtree (whose root becomes an erased leaf:
    /// every visible face, v_list entry, component and volume stays as it was; see
    /// [`Hierarchy`]).
    ///
    /// # Bounded work
    /// O(1) allocation (O(depth) + 8 node reads when the block is taken back) plus 16 NTree
    /// visits (4 faces x 4 children), each O(depth) plus the instantiated nodes across that
    /// face; each visit stops at the first erased leaf.
    ///
    /// # Errors
    /// [`HierarchyError::NotFound`], `NotLeaf`, `Erased`, `TooDeep` leave everything as it
    /// was; [`HierarchyError::Full`] when the arena has no fresh block and no wholly erased
    /// subtree to take one back from: nothing is changed and the refusal is counted in
    /// `saturations`.
    pub fn refine(
        &mut self,
        mesh: &Mesh<'_>,
        tet: TetId,
        index: u32,
    ) -> Result<OpReport, HierarchyError> {
        let path = Path::of_index(index).ok_or(HierarchyError::NotFound)?;
        let r = self.find_path(tet, &path).ok_or(HierarchyError::NotFound)?;
        self.refine_at(mesh, tet, &path, r)
    }

    pub(crate) fn refine_at(
        &mut self,
        mesh: &Mesh<'_>,
        tet: TetId,
        path: &Path,
        r: u32,
    ) -> Result<OpReport, HierarchyError> {
        let node = self.node(r).ok_or(HierarchyError::NotFound)?;
        if !node.is_leaf() {
            return Err(HierarchyError::NotLeaf);
        }
        if node.erased() {
            return Err(HierarchyError::Erased);
        }
        if path.depth as usize >= Self::MAX_DEPTH {
            return Err(HierarchyError::TooDeep);
        }
        let Some(b) = self.take_block() else {
            self.stats.saturations += 1;
            return Err(HierarchyError::Full);
        };
        let base = (b as usize) * 8;
        let inv = node.inverted();
        for c in 0..8u8 {
            if let Some(n) = self.arena.get_mut(base + c as usize) {
                *n = HNode::leaf(inv ^ CHILD_INVERTED[c as usize]);
            }
        }
        let parent_bits = node.visible();
        self.vlist_remove(r);
        if let Some(n) = self.node_mut(r) {
            n.set_visible(0);
            n.set_block(b);
        }
        self.stats.visible_faces = self
            .stats
            .visible_faces
            .saturating_sub(parent_bits.count_ones());
        self.stats.refines += 1;
        let mut rep = OpReport {
            created: 8,
            ..OpReport::default()
        };
        let first = self.block_ref(b);
        let mut child_bits = [0u8; 8];
        for f in 0..4u8 {
            if parent_bits & (1 << f) == 0 {
                continue;
            }
            for (c, g, _) in FACE_SUB[f as usize] {
                let Some(cp) = path.child(c) else { continue };
                let mut exposed = false;
                let side = visit_across(self, mesh, tet, &cp, g, &mut rep.work, |_, met| {
                    exposed = met.record.erased();
                    !exposed
                });
                if side == Side::Boundary || exposed {
                    child_bits[(c & 7) as usize] |= 1 << g;
                }
            }
        }
        for (c, bits) in child_bits.iter().enumerate() {
            if *bits == 0 {
                continue;
            }
            let cr = first + c as u32;
            if let Some(n) = self.node_mut(cr) {
                n.set_visible(*bits);
            }
            self.stats.visible_faces += bits.count_ones();
            self.vlist_insert(tet, path.index * 8 + 1 + c as u32, cr);
        }
        if parent_bits != 0 {
            let mut op = OpTets::new();
            op.add(tet);
            self.log(&op);
        }
        Ok(rep)
    }

    /// Erases leaf `(tet, index)`: every non-erased leaf met across its four faces gets that
    /// face visible (and joins the v_list), then the node leaves the v_list, loses its visible
    /// faces and is marked erased; its volume is added to the removed volume.
    ///
    /// When the leaf completes a wholly erased block (its 7 siblings are erased leaves or
    /// hollow), its parent is marked hollow, and so on up while blocks are completed; a block
    /// of 8 erased leaves joins the arena's reclaimable list. Nothing is freed here: the
    /// hierarchy's shape, and so every later visit, is unchanged until a refinement finds
    /// the fresh arena used up.
    ///
    /// # Bounded work
    /// 4 NTree visits, each O(depth) plus the instantiated nodes across that face, plus 8
    /// node reads; when a block is completed, O(depth) plus 8 node reads per level climbed
    /// (at most `Hierarchy::MAX_DEPTH` levels).
    ///
    /// # Errors
    /// [`HierarchyError::NotFound`], `NotLeaf`, `Erased`: nothing changed. Never needs
    /// storage: the v_list is sized for every leaf (see
    /// [`super::HierarchyStorage::vlist_needed`]).
    pub fn erase(
        &mut self,
        mesh: &Mesh<'_>,
        tet: TetId,
        index: u32,
    ) -> Result<OpReport, HierarchyError> {
        let path = Path::of_index(index).ok_or(HierarchyError::NotFound)?;
        let r = self.find_path(tet, &path).ok_or(HierarchyError::NotFound)?;
        self.erase_at(mesh, tet, &path, r)
    }

    pub(crate) fn erase_at(
        &mut self,
        mesh: &Mesh<'_>,
        tet: TetId,
        path: &Path,
        r: u32,
    ) -> Result<OpReport, HierarchyError> {
        let node = self.node(r).ok_or(HierarchyError::NotFound)?;
        if !node.is_leaf() {
            return Err(HierarchyError::NotLeaf);
        }
        if node.erased() {
            return Err(HierarchyError::Erased);
        }
        let mut rep = OpReport::default();
        // The tets whose visible faces change: this leaf's when it had some, and those of the
        // leaves across it that gain one.
        let mut op = OpTets::new();
        if node.visible() != 0 {
            op.add(tet);
        }
        for f in 0..4u8 {
            visit_across_from(self, mesh, tet, (path, r), f, &mut rep.work, |h, met| {
                let rec = met.record;
                if rec.erased() {
                    return true;
                }
                let bit = 1u8 << (met.face & 3);
                if rec.visible() & bit == 0 {
                    if let Some(n) = h.node_mut(met.node) {
                        n.set_visible(rec.visible() | bit);
                    }
                    h.stats.visible_faces += 1;
                    op.add(met.tet);
                }
                if rec.slot() == NO_SLOT {
                    h.vlist_insert(met.tet, met.index, met.node);
                }
                true
            });
        }
        self.vlist_remove(r);
        self.stats.visible_faces = self
            .stats
            .visible_faces
            .saturating_sub(node.visible().count_ones());
        if let Some(n) = self.node_mut(r) {
            n.set_visible(0);
            n.set_erased();
        }
        self.log(&op);
        self.note_erased(tet, path, r);
        rep.removed = node_volume(mesh, tet, path.depth);
        self.stats.removed_volume += rep.removed;
        self.stats.erased += 1;
        Ok(rep)
    }
}
