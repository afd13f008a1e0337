//! The drilled surface through the C interface: a surface object in the caller's memory that
//! keeps the visible faces in the caller's vertex, normal, label and index buffers, writing
//! only what changed and saying which slot ranges it wrote (the core's `SurfaceExport`); and
//! the erasure of the drilled material's debris that `tetradrill replay` runs before it
//! writes its surface.

use core::mem::{align_of, size_of};

use tetradrill_core::hierarchy::{
    SlotRange, SmoothNormals, SmoothSizes, SmoothStorage, SurfaceBuffers, SurfaceExport,
    SurfaceSizes, SurfaceStorage, DEBRIS_LEAVES,
};
use tetradrill_core::storage::LINE;
use tetradrill_core::TetId;

use super::*;

/// Marks a surface that `td_surface_init` finished ("tdsurfc1").
const SURFACE_MAGIC: u64 = u64::from_le_bytes(*b"tdsurfc1");

/// The most triangle slots a surface has: every vertex index fits a `uint32_t`
/// (`UINT32_MAX / 3`).
pub const TD_MAX_TRIANGLES: u32 = 1_431_655_765;

const _: () = assert!(TD_MAX_TRIANGLES as usize == SurfaceExport::MAX_SLOTS);

/// A surface set up by `td_surface_init` in caller memory. Opaque: C holds a pointer to it
/// (the start of the memory it gave) and never reads it.
#[derive(Debug)]
pub struct TdSurface {
    _opaque: [u8; 0],
}

/// A run of triangle slots a `td_surface_update` wrote: `count` slots from `first` (vertices
/// `3 * first` to `3 * (first + count) - 1` of every buffer).
#[repr(C)]
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default)]
pub struct TdSlotRange {
    /// First slot.
    pub first: u32,
    /// Slots.
    pub count: u32,
}

// The C ranges are the core's, field for field.
const _: () = assert!(size_of::<TdSlotRange>() == size_of::<SlotRange>());
const _: () = assert!(align_of::<TdSlotRange>() == align_of::<SlotRange>());

/// The caller's buffers for `td_surface_update`, each sized for the surface's
/// `max_triangles` (`n`): triangle slot `s` is vertices `3 s`, `3 s + 1`, `3 s + 2`.
///
/// A live slot holds its face's corners (counter-clockwise seen from outside the material),
/// the face's outward unit normal on each vertex, its coarse tet's region label on each, and
/// the indices `3 s`, `3 s + 1`, `3 s + 2`. A free slot is zero in every buffer (indices
/// `0, 0, 0`: a degenerate triangle), so buffers that start zeroed are an empty surface.
#[repr(C)]
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct TdSurfaceBuffers {
    /// `9 n` floats: x, y, z of each vertex.
    pub positions: *mut f32,
    /// `9 n` floats: the vertex normals.
    pub normals: *mut f32,
    /// `3 n` region labels, one a vertex.
    pub labels: *mut i32,
    /// `3 n` vertex indices, three a triangle.
    pub indices: *mut u32,
    /// `range_capacity` entries: the slot ranges a call wrote.
    pub ranges: *mut TdSlotRange,
    /// Entries of `ranges`, at least 1. When a call writes more separate runs, its last entry
    /// is widened to cover the rest (`ranges_merged`).
    pub range_capacity: u32,
}

/// What one `td_surface_update` did.
#[repr(C)]
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default)]
pub struct TdSurfaceReport {
    /// Work units spent (a change read, a coarse tet swept, a face listed, a slot freed).
    pub work: u32,
    /// Coarse tets whose faces were listed again.
    pub tets: u32,
    /// Slots written (a face put in, or freed).
    pub written: u32,
    /// Entries of `ranges` filled: upload those slots of every buffer.
    pub ranges: u32,
    /// 1 when the range list filled up and its last entry covers every later slot written.
    pub ranges_merged: u32,
    /// Faces left out for want of a free slot (`max_triangles` too small); they are placed
    /// as slots free up.
    pub dropped: u32,
    /// Work still to do; 0: the buffers hold the drilled surface exactly.
    pub pending: u32,
    /// Live slots (visible faces in the buffers).
    pub live: u32,
    /// Slots ever used: every live slot is below it (draw this many triangles).
    pub used: u32,
}

