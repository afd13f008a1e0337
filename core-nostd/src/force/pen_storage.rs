//! The pen's per-tick storage ([`super::PenBuffers`]): how many slots of each
//! ([`PenBufferSizes`]) and the one place both are carved from memory
//! ([`PenBuffers::carve`]; see [`crate::storage`]).
//!
//! ```
//! use tetradrill_core::force::{PenBufferSizes, PenBuffers};
//! use tetradrill_core::storage::{Block, Line};
//!
//! // A pen of 27 nodes against an object of 125, every list as long as its body's nodes,
//! // no crossings remembered.
//! let sizes = PenBufferSizes::nodes(27, 125);
//! let mut lines = vec![Line::ZERO; sizes.lines().unwrap()];
//! let bufs = PenBuffers::carve(&sizes, &mut Block::from_lines(&mut lines))?;
//! assert_eq!((bufs.world.len(), bufs.object_hits.len()), (27, 125));
//! # Ok::<(), tetradrill_core::storage::StorageError>(())
//! ```

use glam::Vec3;

use super::pen::PenBuffers;
use crate::collide::Collision;
use crate::depth::{Crossing, DepthScratch, NodeSlot, Penetration};
use crate::ids::{NodeId, TetId};
use crate::storage::{carve, lines_of, Memory, Part, PartSet, Slots, StorageError, LINE};

/// Slots of each part of a [`PenBuffers`]: the pen's and the object's node counts, and the
/// capacities of their lists.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct PenBufferSizes {
    /// Pen nodes: the moved positions, the found tets and the pen side's depth slots.
    pub pen_nodes: usize,
    /// Object nodes: the object side's depth slots.
    pub object_nodes: usize,
    /// Pen nodes inside the object a tick keeps (collisions and penetrations).
    pub pen_contacts: usize,
    /// Object nodes inside the pen a tick keeps.
    pub object_contacts: usize,
    /// Entries of the pen side's depth queue (a short queue changes no depth).
    pub pen_queue: usize,
    /// Entries of the object side's depth queue.
    pub object_queue: usize,
    /// Remembered crossings of the pen side: one per directed edge of the pen's graph
    /// ([`crate::depth::graph_sizes`]'s second number) or none
    /// ([`DepthScratch::with_crossings`]).
    pub pen_crossings: usize,
    /// Remembered crossings of the object side.
    pub object_crossings: usize,
}

impl PenBufferSizes {
    /// Sizes for a pen of `pen` nodes and an object of `object` nodes with every list as
    /// long as its body's nodes (it never fills) and no crossings remembered.
    pub const fn nodes(pen: usize, object: usize) -> Self {
        Self {
            pen_nodes: pen,
            object_nodes: object,
            pen_contacts: pen,
            object_contacts: object,
            pen_queue: pen,
            object_queue: object,
            pen_crossings: 0,
            object_crossings: 0,
        }
    }

    /// The same sizes with `pen` and `object` crossings remembered (one per directed edge of
    /// each body's graph: [`crate::depth::graph_sizes`]).
    pub const fn with_crossings(self, pen: usize, object: usize) -> Self {
        Self {
            pen_crossings: pen,
            object_crossings: object,
            ..self
        }
    }

    /// Every slice of a [`PenBuffers`], in the order [`PenBuffers::carve`] takes them.
    pub const fn parts(&self) -> [Slots; 12] {
        [
            Slots::of::<Vec3>(Part::PenPositions, self.pen_nodes),
            Slots::of::<Collision>(Part::PenHits, self.pen_contacts),
            Slots::of::<TetId>(Part::PenFound, self.pen_nodes),
            Slots::of::<Collision>(Part::ObjectHits, self.object_contacts),
            Slots::of::<Penetration>(Part::PenPenetrations, self.pen_contacts),
            Slots::of::<Penetration>(Part::ObjectPenetrations, self.object_contacts),
            Slots::of::<NodeSlot>(Part::PenDepthSlots, self.pen_nodes),
            Slots::of::<NodeId>(Part::PenDepthQueue, self.pen_queue),
            Slots::of::<Crossing>(Part::PenCrossings, self.pen_crossings),
            Slots::of::<NodeSlot>(Part::ObjectDepthSlots, self.object_nodes),
            Slots::of::<NodeId>(Part::ObjectDepthQueue, self.object_queue),
            Slots::of::<Crossing>(Part::ObjectCrossings, self.object_crossings),
        ]
    }

    /// The [`crate::storage::Line`]s a [`crate::storage::Block`] starting on a line needs for
    /// a [`PenBuffers`] (`None` when the sizes overflow the address space).
    pub const fn lines(&self) -> Option<usize> {
        lines_of(&self.parts(), PartSet::EMPTY, false)
    }

