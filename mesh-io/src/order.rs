//! Spatial order for loaded meshes: nodes along a Morton (Z-order) curve, tets by their first
//! node on that curve.
//!
//! Mesh generators write nodes and tets in the order they were made (TetGen: surface points
//! first, then Steiner points as they were inserted), so two tets that touch sit megabytes apart
//! in memory. Every pass over the mesh (building the face links, `validate`, the checks of
//! `info`) and every query of a tool's neighbourhood (the drill's candidate zone, the contact
//! search) then misses the cache on almost every neighbour. Renumbering along a space-filling
//! curve puts neighbours next to each other: on a 2-million-tet TetGen mesh `info` runs about
//! twice as fast (docs/TIMING.md). The file's numbering is kept beside the mesh
//! ([`LoadedMesh::file_nodes`](crate::LoadedMesh::file_nodes),
//! [`LoadedMesh::file_tets`](crate::LoadedMesh::file_tets)) for callers that must map back.

use tetradrill_core::Vec3;

/// Bits per axis of the Morton key (3 x 21 = 63 bits).
const BITS: u32 = 21;

/// Spreads the low 21 bits of `v` so that bit `i` lands on bit `3 i`.
fn spread(v: u64) -> u64 {
    let mut x = v & 0x1f_ffff;
    x = (x | x << 32) & 0x001f_0000_0000_ffff;
    x = (x | x << 16) & 0x001f_0000_ff00_00ff;
    x = (x | x << 8) & 0x100f_00f0_0f00_f00f;
    x = (x | x << 4) & 0x10c3_0c30_c30c_30c3;
    x = (x | x << 2) & 0x1249_2492_4924_9249;
    x
}

/// The node order: `order[new] = old`, nodes sorted by the Morton key of their position in the
/// bounding box (ties by old index, so the order is deterministic).
///
/// O(N log N). Non-finite coordinates sort as the box's low corner (the build rejects them).
pub fn node_order(positions: &[Vec3]) -> Vec<u32> {
    let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    for p in positions.iter().filter(|p| p.is_finite()) {
        lo = lo.min(*p);
        hi = hi.max(*p);
    }
    let extent = (hi - lo).max_element();
    let cells = (1u64 << BITS) as f32 - 1.0;
    let inv = if extent > 0.0 { cells / extent } else { 0.0 };
    let quantise = |c: f32, l: f32| {
        let q = (c - l) * inv;
        // NaN and negative values go to 0, values past the top to the last cell.
        if q >= 0.0 {
            (q.min(cells)) as u64
        } else {
            0
        }
    };
    let mut keys: Vec<u128> = positions
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let key = spread(quantise(p.x, lo.x))
                | spread(quantise(p.y, lo.y)) << 1
                | spread(quantise(p.z, lo.z)) << 2;
            u128::from(key) << 32 | i as u128
        })
        .collect();
    keys.sort_unstable();
    keys.into_iter().map(|k| k as u32).collect()
}

/// The tet order: `order[new] = old`, tets sorted by their smallest node id (nodes already in
/// [`node_order`]), ties by old index.
///
/// O(T log T).
pub fn tet_order(tets: &[[u32; 4]]) -> Vec<u32> {
    let mut keys: Vec<u64> = tets
        .iter()
        .enumerate()
        .map(|(i, t)| {
            let first = t.iter().copied().min().unwrap_or(0);
            u64::from(first) << 32 | i as u64
        })
        .collect();
    keys.sort_unstable();
    keys.into_iter().map(|k| k as u32).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Bit interleaving checked bit by bit against its definition.
    #[test]
    fn spread_puts_bit_i_at_3i() {
        for v in [0u64, 1, 2, 0x15_5555, 0x1f_ffff, 0x12_3456, 0x0a_bcde] {
            let s = spread(v);
            for i in 0..64 {
                let want = i % 3 == 0 && i / 3 < 21 && v >> (i / 3) & 1 == 1;
                assert_eq!(s >> i & 1 == 1, want, "v {v:#x} bit {i}");
            }
        }
    }

    /// Both orders are permutations, and nodes of one octant come before the next octant's.
    #[test]
    fn orders_are_permutations_in_z_order() {
        let mut positions = Vec::new();
        for i in 0..512u32 {
            // A scrambled 8x8x8 grid.
            let j = (i * 389) % 512;
            positions.push(Vec3::new(
                (j % 8) as f32,
                (j / 8 % 8) as f32,
                (j / 64) as f32,
            ));
        }
        let order = node_order(&positions);
        let mut seen = vec![false; positions.len()];
        for &o in &order {
            assert!(!std::mem::replace(&mut seen[o as usize], true));
        }
        // Z-order visits the 2x2x2 blocks one at a time: each run of 8 is one block.
        for run in order.chunks(8) {
            let first = positions[run[0] as usize];
            for &o in run {
                let p = positions[o as usize];
                assert_eq!((p / 2.0).floor(), (first / 2.0).floor(), "run {run:?}");
            }
        }
        let tets: Vec<[u32; 4]> = (0..100u32)
            .map(|i| [(i * 37) % 101, 200, 300, 400])
            .collect();
        let t = tet_order(&tets);
        let firsts: Vec<u32> = t.iter().map(|&i| tets[i as usize][0]).collect();
        assert!(firsts.windows(2).all(|w| w[0] < w[1]), "{firsts:?}");
    }
}
