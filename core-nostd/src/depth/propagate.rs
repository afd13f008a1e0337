//! Border points, weighted depths and the breadth-first propagation.

use glam::Vec3;

use super::hashed::hashed_hit;
use super::traced::trace_to_surface;
use super::{Method, NodeGraph};
use crate::collide::{Body, Collision};
use crate::ids::{NodeId, TetId};

/// Squared distances are clamped below by this before they are inverted, so a point exactly
/// on the surface gets a huge but finite weight.
const MIN_DIST2: f32 = 1e-30;

/// Per-node working state, stamped so nothing is cleared between calls.
#[derive(Clone, Copy, PartialEq, Debug, Default)]
pub struct NodeSlot {
    stamp: u32,
    state: u8,
    layer: u32,
    tet: TetId,
    depth: f32,
    dir: Vec3,
}

const COLLIDING: u8 = 1;
const QUEUED: u8 = 2;
const KNOWN: u8 = 3;

/// Scratch for [`penetration_depth`]: one slot per node of body A (its length bounds the node
/// ids handled) and a queue for the propagation (its length bounds the nodes that get a depth).
#[derive(Debug)]
pub struct DepthScratch<'a> {
    slots: &'a mut [NodeSlot],
    queue: &'a mut [NodeId],
    stamp: u32,
}

impl<'a> DepthScratch<'a> {
    /// Scratch over caller storage.
    ///
    /// # Bounded work
    /// O(slots) to clear them once.
    pub fn new(slots: &'a mut [NodeSlot], queue: &'a mut [NodeId]) -> Self {
        slots.fill(NodeSlot::default());
        Self {
            slots,
            queue,
            stamp: 0,
        }
    }

    fn next_stamp(&mut self) {
        self.stamp = self.stamp.wrapping_add(1);
        if self.stamp == 0 {
            // Once every 2^32 calls: forget every old stamp.
            self.slots.fill(NodeSlot::default());
            self.stamp = 1;
        }
    }

    fn slot(&self, n: NodeId) -> Option<&NodeSlot> {
        self.slots.get(n.idx()).filter(|s| s.stamp == self.stamp)
    }
}

/// The depth of one colliding node of A.
#[derive(Clone, Copy, PartialEq, Debug, Default)]
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
    /// Border edges with no crossing found (walk too long or lost, box too large, no face).
    pub missed_edges: u32,
    /// Colliding nodes left without a depth: no border edge connects them to a depth source
    /// (a region fully inside), or the queue was full. Never given an invented depth.
    pub unreached: u32,
    /// Collisions naming a node beyond the scratch slots (ignored).
    pub out_of_range: u32,
    /// `true` when the propagation queue filled up.
    pub queue_full: bool,
    /// `true` when the output filled up (later penetrations not written).
    pub out_full: bool,
    /// Tets crossed by traced walks, or candidate faces tested by the hashed search.
    pub work: u32,
}

