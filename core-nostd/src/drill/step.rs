//! The budgeted drill step: refine the nodes that cross a sample sphere, erase the frontier
//! nodes inside it, carry what does not fit to the next tick.

use glam::Vec3;

use super::sphere::{classify, Class, Sphere};
use crate::geom::tri_area;
use crate::hierarchy::{child_packed, Hierarchy, HierarchyError, Path, RootFrame, ROOT_PACKED};
use crate::ids::TetId;
use crate::mesh::template::FACE_VERTS;
use crate::mesh::Mesh;

/// Parameters of the drill step.
#[derive(Clone, Copy, PartialEq, Debug)]
pub struct DrillParams {
    /// Deepest refinement level (clamped to [`crate::hierarchy::MAX_DEPTH`]).
    pub max_depth: u8,
    /// A node whose smallest face area is below this is not refined further.
    pub min_area: f32,
    /// Work units per tick: one per node visited by the step or by an NTree visit, eight per
    /// node created. The step stops starting operations once it is spent.
    pub budget: u32,
}

impl Default for DrillParams {
    fn default() -> Self {
        Self {
            max_depth: 6,
            min_area: 0.0,
            budget: 4000,
        }
    }
}

/// One unit of pending work: a node of a tree, against the sphere it was queued for, with the
/// node's integer barycentric coordinates in its root (so processing it costs no walk from the
/// root). 64 bytes (pinned at compile time).
#[derive(Clone, Copy, PartialEq, Debug, Default)]
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
    /// The node's corners as integer barycentric coordinates of its root's, scaled by
    /// `2^depth`: one `u64` per corner holding four 16-bit weights (each at most
    /// `2^MAX_DEPTH` = 1024, so a child's row is one `u64` addition of two parent rows).
    bary: [u64; 4],
    /// [`epoch_of`] the hierarchy when the item was queued: while [`Hierarchy::reclaimed`]
    /// still equals it, no block has been taken back since and `node` is still the node it
    /// was; otherwise the node is looked up again by `(tet, index)`. Fills what was padding.
    epoch: u32,
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
            bary: ROOT_PACKED,
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
    /// Work items left for the next tick.
    pub pending: u32,
    /// Capacity saturations this step (arena full, pending queue full).
    pub saturations: u32,
}

/// Spheres remembered to skip re-queueing an unchanged sphere whose work is already queued.
const MEMO: usize = 8;

/// The most recently queued spheres the drill remembers as the swept volume (see
/// [`Drill::step`]): a burr queued every quarter radius is covered on each side by the next
/// four positions, so eight spheres hold the whole neighbourhood of one.
pub const SWEPT: usize = 8;

/// The drill: a pending-work deque in caller storage and counters.
#[derive(Debug)]
pub struct Drill<'a> {
    queue: &'a mut [Pending],
    head: usize,
    len: usize,
    memo: [Option<Sphere>; MEMO],
    /// The last [`SWEPT`] spheres queued (a ring; `swept_len` of them valid).
    swept: [Sphere; SWEPT],
    swept_next: usize,
    swept_len: usize,
    /// The root frame of the last tet processed (items come tree by tree).
    frame: Option<(TetId, RootFrame)>,
    retry: bool,
    saturations: u32,
}

impl<'a> Drill<'a> {
    /// A drill whose pending deque is `queue` (its length is the capacity).
    ///
    /// # Bounded work
    /// O(1).
    pub fn new(queue: &'a mut [Pending]) -> Self {
        Self {
            queue,
            head: 0,
            len: 0,
            memo: [None; MEMO],
            swept: [Sphere::default(); SWEPT],
            swept_next: 0,
            swept_len: 0,
            frame: None,
            retry: false,
            saturations: 0,
        }
    }

    /// Work items waiting for the next tick.
    #[inline]
    pub fn pending(&self) -> usize {
        self.len
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
        self.head = 0;
        self.len = 0;
        self.memo = [None; MEMO];
        self.swept_len = 0;
        self.swept_next = 0;
    }

