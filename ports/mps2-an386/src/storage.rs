//! Every slice the core borrows, in statics, sized by the core's own `WorldSizes` so the
//! firmware's world has the capacities of the host's (`EngineStorage::allocate`), except the
//! drill's pending deque: [`PENDING_ITEMS`] entries instead of the host's 32,768, as the host's
//! `builtin:firmware` sets too (`pending_capacity`). At the scenario's budget of 150 units the
//! deque peaks at 9,358 items and never fills; the results are the same bits either way.
//!
//! Each array is a `static_cell::ConstStaticCell`: const-initialised, handed out once as
//! `&'static mut` with no `unsafe` here. Arrays whose const initial value is all zero bytes
//! land in `.bss` (no flash); the ones whose initial value the host sets to something else
//! are refilled with the core's `Default` at start-up, so both sides start from the same
//! bits. The hierarchy nodes start as `HNode::LEAF` and the sphere memo as `SphereSlot::EMPTY`,
//! both all zero bytes: `.bss` too.

use static_cell::ConstStaticCell;

use tetradrill_core::builtin::block_counts;
use tetradrill_core::builtin::{block_labels, BLOCK_CORE, BLOCK_SHELL};
use tetradrill_core::drill::{Pending, Region, Regions};
use tetradrill_core::hash::{Aabb, HashEntry};
use tetradrill_core::hierarchy::{HNode, HierarchyStorage, SphereSlot, VEntry};
use tetradrill_core::mesh::{MeshStorage, Node, Reverse, Tet};
use tetradrill_core::servo::{WorldSizes, WorldStorage};
use tetradrill_core::{NodeId, TetId, Vec3};

use crate::scenario::{self, ARENA, PENDING_ITEMS};
use crate::BLOCK_N;

include!(concat!(env!("OUT_DIR"), "/mesh_counts.rs"));

/// Nodes of the mesh: the block's, or the included blob's.
pub const NODES: usize = if cfg!(blob_mesh) {
    BLOB_NODES
} else {
    block_counts(BLOCK_N).0
};
/// Tets of the mesh: the block's, or the included blob's.
pub const TETS: usize = if cfg!(blob_mesh) {
    BLOB_TETS
} else {
    block_counts(BLOCK_N).1
};
/// Tet records in RAM: the block's; none for a blob's mesh (the cow, the tooth), whose tets
/// the mesh reads in place from the blob in flash.
pub const RAM_TETS: usize = if cfg!(blob_mesh) { 0 } else { TETS };
/// The world's storage sizes, as the host computes them, with the scenario's pending deque
/// and candidate list.
pub const SIZES: WorldSizes = {
    let mut s = WorldSizes::new(TETS, ARENA).with_pending(PENDING_ITEMS);
    s.candidates = scenario::CANDIDATES;
    if cfg!(scenario_soft) {
        // Each step's commit empties the memo: 256 slots (6 KB) instead of the host's 4,096
        // (96 KB). Any size gives the same results.
        s = s.with_sphere_memo(scenario::SOFT_SPHERE_MEMO);
    }
    s
};

// All-zero placeholders (so the statics go to .bss); see `Storage::take`.
const ZERO_NODE: Node = Node {
    tet: TetId(0),
    local: 0,
    boundary: false,
};
const ZERO_TET: Tet = Tet {
    nodes: [NodeId(0); 4],
    neighbours: [TetId(0); 4],
    reverse: [Reverse(0); 4],
};
const ZERO_ENTRY: HashEntry = HashEntry::EMPTY;
const ZERO_BOX: Aabb = Aabb {
    min: Vec3::ZERO,
    max: Vec3::ZERO,
};
const ZERO_VENTRY: VEntry = VEntry {
    tet: TetId(0),
    index: 0,
    node: 0,
};
const ZERO_PENDING: Pending = Pending::EMPTY;

