//! Where everything of a world goes in the caller's memory: the [`State`] at the start, then
//! every slice the core borrows, each at its type's alignment. [`Plan::of`] checks the
//! parameters and computes the offsets with checked arithmetic; `td_world_size` reports its
//! total and `td_world_init` carves the memory by it.

use core::alloc::Layout;
use core::mem::size_of;

use tetradrill_core::drill::{DrillParams, Pending};
use tetradrill_core::force::{ForceDigest, ForceParams, ToolState};
use tetradrill_core::hash::{Aabb, HashEntry};
use tetradrill_core::hierarchy::{HNode, SphereSlot, VEntry};
use tetradrill_core::mesh::{FaceKey, Node, Tet};
use tetradrill_core::servo::{World, WorldSizes};
use tetradrill_core::{TetId, Vec3};

use crate::types::{TdParams, TdStatus};

/// Marks a [`State`] that `td_world_init` finished ("tdworld1").
pub const MAGIC: u64 = u64::from_le_bytes(*b"tdworld1");

/// The most nodes or tets a world takes: every size the core derives from the counts (8 hash
/// entries per tet, a v_list of the tets plus 7/8 of the arena) then fits in 32 bits.
pub const TD_MAX_COUNT: u32 = 1 << 28;

/// The head of a world's memory: the core's world (borrowing the slices after it) and what
/// the C calls carry from tick to tick.
#[derive(Debug)]
pub struct State {
    /// [`MAGIC`] once set up; zero while `td_world_init` works on the memory.
    pub magic: u64,
    /// The core's world over the slices that follow this header.
    pub world: World<'static>,
    /// The tool state the servo force carries between ticks.
    pub tool: ToolState,
    /// Digest of the forces returned so far.
    pub digest: ForceDigest,
    /// Burr radius.
    pub radius: f32,
    /// Contact reach beyond the burr.
    pub reach: f32,
    /// Drill settings.
    pub drill: DrillParams,
    /// Force settings.
    pub force: ForceParams,
    /// `td_world_servo_force` calls.
    pub servo_ticks: u64,
    /// `td_world_simulate` calls.
    pub steps: u64,
    /// Servo ticks with a force other than zero.
    pub contact_ticks: u64,
    /// Mesh volume at set-up.
    pub initial_volume: f64,
}

/// Offsets (bytes from the start of the memory) of every slice of a world, its total size
/// and alignment, and the storage sizes they hold.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct Plan {
    /// Node count.
    pub nodes: usize,
    /// Tet count.
    pub tets: usize,
    /// The core's storage sizes.
    pub sizes: WorldSizes,
    /// `Vec3` per node: positions.
    pub positions: usize,
    /// `Vec3` per node: boundary normals.
    pub normals: usize,
    /// `Node` per node.
    pub node_recs: usize,
    /// `Tet` per tet.
    pub tet_recs: usize,
    /// `FaceKey` per tet face: the mesh build's scratch.
    pub scratch: usize,
    /// Hash bucket starts.
    pub hash_starts: usize,
    /// Hash entries.
    pub hash_entries: usize,
    /// Tet boxes.
    pub tet_boxes: usize,
    /// Hierarchy roots.
    pub roots: usize,
    /// Hierarchy arena.
    pub arena: usize,
    /// v_list.
    pub vlist: usize,
    /// Pending drill work.
    pub pending: usize,
    /// Candidate tets.
    pub candidates: usize,
    /// Sphere memo.
    pub memo: usize,
    /// Bytes in all.
    pub size: usize,
    /// Alignment the memory needs.
    pub align: usize,
}

/// Appends arrays to a layout, each at its alignment.
struct Builder {
    layout: Layout,
}

impl Builder {
    /// Appends `n` values of `T`; their offset, or `TdErrParams` when the total would not fit
    /// the address space.
    fn put<T>(&mut self, n: usize) -> Result<usize, TdStatus> {
        let array = Layout::array::<T>(n).map_err(|_| TdStatus::TdErrParams)?;
        let (layout, offset) = self
            .layout
            .extend(array)
            .map_err(|_| TdStatus::TdErrParams)?;
        self.layout = layout;
        Ok(offset)
    }
}

