//! The host runner end to end: every command-line error path exits 2 with one line naming the
//! flag or the file and line; replays are deterministic; a real-time run of a trace through the
//! simulated device keeps 1 kHz and removes the same volume as the offline replay.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use tetradrill_core::script::DEMO;
use tetradrill_tests::{scratch_dir, tetradrill_bin};

fn run(args: &[&str]) -> Output {
    Command::new(tetradrill_bin())
        .args(args)
        .output()
        .expect("run tetradrill")
}

/// Asserts exit status 2 and a one-line error on stderr containing every `needle`.
fn refused(args: &[&str], needles: &[&str]) {
    let out = run(args);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(
        out.status.code(),
        Some(2),
        "{args:?} should exit 2; stderr: {err}"
    );
    let lines: Vec<&str> = err.lines().filter(|l| !l.trim().is_empty()).collect();
    // clap prints a usage hint after its one error line; ours print exactly one line.
    assert!(!lines.is_empty(), "{args:?}: no message");
    for n in needles {
        assert!(
            lines[0].contains(n),
            "{args:?}: first line {:?} lacks {n:?}",
            lines[0]
        );
    }
}

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).expect("write a scratch file");
    p
}

#[test]
fn bad_flags_exit_2_naming_the_flag() {
    refused(&["replay", "--tool", "sphere:-1"], &["radius"]);
    refused(&["replay", "--tool", "cube:3"], &["sphere:R or mesh:FILE"]);
    refused(&["replay", "--stiffness", "0"], &["stiffness"]);
    refused(&["replay", "--max-depth", "0"], &["max-depth"]);
    refused(&["replay", "--budget-per-tick", "0"], &["budget-per-tick"]);
    refused(&["replay", "--frobnicate"], &["frobnicate"]);
    refused(&["replay", "--repeat", "0"], &["--repeat"]);
    refused(&["replay", "--repeat", "101"], &["--repeat"]);
    refused(
        &[
            "replay",
            "--repeat",
            "2",
            "--tool",
            "mesh:/nonexistent.mesh",
        ],
        &["--repeat", "sphere"],
    );
    refused(&["run", "--device", "joystick"], &["joystick"]);
    refused(&["run", "--duration", "nan"], &["duration"]);
    refused(&["timing", "--duration", "0"], &["duration"]);
    refused(&["replay", "--mesh", "builtin:sphere"], &["builtin:sphere"]);
}

#[test]
fn missing_devices_exit_2_naming_the_device() {
    refused(
        &["run", "--device", "falcon", "--duration", "0.1", "--no-rt"],
        &["falcon"],
    );
    refused(
        &["run", "--device", "touch", "--duration", "0.1", "--no-rt"],
        &["touch"],
    );
    refused(
        &["run", "--device", "omni", "--duration", "0.1", "--no-rt"],
        &["omni"],
    );
}

#[test]
fn bad_scenarios_exit_2_naming_the_file_and_line() {
    let dir = scratch_dir("runner", "scenarios");
    let p = write(
        &dir,
        "typo.toml",
        "mesh = \"builtin:cube12\"\n\nstifness = 3.0\n",
    );
    refused(
        &["replay", "--scenario", p.to_str().unwrap()],
        &["typo.toml:3:", "stifness"],
    );
    let p = write(&dir, "neg.toml", "damping = -1.0\n");
    refused(
        &["replay", "--scenario", p.to_str().unwrap()],
        &["neg.toml", "damping"],
    );
    let p = dir.join("absent.toml");
    refused(
        &["replay", "--scenario", p.to_str().unwrap()],
        &["absent.toml"],
    );
    refused(&["replay", "--scenario", "builtin:nope"], &["builtin:nope"]);
}

