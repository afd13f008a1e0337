//! The drilled surface: visible faces as outward triangles, for rendering and for forces.

use glam::Vec3;

use super::geometry::{child_packed, node_positions, Packed, RootFrame};
use super::node::HNode;
use super::store::Hierarchy;
use super::table::{Path, MAX_DEPTH};
use crate::ids::TetId;
use crate::mesh::template::FACE_VERTS;
use crate::mesh::Mesh;

/// One visible face of a non-erased leaf.
#[derive(Clone, Copy, PartialEq, Debug)]
pub struct VisibleTri {
    /// The coarse tet whose tree holds the leaf.
    pub tet: TetId,
    /// The leaf's tree index.
    pub index: u32,
    /// The leaf's face (opposite its vertex `face`).
    pub face: u8,
    /// Corners, counter-clockwise seen from outside the material (right-hand normal outward).
    pub corners: [Vec3; 3],
}

/// A leaf met by [`Hierarchy::for_each_leaf`].
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct Leaf {
    /// The coarse tet.
    pub tet: TetId,
    /// Tree index.
    pub index: u32,
    /// Node reference.
    pub node: u32,
    /// Node record.
    pub record: HNode,
}

/// DFS stack size over a tree: 7 per level plus 8.
const STACK: usize = 7 * MAX_DEPTH + 8;

/// The outward triangle of face `face` of a node with corners `p` and the given orientation.
#[inline]
pub(super) fn face_corners(p: [Vec3; 4], face: u8, inverted: bool) -> [Vec3; 3] {
    let [a, b, c] = FACE_VERTS[(face & 3) as usize].map(|k| p[k as usize]);
    // Listings are clockwise from outside a positively oriented node.
    if inverted {
        [a, b, c]
    } else {
        [a, c, b]
    }
}

/// The bounding sphere of a node with corners `p` that the walks test: the centroid and the
/// largest distance from it to a corner.
#[inline]
pub(crate) fn bounding_sphere(p: [Vec3; 4]) -> (Vec3, f32) {
    let mid = (p[0] + p[1] + p[2] + p[3]) * 0.25;
    let mut r2 = 0.0f32;
    for q in p {
        // `r2.max(d)` with the same bits (a NaN `d` is skipped either way), but a compare:
        // on a Cortex-M4 `f32::max` is a call to `fmaxf`.
        let d = q.distance_squared(mid);
        if d > r2 {
            r2 = d;
        }
    }
    (mid, libm::sqrtf(r2))
}

/// What a walk over the drilled surface ([`Hierarchy::walk_surface`]) asks of its walkers,
/// up to 32 of them at once (the bits of a mask): which go on into a node, and what a
/// visible face gives them.
pub(crate) trait SurfaceVisit {
    /// The bits of `mask` that go on into the node with corners `p` (none: the subtree is
    /// skipped).
    fn enter(&mut self, p: &[Vec3; 4], mask: u32) -> u32;
    /// A visible face of a leaf reached with the bits `mask`.
    fn face(&mut self, mask: u32, tri: VisibleTri);
    /// Whether the walk ends here: no node is entered after it says so.
    #[inline]
    fn stop(&self) -> bool {
        false
    }
}

/// One walker: the faces whose nodes' bounding spheres meet `near`, from the root down
/// (`None`: all of them), each to `f`.
struct InBall<F> {
    near: Option<(Vec3, f32)>,
    f: F,
}

impl<F: FnMut(VisibleTri)> SurfaceVisit for InBall<F> {
    #[inline]
    fn enter(&mut self, p: &[Vec3; 4], mask: u32) -> u32 {
        let Some((centre, radius)) = self.near else {
            return mask;
        };
        let (mid, rad) = bounding_sphere(*p);
        let reach = rad + radius;
        if mid.distance_squared(centre) > reach * reach {
            0
        } else {
            mask
        }
    }

    #[inline]
    fn face(&mut self, _: u32, tri: VisibleTri) {
        (self.f)(tri);
    }
}

/// The outward triangles of the faces `bits` of a node with the given corners and orientation.
fn emit<F: FnMut(VisibleTri)>(
    tet: TetId,
    index: u32,
    p: [Vec3; 4],
    bits: u8,
    inverted: bool,
    f: &mut F,
) {
    for face in 0..4u8 {
        if bits & (1 << face) == 0 {
            continue;
        }
        f(VisibleTri {
            tet,
            index,
            face,
            corners: face_corners(p, face, inverted),
        });
    }
}

