//! A [`World`] whose mesh moves and deforms: new node positions every simulation step, from
//! whatever physics the caller runs ([`World::set_positions`]), and everything that depends on
//! positions brought up to date within bounded work.
//!
//! What follows the positions, and how:
//! - each tet's box and the Teschner hash of the tets: with spare storage set
//!   ([`World::set_spare`]) only the tets whose cell range changed move in the hash
//!   (`SpatialHash::update`, the spare hash's entries its scratch), else the hash is rebuilt
//!   (counting sort, the cell size of [`World::new`]); the same table either way;
//! - the boundary normals ([`Mesh::update_boundary`]);
//! - the hierarchy's faces: nothing to do, they are barycentric in their root tet and are
//!   evaluated at the current positions whenever they are needed; the hierarchy's change
//!   log notes that every face moved (a surface exporter writes them all again);
//! - the contact search's caches: the sphere memo is emptied, the resume place forgets the
//!   nodes it measured (its tree starts again from the root), the kept faces are measured
//!   again at the new positions (those no longer visible are dropped); a candidate gather
//!   spread over steps ([`World::set_zone_gather`]) and the zone memo forget their lists and gather afresh;
//! - the contact plane and the candidate list stay the last step's until the next
//!   [`World::simulate`], which finds both again on the new positions;
//! - removed volumes are measured in the rest state ([`Mesh::set_rest`]): a leaf's volume is
//!   its root's rest volume over `8^depth`, whatever the current shape.
//!
//! The same update spread over calls, for a board whose tick cannot hold it
//! ([`World::set_spare`], [`World::prepare_positions`], [`World::commit_positions`]): the new
//! boxes, normals and hash are built in spare storage a bounded amount a call while the world
//! keeps answering on the old positions, then one commit swaps them in and does the rest
//! (positions, sphere memo, resume place, kept faces, candidate gather). Both forms run the
//! same pieces, each written once: a node's check and distance from rest
//! (`node_distance2`), a tet's box (`tet_box`, and `stored_box` for the hash), the boundary
//! normals' per-tet sums and per-node normalisation ([`Mesh::add_boundary_normals`],
//! [`Mesh::finish_boundary_normal`], which [`Mesh::update_boundary`] runs on the live
//! normals), the hash's counting sort ([`SpatialHash::rebuild`] in one call,
//! [`SpatialHash::rebuild_part`] cut into calls: the hash module's two forms of it; the one
//! call moves only the changed tets instead when it can, `SpatialHash::update`), and what
//! follows the move (`finish_move`); the one form on the live storage in one call, the other
//! on the spare storage a slice at a time.
//! The committed world is the one [`World::set_positions`] leaves, bit for bit.
//!
//! The same update on two threads ([`World::set_positions_two`], `two.rs`): the passes over
//! the nodes and tets (checks, boxes, the hash's changes listed, the normals) in two parts a
//! caller's `fork` runs, each reading the world and writing its own slices of the spare
//! storage (its list of the hash's changes sorted too); the lists merged, the table moved
//! and the rest done after. The same world, bit for bit.
//!
//! [`Mesh::update_boundary`]: crate::mesh::Mesh::update_boundary
//! [`Mesh::set_rest`]: crate::mesh::Mesh::set_rest
//! [`Mesh::add_boundary_normals`]: crate::mesh::Mesh::add_boundary_normals
//! [`Mesh::finish_boundary_normal`]: crate::mesh::Mesh::finish_boundary_normal

use glam::Vec3;

use super::World;
use crate::hash::{prime_at_most, Aabb, HashEntry, RebuildCursor, Rebuilt, SpatialHash};
use crate::hierarchy::{keep_face, Kept};
use crate::ids::{NodeId, TetId};
use crate::mesh::Mesh;

mod two;
pub use two::{MovePart, FIRST_PART_TETS};

