//! Border points, weighted depths and the breadth-first propagation.

use glam::Vec3;

use super::crossing::{crossing, reuse, traced_crossing, Crossing};
use super::surface::SurfaceHit;
use super::{Method, NodeGraph};
use crate::collide::{Body, Collision};
use crate::ids::{NodeId, TetId};

/// Squared distances are clamped below by this before they are inverted, so a point exactly
/// on the surface gets a huge but finite weight.
const MIN_DIST2: f32 = 1e-30;

/// Per-node working state, stamped so nothing is cleared between calls.
#[derive(Clone, Copy, PartialEq, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C)]
pub struct NodeSlot {
    /// The call's stamp (a multiple of `STATES`) plus the node's state: one word tells
    /// whether the node belongs to this call and in which state, read before anything else.
    mark: u32,
    layer: u32,
    tet: TetId,
    depth: f32,
    dir: Vec3,
    /// The next node of the propagation's overflow chain (see [`Fifo`]).
    next: NodeId,
}

const COLLIDING: u32 = 1;
const QUEUED: u32 = 2;
const KNOWN: u32 = 3;
/// Queued, but every weight from its known neighbours underflowed: no depth.
const STRANDED: u32 = 4;
/// Stamps advance by this much a call, so a mark `stamp + state` keeps the state in its low
/// bits; `mark ^ stamp < STATES` tells a mark of this call.
const STATES: u32 = 8;

/// Scratch for [`penetration_depth`]: one slot per node of body A (its length bounds the node
/// ids handled) and a queue for the propagation. The queue holds the first nodes of the
/// breadth-first order; the rest are chained through their slots (one link per slot), so a
/// short queue changes neither the depths nor their order, and is only counted
/// ([`DepthReport::queue_full`]). Each call stamps the slots it uses, so nothing is cleared
/// between calls; once every 2^29 calls on one scratch the stamp wraps and every slot is
/// cleared.
#[derive(Debug)]
pub struct DepthScratch<'a> {
    slots: &'a mut [NodeSlot],
    queue: &'a mut [NodeId],
    crossings: &'a mut [Crossing],
    reuse: bool,
    stamp: u32,
}

impl<'a> DepthScratch<'a> {
    /// Scratch over caller storage.
    ///
    /// # Bounded work
    /// O(slots) to clear them once.
    pub fn new(slots: &'a mut [NodeSlot], queue: &'a mut [NodeId]) -> Self {
        Self::with_crossings(slots, queue, &mut [])
    }

    /// Scratch that also remembers, per directed edge of A's graph (one [`Crossing`] per
    /// adjacency entry: [`super::graph_sizes`]'s second number), the boundary face of B where
    /// the edge last left B. With `DepthScratch::set_reuse` on, a border edge first tries
    /// that face (one face test): when the edge still leaves B through it, that crossing is
    /// taken without a search ([`DepthReport::reused`]).
    ///
    /// A reused crossing is where the edge's line leaves B through that face, but it is not
    /// proven the *first* place the line leaves B: where a fold of B's surface has come
    /// between the border point and the remembered face since the last call, the search
    /// would have found the fold. So reuse trades the exact first crossing for one face test
    /// a border edge; it is off until `DepthScratch::set_reuse` turns it on, and the two
    /// methods agree bit for bit only without it. Edges beyond `crossings` never reuse.
    ///
    /// # Bounded work
    /// O(slots + crossings) to clear them once.
    pub fn with_crossings(
        slots: &'a mut [NodeSlot],
        queue: &'a mut [NodeId],
        crossings: &'a mut [Crossing],
    ) -> Self {
        slots.fill(NodeSlot::default());
        crossings.fill(Crossing::default());
        Self {
            slots,
            queue,
            crossings,
            reuse: false,
            stamp: 0,
        }
    }

    /// Turns the reuse of remembered crossings on or off ([`DepthScratch::with_crossings`];
    /// without crossing storage it changes nothing). Crossings are remembered either way, so
    /// turning reuse on later starts from the last call's faces.
    ///
    /// # Bounded work
    /// Constant.
    pub(crate) fn set_reuse(&mut self, on: bool) {
        self.reuse = on;
    }

