//! The candidate gather spread over steps (`tetradrill_core::collide::ZoneGather`, as
//! `builtin:firmware-cow` runs it) against the one-shot zone query and a brute force over
//! every tet of the cow, along the firmware's path: the gathered list holds exactly the
//! brute force's tets near the tool whenever the step says it covers the zone, and the
//! contact and the drilling come out as with the one-shot query.

use tetradrill_core::collide::{ZoneGather, ZONE_MARGIN_RADII};
use tetradrill_core::drill::DrillParams;
use tetradrill_core::hash::Aabb;
use tetradrill_core::mesh::Mesh;
use tetradrill_core::script::{DEMO, DRILL_ON};
use tetradrill_core::servo::{World, WorldSizes};
use tetradrill_core::TetId;
use tetradrill_tests::search::Store;

const COW: &str = "models/spot_tetgen_q1.414.node";
/// The firmware scenario's burr and reach.
const R: f32 = 0.1;
const REACH: f32 = 0.05;

/// Storage with the firmware-cow scenario's candidate list and cell bound.
fn store(tets: usize) -> Store {
    let mut sizes = WorldSizes::new(tets, 1 << 17);
    sizes.candidates = 12_288;
    Store::sized(sizes)
}

fn sizes(w: &mut World<'_>, gather: bool) {
    w.set_max_cells(6_144);
    if gather {
        w.set_zone_gather(Some(ZoneGather::new(2_000, ZONE_MARGIN_RADII)));
    }
}

/// Every tet whose box (from its corners) meets `zone`, by id: the oracle.
fn brute_force(mesh: &Mesh<'_>, zone: &Aabb) -> Vec<u32> {
    (0..mesh.tet_count())
        .map(TetId::from_idx)
        .filter(|&t| zone.overlaps(&Aabb::of(mesh.tet_positions(t))))
        .map(|t| t.0)
        .collect()
}

/// The tets of `list` whose boxes meet `zone`, sorted, each once (checked).
fn meeting(mesh: &Mesh<'_>, list: &[TetId], zone: &Aabb) -> Vec<u32> {
    let mut v: Vec<u32> = list
        .iter()
        .filter(|&&t| zone.overlaps(&Aabb::of(mesh.tet_positions(t))))
        .map(|t| t.0)
        .collect();
    v.sort_unstable();
    let n = v.len();
    v.dedup();
    assert_eq!(n, v.len(), "a tet listed twice");
    v
}

/// The firmware's path without drilling (the hierarchies stay untouched, so both worlds see
/// the same surface): whenever the gathered list covers the zone, its tets near the tool are
/// the brute force's and the one-shot query's, and the contact (searches that complete) is
/// the one-shot world's, bit for bit (the closest point, normal and depth). The list stops covering only on the first steps, while
/// the first box is gathered, and the gather moves its box along the path.
#[test]
fn gathered_candidates_are_the_one_shot_querys() {
    let (mut oa, mut ob) = (
        tetradrill_tests::load(COW, 1.0),
        tetradrill_tests::load(COW, 1.0),
    );
    let (mut sa, mut sb) = (store(oa.view().tet_count()), store(ob.view().tet_count()));
    let mut one = sa.world(oa.view());
    let mut gathered = sb.world(ob.view());
    sizes(&mut one, false);
    sizes(&mut gathered, true);
    let params = DrillParams {
        max_depth: 4,
        min_area: 0.0,
        budget: 300,
    };
    let (mut covered, mut uncovered, mut contacts) = (0u32, 0u32, 0u32);
    let ticks = DEMO.ticks();
    for tick in 0..ticks {
        let (c, _) = DEMO.at(tick);
        let ra = one.simulate(c, R, REACH, false, &params);
        let rb = gathered.simulate(c, R, REACH, false, &params);
        let zone = Aabb::point(c).grown(R + REACH);
        let mesh = one.mesh();
        let exact = brute_force(mesh, &zone);
        assert!(!ra.candidates_saturated, "tick {tick}: one-shot saturated");
        assert_eq!(meeting(mesh, one.candidates(), &zone), exact, "tick {tick}");
        assert_eq!(one.candidates().len(), exact.len(), "tick {tick}");
        if rb.candidates_saturated {
            uncovered += 1;
            assert!(tick < 30, "tick {tick}: the gather fell behind the tool");
            continue;
        }
        covered += 1;
        assert_eq!(
            meeting(mesh, gathered.candidates(), &zone),
            exact,
            "tick {tick}: the gathered list near the tool"
        );
        if !ra.contact_saturated && !rb.contact_saturated {
            // (The triangles examined differ: another list, another walk.)
            let (ca, cb) = (one.contact(), gathered.contact());
            assert_eq!(
                (ca.valid, ca.point, ca.normal, ca.depth),
                (cb.valid, cb.point, cb.normal, cb.depth),
                "tick {tick}: contact"
            );
            contacts += u32::from(one.contact().valid);
        }
    }
    let gathers = gathered.zone_gather().map_or(0, |z| z.gathers());
    assert!(uncovered >= 1, "the first box takes more than one step");
    assert!(covered > 5_900, "{covered} steps covered");
    assert!(contacts > 500, "{contacts} contacts compared");
    assert!(gathers > 5, "{gathers} gathers along the path");
}

