//! The soft bench's scenario run from rest for a given number of steps, its displacements
//! written as text: our side of the cross-check against `scripts/xpbd_reference.py`.
//!
//! Usage: `soft_positions MESH STEPS OUT [file-order] [ITERATIONS]` (MESH relative to the meshes folder:
//! `TETRADRILL_MESHES` or the repository's `tests/data/meshes`; `file-order` keeps the file's
//! node and tet order, so the Gauss-Seidel sweep runs in the file's tet order instead of the
//! loader's spatial order; ITERATIONS, default 1, the Gauss-Seidel sweeps per substep). The scenario is the soft
//! bench's: E = 100 kPa, nu = 0.3, density 1000, gravity 9.81 down z, damping 20 /s, the nodes
//! at or below the lowest tenth of the z extent fixed, steps of 1 ms with 10 substeps of one
//! iteration, starting at rest. OUT gets one line per node, in the mesh's node order:
//! `x y z ux uy uz fixed` (rest position, displacement, 1 if fixed); the mean time of a step
//! is printed. Exit status 2 for bad arguments, an unreadable mesh or an unwritable OUT.

use std::io::Write;
use std::process::ExitCode;
use std::time::Instant;

use tetradrill::meshio::{self, ReadOptions};
use tetradrill::soft::SoftOwned;
use tetradrill_benches::{meshes_dir, soft_bench_body};
use tetradrill_core::soft::MAX_ITERATIONS;

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let usage = "usage: soft_positions MESH STEPS OUT [file-order] [ITERATIONS]";
    let (Some(mesh), Some(steps), Some(out)) = (args.first(), args.get(1), args.get(2)) else {
        eprintln!("{usage}");
        return ExitCode::from(2);
    };
    let mut rest = &args[3..];
    let file_order = rest.first().is_some_and(|a| a == "file-order");
    if file_order {
        rest = &rest[1..];
    }
    let iterations = match rest {
        [] => 1,
        [n] => match n.parse::<u32>() {
            Ok(n) if (1..=MAX_ITERATIONS).contains(&n) => n,
            _ => {
                eprintln!("soft_positions: ITERATIONS must be 1..={MAX_ITERATIONS}, not `{n}`");
                return ExitCode::from(2);
            }
        },
        _ => {
            eprintln!("{usage}");
            return ExitCode::from(2);
        }
    };
    let steps = match steps.parse::<usize>() {
        Ok(n) if n > 0 => n,
        _ => {
            eprintln!("soft_positions: STEPS must be a positive whole number, not `{steps}`");
            return ExitCode::from(2);
        }
    };
    let path = meshes_dir().join(mesh);
    let options = ReadOptions {
        file_order,
        ..ReadOptions::default()
    };
    let mut owned = match meshio::load_with(&path, 1.0, &options) {
        Ok(m) => m.mesh,
        Err(e) => {
            eprintln!("soft_positions: {}: {e}", path.display());
            return ExitCode::from(2);
        }
    };
    let mut soft = SoftOwned::from_mesh(&owned.view());
    let (mut body, fixed) = match soft_bench_body(&mut soft, iterations) {
        Ok(b) => b,
        Err(e) => {
            eprintln!("soft_positions: {mesh}: {e}");
            return ExitCode::from(2);
        }
    };
    let t0 = Instant::now();
    for _ in 0..steps {
        if let Err(e) = body.step(1e-3, &[]) {
            eprintln!("soft_positions: step refused: {e}");
            return ExitCode::from(2);
        }
    }
    let per_step = t0.elapsed().as_secs_f64() / steps as f64;
    let mut text = String::with_capacity(body.node_count() * 100);
    for (i, (x, u)) in body.rest().iter().zip(body.displacements()).enumerate() {
        text.push_str(&format!(
            "{:e} {:e} {:e} {:e} {:e} {:e} {}\n",
            x.x,
            x.y,
            x.z,
            u.x,
            u.y,
            u.z,
            u8::from(body.is_fixed(i))
        ));
    }
    let written = std::fs::File::create(out).and_then(|mut f| f.write_all(text.as_bytes()));
    if let Err(e) = written {
        eprintln!("soft_positions: {out}: {e}");
        return ExitCode::from(2);
    }
    let worst = body
        .displacements()
        .iter()
        .map(|u| u.length())
        .fold(0.0f32, f32::max);
    println!(
        "soft_positions {mesh}: {} nodes ({fixed} fixed), {} tets, {steps} steps, {:.2} ms a step, max displacement {worst:e}",
        body.node_count(),
        body.tet_count(),
        per_step * 1e3
    );
    ExitCode::SUCCESS
}
