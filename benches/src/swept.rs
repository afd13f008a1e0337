//! The drill bench's convergence case: a burr path with a 0.5 s hold (the shape of
//! `scripts/clinical-drill.sh`'s path) and a Monte Carlo estimate of the volume it sweeps
//! through the mesh, computed in f64 from the mesh's tet corners (point in tet by barycentric
//! signs over a uniform grid), to print the drill's removed volume beside.

use glam::Vec3;
use tetradrill_core::mesh::Mesh;
use tetradrill_core::TetId;

use crate::Lcg;

type D3 = [f64; 3];

/// The burr's centre at every tick, scaled by its radius `r`: from `5r/3` above the mesh's
/// highest node down to `r` below it in 1,000 ticks, then `10r/3` along x in 2,000 ticks, then
/// held for `hold` ticks.
pub fn hold_path(mesh: &Mesh<'_>, r: f32, hold: usize) -> Vec<Vec3> {
    let top = mesh
        .positions()
        .iter()
        .copied()
        .fold(Vec3::splat(f32::MIN), |a, p| if p.z > a.z { p } else { a });
    let mut out = Vec::new();
    for i in 0..1000 {
        let t = i as f32 / 1000.0;
        out.push(top + Vec3::Z * r * (5.0 / 3.0 - 8.0 / 3.0 * t));
    }
    for i in 0..2000 {
        let t = i as f32 / 2000.0;
        out.push(top + Vec3::new(10.0 / 3.0 * r * t, 0.0, -r));
    }
    let end = top + Vec3::new(10.0 / 3.0 * r, 0.0, -r);
    out.extend(std::iter::repeat_n(end, hold + 1));
    out
}

fn sub(a: D3, b: D3) -> D3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn dot(a: D3, b: D3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn det(a: D3, b: D3, c: D3, d: D3) -> f64 {
    let (u, v, w) = (sub(b, a), sub(c, a), sub(d, a));
    u[0] * (v[1] * w[2] - v[2] * w[1]) - u[1] * (v[0] * w[2] - v[2] * w[0])
        + u[2] * (v[0] * w[1] - v[1] * w[0])
}

fn in_tet(p: &[D3; 4], x: D3) -> bool {
    let total = det(p[0], p[1], p[2], p[3]);
    let eps = -1e-12 * total.abs();
    [
        det(x, p[1], p[2], p[3]),
        det(p[0], x, p[2], p[3]),
        det(p[0], p[1], x, p[3]),
        det(p[0], p[1], p[2], x),
    ]
    .iter()
    .all(|&v| v * total.signum() >= eps)
}

/// Monte Carlo estimate of the union of the spheres of radius `r` at `centres` intersected with
/// the mesh's solid, from `n` samples of a seeded generator in the box around the spheres:
/// (volume, relative standard error).
pub fn swept_volume(mesh: &Mesh<'_>, centres: &[Vec3], r: f32, n: usize) -> (f64, f64) {
    let d3 = |v: Vec3| [v.x as f64, v.y as f64, v.z as f64];
    let r = r as f64;
    // Centres r/64 apart: the union misses at most r/32,768 of the swept surface's depth.
    let mut kept: Vec<D3> = Vec::new();
    for c in centres.iter().map(|&c| d3(c)) {
        if kept
            .last()
            .is_none_or(|&k| dot(sub(c, k), sub(c, k)) >= (r / 64.0).powi(2))
        {
            kept.push(c);
        }
    }
    if let Some(&last) = centres.last() {
        kept.push(d3(last));
    }
    let mut lo = [f64::MAX; 3];
    let mut hi = [f64::MIN; 3];
    for c in &kept {
        for a in 0..3 {
            lo[a] = lo[a].min(c[a] - r);
            hi[a] = hi[a].max(c[a] + r);
        }
    }
    const G: usize = 32;
    let cell = |x: f64, a: usize| {
        (((x - lo[a]) / (hi[a] - lo[a]) * G as f64).floor() as i64).clamp(0, G as i64 - 1) as usize
    };
    let mut grid: Vec<Vec<[D3; 4]>> = vec![Vec::new(); G * G * G];
    for t in 0..mesh.tet_count() {
        let p = mesh.tet_positions(TetId::from_idx(t)).map(d3);
        let tl: D3 = core::array::from_fn(|a| p.iter().map(|q| q[a]).fold(f64::MAX, f64::min));
        let th: D3 = core::array::from_fn(|a| p.iter().map(|q| q[a]).fold(f64::MIN, f64::max));
        if (0..3).any(|a| th[a] < lo[a] || tl[a] > hi[a]) {
            continue;
        }
        for x in cell(tl[0], 0)..=cell(th[0], 0) {
            for y in cell(tl[1], 1)..=cell(th[1], 1) {
                for z in cell(tl[2], 2)..=cell(th[2], 2) {
                    grid[(x * G + y) * G + z].push(p);
                }
            }
        }
    }
    let mut rng = Lcg(0x5eed_d811);
    let mut unit = || {
        // Two draws of 24 bits: 48 bits of resolution in the box.
        let a = rng.unit() as f64;
        let b = rng.unit() as f64;
        a + b / (1u64 << 24) as f64
    };
    let mut hits = 0usize;
    for _ in 0..n {
        let x: D3 = core::array::from_fn(|a| lo[a] + (hi[a] - lo[a]) * unit());
        if !kept.iter().any(|c| dot(sub(x, *c), sub(x, *c)) <= r * r) {
            continue;
        }
        let g = &grid[(cell(x[0], 0) * G + cell(x[1], 1)) * G + cell(x[2], 2)];
        if g.iter().any(|p| in_tet(p, x)) {
            hits += 1;
        }
    }
    let p = hits as f64 / n as f64;
    let boxv: f64 = (0..3).map(|a| hi[a] - lo[a]).product();
    (boxv * p, ((1.0 - p) / (n as f64 * p)).sqrt())
}
