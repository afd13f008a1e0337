//! The shaft's points walking the drilled surface together (`force::offer_near`, pruned as
//! each point learns its nearest face) against a brute force: each point offered every
//! visible face of the v_list ([`Hierarchy::for_each_visible`], which walks no tree), in the
//! v_list's order and in the reverse order. On the cube drilled at random, with points on
//! either side of the surface, moving short and long segments, the states agree bit for bit.

use glam::Vec3;

use super::passive::{offer_near, PassivePoint, PassiveProbe};
use super::MAX_PASSIVE;
use crate::builtin::CUBE12_TETS;
use crate::hierarchy::test_support::{cube_hierarchy, mesh, random_op, Cube, Rng};
use crate::ids::TetId;

/// Most faces the brute force holds.
const MAX: usize = 4096;

#[test]
fn points_walking_together_answer_as_if_offered_every_face() {
    let mut c = Cube::new();
    let mesh = mesh(&mut c);
    cube_hierarchy!(h, &mesh, 8 * 256);
    let all: [TetId; CUBE12_TETS] = core::array::from_fn(TetId::from_idx);
    let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
    let unit = |rng: &mut Rng| rng.next() as f32 / u32::MAX as f32;
    let mut faces = [((0u32, 0u32, 0u8), [Vec3::ZERO; 3]); MAX];
    let (mut planes, mut held) = (0usize, 0usize);
    for round in 0..80 {
        for _ in 0..6 {
            random_op(&mut h, &mesh, &mut rng);
        }
        let mut m = 0;
        h.for_each_visible(&mesh, |tri| {
            faces[m] = ((tri.tet.0, tri.index, tri.face), tri.corners);
            m += 1;
        });
        let faces = &faces[..m];
        let reach = 0.02 + 0.2 * unit(&mut rng);
        let mut probes = [None; MAX_PASSIVE];
        let mut states = [PassivePoint::default(); MAX_PASSIVE];
        let mut want = 0u32;
        for (k, (probe, state)) in probes.iter_mut().zip(&mut states).enumerate() {
            let mut point =
                || Vec3::new(unit(&mut rng), unit(&mut rng), unit(&mut rng)) * 1.2 - 0.6;
            let to = point();
            // Short moves mostly, some across the cube, some with no proxy yet.
            let from = match k % 4 {
                0 => None,
                1 => Some(point()),
                _ => Some(to + (point() * 0.1)),
            };
            *state = PassivePoint {
                proxy: from,
                ..PassivePoint::default()
            };
            // A point left out of the walk (as a held one is) is offered nothing.
            if round % 5 != 0 || k % 7 != 3 {
                want |= 1 << k;
            }
            *probe = Some(PassiveProbe::new(state, to, reach));
        }
        let brute = |reverse: bool| {
            probes.map(|p| {
                p.map(|mut p| {
                    for i in 0..faces.len() {
                        let (key, corners) = faces[if reverse { faces.len() - 1 - i } else { i }];
                        p.offer(corners, key);
                    }
                    p
                })
            })
        };
        let (forward, backward) = (brute(false), brute(true));
        let mut walked = probes;
        let walk = offer_near(&h, &mesh, &all, &mut walked, (want, u32::MAX), |_| true);
        assert!(!walk.cut, "round {round}");
        for k in 0..MAX_PASSIVE {
            let finish = |p: Option<PassiveProbe>| {
                let mut s = states[k];
                if let Some(p) = p {
                    p.finish(&mut s);
                }
                s
            };
            let got = finish(walked[k]);
            if want & (1 << k) == 0 {
                assert_eq!(
                    walked[k].map(|p| p.triangles()),
                    Some(0),
                    "round {round}, point {k}"
                );
                continue;
            }
            assert_eq!(got, finish(forward[k]), "round {round}, point {k}");
            assert_eq!(got, finish(backward[k]), "round {round}, point {k}");
            planes += got.plane.is_some() as usize;
            held += got.held.is_some() as usize;
        }
    }
    // The rounds met faces and crossed them (the test is not empty).
    assert!(planes > 300 && held > 100, "{planes} {held}");
}
