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
//! which writes every slot's starting value (the memory may hold anything before); the mesh's
//! node records, normals and tet records are another, carved by `MeshStorage::carve`, and the
//! soft body's storage a third (`soft::take`). The arrays of lines and of positions start as
//! zero bytes, so they land in `.bss` (no flash).

use static_cell::{ConstStaticCell, StaticCell};

use tetradrill_core::builtin::block_counts;
use tetradrill_core::builtin::{block_labels, BLOCK_CORE, BLOCK_SHELL};
use tetradrill_core::drill::{Region, Regions};
use tetradrill_core::mesh::{FaceKey, Mesh, MeshStorage};
use tetradrill_core::servo::{World, WorldSizes, WorldStorage};
use tetradrill_core::storage::{carve, Block, Line, Part, PartSet, Split};
use tetradrill_core::Vec3;

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
    // No change log: nothing on the board reads it (a surface exporter would sweep instead).
    let mut s = WorldSizes::new(TETS, ARENA)
        .with_pending(PENDING_ITEMS)
        .with_changes(0);
    s.candidates = scenario::CANDIDATES;
    if let Some(entries) = scenario::HASH_ENTRIES {
        s.hash_entries = entries;
    }
    if let Some(slots) = scenario::SPHERE_MEMO {
        s = s.with_sphere_memo(slots);
    }
    if cfg!(scenario_soft) {
        // Each step's commit empties the memo: 256 slots (6 KB) instead of the host's 4,096
        // (96 KB). Any size gives the same results.
        s = s.with_sphere_memo(scenario::SOFT_SPHERE_MEMO);
    }
    s
};

/// The world's parts in its second array ([`WORLD_SECOND`]): on the cow the hash (8 entries a
/// tet, 2.3 MB) and the pending deque, in PSRAM; on a chip the parts its first region cannot
/// hold (`scenario::SECOND_PARTS`); none elsewhere.
pub const SECOND_PARTS: PartSet = if cfg!(scenario_cow) {
    PartSet::EMPTY.with(Part::HashEntries).with(Part::Pending)
} else {
    scenario::SECOND_PARTS
};

/// Lines of the world's storage in its first and its second array.
const WORLD_LINES: usize = match SIZES.lines_in(SECOND_PARTS, false) {
    Some(n) => n,
    None => panic!("the world's sizes overflow"),
};
const SECOND_LINES: usize = match SIZES.lines_in(SECOND_PARTS, true) {
    Some(n) => n,
    None => panic!("the world's sizes overflow"),
};

/// Lines of the mesh's node records, normals and tet records.
const MESH_LINES: usize = match MeshStorage::lines(NODES, RAM_TETS) {
    Some(n) => n,
    None => panic!("the mesh's sizes overflow"),
};

// On a chip every array below names its region (`memory-f405.x.in`, `memory-h743.x.in`):
// NOLOAD sections that `__pre_init` zeroes (the cells' taken flags) and whose slots the carve
// or the mesh's build writes before use. Elsewhere they are `.bss` (the cow's second world
// array in `.psram`, NOLOAD as well).

/// The mesh's node positions.
#[cfg_attr(feature = "chip-f405", link_section = ".ccm.positions")]
#[cfg_attr(feature = "chip-h743", link_section = ".sram4.positions")]
static POSITIONS: ConstStaticCell<[Vec3; NODES]> = ConstStaticCell::new([Vec3::ZERO; NODES]);
/// The mesh's records, carved by the core's layout.
#[cfg_attr(feature = "chip-f405", link_section = ".ccm.mesh")]
#[cfg_attr(feature = "chip-h743", link_section = ".sram4.mesh")]
static MESH: ConstStaticCell<[Line; MESH_LINES]> = ConstStaticCell::new([Line::ZERO; MESH_LINES]);
/// The world's storage but [`SECOND_PARTS`].
#[cfg_attr(feature = "chip-f405", link_section = ".sram.world")]
#[cfg_attr(feature = "chip-h743", link_section = ".axisram.world")]
static WORLD: ConstStaticCell<[Line; WORLD_LINES]> =
    ConstStaticCell::new([Line::ZERO; WORLD_LINES]);
