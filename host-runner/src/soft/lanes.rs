//! A soft body's tets reordered into groups of four that share no node
//! ([`SoftOwned::in_lanes`], [`lane_order`]), which the core's sweep solves four at a time
//! (docs/SOFT.md, "Four tets at once"): the same physics as the loader's order up to the
//! Gauss-Seidel order's change, each step in about a third of the time.

use super::SoftOwned;

pub use tetradrill_core::soft::LANE_WINDOW;

/// The core's [`tetradrill_core::soft::lane_order`] on the heap: the original index of each
/// tet of the new order (groups of four that share no node, then the rest in their order).
///
/// # Work
/// O(tets x [`LANE_WINDOW`]).
pub fn lane_order(tets: &[[u32; 4]]) -> Vec<u32> {
    let mut order = vec![0u32; tets.len()];
    let mut inverse = vec![0u32; tets.len()];
    if !tetradrill_core::soft::lane_order(tets, &mut order, &mut inverse) {
        // Beyond u32 indices: no body that large is stepped; keep the given order.
        return (0..tets.len() as u32).collect();
    }
    order
}

impl SoftOwned {
    /// The same body with its tets in [`lane_order`] (the nodes as they are) and the
    /// original index of each tet of the new order; per-tet materials follow their tets.
    pub fn in_lanes(&self) -> (SoftOwned, Vec<u32>) {
        let tet_of = lane_order(&self.tets);
        let tets = tet_of.iter().map(|&t| self.tets[t as usize]).collect();
        let mut out = SoftOwned::new(self.rest.clone(), tets);
        if !self.tet_material.is_empty() {
            out.tet_material = tet_of
                .iter()
                .map(|&t| self.tet_material[t as usize])
                .collect();
        }
        (out, tet_of)
    }
}
