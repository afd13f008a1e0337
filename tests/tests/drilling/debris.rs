//! Debris: after a drilled groove, the pieces of remaining material too small to see are erased
//! and the pieces left are counted; an independent count (a flood fill over a voxelisation of
//! the remaining leaves, with the tests' own f64 leaf geometry and point-in-tet) agrees.
//!
//! Tolerance rule for thin contacts: the hierarchy joins leaves across shared faces only, the
//! voxels join 6-neighbours. Two pieces meeting only along an edge or at a corner are two
//! pieces in the hierarchy but can share a voxel neighbourhood. The oracle counts voxel pieces
//! of at least `K` max-depth leaves' worth of voxels (smaller ones are the debris it discounts)
//! at a voxel edge of a quarter of the smallest max-depth leaf's edge, and the counts must be
//! equal; a scenario whose pieces touch only along edges would need the rule relaxed (none
//! of those below does: the groove's walls meet the main body across faces).

use std::collections::{HashSet, VecDeque};
use std::path::Path;

use tetradrill::engine::{self, EngineStorage, TickParams};
use tetradrill::scenario::Scenario;
use tetradrill::setup::Setup;
use tetradrill::traces::PoseSource;
use tetradrill_core::force::ToolState;
use tetradrill_core::hierarchy::{
    CrumbStats, Crumbs, DebrisReport, Hierarchy, CRUMB_SEEDS, DEBRIS_LEAVES,
};
use tetradrill_core::mesh::Mesh;
use tetradrill_core::servo::World;
use tetradrill_core::TetId;
use tetradrill_tests::drill::{block_mesh, check_visible, contains, det, leaves, LeafG, Store};
use tetradrill_tests::oracle::D3;
use tetradrill_tests::scratch_dir;

/// A groove along x over the top face (z = 0.5) of the unit block, the burr's centre `depth`
/// below the face, drill on, then held for 300 ticks.
fn write_groove(dir: &Path, name: &str, depth: f64) -> String {
    let z = 0.5 - depth;
    let csv = format!(
        "t,x,y,z,qw,qx,qy,qz,buttons\n0,-0.3,0.05,0.7,1,0,0,0,0\n0.2,-0.3,0.05,{z},1,0,0,0,1\n\
         1.4,0.3,0.05,{z},1,0,0,0,1\n1.7,0.3,0.05,{z},1,0,0,0,1\n"
    );
    let path = dir.join(name);
    std::fs::write(&path, csv).expect("write the groove");
    path.to_string_lossy().into_owned()
}

