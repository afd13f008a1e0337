//! Debris: small pieces of remaining material cut off from the main body. The drill's
//! discretisation leaves single leaves (or a few) floating along the swept boundary, each
//! its own connected piece; a real burr's flutes carry such crumbs away. [`Hierarchy::remove_debris`]
//! erases every piece that is not the largest and is smaller than a given number of
//! max-depth leaves, so [`Hierarchy::components`] counts the pieces a user would see.

use super::components::find;
use super::store::{Hierarchy, HierarchyError};
use super::table::Path;
use crate::ids::TetId;
use crate::mesh::Mesh;

/// Default size below which a detached piece is debris ([`Hierarchy::remove_debris`]'s
/// `max_leaves`): 8 leaves of the deepest level, the volume of one leaf a level up. The
/// crumbs the drill leaves along a groove are one to three such leaves; a piece a user
/// cuts off on purpose is many burr widths, thousands of them.
pub const DEBRIS_LEAVES: u32 = 8;

/// What [`Hierarchy::remove_debris`] did.
#[derive(Clone, Copy, PartialEq, Debug, Default)]
pub struct DebrisReport {
    /// Pieces erased.
    pub pieces: u32,
    /// Leaves erased (hierarchy nodes).
    pub nodes: u32,
    /// Volume erased (also added to [`Hierarchy::removed_volume`]).
    pub volume: f64,
    /// Pieces of remaining material after the removal (what [`Hierarchy::components`] now
    /// counts).
    pub components: u32,
}

/// Mark of a debris leaf in the scratch (after the pieces are known).
const DEBRIS: u32 = u32::MAX;

impl Hierarchy<'_> {
    /// Scratch entries [`Hierarchy::remove_debris`] needs: two per instantiated node.
    ///
    /// # Bounded work
    /// Constant.
    pub fn debris_scratch_needed(&self) -> usize {
        2 * self.node_count()
    }

    /// Erases the debris: every connected piece of remaining material (as
    /// [`Hierarchy::components`] joins them, across shared faces) other than the largest whose
    /// size is below `max_leaves` leaves of depth `max_depth` (a leaf of depth `d` counts
    /// `8^(max_depth - d)` of them, an untouched coarse tet `8^max_depth`; ties for the largest
    /// go to the piece holding the smallest node reference). Returns the pieces, leaves and
    /// volume erased and the pieces left. Erasing follows the v_list: a debris leaf on it is
    /// erased (its debris neighbours become visible and join the v_list), until none is left,
    /// so the visible faces stay exact.
    ///
    /// # Bounded work
    /// [`Hierarchy::components`]' bound, O(nodes) to size and mark the pieces, one pass over
    /// the v_list, and one [`Hierarchy::erase`] per debris leaf. Not for the servo's tick: a
    /// host calls it between steps, at a cadence it can afford.
    ///
    /// # Errors
    /// [`HierarchyError::StorageTooSmall`] when `scratch` is shorter than
    /// [`Hierarchy::debris_scratch_needed`]; nothing is changed.
    pub fn remove_debris(
        &mut self,
        mesh: &Mesh<'_>,
        max_leaves: u32,
        max_depth: u8,
        scratch: &mut [u32],
    ) -> Result<DebrisReport, HierarchyError> {
        self.remove_debris_with(mesh, max_leaves, max_depth, 0.0, scratch, |_, _| {})
    }

    /// [`Hierarchy::remove_debris`] calling `erased(tet, volume)` for every leaf it erases
    /// (the coarse tet whose tree held it and its volume), for tallies kept elsewhere (the
    /// removed volume by region). With a drill `resolution` (mesh units, 0: none) the unit of
    /// each tree is a leaf of its own depth limit when that is shallower than `max_depth`
    /// ([`super::unit_depth`]): the finest leaf the drill makes there.
    ///
    /// # Bounded work
    /// As [`Hierarchy::remove_debris`], plus one call per leaf erased and, with a resolution,
    /// one root frame per tree.
    ///
    /// # Errors
    /// As [`Hierarchy::remove_debris`].
    pub(crate) fn remove_debris_with<F: FnMut(TetId, f64)>(
        &mut self,
        mesh: &Mesh<'_>,
        max_leaves: u32,
        max_depth: u8,
        resolution: f32,
        scratch: &mut [u32],
        mut erased: F,
    ) -> Result<DebrisReport, HierarchyError> {
        let n = self.node_count();
        let (uf, size) = scratch
            .get_mut(..2 * n)
            .ok_or(HierarchyError::StorageTooSmall {
                what: "debris scratch",
                needed: 2 * n,
            })?
            .split_at_mut(n);
        self.join_pieces(mesh, uf);
        size.fill(0);
        // Every leaf points at its root directly, and each root adds up its piece's size.
        for t in 0..self.tet_count() {
            let unit = super::unit_depth(mesh, TetId::from_idx(t), max_depth, resolution);
            self.for_each_leaf(TetId::from_idx(t), |leaf| {
                if leaf.record.erased() {
                    return;
                }
                let root = find(uf, leaf.node);
                if let Some(slot) = uf.get_mut(leaf.node as usize) {
                    *slot = root;
                }
                let depth = Path::of_index(leaf.index).map_or(0, |p| p.depth);
                let units = 8u32.saturating_pow(u32::from(unit.saturating_sub(depth)));
                if let Some(s) = size.get_mut(root as usize) {
                    *s = s.saturating_add(units);
                }
            });
        }
        // The largest piece (smallest root among equals) and the count of pieces.
        let (mut largest, mut best, mut pieces) = (u32::MAX, 0u32, 0u32);
        for (r, (&p, &s)) in uf.iter().zip(size.iter()).enumerate() {
            if p == r as u32 && s > 0 {
                pieces += 1;
                if s > best {
                    (largest, best) = (r as u32, s);
                }
            }
        }
        let debris_root = |r: u32, size: &[u32]| {
            r != largest
                && size
                    .get(r as usize)
                    .is_some_and(|&s| s > 0 && s < max_leaves)
        };
        let mut rep = DebrisReport::default();
        for (r, (&p, &s)) in uf.iter().zip(size.iter()).enumerate() {
            if p == r as u32 && s > 0 && debris_root(r as u32, size) {
                rep.pieces += 1;
            }
        }
        rep.components = pieces - rep.pieces;
        if rep.pieces == 0 {
            return Ok(rep);
        }
        // Mark each leaf of a debris piece (its entry holds its root, read before it is
        // overwritten: a root's own entry is its own).
        for t in 0..self.tet_count() {
            self.for_each_leaf(TetId::from_idx(t), |leaf| {
                if leaf.record.erased() {
                    return;
                }
                if let Some(slot) = uf.get_mut(leaf.node as usize) {
                    if debris_root(*slot, size) {
                        *slot = DEBRIS;
                    }
                }
            });
        }
        // Erase along the v_list: erasing slot i moves the last entry into it (so i is read
        // again) and appends the leaf's newly exposed neighbours at the end.
        let mut i = 0usize;
        while let Some(&e) = self.vlist().get(i) {
            if uf.get(e.node as usize) != Some(&DEBRIS) {
                i += 1;
                continue;
            }
            match self.erase(mesh, e.tet, e.index) {
                Ok(op) => {
                    rep.nodes += 1;
                    rep.volume += op.removed;
                    erased(e.tet, op.removed);
                }
                // Cannot happen for a v_list leaf; never loop on it.
                Err(_) => i += 1,
            }
            if let Some(slot) = uf.get_mut(e.node as usize) {
                *slot = 0;
            }
        }
        Ok(rep)
    }
}
