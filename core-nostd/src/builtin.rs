//! Built-in meshes, made by the project's own code and written into caller slices, so every
//! command and the firmware run with nothing beside the project.
//!
//! - [`cube12`]: the drilling paper's test object, the cube `[-0.5, 0.5]^3` split into 12 tets
//!   by a centre vertex (Turini et al. 2006, section 4).
//! - [`block`]: an `n x n x n` block of cubes, each split into 6 tets around its main diagonal
//!   (Kuhn/Freudenthal), which is conforming across cubes; [`block_labels`] gives it two
//!   regions, an outer shell one cube thick ([`BLOCK_SHELL`]) and the core inside it
//!   ([`BLOCK_CORE`]).
//!
//! ```
//! use tetradrill_core::builtin::{self, BLOCK_CORE};
//! use tetradrill_core::geom::tet_volume;
//! use tetradrill_core::Vec3;
//!
//! let volume = |pos: &[Vec3], tets: &[[u32; 4]]| -> f32 {
//!     tets.iter().map(|t| tet_volume(t.map(|i| pos[i as usize]))).sum()
//! };
//! let (pos, tets) = builtin::cube12();
//! assert!((volume(&pos, &tets) - 1.0).abs() < 1e-6);
//!
//! // A 3 x 3 x 3 block of cubes of edge 0.5 from the origin: 64 nodes, 162 tets.
//! assert_eq!(builtin::block_counts(3), (64, 162));
//! let (mut pos, mut tets) = ([Vec3::ZERO; 64], [[0u32; 4]; 162]);
//! builtin::block(3, 0.5, Vec3::ZERO, &mut pos, &mut tets).unwrap();
//! assert!((volume(&pos, &tets) - 1.5f32.powi(3)).abs() < 1e-5);
//!
//! // Its middle cube (6 tets) is the core, the 26 cubes around it the shell.
//! let mut labels = [0; 162];
//! builtin::block_labels(3, &mut labels).unwrap();
//! assert_eq!(labels.iter().filter(|&&l| l == BLOCK_CORE).count(), 6);
//! ```

use glam::Vec3;

use crate::geom::det6;

/// Nodes of [`cube12`].
pub(crate) const CUBE12_NODES: usize = 9;
/// Tets of [`cube12`].
pub(crate) const CUBE12_TETS: usize = 12;

/// The cube `[-0.5, 0.5]^3` split into 12 positively oriented tets by its centre (node 8).
pub fn cube12() -> ([Vec3; CUBE12_NODES], [[u32; 4]; CUBE12_TETS]) {
    let mut p = [Vec3::ZERO; CUBE12_NODES];
    for (i, q) in p.iter_mut().take(8).enumerate() {
        *q = Vec3::new(
            if i & 1 != 0 { 0.5 } else { -0.5 },
            if i & 2 != 0 { 0.5 } else { -0.5 },
            if i & 4 != 0 { 0.5 } else { -0.5 },
        );
    }
    // Each cube face as a quad (corner bits), split into two triangles, joined to the centre.
    const QUADS: [[u32; 4]; 6] = [
        [0, 1, 3, 2],
        [4, 5, 7, 6],
        [0, 1, 5, 4],
        [2, 3, 7, 6],
        [0, 2, 6, 4],
        [1, 3, 7, 5],
    ];
    let mut t = [[0u32; 4]; CUBE12_TETS];
    for (k, q) in QUADS.iter().enumerate() {
        t[2 * k] = orient(&p, [q[0], q[1], q[2], 8]);
        t[2 * k + 1] = orient(&p, [q[0], q[2], q[3], 8]);
    }
    (p, t)
}

/// Node and tet counts of an `n`-block: `(n+1)^3` nodes, `6 n^3` tets.
pub const fn block_counts(n: usize) -> (usize, usize) {
    ((n + 1) * (n + 1) * (n + 1), 6 * n * n * n)
}

/// Writes an `n x n x n` block of cubes of edge `edge`, with its minimum corner at `origin`,
/// into `positions` and `tets` (sizes from [`block_counts`]). Every tet is positively
/// oriented. Returns the counts, or `None` when a slice is too short (nothing is written).
///
/// # Bounded work
/// O(n^3).
pub fn block(
    n: usize,
    edge: f32,
    origin: Vec3,
    positions: &mut [Vec3],
    tets: &mut [[u32; 4]],
) -> Option<(usize, usize)> {
    let (nn, nt) = block_counts(n);
    if positions.len() < nn || tets.len() < nt || n == 0 {
        return None;
    }
    let m = n + 1;
    let id = |i: usize, j: usize, k: usize| (i + m * (j + m * k)) as u32;
    for k in 0..m {
        for j in 0..m {
            for i in 0..m {
                positions[id(i, j, k) as usize] =
                    origin + Vec3::new(i as f32, j as f32, k as f32) * edge;
            }
        }
    }
    // The six paths from corner (0,0,0) to (1,1,1) along the axes, one tet each.
    const PATHS: [[usize; 3]; 6] = [
        [0, 1, 2],
        [0, 2, 1],
        [1, 0, 2],
        [1, 2, 0],
        [2, 0, 1],
        [2, 1, 0],
    ];
    let mut c = 0;
    for k in 0..n {
        for j in 0..n {
            for i in 0..n {
                for path in PATHS {
                    let mut at = [i, j, k];
                    let mut tet = [id(i, j, k); 4];
                    for (s, axis) in path.iter().enumerate() {
                        at[*axis] += 1;
                        tet[s + 1] = id(at[0], at[1], at[2]);
                    }
                    tets[c] = orient(positions, tet);
                    c += 1;
                }
            }
        }
    }
    Some((nn, nt))
}

/// Region label of the tets of a [`block`]'s outer layer of cubes (a shell one cube thick).
pub const BLOCK_SHELL: i32 = 1;
/// Region label of the tets of a [`block`]'s cubes inside its shell.
pub const BLOCK_CORE: i32 = 2;

/// Writes the region label of each tet of an `n`-block ([`block`]'s order, six tets per cube)
/// into `labels`: [`BLOCK_SHELL`] for the cubes on the block's boundary, [`BLOCK_CORE`] for
/// the others (none when `n <= 2`). Returns the tet count, or `None` when `labels` is too
/// short (nothing is written).
///
/// # Bounded work
/// O(n^3).
pub fn block_labels(n: usize, labels: &mut [i32]) -> Option<usize> {
    let (_, nt) = block_counts(n);
    if labels.len() < nt || n == 0 {
        return None;
    }
    let edge = |i: usize| i == 0 || i + 1 == n;
    let mut c = 0;
    for k in 0..n {
        for j in 0..n {
            for i in 0..n {
                let l = if edge(i) || edge(j) || edge(k) {
                    BLOCK_SHELL
                } else {
                    BLOCK_CORE
                };
                for slot in labels.iter_mut().skip(c).take(6) {
                    *slot = l;
                }
                c += 6;
            }
        }
    }
    Some(nt)
}

fn orient(p: &[Vec3], mut t: [u32; 4]) -> [u32; 4] {
    let q = t.map(|i| p[i as usize]);
    if det6(q[0], q[1], q[2], q[3]) < 0.0 {
        t.swap(2, 3);
    }
    t
}
