//! The mesh blob: a built mesh as one versioned, checksummed byte string a firmware includes
//! at build time (`include_bytes!`) and reads in place. [`write()`] lays it out from a built
//! [`Mesh`] into a caller buffer; [`MeshBlob::parse`] checks one and gives a zero-copy view
//! whose accessors decode fixed-width little-endian fields (no `unsafe`, no alignment needed).
//! [`MeshBlob::mesh`] makes a [`Mesh`] whose tets (36 of the 40 bytes a tet) are read in place
//! through a [`TetView`]; it copies the positions, normals and node records (32 bytes a node)
//! into caller storage, because they change: positions whenever the mesh moves or deforms,
//! normals and boundary flags with [`Mesh::update_boundary`].
//!
//! Layout, every field little-endian (`N` nodes, `T` tets):
//!
//! | offset            | bytes  | what                                                        |
//! |-------------------|--------|-------------------------------------------------------------|
//! | 0                 | 4      | magic `TDMB`                                                |
//! | 4                 | 2      | version ([`VERSION`])                                       |
//! | 6                 | 2      | header length ([`HEADER_LEN`])                              |
//! | 8                 | 4      | `N`                                                         |
//! | 12                | 4      | `T`                                                         |
//! | 16                | 4      | payload length, `32 N + 40 T`                               |
//! | 20                | 4      | FNV-1a 32 of the payload                                    |
//! | 24                | 12 N   | positions, 3 x f32 per node                                 |
//! | 24 + 12 N         | 12 N   | boundary normals, 3 x f32 per node (zero inside)            |
//! | 24 + 24 N         | 8 N    | node records: tet u32 (`u32::MAX`: no tet), local u8,       |
//! |                   |        | boundary u8, 2 zero bytes                                   |
//! | 24 + 32 N         | 36 T   | tets: 4 node ids, 4 neighbour ids (`u32::MAX`: boundary),   |
//! |                   |        | 4 reverse-index bytes                                       |
//! | 24 + 32 N + 36 T  | 4 T    | region labels, i32 per tet                                  |
//!
//! FNV-1a changes its state bijectively with every byte, so any one changed payload byte
//! changes the checksum; a changed header byte breaks the magic, the version, the lengths or
//! the checksum. [`MeshBlob::parse`] also checks every id is in range and every neighbour
//! points back through its reverse index, so a view's accessors never index outside the blob
//! and a mesh read in place never walks outside itself.
//!
//! ```
//! use tetradrill_core::blob::{self, BlobError, MeshBlob};
//! use tetradrill_core::builtin;
//! use tetradrill_core::prelude::*;
//!
//! let (mut pos, tets) = builtin::cube12();
//! let (mut nodes, mut normals) = ([Node::default(); 9], [Vec3::ZERO; 9]);
//! let (mut recs, mut scratch) = ([Tet::default(); 12], [FaceKey::default(); 48]);
//! let storage = MeshStorage { nodes: &mut nodes, normals: &mut normals, tets: &mut recs };
//! let mesh = Mesh::build(&mut pos, &tets, storage, &mut scratch, BuildOptions::default())?;
//!
//! // The blob's bytes (what a firmware includes), region label 0 for every tet.
//! let mut bytes = vec![0u8; blob::blob_len(9, 12).unwrap()];
//! blob::write(&mesh, &[0; 12], &mut bytes)?;
//!
//! // Read in place: the tets stay in the bytes, positions, normals and nodes are copied.
//! let parsed = MeshBlob::parse(&bytes)?;
//! let (mut p, mut n, mut nodes) = ([Vec3::ZERO; 9], [Vec3::ZERO; 9], [Node::default(); 9]);
//! let read = parsed.mesh(&mut p, &mut n, &mut nodes)?;
//! read.validate()?;
//! assert_eq!(read.tet(TetId(5)), mesh.tet(TetId(5)));
//! assert_eq!(read.stats().boundary_faces, 12);
//!
//! // One flipped payload bit is caught by the checksum.
//! bytes[40] ^= 1;
//! assert!(matches!(MeshBlob::parse(&bytes), Err(BlobError::Checksum { .. })));
//! # Ok::<(), tetradrill_core::Error>(())
//! ```

