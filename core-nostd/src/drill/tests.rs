//! Unit tests with tiny capacities: the pending deque and the arena saturate, the hierarchy
//! stays valid, and the work is carried over.

use glam::Vec3;

use super::sphere::{classify, Class};
use super::*;
use crate::builtin::{CUBE12_NODES, CUBE12_TETS};
use crate::collide::test_support::Store;
use crate::hierarchy::test_support::cube_hierarchy;
use crate::ids::TetId;

#[test]
fn classify_cases() {
    let p = [Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z];
    let s = |c: Vec3, r: f32| Sphere {
        center: c,
        radius: r,
    };
    assert_eq!(classify(p, &s(Vec3::ZERO, 2.0)), Class::Inside);
    assert_eq!(classify(p, &s(Vec3::splat(0.2), 0.05)), Class::Crossing);
    assert_eq!(
        classify(p, &s(Vec3::new(0.3, 0.3, -0.1), 0.2)),
        Class::Crossing
    );
    assert_eq!(
        classify(p, &s(Vec3::new(0.3, 0.3, -0.3), 0.2)),
        Class::Outside
    );
    assert_eq!(classify(p, &s(Vec3::splat(1.0), 0.5)), Class::Outside);
    let q = crate::geom::closest_point_on_triangle(
        Vec3::new(2.0, -1.0, 0.0),
        [Vec3::ZERO, Vec3::X, Vec3::Y],
    );
    assert!(q.distance(Vec3::X) < 1e-6);
}

#[test]
fn tiny_capacities_saturate_and_carry_over() {
    let mut store = Store::<CUBE12_NODES, CUBE12_TETS>::cube12(1.0, Vec3::ZERO);
    let mesh = store.refinable_mesh();
    cube_hierarchy!(h, &mesh, 64);
    // A deque that holds the candidates plus one depth-first path (8 + 7 per level) drains:
    // the work is carried over and finished in later ticks.
    let mut queue = [Pending::default(); CUBE12_TETS + 8 + 7 * 3];
    let mut drill = Drill::new(&mut queue);
    let spheres = [Sphere {
        center: Vec3::new(-0.5, 0.0, 0.1),
        radius: 0.3,
    }];
    let mut cand = [TetId::NONE; CUBE12_TETS];
    let n = candidates_brute_force(&mesh, &spheres, &mut cand);
    let params = DrillParams {
        max_depth: 3,
        min_area: 0.0,
        budget: 20,
    };
    let mut ticks = 0;
    loop {
        let r = drill.step(&mut h, &mesh, &cand[..n], &spheres, &params);
        h.validate(&mesh).unwrap();
        assert_eq!(drill.saturations(), 0);
        ticks += 1;
        if r.pending == 0 && drill.debris_pending() == 0 {
            break;
        }
        assert!(ticks < 200);
    }
    assert!(ticks > 1, "the budget spreads the work over several ticks");
    let again = drill.step(&mut h, &mesh, &cand[..n], &spheres, &params);
    assert_eq!(
        again.work, 0,
        "an unchanged sphere whose work is done costs nothing"
    );
    let mut queue = [Pending::default(); 12];
    let mut drill = Drill::new(&mut queue);
    let spheres = [Sphere {
        center: Vec3::new(0.5, 0.1, 0.0),
        radius: 0.3,
    }];
    let n = candidates_brute_force(&mesh, &spheres, &mut cand);
    assert!(n > 0 && n < CUBE12_TETS);
    let mut total = DrillReport::default();
    let removed0 = h.removed_volume();
    for _ in 0..50 {
        let r = drill.step(&mut h, &mesh, &cand[..n], &spheres, &params);
        h.validate(&mesh).unwrap();
        total.erased += r.erased;
        total.saturations += r.saturations;
        total.removed_volume += r.removed_volume;
        assert!(r.work < params.budget + 200);
    }
    // The arena is full and the sphere lies across coarse leaves only: each stays whole (no
    // centroid erasure of a coarse leaf, which would move the surface past the burr at once).
    assert_eq!(total.erased, 0, "{total:?} {}", h.saturations());
    assert!(total.saturations > 0, "tiny queue and arena must saturate");
    assert!(h.saturations() > 0);
    assert!((total.removed_volume - (h.removed_volume() - removed0)).abs() < 1e-12);
}

