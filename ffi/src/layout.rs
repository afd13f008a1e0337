//! Where everything of a world goes in the caller's memory: the [`State`] at the start, then
//! every slice the core borrows, each at its type's alignment. [`Plan::of`] checks the
//! parameters and computes the offsets with checked arithmetic; `td_world_size` reports its
//! total and `td_world_init` carves the memory by it.

use core::alloc::Layout;
use core::mem::size_of;

use tetradrill_core::drill::{DrillParams, Region};
use tetradrill_core::force::ForceParams;
use tetradrill_core::mesh::{FaceKey, MeshStorage};
use tetradrill_core::servo::{ContactHandoff, DrillHandoff, DrillServo, Servo, World, WorldSizes};
use tetradrill_core::storage::Line;
use tetradrill_core::Vec3;

use crate::tools::DrillSim;
use crate::types::{TdParams, TdStatus};

/// Marks a [`State`] that `td_world_init` finished ("tdworld1").
pub const MAGIC: u64 = u64::from_le_bytes(*b"tdworld1");

/// Marks a [`ServoState`] that `td_world_init` finished ("tdservo1").
pub const SERVO_MAGIC: u64 = u64::from_le_bytes(*b"tdservo1");

/// The contact hand-off on a cache line of its own: the simulation's and the servo's only
/// shared memory, reached through shared references alone (its words are atomics).
#[derive(Debug, Default)]
#[repr(C, align(64))]
pub struct SharedHandoff(pub ContactHandoff);

/// A drill's hand-off on cache lines of its own: a drill world's step publishes its burr's
/// contact and its shaft's planes there, for the servo (unused by a sphere's world).
#[derive(Debug, Default)]
#[repr(C, align(64))]
pub struct SharedDrillHandoff(pub DrillHandoff);

/// The servo's own part of a world's memory, apart from the [`State`] so that the servo may
/// preempt the simulation (or run beside it) without either touching the other's memory:
/// the core's [`Servo`] and the hand-off it reads. `td_world_servo` hands C a pointer to it.
#[derive(Debug)]
#[repr(C, align(64))]
pub struct ServoState {
    /// [`SERVO_MAGIC`] once set up; zero while `td_world_init` works on the memory.
    pub magic: u64,
    /// The servo: its contact, tool state, force settings, digest and counters.
    pub servo: Servo,
    /// The contact hand-off, shared with the world's [`State`].
    pub handoff: &'static ContactHandoff,
    /// The drill's servo, for a drill world (`td_world_set_drill`, before the servo starts).
    pub drill: Option<DrillServo>,
    /// The drill's hand-off, shared with the world's [`State`].
    pub drill_handoff: &'static DrillHandoff,
}

crate::marked!(ServoState, SERVO_MAGIC);

/// The most nodes or tets a world takes: every size the core derives from the counts (8 hash
/// entries per tet, a v_list of the tets plus 7/8 of the arena) then fits in 32 bits.
pub const TD_MAX_COUNT: u32 = 1 << 28;

/// The most regions a world keeps (`td_params.region_capacity`, and its default): a tet's
/// region index is a byte in the core.
pub const TD_MAX_REGIONS: u32 = 256;

/// A world's regions before its first simulation step: the materials `td_world_set_region`
/// still changes and each tet's region index. The first step hands both to the core.
#[derive(Debug)]
pub struct Unstarted {
    /// One entry per region, in label order.
    pub table: &'static mut [Region],
    /// Each coarse tet's region index.
    pub of_tet: &'static [u8],
}

