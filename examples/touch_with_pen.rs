//! Presses a pen-shaped tet-mesh tool into the built-in block, tip first, and checks the
//! consistent penetration depth's force: none before the tip reaches the top face, then
//! upward, and growing as the pen goes deeper.
//!
//! `cargo run --release -p tetradrill-examples --example touch_with_pen [PEN_MESH]`

use tetradrill::pen::Touching;
use tetradrill::prelude::*;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let default = format!("{}/models/pen_tool_gmsh.mesh", tetradrill_examples::MESHES);
    // Under `cargo test` the arguments are the test harness's: the default then.
    let arg = std::env::args().nth(1).filter(|_| !cfg!(test));
    let pen = arg.unwrap_or(default);
    let mut setup = Setup::new("builtin:block:6", Tool::mesh(pen));
    setup.forces.max_force = 1.0e6; // no clamp in the way of the depth's growth
    let mut touching = Touching::new(&setup)?;

    // The tip from 0.05 above the top face (z = 0.5) to 0.08 below it, the axis up.
    let forces = touching.run(|touch| {
        (0..=26)
            .map(|i| {
                let z = 0.55 - 0.005 * i as f32;
                (z, touch.tick(&Pose::at(Vec3::new(0.01, 0.02, z))).force)
            })
            .collect::<Vec<_>>()
    })?;
    for (z, f) in forces.iter().step_by(4) {
        println!(
            "tip at z = {z:.3}: force ({:.2}, {:.2}, {:.2}) N",
            f.x, f.y, f.z
        );
    }

    let above = forces.iter().filter(|(z, _)| *z > 0.5 + 1e-4);
    if above.clone().any(|(_, f)| *f != Vec3::ZERO) {
        return Err("a force before the pen touched".into());
    }
    let inside: Vec<f32> = forces
        .iter()
        .filter(|(z, _)| *z < 0.49)
        .map(|(_, f)| f.z)
        .collect();
    if inside.iter().any(|&fz| fz <= 0.0) {
        return Err("the block must push the pen back up".into());
    }
    if inside.windows(2).any(|w| w[1] < w[0]) {
        return Err(format!("the force must grow with depth: {inside:?}").into());
    }
    Ok(())
}

#[test]
fn runs() {
    main().unwrap();
}