static POSITIONS: ConstStaticCell<[Vec3; NODES]> = ConstStaticCell::new([Vec3::ZERO; NODES]);
static NORMALS: ConstStaticCell<[Vec3; NODES]> = ConstStaticCell::new([Vec3::ZERO; NODES]);
static NODE_RECS: ConstStaticCell<[Node; NODES]> = ConstStaticCell::new([ZERO_NODE; NODES]);
static TET_RECS: ConstStaticCell<[Tet; RAM_TETS]> = ConstStaticCell::new([ZERO_TET; RAM_TETS]);
static HASH_STARTS: ConstStaticCell<[u32; SIZES.hash_starts]> =
    ConstStaticCell::new([0; SIZES.hash_starts]);
// On the cow the hash (8 entries a tet, 2.3 MB) and the pending deque live in PSRAM.
#[cfg_attr(scenario_cow, link_section = ".psram.hash_entries")]
static HASH_ENTRIES: ConstStaticCell<[HashEntry; SIZES.hash_entries]> =
    ConstStaticCell::new([ZERO_ENTRY; SIZES.hash_entries]);
static TET_BOXES: ConstStaticCell<[Aabb; SIZES.tet_boxes]> =
    ConstStaticCell::new([ZERO_BOX; SIZES.tet_boxes]);
static ROOTS: ConstStaticCell<[HNode; SIZES.roots]> =
    ConstStaticCell::new([HNode::LEAF; SIZES.roots]);
static ARENA_NODES: ConstStaticCell<[HNode; SIZES.arena]> =
    ConstStaticCell::new([HNode::LEAF; SIZES.arena]);
static VLIST: ConstStaticCell<[VEntry; SIZES.vlist]> =
    ConstStaticCell::new([ZERO_VENTRY; SIZES.vlist]);
#[cfg_attr(scenario_cow, link_section = ".psram.pending")]
static PENDING: ConstStaticCell<[Pending; SIZES.pending]> =
    ConstStaticCell::new([ZERO_PENDING; SIZES.pending]);
static CANDIDATES: ConstStaticCell<[TetId; SIZES.candidates]> =
    ConstStaticCell::new([TetId(0); SIZES.candidates]);
static SPHERE_MEMO: ConstStaticCell<[SphereSlot; SIZES.sphere_memo]> =
    ConstStaticCell::new([SphereSlot::EMPTY; SIZES.sphere_memo]);
/// The materials of `builtin:firmware-regions`, in label order (the shell, then the core).
#[cfg(not(scenario_tooth))]
static REGIONS: ConstStaticCell<[Region; 2]> =
    ConstStaticCell::new([Region::new(scenario::SHELL), Region::new(scenario::CORE)]);
/// The materials of `builtin:firmware-tooth`, in label order (enamel, dentin, pulp).
#[cfg(scenario_tooth)]
static REGIONS: ConstStaticCell<[Region; 3]> = ConstStaticCell::new([
    Region::new(scenario::ENAMEL),
    Region::new(scenario::DENTIN),
    Region::new(scenario::PULP),
]);
/// Each tet's region index (0 the shell, 1 the core; on the tooth its label's place in
/// `scenario::TOOTH_LABELS`; used by the regions and tooth scenarios only).
static TET_REGION: ConstStaticCell<[u8; TETS]> = ConstStaticCell::new([0; TETS]);

/// The storage, taken once.
pub struct Storage {
    /// Node positions of the block.
    pub positions: &'static mut [Vec3],
    /// The mesh's records.
    pub mesh: MeshStorage<'static>,
    /// The world's hash, hierarchy, drill and candidate storage.
    pub world: WorldStorage<'static>,
    /// The regions' materials (two on the block, three on the tooth) and what they have
    /// earned and lost.
    pub regions: &'static mut [Region],
    /// Each tet's region index.
    pub tet_region: &'static mut [u8],
}

