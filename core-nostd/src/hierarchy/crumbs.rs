//! Debris found while drilling, in bounded work: a piece of remaining material that an erasure
//! cuts off contains a leaf that touched the erased node. So each erasure leaves a *seed* (the
//! erased leaf) in a small queue, and a check of a seed floods the remaining leaves from the
//! leaves across its faces, each fill capped at `max_leaves` max-depth leaves' worth: a fill
//! that closes below the cap is a detached piece smaller than the debris size, and is erased
//! (through [`Hierarchy::erase`], so the visible faces stay exact); a fill that reaches the cap
//! is not debris and stops there. Adjacency is the NTree visit [`Hierarchy::components`] joins
//! leaves with (within a tree, across coarse faces, between levels).
//!
//! Storage is fixed (about 10 KB, inside the [`Crumbs`] its owner holds): [`CRUMB_SEEDS`]
//! seeds, [`CRUMB_STARTS`] leaves across one seed's faces, [`CRUMB_FILL`] leaves in one fill,
//! and a cache of [`CRUMB_KNOWN`] leaves known to be in big pieces. A full buffer is never
//! fatal: the seed is dropped or the piece treated as "not debris", and counted in
//! [`CrumbStats::saturations`] ([`Hierarchy::remove_debris`], a whole-object sweep, finds
//! what was skipped).

use super::geometry::node_volume;
use super::store::Hierarchy;
use super::table::Path;
use super::visit::{visit_across_from, Side};
use crate::ids::TetId;
use crate::mesh::Mesh;

/// Seeds (erased leaves) waiting for their check.
pub const CRUMB_SEEDS: usize = 1024;

/// Leaves across one seed's four faces a check starts fills from (more: the seed is checked
/// from the first ones and counted as a saturation).
pub(crate) const CRUMB_STARTS: usize = 8;

/// Leaves one fill holds (a fill stops once it holds `max_leaves` max-depth leaves' worth, so
/// at most `max_leaves` leaves; a larger `max_leaves` fills up: counted, not debris).
pub(crate) const CRUMB_FILL: usize = 16;

/// Slots of the cache of leaves known to be in big pieces (direct-mapped by node reference):
/// the leaves of every fill that reached the debris size in a batch of checks; a later fill
/// that meets one stops there. A slot overwritten only costs a longer fill.
pub(crate) const CRUMB_KNOWN: usize = 256;

/// What the checks of [`Crumbs`] did (cumulative).
#[derive(Clone, Copy, PartialEq, Debug, Default)]
pub struct CrumbStats {
    /// Pieces erased as debris.
    pub pieces: u32,
    /// Leaves erased as debris.
    pub nodes: u32,
    /// Volume erased as debris (also in [`Hierarchy::removed_volume`]).
    pub volume: f64,
    /// Seeds checked.
    pub checked: u32,
    /// Leaves the checks started a fill from.
    pub fills: u32,
    /// NTree nodes the checks touched (their work; the erasures' included).
    pub visits: u64,
    /// The size of the largest piece erased, in max-depth leaves (below the debris size).
    pub largest: u32,
    /// Seeds dropped for a full queue, seeds with more than `CRUMB_STARTS` leaves across,
    /// and fills that ran out of room (each treated as "not debris").
    pub saturations: u32,
}

/// One check's outcome, for the caller's work accounting.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default)]
pub struct CrumbWork {
    /// NTree nodes touched (the fills' visits and the erasures').
    pub visits: u32,
    /// Leaves erased.
    pub erased: u32,
}

/// A leaf in a fill: its tet, tree index, node reference and depth.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default)]
struct FillLeaf {
    tet: TetId,
    index: u32,
    node: u32,
    depth: u8,
}

/// How a fill ended.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum Fill {
    /// Closed below the size: debris.
    Closed,
    /// Reached the size, or met a leaf of a piece that did: not debris.
    Big,
    /// Out of room: not debris, counted.
    Full,
}