#[test]
fn bad_traces_exit_2_naming_the_file_and_line() {
    let dir = scratch_dir("runner", "traces");
    let h = "t,x,y,z,qw,qx,qy,qz,buttons\n";
    let ok = "0.000,0,0,0.9,1,0,0,0,0\n";
    let cases = [
        ("nan.csv", format!("{h}{ok}0.001,NaN,0,0.9,1,0,0,0,0\n"), 3),
        ("inf.csv", format!("{h}{ok}0.001,0,inf,0.9,1,0,0,0,0\n"), 3),
        (
            "back.csv",
            format!("{h}{ok}0.002,0,0,0.9,1,0,0,0,0\n0.001,0,0,0.9,1,0,0,0,0\n"),
            4,
        ),
        ("short.csv", format!("{h}0.000,0,0,0.9,1,0,0\n"), 2),
        ("noheader.csv", ok.to_string(), 1),
    ];
    for (name, text, line) in cases {
        let p = write(&dir, name, &text);
        let at = format!("{name}:{line}:");
        refused(&["replay", "--trace", p.to_str().unwrap()], &[&at]);
    }
    refused(
        &[
            "replay",
            "--trace",
            dir.join("absent.csv").to_str().unwrap(),
        ],
        &["absent.csv"],
    );
}

fn json(path: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(path).expect("read JSON")).expect("parse JSON")
}

#[test]
fn replay_is_deterministic_and_reports_the_documented_fields() {
    let dir = scratch_dir("runner", "replay");
    let (a, b, c) = (dir.join("a.json"), dir.join("b.json"), dir.join("c.json"));
    for (p, repeat) in [(&a, "1"), (&b, "1"), (&c, "3")] {
        let out = run(&[
            "replay",
            "--ticks",
            "2500",
            "--quiet",
            "--repeat",
            repeat,
            "--json",
            p.to_str().unwrap(),
        ]);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        if repeat == "3" {
            let text = String::from_utf8_lossy(&out.stdout);
            assert!(text.contains("fastest of 3 runs"), "{text}");
        }
    }
    let (a, b, c) = (json(&a), json(&b), json(&c));
    // `--repeat 3` replays three times from scratch: the same forces, timed per tick as the
    // fastest of the three.
    assert_eq!(c["force_digest"], a["force_digest"]);
    assert_eq!(c["removed_volume"], a["removed_volume"]);
    assert_eq!((a["runs"].as_u64(), c["runs"].as_u64()), (Some(1), Some(3)));
    for key in [
        "/mesh/nodes",
        "/mesh/tets",
        "/mesh/boundary_faces",
        "/ticks",
        "/initial_volume",
        "/removed_volume",
        "/hierarchy_nodes",
        "/visible_faces",
        "/components",
        "/force/max_n",
        "/force/final",
        "/force_digest",
        "/timing_us/tick_max",
        "/timing_us/tick_p99",
        "/timing_us/tick_mean",
        "/saturations/total",
    ] {
        assert!(a.pointer(key).is_some(), "missing {key}");
    }
    assert_eq!(a["ticks"], 2500);
    assert_eq!(a["force_digest"], b["force_digest"]);
    assert_eq!(a["removed_volume"], b["removed_volume"]);
    assert_eq!(a["hierarchy_nodes"], b["hierarchy_nodes"]);
    // The burr has plunged into the block with the drill on by tick 2500.
    assert!(a["removed_volume"].as_f64().unwrap() > 0.0);
    assert!(a["force"]["max_n"].as_f64().unwrap() > 0.0);
}

/// A real-time run of `ticks` ticks that took `secs` seconds ran on the 1 kHz deadlines: not
/// faster (free-running), and not grossly slower (a wrong period: 2 ms would double it). The
/// bound above is loose: the run's time includes starting and joining its threads, and on a
/// loaded machine late wake-ups stretch it (1,500 ticks took 1.8 s at a load of 10 on two
/// cores); this is a check of pacing, not a benchmark.
fn paced_at_1khz(ticks: f64, secs: f64) -> bool {
    let ms = secs * 1000.0;
    ms >= 0.99 * ticks && ms <= 1.5 * ticks
}

/// The demo path as a trace file, sampled at every servo tick.
fn demo_trace(dir: &Path) -> PathBuf {
    let mut text = String::from("t,x,y,z,qw,qx,qy,qz,buttons\n");
    for i in 0..DEMO.ticks() {
        let (p, b) = DEMO.at(i);
        text.push_str(&format!(
            "{:.3},{},{},{},1,0,0,0,{b}\n",
            i as f64 / 1000.0,
            p.x,
            p.y,
            p.z
        ));
    }
    write(dir, "demo.csv", &text)
}