use glam::Vec3;

use crate::ids::{NodeId, TetId};
use crate::mesh::{BuildStats, Mesh, Node, Tet, TetView, TetViewError, TET_RECORD};

/// The blob's first four bytes.
pub(crate) const MAGIC: [u8; 4] = *b"TDMB";
/// The layout version this module writes and reads.
pub const VERSION: u16 = 1;
/// Bytes before the payload.
pub const HEADER_LEN: usize = 24;
/// Payload bytes per node: position, normal, record.
pub(crate) const NODE_BYTES: usize = 32;
/// Payload bytes per tet: record and label.
pub(crate) const TET_BYTES: usize = 40;

/// Why a blob was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum BlobError {
    /// Shorter than the header, or than the header says.
    Truncated {
        /// Bytes the blob needs.
        needed: usize,
        /// Bytes there are.
        got: usize,
    },
    /// Longer than the header says.
    TrailingBytes {
        /// Bytes the header accounts for.
        expected: usize,
        /// Bytes there are.
        got: usize,
    },
    /// The first four bytes are not `MAGIC`.
    BadMagic,
    /// A version this code does not read.
    Version(u16),
    /// A header length other than [`HEADER_LEN`].
    HeaderLength(u16),
    /// The payload length does not match the counts (or they overflow).
    PayloadLength {
        /// Length the counts give.
        expected: usize,
        /// Length the header says.
        got: usize,
    },
    /// The payload's checksum is not the header's.
    Checksum {
        /// From the header.
        expected: u32,
        /// Of the payload.
        got: u32,
    },
    /// A record refers outside the mesh: which record, at which byte offset.
    BadRecord {
        /// What is wrong.
        what: &'static str,
        /// Byte offset of the field in the blob.
        offset: usize,
    },
    /// The output buffer of [`write()`] is too small, or the labels do not match the tets.
    Buffer,
}

impl core::fmt::Display for BlobError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match *self {
            Self::Truncated { needed, got } => {
                write!(f, "truncated: {got} bytes, {needed} needed")
            }
            Self::TrailingBytes { expected, got } => {
                write!(f, "{got} bytes, the header accounts for {expected}")
            }
            Self::BadMagic => write!(f, "byte 0: not a tetradrill mesh blob (no TDMB magic)"),
            Self::Version(v) => write!(f, "byte 4: version {v}, this build reads {VERSION}"),
            Self::HeaderLength(h) => write!(f, "byte 6: header length {h}, expected {HEADER_LEN}"),
            Self::PayloadLength { expected, got } => write!(
                f,
                "byte 16: payload length {got} does not match the counts ({expected})"
            ),
            Self::Checksum { expected, got } => write!(
                f,
                "byte 20: checksum {expected:08x} but the payload's is {got:08x} (corrupted)"
            ),
            Self::BadRecord { what, offset } => write!(f, "byte {offset}: {what}"),
            Self::Buffer => write!(f, "output buffer or labels of the wrong length"),
        }
    }
}

impl core::error::Error for BlobError {}

/// FNV-1a 32 over `bytes`.
///
/// # Bounded work
/// One multiply per byte.
pub fn checksum(bytes: &[u8]) -> u32 {
    let mut h: u32 = 0x811c_9dc5;
    for &b in bytes {
        h ^= b as u32;
        h = h.wrapping_mul(0x0100_0193);
    }
    h
}

