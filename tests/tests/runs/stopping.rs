//! Real sessions: a run without an end stops cleanly on a request (zero force within a tick,
//! then the report), on a real SIGINT or SIGTERM (exit 0 with the JSON), at once on a second
//! signal; the servo's timing histogram against the exact percentiles of a known sample; the
//! recorder under a full ring, and a recorded session that replays with the same digest.

use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Command, Stdio};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};

use rand::{Rng, SeedableRng};
use tetradrill::commands::pipeline::{self, PipelineSetup, UNTIL_STOPPED};
use tetradrill::scenario::Scenario;
use tetradrill::setup::{Setup, Tool};
use tetradrill::stats::{Histogram, HIST_UNIT_NS};
use tetradrill::tasks::{recorder_task, RecordRing, ToolSample, TRACE_HEADER};
use tetradrill::watchdog::StopRequest;
use tetradrill_core::{Quat, Vec3};
use tetradrill_device::{
    DeviceError, DeviceKind, DeviceSpec, DeviceState, ForceCommand, HapticDevice, MotorCutoff,
    SimConfig, SimDevice, Still, Trace,
};
use tetradrill_tests::{scratch_dir, tetradrill_bin, Scratch};

/// One write the device took: whether the stop request was raised when it came, and the
/// force's magnitude (0 with the motors off).
type Write = (bool, f64);

/// The simulated device, logging every write and counting reads.
struct Logged {
    inner: SimDevice<Still>,
    request: StopRequest,
    reads: Arc<AtomicU64>,
    reads_after_request: Arc<AtomicU64>,
    writes: Arc<Mutex<Vec<Write>>>,
}

impl HapticDevice for Logged {
    fn spec(&self) -> DeviceSpec {
        self.inner.spec()
    }
    fn read(&mut self) -> Result<DeviceState, DeviceError> {
        self.reads.fetch_add(1, Ordering::SeqCst);
        if self.request.is_requested() {
            self.reads_after_request.fetch_add(1, Ordering::SeqCst);
        }
        self.inner.read()
    }
    fn write(&mut self, command: &ForceCommand) -> Result<(), DeviceError> {
        let f = command.force;
        let n = if command.enable {
            (f[0] * f[0] + f[1] * f[1] + f[2] * f[2]).sqrt()
        } else {
            0.0
        };
        if let Ok(mut w) = self.writes.lock() {
            w.push((self.request.is_requested(), n));
        }
        self.inner.write(command)
    }
    fn calibrate(&mut self) -> Result<(), DeviceError> {
        self.inner.calibrate()
    }
    fn cutoff(&self) -> Option<Arc<dyn MotorCutoff>> {
        self.inner.cutoff()
    }
}

fn small_block() -> Setup {
    Setup::new("builtin:block:4", Tool::sphere(0.1))
}

/// `pipeline::run` over the small block.
fn run_small_block(
    setup: PipelineSetup,
    json: Option<&std::path::PathBuf>,
) -> Result<tetradrill::commands::pipeline::RunReport, tetradrill::error::CliError> {
    let sc = small_block();
    let mesh = tetradrill::engine::load_mesh(&sc).expect("the block");
    pipeline::run(&sc, mesh, setup, json)
}