    /// The bytes of [`PenBufferSizes::lines`].
    pub const fn bytes(&self) -> Option<usize> {
        match self.lines() {
            Some(l) => l.checked_mul(LINE),
            None => None,
        }
    }
}

impl<'b> PenBuffers<'b> {
    /// Carves every slice of `sizes` from `mem`, each slot at its starting value (the depth
    /// scratches over their slots, queues and crossings): the one way a pen's per-tick
    /// storage is made, whatever the memory.
    ///
    /// # Bounded work
    /// O(bytes of `sizes`): every slot is written.
    ///
    /// # Errors
    /// [`StorageError`] naming the first part the memory could not hold.
    pub fn carve(sizes: &PenBufferSizes, mem: &mut impl Memory<'b>) -> Result<Self, StorageError> {
        let s = sizes;
        let world = carve(mem, Part::PenPositions, s.pen_nodes, Vec3::ZERO)?;
        let pen_hits = carve(mem, Part::PenHits, s.pen_contacts, Collision::default())?;
        let pen_found = carve(mem, Part::PenFound, s.pen_nodes, TetId::NONE)?;
        let object_hits = carve(
            mem,
            Part::ObjectHits,
            s.object_contacts,
            Collision::default(),
        )?;
        let pen_pens = carve(
            mem,
            Part::PenPenetrations,
            s.pen_contacts,
            Penetration::default(),
        )?;
        let object_pens = carve(
            mem,
            Part::ObjectPenetrations,
            s.object_contacts,
            Penetration::default(),
        )?;
        let slots = carve(mem, Part::PenDepthSlots, s.pen_nodes, NodeSlot::default())?;
        let queue = carve(mem, Part::PenDepthQueue, s.pen_queue, NodeId::NONE)?;
        let crossings = carve(
            mem,
            Part::PenCrossings,
            s.pen_crossings,
            Crossing::default(),
        )?;
        let pen_depth = DepthScratch::with_crossings(slots, queue, crossings);
        let slots = carve(
            mem,
            Part::ObjectDepthSlots,
            s.object_nodes,
            NodeSlot::default(),
        )?;
        let queue = carve(mem, Part::ObjectDepthQueue, s.object_queue, NodeId::NONE)?;
        let crossings = carve(
            mem,
            Part::ObjectCrossings,
            s.object_crossings,
            Crossing::default(),
        )?;
        let object_depth = DepthScratch::with_crossings(slots, queue, crossings);
        Ok(Self {
            world,
            pen_hits,
            pen_found,
            object_hits,
            pen_pens,
            object_pens,
            pen_depth,
            object_depth,
        })
    }
}

// The scene of a tet-mesh tool against an object, as every host, test and C program builds
// it (`owned::PenRig` on the heap, the C interface in caller memory): the grids' and
// clusters' sizes relative to the meshes' average edges.

/// Margin of the object's occupancy grid, in cells (rounding of the barycentric test).
pub const OCCUPANCY_MARGIN: f32 = 1e-3;

/// The object's per-cell tet lists split each occupancy cell this many times along each axis
/// ([`crate::collide::Occupancy::with_tet_lists`]): half-edge cells list about a third of the tets a whole
/// cell does.
pub const OCCUPANCY_LIST_SPLIT: u32 = 2;

/// Margin of the pen's rest-frame boxes, in pen edges (rounding of the moved positions and
/// of the barycentric test).
pub const REST_MARGIN: f32 = 1e-2;

/// Edge of the pen's rest grid (where a point's tets are looked up), in pen edges: half an
/// edge keeps about 24 tets a cell (51 at a whole edge) for the pen's lookups.
pub const REST_GRID_EDGE: f32 = 0.5;

/// Edge of the pen's rest-frame clusters, in cells of the object's node hash.
pub const CLUSTER_EDGE: f32 = 2.5;

