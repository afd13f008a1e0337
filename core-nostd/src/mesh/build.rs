//! Building the adjacency from a plain tet list, without allocating: one sort of the face keys
//! in caller scratch, then one pass that links pairs of equal faces.

use glam::Vec3;

use super::record::{Node, Reverse, Tet};
use super::template::FACE_VERTS;
use super::Mesh;
use crate::geom::det6_f64;
use crate::ids::{NodeId, TetId};
use crate::storage::{carve, lines_of, Memory, Part, PartSet, Slots, StorageError};

/// One face of one tet as a sortable key: the face's node ids sorted ascending and the owner
/// `tet * 4 + face`. Scratch for [`Mesh::build`]: the caller hands in `4 * tets` of them.
///
/// Packed in one `u128` (ids from the high bits down, the owner lowest), so sorting compares
/// one integer: the order is the ids' lexicographic order, then the owner's. Plain bits
/// (`bytemuck::Pod`), so a board can carve its scratch from memory it later carves other
/// storage from ([`crate::storage::carve`]).
#[derive(
    Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Debug, Default, bytemuck::Pod, bytemuck::Zeroable,
)]
#[repr(transparent)]
pub struct FaceKey(u128);

impl FaceKey {
    /// The all-zero key (`FaceKey::default()`), for scratch arrays in `const` context (a
    /// static the caller hands to [`Mesh::build`]).
    pub const ZERO: Self = Self(0);

    fn new(verts: [u32; 3], owner: u32) -> Self {
        let [a, b, c] = verts.map(u128::from);
        Self((a << 96) | (b << 64) | (c << 32) | u128::from(owner))
    }

    /// The face's node ids, ascending.
    fn verts(self) -> u128 {
        self.0 >> 32
    }

    /// `tet * 4 + face`.
    fn owner(self) -> u32 {
        self.0 as u32
    }
}

/// What [`Mesh::build`] may change in the input, and how.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct BuildOptions {
    /// Relabel every tet (by an even permutation, so orientation is kept) so that the
    /// octahedron diagonal `x02-x13` used by red refinement is its shortest one (Bey 1995;
    /// docs/DRILLING.md). On by default; switch it off to keep the file's vertex order.
    pub relabel_for_refinement: bool,
}

impl Default for BuildOptions {
    fn default() -> Self {
        Self {
            relabel_for_refinement: true,
        }
    }
}

/// Counts gathered while building; [`Mesh::stats`] returns them.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default)]
pub struct BuildStats {
    /// Tets found negatively oriented and flipped (two nodes swapped).
    pub orientation_fixes: u32,
    /// Tets relabelled so `x02-x13` is the shortest octahedron diagonal.
    pub relabelled: u32,
    /// Faces with no neighbour.
    pub boundary_faces: u32,
    /// Nodes on at least one boundary face.
    pub boundary_nodes: u32,
    /// Nodes no tet uses (kept, with `Node::tet == NONE`).
    pub unreferenced_nodes: u32,
}

/// Why a tet list could not become a mesh. Each names the first offending tet or node, by its
/// index in the input.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
#[non_exhaustive]
pub enum BuildError {
    /// A storage slice is shorter than the counts need: `what` names it.
    StorageTooSmall {
        /// Which slice: "nodes", "normals", "tets" or "face scratch".
        what: &'static str,
        /// Entries needed.
        needed: usize,
    },
    /// More nodes or tets than a `u32` id can name.
    TooLarge,
    /// A tet names a node outside `0..nodes`.
    NodeOutOfRange {
        /// Input tet index.
        tet: u32,
        /// The node id it names.
        node: u32,
    },
    /// A tet names the same node twice.
    RepeatedNode {
        /// Input tet index.
        tet: u32,
    },
    /// A node position is NaN or infinite.
    NonFinite {
        /// Input node index.
        node: u32,
    },
    /// A tet has (numerically) zero volume.
    ZeroVolume {
        /// Input tet index.
        tet: u32,
    },
    /// The same face is listed by the same tet twice or by more than two tets.
    NonManifoldFace {
        /// One of the tets that share it.
        tet: u32,
    },
    /// Two tets share a face from the same side (they overlap).
    InconsistentFace {
        /// One of the two tets.
        tet: u32,
    },
}

impl core::fmt::Display for BuildError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match *self {
            Self::StorageTooSmall { what, needed } => {
                write!(f, "{what} storage too small: {needed} entries needed")
            }
            Self::TooLarge => write!(f, "more nodes or tets than a 32-bit id can name"),
            Self::NodeOutOfRange { tet, node } => {
                write!(f, "tet {tet} names node {node}, which does not exist")
            }
            Self::RepeatedNode { tet } => write!(f, "tet {tet} names the same node twice"),
            Self::NonFinite { node } => write!(f, "node {node} has a NaN or infinite coordinate"),
            Self::ZeroVolume { tet } => write!(f, "tet {tet} has zero volume"),
            Self::NonManifoldFace { tet } => {
                write!(f, "a face of tet {tet} is shared by more than two tets")
            }
            Self::InconsistentFace { tet } => {
                write!(
                    f,
                    "tet {tet} overlaps a neighbour (they share a face from the same side)"
                )
            }
        }
    }
}

