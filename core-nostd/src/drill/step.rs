//! The budgeted drill step: refine the nodes that cross a sample sphere, erase the frontier
//! nodes inside it, carry what does not fit to the next tick.

use glam::Vec3;

use super::cost::{DrillParams, WorkCost};
use super::deque::{split, Ring, FINE_DESCENT};
use super::material::{Regions, Spend};
use super::sphere::{classify_costed, Class, Sphere};
use crate::geom::tri_area;
use crate::hierarchy::{
    child_of_refinement, child_of_ten, refinement_points, refinement_points_masked, Crumbs,
    Hierarchy, HierarchyError, Path, RootFrame, ALL_POINTS, MAX_DEPTH,
};
use crate::ids::TetId;
use crate::mesh::template::FACE_VERTS;
use crate::mesh::Mesh;

/// One unit of pending work: a node of a tree, against the sphere it was queued for, with the
/// node's integer barycentric coordinates in its root (so processing it costs no walk from the
/// root). 64 bytes (pinned at compile time).
#[derive(Clone, Copy, PartialEq, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C)]
pub struct Pending {
    /// The coarse tet.
    pub tet: TetId,
    /// Tree index.
    pub index: u32,
    /// Node reference (looked up again by `(tet, index)` when the hierarchy has taken back
    /// blocks since the item was queued: see [`Hierarchy::reclaimed`]).
    pub node: u32,
    /// The sphere, as it was when the work was queued (so the removed shape converges to the
    /// swept volume even when the work finishes ticks later).
    pub sphere: Sphere,
    /// [`epoch_of`] the hierarchy when the item was queued: while [`Hierarchy::reclaimed`]
    /// still equals it, no block has been taken back since and `node` is still the node it
    /// was; otherwise the node is looked up again by `(tet, index)`. Placed before `bary`,
    /// it fills what would be padding.
    epoch: u32,
    /// The node's corners as integer barycentric coordinates of its root's, scaled by
    /// `2^depth`: one `u64` per corner holding four 16-bit weights (each at most
    /// `2^MAX_DEPTH` = 1024, so a child's row is one `u64` addition of two parent rows).
    bary: [u64; 4],
}

/// The epoch an item queued now records: [`Hierarchy::reclaimed`], but never `u32::MAX`,
/// where that count saturates, so once it has saturated no item is trusted without a look-up.
#[inline]
fn epoch_of(h: &Hierarchy<'_>) -> u32 {
    h.reclaimed().min(u32::MAX - 1)
}

const _: () = assert!(core::mem::size_of::<Pending>() == 64);

impl Pending {
    /// An empty item (for initialising static storage).
    pub const EMPTY: Self = Self {
        tet: TetId(0),
        index: 0,
        node: 0,
        sphere: Sphere {
            center: Vec3::ZERO,
            radius: 0.0,
        },
        bary: [0; 4],
        epoch: 0,
    };

    /// The root of `tet`'s tree against `sphere`, queued at `epoch` (see [`epoch_of`]).
    fn root(tet: TetId, sphere: Sphere, epoch: u32) -> Self {
        Self {
            tet,
            index: 0,
            node: tet.0,
            sphere,
            // The root's rows depend on its frame's corner order: filled in when taken.
            bary: [0; 4],
            epoch,
        }
    }
}

/// What one [`Drill::step`] did.
#[derive(Clone, Copy, PartialEq, Debug, Default)]
pub struct DrillReport {
    /// Nodes created by refinement.
    pub created: u32,
    /// Leaves erased.
    pub erased: u32,
    /// Volume removed during this step.
    pub removed_volume: f64,
    /// Work units used (may exceed the budget by the cost of the last operation).
    pub work: u32,
    /// Work items taken from the deque.
    pub taken: u32,
    /// Nodes whose eight children were classified (and the survivors queued), or, one level
    /// above `max_depth`, whose children's centroids were tested before a refinement.
    pub expanded: u32,
    /// Nodes touched by the NTree visits of the refinements and erasures.
    pub visits: u32,
    /// Tet-sphere classifications that needed the exact test ([`WorkCost::EXACT_TEST`]).
    pub exact_tests: u32,
    /// Searches of the remembered spheres for an item's sphere ([`WorkCost::LOCATE`]).
    pub located: u32,
    /// Work items left for the next tick.
    pub pending: u32,
    /// Capacity saturations this step (arena full, pending queue full).
    pub saturations: u32,
    /// Items dropped because the pressing force does not remove their region's material
    /// ([`super::Material::admits`]).
    pub held: u32,
    /// 1 when the step ended on a leaf waiting for its region's credit
    /// ([`super::Regions::spend`]).
    pub waited: u32,
    /// Erased leaves checked for debris cut off (`crumbs.rs`).
    pub debris_checked: u32,
    /// Leaves erased as debris (in `removed_volume`, not in `erased`).
    pub debris_erased: u32,
}

