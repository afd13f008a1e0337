//! Stalls, the watchdog and a panicking servo, through `pipeline::run` (the servo,
//! simulation and status tasks of `run` and `demo`) with the fault-injecting wrapper of
//! `tetradrill_tests::faults`, and through the watchdog's supervisor beside a stand-in servo:
//! a servo that stalls briefly (overruns counted, the run goes on) and past the watchdog (the
//! watchdog thread zeroes the force through each backend's second path while the servo is
//! still stalled, then the force ramps back), the watchdog's one report line, a servo that
//! panics. The oracle is what the device's motors and second paths saw, in order (logged by
//! the wrapper and the mocks, not by the runner), and what docs/SAFETY.md says: zero force
//! within the watchdog time, one line naming the fault, nothing aborts.

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use tetradrill::commands::pipeline;
use tetradrill::watchdog::{self, ServoWatch, SERVO_WATCHDOG_NS};
use tetradrill_device::falcon::mock::MockTransport;
use tetradrill_device::omni::mock::MockFirewire;
use tetradrill_device::omni::packet::MOTOR_ZERO;
use tetradrill_device::omni::{OmniConfig, OmniDevice};
use tetradrill_device::{Cut, DeviceError, DeviceKind, ForceCommand, HapticDevice, MotorCutoff};
use tetradrill_tests::faults::{
    falcon, falcon_report, pipeline_with, sim, sim_probed, FaultDevice, Faults, Probe, StallEvent,
};

#[test]
fn a_stalled_servo_counts_overruns_and_carries_on() {
    // The pipeline on the real clock: the device stalls the servo for 6 ms in its read 100.
    // The missed deadlines are counted and skipped (no burst to catch up); the run completes
    // and leaves the motors off.
    let dev = sim(Faults {
        stall: Some((100, Duration::from_millis(6))),
        ..Faults::default()
    });
    let log = Arc::clone(&dev.log);
    let open: pipeline::DeviceFactory = Box::new(move || Ok(Box::new(dev) as Box<_>));
    let rep = pipeline_with(open, DeviceKind::Sim, 300).expect("the run completes");
    assert_eq!(rep.ticks, 300);
    assert!(rep.overruns >= 1, "a 6 ms stall misses deadlines");
    let log = log.lock().expect("log");
    assert_eq!(log.last(), Some(&ForceCommand::OFF));
}

#[test]
fn a_servo_stalled_past_the_watchdog_has_its_force_zeroed_while_stalled_then_ramps_back() {
    // The hand held 0.05 under the block's top face: the burr pushes out, 8 N once ramped.
    // Read 700 blocks until the device's motors render zero: only the watchdog thread can
    // zero them while the servo thread is stuck there.
    let dev = sim_probed(
        [0.0, 0.0, 0.45],
        Faults {
            stall_until_zero: Some(700),
            ..Faults::default()
        },
    );
    let (events, rendered) = (Arc::clone(&dev.events), Arc::clone(&dev.rendered));
    let open: pipeline::DeviceFactory = Box::new(move || Ok(Box::new(dev) as Box<_>));
    let rep = pipeline_with(open, DeviceKind::Sim, 1000).expect("the run recovers");
    // The order of events: the stall began with force on the motors, the motors went to zero
    // while the servo was still stalled, then the servo went on.
    assert_eq!(
        *events.lock().expect("events"),
        vec![
            StallEvent::Began { zeroes: 0 },
            StallEvent::ZeroWhileStalled,
            StallEvent::Ended
        ]
    );
    // The run recovered: every tick done, the stall counted (a loaded machine may add more);
    // the stall lasted at least the watchdog time (the zero came only after it).
    assert_eq!(rep.ticks, 1000);
    assert!(rep.servo_stalls >= 1);
    assert!(rep.servo_stall_max_ms * 1e6 >= SERVO_WATCHDOG_NS as f64);
    // What the motors rendered after each write: force before the stall, zero after the
    // stalled tick's write (the latch), then a ramp from zero (1/500 a tick): no jump back.
    let r = rendered.lock().expect("rendered");
    let mag = |f: [f64; 3]| (f[0] * f[0] + f[1] * f[1] + f[2] * f[2]).sqrt();
    let before = r
        .iter()
        .filter(|(read, _)| *read < 700)
        .map(|(_, f)| mag(*f))
        .fold(0.0, f64::max);
    assert!(before > 1.0, "in contact before the stall: {before} N");
    assert!(r
        .iter()
        .filter(|(read, _)| *read == 700)
        .all(|(_, f)| mag(*f) == 0.0));
    let first_after = r
        .iter()
        .find(|(read, f)| *read > 700 && mag(*f) > 0.0)
        .map(|(_, f)| mag(*f))
        .expect("force again after the stall");
    assert!(
        first_after * 50.0 < before,
        "ramped, not jumped: {first_after} N after, {before} N before"
    );
}