/// The head of a surface's memory: the core's exporter over the lines after it.
#[derive(Debug)]
#[repr(C)]
struct SurfaceState {
    /// [`SURFACE_MAGIC`] once set up.
    magic: u64,
    /// The address of the world it was made for.
    world: usize,
    /// The surface memory's first and last byte + 1.
    span: (usize, usize),
    export: SurfaceExport<'static>,
}

marked!(SurfaceState, SURFACE_MAGIC);

/// A surface's layout: its bytes, the offset of its lines, the exporter's sizes and lines,
/// and (`smooth`) the smooth normals' sizes, whose lines follow the exporter's.
struct Plan {
    size: usize,
    head: usize,
    sizes: SurfaceSizes,
    lines: usize,
    smooth: Option<SmoothSizes>,
}

/// The layout of a surface of `max_triangles` slots over `tets` coarse tets, with smooth
/// normals when `smooth`.
fn surface_plan(tets: usize, max_triangles: u32, smooth: bool) -> Result<Plan, TdStatus> {
    if max_triangles == 0 || max_triangles > TD_MAX_TRIANGLES {
        return Err(TdStatus::TdErrParams);
    }
    let sizes = SurfaceSizes::new(max_triangles as usize, tets);
    let lines = sizes.lines().ok_or(TdStatus::TdErrParams)?;
    let smooth = smooth.then(|| SmoothSizes::for_slots(max_triangles as usize));
    let extra = match &smooth {
        Some(z) => z.lines().ok_or(TdStatus::TdErrParams)?,
        None => 0,
    };
    let head = size_of::<SurfaceState>().div_ceil(LINE) * LINE;
    let size = lines
        .checked_add(extra)
        .and_then(|l| l.checked_mul(LINE))
        .and_then(|b| b.checked_add(head))
        .ok_or(TdStatus::TdErrParams)?;
    Ok(Plan {
        size,
        head,
        sizes,
        lines,
        smooth,
    })
}

/// The alignment of a surface's memory: a line (the core's parts each start on one).
const SURFACE_ALIGN: usize = if align_of::<SurfaceState>() > LINE {
    align_of::<SurfaceState>()
} else {
    LINE
};

/// The surface behind a handle ([`marked_mut`]).
///
/// # Safety
/// As [`marked_mut`], for memory `td_surface_init` was given.
unsafe fn surface_state<'a>(s: *mut TdSurface) -> Result<&'a mut SurfaceState, TdStatus> {
    // SAFETY: the caller's contract.
    unsafe { marked_mut(s.cast::<SurfaceState>()) }
}

/// Writes the bytes (`*out_size`) and the alignment (`*out_align`, 64) a surface of
/// `max_triangles` triangle slots over `world` needs: 16 bytes a slot and 16 a coarse tet,
/// plus a header. The caller's buffers for it are separate (`td_surface_buffers`).
///
/// # Bounded work
/// Constant.
///
/// # Errors
/// `TD_ERR_NULL` / `TD_ERR_ALIGN` for a pointer, `TD_ERR_NOT_INIT` for a world not set up,
/// `TD_ERR_PARAMS` for `max_triangles` 0 or above `TD_MAX_TRIANGLES`, or a size beyond the
/// address space.
///
/// # Safety
/// `world` is a handle from `td_world_init` whose memory is still the caller's; `out_size`
/// and `out_align` point at writable `size_t`s.
#[no_mangle]
pub unsafe extern "C" fn td_surface_size(
    world: *mut TdWorld,
    max_triangles: u32,
    out_size: *mut usize,
    out_align: *mut usize,
) -> TdStatus {
    // SAFETY: the caller's contract on the outputs and on `world` (`state` checks it).
    unsafe {
        sized(out_size, out_align, || {
            let st = state(world)?;
            let plan = surface_plan(st.world.mesh().tet_count(), max_triangles, false)?;
            Ok((plan.size, SURFACE_ALIGN))
        })
    }
}

