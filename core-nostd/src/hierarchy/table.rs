//! The tree table (Turini et al. 2006, section 2.1), as const data for one level of Bey's red
//! refinement plus digit walks for the deeper levels.
//!
//! With `xij` the midpoint of edge `(xi, xj)` the children (0-based, `c = 0..8` is Bey's
//! `T1..T8`) are
//! `T1=(x0,x01,x02,x03) T2=(x01,x1,x12,x13) T3=(x02,x12,x2,x23) T4=(x03,x13,x23,x3)
//!  T5=(x01,x02,x03,x13) T6=(x01,x02,x12,x13) T7=(x02,x03,x13,x23) T8=(x02,x12,x13,x23)`;
//! `T6` and `T8` are inverted relative to their parent (kept as an orientation bit, never
//! reordered, so Bey's shape guarantee holds).
//!
//! Faces follow the mesh template: face `i` is opposite vertex `i`, listed as
//! [`FACE_VERTS`]`[i]`. A child face lying on a parent face sits at one *position* of the
//! parent face's regular 1:4 subdivision: position `k < 3` is the corner sub-triangle at the
//! `k`-th vertex of the parent face's listing, position `3` the centre one. Each child-face
//! listing position is *associated* with one parent listing position (a corner with itself, the
//! midpoint of `(a, b)` on the corner triangle at `a` with `b`, a midpoint on the centre triangle
//! with the parent vertex opposite it); this is the `sigma` of [`Across::Outside`] and of
//! [`FACE_SUB`]. Two listings of one shared face are related by a permutation `pi` of the
//! listing positions (`pi[k]` = the position of the same point in the other listing).
//!
//! Memory of the const tables: [`CHILD_VERTS`] 64 B, [`CHILD_ADJ`] 32 entries of 5 B = 160 B,
//! [`FACE_SUB`] 16 entries of 5 B = 80 B; about 300 bytes in flash. Deeper levels cost nothing:
//! they are walked through the index digits (O(depth) per query, see [`Path`]).
//!
//! [`FACE_VERTS`]: crate::mesh::template::FACE_VERTS

/// Deepest level a tree index can address in a `u32` (the largest index at depth 10 is
/// `(8^11 - 1) / 7 - 1 < 2^31`).
pub const MAX_DEPTH: usize = 10;

/// A permutation of the three listing positions of a face.
pub(crate) type Perm = [u8; 3];

/// The identity permutation.
pub(crate) const ID_PERM: Perm = [0, 1, 2];

/// Child `c`'s vertex `k` is the midpoint of parent vertices `(a, b)` (`a == b`: the vertex).
pub(crate) const CHILD_VERTS: [[(u8, u8); 4]; 8] = [
    [(0, 0), (0, 1), (0, 2), (0, 3)],
    [(0, 1), (1, 1), (1, 2), (1, 3)],
    [(0, 2), (1, 2), (2, 2), (2, 3)],
    [(0, 3), (1, 3), (2, 3), (3, 3)],
    [(0, 1), (0, 2), (0, 3), (1, 3)],
    [(0, 1), (0, 2), (1, 2), (1, 3)],
    [(0, 2), (0, 3), (1, 3), (2, 3)],
    [(0, 2), (1, 2), (1, 3), (2, 3)],
];

/// `true` for the children whose vertex order is inverted relative to the parent (T6, T8).
pub(crate) const CHILD_INVERTED: [bool; 8] = [false, false, false, false, false, true, false, true];

/// What lies across face `f` of child `c`, within one refinement of the parent.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub(crate) enum Across {
    /// A sibling: its child digit, its face, and `pi` from this face's listing to its listing.
    Sibling(u8, u8, Perm),
    /// The face lies on parent face `face` at sub-triangle position `pos` (0..=3) with the
    /// association `sigma` (child listing position -> parent listing position).
    Outside {
        /// Parent face.
        face: u8,
        /// Position in the parent face's 1:4 subdivision (3 = centre).
        pos: u8,
        /// Child listing position -> associated parent listing position.
        sigma: Perm,
    },
}

