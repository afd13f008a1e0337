//! Device faults at the level of the runner's servo loop (`tasks::servo_tick`, and
//! `pipeline::run`, the servo, simulation and status tasks of `run` and `demo`), through the device crate's mock transports (Falcon
//! `MockTransport`, Omni `MockFirewire`, Touch `MockHdLibrary`) and a fault-injecting wrapper
//! written here: a disconnect mid-run, stale and repeated frames, truncated frames, NaN
//! positions, a firmware upload failing halfway, a servo that misses writes, a servo that
//! stalls (briefly, and past the watchdog: the watchdog thread zeroes the force through each
//! backend's second path while the servo is still stalled), a servo that panics. Each case
//! checks what docs/SAFETY.md says the runner does: the force goes to zero within the watchdog
//! time, the error comes back once and names the fault, the runner ends or recovers, nothing
//! aborts.

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use crossbeam::queue::ArrayQueue;
use tetradrill::commands::pipeline::{self, PipelineSetup, MESH_UNITS};
use tetradrill::engine::{self, EngineStorage, TickParams};
use tetradrill::scenario::Scenario;
use tetradrill::tasks::{servo_tick, ServoState, ToolSample};
use tetradrill::traces::Pose;
use tetradrill::watchdog::{self, ServoWatch, SERVO_WATCHDOG_NS};
use tetradrill_core::force::ToolState;
use tetradrill_core::servo::ContactState;
use tetradrill_core::Vec3;
use tetradrill_device::falcon::frame::FalconReport;
use tetradrill_device::falcon::mock::MockTransport;
use tetradrill_device::falcon::{FalconConfig, FalconDevice, Transport};
use tetradrill_device::omni::mock::MockFirewire;
use tetradrill_device::omni::packet::{OmniInput, MOTOR_ZERO};
use tetradrill_device::omni::{OmniConfig, OmniDevice};
use tetradrill_device::touch::{MockHdLibrary, TouchDevice};
use tetradrill_device::{
    Cut, DeviceError, DeviceKind, DeviceSpec, DeviceState, ForceCommand, HapticDevice, MotorCutoff,
    SimConfig, SimDevice, Still,
};
use tetradrill_tests::refused;

/// Faults a [`FaultDevice`] injects, by read number (the n-th call to `read`, from 0). A
/// range `(a, b)` covers reads `a..b`.
#[derive(Debug, Default, Clone, Copy)]
struct Faults {
    /// From this read on, every call fails with `Disconnected` (nothing reaches the device).
    disconnect_from: Option<u64>,
    /// These reads return the sample of the read before the range again (a frozen device).
    repeat: Option<(u64, u64)>,
    /// These reads carry a NaN position.
    nan: Option<(u64, u64)>,
    /// The writes that follow these reads are swallowed (a servo that misses its writes).
    drop_writes: Option<(u64, u64)>,
    /// This read sleeps first (a servo that stalls for several periods).
    stall: Option<(u64, Duration)>,
    /// This read blocks until the device's motors are zeroed once more (seen through
    /// [`FaultDevice::zeroes`], from this thread: nothing but another thread can zero them
    /// now), or 30 s pass: a servo stalled past the watchdog.
    stall_until_zero: Option<u64>,
    /// This read panics (a bug in the servo's path).
    panic_at: Option<u64>,
}

/// What a `stall_until_zero` stall saw, in order.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum StallEvent {
    /// The read stalled; how often the motors had been zeroed by then.
    Began { zeroes: u64 },
    /// The motors were zeroed once more while the read was still stalled.
    ZeroWhileStalled,
    /// The read went on.
    Ended,
}

/// What the motors rendered after a write: (the read it followed, force).
type Rendered = (u64, [f64; 3]);

/// A look at the device's motors from any thread.
#[derive(Clone)]
struct Probe<T>(Arc<dyn Fn() -> T + Send + Sync>);

impl<T> std::fmt::Debug for Probe<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Probe")
    }
}