/// Why [`World::set_positions`] or [`World::enable_deformation`] refused (nothing changed).
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
#[non_exhaustive]
pub enum DeformError {
    /// [`World::enable_deformation`] was not called: there is no rest state to measure
    /// removed volumes in.
    NoRest,
    /// The rest storage holds fewer entries than the mesh has nodes.
    RestTooShort {
        /// Nodes in the mesh.
        nodes: usize,
        /// Entries handed in.
        got: usize,
    },
    /// The new positions are not one per node.
    Count {
        /// Nodes in the mesh.
        nodes: usize,
        /// Positions handed in.
        got: usize,
    },
    /// A new position is not finite.
    NotFinite {
        /// The node.
        node: usize,
    },
    /// A spread update without spare storage ([`World::set_spare`]).
    NoSpare,
    /// The spare storage (named part) does not match the world's: the hash's bucket count
    /// and capacity, one box per stored box, one normal per node.
    SpareSize(&'static str),
    /// [`World::commit_positions`] before [`World::prepare_positions`] finished.
    NotPrepared,
}

impl core::fmt::Display for DeformError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match *self {
            Self::NoRest => write!(f, "the world has no rest state (deformation not enabled)"),
            Self::RestTooShort { nodes, got } => {
                write!(f, "rest storage of {got} positions for {nodes} nodes")
            }
            Self::Count { nodes, got } => write!(f, "{got} positions for {nodes} nodes"),
            Self::NotFinite { node } => write!(f, "position of node {node} is not finite"),
            Self::NoSpare => write!(f, "a spread position update needs spare storage"),
            Self::SpareSize(what) => write!(f, "spare {what} does not match the world's"),
            Self::NotPrepared => write!(f, "the positions' preparation is not finished"),
        }
    }
}

impl core::error::Error for DeformError {}

/// What one [`World::set_positions`] did.
#[derive(Clone, Copy, PartialEq, Debug, Default)]
pub struct DeformReport {
    /// The largest distance of a node from its rest position.
    pub max_displacement: f32,
    /// Entries in the rebuilt hash.
    pub hash_entries: u32,
    /// The hash ran out of entries: the first tets that fit are hashed, the others are not
    /// found by the zone queries until a rebuild fits (counted in `saturations().hash`).
    pub hash_saturated: bool,
    /// Kept contact faces measured again at the new positions (still visible).
    pub kept: u32,
}

impl<'a> World<'a> {
    /// Keeps the current positions in `rest` (one entry per node at least) as the rest state,
    /// so that [`World::set_positions`] may move the nodes: removed volumes are measured
    /// there. Call it before drilling, once.
    ///
    /// # Bounded work
    /// O(N) for N nodes.
    ///
    /// # Errors
    /// [`DeformError::RestTooShort`] (nothing changed).
    pub fn enable_deformation(&mut self, rest: &'a mut [Vec3]) -> Result<(), DeformError> {
        let nodes = self.mesh.node_count();
        self.mesh
            .set_rest(rest)
            .map_err(|r| DeformError::RestTooShort {
                nodes,
                got: r.len(),
            })
    }

    /// Moves every node to `new` (one position per node, the caller's physics' output) and
    /// brings up to date what depends on positions: the boundary normals, each tet's box, the
    /// tet hash (rebuilt with the cell size of [`World::new`]), the contact search's sphere
    /// memo (emptied), its resume place (its tree from the root) and its kept faces (measured
    /// again from the last contact's centre), a candidate gather's lists (forgotten). The
    /// hierarchy follows by itself (barycentric in its roots). The contact plane stays the
    /// last step's until the next [`World::simulate`]. These are the pieces
    /// [`World::prepare_positions`] and [`World::commit_positions`] run (module docs), here on
    /// the live storage in one call.
    ///
    /// # Bounded work
    /// O(N + T + buckets + hash entries + memo slots + m log m) for N nodes, T tets and m
    /// hash entries of the tets that changed cells (at most the hash's capacity), plus
    /// O([`crate::hierarchy::KEEP`] x depth) for the kept faces. docs/TIMING.md gives it for
    /// the cow and the teddy.
    ///
    /// # Capacity
    /// A hash whose entries run out keeps the first tets that fit and counts
    /// `saturations().hash` (a deformed tet whose box covers more cells takes more entries).
    ///
    /// # Errors
    /// [`DeformError::NoRest`] before [`World::enable_deformation`], [`DeformError::Count`]
    /// when `new` is not one position per node, [`DeformError::NotFinite`] for a non-finite
    /// position; nothing changed.
    pub fn set_positions(&mut self, new: &[Vec3]) -> Result<DeformReport, DeformError> {
        self.check_move(new)?;
        let mut max2 = 0.0f32;
        for i in 0..new.len() {
            max2 = max2.max(node_distance2(&self.mesh, new, i)?);
        }
        // Every position checked: from here on nothing refuses.
        let built = self.move_hash(new);
        self.mesh.positions_mut().copy_from_slice(new);
        self.mesh.update_boundary();
        Ok(self.finish_move(max2, built))
    }

