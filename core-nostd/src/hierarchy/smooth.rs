//! Smooth vertex normals for a [`super::SurfaceExport`]: [`SmoothNormals`].
//!
//! Faces of the drilled surface share vertices by their exact place in the subdivision
//! lattice ([`VertexKey`]: the coarse tet's global node ids and integer barycentric weights
//! at the finest level), never by comparing floats. Each vertex keeps the sum of the unit
//! normals of its faces in fixed point (`2^20` a unit, integers: adding a face and taking it
//! away again leaves exactly what was there, whatever the order), and a list of its face
//! corners threaded through the exporter's slots.
//!
//! Faces are of two kinds: *drilled* (on no boundary face of the coarse mesh: cut by the
//! tool, a staircase of subdivision faces meeting at up to 90 degrees over a round cut) and
//! the mesh's own *boundary*. The two are never averaged together (the rim of a cavity
//! stays sharp), and each kind keeps its own sums. The normal written at corner `u` of face
//! `g`:
//! 1. `N(w)`: the unit sum of the normals of `w`'s faces of `g`'s kind; zero when that sum
//!    is shorter than `2^-8` (the faces' normals cancel, as where two sheets of the surface
//!    touch at a point: what is left of the sum is rounding noise);
//! 2. a drilled `g`: `M(w)`, the unit sum over `w`'s drilled faces `f` of `N` at `f`'s
//!    three corners (kept a vertex), and the corner's normal is the unit sum over `u`'s
//!    drilled faces `f` of `M` at `f`'s three corners: a three-ring average with no crease,
//!    as the staircase of one cut needs (one ring leaves neighbouring vertices' normals
//!    about 27 degrees apart on the tooth's cavity, two rings 13, three 9); a corner may
//!    then lean more than 90 degrees from its own facet, as the facets of the staircase do
//!    from the cut;
//! 3. a boundary `g`: the unit sum over `u`'s boundary faces `f` whose normal is within the
//!    crease angle of `g`'s of `N` at `f`'s three corners (a two-ring average), and `g`'s
//!    own normal where that is further than the crease angle from it: the mesh's own edges,
//!    sharper than the angle, stay sharp;
//! 4. a sum (of step 2 or 3) shorter than `2^-8`: the face's own normal.
//!
//! Changes are incremental, in two stages through one queue: a face put into or taken out of
//! a slot changes the sums of its three vertices; each of them and every vertex sharing a
//! face with one is queued to recompute `M` and its corners; a vertex whose `M` was
//! recomputed queues itself and its neighbours' corners. The exporter works the queue a
//! bounded amount each call; once it is empty every corner follows the rule above exactly.

use bytemuck::{Pod, Zeroable};
use glam::Vec3;

pub use super::smooth_storage::{SmoothError, SmoothSizes, SmoothStats, SmoothStorage};
use super::table::MAX_DEPTH;

/// "None": no vertex, no corner.
pub(super) const NO: u32 = u32::MAX;

/// Fixed-point scale of the normal sums: `2^20` a unit (a vertex of up to 2,047 faces sums
/// without overflow; the sums saturate beyond).
const SCALE: f32 = 1_048_576.0;

/// A vertex whose faces' unit normals sum to less than this (fixed point: `2^-8` of a unit)
/// has no normal of its own (`N(w)` is zero): its faces face opposite ways, as where two
/// sheets of the surface touch at a point, and the direction of what is left of the sum is
/// rounding noise.
const CANCELLED: i64 = 1 << 12;

/// A vertex's exact place in the subdivision lattice: the global ids of the coarse corners
/// it is a combination of (ascending, [`u32::MAX`] for an unused entry) and its integer
/// barycentric weights on them, scaled to `2^MAX_DEPTH` (they sum to `2^MAX_DEPTH`). A point
/// shared by nodes of different trees or depths has one key.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Pod, Zeroable)]
#[repr(C)]
pub struct VertexKey {
    /// Global node ids, ascending; [`u32::MAX`] past the last.
    pub nodes: [u32; 4],
    /// Weights, zero past the last.
    pub weights: [u16; 4],
}