/// Computes the consistent penetration depth of A's colliding nodes in B.
///
/// `a_positions` and `graph` are body A (the penetrating nodes and their edges), `b` is the
/// penetrated body, `collisions` the `(node of A, tet of B)` pairs (one per node). Writes one
/// [`Penetration`] per colliding node that received a depth, in the order of `collisions`.
///
/// # Bounded work
/// O(C * v * f) for C collisions, v the largest node valence and f the cost of one surface
/// search ([`Method::Traced`]: `max_steps` tets; [`Method::Hashed`]: `max_cells` cells plus
/// the faces met), plus O(C * v) for the propagation. At most `scratch.queue.len()` nodes get
/// a depth; when the queue is full the rest are counted as `unreached` and `queue_full` is set.
/// At most `out.len()` penetrations are written (`out_full`).
pub fn penetration_depth(
    a_positions: &[Vec3],
    graph: &NodeGraph<'_>,
    b: &Body<'_, '_>,
    collisions: &[Collision],
    method: &Method<'_>,
    scratch: &mut DepthScratch<'_>,
    out: &mut [Penetration],
) -> DepthReport {
    let mut r = DepthReport::default();
    scratch.next_stamp();
    let stamp = scratch.stamp;

    // Mark colliding nodes.
    for c in collisions {
        match scratch.slots.get_mut(c.node.idx()) {
            Some(s) => {
                *s = NodeSlot {
                    stamp,
                    state: COLLIDING,
                    layer: 0,
                    tet: c.tet,
                    ..NodeSlot::default()
                }
            }
            None => r.out_of_range += 1,
        }
    }

    // Border points: weighted surface crossings of their border edges.
    let mut queued = 0usize;
    for c in collisions {
        let Some(&p) = a_positions.get(c.node.idx()) else {
            continue;
        };
        if scratch.slot(c.node).is_none() {
            continue;
        }
        let (mut sw, mut sd, mut sn) = (0.0f32, 0.0f32, Vec3::ZERO);
        let mut border = false;
        for &qn in graph.neighbours(c.node) {
            if scratch.slot(qn).is_some() {
                continue; // both ends collide: not a border edge
            }
            let Some(&q) = a_positions.get(qn.idx()) else {
                continue;
            };
            border = true;
            r.border_edges += 1;
            let hit = match method {
                Method::Traced { max_steps } => {
                    trace_to_surface(b, c.tet, p, q, *max_steps, &mut r.work)
                }
                Method::Hashed {
                    faces,
                    world_to_hash,
                    max_cells,
                } => hashed_hit(faces, world_to_hash, b, p, q, *max_cells, &mut r.work),
            };
            let Some(h) = hit else {
                r.missed_edges += 1;
                continue;
            };
            r.hits += 1;
            let v = h.point - p;
            let w = 1.0 / v.length_squared().max(MIN_DIST2);
            sw += w;
            sd += w * v.dot(h.normal);
            sn += h.normal * w;
        }
        if border {
            r.border_points += 1;
        }
        if sw > 0.0 {
            let Some(slot) = scratch.slots.get_mut(c.node.idx()) else {
                continue;
            };
            if queued >= scratch.queue.len() {
                r.queue_full = true;
                continue;
            }
            slot.state = KNOWN;
            slot.depth = sd / sw;
            slot.dir = sn.normalize_or_zero();
            scratch.queue[queued] = c.node;
            queued += 1;
        }
    }

    // Breadth-first propagation, layer by layer.
    let mut head = 0usize;
    while head < queued {
        let u = scratch.queue[head];
        head += 1;
        let Some(&pu) = a_positions.get(u.idx()) else {
            continue;
        };
        let Some(&su) = scratch.slot(u) else { continue };
        if su.state == QUEUED {
            let (mut sm, mut sd, mut sr) = (0.0f32, 0.0f32, Vec3::ZERO);
            for &j in graph.neighbours(u) {
                let Some(&sj) = scratch.slot(j) else { continue };
                if sj.state != KNOWN || sj.layer >= su.layer {
                    continue;
                }
                let Some(&pj) = a_positions.get(j.idx()) else {
                    continue;
                };
                let v = pj - pu;
                let mu = 1.0 / v.length_squared().max(MIN_DIST2);
                sm += mu;
                sd += mu * (v.dot(sj.dir) + sj.depth);
                sr += sj.dir * mu;
            }
            let Some(slot) = scratch.slots.get_mut(u.idx()) else {
                continue;
            };
            if sm > 0.0 {
                slot.state = KNOWN;
                slot.depth = sd / sm;
                slot.dir = sr.normalize_or_zero();
            } else {
                slot.state = COLLIDING; // cannot happen: it was queued by a known neighbour
                continue;
            }
        }
        let layer = su.layer + 1;
        for &v in graph.neighbours(u) {
            let Some(sv) = scratch.slots.get_mut(v.idx()) else {
                continue;
            };
            if sv.stamp != stamp || sv.state != COLLIDING {
                continue;
            }
            if queued >= scratch.queue.len() {
                r.queue_full = true;
                break;
            }
            sv.state = QUEUED;
            sv.layer = layer;
            scratch.queue[queued] = v;
            queued += 1;
        }
    }

    // Output in collision order.
    for c in collisions {
        let Some(s) = scratch.slot(c.node) else {
            continue;
        };
        if s.state != KNOWN {
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
