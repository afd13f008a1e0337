//! A tet-mesh tool (the pen) against an object on the heap: the storage the pen's contact
//! ([`crate::force::pen_contact`]) needs, allocated once, and the scene built over it
//! ([`PenRig`]).

use alloc::vec;
use alloc::vec::Vec;
use core::fmt;

use crate::collide::{
    hash_tets, walks_exact, Body, GridEntry, ListedNode, Occupancy, OccupancyError,
    OccupancyStorage, RigidError, RigidTets, RigidTetsStorage, MAX_NEAR_CLUSTERS,
};
use crate::depth::{graph_sizes, hash_boundary_faces, GraphError, NodeGraph};
use crate::force::{PenBufferSizes, PenBuffers, PenScene};
use crate::hash::{average_edge_length, prime_at_most, Aabb, HashEntry, SpatialHash};
use crate::ids::NodeId;
use crate::mesh::Mesh;
use crate::storage::{Part, StorageError};

use super::{Heap, OwnedMesh};

pub use crate::force::{
    occupancy_words, CLUSTER_EDGE, OCCUPANCY_LIST_SPLIT, OCCUPANCY_MARGIN, REST_GRID_EDGE,
    REST_MARGIN,
};

/// Storage of one spatial hash: about two buckets per item, `per` entries per item.
#[derive(Debug, Clone)]
pub struct HashStore {
    starts: Vec<u32>,
    entries: Vec<HashEntry>,
}

impl HashStore {
    /// Storage for `items` items of about `per` cells each.
    pub fn new(items: usize, per: usize) -> Self {
        Self::with_buckets(items, per, 2)
    }

    /// Storage for `items` items of about `per` cells each and `buckets` buckets per item
    /// (rounded down to a prime).
    pub fn with_buckets(items: usize, per: usize, buckets: usize) -> Self {
        let b = prime_at_most((buckets * items).clamp(3, u32::MAX as usize) as u32) as usize;
        Self {
            starts: vec![0; b + 1],
            entries: vec![HashEntry::default(); items * per],
        }
    }

    /// The same storage with `entries` entries.
    pub fn with_entries(mut self, entries: usize) -> Self {
        self.entries.truncate(entries);
        self.entries.resize(entries, HashEntry::default());
        self
    }

    /// An empty hash with cells of edge `cell` over this storage (`None` for a cell size the
    /// hash refuses).
    pub fn hash(&mut self, cell: f32) -> Option<SpatialHash<'_>> {
        SpatialHash::new(&mut self.starts, &mut self.entries, cell).ok()
    }
}

/// Why a pen scene could not be set up.
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub enum RigError {
    /// A node graph refused its storage.
    Graph(GraphError),
    /// A hash refused its cell size (a mesh with no edges).
    Hash,
    /// A static hash ran out of entries (the counts say which).
    Saturated(&'static str),
    /// The pen's rest-frame tets could not be prepared.
    Rigid(RigidError),
    /// The object's occupancy grid could not be built.
    Occupancy(OccupancyError),
    /// The per-tick buffers could not be allocated or carved.
    Storage(StorageError),
}

impl fmt::Display for RigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Graph(e) => write!(f, "node graph: {e:?}"),
            Self::Hash => f.write_str("spatial hash: no usable cell size"),
            Self::Saturated(what) => write!(f, "the {what} hash ran out of entries"),
            Self::Rigid(e) => write!(f, "pen at rest: {e}"),
            Self::Occupancy(e) => write!(f, "object occupancy: {e}"),
            Self::Storage(e) => write!(f, "pen buffers: {e}"),
        }
    }
}

impl core::error::Error for RigError {}

/// A pen and an object, owned; [`PenRig::with`] builds the scene and the per-tick buffers.
#[derive(Debug, Clone)]
pub struct PenRig {
    /// The tool at rest (tip at the origin, axis +z).
    pub pen: OwnedMesh,
    /// The object.
    pub obj: OwnedMesh,
}