/// A pending item queued before the arena took its node's block back must not act on the
/// block's new nodes: it is looked up again by its tree index (the collapsed subtree answers
/// `None`) and dropped.
#[test]
fn pending_items_of_a_block_taken_back_are_dropped() {
    let mut store = Store::<CUBE12_NODES, CUBE12_TETS>::cube12(1.0, Vec3::ZERO);
    let mesh = store.refinable_mesh();
    // One block: the second refinement must take it back.
    cube_hierarchy!(h, &mesh, 8);
    // A sphere just around tet 0's child T5 (tree index 5): the root crosses it, T5 lies
    // inside.
    let t0 = TetId(0);
    let c5 =
        crate::hierarchy::node_positions(&mesh, t0, &crate::hierarchy::Path::of_index(5).unwrap());
    let centre = (c5[0] + c5[1] + c5[2] + c5[3]) * 0.25;
    let radius = 1.01 * c5.iter().map(|q| q.distance(centre)).fold(0.0, f32::max);
    assert!(mesh
        .tet_positions(t0)
        .iter()
        .any(|q| q.distance(centre) > radius));
    let spheres = [Sphere {
        center: centre,
        radius,
    }];
    let mut queue = [Pending::default(); 64];
    let mut drill = Drill::new(&mut queue);
    // Budget 1: the root is refined (block 0) and its 8 children wait in the deque.
    let params = DrillParams {
        max_depth: 3,
        min_area: 0.0,
        budget: 1,
    };
    let r = drill.step(&mut h, &mesh, &[t0], &spheres, &params);
    assert_eq!((r.created, r.pending), (8, 8));
    // Meanwhile tet 0's children are all erased and tet 5 is refined: the arena has no fresh
    // block left, so it takes block 0 back (tet 0's root becomes an erased leaf) and gives it
    // to tet 5's children.
    for c in 1..=8 {
        h.erase(&mesh, t0, c).unwrap();
    }
    h.refine(&mesh, TetId(5), 0).unwrap();
    assert_eq!(h.reclaimed(), 1);
    h.validate(&mesh).unwrap();
    let faces = h.visible_face_count();
    // The 8 waiting items name nodes of block 0, now tet 5's children, one of them with
    // T5's corners, inside the sphere: they must all be dropped.
    let params = DrillParams {
        budget: 1000,
        ..params
    };
    let r = drill.step(&mut h, &mesh, &[t0], &spheres, &params);
    assert_eq!((r.erased, r.created, r.pending), (0, 0, 0));
    h.validate(&mesh).unwrap();
    assert_eq!(h.visible_face_count(), faces);
    for c in 1..=8 {
        let n = h.node(h.find(TetId(5), c).unwrap()).unwrap();
        assert!(n.is_leaf() && !n.erased());
    }
}

/// [`Spacing::admit`] against a count made by hand: one position per `DRILL_SPACING` radii
/// along a straight path offered in one step, at most `MAX_STEP_SPHERES` of them with the
/// newest last; unusable positions are never taken.
#[test]
fn spacing_takes_every_eighth_radius_and_keeps_the_newest() {
    let r = 0.5;
    let gap = DRILL_SPACING * r;
    // 40 positions a third of a gap apart: every third is a gap from the last one taken
    // (the first is taken, then 3, 6, ...), 14 in all: 0, 3, ..., 39.
    let path: [Sphere; 40] = core::array::from_fn(|i| Sphere {
        center: Vec3::X * (gap * i as f32 / 3.0 + 1.0e-4 * i as f32),
        radius: r,
    });
    let mut out = [Sphere::default(); MAX_STEP_SPHERES];
    let mut sp = Spacing::new();
    let n = sp.admit(Vec3::ZERO, r, &path, &mut out);
    assert_eq!(n, 14);
    for (k, s) in out[..n].iter().enumerate() {
        assert_eq!(s.center, path[3 * k].center, "slot {k}");
    }
    // 100 positions each a full gap from the last: 16 slots, the last holding the newest.
    let far: [Sphere; 100] = core::array::from_fn(|i| Sphere {
        center: Vec3::Y * (1.5 * gap * i as f32),
        radius: r,
    });
    let mut sp = Spacing::new();
    let n = sp.admit(Vec3::ZERO, r, &far, &mut out);
    assert_eq!(n, MAX_STEP_SPHERES);
    assert_eq!(
        out[..15]
            .iter()
            .map(|s| s.center)
            .collect::<heapless::Vec<_, 16>>(),
        far[..15]
            .iter()
            .map(|s| s.center)
            .collect::<heapless::Vec<_, 16>>()
    );
    assert_eq!(out[15].center, far[99].center);
    // Not finite, or no radius: never taken, and nothing taken since.
    let bad = [
        Sphere {
            center: Vec3::splat(f32::NAN),
            radius: r,
        },
        Sphere {
            center: Vec3::Z * 10.0,
            radius: 0.0,
        },
    ];
    let mut sp = Spacing::new();
    assert_eq!(sp.admit(Vec3::ZERO, r, &bad, &mut out), 0);
    assert_eq!(sp, {
        let mut fresh = Spacing::new();
        fresh.admit(Vec3::ZERO, r, &[], &mut out);
        fresh
    });
}

