//! The contact search bounded and carried over ticks: searches resumed where the last stopped,
//! continued to the end of a round, hinted with the kept faces, and bounded by what the drill
//! left of one tick budget, each against the exhaustive search over every visible triangle
//! near the tool (`tetradrill_tests::search`): never closer than it, never moving away, and
//! equal to it once a round or a search completes.

use glam::Vec3;
use tetradrill_core::drill::DrillParams;
use tetradrill_core::force::closest_point_on_triangle;
use tetradrill_core::hierarchy::{
    FaceRef, Hierarchy, Kept, Nearest, NearestCursor, NearestQuery, SphereMemo, SphereSlot,
    VisibleTri,
};
use tetradrill_core::mesh::Mesh;
use tetradrill_core::servo::World;
use tetradrill_core::TetId;
use tetradrill_tests::search::{exhaustive, exhaustive_uncut, on_block4, skipped};

/// Drills a cavity into `world` (the burr plunged from the top face, then dragged sideways)
/// and returns six poses in and around it, for the held-pose tests.
fn drill_cavity(world: &mut World<'_>, params: &DrillParams, r: f32, reach: f32) -> [Vec3; 6] {
    for k in 0..40 {
        let c = if k < 20 {
            Vec3::new(0.0, 0.0, 0.55 - 0.01 * k as f32)
        } else {
            Vec3::new(0.01 * (k - 20) as f32, 0.0, 0.36)
        };
        world.simulate(c, r, reach, true, params);
    }
    [
        Vec3::new(0.02, 0.0, 0.4),
        Vec3::new(0.1, 0.03, 0.33),
        Vec3::new(-0.03, 0.02, 0.42),
        Vec3::new(0.15, -0.02, 0.37),
        Vec3::new(0.05, -0.05, 0.3),
        Vec3::new(0.12, 0.06, 0.38),
    ]
}

/// One step of a chain of searches at a held pose `c`: its answer becomes the next hint, and
/// it never moves away from the last one nor comes closer than the `exact` squared distance.
fn follow(
    near: &Nearest,
    hint: &mut Option<FaceRef>,
    last: &mut f32,
    exact: f32,
    c: Vec3,
    step: usize,
) {
    if let Some(vt) = near.tri {
        *hint = Some(FaceRef {
            tet: vt.tet,
            index: vt.index,
            face: vt.face,
        });
        assert!(near.d2 <= *last, "{c}: step {step} moved away");
        assert!(near.d2 >= exact, "{c}: closer than the exhaustive answer");
        *last = near.d2;
    }
}

/// Bounded searches at a held pose, each hinted with the last answer: started after the tree
/// where the last one stopped (`Nearest::resume`, as `World::simulate` does), the answer never
/// moves farther away, is never closer than the exhaustive one, and ends at least as close as
/// the same chain always started at the first tree, strictly closer at some poses. (It need
/// not reach the exhaustive answer: a tree whose depth-first prefix within the bound misses
/// the closest face is never finished.)
#[test]
fn bounded_searches_resumed_where_the_last_stopped_get_closer() {
    on_block4(|world, params, r, reach| {
        let (mut better, mut stopped, mut poses) = (0, 0, 0);
        for c in drill_cavity(world, params, r, reach) {
            world.simulate(c, r, reach, false, params);
            let (h, m) = (world.hierarchy(), world.mesh());
            let cands = world.candidates();
            let Some((exact, _, _)) = exhaustive(h, m, cands, c, r + reach) else {
                continue;
            };
            poses += 1;
            // One chain of 40 searches bounded at 32 nodes; `resume` picks the next start.
            let chain = |resume: bool| {
                let (mut start, mut hint, mut last, mut n_stopped) =
                    (0usize, None, f32::INFINITY, 0);
                for step in 0..40 {
                    let near = h.nearest_uncut_from(m, cands, start, c, r + reach, None, hint, 32);
                    n_stopped += u32::from(!near.complete);
                    follow(&near, &mut hint, &mut last, exact, c, step);
                    if resume {
                        start = near.resume as usize;
                    }
                }
                (last, n_stopped)
            };
            let (resumed, n) = chain(true);
            let (first, _) = chain(false);
            stopped += n;
            assert!(
                resumed <= first,
                "{c}: resumed {resumed} farther than {first}"
            );
            better += u32::from(resumed < first);
        }
        assert!(poses >= 4, "{poses} poses with surface in reach");
        assert!(
            stopped > 100,
            "the bound must stop searches here ({stopped})"
        );
        eprintln!("resumed chains closer at {better} of {poses} poses, {stopped} searches stopped");
        assert!(
            better * 2 >= poses,
            "resuming got closer at {better} of {poses} poses only"
        );
    });
}