fn within(r: Option<(u64, u64)>, n: u64) -> bool {
    r.is_some_and(|(a, b)| (a..b).contains(&n))
}

/// A device wrapper that injects [`Faults`] and records every command the servo wrote.
#[derive(Debug)]
struct FaultDevice<D> {
    inner: D,
    faults: Faults,
    reads: u64,
    held: Option<DeviceState>,
    /// Every command the servo wrote (forwarded or not), in order; shared, so a test can
    /// read it after the device moved into the servo thread.
    log: Arc<Mutex<Vec<ForceCommand>>>,
    /// How often the inner device's motors were zeroed so far (for a state probe: 1 while
    /// they render zero, else 0).
    zeroes: Option<Probe<u64>>,
    /// What the inner device's motors render, logged after each write with the read it
    /// followed.
    motors: Option<Probe<[f64; 3]>>,
    rendered: Arc<Mutex<Vec<Rendered>>>,
    /// The events of a `stall_until_zero` stall.
    events: Arc<Mutex<Vec<StallEvent>>>,
}

impl<D: HapticDevice> FaultDevice<D> {
    fn new(inner: D, faults: Faults) -> Self {
        Self {
            inner,
            faults,
            reads: 0,
            held: None,
            log: Arc::default(),
            zeroes: None,
            motors: None,
            rendered: Arc::default(),
            events: Arc::default(),
        }
    }

    fn event(&self, e: StallEvent) {
        self.events.lock().expect("events").push(e);
    }

    /// The commands written so far.
    fn written(&self) -> Vec<ForceCommand> {
        self.log.lock().expect("log").clone()
    }

    fn gone(&self) -> bool {
        self.faults.disconnect_from.is_some_and(|k| self.reads > k)
    }
}

impl<D: HapticDevice> HapticDevice for FaultDevice<D> {
    fn spec(&self) -> DeviceSpec {
        self.inner.spec()
    }

    fn read(&mut self) -> Result<DeviceState, DeviceError> {
        let n = self.reads;
        self.reads += 1;
        if self.gone() {
            return Err(DeviceError::Disconnected);
        }
        if let Some((k, d)) = self.faults.stall {
            if n == k {
                std::thread::sleep(d);
            }
        }
        if self.faults.panic_at == Some(n) {
            panic!("injected servo panic at read {n}");
        }
        if self.faults.stall_until_zero == Some(n) {
            let zeroes = || self.zeroes.as_ref().map_or(0, |p| (p.0)());
            let start = zeroes();
            self.event(StallEvent::Began { zeroes: start });
            let until = Instant::now() + Duration::from_secs(30);
            while Instant::now() < until {
                if zeroes() > start {
                    self.event(StallEvent::ZeroWhileStalled);
                    break;
                }
                std::thread::sleep(Duration::from_millis(1));
            }
            self.event(StallEvent::Ended);
        }
        // The device itself goes on (its clock and its watchdog advance).
        let mut s = self.inner.read()?;
        if within(self.faults.repeat, n) {
            if let Some(h) = self.held {
                return Ok(h);
            }
        }
        if within(self.faults.nan, n) {
            s.position = [f64::NAN; 3];
        }
        self.held = Some(s);
        Ok(s)
    }

    fn write(&mut self, command: &ForceCommand) -> Result<(), DeviceError> {
        self.log.lock().expect("log").push(*command);
        if self.gone() {
            return Err(DeviceError::Disconnected);
        }
        if within(self.faults.drop_writes, self.reads.saturating_sub(1)) {
            return Ok(());
        }
        let r = self.inner.write(command);
        if let Some(p) = &self.motors {
            let read = self.reads.saturating_sub(1);
            self.rendered
                .lock()
                .expect("rendered")
                .push((read, (p.0)()));
        }
        r
    }

    fn calibrate(&mut self) -> Result<(), DeviceError> {
        self.inner.calibrate()
    }

