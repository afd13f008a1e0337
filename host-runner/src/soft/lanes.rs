//! A soft body's tets reordered into groups of four that share no node
//! ([`SoftOwned::in_lanes`], [`lane_order`]), which the core's sweep solves four at a time
//! (docs/SOFT.md, "Four tets at once"): the same physics as the loader's order up to the
//! Gauss-Seidel order's change, each step in about a third of the time.

use super::SoftOwned;

/// How far ahead of a group's first tet [`lane_order`] looks for the others: far enough that
/// nearly every group fills, near enough that a group's tets stay neighbours in the loader's
/// spatial order (so the sweep keeps its locality and the Gauss-Seidel order moves little).
pub const LANE_WINDOW: usize = 64;

/// A permutation of `tets` (the original index of each tet of the new order) in which the
/// tets come in groups of four that share no node, from the start: each group begins with
/// the first tet not yet placed and takes the next ones, in order, that share no node with
/// it, looking at most [`LANE_WINDOW`] unplaced tets ahead. The tets for which no group could
/// be filled follow all the groups, in their order (the sweep solves them one at a time).
///
/// # Work
/// O(tets x [`LANE_WINDOW`]).
pub fn lane_order(tets: &[[u32; 4]]) -> Vec<u32> {
    let mut placed = vec![false; tets.len()];
    let mut order = Vec::with_capacity(tets.len());
    let mut left = Vec::new();
    let mut first = 0;
    let mut group = Vec::with_capacity(4);
    loop {
        while placed.get(first) == Some(&true) {
            first += 1;
        }
        if first >= tets.len() {
            break;
        }
        group.clear();
        group.push(first);
        placed[first] = true;
        let mut looked = 0;
        let mut next = first + 1;
        while group.len() < 4 && looked < LANE_WINDOW && next < tets.len() {
            if !placed[next] {
                looked += 1;
                let t = &tets[next];
                if group
                    .iter()
                    .all(|&g: &usize| !tets[g].iter().any(|k| t.contains(k)))
                {
                    group.push(next);
                    placed[next] = true;
                }
            }
            next += 1;
        }
        if group.len() == 4 {
            order.extend(group.iter().map(|&g| g as u32));
        } else {
            left.extend(group.iter().map(|&g| g as u32));
        }
    }
    left.sort_unstable();
    order.extend(left);
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

#[cfg(test)]
mod tests {
    use super::*;

    fn shares(a: &[u32; 4], b: &[u32; 4]) -> bool {
        a.iter().any(|k| b.contains(k))
    }

    #[test]
    fn the_order_is_a_permutation_in_disjoint_groups_then_the_rest() {
        // A strip of tets, each sharing three nodes with the next: a group must look ahead.
        let tets: Vec<[u32; 4]> = (0..403).map(|i| [i, i + 1, i + 2, i + 3]).collect();
        let order = lane_order(&tets);
        let mut seen = order.clone();
        seen.sort_unstable();
        assert_eq!(seen, (0..403).collect::<Vec<u32>>());
        let t = |i: usize| &tets[order[i] as usize];
        let full = order.len() / 4 * 4;
        let mut groups = 0;
        for g in (0..full).step_by(4) {
            if (0..4).all(|a| (a + 1..4).all(|b| !shares(t(g + a), t(g + b)))) {
                groups += 1;
            } else {
                // Past the groups: the leftovers, in their order.
                assert!(order[g..].windows(2).all(|w| w[0] < w[1]), "at {g}");
                break;
            }
        }
        assert!(groups * 4 >= 380, "{groups} groups of 403 tets");
    }
}