/// Runs `dev` through the pipeline for 600 ticks with its servo stalled at read 300 until
/// the watchdog's zero has come through the second path, whose log is `second`; asserts the
/// run recovers, the stall is counted, the events are in order; returns what came that way.
fn stalled_through_second_path<D, T>(dev: D, second: Arc<Mutex<Vec<T>>>, kind: DeviceKind) -> Vec<T>
where
    D: HapticDevice + Send + 'static,
    T: Clone + Send + 'static,
{
    let mut dev = FaultDevice::new(
        dev,
        Faults {
            stall_until_zero: Some(300),
            ..Faults::default()
        },
    );
    let seen = Arc::clone(&second);
    dev.zeroes = Some(Probe(Arc::new(move || {
        seen.lock().expect("log").len() as u64
    })));
    let events = Arc::clone(&dev.events);
    let open: pipeline::DeviceFactory = Box::new(move || Ok(Box::new(dev) as Box<_>));
    let rep = pipeline_with(open, kind, 600).expect("the run recovers");
    assert_eq!(rep.ticks, 600);
    assert!(rep.servo_stalls >= 1);
    assert_stalled_then_zeroed(&events.lock().expect("events"));
    let log = second.lock().expect("log").clone();
    log
}

#[test]
fn the_watchdog_zeroes_the_falcon_and_the_omni_through_their_second_paths() {
    // The Falcon: its mock records what comes through the second path (the shared USB
    // handle on hardware). The read blocks until a new frame has come that way; every frame
    // that came that way is a zero.
    let mut mock = MockTransport::running();
    mock.report = falcon_report();
    let second = Arc::clone(&mock.out_log);
    let frames = stalled_through_second_path(falcon(mock), second, DeviceKind::Falcon);
    assert!(!frames.is_empty());
    assert!(frames.iter().all(|c| c.motors == [0; 3]), "{frames:?}");

    // The Omni: motors-off packets through the second path (the shared transmit stream of
    // the firewire-cdev transport on hardware).
    let mut c = OmniConfig::default();
    c.safety.ramp_ticks = 1;
    let mock = MockFirewire::omni();
    let second = Arc::clone(&mock.out_log);
    let dev = OmniDevice::start(mock, c).expect("start-up");
    let packets = stalled_through_second_path(dev, second, DeviceKind::Omni);
    assert!(packets
        .iter()
        .all(|o| !o.motors_on && o.motors == [MOTOR_ZERO; 3]));
}

/// The stall's events: it began, the second path carried a new zero while it lasted, it
/// ended. (A loaded machine may have made the watchdog trip before, so the count the stall
/// began with is not asserted.)
fn assert_stalled_then_zeroed(events: &[StallEvent]) {
    assert!(
        matches!(
            events,
            [
                StallEvent::Began { .. },
                StallEvent::ZeroWhileStalled,
                StallEvent::Ended
            ]
        ),
        "{events:?}"
    );
}

/// A cutoff whose path answers `Busy` until told otherwise, counting its calls.
#[derive(Debug, Default)]
struct BusyCutoff {
    latch: AtomicBool,
    busy: AtomicBool,
    calls: AtomicU64,
}

impl MotorCutoff for BusyCutoff {
    fn cut(&self) -> Result<Cut, DeviceError> {
        self.latch.store(true, Ordering::SeqCst);
        self.calls.fetch_add(1, Ordering::SeqCst);
        Ok(if self.busy.load(Ordering::SeqCst) {
            Cut::Busy
        } else {
            Cut::Done
        })
    }
    fn is_cut(&self) -> bool {
        self.latch.load(Ordering::SeqCst)
    }
    fn rearm(&self) {
        self.latch.store(false, Ordering::SeqCst);
    }
}

/// A stand-in servo: beats `n` times, stops beating until the watchdog trips, then (after
/// `then` ran) comes back like the servo task does and beats until `stop`.
fn fake_servo(watch: &ServoWatch, stop: &AtomicBool, then: impl FnOnce()) {
    // Twenty ticks done, then silence (one store: a loaded machine cannot make the watchdog
    // see a gap between beats).
    watch.beat(20);
    let until = Instant::now() + Duration::from_secs(30);
    while !watch.tripped() && Instant::now() < until {
        std::thread::sleep(Duration::from_millis(1));
    }
    assert!(watch.tripped(), "the watchdog tripped");
    then();
    watch.resumed(0);
    for k in 21..=40 {
        watch.beat(k);
        std::thread::sleep(Duration::from_millis(1));
    }
    watch.disarm();
    stop.store(true, Ordering::Relaxed);
}

