//! The drilled surface written into a renderer's buffers a part at a time: [`SurfaceExport`].
//!
//! The buffers are a triangle soup of fixed slots (three vertices a slot: faces of different
//! levels need not share corners). Each coarse tet owns a chain of slots; when the tet's
//! visible faces change (the hierarchy's change log, [`Hierarchy::change_at`]), its faces are
//! listed again into its own slots first, then into free ones, and the slots it no longer
//! needs are freed. Only slots whose contents change are written, and each call returns the
//! ranges of slots it wrote, so a renderer uploads those and nothing else.

use bytemuck::{Pod, Zeroable};
use glam::Vec3;

use super::changes::Change;
use super::export_keys::face_keys;
pub(super) use super::export_keys::walk_key;
use super::smooth::SmoothNormals;
use super::store::Hierarchy;
use crate::ids::TetId;
use crate::mesh::Mesh;
use crate::storage::{carve, lines_of, Memory, Part, PartSet, Slots, StorageError};

/// "No slot": the end of a chain.
const NO: u32 = u32::MAX;

/// What a triangle slot holds: the face it shows (`tet` [`TetId::NONE`] when free) and the
/// next slot of its coarse tet's chain (or of the free list).
#[derive(Clone, Copy, PartialEq, Eq, Debug, Pod, Zeroable)]
#[repr(C)]
pub struct SlotRecord {
    tet: u32,
    index: u32,
    face: u32,
    next: u32,
}

impl SlotRecord {
    /// A free slot.
    pub const FREE: Self = Self {
        tet: u32::MAX,
        index: 0,
        face: 0,
        next: NO,
    };
}

/// What a surface exporter keeps for each coarse tet: the first slot of its chain and the
/// change log's length when its slots were last made to match its faces.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Pod, Zeroable)]
#[repr(C)]
pub struct TetRecord {
    head: u32,
    slots: u32,
    done_at: u64,
}

impl TetRecord {
    /// A tet with no slots, never listed.
    pub const EMPTY: Self = Self {
        head: NO,
        slots: 0,
        done_at: 0,
    };
}

const _: () = assert!(core::mem::size_of::<SlotRecord>() == 16);
const _: () = assert!(core::mem::size_of::<TetRecord>() == 16);

/// Storage sizes of a [`SurfaceExport`]: triangle slots and coarse tets.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct SurfaceSizes {
    /// Triangle slots (the renderer's buffers hold three vertices a slot), at most
    /// [`SurfaceExport::MAX_SLOTS`].
    pub slots: usize,
    /// Coarse tets of the mesh.
    pub tets: usize,
}

impl SurfaceSizes {
    /// Sizes for `slots` triangle slots over a mesh of `tets` coarse tets.
    pub const fn new(slots: usize, tets: usize) -> Self {
        Self { slots, tets }
    }

    /// The slices of a [`SurfaceStorage`], in the order [`SurfaceStorage::carve`] takes them.
    pub const fn parts(&self) -> [Slots; 2] {
        [
            Slots::of::<SlotRecord>(Part::SurfaceSlots, self.slots),
            Slots::of::<TetRecord>(Part::SurfaceTets, self.tets),
        ]
    }

    /// The [`crate::storage::Line`]s a block starting on a line needs for these sizes.
    pub const fn lines(&self) -> Option<usize> {
        lines_of(&self.parts(), PartSet::EMPTY, false)
    }
}

/// Storage for a [`SurfaceExport`]: 16 bytes a triangle slot and 16 a coarse tet.
#[derive(Debug)]
pub struct SurfaceStorage<'a> {
    /// One record a triangle slot.
    pub slots: &'a mut [SlotRecord],
    /// One record a coarse tet.
    pub tets: &'a mut [TetRecord],
}

impl<'a> SurfaceStorage<'a> {
    /// Carves the slots and tet records of `sizes` from `mem`, every slot free.
    ///
    /// # Bounded work
    /// O(bytes of `sizes`).
    ///
    /// # Errors
    /// [`StorageError`] naming the first part the memory could not hold.
    pub fn carve(sizes: &SurfaceSizes, mem: &mut impl Memory<'a>) -> Result<Self, StorageError> {
        Ok(Self {
            slots: carve(mem, Part::SurfaceSlots, sizes.slots, SlotRecord::FREE)?,
            tets: carve(mem, Part::SurfaceTets, sizes.tets, TetRecord::EMPTY)?,
        })
    }
}