#[test]
fn a_stop_request_zeroes_the_force_within_a_tick_and_ends_the_run_cleanly() {
    let request = StopRequest::new();
    let reads = Arc::new(AtomicU64::new(0));
    let late = Arc::new(AtomicU64::new(0));
    let writes = Arc::new(Mutex::new(Vec::new()));
    let (r, n, l, w) = (request.clone(), reads.clone(), late.clone(), writes.clone());
    // The burr held 0.05 into the block's top face: a steady force.
    let open: pipeline::DeviceFactory = Box::new(move || {
        Ok(Box::new(Logged {
            inner: SimDevice::new(Still([0.0, 0.0, 0.55]), SimConfig::default()),
            request: r,
            reads: n,
            reads_after_request: l,
            writes: w,
        }) as Box<dyn HapticDevice>)
    });
    let mut setup = PipelineSetup::plain(DeviceKind::Sim, open, UNTIL_STOPPED);
    setup.stop = request.clone();
    let dir = scratch_dir("session", "request");
    let json = dir.join("run.json");
    let rep = std::thread::scope(|s| {
        s.spawn(|| {
            while reads.load(Ordering::SeqCst) < 300 {
                std::thread::sleep(std::time::Duration::from_millis(1));
            }
            request.request();
        });
        run_small_block(setup, Some(&json)).expect("a clean stop")
    });
    assert_eq!(rep.stop_reason, "signal");
    assert_eq!(rep.stop_signal, None, "a call, not a signal");
    assert!(rep.ticks >= 300, "{} ticks", rep.ticks);
    assert!(rep.stop_to_zero_force_us.is_some());
    assert_eq!(rep.force.last_written_n, 0.0);
    // The device's side: at most one tick (read) began after the request, at most one force
    // went out after it, and the last write is zero.
    let log = writes.lock().expect("log").clone();
    let before: Vec<&Write> = log.iter().filter(|w| !w.0).collect();
    let after: Vec<&Write> = log.iter().filter(|w| w.0).collect();
    assert!(
        before.iter().rev().take(100).all(|w| w.1 > 0.1),
        "the force was on before the request"
    );
    assert!(late.load(Ordering::SeqCst) <= 1, "ticks after the request");
    assert!(after.iter().filter(|w| w.1 > 0.0).count() <= 1, "{after:?}");
    assert!(
        after.iter().any(|w| w.1 == 0.0),
        "a zero write after the request"
    );
    assert_eq!(log.last().map(|w| w.1), Some(0.0));
    // The JSON says the same.
    let j: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).expect("json")).expect("parse");
    assert_eq!(j["stop_reason"], "signal");
    assert_eq!(j["force"]["last_written_n"], 0.0);
    assert_eq!(j["ticks"], rep.ticks);
    assert_eq!(j["wake_us"]["count"], rep.ticks);
}

#[test]
fn each_end_of_a_run_has_its_stop_reason_and_leaves_zero_force() {
    let dir = scratch_dir("session", "reasons");
    // Its ticks done.
    let open: pipeline::DeviceFactory = Box::new(|| {
        Ok(Box::new(SimDevice::new(
            Still([0.0, 0.0, 0.55]),
            SimConfig::default(),
        )) as Box<dyn HapticDevice>)
    });
    let rep =
        run_small_block(PipelineSetup::plain(DeviceKind::Sim, open, 200), None).expect("a run");
    assert_eq!((rep.stop_reason, rep.ticks), ("duration", 200));
    assert!(rep.force_max_n > 0.1);
    assert_eq!(rep.force.last_written_n, 0.0);
    assert_eq!(rep.stop_to_zero_force_us, None);
    // The device unplugged at tick 250 of a run without an end: exit 1, the JSON written.
    let open: pipeline::DeviceFactory = Box::new(|| {
        let c = SimConfig {
            disconnect_at_tick: Some(250),
            ..SimConfig::default()
        };
        Ok(Box::new(SimDevice::new(Still([0.0, 0.0, 0.55]), c)) as Box<dyn HapticDevice>)
    });
    let json = dir.join("lost.json");
    let e = run_small_block(
        PipelineSetup::plain(DeviceKind::Sim, open, UNTIL_STOPPED),
        Some(&json),
    )
    .expect_err("the device failed");
    assert_eq!(e.code, 1);
    let j: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).expect("json")).expect("parse");
    assert_eq!(j["stop_reason"], "device_error");
    assert!(j["ticks"]
        .as_u64()
        .is_some_and(|t| (240..=260).contains(&t)));
}

/// The exact nearest-rank percentile: the smallest sample with at least `per_mille` of the
/// samples at or below it.
fn exact(sorted: &[u64], per_mille: u64) -> u64 {
    let n = sorted.len() as u64;
    let rank = (per_mille * n).div_ceil(1000).max(1);
    sorted[(rank - 1) as usize]
}

#[test]
fn the_histogram_matches_the_exact_percentiles_of_a_known_sample() {
    let mut rng = rand::rngs::StdRng::seed_from_u64(7);
    // Log-uniform from 50 ns to 20 ms (the servo's range: tick times to stalls), with ties.
    let mut v: Vec<u64> = (0..20_000)
        .map(|_| (50.0 * (rng.gen::<f64>() * (4e5f64).ln()).exp()) as u64)
        .collect();
    v.extend([
        0,
        125,
        124,
        31_999,
        32_000,
        32_125,
        1_000_000,
        60_000_000_000,
    ]);
    v.extend(std::iter::repeat_n(27_000, 500));
    let h = Histogram::new();
    for &x in &v {
        h.record(x);
    }
    let mut s = v.clone();
    s.sort_unstable();
    for pm in (1..=1000).chain([500, 990, 999]) {
        let want = exact(&s, pm);
        let got = h.percentile_ns(pm as u32).expect("not empty");
        let width = (want / 128).max(HIST_UNIT_NS);
        assert!(
            got >= want && got - want <= width,
            "p{pm}/1000: {got} ns for exactly {want} ns"
        );
    }
    let sum = h.summary();
    let us = |ns: u64| ns as f64 / 1000.0;
    assert_eq!(sum.count, v.len());
    assert_eq!((sum.min, sum.max), (0.0, us(60_000_000_000)));
    let mean = v.iter().map(|&x| x as f64).sum::<f64>() / v.len() as f64 / 1000.0;
    assert!(
        (sum.mean - mean).abs() < 1e-9 * mean,
        "{} vs {mean}",
        sum.mean
    );
    assert_eq!(
        h.percentile_ns(1000),
        Some(60_000_000_000),
        "p100 is the max"
    );
    // The 1 us histogram, counted here sample by sample: equal (exact below 256 us).
    let mut ones = vec![0u64; 200];
    for &x in &v {
        ones[((x / 1000) as usize).min(199)] += 1;
    }
    assert_eq!(h.histogram_us(200), ones);
    assert_eq!(Histogram::new().percentile_ns(500), None);
}