/// Capacities of a pen rig; `None` sizes a buffer from the meshes so it never fills.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct PenSizes {
    /// Entries of the object's static tet hash (`None`: 16 per tet, and a full hash is an
    /// error, the mesh being degenerate; `Some`: a full hash keeps the tets that fit and is
    /// counted in [`PenSetup::hash_saturations`]).
    pub hash: Option<usize>,
    /// Collisions (and penetrations) each body holds per tick (`None`: its node count).
    pub contacts: Option<usize>,
    /// Entries of each depth propagation queue (`None`: the body's node count).
    pub queue: Option<usize>,
}

impl PenSizes {
    /// The per-tick buffers' sizes for a pen of `pen_nodes` nodes and `pen_edges` directed
    /// graph edges against an object of `object_nodes` and `object_edges`: these capacities,
    /// the node counts where they are `None`, and one remembered crossing per directed edge.
    pub fn buffers(
        &self,
        (pen_nodes, pen_edges): (usize, usize),
        (object_nodes, object_edges): (usize, usize),
    ) -> PenBufferSizes {
        PenBufferSizes {
            pen_contacts: self.contacts.unwrap_or(pen_nodes),
            object_contacts: self.contacts.unwrap_or(object_nodes),
            pen_queue: self.queue.unwrap_or(pen_nodes),
            object_queue: self.queue.unwrap_or(object_nodes),
            ..PenBufferSizes::nodes(pen_nodes, object_nodes)
        }
        .with_crossings(pen_edges, object_edges)
    }
}

/// What setting up a pen rig counted.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct PenSetup {
    /// Static hashes that ran out of entries (only with [`PenSizes::hash`] set).
    pub hash_saturations: u32,
}

impl PenRig {
    /// Builds the scene (node graphs, the object's tets, nodes and boundary faces hashed once,
    /// the pen's boundary faces hashed at rest) and the buffers, and hands them to `f`.
    ///
    /// # Errors
    /// [`RigError`] when the scene cannot be built from these meshes.
    pub fn with<R>(
        &mut self,
        f: impl FnOnce(&PenScene<'_, '_, '_>, &mut PenBuffers<'_>) -> R,
    ) -> Result<R, RigError> {
        self.with_sizes(PenSizes::default(), f).map(|(r, _)| r)
    }

    /// [`PenRig::with`] with the capacities of `sizes`. Everything is allocated and built
    /// before `f` runs; nothing is allocated while it runs.
    ///
    /// # Errors
    /// [`RigError`] when the scene cannot be built from these meshes and sizes.
    pub fn with_sizes<R>(
        &mut self,
        sizes: PenSizes,
        f: impl FnOnce(&PenScene<'_, '_, '_>, &mut PenBuffers<'_>) -> R,
    ) -> Result<(R, PenSetup), RigError> {
        let mut setup = PenSetup::default();
        let pen = self.pen.view();
        let obj = self.obj.view();
        let ob = Body::fixed(&obj);
        let (po, pa) = graph_sizes(&pen);
        let (mut pgo, mut pga) = (vec![0u32; po], vec![NodeId::NONE; pa]);
        let pg = NodeGraph::build(&pen, &mut pgo, &mut pga).map_err(RigError::Graph)?;
        let (oo, oa) = graph_sizes(&obj);
        let (mut ogo, mut oga) = (vec![0u32; oo], vec![NodeId::NONE; oa]);
        let og = NodeGraph::build(&obj, &mut ogo, &mut oga).map_err(RigError::Graph)?;
        let cell = average_edge_length(&obj);
        // About two buckets per stored entry (a tet's box covers about eight cells): each
        // pen-node lookup then scans little more than its own cell's tets.
        let mut ts = HashStore::with_buckets(obj.tet_count(), 16, 16);
        if let Some(n) = sizes.hash {
            ts = ts.with_entries(n);
        }
        let mut th = ts.hash(cell).ok_or(RigError::Hash)?;
        let tets_hashed = !hash_tets(&mut th, &ob).saturated;
        if !tets_hashed {
            if sizes.hash.is_none() {
                return Err(RigError::Saturated("object tet"));
            }
            setup.hash_saturations += 1;
        }
        let mut ns = HashStore::new(obj.node_count(), 1);
        let mut nh = ns.hash(cell).ok_or(RigError::Hash)?;
        if nh.rebuild_points(obj.positions()).saturated {
            return Err(RigError::Saturated("object node"));
        }
        let mut fs = HashStore::new(obj.tet_count(), 8);
        let mut fh = fs.hash(cell).ok_or(RigError::Hash)?;
        if hash_boundary_faces(&mut fh, &ob).saturated {
            return Err(RigError::Saturated("object face"));
        }
        let mut ps = HashStore::new(pen.tet_count(), 16);
        let mut ph = ps.hash(average_edge_length(&pen)).ok_or(RigError::Hash)?;
        if hash_boundary_faces(&mut ph, &Body::fixed(&pen)).saturated {
            return Err(RigError::Saturated("pen face"));
        }
        let mut rest = PenRest::new(&pen);
        let pen_rest = rest.build(&pen, cell)?;
        let mut cell_store = ObjectCells::new(&obj, cell);
        let cells = cell_store.build(&ob, cell)?;
        let scene = PenScene {
            pen: &pen,
            pen_graph: pg,
            pen_rest: &pen_rest,
            pen_faces: Some(&ph),
            object: ob,
            object_graph: og,
            object_tets: &th,
            object_nodes: &nh,
            object_cells: &cells,
            object_faces: Some(&fh),
            // Walks give the hash's contacts only over well-shaped tets that are all hashed.
            object_walks: tets_hashed && walks_exact(&ob),
            // `pen_rest` holds every pen tet (a full rest grid fails its build).
            pen_walks: walks_exact(&Body::fixed(&pen)),
        };
        let mut buffers =
            PenBufferHeap::new(sizes.buffers((pen.node_count(), pa), (obj.node_count(), oa)))
                .map_err(RigError::Storage)?;
        let mut bufs = buffers.buffers().map_err(RigError::Storage)?;
        Ok((f(&scene, &mut bufs), setup))
    }
}