#[test]
fn a_trees_depth_limit_halves_its_longest_edge_down_to_the_resolution() {
    use crate::hierarchy::depth_limit;
    use crate::hierarchy::MAX_DEPTH;
    // Written out: 1.0 halved to 0.5, 0.25, 0.125 (<= 0.2 at depth 3).
    assert_eq!(depth_limit(1.0, 0.2), 3);
    assert_eq!(depth_limit(1.0, 0.25), 2, "exactly the resolution");
    assert_eq!(depth_limit(0.1, 0.2), 0, "already fine enough");
    assert_eq!(depth_limit(1.0, 0.0), MAX_DEPTH as u8, "no resolution");
    assert_eq!(depth_limit(1e9, 1e-9), MAX_DEPTH as u8, "capped");
}

/// Work the feed paid into the pool while the drill lagged behind the burr is spent on the
/// queued material once the burr presses nothing: the queue drains, each leaf it erases is
/// paid from the pool, and a leaf the pool no longer covers is left.
#[test]
fn work_left_in_the_pool_cuts_the_queued_material_once_the_burr_lets_go() {
    pool_spent_after_the_let_go(1.0);
}

/// The same with a threshold of zero, which the material admits at zero force: a leaf the
/// pool no longer covers is still left, not waited for (nothing pays while the burr presses
/// nothing), so the queue drains.
#[test]
fn without_a_threshold_the_queue_drains_after_the_let_go_too() {
    pool_spent_after_the_let_go(0.0);
}

fn pool_spent_after_the_let_go(threshold: f32) {
    let mut store = Store::<CUBE12_NODES, CUBE12_TETS>::cube12(1.0, Vec3::ZERO);
    let mesh = store.refinable_mesh();
    cube_hierarchy!(h, &mesh, 1 << 13);
    // One region cut by the feed at 1,000 per cubic unit, threshold `threshold` N.
    let e = 1_000.0f32;
    let gated = Material {
        threshold,
        ..Material::DEFAULT
    };
    let mut table = [Region::new(gated).with_cutting_energy(e)];
    let of_tet = [0u8; CUBE12_TETS];
    let mut queue = [Pending::default(); 2048];
    let mut drill = Drill::new(&mut queue);
    drill.set_regions(Regions::new(&mut table, &of_tet).expect("regions"));
    // A burr of radius 0.2 centred on the top face: the half ball under it is 0.01676, whose
    // cutting takes 16.8 of work; the burr pays 5 of it (2 N over 2.5) and the drill, held
    // to a small budget a step, has cut only part of that when the burr lets go.
    let burr = [Sphere {
        center: Vec3::new(0.0, 0.0, 0.5),
        radius: 0.2,
    }];
    let mut cand = [TetId::NONE; CUBE12_TETS];
    let n = candidates_brute_force(&mesh, &burr, &mut cand);
    let params = DrillParams {
        max_depth: 3,
        min_area: 0.0,
        budget: 40,
    };
    let under = Some(cand[0]);
    let grant = |d: &mut Drill<'_>, force: f32, feed: f32| {
        let queued = d.pending() > 0;
        d.regions_mut()
            .expect("regions")
            .grant(force, 0.001, true, feed, under, queued);
    };
    grant(&mut drill, 2.0, 2.5);
    drill.step(&mut h, &mesh, &cand[..n], &burr, &params);
    while h.removed_volume() == 0.0 {
        grant(&mut drill, 2.0, 0.0);
        drill.step(&mut h, &mesh, &cand[..n], &[], &params);
        assert!(drill.pending() > 0);
    }
    let pressed = h.removed_volume();
    assert!(drill.pending() > 0 && pressed > 0.0, "{pressed}");
    // The burr lets go (no force, the drill on): the queue goes on with the pool's work.
    let mut steps = 0;
    while drill.pending() > 0 {
        grant(&mut drill, 0.0, 0.0);
        drill.step(&mut h, &mesh, &cand[..n], &[], &params);
        h.validate(&mesh).expect("valid");
        steps += 1;
        assert!(steps < 10_000, "the queue drains");
    }
    let regions = drill.regions().expect("regions");
    let cut = h.removed_volume();
    assert!(cut > 2.0 * pressed, "{cut} after {pressed}");
    // Every leaf erased was paid: the hierarchy's removed volume at e is the energy spent,
    // and with the pool's rest the work done.
    let energy = regions.cutting_energy();
    assert!(
        (f64::from(e) * cut - energy).abs() < 1e-9 * energy,
        "{cut} {energy}"
    );
    let work = regions.cutting_work();
    assert!((work - 5.0).abs() < 1e-6, "{work}");
    assert!((work - energy - regions.feed_pool() - regions.feed_dropped()).abs() < 1e-9);
    // The pool was spent down to less than what one leaf of depth 1 would take, on material
    // inside the burr.
    let big_leaf = (0..CUBE12_TETS)
        .map(|t| crate::hierarchy::node_volume(&mesh, TetId::from_idx(t), 1))
        .fold(0.0, f64::max);
    assert!(regions.feed_pool() < f64::from(e) * big_leaf, "{regions:?}");
    let half_ball = 2.0 / 3.0 * core::f64::consts::PI * 0.2f64.powi(3);
    assert!(cut < half_ball, "{cut} against {half_ball}");
}

