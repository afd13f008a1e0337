//! [`NodeGraph`]: the node adjacency of a mesh (its edges) in compressed rows, built once.

use crate::ids::NodeId;
use crate::mesh::Mesh;

/// The neighbours of every node, from the mesh's edges: node `n`'s neighbours are
/// `adj[offsets[n]..offsets[n + 1]]`.
#[derive(Clone, Copy, Debug)]
pub struct NodeGraph<'a> {
    offsets: &'a [u32],
    adj: &'a [NodeId],
}

/// Why a graph cannot be built.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
#[non_exhaustive]
pub enum GraphError {
    /// `offsets` needs `nodes + 1` entries and `adj` twice the edge count ([`graph_sizes`]).
    StorageTooSmall {
        /// Offsets needed.
        offsets: usize,
        /// Adjacency entries needed.
        adj: usize,
    },
}

impl core::fmt::Display for GraphError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        let Self::StorageTooSmall { offsets, adj } = self;
        write!(
            f,
            "node graph needs {offsets} offsets and {adj} adjacency entries"
        )
    }
}

impl core::error::Error for GraphError {}

/// `(offsets, adjacency)` lengths [`NodeGraph::build`] needs for `mesh`.
///
/// # Bounded work
/// O(T * 6 * v), one pass over [`Mesh::edges`]; set-up only.
pub fn graph_sizes(mesh: &Mesh<'_>) -> (usize, usize) {
    (mesh.node_count() + 1, 2 * mesh.edges().count())
}

impl<'a> NodeGraph<'a> {
    /// Builds the graph into caller storage (counting sort over [`Mesh::edges`]).
    ///
    /// # Bounded work
    /// Two passes over [`Mesh::edges`], O(T * 6 * v); set-up only.
    ///
    /// # Errors
    /// [`GraphError::StorageTooSmall`] before anything is written when a slice is too short.
    pub fn build(
        mesh: &Mesh<'_>,
        offsets: &'a mut [u32],
        adj: &'a mut [NodeId],
    ) -> Result<Self, GraphError> {
        let (no, na) = graph_sizes(mesh);
        if offsets.len() < no || adj.len() < na || na > u32::MAX as usize {
            return Err(GraphError::StorageTooSmall {
                offsets: no,
                adj: na,
            });
        }
        let offsets = &mut offsets[..no];
        let adj = &mut adj[..na];
        offsets.fill(0);
        for e in mesh.edges() {
            for n in mesh.edge_nodes(e) {
                offsets[n.idx()] += 1;
            }
        }
        let mut run = 0u32;
        for o in offsets.iter_mut() {
            run += *o;
            *o = run; // end of the row
        }
        for e in mesh.edges() {
            let [a, b] = mesh.edge_nodes(e);
            for (n, m) in [(a, b), (b, a)] {
                let o = &mut offsets[n.idx()];
                *o -= 1;
                adj[*o as usize] = m;
            }
        }
        // Rows in ascending neighbour order, so results never depend on the edge order.
        for n in 0..no - 1 {
            let (lo, hi) = (offsets[n] as usize, offsets[n + 1] as usize);
            adj[lo..hi].sort_unstable();
        }
        Ok(Self { offsets, adj })
    }

    /// The index of `n`'s first adjacency entry and its neighbours: neighbour `i` of the row
    /// is adjacency entry `index + i`, one number per directed edge (empty for an id out of
    /// range).
    ///
    /// # Bounded work
    /// Constant.
    #[inline]
    pub(crate) fn row(&self, n: NodeId) -> (usize, &'a [NodeId]) {
        let i = n.idx();
        match self.offsets.get(i..i.saturating_add(2)) {
            Some(&[lo, hi]) => (
                lo as usize,
                self.adj.get(lo as usize..hi as usize).unwrap_or(&[]),
            ),
            _ => (0, &[]),
        }
    }

    /// The neighbours of `n` (empty for an id out of range).
    #[inline]
    pub fn neighbours(&self, n: NodeId) -> &'a [NodeId] {
        self.row(n).1
    }
}
