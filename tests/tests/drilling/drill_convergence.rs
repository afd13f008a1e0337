//! The drill converges as fast at depth 6 as at depth 5: a burr path that ends with a 0.5 s
//! hold removes, at both depths, within 5 % of the volume it swept, within the default per-tick
//! budget.
//!
//! Oracle: a Monte Carlo estimate, written here in f64 and sharing no code with the core, of
//! the union of the burr spheres over the path's tick positions intersected with the mesh's
//! solid (point in tet by barycentric signs over a uniform grid of the tets near the path, read
//! from the TetGen files by this file's own parser). 1,000,000 samples from a seeded generator in
//! the box around the spheres: the estimate's relative standard error, `sqrt((1 - p) / (n p))`
//! for the fraction `p` of samples that hit, is computed and checked to be under 0.5 %.

use tetradrill::engine;
use tetradrill::scenario::Scenario;
use tetradrill::traces::Pose;
use tetradrill_core::force::ToolState;
use tetradrill_core::script::DRILL_ON;
use tetradrill_core::Vec3;

type D3 = [f64; 3];

/// Nodes and tets of a TetGen mesh, read here (the first row of each file holds the count).
fn read_tetgen(rel: &str) -> (Vec<D3>, Vec<[usize; 4]>) {
    let node = tetradrill_tests::mesh(rel);
    let rows = |p: &std::path::Path| -> Vec<Vec<f64>> {
        std::fs::read_to_string(p)
            .unwrap()
            .lines()
            .map(|l| l.split('#').next().unwrap_or("").trim().to_string())
            .filter(|l| !l.is_empty())
            .map(|l| l.split_whitespace().map(|w| w.parse().unwrap()).collect())
            .collect()
    };
    let nr = rows(&node);
    let er = rows(&node.with_extension("ele"));
    let n = nr[0][0] as usize;
    let base = nr[1][0] as usize;
    let nodes = nr[1..=n].iter().map(|r| [r[1], r[2], r[3]]).collect();
    let m = er[0][0] as usize;
    let tets = er[1..=m]
        .iter()
        .map(|r| core::array::from_fn(|k| r[k + 1] as usize - base))
        .collect();
    (nodes, tets)
}

/// The burr's centre at every tick, in the shape of `scripts/clinical-drill.sh`'s path scaled
/// by the radius `r`: from `5r/3` above the mesh's highest node down to `r` below it in 1 s,
/// then `10r/3` along x in 2 s, then held for `hold` ticks.
fn path(nodes: &[D3], r: f64, hold: usize) -> Vec<D3> {
    let top = nodes
        .iter()
        .copied()
        .fold([0.0, 0.0, f64::MIN], |a, p| if p[2] > a[2] { p } else { a });
    let mut out = Vec::new();
    for i in 0..1000 {
        let t = i as f64 / 1000.0;
        out.push([top[0], top[1], top[2] + r * (5.0 / 3.0 - 8.0 / 3.0 * t)]);
    }
    for i in 0..2000 {
        let t = i as f64 / 2000.0;
        out.push([top[0] + 10.0 / 3.0 * r * t, top[1], top[2] - r]);
    }
    let end = [top[0] + 10.0 / 3.0 * r, top[1], top[2] - r];
    out.extend(std::iter::repeat_n(end, hold + 1));
    out
}

