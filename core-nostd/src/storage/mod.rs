//! Sizes in, storage out: where every structure's slices come from.
//!
//! The core never allocates: each structure borrows slices whose lengths are its capacities
//! ([`crate::servo::WorldStorage`], [`crate::hierarchy::HierarchyStorage`], ...). This module
//! turns a structure's sizes into those slices, in one function per structure, from any
//! [`Memory`]:
//!
//! - [`Block`]: one run of bytes, carved part after part (a caller's buffer, a C program's
//!   memory, a firmware's `static`);
//! - [`Split`]: two runs, the parts of a [`PartSet`] in the second (a board's fast and slow
//!   RAM regions);
//! - with the `alloc` feature, `crate::owned`: the heap, for a desktop program or a test
//!   (`WorldBuffers::new(sizes)`, then `.world(mesh)`).
//!
//! Every part starts on a [`LINE`] (64 bytes): no two parts share a cache line, and a block
//! of eight hierarchy nodes or one pending drill item fills exactly one. A structure's sizes
//! say how many bytes a block needs ([`crate::servo::WorldSizes::bytes`]); carving writes
//! every slot with its starting value, so the memory may hold anything beforehand (a board's
//! RAM is not zero at reset).
//!
//! ```
//! use tetradrill_core::builtin;
//! use tetradrill_core::mesh::{BuildOptions, FaceKey, Mesh, MeshStorage, Node, Tet};
//! use tetradrill_core::servo::{World, WorldSizes, WorldStorage};
//! use tetradrill_core::storage::{Block, Line};
//! use tetradrill_core::Vec3;
//!
//! // The paper's 12-tet cube.
//! let (mut pos, tets) = builtin::cube12();
//! let (mut nodes, mut normals) = ([Node::default(); 9], [Vec3::ZERO; 9]);
//! let (mut recs, mut scratch) = ([Tet::default(); 12], [FaceKey::default(); 48]);
//! let storage = MeshStorage { nodes: &mut nodes, normals: &mut normals, tets: &mut recs };
//! let mesh = Mesh::build(&mut pos, &tets, storage, &mut scratch, BuildOptions::default())?;
//!
//! // Sizes for its 12 tets and 4,096 hierarchy nodes, carved from an array of lines.
//! let sizes = WorldSizes::new(12, 4096);
//! let mut lines = vec![Line::ZERO; sizes.lines().unwrap()];
//! let storage = WorldStorage::carve(&sizes, &mut Block::from_lines(&mut lines))?;
//! let world = World::new(mesh, storage)?;
//! assert_eq!(world.mesh().tet_count(), 12);
//! # Ok::<(), tetradrill_core::Error>(())
//! ```

use core::fmt;
use core::mem::{align_of, size_of};

use bytemuck::{AnyBitPattern, NoUninit};

/// The alignment of every part and of a block's start: one cache line.
pub const LINE: usize = 64;

/// One line of storage: what a [`Block`] is made of when a program holds its memory as an
/// array (`static`, `Vec`), so that the block starts on a line.
#[derive(Clone, Copy, PartialEq, Eq, Debug, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C, align(64))]
pub struct Line(pub [u8; LINE]);

impl Line {
    /// A line of zero bytes.
    pub const ZERO: Self = Self([0; LINE]);
}

const _: () = assert!(size_of::<Line>() == LINE && align_of::<Line>() == LINE);