    /// The tet boxes and the hash brought to the positions `new`: the hash updated in place
    /// ([`SpatialHash::update`], only the tets whose cell range changed) when every tet has a
    /// stored box and the spare storage is set and idle (its hash entries are the update's
    /// scratch), else built whole. Either way the table a whole build leaves.
    ///
    /// # Bounded work
    /// O(T + buckets + hash entries + m log m) for m entries of the tets that changed cells
    /// (at most the spare's capacity); O(T + buckets + hash entries) for the whole build.
    fn move_hash(&mut self, new: &[Vec3]) -> Rebuilt {
        let mesh = &self.mesh;
        let tets = mesh.tet_count();
        let boxes = &mut *self.boxes;
        let usable = |s: &&mut Spare<'a>| s.prep == Prep::default() && boxes.len() >= tets;
        if let Some(spare) = self.spare.as_mut().filter(usable) {
            // Every box is made new here, whatever the update's outcome.
            let moved = |t: usize| {
                let now = tet_box(mesh, new, t);
                let was = boxes.get_mut(t).map(|b| core::mem::replace(b, now));
                (was, Some(now))
            };
            if let Some(built) = self.hash.update(tets, moved, spare.hash.scratch()) {
                return built;
            }
        } else {
            for (t, b) in boxes.iter_mut().enumerate().take(tets) {
                *b = tet_box(mesh, new, t);
            }
        }
        let boxes = &*boxes;
        self.hash
            .rebuild(tets, |t| Some(stored_box(boxes, mesh, new, t)))
    }

    /// Refuses a move before [`World::enable_deformation`] or of the wrong node count.
    ///
    /// # Bounded work
    /// Constant.
    fn check_move(&self, new: &[Vec3]) -> Result<(), DeformError> {
        if !self.mesh.has_rest() {
            return Err(DeformError::NoRest);
        }
        let nodes = self.mesh.node_count();
        if new.len() != nodes {
            return Err(DeformError::Count {
                nodes,
                got: new.len(),
            });
        }
        Ok(())
    }

    /// What follows a move once positions, normals, boxes and hash are new: a hash that ran
    /// out of entries counted, the sphere memo emptied, the resume place's tree restarted, a
    /// candidate gather's lists and the zone memo forgotten, the kept faces measured again.
    /// Returns the move's report (`max2`: the largest squared distance from rest).
    ///
    /// # Bounded work
    /// O(memo slots) plus O([`crate::hierarchy::KEEP`] x depth).
    fn finish_move(&mut self, max2: f32, built: Rebuilt) -> DeformReport {
        if built.saturated {
            self.sat.hash += 1;
        }
        self.memo.clear();
        self.cursor.restart_tree();
        // Every visible face moved: readers of the hierarchy's change log redo them all.
        self.hier.note_all_changed();
        // A gathered candidate list holds the tets whose old boxes met its box: gather afresh.
        if let Some(z) = self.zone.as_mut() {
            z.forget();
        }
        // So does the zone memo's: its lists were cut from the old boxes.
        self.zone_memo.forget();
        let centre = self.contact.centre;
        let mut kept = Kept::new();
        for &(_, t) in &self.kept {
            if let Some((d2, vt)) = self
                .hier
                .visible_face_distance2(&self.mesh, t.key(), centre)
            {
                keep_face(&mut kept, d2, vt);
            }
        }
        let n = kept.len() as u32;
        self.kept = kept;
        DeformReport {
            max_displacement: libm::sqrtf(max2),
            hash_entries: built.entries as u32,
            hash_saturated: built.saturated,
            kept: n,
        }
    }
}