    fn cutoff(&self) -> Option<Arc<dyn MotorCutoff>> {
        self.inner.cutoff()
    }
}

/// Stiffness 100 N per unit, damping 0.5 N s per unit, clamp 8 N, burr radius 0.1.
fn params() -> TickParams {
    TickParams::of(&Scenario {
        stiffness: 100.0,
        ..Scenario::default()
    })
    .expect("valid scenario")
}

/// A contact plane through `point` facing +z: a burr centred at `point` is `radius` deep.
fn plane(point: Vec3) -> ContactState {
    ContactState {
        valid: true,
        point,
        normal: Vec3::Z,
        depth: 0.0,
        centre: point,
        triangles: 1,
    }
}

fn length(f: [f64; 3]) -> f64 {
    (f[0] * f[0] + f[1] * f[1] + f[2] * f[2]).sqrt()
}

/// The simulated device without a ramp, held at the origin.
fn sim(faults: Faults) -> FaultDevice<SimDevice<Still>> {
    let mut c = SimConfig::default();
    c.safety.ramp_ticks = 1;
    FaultDevice::new(SimDevice::new(Still([0.0; 3]), c), faults)
}

/// Runs `servo_tick` `ticks` times against `contact`; returns each tick's result.
fn drive(
    device: &mut dyn HapticDevice,
    contact: &ContactState,
    ticks: u64,
    st: &mut ServoState,
) -> Vec<Result<(), DeviceError>> {
    let p = params();
    let ring: ArrayQueue<ToolSample> = ArrayQueue::new(4);
    let mut out = Vec::new();
    for tick in 0..ticks {
        let r = servo_tick(device, &MESH_UNITS, &p, contact, &ring, st, tick);
        while ring.pop().is_some() {}
        let stop = r.is_err();
        out.push(r);
        if stop {
            // The servo task ends at the first error: so does this loop.
            break;
        }
    }
    out
}

#[test]
fn disconnect_mid_run_ends_the_servo_once_with_the_force_off() {
    // The simulated device unplugged at its tick 200 (its 201st read).
    let mut c = SimConfig::default();
    c.safety.ramp_ticks = 1;
    c.disconnect_at_tick = Some(200);
    let mut dev = FaultDevice::new(SimDevice::new(Still([0.0; 3]), c), Faults::default());
    let mut st = ServoState::default();
    let results = drive(&mut dev, &plane(Vec3::ZERO), 1000, &mut st);
    // Reads 0..=199 work; read 200 fails; the servo stops there: one error, no retries.
    assert_eq!(results.len(), 201);
    assert!(results[..200].iter().all(|r| r.is_ok()));
    assert_eq!(results[200], Err(DeviceError::Disconnected));
    assert!(
        st.max_force > 0.0,
        "the burr was in contact before the fault"
    );
    // After the failed read the servo still tried to switch the motors off.
    let last = dev.written().last().copied();
    assert_eq!(last, Some(ForceCommand::OFF));
    // The device renders nothing once disconnected.
    assert_eq!(dev.inner.applied_force(), [0.0; 3]);
}

/// The Falcon's motor commands at the reported position (the mock answers every frame).
fn falcon(mock: MockTransport) -> FalconDevice<MockTransport> {
    let mut c = FalconConfig::default();
    c.safety.ramp_ticks = 1;
    FalconDevice::new(mock, c)
}

fn falcon_report() -> FalconReport {
    FalconReport {
        encoders: [200, 200, 200],
        buttons: 0,
        homed: 0b111,
    }
}

/// A contact plane that puts `dev`'s first reported position `depth` under the surface.
fn plane_at_device(dev: &mut dyn HapticDevice, depth: f32) -> ContactState {
    let s = dev.read().expect("first read");
    dev.write(&ForceCommand::ZERO).expect("first write");
    let m = MESH_UNITS.to_mesh(s.position);
    plane(m + Vec3::Z * depth)
}