/// Bytes of the blob of a mesh with `nodes` nodes and `tets` tets; `None` on overflow or a
/// count that does not fit a `u32`.
///
/// # Bounded work
/// O(1).
pub fn blob_len(nodes: usize, tets: usize) -> Option<usize> {
    if u32::try_from(nodes).is_err() || u32::try_from(tets).is_err() {
        return None;
    }
    let payload = nodes
        .checked_mul(NODE_BYTES)?
        .checked_add(tets.checked_mul(TET_BYTES)?)?;
    u32::try_from(payload).ok()?;
    payload.checked_add(HEADER_LEN)
}

/// Writes the blob of `mesh` with one region label per tet into `out`, which must be exactly
/// [`blob_len`] bytes long.
///
/// # Bounded work
/// O(nodes + tets): each field written once, then one checksum pass.
///
/// # Errors
/// [`BlobError::Buffer`] when `out` or `labels` has the wrong length.
pub fn write(mesh: &Mesh<'_>, labels: &[i32], out: &mut [u8]) -> Result<usize, BlobError> {
    let (n, t) = (mesh.node_count(), mesh.tet_count());
    let len = blob_len(n, t).ok_or(BlobError::Buffer)?;
    if out.len() != len || labels.len() != t {
        return Err(BlobError::Buffer);
    }
    let mut w = Cursor {
        out,
        at: HEADER_LEN,
    };
    for p in mesh.positions() {
        w.vec3(*p);
    }
    for q in mesh.normals() {
        w.vec3(*q);
    }
    for node in mesh.nodes() {
        w.u32(node.tet.0);
        w.bytes(&[node.local, node.boundary() as u8, 0, 0]);
    }
    for tet in mesh.tets() {
        w.bytes(&tet.to_le_bytes());
    }
    for &l in labels {
        w.u32(l as u32);
    }
    let sum = checksum(&w.out[HEADER_LEN..]);
    let mut h = Cursor { out: w.out, at: 0 };
    h.bytes(&MAGIC);
    h.bytes(&VERSION.to_le_bytes());
    h.bytes(&(HEADER_LEN as u16).to_le_bytes());
    h.u32(n as u32);
    h.u32(t as u32);
    h.u32((len - HEADER_LEN) as u32);
    h.u32(sum);
    Ok(len)
}

/// A forward writer over a buffer [`write()`] has sized.
struct Cursor<'a> {
    out: &'a mut [u8],
    at: usize,
}

impl Cursor<'_> {
    fn bytes(&mut self, b: &[u8]) {
        if let Some(dst) = self.out.get_mut(self.at..self.at + b.len()) {
            dst.copy_from_slice(b);
        }
        self.at += b.len();
    }
    fn u32(&mut self, v: u32) {
        self.bytes(&v.to_le_bytes());
    }
    fn vec3(&mut self, v: Vec3) {
        for c in [v.x, v.y, v.z] {
            self.u32(c.to_bits());
        }
    }
}

/// A checked blob, read in place: every accessor decodes its fields from the borrowed bytes.
#[derive(Clone, Copy, Debug)]
pub struct MeshBlob<'a> {
    bytes: &'a [u8],
    nodes: usize,
    tets: usize,
    view: TetView<'a>,
}

/// The little-endian `u32` at `at` (0 outside `b`; [`MeshBlob::parse`] keeps every read
/// inside).
#[inline]
fn le32(b: &[u8], at: usize) -> u32 {
    match b.get(at..at + 4) {
        Some(&[a, c, d, e]) => u32::from_le_bytes([a, c, d, e]),
        _ => 0,
    }
}