impl Storage {
    /// Takes every static, filled with the values the host's storage starts with. Panics
    /// (exit status 1 through the panic handler) if called twice.
    pub fn take() -> Self {
        let nodes = NODE_RECS.take();
        nodes.fill(Node::default());
        let tets = TET_RECS.take();
        tets.fill(Tet::default());
        let vlist = VLIST.take();
        vlist.fill(VEntry::default());
        let candidates = CANDIDATES.take();
        candidates.fill(TetId::NONE);
        let entries = HASH_ENTRIES.take();
        entries.fill(HashEntry::default());
        let pending = PENDING.take();
        pending.fill(Pending::default());
        Self {
            positions: POSITIONS.take(),
            mesh: MeshStorage {
                nodes,
                normals: NORMALS.take(),
                tets,
            },
            world: WorldStorage {
                hash_starts: HASH_STARTS.take(),
                hash_entries: entries,
                tet_boxes: TET_BOXES.take(),
                hierarchy: HierarchyStorage {
                    roots: ROOTS.take(),
                    arena: ARENA_NODES.take(),
                    vlist,
                },
                pending,
                candidates,
                sphere_memo: SPHERE_MEMO.take(),
            },
            regions: REGIONS.take(),
            tet_region: TET_REGION.take(),
        }
    }
}

/// The regions of `builtin:firmware-regions` over the block: each tet's index from its label
/// (`builtin::block_labels`, the host's labels of `builtin:block:N`; one region per distinct
/// label in label order, as the host's `region_table` numbers them). `None` if the block's
/// labels do not fit or the core refuses the table.
pub fn regions(
    table: &'static mut [Region],
    of_tet: &'static mut [u8],
) -> Option<Regions<'static>> {
    let mut labels = [0i32; TETS];
    block_labels(BLOCK_N, &mut labels)?;
    for (slot, &label) in of_tet.iter_mut().zip(labels.iter()) {
        *slot = match label {
            BLOCK_SHELL => 0,
            BLOCK_CORE => 1,
            _ => return None,
        };
    }
    Regions::new(table, of_tet).ok()
}

/// The soft body's storage in `builtin:firmware-soft` (cfg `scenario_soft`): the body's rest
/// mesh and state (`SoftStorage`), the world's rest positions and spare tables
/// (`World::enable_deformation`, `World::set_spare`), and the link's buffers
/// (`soft::LinkBuffers`); all zero, so all in `.bss`.
#[cfg(scenario_soft)]
pub mod soft {
    use static_cell::ConstStaticCell;

    use tetradrill_core::hash::{Aabb, HashEntry};
    use tetradrill_core::soft::TetRest;
    use tetradrill_core::Vec3;

    use super::{NODES, SIZES, TETS, ZERO_BOX, ZERO_ENTRY};

    const ZERO_REST: TetRest = TetRest::ZERO;

    static REST: ConstStaticCell<[Vec3; NODES]> = ConstStaticCell::new([Vec3::ZERO; NODES]);
    static TET_NODES: ConstStaticCell<[[u32; 4]; TETS]> = ConstStaticCell::new([[0; 4]; TETS]);
    static DISPLACEMENT: ConstStaticCell<[Vec3; NODES]> = ConstStaticCell::new([Vec3::ZERO; NODES]);
    static VELOCITY: ConstStaticCell<[Vec3; NODES]> = ConstStaticCell::new([Vec3::ZERO; NODES]);
    static PREVIOUS: ConstStaticCell<[Vec3; NODES]> = ConstStaticCell::new([Vec3::ZERO; NODES]);
    static MASS: ConstStaticCell<[f32; NODES]> = ConstStaticCell::new([0.0; NODES]);
    static INV_MASS: ConstStaticCell<[f32; NODES]> = ConstStaticCell::new([0.0; NODES]);
    static TET_REST: ConstStaticCell<[TetRest; TETS]> = ConstStaticCell::new([ZERO_REST; TETS]);
    static LAMBDAS: ConstStaticCell<[[f32; 2]; TETS]> = ConstStaticCell::new([[0.0; 2]; TETS]);
    static WORLD_REST: ConstStaticCell<[Vec3; NODES]> = ConstStaticCell::new([Vec3::ZERO; NODES]);
    static SPARE_STARTS: ConstStaticCell<[u32; SIZES.hash_starts]> =
        ConstStaticCell::new([0; SIZES.hash_starts]);
    static SPARE_ENTRIES: ConstStaticCell<[HashEntry; SIZES.hash_entries]> =
        ConstStaticCell::new([ZERO_ENTRY; SIZES.hash_entries]);
    static SPARE_BOXES: ConstStaticCell<[Aabb; SIZES.tet_boxes]> =
        ConstStaticCell::new([ZERO_BOX; SIZES.tet_boxes]);
    static SPARE_NORMALS: ConstStaticCell<[Vec3; NODES]> =
        ConstStaticCell::new([Vec3::ZERO; NODES]);
    static LOAD_A: ConstStaticCell<[Vec3; NODES]> = ConstStaticCell::new([Vec3::ZERO; NODES]);
    static LOAD_B: ConstStaticCell<[Vec3; NODES]> = ConstStaticCell::new([Vec3::ZERO; NODES]);
    static NEXT: ConstStaticCell<[Vec3; NODES]> = ConstStaticCell::new([Vec3::ZERO; NODES]);