#[test]
fn falcon_disconnect_through_the_servo_zeroes_its_output() {
    let mut mock = MockTransport::running();
    mock.report = falcon_report();
    mock.disconnect_after_frames = Some(30);
    let mut dev = falcon(mock);
    let contact = plane_at_device(&mut dev, 0.01);
    let mut st = ServoState::default();
    let results = drive(&mut dev, &contact, 1000, &mut st);
    assert_eq!(
        *results.last().expect("ticks"),
        Err(DeviceError::Disconnected)
    );
    assert_eq!(
        results.iter().filter(|r| r.is_err()).count(),
        1,
        "one error, then the servo stops"
    );
    // Before the fault the motors carried the contact force.
    let cmds = &dev.transport().commands;
    assert!(cmds.iter().any(|c| c.motors != [0; 3]), "{cmds:?}");
    // Afterwards the driver's own output is off and it refuses to go on.
    assert!(!dev.safety().is_enabled());
    assert_eq!(dev.safety().output().force, [0.0; 3]);
    assert_eq!(dev.read(), Err(DeviceError::Disconnected));
}

#[test]
fn omni_disconnect_and_truncated_frames_end_with_the_named_error() {
    let mut c = OmniConfig::default();
    c.safety.ramp_ticks = 1;
    // Disconnect: the named error, the output off.
    let mut mock = MockFirewire::omni();
    mock.disconnect_after = Some(40);
    // Calibrated in the dock first: the Omni renders no force before that.
    mock.current.docked = true;
    let mut dev = OmniDevice::start(mock, c).expect("start-up");
    dev.read().expect("a first packet");
    dev.calibrate().expect("docked");
    let contact = plane_at_device(&mut dev, 0.01);
    let mut st = ServoState::default();
    let results = drive(&mut dev, &contact, 1000, &mut st);
    assert_eq!(
        *results.last().expect("ticks"),
        Err(DeviceError::Disconnected)
    );
    assert!(!dev.safety().is_enabled());
    let sent = &dev.transport().sent;
    assert!(sent
        .iter()
        .any(|o| o.motors_on && o.motors != [MOTOR_ZERO; 3]));
    // Every packet truncated: the read gives up after three tries with `NoFrame`, which ends
    // the run (the message names it); the motors were never left on.
    let mut mock = MockFirewire::omni();
    mock.short_every = Some(1);
    let mut dev = OmniDevice::start(mock, c).expect("start-up");
    let results = drive(
        &mut dev,
        &plane(Vec3::ZERO),
        100,
        &mut ServoState::default(),
    );
    assert_eq!(results, vec![Err(DeviceError::NoFrame)]);
    assert!(DeviceError::NoFrame
        .to_string()
        .contains("no complete frame"));
    assert!(dev.transport().sent.iter().all(|o| !o.motors_on));
}

#[test]
fn touch_library_failure_turns_forces_off_through_the_library() {
    let mut lib = MockHdLibrary::default();
    lib.fail_after_frames = Some(60);
    let mut dev = TouchDevice::new(lib, None).expect("init");
    let contact = plane_at_device(&mut dev, 0.01);
    let mut st = ServoState::default();
    let results = drive(&mut dev, &contact, 1000, &mut st);
    assert_eq!(
        *results.last().expect("ticks"),
        Err(DeviceError::Disconnected)
    );
    assert!(st.max_force > 0.0);
    assert!(
        !dev.library().force_enabled,
        "the driver switched forces off"
    );
    assert!(!dev.safety().is_enabled());
}