/// Sets up a surface of `max_triangles` triangle slots for `world` in `mem` (`len` bytes,
/// aligned as `td_surface_size` says) and writes its handle to `*out` (it is `mem`). It
/// starts with every slot free and the whole drilled surface to write: the first
/// `td_surface_update` calls write it, as the buffers are to start zeroed.
///
/// # Bounded work
/// O(`max_triangles` + T) to initialise the memory, for T coarse tets.
///
/// # Errors
/// `TD_ERR_NULL` / `TD_ERR_ALIGN` for a pointer, `TD_ERR_NOT_INIT` for a world not set up,
/// `TD_ERR_PARAMS` as `td_surface_size`, `TD_ERR_TOO_SMALL` when `len` is short. After an
/// error the memory is no surface until a successful init.
///
/// # Safety
/// `world` is a handle from `td_world_init` whose memory is still the caller's; `mem` points
/// at `len` writable bytes that the caller does not otherwise use (and that are not the
/// world's) for as long as it uses the surface (there is nothing to free); `out` at a
/// writable `td_surface *`.
#[no_mangle]
pub unsafe extern "C" fn td_surface_init(
    mem: *mut c_void,
    len: usize,
    world: *mut TdWorld,
    max_triangles: u32,
    out: *mut *mut TdSurface,
) -> TdStatus {
    // SAFETY: the caller's contract, as `surface_init` states it.
    status(|| unsafe { surface_init(mem, len, world, max_triangles, None, out) })
}

/// Writes the bytes (`*out_size`) and the alignment (`*out_align`, 64) a surface with smooth
/// normals (`td_surface_init_smooth`) of `max_triangles` slots over `world` needs: what
/// `td_surface_size` says plus 121 to 129 bytes a slot (its smooth record, a shared vertex
/// and its hash table entries, an eighth of a queue entry).
///
/// # Bounded work
/// Constant.
///
/// # Errors
/// As `td_surface_size`.
///
/// # Safety
/// As `td_surface_size`.
#[no_mangle]
pub unsafe extern "C" fn td_surface_smooth_size(
    world: *mut TdWorld,
    max_triangles: u32,
    out_size: *mut usize,
    out_align: *mut usize,
) -> TdStatus {
    // SAFETY: the caller's contract on the outputs and on `world` (`state` checks it).
    unsafe {
        sized(out_size, out_align, || {
            let st = state(world)?;
            let plan = surface_plan(st.world.mesh().tet_count(), max_triangles, true)?;
            Ok((plan.size, SURFACE_ALIGN))
        })
    }
}

/// Sets up a surface as `td_surface_init` does, in memory sized by `td_surface_smooth_size`,
/// whose `td_surface_update` writes each corner's smooth normal into the normals buffer
/// rather than its face's: corners share vertices by their exact subdivision-lattice keys, a
/// drilled corner's normal is a three-ring average over the drilled faces, a corner on the
/// mesh's own boundary averages the boundary faces within `crease_degrees` of its face (0 or
/// less: the core's default, 75). `td_surface_smooth_stats` counts what went short. The
/// normals are kept up to date a bounded amount a call, as the faces are (`pending`).
///
/// # Bounded work
/// O(`max_triangles` + T) to initialise the memory, for T coarse tets.
///
/// # Errors
/// As `td_surface_init`, with `td_surface_smooth_size`'s size.
///
/// # Safety
/// As `td_surface_init`.
#[no_mangle]
pub unsafe extern "C" fn td_surface_init_smooth(
    mem: *mut c_void,
    len: usize,
    world: *mut TdWorld,
    max_triangles: u32,
    crease_degrees: f32,
    out: *mut *mut TdSurface,
) -> TdStatus {
    let crease = if crease_degrees > 0.0 {
        crease_degrees
    } else {
        SmoothNormals::CREASE_DEGREES
    };
    // SAFETY: the caller's contract, as `surface_init` states it.
    status(|| unsafe { surface_init(mem, len, world, max_triangles, Some(crease), out) })
}

/// What went short in a surface's smooth normals, counted since its init.
#[repr(C)]
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default)]
pub struct TdSmoothStats {
    /// Live shared vertices.
    pub vertices: u32,
    /// Corners that found no free vertex: such a corner has its face's normal until its face
    /// is listed again.
    pub vertices_full: u32,
    /// Times the queue of vertices to recompute was full: every vertex is then recomputed,
    /// a bounded amount a call.
    pub queue_full: u32,
}

