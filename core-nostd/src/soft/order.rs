//! A soft body's tets in groups of four that share no node ([`lane_order`]), which the sweep
//! solves four at a time where the target has four-wide f32 arithmetic (docs/SOFT.md, "Four
//! tets at once"): the same physics as the given order up to the Gauss-Seidel order's change,
//! each step in about a third of the time. In caller storage, no allocation: the host's soft
//! driver, Python's `SoftBody` and the C interface's `td_soft_init` order their bodies here.

/// How far ahead of a group's first tet [`lane_order`] looks for the others: far enough that
/// nearly every group fills, near enough that a group's tets stay neighbours in the given
/// (spatial) order, so the sweep keeps its locality and the Gauss-Seidel order moves little.
pub const LANE_WINDOW: usize = 64;

/// Marks, in `body_tet`, a tet not yet placed.
const UNPLACED: u32 = u32::MAX;
/// Marks, in `body_tet`, a tet left out of every group (placed after them).
const LEFT: u32 = u32::MAX - 1;

/// Writes to `tet_of` a permutation of `tets` (the given index of each tet of the new order)
/// in which the tets come in groups of four that share no node, from the start: each group
/// begins with the first tet not yet placed and takes the next ones, in order, that share no
/// node with it, looking at most [`LANE_WINDOW`] unplaced tets ahead. The tets for which no
/// group could be filled follow all the groups, in their given order (the sweep solves them
/// one at a time). `body_tet` gets the inverse: the new index of each given tet.
///
/// Returns `false` (nothing meaningful written) unless `tet_of` and `body_tet` hold one
/// entry per tet and the tets fewer than `u32::MAX - 1`.
///
/// # Bounded work
/// O(tets x [`LANE_WINDOW`]).
pub fn lane_order(tets: &[[u32; 4]], tet_of: &mut [u32], body_tet: &mut [u32]) -> bool {
    let n = tets.len();
    if tet_of.len() != n || body_tet.len() != n || n >= LEFT as usize {
        return false;
    }
    body_tet.fill(UNPLACED);
    // Every index below is under `n`, the length of all three slices (checked above); the
    // lookups go through `get` so that a bare-metal build carries no panic path.
    let unplaced = |b: &[u32], i: usize| b.get(i).is_some_and(|&x| x == UNPLACED);
    let mut placed = 0usize;
    let mut first = 0usize;
    loop {
        while body_tet.get(first).is_some_and(|&b| b != UNPLACED) {
            first += 1;
        }
        let Some(&lead) = tets.get(first) else {
            break;
        };
        let mut group = [first; 4];
        let mut size = 1;
        mark(body_tet, first, LEFT);
        let (mut looked, mut next) = (0, first + 1);
        while size < 4 && looked < LANE_WINDOW && next < n {
            if unplaced(body_tet, next) {
                looked += 1;
                let t = tets.get(next).copied().unwrap_or(lead);
                let shares = |g: &usize| {
                    tets.get(*g)
                        .is_some_and(|u| u.iter().any(|k| t.contains(k)))
                };
                if !lead.iter().any(|k| t.contains(k))
                    && !group.iter().take(size).skip(1).any(shares)
                {
                    group[size] = next;
                    size += 1;
                    mark(body_tet, next, LEFT);
                }
            }
            next += 1;
        }
        if size == 4 {
            for g in group {
                mark(tet_of, placed, g as u32);
                mark(body_tet, g, placed as u32);
                placed += 1;
            }
        }
    }
    // The tets left out, in their given order.
    for (t, b) in body_tet.iter_mut().enumerate() {
        if *b == LEFT {
            mark(tet_of, placed, t as u32);
            *b = placed as u32;
            placed += 1;
        }
    }
    true
}

/// `s[i] = v` where `i` is in range (it always is where [`lane_order`] calls it).
fn mark(s: &mut [u32], i: usize, v: u32) {
    if let Some(x) = s.get_mut(i) {
        *x = v;
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
        let tets: [[u32; 4]; 403] = core::array::from_fn(|i| {
            let i = i as u32;
            [i, i + 1, i + 2, i + 3]
        });
        let (mut order, mut inverse) = ([0u32; 403], [0u32; 403]);
        assert!(lane_order(&tets, &mut order, &mut inverse));
        let mut seen = order;
        seen.sort_unstable();
        assert!(seen.iter().enumerate().all(|(i, &t)| t == i as u32));
        assert!(order
            .iter()
            .enumerate()
            .all(|(i, &t)| inverse[t as usize] == i as u32));
        let t = |i: usize| &tets[order[i] as usize];
        let mut groups = 0;
        for g in (0..order.len() / 4 * 4).step_by(4) {
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

    #[test]
    fn storage_of_the_wrong_length_is_refused() {
        let tets = [[0, 1, 2, 3], [4, 5, 6, 7]];
        assert!(!lane_order(&tets, &mut [0; 1], &mut [0; 2]));
        assert!(!lane_order(&tets, &mut [0; 2], &mut [0; 3]));
        let (mut o, mut i) = ([9; 2], [9; 2]);
        assert!(lane_order(&tets, &mut o, &mut i));
        // Two tets cannot fill a group: both follow, in order.
        assert_eq!((o, i), ([0, 1], [0, 1]));
    }
}