/// The comparison holds for a scenario whose erosion keeps up with the tool in real time
/// (max depth 3, a budget of 20,000 work units): both runs then converge to the swept volume
/// (~3.4% of the block). With a budget the servo cannot clear, both lag the tool, by amounts
/// that depend on how often each runs the drill, and there is nothing to compare.
#[test]
fn real_time_run_keeps_1khz_and_removes_what_the_replay_removes() {
    let dir = scratch_dir("runner", "realtime");
    let trace = demo_trace(&dir);
    let (rj, oj) = (dir.join("run.json"), dir.join("replay.json"));
    let t = trace.to_str().unwrap();
    // The same scenario for both runs: erosion that keeps up with the tool.
    let keep_up = ["--max-depth", "3", "--budget-per-tick", "20000"];
    let mut args = vec![
        "run",
        "--device",
        "sim",
        "--trace",
        t,
        "--headless",
        "--quiet",
    ];
    args.extend(keep_up);
    args.extend(["--json", rj.to_str().unwrap()]);
    let out = run(&args);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let mut args = vec!["replay", "--trace", t, "--quiet"];
    args.extend(keep_up);
    args.extend(["--json", oj.to_str().unwrap()]);
    let out = run(&args);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let (r, o) = (json(&rj), json(&oj));
    let ticks = r["ticks"].as_f64().unwrap();
    let secs = r["duration_s"].as_f64().unwrap();
    assert_eq!(
        ticks,
        o["ticks"].as_f64().unwrap(),
        "both ran the whole trace"
    );
    assert!(paced_at_1khz(ticks, secs), "{ticks} ticks in {secs} s");
    let (vr, vo) = (
        r["removed_volume"].as_f64().unwrap(),
        o["removed_volume"].as_f64().unwrap(),
    );
    assert!(vo > 0.0, "the replay drilled");
    assert!(
        (vr - vo).abs() <= 0.10 * vo,
        "real time removed {vr}, the replay {vo}"
    );
}

/// `replay` of the mesh tool `tool` (x10) on `builtin:block:8` along `wander:3` for `ticks`
/// ticks (forces clamped at 10 kN), JSON to `json`, plus each flag and value pair in `extra`
/// whose value is not empty.
fn pen_on_block(tool: &str, ticks: u32, json: &Path, extra: &[&str]) -> Output {
    let ticks = ticks.to_string();
    let mut args = vec![
        "replay",
        "--quiet",
        "--mesh",
        "builtin:block:8",
        "--tool",
        tool,
        "--tool-scale",
        "10",
        "--trace",
        "wander:3",
        "--ticks",
        &ticks,
        "--max-force",
        "10000",
        "--json",
        json.to_str().expect("a UTF-8 scratch path"),
    ];
    for flag in extra.chunks(2) {
        if flag.get(1).is_some_and(|v| !v.is_empty()) {
            args.extend(flag);
        }
    }
    run(&args)
}