impl core::error::Error for BuildError {}

/// Storage for one mesh, handed in by the caller. Lengths are capacities: `nodes` and
/// `normals` need at least one entry per node, `tets` one per tet.
#[derive(Debug)]
pub struct MeshStorage<'a> {
    /// One per node.
    pub nodes: &'a mut [Node],
    /// One per node: averaged outward normals of boundary nodes (zero inside).
    pub normals: &'a mut [Vec3],
    /// One per tet.
    pub tets: &'a mut [Tet],
}

impl<'a> MeshStorage<'a> {
    /// Every slice of a [`MeshStorage`] for `nodes` nodes and `tets` tet records, in the
    /// order [`MeshStorage::carve`] takes them.
    pub const fn parts(nodes: usize, tets: usize) -> [Slots; 3] {
        [
            Slots::of::<Node>(Part::MeshNodes, nodes),
            Slots::of::<Vec3>(Part::MeshNormals, nodes),
            Slots::of::<Tet>(Part::MeshTets, tets),
        ]
    }

    /// The [`crate::storage::Line`]s a [`crate::storage::Block`] starting on a line needs for
    /// [`MeshStorage::parts`] (`None` when they overflow the address space).
    pub const fn lines(nodes: usize, tets: usize) -> Option<usize> {
        lines_of(&Self::parts(nodes, tets), PartSet::EMPTY, false)
    }

    /// Carves the storage of a mesh of `nodes` nodes and `tets` tet records (zero for a mesh
    /// whose tets are read in place, [`super::Mesh::in_place`]) from `mem`, every record at
    /// its default and every normal zero, for [`super::Mesh::build`] to fill.
    ///
    /// # Bounded work
    /// O(`nodes + tets`): every slot is written.
    ///
    /// # Errors
    /// [`StorageError`] naming the first part the memory could not hold.
    pub fn carve(
        nodes: usize,
        tets: usize,
        mem: &mut impl Memory<'a>,
    ) -> Result<Self, StorageError> {
        Ok(Self {
            nodes: carve(mem, Part::MeshNodes, nodes, Node::default())?,
            normals: carve(mem, Part::MeshNormals, nodes, Vec3::ZERO)?,
            tets: carve(mem, Part::MeshTets, tets, Tet::default())?,
        })
    }
}

/// Relative volume below which a tet counts as degenerate: `|6V| <= EPS * L^3` for its
/// longest edge `L`. Far below any tet a mesher produces (a 0.2 degree sliver is ~1e-4).
const ZERO_VOLUME_REL: f64 = 1e-10;

/// The even permutations that move each of the three vertex pairings onto `{0,2} | {1,3}`:
/// new vertex `i` is old vertex `perm[i]`.
const RELABEL: [[u8; 4]; 3] = [
    [1, 2, 0, 3], // pairing {0,1}|{2,3}
    [0, 1, 2, 3], // pairing {0,2}|{1,3}: already x02-x13
    [0, 2, 3, 1], // pairing {0,3}|{1,2}
];

/// The permutation that makes `x02-x13` the shortest octahedron diagonal of the tet `p`
/// (ties keep the current labelling). Even, so orientation is kept.
pub(crate) fn refinement_relabel(p: [Vec3; 4]) -> [u8; 4] {
    // Diagonal between midpoints of (a,b) and (c,d) is ((a+b) - (c+d)) / 2.
    let d = |a: usize, b: usize, c: usize, e: usize| (p[a] + p[b] - p[c] - p[e]).length_squared();
    let lens = [d(0, 1, 2, 3), d(0, 2, 1, 3), d(0, 3, 1, 2)];
    let mut best = 1;
    if lens[0] < lens[best] {
        best = 0;
    }
    if lens[2] < lens[best] {
        best = 2;
    }
    RELABEL[best]
}

