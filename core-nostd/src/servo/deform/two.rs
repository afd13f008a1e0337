//! [`World::set_positions`] in two parts for two threads ([`World::set_positions_two`]): the
//! passes over every node and tet split between the parts, which only read the world and
//! write their own slices of the spare storage; the merge of their lists, the table's move
//! and the rest here.

use glam::Vec3;

use super::{node_distance2, stored_box, tet_box, DeformError, DeformReport, Prep, Spare};
use crate::hash::{Aabb, HashEntry, MoveSpan, Sorted, SpatialHash};
use crate::ids::{NodeId, TetId};
use crate::mesh::Mesh;
use crate::servo::World;

impl<'a> World<'a> {
    /// [`World::set_positions`] with its passes over every node and tet in two parts handed
    /// to `fork` (the first part, the second), which runs both ([`MovePart::run`]), on two
    /// threads if it likes. Each part checks half of the nodes, makes the new boxes of its
    /// tets (into the spare storage) and lists and sorts their changes of the hash (into its
    /// half of the spare hash's entries; the table only read); the first part takes
    /// [`FIRST_PART_TETS`] of the tets, the second the rest and the boundary normals (into
    /// the spare normals, as [`World::prepare_positions`] makes them), so the two take about
    /// the same time. A part `fork` left unrun is run after it returns. Then, here: the
    /// boxes and normals swapped in and the two parts' sorted lists merged
    /// (`SpatialHash::update_sorted`); the hash table is moved by them in two parts handed
    /// to `fork` again (the buckets below the one where the entries reach half their number,
    /// and the rest; each part writes its own entries and offsets, the few entries one part
    /// lands in the other's reach go through a side buffer copied in after both), or here
    /// in one part when the parts' buffers do not fit, or built whole when the lists do not
    /// fit; then the rest as [`World::set_positions`]. The world is the one
    /// [`World::set_positions`] leaves, bit for bit. Without spare storage, or while a
    /// spread update holds it ([`World::prepare_positions`]), this is
    /// [`World::set_positions`], and `fork` is not called.
    ///
    /// # Bounded work
    /// As [`World::set_positions`], plus at most two calls of `fork`; outside the parts,
    /// O(N + memo slots + m + buckets) for the m changed hash entries (the positions copied,
    /// the parts' sorted lists merged, the side buffer copied in), and O(buckets + hash
    /// entries) more when the table's move runs here in one part or the hash is built whole.
    ///
    /// # Capacity
    /// As [`World::set_positions`].
    ///
    /// # Errors
    /// As [`World::set_positions`] (the first non-finite node named); nothing changed but
    /// the spare storage's contents, which an idle spare does not keep.
    pub fn set_positions_two(
        &mut self,
        new: &[Vec3],
        fork: &mut dyn FnMut(&mut MovePart<'_>, &mut MovePart<'_>),
    ) -> Result<DeformReport, DeformError> {
        self.check_move(new)?;
        let tets = self.mesh.tet_count();
        let nodes = new.len();
        let idle = |s: &&mut Spare<'a>| {
            s.prep == Prep::default() && s.boxes.len() >= tets && s.normals.len() == nodes
        };
        let (Some(spare), Some(old)) = (self.spare.as_mut().filter(idle), self.boxes.get(..tets))
        else {
            return self.set_positions(new);
        };
        let (mesh, hash) = (&self.mesh, &self.hash);
        let scratch = spare.hash.scratch();
        let (scratch_a, scratch_b) = scratch.split_at_mut(scratch.len() / 2);
        let split = tets / FIRST_PART_TETS.1 * FIRST_PART_TETS.0
            + tets % FIRST_PART_TETS.1 * FIRST_PART_TETS.0 / FIRST_PART_TETS.1;
        let (old_a, old_b) = old.split_at(split);
        let (now_a, now_b) = spare.boxes.split_at_mut(split);
        let part = |nodes, first_tet, old, now, scratch, normals| MovePart {
            work: Some(Work::Lists(MoveWork {
                mesh,
                hash,
                new,
                nodes,
                first_tet,
                old,
                now,
                scratch,
                normals,
            })),
            done: PartDone::default(),
        };
        let mut a = part(0..nodes / 2, 0, old_a, now_a, scratch_a, None);
        let normals = Some(&mut *spare.normals);
        let mut b = part(nodes / 2..nodes, split, old_b, now_b, scratch_b, normals);
        fork(&mut a, &mut b);
        a.run();
        b.run();
        let (da, db) = (a.done, b.done);
        if let Some(node) = da.bad.or(db.bad) {
            return Err(DeformError::NotFinite { node });
        }
        // Every position checked: from here on nothing refuses.
        core::mem::swap(&mut self.boxes, &mut spare.boxes);
        let cut = self.hash.middle_bucket();
        // The table's move in two parts, handed to `fork` as the lists were.
        let halves = |lower: MoveSpan<'_>, upper: MoveSpan<'_>| {
            let (mut a, mut b) = (MovePart::table(lower), MovePart::table(upper));
            fork(&mut a, &mut b);
            a.run();
            b.run();
            a.done.moved && b.done.moved
        };
        let listed = self.hash.update_sorted(
            tets,
            da.listed,
            db.listed,
            spare.hash.scratch(),
            Some(cut),
            halves,
        );
        let built = listed.unwrap_or_else(|| {
            let (boxes, mesh) = (&*self.boxes, &self.mesh);
            self.hash
                .rebuild(tets, |t| Some(stored_box(boxes, mesh, new, t)))
        });
        self.mesh.positions_mut().copy_from_slice(new);
        // The length was checked above: the swap cannot refuse.
        self.mesh.swap_normals(&mut spare.normals);
        Ok(self.finish_move(da.max2.max(db.max2), built))
    }
}

