//! Device faults at the level of the runner's servo tick (`tasks::servo_tick`), through the
//! device crate's mock transports (Falcon `MockTransport`, Omni `MockFirewire`, Touch
//! `MockHdLibrary`) and the fault-injecting wrapper of `tetradrill_tests::faults`: a
//! disconnect mid-run, stale and repeated frames, truncated frames, NaN positions, a servo
//! that misses writes, a firmware upload failing halfway, and the one line `pipeline::run`
//! ends with after a device fault. The oracle is what docs/SAFETY.md says the runner does,
//! read from what reached the mocks: the force goes to zero within the watchdog time, the
//! error comes back once and names the fault, the runner ends or recovers, nothing aborts.

use crossbeam::queue::ArrayQueue;
use tetradrill::commands::pipeline::{self, MESH_UNITS};
use tetradrill::engine::{self, EngineStorage, TickParams};
use tetradrill::scenario::Scenario;
use tetradrill::setup::Setup;
use tetradrill::tasks::{servo_tick, ServoState, ToolSample};
use tetradrill::traces::Pose;
use tetradrill_core::force::ToolState;
use tetradrill_core::servo::ContactState;
use tetradrill_core::Vec3;
use tetradrill_device::falcon::mock::MockTransport;
use tetradrill_device::falcon::{FalconConfig, FalconDevice, Transport};
use tetradrill_device::omni::mock::MockFirewire;
use tetradrill_device::omni::packet::{OmniInput, MOTOR_ZERO};
use tetradrill_device::omni::{OmniConfig, OmniDevice};
use tetradrill_device::touch::{MockHdLibrary, TouchDevice};
use tetradrill_device::{
    DeviceError, DeviceKind, ForceCommand, HapticDevice, SimConfig, SimDevice, Still,
};
use tetradrill_tests::faults::{falcon, falcon_report, pipeline_with, sim, FaultDevice, Faults};

/// Stiffness 100 N per unit, damping 0.5 N s per unit, clamp 8 N, burr radius 0.1.
fn params() -> TickParams {
    let mut setup = Setup::default();
    setup.forces.stiffness = 100.0;
    TickParams::of(&setup).expect("valid scenario")
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
        stiffness: 0.0,
        vibration: tetradrill_core::servo::VibrationCue::default(),
        friction: 0.0,
    }
}

fn length(f: [f64; 3]) -> f64 {
    (f[0] * f[0] + f[1] * f[1] + f[2] * f[2]).sqrt()
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

/// A contact plane that puts `dev`'s first reported position `depth` under the surface.
fn plane_at_device(dev: &mut dyn HapticDevice, depth: f32) -> ContactState {
    let s = dev.read().expect("first read");
    dev.write(&ForceCommand::ZERO).expect("first write");
    let m = MESH_UNITS.to_mesh(s.position);
    plane(m + Vec3::Z * depth)
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
    }
    .setup()
    .expect("a valid set-up");
    let tp = TickParams::of(&sc).expect("scenario");
    let mut store =
        EngineStorage::new(engine::load_mesh(&sc).expect("mesh").mesh, &sc).expect("storage");
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
    // Not a real firmware: 600 deterministic bytes, ten 62-byte blocks.
    (0..600u32)
        .map(|i| (i.wrapping_mul(31) ^ 0xA5) as u8)
        .collect()
}

fn falcon_with<T: Transport>(t: T) -> FalconDevice<T> {
    let mut c = FalconConfig::default();
    c.safety.ramp_ticks = 1;
    FalconDevice::new(t, c)
}

#[test]
fn firmware_upload_failing_halfway_never_enables_the_motors() {
    // The echo of the fifth block (bytes 248..310) comes back corrupted.
    let mut mock = MockTransport::new();
    mock.corrupt_echo_at = Some(300);
    let mut dev = falcon(mock);
    assert_eq!(
        dev.load_firmware(&firmware()),
        Err(DeviceError::FirmwareMismatch { offset: 248 })
    );
    assert!(dev.transport().commands.is_empty(), "no command frame sent");
    assert!(!dev.safety().is_enabled());
    // Unplugged after the handshake and two blocks: the disconnect is reported as such and
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
    for needle in ["--device falcon", "firmware echo mismatch", "248"] {
        assert!(e.message.contains(needle), "{}", e.message);
    }
}