/// Bounded searches at a held pose that go on from a cursor (`Hierarchy::nearest_continued`,
/// as `World::simulate` does), each hinted with the last answer: no search tests more nodes
/// than its bound (an expansion is never split), the answer never moves away and is never
/// closer than the exhaustive one, and once a round over the trees has ended (the cursor
/// cleared) the answer is the exhaustive triangle, bit for bit: every tree was walked to the
/// end, pruned at distances no nearer than the closest face. A search that went on from a
/// place and ends its round goes on with a fresh one (`complete` when that ends too).
#[test]
fn continued_searches_finish_every_tree_and_reach_the_exhaustive_answer() {
    on_block4(|world, params, r, reach| {
        let (mut poses, mut rounds, mut went_on) = (0, 0, 0);
        for c in drill_cavity(world, params, r, reach) {
            world.simulate(c, r, reach, false, params);
            let (h, m) = (world.hierarchy(), world.mesh());
            let mut cands = world.candidates().to_vec();
            cands.sort_unstable();
            let Some((exact, key, _)) = exhaustive(h, m, &cands, c, r + reach) else {
                continue;
            };
            poses += 1;
            let mut slots = vec![SphereSlot::EMPTY; 64];
            let mut memo = SphereMemo::new(&mut slots);
            let mut cursor = NearestCursor::new();
            let (mut hint, mut last, mut ended) = (None, f32::INFINITY, false);
            let mut hint_tri = None;
            for step in 0..400 {
                let max_nodes = 12;
                let q = NearestQuery {
                    tets: &cands,
                    start: 0,
                    centre: c,
                    reach: r + reach,
                    cut: None,
                    hints: hint_tri.as_slice(),
                    max_nodes,
                };
                let had_place = cursor.tet().is_some();
                let rounds_before = cursor.rounds();
                let near = h.nearest_continued(m, &q, &mut memo, &mut cursor);
                assert!(
                    near.nodes <= max_nodes,
                    "{c}: step {step}: {} nodes",
                    near.nodes
                );
                went_on += u32::from(had_place);
                follow(&near, &mut hint, &mut last, exact, c, step);
                hint_tri = near.tri.or(hint_tri);
                if ended {
                    assert_eq!(near.d2.to_bits(), exact.to_bits(), "{c}: step {step}");
                    assert_eq!(hint, Some(key), "{c}: step {step}");
                }
                if cursor.rounds() > rounds_before {
                    ended = true;
                }
            }
            assert!(ended, "{c}: no round ended in 400 searches of 12 nodes");
            rounds += cursor.rounds();
        }
        assert!(poses >= 4, "{poses} poses with surface in reach");
        assert!(
            went_on > 100,
            "the bound must stop searches here ({went_on})"
        );
        eprintln!("{rounds} rounds at {poses} poses, {went_on} searches went on");
    });
}

/// Every visible face of the candidate trees, from the v_list (no walk shared with the
/// search): face -> corners.
fn visible_faces(
    h: &Hierarchy<'_>,
    mesh: &Mesh<'_>,
    cands: &[TetId],
) -> std::collections::HashMap<FaceRef, [Vec3; 3]> {
    let mut all = std::collections::HashMap::new();
    h.for_each_visible(mesh, |vt| {
        if cands.binary_search(&vt.tet).is_ok() {
            all.insert(
                FaceRef {
                    tet: vt.tet,
                    index: vt.index,
                    face: vt.face,
                },
                vt.corners,
            );
        }
    });
    all
}

