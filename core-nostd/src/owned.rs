//! Heap storage (feature `alloc`): a structure's sizes turned into its storage in one call,
//! for desktop programs, tests and benches. Each type holds one heap [`Heap`] of lines and
//! carves its structure's slices from it with the same function a firmware or a C program
//! uses on its own memory ([`crate::servo::WorldStorage::carve`],
//! [`crate::hierarchy::HierarchyStorage::carve`], [`crate::force::PenBuffers::carve`],
//! [`crate::soft::SoftStorage::carve`]), so there is one layout for all of them:
//! [`WorldBuffers`], [`HierarchyBuffers`], [`PenBufferHeap`], [`SoftBuffers`]. A tet-mesh
//! tool's whole scene (node graphs, spatial hashes, the pen's rest grid, the object's
//! occupancy, the per-tick buffers) is built by [`PenRig`]. [`OwnedMesh`] keeps its records
//! in typed vectors: a built mesh is viewed again and again, and read through `&self`, which a
//! carve (it writes every slot) cannot give.
//!
//! ```
//! use tetradrill_core::owned::{OwnedMesh, WorldBuffers};
//! use tetradrill_core::servo::WorldSizes;
//! use tetradrill_core::builtin;
//!
//! let (pos, tets) = builtin::cube12();
//! let mut mesh = OwnedMesh::build(pos.to_vec(), &tets, Default::default())?;
//! let mut buffers = WorldBuffers::new(WorldSizes::new(mesh.tets().len(), 4096))?;
//! let world = buffers.world(mesh.view())?;
//! assert_eq!(world.hierarchy().stats().visible_faces, 12);
//! # Ok::<(), tetradrill_core::Error>(())
//! ```

mod pen;
mod soft;

pub use pen::{
    occupancy_words, HashStore, ObjectCells, PenBufferHeap, PenRest, PenRig, PenSetup, PenSizes,
    RigError, CLUSTER_EDGE, OCCUPANCY_LIST_SPLIT, OCCUPANCY_MARGIN, REST_GRID_EDGE, REST_MARGIN,
};
pub use soft::SoftBuffers;

use alloc::vec;
use alloc::vec::Vec;

use glam::Vec3;

use crate::drill::{Region, Regions};
use crate::hierarchy::{Hierarchy, HierarchyError, HierarchySizes, HierarchyStorage};
use crate::mesh::{BuildError, BuildOptions, BuildStats, FaceKey, Mesh, MeshStorage, Node, Tet};
use crate::servo::{carve_rest, SpareStorage, World, WorldError, WorldSizes, WorldStorage};
use crate::storage::{Block, Line, Part, StorageError, LINE};

/// A run of lines on the heap, allocated once.
#[derive(Debug, Clone)]
pub struct Heap {
    lines: Vec<Line>,
}

impl Heap {
    /// `lines` lines of zero bytes (`None` counts as an overflow of `part`'s sizes).
    ///
    /// # Errors
    /// [`StorageError::Alloc`] when the heap refuses the bytes (a mistyped capacity is an
    /// error, not an abort), [`StorageError::Overflow`] when `lines` is `None`.
    pub fn new(lines: Option<usize>, part: Part) -> Result<Self, StorageError> {
        let n = lines.ok_or(StorageError::Overflow { part })?;
        let bytes = n.saturating_mul(LINE);
        let mut v = Vec::new();
        v.try_reserve_exact(n)
            .map_err(|_| StorageError::Alloc { bytes })?;
        v.resize(n, Line::ZERO);
        Ok(Self { lines: v })
    }

    /// The lines as a [`Block`] to carve from.
    pub fn block(&mut self) -> Block<'_> {
        Block::from_lines(&mut self.lines)
    }

    /// Bytes held.
    pub fn bytes(&self) -> usize {
        self.lines.len() * LINE
    }
}

/// The materials of a world's regions and each tet's region (see [`Regions`]).
#[derive(Debug, Clone)]
struct RegionBuffers {
    table: Vec<Region>,
    of_tet: Vec<u8>,
}

