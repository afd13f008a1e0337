//! The drill's resolution in mesh units (`--resolution L`): a fine mesh and a coarse one drill
//! with leaves of the same size, so a plunge removes the analytic swept volume on both with
//! about the same number of hierarchy nodes, where a depth limit alone gives the fine mesh
//! leaves half the size and far more nodes.

use tetradrill_tests::{json_of, scratch_dir};

/// A plunge of a 0.15 burr from above the block's top face (z = 0.5) down to z = 0.1, held
/// there for 3 s so the drill catches up.
fn plunge(mesh: &str, extra: &[&str], name: &str) -> serde_json::Value {
    let dir = scratch_dir("resolution-trace", name);
    let trace = dir.join("plunge.csv");
    std::fs::write(
        &trace,
        "t,x,y,z,qw,qx,qy,qz,buttons\n0.0,0.013,0.021,0.9,1,0,0,0,1\n\
         0.5,0.013,0.021,0.9,1,0,0,0,1\n2.0,0.013,0.021,0.1,1,0,0,0,1\n\
         5.0,0.013,0.021,0.1,1,0,0,0,1\n",
    )
    .expect("trace");
    let trace = trace.to_string_lossy().into_owned();
    let mut args = vec![
        "replay",
        "--mesh",
        mesh,
        "--trace",
        &trace,
        "--tool",
        "sphere:0.15",
        "--quiet",
    ];
    args.extend_from_slice(extra);
    json_of(&args, "resolution", name)
}

#[test]
fn fine_and_coarse_meshes_drill_with_leaves_of_one_size() {
    // The swept volume, analytic: a cylinder of radius 0.15 from z = 0.1 to the top face and
    // the half ball below it (both inside the block).
    let r = 0.15f64;
    let swept = std::f64::consts::PI * r * r * 0.4 + 2.0 / 3.0 * std::f64::consts::PI * r.powi(3);
    let res = ["--resolution", "0.03", "--max-depth", "9"];
    let coarse = plunge("builtin:block:4", &res, "coarse");
    let fine = plunge("builtin:block:8", &res, "fine");
    for (name, j) in [("block:4", &coarse), ("block:8", &fine)] {
        let v = j["removed_volume"].as_f64().expect("removed");
        assert!(
            (v - swept).abs() < 0.01 * swept,
            "{name}: removed {v}, swept {swept}"
        );
        assert_eq!(j["valid"], true);
    }
    // The same leaves: the nodes the drill made differ by less than a quarter (the meshes' tets
    // are cut differently), not by the factor eight a level more would cost.
    let nodes = |j: &serde_json::Value| j["hierarchy_nodes"].as_f64().expect("nodes");
    let ratio = nodes(&fine) / nodes(&coarse);
    assert!(
        (0.8..1.25).contains(&ratio),
        "{ratio}: {fine} against {coarse}"
    );
    // A depth limit alone (4 on both) gives the fine mesh's tets leaves half the size: far
    // more nodes for the same cut.
    let depth_coarse = plunge("builtin:block:4", &["--max-depth", "4"], "depth-coarse");
    let depth_fine = plunge("builtin:block:8", &["--max-depth", "4"], "depth-fine");
    assert!(
        nodes(&depth_fine) > 2.0 * nodes(&depth_coarse),
        "{} against {}",
        nodes(&depth_fine),
        nodes(&depth_coarse)
    );
}

#[test]
fn a_negative_resolution_is_refused() {
    tetradrill_tests::refused(
        &["replay", "--resolution", "-1", "--json", "/dev/null"],
        &["--resolution"],
    );
}