fn sub(a: D3, b: D3) -> D3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
fn dot(a: D3, b: D3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
fn cross(a: D3, b: D3) -> D3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// `x` inside the tet `p` (closed, with a relative tolerance for points on a shared face).
fn in_tet(p: &[D3; 4], x: D3) -> bool {
    let vol = |a: D3, b: D3, c: D3, d: D3| dot(sub(b, a), cross(sub(c, a), sub(d, a)));
    let total = vol(p[0], p[1], p[2], p[3]);
    let eps = -1e-12 * total.abs();
    let parts = [
        vol(x, p[1], p[2], p[3]),
        vol(p[0], x, p[2], p[3]),
        vol(p[0], p[1], x, p[3]),
        vol(p[0], p[1], p[2], x),
    ];
    parts.iter().all(|&v| v * total.signum() >= eps)
}

/// splitmix64: a seeded generator of doubles in `[0, 1)`.
struct Rng(u64);
impl Rng {
    fn unit(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// Monte Carlo estimate of the union of the spheres of radius `r` at `centres`, intersected
/// with the mesh: (volume, relative standard error).
fn swept_volume(nodes: &[D3], tets: &[[usize; 4]], centres: &[D3], r: f64, n: usize) -> (f64, f64) {
    // Centres closer than r/64 to the last one kept add nothing measurable (the union of
    // spheres r/64 apart misses at most r/32,768 of the swept surface's depth).
    let mut kept: Vec<D3> = Vec::new();
    for &c in centres {
        if kept
            .last()
            .is_none_or(|&k| dot(sub(c, k), sub(c, k)) >= (r / 64.0).powi(2))
        {
            kept.push(c);
        }
    }
    if let Some(&last) = centres.last() {
        kept.push(last);
    }
    let mut lo = [f64::MAX; 3];
    let mut hi = [f64::MIN; 3];
    for c in &kept {
        for a in 0..3 {
            lo[a] = lo[a].min(c[a] - r);
            hi[a] = hi[a].max(c[a] + r);
        }
    }
    // The tets meeting the box, on a grid of 32^3 cells over it.
    const G: usize = 32;
    let cell = |x: f64, a: usize| {
        (((x - lo[a]) / (hi[a] - lo[a]) * G as f64).floor() as i64).clamp(0, G as i64 - 1) as usize
    };
    let mut grid: Vec<Vec<usize>> = vec![Vec::new(); G * G * G];
    for (i, t) in tets.iter().enumerate() {
        let p = t.map(|k| nodes[k]);
        let tl: D3 = core::array::from_fn(|a| p.iter().map(|q| q[a]).fold(f64::MAX, f64::min));
        let th: D3 = core::array::from_fn(|a| p.iter().map(|q| q[a]).fold(f64::MIN, f64::max));
        if (0..3).any(|a| th[a] < lo[a] || tl[a] > hi[a]) {
            continue;
        }
        for x in cell(tl[0], 0)..=cell(th[0], 0) {
            for y in cell(tl[1], 1)..=cell(th[1], 1) {
                for z in cell(tl[2], 2)..=cell(th[2], 2) {
                    grid[(x * G + y) * G + z].push(i);
                }
            }
        }
    }
    let mut rng = Rng(0x5eed_d811);
    let r2 = r * r;
    let mut hits = 0usize;
    for _ in 0..n {
        let x: D3 = core::array::from_fn(|a| lo[a] + (hi[a] - lo[a]) * rng.unit());
        if !kept.iter().any(|c| dot(sub(x, *c), sub(x, *c)) <= r2) {
            continue;
        }
        let g = &grid[(cell(x[0], 0) * G + cell(x[1], 1)) * G + cell(x[2], 2)];
        if g.iter().any(|&i| in_tet(&tets[i].map(|k| nodes[k]), x)) {
            hits += 1;
        }
    }
    let p = hits as f64 / n as f64;
    let box_volume = (0..3).map(|a| hi[a] - lo[a]).product::<f64>();
    (box_volume * p, ((1.0 - p) / (n as f64 * p)).sqrt())
}

/// The removed volume after the burr of radius `r` follows `centres` with the drill on, at
/// `max_depth`, the default budgets and buffers (as `tetradrill replay`).
fn drill(mesh: &str, r: f64, max_depth: u8, centres: &[D3]) -> f64 {
    let sc = Scenario {
        mesh: tetradrill_tests::mesh(mesh).display().to_string(),
        tool: format!("sphere:{r}"),
        max_depth,
        // Depth alone decides here (no drill resolution).
        resolution: Some(0.0),
        ..Scenario::default()
    }
    .setup()
    .expect("a valid set-up");
    let (params, mut store) = tetradrill_tests::engine_storage(&sc);
    let mut world = store.world().expect("world");
    let mut tool = ToolState::default();
    for c in centres {
        let pose = Pose {
            position: Vec3::new(c[0] as f32, c[1] as f32, c[2] as f32),
            rotation: [1.0, 0.0, 0.0, 0.0],
            buttons: DRILL_ON,
        };
        engine::tick(&mut world, &mut tool, &params, &pose);
    }
    assert_eq!(world.saturations().total(), world.saturations().contact);
    world.hierarchy().removed_volume()
}

/// The cow, a burr of 0.03 (its tets are about 0.05 across): the path's work at depth 6 is
/// more than its ticks' budget, so the order the work is done in decides what is removed by the
/// end of the hold.
#[test]
fn a_path_with_a_half_second_hold_removes_its_swept_volume_at_depths_5_and_6() {
    let mesh = "models/spot_tetgen_q1.414.node";
    let (nodes, tets) = read_tetgen(mesh);
    let r = 0.03;
    let centres = path(&nodes, r, 500);
    let (reference, se) = swept_volume(&nodes, &tets, &centres, r, 1_000_000);
    assert!(se < 0.005, "standard error {se}");
    for depth in [5, 6] {
        let removed = drill(mesh, r, depth, &centres);
        let ratio = removed / reference;
        println!("depth {depth}: removed {removed:.6e}, reference {reference:.6e} (se {:.2} %), ratio {ratio:.4}", se * 100.0);
        assert!(
            (ratio - 1.0).abs() < 0.05,
            "depth {depth}: removed {removed:.6e} against {reference:.6e} swept ({ratio:.4})"
        );
    }
}