const fn s(c: u8, f: u8, p: Perm) -> Across {
    Across::Sibling(c, f, p)
}
const fn o(face: u8, pos: u8, sigma: Perm) -> Across {
    Across::Outside { face, pos, sigma }
}

/// Same-level adjacency of the children: `CHILD_ADJ[c][f]`.
pub(crate) const CHILD_ADJ: [[Across; 4]; 8] = [
    [
        s(4, 3, [0, 2, 1]),
        o(1, 0, ID_PERM),
        o(2, 0, ID_PERM),
        o(3, 0, ID_PERM),
    ],
    [
        o(0, 0, ID_PERM),
        s(5, 1, ID_PERM),
        o(2, 2, ID_PERM),
        o(3, 1, ID_PERM),
    ],
    [
        o(0, 2, ID_PERM),
        o(1, 1, ID_PERM),
        s(7, 2, ID_PERM),
        o(3, 2, ID_PERM),
    ],
    [
        o(0, 1, ID_PERM),
        o(1, 2, ID_PERM),
        o(2, 1, ID_PERM),
        s(6, 0, [0, 2, 1]),
    ],
    [
        s(6, 3, [0, 2, 1]),
        o(2, 3, [1, 2, 0]),
        s(5, 2, ID_PERM),
        s(0, 0, [0, 2, 1]),
    ],
    [
        s(7, 3, [0, 2, 1]),
        s(1, 1, ID_PERM),
        s(4, 2, ID_PERM),
        o(3, 3, [2, 1, 0]),
    ],
    [
        s(3, 3, [0, 2, 1]),
        s(7, 1, ID_PERM),
        o(1, 3, [2, 0, 1]),
        s(4, 0, [0, 2, 1]),
    ],
    [
        o(0, 3, [1, 0, 2]),
        s(6, 1, ID_PERM),
        s(2, 2, ID_PERM),
        s(5, 0, [0, 2, 1]),
    ],
];

/// The children on a parent face: `FACE_SUB[face][pos] = (child, child face, sigma)`; the
/// inverse of the `Outside` entries of [`CHILD_ADJ`]. Note T5's face 1 lies on parent face 2
/// and T7's face 2 on parent face 1 (the per-child face map).
pub(crate) const FACE_SUB: [[(u8, u8, Perm); 4]; 4] = [
    [
        (1, 0, ID_PERM),
        (3, 0, ID_PERM),
        (2, 0, ID_PERM),
        (7, 0, [1, 0, 2]),
    ],
    [
        (0, 1, ID_PERM),
        (2, 1, ID_PERM),
        (3, 1, ID_PERM),
        (6, 2, [2, 0, 1]),
    ],
    [
        (0, 2, ID_PERM),
        (3, 2, ID_PERM),
        (1, 2, ID_PERM),
        (4, 1, [1, 2, 0]),
    ],
    [
        (0, 3, ID_PERM),
        (1, 3, ID_PERM),
        (2, 3, ID_PERM),
        (5, 3, [2, 1, 0]),
    ],
];

/// The inverse of a permutation.
#[inline]
pub(crate) const fn invert(p: Perm) -> Perm {
    let mut q = [0u8; 3];
    q[(p[0] % 3) as usize] = 0;
    q[(p[1] % 3) as usize] = 1;
    q[(p[2] % 3) as usize] = 2;
    q
}

/// `k -> b[a[k]]`.
#[inline]
pub(crate) const fn then(a: Perm, b: Perm) -> Perm {
    [
        b[(a[0] % 3) as usize],
        b[(a[1] % 3) as usize],
        b[(a[2] % 3) as usize],
    ]
}

/// The root's integer barycentric coordinates (its own corners).
pub(crate) const ROOT_BARY: [[u32; 4]; 4] =
    [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]];

/// Integer barycentric coordinates of child `c` from its parent's (one level down: each row
/// of the result sums to twice the parent's row sum).
///
/// # Bounded work
/// Constant: 16 additions.
#[inline]
pub(crate) fn child_bary(parent: &[[u32; 4]; 4], c: u8) -> [[u32; 4]; 4] {
    let cv = CHILD_VERTS[(c & 7) as usize];
    let mut n = [[0u32; 4]; 4];
    for (row, &(a, e)) in n.iter_mut().zip(cv.iter()) {
        for j in 0..4 {
            row[j] = parent[(a & 3) as usize][j] + parent[(e & 3) as usize][j];
        }
    }
    n
}