impl Hierarchy<'_> {
    /// Calls `f` for every visible triangle (the v_list's visible faces).
    ///
    /// # Bounded work
    /// O(V * depth) for V v_list entries (at most `tets + 7/8 arena`).
    pub fn for_each_visible<F: FnMut(VisibleTri)>(&self, mesh: &Mesh<'_>, mut f: F) {
        for e in self.vlist() {
            let (Some(node), Some(path)) = (self.node(e.node), Path::of_index(e.index)) else {
                continue;
            };
            let p = node_positions(mesh, e.tet, &path);
            emit(e.tet, e.index, p, node.visible(), node.inverted(), &mut f);
        }
    }

    /// Calls `f` for every visible triangle of the trees of `tets` whose node lies within
    /// `near = (centre, radius)` (by the node's bounding sphere; `None`: all of them). Subtrees
    /// without a v_list leaf (their surface bit clear: erased or interior material) are
    /// skipped. [`Hierarchy::nearest_visible`] finds the closest of these triangles without
    /// yielding them all.
    ///
    /// # Bounded work
    /// O(nodes of those trees that hold surface and meet the ball); each node is constant
    /// work.
    pub fn for_each_visible_in<F: FnMut(VisibleTri)>(
        &self,
        mesh: &Mesh<'_>,
        tets: &[TetId],
        near: Option<(Vec3, f32)>,
        f: F,
    ) {
        self.walk_surface(mesh, tets, 1, &mut InBall { near, f });
    }

    /// Calls `f` for every leaf (erased or not) of the tree of `tet`.
    ///
    /// # Bounded work
    /// O(nodes of the tree).
    pub fn for_each_leaf<F: FnMut(Leaf)>(&self, tet: TetId, mut f: F) {
        if tet.idx() >= self.tet_count() {
            return;
        }
        let mut stack = [(0u32, 0u32); STACK];
        stack[0] = (tet.0, 0);
        let mut top = 1usize;
        while top > 0 {
            top -= 1;
            let Some(&(r, index)) = stack.get(top) else {
                break;
            };
            let Some(node) = self.node(r) else { continue };
            if node.is_leaf() {
                f(Leaf {
                    tet,
                    index,
                    node: r,
                    record: node,
                });
                continue;
            }
            for c in 0..8u8 {
                if let (Some(ch), Some(slot)) = (self.child(r, c), stack.get_mut(top)) {
                    *slot = (ch, index * 8 + 1 + c as u32);
                    top += 1;
                }
            }
        }
    }

    /// Walks the trees of `tets` for `v`, each once, depth first: a node is entered with the
    /// bits of its parent's mask that [`SurfaceVisit::enter`] keeps (`want` at a root), a
    /// subtree without surface (see [`HNode::surface`]) or with no bit left is skipped, and
    /// each visible face of a non-erased leaf is given to [`SurfaceVisit::face`] with its
    /// leaf's bits; once [`SurfaceVisit::stop`] says so, the walk ends. The packed barycentric coordinates ([`Packed`]) are carried down the
    /// stack, so each node costs O(1) (not O(depth)) and gets the same bits as
    /// [`node_positions`].
    ///
    /// # Bounded work
    /// O(nodes of those trees that hold surface and are entered) times what `v` does a node.
    pub(crate) fn walk_surface<V: SurfaceVisit>(
        &self,
        mesh: &Mesh<'_>,
        tets: &[TetId],
        want: u32,
        v: &mut V,
    ) {
        for &tet in tets {
            if v.stop() {
                return;
            }
            self.walk_tree(mesh, tet, want, v);
        }
    }

    /// [`Hierarchy::walk_surface`] over one tree.
    fn walk_tree<V: SurfaceVisit>(&self, mesh: &Mesh<'_>, tet: TetId, want: u32, v: &mut V) {
        // A tree without surface (interior material, or erased whole) costs no frame.
        if tet.idx() >= self.tet_count() || !self.node(tet.0).is_some_and(|n| n.surface()) {
            return;
        }
        let Some(frame) = RootFrame::of(mesh, tet) else {
            return;
        };
        let mut stack = [(0u32, 0u32, 0u8, [0 as Packed; 4], 0u32); STACK];
        stack[0] = (tet.0, 0, 0, frame.root_packed(), want);
        let mut top = 1usize;
        while top > 0 && !v.stop() {
            top -= 1;
            let Some(&(r, index, depth, bary, mask)) = stack.get(top) else {
                break;
            };
            let Some(node) = self.node(r) else { continue };
            if !node.surface() {
                continue;
            }
            let p = frame.positions_packed(&bary, depth);
            let mask = v.enter(&p, mask);
            if mask == 0 {
                continue;
            }
            if node.is_leaf() {
                if !node.erased() {
                    let inverted = node.inverted();
                    emit(tet, index, p, node.visible(), inverted, &mut |t| {
                        v.face(mask, t)
                    });
                }
                continue;
            }
            if depth as usize >= MAX_DEPTH {
                continue;
            }
            let Some(b) = node.block() else { continue };
            let first = self.block_ref(b);
            for c in 0..8u8 {
                // A child without surface would be dropped when taken: not pushed.
                let ch = first + u32::from(c);
                if !self.node(ch).is_some_and(|n| n.surface()) {
                    continue;
                }
                if let Some(slot) = stack.get_mut(top) {
                    *slot = (
                        ch,
                        index * 8 + 1 + c as u32,
                        depth + 1,
                        child_packed(&bary, c),
                        mask,
                    );
                    top += 1;
                }
            }
        }
    }
}
