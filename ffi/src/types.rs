//! The C-visible types: status codes, parameters, vectors, reports and counters. Every field
//! is a plain integer or float, so any bit pattern C hands in is a valid value; nothing here
//! is an enum that C writes (a C `int` outside an enum's values would be undefined behaviour
//! in Rust).

use core::ffi::c_char;

/// What a call did. `TD_OK` is zero; every error leaves the world as it was, except
/// `td_world_init`, which leaves the memory it was given unusable as a world until a
/// successful init.
#[repr(C)]
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
// The names are the C constants (`TD_OK`, `TD_ERR_NULL`, ...): the prefix is the point.
#[allow(clippy::enum_variant_names)]
pub enum TdStatus {
    /// Done.
    TdOk = 0,
    /// A pointer that must not be null was null.
    TdErrNull = 1,
    /// A pointer was not aligned for what it points to (`td_world_size` gives the world's
    /// alignment; float and index arrays need 4 bytes).
    TdErrAlign = 2,
    /// The memory given for the world is shorter than `td_world_size` says.
    TdErrTooSmall = 3,
    /// A parameter is out of range (a count or capacity of zero or too large for this
    /// machine's address space, a radius that is not positive, a non-finite number).
    TdErrParams = 4,
    /// The mesh arrays were refused: a tet names a node out of range or twice, a node is not
    /// finite, a tet has zero volume, a face is shared by more than two tets or two tets
    /// overlap. `td_world_init`'s `bad_item` names the tet (or the node) at fault.
    TdErrMesh = 5,
    /// The world could not be set up over the mesh (the spatial hash or the hierarchy refused
    /// its storage).
    TdErrWorld = 6,
    /// The world pointer does not point at a world `td_world_init` set up.
    TdErrNotInit = 7,
    /// A pose or a pressing force is not finite (NaN or infinite), or the force or its
    /// duration is negative.
    TdErrInput = 8,
    /// A region label was refused: `td_world_init` met more distinct labels than
    /// `region_capacity` (its `bad_item` names the first tet over), or a region function named
    /// a label the mesh does not have (or an index past the last region).
    TdErrLabel = 9,
    /// Materials are set before the first simulation step; this world has already stepped.
    TdErrStarted = 10,
    /// A mesh file could not be read or built: missing, unreadable, or not what its extension
    /// says (`td_file_error` names the line or byte and the reason).
    TdErrFile = 11,
    /// A mesh blob was refused: not a blob, another version, truncated, corrupted, or a record
    /// out of range (`bad_item` gets the byte offset at fault).
    TdErrBlob = 12,
    /// The world's mesh is rigid: it was set up with `td_params.deformable` 0, so its nodes
    /// cannot move (`td_world_set_positions`).
    TdErrRigid = 13,
    /// A step spread over ticks is under way: the soft body steps through its link
    /// (`td_link_tick`) until the cycle ends, and the world's update is prepared.
    TdErrBusy = 14,
}

impl TdStatus {
    /// Every status, in code order (for `td_status_name`).
    pub(crate) const ALL: [TdStatus; 15] = [
        TdStatus::TdOk,
        TdStatus::TdErrNull,
        TdStatus::TdErrAlign,
        TdStatus::TdErrTooSmall,
        TdStatus::TdErrParams,
        TdStatus::TdErrMesh,
        TdStatus::TdErrWorld,
        TdStatus::TdErrNotInit,
        TdStatus::TdErrInput,
        TdStatus::TdErrLabel,
        TdStatus::TdErrStarted,
        TdStatus::TdErrFile,
        TdStatus::TdErrBlob,
        TdStatus::TdErrRigid,
        TdStatus::TdErrBusy,
    ];

    /// A NUL-terminated line saying what the status means.
    pub(crate) fn text(self) -> &'static core::ffi::CStr {
        match self {
            TdStatus::TdOk => c"ok",
            TdStatus::TdErrNull => c"a required pointer is null",
            TdStatus::TdErrAlign => c"a pointer is not aligned for its type",
            TdStatus::TdErrTooSmall => c"the world memory is smaller than td_world_size says",
            TdStatus::TdErrParams => c"a parameter is out of range",
            TdStatus::TdErrMesh => c"the mesh arrays were refused (see bad_item)",
            TdStatus::TdErrWorld => c"the world could not be set up over the mesh",
            TdStatus::TdErrNotInit => c"the world pointer is not an initialised world",
            TdStatus::TdErrInput => c"a pose or pressing force is not finite or is negative",
            TdStatus::TdErrLabel => c"a region label is unknown, or there are too many labels",
            TdStatus::TdErrStarted => c"materials are set before the first simulation step",
            TdStatus::TdErrFile => c"the mesh file could not be read (see td_file_error)",
            TdStatus::TdErrBlob => c"the mesh blob was refused (see bad_item: the byte)",
            TdStatus::TdErrRigid => c"the world is rigid (td_params.deformable is 0)",
            TdStatus::TdErrBusy => c"a step spread over ticks is under way (td_link_tick)",
        }
    }

    /// The text as a C pointer.
    pub(crate) fn c_text(self) -> *const c_char {
        self.text().as_ptr()
    }
}