#[test]
fn repeated_frames_hold_one_bounded_force_and_the_servo_recovers() {
    // An Omni whose node keeps sending the same packet (the mock repeats `current` once its
    // queue is empty): the same position every tick.
    let mut c = OmniConfig::default();
    c.safety.ramp_ticks = 1;
    let mut mock = MockFirewire::omni();
    mock.current = OmniInput::default();
    let mut dev = OmniDevice::start(mock, c).expect("start-up");
    let contact = plane_at_device(&mut dev, 0.02);
    let mut st = ServoState::default();
    let p = params();
    let ring: ArrayQueue<ToolSample> = ArrayQueue::new(4);
    let mut forces = Vec::new();
    for tick in 0..200 {
        servo_tick(&mut dev, &MESH_UNITS, &p, &contact, &ring, &mut st, tick).expect("tick");
        while ring.pop().is_some() {}
        forces.push(st.last_force);
    }
    // No motion, no damping: a plane that appears already penetrated ramps in over the switch
    // time (16 ticks), then the same force bit for bit, bounded by the clamp, never growing.
    assert!(forces[0].length() > 0.0);
    let held = &forces[16..];
    assert!(held.iter().all(|f| *f == held[0]), "{forces:?}");
    assert!(forces[..16].iter().all(|f| f.length() <= held[0].length()));
    assert!(held[0].length() <= p.force.max_force);

    // A frozen device in the middle of a motion (the wrapper repeats one sample for 50
    // reads): the force is constant while frozen and follows the motion again afterwards.
    let mut c = SimConfig::default();
    c.safety.ramp_ticks = 1;
    let path = tetradrill_device::Scripted(|t: f64| tetradrill_device::PathPoint {
        position: [0.0, 0.0, -0.02 * t],
        rotation: tetradrill_device::QUAT_IDENTITY,
        buttons: 0,
    });
    let mut dev = FaultDevice::new(
        SimDevice::new(path, c),
        Faults {
            repeat: Some((100, 150)),
            ..Faults::default()
        },
    );
    let mut st = ServoState::default();
    let mut forces = Vec::new();
    for tick in 0..300 {
        servo_tick(
            &mut dev,
            &MESH_UNITS,
            &p,
            &plane(Vec3::ZERO),
            &ring,
            &mut st,
            tick,
        )
        .expect("tick");
        while ring.pop().is_some() {}
        forces.push(st.last_force);
    }
    // The first repeated read has no velocity any more (damping drops out); the rest equal it.
    assert!(forces[101..150].iter().all(|f| *f == forces[101]));
    assert!(forces.iter().all(|f| f.is_finite() && f.length() <= 8.0));
    assert_ne!(
        forces[160], forces[101],
        "the servo follows the device again"
    );
}

#[test]
fn nan_positions_give_zero_force_and_the_servo_recovers() {
    let mut dev = sim(Faults {
        nan: Some((100, 105)),
        ..Faults::default()
    });
    let mut st = ServoState::default();
    let results = drive(&mut dev, &plane(Vec3::ZERO), 200, &mut st);
    assert!(results.iter().all(|r| r.is_ok()), "{results:?}");
    let w = &dev.written();
    // Reads 100..105 carried NaN: their commands hold zero force (never NaN, so the device
    // has nothing to refuse).
    for c in &w[100..105] {
        assert_eq!(c.force, [0.0; 3], "{c:?}");
    }
    assert_eq!(dev.inner.safety().refused(), 0);
    // The first good sample after them still has a NaN previous position (its damping is
    // NaN, which the clamp turns to zero); from the next one the contact force is back.
    assert!(length(w[99].force) > 0.0);
    assert!(w[106..].iter().all(|c| length(c.force) > 0.0));
    assert_eq!(st.nonfinite_samples, 5, "counted for the run's report");

    // The simulation side: NaN and infinite burr positions leave the world valid and give no
    // force.
    let sc = Scenario {
        mesh: "builtin:block:4".into(),
        ..Scenario::default()
    };
    let tp = TickParams::of(&sc).expect("scenario");
    let mut store = EngineStorage::try_allocate(engine::load_mesh(&sc).expect("mesh").mesh, &sc)
        .expect("storage");
    let mut world = store.world().expect("world");
    let mut tool = ToolState::default();
    for p in [
        Vec3::new(0.0, 0.0, 0.45),
        Vec3::NAN,
        Vec3::new(f32::INFINITY, 0.0, 0.0),
        Vec3::new(0.0, 0.0, 0.45),
        Vec3::new(0.0, 0.0, 0.45),
    ] {
        let pose = Pose {
            position: p,
            rotation: [1.0, 0.0, 0.0, 0.0],
            buttons: 1,
        };
        let (f, _) = engine::tick(&mut world, &mut tool, &tp, &pose);
        assert!(f.is_finite());
        if !p.is_finite() {
            assert_eq!(f, Vec3::ZERO);
        }
        world.mesh().validate().expect("mesh valid");
        world
            .hierarchy()
            .validate(world.mesh())
            .expect("hierarchy valid");
    }
}