impl<'a> MeshBlob<'a> {
    /// Checks `bytes` (header, lengths, checksum, every id in range) and gives the view.
    ///
    /// # Bounded work
    /// O(len): one checksum pass and one pass over the records.
    ///
    /// # Errors
    /// The first problem found, with the byte offset where there is one.
    pub fn parse(bytes: &'a [u8]) -> Result<Self, BlobError> {
        if bytes.len() < HEADER_LEN {
            return Err(BlobError::Truncated {
                needed: HEADER_LEN,
                got: bytes.len(),
            });
        }
        if bytes[0..4] != MAGIC {
            return Err(BlobError::BadMagic);
        }
        let version = u16::from_le_bytes([bytes[4], bytes[5]]);
        if version != VERSION {
            return Err(BlobError::Version(version));
        }
        let header = u16::from_le_bytes([bytes[6], bytes[7]]);
        if header as usize != HEADER_LEN {
            return Err(BlobError::HeaderLength(header));
        }
        let nodes = le32(bytes, 8) as usize;
        let tets = le32(bytes, 12) as usize;
        let payload = le32(bytes, 16) as usize;
        let expected = blob_len(nodes, tets).map(|l| l - HEADER_LEN);
        if expected != Some(payload) {
            return Err(BlobError::PayloadLength {
                expected: expected.unwrap_or(usize::MAX),
                got: payload,
            });
        }
        let total = HEADER_LEN + payload;
        if bytes.len() < total {
            return Err(BlobError::Truncated {
                needed: total,
                got: bytes.len(),
            });
        }
        if bytes.len() > total {
            return Err(BlobError::TrailingBytes {
                expected: total,
                got: bytes.len(),
            });
        }
        let sum = checksum(&bytes[HEADER_LEN..]);
        let want = le32(bytes, 20);
        if sum != want {
            return Err(BlobError::Checksum {
                expected: want,
                got: sum,
            });
        }
        let tet_start = HEADER_LEN + 32 * nodes;
        let tet_bytes = bytes
            .get(tet_start..tet_start + TET_RECORD * tets)
            .unwrap_or_default();
        let view = TetView::new(tet_bytes, nodes).map_err(|e| match e {
            TetViewError::BadRecord { what, offset } => BlobError::BadRecord {
                what,
                offset: tet_start + offset,
            },
            TetViewError::Length { .. } => BlobError::PayloadLength {
                expected: payload,
                got: payload,
            },
        })?;
        let blob = Self {
            bytes,
            nodes,
            tets,
            view,
        };
        blob.check_nodes()?;
        Ok(blob)
    }

    /// Every node record's tet in range and pointing back at the node; every small field
    /// within its values. The tets are checked by [`TetView::new`].
    fn check_nodes(&self) -> Result<(), BlobError> {
        let bad = |what, offset| Err(BlobError::BadRecord { what, offset });
        for i in 0..self.nodes {
            let at = self.node_at(i);
            let tet = le32(self.bytes, at);
            // The payload length was checked: every record lies inside the bytes.
            let byte = |k: usize| self.bytes.get(at + k).copied().unwrap_or(u8::MAX);
            let local = byte(4);
            if local > 3 {
                return bad("node record: local vertex over 3", at + 4);
            }
            if byte(5) > 1 {
                return bad("node record: boundary flag not 0 or 1", at + 5);
            }
            if tet == TetId::NONE.0 {
                continue;
            }
            match self.view.nodes(TetId(tet)) {
                None => return bad("node record: tet id out of range", at),
                Some(ids) if ids.get(usize::from(local)).map(|n| n.idx()) != Some(i) => {
                    return bad("node record: its tet does not use the node", at)
                }
                Some(_) => {}
            }
        }
        Ok(())
    }

    fn positions_at(&self) -> usize {
        HEADER_LEN
    }
    fn normal_at(&self, i: usize) -> usize {
        HEADER_LEN + 12 * self.nodes + 12 * i
    }
    fn node_at(&self, i: usize) -> usize {
        HEADER_LEN + 24 * self.nodes + 8 * i
    }
    fn label_at(&self, i: usize) -> usize {
        HEADER_LEN + 32 * self.nodes + 36 * self.tets + 4 * i
    }
    fn vec3_at(&self, at: usize) -> Vec3 {
        let c = |k: usize| f32::from_bits(le32(self.bytes, at + 4 * k));
        Vec3::new(c(0), c(1), c(2))
    }