/// Everything a world needs to know before it is built: the mesh's counts, the capacities of
/// the storage it lives in, and the tool, drilling and force settings. `td_params_default`
/// fills it; change fields, then `td_world_size` and `td_world_init`.
///
/// Capacities and their defaults are the core's (`WorldSizes::new`,
/// `tetradrill_core::servo`); the tool and force defaults are the host's default scenario
/// (`tetradrill replay` with no flags: a burr of radius 0.1 on a unit block).
#[repr(C)]
#[derive(Clone, Copy, PartialEq, Debug)]
pub struct TdParams {
    /// Mesh nodes (`positions` holds `3 * node_count` floats). 1 ..= 2^28.
    pub node_count: u32,
    /// Mesh tets (`tets` holds `4 * tet_count` node indices). 1 ..= 2^28.
    pub tet_count: u32,
    /// Hierarchy arena nodes for drilling (rounded down to a multiple of 8; at least 8). A
    /// full arena refuses refinements and counts them (`sat_arena`).
    pub hierarchy_capacity: u32,
    /// Drill work items carried from tick to tick (at least 1; a full deque drops items and
    /// counts them, `sat_pending`).
    pub pending_capacity: u32,
    /// Coarse tets one simulation step may take near the tool (at least 1; a full list is
    /// counted, `sat_candidates`).
    pub candidate_capacity: u32,
    /// Entries of the static tet hash (default 8 per tet; a full table keeps the first tets
    /// and is counted, `sat_hash`).
    pub hash_capacity: u32,
    /// Slots of the contact search's sphere memo (any number, zero included, gives the same
    /// results; it saves work).
    pub sphere_memo_slots: u32,
    /// Most hash cells one step's zone query visits (at least 1).
    pub max_cells: u32,
    /// Hierarchy nodes one contact search may test (at least 1; a search cut short is
    /// counted, `sat_contact`).
    pub contact_search_nodes: u32,
    /// Work units for a whole simulation step, drill and contact search together; 0 gives
    /// each its own bound.
    pub tick_budget: u32,
    /// Distinct region labels the world keeps, 1 ..= 256 (`TD_MAX_REGIONS`, the default): 44
    /// bytes each. A mesh with more distinct labels is refused (`TD_ERR_LABEL`).
    pub region_capacity: u32,
    /// Deepest subdivision level of a drilled tet, 1 ..= 9.
    pub max_depth: u32,
    /// Drill work units per tick (about 100 Cortex-M4 instructions each), at least 1.
    pub budget_per_tick: u32,
    /// Burr radius, mesh units (positive).
    pub radius: f32,
    /// How far beyond the burr the simulation looks for the surface (the servo's
    /// extrapolation range), mesh units, at least 0. The host uses half the radius.
    pub reach: f32,
    /// Refinement stops below this face area, mesh units squared, at least 0.
    pub min_area: f32,
    /// Newtons per mesh unit of depth (at least 0).
    pub stiffness: f32,
    /// Newton-seconds per mesh unit (at least 0).
    pub damping: f32,
    /// Force clamp, newtons (positive).
    pub max_force: f32,
    /// Servo period, seconds (positive).
    pub dt: f32,
    /// Seconds over which the force moves from one contact plane to the next (at least 0).
    pub switch_time: f32,
    /// The release rule of `td_world_tick`, 0 or 1: 0 runs the step, then the servo force
    /// from its contact (`tetradrill replay`'s default); 1 runs the servo force from the
    /// previous tick's contact, then the step (the RTIC firmware, whose servo interrupt
    /// releases the step: the scenario key `servo_lag`, which `builtin:firmware` sets).
    pub servo_lag: u32,
    /// The candidate tets gathered through the hash in parts of at most this many work units
    /// a step, kept across steps as the burr moves (the scenario key `zone_gather_work`,
    /// `builtin:firmware-tooth` sets 2,000); 0: one zone query every step.
    pub zone_gather_work: u32,
    /// The burr's vibration while it cuts, hertz (the scenario key `vibration_hz`): 0 (none,
    /// the default) up to the servo's Nyquist frequency, `0.5 / dt` (500 at 1 kHz). Its
    /// amplitude is each region's `vibration` (`td_world_set_region_feel`).
    pub vibration_hz: f32,
    /// Hierarchy nodes a drill world's shaft walk may enter a step (the scenario key
    /// `shaft_nodes`; its points left on their last state when a walk is cut, and under
    /// `tick_budget` at most what the step left of it, 6 units a node): 4,096 by default
    /// (`td_params_default`), 0 unbounded. A burr world does not use it.
    pub shaft_nodes: u32,
    /// 0 (the default): the mesh is rigid. 1: its nodes may move (`td_world_set_positions`,
    /// a soft body's positions after each of its steps); the memory then also holds the rest
    /// positions (removed volumes are measured there) and a spare copy of the hash, the tet
    /// boxes and the normals, so that only the tets that changed cells move in the hash
    /// (`td_world_size` counts them: 160 bytes a tet and 24 a node more, most of it the
    /// hash's eight entries a tet).
    pub deformable: u32,
}

