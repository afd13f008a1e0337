//! Node geometry from the tree table: the vertices of a node are integer barycentric
//! combinations of its root's corners, evaluated in one canonical order (ascending global node
//! id), so a point shared by several nodes, trees or depths gets the same bits everywhere and
//! the drilled surface is watertight.

use glam::Vec3;

use super::table::{Path, CHILD_VERTS};
use super::MAX_DEPTH;
use crate::ids::TetId;
use crate::mesh::Mesh;

/// The four vertex positions of node `path` in the tree of coarse tet `tet` (in the node's own
/// vertex order; see [`Path::inverted`] for its orientation). Zero when `tet` or one of its
/// node ids is out of range.
///
/// # Bounded work
/// O(depth) <= [`super::MAX_DEPTH`] steps.
pub(crate) fn node_positions(mesh: &Mesh<'_>, tet: TetId, path: &Path) -> [Vec3; 4] {
    match RootFrame::of(mesh, tet) {
        Some(frame) => frame.positions(&path.bary(), path.depth),
        None => [Vec3::ZERO; 4],
    }
}

/// A coarse tet's corners and their canonical order (ascending global node id): everything
/// needed to turn a node's integer barycentric coordinates into positions. Walks that carry
/// the coordinates down the tree use it to get each node's corners in O(1) with the same bits
/// as [`node_positions`].
#[derive(Clone, Copy, Debug)]
pub(crate) struct RootFrame {
    /// The corners in canonical order: `sorted[k]` is corner `order[k]`.
    sorted: [Vec3; 4],
    /// `order[k]`: the root-local corner (0..4) that comes `k`-th in canonical order.
    order: [u8; 4],
}

/// The depth at which a tree whose root's longest edge is `edge` has leaves of at most
/// `resolution` (each level halves the edges); [`MAX_DEPTH`] without a resolution (0).
///
/// # Bounded work
/// At most [`MAX_DEPTH`] halvings.
pub(crate) fn depth_limit(edge: f32, resolution: f32) -> u8 {
    if resolution <= 0.0 {
        return MAX_DEPTH as u8;
    }
    let mut e = edge;
    let mut d = 0u8;
    while e > resolution && (d as usize) < MAX_DEPTH {
        e *= 0.5;
        d += 1;
    }
    d
}

/// The depth of the leaves that are the debris's unit in the tree of `tet`: `max_depth`, or,
/// with a drill resolution (`crate::drill::Drill::set_resolution`), the tree's own depth limit
/// when it is shallower (the finest leaf the drill makes there).
///
/// # Bounded work
/// Constant without a resolution; with one, the root's frame and [`depth_limit`].
pub(crate) fn unit_depth(mesh: &Mesh<'_>, tet: TetId, max_depth: u8, resolution: f32) -> u8 {
    if resolution > 0.0 {
        RootFrame::of(mesh, tet).map_or(max_depth, |f| {
            depth_limit(f.longest_edge(), resolution).min(max_depth)
        })
    } else {
        max_depth
    }
}

impl RootFrame {
    /// The frame of coarse tet `tet`, `None` when it or one of its node ids is out of range.
    pub(crate) fn of(mesh: &Mesh<'_>, tet: TetId) -> Option<Self> {
        let ids = mesh.get_tet_nodes(tet)?;
        let [a, b, c, d] = ids.map(|n| mesh.positions().get(n.idx()));
        let corners = [*a?, *b?, *c?, *d?];
        // Canonical order of the four corners by global node id (a 4-element insertion sort).
        let mut order = [0u8, 1, 2, 3];
        for i in 1..4 {
            let mut j = i;
            while j > 0 && ids[order[j - 1] as usize].0 > ids[order[j] as usize].0 {
                order.swap(j - 1, j);
                j -= 1;
            }
        }
        let sorted = order.map(|k| corners[(k & 3) as usize]);
        Some(Self { sorted, order })
    }