/// Node `i`'s squared distance from its rest position at `new[i]` (a missing entry counts as
/// the origin). The check and measure of a node, in both forms of the update.
///
/// # Errors
/// [`DeformError::NotFinite`] when `new[i]` is not finite.
#[inline]
fn node_distance2(mesh: &Mesh<'_>, new: &[Vec3], i: usize) -> Result<f32, DeformError> {
    let p = new.get(i).copied().unwrap_or_default();
    if !p.is_finite() {
        return Err(DeformError::NotFinite { node: i });
    }
    let r = mesh.rest_positions().get(i).copied().unwrap_or_default();
    Ok(p.distance_squared(r))
}

/// Tet `t`'s box at the positions `new` (all corners at the origin for an id out of range,
/// as [`Mesh::tet_positions`] does).
#[inline]
pub(super) fn tet_box(mesh: &Mesh<'_>, new: &[Vec3], t: usize) -> Aabb {
    let ids = mesh.tet_nodes(TetId::from_idx(t));
    let corners = match ids.map(|n| new.get(n.idx())) {
        [Some(&a), Some(&b), Some(&c), Some(&d)] => [a, b, c, d],
        _ => [Vec3::ZERO; 4],
    };
    Aabb::of(corners)
}

/// Tet `t`'s box for the hash: the stored one, or for a tet beyond the stored boxes the same
/// box made from its corners.
#[inline]
pub(super) fn stored_box(boxes: &[Aabb], mesh: &Mesh<'_>, new: &[Vec3], t: usize) -> Aabb {
    boxes
        .get(t)
        .copied()
        .unwrap_or_else(|| tet_box(mesh, new, t))
}

/// Spare storage for the spread position update ([`World::set_spare`]): a second tet hash
/// (the same sizes as the world's), a second box per stored tet box, a second normal per
/// node. About the size of the world's own hash and boxes.
#[derive(Debug)]
pub struct SpareStorage<'a> {
    /// Bucket offsets, as `WorldStorage::hash_starts` (same length).
    pub hash_starts: &'a mut [u32],
    /// Entries, as `WorldStorage::hash_entries` (same length).
    pub hash_entries: &'a mut [HashEntry],
    /// One box per box of `WorldStorage::tet_boxes`.
    pub tet_boxes: &'a mut [Aabb],
    /// One normal per node.
    pub normals: &'a mut [Vec3],
}

/// Units of one node in the first pass of [`World::prepare_positions`] (its check, its
/// distance from rest, its spare normal cleared).
pub(crate) const PREP_NODE_UNITS: u32 = 2;
/// Units of one tet's new box.
pub(crate) const PREP_BOX_UNITS: u32 = 4;
/// Units of one tet's boundary faces added to the normals (four neighbour looks, a cross
/// product per boundary face).
pub(crate) const PREP_FACE_UNITS: u32 = 4;
/// Units of one node's normal normalised.
pub(crate) const PREP_NORMALISE_UNITS: u32 = 6;

/// The passes of [`World::prepare_positions`].
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default)]
enum PrepPhase {
    /// Nodes: finite, distance from rest, spare normal cleared.
    #[default]
    Nodes,
    /// Tets: new boxes.
    Boxes,
    /// Tets: boundary faces into the spare normals.
    Faces,
    /// Nodes: boundary normals normalised.
    Normalise,
    /// The spare hash ([`SpatialHash::rebuild_part`]).
    Hash,
    /// Done: ready to commit.
    Ready,
}

/// Where a preparation stands.
#[derive(Clone, Copy, PartialEq, Debug, Default)]
struct Prep {
    phase: PrepPhase,
    at: usize,
    max2: f32,
    cursor: RebuildCursor,
    built: Rebuilt,
}

/// The spare tables and where their preparation stands.
#[derive(Debug)]
pub(super) struct Spare<'a> {
    hash: SpatialHash<'a>,
    boxes: &'a mut [Aabb],
    normals: &'a mut [Vec3],
    prep: Prep,
}

/// What one [`World::prepare_positions`] did.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default)]
pub struct Prepared {
    /// Units done in this call.
    pub units: u32,
    /// `true` when the preparation is complete: [`World::commit_positions`] may follow.
    pub ready: bool,
}