impl<'a> Mesh<'a> {
    /// Builds a mesh from node positions and a tet list.
    ///
    /// `positions` holds one point per node (its length is the node count) and stays borrowed
    /// by the mesh; `tet_nodes` holds four node indices per tet. Negatively oriented tets are
    /// flipped (counted in [`BuildStats::orientation_fixes`]); with
    /// [`BuildOptions::relabel_for_refinement`] each tet is relabelled so `x02-x13` is its
    /// shortest octahedron diagonal. `scratch` needs `4 * tet_nodes.len()` entries and is free
    /// again when this returns.
    ///
    /// # Bounded work
    /// O(T log T) for T tets (the 4T face keys sorted in two parts, run by run when the tets come
    /// sorted by their smallest node), O(N) for N nodes; no allocation.
    ///
    /// # Errors
    /// [`BuildError`] names the first bad tet or node; storage too small is reported before
    /// anything is written.
    pub fn build(
        positions: &'a mut [Vec3],
        tet_nodes: &[[u32; 4]],
        storage: MeshStorage<'a>,
        scratch: &mut [FaceKey],
        options: BuildOptions,
    ) -> Result<Self, BuildError> {
        let n = positions.len();
        let t = tet_nodes.len();
        if n >= u32::MAX as usize || t >= (u32::MAX / 4) as usize {
            return Err(BuildError::TooLarge);
        }
        let MeshStorage {
            nodes,
            normals,
            tets,
        } = storage;
        check_len("nodes", nodes.len(), n)?;
        check_len("normals", normals.len(), n)?;
        check_len("tets", tets.len(), t)?;
        check_len("face scratch", scratch.len(), 4 * t)?;
        let nodes = &mut nodes[..n];
        let normals = &mut normals[..n];
        let tets = &mut tets[..t];
        let scratch = &mut scratch[..4 * t];

        for (i, p) in positions.iter().enumerate() {
            if !p.is_finite() {
                return Err(BuildError::NonFinite { node: i as u32 });
            }
        }

        let mut stats = BuildStats::default();
        for (i, (src, dst)) in tet_nodes.iter().zip(tets.iter_mut()).enumerate() {
            let ti = i as u32;
            for &v in src {
                if v as usize >= n {
                    return Err(BuildError::NodeOutOfRange { tet: ti, node: v });
                }
            }
            for a in 0..4 {
                for b in a + 1..4 {
                    if src[a] == src[b] {
                        return Err(BuildError::RepeatedNode { tet: ti });
                    }
                }
            }
            let mut ids = *src;
            let p = ids.map(|v| positions[v as usize]);
            let det = det6_f64(p[0], p[1], p[2], p[3]);
            let mut longest = 0.0f64;
            for a in 0..4 {
                for b in a + 1..4 {
                    longest = longest.max((p[a] - p[b]).length() as f64);
                }
            }
            let big_enough = det.abs() > ZERO_VOLUME_REL * longest * longest * longest;
            if !big_enough {
                return Err(BuildError::ZeroVolume { tet: ti });
            }
            if det < 0.0 {
                ids.swap(2, 3);
                stats.orientation_fixes += 1;
            }
            if options.relabel_for_refinement {
                let q = ids.map(|v| positions.get(v as usize).copied().unwrap_or_default());
                let perm = refinement_relabel(q);
                if perm != [0, 1, 2, 3] {
                    ids = perm.map(|k| ids[k as usize]);
                    stats.relabelled += 1;
                }
            }
            *dst = Tet::new(ids.map(NodeId));
        }

        // Face keys, sorted, then equal neighbours linked. The three faces through each tet's
        // smallest node go first (`near`), the opposite faces after (`far`): when the tets come
        // sorted by their smallest node, as a loaded file's do (spatial order), `near` is already
        // grouped by its leading id and sorts run by run; the two halves are then walked as one
        // sorted sequence, so the links are the ones a single sort would give.
        let (near, far) = scratch.split_at_mut(3 * t);
        for (ti, tet) in tets.iter().enumerate() {
            let first = (0..4).min_by_key(|&k| tet.nodes[k].0).unwrap_or(0);
            let mut slot = 0;
            for (f, face) in FACE_VERTS.iter().enumerate() {
                let mut verts = face.map(|k| tet.nodes[k as usize].0);
                verts.sort_unstable();
                let key = FaceKey::new(verts, (ti * 4 + f) as u32);
                // Face f is opposite local node f.
                // In range: `far` has `t` entries and `near` `3 * t` (checked above).
                if f == first {
                    if let Some(at) = far.get_mut(ti) {
                        *at = key;
                    }
                } else {
                    if let Some(at) = near.get_mut(ti * 3 + slot) {
                        *at = key;
                    }
                    slot += 1;
                }
            }
        }
        sort_faces(near);
        far.sort_unstable();
        let mut faces = Merged::new(near, far);
        let mut group = faces.next();
        while let Some(head) = group {
            let mut count = 1;
            let mut second = head;
            group = None;
            for key in faces.by_ref() {
                if key.verts() != head.verts() {
                    group = Some(key);
                    break;
                }
                if count == 1 {
                    second = key;
                }
                count += 1;
            }
            match count {
                1 => stats.boundary_faces += 1,
                2 => link(tets, head.owner(), second.owner())?,
                _ => {
                    return Err(BuildError::NonManifoldFace {
                        tet: head.owner() / 4,
                    })
                }
            }
        }

        for node in nodes.iter_mut() {
            *node = Node::default();
        }
        for (ti, tet) in tets.iter().enumerate() {
            for (local, id) in tet.nodes.iter().enumerate() {
                // In range: every id was checked against the node count above.
                let Some(node) = nodes.get_mut(id.idx()) else {
                    continue;
                };
                if node.tet.is_none() {
                    node.tet = TetId::from_idx(ti);
                    node.local = local as u8;
                }
            }
        }
        stats.unreferenced_nodes = nodes.iter().filter(|n| n.tet.is_none()).count() as u32;

        let mut mesh = Mesh {
            positions,
            rest: &mut [],
            normals,
            nodes,
            tet_count: tets.len(),
            ram: tets,
            view: super::TetView::EMPTY,
            stats,
        };
        mesh.update_boundary();
        Ok(mesh)
    }
}