/// [`super::classify`], charging the exact test when it runs ([`WorkCost::EXACT_TEST`]).
fn classify_charged(p: [Vec3; 4], s: &Sphere, rep: &mut DrillReport) -> Class {
    let (class, exact) = classify_costed(p, s);
    if exact {
        rep.exact_tests += 1;
        rep.work = rep.work.saturating_add(WorkCost::EXACT_TEST);
    }
    class
}

/// A node whose children were queued, with the ten points of its red refinement: its
/// children's corners.
#[derive(Clone, Copy, Debug)]
struct Parent {
    tet: TetId,
    index: u32,
    pts: [Vec3; 10],
}

impl Parent {
    /// No node ([`TetId::NONE`] matches no item).
    const EMPTY: Self = Self {
        tet: TetId::NONE,
        index: 0,
        pts: [Vec3::ZERO; 10],
    };
}

/// The ten points of a node's refinement: integer barycentric rows and positions.
type Ten = ([u64; 10], [Vec3; 10]);

/// A drill step whose debris seed queue is full checks a seed before each item until it has
/// spent `budget / CRUMB_SHARE` on checks: a drill lagging behind the burr keeps seven eighths
/// of its budget for material, and its crumbs are still found while it drills.
pub const CRUMB_SHARE: u32 = 8;

/// The coarse pass defers the last level's refinements only while at least this many spheres
/// were queued after the item's own: a drill that keeps up with the burr refines at once (the
/// fine pass walks the trees down again, about 7 % more work).
pub const DEFER_LAG: usize = 8;

/// Which ring an item came from (its children go to the same one).
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum Pass {
    Coarse,
    Fine,
}

/// Spheres remembered to skip re-queueing an unchanged sphere whose work is already queued.
const MEMO: usize = 8;

/// Spheres the drill remembers, in the order they were queued (a ring: the oldest is
/// forgotten). Work is taken in that order too, so while the drill lags behind the burr the
/// spheres queued after the one being worked on are known; [`SWEPT_AHEAD`] of them are its
/// swept volume (see [`Drill::step`]). The ring holds that many past a lag of
/// `SWEPT - SWEPT_AHEAD` spheres; a drill further behind sees fewer, down to none once its
/// sphere has been forgotten.
pub const SWEPT: usize = 64;

/// How many spheres queued after an item's own count as the swept volume for it: a burr queued
/// every eighth of the radius ([`crate::servo::DRILL_SPACING`]) meets the next sixteen
/// positions, the only ones a node on its surface can lie inside. Spheres queued *before* an
/// item's are not tested: their work came first, and it erased what lay inside them.
pub const SWEPT_AHEAD: usize = 16;

/// The drill: a pending-work deque in caller storage (two rings, coarse and fine: see
/// [`Drill::step`]) and counters.
#[derive(Debug)]
pub struct Drill<'a> {
    /// The coarse pass: every sphere's work except the refinement of the last level.
    coarse: Ring<'a>,
    /// The fine pass: the roots whose coarse pass met a leaf one level above `max_depth`
    /// worth refining, taken only once the coarse ring is empty.
    fine: Ring<'a>,
    memo: [Option<Sphere>; MEMO],
    /// The last [`SWEPT`] spheres queued (a ring; `swept_len` of them valid).
    swept: [Sphere; SWEPT],
    swept_next: usize,
    swept_len: usize,
    /// The sphere whose successors were last looked up (cleared when a sphere is
    /// remembered), the slot of the first of them and how many (see [`Drill::swept_after`]).
    swept_for: Option<Sphere>,
    swept_first: usize,
    swept_count: usize,
    /// How many remembered spheres were queued after that sphere (all of them when it is
    /// forgotten): how far the drill lags behind the burr.
    swept_lag: usize,
    /// The root frame of the last tet processed (items come tree by tree).
    frame: Option<(TetId, RootFrame)>,
    /// Per depth, the last node whose children were queued and the ten points of its
    /// refinement (see [`Drill::corners`]); [`Parent::EMPTY`] for none. Written in place:
    /// the ten points are evaluated into their entry, not copied there (on the Cortex-M4 a
    /// copy of the 120 bytes is a call to `memcpy`).
    parents: [Parent; MAX_DEPTH],
    retry: bool,
    saturations: u32,
    /// The materials per region, if set ([`Drill::set_regions`]).
    pub(super) regions: Option<Regions<'a>>,
    /// A leaf waits for its region's credit: the step stops.
    stalled: bool,
    /// The erased leaves waiting for their debris check.
    pub(super) crumbs: Crumbs,
}