impl VertexKey {
    /// No vertex.
    pub const NONE: Self = Self {
        nodes: [NO; 4],
        weights: [0; 4],
    };

    /// The key of the point with integer barycentric weights `w` (summing to `2^depth`) over
    /// the corners with global ids `ids`.
    ///
    /// # Bounded work
    /// Constant.
    pub fn of(ids: [u32; 4], w: [u32; 4], depth: u8) -> Self {
        let shift = (MAX_DEPTH as u32).saturating_sub(u32::from(depth));
        let mut key = Self::NONE;
        let mut n = 0usize;
        for (&id, &wk) in ids.iter().zip(w.iter()) {
            if wk == 0 {
                continue;
            }
            let weight = (wk << shift).min(u32::from(u16::MAX)) as u16;
            // Insertion in ascending id order.
            let mut j = n;
            while j > 0 && key.nodes[j - 1] > id {
                key.nodes[j] = key.nodes[j - 1];
                key.weights[j] = key.weights[j - 1];
                j -= 1;
            }
            if let (Some(kn), Some(kw)) = (key.nodes.get_mut(j), key.weights.get_mut(j)) {
                *kn = id;
                *kw = weight;
            }
            n += 1;
        }
        key
    }

    fn hash(&self) -> u32 {
        let mut h: u32 = 0x811c_9dc5;
        for (&id, &w) in self.nodes.iter().zip(self.weights.iter()) {
            h = (h ^ id).wrapping_mul(0x0100_0193);
            h = (h ^ u32::from(w)).wrapping_mul(0x0100_0193);
        }
        h ^ (h >> 15)
    }
}

/// A shared vertex: its key, the fixed-point sums of its boundary and of its drilled faces'
/// unit normals, its smoothed drilled normal `M` (fixed point), the first of its face corners
/// (`3 slot + corner`), how many faces it has, and its queued stages.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Pod, Zeroable)]
#[repr(C)]
pub struct SmoothVertex {
    key: VertexKey,
    sum: [[i32; 3]; 2],
    smooth: [i32; 3],
    head: u32,
    faces: u32,
    queued: u32,
}

impl SmoothVertex {
    /// An unused vertex.
    pub const EMPTY: Self = Self {
        key: VertexKey::NONE,
        sum: [[0; 3]; 2],
        smooth: [0; 3],
        head: NO,
        faces: 0,
        queued: 0,
    };
}

/// What [`SmoothNormals`] keeps for one triangle slot of the exporter: its three vertices,
/// the next corner of each vertex's list, its fixed-point unit normal, and flags (live,
/// drilled).
#[derive(Clone, Copy, PartialEq, Eq, Debug, Pod, Zeroable)]
#[repr(C)]
pub struct SmoothSlot {
    verts: [u32; 3],
    next: [u32; 3],
    normal: [i32; 3],
    flags: u32,
}

impl SmoothSlot {
    /// A free slot.
    pub const FREE: Self = Self {
        verts: [NO; 3],
        next: [NO; 3],
        normal: [0; 3],
        flags: 0,
    };
}

const LIVE: u32 = 1;
const DRILLED: u32 = 2;

const _: () = assert!(core::mem::size_of::<SmoothVertex>() == 72);

/// Queue stages: recompute a vertex's `M`, or its corners.
const STAGE_M: u32 = 0;
const STAGE_CORNERS: u32 = 1;
/// A queue entry's stage bit (vertex indices stay below it).
const STAGE_BIT: u32 = 1 << 31;
const _: () = assert!(core::mem::size_of::<SmoothSlot>() == 40);

impl core::error::Error for SmoothError {}

/// Shared vertices and smooth per-corner normals of a surface exporter's faces: see the
/// module's docs. Made with [`SmoothNormals::new`] and given to
/// [`super::SurfaceExport::with_smooth`].
#[derive(Debug)]
pub struct SmoothNormals<'a> {
    slots: &'a mut [SmoothSlot],
    verts: &'a mut [SmoothVertex],
    table: &'a mut [u32],
    queue: &'a mut [u32],
    /// Vertices handed out so far.
    fresh: u32,
    /// Freed vertices, threaded through `head`.
    free: u32,
    q_first: usize,
    q_len: usize,
    /// The stage and next vertex of a sweep over every vertex (after the queue was full):
    /// every `M`, then every vertex's corners.
    sweep: Option<(u32, u32)>,
    cos_crease: f32,
    stats: SmoothStats,
}