/// `Ok` when `ok`, else `TdErrParams`.
fn check(ok: bool) -> Result<(), TdStatus> {
    if ok {
        Ok(())
    } else {
        Err(TdStatus::TdErrParams)
    }
}

/// `true` for a finite `v >= 0`.
fn non_negative(v: f32) -> bool {
    v.is_finite() && v >= 0.0
}

/// `true` for a finite `v > 0`.
fn positive(v: f32) -> bool {
    v.is_finite() && v > 0.0
}

impl Plan {
    /// Checks `p` and lays out its world.
    ///
    /// # Bounded work
    /// Constant.
    ///
    /// # Errors
    /// `TdErrParams` for a count or capacity out of range, a non-finite or out-of-range
    /// setting, or a world larger than the address space.
    pub fn of(p: &TdParams) -> Result<Self, TdStatus> {
        check((1..=TD_MAX_COUNT).contains(&p.node_count))?;
        check((1..=TD_MAX_COUNT).contains(&p.tet_count))?;
        check(p.hierarchy_capacity >= 8)?;
        check(p.pending_capacity >= 1)?;
        check(p.candidate_capacity >= 1)?;
        check(p.hash_capacity >= 1)?;
        check(p.max_cells >= 1)?;
        check(p.contact_search_nodes >= 1)?;
        check((1..=9).contains(&p.max_depth))?;
        check(p.budget_per_tick >= 1)?;
        check(positive(p.radius) && non_negative(p.reach) && non_negative(p.min_area))?;
        check(non_negative(p.stiffness) && non_negative(p.damping))?;
        check(positive(p.max_force) && positive(p.dt) && non_negative(p.switch_time))?;
        let to_usize = |v: u32| usize::try_from(v).map_err(|_| TdStatus::TdErrParams);
        let nodes = to_usize(p.node_count)?;
        let tets = to_usize(p.tet_count)?;
        let arena = to_usize(p.hierarchy_capacity)?;
        // The counts are at most 2^28 and the arena below 2^32: every size `WorldSizes::new`
        // derives (2 t + 2, 8 t, t + 7/8 of the arena) fits a 32-bit usize.
        let mut sizes = WorldSizes::new(tets, arena)
            .with_pending(to_usize(p.pending_capacity)?)
            .with_sphere_memo(to_usize(p.sphere_memo_slots)?);
        sizes.candidates = to_usize(p.candidate_capacity)?;
        sizes.hash_entries = to_usize(p.hash_capacity)?;
        let faces = tets.checked_mul(4).ok_or(TdStatus::TdErrParams)?;

        let mut b = Builder {
            layout: Layout::new::<State>(),
        };
        let positions = b.put::<Vec3>(nodes)?;
        let normals = b.put::<Vec3>(nodes)?;
        let node_recs = b.put::<Node>(nodes)?;
        let tet_recs = b.put::<Tet>(tets)?;
        let scratch = b.put::<FaceKey>(faces)?;
        let hash_starts = b.put::<u32>(sizes.hash_starts)?;
        let hash_entries = b.put::<HashEntry>(sizes.hash_entries)?;
        let tet_boxes = b.put::<Aabb>(sizes.tet_boxes)?;
        let roots = b.put::<HNode>(sizes.roots)?;
        let arena_at = b.put::<HNode>(sizes.arena)?;
        let vlist = b.put::<VEntry>(sizes.vlist)?;
        let pending = b.put::<Pending>(sizes.pending)?;
        let candidates = b.put::<TetId>(sizes.candidates)?;
        let memo = b.put::<SphereSlot>(sizes.sphere_memo)?;
        let layout = b.layout.pad_to_align();
        Ok(Self {
            nodes,
            tets,
            sizes,
            positions,
            normals,
            node_recs,
            tet_recs,
            scratch,
            hash_starts,
            hash_entries,
            tet_boxes,
            roots,
            arena: arena_at,
            vlist,
            pending,
            candidates,
            memo,
            size: layout.size(),
            align: layout.align(),
        })
    }
}

/// Bytes of the header alone (for the docs and the tests).
pub const STATE_BYTES: usize = size_of::<State>();