    /// Remembers `s` as part of the swept volume (the oldest of [`SWEPT`] is forgotten).
    fn remember(&mut self, s: Sphere) {
        if let Some(slot) = self.swept.get_mut(self.swept_next) {
            *slot = s;
        }
        self.swept_next = (self.swept_next + 1) % SWEPT;
        self.swept_len = (self.swept_len + 1).min(SWEPT);
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

    /// `true` when all four corners `p` lie inside one of the remembered spheres.
    fn inside_swept(&self, p: &[Vec3; 4]) -> bool {
        self.swept.iter().take(self.swept_len).any(|s| {
            let r2 = s.radius * s.radius;
            p.iter().all(|q| q.distance_squared(s.center) <= r2)
        })
    }

    /// `true` when `x` lies inside one of the remembered spheres.
    fn point_in_swept(&self, x: Vec3) -> bool {
        self.swept
            .iter()
            .take(self.swept_len)
            .any(|s| x.distance_squared(s.center) <= s.radius * s.radius)
    }

    fn push_back(&mut self, p: Pending) -> bool {
        let cap = self.queue.len();
        if self.len >= cap {
            return false;
        }
        let at = (self.head + self.len) % cap;
        if let Some(slot) = self.queue.get_mut(at) {
            *slot = p;
            self.len += 1;
            true
        } else {
            false
        }
    }

    fn push_front(&mut self, p: Pending) -> bool {
        let cap = self.queue.len();
        if self.len >= cap {
            return false;
        }
        let at = (self.head + cap - 1) % cap;
        if let Some(slot) = self.queue.get_mut(at) {
            *slot = p;
            self.head = at;
            self.len += 1;
            true
        } else {
            false
        }
    }

    fn pop_front(&mut self) -> Option<Pending> {
        if self.len == 0 {
            return None;
        }
        let p = self.queue.get(self.head).copied()?;
        self.head = (self.head + 1) % self.queue.len().max(1);
        self.len -= 1;
        Some(p)
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
    /// empty). Then work
    /// items are taken oldest first (each node's children go to the front, so one sphere's
    /// subtree is finished depth first) until the budget is spent:
    /// - a node outside the sphere, or erased, is dropped;
    /// - an inner node passes its eight children on;
    /// - a leaf entirely inside the sphere (all four corners), or inside one of the last
    ///   [`SWEPT`] spheres queued (the swept path, which erases it anyway when its own work
    ///   arrives), is erased at once: only the boundary of the swept volume is refined, not
    ///   the shell of every sphere along it;
    /// - a leaf crossing the sphere is refined when it is above `max_depth` and its smallest
    ///   face is at least `min_area`, and its children are queued;
    /// - a crossing leaf at `max_depth` or below `min_area` is erased iff its centroid is
    ///   inside the sphere or one of the remembered swept spheres. This is the erosion
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
    /// `budget` units are spent; the last one may overrun it by its own cost: a refinement
    /// is 8 units plus 16 NTree visits, an erasure 4 NTree visits, each O(depth) plus the
    /// instantiated nodes across one face.
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
        let removed0 = h.removed_volume();
        let sat0 = h.saturations();
        if self.retry && self.len == 0 {
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
                if !self.push_back(Pending::root(t, *s, epoch_of(h))) {
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
        while rep.work < params.budget {
            let Some(item) = self.pop_front() else { break };
            rep.work += 1;
            self.process(h, mesh, item, max_depth, params.min_area, &mut rep);
        }
        rep.pending = self.len as u32;
        rep.removed_volume = h.removed_volume() - removed0;
        rep.saturations += h.saturations() - sat0;
        rep
    }

    fn process(
        &mut self,
        h: &mut Hierarchy<'_>,
        mesh: &Mesh<'_>,
        item: Pending,
        max_depth: u8,
        min_area: f32,
        rep: &mut DrillReport,
    ) {
        // A reference stays valid until the arena takes back the block holding it (only
        // blocks of erased leaves are taken back, once the fresh ones are used up). When a
        // block has been taken back since the item was queued, the reference may name a node
        // of a reused block: the item is looked up again by its tree index (a collapsed
        // subtree's nodes answer `None`; they were all erased, so the item had nothing left
        // to do).
        if item.epoch != h.reclaimed() && h.find(item.tet, item.index) != Some(item.node) {
            return;
        }
        let Some(node) = h.node(item.node) else {
            return;
        };
        if node.erased() {
            return;
        }
        let Some(depth) = Path::depth_of(item.index) else {
            return;
        };
        let Some(frame) = self.frame(mesh, item.tet) else {
            return;
        };
        let p = frame.positions_packed(&item.bary, depth);
        let class = classify(p, &item.sphere);
        if class == Class::Outside {
            return;
        }
        if !node.is_leaf() {
            self.queue_children(h, item, rep);
            return;
        }
        // Inside this sphere, or inside another sphere of the swept path (which erases it
        // anyway when its own work arrives): erased at once, never refined.
        let Some(path) = Path::of_index(item.index) else {
            return;
        };
        if class == Class::Inside || self.inside_swept(&p) {
            self.erase(h, mesh, item, &path, rep);
            return;
        }
        let min_face = FACE_VERTS
            .iter()
            .map(|f| tri_area(p[f[0] as usize], p[f[1] as usize], p[f[2] as usize]))
            .fold(f32::INFINITY, f32::min);
        if path.depth < max_depth && min_face >= min_area {
            match h.refine_at(mesh, item.tet, &path, item.node) {
                Ok(r) => {
                    rep.work = rep.work.saturating_add(r.work + 8 * r.created);
                    rep.created += r.created;
                    self.queue_children(h, item, rep);
                    return;
                }
                Err(HierarchyError::Full) => {
                    // Counted by the hierarchy. The leaf stays: erasing a coarse leaf by its
                    // centroid would move the surface past the burr in one tick (a force
                    // jump); kept, it still bounds the material and the burr feels it.
                    // Not retried here: the arena only gets blocks back when more material
                    // is erased; a later sphere's work reaches the leaf again.
                    return;
                }
                Err(_) => return,
            }
        }
        let centroid = (p[0] + p[1] + p[2] + p[3]) * 0.25;
        let r = item.sphere.radius;
        if centroid.distance_squared(item.sphere.center) <= r * r || self.point_in_swept(centroid) {
            self.erase(h, mesh, item, &path, rep);
        }
    }

    fn erase(
        &mut self,
        h: &mut Hierarchy<'_>,
        mesh: &Mesh<'_>,
        item: Pending,
        path: &Path,
        rep: &mut DrillReport,
    ) {
        if let Ok(r) = h.erase_at(mesh, item.tet, path, item.node) {
            rep.work = rep.work.saturating_add(r.work);
            rep.erased += 1;
        }
    }

    fn queue_children(&mut self, h: &Hierarchy<'_>, item: Pending, rep: &mut DrillReport) {
        if self.queue.len() - self.len < 8 {
            self.saturate(rep);
            return;
        }
        // The 8 children are contiguous: child `c` is `first + c`.
        let Some(first) = h.child(item.node, 0) else {
            return;
        };
        let epoch = epoch_of(h);
        for c in (0..8u8).rev() {
            let next = Pending {
                tet: item.tet,
                index: item.index * 8 + 1 + c as u32,
                node: first + c as u32,
                bary: child_packed(&item.bary, c),
                epoch,
                ..item
            };
            self.push_front(next);
        }
    }
}