/// Voxel pieces of the remaining material: every non-erased leaf's tet (f64, the tests' own
/// descent) rasterised at voxel centres of edge `h`, 6-connected flood fill; pieces of fewer
/// than `min_voxels` voxels are not counted.
fn voxel_pieces(mesh: &Mesh<'_>, h: &Hierarchy<'_>, edge: f64, min_voxels: usize) -> usize {
    let all = leaves(mesh, h, 0..mesh.tet_count());
    let (mut lo, mut hi) = ([f64::MAX; 3], [f64::MIN; 3]);
    for l in all.iter().filter(|l| !l.erased) {
        for p in &l.p {
            for a in 0..3 {
                lo[a] = lo[a].min(p[a]);
                hi[a] = hi[a].max(p[a]);
            }
        }
    }
    let n: Vec<usize> = (0..3)
        .map(|a| ((hi[a] - lo[a]) / edge).ceil() as usize + 1)
        .collect();
    let idx = |i: usize, j: usize, k: usize| (k * n[1] + j) * n[0] + i;
    let mut full = vec![false; n[0] * n[1] * n[2]];
    for l in all.iter().filter(|l| !l.erased) {
        let (mut a, mut b) = ([f64::MAX; 3], [f64::MIN; 3]);
        for p in &l.p {
            for c in 0..3 {
                a[c] = a[c].min(p[c]);
                b[c] = b[c].max(p[c]);
            }
        }
        let r = |c: usize| {
            let s = ((a[c] - lo[c]) / edge - 0.5).floor().max(0.0) as usize;
            let e = (((b[c] - lo[c]) / edge - 0.5).ceil() as usize).min(n[c] - 1);
            s..=e
        };
        for k in r(2) {
            for j in r(1) {
                for i in r(0) {
                    let x = [
                        lo[0] + (i as f64 + 0.5) * edge,
                        lo[1] + (j as f64 + 0.5) * edge,
                        lo[2] + (k as f64 + 0.5) * edge,
                    ];
                    if contains(&l.p, x) {
                        full[idx(i, j, k)] = true;
                    }
                }
            }
        }
    }
    let mut seen = vec![false; full.len()];
    let mut pieces = 0;
    let mut queue = VecDeque::new();
    for start in 0..full.len() {
        if !full[start] || seen[start] {
            continue;
        }
        seen[start] = true;
        queue.push_back(start);
        let mut size = 0usize;
        while let Some(v) = queue.pop_front() {
            size += 1;
            let (i, j, k) = (v % n[0], (v / n[0]) % n[1], v / (n[0] * n[1]));
            let mut near = Vec::with_capacity(6);
            if i > 0 {
                near.push(idx(i - 1, j, k));
            }
            if i + 1 < n[0] {
                near.push(idx(i + 1, j, k));
            }
            if j > 0 {
                near.push(idx(i, j - 1, k));
            }
            if j + 1 < n[1] {
                near.push(idx(i, j + 1, k));
            }
            if k > 0 {
                near.push(idx(i, j, k - 1));
            }
            if k + 1 < n[2] {
                near.push(idx(i, j, k + 1));
            }
            for w in near {
                if full[w] && !seen[w] {
                    seen[w] = true;
                    queue.push_back(w);
                }
            }
        }
        if size >= min_voxels {
            pieces += 1;
        }
    }
    pieces
}

struct Groove {
    before: u32,
    after: u32,
    erased_pieces: u32,
    erased_nodes: u32,
    voxels_before: usize,
    voxels_after: usize,
}

fn groove(trace: &str, mesh: &str, radius: f64, max_depth: u8) -> Groove {
    let sc = Scenario {
        mesh: mesh.into(),
        trace: trace.into(),
        tool: format!("sphere:{radius}"),
        max_depth,
        // Depth alone decides here (no drill resolution).
        resolution: Some(0.0),
        ..Scenario::default()
    }
    .setup()
    .expect("a valid set-up");
    let params = TickParams::of(&sc).expect("scenario");
    let loaded = engine::load_mesh(&sc).expect("mesh");
    let poses = PoseSource::new(&sc.poses, Some(&loaded.mesh)).expect("trace");
    let mut store = EngineStorage::new(loaded.mesh, &sc).expect("storage");
    let mut world = store.world().expect("world");
    world.set_debris_leaves(0);
    let mut tool = ToolState::default();
    for i in 0..poses.ticks() {
        engine::tick(&mut world, &mut tool, &params, &poses.at(i));
    }
    assert_eq!(world.pending(), 0, "the drill caught up");
    let mut scratch = vec![0u32; world.hierarchy().debris_scratch_needed()];
    let before = world
        .hierarchy()
        .components(world.mesh(), &mut scratch)
        .expect("scratch");
    // The smallest max-depth leaf's edge: the voxel edge is a quarter of it.
    let mut leaf_edge = f64::MAX;
    for t in 0..world.mesh().tet_count() {
        let p = world
            .mesh()
            .tet_positions(tetradrill_core::TetId::from_idx(t));
        for a in 0..4 {
            for b in a + 1..4 {
                leaf_edge = leaf_edge.min(f64::from((p[a] - p[b]).length()));
            }
        }
    }
    let leaf_edge = leaf_edge / f64::from(1u32 << max_depth);
    let edge = leaf_edge / 4.0;
    // A max-depth leaf holds about (its volume / voxel volume) voxels; the block's leaves are
    // at least a sixth of the cube of their edge.
    let per_leaf = (leaf_edge.powi(3) / 6.0 / edge.powi(3)) as usize;
    let min_voxels = DEBRIS_LEAVES as usize * per_leaf;
    let voxels_before = voxel_pieces(world.mesh(), world.hierarchy(), edge, 1);
    let removed = world.hierarchy().removed_volume();
    let rep = world
        .remove_debris(DEBRIS_LEAVES, max_depth, &mut scratch)
        .expect("scratch");
    engine::validate(&world).expect("valid after the debris is erased");
    let after = world
        .hierarchy()
        .components(world.mesh(), &mut scratch)
        .expect("scratch");
    assert_eq!(rep.components, after);
    assert_eq!(before - rep.pieces, after);
    assert!(
        (world.hierarchy().removed_volume() - removed - rep.volume).abs() < 1e-12,
        "the debris is in the removed volume"
    );
    let voxels_after = voxel_pieces(world.mesh(), world.hierarchy(), edge, min_voxels);
    Groove {
        before,
        after,
        erased_pieces: rep.pieces,
        erased_nodes: rep.nodes,
        voxels_before,
        voxels_after,
    }
}