/// A run of slots written by one [`SurfaceExport::update`]: `count` slots from `first`.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default, Pod, Zeroable)]
#[repr(C)]
pub struct SlotRange {
    /// First slot.
    pub first: u32,
    /// Slots.
    pub count: u32,
}

impl SlotRange {
    fn end(&self) -> u32 {
        self.first.saturating_add(self.count)
    }
}

/// The renderer's buffers a [`SurfaceExport::update`] writes, slot `s` at vertices `3 s`,
/// `3 s + 1`, `3 s + 2`; each holds at least three entries a slot of the exporter.
///
/// A live slot holds its face's corners (counter-clockwise seen from outside the material),
/// the face's outward unit normal on each of its three vertices, its coarse tet's label on
/// each, and the indices `3 s`, `3 s + 1`, `3 s + 2`. A free slot is zero in every buffer
/// (indices `0, 0, 0`: a degenerate triangle a renderer draws as nothing), so buffers that
/// start zeroed are an empty surface.
#[derive(Debug)]
pub struct SurfaceBuffers<'b> {
    /// Vertex positions.
    pub positions: &'b mut [[f32; 3]],
    /// Vertex normals.
    pub normals: &'b mut [[f32; 3]],
    /// Vertex labels.
    pub labels: &'b mut [i32],
    /// Vertex indices, three a triangle.
    pub indices: &'b mut [u32],
    /// The ranges of slots the call wrote (at least one entry).
    pub ranges: &'b mut [SlotRange],
}

/// Why a [`SurfaceExport`] could not be made or updated (nothing changed).
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
#[non_exhaustive]
pub enum SurfaceError {
    /// The storage has fewer tet records than the mesh has coarse tets, or more slots than
    /// [`SurfaceExport::MAX_SLOTS`].
    Storage,
    /// A buffer holds fewer than three entries a slot, or the range list is empty.
    Buffers,
}

impl core::fmt::Display for SurfaceError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::Storage => write!(f, "surface storage does not fit the mesh"),
            Self::Buffers => write!(f, "surface buffers are shorter than three entries a slot"),
        }
    }
}

impl core::error::Error for SurfaceError {}

/// What one [`SurfaceExport::update`] did.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default)]
pub struct ExportReport {
    /// Work units spent: one a change log entry read or coarse tet swept, plus, for each tet
    /// listed again, its faces and the slots it freed.
    pub work: u32,
    /// Coarse tets whose faces were listed again.
    pub tets: u32,
    /// Slots written (a face put in, or freed).
    pub written: u32,
    /// Entries of the range list filled.
    pub ranges: u32,
    /// The range list filled up: its last entry was widened to cover every later slot
    /// written (it then covers slots that did not change too).
    pub ranges_merged: bool,
    /// Faces that found no free slot (the buffers are full): left out until a slot frees up
    /// (see [`SurfaceExport`]).
    pub dropped: u32,
    /// Work still to do: change log entries unread plus coarse tets left to sweep (zero: the
    /// buffers hold the surface exactly).
    pub pending: u32,
    /// Live slots (visible faces in the buffers).
    pub live: u32,
    /// Slots ever used: every live slot is below it (a renderer draws this many).
    pub used: u32,
}

/// A sweep over every coarse tet: after a lost change log, a move of the nodes, or faces left
/// out for want of a slot.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
struct Sweep {
    /// The next tet.
    next: u32,
    /// The change log's length when the sweep began: its entries from there on are read once
    /// it ends.
    resume: u64,
    /// Every slot is written again, even one that holds the same face (the nodes moved).
    rewrite: bool,
}