    /// The length of the root tet's longest edge.
    ///
    /// # Bounded work
    /// Constant: six squared distances and one square root.
    pub(crate) fn longest_edge(&self) -> f32 {
        let c = self.sorted;
        let mut m = 0.0f32;
        for i in 0..4 {
            for j in i + 1..4 {
                m = m.max(c[i].distance_squared(c[j]));
            }
        }
        libm::sqrtf(m)
    }

    /// The point with integer barycentric coordinates `w` (scaled by `2^depth`): the sum, in
    /// canonical corner order, of corner times weight, then scaled. A point shared by several
    /// nodes (of any depth or tree) has the same reduced coordinates, so it gets the same bits.
    ///
    /// # Bounded work
    /// Constant: 4 vector multiply-adds and a scaling.
    #[inline]
    pub(crate) fn point(&self, w: &[u32; 4], depth: u8) -> Vec3 {
        let scale = scale_of(depth);
        let [o0, o1, o2, o3] = self.order.map(|k| (k & 3) as usize);
        let [c0, c1, c2, c3] = self.sorted;
        let mut p = Vec3::ZERO;
        p += c0 * w[o0] as f32;
        p += c1 * w[o1] as f32;
        p += c2 * w[o2] as f32;
        p += c3 * w[o3] as f32;
        p * scale
    }

    /// The four vertex positions of the node with integer barycentric coordinates `bary`
    /// (scaled by `2^depth`), each as [`RootFrame::point`].
    ///
    /// # Bounded work
    /// Constant: 16 vector multiply-adds and 4 scalings.
    #[inline]
    pub(crate) fn positions(&self, bary: &[[u32; 4]; 4], depth: u8) -> [Vec3; 4] {
        bary.map(|w| self.point(&w, depth))
    }

    /// The root's corners as packed coordinates, lanes in canonical order ([`Packed`]):
    /// root-local corner `k` has weight 1 in the lane of its canonical rank.
    ///
    /// # Bounded work
    /// Constant.
    #[inline]
    pub(crate) fn root_packed(&self) -> [Packed; 4] {
        let mut rows = [0; 4];
        for (lane, &k) in self.order.iter().enumerate() {
            rows[(k & 3) as usize] = 1 << (16 * lane);
        }
        rows
    }

    /// The point with packed coordinates `w` (lanes in canonical order) scaled by `scale`
    /// (`2^-depth`): [`RootFrame::point`] of the same weights, bit for bit (the same products,
    /// summed in the same order), without unpacking through the corner order.
    ///
    /// # Bounded work
    /// Constant: 4 vector multiply-adds and a scaling.
    #[inline(always)]
    pub(crate) fn packed_point(&self, w: Packed, scale: f32) -> Vec3 {
        let l = [0u32, 16, 32, 48].map(|sh| ((w >> sh) & 0xffff) as u32);
        let lane = |k: usize| l[k] as f32;
        let [c0, c1, c2, c3] = self.sorted;
        let mut p = Vec3::ZERO;
        p += c0 * lane(0);
        p += c1 * lane(1);
        p += c2 * lane(2);
        p += c3 * lane(3);
        p * scale
    }

    /// [`RootFrame::positions`] of packed coordinates ([`Packed`]).
    ///
    /// # Bounded work
    /// Constant: four [`RootFrame::packed_point`].
    #[inline(always)]
    pub(crate) fn positions_packed(&self, bary: &[Packed; 4], depth: u8) -> [Vec3; 4] {
        let scale = scale_of(depth);
        [
            self.packed_point(bary[0], scale),
            self.packed_point(bary[1], scale),
            self.packed_point(bary[2], scale),
            self.packed_point(bary[3], scale),
        ]
    }
}

/// `2^-depth` (exact), the scaling of [`RootFrame::point`].
#[inline]
fn scale_of(depth: u8) -> f32 {
    1.0 / (1u32 << depth.min(31)) as f32
}

/// The ten points of one red refinement, indexed by [`PAIR`]: the parent's four vertices
/// (`i`) then the six edge midpoints (`4..10`).
pub(crate) const PAIRS: [(u8, u8); 10] = [
    (0, 0),
    (1, 1),
    (2, 2),
    (3, 3),
    (0, 1),
    (0, 2),
    (0, 3),
    (1, 2),
    (1, 3),
    (2, 3),
];