#[test]
fn a_clean_groove_keeps_its_one_piece() {
    let dir = scratch_dir("debris", "groove");
    let trace = write_groove(&dir, "groove.csv", 0.05);
    let g = groove(&trace, "builtin:block:4", 0.1, 3);
    eprintln!(
        "groove: {} pieces before ({} by voxels), {} erased ({} leaves), {} after ({} by voxels)",
        g.before, g.voxels_before, g.erased_pieces, g.erased_nodes, g.after, g.voxels_after
    );
    assert_eq!((g.before, g.erased_pieces, g.after), (1, 0, 1));
    assert_eq!(g.after as usize, g.voxels_after);
}

/// The centroid of a leaf.
fn centroid(l: &LeafG) -> D3 {
    let mut c = [0.0; 3];
    for p in &l.p {
        for a in 0..3 {
            c[a] += p[a] / 4.0;
        }
    }
    c
}

/// The unit block `[0, 1]^3` (48 tets) refined to depth 2, a slab `0.3 < x < 0.7` (by leaf
/// centroid) erased but for the leaves nearest to `crumbs`: two halves and the crumbs.
fn cut_with_crumbs<'a>(mesh: &Mesh<'_>, st: &'a mut Store, crumbs: &[D3]) -> Hierarchy<'a> {
    cut_with_crumbs_then(mesh, st, crumbs, |_, _, _| {})
}

/// [`cut_with_crumbs`] calling `after(h, tet, index)` after each erasure.
fn cut_with_crumbs_then<'a>(
    mesh: &Mesh<'_>,
    st: &'a mut Store,
    crumbs: &[D3],
    mut after: impl FnMut(&mut Hierarchy<'_>, TetId, u32),
) -> Hierarchy<'a> {
    let mut h = st.hierarchy(mesh);
    for t in 0..mesh.tet_count() {
        let tet = TetId::from_idx(t);
        h.refine(mesh, tet, 0).unwrap();
        for c in 1..=8 {
            h.refine(mesh, tet, c).unwrap();
        }
    }
    let all = leaves(mesh, &h, 0..mesh.tet_count());
    let d2 = |a: D3, b: D3| (0..3).map(|i| (a[i] - b[i]).powi(2)).sum::<f64>();
    let keep: Vec<usize> = crumbs
        .iter()
        .map(|&x| {
            (0..all.len())
                .min_by(|&a, &b| d2(centroid(&all[a]), x).total_cmp(&d2(centroid(&all[b]), x)))
                .unwrap()
        })
        .collect();
    for (i, l) in all.iter().enumerate() {
        let x = centroid(l)[0];
        if x > 0.3 && x < 0.7 && !keep.contains(&i) {
            h.erase(mesh, l.tet, l.index).unwrap();
            after(&mut h, l.tet, l.index);
        }
    }
    h.validate(mesh).unwrap();
    h
}

/// The tests' own volume of the non-erased leaves (f64 corners).
fn material(mesh: &Mesh<'_>, h: &Hierarchy<'_>) -> f64 {
    leaves(mesh, h, 0..mesh.tet_count())
        .iter()
        .filter(|l| !l.erased)
        .map(|l| det(&l.p).abs() / 6.0)
        .sum()
}