/// The fixed-point normal of a unit vector.
fn quantize(n: Vec3) -> [i32; 3] {
    n.to_array().map(|c| libm::roundf(c * SCALE) as i32)
}

fn unit_of(s: [i32; 3]) -> Vec3 {
    Vec3::new(s[0] as f32, s[1] as f32, s[2] as f32).normalize_or_zero()
}

impl<'a> SmoothNormals<'a> {
    /// The default crease angle, degrees: faces further apart than this are not averaged
    /// together (a cube's 90-degree edges stay sharp; the subdivision's steps inside a cavity,
    /// up to about 70 degrees, are smoothed).
    pub const CREASE_DEGREES: f32 = 75.0;

    /// Smooth normals over `storage` with crease angle `crease_degrees`.
    ///
    /// # Bounded work
    /// O(table + slots + vertices) to clear them.
    ///
    /// # Errors
    /// [`SmoothError::Storage`] when the table is not a power of two at least twice the
    /// vertices, or the queue is empty.
    pub fn new(storage: SmoothStorage<'a>, crease_degrees: f32) -> Result<Self, SmoothError> {
        let SmoothStorage {
            slots,
            vertices,
            table,
            queue,
        } = storage;
        if !table.len().is_power_of_two()
            || table.len() < 2 * vertices.len()
            || queue.is_empty()
            || vertices.len() >= STAGE_BIT as usize
        {
            return Err(SmoothError::Storage);
        }
        table.fill(NO);
        slots.fill(SmoothSlot::FREE);
        vertices.fill(SmoothVertex::EMPTY);
        let cos_crease = libm::cosf(crease_degrees.clamp(0.0, 180.0).to_radians());
        Ok(Self {
            slots,
            verts: vertices,
            table,
            queue,
            fresh: 0,
            free: NO,
            q_first: 0,
            q_len: 0,
            sweep: None,
            cos_crease,
            stats: SmoothStats::default(),
        })
    }

    /// Clears every slot, vertex and counter, as [`SmoothNormals::new`] does (the crease
    /// angle kept).
    ///
    /// # Bounded work
    /// O(table + slots + vertices).
    pub fn reset(&mut self) {
        self.table.fill(NO);
        self.slots.fill(SmoothSlot::FREE);
        self.verts.fill(SmoothVertex::EMPTY);
        self.fresh = 0;
        self.free = NO;
        self.q_first = 0;
        self.q_len = 0;
        self.sweep = None;
        self.stats = SmoothStats::default();
    }

    /// Slots (the exporter's must match).
    pub fn slots(&self) -> usize {
        self.slots.len()
    }

    /// What went short, and the live vertices.
    pub fn stats(&self) -> SmoothStats {
        self.stats
    }

    /// The shared vertices of slot `s`'s corners (indices below the vertex storage's length;
    /// [`u32::MAX`] for a corner that found no vertex), `None` when the slot is free.
    pub fn slot_vertices(&self, s: u32) -> Option<[u32; 3]> {
        let r = self.slots.get(s as usize)?;
        (r.flags & LIVE != 0).then_some(r.verts)
    }

    /// `true` when slot `s` holds a drilled face: one that does not lie on a boundary face
    /// of the coarse mesh.
    pub fn slot_drilled(&self, s: u32) -> bool {
        self.slots
            .get(s as usize)
            .is_some_and(|r| r.flags & (LIVE | DRILLED) == LIVE | DRILLED)
    }

    /// The key of vertex `v`, `None` when it is not live.
    pub fn vertex_key(&self, v: u32) -> Option<VertexKey> {
        let r = self.verts.get(v as usize)?;
        (r.faces > 0).then_some(r.key)
    }

    /// The faces at vertex `v` (zero when it is not live).
    pub fn vertex_faces(&self, v: u32) -> u32 {
        self.verts.get(v as usize).map_or(0, |r| r.faces)
    }

