//! Same-level adjacency through the index digits, and the NTree visit of Turini et al. 2006,
//! section 2.1 (never built).
//!
//! [`neighbour`] walks up from a node while its face lies on its parent's face (recording the
//! sub-triangle position at each level), takes the sibling step from [`CHILD_ADJ`] at the first
//! level where the face is interior — or crosses the coarse face into the neighbouring tet's
//! tree through the mesh's reverse index (its ring offset gives the listing permutation) —
//! and walks back down on the other side, mapping each recorded position through the listing
//! permutation. `visit_across` then follows that path in the instantiated hierarchy: it meets
//! either one coarser leaf on the path, or the subtree of the neighbour restricted to the nodes
//! with a face on the shared face.

use super::node::HNode;
use super::table::{invert, then, Across, Path, Perm, CHILD_ADJ, FACE_SUB, MAX_DEPTH};
use crate::ids::TetId;
use crate::mesh::{FaceUse, Mesh};

/// The same-level neighbour of a node across one face.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub(crate) struct Neighbour {
    /// Its coarse tet.
    pub(crate) tet: TetId,
    /// Its path (same depth as the query).
    pub(crate) path: Path,
    /// Its face that is the shared face.
    pub(crate) face: u8,
    /// Listing permutation: position `k` of the query face's listing is position `pi[k]` of
    /// the neighbour face's listing.
    pub(crate) pi: Perm,
    /// Depth of the first level where the neighbour's ancestors differ from the query's
    /// (0 when across a coarse face).
    pub(crate) split: u8,
    /// `faces[m]` for `split <= m <= depth`: the face of the neighbour's ancestor at depth `m`
    /// that contains the shared face.
    pub(crate) faces: [u8; MAX_DEPTH + 1],
}

/// The same-level neighbour of node `path` of coarse tet `tet` across face `face`, or `None`
/// when that face lies on the mesh boundary (or `tet` is out of range, or `path` is deeper
/// than [`MAX_DEPTH`]).
///
/// # Bounded work
/// O(depth) <= 2 * [`MAX_DEPTH`] table steps, one mesh look-up.
pub(crate) fn neighbour(mesh: &Mesh<'_>, tet: TetId, path: &Path, face: u8) -> Option<Neighbour> {
    let d = path.depth as usize;
    if d > MAX_DEPTH {
        return None;
    }
    let mut pos = [0u8; MAX_DEPTH + 1];
    let mut sig = [[0u8, 1, 2]; MAX_DEPTH + 1];
    let mut k = d;
    let mut phi = face & 3;
    let mut out = Neighbour {
        tet,
        path: *path,
        face: 0,
        pi: [0, 1, 2],
        split: 0,
        faces: [0; 11],
    };
    loop {
        if k == 0 {
            if tet.idx() >= mesh.tet_count() {
                return None;
            }
            let nb = mesh.face_match(FaceUse { tet, local: phi })?;
            let off = mesh.tet(tet).reverse[phi as usize].offset();
            out.tet = nb.tet;
            out.path = Path::ROOT;
            out.face = nb.local;
            out.pi = [(3 + off) % 3, (2 + off) % 3, (1 + off) % 3];
            break;
        }
        let c = path.digit(k);
        match CHILD_ADJ[c as usize][(phi & 3) as usize] {
            Across::Sibling(c2, f2, p) => {
                let mut q = *path;
                q.depth = (k - 1) as u8;
                q.index = path.prefix_index(k - 1);
                out.path = q.child(c2)?;
                out.face = f2;
                out.pi = p;
                break;
            }
            Across::Outside {
                face: pf,
                pos: s,
                sigma,
            } => {
                pos[k] = s;
                sig[k] = sigma;
                phi = pf;
                k -= 1;
            }
        }
    }
    out.split = k as u8;
    out.faces[k] = out.face;
    for m in k + 1..=d {
        let s = pos[m];
        let s2 = if s < 3 { out.pi[s as usize] % 3 } else { 3 };
        let (c2, g2, sig2) = FACE_SUB[(out.face & 3) as usize][s2 as usize];
        out.pi = then(then(sig[m], out.pi), invert(sig2));
        out.path = out.path.child(c2)?;
        out.face = g2;
        out.faces[m] = g2;
    }
    Some(out)
}

/// A leaf met by `visit_across`.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub(crate) struct Met {
    /// Its coarse tet.
    pub(crate) tet: TetId,
    /// Its tree index.
    pub(crate) index: u32,
    /// Its node reference.
    pub(crate) node: u32,
    /// Its face that lies on (contains, or is contained in) the shared face.
    pub(crate) face: u8,
    /// Its depth.
    pub(crate) depth: u8,
    /// Its node record at the time it was met.
    pub(crate) record: HNode,
}

/// What `visit_across` found on the other side.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub(crate) enum Side {
    /// The face is on the mesh boundary: nothing across it.
    Boundary,
    /// Every leaf across was reported.
    Done,
    /// The callback stopped the visit.
    Stopped,
}

/// Read access to the trees, for visits that may also mutate between callbacks.
pub(crate) trait TreeRead {
    fn tree_node(&self, r: u32) -> Option<HNode>;
    fn tree_child(&self, r: u32, c: u8) -> Option<u32>;
}

impl TreeRead for super::Hierarchy<'_> {
    #[inline]
    fn tree_node(&self, r: u32) -> Option<HNode> {
        self.node(r)
    }
    #[inline]
    fn tree_child(&self, r: u32, c: u8) -> Option<u32> {
        self.child(r, c)
    }
}