/// `--crossings`: a mesh tool's border edges take last tick's crossing face when they still
/// cross it by default (the JSON counts them), and search every tick with `search`. On the
/// block, which is convex, a line from inside leaves it once, so the forces agree: to the bit
/// but where a line crosses exactly where two faces meet and the search names the other one
/// (10 of these 1,500 ticks, by at most 1e-4 N). A bad value exits 2 naming the flag.
#[test]
fn mesh_tool_crossings_reuse_by_default_and_search_on_request() {
    let dir = scratch_dir("runner", "crossings");
    let pen = tetradrill_tests::mesh("models/pen_tool_gmsh.mesh");
    let tool = format!("mesh:{}", pen.display());
    let mut runs = Vec::new();
    for mode in ["", "search", "reuse"] {
        let out_json = dir.join(format!("crossings-{mode}.json"));
        let out = pen_on_block(&tool, 1500, &out_json, &["--crossings", mode]);
        assert!(
            out.status.success(),
            "{mode}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        let j = json(&out_json);
        let count = |k: &str| j["pen"][k].as_u64().expect(k);
        let last: Vec<f64> = (0..3)
            .map(|i| j["force"]["final"][i].as_f64().expect("final force"))
            .collect();
        runs.push((
            j["force_digest"].clone(),
            count("border_edges"),
            count("reused_crossings"),
            j["scenario"]["crossings"].clone(),
            last,
        ));
    }
    let [default, search, reuse] = [&runs[0], &runs[1], &runs[2]];
    assert_eq!((&default.3, &search.3), (&"reuse".into(), &"search".into()));
    assert!(default.1 > 1_000, "the pen must touch: {default:?}");
    assert_eq!(search.2, 0);
    assert!(default.2 * 10 > default.1 * 8, "most reuse: {default:?}");
    assert_eq!(default, reuse);
    assert_eq!(search.1, default.1);
    let gap: f64 = (0..3).map(|i| (search.4[i] - default.4[i]).abs()).sum();
    assert!(gap < 1e-3, "{:?} vs {:?}", search.4, default.4);
    assert!(
        search.4.iter().any(|f| f.abs() > 1.0),
        "a force: {:?}",
        search.4
    );
    refused(&["replay", "--crossings", "sometimes"], &["--crossings"]);
}

/// `--contact-period N`: a mesh tool's contact pass runs every N-th tick and the servo
/// carries the last pass to the ticks between. The default is a pass every tick, the same
/// forces bit for bit as `--contact-period 1`; with 4 the replay makes a quarter of the
/// passes, its forces differ, and the JSON times the servo half and the passes apart. A
/// period out of range, or one with a sphere tool (whose replay simulates every tick), exits
/// 2 naming the flag; a scenario file's value is checked the same way.
#[test]
fn mesh_tool_contact_period_spaces_the_passes() {
    let dir = scratch_dir("runner", "contact-period");
    let pen = tetradrill_tests::mesh("models/pen_tool_gmsh.mesh");
    let tool = format!("mesh:{}", pen.display());
    let mut runs = Vec::new();
    for period in ["", "1", "4"] {
        let out_json = dir.join(format!("period-{period}.json"));
        let out = pen_on_block(&tool, 1501, &out_json, &["--contact-period", period]);
        assert!(
            out.status.success(),
            "{period}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        let j = json(&out_json);
        let servo_max = j["pen"]["servo_us"]["tick_max"]
            .as_f64()
            .expect("servo max");
        let pass_max = j["pen"]["pass_us"]["tick_max"].as_f64().expect("pass max");
        assert!(servo_max > 0.0 && pass_max > 0.0, "{period}: {j}");
        runs.push((
            j["force_digest"].as_str().expect("digest").to_string(),
            j["pen"]["passes"].as_u64().expect("passes"),
            j["pen"]["contact_period"].as_u64().expect("period"),
            j["force"]["contact_ticks"].as_u64().expect("contact ticks"),
        ));
    }
    let [default, one, four] = [&runs[0], &runs[1], &runs[2]];
    assert_eq!(default, one);
    assert_eq!((one.1, one.2), (1501, 1));
    assert_eq!((four.1, four.2), (376, 4), "ticks 0, 4, ..., 1500");
    assert!(one.3 > 100, "the pen must touch: {one:?}");
    assert_ne!(four.0, one.0, "carried forces are not the passes'");
    refused(
        &["replay", "--tool", &tool, "--contact-period", "0"],
        &["--contact-period"],
    );
    refused(
        &["replay", "--tool", "sphere:0.1", "--contact-period", "2"],
        &["--contact-period"],
    );
    let bad = write(&dir, "period.toml", "contact_period = 5000\n");
    refused(
        &["replay", "--scenario", bad.to_str().unwrap()],
        &["period.toml:1:", "contact_period"],
    );
}

/// `--pass-threads 2`: a mesh tool's contact pass with its object side on a second thread
/// gives the forces of one thread bit for bit (the default, and with passes spaced by
/// `--contact-period`), and says so in the JSON; a `run` with it keeps 1 kHz and reports its
/// passes. A count out of range, or one with a sphere tool, exits 2 naming the flag; a
/// scenario file's value is checked the same way.
#[test]
fn mesh_tool_pass_threads_keep_the_forces() {
    let dir = scratch_dir("runner", "pass-threads");
    let pen = tetradrill_tests::mesh("models/pen_tool_gmsh.mesh");
    let tool = format!("mesh:{}", pen.display());
    let mut runs = Vec::new();
    for (threads, period) in [("1", "1"), ("2", "1"), ("1", "3"), ("2", "3")] {
        let out_json = dir.join(format!("threads-{threads}-{period}.json"));
        let out = pen_on_block(
            &tool,
            901,
            &out_json,
            &["--pass-threads", threads, "--contact-period", period],
        );
        assert!(
            out.status.success(),
            "{threads} {period}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        let j = json(&out_json);
        runs.push((
            j["force_digest"].as_str().expect("digest").to_string(),
            j["pen"]["pass_threads"].as_u64().expect("threads"),
            j["pen"]["passes"].as_u64().expect("passes"),
            j["force"]["contact_ticks"].as_u64().expect("contact ticks"),
        ));
    }
    assert_eq!((runs[0].1, runs[1].1), (1, 2));
    assert!(runs[0].3 > 100, "the pen must touch: {:?}", runs[0]);
    for (one, two) in [(&runs[0], &runs[1]), (&runs[2], &runs[3])] {
        assert_eq!((&one.0, one.2, one.3), (&two.0, two.2, two.3));
    }
    assert_ne!(runs[0].0, runs[2].0, "carried forces are not the passes'");

    let out_json = dir.join("run.json");
    let j = out_json.to_str().expect("a UTF-8 scratch path");
    let out = pen_run(&tool, "1.0", &["--pass-threads", "2", "--json", j]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let j = json(&out_json);
    assert_eq!(j["pen"]["pass_threads"].as_u64(), Some(2), "{j}");
    let passes = j["pen"]["passes"].as_u64().expect("passes");
    assert!(passes > 0 && passes <= 1000, "{j}");

    refused(
        &["replay", "--tool", &tool, "--pass-threads", "3"],
        &["--pass-threads"],
    );
    refused(
        &["replay", "--tool", "sphere:0.1", "--pass-threads", "2"],
        &["--pass-threads"],
    );
    refused(
        &[
            "run",
            "--device",
            "sim",
            "--tool",
            "sphere:0.1",
            "--pass-threads",
            "2",
        ],
        &["--pass-threads"],
    );
    let bad = write(&dir, "threads.toml", "pass_threads = 4\n");
    refused(
        &["replay", "--scenario", bad.to_str().unwrap()],
        &["threads.toml:1:", "pass_threads"],
    );
}

/// `run` (no real-time settings, headless, quiet) of the mesh tool `tool` (x10) on
/// `builtin:block:8` along `wander:3` for `secs` seconds, plus `extra`.
fn pen_run(tool: &str, secs: &str, extra: &[&str]) -> Output {
    let mut args = vec![
        "run",
        "--no-rt",
        "--headless",
        "--quiet",
        "--tool",
        tool,
        "--tool-scale",
        "10",
        "--trace",
        "wander:3",
        "--duration",
        secs,
    ];
    args.extend(extra);
    run(&args)
}

/// `run --tool mesh:FILE`: the pen in the real-time pipeline (the contact task's passes, the
/// servo carrying them) keeps 1 kHz, reports its passes and takes a screenshot; a contact
/// period (replay's) exits 2 naming the flag. (`tests/tests/contact/pen_pipeline.rs` checks its
/// forces tick by tick, `tests/tests/viewer/viewer_render.rs` how the pen is drawn.)
#[test]
fn mesh_tool_runs_in_real_time() {
    let dir = scratch_dir("runner", "pen-run");
    let pen = tetradrill_tests::mesh("models/pen_tool_gmsh.mesh");
    let tool = format!("mesh:{}", pen.display());
    let out_json = dir.join("pen-run.json");
    let j = out_json.to_str().expect("a UTF-8 scratch path");
    let out = pen_run(&tool, "1.5", &["--max-force", "10000", "--json", j]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(stdout.contains("contact passes"), "{stdout}");
    let j = json(&out_json);
    let ticks = j["ticks"].as_f64().expect("ticks");
    let secs = j["duration_s"].as_f64().expect("duration");
    assert_eq!(ticks, 1500.0);
    assert!(paced_at_1khz(ticks, secs), "{ticks} ticks in {secs} s");
    let p = &j["pen"];
    let passes = p["passes"].as_u64().expect("passes");
    assert!(p["pass_age_max_ticks"].as_u64().is_some(), "{p}");
    assert!(passes > 0 && passes <= 1500, "{p}");
    assert_eq!(j["simulation_steps"].as_u64(), Some(passes));
    assert!(p["pass_us"]["tick_max"].as_f64().expect("pass max") > 0.0);
    assert!(p["pen_collisions_max"].as_u64().expect("inside") > 0, "{p}");
    assert!(j["force_max_n"].as_f64().expect("force") > 0.0);
    assert_eq!(j["valid"], true);
    assert_eq!(j["removed_volume"].as_f64(), Some(0.0));

    refused(
        &["run", "--no-rt", "--tool", &tool, "--contact-period", "2"],
        &["--contact-period"],
    );
    // The picture at the end: the block and the pen (drawn clear of it).
    let png = dir.join("pen.png");
    let shot = png.to_str().expect("a UTF-8 scratch path");
    let out = pen_run(&tool, "0.3", &["--screenshot", shot]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let bytes = std::fs::read(&png).expect("the screenshot");
    assert!(bytes.starts_with(b"\x89PNG"), "not a PNG");
}

/// A closed stdout (`tetradrill replay | head -1`) loses the summary lines, not the run: no
/// panic, exit status 0, the JSON written; a JSON meant for stdout that cannot go there is an
/// error. The pipe's reading end is closed before the run starts, so every write to stdout
/// fails.
#[test]
fn a_closed_stdout_loses_lines_not_the_run() {
    let dir = scratch_dir("runner", "closed-stdout");
    for (cmd, extra) in [
        ("replay", &["--ticks", "200"][..]),
        ("demo", &["--headless", "--duration", "0.2", "--no-rt"][..]),
    ] {
        let out_json = dir.join(format!("{cmd}.json"));
        let (reader, writer) = std::io::pipe().expect("a pipe");
        drop(reader);
        let out = Command::new(tetradrill_bin())
            .arg(cmd)
            .args(extra)
            .args(["--json", out_json.to_str().expect("a UTF-8 scratch path")])
            .stdout(writer)
            .output()
            .expect("run tetradrill");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{cmd}: {:?}\n{err}", out.status);
        assert!(!err.contains("panicked"), "{cmd}: {err}");
        assert!(json(&out_json)["ticks"].as_u64().expect("ticks") > 0);
    }
    // `info --json -` writes its product to stdout: losing it is an error, one line, exit 1.
    let (reader, writer) = std::io::pipe().expect("a pipe");
    drop(reader);
    let out = Command::new(tetradrill_bin())
        .args(["info", "--mesh", "builtin:cube12", "--json", "-"])
        .stdout(writer)
        .output()
        .expect("run tetradrill");
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains("stdout") && !err.contains("panicked"), "{err}");
}

/// `--entry-remedy` (scenario key `entry_remedy`) reaches a mesh tool's force in `replay` and
/// `run`: the pen wandering into the block gets other forces with it than without, the JSON
/// says it was on; a sphere tool has no such remedy (exit 2 naming the flag).
#[test]
fn mesh_tool_entry_remedy_is_a_flag() {
    let dir = scratch_dir("runner", "entry-remedy");
    let pen = tetradrill_tests::mesh("models/pen_tool_gmsh.mesh");
    let tool = format!("mesh:{}", pen.display());
    let mut digests = Vec::new();
    for on in ["false", "true"] {
        let out_json = dir.join(format!("remedy-{on}.json"));
        let out = pen_on_block(&tool, 1500, &out_json, &["--entry-remedy", on]);
        assert!(
            out.status.success(),
            "{on}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        let j = json(&out_json);
        assert_eq!(j["scenario"]["entry_remedy"].as_bool(), Some(on == "true"));
        assert!(j["force"]["contact_ticks"].as_u64().expect("contact ticks") > 100);
        digests.push(j["force_digest"].as_str().expect("digest").to_string());
    }
    assert_ne!(
        digests[0], digests[1],
        "the remedy changes the forces in contact"
    );
    let run_json = dir.join("remedy-run.json");
    let j = run_json.to_str().expect("a UTF-8 scratch path");
    let out = pen_run(&tool, "0.3", &["--entry-remedy", "--json", j]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert_eq!(json(&run_json)["pen"]["entry_remedy"].as_bool(), Some(true));
    refused(
        &["replay", "--tool", "sphere:0.1", "--entry-remedy"],
        &["--entry-remedy"],
    );
    let bad = write(&dir, "remedy.toml", "entry_remedy = 3\n");
    refused(
        &[
            "replay",
            "--scenario",
            bad.to_str().expect("a UTF-8 scratch path"),
        ],
        &["remedy.toml:1:"],
    );
}