/// Writes the smooth normals' counters of `surface` to `*out` (all zero for a surface made
/// by `td_surface_init`, which has none).
///
/// # Bounded work
/// Constant.
///
/// # Errors
/// `TD_ERR_NULL` / `TD_ERR_ALIGN` for a pointer, `TD_ERR_NOT_INIT` for a surface not set up.
///
/// # Safety
/// `surface` is a handle from `td_surface_init` or `td_surface_init_smooth` whose memory is
/// still the caller's; `out` points at a writable `td_smooth_stats`.
#[no_mangle]
pub unsafe extern "C" fn td_surface_smooth_stats(
    surface: *mut TdSurface,
    out: *mut TdSmoothStats,
) -> TdStatus {
    status(|| {
        check_ptr(out)?;
        // SAFETY: the caller's contract on the handle; it is checked.
        let sf = unsafe { surface_state(surface) }?;
        let st = sf
            .export
            .smooth()
            .map(SmoothNormals::stats)
            .unwrap_or_default();
        let r = TdSmoothStats {
            vertices: st.vertices,
            vertices_full: st.vertices_full,
            queue_full: st.queue_full,
        };
        // SAFETY: checked above; the caller's contract makes it writable.
        unsafe { put(out, r) }
    })
}

/// `td_surface_init` and `td_surface_init_smooth` (`crease`: smooth normals).
///
/// # Safety
/// As `td_surface_init`.
unsafe fn surface_init(
    mem: *mut c_void,
    len: usize,
    world: *mut TdWorld,
    max_triangles: u32,
    crease: Option<f32>,
    out: *mut *mut TdSurface,
) -> Result<(), TdStatus> {
    check_ptr(out)?;
    // SAFETY: the caller's contract on `world`; `state` checks it.
    let st = unsafe { state(world) }?;
    let plan = surface_plan(st.world.mesh().tet_count(), max_triangles, crease.is_some())?;
    let (size, head) = (plan.size, plan.head);
    let base = mem.cast::<u8>();
    if base.is_null() {
        return Err(TdStatus::TdErrNull);
    }
    // A power of two: the mask test is the alignment test.
    if (base as usize) & (SURFACE_ALIGN - 1) != 0 {
        return Err(TdStatus::TdErrAlign);
    }
    if len < size {
        return Err(TdStatus::TdErrTooSmall);
    }
    let state_ptr = base.cast::<SurfaceState>();
    // SAFETY: aligned for the state and at least `size > size_of::<SurfaceState>()`
    // bytes: a handle to this memory is refused from here on until the init succeeds.
    unsafe { ptr::addr_of_mut!((*state_ptr).magic).write(0) };
    // SAFETY: the lines lie after the header, inside `size <= len` bytes of `mem`, which
    // the caller keeps for as long as the surface is used.
    let lines = unsafe { lines_at(base, head, (size - head) / LINE) };
    let (lines, rest) = lines.split_at_mut(plan.lines.min(lines.len()));
    let storage = SurfaceStorage::carve(&plan.sizes, &mut Block::from_lines(lines))
        .map_err(|_| TdStatus::TdErrTooSmall)?;
    let mut export =
        SurfaceExport::new(storage, st.world.hierarchy()).map_err(|_| TdStatus::TdErrParams)?;
    if let (Some(z), Some(crease)) = (&plan.smooth, crease) {
        let sst = SmoothStorage::carve(z, &mut Block::from_lines(rest))
            .map_err(|_| TdStatus::TdErrTooSmall)?;
        let smooth = SmoothNormals::new(sst, crease).map_err(|_| TdStatus::TdErrParams)?;
        export = export
            .with_smooth(smooth)
            .map_err(|_| TdStatus::TdErrParams)?;
    }
    let s = SurfaceState {
        magic: SURFACE_MAGIC,
        world: world as usize,
        span: span(base, size),
        export,
    };
    // SAFETY: aligned, inside `mem` (checked above); the magic goes in last with it.
    unsafe { state_ptr.write(s) };
    // SAFETY: checked above; the caller's contract makes it writable.
    unsafe { put(out, mem.cast::<TdSurface>()) }
}

/// Writes `n` zero lines from `base + offset` on and returns them.
///
/// # Safety
/// `base + offset` is aligned for a line, and `n` lines from there lie inside memory the
/// caller owns for `'static` and nothing else borrows.
unsafe fn lines_at(base: *mut u8, offset: usize, n: usize) -> &'static mut [Line] {
    // SAFETY: inside the caller's memory, aligned (the function's contract).
    let p = unsafe { base.add(offset) }.cast::<Line>();
    for i in 0..n {
        // SAFETY: `i < n`, inside the region.
        unsafe { p.add(i).write(Line::ZERO) };
    }
    // SAFETY: every line was just written; the region is the caller's for `'static` and
    // borrowed by nothing else.
    unsafe { core::slice::from_raw_parts_mut(p, n) }
}