/// The world's [`SECOND_PARTS`].
#[cfg_attr(scenario_cow, link_section = ".psram.world")]
#[cfg_attr(feature = "chip-f405", link_section = ".ccm.world")]
#[cfg_attr(feature = "chip-h743", link_section = ".sram123.world")]
static WORLD_SECOND: ConstStaticCell<[Line; SECOND_LINES]> =
    ConstStaticCell::new([Line::ZERO; SECOND_LINES]);
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
#[cfg_attr(feature = "chip-f405", link_section = ".ccm.tet_region")]
#[cfg_attr(feature = "chip-h743", link_section = ".sram4.tet_region")]
static TET_REGION: ConstStaticCell<[u8; TETS]> = ConstStaticCell::new([0; TETS]);

/// The block's tet list (node indices; empty for a blob's mesh), written by `builtin::block`.
#[cfg_attr(feature = "chip-f405", link_section = ".ccm.tet_nodes")]
#[cfg_attr(feature = "chip-h743", link_section = ".sram4.tet_nodes")]
static TET_NODES: ConstStaticCell<[[u32; 4]; RAM_TETS]> = ConstStaticCell::new([[0; 4]; RAM_TETS]);
/// The world itself (25 KB: its zone memo and walk stacks are inline), in `.bss` rather than
/// moved through `init`'s stack frame into RTIC's resources.
#[cfg_attr(feature = "chip-f405", link_section = ".sram.world_value")]
#[cfg_attr(feature = "chip-h743", link_section = ".dtcm.world_value")]
static WORLD_VALUE: StaticCell<World<'static>> = StaticCell::new();

/// The world over `mesh` and `storage`, built into its static (once; a second call panics).
/// Exits through [`crate::fail`] if the core refuses the storage.
#[inline(never)]
pub fn place_world(
    mesh: Mesh<'static>,
    storage: WorldStorage<'static>,
) -> &'static mut World<'static> {
    WORLD_VALUE.init_with(|| {
        World::new(mesh, storage).unwrap_or_else(|_| crate::fail("world storage refused"))
    })
}

/// The storage, taken once.
pub struct Storage {
    /// Node positions of the block.
    pub positions: &'static mut [Vec3],
    /// The mesh's records.
    pub mesh: MeshStorage<'static>,
    /// The world's arrays, carved into its storage once the mesh is built.
    pub world: WorldLines,
    /// The regions' materials (two on the block, three on the tooth) and what they have
    /// earned and lost.
    pub regions: &'static mut [Region],
    /// Each tet's region index.
    pub tet_region: &'static mut [u8],
    /// The block's tet list (empty for a blob's mesh).
    pub tet_nodes: &'static mut [[u32; 4]],
}

/// The world's two arrays of lines before its storage is carved from them: first lent to
/// `Mesh::build` as its face scratch ([`WorldLines::face_scratch`], 24 KB on the block), then
/// carved ([`WorldLines::carve`]), so the scratch takes no memory of its own.
pub struct WorldLines {
    first: &'static mut [Line],
    second: &'static mut [Line],
}

impl WorldLines {
    /// `Mesh::build`'s face scratch (`4 * RAM_TETS` keys; empty for a blob's mesh, built
    /// without it), carved from the world's first array. Exits through [`crate::fail`] if
    /// the array is smaller.
    pub fn face_scratch(&mut self) -> &mut [FaceKey] {
        let mut mem = Block::from_lines(&mut *self.first);
        carve(&mut mem, Part::Other, 4 * RAM_TETS, FaceKey::ZERO)
            .unwrap_or_else(|_| crate::fail("the world's statics do not hold the face scratch"))
    }