#[test]
fn crumbs_are_erased_and_the_pieces_a_user_sees_are_counted() {
    let mut om = block_mesh(2, 0.5);
    let mesh = om.view();
    let mut st = Store::new(mesh.tet_count(), 8 * 48 * 9);
    let crumbs = [[0.5, 0.5, 0.5], [0.5, 0.2, 0.8], [0.45, 0.8, 0.25]];
    let mut h = cut_with_crumbs(&mesh, &mut st, &crumbs);
    let mut scratch = vec![0u32; h.debris_scratch_needed()];
    let before = h.components(&mesh, &mut scratch).unwrap();
    // A leaf of depth 2 has an edge of an eighth of the block's 0.5 tet edges (some are
    // diagonals, longer); a quarter of that is the voxel.
    let leaf_edge = 0.5f64 / 4.0;
    let edge = leaf_edge / 4.0;
    let per_leaf = (leaf_edge.powi(3) / 6.0 / edge.powi(3)) as usize;
    assert_eq!(before, 2 + crumbs.len() as u32);
    assert_eq!(voxel_pieces(&mesh, &h, edge, 1), before as usize);
    let material_before = material(&mesh, &h);
    let removed_before = h.removed_volume();
    let rep = h
        .remove_debris(&mesh, DEBRIS_LEAVES, 2, &mut scratch)
        .unwrap();
    h.validate(&mesh).unwrap();
    assert_eq!(rep.pieces, crumbs.len() as u32);
    assert_eq!(rep.nodes, crumbs.len() as u32);
    assert_eq!(rep.components, 2);
    assert_eq!(h.components(&mesh, &mut scratch).unwrap(), 2);
    let min_voxels = DEBRIS_LEAVES as usize * per_leaf;
    assert_eq!(voxel_pieces(&mesh, &h, edge, min_voxels), 2);
    assert_eq!(
        voxel_pieces(&mesh, &h, edge, 1),
        2,
        "nothing smaller is left"
    );
    // The erased volume is what the tests' own geometry lost, and in the removed volume.
    let lost = material_before - material(&mesh, &h);
    assert!((rep.volume - lost).abs() < 1e-9, "{} vs {lost}", rep.volume);
    assert!((h.removed_volume() - removed_before - rep.volume).abs() < 1e-12);
    let check: HashSet<usize> = (0..mesh.tet_count()).collect();
    check_visible(&mesh, &h, &check);
    // Again: nothing left to erase.
    let again = h
        .remove_debris(&mesh, DEBRIS_LEAVES, 2, &mut scratch)
        .unwrap();
    assert_eq!((again.pieces, again.nodes, again.components), (0, 0, 2));
}

#[test]
fn the_size_limit_and_the_largest_piece_decide() {
    let mut om = block_mesh(2, 0.5);
    let mesh = om.view();
    let crumbs = [[0.5, 0.5, 0.5]];
    // A limit of one leaf: a one-leaf crumb is not below it and stays.
    let mut st = Store::new(mesh.tet_count(), 8 * 48 * 9);
    let mut h = cut_with_crumbs(&mesh, &mut st, &crumbs);
    let mut scratch = vec![0u32; h.debris_scratch_needed()];
    let rep = h.remove_debris(&mesh, 1, 2, &mut scratch).unwrap();
    assert_eq!((rep.pieces, rep.components), (0, 3));
    // Two leaves: it goes.
    let rep = h.remove_debris(&mesh, 2, 2, &mut scratch).unwrap();
    assert_eq!((rep.pieces, rep.nodes, rep.components), (1, 1, 2));
    // No limit: only the largest piece stays, and the erased half is the smaller one.
    let left = material(&mesh, &h);
    let rep = h.remove_debris(&mesh, u32::MAX, 2, &mut scratch).unwrap();
    h.validate(&mesh).unwrap();
    assert_eq!((rep.pieces, rep.components), (1, 1));
    let kept = material(&mesh, &h);
    // The core's leaf volumes come from f32 corners: 1e-6 relative.
    assert!(
        (left - kept - rep.volume).abs() < 1e-6 * rep.volume,
        "{left} {kept} {}",
        rep.volume
    );
    // (The halves are equal here: the tie goes to the piece of the smaller node reference.)
    assert!(
        kept >= rep.volume * (1.0 - 1e-6),
        "the larger half stays: {kept} vs {}",
        rep.volume
    );
    // A short scratch is refused and changes nothing.
    let n = h.debris_scratch_needed();
    assert!(h
        .remove_debris(&mesh, u32::MAX, 2, &mut scratch[..n - 1])
        .is_err());
}