impl<'a> World<'a> {
    /// Hands the world the spare storage of the spread position update
    /// ([`World::prepare_positions`]); any preparation under way is dropped.
    ///
    /// # Bounded work
    /// O(buckets) to clear the spare bucket offsets.
    ///
    /// # Errors
    /// [`DeformError::SpareSize`] when a part does not match the world's (nothing changed).
    pub fn set_spare(&mut self, spare: SpareStorage<'a>) -> Result<(), DeformError> {
        let SpareStorage {
            hash_starts,
            hash_entries,
            tet_boxes,
            normals,
        } = spare;
        if tet_boxes.len() != self.boxes.len() {
            return Err(DeformError::SpareSize("tet_boxes"));
        }
        if normals.len() != self.mesh.node_count() {
            return Err(DeformError::SpareSize("normals"));
        }
        if hash_entries.len() != self.hash.capacity() {
            return Err(DeformError::SpareSize("hash_entries"));
        }
        // The bucket count as `World::new` derives it.
        let buckets =
            prime_at_most((hash_starts.len().saturating_sub(1)).min(u32::MAX as usize) as u32);
        if buckets != self.hash.buckets() {
            return Err(DeformError::SpareSize("hash_starts"));
        }
        let Some((hash_starts, _)) = hash_starts.split_at_mut_checked(buckets as usize + 1) else {
            return Err(DeformError::SpareSize("hash_starts"));
        };
        let hash = SpatialHash::new(hash_starts, hash_entries, self.hash.cell_size())
            .map_err(|_| DeformError::SpareSize("hash_starts"))?;
        self.spare = Some(Spare {
            hash,
            boxes: tet_boxes,
            normals,
            prep: Prep::default(),
        });
        Ok(())
    }

    /// Units of one whole preparation ([`World::prepare_positions`]) with the spare storage
    /// set (fewer when the hash fills up: the tets left out are not hashed): nodes x (`PREP_NODE_UNITS` + `PREP_NORMALISE_UNITS`) + tets x
    /// (`PREP_BOX_UNITS` + `PREP_FACE_UNITS`) + the hash build's
    /// (`SpatialHash::rebuild_units`). `None` without spare storage.
    ///
    /// # Bounded work
    /// Constant.
    pub fn prepare_units(&self) -> Option<u64> {
        let spare = self.spare.as_ref()?;
        let n = self.mesh.node_count() as u64;
        let t = self.mesh.tet_count() as u64;
        Some(
            n * u64::from(PREP_NODE_UNITS + PREP_NORMALISE_UNITS)
                + t * u64::from(PREP_BOX_UNITS + PREP_FACE_UNITS)
                + spare.hash.rebuild_units(self.mesh.tet_count()),
        )
    }