fn sample(tick: u64, x: f32) -> ToolSample {
    ToolSample {
        tick,
        position: Vec3::new(x, -0.25, 0.5),
        rotation: Quat::IDENTITY,
        buttons: 1,
    }
}

#[test]
fn a_full_record_ring_drops_and_counts_rows_and_the_file_is_a_trace() {
    let ring = RecordRing::new(8);
    // The servo pushes 20 rows while the recorder is away: 8 fit, 12 are dropped, no push
    // waits.
    for t in 0..20 {
        ring.push(sample(t, t as f32 * 0.01));
    }
    assert_eq!(ring.dropped(), 12);
    let stop = std::sync::atomic::AtomicBool::new(true);
    let mut out = Vec::new();
    let rows = recorder_task(&ring, &mut out, &stop).expect("written");
    assert_eq!(rows, 8);
    // Room again: a pose that is not finite is counted, not written.
    ring.push(sample(1500, 0.5));
    ring.push(sample(1501, f32::NAN));
    let mut more = Vec::new();
    assert_eq!(recorder_task(&ring, &mut more, &stop).expect("written"), 1);
    assert_eq!(ring.dropped(), 13);
    let text = String::from_utf8(out).expect("text");
    assert_eq!(text.lines().next(), Some(TRACE_HEADER));
    let trace = Trace::parse(&text, "recorded").expect("a trace CSV");
    assert_eq!(trace.len(), 8);
    for (i, s) in trace.samples().iter().enumerate() {
        assert_eq!(s.t, i as f64 / 1000.0);
        // Each f32 is written in its shortest form: read back as f32, it is the same value.
        assert_eq!(s.position.map(|v| v as f32), [i as f32 * 0.01, -0.25, 0.5]);
        assert_eq!(s.rotation, [1.0, 0.0, 0.0, 0.0]);
        assert_eq!(s.buttons, 1);
    }
    let more = String::from_utf8(more).expect("text");
    assert_eq!(more.lines().nth(1), Some("1.500,0.5,-0.25,0.5,1,0,0,0,1"));
}

fn field(json: &Path, key: &str) -> serde_json::Value {
    let j: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(json).expect("json")).expect("parse");
    key.split('.').fold(j, |v, k| v[k].clone())
}

#[test]
fn a_recorded_session_replays_with_the_same_digest_twice() {
    let dir = scratch_dir("session", "record");
    let (trace, run_json) = (dir.join("session.csv"), dir.join("run.json"));
    let out = Command::new(tetradrill_bin())
        .args(["run", "--device", "sim", "--headless", "--no-rt", "--quiet"])
        .args(["--duration", "1", "--record"])
        .arg(&trace)
        .arg("--json")
        .arg(&run_json)
        .output()
        .expect("run");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert_eq!(field(&run_json, "stop_reason"), "duration");
    let rows = field(&run_json, "recorded_rows").as_u64().expect("rows");
    let dropped = field(&run_json, "dropped_rows").as_u64().expect("dropped");
    assert_eq!(rows + dropped, 1000);
    let text = std::fs::read_to_string(&trace).expect("the trace");
    assert_eq!(text.lines().count() as u64, rows + 1);
    let digest = |name: &str| {
        let json = dir.join(name);
        let out = Command::new(tetradrill_bin())
            .args(["replay", "--trace"])
            .arg(&trace)
            .arg("--json")
            .arg(&json)
            .output()
            .expect("replay");
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        (field(&json, "force_digest"), field(&json, "ticks"))
    };
    let (a, b) = (digest("r1.json"), digest("r2.json"));
    assert_eq!(a, b);
    assert_eq!(a.1, 1000);
}