/// The cow (18,098 tets) and 4 s of a seeded wander with a 0.05 burr, the drill on, the
/// drill's own debris checks on or off; `then` gets the world after the last tick.
fn cow_wander(
    checks: bool,
    then: impl FnOnce(&Setup, &mut World<'_>, &mut ToolState, &TickParams, &PoseSource),
) {
    cow_wander_at(checks, None, then);
}

/// [`cow_wander`] at a drill resolution (`--resolution L --max-depth 9`), if given.
fn cow_wander_at(
    checks: bool,
    resolution: Option<f64>,
    then: impl FnOnce(&Setup, &mut World<'_>, &mut ToolState, &TickParams, &PoseSource),
) {
    let sc = Scenario {
        mesh: tetradrill_tests::mesh("models/spot_tetgen_q1.414.node")
            .to_string_lossy()
            .into_owned(),
        trace: "wander:1".into(),
        tool: "sphere:0.05".into(),
        resolution: Some(resolution.unwrap_or(0.0)),
        max_depth: if resolution.is_some() { 9 } else { 5 },
        ..Scenario::default()
    }
    .setup()
    .expect("a valid set-up");
    let params = TickParams::of(&sc).expect("scenario");
    let loaded = engine::load_mesh(&sc).expect("mesh");
    let poses = PoseSource::new(&sc.poses, Some(&loaded.mesh)).expect("trace");
    let mut store = EngineStorage::new(loaded.mesh, &sc).expect("storage");
    let mut world = store.world().expect("world");
    if !checks {
        world.set_debris_leaves(0);
    }
    let mut tool = ToolState::default();
    for i in 0..4000 {
        engine::tick(&mut world, &mut tool, &params, &poses.at(i));
    }
    then(&sc, &mut world, &mut tool, &params, &poses);
}

/// The cow (18,098 tets) after 4 s of a seeded wander with the drill on: the crumbs the
/// drill leaves are counted as pieces until they are erased, and then one piece is left.
#[test]
fn the_cow_after_a_wander_is_one_piece_once_its_crumbs_are_erased() {
    cow_wander(false, |sc, world, _, _, _| {
        let (before, rep) = sweep(sc, world);
        engine::validate(world).expect("valid");
        eprintln!(
            "cow wander: {before} pieces, {} erased ({} leaves, volume {:.3e}), {} left",
            rep.pieces, rep.nodes, rep.volume, rep.components
        );
        // The drill leaves crumbs on this path (3 since the coarse and fine passes; 13 before).
        assert!(rep.pieces >= 1, "{}", rep.pieces);
        assert!(rep.nodes < rep.pieces * DEBRIS_LEAVES);
        assert_eq!(before, rep.pieces + 1);
        assert_eq!(rep.components, 1);
        let mut scratch = vec![0u32; world.hierarchy().debris_scratch_needed()];
        assert_eq!(
            world
                .hierarchy()
                .components(world.mesh(), &mut scratch)
                .expect("scratch"),
            1
        );
    });
}

/// The drill's backlog and the checks its budget deferred, done in ticks with the drill off
/// and a budget that lets them finish; then the sweep ([`sweep`]). Returns the checks'
/// figures, the pieces counted before the sweep and the sweep's report.
fn drain_and_sweep(
    sc: &Setup,
    world: &mut World<'_>,
    tool: &mut ToolState,
    params: &TickParams,
    poses: &PoseSource,
) -> (CrumbStats, u32, DebrisReport) {
    let mut still = poses.at(3999);
    still.buttons = 0;
    let mut drain = *params;
    drain.drill.budget = 10_000_000;
    world.set_tick_budget(None);
    let mut extra = 0;
    while (world.debris_pending() > 0 || world.pending() > 0) && extra < 100 {
        engine::tick(world, tool, &drain, &still);
        extra += 1;
    }
    assert_eq!(world.debris_pending(), 0);
    let d = world.debris();
    let (before, rep) = sweep(sc, world);
    (d, before, rep)
}

/// The pieces counted, then the debris swept (`World::remove_debris` with the default size
/// limit): the pieces before and the sweep's report.
fn sweep(sc: &Setup, world: &mut World<'_>) -> (u32, DebrisReport) {
    let mut scratch = vec![0u32; world.hierarchy().debris_scratch_needed()];
    let before = world
        .hierarchy()
        .components(world.mesh(), &mut scratch)
        .expect("scratch");
    let rep = world
        .remove_debris(DEBRIS_LEAVES, sc.drilling.max_depth, &mut scratch)
        .expect("scratch");
    (before, rep)
}

/// With a drill resolution each tree's leaves stop at its own depth limit, above
/// `max_depth`: the debris's unit is then the finest leaf of the tree, not a `max_depth`
/// leaf (counted in `max_depth` leaves, a leaf at the limit would weigh
/// `8^(max_depth - limit)` units and no crumb would ever be small enough). With the drill's
/// checks and then the sweep, the cow's wander at `--resolution 0.00625 --max-depth 9` ends
/// in one piece, every piece erased smaller than the unit's limit.
///
/// Oracle: the pieces counted before and after ([`Hierarchy::components`], the union-find
/// over shared faces the debris tests above check against a voxel flood fill).
#[test]
fn with_a_resolution_the_crumbs_are_erased_too() {
    cow_wander_at(true, Some(0.05 / 8.0), |sc, world, tool, params, poses| {
        assert!(world.drill_resolution() > 0.0);
        let (d, before, rep) = drain_and_sweep(sc, world, tool, params, poses);
        eprintln!("cow wander at a resolution: checks {d:?}; sweep {rep:?}, {before} before");
        assert!(d.pieces + rep.pieces >= 1, "no crumb erased: {d:?} {rep:?}");
        assert!(d.largest < DEBRIS_LEAVES, "{d:?}");
        assert_eq!(before, rep.pieces + 1);
        assert_eq!(rep.components, 1);
        engine::validate(world).expect("valid");
    });
}

/// The checks of [`Crumbs`], fed every erasure of the slab (checked as the queue fills, then
/// to the end): the one-leaf crumbs go, the halves stay, the visible faces stay exact, and the
/// erased volume is what the tests' own geometry lost.
#[test]
fn the_checks_after_each_erasure_erase_the_crumbs_and_nothing_else() {
    let mut om = block_mesh(2, 0.5);
    let mesh = om.view();
    let mut st = Store::new(mesh.tet_count(), 8 * 48 * 9);
    let crumbs = [[0.5, 0.5, 0.5], [0.5, 0.2, 0.8], [0.45, 0.8, 0.25]];
    let mut c = Crumbs::new(DEBRIS_LEAVES);
    let mut noted = Vec::new();
    let mut h = cut_with_crumbs_then(&mesh, &mut st, &crumbs, |h, tet, index| {
        c.note(tet, index);
        if c.is_full() {
            c.forget();
            while c
                .check_one(h, &mesh, 2, |t, v| noted.push((t, v)))
                .is_some()
            {}
        }
    });
    let material_before = material(&mesh, &h);
    let removed_before = h.removed_volume();
    c.forget();
    while c
        .check_one(&mut h, &mesh, 2, |t, v| noted.push((t, v)))
        .is_some()
    {}
    h.validate(&mesh).unwrap();
    let s = c.stats();
    assert_eq!((s.pieces, s.nodes, s.saturations), (3, 3, 0), "{s:?}");
    assert_eq!(s.largest, 1);
    assert_eq!(noted.len(), 3);
    let mut scratch = vec![0u32; h.debris_scratch_needed()];
    assert_eq!(h.components(&mesh, &mut scratch).unwrap(), 2);
    let leaf_edge = 0.5f64 / 4.0;
    let edge = leaf_edge / 4.0;
    assert_eq!(
        voxel_pieces(&mesh, &h, edge, 1),
        2,
        "only the halves are left"
    );
    // Erased at the end (all seeds were checked when the crumbs' last neighbour went).
    let lost = material_before - material(&mesh, &h);
    assert!(lost >= 0.0);
    let total: f64 = noted.iter().map(|n| n.1).sum();
    assert!((total - s.volume).abs() < 1e-12);
    assert!((h.removed_volume() - removed_before - (s.volume - (total - lost))).abs() < 1e-9);
    let check: HashSet<usize> = (0..mesh.tet_count()).collect();
    check_visible(&mesh, &h, &check);
    // The sweep finds nothing more.
    let again = h
        .remove_debris(&mesh, DEBRIS_LEAVES, 2, &mut scratch)
        .unwrap();
    assert_eq!((again.pieces, again.components), (0, 2));
}

/// The size decides: with a limit of one leaf a one-leaf crumb stays; with two it goes.
#[test]
fn the_checks_keep_a_piece_of_the_debris_size() {
    let mut om = block_mesh(2, 0.5);
    let mesh = om.view();
    let crumbs = [[0.5, 0.5, 0.5]];
    for (limit, erased) in [(1u32, 0u32), (2, 1)] {
        let mut st = Store::new(mesh.tet_count(), 8 * 48 * 9);
        let mut seeds = Vec::new();
        let mut h = cut_with_crumbs_then(&mesh, &mut st, &crumbs, |_, t, i| seeds.push((t, i)));
        let mut c = Crumbs::new(limit);
        for chunk in seeds.chunks(CRUMB_SEEDS) {
            for &(t, i) in chunk {
                c.note(t, i);
            }
            c.forget();
            while c.check_one(&mut h, &mesh, 2, |_, _| {}).is_some() {}
        }
        h.validate(&mesh).unwrap();
        assert_eq!(c.stats().pieces, erased, "limit {limit}");
        let mut scratch = vec![0u32; h.components_scratch_needed()];
        assert_eq!(h.components(&mesh, &mut scratch).unwrap(), 3 - erased);
    }
}

/// A drilling sequence with the drill's checks on (the default): every 1000 ticks the pieces
/// the hierarchy counts are the voxel flood fill's pieces above the debris size, and every
/// piece the checks erased was below it (per tick: its leaves, and the largest one).
#[test]
fn while_drilling_the_pieces_counted_are_the_pieces_a_user_sees() {
    let sc = Scenario {
        mesh: "builtin:block:4".into(),
        trace: "wander:1".into(),
        tool: "sphere:0.1".into(),
        max_depth: 3,
        ..Scenario::default()
    }
    .setup()
    .expect("a valid set-up");
    let params = TickParams::of(&sc).expect("scenario");
    let loaded = engine::load_mesh(&sc).expect("mesh");
    let poses = PoseSource::new(&sc.poses, Some(&loaded.mesh)).expect("trace");
    let mut store = EngineStorage::new(loaded.mesh, &sc).expect("storage");
    let mut world = store.world().expect("world");
    assert_eq!(world.debris().pieces, 0);
    let mut tool = ToolState::default();
    // The same drilling with the checks off: the crumbs it leaves show the scenario makes
    // some (so the comparison above can fail).
    let mut store_off =
        EngineStorage::new(engine::load_mesh(&sc).expect("mesh").mesh, &sc).expect("storage");
    let mut off = store_off.world().expect("world");
    off.set_debris_leaves(0);
    let mut tool_off = ToolState::default();
    let mut off_more = 0;
    // The block's tet edges are 0.25 and longer; a quarter of a depth-3 leaf's is the voxel.
    let leaf_edge = 0.25f64 / 8.0;
    let edge = leaf_edge / 4.0;
    let per_leaf = (leaf_edge.powi(3) / 6.0 / edge.powi(3)) as usize;
    let min_voxels = DEBRIS_LEAVES as usize * per_leaf;
    let mut scratch = Vec::new();
    let mut checkpoints = 0;
    let mut last = world.debris();
    for i in 0..12_000u64 {
        let (_, rep) = engine::tick(&mut world, &mut tool, &params, &poses.at(i));
        engine::tick(&mut off, &mut tool_off, &params, &poses.at(i));
        let now = world.debris();
        let (pieces, nodes) = (now.pieces - last.pieces, now.nodes - last.nodes);
        assert_eq!(rep.drill.debris_erased, nodes);
        assert!(
            nodes <= pieces * (DEBRIS_LEAVES - 1),
            "tick {i}: {pieces} pieces, {nodes} leaves"
        );
        last = now;
        if i % 1000 == 999 {
            engine::validate(&world).expect("valid");
            scratch.resize(world.hierarchy().components_scratch_needed(), 0);
            let counted = world
                .hierarchy()
                .components(world.mesh(), &mut scratch)
                .expect("scratch");
            let voxels = voxel_pieces(world.mesh(), world.hierarchy(), edge, min_voxels);
            eprintln!(
                "tick {i}: {counted} piece(s), {voxels} by voxels; {:?}, {} seeds waiting",
                world.debris(),
                world.debris_pending()
            );
            assert_eq!(counted as usize, voxels, "tick {i}");
            checkpoints += 1;
            scratch.resize(off.hierarchy().components_scratch_needed(), 0);
            let raw = off
                .hierarchy()
                .components(off.mesh(), &mut scratch)
                .expect("scratch");
            let seen = voxel_pieces(off.mesh(), off.hierarchy(), edge, min_voxels);
            eprintln!("tick {i}, checks off: {raw} piece(s), {seen} by voxels");
            off_more += usize::from(raw as usize > seen);
        }
    }
    assert_eq!(checkpoints, 12);
    assert!(
        off_more > 0,
        "the checks off leave crumbs at some checkpoint"
    );
    let d = world.debris();
    assert!(d.pieces >= 10, "{d:?}");
    assert!(d.largest < DEBRIS_LEAVES, "{d:?}");
    assert_eq!(d.saturations, 0, "{d:?}");
}

/// The cow after the wander of the sweep's test, with the drill's checks on: they erase
/// crumbs (never a piece of the debris size) while the drill lags behind, and the sweep
/// leaves one piece.
#[test]
fn the_cow_after_a_wander_is_one_piece_with_the_drills_checks() {
    cow_wander(true, |sc, world, tool, params, poses| {
        let (d, before, rep) = drain_and_sweep(sc, world, tool, params, poses);
        eprintln!("cow wander, checks on: {d:?}");
        assert!(d.pieces >= 1, "{d:?}");
        assert!(d.largest < DEBRIS_LEAVES, "{d:?}");
        // A drill far behind the burr gives the checks an eighth of its budget, so seeds are
        // dropped (counted) and some crumbs wait for the sweep: the checks erase crumbs and
        // nothing larger, and the sweep leaves one piece.
        assert!(d.saturations > 0, "{d:?}");
        assert_eq!(rep.components, 1);
        assert_eq!(before, rep.pieces + 1);
        engine::validate(world).expect("valid");
    });
}

/// `demo` (the real-time pipeline, simulated device) reports the debris its drill's checks
/// erased: part of the removed volume, at least one leaf a piece, and no final sweep.
#[test]
fn the_demo_json_reports_the_debris_erased_while_drilling() {
    let j = tetradrill_tests::json_of(
        &["demo", "--headless", "--no-rt", "--duration", "3"],
        "debris",
        "demo",
    );
    let d = &j["debris_erased"];
    let removed = j["removed_volume"].as_f64().expect("removed");
    let (pieces, nodes) = (
        d["pieces"].as_u64().expect("pieces"),
        d["nodes"].as_u64().expect("nodes"),
    );
    let volume = d["volume"].as_f64().expect("volume");
    assert_eq!(d["final_sweep"], 0, "{d}");
    assert!(nodes >= pieces, "{d}");
    assert!((pieces == 0) == (volume == 0.0), "{d}");
    assert!(volume <= removed, "{d} of {removed}");
}