/// Storage words of an occupancy grid with cells of `cell` over `mesh` (with a cell to spare
/// per axis for the margin and rounding).
pub fn occupancy_words(mesh: &crate::mesh::Mesh<'_>, cell: f32) -> usize {
    let b = mesh
        .positions()
        .iter()
        .fold(crate::hash::Aabb::of::<0>([]), |b, &p| {
            b.union(crate::hash::Aabb::point(p))
        });
    let e = (b.max - b.min) / cell;
    let cells: f64 = [e.x, e.y, e.z]
        .iter()
        .map(|v| libm::floor(v.max(0.0) as f64) + 3.0)
        .product();
    libm::ceil(cells / 32.0).min(1e9) as usize + 1
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::storage::{Block, Line};

    const SIZES: PenBufferSizes = PenBufferSizes {
        pen_nodes: 27,
        object_nodes: 125,
        pen_contacts: 20,
        object_contacts: 100,
        pen_queue: 9,
        object_queue: 31,
        pen_crossings: 300,
        object_crossings: 1500,
    };
    const LINES: usize = match SIZES.lines() {
        Some(n) => n,
        None => 0,
    };

    fn sizes() -> PenBufferSizes {
        SIZES
    }

    /// Lines of `n` slots of `bytes` bytes, counted here by hand.
    fn lines(n: usize, bytes: usize) -> usize {
        (n * bytes).div_ceil(64)
    }

    #[test]
    fn the_sizes_count_every_part_in_lines() {
        let s = sizes();
        // Vec3 12, Collision 8, TetId 4, Penetration 28, NodeSlot 32, NodeId 4, Crossing 8.
        let want = lines(27, 12)
            + lines(20, 8)
            + lines(27, 4)
            + lines(100, 8)
            + lines(20, 28)
            + lines(100, 28)
            + lines(27, 32)
            + lines(9, 4)
            + lines(300, 8)
            + lines(125, 32)
            + lines(31, 4)
            + lines(1500, 8);
        assert_eq!(s.lines(), Some(want));
        assert_eq!(s.bytes(), Some(want * 64));
    }

    #[test]
    fn carving_puts_every_part_on_a_line_and_writes_its_starting_values() {
        let s = sizes();
        let n = s.lines().unwrap();
        // Garbage first: carving must overwrite it.
        let mut lines = [Line([0xA5; 64]); LINES];
        let base = lines.as_ptr() as usize;
        let b = PenBuffers::carve(&s, &mut Block::from_lines(&mut lines)).unwrap();
        let (ps, pq, pc) = b.pen_depth.storage();
        let (os, oq, oc) = b.object_depth.storage();
        let starts = [
            b.world.as_ptr() as usize,
            b.pen_hits.as_ptr() as usize,
            b.pen_found.as_ptr() as usize,
            b.object_hits.as_ptr() as usize,
            b.pen_pens.as_ptr() as usize,
            b.object_pens.as_ptr() as usize,
            ps.as_ptr() as usize,
            pq.as_ptr() as usize,
            pc.as_ptr() as usize,
            os.as_ptr() as usize,
            oq.as_ptr() as usize,
            oc.as_ptr() as usize,
        ];
        for (i, at) in starts.into_iter().enumerate() {
            assert_eq!((at - base) % 64, 0, "part {i} off its line");
        }
        let empty = Collision {
            node: NodeId(0),
            tet: TetId(0),
        };
        assert_eq!(b.world.len(), 27);
        assert!(b.world.iter().all(|&p| p == Vec3::ZERO));
        assert_eq!(b.pen_hits.len(), 20);
        assert!(b.pen_hits.iter().all(|&c| c == empty));
        assert_eq!(b.pen_found.len(), 27);
        assert!(b.pen_found.iter().all(|&t| t == TetId(u32::MAX)));
        assert_eq!(b.object_hits.len(), 100);
        assert!(b.object_hits.iter().all(|&c| c == empty));
        assert_eq!((b.pen_pens.len(), b.object_pens.len()), (20, 100));
        let zero = |p: &Penetration| {
            p.node == NodeId(0)
                && p.tet == TetId(0)
                && p.depth == 0.0
                && p.dir == Vec3::ZERO
                && p.layer == 0
        };
        assert!(b.pen_pens.iter().chain(b.object_pens.iter()).all(zero));
        // The depth scratches: fresh slots, empty queues, no crossing remembered.
        assert_eq!((ps.len(), pq.len(), pc.len()), (27, 9, 300));
        assert_eq!((os.len(), oq.len(), oc.len()), (125, 31, 1500));
        let slot = NodeSlot::default();
        assert!(ps.iter().chain(os).all(|s| *s == slot));
        assert!(pq.iter().chain(oq).all(|&q| q == NodeId(u32::MAX)));
        assert!(pc.iter().chain(oc).all(|c| *c == Crossing::default()));
        // The last part ends inside the block.
        let end = base + n * 64;
        assert!(starts[11] + 1500 * 8 <= end);
    }

    #[test]
    fn a_block_one_line_short_is_refused_naming_the_last_part() {
        let s = sizes();
        let mut lines = [Line::ZERO; LINES];
        assert_eq!(s.lines(), Some(LINES));
        let err = PenBuffers::carve(&s, &mut Block::from_lines(&mut lines[1..])).unwrap_err();
        assert!(
            matches!(
                err,
                StorageError::TooSmall {
                    part: Part::ObjectCrossings,
                    ..
                }
            ),
            "{err:?}"
        );
    }
}
