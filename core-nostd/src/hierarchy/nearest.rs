//! The closest visible triangle to a point: a branch-and-bound walk over the drilled surface.
//!
//! The contact of a spherical burr needs one triangle per simulation step: the visible face
//! closest to the burr's centre within a reach. [`Hierarchy::for_each_visible_in`] would yield
//! every visible face near the tool (thousands on a finely drilled groove) and visit every
//! node whose bounding sphere meets the reach ball (tens of thousands with erased and interior
//! material). [`Hierarchy::nearest_visible`] finds the same triangle while visiting few nodes:
//!
//! - subtrees whose *surface* bit is clear (no v_list leaf below: erased or interior
//!   material) are skipped;
//! - children are walked nearest first (by the distance of their bounding spheres' centres),
//!   and a subtree whose bounding sphere lies farther than the best distance found so far (by
//!   more than a rounding slack) is pruned;
//! - hints (the closest faces the last step met, which move little between steps: [`Kept`])
//!   give a tight bound from the start, so far trees are pruned at their root.
//!
//! Every node that is kept passes exactly the bounding-sphere test of
//! [`Hierarchy::for_each_visible_in`] (same positions, same arithmetic), and the triangles are
//! compared with the same arithmetic and the same tie-break, so the answer is the one the
//! exhaustive search gives, bit for bit, whenever the search completes.
//!
//! A search bounded by a node count answers with the closest triangle it met or hinted
//! and says where it would go on ([`Nearest::resume`]: [`Hierarchy::nearest_uncut_from`]
//! starts the next one in the next tree). [`Hierarchy::nearest_continued`] keeps more: the
//! nodes still waiting in the tree where it stopped ([`NearestCursor`]), so successive bounded
//! searches at a slowly moving tool walk every tree near it to the end, in rounds, without
//! paying the descent from a root again. [`SphereMemo`] remembers the nodes' bounding spheres
//! across searches (same results, less work). On a Cortex-M4 a node test costs 500 to 800
//! instructions in a drilled cavity (docs/PORTING.md): node look-ups, bounding spheres (from
//! the memo, mostly), refinement points for the leaves whose faces are tested, and the
//! triangle tests.

use glam::Vec3;

use super::geometry::{
    child_of_ten, child_packed, node_positions, refinement_points_masked, Packed, RootFrame,
    CHILD_POINTS,
};
use super::memo::SphereMemo;
use super::node::HNode;
use super::store::Hierarchy;
use super::surface::{bounding_sphere, face_corners, VisibleTri};
use super::table::{Path, MAX_DEPTH};
use crate::force::closest_point_on_triangle;
use crate::ids::TetId;
use crate::mesh::Mesh;

/// A visible face named by its leaf and face: `(tet, tree index, face)`, the order of ties.
#[derive(Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Debug, Hash)]
pub struct FaceRef {
    /// The coarse tet.
    pub tet: TetId,
    /// The leaf's tree index.
    pub index: u32,
    /// The face (opposite vertex `face`).
    pub face: u8,
}

impl VisibleTri {
    /// The face's name.
    pub fn key(&self) -> FaceRef {
        FaceRef {
            tet: self.tet,
            index: self.index,
            face: self.face,
        }
    }
}

/// What [`Hierarchy::nearest_visible`] found.
#[derive(Clone, Copy, PartialEq, Debug)]
pub struct Nearest {
    /// The closest visible triangle within reach (ties: smallest [`FaceRef`]), or `None`.
    pub tri: Option<VisibleTri>,
    /// Its squared distance from the centre (`f32::INFINITY` when there is none).
    pub d2: f32,
    /// Nodes whose bounding sphere was tested (the unit of work).
    pub nodes: u32,
    /// Visible triangles tested.
    pub triangles: u32,
    /// Where a walk stopped by `max_nodes` would go on: the index in `tets` of the tree after
    /// the one it was in (0 when `complete`; it may equal `tets.len()`, which
    /// [`Hierarchy::nearest_uncut_from`] reads as 0). A later search over a similar list that
    /// starts there looks at other trees than this one did.
    pub resume: u32,
    /// `false` when `max_nodes` stopped the walk: `tri` is then the closest of the hints in
    /// play and the triangles of the part walked: a visible triangle no closer than the closest one
    /// (an anytime answer: the depth it gives is never too deep).
    pub complete: bool,
}

impl Default for Nearest {
    fn default() -> Self {
        Self {
            tri: None,
            d2: f32::INFINITY,
            nodes: 0,
            triangles: 0,
            resume: 0,
            complete: true,
        }
    }
}