impl TreeRead for &super::Hierarchy<'_> {
    #[inline]
    fn tree_node(&self, r: u32) -> Option<HNode> {
        self.node(r)
    }
    #[inline]
    fn tree_child(&self, r: u32, c: u8) -> Option<u32> {
        self.child(r, c)
    }
}

/// Stack depth of the restricted subtree visit: 3 per level plus one.
const STACK: usize = 3 * MAX_DEPTH + 2;

/// Visits NTree(adj(t, face), j): calls `f` for every leaf across face `face` of node `path`
/// of tet `tet` (one coarser leaf, or every leaf of the neighbour's subtree with a face on
/// the shared face), until `f` returns `false`. `work` is increased by the nodes touched.
///
/// # Bounded work
/// O(depth) to reach the neighbour, plus the instantiated nodes of its subtree that touch the
/// shared face: at most `(4^(L+1) - 1) / 3` for `L` levels below it.
pub(crate) fn visit_across<C: TreeRead, F: FnMut(&mut C, Met) -> bool>(
    ctx: &mut C,
    mesh: &Mesh<'_>,
    tet: TetId,
    path: &Path,
    face: u8,
    work: &mut u32,
    mut f: F,
) -> Side {
    let Some(nb) = neighbour(mesh, tet, path, face) else {
        return Side::Boundary;
    };
    // Descend the neighbour's path; stop at the first leaf above its depth.
    let mut r = nb.tet.0;
    let mut index = 0u32;
    let d = nb.path.depth as usize;
    for m in 0..d {
        *work = work.saturating_add(1);
        let Some(node) = ctx.tree_node(r) else {
            return Side::Done;
        };
        if node.is_leaf() {
            let met = Met {
                tet: nb.tet,
                index,
                node: r,
                face: nb
                    .faces
                    .get(m.max(nb.split as usize))
                    .copied()
                    .unwrap_or(nb.face),
                depth: m as u8,
                record: node,
            };
            return if f(ctx, met) {
                Side::Done
            } else {
                Side::Stopped
            };
        }
        let c = nb.path.digit(m + 1);
        let Some(next) = ctx.tree_child(r, c) else {
            return Side::Done;
        };
        r = next;
        index = index * 8 + 1 + c as u32;
    }
    visit_face_subtree(ctx, nb.tet, (r, index, nb.face, d as u8), work, &mut f)
}

/// [`visit_across`] from node `path` whose reference `node` is known: when face `face` is shared
/// with a sibling (half the faces of a child), the sibling is the same block's entry and the
/// visit starts there, with no walk through the tree table and no descent from the root;
/// otherwise it is [`visit_across`]. Same leaves, same order, same callbacks.
///
/// # Bounded work
/// As [`visit_across`]; for a sibling face, only the sibling's subtree restricted to the
/// shared face.
pub(crate) fn visit_across_from<C: TreeRead, F: FnMut(&mut C, Met) -> bool>(
    ctx: &mut C,
    mesh: &Mesh<'_>,
    tet: TetId,
    (path, node): (&Path, u32),
    face: u8,
    work: &mut u32,
    mut f: F,
) -> Side {
    let d = path.depth as usize;
    if d > 0 {
        let c = path.digit(d);
        if let Across::Sibling(c2, f2, _) = CHILD_ADJ[c as usize][(face & 3) as usize] {
            // The block's entries are contiguous: child `k` is `first + k`.
            let Some(sib) = node.checked_sub(c as u32).map(|first| first + c2 as u32) else {
                return Side::Done;
            };
            let index = path.index.wrapping_sub(c as u32).wrapping_add(c2 as u32);
            return visit_face_subtree(ctx, tet, (sib, index, f2, d as u8), work, &mut f);
        }
    }
    visit_across(ctx, mesh, tet, path, face, work, f)
}

/// Calls `f` for every leaf of the subtree of `start = (node, index, face, depth)` in tree
/// `tet` that has a face on face `face` of that node (the node itself when it is a leaf),
/// until `f` returns `false`. `work` is increased by the nodes touched.
///
/// # Bounded work
/// The instantiated nodes of the subtree that touch the face: at most `(4^(L+1) - 1) / 3` for
/// `L` levels below it (the stack holds 3 per level plus one).
fn visit_face_subtree<C: TreeRead, F: FnMut(&mut C, Met) -> bool>(
    ctx: &mut C,
    tet: TetId,
    start: (u32, u32, u8, u8),
    work: &mut u32,
    f: &mut F,
) -> Side {
    // A heapless stack, left uninitialised: an initialised array of `STACK` entries was a
    // 384-byte clear on every call of an erasure's or a crumb check's visits.
    let mut stack: heapless::Vec<(u32, u32, u8, u8), STACK> = heapless::Vec::new();
    let _ = stack.push(start);
    while let Some((r, index, g, depth)) = stack.pop() {
        *work = work.saturating_add(1);
        let Some(node) = ctx.tree_node(r) else {
            continue;
        };
        if node.is_leaf() {
            let met = Met {
                tet,
                index,
                node: r,
                face: g,
                depth,
                record: node,
            };
            if !f(ctx, met) {
                return Side::Stopped;
            }
            continue;
        }
        for (c, g2, _) in FACE_SUB[(g & 3) as usize] {
            if let Some(ch) = ctx.tree_child(r, c) {
                // A full stack drops the child, as the bound above says it never is.
                let _ = stack.push((ch, index * 8 + 1 + c as u32, g2, depth + 1));
            }
        }
    }
    Side::Done
}