    /// Forgets every remembered crossing (for a body that jumped, or a new scene).
    ///
    /// # Bounded work
    /// O(crossings).
    pub(crate) fn forget_crossings(&mut self) {
        self.crossings.fill(Crossing::default());
    }

    /// Starts a call: a stamp no slot holds.
    fn next_stamp(&mut self) {
        self.stamp = self.stamp.wrapping_add(STATES);
        if self.stamp == 0 {
            // Once every 2^29 calls: forget every old stamp.
            self.slots.fill(NodeSlot::default());
            self.stamp = STATES;
        }
    }

    /// The slots, the queue and the crossings (tests of the storage's carving).
    #[cfg(test)]
    pub(crate) fn storage(&self) -> (&[NodeSlot], &[NodeId], &[Crossing]) {
        (self.slots, self.queue, self.crossings)
    }

    /// Sets the stamp of the last call (tests of the stamp's wrap).
    #[cfg(test)]
    pub(super) fn set_stamp(&mut self, stamp: u32) {
        self.stamp = stamp & !(STATES - 1);
    }
}

/// The depth of one colliding node of A.
#[derive(Clone, Copy, PartialEq, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C)]
pub struct Penetration {
    /// Node of A.
    pub node: NodeId,
    /// The tet of B that holds it.
    pub tet: TetId,
    /// Consistent penetration depth (B's surface is this far along `dir`).
    pub depth: f32,
    /// Unit direction out of B (zero if the contributing normals cancel).
    pub dir: Vec3,
    /// 0 for a border point, k for a node k edges away from the nearest border point.
    pub layer: u32,
}

/// What one depth pass found.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default)]
pub struct DepthReport {
    /// Penetrations written to the output (in the order of the collisions).
    pub written: usize,
    /// Colliding nodes with at least one border edge.
    pub border_points: u32,
    /// Border edges examined.
    pub border_edges: u32,
    /// Border edges whose surface crossing was found.
    pub hits: u32,
    /// Of the `hits`, the crossings taken from the edge's remembered face without a search
    /// ([`DepthScratch::with_crossings`]).
    pub reused: u32,
    /// Border edges with no crossing found (walk too long or lost, box too large, no face).
    pub missed_edges: u32,
    /// Of the `hits`, the edges to a node missing from a partial list (`Listed::Partial`)
    /// whose line left B only past that node, followed on to where it leaves B.
    pub beyond: u32,
    /// Colliding nodes left without a depth: no border edge connects them to a depth source
    /// (a region fully inside). Never given an invented depth.
    pub unreached: u32,
    /// Collisions naming a node beyond the scratch slots (ignored).
    pub out_of_range: u32,
    /// `true` when the propagation queue filled up: the rest of the breadth-first order went
    /// through the chain in the slots (the same depths, in the same order).
    pub queue_full: bool,
    /// `true` when the output filled up (later penetrations not written).
    pub out_full: bool,
    /// Tets crossed by traced walks, or candidate faces tested by the hashed search (plus the
    /// tets of its walks past unlisted nodes, `Listed::Partial`), plus one per remembered
    /// face tested ([`DepthScratch::with_crossings`]).
    pub work: u32,
}

/// The collisions handed to [`penetration_depth_of`]: all of A's nodes inside B, or only some.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Listed<'c> {
    /// Every node of A inside B is listed (the collision buffer did not fill).
    All(&'c [Collision]),
    /// The collision buffer was full, so nodes of A inside B may be missing from `list`.
    ///
    /// An edge from a listed node `p` to an unlisted node `q` is a border edge as always.
    /// When its line leaves B only past `q` (so `q` is inside B as well), the line is followed
    /// on from `p` to where it leaves B, and that crossing counts like any other. Without this
    /// a listed node would lose the border edges that give it its depth as its neighbours
    /// enter B unlisted; with it, its depth changes continuously (at the moment `q` crosses
    /// B's surface the crossing is `q` itself, on either rule).
    Partial {
        /// The collisions that fitted.
        list: &'c [Collision],
        /// Most tets a walk past an unlisted node may cross ([`Method::Hashed`]; with
        /// [`Method::Traced`] its own walk, bounded by its own `max_steps`, serves, so the two
        /// agree when the bounds are the same).
        max_steps: u32,
    },
}