/// The head of a world's memory: the core's world (borrowing the slices after it) and what
/// the C calls carry from tick to tick.
#[derive(Debug)]
#[repr(C)]
pub struct State {
    /// [`MAGIC`] once set up; zero while `td_world_init` works on the memory.
    pub magic: u64,
    /// The core's world over the slices that follow this header.
    pub world: World<'static>,
    /// The contact hand-off: each step publishes its contact; the servo reports its force.
    pub handoff: &'static ContactHandoff,
    /// The world's servo (its own memory: touched here only by `td_world_tick` and
    /// `td_world_servo`, never while the world is borrowed).
    pub servo: *mut ServoState,
    /// The hand-off's servo tick count at the last step (what the pressing force covers).
    pub servo_seen: u32,
    /// `td_world_set_pressing` was called: the pressing force is the caller's, not the
    /// servo's.
    pub manual_pressing: bool,
    /// `td_params.servo_lag` is 1: `td_world_tick` runs the servo force before the step.
    pub servo_lag: bool,
    /// Burr radius.
    pub radius: f32,
    /// Contact reach beyond the burr.
    pub reach: f32,
    /// Drill settings.
    pub drill: DrillParams,
    /// Force settings.
    pub force: ForceParams,
    /// `td_world_simulate` calls.
    pub steps: u64,
    /// Mesh volume at set-up.
    pub initial_volume: f64,
    /// The label of each region, ascending (one per distinct label of the mesh).
    pub labels: &'static [i32],
    /// The regions until the first simulation step hands them to the world (`None` after).
    pub unstarted: Option<Unstarted>,
    /// The drill's shape and its shaft's state, for a drill world (`td_world_set_drill`).
    pub shaft: Option<DrillSim>,
    /// The drill's hand-off, shared with the servo.
    pub drill_handoff: &'static DrillHandoff,
    /// Set up with `td_params.deformable` 1: the world has its rest positions and spare
    /// storage, and `td_world_set_positions` moves its nodes.
    pub deformable: bool,
    /// The link (its handle's address) whose cycle holds the world's next positions, from a
    /// cycle's first `td_link_tick` to its commit; 0: none.
    pub link_cycle: usize,
}

crate::marked!(State, MAGIC);

impl State {
    /// The regions' materials and removed volumes, in label order.
    ///
    /// # Bounded work
    /// Constant.
    pub fn regions(&self) -> &[Region] {
        match &self.unstarted {
            Some(u) => u.table,
            None => self.world.regions().map_or(&[], |r| r.table()),
        }
    }

    /// The index of the region labelled `label`, if the mesh has it.
    ///
    /// # Bounded work
    /// O(log regions).
    pub fn region_index(&self, label: i32) -> Option<usize> {
        self.labels.binary_search(&label).ok()
    }
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
    /// The mesh's node records, boundary normals and tet records:
    /// [`MeshStorage::lines`] lines, carved by `MeshStorage::carve` (the core's one layout
    /// of a mesh's storage).
    pub mesh: usize,
    /// Lines of the mesh's storage.
    pub mesh_lines: usize,
    /// `FaceKey` per tet face: the mesh build's scratch.
    pub scratch: usize,
    /// Face keys in the scratch: 4 per tet, none for a mesh read in place.
    pub faces: usize,
    /// The world's storage: [`WorldSizes::lines`] lines, carved by `WorldStorage::carve`
    /// (the core's one layout of a world's storage).
    pub world: usize,
    /// Lines of the world's storage.
    pub world_lines: usize,
    /// Region slots (`Region` each).
    pub regions: usize,
    /// Region labels (`i32` each).
    pub region_labels: usize,
    /// Each tet's region index (`u8` each).
    pub tet_region: usize,
    /// Region slots: `region_capacity`.
    pub region_slots: usize,
    /// The contact hand-off (`SharedHandoff`).
    pub handoff: usize,
    /// The servo's state (`ServoState`).
    pub servo: usize,
    /// The drill's hand-off (`SharedDrillHandoff`).
    pub drill_handoff: usize,
    /// A deforming world's spare storage and rest positions (`td_params.deformable`):
    /// [`WorldSizes::deform_lines`] lines at this offset, carved by `SpareStorage::carve` and
    /// `carve_rest` (the core's one layout of them).
    pub deform: Option<(usize, usize)>,
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
    /// Checks `p` and lays out its world; `in_place`: the tets are read in place from a
    /// blob, so the memory holds no tet records and no build scratch.
    ///
    /// # Bounded work
    /// Constant.
    ///
    /// # Errors
    /// `TdErrParams` for a count or capacity out of range, a non-finite or out-of-range
    /// setting, or a world larger than the address space.
    pub fn of(p: &TdParams, in_place: bool) -> Result<Self, TdStatus> {
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
        check((1..=TD_MAX_REGIONS).contains(&p.region_capacity))?;
        check(positive(p.radius) && non_negative(p.reach) && non_negative(p.min_area))?;
        check(non_negative(p.stiffness) && non_negative(p.damping))?;
        check(positive(p.max_force) && positive(p.dt) && non_negative(p.switch_time))?;
        check(p.servo_lag <= 1)?;
        check(p.deformable <= 1)?;
        // Up to the servo's Nyquist frequency (500 Hz at 1 kHz: the product rounds to 0.5).
        check(non_negative(p.vibration_hz) && p.vibration_hz * p.dt <= 0.5)?;
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
        let built = if in_place { 0 } else { tets };
        let faces = built.checked_mul(4).ok_or(TdStatus::TdErrParams)?;

        let mut b = Builder {
            layout: Layout::new::<State>(),
        };
        let handoff = b.put::<SharedHandoff>(1)?;
        let servo = b.put::<ServoState>(1)?;
        let drill_handoff = b.put::<SharedDrillHandoff>(1)?;
        let positions = b.put::<Vec3>(nodes)?;
        let mesh_lines = MeshStorage::lines(nodes, built).ok_or(TdStatus::TdErrParams)?;
        let mesh = b.put::<Line>(mesh_lines)?;
        let scratch = b.put::<FaceKey>(faces)?;
        let world_lines = sizes.lines().ok_or(TdStatus::TdErrParams)?;
        let world = b.put::<Line>(world_lines)?;
        let region_slots = to_usize(p.region_capacity)?;
        let regions = b.put::<Region>(region_slots)?;
        let region_labels = b.put::<i32>(region_slots)?;
        let tet_region = b.put::<u8>(tets)?;
        let deform = if p.deformable == 1 {
            let lines = sizes.deform_lines(nodes).ok_or(TdStatus::TdErrParams)?;
            Some((b.put::<Line>(lines)?, lines))
        } else {
            None
        };
        let layout = b.layout.pad_to_align();
        Ok(Self {
            nodes,
            tets,
            sizes,
            positions,
            mesh,
            mesh_lines,
            scratch,
            faces,
            world,
            world_lines,
            regions,
            region_labels,
            tet_region,
            region_slots,
            handoff,
            servo,
            drill_handoff,
            deform,
            size: layout.size(),
            align: layout.align(),
        })
    }
}