impl<'a> Drill<'a> {
    /// A drill whose pending deque is `queue` (its length is the capacity). From
    /// [`super::FINE_MIN_DEQUE`] entries up, the second half holds the fine pass's roots; a smaller
    /// deque is all coarse pass (every refinement done at once).
    ///
    /// # Bounded work
    /// O(1).
    pub fn new(queue: &'a mut [Pending]) -> Self {
        let (coarse, fine) = split(queue);
        Self {
            coarse,
            fine,
            memo: [None; MEMO],
            swept: [Sphere::default(); SWEPT],
            swept_next: 0,
            swept_len: 0,
            swept_for: None,
            swept_first: 0,
            swept_count: 0,
            swept_lag: 0,
            frame: None,
            parents: [Parent::EMPTY; MAX_DEPTH],
            retry: false,
            saturations: 0,
            regions: None,
            stalled: false,
            crumbs: Crumbs::default(),
        }
    }

    /// Work items waiting for the next tick.
    #[inline]
    pub fn pending(&self) -> usize {
        self.coarse.len() + self.fine.len()
    }

    /// Work items dropped because the pending deque was full (since creation). The arena's
    /// refusals are counted by [`Hierarchy::saturations`].
    #[inline]
    pub fn saturations(&self) -> u32 {
        self.saturations
    }

    /// Drops all pending work (e.g. after [`Hierarchy::reset`]).
    ///
    /// # Bounded work
    /// O(1).
    pub fn clear(&mut self) {
        self.coarse.clear();
        self.fine.clear();
        self.memo = [None; MEMO];
        self.swept_len = 0;
        self.swept_next = 0;
        self.frame = None;
        self.parents = [Parent::EMPTY; MAX_DEPTH];
        self.stalled = false;
        self.crumbs.clear();
    }

    /// Remembers `s` as part of the swept volume (the oldest of [`SWEPT`] is forgotten).
    fn remember(&mut self, s: Sphere) {
        if let Some(slot) = self.swept.get_mut(self.swept_next) {
            *slot = s;
        }
        self.swept_next = (self.swept_next + 1) % SWEPT;
        self.swept_len = (self.swept_len + 1).min(SWEPT);
        self.swept_for = None;
    }

    /// The root frame of `tet`, cached across consecutive items of one tree.
    fn frame(&mut self, mesh: &Mesh<'_>, tet: TetId) -> Option<RootFrame> {
        match self.frame {
            Some((t, f)) if t == tet => Some(f),
            _ => {
                let f = RootFrame::of(mesh, tet)?;
                self.frame = Some((tet, f));
                Some(f)
            }
        }
    }

    /// The corners of `item` at `depth`. Children are queued at the front, so a node's eight
    /// children are taken before any other node of its depth has its children queued: the
    /// parent's refinement points, kept per depth, are still there and a child's corners are
    /// four of them (the same bits as [`RootFrame::positions_packed`] of its own
    /// coordinates). Otherwise (a root, an item carried from an earlier tick whose parent
    /// entry was overwritten) they are evaluated from the item's coordinates.
    ///
    /// # Bounded work
    /// Constant: four look-ups, or four point evaluations.
    fn corners(&self, frame: &RootFrame, item: &Pending, depth: u8) -> [Vec3; 4] {
        if depth > 0 {
            let parent = (item.index - 1) / 8;
            if let Some(q) = self.parents.get(depth as usize - 1) {
                if q.tet == item.tet && q.index == parent {
                    let c = ((item.index - 1) % 8) as u8;
                    return child_of_ten(&q.pts, c);
                }
            }
        }
        frame.positions_packed(&item.bary, depth)
    }

