//! Cuts an access cavity into a premolar (enamel, dentin and pulp as the mesh's region
//! labels 1, 2 and 3) with a 0.7 mm burr, each tissue its own hardness, pressure threshold and
//! stiffness, and prints the volume removed from each. The cavity goes through the enamel
//! into the dentin and opens the pulp chamber: each region must have lost material, and the
//! regions' volumes must add up to the total.
//!
//! `cargo run --release -p tetradrill-examples --example drill_tooth_regions [MESH]`

use tetradrill::prelude::*;
use tetradrill::setup::tooth_regions;
use tetradrill::traces::PoseSource;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let default = format!(
        "{}/models/tooth_premolar_gmsh.msh22.msh",
        tetradrill_examples::MESHES
    );
    // Under `cargo test` the arguments are the test harness's: the default then.
    let arg = std::env::args().nth(1).filter(|_| !cfg!(test));
    let mesh = arg.unwrap_or(default);
    let mut setup = Setup::new(&mesh, Tool::sphere(0.0007)); // metres
    setup.materials.regions = tooth_regions();
    setup.forces.stiffness = 6_000.0;
    setup.poses = Poses::ToothAccess;

    let poses = PoseSource::new(&setup.poses, None)?;
    let mut drilling = Drilling::new(&setup)?;
    let mut run = drilling.start()?;
    for i in 0..poses.ticks() {
        run.tick(&poses.at(i));
    }

    let names = ["", "enamel", "dentin", "pulp"];
    let by_region = run.removed_by_region();
    for &(label, volume) in &by_region {
        let name = names.get(label as usize).unwrap_or(&"other");
        println!(
            "{name:>7} (label {label}): {:.4} mm^3 removed",
            volume * 1e9
        );
    }
    println!("drilled surface: {} triangles", run.surface().triangles());

    let total: f64 = by_region.iter().map(|(_, v)| v).sum();
    let removed = run.removed_volume();
    if (total - removed).abs() > 1e-9 * removed.max(1e-12) + 1e-18 {
        return Err(format!("regions sum to {total}, the total is {removed}").into());
    }
    for label in 1..=3 {
        let v = by_region
            .iter()
            .find(|(l, _)| *l == label)
            .map_or(0.0, |r| r.1);
        if v <= 0.0 {
            return Err(format!("nothing removed from {}", names[label as usize]).into());
        }
    }
    Ok(())
}

#[test]
fn runs() {
    main().unwrap();
}