/// The faces a search keeps (`Hierarchy::nearest_continued_keeping`), along a path through a
/// drilled cavity with searches bounded at a few nodes: every kept face is a visible face of
/// the candidate trees, within reach and not skipped by the cutting rule, at the squared
/// distance measured here from the v_list; nearest first, no face twice, at most `KEEP`; the
/// answer is the first of them, never closer than the exhaustive answer, and no farther than the
/// nearest hint still in play; a search that completes gives the exhaustive answer whatever
/// the hints (every tenth search is unbounded). Carrying all the kept faces to the next
/// search as hints ends, summed over the path, strictly closer to the exhaustive answers
/// than carrying the answer alone (what `World::simulate` did before 2026-11-24).
#[test]
fn kept_faces_are_true_faces_nearest_first_and_carry_the_answer_closer() {
    on_block4(|world, params, r, reach| {
        drill_cavity(world, params, r, reach);
        let path: Vec<Vec3> = (0..120)
            .map(|k| {
                let u = k as f32 / 119.0;
                Vec3::new(-0.02 + 0.2 * u, 0.03 * (7.0 * u).sin(), 0.42 - 0.1 * u)
            })
            .collect();
        // Each chain runs the same path with its own cursor and memo; `all_kept` chooses
        // what goes on as hints.
        let mut chain = |all_kept: bool| -> (f64, u32, u32) {
            let mut slots = vec![SphereSlot::EMPTY; 64];
            let mut memo = SphereMemo::new(&mut slots);
            let mut cursor = NearestCursor::new();
            let mut hints: Vec<VisibleTri> = Vec::new();
            let (mut shortfall, mut stopped, mut completed) = (0.0f64, 0u32, 0u32);
            for (step, &c) in path.iter().enumerate() {
                let cut = (step % 3 == 0).then_some(r);
                world.simulate(c, r, reach, false, params);
                let (h, m) = (world.hierarchy(), world.mesh());
                let mut cands = world.candidates().to_vec();
                cands.sort_unstable();
                let faces = visible_faces(h, m, &cands);
                let reach2 = (r + reach) * (r + reach);
                let measure = |k: &FaceRef| -> Option<f32> {
                    let q = faces.get(k)?;
                    let d2 = (c - closest_point_on_triangle(c, *q)).length_squared();
                    (d2 <= reach2 && !skipped(*q, c, cut)).then_some(d2)
                };
                let best_hint = hints
                    .iter()
                    .filter_map(|t| measure(&t.key()))
                    .fold(f32::INFINITY, f32::min);
                let q = NearestQuery {
                    tets: &cands,
                    start: 0,
                    centre: c,
                    reach: r + reach,
                    cut,
                    hints: &hints,
                    max_nodes: if step % 10 == 9 { u32::MAX } else { 24 },
                };
                let mut kept = Kept::new();
                let near = h.nearest_continued_keeping(m, &q, &mut memo, &mut cursor, &mut kept);
                let exact = exhaustive_uncut(h, m, &cands, c, r + reach, cut);
                assert!(kept.len() <= tetradrill_core::hierarchy::KEEP);
                for (i, &(d2, t)) in kept.iter().enumerate() {
                    let k = t.key();
                    assert_eq!(faces.get(&k), Some(&t.corners), "{c}: {k:?} corners");
                    assert_eq!(
                        measure(&k).map(f32::to_bits),
                        Some(d2.to_bits()),
                        "{c}: {k:?}"
                    );
                    if i > 0 {
                        let (pd, pk) = (kept[i - 1].0, kept[i - 1].1.key());
                        assert!(pd < d2 || (pd == d2 && pk < k), "{c}: kept out of order");
                    }
                }
                if let Some(vt) = near.tri {
                    let key = FaceRef {
                        tet: vt.tet,
                        index: vt.index,
                        face: vt.face,
                    };
                    assert_eq!(
                        kept.first().map(|(_, t)| t.key()),
                        Some(key),
                        "{c}: the answer is not the first kept face"
                    );
                    assert!(near.d2 <= best_hint, "{c}: farther than a hint in play");
                }
                match exact {
                    Some((e, key, _)) => {
                        assert!(near.d2 >= e, "{c}: closer than the exhaustive answer");
                        if near.complete {
                            completed += 1;
                            assert_eq!(near.d2.to_bits(), e.to_bits(), "{c}");
                            assert_eq!(
                                near.tri.map(|t| (t.tet, t.index, t.face)),
                                Some((key.tet, key.index, key.face))
                            );
                        }
                        if near.tri.is_some() {
                            shortfall += f64::from(near.d2.sqrt() - e.sqrt());
                        }
                    }
                    None => assert!(near.tri.is_none(), "{c}: a face beyond reach"),
                }
                stopped += u32::from(!near.complete);
                hints = if all_kept {
                    kept.iter().map(|&(_, t)| t).collect()
                } else {
                    near.tri.into_iter().collect()
                };
            }
            (shortfall, stopped, completed)
        };
        let (kept_all, stopped, completed) = chain(true);
        let (answer_only, _, _) = chain(false);
        eprintln!(
            "shortfall summed over the path: kept faces {kept_all:.4}, answer only \
             {answer_only:.4} ({stopped} of 120 searches stopped, {completed} complete)"
        );
        assert!(
            stopped > 60,
            "the bound must stop most searches ({stopped})"
        );
        assert!(completed > 0, "no search completed");
        assert!(
            kept_all < answer_only,
            "kept faces {kept_all} not closer than the answer alone {answer_only}"
        );
    });
}

