//! A soft body coupled to a deformable world with its step spread over servo ticks (the core's
//! `soft::Link`): every tick does the same bounded share of the body's step and of the world's
//! update, and the world takes the new positions at the cycle's last tick. This is how a board
//! whose tick cannot hold a whole step (or a host that wants each tick's work known) drives
//! soft tissue; `td_soft_step` with `td_world_set_positions` is the whole step at once.
//!
//! The memory holds a [`LinkState`] (the core's `Link`, the handles it was made for), then the
//! link's three per-node buffers (two loads, the next positions), each at its type's alignment.

use core::alloc::Layout;
use core::mem::size_of;

use tetradrill_core::servo::DeformError;
use tetradrill_core::soft::{Link, LinkBuffers, LinkError, StepError};

use super::*;
use crate::soft::{soft_state, TdSoft};
use crate::types::TdDeformReport;

/// Marks a [`LinkState`] that `td_link_init` finished ("tdlink01").
const LINK_MAGIC: u64 = u64::from_le_bytes(*b"tdlink01");

/// A soft body's step spread over servo ticks, set up by `td_link_init` in caller memory.
/// Opaque: C holds a pointer to it (the start of the memory it gave) and never reads it.
#[derive(Debug)]
pub struct TdLink {
    _opaque: [u8; 0],
}

/// What one `td_link_tick` did.
#[repr(C)]
#[derive(Clone, Copy, PartialEq, Debug, Default)]
pub struct TdLinkReport {
    /// Work units done this tick (one unit is about 37 Cortex-M4 instructions): by each tick
    /// of a cycle but its last, the shares of its ticks so far less under one tet solve's
    /// (18 units); the last tick finishes the cycle.
    pub units: u32,
    /// 1 on a cycle's last tick: the world took the body's new positions (`report` says what
    /// the update did); else 0.
    pub committed: u32,
    /// The world's update on a cycle's last tick (all zero on the others).
    pub report: TdDeformReport,
}

/// A link's settings and what it has done.
#[repr(C)]
#[derive(Clone, Copy, PartialEq, Debug, Default)]
pub struct TdLinkCounts {
    /// Ticks a cycle (one body step a cycle).
    pub ticks: u32,
    /// Work units a tick: the cycle's units spread evenly.
    pub units_per_tick: u32,
    /// Work units of one cycle (the commit aside).
    pub cycle_units: u64,
    /// Steps committed to the world.
    pub steps: u32,
    /// Cycles whose work was not done by their last tick and was finished there (0 with the
    /// units a tick `td_link_init` computed: a check).
    pub late: u32,
    /// The largest distance of a node from rest the world has taken so far, mesh units.
    pub max_displacement: f32,
}

/// The head of a link's memory.
#[derive(Debug)]
#[repr(C)]
struct LinkState {
    /// [`LINK_MAGIC`] once set up; zero while `td_link_init` works on the memory.
    magic: u64,
    /// The core's link.
    link: Link,
    /// The address of the world it was made for.
    world: usize,
    /// The address of the soft body it was made for.
    soft: usize,
    /// The first load buffer.
    a: &'static mut [Vec3],
    /// The second load buffer.
    b: &'static mut [Vec3],
    /// The next positions.
    next: &'static mut [Vec3],
}

marked!(LinkState, LINK_MAGIC);

/// Where each part of a link's memory starts, and the whole's size and alignment.
struct LinkPlan {
    size: usize,
    align: usize,
    a: usize,
    b: usize,
    next: usize,
}

impl LinkPlan {
    /// The plan for a body of `nodes` nodes: `TdErrParams` for zero or above `TD_MAX_COUNT`.
    fn of(nodes: u32) -> Result<Self, TdStatus> {
        if nodes == 0 || nodes > TD_MAX_COUNT {
            return Err(TdStatus::TdErrParams);
        }
        let n = nodes as usize;
        let mut all = Layout::new::<LinkState>();
        let mut at = || {
            let (grown, offset) = Layout::array::<Vec3>(n)
                .and_then(|p| all.extend(p))
                .map_err(|_| TdStatus::TdErrParams)?;
            all = grown;
            Ok::<usize, TdStatus>(offset)
        };
        let (a, b, next) = (at()?, at()?, at()?);
        let all = all.pad_to_align();
        Ok(Self {
            size: all.size(),
            align: all.align(),
            a,
            b,
            next,
        })
    }
}