/// `PAIR[a][b]`: the index in [`PAIRS`] of the point `(a, b)` (vertex when `a == b`).
pub(crate) const PAIR: [[usize; 4]; 4] = [[0, 4, 5, 6], [4, 1, 7, 8], [5, 7, 2, 9], [6, 8, 9, 3]];

/// A point's four integer barycentric weights packed into one `u64`, the weight of the
/// root's `j`-th corner in canonical order ([`RootFrame`]) in bits `16j..16j+16`, so a point
/// is evaluated without looking up the corner order ([`RootFrame::packed_point`]). Weights
/// are at most `2^MAX_DEPTH` = 1024 (and the sum of two at most 2048), so a child's point is
/// one `u64` addition of two parent points, lane by lane (in any lane order). A tree's root
/// rows are [`RootFrame::root_packed`].
pub(crate) type Packed = u64;

/// The packed point `(a, b)` of the refinement of a node with packed corners `bary`: the
/// midpoint of corners `a` and `b` one level down (corner `a` itself when `a == b`), i.e. the
/// sum of the two rows.
#[inline]
fn pair_row(bary: &[Packed; 4], (a, b): (u8, u8)) -> Packed {
    bary[(a & 3) as usize].wrapping_add(bary[(b & 3) as usize])
}

/// The packed corners of child `c` (Bey's order) of a node with packed corners `bary`: the
/// packed form of [`super::table::child_bary`].
///
/// # Bounded work
/// Constant: four additions.
#[inline]
pub(crate) fn child_packed(bary: &[Packed; 4], c: u8) -> [Packed; 4] {
    let [i, j, k, l] = CHILD_TEN[(c & 7) as usize];
    let row = |x: u8| pair_row(bary, PAIRS[(x as usize).min(9)]);
    [row(i), row(j), row(k), row(l)]
}

/// The packed integer barycentric coordinates (one level down, scaled by `2^(depth+1)`) and
/// the positions of the ten points of the red refinement of the node with packed coordinates
/// `bary` at `depth`: a child's corners are four of them (`PAIR` of
/// [`super::table::CHILD_VERTS`]), so eight children cost ten point evaluations instead of
/// thirty-two, with the same bits as [`RootFrame::positions`] of each child.
///
/// # Bounded work
/// Constant: ten [`RootFrame::point`] evaluations.
#[inline(always)]
pub(crate) fn refinement_points(
    frame: &RootFrame,
    bary: &[Packed; 4],
    depth: u8,
) -> ([Packed; 10], [Vec3; 10]) {
    let mut rows = [0; 10];
    let mut pts = [Vec3::ZERO; 10];
    refinement_points_masked(frame, bary, depth, ALL_POINTS, &mut rows, &mut pts);
    (rows, pts)
}

/// Child `c`'s packed coordinates and corners, picked from the ten rows and points of its
/// parent's refinement ([`refinement_points`]): the child's own packed corners and
/// [`RootFrame::positions_packed`] of them, bit for bit (a shared point has the same reduced
/// coordinates whichever node names it).
///
/// # Bounded work
/// Constant: eight look-ups.
#[inline]
pub(crate) fn child_of_refinement(
    rows: &[Packed; 10],
    pts: &[Vec3; 10],
    c: u8,
) -> ([Packed; 4], [Vec3; 4]) {
    (child_of_ten(rows, c), child_of_ten(pts, c))
}

/// `CHILD_TEN[c][k]`: the index in [`PAIRS`] of child `c`'s vertex `k`, i.e. `PAIR` of
/// [`super::table::CHILD_VERTS`]`[c][k]`, folded at compile time.
const CHILD_TEN: [[u8; 4]; 8] = {
    let mut t = [[0u8; 4]; 8];
    let mut c = 0;
    while c < 8 {
        let mut k = 0;
        while k < 4 {
            let (a, b) = CHILD_VERTS[c][k];
            t[c][k] = PAIR[a as usize][b as usize] as u8;
            k += 1;
        }
        c += 1;
    }
    t
};