/// Drilling along the firmware's path with a budget large enough that every step finishes
/// its work: the gathered lists give the drill the same tets near the burr as the one-shot
/// query (in another order), so the same material goes (the removed volume, summed in
/// another order, agrees to 1e-9 of it) and the contact agrees.
#[test]
fn drilling_with_gathered_candidates_removes_what_the_one_shot_query_does() {
    let (mut oa, mut ob) = (
        tetradrill_tests::load(COW, 1.0),
        tetradrill_tests::load(COW, 1.0),
    );
    let (mut sa, mut sb) = (store(oa.view().tet_count()), store(ob.view().tet_count()));
    let mut one = sa.world(oa.view());
    let mut gathered = sb.world(ob.view());
    sizes(&mut one, false);
    sizes(&mut gathered, true);
    let params = DrillParams {
        max_depth: 3,
        min_area: 0.0,
        budget: 1_000_000,
    };
    let mut drilled = 0u32;
    for tick in 0..DEMO.ticks().min(3_000) {
        let (c, buttons) = DEMO.at(tick);
        let on = buttons & DRILL_ON != 0;
        let ra = one.simulate(c, R, REACH, on, &params);
        let rb = gathered.simulate(c, R, REACH, on, &params);
        assert_eq!(ra.drill.pending, 0, "tick {tick}: one-shot work left");
        assert_eq!(rb.drill.pending, 0, "tick {tick}: gathered work left");
        if rb.candidates_saturated {
            assert!(tick < 30, "tick {tick}: the gather fell behind the tool");
            assert!(!on, "tick {tick}: drilling before the first box");
            continue;
        }
        let (va, vb) = (
            one.hierarchy().removed_volume(),
            gathered.hierarchy().removed_volume(),
        );
        assert!(
            (va - vb).abs() <= 1e-9 * va.max(1e-12),
            "tick {tick}: removed {va} vs {vb}"
        );
        drilled += u32::from(ra.queued > 0);
        let (ca, cb) = (one.contact(), gathered.contact());
        if !ra.contact_saturated && !rb.contact_saturated {
            assert_eq!(ca.valid, cb.valid, "tick {tick}");
            assert!((ca.depth - cb.depth).abs() <= 1e-5, "tick {tick}: depth");
        }
    }
    assert!(drilled >= 40, "{drilled} positions queued");
    assert!(one.hierarchy().removed_volume() > 1e-3);
}

/// A moving cow with the gather on: every 40 ticks the mesh jumps by more than the gather's
/// margin (`World::set_positions`), and the gathered list, whenever the step says it covers
/// the zone, still holds exactly the brute force's tets near the tool on the moved mesh (the
/// lists gathered on the old positions are forgotten, not served).
#[test]
fn a_moving_mesh_gathers_afresh() {
    let mut om = tetradrill_tests::load(COW, 1.0);
    let rest0 = om.view().positions().to_vec();
    let mut st = store(om.view().tet_count());
    let mut world = st.world(om.view());
    sizes(&mut world, true);
    let mut rest = vec![tetradrill_core::Vec3::ZERO; rest0.len()];
    world.enable_deformation(&mut rest).expect("rest storage");
    let params = DrillParams {
        max_depth: 4,
        min_area: 0.0,
        budget: 300,
    };
    let (mut covered, mut moves) = (0u32, 0u32);
    for tick in 0..DEMO.ticks().min(2_000) {
        if tick % 40 == 39 {
            // Half a burr radius along x and back: five times the gather's margin.
            let dx = if moves % 2 == 0 { 0.5 * R } else { 0.0 };
            let moved: Vec<_> = rest0
                .iter()
                .map(|&p| p + tetradrill_core::Vec3::X * dx)
                .collect();
            world.set_positions(&moved).expect("positions");
            moves += 1;
        }
        let (c, _) = DEMO.at(tick);
        let r = world.simulate(c, R, REACH, false, &params);
        if r.candidates_saturated {
            continue;
        }
        covered += 1;
        let zone = Aabb::point(c).grown(R + REACH);
        let mesh = world.mesh();
        assert_eq!(
            meeting(mesh, world.candidates(), &zone),
            brute_force(mesh, &zone),
            "tick {tick}: the gathered list after {moves} moves"
        );
    }
    assert!(moves >= 40, "{moves} moves");
    assert!(covered > 1_000, "{covered} steps covered");
}