    /// Number of nodes.
    pub fn node_count(&self) -> usize {
        self.nodes
    }

    /// Number of tets.
    pub fn tet_count(&self) -> usize {
        self.tets
    }

    /// Position of node `n`; `None` outside the mesh.
    ///
    /// # Bounded work
    /// O(1).
    pub fn position(&self, n: NodeId) -> Option<Vec3> {
        (n.idx() < self.nodes).then(|| self.vec3_at(self.positions_at() + 12 * n.idx()))
    }

    /// Boundary normal of node `n` (zero for an interior node); `None` outside the mesh.
    ///
    /// # Bounded work
    /// O(1).
    pub fn normal(&self, n: NodeId) -> Option<Vec3> {
        (n.idx() < self.nodes).then(|| self.vec3_at(self.normal_at(n.idx())))
    }

    /// Record of node `n`; `None` outside the mesh.
    ///
    /// # Bounded work
    /// O(1).
    pub fn node(&self, n: NodeId) -> Option<Node> {
        (n.idx() < self.nodes).then(|| {
            let at = self.node_at(n.idx());
            let byte = |i: usize| self.bytes.get(at + i).copied().unwrap_or(0);
            Node::new(TetId(le32(self.bytes, at)), byte(4), byte(5) != 0)
        })
    }

    /// Record of tet `t` (nodes, neighbours, reverse indices); `None` outside the mesh.
    ///
    /// # Bounded work
    /// O(1).
    pub fn tet(&self, t: TetId) -> Option<Tet> {
        self.view.get(t)
    }

    /// The tet records, checked, read in place.
    pub fn tets(&self) -> TetView<'a> {
        self.view
    }

    /// The mesh with its tets read in place ([`Mesh::in_place`]): the positions, normals and
    /// node records copied into `positions`, `normals` and `nodes` (cut to the node count),
    /// the build statistics recounted from the records (`orientation_fixes` and `relabelled`
    /// are not stored and read 0).
    ///
    /// # Bounded work
    /// O(N + T): one pass over the nodes, one over the tets to count boundary faces.
    ///
    /// # Errors
    /// [`BlobError::Buffer`] when a slice is shorter than the node count.
    pub fn mesh(
        &self,
        positions: &'a mut [Vec3],
        normals: &'a mut [Vec3],
        nodes: &'a mut [Node],
    ) -> Result<Mesh<'a>, BlobError> {
        let n = self.nodes;
        if normals.len() < n || nodes.len() < n {
            return Err(BlobError::Buffer);
        }
        let (positions, _) = positions.split_at_mut_checked(n).ok_or(BlobError::Buffer)?;
        let mut stats = BuildStats::default();
        let slots = positions
            .iter_mut()
            .zip(normals.iter_mut())
            .zip(nodes.iter_mut());
        for (i, ((p, nrm), node)) in slots.enumerate() {
            let id = NodeId::from_idx(i);
            *p = self.position(id).unwrap_or(Vec3::ZERO);
            *nrm = self.normal(id).unwrap_or(Vec3::ZERO);
            let rec = self.node(id).unwrap_or_default();
            stats.boundary_nodes += rec.boundary() as u32;
            stats.unreferenced_nodes += rec.tet.is_none() as u32;
            *node = rec;
        }
        for t in 0..self.tets {
            for f in 0..4 {
                let nb = self.view.neighbour(TetId::from_idx(t), f);
                stats.boundary_faces += (nb == Some(TetId::NONE)) as u32;
            }
        }
        Mesh::in_place(positions, normals, nodes, self.view, stats).ok_or(BlobError::Buffer)
    }

    /// Region label of tet `t`; `None` outside the mesh.
    ///
    /// # Bounded work
    /// O(1).
    pub fn label(&self, t: TetId) -> Option<i32> {
        (t.idx() < self.tets).then(|| le32(self.bytes, self.label_at(t.idx())) as i32)
    }
}