/// The link behind a handle ([`marked_mut`]).
///
/// # Safety
/// As [`marked_mut`], for memory `td_link_init` was given.
unsafe fn link_state<'a>(l: *mut TdLink) -> Result<&'a mut LinkState, TdStatus> {
    // SAFETY: the caller's contract.
    unsafe { marked_mut(l.cast::<LinkState>()) }
}

/// The status of a link's refusal.
fn link_status(e: LinkError) -> TdStatus {
    match e {
        LinkError::NoSpare => TdStatus::TdErrRigid,
        LinkError::Step(StepError::InProgress) => TdStatus::TdErrBusy,
        LinkError::Deform(DeformError::NotFinite { .. }) | LinkError::Step(_) => {
            TdStatus::TdErrInput
        }
        LinkError::Deform(_) => TdStatus::TdErrWorld,
        _ => TdStatus::TdErrParams,
    }
}

/// Writes the bytes (`*out_size`) and the alignment (`*out_align`) a link for a body of
/// `node_count` nodes needs: the link and three vectors a node. Allocate at least that many
/// bytes at that alignment for `td_link_init`.
///
/// # Bounded work
/// Constant.
///
/// # Errors
/// `TD_ERR_NULL` / `TD_ERR_ALIGN` for a pointer; `TD_ERR_PARAMS` for a count of zero or above
/// `TD_MAX_COUNT`.
///
/// # Safety
/// `out_size` and `out_align` point at writable `size_t`s.
#[no_mangle]
pub unsafe extern "C" fn td_link_size(
    node_count: u32,
    out_size: *mut usize,
    out_align: *mut usize,
) -> TdStatus {
    // SAFETY: the caller's contract on the outputs (`sized` checks them).
    unsafe {
        sized(out_size, out_align, || {
            let plan = LinkPlan::of(node_count)?;
            Ok((plan.size, plan.align))
        })
    }
}