/// Sorts face keys, run by run when they are already grouped by their smallest node id (each
/// run holds one node's faces: a few dozen keys), whole otherwise.
///
/// # Bounded work
/// O(K log K) for K keys; one O(K) scan to choose.
fn sort_faces(keys: &mut [FaceKey]) {
    let lead = |k: &FaceKey| (k.0 >> 96) as u32;
    if !keys.windows(2).all(|w| lead(&w[0]) <= lead(&w[1])) {
        keys.sort_unstable();
        return;
    }
    let mut rest = keys;
    while let Some(first) = rest.first() {
        let id = lead(first);
        let end = rest
            .iter()
            .position(|k| lead(k) != id)
            .unwrap_or(rest.len());
        let (run, tail) = rest.split_at_mut(end);
        run.sort_unstable();
        rest = tail;
    }
}

/// Two sorted runs of face keys read as one sorted sequence (a merge without a buffer).
struct Merged<'k> {
    a: &'k [FaceKey],
    b: &'k [FaceKey],
}

impl<'k> Merged<'k> {
    fn new(a: &'k [FaceKey], b: &'k [FaceKey]) -> Self {
        Self { a, b }
    }
}

impl Iterator for Merged<'_> {
    type Item = FaceKey;

    fn next(&mut self) -> Option<FaceKey> {
        let take_a = match (self.a.first(), self.b.first()) {
            (Some(x), Some(y)) => x <= y,
            (Some(_), None) => true,
            (None, Some(_)) => false,
            (None, None) => return None,
        };
        let side = if take_a { &mut self.a } else { &mut self.b };
        let (head, tail) = side.split_first()?;
        *side = tail;
        Some(*head)
    }
}

fn check_len(what: &'static str, have: usize, needed: usize) -> Result<(), BuildError> {
    if have < needed {
        Err(BuildError::StorageTooSmall { what, needed })
    } else {
        Ok(())
    }
}

/// Links face `a = t1*4+f1` with face `b = t2*4+f2`, which list the same three nodes.
fn link(tets: &mut [Tet], a: u32, b: u32) -> Result<(), BuildError> {
    let (t1, f1) = ((a / 4) as usize, (a % 4) as usize);
    let (t2, f2) = ((b / 4) as usize, (b % 4) as usize);
    if t1 == t2 {
        return Err(BuildError::NonManifoldFace { tet: t1 as u32 });
    }
    let (Some(n1), Some(n2)) = (tets.get(t1).map(|r| r.nodes), tets.get(t2).map(|r| r.nodes))
    else {
        return Err(BuildError::NonManifoldFace { tet: t1 as u32 });
    };
    let l1 = FACE_VERTS[f1].map(|k| n1[k as usize]);
    let l2 = FACE_VERTS[f2].map(|k| n2[k as usize]);
    // Position in l2 of l1[0] gives the offset; the rest must follow in reverse order.
    let Some(q) = l2.iter().position(|&v| v == l1[0]) else {
        return Err(BuildError::NonManifoldFace { tet: t1 as u32 });
    };
    for p in 0..3 {
        if l2[(3 - p + q) % 3] != l1[p] {
            return Err(BuildError::InconsistentFace { tet: t1 as u32 });
        }
    }
    // Seen from t2 the relation is symmetric: l1[(3 - p + q) % 3] == l2[p].
    tets[t1].neighbours[f1] = TetId(t2 as u32);
    tets[t1].reverse[f1] = Reverse::new(f2 as u8, q as u8);
    tets[t2].neighbours[f2] = TetId(t1 as u32);
    tets[t2].reverse[f2] = Reverse::new(f1 as u8, q as u8);
    Ok(())
}