/// Every one of the ten points of a refinement, as a mask of [`refinement_points_masked`].
pub(crate) const ALL_POINTS: u16 = (1 << 10) - 1;

/// `CHILD_POINTS[c]`: bit `i` set when child `c` has point `i` of [`PAIRS`] as a corner.
pub(crate) const CHILD_POINTS: [u16; 8] = {
    let mut m = [0u16; 8];
    let mut c = 0;
    while c < 8 {
        let mut k = 0;
        while k < 4 {
            m[c] |= 1 << CHILD_TEN[c][k];
            k += 1;
        }
        c += 1;
    }
    m
};

/// The ten points of [`refinement_points`] whose bit is set in `mask` (the corners of the
/// children a walk will look at, [`CHILD_POINTS`]; [`ALL_POINTS`] for every one), written into
/// the caller's arrays (a walk keeps them across iterations and copies no 120-byte array per
/// refinement); the other entries are left as they were.
///
/// # Bounded work
/// Constant: at most ten [`RootFrame::point`] evaluations, one per bit of `mask`.
#[inline(always)]
pub(crate) fn refinement_points_masked(
    frame: &RootFrame,
    bary: &[Packed; 4],
    depth: u8,
    mask: u16,
    rows: &mut [Packed; 10],
    pts: &mut [Vec3; 10],
) {
    let scale = scale_of(depth + 1);
    for (i, ((row, pt), pair)) in rows.iter_mut().zip(pts.iter_mut()).zip(PAIRS).enumerate() {
        if mask & (1 << i) != 0 {
            *row = pair_row(bary, pair);
            *pt = frame.packed_point(*row, scale);
        }
    }
}

/// Child `c`'s four entries (its corners in its own order) among ten per-point values of its
/// parent's refinement, indexed as [`PAIRS`]. One table row and four loads: through
/// `CHILD_VERTS` and `PAIR` with `array::map` it was a fifth of the contact search's
/// instructions (callgrind, firmware scenario).
///
/// # Bounded work
/// Constant: four look-ups.
#[inline(always)]
pub(crate) fn child_of_ten<T: Copy>(ten: &[T; 10], c: u8) -> [T; 4] {
    let [i, j, k, l] = CHILD_TEN[(c & 7) as usize];
    let at = |x: u8| ten[(x as usize).min(9)];
    [at(i), at(j), at(k), at(l)]
}

/// Volume of node `path` of tet `tet`: the root's volume over `8^depth` (Bey's eight children
/// have equal volumes), measured in the rest state ([`Mesh::rest_tet_positions`]), so the
/// volume a deforming mesh loses is the material's, not its current shape's.
///
/// # Bounded work
/// O(depth).
pub(crate) fn node_volume(mesh: &Mesh<'_>, tet: TetId, depth: u8) -> f64 {
    if tet.idx() >= mesh.tet_count() {
        return 0.0;
    }
    // One multiply by 8^-depth instead of `depth` multiplies by 1/8: scaling by a power of
    // two is exact in f64 (a tet's f32 volume over 8^10 stays far from the subnormals),
    // so the bits are the same, and on the Cortex-M4 each f64 multiply is a software call.
    let mut v = crate::geom::tet_volume(mesh.rest_tet_positions(tet)) as f64;
    match EIGHTH_POWERS.get(depth as usize) {
        Some(&scale) => v * scale,
        None => {
            for _ in 0..depth {
                v *= 0.125;
            }
            v
        }
    }
}

/// `EIGHTH_POWERS[d]` = `0.125^d`, exact in f64.
const EIGHTH_POWERS: [f64; super::table::MAX_DEPTH + 1] = {
    let mut p = [1.0f64; super::table::MAX_DEPTH + 1];
    let mut d = 1;
    while d < p.len() {
        p[d] = p[d - 1] * 0.125;
        d += 1;
    }
    p
};