/// Sets up in `mem` (`len` bytes at the alignment `td_link_size` gave) a link that steps
/// `soft` by `dt` every `ticks` servo ticks and moves `world` to its positions, its work spread
/// evenly over each cycle of `ticks` ticks (`td_link_counters` gives the units a tick), and
/// writes its handle to `*out`. The world must be deformable (`td_params.deformable`) and built
/// from the same nodes as the body (its tets may be in any order). The units a tick are
/// computed here, once, from the body's and the world's sizes.
///
/// A cycle holds the body and the world from its first `td_link_tick` to its last (the
/// commit): meanwhile `td_soft_step`, `td_soft_set_fixed`, `td_soft_fix_below`,
/// `td_world_set_positions`, another link's `td_link_tick` and a `td_link_init` on either are
/// `TD_ERR_BUSY`. Between cycles they are the caller's again (a body stepped or a world moved
/// then is overtaken by the next commit).
///
/// # Bounded work
/// O(nodes) (the buffers cleared).
///
/// # Errors
/// `TD_ERR_NULL` / `TD_ERR_ALIGN` for a pointer, `TD_ERR_NOT_INIT` for a world or body not set
/// up, `TD_ERR_RIGID` for a rigid world, `TD_ERR_PARAMS` for `ticks` of zero, a `dt` that is
/// not finite and positive, a body and world of different node counts, or `mem` overlapping
/// the world's or the body's header, `TD_ERR_BUSY` for a body or world a link's cycle holds,
/// `TD_ERR_TOO_SMALL` for `len`. On an error after the checks of `mem` (null, alignment,
/// length, overlap) the memory holds no link: a handle to it is refused until an init
/// succeeds.
///
/// # Safety
/// `mem` points at `len` writable bytes the caller keeps, untouched, for as long as it uses
/// the link, apart from the world's and the body's memory; `world` and `soft` are handles from
/// `td_world_init` and `td_soft_init`; `out` points at a writable pointer.
#[no_mangle]
pub unsafe extern "C" fn td_link_init(
    mem: *mut c_void,
    len: usize,
    world: *mut TdWorld,
    soft: *mut TdSoft,
    ticks: u32,
    dt: f32,
    out: *mut *mut TdLink,
) -> TdStatus {
    status(|| {
        check_ptr(out)?;
        // SAFETY: the caller's contract on both handles (each lookup checks its own).
        let (st, body) = unsafe { (state(world)?, soft_state(soft)?) };
        let n = body.body.node_count();
        let plan = LinkPlan::of(u32::try_from(n).map_err(|_| TdStatus::TdErrParams)?)?;
        let base = caller_memory(mem, len, plan.size, plan.align)?;
        // The link's memory apart from the two headers it borrows (a C caller passing a handle
        // as `mem` would have the init write over a header in use).
        let apart = |h: usize, n: usize| {
            let (m, end) = (base as usize, (base as usize).saturating_add(plan.size));
            end <= h || h.saturating_add(n) <= m
        };
        if !(apart(world as usize, size_of::<State>())
            && apart(soft as usize, size_of::<crate::soft::SoftState>()))
        {
            return Err(TdStatus::TdErrParams);
        }
        let head = base.cast::<LinkState>();
        // SAFETY: `mem` is aligned for LinkState and at least `plan.size` bytes long: a handle
        // to this memory is refused from here on until the init succeeds.
        unsafe { ptr::addr_of_mut!((*head).magic).write(0) };
        if !st.deformable {
            return Err(TdStatus::TdErrRigid);
        }
        if st.link_cycle != 0 || body.link_cycle != 0 || body.body.stepping() {
            return Err(TdStatus::TdErrBusy);
        }
        let link = Link::new(&body.body, &st.world, ticks, dt).map_err(link_status)?;
        // SAFETY: every offset comes from the plan, which places each buffer after the header
        // at its alignment, apart from the others, inside `plan.size <= len` bytes of `mem`;
        // the caller keeps `mem` for as long as the link is used.
        let (a, b, next) = unsafe {
            (
                carve(base, plan.a, n, Vec3::ZERO),
                carve(base, plan.b, n, Vec3::ZERO),
                carve(base, plan.next, n, Vec3::ZERO),
            )
        };
        // SAFETY: the header's region is `mem`'s start, aligned and inside it (above); its
        // magic is zero, so no handle reads it while it is written; the magic goes last.
        unsafe {
            ptr::addr_of_mut!((*head).link).write(link);
            ptr::addr_of_mut!((*head).world).write(world as usize);
            ptr::addr_of_mut!((*head).soft).write(soft as usize);
            ptr::addr_of_mut!((*head).a).write(a);
            ptr::addr_of_mut!((*head).b).write(b);
            ptr::addr_of_mut!((*head).next).write(next);
            ptr::addr_of_mut!((*head).magic).write(LINK_MAGIC);
            out.write(head.cast::<TdLink>());
        }
        Ok(())
    })
}