/// The drilled surface kept in a renderer's buffers, brought up to date a bounded amount of
/// work a call: see the module's docs and [`SurfaceExport::update`].
///
/// Slots are stable: a coarse tet's faces stay in the slots they were written to until that
/// tet's faces change, and then its new faces fill its own slots first. A face needs a free
/// slot only when its tet grows; when there is none (the buffers are full), the face is left
/// out and counted ([`ExportReport::dropped`]), and the exporter sweeps every tet again once
/// its change log is read, until every face has a slot: `pending` stays above zero
/// meanwhile. The buffers hold the drilled surface exactly whenever a call reports
/// `pending == 0`.
///
/// A new exporter starts with a sweep of every tet (its buffers start zeroed, see
/// [`SurfaceBuffers`]); after that, it reads the hierarchy's change log and lists again only
/// the tets named there (a tet listed again since its entry was written is skipped). When
/// the log has lost entries it has not read, or the mesh's nodes moved, it sweeps every tet.
///
/// ```
/// use tetradrill_core::builtin;
/// use tetradrill_core::hierarchy::{SlotRange, SurfaceBuffers, SurfaceExport, SurfaceSizes,
///     SurfaceStorage};
/// use tetradrill_core::prelude::*;
///
/// let (mut pos, tets) = builtin::cube12();
/// let (mut nodes, mut normals) = ([Node::default(); 9], [Vec3::ZERO; 9]);
/// let (mut recs, mut scratch) = ([Tet::default(); 12], [FaceKey::default(); 48]);
/// let storage = MeshStorage { nodes: &mut nodes, normals: &mut normals, tets: &mut recs };
/// let mesh = Mesh::build(&mut pos, &tets, storage, &mut scratch, BuildOptions::default())?;
/// let sizes = WorldSizes::new(12, 4096);
/// let mut lines = vec![Line::ZERO; sizes.lines().unwrap()];
/// let storage = WorldStorage::carve(&sizes, &mut Block::from_lines(&mut lines))?;
/// let world = World::new(mesh, storage)?;
///
/// // An exporter of 64 triangle slots and buffers for them, zeroed.
/// let sizes = SurfaceSizes::new(64, 12);
/// let mut lines = vec![Line::ZERO; sizes.lines().unwrap()];
/// let storage = SurfaceStorage::carve(&sizes, &mut Block::from_lines(&mut lines))?;
/// let mut surface = SurfaceExport::new(storage, world.hierarchy())?;
/// let (mut p, mut n) = (vec![[0.0; 3]; 3 * 64], vec![[0.0; 3]; 3 * 64]);
/// let (mut l, mut i) = (vec![0; 3 * 64], vec![0; 3 * 64]);
/// let mut ranges = [SlotRange::default(); 8];
/// let mut out = SurfaceBuffers {
///     positions: &mut p, normals: &mut n, labels: &mut l, indices: &mut i,
///     ranges: &mut ranges,
/// };
///
/// // The cube's 12 boundary faces, at most 100 work units a call.
/// let report = surface.update(world.hierarchy(), world.mesh(), |_| 7, 100, &mut out)?;
/// assert_eq!((report.live, report.pending), (12, 0));
/// assert_eq!(out.ranges[0], SlotRange { first: 0, count: 12 });
/// assert_eq!(&out.indices[..6], &[0, 1, 2, 3, 4, 5]);
/// assert_eq!(out.labels[0], 7);
///
/// // Nothing changed since: nothing is written.
/// let report = surface.update(world.hierarchy(), world.mesh(), |_| 7, 100, &mut out)?;
/// assert_eq!((report.written, report.ranges), (0, 0));
/// # Ok::<(), tetradrill_core::Error>(())
/// ```
#[derive(Debug)]
pub struct SurfaceExport<'a> {
    slots: &'a mut [SlotRecord],
    tets: &'a mut [TetRecord],
    /// Slots handed out so far (those from here on have never been used).
    fresh: u32,
    /// The list of freed slots, threaded through their `next`.
    free: u32,
    live: u32,
    /// The change log is read up to here.
    cursor: u64,
    /// The last change of every face at once this copy has seen.
    seen_all: u64,
    sweep: Option<Sweep>,
    /// A face was left out for want of a slot since the last sweep began.
    short: bool,
    /// Shared vertices and smooth normals, when given ([`SurfaceExport::with_smooth`]).
    smooth: Option<SmoothNormals<'a>>,
}