/// The pool's side of the test above: once the burr presses nothing, the pool admits the
/// feed's queued leaves it covers; one it covers is erased, a bigger one is left, not waited
/// for; while the burr presses below the threshold nothing is admitted.
#[test]
fn once_the_burr_presses_nothing_the_pool_admits_the_leaves_it_covers() {
    use super::material::Spend;
    // Region 0 removed at once, region 1 cut by the feed at 2,000 per cubic unit
    // (threshold 1 N), region 2 rate-limited.
    let feed = Region::new(Material {
        threshold: 1.0,
        ..Material::DEFAULT
    })
    .with_cutting_energy(2_000.0);
    let rate = Region::new(Material {
        hardness: 100.0,
        threshold: 1.0,
        stiffness: 0.0,
    });
    let mut table = [Region::default(), feed, rate];
    let of_tet = [0u8, 1, 2];
    let mut r = Regions::new(&mut table, &of_tet).expect("valid");
    let under = Some(TetId(1));
    // Once the burr presses nothing, the pool's work admits the feed's queued leaves it
    // covers (the smallest, given): one it covers is erased, a bigger one is left, not
    // waited for; while the burr presses below the threshold a leaf is not admitted.
    r.grant(2.0, 0.001, true, 0.0015, under, false);
    r.grant(0.0, 0.001, true, 0.0, None, true);
    assert!((r.feed_pool() - 0.003).abs() < 1e-9);
    assert!(r.admits_paid(TetId(1), || 1e-6) && !r.admits(TetId(1)));
    assert!(
        !r.admits_paid(TetId(1), || 2e-6),
        "0.004 of work for 0.003 in the pool"
    );
    assert!(!r.admits_paid(TetId(2), || 1e-9) && !r.admits_paid(TetId(0), || 1e-9));
    assert_eq!(r.spend(TetId(1), 1e-6), Spend::Erase);
    assert_eq!(r.spend(TetId(1), 1e-6), Spend::Drop);
    assert!((r.feed_pool() - 0.001).abs() < 1e-9);
    r.grant(0.5, 0.001, true, 0.0, under, true);
    assert!(!r.admits_paid(TetId(1), || 1e-7) && !r.admits(TetId(1)));
    r.grant(2.0, 0.001, true, 0.0, under, true);
    assert_eq!(
        r.spend(TetId(1), 1e-6),
        Spend::Wait,
        "pressed: the leaf waits"
    );
    // A region without a threshold admits a leaf at zero force; once the burr presses
    // nothing, one the pool does not cover is still left, not waited for.
    let mut table = [Region::new(Material::DEFAULT).with_cutting_energy(2_000.0)];
    let mut r = Regions::new(&mut table, &[0u8]).expect("valid");
    r.grant(2.0, 0.001, true, 0.0015, Some(TetId(0)), false);
    r.grant(0.0, 0.001, true, 0.0, None, true);
    assert!(r.admits(TetId(0)) && r.admits_paid(TetId(0), || 1e-6));
    assert_eq!(r.spend(TetId(0), 1e-6), Spend::Erase);
    assert_eq!(r.spend(TetId(0), 1e-6), Spend::Drop, "unpressed: left");
    r.grant(2.0, 0.001, true, 0.0, Some(TetId(0)), true);
    assert_eq!(r.spend(TetId(0), 1e-6), Spend::Wait, "pressed: waits");
}