impl<'c> Listed<'c> {
    /// The collisions.
    pub(crate) fn list(&self) -> &'c [Collision] {
        match *self {
            Self::All(l) | Self::Partial { list: l, .. } => l,
        }
    }
}

/// Computes the consistent penetration depth of A's colliding nodes in B.
///
/// `a_positions` and `graph` are body A (the penetrating nodes and their edges), `b` is the
/// penetrated body, `collisions` the `(node of A, tet of B)` pairs (one per node; all of A's
/// nodes inside B: see `penetration_depth_of` for a list that may be incomplete). Writes one
/// [`Penetration`] per colliding node that received a depth, in the order of `collisions`.
///
/// # Bounded work
/// O(C * v * f) for C collisions, v the largest node valence and f the cost of one surface
/// search ([`Method::Traced`]: `max_steps` tets; [`Method::Hashed`]: `max_cells` cells plus
/// the faces met), plus O(C * v) for the propagation. Every node of A reached from a depth
/// source gets its depth whatever the queue's length: the breadth-first order goes on in a
/// chain through the slots when the queue is full (`queue_full` tells). At most `out.len()`
/// penetrations are written (`out_full`). Once every 2^29 calls on one scratch, O(slots) more
/// to clear them when the stamp wraps ([`DepthScratch`]).
pub fn penetration_depth(
    a_positions: &[Vec3],
    graph: &NodeGraph<'_>,
    b: &Body<'_, '_>,
    collisions: &[Collision],
    method: &Method<'_>,
    scratch: &mut DepthScratch<'_>,
    out: &mut [Penetration],
) -> DepthReport {
    penetration_depth_of(
        a_positions,
        graph,
        b,
        Listed::All(collisions),
        method,
        scratch,
        out,
    )
}

/// [`penetration_depth`] for a collision list that may be incomplete ([`Listed::Partial`]:
/// edges to unlisted nodes inside B are followed past them to B's surface).
///
/// # Bounded work
/// As [`penetration_depth`], with f also covering one walk of at most `max_steps` tets per
/// border edge for [`Listed::Partial`] with [`Method::Hashed`], and, with reuse on
/// ([`DepthScratch::with_crossings`]), one face test per border edge before its search (the
/// search skipped when the test holds).
pub(crate) fn penetration_depth_of(
    a_positions: &[Vec3],
    graph: &NodeGraph<'_>,
    b: &Body<'_, '_>,
    listed: Listed<'_>,
    method: &Method<'_>,
    scratch: &mut DepthScratch<'_>,
    out: &mut [Penetration],
) -> DepthReport {
    let collisions = listed.list();
    let past = match listed {
        Listed::All(_) => None,
        Listed::Partial { max_steps, .. } => Some(max_steps),
    };
    let mut r = DepthReport::default();
    scratch.next_stamp();
    let stamp = scratch.stamp;
    let reuse_on = scratch.reuse;
    let DepthScratch {
        slots,
        queue,
        crossings,
        ..
    } = scratch;
    let (slots, queue, crossings) = (&mut **slots, &mut **queue, &mut **crossings);

    // Mark colliding nodes (depth, direction and link are written before they are read: when
    // the node becomes known, when it is chained).
    r.out_of_range = mark_colliding(slots, collisions, stamp + COLLIDING);

    // Border points: weighted surface crossings of their border edges (one copy of the loop
    // a method, so neither pays for the other's set-up).
    let mut fifo = Fifo::new();
    match *method {
        Method::Traced { max_steps } => {
            let mut edges = BorderEdges {
                a_positions,
                b,
                reuse: reuse_on,
                crossings,
                search: move |tet, p, q, r: &mut DepthReport| {
                    traced_crossing(b, tet, p, q, max_steps, past, r)
                },
            };
            border_points(
                &mut edges, graph, collisions, slots, queue, &mut fifo, stamp, &mut r,
            );
        }
        Method::Hashed { .. } => {
            let mut edges = BorderEdges {
                a_positions,
                b,
                reuse: reuse_on,
                crossings,
                search: move |tet, p, q, r: &mut DepthReport| {
                    crossing(b, tet, p, q, method, past, r)
                },
            };
            border_points(
                &mut edges, graph, collisions, slots, queue, &mut fifo, stamp, &mut r,
            );
        }
    }

    propagate(a_positions, graph, slots, queue, fifo, stamp, &mut r);

    // Output in collision order (every collision in range carries this call's mark).
    let known = stamp + KNOWN;
    for c in collisions {
        let Some(s) = slots.get(c.node.idx()) else {
            continue;
        };
        if s.mark != known {
            r.unreached += 1;
            continue;
        }
        let Some(o) = out.get_mut(r.written) else {
            r.out_full = true;
            continue;
        };
        *o = Penetration {
            node: c.node,
            tet: s.tet,
            depth: s.depth,
            dir: s.dir,
            layer: s.layer,
        };
        r.written += 1;
    }
    r
}