/// The share of the tets the first part of [`World::set_positions_two`] takes, as a fraction
/// (four sevenths): the second part's normals cost about a seventh of a tet's box, listing
/// and sorting per tet (callgrind on the cow and the teddy), so the parts take about the
/// same time. Any share gives the same world.
pub const FIRST_PART_TETS: (usize, usize) = (4, 7);

/// One part of [`World::set_positions_two`]: its nodes checked and measured, its tets' new
/// boxes made and their changes of the hash listed and sorted, and for the second part the
/// boundary normals made; or, in the second call of `fork`, its part of the hash table's
/// move. Holds shared views of the world and its own slices of the storage, so the two
/// parts may run on two threads at once.
pub struct MovePart<'p> {
    work: Option<Work<'p>>,
    done: PartDone,
}

/// What a [`MovePart`] does: a part of the passes over nodes and tets, or a part of the
/// hash table's move.
enum Work<'p> {
    Lists(MoveWork<'p>),
    Table(MoveSpan<'p>),
}

/// What a [`MovePart`] works on.
struct MoveWork<'p> {
    mesh: &'p Mesh<'p>,
    hash: &'p SpatialHash<'p>,
    new: &'p [Vec3],
    /// Its nodes.
    nodes: core::ops::Range<usize>,
    /// Its first tet; its tets are as many as `old`.
    first_tet: usize,
    /// Its tets' boxes at the last move.
    old: &'p [Aabb],
    /// Its tets' new boxes (spare storage).
    now: &'p mut [Aabb],
    /// Its part of the spare hash's entries, for its list of changes.
    scratch: &'p mut [HashEntry],
    /// The spare normals, for the part that makes the boundary normals.
    normals: Option<&'p mut [Vec3]>,
}

/// What a [`MovePart`] found.
#[derive(Clone, Copy, Debug, Default)]
struct PartDone {
    /// The largest squared distance of its nodes from rest.
    max2: f32,
    /// Its first node with a non-finite position.
    bad: Option<usize>,
    /// Its changes of the hash, sorted (`None`: they do not fit, or the table is not a
    /// whole build).
    listed: Option<Sorted>,
    /// Its part of the table's move went as the lists say.
    moved: bool,
}

impl core::fmt::Debug for MovePart<'_> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("MovePart")
            .field("ran", &self.work.is_none())
            .field("done", &self.done)
            .finish()
    }
}

impl<'p> MovePart<'p> {
    /// A part of the hash table's move.
    fn table(span: MoveSpan<'p>) -> Self {
        MovePart {
            work: Some(Work::Table(span)),
            done: PartDone::default(),
        }
    }

    /// Does the part's work; later calls do nothing. Never allocates or panics.
    ///
    /// # Bounded work
    /// A part of the passes: O(its nodes + its tets + its part of the spare hash's entries +
    /// m log m) for the m hash entries it lists, and for the second part O(N + T) for the
    /// normals. A part of the table's move: O(its buckets + its entries + its listed
    /// entries).
    pub fn run(&mut self) {
        let w = match self.work.take() {
            Some(Work::Lists(w)) => w,
            Some(Work::Table(span)) => {
                self.done.moved = span.run();
                return;
            }
            None => return,
        };
        let mut max2 = 0.0f32;
        for i in w.nodes {
            match node_distance2(w.mesh, w.new, i) {
                Ok(d2) => max2 = max2.max(d2),
                Err(_) => {
                    // The move is refused: its boxes are not needed.
                    self.done.bad = Some(i);
                    return;
                }
            }
        }
        let (old, now, first) = (w.old, w.now, w.first_tet);
        let tets = first..first + old.len().min(now.len());
        let mut moved = |t: usize| {
            let k = t.wrapping_sub(first);
            let b = tet_box(w.mesh, w.new, t);
            if let Some(slot) = now.get_mut(k) {
                *slot = b;
            }
            (old.get(k).copied(), Some(b))
        };
        let count = w.mesh.tet_count();
        self.done = PartDone {
            max2,
            bad: None,
            listed: w.hash.changes_sorted(tets, count, &mut moved, w.scratch),
            moved: false,
        };
        if let Some(normals) = w.normals {
            // As `World::prepare_positions` makes them: every tet's boundary faces summed
            // in tet order, then each node's sum normalised.
            normals.fill(Vec3::ZERO);
            for t in 0..count {
                w.mesh
                    .add_boundary_normals(TetId::from_idx(t), w.new, normals);
            }
            for i in 0..normals.len() {
                w.mesh.finish_boundary_normal(NodeId::from_idx(i), normals);
            }
        }
    }
}
