//! The budgeted drill step: refine the nodes that cross a sample sphere, erase the frontier
//! nodes inside it, carry what does not fit to the next tick.

use super::sphere::{classify, Class, Sphere};
use crate::geom::tri_area;
use crate::hierarchy::{node_positions, Hierarchy, HierarchyError, Path};
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

/// One unit of pending work: a node of a tree, against the sphere it was queued for. 28 bytes.
#[derive(Clone, Copy, PartialEq, Debug, Default)]
pub struct Pending {
    /// The coarse tet.
    pub tet: TetId,
    /// Tree index.
    pub index: u32,
    /// Node reference.
    pub node: u32,
    /// The sphere, as it was when the work was queued (so the removed shape converges to the
    /// swept volume even when the work finishes ticks later).
    pub sphere: Sphere,
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

/// The drill: a pending-work deque in caller storage and counters.
#[derive(Debug)]
pub struct Drill<'a> {
    queue: &'a mut [Pending],
    head: usize,
    len: usize,
    memo: [Option<Sphere>; MEMO],
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
    /// - a leaf entirely inside the sphere (all four corners) is erased at once;
    /// - a leaf crossing the sphere is refined when it is above `max_depth` and its smallest
    ///   face is at least `min_area`, and its children are queued;
    /// - a crossing leaf that cannot be refined is erased iff its centroid is inside the
    ///   sphere. This is the erosion criterion: the misclassified volume lies within one leaf
    ///   of the sphere's surface and is unbiased to first order, so the removed volume
    ///   converges to the swept volume as the leaves shrink.
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
    /// Arena full: the leaf is not refined (it is erased or kept by the centroid rule); the
    /// hierarchy counts it. Pending deque full: the new item or the children are dropped and
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
            let mut all = true;
            for &t in candidates {
                if t.idx() >= h.tet_count() {
                    continue;
                }
                let item = Pending {
                    tet: t,
                    index: 0,
                    node: t.0,
                    sphere: *s,
                };
                if !self.push_back(item) {
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
        let Some(node) = h.node(item.node) else {
            return;
        };
        if node.erased() {
            return;
        }
        let Some(path) = Path::of_index(item.index) else {
            return;
        };
        let p = node_positions(mesh, item.tet, &path);
        let class = classify(p, &item.sphere);
        if class == Class::Outside {
            return;
        }
        if !node.is_leaf() {
            self.queue_children(h, item, rep);
            return;
        }
        if class == Class::Inside {
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
                    // Counted by the hierarchy; fall back to the centroid rule (retrying
                    // would not help: nodes are never freed).
                }
                Err(_) => return,
            }
        }
        let centroid = (p[0] + p[1] + p[2] + p[3]) * 0.25;
        let r = item.sphere.radius;
        if centroid.distance_squared(item.sphere.center) <= r * r {
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
        for c in (0..8u8).rev() {
            let Some(child) = h.child(item.node, c) else {
                return;
            };
            let next = Pending {
                tet: item.tet,
                index: item.index * 8 + 1 + c as u32,
                node: child,
                ..item
            };
            self.push_front(next);
        }
    }
}