/// The parts structures are carved into. Each names one slice of one structure, so a
/// [`Memory`] can place it (a [`Split`]) and an error can name it.
#[derive(Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Debug)]
#[non_exhaustive]
#[repr(u8)]
pub enum Part {
    /// The tet hash's bucket offsets ([`crate::servo::WorldStorage::hash_starts`]).
    HashStarts,
    /// The tet hash's entries.
    HashEntries,
    /// Each tet's bounding box.
    TetBoxes,
    /// The hierarchy's root nodes ([`crate::hierarchy::HierarchyStorage::roots`]).
    Roots,
    /// The hierarchy's node arena.
    Arena,
    /// The hierarchy's v_list.
    VList,
    /// The drill's pending-work deque.
    Pending,
    /// The candidate tets near the tool.
    Candidates,
    /// The contact search's sphere memo.
    SphereMemo,
    /// The spare tet hash's bucket offsets ([`crate::servo::SpareStorage`]).
    SpareHashStarts,
    /// The spare tet hash's entries.
    SpareHashEntries,
    /// The spare tet boxes.
    SpareTetBoxes,
    /// The spare boundary normals.
    SpareNormals,
    /// A deforming world's rest positions ([`crate::servo::World::enable_deformation`]).
    RestPositions,
    /// A part of the caller's own (the firmware's regions, a C program's arrays).
    Other,
    /// The pen's nodes at the current pose ([`crate::force::PenBuffers::world`]).
    PenPositions,
    /// Pen nodes inside object tets.
    PenHits,
    /// The object tet each pen node was found in.
    PenFound,
    /// Object nodes inside pen tets.
    ObjectHits,
    /// The pen nodes' penetration depths.
    PenPenetrations,
    /// The object nodes' penetration depths.
    ObjectPenetrations,
    /// The pen side's depth slots (one per pen node).
    PenDepthSlots,
    /// The pen side's depth queue.
    PenDepthQueue,
    /// The pen side's remembered crossings (one per directed edge of the pen's graph).
    PenCrossings,
    /// The object side's depth slots (one per object node).
    ObjectDepthSlots,
    /// The object side's depth queue.
    ObjectDepthQueue,
    /// The object side's remembered crossings.
    ObjectCrossings,
    /// A soft body's displacements ([`crate::soft::SoftStorage::displacement`]).
    SoftDisplacement,
    /// A soft body's velocities.
    SoftVelocity,
    /// A soft body's displacements at the start of a substep.
    SoftPrevious,
    /// A soft body's lumped masses.
    SoftMass,
    /// A soft body's inverse masses.
    SoftInvMass,
    /// A soft body's rest data per tet.
    SoftTetRest,
    /// A soft body's constraint multipliers per tet.
    SoftLambdas,
    /// A soft body's rest positions ([`crate::soft::SoftMesh::rest`]).
    SoftRest,
    /// A soft body's tets as node indices.
    SoftTets,
    /// A soft link's first load buffer ([`crate::soft::LinkBuffers::a`]).
    LinkLoadA,
    /// A soft link's second load buffer.
    LinkLoadB,
    /// A soft link's next positions.
    LinkNext,
    /// A mesh's node records ([`crate::mesh::MeshStorage::nodes`]).
    MeshNodes,
    /// A mesh's boundary normals.
    MeshNormals,
    /// A mesh's tet records.
    MeshTets,
    /// The hierarchy's change log ([`crate::hierarchy::HierarchyStorage::changes`]).
    Changes,
    /// A surface exporter's triangle slots ([`crate::hierarchy::SurfaceStorage::slots`]).
    SurfaceSlots,
    /// A surface exporter's records per coarse tet.
    SurfaceTets,
    /// Smooth normals' records per triangle slot ([`crate::hierarchy::SmoothStorage::slots`]).
    SmoothSlots,
    /// Smooth normals' shared vertices.
    SmoothVertices,
    /// Smooth normals' hash table of vertices.
    SmoothTable,
    /// Smooth normals' queue of vertices to recompute.
    SmoothQueue,
}

impl Part {
    /// The part's name, as errors print it.
    pub const fn name(self) -> &'static str {
        match self {
            Self::HashStarts => "hash bucket offsets",
            Self::HashEntries => "hash entries",
            Self::TetBoxes => "tet boxes",
            Self::Roots => "hierarchy roots",
            Self::Arena => "hierarchy arena",
            Self::VList => "v_list",
            Self::Pending => "pending drill work",
            Self::Candidates => "candidate tets",
            Self::SphereMemo => "sphere memo",
            Self::SpareHashStarts => "spare hash bucket offsets",
            Self::SpareHashEntries => "spare hash entries",
            Self::SpareTetBoxes => "spare tet boxes",
            Self::SpareNormals => "spare normals",
            Self::RestPositions => "rest positions",
            Self::Other => "caller part",
            Self::PenPositions => "pen positions",
            Self::PenHits => "pen collisions",
            Self::PenFound => "pen found tets",
            Self::ObjectHits => "object collisions",
            Self::PenPenetrations => "pen penetrations",
            Self::ObjectPenetrations => "object penetrations",
            Self::PenDepthSlots => "pen depth slots",
            Self::PenDepthQueue => "pen depth queue",
            Self::PenCrossings => "pen crossings",
            Self::ObjectDepthSlots => "object depth slots",
            Self::ObjectDepthQueue => "object depth queue",
            Self::ObjectCrossings => "object crossings",
            Self::SoftDisplacement => "soft displacements",
            Self::SoftVelocity => "soft velocities",
            Self::SoftPrevious => "soft substep displacements",
            Self::SoftMass => "soft masses",
            Self::SoftInvMass => "soft inverse masses",
            Self::SoftTetRest => "soft tet rest data",
            Self::SoftLambdas => "soft multipliers",
            Self::SoftRest => "soft rest positions",
            Self::SoftTets => "soft tets",
            Self::LinkLoadA => "link load buffer a",
            Self::LinkLoadB => "link load buffer b",
            Self::LinkNext => "link next positions",
            Self::MeshNodes => "mesh node records",
            Self::MeshNormals => "mesh normals",
            Self::MeshTets => "mesh tet records",
            Self::Changes => "hierarchy change log",
            Self::SurfaceSlots => "surface slots",
            Self::SurfaceTets => "surface tet records",
            Self::SmoothSlots => "smooth normal slots",
            Self::SmoothVertices => "smooth normal vertices",
            Self::SmoothTable => "smooth normal vertex table",
            Self::SmoothQueue => "smooth normal queue",
        }
    }
}