/// One contact search's question, for [`Hierarchy::nearest`] (the arguments of
/// [`Hierarchy::nearest_uncut_from`]).
#[derive(Clone, Copy, Debug)]
pub struct NearestQuery<'q> {
    /// The coarse tets whose trees are searched.
    pub tets: &'q [TetId],
    /// The index in `tets` of the first tree walked (the others follow in turn; past the end
    /// reads as 0).
    pub start: usize,
    /// The point whose closest visible triangle is sought.
    pub centre: Vec3,
    /// Triangles farther than this are not considered.
    pub reach: f32,
    /// The radius of a burr that is cutting (see [`Hierarchy::nearest_uncut`]), or `None`.
    pub cut: Option<f32>,
    /// Faces likely to be close (the last search's [`Kept`] faces): the closest of them still
    /// in play prunes from the start, and all of them compete for the answer of a search the
    /// node bound stops. Their corners must be the ones the hierarchy gives (a hint is only
    /// checked to be still visible, then measured from its corners).
    pub hints: &'q [VisibleTri],
    /// The most bounding-sphere tests the search makes.
    pub max_nodes: u32,
}

/// What one walk over the trees needs of the query, prepared once.
#[derive(Clone, Copy)]
struct Walk<'q> {
    tets: &'q [TetId],
    start: usize,
    /// How many trees, from `start` on (cyclically).
    count: usize,
    centre: Vec3,
    reach: f32,
    /// Squared cutting radius, negative when not cutting.
    cut2: f32,
}

/// DFS stack size over one tree: 7 per level plus 8.
const STACK: usize = 7 * MAX_DEPTH + 8;

/// One node waiting on the stack.
#[derive(Clone, Copy, Debug)]
struct Entry {
    r: u32,
    index: u32,
    depth: u8,
    /// The node's corners as packed integer barycentric coordinates.
    bary: [Packed; 4],
    /// Bounding sphere centre (a search that goes on from a [`NearestCursor`] measures it
    /// again from its own centre).
    mid: Vec3,
    /// Squared distance from the centre to the bounding sphere's centre.
    d2: f32,
    /// Bounding sphere radius.
    rad: f32,
}

/// Where a bounded search stopped, kept for the next one to go on from
/// ([`Hierarchy::nearest_continued`]): the tree it was in and the nodes of that tree still
/// waiting (none: that tree from its root). 5,024 bytes on x86-64.
#[derive(Clone, Debug, Default)]
pub struct NearestCursor {
    tet: Option<TetId>,
    /// The tree the round began with: the round ends before it comes round to it again.
    first: Option<TetId>,
    /// [`Hierarchy::reclaimed`] when it was saved: the node references on the stack are
    /// valid while it is unchanged.
    reclaimed: u32,
    /// Rounds ended so far.
    rounds: u32,
    stack: heapless::Vec<Entry, STACK>,
}

impl NearestCursor {
    /// A cursor that goes on from nowhere (the next search starts afresh).
    pub const fn new() -> Self {
        Self {
            tet: None,
            first: None,
            reclaimed: 0,
            rounds: 0,
            stack: heapless::Vec::new(),
        }
    }

    /// Rounds over the trees that ended so far (saturating): each one walked every tree of
    /// the list to the end.
    pub fn rounds(&self) -> u32 {
        self.rounds
    }

    /// The tree the next search goes on with, if any.
    pub fn tet(&self) -> Option<TetId> {
        self.tet
    }

    /// Forgets the place (the next search starts afresh).
    pub fn clear(&mut self) {
        self.tet = None;
        self.first = None;
        self.stack.clear();
    }
}

/// The state of one search.
struct Search {
    centre: Vec3,
    reach: f32,
    reach2: f32,
    /// Squared radius of the cutting sphere (negative when none): a triangle with all three
    /// corners within it is material being cut, not surface to push against.
    cut2: f32,
    /// Its radius (`sqrtf(cut2)`, once per search; meaningless when `cut2` is negative).
    cut_r: f32,
    /// Rounding slack added to the pruning distance.
    slack: f32,
    /// Pruning distance: the best distance so far (or the hint's, or the reach).
    bound: f32,
    best: Option<(f32, FaceRef, VisibleTri)>,
    nodes: u32,
    triangles: u32,
    max_nodes: u32,
    stopped: bool,
    /// The index in the walk's list of the tree being walked when it stopped.
    stopped_in: usize,
    /// The closest faces met (ascending by distance, then face).
    kept: Kept,
}

/// How many of the closest faces a search keeps for the next one ([`Kept`]).
///
/// Why more than the answer: a search stopped by its node bound answers with the closest face
/// it met or was hinted, and the next step's closest face is most often one that was nearly
/// as close a step before (a neighbour of the answer on the same wall, or the near wall of a
/// cavity the burr is crossing). On the demo replay with the contact bound at 1,024 nodes,
/// hinting the 4 closest faces met instead of the answer alone cut the contact depth's
/// shortfall against the exhaustive search from 2.5e-4 to 5.4e-5 mesh units on average and
/// the ticks short by more than 1e-3 from 115 to 32 (2, 8, 16, 64 faces: 85, 28, 36, 35
/// ticks; docs/DRILLING.md). Each hint costs a node look-up per level and a triangle test
/// a search (4 of them: 0.2 % of the firmware's worst tick).
pub const KEEP: usize = 4;

/// The closest faces a search met or was hinted, with their squared distances from its
/// centre, nearest first (ties: the smaller face), each face once.
pub type Kept = heapless::Vec<(f32, VisibleTri), KEEP>;

