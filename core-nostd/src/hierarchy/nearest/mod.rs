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

mod hints;
mod walk;

use glam::Vec3;

use super::geometry::Packed;
use super::memo::SphereMemo;
use super::store::Hierarchy;
use super::surface::VisibleTri;
use super::table::MAX_DEPTH;
use crate::ids::TetId;
use crate::mesh::Mesh;

pub(crate) use hints::keep_face;
pub use hints::{Kept, KEEP};

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

    /// Forgets the nodes waiting in its tree but keeps the tree and the round: the next search
    /// goes on with that tree from its root. For a mesh whose nodes moved (the waiting nodes'
    /// bounding spheres were measured on the old positions).
    ///
    /// # Bounded work
    /// Constant.
    pub(crate) fn restart_tree(&mut self) {
        self.stack.clear();
    }

    /// Forgets the place (the next search starts afresh).
    pub(crate) fn clear(&mut self) {
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

impl Hierarchy<'_> {
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
