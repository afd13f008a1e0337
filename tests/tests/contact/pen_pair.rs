//! The pen's contact pass on two threads (`PenPair`) against the one-thread pass
//! (`pen_contact`, itself checked against an f64 reference in `pen_reference.rs`): over the
//! contact bench's teddy poses, touching and impaled, in a row with the state carried and each
//! from a fresh state, every result bit for bit: the forces, the reports, the penetrations of
//! both bodies and the next pass's starting lists. Entries beyond a pass's count are left
//! from earlier passes, so whole buffers are compared after the same sequence of poses.

use glam::{Quat, Vec3};
use tetradrill::pen_pair::with_pen_pair;
use tetradrill_benches::{impaled_poses, touch_poses};
use tetradrill_core::depth::Penetration;
use tetradrill_core::force::{pen_contact, PenContact, PenOptions, PenState};
use tetradrill_tests::contact::{rig, COW, TEDDY};

/// What one call leaves: the contact, the state and the whole penetration buffers.
type Outcome = (PenContact, PenState, Vec<Penetration>, Vec<Penetration>);

fn bits(p: &[Penetration]) -> Vec<[u32; 7]> {
    p.iter()
        .map(|p| {
            [
                p.node.0,
                p.tet.0,
                p.layer,
                p.depth.to_bits(),
                p.dir.x.to_bits(),
                p.dir.y.to_bits(),
                p.dir.z.to_bits(),
            ]
        })
        .collect()
}

fn same(label: &str, i: usize, a: &Outcome, b: &Outcome) {
    let force =
        |c: &PenContact| [c.raw, c.force, c.display_offset].map(|v| v.to_array().map(f32::to_bits));
    assert_eq!(force(&a.0), force(&b.0), "{label} pose {i}: force");
    assert_eq!(a.0.pass(), b.0.pass(), "{label} pose {i}: reports");
    assert_eq!(a.1.pen_listed, b.1.pen_listed, "{label} pose {i}: pen list");
    assert_eq!(
        a.1.object_listed, b.1.object_listed,
        "{label} pose {i}: object list"
    );
    assert_eq!(bits(&a.2), bits(&b.2), "{label} pose {i}: pen depths");
    assert_eq!(bits(&a.3), bits(&b.3), "{label} pose {i}: object depths");
}

/// Both passes over `poses`, state carried (`carried`) or fresh each call.
fn check(obj: &str, label: &str, touching: bool, carried: bool) {
    let mut r = rig(10.0, obj, 1.0);
    let poses: Vec<(Vec3, Quat)> = {
        let v = r.obj.view();
        if touching {
            touch_poses(&v, 200, 0.05, 7)
        } else {
            impaled_poses(&v, 200, 0.25, 7)
        }
    };
    let opts = PenOptions::default();
    let one: Vec<Outcome> = r
        .with(|scene, bufs| {
            let mut st = PenState::default();
            poses
                .iter()
                .map(|&(p, q)| {
                    if !carried {
                        st = PenState::default();
                    }
                    let c = pen_contact(scene, bufs, p, q, &opts, &mut st);
                    (c, st, bufs.pen_pens.to_vec(), bufs.object_pens.to_vec())
                })
                .collect()
        })
        .expect("rig builds");
    let two: Vec<Outcome> = r
        .with(|scene, bufs| {
            with_pen_pair(scene, bufs, |pair| {
                let mut st = PenState::default();
                poses
                    .iter()
                    .map(|&(p, q)| {
                        if !carried {
                            st = PenState::default();
                        }
                        let c = pair.contact(p, q, &opts, &mut st).expect("worker runs");
                        (c, st, pair.pen_pens().to_vec(), pair.object_pens().to_vec())
                    })
                    .collect()
            })
        })
        .expect("rig builds");
    assert_eq!(one.len(), two.len());
    let touched = one.iter().filter(|o| o.0.penetrations.1 > 0).count();
    assert!(
        touched > 0,
        "{label}: some poses put object nodes in the pen"
    );
    for (i, (a, b)) in one.iter().zip(&two).enumerate() {
        same(label, i, a, b);
    }
}

#[test]
fn the_pair_matches_one_thread_on_the_teddy_touching_state_carried() {
    check(TEDDY, "teddy touching", true, true);
}

#[test]
fn the_pair_matches_one_thread_on_the_teddy_impaled_fresh_states() {
    check(TEDDY, "teddy impaled", false, false);
}

#[test]
fn the_pair_matches_one_thread_on_the_cow_touching_fresh_states() {
    check(COW, "cow touching", true, false);
}