/// Puts face `tri` at squared distance `d2` into `kept` when it is among the [`KEEP`] nearest
/// by `(d2, face)`; a face already there stays as it is.
///
/// # Bounded work
/// O([`KEEP`]).
pub fn keep_face(kept: &mut Kept, d2: f32, tri: VisibleTri) {
    let key = tri.key();
    let before = |&(d, t): &(f32, VisibleTri)| d2 < d || (d2 == d && key < t.key());
    if kept.is_full() && kept.last().is_some_and(|e| !before(e)) {
        return;
    }
    if kept.iter().any(|(_, t)| t.key() == key) {
        return;
    }
    let at = kept.iter().position(before).unwrap_or(kept.len());
    if at >= KEEP {
        return;
    }
    if kept.is_full() {
        kept.pop();
    }
    let _ = kept.insert(at, (d2, tri));
}

/// [`keep_face`] for every face of `from`.
fn keep_all(kept: &mut Kept, from: &Kept) {
    for &(d2, t) in from {
        keep_face(kept, d2, t);
    }
}

impl Search {
    /// `true` when a bounding sphere `(d2 = |mid - centre|^2, rad)` may hold a point at most
    /// `bound` (plus slack) from the centre.
    #[inline]
    fn may_hold_better(&self, d2: f32, rad: f32) -> bool {
        let lim = rad + self.bound + self.slack;
        d2 <= lim * lim
    }

    /// `true` when a bounding sphere lies inside the cutting sphere with room to spare: every
    /// triangle below has all three corners inside it, so the cutting rule skips them all.
    #[inline]
    fn all_cut(&self, d2: f32, rad: f32) -> bool {
        if self.cut2 < 0.0 {
            return false;
        }
        let lim = self.cut_r - rad - self.slack;
        lim > 0.0 && d2 < lim * lim
    }

    /// Tests the visible faces of leaf `(t, index)` with corners `p`. A face that would become
    /// the best is taken only when the leaf passes the reach test of the exhaustive walk
    /// (checked once, lazily: it almost always passes, and most faces never need it).
    fn offer_leaf(&mut self, t: TetId, index: u32, node: HNode, p: [Vec3; 4], sphere: (Vec3, f32)) {
        let mut in_reach: Option<bool> = None;
        for face in 0..4u8 {
            if node.visible() & (1 << face) == 0 {
                continue;
            }
            self.triangles = self.triangles.wrapping_add(1);
            let corners = face_corners(p, face, node.inverted());
            let x = closest_point_on_triangle(self.centre, corners);
            if cut_skips(&corners, self.centre, x, self.cut2) {
                continue;
            }
            let d2 = (self.centre - x).length_squared();
            if d2.is_nan() || d2 > self.reach2 {
                continue;
            }
            let key = FaceRef {
                tet: t,
                index,
                face,
            };
            keep_face(
                &mut self.kept,
                d2,
                VisibleTri {
                    tet: t,
                    index,
                    face,
                    corners,
                },
            );
            if !beats((d2, key), self.best.as_ref().map(|b| (b.0, b.1))) {
                continue;
            }
            let ok = *in_reach.get_or_insert_with(|| {
                let (mid, rad) = sphere;
                let lim = rad + self.reach;
                mid.distance_squared(self.centre) <= lim * lim
            });
            if !ok {
                return;
            }
            let vt = VisibleTri {
                tet: t,
                index,
                face,
                corners,
            };
            self.best = Some((d2, key, vt));
            let d = libm::sqrtf(d2);
            if d < self.bound {
                self.bound = d;
            }
        }
    }
}