/// One budget for the whole step (`World::set_tick_budget`). Three worlds drill the same path:
/// without a tick budget, with one too large to bind, and with one a third of the first
/// world's busiest step. The second is the first bit for bit (reports and contacts). In the
/// third, at every step the contact search's bound is what the drill left,
/// `min(contact_max_nodes, (budget - drill work) / CONTACT_NODE_UNITS)`, the search keeps to
/// it, the contact face is never nearer than the exhaustive one, and the drill's work stays within
/// the budget plus its last operation's overshoot.
#[test]
fn a_tick_budget_is_shared_by_the_drill_and_the_contact_search() {
    use tetradrill_core::servo::{SimReport, CONTACT_NODE_UNITS};
    let path: Vec<(Vec3, bool)> = (0..160)
        .map(|k| {
            let u = k as f32 / 159.0;
            let c = if k < 60 {
                Vec3::new(0.0, 0.0, 0.58 - 0.004 * k as f32)
            } else {
                Vec3::new(0.25 * (u - 0.375), 0.04 * (9.0 * u).sin(), 0.34)
            };
            (c, k % 40 < 30)
        })
        .collect();
    let run = |budget: Option<u32>, check: &mut dyn FnMut(&World<'_>, &SimReport, Vec3, bool)| {
        let mut reports = Vec::new();
        on_block4(|world, params, r, reach| {
            world.set_tick_budget(budget);
            assert_eq!(world.tick_budget(), budget);
            for &(c, drill) in &path {
                let rep = world.simulate(c, r, reach, drill, params);
                check(world, &rep, c, drill);
                reports.push((rep, *world.contact()));
            }
        });
        reports
    };
    let plain = run(None, &mut |_, _, _, _| {});
    let roomy = run(Some(u32::MAX), &mut |_, _, _, _| {});
    assert_eq!(plain, roomy, "a budget that never binds changed a step");
    let busiest = plain.iter().map(|(r, _)| r.drill.work).max().unwrap();
    let t = busiest / 3;
    assert!(t > 100, "the path must give the drill work ({busiest})");
    let (mut bound_cut, mut over, mut steps_at_budget, mut kept_plane) = (0, 0u32, 0, 0);
    run(Some(t), &mut |world, rep, c, drill| {
        let left = t.saturating_sub(rep.drill.work) / CONTACT_NODE_UNITS;
        assert_eq!(
            rep.contact_bound,
            left.min(world.contact_max_nodes()),
            "at {c}"
        );
        assert!(rep.contact_nodes <= rep.contact_bound, "at {c}");
        bound_cut += u32::from(rep.contact_bound < world.contact_max_nodes());
        if rep.drill.work >= t {
            steps_at_budget += 1;
            over = over.max(rep.drill.work - t);
        }
        let (h, m) = (world.hierarchy(), world.mesh());
        let mut cands = world.candidates().to_vec();
        cands.sort_unstable();
        let r = 0.1;
        let want = exhaustive_uncut(h, m, &cands, c, r + 0.05, drill.then_some(r));
        let got = world.contact();
        kept_plane += u32::from(got.centre != c);
        if let (true, true, Some((d2, _, _))) = (got.valid, got.centre == c, want) {
            // The contact point is on the face the search chose (unless it found none and
            // kept an older step's plane): never nearer than the exhaustive closest face.
            let d = (c - got.point).length();
            assert!(
                d >= d2.sqrt() * (1.0 - 1e-6),
                "{c}: {d} nearer than {}",
                d2.sqrt()
            );
        }
    });
    eprintln!(
        "tick budget {t} (busiest step {busiest}): {steps_at_budget} steps spent it, \
         overshoot at most {over}, contact bound cut at {bound_cut} steps, an older plane \
         kept at {kept_plane}"
    );
    assert!(
        steps_at_budget > 0 && bound_cut > 0,
        "the budget never bound"
    );
    assert!(over < 256, "the drill overshot the budget by {over} units");
}
