//! The soft step's displacement field against a recorded one: the soft bench's scenario on the
//! cow (E = 100 kPa, nu = 0.3, 1000 kg/m^3, gravity, damping 20 /s, the lowest tenth fixed,
//! 1 ms steps of 10 substeps x 1 iteration) run from rest for 100 steps. The golden file
//! `tests/data/soft/cow_bench_100_steps.txt` holds the field the sequential Gauss-Seidel
//! sweep gave before the step was made faster (`soft_positions models/spot_tetgen_q1.414.node
//! 100 OUT`, one line per node: rest position, displacement, fixed), so it shares no code with
//! the present step: each way of stepping must stay within 1 % of it (relative L2 over the
//! nodes, matched by rest position) and fix the same nodes.

use std::collections::HashMap;

use tetradrill::soft::SoftOwned;
use tetradrill_core::soft::SoftBody;
use tetradrill_core::Vec3;
use tetradrill_tests::{load, workspace_root};

/// The recorded field by rest position (bits of x, y, z): displacement and whether fixed.
fn golden() -> HashMap<[u32; 3], (Vec3, bool)> {
    let path = workspace_root().join("tests/data/soft/cow_bench_100_steps.txt");
    let text = std::fs::read_to_string(&path).expect("golden field");
    let mut out = HashMap::new();
    for line in text.lines() {
        let v: Vec<f32> = line
            .split_whitespace()
            .map(|w| w.parse().expect("a number"))
            .collect();
        assert_eq!(v.len(), 7, "{line}");
        let key = [v[0].to_bits(), v[1].to_bits(), v[2].to_bits()];
        out.insert(key, (Vec3::new(v[3], v[4], v[5]), v[6] == 1.0));
    }
    out
}

/// Relative L2 difference of `body`'s field from the golden one, after checking both fix the
/// same nodes.
pub(crate) fn relative_l2(body: &SoftBody<'_>) -> f64 {
    let gold = golden();
    assert_eq!(gold.len(), body.node_count());
    let (mut diff, mut norm) = (0.0f64, 0.0f64);
    for (i, (x, u)) in body.rest().iter().zip(body.displacements()).enumerate() {
        let key = [x.x.to_bits(), x.y.to_bits(), x.z.to_bits()];
        let (g, fixed) = gold.get(&key).copied().expect("the same rest node");
        assert_eq!(fixed, body.is_fixed(i), "node {i}");
        let sq = |v: Vec3| {
            [v.x, v.y, v.z]
                .map(|c| c as f64 * c as f64)
                .iter()
                .sum::<f64>()
        };
        diff += sq(*u - g);
        norm += sq(g);
    }
    assert!(norm > 0.0);
    (diff / norm).sqrt()
}

/// The cow's soft body of the bench's scenario over `soft`.
pub(crate) fn cow() -> SoftOwned {
    let mut owned = load("models/spot_tetgen_q1.414.node", 1.0);
    SoftOwned::from_mesh(&owned.view())
}

#[test]
fn the_sequential_step_keeps_the_recorded_field() {
    let mut soft = cow();
    let (mut body, _) = tetradrill_benches::soft_bench_body(&mut soft, 1).unwrap();
    for _ in 0..100 {
        body.step(1e-3, &[]).unwrap();
    }
    let err = relative_l2(&body);
    eprintln!("sequential step: relative L2 {err:e} from the recorded field");
    assert!(err < 1e-2, "{err}");
}