#[test]
fn missed_writes_zero_the_force_within_the_watchdog() {
    // The servo reads but its writes never arrive for 10 ticks (a wrapper swallows them):
    // the Falcon's driver keeps the exchange going on its own, and 3 ticks after the last
    // write (the watchdog) its frames carry zero motors; a later write ramps up from zero.
    let mut mock = MockTransport::running();
    mock.report = falcon_report();
    let mut c = FalconConfig::default();
    c.safety.ramp_ticks = 100;
    // Homed from the first report: no homing ramp on top of the enable ramp this test counts.
    c.homing_ramp_s = 0.0;
    let inner = FalconDevice::new(mock, c);
    let mut dev = FaultDevice::new(
        inner,
        Faults {
            drop_writes: Some((301, 311)),
            ..Faults::default()
        },
    );
    let contact = plane_at_device(&mut dev, 0.01);
    let mut st = ServoState::default();
    let p = params();
    let ring: ArrayQueue<ToolSample> = ArrayQueue::new(4);
    let mut frames_after = Vec::new();
    for tick in 0..340u64 {
        servo_tick(&mut dev, &MESH_UNITS, &p, &contact, &ring, &mut st, tick).expect("tick");
        while ring.pop().is_some() {}
        frames_after.push(dev.inner.transport().commands.len());
    }
    // `frames_after[t]`: frames sent by the end of loop tick t, which is the device's read
    // t + 1 (the plane took read 0). `at(r)`: the last frame sent by the end of read r.
    let cmds = &dev.inner.transport().commands;
    let at = |read: usize| cmds[frames_after[read - 1] - 1].motors;
    let full = at(300);
    assert_ne!(full, [0; 3], "full force before the fault");
    // The writes after reads 301..=310 are lost. The driver answers each read without a write
    // by sending the output itself: the held force for reads 302 and 303 (the watchdog allows
    // 3 ticks without a write: reads 301..=303), zero from read 304 on.
    for r in 302..=303 {
        assert_eq!(at(r), full, "read {r} holds the force");
    }
    for r in 304..=310 {
        assert_eq!(at(r), [0; 3], "read {r}: zero after the watchdog");
    }
    assert_eq!(dev.inner.safety().watchdog_trips(), 1);
    // Writes arrive again from read 311 on: a fresh ramp over 100 ticks, not a jump.
    let resumed = at(311);
    let mag = |m: [i16; 3]| m.iter().map(|v| i32::from(*v).abs()).max().unwrap_or(0);
    assert!(
        mag(resumed) > 0 && mag(resumed) * 10 < mag(full),
        "{resumed:?} vs {full:?}"
    );
}

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

/// A Falcon transport that loses the device after `writes` bulk writes.
#[derive(Debug)]
struct Unplugged {
    mock: MockTransport,
    writes: usize,
}

