//! Drills the built-in block along the demo's scripted path with a spherical burr and
//! checks what a drill must do: the force stays within its clamp and pushes the burr out of
//! the material, material is removed, and the drilled surface is larger than the block's.
//!
//! `cargo run --release -p tetradrill-examples --example drill_block`

use tetradrill::prelude::*;
use tetradrill::traces::PoseSource;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    // The demo's block (8 cubes a side, unit size) and a burr of radius 0.1.
    let setup = Setup::new("builtin:block:8", Tool::sphere(0.1));
    let poses = PoseSource::new(&Poses::Demo, None)?;
    let mut drilling = Drilling::new(&setup)?;
    let mut run = drilling.start()?;
    let area_before = run.surface().area();

    let (mut max_force, mut pushing_out) = (0.0f32, 0u64);
    for i in 0..poses.ticks() {
        let pose = poses.at(i);
        let force = run.tick(&pose);
        max_force = max_force.max(force.length());
        // Inside the block the force points away from the block's centre.
        if force != Vec3::ZERO && force.dot(pose.position) > 0.0 {
            pushing_out += 1;
        }
    }

    let surface = run.surface();
    println!(
        "{} ticks: removed {:.5} of {:.5}, {} triangles (area {:.3} -> {:.3}), max force {:.2} N",
        poses.ticks(),
        run.removed_volume(),
        run.initial_volume(),
        surface.triangles(),
        area_before,
        surface.area(),
        max_force
    );
    check(
        max_force <= setup.forces.max_force as f32 + 1e-3,
        "the force stays clamped",
    )?;
    check(
        pushing_out > 1000,
        "the force pushes the burr out of the material",
    )?;
    check(run.removed_volume() > 0.001, "the burr removed material")?;
    check(
        run.removed_volume() < run.initial_volume(),
        "not more than the block",
    )?;
    check(
        surface.area() > area_before,
        "the cavity's walls add surface",
    )?;
    Ok(())
}

/// `Err` naming `what` unless `ok`.
fn check(ok: bool, what: &str) -> Result<(), String> {
    ok.then_some(()).ok_or(format!("check failed: {what}"))
}

#[test]
fn runs() {
    main().unwrap();
}