/// Marks the collisions' nodes colliding (layer 0, their tet); returns how many are beyond
/// the slots.
#[inline(never)]
fn mark_colliding(slots: &mut [NodeSlot], collisions: &[Collision], colliding: u32) -> u32 {
    let mut out_of_range = 0;
    for c in collisions {
        match slots.get_mut(c.node.idx()) {
            Some(s) => {
                s.mark = colliding;
                s.layer = 0;
                s.tet = c.tet;
            }
            None => out_of_range += 1,
        }
    }
    out_of_range
}

/// How many of `nbs`, from the first, carry this call's mark (`stamp`).
#[inline(always)]
fn marked_run(slots: &[NodeSlot], nbs: &[NodeId], stamp: u32) -> usize {
    let marked = |q: &NodeId| slots.get(q.idx()).is_some_and(|s| s.mark ^ stamp < STATES);
    // Four at a time while all four are marked (rows are mostly marked), then one by one.
    let mut quads = nbs.chunks_exact(4);
    let mut k = 0;
    for c in &mut quads {
        for (i, q) in c.iter().enumerate() {
            if !marked(q) {
                return k + i;
            }
        }
        k += 4;
    }
    let rest = quads.remainder();
    k + rest.iter().position(|q| !marked(q)).unwrap_or(rest.len())
}

/// Gives every colliding node with a border edge that found B's surface its depth and
/// direction (known, layer 0) and queues it, in the order of `collisions`. Nodes whose
/// neighbours all collide are passed over in one scan of their row.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn border_points<S>(
    edges: &mut BorderEdges<'_, '_, '_, S>,
    graph: &NodeGraph<'_>,
    collisions: &[Collision],
    slots: &mut [NodeSlot],
    queue: &mut [NodeId],
    fifo: &mut Fifo,
    stamp: u32,
    r: &mut DepthReport,
) where
    S: FnMut(TetId, Vec3, Vec3, &mut DepthReport) -> Option<SurfaceHit>,
{
    for c in collisions {
        let (row, nbs) = graph.row(c.node);
        // Edges whose both ends collide are no border edges.
        let k = marked_run(slots, nbs, stamp);
        if k < nbs.len() {
            border_point(edges, c, row, nbs, k, slots, queue, fifo, stamp, r);
        }
    }
}