impl Transport for Unplugged {
    fn control_out(&mut self, request: u8, value: u16, index: u16) -> Result<(), DeviceError> {
        self.mock.control_out(request, value, index)
    }
    fn bulk_write(&mut self, data: &[u8], timeout_ms: u32) -> Result<usize, DeviceError> {
        if self.writes == 0 {
            return Err(DeviceError::Disconnected);
        }
        self.writes -= 1;
        self.mock.bulk_write(data, timeout_ms)
    }
    fn bulk_read(&mut self, buf: &mut [u8], timeout_ms: u32) -> Result<usize, DeviceError> {
        self.mock.bulk_read(buf, timeout_ms)
    }
}

fn firmware() -> Vec<u8> {
    // Not a real firmware: 600 deterministic bytes, five chunks.
    (0..600u32)
        .map(|i| (i.wrapping_mul(31) ^ 0xA5) as u8)
        .collect()
}

#[test]
fn firmware_upload_failing_halfway_never_enables_the_motors() {
    // The echo of the second chunk comes back corrupted.
    let mut mock = MockTransport::new();
    mock.corrupt_echo_at = Some(300);
    let mut dev = falcon(mock);
    assert_eq!(
        dev.load_firmware(&firmware()),
        Err(DeviceError::FirmwareMismatch { offset: 256 })
    );
    assert!(dev.transport().commands.is_empty(), "no command frame sent");
    assert!(!dev.safety().is_enabled());
    // Unplugged after the handshake and two chunks: the disconnect is reported as such and
    // the device stays unusable (every later call says so, none panics).
    let unplugged = Unplugged {
        mock: MockTransport::new(),
        writes: 4,
    };
    let mut dev = falcon_with(unplugged);
    assert_eq!(
        dev.load_firmware(&firmware()),
        Err(DeviceError::Disconnected)
    );
    assert_eq!(dev.read(), Err(DeviceError::Disconnected));
    assert!(dev.write(&ForceCommand::force([1.0, 0.0, 0.0])).is_err());
    assert!(!dev.safety().is_enabled());
}

fn falcon_with<T: Transport>(t: T) -> FalconDevice<T> {
    let mut c = FalconConfig::default();
    c.safety.ramp_ticks = 1;
    FalconDevice::new(t, c)
}

/// `pipeline::run` (what `run` and `demo` call) with a device from `open`, no viewer, no
/// real-time settings, a small mesh.
fn pipeline_with(
    open: pipeline::DeviceFactory,
    kind: DeviceKind,
    ticks: u64,
) -> Result<pipeline::RunReport, tetradrill::error::CliError> {
    let sc = Scenario {
        mesh: "builtin:block:4".into(),
        ..Scenario::default()
    };
    pipeline::run(&sc, PipelineSetup::plain(kind, open, ticks), None)
}

#[test]
fn the_pipeline_reports_a_device_fault_once_on_one_line() {
    // A simulated device unplugged at tick 250 of 2000.
    let open: pipeline::DeviceFactory = Box::new(|| {
        let c = SimConfig {
            disconnect_at_tick: Some(250),
            ..SimConfig::default()
        };
        Ok(Box::new(SimDevice::new(Still([0.0, 0.0, 0.55]), c)) as Box<dyn HapticDevice>)
    });
    let e = pipeline_with(open, DeviceKind::Sim, 2000).expect_err("the device failed");
    assert_eq!(e.code, 1);
    assert_eq!(e.message.lines().count(), 1, "{}", e.message);
    for needle in ["sim device", "disconnected", "force was set to zero"] {
        assert!(e.message.contains(needle), "{}", e.message);
    }
    // A Falcon whose firmware upload fails halfway: the run never starts, one line.
    let open: pipeline::DeviceFactory = Box::new(|| {
        let mut mock = MockTransport::new();
        mock.corrupt_echo_at = Some(300);
        let mut dev = falcon(mock);
        dev.load_firmware(&firmware())?;
        Ok(Box::new(dev) as Box<dyn HapticDevice>)
    });
    let e = pipeline_with(open, DeviceKind::Falcon, 2000).expect_err("the upload failed");
    assert_eq!(e.code, 1);
    assert_eq!(e.message.lines().count(), 1, "{}", e.message);
    for needle in ["--device falcon", "firmware echo mismatch", "256"] {
        assert!(e.message.contains(needle), "{}", e.message);
    }
}