/// The region label of coarse tet `t` of a world: its region's label.
fn label_of(st: &State, t: TetId) -> i32 {
    let region = match &st.unstarted {
        Some(u) => u.of_tet.get(t.idx()).copied().unwrap_or(0),
        None => st.world.regions().map_or(0, |r| r.region_of(t)),
    };
    st.labels.get(region as usize).copied().unwrap_or(0)
}

/// A caller array's bytes as an address range, after the pointer checks.
fn span<T>(p: *const T, n: usize) -> (usize, usize) {
    let start = p as usize;
    (
        start,
        start.saturating_add(n.saturating_mul(size_of::<T>())),
    )
}

/// Brings the caller's buffers a step closer to `world`'s drilled surface, for at most about
/// `budget` work units, and writes what it did to `*out` (`ranges` says which slots of every
/// buffer changed: an engine uploads those). A coarse tet's faces stay in their slots until
/// its faces change; then only its slots are written (a new face takes a free slot, a slot
/// no longer needed is written zero). When `out->pending` is 0 the buffers hold the drilled
/// surface exactly; otherwise later calls finish the work. The buffers are the same from call
/// to call and nothing else writes them.
///
/// Call it from the thread that calls `td_world_simulate` (between steps, never while one
/// runs): it reads the world's hierarchy, which the step changes.
///
/// # Bounded work
/// A call starts a coarse tet's faces only while its work is below `budget`, and finishes the
/// tet: its work is below `budget` plus one tet's (1 + the tet's faces + the slots it frees).
///
/// # Errors
/// `TD_ERR_NULL` / `TD_ERR_ALIGN` for a pointer (the float, label and index arrays at 4
/// bytes), `TD_ERR_NOT_INIT` for a surface or world not set up, `TD_ERR_PARAMS` for a world
/// other than the surface's, a `budget` of 0, a `range_capacity` of 0, or arrays that overlap
/// one another or the surface's memory. An error writes nothing.
///
/// # Safety
/// `surface` and `world` are handles from `td_surface_init` and `td_world_init` whose memory
/// is still the caller's; `buffers` points at a `td_surface_buffers` whose arrays hold the
/// counts it states for the surface's `max_triangles`, writable and used by nothing else
/// during the call; `out` at a writable `td_surface_report`.
#[no_mangle]
pub unsafe extern "C" fn td_surface_update(
    surface: *mut TdSurface,
    world: *mut TdWorld,
    budget: u32,
    buffers: *const TdSurfaceBuffers,
    out: *mut TdSurfaceReport,
) -> TdStatus {
    status(|| {
        check_ptr(out)?;
        // SAFETY: the caller's contracts on the handles; both are checked.
        let (sf, st) = unsafe { (surface_state(surface)?, state(world)?) };
        if sf.world != world as usize || budget == 0 {
            return Err(TdStatus::TdErrParams);
        }
        // SAFETY: the caller's contract on `buffers`; `get` checks null and alignment.
        let b = unsafe { get(buffers) }?;
        check_ptr(b.positions)?;
        check_ptr(b.normals)?;
        check_ptr(b.labels)?;
        check_ptr(b.indices)?;
        check_ptr(b.ranges)?;
        if b.range_capacity == 0 {
            return Err(TdStatus::TdErrParams);
        }
        let verts = 3 * sf.export.capacity();
        let spans = [
            span(b.positions.cast::<[f32; 3]>(), verts),
            span(b.normals.cast::<[f32; 3]>(), verts),
            span(b.labels, verts),
            span(b.indices, verts),
            span(b.ranges, b.range_capacity as usize),
            sf.span,
        ];
        for (i, a) in spans.iter().enumerate() {
            for c in spans.iter().skip(i + 1) {
                if a.0 < c.1 && c.0 < a.1 {
                    return Err(TdStatus::TdErrParams);
                }
            }
        }
        // SAFETY: not null and aligned (checked; `[f32; 3]` and the ranges have the
        // alignment of their fields), of the lengths the caller's contract gives, apart from
        // one another and from the surface (checked), used by nothing else during the call.
        let mut bufs = unsafe {
            SurfaceBuffers {
                positions: core::slice::from_raw_parts_mut(b.positions.cast(), verts),
                normals: core::slice::from_raw_parts_mut(b.normals.cast(), verts),
                labels: core::slice::from_raw_parts_mut(b.labels, verts),
                indices: core::slice::from_raw_parts_mut(b.indices, verts),
                ranges: core::slice::from_raw_parts_mut(
                    b.ranges.cast::<SlotRange>(),
                    b.range_capacity as usize,
                ),
            }
        };
        let st: &State = st;
        let rep = sf
            .export
            .update(
                st.world.hierarchy(),
                st.world.mesh(),
                |t| label_of(st, t),
                budget,
                &mut bufs,
            )
            .map_err(|_| TdStatus::TdErrParams)?;
        let r = TdSurfaceReport {
            work: rep.work,
            tets: rep.tets,
            written: rep.written,
            ranges: rep.ranges,
            ranges_merged: rep.ranges_merged as u32,
            dropped: rep.dropped,
            pending: rep.pending,
            live: rep.live,
            used: rep.used,
        };
        // SAFETY: checked above; the caller's contract makes it writable.
        unsafe { put(out, r) }
    })
}