    /// The world's storage, every slot at the value the host's storage starts with (what the
    /// face scratch left there overwritten). Panics (exit status 1) if the arrays do not hold
    /// [`SIZES`].
    pub fn carve(self) -> WorldStorage<'static> {
        let mut world = Split {
            a: Block::from_lines(self.first),
            b: Block::from_lines(self.second),
            second: SECOND_PARTS,
        };
        let Ok(world) = WorldStorage::carve(&SIZES, &mut world) else {
            panic!("the world's statics do not hold its sizes");
        };
        world
    }
}

impl Storage {
    /// Takes every static, filled with the values the host's storage starts with. Panics
    /// (exit status 1 through the panic handler) if called twice.
    pub fn take() -> Self {
        let Ok(mesh) = MeshStorage::carve(NODES, RAM_TETS, &mut Block::from_lines(MESH.take()))
        else {
            panic!("the mesh's statics do not hold its sizes");
        };
        let world = WorldLines {
            first: WORLD.take(),
            second: WORLD_SECOND.take(),
        };
        Self {
            positions: POSITIONS.take(),
            mesh,
            world,
            regions: REGIONS.take(),
            tet_region: TET_REGION.take(),
            tet_nodes: TET_NODES.take(),
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

/// The soft body's storage in `builtin:firmware-soft` (cfg `scenario_soft`): the world's
/// spare tables and rest positions (`World::set_spare`, `World::enable_deformation`), the
/// body's rest mesh (`soft::carve_mesh`), its state (`SoftStorage`) and the link's buffers
/// (`soft::LinkBuffers`), all carved by the core's layout from one array of lines in `.bss`.
#[cfg(scenario_soft)]
pub mod soft {
    use static_cell::ConstStaticCell;

    use tetradrill_core::servo::{carve_rest, SpareStorage};
    use tetradrill_core::soft::{carve_mesh, mesh_lines, LinkBuffers, SoftStorage};
    use tetradrill_core::storage::{Block, Line};
    use tetradrill_core::Vec3;

    use super::{NODES, SIZES, TETS};

    /// Lines of the whole soft storage: the world's spare tables and rest positions, the
    /// body's rest mesh, its state and the link's buffers.
    const SOFT_LINES: usize = match (
        SIZES.deform_lines(NODES),
        mesh_lines(NODES, TETS),
        SoftStorage::lines(NODES, TETS),
        LinkBuffers::lines(NODES),
    ) {
        (Some(a), Some(b), Some(c), Some(d)) => a + b + c + d,
        _ => panic!("the soft storage's sizes overflow"),
    };

    /// Every soft part, carved by the core's layout.
    static SOFT: ConstStaticCell<[Line; SOFT_LINES]> =
        ConstStaticCell::new([Line::ZERO; SOFT_LINES]);

    /// The soft body's slices, taken once.
    pub struct SoftStatics {
        /// Rest positions (`SoftMesh::rest`).
        pub rest: &'static mut [Vec3],
        /// Tets as node indices (`SoftMesh::tets`).
        pub tets: &'static mut [[u32; 4]],
        /// The body's state and scratch.
        pub storage: SoftStorage<'static>,
        /// The world's rest state (`World::enable_deformation`).
        pub world_rest: &'static mut [Vec3],
        /// The world's spare tables (`World::set_spare`).
        pub spare: SpareStorage<'static>,
        /// The link's load buffers and next positions.
        pub link: LinkBuffers<'static>,
    }

    /// Takes every soft static (panics, exit status 1, if called twice), every slot at its
    /// starting value, as the host's.
    pub fn take() -> SoftStatics {
        let mut mem = Block::from_lines(SOFT.take());
        let (Ok(spare), Ok(world_rest), Ok((rest, tets)), Ok(storage), Ok(link)) = (
            SpareStorage::carve(&SIZES, NODES, &mut mem),
            carve_rest(NODES, &mut mem),
            carve_mesh(NODES, TETS, &mut mem),
            SoftStorage::carve(NODES, TETS, &mut mem),
            LinkBuffers::carve(NODES, &mut mem),
        ) else {
            panic!("the soft statics do not hold the soft body's sizes");
        };
        SoftStatics {
            rest,
            tets,
            storage,
            world_rest,
            spare,
            link,
        }
    }
}