    /// The soft body's slices, taken once.
    pub struct SoftStatics {
        /// Rest positions (`SoftMesh::rest`).
        pub rest: &'static mut [Vec3],
        /// Tets as node indices (`SoftMesh::tets`).
        pub tets: &'static mut [[u32; 4]],
        /// `SoftStorage::displacement`.
        pub displacement: &'static mut [Vec3],
        /// `SoftStorage::velocity`.
        pub velocity: &'static mut [Vec3],
        /// `SoftStorage::previous`.
        pub previous: &'static mut [Vec3],
        /// `SoftStorage::mass`.
        pub mass: &'static mut [f32],
        /// `SoftStorage::inv_mass`.
        pub inv_mass: &'static mut [f32],
        /// `SoftStorage::tet_rest`.
        pub tet_rest: &'static mut [TetRest],
        /// `SoftStorage::lambdas`.
        pub lambdas: &'static mut [[f32; 2]],
        /// The world's rest state (`World::enable_deformation`).
        pub world_rest: &'static mut [Vec3],
        /// `SpareStorage::hash_starts`.
        pub spare_starts: &'static mut [u32],
        /// `SpareStorage::hash_entries`.
        pub spare_entries: &'static mut [HashEntry],
        /// `SpareStorage::tet_boxes`.
        pub spare_boxes: &'static mut [Aabb],
        /// `SpareStorage::normals`.
        pub spare_normals: &'static mut [Vec3],
        /// `LinkBuffers::a`.
        pub load_a: &'static mut [Vec3],
        /// `LinkBuffers::b`.
        pub load_b: &'static mut [Vec3],
        /// `LinkBuffers::next`.
        pub next: &'static mut [Vec3],
    }

    /// Takes every soft static (panics, exit status 1, if called twice). The hash entries are
    /// refilled with the core's `Default`, as the host's spare starts.
    pub fn take() -> SoftStatics {
        let spare_entries = SPARE_ENTRIES.take();
        spare_entries.fill(HashEntry::default());
        SoftStatics {
            rest: REST.take(),
            tets: TET_NODES.take(),
            displacement: DISPLACEMENT.take(),
            velocity: VELOCITY.take(),
            previous: PREVIOUS.take(),
            mass: MASS.take(),
            inv_mass: INV_MASS.take(),
            tet_rest: TET_REST.take(),
            lambdas: LAMBDAS.take(),
            world_rest: WORLD_REST.take(),
            spare_starts: SPARE_STARTS.take(),
            spare_entries,
            spare_boxes: SPARE_BOXES.take(),
            spare_normals: SPARE_NORMALS.take(),
            load_a: LOAD_A.take(),
            load_b: LOAD_B.take(),
            next: NEXT.take(),
        }
    }
}