    /// The spheres queued after `s`, oldest first, at most [`SWEPT_AHEAD`] of them. When `s`
    /// is no longer remembered, every remembered sphere was queued after it: the oldest
    /// [`SWEPT_AHEAD`] of them. The answer for the last sphere asked for is kept (items come
    /// sphere by sphere); remembering a new sphere clears it.
    ///
    /// # Bounded work
    /// O(1) when `s` is the last sphere asked for, else O([`SWEPT`]) comparisons, charged
    /// [`WorkCost::LOCATE`].
    fn swept_after<'s>(
        &'s mut self,
        s: &Sphere,
        rep: &mut DrillReport,
    ) -> impl Iterator<Item = &'s Sphere> + 's {
        if self.swept_for != Some(*s) {
            rep.work = rep.work.saturating_add(WorkCost::LOCATE);
            rep.located += 1;
            let oldest = (self.swept_next + SWEPT - self.swept_len) % SWEPT;
            let ring = &self.swept;
            let (first, count) =
                match (0..self.swept_len).find(|&k| ring.get((oldest + k) % SWEPT) == Some(s)) {
                    Some(k) => (oldest + k + 1, self.swept_len - 1 - k),
                    None => (oldest, self.swept_len),
                };
            self.swept_for = Some(*s);
            self.swept_first = first % SWEPT;
            self.swept_count = count.min(SWEPT_AHEAD);
            self.swept_lag = count;
        }
        let (first, ring) = (self.swept_first, &self.swept);
        (0..self.swept_count).filter_map(move |k| ring.get((first + k) % SWEPT))
    }

    /// `true` when all four corners `p` lie inside one of the spheres queued after `s`.
    fn inside_swept(&mut self, s: &Sphere, p: &[Vec3; 4], rep: &mut DrillReport) -> bool {
        self.swept_after(s, rep).any(|t| {
            let r2 = t.radius * t.radius;
            p.iter().all(|q| q.distance_squared(t.center) <= r2)
        })
    }

    /// `true` when `x` lies inside one of the spheres queued after `s`.
    fn point_in_swept(&mut self, s: &Sphere, x: Vec3, rep: &mut DrillReport) -> bool {
        self.swept_after(s, rep)
            .any(|t| x.distance_squared(t.center) <= t.radius * t.radius)
    }

    fn saturate(&mut self, rep: &mut DrillReport) {
        self.saturations += 1;
        rep.saturations += 1;
        // Dropped work is retried once the backlog is done (re-queueing now would only be
        // dropped again).
        self.retry = true;
    }

    /// One drill tick. New work: every candidate coarse tet against every sphere (skipped for
    /// a sphere identical to last tick's when its work is already queued or done; after work
    /// was dropped for a full deque, unchanged spheres are queued again once the deque is
    /// empty). Then work items are taken until the budget is spent, in two passes: the coarse
    /// ring first, oldest sphere first (each node's children go to the front, so one sphere's
    /// subtree is finished depth first); once it is empty, the fine ring, where the coarse pass
    /// left the refinement of the last level (below). A path's work at a fine `max_depth` can
    /// be more than its ticks' budget (the last level's refinements cost most of it and hold
    /// the least volume): every sphere's coarse material goes first, and the drill no longer
    /// falls behind the burr refining the first spheres' walls.
    ///
    /// Each item:
    /// - a node outside the sphere, or with every leaf erased, is dropped;
    /// - an inner node's eight children are classified from the ten points of its refinement
    ///   and those that meet the sphere and still hold material are queued (the others would
    ///   only be dropped);
    /// - a leaf entirely inside the sphere (all four corners), or inside one of the
    ///   [`SWEPT_AHEAD`] spheres queued after it (the swept path, which erases it anyway when
    ///   its own work arrives), is erased at once: only the boundary of the swept volume is
    ///   refined, not the shell of every sphere along it. The later spheres are known when
    ///   the drill lags behind the burr, which is when the work matters (before 2026-11-24 the
    ///   last [`SWEPT_AHEAD`] spheres queued were tested instead: useless once the drill was
    ///   more than that many spheres behind, and the earlier ones never hold material);
    /// - a leaf crossing the sphere is refined when it is above `max_depth` and its smallest
    ///   face is at least `min_area`, and its children are queued. One level above
    ///   `max_depth`, while the drill lags [`DEFER_LAG`] spheres or more behind the burr: in
    ///   the coarse pass its tree's root goes to the fine ring instead (once for a run of such
    ///   leaves of one tree, while the fine ring has room for the root and a descent, else it
    ///   is refined now); the fine pass, or a coarse pass that keeps up, refines it only when
    ///   the centroid of one of its children lies inside the sphere or the spheres queued
    ///   after it (the children would otherwise all stay: the refinement would only add
    ///   nodes);
    /// - a crossing leaf at `max_depth` or below `min_area` is erased iff its centroid is
    ///   inside the sphere or one of the spheres queued after it. This is the erosion
    ///   criterion: the misclassified volume lies within one leaf of the sphere's surface and
    ///   is unbiased to first order, so the removed volume converges to the swept volume as
    ///   the leaves shrink;
    /// - a crossing leaf whose refinement the full arena refuses stays whole.
    ///
    /// `candidates` are the coarse tets near the tool (from the spatial hash, or
    /// [`super::candidates_brute_force`]).
    ///
    /// # Bounded work
    /// The new work is O(candidates * spheres) pushes. After that no operation starts once
    /// `budget` units are spent ([`WorkCost`]: each item taken, each node expanded, each
    /// NTree node visited and each node created is charged what it costs); the last one may
    /// overrun it by its own cost. A refinement does not start when its 8 created nodes alone
    /// would pass the budget, unless it is the tick's first item: the item waits at the front
    /// of its ring for the next tick. A refinement is 8 nodes created plus 16 NTree visits (one
    /// level above `max_depth`, after its children's centroid test, counted as the expansion
    /// that follows the refinement), an
    /// erasure 4 NTree visits, each O(depth) plus the instantiated nodes across one face. A
    /// leaf's swept test is at most [`SWEPT_AHEAD`] sphere tests, after a search of the
    /// [`SWEPT`] remembered spheres when the item's sphere is not the last one looked up
    /// ([`WorkCost::LOCATE`]). Every leaf erased leaves a debris seed; the seeds are checked
    /// after the items, while the budget lasts, and before the next item when their queue is
    /// full ([`crate::hierarchy::Crumbs::check_one`], charged [`WorkCost::TAKEN`] plus its NTree
    /// visits; the rest wait for the next step).
    ///
    /// # Capacity
    /// Arena full (no fresh block, and no wholly erased subtree to take one back from): the
    /// leaf is not refined and stays whole (erasing a coarse leaf by its centroid would move
    /// the surface past the burr in one tick, a force jump); the hierarchy counts it. Once
    /// the arena takes blocks back, an item queued before a block was taken back is looked
    /// up again by its tree index before it is used (O(depth) more for that item; stale
    /// items are dropped). Pending deque full: the new item or the children are dropped and
    /// counted; the hierarchy stays valid, only the erosion is coarser there.
    pub fn step(
        &mut self,
        h: &mut Hierarchy<'_>,
        mesh: &Mesh<'_>,
        candidates: &[TetId],
        spheres: &[Sphere],
        params: &DrillParams,
    ) -> DrillReport {
        let mut rep = DrillReport::default();
        self.stalled = false;
        let removed0 = h.removed_volume();
        let sat0 = h.saturations();
        if self.retry && self.pending() == 0 {
            self.retry = false;
            self.memo = [None; MEMO];
        }
        for (k, s) in spheres.iter().enumerate() {
            if k < MEMO && self.memo[k] == Some(*s) {
                continue;
            }
            if self.swept_len == 0 || self.swept[(self.swept_next + SWEPT - 1) % SWEPT] != *s {
                self.remember(*s);
            }
            let mut all = true;
            for &t in candidates {
                if t.idx() >= h.tet_count() {
                    continue;
                }
                if !self.coarse.push_back(Pending::root(t, *s, epoch_of(h))) {
                    all = false;
                }
            }
            if all {
                if let Some(m) = self.memo.get_mut(k) {
                    *m = Some(*s);
                }
            } else {
                self.saturate(&mut rep);
            }
        }
        let max_depth = params.max_depth.min(crate::hierarchy::MAX_DEPTH as u8);
        // While the seed queue is full, a seed is checked before the next item, up to an
        // eighth of the budget ([`CRUMB_SHARE`]); past that, new seeds are dropped (counted)
        // and the items get the rest.
        let share = params.budget / CRUMB_SHARE;
        let mut checks = 0u32;
        while rep.work < params.budget && !self.stalled {
            if self.crumbs.is_full() && checks < share {
                // Items may have changed the hierarchy since the last check.
                self.crumbs.forget();
                let w0 = rep.work;
                if self.check_crumb(h, mesh, max_depth, &mut rep) {
                    checks = checks.saturating_add(rep.work - w0);
                    continue;
                }
            }
            let (item, pass) = match self.coarse.pop_front() {
                Some(item) => (item, Pass::Coarse),
                None => match self.fine.pop_front() {
                    Some(item) => (item, Pass::Fine),
                    None => break,
                },
            };
            rep.work = rep.work.saturating_add(WorkCost::TAKEN);
            rep.taken += 1;
            if !self.process(h, mesh, item, pass, max_depth, params, &mut rep) {
                // A refinement that would overrun the budget: the item waits at the front.
                let _ = match pass {
                    Pass::Coarse => self.coarse.push_front(item),
                    Pass::Fine => self.fine.push_front(item),
                };
                break;
            }
        }
        // Debris checks take what the drill's items leave of the budget: removing material
        // comes first (a seed queue still full drops seeds, counted in
        // `CrumbStats::saturations`).
        self.check_crumbs(h, mesh, max_depth, params.budget, &mut rep);
        rep.pending = self.pending() as u32;
        rep.removed_volume = h.removed_volume() - removed0;
        rep.saturations += h.saturations() - sat0;
        rep
    }

    #[allow(clippy::too_many_arguments)]
    fn process(
        &mut self,
        h: &mut Hierarchy<'_>,
        mesh: &Mesh<'_>,
        item: Pending,
        pass: Pass,
        max_depth: u8,
        params: &DrillParams,
        rep: &mut DrillReport,
    ) -> bool {
        let min_area = params.min_area;
        // A reference stays valid until the arena takes back the block holding it (only
        // blocks of erased leaves are taken back, once the fresh ones are used up). When a
        // block has been taken back since the item was queued, the reference may name a node
        // of a reused block: the item is looked up again by its tree index (a collapsed
        // subtree's nodes answer `None`; they were all erased, so the item had nothing left
        // to do).
        if item.epoch != h.reclaimed() && h.find(item.tet, item.index) != Some(item.node) {
            return true;
        }
        let Some(node) = h.node(item.node) else {
            return true;
        };
        if node.all_erased() {
            return true;
        }
        // Material the pressing force does not remove is neither refined nor erased; the
        // burr's unchanged positions are queued again once the backlog is done (as after a
        // full deque), so a burr held still cuts when pressed harder.
        if !self.admits(item.tet) {
            rep.held += 1;
            self.retry = true;
            return true;
        }
        let Some(depth) = Path::depth_of(item.index) else {
            return true;
        };
        let Some(frame) = self.frame(mesh, item.tet) else {
            return true;
        };
        let item = match item.index {
            0 => Pending {
                bary: frame.root_packed(),
                ..item
            },
            _ => item,
        };
        let p = self.corners(&frame, &item, depth);
        let class = classify_charged(p, &item.sphere, rep);
        if class == Class::Outside {
            return true;
        }
        if !node.is_leaf() {
            self.queue_children(h, &frame, item, depth, pass, None, rep);
            return true;
        }
        // Inside this sphere: erased at once, never refined.
        let Some(path) = Path::of_index(item.index) else {
            return true;
        };
        if class == Class::Inside {
            self.erase(h, mesh, item, pass, &path, rep);
            return true;
        }
        // Areas are never negative (and `f32::min` skips NaN), so a `min_area` of zero or
        // less passes without computing them; at `max_depth` they are not needed at all.
        let big_enough = || {
            min_area <= 0.0
                || FACE_VERTS
                    .iter()
                    .map(|f| tri_area(p[f[0] as usize], p[f[1] as usize], p[f[2] as usize]))
                    .fold(f32::INFINITY, f32::min)
                    >= min_area
        };
        let refinable = path.depth < max_depth && big_enough();
        // One level above the last: refined in the fine pass (the coarse pass of every sphere
        // comes first). Deferred before the swept test: a leaf inside a later sphere is
        // erased by that sphere's own coarse pass.
        if refinable
            && path.depth + 1 == max_depth
            && pass == Pass::Coarse
            && self.defer(&item, rep)
        {
            return true;
        }
        // Inside another sphere of the swept path (which erases it anyway when its own work
        // arrives): erased at once, never refined.
        if self.inside_swept(&item.sphere, &p, rep) {
            self.erase(h, mesh, item, pass, &path, rep);
            return true;
        }
        if refinable {
            // Not started when its nodes alone would overrun the budget, unless it is the
            // tick's first item (the step always makes progress): the overrun of a tick is
            // then at most an erasure or an expansion, not a refinement.
            if rep.taken > 1 && rep.work.saturating_add(WorkCost::CREATED * 8) > params.budget {
                return false;
            }
            let ten = if path.depth + 1 == max_depth {
                match self.a_child_would_go(&frame, &item, depth, rep) {
                    Some(ten) => Some(ten),
                    None => return true,
                }
            } else {
                None
            };
            match h.refine_at(mesh, item.tet, &path, item.node) {
                Ok(r) => {
                    rep.work = rep
                        .work
                        .saturating_add(WorkCost::VISIT * r.work + WorkCost::CREATED * r.created);
                    rep.visits = rep.visits.saturating_add(r.work);
                    rep.created += r.created;
                    self.queue_children(h, &frame, item, depth, pass, ten, rep);
                    return true;
                }
                Err(HierarchyError::Full) => {
                    // Counted by the hierarchy. The leaf stays: erasing a coarse leaf by its
                    // centroid would move the surface past the burr in one tick (a force
                    // jump); kept, it still bounds the material and the burr feels it.
                    // Not retried here: the arena only gets blocks back when more material
                    // is erased; a later sphere's work reaches the leaf again.
                    return true;
                }
                Err(_) => return true,
            }
        }
        let centroid = (p[0] + p[1] + p[2] + p[3]) * 0.25;
        let r = item.sphere.radius;
        if centroid.distance_squared(item.sphere.center) <= r * r
            || self.point_in_swept(&item.sphere, centroid, rep)
        {
            self.erase(h, mesh, item, pass, &path, rep);
        }
        true
    }

    /// The ten points of `item`'s refinement (rows and positions) when the centroid of one of
    /// its eight children lies inside its sphere or one of the spheres queued after it: refined
    /// to the last level, the leaf would lose that child. `None` otherwise: no child would go
    /// (a child inside a sphere has its centroid inside it), and refining the leaf would only
    /// add nodes. Counted as the expansion that follows the refinement, which takes the points
    /// from here ([`WorkCost::EXPANDED`], charged once).
    fn a_child_would_go(
        &mut self,
        frame: &RootFrame,
        item: &Pending,
        depth: u8,
        rep: &mut DrillReport,
    ) -> Option<Ten> {
        rep.expanded += 1;
        rep.work = rep.work.saturating_add(WorkCost::EXPANDED);
        let (rows, pts) = refinement_points(frame, &item.bary, depth);
        let s = item.sphere;
        let goes = (0..8u8).any(|c| {
            let q = child_of_ten(&pts, c);
            let centroid = (q[0] + q[1] + q[2] + q[3]) * 0.25;
            centroid.distance_squared(s.center) <= s.radius * s.radius
                || self.point_in_swept(&s, centroid, rep)
        });
        goes.then_some((rows, pts))
    }

    /// Leaves `item`'s refinement of the last level to the fine pass: its tree's root against
    /// its sphere goes to the fine ring (once for a run of such leaves of one tree). `false`
    /// when the fine ring has no room for it and a descent (the refinement is then done now).
    fn defer(&mut self, item: &Pending, rep: &mut DrillReport) -> bool {
        let _ = self.swept_after(&item.sphere, rep);
        if self.swept_lag < DEFER_LAG {
            return false;
        }
        if let Some(b) = self.fine.back() {
            if b.tet == item.tet && b.index == 0 && b.sphere == item.sphere {
                return true;
            }
        }
        self.fine.free() > FINE_DESCENT
            && self
                .fine
                .push_back(Pending::root(item.tet, item.sphere, item.epoch))
    }

    fn erase(
        &mut self,
        h: &mut Hierarchy<'_>,
        mesh: &Mesh<'_>,
        item: Pending,
        pass: Pass,
        path: &Path,
        rep: &mut DrillReport,
    ) {
        // A leaf of a rate-limited material waits at the front of its ring until its region
        // has earned its volume; the step stops there.
        if self.spend(mesh, item.tet, path.depth) == Spend::Wait {
            let _ = match pass {
                Pass::Coarse => self.coarse.push_front(item),
                Pass::Fine => self.fine.push_front(item),
            };
            self.stalled = true;
            rep.waited = 1;
            return;
        }
        if let Ok(r) = h.erase_at(mesh, item.tet, path, item.node) {
            rep.work = rep.work.saturating_add(WorkCost::VISIT * r.work);
            rep.visits = rep.visits.saturating_add(r.work);
            rep.erased += 1;
            self.note_removed(item.tet, r.removed);
            self.crumbs.note(item.tet, item.index);
        }
    }

    #[allow(clippy::too_many_arguments)]
    fn queue_children(
        &mut self,
        h: &Hierarchy<'_>,
        frame: &RootFrame,
        item: Pending,
        depth: u8,
        pass: Pass,
        ten: Option<Ten>,
        rep: &mut DrillReport,
    ) {
        let ring = match pass {
            Pass::Coarse => &mut self.coarse,
            Pass::Fine => &mut self.fine,
        };
        if ring.free() < 8 {
            self.saturate(rep);
            return;
        }
        // The 8 children are contiguous: child `c` is `first + c`.
        let Some(first) = h.child(item.node, 0) else {
            return;
        };
        let epoch = epoch_of(h);
        // Points from the last level's child test were counted there.
        if ten.is_none() {
            rep.expanded += 1;
            rep.work = rep.work.saturating_add(WorkCost::EXPANDED);
        }
        let ring = match pass {
            Pass::Coarse => &mut self.coarse,
            Pass::Fine => &mut self.fine,
        };
        match self.parents.get_mut(depth as usize) {
            Some(slot) => {
                slot.tet = item.tet;
                slot.index = item.index;
                let rows = match ten {
                    Some((rows, pts)) => {
                        slot.pts = pts;
                        rows
                    }
                    None => {
                        let mut rows = [0; 10];
                        refinement_points_masked(
                            frame,
                            &item.bary,
                            depth,
                            ALL_POINTS,
                            &mut rows,
                            &mut slot.pts,
                        );
                        rows
                    }
                };
                queue_eight(ring, h, &item, first, epoch, (&rows, &slot.pts), rep);
            }
            None => {
                let (rows, pts) =
                    ten.unwrap_or_else(|| refinement_points(frame, &item.bary, depth));
                queue_eight(ring, h, &item, first, epoch, (&rows, &pts), rep);
            }
        }
    }
}

/// Queues the children of `item` (the eight nodes from `first`) that are not erased and
/// not wholly outside its sphere, at the front of `ring`, the last child first; `ten`: the
/// rows and points of `item`'s refinement.
///
/// # Bounded work
/// Constant: eight node look-ups and up to eight classifications.
fn queue_eight(
    ring: &mut Ring<'_>,
    h: &Hierarchy<'_>,
    item: &Pending,
    first: u32,
    epoch: u32,
    (rows, pts): (&[u64; 10], &[Vec3; 10]),
    rep: &mut DrillReport,
) {
    for c in (0..8u8).rev() {
        // A child wholly outside the sphere, or with nothing left to erase, would be
        // dropped when taken: it is not queued.
        let gone = h.node(first + c as u32).is_none_or(|n| n.all_erased());
        if gone || classify_charged(child_of_ten(pts, c), &item.sphere, rep) == Class::Outside {
            continue;
        }
        let next = Pending {
            tet: item.tet,
            index: item.index * 8 + 1 + c as u32,
            node: first + c as u32,
            bary: child_of_refinement(rows, pts, c).0,
            epoch,
            ..*item
        };
        let _ = ring.push_front(next);
    }
}