/// A node's place in its tree: the coarse tet's index digits from the root down.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub(crate) struct Path {
    /// Tree index (root 0, children of `i` are `8i+1 ..= 8i+8`).
    pub(crate) index: u32,
    /// Depth (root 0).
    pub(crate) depth: u8,
    /// Child digit (0..8) per level, `digits[0]` just below the root.
    pub(crate) digits: [u8; MAX_DEPTH],
}

impl Path {
    /// The root.
    pub(crate) const ROOT: Self = Self {
        index: 0,
        depth: 0,
        digits: [0; MAX_DEPTH],
    };

    /// The path of a tree index, or `None` when it is deeper than [`MAX_DEPTH`].
    ///
    /// # Bounded work
    /// O(depth) <= [`MAX_DEPTH`] steps.
    pub(crate) fn of_index(index: u32) -> Option<Self> {
        let mut rev = [0u8; MAX_DEPTH];
        let mut d = 0usize;
        let mut i = index;
        while i > 0 {
            let slot = rev.get_mut(d)?;
            *slot = ((i - 1) % 8) as u8;
            i = (i - 1) / 8;
            d += 1;
        }
        let mut digits = [0u8; MAX_DEPTH];
        for (dst, src) in digits.iter_mut().zip(rev.iter().take(d).rev()) {
            *dst = *src;
        }
        Some(Self {
            index,
            depth: d as u8,
            digits,
        })
    }

    /// The depth of tree index `index` without building its path, `None` beyond
    /// [`MAX_DEPTH`].
    ///
    /// # Bounded work
    /// O(depth) <= [`MAX_DEPTH`] + 1 divisions.
    #[inline]
    pub(crate) fn depth_of(index: u32) -> Option<u8> {
        let mut i = index;
        let mut d = 0usize;
        while i > 0 {
            i = (i - 1) / 8;
            d += 1;
        }
        (d <= MAX_DEPTH).then_some(d as u8)
    }

    /// The path of child `c` (0..8), or `None` at [`MAX_DEPTH`].
    #[inline]
    pub(crate) fn child(&self, c: u8) -> Option<Self> {
        let d = self.depth as usize;
        if d >= MAX_DEPTH {
            return None;
        }
        let mut p = *self;
        p.digits[d] = c & 7;
        p.depth += 1;
        p.index = self.index * 8 + 1 + (c & 7) as u32;
        Some(p)
    }

    /// The digit at level `k` (1-based: the digit that leads from depth `k-1` to depth `k`).
    #[inline]
    pub(crate) fn digit(&self, k: usize) -> u8 {
        self.digits.get(k.wrapping_sub(1)).copied().unwrap_or(0) & 7
    }

    /// The tree index of the ancestor at depth `k` (`k <= depth`).
    #[inline]
    pub(crate) fn prefix_index(&self, k: usize) -> u32 {
        let mut i = 0u32;
        for &c in self.digits.iter().take(k.min(self.depth as usize)) {
            i = i * 8 + 1 + (c & 7) as u32;
        }
        i
    }

    /// Integer barycentric coordinates of the four vertices in the root tet, scaled by
    /// `2^depth` (each row sums to `2^depth`): the tree table's vertex coordinates, derived by
    /// descending the digits.
    ///
    /// # Bounded work
    /// O(depth).
    pub(crate) fn bary(&self) -> [[u32; 4]; 4] {
        let mut b = ROOT_BARY;
        for &c in self.digits.iter().take(self.depth as usize) {
            b = child_bary(&b, c);
        }
        b
    }

    /// `true` when the node's vertex order is inverted relative to its root (an odd number of
    /// T6/T8 steps).
    #[inline]
    pub(crate) fn inverted(&self) -> bool {
        self.digits
            .iter()
            .take(self.depth as usize)
            .fold(false, |inv, &c| inv ^ CHILD_INVERTED[(c & 7) as usize])
    }
}