/// Writes the `uint32_t` scratch entries `td_world_remove_debris` needs now to `*out_len`
/// (two per hierarchy node in use: it grows as the world drills).
///
/// # Bounded work
/// Constant.
///
/// # Errors
/// `TD_ERR_NULL` / `TD_ERR_ALIGN` for a pointer, `TD_ERR_NOT_INIT` for a world not set up.
///
/// # Safety
/// `world` is a handle from `td_world_init` whose memory is still the caller's; `out_len`
/// points at a writable `size_t`.
#[no_mangle]
pub unsafe extern "C" fn td_world_debris_scratch(
    world: *mut TdWorld,
    out_len: *mut usize,
) -> TdStatus {
    status(|| {
        check_ptr(out_len)?;
        // SAFETY: the caller's contract on `world`; `state` checks it.
        let st = unsafe { state(world) }?;
        // SAFETY: checked above; the caller's contract makes it writable.
        unsafe { put(out_len, st.world.hierarchy().debris_scratch_needed()) }
    })
}

/// Erases the debris of the drilled material: the detached pieces smaller than the core's
/// `DEBRIS_LEAVES` leaves of the world's deepest level, as `tetradrill replay` does once its
/// path ends (its `--surface` is the surface after it). `scratch` holds `scratch_len`
/// entries, at least what `td_world_debris_scratch` says; `*out_pieces`, when not null, gets
/// the pieces erased. A surface (`td_surface_update`) then shows the faces that changed.
///
/// # Bounded work
/// O(hierarchy nodes): not for the servo's tick; between steps, at a cadence the caller can
/// afford.
///
/// # Errors
/// `TD_ERR_NULL` / `TD_ERR_ALIGN` for a pointer, `TD_ERR_NOT_INIT` for a world not set up,
/// `TD_ERR_TOO_SMALL` for a scratch shorter than needed (nothing is erased).
///
/// # Safety
/// `world` is a handle from `td_world_init` whose memory is still the caller's; `scratch`
/// points at `scratch_len` writable `uint32_t`s outside the world's memory; `out_pieces` at a
/// writable `uint32_t` or is null.
#[no_mangle]
pub unsafe extern "C" fn td_world_remove_debris(
    world: *mut TdWorld,
    scratch: *mut u32,
    scratch_len: usize,
    out_pieces: *mut u32,
) -> TdStatus {
    status(|| {
        check_ptr(scratch)?;
        if !out_pieces.is_null() {
            check_ptr(out_pieces)?;
        }
        // SAFETY: the caller's contract on `world`; `state` checks it.
        let st = unsafe { state(world) }?;
        if scratch_len < st.world.hierarchy().debris_scratch_needed() {
            return Err(TdStatus::TdErrTooSmall);
        }
        // SAFETY: not null and aligned (checked), `scratch_len` entries outside the world's
        // memory (the caller's contract).
        let scratch = unsafe { core::slice::from_raw_parts_mut(scratch, scratch_len) };
        let depth = st.drill.max_depth;
        let rep = st
            .world
            .remove_debris(DEBRIS_LEAVES, depth, scratch)
            .map_err(|_| TdStatus::TdErrTooSmall)?;
        if !out_pieces.is_null() {
            // SAFETY: checked above; the caller's contract makes it writable.
            unsafe { put(out_pieces, rep.pieces) }?;
        }
        Ok(())
    })
}
