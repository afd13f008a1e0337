//! The drill shaft's candidate list (`World::track_shaft`) against a brute force over every
//! tet: after each step it lists, once each and in ascending order, at least every tet whose
//! box meets one of the points' zones (the box around a point's position and its proxy,
//! grown by the shaft's radius and the reach), with the shaft upright, lying along an axis
//! and tilted, near and across the block's faces; and it does not saturate where one zone
//! query per point would not (the hash's cell bound set to the largest single zone's cells).

use tetradrill_benches::Lcg;
use tetradrill_core::drill::DrillParams;
use tetradrill_core::force::{DrillTool, MAX_PASSIVE};
use tetradrill_core::hash::Aabb;
use tetradrill_core::servo::{DrillState, World, WorldSizes};
use tetradrill_core::{TetId, Vec3};
use tetradrill_tests::search::{block_mesh, Store};

const REACH: f32 = 0.02;

const TOOL: DrillTool = DrillTool {
    burr_radius: 0.05,
    shaft_length: 0.9,
    shaft_radius: 0.04,
};

/// The zones `World::track_shaft` queries for the shaft at `centre` along `axis`, from the
/// points' proxies in `before` (the state handed to the step).
fn zones(centre: Vec3, axis: Vec3, before: &DrillState) -> Vec<Aabb> {
    let mut pos = [Vec3::ZERO; MAX_PASSIVE];
    let n = TOOL.passive_positions(centre, axis, &mut pos);
    let grow = TOOL.shaft_radius + REACH;
    (0..n)
        .map(|i| {
            let b = Aabb::point(pos[i]).grown(grow);
            match before.points[i].proxy {
                Some(q) => b.union(Aabb::point(q).grown(grow)),
                None => b,
            }
        })
        .collect()
}

/// Cells of the world's hash a box covers.
fn cells(w: &World<'_>, b: &Aabb) -> u64 {
    let (lo, hi) = (w.hash().cell_of(b.min), w.hash().cell_of(b.max));
    (0..3).map(|a| (hi[a] - lo[a] + 1) as u64).product::<u64>()
}

/// A seeded pose sequence: the burr wandering through and around the block in small steps,
/// the shaft's axis turning slowly through upright, axis-aligned and tilted directions, now
/// and then a jump.
pub(crate) fn wandering_shaft(n: usize, seed: u64) -> Vec<(Vec3, Vec3)> {
    let mut rng = Lcg(seed);
    let mut next = || rng.signed();
    let axes = [
        Vec3::Z,
        Vec3::X,
        Vec3::new(1.0, 0.0, 1.0).normalize(),
        Vec3::new(1.0, 1.0, 1.0).normalize(),
        Vec3::new(-0.3, 0.8, 0.5).normalize(),
        Vec3::NEG_Y,
    ];
    let mut p = Vec3::ZERO;
    let mut v = Vec::with_capacity(n);
    for i in 0..n {
        let jump = i % 97 == 50;
        let d = Vec3::new(next(), next(), next()) * if jump { 0.4 } else { 0.01 };
        p = (p + d).clamp(Vec3::splat(-0.7), Vec3::splat(0.7));
        let k = i / 40;
        let t = (i % 40) as f32 / 40.0;
        let a = axes[k % axes.len()].lerp(axes[(k + 1) % axes.len()], t);
        v.push((p, a.normalize()));
    }
    v
}

#[test]
fn the_shaft_lists_every_tet_its_points_zones_meet_once_in_order() {
    let mut om = block_mesh(8);
    let mesh = om.view();
    // Room for every tet's listing in every zone: the storage never limits the list.
    let mut st = Store::sized(WorldSizes {
        candidates: 1 << 15,
        ..WorldSizes::new(mesh.tet_count(), 1 << 15)
    });
    let mut w = st.world(mesh);
    let params = DrillParams {
        max_depth: 2,
        min_area: 0.0,
        budget: 300,
    };
    let path = wandering_shaft(600, 11);
    let mut state = DrillState::default();
    let (mut listed, mut held) = (0usize, 0u32);
    for (i, &(c, a)) in path.iter().enumerate() {
        w.set_max_cells(1 << 20);
        w.simulate(c, TOOL.burr_radius, REACH, i % 3 == 0, &params);
        // The hash's bound: this step's largest zone, so one query per point would not
        // saturate, and no more.
        let zs = zones(c, a, &state);
        let most = zs.iter().map(|z| cells(&w, z)).max().expect("zones");
        w.set_max_cells(u32::try_from(most).expect("cells"));
        let (prep, saturated) = w.track_shaft(&TOOL, c, a, REACH, &mut state);
        assert!(!saturated, "step {i}: saturated");
        let cands = w.candidates();
        assert!(
            cands.windows(2).all(|p| p[0] < p[1]),
            "step {i}: not ascending and once each"
        );
        let mesh = w.mesh();
        for z in &zs {
            for t in (0..mesh.tet_count()).map(TetId::from_idx) {
                if Aabb::of(mesh.tet_positions(t)).overlaps(z) {
                    assert!(
                        cands.binary_search(&t).is_ok(),
                        "step {i}: tet {} meets the zone {z:?} and is not listed",
                        t.0
                    );
                }
            }
        }
        listed += cands.len();
        held += prep.held;
    }
    // The path goes through material: the lists are not empty and points were held.
    assert!(listed > 10_000, "{listed}");
    assert!(held > 100, "{held}");
}
