//! The firmware's application, shared by its binaries: the servo and the simulation around
//! tetradrill-core, the lock-free hand-offs, the scenario, the static storage, the stack's
//! guard and measure, the [`hw::Board`] trait and the fault path. It plays the host's
//! `builtin:firmware` scenario (or `builtin:firmware-regions`, `builtin:firmware-soft`;
//! `builtin:firmware-cow` or `builtin:firmware-tooth`, the mesh's tets read in place from a
//! blob in flash) and prints the force digest the host's `replay` prints, the servo's latency
//! and the simulation's steps in instructions, and the deadline misses.
//!
//! Each binary is a small `#[rtic::app]` that binds its own servo timer and board
//! ([`bind_board!`]): this package's, QEMU's MPS2 machines (SysTick, [`mps2::Mps2`]), and the
//! STM32H743 board crate's (`ports/stm32h743`).
//!
//! | module          | what it is here                                                       |
//! |-----------------|-----------------------------------------------------------------------|
//! | [`servo`]       | one servo tick: device read, due contact, force, motor write, release  |
//! | [`sim`]         | one `World::simulate` per release, the contact handed back, the report |
//! | [`handoff`]     | the two SPSC queues (poses down, contacts up): no lock, no masking     |
//! | [`clock`]       | SysTick as the servo timer and the instruction counter under `-icount` |
//! | [`storage`]     | every slice the core borrows, in statics sized by `WorldSizes`         |
//! | [`memory`]      | the stack's guard and high-water mark; `.psram` zeroed at reset        |
//! | [`hw`]          | the `Board` trait; the force as three motor commands                  |
//! | [`policy`]      | the deadline-miss policy: hold one late tick, then ramp to zero        |
//! | [`fault`]       | every fault stops the motors first, then logs and resets; injection    |
//! | [`mps2`]        | QEMU's MPS2 board: a static DAC, the CMSDK watchdog, UART0             |
//! | `soft`          | `builtin:firmware-soft`: the soft body, its step spread by `soft::Link` |
//! | [`target`]      | the M4 / M7 differences: board and the clock the period assumes        |

#![no_std]

pub mod board;
pub mod clock;
pub mod fault;
pub mod handoff;
pub mod hw;
pub mod memory;
pub mod mps2;
pub mod policy;
pub mod scenario;
pub mod servo;
pub mod sim;
#[cfg(scenario_soft)]
pub mod soft;
pub mod storage;
pub mod target;

use tetradrill_core::blob::MeshBlob;
use tetradrill_core::builtin;
use tetradrill_core::collide::{ZoneGather, ZONE_MARGIN_RADII};
use tetradrill_core::force::closest_point_on_triangle;
use tetradrill_core::ids::TetId;
use tetradrill_core::mesh::{BuildOptions, FaceKey, Mesh, MeshStorage, Node};
use tetradrill_core::servo::World;
use tetradrill_core::Vec3;

use storage::{Storage, NODES, TETS};

/// Cubes per side of the built-in block (`builtin:block:4`).
pub const BLOCK_N: usize = 4;
/// The mesh blob `tetradrill export --firmware` wrote, included at build time and read in
/// place from flash (empty for the block; see `build.rs`).
static MESH_BLOB: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/mesh.tdb"));

/// Builds the mesh (the block, or the blob's) and the world over the static storage, the world
/// itself in a static ([`storage::place_world`]: 25 KB, kept off the stack).
#[inline(never)]
pub fn build_world() -> &'static mut World<'static> {
    let st = Storage::take();
    if cfg!(blob_mesh) {
        let mesh = mesh_from_blob(st.positions, st.mesh.normals, st.mesh.nodes);
        let world = storage::place_world(mesh, st.world);
        world.set_contact_max_nodes(scenario::contact_nodes());
        if cfg!(scenario_tooth) {
            let regions = blob_regions(st.regions, st.tet_region)
                .unwrap_or_else(|| fail("region storage refused or a label not the tooth's"));
            world.set_regions(regions);
            world.set_zone_gather(Some(ZoneGather::new(
                scenario::ZONE_WORK,
                ZONE_MARGIN_RADII,
            )));
        }
        if cfg!(scenario_cow) {
            world.set_max_cells(scenario::COW_MAX_CELLS);
            world.set_zone_gather(Some(ZoneGather::new(
                scenario::ZONE_WORK,
                ZONE_MARGIN_RADII,
            )));
        }
        return world;
    }
    let mesh = block_mesh(st.positions, st.tet_nodes, st.face_scratch, st.mesh);
    let world = storage::place_world(mesh, st.world);
    world.set_contact_max_nodes(scenario::contact_nodes());
    if cfg!(scenario_regions) {
        let regions = crate::storage::regions(st.regions, st.tet_region)
            .unwrap_or_else(|| fail("region storage refused"));
        world.set_regions(regions);
    }
    world
}