/// Where one call writes: the buffers and the ranges so far.
struct Out<'o, 'b> {
    bufs: &'o mut SurfaceBuffers<'b>,
    ranges: usize,
    merged: bool,
    written: u32,
}

impl Out<'_, '_> {
    /// Notes slot `s` as written.
    fn mark(&mut self, s: u32) {
        self.written += 1;
        let n = self.ranges;
        if let Some(last) = n.checked_sub(1).and_then(|i| self.bufs.ranges.get_mut(i)) {
            if s >= last.first && s < last.end() {
                return;
            }
            if s == last.end() {
                last.count += 1;
                return;
            }
        }
        if let Some(r) = self.bufs.ranges.get_mut(n) {
            *r = SlotRange { first: s, count: 1 };
            self.ranges += 1;
        } else if let Some(last) = n.checked_sub(1).and_then(|i| self.bufs.ranges.get_mut(i)) {
            let first = last.first.min(s);
            let end = last.end().max(s.saturating_add(1));
            *last = SlotRange {
                first,
                count: end - first,
            };
            self.merged = true;
        }
    }

    /// Writes face `corners` with `label` into slot `s`.
    fn put(&mut self, s: u32, corners: [Vec3; 3], label: i32) {
        let [a, b, c] = corners;
        let n = (b - a).cross(c - a).normalize_or_zero();
        let v = 3 * s as usize;
        let base = 3 * s;
        for (k, corner) in corners.iter().enumerate() {
            if let Some(p) = self.bufs.positions.get_mut(v + k) {
                *p = corner.to_array();
            }
            if let Some(q) = self.bufs.normals.get_mut(v + k) {
                *q = n.to_array();
            }
            if let Some(l) = self.bufs.labels.get_mut(v + k) {
                *l = label;
            }
            if let Some(i) = self.bufs.indices.get_mut(v + k) {
                *i = base + k as u32;
            }
        }
        self.mark(s);
    }

    /// Writes slot `s` as free: zero in every buffer.
    fn clear(&mut self, s: u32) {
        let v = 3 * s as usize;
        for k in 0..3 {
            if let Some(p) = self.bufs.positions.get_mut(v + k) {
                *p = [0.0; 3];
            }
            if let Some(q) = self.bufs.normals.get_mut(v + k) {
                *q = [0.0; 3];
            }
            if let Some(l) = self.bufs.labels.get_mut(v + k) {
                *l = 0;
            }
            if let Some(i) = self.bufs.indices.get_mut(v + k) {
                *i = 0;
            }
        }
        self.mark(s);
    }
}

impl<'a> SurfaceExport<'a> {
    /// The most slots an exporter has: every vertex index fits a `u32`.
    pub const MAX_SLOTS: usize = (u32::MAX / 3) as usize;

    /// An exporter over `storage` for the trees of `hier`, every slot free, a sweep of every
    /// coarse tet to come.
    ///
    /// # Bounded work
    /// Constant.
    ///
    /// # Errors
    /// [`SurfaceError::Storage`] when `storage` has fewer tet records than `hier` has trees,
    /// or more than [`SurfaceExport::MAX_SLOTS`] slots.
    pub fn new(storage: SurfaceStorage<'a>, hier: &Hierarchy<'_>) -> Result<Self, SurfaceError> {
        let SurfaceStorage { slots, tets } = storage;
        if tets.len() < hier.tet_count() || slots.len() > Self::MAX_SLOTS {
            return Err(SurfaceError::Storage);
        }
        let (tets, _) = tets.split_at_mut(hier.tet_count());
        Ok(Self {
            slots,
            tets,
            fresh: 0,
            free: NO,
            live: 0,
            cursor: hier.change_count(),
            seen_all: hier.all_changed_at(),
            sweep: Some(Sweep {
                next: 0,
                resume: hier.change_count(),
                rewrite: true,
            }),
            short: false,
            smooth: None,
        })
    }