    /// Recomputes every corner again, a bounded amount each [`super::SurfaceExport::update`]
    /// (as after the queue was full).
    pub fn refresh(&mut self) {
        self.sweep = Some((STAGE_M, 0));
    }

    /// Checks the invariants: every live vertex is found by its key, its corner list holds
    /// exactly its faces (live slots naming it), and its sum is the sum of their normals.
    ///
    /// # Bounded work
    /// O(vertices x faces a vertex + table).
    ///
    /// # Errors
    /// What is wrong, in words.
    pub fn validate(&self) -> Result<(), &'static str> {
        for (v, r) in self.verts.iter().enumerate().take(self.fresh as usize) {
            if r.faces == 0 {
                continue;
            }
            match self.find(&r.key) {
                Ok(i) if self.table.get(i) == Some(&(v as u32)) => {}
                _ => return Err("a live vertex is not found by its key"),
            }
            let (mut n, mut sum) = (0u32, [[0i32; 3]; 2]);
            let mut c = r.head;
            while let Some(s) = self.slots.get((c / 3) as usize) {
                let k = (c % 3) as usize;
                if s.flags & LIVE == 0 || s.verts.get(k) != Some(&(v as u32)) {
                    return Err("a vertex's corner list names a corner not at it");
                }
                n += 1;
                if n > r.faces {
                    return Err("a vertex's corner list is longer than its faces");
                }
                let kind = usize::from(s.flags & DRILLED != 0);
                if let Some(sk) = sum.get_mut(kind) {
                    for (a, b) in sk.iter_mut().zip(s.normal) {
                        *a = a.saturating_add(b);
                    }
                }
                c = s.next.get(k).copied().unwrap_or(NO);
            }
            if n != r.faces || sum != r.sum {
                return Err("a vertex's faces or sum differ from its corner list");
            }
        }
        Ok(())
    }

    /// Queued work: vertices to recompute (every vertex left in a sweep too).
    pub fn pending(&self) -> u32 {
        let sweep = self.sweep.map_or(0, |(stage, v)| {
            let left = self.fresh.saturating_sub(v);
            if stage == STAGE_M {
                left.saturating_add(self.fresh)
            } else {
                left
            }
        });
        (self.q_len as u32).saturating_add(sweep)
    }

    /// The table position holding `key`'s vertex, or the empty position where it would go
    /// (`None`: the table is full).
    fn find(&self, key: &VertexKey) -> Result<usize, Option<usize>> {
        let mask = self.table.len() - 1;
        let mut i = key.hash() as usize & mask;
        for _ in 0..self.table.len() {
            let e = self.table.get(i).copied().unwrap_or(NO);
            if e == NO {
                return Err(Some(i));
            }
            if self.verts.get(e as usize).is_some_and(|v| v.key == *key) {
                return Ok(i);
            }
            i = (i + 1) & mask;
        }
        Err(None)
    }

    /// The vertex of `key`, made when new; `None` when the vertices are full.
    fn vertex(&mut self, key: &VertexKey) -> Option<u32> {
        let at = match self.find(key) {
            Ok(i) => return self.table.get(i).copied(),
            Err(at) => at?,
        };
        let v = if let Some(r) = self.verts.get(self.free as usize) {
            let v = self.free;
            self.free = r.head;
            v
        } else if (self.fresh as usize) < self.verts.len() {
            self.fresh += 1;
            self.fresh - 1
        } else {
            return None;
        };
        if let Some(r) = self.verts.get_mut(v as usize) {
            *r = SmoothVertex {
                key: *key,
                ..SmoothVertex::EMPTY
            };
        }
        if let Some(e) = self.table.get_mut(at) {
            *e = v;
        }
        self.stats.vertices += 1;
        Some(v)
    }

    /// Takes vertex `v` (no faces left) out of the table (linear probing, backward shift).
    fn release(&mut self, v: u32) {
        let Some(key) = self.verts.get(v as usize).map(|r| r.key) else {
            return;
        };
        let Ok(found) = self.find(&key) else {
            return;
        };
        let mask = self.table.len() - 1;
        let mut hole = found;
        let mut i = (hole + 1) & mask;
        loop {
            let e = self.table.get(i).copied().unwrap_or(NO);
            if e == NO {
                break;
            }
            let home = self
                .verts
                .get(e as usize)
                .map_or(i, |r| r.key.hash() as usize & mask);
            // `e` may move to the hole when its home is not cyclically in (hole, i].
            if (i.wrapping_sub(home) & mask) >= (i.wrapping_sub(hole) & mask) {
                if let Some(h) = self.table.get_mut(hole) {
                    *h = e;
                }
                hole = i;
            }
            i = (i + 1) & mask;
        }
        if let Some(h) = self.table.get_mut(hole) {
            *h = NO;
        }
        if let Some(r) = self.verts.get_mut(v as usize) {
            *r = SmoothVertex {
                head: self.free,
                ..SmoothVertex::EMPTY
            };
        }
        self.free = v;
        self.stats.vertices = self.stats.vertices.saturating_sub(1);
    }

    /// Queues stage `stage` of vertex `v`.
    fn push(&mut self, v: u32, stage: u32) {
        let bit = 1 << stage;
        let Some(r) = self.verts.get_mut(v as usize) else {
            return;
        };
        if r.queued & bit != 0 {
            return;
        }
        if self.q_len >= self.queue.len() {
            // Full: every vertex is recomputed instead (the queue's entries stay valid).
            if self.sweep.is_none() {
                self.stats.queue_full = self.stats.queue_full.saturating_add(1);
                self.sweep = Some((STAGE_M, 0));
            }
            return;
        }
        r.queued |= bit;
        let at = (self.q_first + self.q_len) % self.queue.len();
        if let Some(q) = self.queue.get_mut(at) {
            *q = v | if stage == STAGE_CORNERS { STAGE_BIT } else { 0 };
        }
        self.q_len += 1;
    }

    /// Queues the stages `stages` (bits) of `v` and of every vertex that shares a face with
    /// it.
    fn push_around(&mut self, v: u32, stages: u32, work: &mut u32) {
        let push_all = |me: &mut Self, w: u32| {
            for stage in [STAGE_M, STAGE_CORNERS] {
                if stages & (1 << stage) != 0 {
                    me.push(w, stage);
                }
            }
        };
        push_all(self, v);
        let mut c = self
            .verts
            .get(v as usize)
            .filter(|r| r.faces > 0)
            .map_or(NO, |r| r.head);
        while let Some(r) = self.slots.get((c / 3) as usize).copied() {
            *work = work.saturating_add(1);
            for w in r.verts {
                if w != v {
                    push_all(self, w);
                }
            }
            c = r.next.get((c % 3) as usize).copied().unwrap_or(NO);
        }
    }

    /// Puts face `keys` (corners in the exporter's order) with unit normal `normal` into
    /// slot `s` (taking out what it held), `drilled` when it lies on no boundary face of the
    /// coarse mesh. Returns the work spent (faces visited).
    pub(super) fn set_face(
        &mut self,
        s: u32,
        keys: &[VertexKey; 3],
        normal: Vec3,
        drilled: bool,
    ) -> u32 {
        let mut work = self.unset_face(s);
        let q = quantize(normal);
        let mut verts = [NO; 3];
        for (k, key) in keys.iter().enumerate() {
            match self.vertex(key) {
                Some(v) => verts[k] = v,
                None => self.stats.vertices_full = self.stats.vertices_full.saturating_add(1),
            }
        }
        let mut next = [NO; 3];
        let kind = usize::from(drilled);
        for (k, &v) in verts.iter().enumerate() {
            if let Some(r) = self.verts.get_mut(v as usize) {
                next[k] = r.head;
                r.head = 3 * s + k as u32;
                r.faces += 1;
                if let Some(sk) = r.sum.get_mut(kind) {
                    for (a, b) in sk.iter_mut().zip(q) {
                        *a = a.saturating_add(b);
                    }
                }
            }
        }
        if let Some(r) = self.slots.get_mut(s as usize) {
            *r = SmoothSlot {
                verts,
                next,
                normal: q,
                flags: LIVE | if drilled { DRILLED } else { 0 },
            };
        }
        for v in verts {
            self.push_around(v, BOTH, &mut work);
        }
        work
    }

    /// Takes the face out of slot `s` (nothing when it is free). Returns the work spent.
    pub(super) fn unset_face(&mut self, s: u32) -> u32 {
        let Some(rec) = self.slots.get(s as usize).copied() else {
            return 0;
        };
        if rec.flags & LIVE == 0 {
            return 0;
        }
        let mut work = 0u32;
        if let Some(r) = self.slots.get_mut(s as usize) {
            *r = SmoothSlot::FREE;
        }
        for (k, &v) in rec.verts.iter().enumerate() {
            let me = 3 * s + k as u32;
            let Some(head) = self.verts.get(v as usize).map(|r| r.head) else {
                continue;
            };
            // Unlink corner `me` from the vertex's list.
            let after = rec.next[k];
            if head == me {
                if let Some(r) = self.verts.get_mut(v as usize) {
                    r.head = after;
                }
            } else {
                let mut c = head;
                while let Some(r) = self.slots.get_mut((c / 3) as usize) {
                    work = work.saturating_add(1);
                    let Some(n) = r.next.get_mut((c % 3) as usize) else {
                        break;
                    };
                    if *n == me {
                        *n = after;
                        break;
                    }
                    c = *n;
                }
            }
            let gone = match self.verts.get_mut(v as usize) {
                Some(r) => {
                    r.faces = r.faces.saturating_sub(1);
                    let kind = usize::from(rec.flags & DRILLED != 0);
                    if let Some(sk) = r.sum.get_mut(kind) {
                        for (a, b) in sk.iter_mut().zip(rec.normal) {
                            *a = a.saturating_sub(b);
                        }
                    }
                    r.faces == 0
                }
                None => false,
            };
            if gone {
                self.release(v);
            }
        }
        for v in rec.verts {
            if self.verts.get(v as usize).is_some_and(|r| r.faces > 0) {
                self.push_around(v, BOTH, &mut work);
            }
        }
        work
    }

    /// `N(w)` of faces of kind `kind` (1: drilled): the unit sum of their normals at vertex
    /// `w`; zero when the sum is shorter than [`CANCELLED`] (the faces' normals cancel).
    fn vertex_normal(&self, w: u32, kind: usize) -> Vec3 {
        let Some(sum) = self.verts.get(w as usize).and_then(|r| r.sum.get(kind)) else {
            return Vec3::ZERO;
        };
        let len2: i64 = sum.iter().map(|&c| i64::from(c) * i64::from(c)).sum();
        if len2 < CANCELLED * CANCELLED {
            Vec3::ZERO
        } else {
            unit_of(*sum)
        }
    }

    /// `M(x)`: the unit sum over `x`'s drilled faces of `N` at their corners (zero when
    /// shorter than `2^-8`).
    fn smooth_normal(&self, x: u32, work: &mut u32) -> Vec3 {
        let mut sum = Vec3::ZERO;
        let mut c = self
            .verts
            .get(x as usize)
            .filter(|r| r.faces > 0)
            .map_or(NO, |r| r.head);
        while let Some(r) = self.slots.get((c / 3) as usize) {
            *work = work.saturating_add(1);
            if r.flags & DRILLED != 0 {
                for w in r.verts {
                    sum += self.vertex_normal(w, 1);
                }
            }
            c = r.next.get((c % 3) as usize).copied().unwrap_or(NO);
        }
        unit_or_zero(sum)
    }

    /// The normal of a corner at vertex `u` of a face with unit normal `own`, drilled or
    /// not: see the module's docs.
    fn corner_normal(&self, u: u32, own: Vec3, drilled: bool, work: &mut u32) -> Vec3 {
        let mut sum = Vec3::ZERO;
        let mut c = self.verts.get(u as usize).map_or(NO, |r| r.head);
        while let Some(r) = self.slots.get((c / 3) as usize) {
            *work = work.saturating_add(1);
            let same_kind = (r.flags & DRILLED != 0) == drilled;
            if same_kind && drilled {
                for w in r.verts {
                    sum += self
                        .verts
                        .get(w as usize)
                        .map_or(Vec3::ZERO, |v| unit_of(v.smooth));
                }
            } else if same_kind && unit_of(r.normal).dot(own) >= self.cos_crease {
                for w in r.verts {
                    sum += self.vertex_normal(w, 0);
                }
            }
            c = r.next.get((c % 3) as usize).copied().unwrap_or(NO);
        }
        let m = unit_or_zero(sum);
        if m == Vec3::ZERO || (!drilled && m.dot(own) < self.cos_crease) {
            own
        } else {
            m
        }
    }

    /// Recomputes the corners of vertex `u`, `write(slot, corner, normal)` for each.
    fn redo_vertex(&mut self, u: u32, work: &mut u32, write: &mut impl FnMut(u32, usize, Vec3)) {
        // A freed vertex (still queued) threads the free list through `head`: no corners.
        let mut c = self
            .verts
            .get(u as usize)
            .filter(|r| r.faces > 0)
            .map_or(NO, |r| r.head);
        while let Some(r) = self.slots.get((c / 3) as usize).copied() {
            let own = unit_of(r.normal);
            let n = self.corner_normal(u, own, r.flags & DRILLED != 0, work);
            write(c / 3, (c % 3) as usize, n);
            self.stats.corners += 1;
            c = r.next.get((c % 3) as usize).copied().unwrap_or(NO);
        }
    }

    /// Recomputes `M` of vertex `x`; `then` queues the corners around it.
    fn redo_smooth(&mut self, x: u32, then: bool, work: &mut u32) {
        if self.verts.get(x as usize).is_none_or(|r| r.faces == 0) {
            return;
        }
        let m = quantize(self.smooth_normal(x, work));
        if let Some(r) = self.verts.get_mut(x as usize) {
            r.smooth = m;
        }
        if then {
            self.push_around(x, 1 << STAGE_CORNERS, work);
        }
    }

    /// Works the queue, then any sweep, while `work` is below `budget`; `write(slot, corner,
    /// normal)` receives each corner recomputed.
    ///
    /// # Bounded work
    /// An entry is started only while `work < budget`; one vertex of `F` faces costs `F`
    /// faces for its `M` and `F` corners of `F` faces each (`F^2` work units).
    pub(super) fn flush(
        &mut self,
        work: &mut u32,
        budget: u32,
        mut write: impl FnMut(u32, usize, Vec3),
    ) {
        while *work < budget && self.q_len > 0 {
            let e = self.queue.get(self.q_first).copied().unwrap_or(NO);
            self.q_first = (self.q_first + 1) % self.queue.len();
            self.q_len -= 1;
            let (v, stage) = if e & STAGE_BIT != 0 {
                (e & !STAGE_BIT, STAGE_CORNERS)
            } else {
                (e, STAGE_M)
            };
            if let Some(r) = self.verts.get_mut(v as usize) {
                r.queued &= !(1 << stage);
            }
            *work = work.saturating_add(1);
            if stage == STAGE_M {
                self.redo_smooth(v, true, work);
            } else {
                self.redo_vertex(v, work, &mut write);
            }
        }
        while *work < budget {
            let Some((stage, v)) = self.sweep else { break };
            if v >= self.fresh {
                self.sweep = (stage == STAGE_M).then_some((STAGE_CORNERS, 0));
                continue;
            }
            self.sweep = Some((stage, v + 1));
            *work = work.saturating_add(1);
            if stage == STAGE_M {
                self.redo_smooth(v, false, work);
            } else {
                self.redo_vertex(v, work, &mut write);
            }
        }
    }
}

/// Both queue stages.
const BOTH: u32 = (1 << STAGE_M) | (1 << STAGE_CORNERS);

/// `v`'s unit vector, zero when `v` is shorter than `2^-8`.
fn unit_or_zero(v: Vec3) -> Vec3 {
    if v.length_squared() < 1.0 / 65_536.0 {
        Vec3::ZERO
    } else {
        v.normalize()
    }
}
