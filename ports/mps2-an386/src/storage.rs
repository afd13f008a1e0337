//! Every slice the core borrows, in statics, sized by the core's own `WorldSizes` so the
//! firmware's world has the capacities of the host's (`EngineStorage::allocate`), except the
//! drill's pending deque: [`PENDING_ITEMS`] entries instead of the host's 32,768, as the host's
//! `builtin:firmware` sets too (`pending_capacity`). At the scenario's budget of 150 units the
//! deque peaks at 9,358 items and never fills; the results are the same bits either way.
//!
//! Each array is a `static_cell::ConstStaticCell`: const-initialised, handed out once as
//! `&'static mut` with no `unsafe` here. The world's storage is one array of 64-byte lines
//! (two on the cow: the hash entries and the pending deque in PSRAM), carved at start-up by
//! the core's `WorldStorage::carve`, the one layout every host, test and C program shares,
//! which writes every slot's starting value (the memory may hold anything before). The mesh's
//! arrays whose const initial value is all zero bytes land in `.bss` (no flash); the ones whose
//! initial value the host sets to something else are refilled with the core's `Default` at
//! start-up, so both sides start from the same bits.

use static_cell::ConstStaticCell;

use tetradrill_core::builtin::block_counts;
use tetradrill_core::builtin::{block_labels, BLOCK_CORE, BLOCK_SHELL};
use tetradrill_core::drill::{Region, Regions};
use tetradrill_core::mesh::{MeshStorage, Node, Reverse, Tet};
use tetradrill_core::servo::{WorldSizes, WorldStorage};
use tetradrill_core::storage::{Block, Line, Part, PartSet, Split};
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

/// The parts in PSRAM: on the cow the hash (8 entries a tet, 2.3 MB) and the pending deque;
/// none elsewhere.
pub const PSRAM_PARTS: PartSet = if cfg!(scenario_cow) {
    PartSet::EMPTY.with(Part::HashEntries).with(Part::Pending)
} else {
    PartSet::EMPTY
};

/// Lines of the world's storage in RAM and in PSRAM.
const WORLD_LINES: usize = match SIZES.lines_in(PSRAM_PARTS, false) {
    Some(n) => n,
    None => panic!("the world's sizes overflow"),
};
const PSRAM_LINES: usize = match SIZES.lines_in(PSRAM_PARTS, true) {
    Some(n) => n,
    None => panic!("the world's sizes overflow"),
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
static POSITIONS: ConstStaticCell<[Vec3; NODES]> = ConstStaticCell::new([Vec3::ZERO; NODES]);
static NORMALS: ConstStaticCell<[Vec3; NODES]> = ConstStaticCell::new([Vec3::ZERO; NODES]);
static NODE_RECS: ConstStaticCell<[Node; NODES]> = ConstStaticCell::new([ZERO_NODE; NODES]);
static TET_RECS: ConstStaticCell<[Tet; RAM_TETS]> = ConstStaticCell::new([ZERO_TET; RAM_TETS]);
static WORLD: ConstStaticCell<[Line; WORLD_LINES]> =
    ConstStaticCell::new([Line::ZERO; WORLD_LINES]);
// NOLOAD: its contents at reset do not matter, every slot is written by the carve.
#[cfg_attr(scenario_cow, link_section = ".psram.world")]
static WORLD_PSRAM: ConstStaticCell<[Line; PSRAM_LINES]> =
    ConstStaticCell::new([Line::ZERO; PSRAM_LINES]);
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
        let mut world = Split {
            a: Block::from_lines(WORLD.take()),
            b: Block::from_lines(WORLD_PSRAM.take()),
            second: PSRAM_PARTS,
        };
        let Ok(world) = WorldStorage::carve(&SIZES, &mut world) else {
            panic!("the world's statics do not hold its sizes");
        };
        Self {
            positions: POSITIONS.take(),
            mesh: MeshStorage {
                nodes,
                normals: NORMALS.take(),
                tets,
            },
            world,
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

    use tetradrill_core::servo::{carve_rest, SpareStorage};
    use tetradrill_core::soft::TetRest;
    use tetradrill_core::storage::{Block, Line};
    use tetradrill_core::Vec3;

    use super::{NODES, SIZES, TETS};

    /// Lines of the world's spare tables and rest positions.
    const DEFORM_LINES: usize = match SIZES.deform_lines(NODES) {
        Some(n) => n,
        None => panic!("the spare tables' sizes overflow"),
    };

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
    /// The world's spare tables and rest positions, carved by the core's layout.
    static DEFORM: ConstStaticCell<[Line; DEFORM_LINES]> =
        ConstStaticCell::new([Line::ZERO; DEFORM_LINES]);
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
        /// The world's spare tables (`World::set_spare`).
        pub spare: SpareStorage<'static>,
        /// `LinkBuffers::a`.
        pub load_a: &'static mut [Vec3],
        /// `LinkBuffers::b`.
        pub load_b: &'static mut [Vec3],
        /// `LinkBuffers::next`.
        pub next: &'static mut [Vec3],
    }

    /// Takes every soft static (panics, exit status 1, if called twice). The spare tables and
    /// rest positions are carved by the core's layout, every slot at its starting value, as
    /// the host's.
    pub fn take() -> SoftStatics {
        let mut deform = Block::from_lines(DEFORM.take());
        let (Ok(spare), Ok(world_rest)) = (
            SpareStorage::carve(&SIZES, NODES, &mut deform),
            carve_rest(NODES, &mut deform),
        ) else {
            panic!("the spare statics do not hold the world's sizes");
        };
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
            world_rest,
            spare,
            load_a: LOAD_A.take(),
            load_b: LOAD_B.take(),
            next: NEXT.take(),
        }
    }
}
