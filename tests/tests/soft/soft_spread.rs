//! The soft step spread over ticks: a step sliced into random amounts of work
//! (`SoftBody::begin_step`, `SoftBody::advance`) leaves the same bits as the whole step
//! (`SoftBody::step`, the same code given all the units at once), step after step, on a block
//! under a load and gravity: the slicing changes nothing. The step's physics is checked
//! against oracles elsewhere (`soft_body`, `soft_block`, `soft_tooth`).

use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use tetradrill::soft::SoftOwned;
use tetradrill_core::soft::{Material, SoftParams, TET_UNITS};
use tetradrill_core::Vec3;
use tetradrill_tests::search::block_mesh;

fn params() -> SoftParams {
    SoftParams {
        gravity: Vec3::new(0.0, 0.0, -9.81),
        damping: 5.0,
        substeps: 3,
        iterations: 2,
    }
}

const MATERIAL: Material = Material {
    young: 2e3,
    poisson: 0.3,
    density: 1000.0,
};

/// The bits of a body's state.
fn bits(u: &[Vec3], v: &[Vec3]) -> Vec<u32> {
    u.iter()
        .chain(v)
        .flat_map(|x| x.to_array().map(f32::to_bits))
        .collect()
}

#[test]
fn random_slicings_give_the_whole_steps_bits() {
    let mut om = block_mesh(3);
    let mut whole = SoftOwned::from_mesh(&om.view());
    let mut spread = whole.clone();
    let n = whole.rest.len();
    // A load on the top nodes, different every step.
    let top: Vec<usize> = (0..n).filter(|&i| whole.rest[i].z > 0.49).collect();
    let mut a = whole.body(&[MATERIAL], params()).unwrap();
    let mut b = spread.body(&[MATERIAL], params()).unwrap();
    let origin = Vec3::new(0.0, 0.0, -0.45);
    assert!(a.fix_below(origin, Vec3::Z) > 0);
    b.fix_below(origin, Vec3::Z);
    let per_step = b.step_units();
    let mut rng = StdRng::seed_from_u64(27);
    let mut external = vec![Vec3::ZERO; n];
    let mut calls_total = 0u64;
    for k in 0..12 {
        external.fill(Vec3::ZERO);
        for &i in &top {
            external[i] = Vec3::new(0.3 * (k % 3) as f32, -0.1, -2.0 - k as f32);
        }
        a.step(2e-3, &external).unwrap();
        b.begin_step(2e-3).unwrap();
        // A slicing of its own each step: from the smallest that always progresses to a
        // whole step at once.
        let most = [TET_UNITS, 3 * TET_UNITS, 1000, u32::MAX][k % 4];
        let mut units = 0u64;
        loop {
            let w = rng.gen_range(TET_UNITS..=most.max(TET_UNITS));
            let adv = b.advance(&external, w);
            assert!(adv.units <= w);
            units += u64::from(adv.units);
            calls_total += 1;
            if adv.done {
                break;
            }
            assert!(b.stepping());
        }
        assert_eq!(units, per_step, "step {k}");
        assert_eq!(
            bits(a.displacements(), a.velocities()),
            bits(b.displacements(), b.velocities()),
            "step {k}"
        );
    }
    // The load moved the body (the comparison is not between two bodies at rest).
    let sag = a
        .displacements()
        .iter()
        .map(|u| u.length())
        .fold(0.0, f32::max);
    assert!(sag > 1e-4, "sag {sag}");
    assert!(calls_total > 100);
}