// Every part has a bit in a [`PartSet`].
const _: () = assert!((Part::SmoothQueue as u32) < u64::BITS);

/// One part's slice: what it is, how many slots, and the bytes of one slot.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct Slots {
    /// The part.
    pub part: Part,
    /// Slots (the slice's length).
    pub len: usize,
    /// Bytes per slot.
    pub size: usize,
}

impl Slots {
    /// `len` slots of `T` for `part`.
    pub const fn of<T>(part: Part, len: usize) -> Self {
        Self {
            part,
            len,
            size: size_of::<T>(),
        }
    }

    /// The slice's bytes (`None` on overflow).
    pub const fn bytes(&self) -> Option<usize> {
        self.len.checked_mul(self.size)
    }

    /// Lines the part takes in a block: its bytes rounded up to a [`LINE`] (`None` on
    /// overflow).
    pub const fn lines(&self) -> Option<usize> {
        match self.bytes() {
            Some(b) => Some(b.div_ceil(LINE)),
            None => None,
        }
    }
}

/// A set of parts (one bit each), for a [`Split`]'s second run and the sizes of each run.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default)]
pub struct PartSet(u64);

impl PartSet {
    /// No part.
    pub const EMPTY: Self = Self(0);

    /// This set with `part` added.
    pub const fn with(self, part: Part) -> Self {
        Self(self.0 | 1 << part as u64)
    }

    /// `true` when `part` is in the set.
    pub const fn contains(self, part: Part) -> bool {
        self.0 & (1 << part as u64) != 0
    }
}

/// Lines a block needs for `parts`, each starting on a line, counting only the parts for
/// which `in_set == set.contains(part)` (`None` on overflow). With [`PartSet::EMPTY`] and
/// `in_set` false: all of them.
///
/// # Bounded work
/// O(`parts.len()`).
pub const fn lines_of(parts: &[Slots], set: PartSet, in_set: bool) -> Option<usize> {
    let mut total = 0usize;
    let mut i = 0;
    while i < parts.len() {
        if set.contains(parts[i].part) == in_set {
            total = match parts[i].lines() {
                Some(l) => match total.checked_add(l) {
                    Some(t) => t,
                    None => return None,
                },
                None => return None,
            };
        }
        i += 1;
    }
    Some(total)
}

/// Why storage could not be carved.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
#[non_exhaustive]
pub enum StorageError {
    /// The memory ran out at `part`: it needed `needed` bytes (with its line alignment),
    /// `left` were left.
    TooSmall {
        /// The part that did not fit.
        part: Part,
        /// Bytes it needed.
        needed: usize,
        /// Bytes left.
        left: usize,
    },
    /// A part's size overflows the address space.
    Overflow {
        /// The part.
        part: Part,
    },
    /// The heap refused the allocation (`owned`): `bytes` were asked for.
    Alloc {
        /// Bytes asked for.
        bytes: usize,
    },
}

impl fmt::Display for StorageError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Self::TooSmall { part, needed, left } => write!(
                f,
                "storage too small for the {}: {needed} bytes needed, {left} left",
                part.name()
            ),
            Self::Overflow { part } => {
                write!(f, "the {} would not fit in memory at all", part.name())
            }
            Self::Alloc { bytes } => write!(f, "could not allocate {bytes} bytes"),
        }
    }
}

impl core::error::Error for StorageError {}