/// [`border_points`] for the collision `c`, whose row `nbs` (adjacency entries from `row`)
/// has its first neighbour that does not collide at `k`.
#[allow(clippy::too_many_arguments)]
#[inline(never)]
fn border_point<S>(
    edges: &mut BorderEdges<'_, '_, '_, S>,
    c: &Collision,
    row: usize,
    nbs: &[NodeId],
    mut k: usize,
    slots: &mut [NodeSlot],
    queue: &mut [NodeId],
    fifo: &mut Fifo,
    stamp: u32,
    r: &mut DepthReport,
) where
    S: FnMut(TetId, Vec3, Vec3, &mut DepthReport) -> Option<SurfaceHit>,
{
    let i = c.node.idx();
    // Every collision in range carries this call's mark since the marking.
    let Some(&p) = edges.a_positions.get(i) else {
        return;
    };
    if i >= slots.len() {
        return;
    }
    let (mut sw, mut sd, mut sn) = (0.0f32, 0.0f32, Vec3::ZERO);
    let mut border = false;
    while let Some(&qn) = nbs.get(k) {
        match edges.weigh(c.tet, p, qn, row + k, r) {
            Edge::Unplaced => {}
            Edge::Missed => border = true,
            Edge::Hit(w, wd, wn) => {
                border = true;
                sw += w;
                sd += wd;
                sn += wn;
            }
        }
        k += 1;
        k += marked_run(slots, nbs.get(k..).unwrap_or(&[]), stamp);
    }
    if border {
        r.border_points += 1;
    }
    if sw > 0.0 {
        let Some(slot) = slots.get_mut(i) else {
            return;
        };
        slot.mark = stamp + KNOWN;
        slot.depth = sd / sw;
        slot.dir = sn.normalize_or_zero();
        fifo.push(queue, slots, c.node, r);
    }
}

/// What a border edge found: its node outside has no position, no crossing was found, or the
/// crossing's weight `w` with `w * (x - p).n` and `n * w`.
enum Edge {
    Unplaced,
    Missed,
    Hit(f32, f32, Vec3),
}

/// What the border edges of body A need to find their crossings with B's surface; `search`
/// is the method's search.
struct BorderEdges<'s, 'm, 'a, S> {
    a_positions: &'s [Vec3],
    b: &'s Body<'m, 'a>,
    reuse: bool,
    crossings: &'s mut [Crossing],
    search: S,
}

impl<S> BorderEdges<'_, '_, '_, S>
where
    S: FnMut(TetId, Vec3, Vec3, &mut DepthReport) -> Option<SurfaceHit>,
{
    /// The border edge from `p` (in tet `tet` of B) to the node `qn` that does not collide,
    /// adjacency entry `entry`: its crossing, first through the remembered face when reuse is
    /// on, else searched; the entry then remembers the crossing's face.
    #[inline(always)]
    fn weigh(
        &mut self,
        tet: TetId,
        p: Vec3,
        qn: NodeId,
        entry: usize,
        r: &mut DepthReport,
    ) -> Edge {
        let Some(&q) = self.a_positions.get(qn.idx()) else {
            return Edge::Unplaced;
        };
        r.border_edges += 1;
        let memo = self.crossings.get_mut(entry);
        let again = match (&memo, self.reuse) {
            (Some(m), true) => reuse(self.b, m.face(), p, q, r),
            _ => None,
        };
        let found = match again {
            Some(h) => Some(h),
            None => (self.search)(tet, p, q, r),
        };
        if let Some(m) = memo {
            *m = found.map_or(Crossing::default(), |h| Crossing::of(h.face));
        }
        let Some(h) = found else {
            r.missed_edges += 1;
            return Edge::Missed;
        };
        r.hits += 1;
        let v = h.point - p;
        let w = 1.0 / v.length_squared().max(MIN_DIST2);
        Edge::Hit(w, w * v.dot(h.normal), h.normal * w)
    }
}