/// A point or a force: three floats.
#[repr(C)]
#[derive(Clone, Copy, PartialEq, Debug, Default)]
pub struct TdVec3 {
    /// x.
    pub x: f32,
    /// y.
    pub y: f32,
    /// z.
    pub z: f32,
}

/// A rotation as a unit quaternion `w + x i + y j + z k` (the order of a trace's `qw, qx, qy,
/// qz`); the identity `{1, 0, 0, 0}` leaves the tool's axis along +z.
#[repr(C)]
#[derive(Clone, Copy, PartialEq, Debug)]
pub struct TdQuat {
    /// Real part.
    pub w: f32,
    /// i.
    pub x: f32,
    /// j.
    pub y: f32,
    /// k.
    pub z: f32,
}

/// A tool's pose: its position (a burr's centre, a pen's tip) and its rotation (the tool's
/// axis is its local +z turned by it).
#[repr(C)]
#[derive(Clone, Copy, PartialEq, Debug)]
pub struct TdPose {
    /// Position, mesh units.
    pub position: TdVec3,
    /// Rotation.
    pub rotation: TdQuat,
}

/// A drill's shaft as the simulation tracked it (`td_world_shaft`): the figures of
/// `tetradrill replay --json`'s `shaft`.
#[repr(C)]
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default)]
pub struct TdShaftCounts {
    /// Passive points along the shaft (0 for a world without a drill).
    pub passive_points: u32,
    /// Of them, with a contact plane at the last step (a face within reach, or held).
    pub near: u32,
    /// Of them, held at a face they crossed at the last step.
    pub held: u32,
    /// Most points held at one step.
    pub held_max: u32,
    /// Steps in which a point had a contact plane.
    pub near_ticks: u64,
    /// Steps in which a point was held.
    pub held_ticks: u64,
}

/// A servo's torque figures (`td_servo_tool_counters`).
#[repr(C)]
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default)]
pub struct TdToolCounts {
    /// A drill's: FNV-1a 64 digest of every torque its servo rendered (`td_servo_wrench`,
    /// `td_servo_force`), in order, as `force_digest` digests forces. 0 for a sphere, which
    /// renders no torque.
    pub torque_digest: u64,
    /// The world's tool: 0 a spherical burr, 1 a drill (`td_world_set_drill`).
    pub tool: u32,
}

/// Where the tool touches a world (`td_world_contact_at`).
#[repr(C)]
#[derive(Clone, Copy, PartialEq, Debug, Default)]
pub struct TdContactAt {
    /// The contact's coarse tet, an index into the tets the world was given, or `TD_NO_TET`
    /// when the last step found no contact.
    pub tet: u32,
    /// The contact point on the visible surface (zero without a contact).
    pub point: TdVec3,
}

/// What one `td_world_set_positions` did.
#[repr(C)]
#[derive(Clone, Copy, PartialEq, Debug, Default)]
pub struct TdDeformReport {
    /// The largest distance of a node from its rest position, mesh units.
    pub max_displacement: f32,
    /// Entries in the hash after the update.
    pub hash_entries: u32,
    /// 1 when the hash ran out of entries: the tets past them are not found near the tool
    /// until an update fits (counted in `sat_hash`).
    pub hash_saturated: u32,
    /// Kept contact faces measured again at the new positions (still visible).
    pub kept: u32,
}

/// What one `td_world_simulate` did.
#[repr(C)]
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default)]
pub struct TdSimReport {
    /// Coarse tets near the tool.
    pub candidates: u32,
    /// Visible triangles examined for the contact.
    pub triangles: u32,
    /// Hierarchy nodes the contact search tested.
    pub contact_nodes: u32,
    /// Drill work units spent (0 with the drill off).
    pub drill_work: u32,
    /// Hierarchy nodes the drill created.
    pub created: u32,
    /// Leaves the drill erased.
    pub erased: u32,
    /// Drill work items left for later ticks.
    pub pending: u32,
    /// 1 when the contact search hit its node bound.
    pub contact_saturated: u32,
    /// 1 when the candidate list filled up or the zone covered too many cells.
    pub candidates_saturated: u32,
}

