//! A soft body's nodes and tets reordered into two parts that share no node
//! ([`SoftOwned::in_two_parts`]), and the two parts' sweeps run on two threads
//! ([`on_two_threads`]), for `SoftBody::step_two`: the same physics as `SoftBody::step` on the
//! reordered body, bit for bit, the sweep's larger part split over two cores; and the world's
//! update after the step in two parts the same way ([`move_on_two_threads`],
//! `World::set_positions_two`).

use tetradrill_core::servo::MovePart;
use tetradrill_core::soft::{PartSweep, SoftBody, TwoParts};
use tetradrill_core::Vec3;

use super::lanes::lane_order;
use super::SoftOwned;

/// Where [`SoftOwned::in_two_parts`] put a body's nodes and tets.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PartsOrder {
    /// The original index of each node of the reordered body.
    pub node_of: Vec<u32>,
    /// The reordered body's index of each original node (`node_of` inverted).
    pub body_node: Vec<u32>,
    /// The original index of each tet of the reordered body.
    pub tet_of: Vec<u32>,
    /// Nodes of the first part (`0..nodes_a`).
    pub nodes_a: usize,
    /// Tets of the first part (`0..tets_a`).
    pub tets_a: usize,
    /// End of the second part's tets (`tets_a..tets_b`); the joining tets follow.
    pub tets_b: usize,
}

impl PartsOrder {
    /// The checked split of `body` (`SoftBody::two_parts`), `None` when `body` is not the
    /// reordered one.
    pub fn parts(&self, body: &SoftBody<'_>) -> Option<TwoParts> {
        body.two_parts(self.nodes_a, self.tets_a, self.tets_b)
    }
}

impl SoftOwned {
    /// The same body with its nodes and tets reordered into two parts that share no node:
    /// the nodes on either side of the median of the tets' centroids along the rest mesh's
    /// longest axis, the tets whose four nodes lie on one side in that side's part, the tets
    /// that straddle the cut last. Each of the three keeps its original relative order (the
    /// loader's spatial order) as far as [`lane_order`] does, grouping its tets in fours that
    /// share no node for the sweep's lanes, so the sweep's order, and its Gauss-Seidel
    /// result, changes only where the cut moves the straddling tets to the end and within a
    /// group's window. Per-tet materials follow their tets.
    pub fn in_two_parts(&self) -> (SoftOwned, PartsOrder) {
        let (lo, hi) = self.rest.iter().fold(
            (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)),
            |(a, b), x| (a.min(*x), b.max(*x)),
        );
        let ext = hi - lo;
        let axis = if ext.x >= ext.y && ext.x >= ext.z {
            0
        } else if ext.y >= ext.z {
            1
        } else {
            2
        };
        let coord = |k: u32| self.rest.get(k as usize).map_or(0.0, |p| p[axis]);
        let mut centres: Vec<f32> = self
            .tets
            .iter()
            .map(|t| t.iter().map(|&k| coord(k)).sum::<f32>() * 0.25)
            .collect();
        let cut = if centres.is_empty() {
            0.0
        } else {
            let mid = centres.len() / 2;
            *centres.select_nth_unstable_by(mid, f32::total_cmp).1
        };
        let side_a: Vec<bool> = self.rest.iter().map(|p| p[axis] < cut).collect();
        let mut node_of: Vec<u32> = (0..self.rest.len() as u32)
            .filter(|&k| side_a[k as usize])
            .collect();
        let nodes_a = node_of.len();
        node_of.extend((0..self.rest.len() as u32).filter(|&k| !side_a[k as usize]));
        let mut body_node = vec![0u32; self.rest.len()];
        for (new, &old) in node_of.iter().enumerate() {
            body_node[old as usize] = new as u32;
        }
        // 0: all in the first part, 1: all in the second, 2: straddling.
        let class = |t: &[u32; 4]| {
            let a = t.iter().filter(|&&k| side_a[k as usize]).count();
            match a {
                4 => 0,
                0 => 1,
                _ => 2,
            }
        };
        let mut tet_of = Vec::with_capacity(self.tets.len());
        let mut ends = [0usize; 3];
        for (c, end) in ends.iter_mut().enumerate() {
            let of: Vec<u32> = (0..self.tets.len() as u32)
                .filter(|&t| class(&self.tets[t as usize]) == c)
                .collect();
            let tets: Vec<[u32; 4]> = of.iter().map(|&t| self.tets[t as usize]).collect();
            tet_of.extend(lane_order(&tets).into_iter().map(|i| of[i as usize]));
            *end = tet_of.len();
        }
        let rest = node_of.iter().map(|&k| self.rest[k as usize]).collect();
        let tets = tet_of
            .iter()
            .map(|&t| self.tets[t as usize].map(|k| body_node[k as usize]))
            .collect();
        let mut out = SoftOwned::new(rest, tets);
        if !self.tet_material.is_empty() {
            out.tet_material = tet_of
                .iter()
                .map(|&t| self.tet_material[t as usize])
                .collect();
        }
        centres.clear();
        (
            out,
            PartsOrder {
                node_of,
                body_node,
                tet_of,
                nodes_a,
                tets_a: ends[0],
                tets_b: ends[1],
            },
        )
    }
}

/// A `fork` for `SoftBody::step_two`: the second part's sweep on a scoped thread while the
/// calling thread runs the first (both on the calling thread when a thread cannot be made).
pub fn on_two_threads(a: &mut PartSweep<'_>, b: &mut PartSweep<'_>) {
    both(|| a.run(), || b.run());
}

/// A `fork` for `World::set_positions_two`, as [`on_two_threads`] runs a step's parts.
pub fn move_on_two_threads(a: &mut MovePart<'_>, b: &mut MovePart<'_>) {
    both(|| a.run(), || b.run());
}

/// `b` on a scoped thread while the calling thread runs `a`; `b` here after it when a
/// thread cannot be made.
fn both(a: impl FnOnce(), b: impl FnOnce() + Send) {
    let mut b = Some(b);
    std::thread::scope(|s| {
        // A thread that cannot be made drops its closure with `b` still in place.
        let _ = std::thread::Builder::new().spawn_scoped(s, || b.take().map(|b| b()));
        a();
    });
    if let Some(b) = b {
        b();
    }
}