/// An exact gather (`ZoneGather::exact`, the host's default on large meshes) whose work a
/// step is far too small for the tool (400 units: a box takes several steps, and the tool
/// leaves it first when it moves fast) and whose mesh jumps every 200 ticks (the lists are
/// forgotten): it is never short of a tet. Every step's list holds exactly
/// the brute force's tets near the tool, no step counts a saturation, the steps the gather
/// could not serve fell back to the one-shot query (counted), and the others were served
/// by gathered lists; the contact is the one-shot world's wherever both searches complete,
/// and drilling removes what it removes (to 1e-9).
#[test]
fn an_exact_gather_is_never_short_of_a_tet() {
    let (mut oa, mut ob) = (
        tetradrill_tests::load(COW, 1.0),
        tetradrill_tests::load(COW, 1.0),
    );
    let rest0 = ob.view().positions().to_vec();
    let (mut sa, mut sb) = (store(oa.view().tet_count()), store(ob.view().tet_count()));
    let mut one = sa.world(oa.view());
    let mut exact = sb.world(ob.view());
    sizes(&mut one, false);
    exact.set_zone_gather(Some(ZoneGather::exact(400, ZONE_MARGIN_RADII)));
    let (mut ra_rest, mut rb_rest) = (
        vec![tetradrill_core::Vec3::ZERO; rest0.len()],
        vec![tetradrill_core::Vec3::ZERO; rest0.len()],
    );
    one.enable_deformation(&mut ra_rest).expect("rest storage");
    exact
        .enable_deformation(&mut rb_rest)
        .expect("rest storage");
    let params = DrillParams {
        max_depth: 3,
        min_area: 0.0,
        budget: 1_000_000,
    };
    let (mut moves, mut contacts) = (0u32, 0u32);
    for tick in 0..DEMO.ticks().min(3_000) {
        if tick % 200 == 199 {
            let dx = if moves % 2 == 0 { 0.5 * R } else { 0.0 };
            let moved: Vec<_> = rest0
                .iter()
                .map(|&p| p + tetradrill_core::Vec3::X * dx)
                .collect();
            one.set_positions(&moved).expect("positions");
            exact.set_positions(&moved).expect("positions");
            moves += 1;
        }
        let (c, buttons) = DEMO.at(tick);
        let on = buttons & DRILL_ON != 0;
        let ra = one.simulate(c, R, REACH, on, &params);
        let rb = exact.simulate(c, R, REACH, on, &params);
        assert!(
            !ra.candidates_saturated && !rb.candidates_saturated,
            "tick {tick}"
        );
        let zone = Aabb::point(c).grown(R + REACH);
        let mesh = exact.mesh();
        assert_eq!(
            meeting(mesh, exact.candidates(), &zone),
            brute_force(mesh, &zone),
            "tick {tick}: the exact gather's list"
        );
        let (va, vb) = (
            one.hierarchy().removed_volume(),
            exact.hierarchy().removed_volume(),
        );
        assert!(
            (va - vb).abs() <= 1e-9 * va.max(1e-12),
            "tick {tick}: removed {va} vs {vb}"
        );
        if !ra.contact_saturated && !rb.contact_saturated {
            let (ca, cb) = (one.contact(), exact.contact());
            assert_eq!(ca.valid, cb.valid, "tick {tick}");
            assert!((ca.depth - cb.depth).abs() <= 1e-5, "tick {tick}: depth");
            contacts += u32::from(ca.valid);
        }
    }
    let z = exact.zone_gather().expect("the gather");
    assert!(z.is_exact());
    assert!(z.fallbacks() > 100, "{} steps fell back", z.fallbacks());
    println!("{} fallbacks, {} gathers", z.fallbacks(), z.gathers());
    assert!(z.gathers() > 5, "{} gathers", z.gathers());
    assert!(
        (z.fallbacks() as usize) < DEMO.ticks().min(3_000) as usize - 500,
        "{} of the steps fell back: the gathered lists served too few",
        z.fallbacks()
    );
    assert!(one.hierarchy().removed_volume() > 1e-3);
    assert!(contacts > 300, "{contacts} contacts compared");
}