/// A deforming world's spare tables and rest positions ([`WorldBuffers::with_deformation`]).
#[derive(Debug, Clone)]
struct DeformBuffers {
    nodes: usize,
    heap: Heap,
}

/// A [`World`]'s storage on the heap: `WorldBuffers::new(sizes)`, then
/// [`WorldBuffers::world`] for each world over it (a reset makes a fresh one).
#[derive(Debug, Clone)]
pub struct WorldBuffers {
    sizes: WorldSizes,
    heap: Heap,
    regions: Option<RegionBuffers>,
    deform: Option<DeformBuffers>,
}

impl WorldBuffers {
    /// Allocates the storage of `sizes` (one heap block, [`WorldSizes::bytes`]).
    ///
    /// # Errors
    /// [`StorageError`] when the sizes overflow or the heap refuses them.
    pub fn new(sizes: WorldSizes) -> Result<Self, StorageError> {
        Ok(Self {
            heap: Heap::new(sizes.lines(), Part::HashStarts)?,
            sizes,
            regions: None,
            deform: None,
        })
    }

    /// Gives the worlds made from these buffers their regions: `regions[r]` for region `r`
    /// (its material and settings: [`Region::with_vibration`], [`Region::with_cutting_energy`],
    /// [`Region::with_friction`]), and `of_tet[t]` the region of tet `t` (see
    /// [`Regions::new`]). Each world starts with no credit and nothing removed
    /// ([`Region::fresh`]).
    pub fn set_regions(&mut self, regions: &[Region], of_tet: Vec<u8>) {
        self.regions = Some(RegionBuffers {
            table: regions.iter().map(Region::fresh).collect(),
            of_tet,
        });
    }

    /// Allocates a deforming world's rest positions and spare tables for a mesh of `nodes`
    /// nodes ([`World::enable_deformation`], [`World::set_spare`]): the worlds made from
    /// these buffers may then move their nodes.
    ///
    /// # Errors
    /// [`StorageError`] when the sizes overflow or the heap refuses them (nothing changed).
    pub fn enable_deformation(&mut self, nodes: usize) -> Result<(), StorageError> {
        let heap = Heap::new(self.sizes.deform_lines(nodes), Part::SpareHashStarts)?;
        self.deform = Some(DeformBuffers { nodes, heap });
        Ok(())
    }

    /// The sizes these buffers hold.
    pub fn sizes(&self) -> &WorldSizes {
        &self.sizes
    }

    /// Bytes held, all parts together.
    pub fn bytes(&self) -> usize {
        self.heap.bytes() + self.deform.as_ref().map_or(0, |d| d.heap.bytes())
    }

    /// The storage, every slot at its starting value.
    ///
    /// # Bounded work
    /// O(bytes held).
    ///
    /// # Errors
    /// None in practice (the heap block was sized for `sizes`); a [`StorageError`] otherwise.
    pub fn storage(&mut self) -> Result<WorldStorage<'_>, StorageError> {
        WorldStorage::carve(&self.sizes, &mut self.heap.block())
    }

    /// A fresh world over `mesh` and these buffers, with their regions and deformation
    /// storage if set.
    ///
    /// # Bounded work
    /// O(bytes held + T) for T tets (see [`World::new`]).
    ///
    /// # Errors
    /// [`WorldError`] when a part refuses its storage.
    pub fn world<'a>(&'a mut self, mesh: Mesh<'a>) -> Result<World<'a>, WorldError> {
        let storage = WorldStorage::carve(&self.sizes, &mut self.heap.block())
            .map_err(WorldError::Storage)?;
        let mut world = World::new(mesh, storage)?;
        if let Some(r) = &mut self.regions {
            for region in r.table.iter_mut() {
                *region = region.fresh();
            }
            world.set_regions(Regions::new(&mut r.table, &r.of_tet).map_err(WorldError::Regions)?);
        }
        if let Some(d) = &mut self.deform {
            let mut mem = d.heap.block();
            let spare =
                SpareStorage::carve(&self.sizes, d.nodes, &mut mem).map_err(WorldError::Storage)?;
            let rest = carve_rest(d.nodes, &mut mem).map_err(WorldError::Storage)?;
            world.enable_deformation(rest).map_err(WorldError::Deform)?;
            world.set_spare(spare).map_err(WorldError::Deform)?;
        }
        Ok(world)
    }
}

