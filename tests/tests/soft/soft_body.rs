//! The soft body on a real mesh (the cow, about 18k tets): held at its lowest tenth and loaded
//! by gravity, every tet keeps a positive volume (f64 volumes computed here), the settled
//! state obeys Clapeyron's theorem of linear elasticity (elastic energy = half the work of
//! the loads), and released it returns to rest.

use tetradrill::soft::SoftOwned;
use tetradrill_core::soft::{Material, SoftParams};
use tetradrill_core::Vec3;
use tetradrill_tests::load;

fn det(p: [Vec3; 4]) -> f64 {
    let d = |v: Vec3| [v.x as f64, v.y as f64, v.z as f64];
    let (a, b, c) = (d(p[1] - p[0]), d(p[2] - p[0]), d(p[3] - p[0]));
    a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0])
        + a[2] * (b[0] * c[1] - b[1] * c[0])
}

#[test]
fn cow_sags_under_gravity_as_linear_elasticity_and_springs_back() {
    let mut owned = load("models/spot_tetgen_q1.414.node", 1.0);
    // Its tets grouped in fours that share no node (the sweep's lanes, as the runs have it).
    let mut st = SoftOwned::from_mesh(&owned.view()).in_lanes().0;
    let rest = st.rest.clone();
    let tets = st.tets.clone();
    let n = rest.len();
    // Gravity a tenth of earth's, so the strain stays small (the sag about 1 % of the
    // height); damping near critical for the sag mode (omega about sqrt(g / sag) at full
    // gravity, 11 rad/s): heavier damping makes it creep.
    let mat = Material {
        young: 1e7,
        poisson: 0.3,
        density: 1000.0,
    };
    let g = Vec3::new(0.0, 0.0, -0.981);
    let params = SoftParams {
        gravity: g,
        damping: 22.0,
        substeps: 20,
        iterations: 1,
    };
    let mut body = st.body(&[mat], params).unwrap();
    let (lo, hi) = rest
        .iter()
        .fold((f32::MAX, f32::MIN), |(a, b), x| (a.min(x.z), b.max(x.z)));
    let fixed = body.fix_below(Vec3::new(0.0, 0.0, lo + 0.1 * (hi - lo)), Vec3::Z);
    assert!(fixed > 0 && fixed < n / 2, "{fixed} of {n} nodes fixed");

    let mut x = vec![Vec3::ZERO; n];
    let mut smallest = f64::MAX;
    for k in 0..1200 {
        body.step(1e-3, &[]).unwrap();
        if k % 25 == 24 {
            body.write_positions(&mut x);
            for tet in &tets {
                smallest = smallest.min(det(tet.map(|i| x[i as usize])));
            }
        }
    }
    assert!(smallest > 0.0, "a tet inverted: {smallest}");
    // Clapeyron: at equilibrium of a linear body, U = W / 2 with W = sum m_i g . u_i.
    let work: f64 = body
        .masses()
        .iter()
        .zip(body.displacements())
        .map(|(&mi, ui)| mi as f64 * g.dot(*ui) as f64)
        .sum();
    let energy = body.elastic_energy();
    let kinetic = body.kinetic_energy();
    let sag = body
        .displacements()
        .iter()
        .map(|u| u.length())
        .fold(0.0f32, f32::max);
    println!(
        "cow: sag {sag:.3e}, elastic {energy:.4e}, half the work {:.4e}, kinetic {kinetic:.2e}",
        work / 2.0
    );
    assert!(work > 0.0 && sag > 0.0);
    assert!(
        kinetic < 1e-3 * energy,
        "not settled: kinetic {kinetic}, elastic {energy}"
    );
    let err = (energy - work / 2.0).abs() / (work / 2.0);
    assert!(err < 0.05, "Clapeyron off by {err}");

    // Released: gravity off, back to rest.
    body.set_params(SoftParams {
        gravity: Vec3::ZERO,
        ..params
    })
    .unwrap();
    for _ in 0..600 {
        body.step(1e-3, &[]).unwrap();
    }
    let left = body
        .displacements()
        .iter()
        .map(|u| u.length())
        .fold(0.0f32, f32::max);
    println!("cow: left {left:.3e} of {sag:.3e}");
    assert!(left < 1e-2 * sag, "{left} left of {sag}");
}