impl Hierarchy<'_> {
    /// The squared distance from `centre` to visible face `key`, and the face, when that face
    /// is still visible on a non-erased leaf.
    ///
    /// # Bounded work
    /// O(depth).
    pub fn visible_face_distance2(
        &self,
        mesh: &Mesh<'_>,
        key: FaceRef,
        centre: Vec3,
    ) -> Option<(f32, VisibleTri)> {
        let node = self.visible_leaf(key)?;
        let path = Path::of_index(key.index)?;
        let p = node_positions(mesh, key.tet, &path);
        let corners = face_corners(p, key.face, node.inverted());
        let x = closest_point_on_triangle(centre, corners);
        let vt = VisibleTri {
            tet: key.tet,
            index: key.index,
            face: key.face,
            corners,
        };
        Some(((centre - x).length_squared(), vt))
    }

    /// `true` when face `key` is still visible: its node is a non-erased leaf with that face
    /// visible.
    ///
    /// # Bounded work
    /// O(depth) node look-ups.
    pub fn face_visible(&self, key: FaceRef) -> bool {
        self.visible_leaf(key).is_some()
    }

    /// The leaf of face `key` when it is not erased and has that face visible.
    fn visible_leaf(&self, key: FaceRef) -> Option<HNode> {
        let node = self.node(self.find(key.tet, key.index)?)?;
        (node.is_leaf() && !node.erased() && node.visible() & (1 << (key.face & 3)) != 0)
            .then_some(node)
    }

    /// Hint `tri` measured from `centre` when a search with squared reach `reach2` and squared
    /// cutting radius `cut2` (negative: not cutting) would consider it: still a visible face,
    /// within reach, not skipped by the cutting rule. Its squared distance.
    ///
    /// # Bounded work
    /// O(depth) node look-ups and one triangle test (the corners come with the hint).
    fn hint_in_play(&self, tri: &VisibleTri, centre: Vec3, reach2: f32, cut2: f32) -> Option<f32> {
        if !self.face_visible(tri.key()) {
            return None;
        }
        let x = closest_point_on_triangle(centre, tri.corners);
        let d2 = (centre - x).length_squared();
        (d2 <= reach2 && !cut_skips(&tri.corners, centre, x, cut2)).then_some(d2)
    }

    /// The visible triangle of the trees of `tets` closest to `centre` within `reach`: the
    /// triangle whose closest point is nearest (squared distance at most `reach^2`), ties to
    /// the smallest `(tet, index, face)`, among the triangles that
    /// [`Hierarchy::for_each_visible_in`]`(mesh, tets, Some((centre, reach)), ..)` yields. The
    /// same triangle, bit for bit, when `complete`.
    ///
    /// `hint`: a face likely to be close (the last step's answer); it only tightens the
    /// pruning bound from the start (a [`NearestQuery`] takes several). When it turns out
    /// not to be a triangle the walk can reach (rounding at the edge of the reach ball), the
    /// walk is done again without it.
    ///
    /// # Bounded work
    /// At most `max_nodes` bounding-sphere tests (each constant: the node's corners come from
    /// integer barycentric coordinates carried down the stack), 4 triangle tests per leaf
    /// reached, plus O(depth) per hint and O(`tets`) root look-ups; twice that when the
    /// walk is redone without the hint. Without the bound: the nodes holding surface within
    /// `reach` that are not pruned, typically a few hundred on a drilled groove at depth 5.
    ///
    /// # Capacity
    /// When `max_nodes` tests are spent the walk stops with `complete == false` and the best
    /// triangle of the part walked.
    pub fn nearest_visible(
        &self,
        mesh: &Mesh<'_>,
        tets: &[TetId],
        centre: Vec3,
        reach: f32,
        hint: Option<FaceRef>,
        max_nodes: u32,
    ) -> Nearest {
        self.nearest_uncut(mesh, tets, centre, reach, None, hint, max_nodes)
    }

    /// [`Hierarchy::nearest_visible`] for a burr that is cutting (`cut` = its radius): a
    /// triangle is skipped when all three corners lie within `cut` of `centre` (it bounds
    /// material the drill is removing under the burr) or when `centre` lies behind it (on
    /// the material side of its plane at its closest point: the far side of a sliver of
    /// not-yet-eroded material, which would push the burr through the sliver, the wrong way;
    /// the sliver's near side still pushes it back). `None` is
    /// [`Hierarchy::nearest_visible`]. Same answer as the exhaustive search with the same
    /// rule, bit for bit, when `complete`.
    ///
    /// # Bounded work
    /// As [`Hierarchy::nearest_visible`], plus 3 distances per triangle tested.
    #[allow(clippy::too_many_arguments)]
    pub fn nearest_uncut(
        &self,
        mesh: &Mesh<'_>,
        tets: &[TetId],
        centre: Vec3,
        reach: f32,
        cut: Option<f32>,
        hint: Option<FaceRef>,
        max_nodes: u32,
    ) -> Nearest {
        self.nearest_uncut_from(mesh, tets, 0, centre, reach, cut, hint, max_nodes)
    }

    /// [`Hierarchy::nearest_uncut`] walking the trees of `tets` from index `start` on (then
    /// from the first up to `start`; a `start` past the end is 0): the same answer when
    /// `complete` (ties never depend on the order); when the node bound stops it, another part
    /// was walked. A caller that starts each search after the tree where the last one stopped
    /// ([`Nearest::resume`]) and hints it with the last answer walks, over a few steps, every
    /// tree near a tool that moves little, instead of the first trees of the list every step,
    /// and the hint carries the closest triangle found on to the next step. On the firmware
    /// scenario (contact bound 128 nodes, 3,739 of 4,236 contact searches stopped) the depth
    /// shortfall against the exhaustive search fell from 0.0064 to 0.0005 mesh units on
    /// average and from 0.049 to 0.0095 at p99 (docs/PORTING.md).
    ///
    /// # Bounded work
    /// As [`Hierarchy::nearest_uncut`].
    #[allow(clippy::too_many_arguments)]
    pub fn nearest_uncut_from(
        &self,
        mesh: &Mesh<'_>,
        tets: &[TetId],
        start: usize,
        centre: Vec3,
        reach: f32,
        cut: Option<f32>,
        hint: Option<FaceRef>,
        max_nodes: u32,
    ) -> Nearest {
        let hint_tri = hint
            .and_then(|k| self.visible_face_distance2(mesh, k, centre))
            .map(|(_, vt)| vt);
        let q = NearestQuery {
            tets,
            start,
            centre,
            reach,
            cut,
            hints: hint_tri.as_slice(),
            max_nodes,
        };
        self.nearest(mesh, &q, &mut SphereMemo::new(&mut []))
    }

    /// [`Hierarchy::nearest_uncut_from`] of the query `q`, taking the nodes' bounding spheres
    /// from `memo` when it holds them and leaving there those it evaluates. The answer, the
    /// node and triangle counts and the resume place are those of the search without a memo,
    /// bit for bit (a sphere is a function of its node's tet and tree index; see
    /// [`SphereMemo`]); only the work per node shrinks: a node whose sphere is remembered
    /// costs no corner evaluation unless it is a leaf whose faces are tested.
    ///
    /// # Bounded work
    /// As [`Hierarchy::nearest_uncut`], plus one memo look-up per node tested and one store
    /// per sphere evaluated.
    pub fn nearest(
        &self,
        mesh: &Mesh<'_>,
        q: &NearestQuery<'_>,
        memo: &mut SphereMemo<'_>,
    ) -> Nearest {
        self.nearest_inner(mesh, q, memo, None, None)
    }

    /// [`Hierarchy::nearest`] that goes on where the last bounded search stopped: when
    /// `cursor` holds a place in a tree of `q.tets` (and no block was taken back since,
    /// [`Hierarchy::reclaimed`]), the walk starts in that tree with the nodes that were still
    /// waiting there, measured again from this centre, then takes the other trees in turn;
    /// otherwise it starts afresh at `q.start`. A search stopped by `max_nodes` leaves its
    /// place in `cursor`; one that ends its rounds clears it. So successive bounded searches
    /// at a slowly moving tool walk every tree near it to the end, one after another, paying
    /// the descent from a root once, where [`Hierarchy::nearest_uncut_from`] restarts at a root every
    /// time and never finishes a tree its bound cuts short.
    ///
    /// A round over the trees begins at `q.start` and ends when the walk comes round to the
    /// tree it began with (or, when that tree left the list, at the list's end). A search
    /// whose round ends within the bound begins a fresh one with the nodes left; `complete`
    /// is `true` when that fresh round ends too: its answer is then the exhaustive one, bit
    /// for bit (the triangles met in the old round are true faces measured from this
    /// centre, never closer than the closest). Otherwise the answer is the closest triangle
    /// met or the closest hint in play, like any stopped search. An expansion is never
    /// split: a node's children are tested only when all of them fit in what is left of
    /// `max_nodes`.
    ///
    /// # Bounded work
    /// As [`Hierarchy::nearest`], plus O(stack) to measure the waiting nodes again (at most
    /// 7 per level plus 8) and O(`tets`) to find the cursor's tree.
    pub fn nearest_continued(
        &self,
        mesh: &Mesh<'_>,
        q: &NearestQuery<'_>,
        memo: &mut SphereMemo<'_>,
        cursor: &mut NearestCursor,
    ) -> Nearest {
        self.nearest_inner(mesh, q, memo, Some(cursor), None)
    }

    /// [`Hierarchy::nearest_continued`] that also leaves in `kept` the closest faces the
    /// walks met and the hints in play ([`Kept`]: visible faces within reach that the cutting
    /// rule keeps, measured from `q.centre`, nearest first), the answer among them: the
    /// hints for the next search. Same answer as [`Hierarchy::nearest_continued`].
    ///
    /// # Bounded work
    /// As [`Hierarchy::nearest_continued`], plus O([`KEEP`]) per triangle tested and per hint.
    pub fn nearest_continued_keeping(
        &self,
        mesh: &Mesh<'_>,
        q: &NearestQuery<'_>,
        memo: &mut SphereMemo<'_>,
        cursor: &mut NearestCursor,
        kept: &mut Kept,
    ) -> Nearest {
        self.nearest_inner(mesh, q, memo, Some(cursor), Some(kept))
    }

    fn nearest_inner(
        &self,
        mesh: &Mesh<'_>,
        q: &NearestQuery<'_>,
        memo: &mut SphereMemo<'_>,
        mut cursor: Option<&mut NearestCursor>,
        kept_out: Option<&mut Kept>,
    ) -> Nearest {
        let NearestQuery {
            tets,
            start,
            centre,
            reach,
            cut,
            hints,
            max_nodes,
        } = *q;
        let n = tets.len();
        let start = if start < n { start } else { 0 };
        if !(centre.is_finite() && reach.is_finite() && reach >= 0.0) {
            if let Some(c) = cursor {
                c.clear();
            }
            return Nearest::default();
        }
        // Go on from the cursor's place when it is still good: from its tree up to the tree
        // its round started with (or the end of the list when that one is gone).
        let mut local: heapless::Vec<Entry, STACK> = heapless::Vec::new();
        let mut going_on: Option<(usize, usize)> = None;
        if let Some(c) = cursor.as_deref_mut() {
            let at = c
                .tet
                .filter(|_| c.reclaimed == self.reclaimed())
                .and_then(|t| tets.iter().position(|&x| x == t));
            match at {
                Some(i) => {
                    let count = match c.first.and_then(|f| tets.iter().position(|&x| x == f)) {
                        Some(f) if f != i => (f + n - i) % n,
                        Some(_) => n,
                        None => n - i,
                    };
                    going_on = Some((i, count));
                }
                None => c.clear(),
            }
        }
        let reach2 = reach * reach;
        let cut2 = cut
            .filter(|r| r.is_finite() && *r >= 0.0)
            .map_or(-1.0, |r| r * r);
        // The hints still in play, measured from this centre; the closest prunes.
        let mut measured = Kept::new();
        let mut hint_tri: Option<(f32, VisibleTri)> = None;
        for vt in hints {
            if let Some(d2) = self.hint_in_play(vt, centre, reach2, cut2) {
                keep_face(&mut measured, d2, *vt);
                if beats((d2, vt.key()), hint_tri.map(|(h, t)| (h, t.key()))) {
                    hint_tri = Some((d2, *vt));
                }
            }
        }
        let hinted = hint_tri.map(|(d2, _)| d2);
        let fresh = Walk {
            tets,
            start,
            count: n,
            centre,
            reach,
            cut2,
        };
        let stack = match cursor.as_deref_mut() {
            Some(c) => &mut c.stack,
            None => &mut local,
        };
        let mut ended = 0u32;
        let mut s = match going_on {
            Some((i, count)) => {
                let on = Walk {
                    start: i,
                    count,
                    ..fresh
                };
                let s = self.nearest_walk(mesh, &on, hinted, max_nodes, memo, stack, true);
                if s.stopped {
                    s
                } else {
                    // The round ended within the bound: a fresh one with what is left (exact
                    // when it ends too); the triangles met so far stay in the running.
                    let left = max_nodes.saturating_sub(s.nodes);
                    let mut again =
                        self.nearest_walk(mesh, &fresh, hinted, left, memo, stack, false);
                    again.nodes += s.nodes;
                    again.triangles += s.triangles;
                    again.best = closer(again.best, s.best);
                    keep_all(&mut again.kept, &s.kept);
                    going_on = None;
                    ended += 1;
                    again
                }
            }
            None => self.nearest_walk(mesh, &fresh, hinted, max_nodes, memo, stack, false),
        };
        if let Some(h) = hinted {
            // Pruning at the hint's distance is exact iff the walk met a triangle at most as
            // far (then the true closest one is no farther than that triangle).
            let ok = s.best.is_some_and(|(d2, _, _)| d2 <= h);
            if !ok && !s.stopped && going_on.is_none() {
                let left = max_nodes.saturating_sub(s.nodes);
                let again = self.nearest_walk(mesh, &fresh, None, left, memo, stack, false);
                let (nodes, triangles) = (s.nodes + again.nodes, s.triangles + again.triangles);
                let mut again = again;
                keep_all(&mut again.kept, &s.kept);
                s = again;
                s.nodes = nodes;
                s.triangles = triangles;
            }
        }
        if let Some(c) = cursor {
            c.rounds = c.rounds.saturating_add(ended + u32::from(!s.stopped));
            if s.stopped {
                if going_on.is_none() {
                    c.first = tets.get(start).copied();
                }
                c.tet = tets.get(s.stopped_in).copied();
                c.reclaimed = self.reclaimed();
            } else {
                c.clear();
            }
        }
        if s.stopped {
            // Anytime answer: the closer of the closest hint and the closest triangle met (ties:
            // the smaller face), so the answer is the first kept face.
            if let Some((h, vt)) = hint_tri {
                if beats((h, vt.key()), s.best.map(|(d2, k, _)| (d2, k))) {
                    s.best = Some((h, vt.key(), vt));
                }
            }
        }
        if let Some(out) = kept_out {
            *out = s.kept.clone();
            keep_all(out, &measured);
        }
        Nearest {
            tri: s.best.map(|(_, _, vt)| vt),
            d2: s.best.map_or(f32::INFINITY, |(d2, _, _)| d2),
            nodes: s.nodes,
            triangles: s.triangles,
            resume: if s.stopped {
                (s.stopped_in + 1) as u32
            } else {
                0
            },
            complete: !s.stopped,
        }
    }

    /// The bounding sphere of node `index` of `t` (corners `p()` when it must be evaluated),
    /// from the memo or evaluated and left there.
    #[inline]
    fn sphere_of(
        memo: &mut SphereMemo<'_>,
        t: TetId,
        index: u32,
        p: impl FnOnce() -> [Vec3; 4],
    ) -> (Vec3, f32) {
        match memo.get(t, index) {
            Some(sp) => sp,
            None => {
                let sp = bounding_sphere(p());
                memo.put(t, index, sp);
                sp
            }
        }
    }

    /// The walk over the trees of `w` from `w.start`, depth first in each, on `stack`: when
    /// `goes_on`, the first tree goes on with the nodes waiting on `stack` (none: from its
    /// root). A walk stopped by `max_nodes` leaves the waiting nodes of the tree it stopped in
    /// (`stopped_in`) on `stack`.
    #[allow(clippy::too_many_arguments)]
    fn nearest_walk(
        &self,
        mesh: &Mesh<'_>,
        w: &Walk<'_>,
        hint_d2: Option<f32>,
        max_nodes: u32,
        memo: &mut SphereMemo<'_>,
        stack: &mut heapless::Vec<Entry, STACK>,
        goes_on: bool,
    ) -> Search {
        let (tets, start, centre, reach) = (w.tets, w.start, w.centre, w.reach);
        let scale = centre.abs().max_element() + reach;
        let mut s = Search {
            centre,
            reach,
            reach2: reach * reach,
            cut2: w.cut2,
            cut_r: if w.cut2 < 0.0 {
                0.0
            } else {
                libm::sqrtf(w.cut2)
            },
            slack: scale * 1.0e-5 + 1.0e-30,
            bound: hint_d2.map_or(reach, libm::sqrtf).min(reach),
            best: None,
            nodes: 0,
            triangles: 0,
            max_nodes,
            stopped: false,
            stopped_in: 0,
            kept: Kept::new(),
        };
        // The ten points of the refinement being expanded (only those some child needs) and
        // the spheres of its children (from the memo or evaluated).
        let mut ten_rows = [0; 10];
        let mut ten = [Vec3::ZERO; 10];
        let mut spheres = [(Vec3::ZERO, 0.0f32); 8];
        let n = tets.len();
        for (k, &t) in tets
            .iter()
            .cycle()
            .skip(start)
            .take(w.count.min(n))
            .enumerate()
        {
            if s.stopped {
                break;
            }
            s.stopped_in = (start + k) % n.max(1);
            // A tree with no surface (interior or erased material) costs one node look-up.
            if t.idx() >= self.tet_count() || !self.node(t.0).is_some_and(|n| n.surface()) {
                continue;
            }
            let Some(frame) = RootFrame::of(mesh, t) else {
                continue;
            };
            if k == 0 && goes_on && !stack.is_empty() {
                // The nodes still waiting in this tree, measured from this centre.
                for e in stack.iter_mut() {
                    e.d2 = e.mid.distance_squared(centre);
                }
            } else {
                stack.clear();
                let rows = frame.root_packed();
                let sp = Self::sphere_of(memo, t, 0, || frame.positions_packed(&rows, 0));
                let Some((d2, rad)) = Self::test_node(&mut s, sp) else {
                    continue;
                };
                let _ = stack.push(Entry {
                    r: t.0,
                    index: 0,
                    depth: 0,
                    bary: rows,
                    mid: sp.0,
                    d2,
                    rad,
                });
            }
            while !s.stopped {
                let Some(e) = stack.pop() else {
                    break;
                };
                if !s.may_hold_better(e.d2, e.rad) {
                    continue;
                }
                // (A node waiting since an earlier search may have lost its surface since.)
                let Some(node) = self.node(e.r).filter(|n| n.surface()) else {
                    continue;
                };
                let Some(b) = node.block() else {
                    // A root that is a leaf (its reach test is done).
                    let p = frame.positions_packed(&e.bary, e.depth);
                    let sp = Self::sphere_of(memo, t, e.index, || p);
                    s.offer_leaf(t, e.index, node, p, sp);
                    continue;
                };
                if e.depth as usize >= MAX_DEPTH {
                    continue;
                }
                // The children kept go straight onto the stack, then that segment is sorted
                // farthest first so the nearest is walked first.
                let first = self.block_ref(b);
                let Some(block) = self.block_nodes(b) else {
                    continue;
                };
                let mut order = [(0.0f32, 0u8); 8];
                let mut kept = 0usize;
                // The children holding surface, their spheres from the memo, and of the ten
                // points of this refinement only the corners of the children whose sphere
                // is not remembered (a third of the children hold surface on a drilled
                // groove); a leaf whose faces are tested gets its corners later.
                let mut kids = 0u8;
                for (c, k) in block.iter().enumerate() {
                    if k.surface() {
                        kids |= 1 << c;
                    }
                }
                // An expansion is never split: when its children do not all fit in the
                // bound, the node waits (on the stack, for a search that goes on).
                if s.nodes.saturating_add(kids.count_ones()) > s.max_nodes {
                    let _ = stack.push(e);
                    s.stopped = true;
                    break;
                }
                let mut remembered = 0u8;
                let mut need = 0u16;
                for c in 0..8u8 {
                    if kids & (1 << c) != 0 {
                        let index = e.index * 8 + 1 + c as u32;
                        match memo.get(t, index) {
                            Some(sp) => {
                                remembered |= 1 << c;
                                if let Some(slot) = spheres.get_mut(c as usize) {
                                    *slot = sp;
                                }
                            }
                            None => need |= CHILD_POINTS[c as usize],
                        }
                    }
                }
                if need != 0 {
                    refinement_points_masked(
                        &frame,
                        &e.bary,
                        e.depth,
                        need,
                        &mut ten_rows,
                        &mut ten,
                    );
                }
                let mut have = need;
                for c in 0..8u8 {
                    if kids & (1 << c) == 0 {
                        continue;
                    }
                    let Some(&child) = block.get(c as usize) else {
                        continue;
                    };
                    let index = e.index * 8 + 1 + c as u32;
                    let sp = match spheres.get(c as usize) {
                        Some(&sp) if remembered & (1 << c) != 0 => sp,
                        _ => {
                            let sp = bounding_sphere(child_of_ten(&ten, c));
                            memo.put(t, index, sp);
                            sp
                        }
                    };
                    if child.is_leaf() {
                        // Leaves are tested at once (no stack round trip), after the same
                        // bound test as an inner node: a leaf that cannot hold a better
                        // triangle costs no triangle tests.
                        if s.nodes >= s.max_nodes {
                            s.stopped = true;
                            break;
                        }
                        s.nodes += 1;
                        let d2 = sp.0.distance_squared(s.centre);
                        if s.may_hold_better(d2, sp.1) && !s.all_cut(d2, sp.1) {
                            let more = CHILD_POINTS[c as usize] & !have;
                            if more != 0 {
                                refinement_points_masked(
                                    &frame,
                                    &e.bary,
                                    e.depth,
                                    more,
                                    &mut ten_rows,
                                    &mut ten,
                                );
                                have |= more;
                            }
                            s.offer_leaf(t, index, child, child_of_ten(&ten, c), sp);
                        }
                        continue;
                    }
                    if let Some((d2, _)) = Self::test_node(&mut s, sp) {
                        // Kept: into `order` by decreasing distance (ties in child order),
                        // its sphere in `spheres`.
                        if let Some(slot) = spheres.get_mut(c as usize) {
                            *slot = sp;
                        }
                        let mut at = kept;
                        while at > 0 && order.get(at - 1).is_some_and(|o| o.0 < d2) {
                            at -= 1;
                        }
                        if let Some(o) = order.get_mut(at..=kept) {
                            o.rotate_right(1);
                            o[0] = (d2, c);
                        }
                        kept += 1;
                    }
                }
                // The kept children onto the stack farthest first, so the nearest is walked
                // first (never full: at most 7 entries per level wait, plus 8).
                for &(d2, c) in order.iter().take(kept) {
                    let (mid, rad) = spheres.get(c as usize).copied().unwrap_or_default();
                    let _ = stack.push(Entry {
                        r: first + c as u32,
                        index: e.index * 8 + 1 + c as u32,
                        depth: e.depth + 1,
                        bary: child_packed(&e.bary, c),
                        mid,
                        d2,
                        rad,
                    });
                }
            }
        }
        s
    }

    /// The tests a node holding surface with bounding sphere `(mid, rad)` passes to be kept:
    /// the reach test of [`Hierarchy::for_each_visible_in`], the bound and the cutting rule;
    /// counts one node of work (or stops the search when `max_nodes` are spent). Returns the
    /// squared distance to the sphere's centre and its radius when the node is kept.
    #[inline]
    fn test_node(s: &mut Search, (mid, rad): (Vec3, f32)) -> Option<(f32, f32)> {
        if s.nodes >= s.max_nodes {
            s.stopped = true;
            return None;
        }
        s.nodes += 1;
        let d2 = mid.distance_squared(s.centre);
        let lim = rad + s.reach;
        if d2 > lim * lim || !s.may_hold_better(d2, rad) || s.all_cut(d2, rad) {
            return None;
        }
        Some((d2, rad))
    }
}