/// Bytes of the header alone (for the docs and the tests).
pub const STATE_BYTES: usize = size_of::<State>();

#[cfg(test)]
mod tests {
    use super::*;
    use core::mem::align_of;
    use tetradrill_core::drill::Pending;
    use tetradrill_core::hierarchy::HNode;

    fn params(nodes: u32, tets: u32, arena: u32, pending: u32, memo: u32) -> TdParams {
        TdParams {
            node_count: nodes,
            tet_count: tets,
            hierarchy_capacity: arena,
            pending_capacity: pending,
            candidate_capacity: 3,
            hash_capacity: 8 * tets,
            sphere_memo_slots: memo,
            max_cells: 1,
            contact_search_nodes: 1,
            tick_budget: 0,
            region_capacity: 2,
            max_depth: 1,
            budget_per_tick: 1,
            radius: 0.1,
            reach: 0.0,
            min_area: 0.0,
            stiffness: 0.0,
            damping: 0.0,
            max_force: 1.0,
            dt: 1e-3,
            switch_time: 0.0,
            servo_lag: 0,
            zone_gather_work: 0,
            vibration_hz: 0.0,
            shaft_nodes: 0,
            deformable: 0,
        }
    }

    /// Each region as (offset, bytes, alignment of its type), in plan order.
    fn regions(p: &Plan) -> std::vec::Vec<(usize, usize, usize)> {
        fn r<T>(at: usize, n: usize) -> (usize, usize, usize) {
            (at, n * size_of::<T>(), align_of::<T>())
        }
        let mut all = std::vec![
            r::<SharedHandoff>(p.handoff, 1),
            r::<ServoState>(p.servo, 1),
            r::<SharedDrillHandoff>(p.drill_handoff, 1),
            r::<Vec3>(p.positions, p.nodes),
            r::<Line>(p.mesh, p.mesh_lines),
            r::<FaceKey>(p.scratch, p.faces),
            r::<Line>(p.world, p.world_lines),
            r::<Region>(p.regions, p.region_slots),
            r::<i32>(p.region_labels, p.region_slots),
            r::<u8>(p.tet_region, p.tets),
        ];
        if let Some((at, lines)) = p.deform {
            all.push(r::<Line>(at, lines));
        }
        all
    }