/// The seed queue and the fill storage of the debris checks (fixed size, no allocation).
#[derive(Clone, Debug)]
pub struct Crumbs {
    seeds: [(TetId, u32); CRUMB_SEEDS],
    head: usize,
    len: usize,
    fill: [FillLeaf; CRUMB_FILL],
    /// Leaves found in big pieces: `(node, batch)`, valid when `batch` is the current one.
    known: [(u32, u32); CRUMB_KNOWN],
    batch: u32,
    max_leaves: u32,
    /// The drill's resolution, mesh units (0: none): each tree's unit is then the leaf of
    /// its own depth limit where that is shallower than `max_depth` ([`super::unit_depth`]).
    resolution: f32,
    stats: CrumbStats,
}

impl Default for Crumbs {
    fn default() -> Self {
        Self::new(super::DEBRIS_LEAVES)
    }
}

impl Crumbs {
    /// Empty, checking for pieces below `max_leaves` max-depth leaves (0: off, no seed is
    /// kept).
    ///
    /// # Bounded work
    /// Constant.
    pub const fn new(max_leaves: u32) -> Self {
        Self {
            seeds: [(TetId(0), 0); CRUMB_SEEDS],
            head: 0,
            len: 0,
            fill: [FillLeaf {
                tet: TetId(0),
                index: 0,
                node: 0,
                depth: 0,
            }; CRUMB_FILL],
            known: [(u32::MAX, 0); CRUMB_KNOWN],
            batch: 0,
            max_leaves,
            resolution: 0.0,
            stats: CrumbStats {
                pieces: 0,
                nodes: 0,
                volume: 0.0,
                checked: 0,
                fills: 0,
                visits: 0,
                largest: 0,
                saturations: 0,
            },
        }
    }

    /// Sets the drill's resolution (mesh units; 0, negative or not finite: none), so that a
    /// piece's size counts the leaves of each tree's own depth limit
    /// ([`crate::drill::Drill::set_resolution`] sets it for the drill's checks).
    ///
    /// # Bounded work
    /// Constant.
    pub fn set_resolution(&mut self, resolution: f32) {
        self.resolution = if resolution.is_finite() && resolution > 0.0 {
            resolution
        } else {
            0.0
        };
    }

    /// Sets the debris size in max-depth leaves; 0 turns the checks off and drops the seeds.
    ///
    /// # Bounded work
    /// Constant.
    pub(crate) fn set_max_leaves(&mut self, max_leaves: u32) {
        self.max_leaves = max_leaves;
        if max_leaves == 0 {
            self.clear();
        }
    }

    /// Drops the waiting seeds (after [`Hierarchy::reset`]); the counts stay.
    ///
    /// # Bounded work
    /// Constant.
    pub(crate) fn clear(&mut self) {
        self.head = 0;
        self.len = 0;
    }

    /// Starts a batch of checks: forgets the leaves found in big pieces (valid only while
    /// nothing but these checks changes the hierarchy: a drill operation may cut them off).
    ///
    /// # Bounded work
    /// Constant.
    pub fn forget(&mut self) {
        self.batch = self.batch.wrapping_add(1);
        if self.batch == 0 {
            // Wrapped: no old entry may look current.
            self.known = [(u32::MAX, 0); CRUMB_KNOWN];
            self.batch = 1;
        }
    }

    /// `true` when leaf `node` is known to be in a big piece in this batch.
    fn is_known(&self, node: u32) -> bool {
        self.known.get(node as usize % CRUMB_KNOWN) == Some(&(node, self.batch))
    }

    /// Seeds waiting for their check.
    pub(crate) fn pending(&self) -> usize {
        self.len
    }

    /// `true` when the next seed would be dropped: the caller checks one first.
    pub fn is_full(&self) -> bool {
        self.max_leaves > 0 && self.len == CRUMB_SEEDS
    }

    /// The counts so far.
    pub fn stats(&self) -> CrumbStats {
        self.stats
    }

    /// Notes leaf `(tet, index)` as erased just now: a seed to check (dropped and counted
    /// when the queue is full; nothing when the checks are off).
    ///
    /// # Bounded work
    /// Constant.
    pub fn note(&mut self, tet: TetId, index: u32) {
        if self.max_leaves == 0 {
            return;
        }
        if self.len == CRUMB_SEEDS {
            self.stats.saturations = self.stats.saturations.saturating_add(1);
            return;
        }
        if let Some(s) = self.seeds.get_mut((self.head + self.len) % CRUMB_SEEDS) {
            *s = (tet, index);
            self.len += 1;
        }
    }