/// `run` with a wander (no end of its own) until `signals` are sent, the first once the
/// status line shows the servo running; returns the exit status and the scratch folder (the
/// JSON is its `run.json`).
fn signalled(name: &str, signals: &[i32]) -> (Option<i32>, Scratch) {
    let dir = scratch_dir("session", name);
    let json = dir.join("run.json");
    let mut child = Command::new(tetradrill_bin())
        .args(["run", "--device", "sim", "--headless", "--no-rt"])
        .args(["--mesh", "builtin:block:4", "--trace", "wander:1", "--json"])
        .arg(&json)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("run");
    let stderr = child.stderr.take().expect("stderr");
    let (tx, rx) = std::sync::mpsc::channel();
    let reader = std::thread::spawn(move || {
        let mut sent = false;
        for line in BufReader::new(stderr).lines().map_while(Result::ok) {
            if !sent && line.contains("| servo") {
                sent = true;
                let _ = tx.send(());
            }
        }
    });
    rx.recv().expect("a status line");
    let pid = child.id() as i32;
    for &sig in signals {
        // SAFETY: kill(2) with the pid of our own child, which has not been waited for.
        assert_eq!(unsafe { libc::kill(pid, sig) }, 0);
    }
    let status = child.wait().expect("wait");
    reader.join().expect("reader");
    (status.code(), dir)
}

#[test]
fn sigint_and_sigterm_stop_a_run_cleanly_with_its_json() {
    for (sig, name) in [(libc::SIGINT, "SIGINT"), (libc::SIGTERM, "SIGTERM")] {
        let (code, dir) = signalled(name, &[sig]);
        let json = dir.join("run.json");
        assert_eq!(code, Some(0), "{name}");
        assert_eq!(field(&json, "stop_reason"), "signal");
        assert_eq!(field(&json, "stop_signal"), name);
        assert_eq!(field(&json, "force.last_written_n"), 0.0);
        assert!(field(&json, "ticks").as_u64().is_some_and(|t| t > 0));
        assert!(field(&json, "stop_to_zero_force_us").is_number());
    }
}

#[test]
fn a_second_signal_exits_at_once() {
    let (code, dir) = signalled("twice", &[libc::SIGINT, libc::SIGTERM]);
    let json = dir.join("run.json");
    // Both are pending at once: either may be taken second (128 + its number).
    assert!(
        [128 + libc::SIGINT, 128 + libc::SIGTERM]
            .map(Some)
            .contains(&code),
        "{code:?}"
    );
    assert!(!json.exists(), "no JSON after a second signal");
}

#[test]
fn only_scripts_and_traces_give_a_run_its_own_end() {
    use tetradrill::commands::run::{device_factory, run_ticks};
    use tetradrill_device::discovery::OpenOptions;
    let ticks = |kind: DeviceKind, trace: &str| {
        let sc = Scenario {
            mesh: "builtin:block:2".into(),
            trace: trace.into(),
            ..Scenario::default()
        }
        .setup()
        .expect("a valid set-up");
        let (_, t, _) = device_factory(
            kind,
            &sc,
            &tetradrill::engine::load_mesh(&sc).expect("the block"),
            OpenOptions::default(),
        )
        .expect("a factory");
        t
    };
    assert_eq!(
        ticks(DeviceKind::Sim, "builtin:demo"),
        tetradrill_core::script::DEMO.ticks() as u64
    );
    assert_eq!(ticks(DeviceKind::Sim, "wander:3"), UNTIL_STOPPED);
    // A real device is opened and started by `device_factory` itself, on the main thread:
    // with a Falcon attached the run has no end of its own; without one, one line, exit 2.
    let sc = Scenario {
        mesh: "builtin:block:2".into(),
        trace: "builtin:demo".into(),
        ..Scenario::default()
    }
    .setup()
    .expect("a valid set-up");
    match device_factory(
        DeviceKind::Falcon,
        &sc,
        &tetradrill::engine::load_mesh(&sc).expect("the block"),
        OpenOptions::default(),
    ) {
        Ok((_, t, _)) => assert_eq!(t, UNTIL_STOPPED),
        Err(e) => {
            assert_eq!(e.code, 2, "{}", e.message);
            assert_eq!(e.message.lines().count(), 1, "{}", e.message);
            assert!(e.message.contains("--device falcon"), "{}", e.message);
        }
    }
    assert_eq!(run_ticks(None, UNTIL_STOPPED), UNTIL_STOPPED);
    assert_eq!(run_ticks(Some(2.5), UNTIL_STOPPED), 2500);
}