/// The mesh of the included blob: checked ([`MeshBlob::parse`]: version, checksum, ids in
/// range, neighbours pointing back), its tets read in place from flash, its positions,
/// normals and node records copied into RAM ([`MeshBlob::mesh`]).
fn mesh_from_blob(
    positions: &'static mut [Vec3],
    normals: &'static mut [Vec3],
    nodes: &'static mut [Node],
) -> Mesh<'static> {
    let blob =
        MeshBlob::parse(MESH_BLOB).unwrap_or_else(|e| fail_args(format_args!("mesh blob: {}", e)));
    if blob.node_count() != positions.len() || blob.tet_count() != TETS {
        fail("mesh blob counts differ from the storage");
    }
    blob.mesh(positions, normals, nodes)
        .unwrap_or_else(|_| fail("mesh blob storage refused"))
}

/// The tooth's regions: each tet's index is its blob label's place in
/// [`scenario::TOOTH_LABELS`] (the host's numbering, one region per distinct label in label
/// order). `None` for a label not among them or a table the core refuses.
fn blob_regions(
    table: &'static mut [tetradrill_core::drill::Region],
    of_tet: &'static mut [u8],
) -> Option<tetradrill_core::drill::Regions<'static>> {
    let blob = MeshBlob::parse(MESH_BLOB).ok()?;
    for (i, slot) in of_tet.iter_mut().enumerate() {
        let label = blob.label(TetId(i as u32))?;
        let at = scenario::TOOTH_LABELS.iter().position(|&l| l == label)?;
        *slot = at as u8;
    }
    tetradrill_core::drill::Regions::new(table, of_tet).ok()
}

/// Instructions for a few primitives the core leans on (a diagnostic for docs/PORTING.md):
/// `Vec3::length` (glam through libm's software `sqrtf`), the point-triangle distance, and one
/// f64 multiply-add (software on a single-precision FPU).
#[inline(never)]
pub fn unit_costs(overhead: u64) -> [u64; 3] {
    use core::hint::black_box;
    let v = black_box(Vec3::new(0.3, -0.2, 0.7));
    let tri = black_box([
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::new(1.0, 0.0, 0.1),
        Vec3::new(0.0, 1.0, 0.2),
    ]);
    let (a, b, c) = (black_box(1.25f64), black_box(3.5f64), black_box(0.75f64));
    let t0 = clock::read();
    black_box(black_box(v).length());
    let t1 = clock::read();
    black_box(closest_point_on_triangle(black_box(v), tri));
    let t2 = clock::read();
    black_box(black_box(a) * b + c);
    let t3 = clock::read();
    [t1 - t0, t2 - t1, t3 - t2].map(|d| clock::instructions(d as u64).saturating_sub(overhead))
}

/// The unit block, exactly as the host's `builtin:block:N` makes it (its tet list and the
/// face scratch in statics, see [`storage`]).
fn block_mesh(
    positions: &'static mut [Vec3],
    tet_nodes: &'static mut [[u32; 4]],
    scratch: &'static mut [FaceKey],
    storage: MeshStorage<'static>,
) -> Mesh<'static> {
    let edge = 1.0 / BLOCK_N as f32;
    if builtin::block(BLOCK_N, edge, Vec3::splat(-0.5), positions, tet_nodes).is_none() {
        fail("block storage too small");
    }
    debug_assert_eq!(positions.len(), NODES);
    Mesh::build(
        positions,
        tet_nodes,
        storage,
        scratch,
        BuildOptions::default(),
    )
    .unwrap_or_else(|_| fail("mesh build failed"))
}

/// Ends the run: motors off, `exit_status=0`, reset ([`fault::exit_success`]).
pub fn exit_success() -> ! {
    fault::exit_success()
}

/// Stops with `error: REASON` ([`fault::stop`]: motors off first, then the report, then a
/// reset).
pub fn fail(reason: &str) -> ! {
    fail_args(format_args!("{}", reason))
}

/// [`fail`] with a formatted reason.
pub fn fail_args(reason: core::fmt::Arguments) -> ! {
    fault::stop("error", format_args!("error: {}", reason))
}