/// A world's counters since `td_world_init`.
#[repr(C)]
#[derive(Clone, Copy, PartialEq, Debug, Default)]
pub struct TdCounters {
    /// `td_world_simulate` calls.
    pub simulate_steps: u64,
    /// Volume of the mesh before drilling, mesh units cubed.
    pub initial_volume: f64,
    /// Volume the drill removed, mesh units cubed.
    pub removed_volume: f64,
    /// Hierarchy nodes in use (roots included).
    pub hierarchy_nodes: u64,
    /// Visible faces of the drilled surface.
    pub visible_faces: u32,
    /// Static hash builds that ran out of entries.
    pub sat_hash: u32,
    /// Steps whose candidate list filled up or whose zone was too wide.
    pub sat_candidates: u32,
    /// Refinements refused because the arena was full.
    pub sat_arena: u32,
    /// Drill work items dropped because the pending deque was full.
    pub sat_pending: u32,
    /// Steps whose contact search hit its node bound.
    pub sat_contact: u32,
    /// All saturations added up.
    pub sat_total: u32,
    /// Regions of the world: its mesh's distinct labels (one, label 0, without labels).
    /// `td_world_region` and `td_world_region_at` give each one's removed volume.
    pub region_count: u32,
}

/// A servo's counters (`td_servo_counters`).
#[repr(C)]
#[derive(Clone, Copy, PartialEq, Debug, Default)]
pub struct TdServoCounts {
    /// FNV-1a 64 digest of every force `td_servo_force` returned, in order: the
    /// `force_digest` of `tetradrill replay` (printed as 16 hex digits).
    pub force_digest: u64,
    /// `td_servo_force` calls (`td_world_tick` makes one each).
    pub servo_ticks: u64,
    /// Servo ticks whose force was not zero.
    pub contact_ticks: u64,
    /// Servo ticks that rendered from the contact before, every read of the hand-off having
    /// been overtaken by a step published meanwhile (only with the two on different cores).
    pub stale_reads: u64,
    /// The number of the step whose contact the last tick rendered (steps counted from 1; 0:
    /// no step yet).
    pub step: u32,
}

/// One region of a world: its label, its material, the volume removed from it and its feel.
#[repr(C)]
#[derive(Clone, Copy, PartialEq, Debug, Default)]
pub struct TdRegion {
    /// The region's label (the mesh's, from `td_world_init`'s `labels`; 0 without them).
    pub label: i32,
    /// Newton-seconds per cubic mesh unit: the burr pressing `F` newtons above the threshold
    /// removes `(F - threshold) / hardness` cubic mesh units a second; 0: removed at once.
    pub hardness: f32,
    /// Newtons the burr must press with before it removes anything.
    pub threshold: f32,
    /// Contact stiffness, newtons per mesh unit of depth; 0: `td_params.stiffness`.
    pub stiffness: f32,
    /// Volume removed from the region so far, mesh units cubed (`removed_by_region` of
    /// `tetradrill replay`).
    pub removed_volume: f64,
    /// Newtons: the burr's vibration at full cut in the region (0: none;
    /// `td_world_set_region_feel`).
    pub vibration: f32,
    /// Newtons per square mesh unit: the work the feed does per unit volume removed (0: the
    /// hardness law; `td_world_set_region_feel`).
    pub cutting_energy: f32,
    /// The friction coefficient between the spinning burr and the region (0: no sideways
    /// pull; `td_world_set_region_feel`).
    pub friction: f32,
}

/// The work the feed did on the regions it cuts (`td_world_cutting`), newton mesh units
/// (joules for a mesh in metres): `work = energy + pool + dropped`.
#[repr(C)]
#[derive(Clone, Copy, PartialEq, Debug, Default)]
pub struct TdCutting {
    /// Work done pushing the burr into material cut by the feed, against the contact's
    /// reaction (the servo's force times the burr's advance into the material, summed over
    /// the steps).
    pub work: f64,
    /// Each erased leaf's volume times its region's cutting energy, summed: the energy the
    /// removed material took.
    pub energy: f64,
    /// Work done and not yet spent on a leaf.
    pub pool: f64,
    /// Work done that bought no material: left in the pool when the burr stopped cutting
    /// and the drill had nothing left to remove.
    pub dropped: f64,
}

/// A world set up by `td_world_init` in caller memory. Opaque: C holds a pointer to it (the
/// start of the memory it gave) and never reads it.
#[derive(Debug)]
pub struct TdWorld {
    _opaque: [u8; 0],
}

/// A world's servo, from `td_world_servo`: its own part of the world's memory, which the
/// servo's force call uses alone. Opaque: C holds a pointer to it and never reads it.
#[derive(Debug)]
pub struct TdServo {
    _opaque: [u8; 0],
}