/// Memory that parts are carved from.
pub trait Memory<'m> {
    /// Hands out `slots.bytes()` bytes starting on a [`LINE`] for `slots.part`, or says why
    /// not. The bytes may hold anything; the carver writes every slot.
    ///
    /// # Errors
    /// [`StorageError::TooSmall`] or [`StorageError::Overflow`].
    fn take(&mut self, slots: &Slots) -> Result<&'m mut [u8], StorageError>;
}

/// One run of bytes, carved from its start: each part on the next [`LINE`].
#[derive(Debug)]
pub struct Block<'m> {
    rest: &'m mut [u8],
}

impl<'m> Block<'m> {
    /// A block over `bytes`. A start that is not on a line loses the bytes up to the first
    /// line boundary.
    pub fn new(bytes: &'m mut [u8]) -> Self {
        Self { rest: bytes }
    }

    /// A block over `lines` (a `static` array or a `Vec` of [`Line`]s: it starts on a line).
    pub fn from_lines(lines: &'m mut [Line]) -> Self {
        Self::new(bytemuck::cast_slice_mut(lines))
    }

    /// Bytes not yet handed out.
    pub fn left(&self) -> usize {
        self.rest.len()
    }
}

impl<'m> Memory<'m> for Block<'m> {
    fn take(&mut self, slots: &Slots) -> Result<&'m mut [u8], StorageError> {
        let part = slots.part;
        let (Some(bytes), Some(lines)) = (slots.bytes(), slots.lines()) else {
            return Err(StorageError::Overflow { part });
        };
        // Bytes to the next line boundary of the run's address (no `unsafe`: only the
        // address's value is read).
        let pad = (self.rest.as_ptr() as usize).wrapping_neg() & (LINE - 1);
        let left = self.rest.len();
        let needed = pad.saturating_add(bytes);
        let too_small = StorageError::TooSmall { part, needed, left };
        if needed > left {
            return Err(too_small);
        }
        // The part's bytes, then the rest of its last line (the next part starts on a line).
        let span = lines
            .saturating_mul(LINE)
            .min(left.saturating_sub(pad))
            .max(bytes);
        let rest = core::mem::take(&mut self.rest);
        // Checked splits: the sizes were checked above, and no split can panic.
        let Some((_, rest)) = rest.split_at_mut_checked(pad) else {
            return Err(too_small);
        };
        let Some((part_bytes, rest)) = rest.split_at_mut_checked(span) else {
            return Err(too_small);
        };
        self.rest = rest;
        match part_bytes.split_at_mut_checked(bytes) {
            Some((b, _)) => Ok(b),
            None => Err(too_small),
        }
    }
}

/// Two runs of bytes: the parts in `second` are carved from `b`, the others from `a` (a
/// board's tightly coupled RAM and its larger, slower RAM; sizes:
/// [`crate::servo::WorldSizes::lines_in`]).
#[derive(Debug)]
pub struct Split<'m> {
    /// The run of every part not in `second`.
    pub a: Block<'m>,
    /// The run of the parts in `second`.
    pub b: Block<'m>,
    /// Which parts go to `b`.
    pub second: PartSet,
}

impl<'m> Memory<'m> for Split<'m> {
    fn take(&mut self, slots: &Slots) -> Result<&'m mut [u8], StorageError> {
        if self.second.contains(slots.part) {
            self.b.take(slots)
        } else {
            self.a.take(slots)
        }
    }
}

/// Carves `len` slots of `T` for `part` from `mem`, each set to `init`.
///
/// # Bounded work
/// O(`len`): every slot is written.
///
/// # Errors
/// What [`Memory::take`] says.
pub fn carve<'m, T: NoUninit + AnyBitPattern>(
    mem: &mut impl Memory<'m>,
    part: Part,
    len: usize,
    init: T,
) -> Result<&'m mut [T], StorageError> {
    let slots = Slots::of::<T>(part, len);
    let bytes = mem.take(&slots)?;
    // A memory hands out `len * size_of::<T>()` bytes on a line (a multiple of every slot
    // type's alignment here): the cast cannot fail, but a foreign `Memory` may break that
    // contract, which is then reported rather than trusted.
    let slice: &mut [T] =
        bytemuck::try_cast_slice_mut(bytes).map_err(|_| StorageError::TooSmall {
            part,
            needed: slots.bytes().unwrap_or(usize::MAX),
            left: 0,
        })?;
    slice.fill(init);
    Ok(slice)
}