/// A pen's per-tick buffers on the heap: one block of lines, carved by
/// [`PenBuffers::carve`].
#[derive(Debug, Clone)]
pub struct PenBufferHeap {
    sizes: PenBufferSizes,
    heap: Heap,
}

impl PenBufferHeap {
    /// Allocates the buffers of `sizes` (one heap block, [`PenBufferSizes::bytes`]).
    ///
    /// # Errors
    /// [`StorageError`] when the sizes overflow or the heap refuses them.
    pub fn new(sizes: PenBufferSizes) -> Result<Self, StorageError> {
        Ok(Self {
            heap: Heap::new(sizes.lines(), Part::PenPositions)?,
            sizes,
        })
    }

    /// The sizes these buffers hold.
    pub fn sizes(&self) -> &PenBufferSizes {
        &self.sizes
    }

    /// The buffers, every slot at its starting value.
    ///
    /// # Bounded work
    /// O(bytes held).
    ///
    /// # Errors
    /// None in practice (the block was sized for `sizes`); a [`StorageError`] otherwise.
    pub fn buffers(&mut self) -> Result<PenBuffers<'_>, StorageError> {
        PenBuffers::carve(&self.sizes, &mut self.heap.block())
    }
}

/// Storage of the object's [`Occupancy`]: the grid's words, a box per tet, the cells' tet
/// lists and node lists.
#[derive(Debug, Clone)]
pub struct ObjectCells {
    words: Vec<u32>,
    boxes: Vec<Aabb>,
    starts: Vec<u32>,
    tets: Vec<GridEntry>,
    node_starts: Vec<u32>,
    nodes: Vec<ListedNode>,
}

impl ObjectCells {
    /// Storage for `obj` with cells of `cell` ([`occupancy_words`]).
    pub fn new(obj: &Mesh<'_>, cell: f32) -> Self {
        Self {
            words: vec![0; occupancy_words(obj, cell)],
            boxes: vec![Aabb::of::<0>([]); obj.tet_count()],
            starts: Vec::new(),
            tets: Vec::new(),
            node_starts: Vec::new(),
            nodes: Vec::new(),
        }
    }

