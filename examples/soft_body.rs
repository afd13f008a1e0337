//! A soft block (Young's modulus 5 kPa, Poisson ratio 0.3) held at its bottom face and
//! pressed on its top face: it settles into a dent whose depth is proportional to the load
//! (linear elasticity: twice the load, twice the dent), and its held nodes never move.
//!
//! `cargo run --release -p tetradrill-examples --example soft_body`

use tetradrill::meshio;
use tetradrill::soft::SoftOwned;
use tetradrill_core::soft::{Material, SoftParams};
use tetradrill_core::Vec3;

/// The top face's sag after one second under `load` newtons spread over its nodes, and the
/// largest move of a held node.
fn sag(load: f32) -> Result<(f32, f32), Box<dyn std::error::Error>> {
    let mut block = meshio::load(std::path::Path::new("builtin:block:4"), 1.0)?.mesh;
    let mut owned = SoftOwned::from_mesh(&block.view());
    let material = Material {
        young: 5_000.0,
        poisson: 0.3,
        density: 1_000.0,
    };
    let params = SoftParams {
        damping: 20.0,
        substeps: 20,
        ..SoftParams::default()
    };
    let mut body = owned.body(&[material], params)?;
    body.fix_below(Vec3::new(0.0, 0.0, -0.49), Vec3::Z);

    let top: Vec<usize> = (0..body.node_count())
        .filter(|&i| body.rest()[i].z > 0.49)
        .collect();
    let mut loads = vec![Vec3::ZERO; body.node_count()];
    for &i in &top {
        loads[i] = Vec3::new(0.0, 0.0, -load / top.len() as f32);
    }
    for _ in 0..250 {
        body.step(0.004, &loads)?; // 250 steps of 4 ms
    }
    let d = body.displacements();
    let sag = -top.iter().map(|&i| d[i].z).sum::<f32>() / top.len() as f32;
    let held = (0..body.node_count())
        .filter(|&i| body.is_fixed(i))
        .map(|i| d[i].length())
        .fold(0.0, f32::max);
    Ok((sag, held))
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let (one, held1) = sag(50.0)?;
    let (two, held2) = sag(100.0)?;
    println!(
        "top face sag: {:.2} mm under 50 N, {:.2} mm under 100 N",
        one * 1e3,
        two * 1e3
    );
    if !(one > 0.0 && two > one) {
        return Err("the top face must sink, more under more load".into());
    }
    let ratio = two / one;
    if !(1.8..=2.2).contains(&ratio) {
        return Err(format!("twice the load gave {ratio:.3} times the sag").into());
    }
    if held1.max(held2) != 0.0 {
        return Err("a held node moved".into());
    }
    Ok(())
}

#[test]
fn runs() {
    main().unwrap();
}