    #[test]
    fn regions_follow_the_header_aligned_and_apart_inside_the_size() {
        for ((nodes, tets, arena, pending, memo), deformable) in [
            (1, 1, 8, 1, 0),
            (27, 48, 15, 7, 1),
            (729, 3072, 1 << 20, 1 << 15, 4096),
            (125, 384, 20_000, 16_384, 4096),
        ]
        .into_iter()
        .flat_map(|c| [(c, 0), (c, 1)])
        {
            let mut p = params(nodes, tets, arena, pending, memo);
            p.deformable = deformable;
            let plan = Plan::of(&p, false).expect("plan");
            assert_eq!(plan.deform.is_some(), deformable == 1);
            assert!(plan.align.is_power_of_two());
            assert!(plan.align >= align_of::<State>());
            assert_eq!(plan.size % plan.align, 0);
            let mut end = size_of::<State>();
            for (i, (at, bytes, align)) in regions(&plan).into_iter().enumerate() {
                assert!(at >= end, "region {i} overlaps the one before");
                assert_eq!(at % align, 0, "region {i} misaligned");
                assert!(
                    align <= plan.align,
                    "region {i} needs more than the plan's alignment"
                );
                end = at + bytes;
            }
            assert!(end <= plan.size, "the last region passes the size");
            assert_eq!(plan.sizes.arena, arena as usize / 8 * 8);
            assert_eq!(Some(plan.world_lines), plan.sizes.lines());
            // Node 8 bytes, normal 12, tet 36, each part on a 64-byte line.
            let (n, t) = (nodes as usize, tets as usize);
            let want = (8 * n).div_ceil(64) + (12 * n).div_ceil(64) + (36 * t).div_ceil(64);
            assert_eq!(plan.mesh_lines, want);
        }
    }

    #[test]
    fn out_of_range_parameters_are_refused() {
        let ok = params(8, 6, 8, 1, 0);
        assert!(Plan::of(&ok, false).is_ok());
        let bad: [fn(&mut TdParams); 18] = [
            |p| p.node_count = 0,
            |p| p.tet_count = TD_MAX_COUNT + 1,
            |p| p.hierarchy_capacity = 7,
            |p| p.pending_capacity = 0,
            |p| p.candidate_capacity = 0,
            |p| p.hash_capacity = 0,
            |p| p.max_depth = 0,
            |p| p.radius = 0.0,
            |p| p.reach = f32::INFINITY,
            |p| p.max_force = f32::NAN,
            |p| p.dt = -1e-3,
            |p| p.switch_time = -1.0,
            |p| p.servo_lag = 2,
            |p| p.region_capacity = 0,
            |p| p.region_capacity = TD_MAX_REGIONS + 1,
            |p| p.vibration_hz = -1.0,
            |p| p.vibration_hz = 500.1,
            |p| p.deformable = 2,
        ];
        for (i, change) in bad.iter().enumerate() {
            let mut p = ok;
            change(&mut p);
            assert_eq!(
                Plan::of(&p, false),
                Err(TdStatus::TdErrParams),
                "change {i}"
            );
        }
        // The Nyquist frequency itself is taken (500 Hz at 1 kHz).
        let mut p = ok;
        p.vibration_hz = 500.0;
        assert!(Plan::of(&p, false).is_ok());
    }

    #[test]
    fn a_world_larger_than_the_address_space_is_refused_not_wrapped() {
        // Every count at its largest: on a 64-bit machine the plan fits, on a 32-bit one it
        // must be refused; either way the size is at least the sum of the parts.
        let p = params(TD_MAX_COUNT, TD_MAX_COUNT, u32::MAX, u32::MAX, u32::MAX);
        match Plan::of(&p, false) {
            Ok(plan) => {
                let parts = size_of::<Pending>() as u128 * u128::from(u32::MAX)
                    + size_of::<HNode>() as u128 * u128::from(u32::MAX / 8 * 8);
                assert!(plan.size as u128 >= parts);
            }
            Err(e) => assert_eq!(e, TdStatus::TdErrParams),
        }
    }
}