    /// Checks the oldest seed: floods the remaining leaves from each leaf across its faces,
    /// up to `max_leaves` leaves of depth `max_depth` (a leaf of depth `d` counts
    /// `8^(max_depth - d)`), and erases every fill that closes below that, unless it holds
    /// half the remaining material or more (then it may be the main body: a whole-object
    /// [`Hierarchy::remove_debris`] decides). `erased(tet, volume)` is called for every leaf
    /// erased. `None` when no seed waits.
    ///
    /// Leaves found in big pieces are remembered until [`Crumbs::forget`], which the caller
    /// calls before a batch of checks whenever anything else changed the hierarchy since the
    /// last one.
    ///
    /// The seed is looked up by its tree index (the deepest instantiated node on its path: an
    /// erased leaf, the seed itself or the erased ancestor its block was given back to).
    ///
    /// # Bounded work
    /// O(depth) to find the seed, 4 NTree visits across its faces (stopped after
    /// `CRUMB_STARTS` leaves), then per start leaf a fill of at most `max_leaves` leaves
    /// (and at most `CRUMB_FILL`), 4 NTree visits each (and a scan of the fill per leaf
    /// met), and for a closed fill one [`Hierarchy::erase`] per leaf: O(`CRUMB_STARTS` *
    /// `CRUMB_FILL`) NTree visits in all.
    pub fn check_one<F: FnMut(TetId, f64)>(
        &mut self,
        h: &mut Hierarchy<'_>,
        mesh: &Mesh<'_>,
        max_depth: u8,
        mut erased: F,
    ) -> Option<CrumbWork> {
        if self.len == 0 {
            return None;
        }
        let (tet, index) = self.seeds.get(self.head).copied()?;
        self.head = (self.head + 1) % CRUMB_SEEDS;
        self.len -= 1;
        self.stats.checked = self.stats.checked.saturating_add(1);
        let mut work = CrumbWork::default();
        let Some(full) = Path::of_index(index) else {
            return Some(work);
        };
        // The deepest node on the seed's path: an erased leaf (erasures are never undone).
        let (mut r, mut path) = (tet.0, Path::ROOT);
        if tet.idx() >= h.tet_count() {
            return Some(work);
        }
        for k in 1..=full.depth as usize {
            work.visits += 1;
            let Some(c) = h.child(r, full.digit(k)) else {
                break;
            };
            let Some(p) = path.child(full.digit(k)) else {
                break;
            };
            (r, path) = (c, p);
        }
        if !h.node(r).is_some_and(|n| n.is_leaf() && n.erased()) {
            return Some(work);
        }
        // The leaves across its faces.
        let mut starts = [FillLeaf::default(); CRUMB_STARTS];
        let mut ns = 0usize;
        let mut over = false;
        for f in 0..4u8 {
            let mut ctx = &*h;
            let side = visit_across_from(
                &mut ctx,
                mesh,
                tet,
                (&path, r),
                f,
                &mut work.visits,
                |_, met| {
                    if met.record.erased() {
                        return true;
                    }
                    let Some(slot) = starts.get_mut(ns) else {
                        return false;
                    };
                    *slot = FillLeaf {
                        tet: met.tet,
                        index: met.index,
                        node: met.node,
                        depth: met.depth,
                    };
                    ns += 1;
                    true
                },
            );
            if side == Side::Stopped {
                over = true;
                break;
            }
        }
        if over {
            self.stats.saturations = self.stats.saturations.saturating_add(1);
        }
        for s in starts.iter().take(ns) {
            // Part of a piece already found big (or erased just now as debris): nothing to do.
            if self.is_known(s.node) || h.node(s.node).is_none_or(|n| n.erased() || !n.is_leaf()) {
                continue;
            }
            self.stats.fills = self.stats.fills.saturating_add(1);
            let (end, outcome, size) = self.flood(h, mesh, *s, max_depth, &mut work.visits);
            match outcome {
                Fill::Big => {
                    let batch = self.batch;
                    for l in self.fill.iter().take(end) {
                        if let Some(slot) = self.known.get_mut(l.node as usize % CRUMB_KNOWN) {
                            *slot = (l.node, batch);
                        }
                    }
                }
                Fill::Full => {
                    self.stats.saturations = self.stats.saturations.saturating_add(1);
                }
                Fill::Closed => {
                    let piece = self.fill.get(..end).unwrap_or(&[]);
                    let volume: f64 = piece
                        .iter()
                        .map(|l| node_volume(mesh, l.tet, l.depth))
                        .sum();
                    let remaining = h.initial_volume() - h.removed_volume();
                    if 2.0 * volume >= remaining {
                        continue;
                    }
                    let (mut n, mut v) = (0u32, 0.0f64);
                    for l in piece {
                        let Some(p) = Path::of_index(l.index) else {
                            continue;
                        };
                        if let Ok(op) = h.erase_at(mesh, l.tet, &p, l.node) {
                            work.visits = work.visits.saturating_add(op.work);
                            n += 1;
                            v += op.removed;
                            erased(l.tet, op.removed);
                        }
                    }
                    work.erased += n;
                    self.stats.pieces = self.stats.pieces.saturating_add(1);
                    self.stats.nodes = self.stats.nodes.saturating_add(n);
                    self.stats.volume += v;
                    self.stats.largest = self.stats.largest.max(size);
                }
            }
        }
        self.stats.visits = self.stats.visits.saturating_add(u64::from(work.visits));
        Some(work)
    }