#[test]
fn the_watchdog_reports_once_what_it_could_do() {
    let supervise = |cutoff: Option<Arc<dyn MotorCutoff>>, then: &(dyn Fn() + Sync)| {
        let watch = ServoWatch::default();
        watch.attach(cutoff);
        let stop = AtomicBool::new(false);
        let mut lines = Vec::new();
        std::thread::scope(|s| {
            s.spawn(|| fake_servo(&watch, &stop, then));
            watchdog::supervisor_task(&watch, "touch", SERVO_WATCHDOG_NS, &stop, |l| lines.push(l));
        });
        // At least the stall the fake servo made; a loaded machine may add a second one while
        // it beats again, which must not add a line.
        assert!(watch.stalls() >= 1);
        lines
    };
    // No second path (the Touch): said so, once.
    let lines = supervise(None, &|| {});
    assert_eq!(lines.len(), 1, "{lines:?}");
    assert!(lines[0].starts_with("the servo stalled for "), "{lines:?}");
    assert!(lines[0].contains("after 20 ticks"), "{lines:?}");
    assert!(
        lines[0].contains("the touch device can be reached only through the servo thread"),
        "{lines:?}"
    );
    // A path that works: force set to zero, once.
    let c = Arc::new(BusyCutoff::default());
    let lines = supervise(Some(c.clone()), &|| {});
    assert_eq!(lines.len(), 1, "{lines:?}");
    assert!(lines[0].contains("force was set to zero"), "{lines:?}");
    assert!(c.is_cut(), "the latch stays set until the servo re-arms it");
    // A path that stays busy: tried again at every look until the servo came back; the latch
    // was set from the first try, and the line says what happened.
    let c = Arc::new(BusyCutoff::default());
    c.busy.store(true, Ordering::SeqCst);
    let probe = Arc::clone(&c);
    let lines = supervise(Some(c.clone()), &move || {
        // The servo comes back only once the watchdog has tried at least twice.
        let until = Instant::now() + Duration::from_secs(30);
        while probe.calls.load(Ordering::SeqCst) < 2 && Instant::now() < until {
            std::thread::sleep(Duration::from_millis(1));
        }
    });
    assert!(c.calls.load(Ordering::SeqCst) >= 2);
    assert!(c.is_cut());
    assert_eq!(lines.len(), 1, "{lines:?}");
    assert!(lines[0].contains("stayed busy"), "{lines:?}");
}

/// The scenario of the panic test: the simulated device pushed into the block, the servo
/// panicking in its read 600. Returns the run's error and the device's motors.
fn panicking_servo() -> (
    tetradrill::error::CliError,
    Arc<tetradrill_device::sim::SimMotors>,
) {
    let dev = sim_probed(
        [0.0, 0.0, 0.45],
        Faults {
            panic_at: Some(600),
            ..Faults::default()
        },
    );
    let motors = dev.inner.motors();
    let open: pipeline::DeviceFactory = Box::new(move || Ok(Box::new(dev) as Box<_>));
    let e = pipeline_with(open, DeviceKind::Sim, 2000).expect_err("the servo panicked");
    (e, motors)
}

#[test]
fn a_panicking_servo_zeroes_the_force_and_ends_with_one_line() {
    // In a child process (below): only print the line the runner prints.
    if std::env::var_os("TETRADRILL_PANIC_CHILD").is_some() {
        let (e, _) = panicking_servo();
        eprintln!("tetradrill: {e}");
        return;
    }
    let (e, motors) = panicking_servo();
    assert_eq!(e.code, 1);
    assert_eq!(e.message.lines().count(), 1, "{}", e.message);
    for needle in [
        "the servo panicked after 600 ticks (a bug)",
        "injected servo panic at read 600",
        "faults.rs:",
        "force was set to zero",
    ] {
        assert!(e.message.contains(needle), "{needle:?} in {}", e.message);
    }
    // The motors render nothing now (the force was on before: the burr was pushed in).
    assert_eq!(motors.output(), ForceCommand::OFF);
    // The same run in a child process: stderr holds that one line and no panic report (the
    // watchdog may add its warning on a loaded machine; nothing else).
    // This test's name as the harness lists it: its module path without the crate's name.
    let path = concat!(
        module_path!(),
        "::a_panicking_servo_zeroes_the_force_and_ends_with_one_line"
    );
    let name = path.split_once("::").map_or(path, |(_, name)| name);
    let out = std::process::Command::new(std::env::current_exe().expect("test binary"))
        .args(["--exact", name, "--nocapture", "--test-threads=1"])
        .env("TETRADRILL_PANIC_CHILD", "1")
        .output()
        .expect("run the child");
    assert!(out.status.success(), "the child did not abort: {out:?}");
    let err = String::from_utf8_lossy(&out.stderr);
    let lines: Vec<&str> = err
        .lines()
        .filter(|l| !l.starts_with("tetradrill: warning: the servo stalled"))
        .collect();
    assert_eq!(lines.len(), 1, "{err}");
    assert!(
        lines[0].starts_with("tetradrill: the servo panicked after 600 ticks"),
        "{err}"
    );
    assert!(!err.contains("panicked at"), "{err}");
}