/// The closer of two candidate answers (ties: the smaller face), as a walk compares them.
fn closer(
    a: Option<(f32, FaceRef, VisibleTri)>,
    b: Option<(f32, FaceRef, VisibleTri)>,
) -> Option<(f32, FaceRef, VisibleTri)> {
    match (a, b) {
        (Some(x), Some(y)) => Some(if beats((y.0, y.1), Some((x.0, x.1))) {
            y
        } else {
            x
        }),
        (x, None) => x,
        (None, y) => y,
    }
}

/// The order of answers: `(d2, key)` beats `best` when it is nearer, or as near with the
/// smaller face (so no answer depends on the visiting order); anything beats no answer.
#[inline]
fn beats((d2, key): (f32, FaceRef), best: Option<(f32, FaceRef)>) -> bool {
    match best {
        None => true,
        Some((bd, bk)) => d2 < bd || (d2 == bd && key < bk),
    }
}

/// The cutting rule of [`Hierarchy::nearest_uncut`] for the outward (counter-clockwise)
/// triangle `corners` whose closest point to `centre` is `x` (`cut2`: the burr's squared
/// radius, negative when it is not cutting): `true` when all three corners lie within the
/// burr, or when `centre` lies behind the triangle seen from `x` (the "inside" test of
/// [`crate::force::sphere_contact`]).
#[inline]
fn cut_skips(corners: &[Vec3; 3], centre: Vec3, x: Vec3, cut2: f32) -> bool {
    if cut2 < 0.0 {
        return false;
    }
    let inside = corners.iter().all(|q| q.distance_squared(centre) <= cut2);
    let n = (corners[1] - corners[0]).cross(corners[2] - corners[0]);
    inside || (centre - x).dot(n) < 0.0
}