/// Bad input that `tests/runner.rs` does not cover yet: negative and non-finite flag values
/// (a negative number used to be taken for an unknown flag), impossible values in a scenario
/// file (named with their line), and a bad trace given to `run` rather than `replay`.
#[test]
fn impossible_values_exit_2_naming_the_flag_or_the_file_and_line() {
    for (flag, value) in [
        ("--stiffness", "-1"),
        ("--stiffness", "nan"),
        ("--stiffness", "inf"),
        ("--damping", "-0.5"),
        ("--max-force", "0"),
        ("--switch-ms", "-1"),
        ("--switch-ms", "nan"),
        ("--scale", "-2"),
        ("--tool-scale", "inf"),
        ("--min-area", "nan"),
        ("--max-depth", "-1"),
        ("--ticks", "-5"),
    ] {
        refused(&["replay", flag, value], &[flag]);
    }
    refused(&["run", "--duration", "-1"], &["--duration"]);
    refused(&["demo", "--headless", "--duration", "-1"], &["--duration"]);
    refused(&["timing", "--duration", "-2"], &["--duration"]);
    for tool in ["sphere:0", "sphere:nan", "sphere:-0.1", "sphere:inf"] {
        refused(&["replay", "--tool", tool], &["radius"]);
    }
    refused(&["replay", "--trace", "wander:x"], &["wander:SEED"]);

    let dir = tetradrill_tests::scratch_dir("faults", "scenarios");
    for (name, text, line, needle) in [
        (
            "stiff.toml",
            "mesh = \"builtin:cube12\"\nstiffness = 0.0\n",
            2,
            "stiffness",
        ),
        ("nan.toml", "\n\nmax_force = nan\n", 3, "max_force"),
        ("switch.toml", "switch_ms = -16.0\n", 1, "switch_ms"),
        ("radius.toml", "tool = \"sphere:-1\"\n", 1, "radius"),
        (
            "area.toml",
            "damping = 1.0\nmin_area = -inf\n",
            2,
            "min_area",
        ),
    ] {
        let p = dir.join(name);
        std::fs::write(&p, text).expect("write scenario");
        let at = format!("{name}:{line}:");
        refused(
            &["replay", "--scenario", p.to_str().expect("utf-8")],
            &[&at, needle],
        );
    }
    // A bad trace through `run` (the simulated device plays it): file and line.
    let p = dir.join("nan.csv");
    std::fs::write(
        &p,
        "t,x,y,z,qw,qx,qy,qz,buttons\n0,0,0,0.9,1,0,0,0,0\n0.001,0,0,NaN,1,0,0,0,0\n",
    )
    .expect("write trace");
    refused(
        &[
            "run",
            "--device",
            "sim",
            "--no-rt",
            "--headless",
            "--trace",
            p.to_str().expect("utf-8"),
        ],
        &["nan.csv:3:"],
    );
}

/// The simulated device (default ramp, 500 ticks) with its hand held still at `at`, the motors
/// probed through its shared motors.
fn sim_probed(at: [f64; 3], faults: Faults) -> FaultDevice<SimDevice<Still>> {
    let mut dev = FaultDevice::new(SimDevice::new(Still(at), SimConfig::default()), faults);
    let m = dev.inner.motors();
    dev.zeroes = Some(Probe(Arc::new(move || {
        u64::from(m.output() == ForceCommand::OFF)
    })));
    let m = dev.inner.motors();
    dev.motors = Some(Probe(Arc::new(move || m.output().force)));
    dev
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
    let out = std::process::Command::new(std::env::current_exe().expect("test binary"))
        .args([
            "--exact",
            "a_panicking_servo_zeroes_the_force_and_ends_with_one_line",
            "--nocapture",
            "--test-threads=1",
        ])
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