    /// The exporter with shared vertices and smooth per-corner normals ([`SmoothNormals`],
    /// its own storage): from now on the normals buffer holds, at each corner, the smooth
    /// normal [`SmoothNormals`] computes rather than the face's. Every face is listed again (a
    /// sweep), so this may come at any time.
    ///
    /// # Errors
    /// [`SurfaceError::Storage`] when `smooth` has not one slot record per triangle slot.
    pub fn with_smooth(mut self, smooth: SmoothNormals<'a>) -> Result<Self, SurfaceError> {
        if smooth.slots() != self.slots.len() {
            return Err(SurfaceError::Storage);
        }
        self.smooth = Some(smooth);
        let resume = self.sweep.map_or(self.cursor, |sw| sw.resume);
        self.sweep = Some(Sweep {
            next: 0,
            resume,
            rewrite: true,
        });
        Ok(self)
    }

    /// The shared vertices and smooth normals, when the exporter has them.
    pub fn smooth(&self) -> Option<&SmoothNormals<'a>> {
        self.smooth.as_ref()
    }

    /// The shared vertices and smooth normals, mutably ([`SmoothNormals::refresh`]).
    pub fn smooth_mut(&mut self) -> Option<&mut SmoothNormals<'a>> {
        self.smooth.as_mut()
    }

    /// Triangle slots.
    pub fn capacity(&self) -> usize {
        self.slots.len()
    }

    /// Live slots: the visible faces in the buffers.
    pub fn live(&self) -> u32 {
        self.live
    }

    /// The coarse tet whose face slot `s` holds, `None` when the slot is free.
    pub fn slot_tet(&self, s: u32) -> Option<TetId> {
        let r = self.slots.get(s as usize)?;
        (r.tet != u32::MAX).then_some(TetId(r.tet))
    }

    /// The slots of coarse tet `t`, in the order [`Hierarchy::for_each_visible_in`] lists its
    /// faces (as they were when the tet was last listed again).
    ///
    /// # Bounded work
    /// O(1) an item.
    pub fn tet_slots(&self, t: TetId) -> impl Iterator<Item = u32> + '_ {
        let rec = self.tets.get(t.idx()).copied().unwrap_or(TetRecord::EMPTY);
        let first = (rec.head != NO).then_some(rec.head);
        core::iter::successors(first, move |&s| {
            let next = self.slots.get(s as usize).map_or(NO, |r| r.next);
            (next != NO).then_some(next)
        })
        .take(rec.slots as usize)
    }

    /// Starts over on `hier` in the same storage, as [`SurfaceExport::new`] (and
    /// [`SmoothNormals::new`], with the same crease angle) would: every slot free, every face
    /// listed again. The caller zeroes its buffers (slots that were live need not be written
    /// again).
    ///
    /// # Bounded work
    /// O(slots + tets), and the smooth normals' storage.
    ///
    /// # Errors
    /// [`SurfaceError::Storage`] when `hier` has more trees than the exporter was made for
    /// (nothing changed).
    pub fn reset(&mut self, hier: &Hierarchy<'_>) -> Result<(), SurfaceError> {
        if hier.tet_count() > self.tets.len() {
            return Err(SurfaceError::Storage);
        }
        self.slots.fill(SlotRecord::FREE);
        self.tets.fill(TetRecord::EMPTY);
        self.fresh = 0;
        self.free = NO;
        self.live = 0;
        self.cursor = hier.change_count();
        self.seen_all = hier.all_changed_at();
        self.sweep = Some(Sweep {
            next: 0,
            resume: hier.change_count(),
            rewrite: true,
        });
        self.short = false;
        if let Some(sm) = self.smooth.as_mut() {
            sm.reset();
        }
        Ok(())
    }

    /// Brings the buffers a step closer to the visible faces of `hier` over `mesh` (the ones
    /// the exporter was made for), `label` giving each coarse tet's label, for at most about
    /// `budget` work units; `out.ranges` receives the ranges of slots written. The buffers
    /// are the same from call to call and nothing else writes them: the exporter compares
    /// faces with what it wrote before, not with the buffers.
    ///
    /// # Bounded work
    /// A call starts a coarse tet only while its work is below `budget`, and finishes the tet
    /// it started, so its work is below `budget` plus one tet's (1 + the tet's faces + the
    /// slots it frees); a work unit is a change log entry read, a tet swept, a face listed or
    /// a slot freed, each O(1) but the listing, which walks the tet's tree (O(depth) a face).
    /// What is left is done by the next calls ([`ExportReport::pending`]).
    ///
    /// # Errors
    /// [`SurfaceError::Buffers`] when a buffer holds fewer than three entries a slot or
    /// `out.ranges` is empty (nothing changed).
    pub fn update(
        &mut self,
        hier: &Hierarchy<'_>,
        mesh: &Mesh<'_>,
        mut label: impl FnMut(TetId) -> i32,
        budget: u32,
        out: &mut SurfaceBuffers<'_>,
    ) -> Result<ExportReport, SurfaceError> {
        let need = 3 * self.slots.len();
        if out.positions.len() < need
            || out.normals.len() < need
            || out.labels.len() < need
            || out.indices.len() < need
            || out.ranges.is_empty()
        {
            return Err(SurfaceError::Buffers);
        }
        let mut o = Out {
            bufs: out,
            ranges: 0,
            merged: false,
            written: 0,
        };
        let mut rep = ExportReport::default();
        if hier.all_changed_at() > self.seen_all {
            // The nodes moved (or the trees were reset): every face again, positions too.
            self.seen_all = hier.all_changed_at();
            self.start_sweep(hier, true);
        }
        while rep.work < budget {
            if let Some(sw) = self.sweep {
                let t = sw.next;
                if t as usize >= self.tets.len() {
                    self.sweep = None;
                    self.cursor = sw.resume;
                    continue;
                }
                self.sweep = Some(Sweep { next: t + 1, ..sw });
                rep.work = rep.work.saturating_add(1);
                self.relist(
                    hier,
                    mesh,
                    TetId(t),
                    sw.rewrite,
                    &mut label,
                    &mut o,
                    &mut rep,
                );
                continue;
            }
            match hier.change_at(self.cursor) {
                Change::End => {
                    if !self.short {
                        break;
                    }
                    // Faces were left out for want of a slot: try them all again.
                    self.start_sweep(hier, false);
                }
                Change::Lost => self.start_sweep(hier, false),
                Change::Tet(t) => {
                    let seq = self.cursor;
                    self.cursor += 1;
                    rep.work = rep.work.saturating_add(1);
                    let done = self.tets.get(t.idx()).map_or(u64::MAX, |r| r.done_at);
                    // Listed again since this entry was written: up to date already.
                    if done <= seq {
                        self.relist(hier, mesh, t, false, &mut label, &mut o, &mut rep);
                    }
                }
            }
        }
        if let Some(sm) = self.smooth.as_mut() {
            let mut work = rep.work;
            sm.flush(&mut work, budget, |s, k, n| {
                if let Some(q) = o.bufs.normals.get_mut(3 * s as usize + k) {
                    *q = n.to_array();
                }
                o.mark(s);
            });
            rep.work = work;
        }
        rep.written = o.written;
        rep.ranges = o.ranges as u32;
        rep.ranges_merged = o.merged;
        rep.pending = self.pending(hier);
        rep.live = self.live;
        rep.used = self.fresh;
        Ok(rep)
    }

    /// Work left: change log entries unread and tets left to sweep, and every tet again when
    /// a sweep is to come for faces left out.
    fn pending(&self, hier: &Hierarchy<'_>) -> u32 {
        let tets = self.tets.len() as u64;
        let left = match self.sweep {
            Some(sw) => (tets - (sw.next as u64).min(tets)) + (hier.change_count() - sw.resume),
            None => hier.change_count().saturating_sub(self.cursor),
        };
        let again = if self.short { tets.max(1) } else { 0 };
        let smooth = self.smooth.as_ref().map_or(0, |s| u64::from(s.pending()));
        (left + again + smooth).min(u32::MAX as u64) as u32
    }

    fn start_sweep(&mut self, hier: &Hierarchy<'_>, rewrite: bool) {
        self.short = false;
        self.sweep = Some(Sweep {
            next: 0,
            resume: hier.change_count(),
            rewrite,
        });
    }

    /// Takes a free slot: a freed one first, then a fresh one.
    fn take(&mut self) -> Option<u32> {
        if let Some(r) = self.slots.get(self.free as usize) {
            let s = self.free;
            self.free = r.next;
            return Some(s);
        }
        if (self.fresh as usize) < self.slots.len() {
            self.fresh += 1;
            return Some(self.fresh - 1);
        }
        None
    }

    /// Lists the faces of tet `t` again into its slots. The tet's chain is in listing order,
    /// so the old chain and the new listing are merged: a slot whose face is listed again
    /// keeps it (and is not written unless `rewrite`), a new face takes the slot of a face
    /// that went, else a free one; the slots left over are freed.
    #[allow(clippy::too_many_arguments)]
    fn relist(
        &mut self,
        hier: &Hierarchy<'_>,
        mesh: &Mesh<'_>,
        t: TetId,
        rewrite: bool,
        label: &mut impl FnMut(TetId) -> i32,
        o: &mut Out<'_, '_>,
        rep: &mut ExportReport,
    ) {
        let Some(rec) = self.tets.get(t.idx()).copied() else {
            return;
        };
        rep.tets += 1;
        let lab = label(t);
        let mut old = rec.head;
        // Slots of faces that went, for the new faces (a list through `next`).
        let mut spare = NO;
        let (mut head, mut tail, mut count) = (NO, NO, 0u32);
        hier.for_each_visible_in(mesh, &[t], None, |vt| {
            rep.work = rep.work.saturating_add(1);
            let key = walk_key(vt.index, vt.face);
            // The old faces listed before this one are gone.
            let mut kept = None;
            while let Some(r) = self.slots.get_mut(old as usize) {
                let k = walk_key(r.index, r.face as u8);
                if k > key {
                    break;
                }
                let s = old;
                old = r.next;
                if k == key {
                    kept = Some(s);
                    break;
                }
                r.next = spare;
                spare = s;
                rep.work = rep.work.saturating_add(1);
            }
            let (s, same) = if let Some(s) = kept {
                (s, !rewrite)
            } else if let Some(r) = self.slots.get(spare as usize) {
                let s = spare;
                spare = r.next;
                (s, false)
            } else if let Some(s) = self.take() {
                self.live += 1;
                (s, false)
            } else {
                rep.dropped += 1;
                self.short = true;
                return;
            };
            let Some(slot) = self.slots.get_mut(s as usize) else {
                return;
            };
            *slot = SlotRecord {
                tet: t.0,
                index: vt.index,
                face: vt.face as u32,
                next: NO,
            };
            if !same {
                o.put(s, vt.corners, lab);
                if let Some(sm) = self.smooth.as_mut() {
                    let [a, b, c] = vt.corners;
                    let n = (b - a).cross(c - a).normalize_or_zero();
                    let (keys, drilled) = face_keys(mesh, t, vt.index, vt.face, &vt.corners);
                    let w = sm.set_face(s, &keys, n, drilled);
                    rep.work = rep.work.saturating_add(w);
                }
            }
            match self.slots.get_mut(tail as usize) {
                Some(prev) => prev.next = s,
                None => head = s,
            }
            tail = s;
            count += 1;
        });
        // The faces after the last one listed are gone too.
        while let Some(r) = self.slots.get_mut(old as usize) {
            let s = old;
            old = r.next;
            r.next = spare;
            spare = s;
            rep.work = rep.work.saturating_add(1);
        }
        // The slots the tet no longer needs.
        while let Some(r) = self.slots.get_mut(spare as usize) {
            let s = spare;
            spare = r.next;
            *r = SlotRecord {
                next: self.free,
                ..SlotRecord::FREE
            };
            self.free = s;
            self.live = self.live.saturating_sub(1);
            o.clear(s);
            if let Some(sm) = self.smooth.as_mut() {
                let w = sm.unset_face(s);
                rep.work = rep.work.saturating_add(w);
            }
        }
        if let Some(r) = self.tets.get_mut(t.idx()) {
            *r = TetRecord {
                head,
                slots: count,
                done_at: hier.change_count(),
            };
        }
    }
}