/// A [`Hierarchy`]'s storage on the heap.
#[derive(Debug, Clone)]
pub struct HierarchyBuffers {
    sizes: HierarchySizes,
    heap: Heap,
}

impl HierarchyBuffers {
    /// Allocates the storage of `sizes`.
    ///
    /// # Errors
    /// [`StorageError`] when the sizes overflow or the heap refuses them.
    pub fn new(sizes: HierarchySizes) -> Result<Self, StorageError> {
        Ok(Self {
            heap: Heap::new(sizes.lines(), Part::Roots)?,
            sizes,
        })
    }

    /// The sizes these buffers hold.
    pub fn sizes(&self) -> &HierarchySizes {
        &self.sizes
    }

    /// The storage, every node a fresh leaf.
    ///
    /// # Errors
    /// None in practice (the block was sized for `sizes`); a [`StorageError`] otherwise.
    pub fn storage(&mut self) -> Result<HierarchyStorage<'_>, StorageError> {
        HierarchyStorage::carve(&self.sizes, &mut self.heap.block())
    }

    /// A fresh hierarchy over `mesh` and these buffers.
    ///
    /// # Errors
    /// [`HierarchyError`] when the storage is too small for the mesh.
    pub fn hierarchy<'a>(&'a mut self, mesh: &Mesh<'_>) -> Result<Hierarchy<'a>, HierarchyError> {
        let storage = self.storage().map_err(HierarchyError::Storage)?;
        Hierarchy::new(mesh, storage)
    }
}

/// One built core mesh on the heap: the positions, boundary normals, node and tet records,
/// built once ([`Mesh::build`]); [`OwnedMesh::view`] is the mesh over them, as often as
/// needed.
#[derive(Debug, Clone)]
pub struct OwnedMesh {
    positions: Vec<Vec3>,
    normals: Vec<Vec3>,
    nodes: Vec<Node>,
    tets: Vec<Tet>,
    stats: BuildStats,
}

impl OwnedMesh {
    /// Allocates storage for the counts and builds the mesh (see [`Mesh::build`]).
    ///
    /// # Errors
    /// What [`Mesh::build`] refuses.
    pub fn build(
        positions: Vec<Vec3>,
        tet_nodes: &[[u32; 4]],
        options: BuildOptions,
    ) -> Result<Self, BuildError> {
        let n = positions.len();
        let t = tet_nodes.len();
        let mut me = Self {
            positions,
            normals: vec![Vec3::ZERO; n],
            nodes: vec![Node::default(); n],
            tets: vec![Tet::default(); t],
            stats: BuildStats::default(),
        };
        let mut scratch = vec![FaceKey::default(); 4 * t];
        let storage = MeshStorage {
            nodes: &mut me.nodes,
            normals: &mut me.normals,
            tets: &mut me.tets,
        };
        let mesh = Mesh::build(&mut me.positions, tet_nodes, storage, &mut scratch, options)?;
        me.stats = mesh.stats();
        Ok(me)
    }

    /// A view of the mesh.
    ///
    /// # Bounded work
    /// O(1).
    pub fn view(&mut self) -> Mesh<'_> {
        let t = self.tets.len();
        let stats = self.stats;
        let storage = MeshStorage {
            nodes: &mut self.nodes,
            normals: &mut self.normals,
            tets: &mut self.tets,
        };
        Mesh::from_parts(&mut self.positions, storage, t, stats)
    }

    /// Build statistics.
    pub fn stats(&self) -> BuildStats {
        self.stats
    }

    /// Node positions.
    pub fn positions(&self) -> &[Vec3] {
        &self.positions
    }

    /// Node records (with each node's boundary flag).
    pub fn nodes(&self) -> &[Node] {
        &self.nodes
    }

    /// Tets.
    pub fn tets(&self) -> &[Tet] {
        &self.tets
    }
}