    /// Floods the non-erased leaves from `start`, writing them at `fill[..]`; returns the end
    /// of what it wrote, how it ended and the size met (max-depth leaves). A leaf met that is
    /// known to be in a big piece ends it.
    fn flood(
        &mut self,
        h: &Hierarchy<'_>,
        mesh: &Mesh<'_>,
        start: FillLeaf,
        max_depth: u8,
        visits: &mut u32,
    ) -> (usize, Fill, u32) {
        let k = self.max_leaves;
        let resolution = self.resolution;
        // Each tree's unit depth, the last tree's kept (the flood meets a tree's leaves in
        // runs).
        let mut last: Option<(TetId, u8)> = None;
        let mut units = |tet: TetId, depth: u8| {
            let unit = match last {
                _ if resolution <= 0.0 => max_depth,
                Some((t, u)) if t == tet => u,
                _ => {
                    let u = super::unit_depth(mesh, tet, max_depth, resolution);
                    last = Some((tet, u));
                    u
                }
            };
            8u32.saturating_pow(u32::from(unit.saturating_sub(depth)))
        };
        let Some(slot) = self.fill.get_mut(0) else {
            return (0, Fill::Full, 0);
        };
        *slot = start;
        let mut end = 1;
        let mut size = units(start.tet, start.depth);
        if size >= k {
            return (end, Fill::Big, size);
        }
        let mut i = 0;
        while i < end {
            let Some(leaf) = self.fill.get(i).copied() else {
                break;
            };
            i += 1;
            let Some(path) = Path::of_index(leaf.index) else {
                continue;
            };
            for f in 0..4u8 {
                let mut outcome = None;
                let (fill, known, batch) = (&mut self.fill, &self.known, self.batch);
                let mut ctx = h;
                visit_across_from(
                    &mut ctx,
                    mesh,
                    leaf.tet,
                    (&path, leaf.node),
                    f,
                    visits,
                    |_, met| {
                        if met.record.erased() {
                            return true;
                        }
                        if known.get(met.node as usize % CRUMB_KNOWN) == Some(&(met.node, batch)) {
                            outcome = Some(Fill::Big);
                            return false;
                        }
                        if fill.iter().take(end).any(|l| l.node == met.node) {
                            return true;
                        }
                        let Some(slot) = fill.get_mut(end) else {
                            outcome = Some(Fill::Full);
                            return false;
                        };
                        *slot = FillLeaf {
                            tet: met.tet,
                            index: met.index,
                            node: met.node,
                            depth: met.depth,
                        };
                        end += 1;
                        size = size.saturating_add(units(met.tet, met.depth));
                        if size >= k {
                            outcome = Some(Fill::Big);
                            return false;
                        }
                        true
                    },
                );
                if let Some(o) = outcome {
                    return (end, o, size);
                }
            }
        }
        (end, Fill::Closed, size)
    }
}