    /// The occupancy of `obj` with cells of `cell`, tet boxes grown by [`OCCUPANCY_MARGIN`]
    /// cells, each cell's list of tets ([`Occupancy::with_tet_lists`]: the pen's nodes are
    /// looked up there, not in the tet hash) and of nodes ([`Occupancy::with_node_lists`]: the
    /// object's nodes in the pen's clusters are read there, not in the node hash).
    ///
    /// # Errors
    /// [`RigError::Occupancy`] when the grid cannot be built.
    pub fn build(&mut self, obj: &Body<'_, '_>, cell: f32) -> Result<Occupancy<'_>, RigError> {
        let Self {
            words,
            boxes,
            starts,
            tets,
            node_starts,
            nodes,
        } = self;
        let storage = OccupancyStorage { words, boxes };
        let grid = Occupancy::build(obj, cell, OCCUPANCY_MARGIN * cell, storage)
            .map_err(RigError::Occupancy)?;
        let (n_starts, n_tets) = grid
            .tet_list_sizes(OCCUPANCY_LIST_SPLIT)
            .ok_or(RigError::Occupancy(OccupancyError::ListStorage))?;
        starts.resize(n_starts, 0);
        tets.resize(n_tets, GridEntry::default());
        let grid = grid
            .with_tet_lists(obj, OCCUPANCY_LIST_SPLIT, starts, tets)
            .map_err(RigError::Occupancy)?;
        let (n_starts, n_nodes) = grid.node_list_sizes(obj.positions.len());
        node_starts.resize(n_starts, 0);
        nodes.resize(n_nodes, ListedNode::default());
        grid.with_node_lists(obj, node_starts, nodes)
            .map_err(RigError::Occupancy)
    }
}

/// Storage of the pen's tets prepared at rest ([`RigidTets`]).
#[derive(Debug, Clone)]
pub struct PenRest {
    grid_starts: Vec<u32>,
    grid_tets: Vec<GridEntry>,
    tet_boxes: Vec<Aabb>,
    clusters: Vec<Aabb>,
    node_clusters: Vec<u32>,
}

impl PenRest {
    /// Storage for `pen`: its rest grid ([`RigidTets::grid_sizes`] with cells of
    /// [`REST_GRID_EDGE`] pen edges), up to [`MAX_NEAR_CLUSTERS`] clusters, a cluster index per
    /// node.
    pub fn new(pen: &Mesh<'_>) -> Self {
        let empty = Aabb::of::<0>([]);
        let mut tet_boxes = vec![empty; pen.tet_count()];
        let edge = average_edge_length(pen);
        let (cells, tets) = RigidTets::grid_sizes(
            &Body::fixed(pen),
            REST_GRID_EDGE * edge,
            REST_MARGIN * edge,
            &mut tet_boxes,
        )
        .unwrap_or((2, 0));
        Self {
            grid_starts: vec![0; cells],
            grid_tets: vec![GridEntry::default(); tets],
            tet_boxes,
            clusters: vec![empty; MAX_NEAR_CLUSTERS],
            node_clusters: vec![0; pen.node_count()],
        }
    }

    /// Grids and clusters `pen` at rest: the rest grid's cells are [`REST_GRID_EDGE`] of the
    /// pen's average edge, the clusters [`CLUSTER_EDGE`] cells of `object_cell` (the object's
    /// node hash cell).
    ///
    /// # Errors
    /// [`RigError::Rigid`] when the pen's tets cannot be gridded.
    pub fn build(&mut self, pen: &Mesh<'_>, object_cell: f32) -> Result<RigidTets<'_>, RigError> {
        let edge = average_edge_length(pen);
        RigidTets::build(
            &Body::fixed(pen),
            RigidTetsStorage {
                grid_starts: &mut self.grid_starts,
                grid_tets: &mut self.grid_tets,
                tet_boxes: &mut self.tet_boxes,
                clusters: &mut self.clusters,
                node_clusters: &mut self.node_clusters,
            },
            REST_GRID_EDGE * edge,
            CLUSTER_EDGE * object_cell,
            REST_MARGIN * edge,
        )
        .map_err(RigError::Rigid)
    }
}