    /// Prepares the move of every node to `new` in the spare storage, at most `max_units`
    /// units a call (a step is taken only while it fits; give at least the largest step,
    /// [`crate::hash::REBUILD_ITEM_UNITS`], to be sure of progress): checks the positions and
    /// measures the largest distance from rest, builds each tet's new box, the new boundary
    /// normals and the new tet hash, with the pieces [`World::set_positions`] runs on the live
    /// storage (module docs). The world is not changed: it answers on the old positions until
    /// [`World::commit_positions`]. `new` must hold the same positions for every call of one
    /// preparation; once ready, further calls do nothing.
    ///
    /// # Bounded work
    /// At most `max_units` units plus the cells of one tet's box in the hash (one unit is
    /// about a soft-body node update: docs/SOFT.md has the instructions); a whole
    /// preparation is [`World::prepare_units`].
    ///
    /// # Errors
    /// [`DeformError::NoRest`], [`DeformError::NoSpare`], [`DeformError::Count`] (nothing
    /// done); [`DeformError::NotFinite`] for a non-finite position (the preparation starts
    /// again at the next call).
    pub fn prepare_positions(
        &mut self,
        new: &[Vec3],
        max_units: u32,
    ) -> Result<Prepared, DeformError> {
        self.check_move(new)?;
        let mesh = &self.mesh;
        let nodes = mesh.node_count();
        let Some(spare) = self.spare.as_mut() else {
            return Err(DeformError::NoSpare);
        };
        let tets = mesh.tet_count();
        let Spare {
            hash,
            boxes,
            normals,
            prep: p,
        } = spare;
        let mut left = max_units;
        loop {
            match p.phase {
                PrepPhase::Nodes => {
                    if p.at >= nodes {
                        p.phase = PrepPhase::Boxes;
                        p.at = 0;
                        continue;
                    }
                    if left < PREP_NODE_UNITS {
                        break;
                    }
                    left -= PREP_NODE_UNITS;
                    let i = p.at;
                    match node_distance2(mesh, new, i) {
                        Ok(d2) => p.max2 = p.max2.max(d2),
                        Err(e) => {
                            *p = Prep::default();
                            return Err(e);
                        }
                    }
                    if let Some(normal) = normals.get_mut(i) {
                        *normal = Vec3::ZERO;
                    }
                    p.at += 1;
                }
                PrepPhase::Boxes => {
                    if p.at >= tets {
                        p.phase = PrepPhase::Faces;
                        p.at = 0;
                        continue;
                    }
                    if left < PREP_BOX_UNITS {
                        break;
                    }
                    left -= PREP_BOX_UNITS;
                    let t = p.at;
                    if let Some(b) = boxes.get_mut(t) {
                        *b = tet_box(mesh, new, t);
                    }
                    p.at += 1;
                }
                PrepPhase::Faces => {
                    if p.at >= tets {
                        p.phase = PrepPhase::Normalise;
                        p.at = 0;
                        continue;
                    }
                    if left < PREP_FACE_UNITS {
                        break;
                    }
                    left -= PREP_FACE_UNITS;
                    mesh.add_boundary_normals(TetId::from_idx(p.at), new, normals);
                    p.at += 1;
                }
                PrepPhase::Normalise => {
                    if p.at >= nodes {
                        p.phase = PrepPhase::Hash;
                        p.at = 0;
                        continue;
                    }
                    if left < PREP_NORMALISE_UNITS {
                        break;
                    }
                    left -= PREP_NORMALISE_UNITS;
                    mesh.finish_boundary_normal(NodeId::from_idx(p.at), normals);
                    p.at += 1;
                }
                PrepPhase::Hash => {
                    let stored = &**boxes;
                    let bounds = |t: usize| Some(stored_box(stored, mesh, new, t));
                    let (done, built) = hash.rebuild_part(&mut p.cursor, tets, bounds, left);
                    left -= done;
                    match built {
                        Some(b) => {
                            p.built = b;
                            p.phase = PrepPhase::Ready;
                        }
                        None => break,
                    }
                }
                PrepPhase::Ready => {
                    return Ok(Prepared {
                        units: max_units - left,
                        ready: true,
                    })
                }
            }
        }
        Ok(Prepared {
            units: max_units - left,
            ready: false,
        })
    }

    /// Moves every node to `new`, whose update [`World::prepare_positions`] prepared: copies
    /// the positions, swaps in the new normals, boxes and hash (the old ones become the
    /// spare storage), and does the rest of [`World::set_positions`] (sphere memo emptied,
    /// resume place restarted, candidate gather forgotten, kept faces measured again: the same
    /// code). The world is then the one [`World::set_positions`] with `new` leaves, bit for
    /// bit.
    ///
    /// # Bounded work
    /// O(N + memo slots) plus O([`crate::hierarchy::KEEP`] x depth).
    ///
    /// # Errors
    /// [`DeformError::NoSpare`], [`DeformError::NotPrepared`], [`DeformError::Count`]
    /// (nothing changed).
    pub fn commit_positions(&mut self, new: &[Vec3]) -> Result<DeformReport, DeformError> {
        let nodes = self.mesh.node_count();
        let Some(spare) = self.spare.as_mut() else {
            return Err(DeformError::NoSpare);
        };
        if spare.prep.phase != PrepPhase::Ready {
            return Err(DeformError::NotPrepared);
        }
        if new.len() != nodes {
            return Err(DeformError::Count {
                nodes,
                got: new.len(),
            });
        }
        let p = core::mem::take(&mut spare.prep);
        self.mesh.positions_mut().copy_from_slice(new);
        // Lengths were checked by `set_spare`: neither can refuse.
        self.mesh.swap_normals(&mut spare.normals);
        self.hash.adopt(&mut spare.hash, p.built);
        core::mem::swap(&mut self.boxes, &mut spare.boxes);
        Ok(self.finish_move(p.max2, p.built))
    }

    /// `true` while a spread update is prepared and not committed.
    pub fn preparing(&self) -> bool {
        self.spare
            .as_ref()
            .is_some_and(|s| s.prep != Prep::default())
    }
}