/// Breadth-first propagation, layer by layer, from the known border points in `fifo`. A border
/// point queues its colliding neighbours; a queued node takes its value from its known
/// neighbours of lower layers and queues its colliding neighbours in the same pass over its
/// neighbours (a neighbour is either known or colliding, never both, so the sums and the
/// queue order are those of two separate passes).
#[inline(never)]
fn propagate(
    a_positions: &[Vec3],
    graph: &NodeGraph<'_>,
    slots: &mut [NodeSlot],
    queue: &mut [NodeId],
    mut fifo: Fifo,
    stamp: u32,
    r: &mut DepthReport,
) {
    let (colliding, queued, known) = (stamp + COLLIDING, stamp + QUEUED, stamp + KNOWN);
    while let Some(u) = fifo.pop(queue, slots) {
        let Some(&pu) = a_positions.get(u.idx()) else {
            continue;
        };
        let Some(su) = slots.get(u.idx()) else {
            continue;
        };
        let (su_mark, su_layer) = (su.mark, su.layer);
        if su_mark ^ stamp >= STATES {
            continue; // cannot happen: only marked nodes are queued
        }
        let layer = su_layer + 1;
        let nbs = graph.neighbours(u);
        if su_mark != queued {
            for &j in nbs {
                let Some(sj) = slots.get_mut(j.idx()) else {
                    continue;
                };
                if sj.mark == colliding {
                    sj.mark = queued;
                    sj.layer = layer;
                    fifo.push(queue, slots, j, r);
                }
            }
            continue;
        }
        let (mut sm, mut sd, mut sr) = (0.0f32, 0.0f32, Vec3::ZERO);
        for &j in nbs {
            let Some(sj) = slots.get_mut(j.idx()) else {
                continue;
            };
            if sj.mark == known {
                if sj.layer < su_layer {
                    let (dj, rj) = (sj.depth, sj.dir);
                    // A known node has a position (it was a border point or popped).
                    let Some(&pj) = a_positions.get(j.idx()) else {
                        continue;
                    };
                    let v = pj - pu;
                    let mu = 1.0 / v.length_squared().max(MIN_DIST2);
                    sm += mu;
                    sd += mu * (v.dot(rj) + dj);
                    sr += rj * mu;
                }
            } else if sj.mark == colliding {
                sj.mark = queued;
                sj.layer = layer;
                fifo.push(queue, slots, j, r);
            }
        }
        let Some(slot) = slots.get_mut(u.idx()) else {
            continue;
        };
        if sm > 0.0 {
            slot.mark = known;
            slot.depth = sd / sm;
            slot.dir = sr.normalize_or_zero();
        } else {
            // Only for positions so far apart that every weight underflows (it was queued by
            // a known neighbour): no depth, as for an unreached node, and never queued again
            // (each node is queued at most once, so the work stays bounded).
            slot.mark = stamp + STRANDED;
        }
    }
}

/// The breadth-first order: the caller's queue holds its first `queue.len()` nodes, the rest
/// are chained through their slots (`NodeSlot::next`) in the order they came. Popping reads the
/// queue and then the chain, so the order is that of an unbounded queue.
#[derive(Clone, Copy, Debug)]
struct Fifo {
    pushed: usize,
    popped: usize,
    /// Last node chained (valid while `cursor` is some).
    tail: NodeId,
    /// Next chained node to pop (`NONE`: no chained node waits).
    cursor: NodeId,
}

impl Fifo {
    fn new() -> Self {
        Self {
            pushed: 0,
            popped: 0,
            tail: NodeId::NONE,
            cursor: NodeId::NONE,
        }
    }

    /// Appends `v` (a node with a slot).
    #[inline(always)]
    fn push(
        &mut self,
        queue: &mut [NodeId],
        slots: &mut [NodeSlot],
        v: NodeId,
        r: &mut DepthReport,
    ) {
        if let Some(e) = queue.get_mut(self.pushed) {
            *e = v;
            self.pushed += 1;
        } else {
            self.chain(slots, v, r);
        }
    }

    /// Appends `v` (a node with a slot) to the chain: the queue is full.
    #[inline(never)]
    fn chain(&mut self, slots: &mut [NodeSlot], v: NodeId, r: &mut DepthReport) {
        r.queue_full = true;
        let Some(s) = slots.get_mut(v.idx()) else {
            return; // cannot happen: only nodes with a slot are pushed
        };
        s.next = NodeId::NONE;
        if self.cursor.is_none() {
            self.cursor = v;
        } else if let Some(t) = slots.get_mut(self.tail.idx()) {
            t.next = v;
        }
        self.tail = v;
        self.pushed += 1;
    }

    /// The oldest node not popped yet.
    fn pop(&mut self, queue: &[NodeId], slots: &[NodeSlot]) -> Option<NodeId> {
        if self.popped >= self.pushed {
            return None;
        }
        self.popped += 1;
        if let Some(&v) = queue.get(self.popped - 1) {
            return Some(v);
        }
        let v = self.cursor;
        self.cursor = slots.get(v.idx())?.next;
        Some(v)
    }
}