/// One servo tick of the link, after the world's simulation step of that tick
/// (`td_world_simulate` or `td_world_tick`), `force` being the force the servo gave the hand
/// that tick: at a cycle's first tick the body's step begins, loaded with the mean reaction of
/// the cycle before; the tool's reaction (`-force` at the world's contact point, spread over its
/// contact tet's corners) is gathered for the next step; this tick's share of the step and of
/// the world's update is done; at the cycle's last tick the world takes the new positions. So
/// the world shows a reaction between one and two cycles later. `*out`, when not null, gets
/// what the tick did. Call it from the thread that runs the simulation steps (the servo's force
/// call may run beside it, as beside `td_world_set_positions`).
///
/// # Bounded work
/// At most `units_per_tick` units plus less than one piece's units (a tet solve, 18) carried
/// from the tick before (about 37 Cortex-M4 instructions a unit), and in the hash's rebuild the
/// cells of one tet's box; on a cycle's last tick what is left of the cycle and the commit:
/// O(nodes + the contact memo's slots).
///
/// # Errors
/// `TD_ERR_NULL` / `TD_ERR_ALIGN` for a pointer, `TD_ERR_NOT_INIT` for a handle not set up,
/// `TD_ERR_PARAMS` for a world or body other than the ones `td_link_init` was given,
/// `TD_ERR_INPUT` for a force that is not finite (nothing done) or positions the physics made
/// non-finite, `TD_ERR_BUSY` for a body or world another link's cycle holds (nothing done).
///
/// # Safety
/// `link`, `world` and `soft` are handles from `td_link_init`, `td_world_init` and
/// `td_soft_init` whose memory is still the caller's; `out` is null or points at a writable
/// `td_link_report`.
#[no_mangle]
pub unsafe extern "C" fn td_link_tick(
    link: *mut TdLink,
    world: *mut TdWorld,
    soft: *mut TdSoft,
    force: TdVec3,
    out: *mut TdLinkReport,
) -> TdStatus {
    status(|| {
        if !out.is_null() {
            check_ptr(out)?;
        }
        // SAFETY: the caller's contract on the three handles (each lookup checks its own).
        let (l, st, body) = unsafe { (link_state(link)?, state(world)?, soft_state(soft)?) };
        if l.world != world as usize || l.soft != soft as usize {
            return Err(TdStatus::TdErrParams);
        }
        let me = link as usize;
        if [st.link_cycle, body.link_cycle]
            .iter()
            .any(|&o| o != 0 && o != me)
        {
            return Err(TdStatus::TdErrBusy);
        }
        let f = pose(force)?;
        let buffers = LinkBuffers {
            a: l.a,
            b: l.b,
            next: l.next,
        };
        let done = l
            .link
            .tick(&mut body.body, &mut st.world, buffers, f)
            .map_err(link_status)?;
        // The cycle holds the body and the world until its commit.
        let holder = if done.committed.is_some() { 0 } else { me };
        (st.link_cycle, body.link_cycle) = (holder, holder);
        let mut t = TdLinkReport {
            units: done.units,
            ..TdLinkReport::default()
        };
        if let Some(rep) = done.committed {
            body.steps += 1;
            body.time += f64::from(l.link.ticks()) * f64::from(l.link.dt());
            t.committed = 1;
            t.report = TdDeformReport {
                max_displacement: rep.max_displacement,
                hash_entries: rep.hash_entries,
                hash_saturated: u32::from(rep.hash_saturated),
                kept: rep.kept,
            };
        }
        if out.is_null() {
            return Ok(());
        }
        // SAFETY: checked above; the caller's contract makes it writable.
        unsafe { put(out, t) }
    })
}

/// Writes the link's settings and counts.
///
/// # Bounded work
/// Constant.
///
/// # Errors
/// `TD_ERR_NULL` / `TD_ERR_ALIGN` for a pointer, `TD_ERR_NOT_INIT` for a link not set up.
///
/// # Safety
/// `link` is a handle from `td_link_init`, not in a `td_link_tick` meanwhile; `out` points at
/// a writable `td_link_counts`.
#[no_mangle]
pub unsafe extern "C" fn td_link_counters(link: *mut TdLink, out: *mut TdLinkCounts) -> TdStatus {
    status(|| {
        // SAFETY: the caller's contract on `link`.
        let l = unsafe { link_state(link) }?;
        let k = &l.link;
        let c = TdLinkCounts {
            ticks: k.ticks(),
            units_per_tick: k.units_per_tick(),
            cycle_units: k.cycle_units(),
            steps: k.steps(),
            late: k.late(),
            max_displacement: k.max_displacement(),
        };
        // SAFETY: the caller's contract on `out`; `put` checks null and alignment.
        unsafe { put(out, c) }
    })
}
