//! Connected pieces of the remaining material (the future work of Turini et al. 2006, section 5):
//! union-find over the non-erased leaves, joined across every face to the leaves met by the NTree
//! visit (within a tree, across coarse faces, and between different levels).

use super::store::{Hierarchy, HierarchyError};
use super::table::Path;
use super::visit::visit_across;
use crate::ids::TetId;
use crate::mesh::Mesh;

pub(super) fn find(uf: &mut [u32], mut x: u32) -> u32 {
    // Path halving; every step strictly shortens the chain, so this ends.
    loop {
        let Some(&p) = uf.get(x as usize) else {
            return x;
        };
        if p == x {
            return x;
        }
        let gp = uf.get(p as usize).copied().unwrap_or(p);
        if let Some(slot) = uf.get_mut(x as usize) {
            *slot = gp;
        }
        x = gp;
    }
}

impl Hierarchy<'_> {
    /// Fills `uf` (one entry per instantiated node) with a union-find forest of the non-erased
    /// leaves joined across shared faces: after it, two leaves are in the same piece iff
    /// `find` gives them the same root, the smallest node reference of the piece.
    ///
    /// # Bounded work
    /// As [`Hierarchy::components`].
    pub(super) fn join_pieces(&self, mesh: &Mesh<'_>, uf: &mut [u32]) {
        for (i, p) in uf.iter_mut().enumerate() {
            *p = i as u32;
        }
        let mut work = 0u32;
        let mut ctx = self;
        for t in 0..self.tet_count() {
            let tet = TetId::from_idx(t);
            self.for_each_leaf(tet, |leaf| {
                if leaf.record.erased() {
                    return;
                }
                let Some(path) = Path::of_index(leaf.index) else {
                    return;
                };
                for f in 0..4u8 {
                    visit_across(&mut ctx, mesh, tet, &path, f, &mut work, |_, met| {
                        if !met.record.erased() {
                            let a = find(uf, leaf.node);
                            let b = find(uf, met.node);
                            let (lo, hi) = if a < b { (a, b) } else { (b, a) };
                            if let Some(slot) = uf.get_mut(hi as usize) {
                                *slot = lo;
                            }
                        }
                        true
                    });
                }
            });
        }
    }

    /// Scratch entries [`Hierarchy::components`] needs: one per instantiated node.
    pub fn components_scratch_needed(&self) -> usize {
        self.node_count()
    }

    /// Number of connected pieces of remaining material (non-erased leaves and untouched coarse
    /// tets, joined across shared faces). A piece cut off by drilling counts as its own.
    ///
    /// # Bounded work
    /// O(L * 4 * (depth + nodes across one face)) for L non-erased leaves, plus O(nodes) for
    /// the union-find (path halving, smaller index wins).
    ///
    /// # Errors
    /// [`HierarchyError::StorageTooSmall`] when `scratch` is shorter than
    /// [`Hierarchy::components_scratch_needed`].
    pub fn components(&self, mesh: &Mesh<'_>, scratch: &mut [u32]) -> Result<u32, HierarchyError> {
        let n = self.node_count();
        let uf = scratch
            .get_mut(..n)
            .ok_or(HierarchyError::StorageTooSmall {
                what: "components scratch",
                needed: n,
            })?;
        self.join_pieces(mesh, uf);
        let mut count = 0u32;
        for t in 0..self.tet_count() {
            self.for_each_leaf(TetId::from_idx(t), |leaf| {
                if !leaf.record.erased() && find(uf, leaf.node) == leaf.node {
                    count += 1;
                }
            });
        }
        Ok(count)
    }
}
