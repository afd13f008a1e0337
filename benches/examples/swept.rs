//! The volume a burr's path sweeps through a mesh, by Monte Carlo: the reference a drill's
//! removed volume is held against (`scripts/clinical-drill.sh`).
//!
//! ```text
//! cargo run --release -p tetradrill-benches --example swept -- MESH TRACE RADIUS [SAMPLES]
//! ```
//!
//! Prints `swept VOLUME se RELATIVE_ERROR` (mesh units cubed): the union of the burr spheres
//! at every tick of the trace's drilling part (its button on) intersected with the mesh, from
//! SAMPLES (default 1,000,000) seeded samples, in f64 (`tetradrill_benches::swept`).

use std::path::PathBuf;
use std::process::ExitCode;

use tetradrill::traces::PoseSource;
use tetradrill::Poses;
use tetradrill_benches::swept::swept_volume;

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (Some(mesh), Some(trace), Some(r)) = (args.first(), args.get(1), args.get(2)) else {
        eprintln!("usage: swept MESH TRACE RADIUS [SAMPLES]");
        return ExitCode::from(2);
    };
    let Ok(r) = r.parse::<f32>() else {
        eprintln!("swept: RADIUS {r:?} is not a number");
        return ExitCode::from(2);
    };
    let samples = match args.get(3).map(|s| s.parse::<usize>()) {
        None => 1_000_000,
        Some(Ok(n)) if n > 0 => n,
        Some(_) => {
            eprintln!("swept: SAMPLES must be a positive count");
            return ExitCode::from(2);
        }
    };
    let mut loaded = match tetradrill::meshio::load(&PathBuf::from(mesh), 1.0) {
        Ok(l) => l,
        Err(e) => {
            eprintln!("swept: {e}");
            return ExitCode::from(2);
        }
    };
    let poses = match Poses::parse(trace) {
        Ok(p) => p,
        Err(e) => {
            eprintln!("swept: {e}");
            return ExitCode::from(2);
        }
    };
    let poses = match PoseSource::new(&poses, Some(&loaded.mesh)) {
        Ok(p) => p,
        Err(e) => {
            eprintln!("swept: {e}");
            return ExitCode::from(2);
        }
    };
    let centres: Vec<_> = (0..poses.ticks())
        .map(|i| poses.at(i))
        .filter(|p| p.buttons & tetradrill_core::script::DRILL_ON != 0)
        .map(|p| p.position)
        .collect();
    let mesh = loaded.mesh.view();
    let (v, se) = swept_volume(&mesh, &centres, r, samples);
    println!("swept {v:.6e} se {se:.4}");
    ExitCode::SUCCESS
}
