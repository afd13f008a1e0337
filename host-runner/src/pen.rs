//! A tet-mesh tool (the pen) against an object: the storage the core's
//! [`pen_contact`](tetradrill_core::force::pen_contact) needs, allocated once, and the scene
//! built over it. Used by `replay --tool mesh:FILE`, the contact tests and the benches.

use tetradrill_core::collide::{hash_tets, Body, Collision};
use tetradrill_core::depth::{
    graph_sizes, hash_boundary_faces, DepthScratch, GraphError, NodeGraph, NodeSlot, Penetration,
};
use tetradrill_core::force::{PenBuffers, PenScene};
use tetradrill_core::hash::{average_edge_length, prime_at_most, HashEntry, SpatialHash};
use tetradrill_core::{NodeId, Vec3};

use crate::owned::OwnedMesh;

/// Storage of one spatial hash: about two buckets per item, `per` entries per item.
#[derive(Debug, Clone)]
pub struct HashStore {
    starts: Vec<u32>,
    entries: Vec<HashEntry>,
}

impl HashStore {
    /// Storage for `items` items of about `per` cells each.
    pub fn new(items: usize, per: usize) -> Self {
        let b = prime_at_most((2 * items).clamp(3, u32::MAX as usize) as u32) as usize;
        Self {
            starts: vec![0; b + 1],
            entries: vec![HashEntry::default(); items * per],
        }
    }

    /// An empty hash with cells of edge `cell` over this storage.
    pub fn hash(&mut self, cell: f32) -> Option<SpatialHash<'_>> {
        SpatialHash::new(&mut self.starts, &mut self.entries, cell).ok()
    }
}

/// Why a pen scene could not be set up.
#[derive(Debug, Clone, PartialEq)]
pub enum RigError {
    /// A node graph refused its storage.
    Graph(GraphError),
    /// A hash refused its cell size (a mesh with no edges).
    Hash,
    /// A static hash ran out of entries (the counts say which).
    Saturated(&'static str),
}

impl std::fmt::Display for RigError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Graph(e) => write!(f, "node graph: {e:?}"),
            Self::Hash => f.write_str("spatial hash: no usable cell size"),
            Self::Saturated(what) => write!(f, "the {what} hash ran out of entries"),
        }
    }
}

/// A pen and an object, owned; [`PenRig::with`] builds the scene and the per-tick buffers.
#[derive(Debug, Clone)]
pub struct PenRig {
    /// The tool at rest (tip at the origin, axis +z).
    pub pen: OwnedMesh,
    /// The object.
    pub obj: OwnedMesh,
}

impl PenRig {
    /// Builds the scene (node graphs, the object's tets, nodes and boundary faces hashed once,
    /// the pen's boundary faces hashed at rest) and the buffers, and hands them to `f`.
    pub fn with<R>(
        &mut self,
        f: impl FnOnce(&PenScene<'_, '_, '_>, &mut PenBuffers<'_>) -> R,
    ) -> Result<R, RigError> {
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
        let mut ts = HashStore::new(obj.tet_count(), 16);
        let mut th = ts.hash(cell).ok_or(RigError::Hash)?;
        if hash_tets(&mut th, &ob).saturated {
            return Err(RigError::Saturated("object tet"));
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
        let scene = PenScene {
            pen: &pen,
            pen_graph: pg,
            pen_faces: Some(&ph),
            object: ob,
            object_graph: og,
            object_tets: &th,
            object_nodes: &nh,
            object_faces: Some(&fh),
        };
        let (np, no) = (pen.node_count(), obj.node_count());
        let mut world = vec![Vec3::ZERO; np];
        let (mut h1, mut h2) = (
            vec![Collision::default(); np],
            vec![Collision::default(); no],
        );
        let (mut p1, mut p2) = (
            vec![Penetration::default(); np],
            vec![Penetration::default(); no],
        );
        let (mut s1, mut q1) = (vec![NodeSlot::default(); np], vec![NodeId::NONE; np]);
        let (mut s2, mut q2) = (vec![NodeSlot::default(); no], vec![NodeId::NONE; no]);
        let mut bufs = PenBuffers {
            world: &mut world,
            pen_hits: &mut h1,
            object_hits: &mut h2,
            pen_pens: &mut p1,
            object_pens: &mut p2,
            pen_depth: DepthScratch::new(&mut s1, &mut q1),
            object_depth: DepthScratch::new(&mut s2, &mut q2),
        };
        Ok(f(&scene, &mut bufs))
    }
}
