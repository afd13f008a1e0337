//! Device faults injected for the fault tests (`tests/faults_*.rs`): [`FaultDevice`], a
//! wrapper around any [`HapticDevice`] that injects [`Faults`] by read number (disconnects,
//! repeated frames, NaN positions, swallowed writes, stalls, a panic) and records what the
//! servo wrote and what the motors rendered; the simulated and Falcon devices those tests
//! wrap; `pipeline::run` on a small mesh.

use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use tetradrill::commands::pipeline::{self, PipelineSetup};
use tetradrill::setup::{MeshSpec, Setup};
use tetradrill_device::falcon::frame::FalconReport;
use tetradrill_device::falcon::mock::MockTransport;
use tetradrill_device::falcon::{FalconConfig, FalconDevice};
use tetradrill_device::{
    DeviceError, DeviceKind, DeviceSpec, DeviceState, ForceCommand, HapticDevice, MotorCutoff,
    SimConfig, SimDevice, Still,
};

/// Faults a [`FaultDevice`] injects, by read number (the n-th call to `read`, from 0). A
/// range `(a, b)` covers reads `a..b`.
#[derive(Debug, Default, Clone, Copy)]
pub struct Faults {
    /// From this read on, every call fails with `Disconnected` (nothing reaches the device).
    pub disconnect_from: Option<u64>,
    /// These reads return the sample of the read before the range again (a frozen device).
    pub repeat: Option<(u64, u64)>,
    /// These reads carry a NaN position.
    pub nan: Option<(u64, u64)>,
    /// The writes that follow these reads are swallowed (a servo that misses its writes).
    pub drop_writes: Option<(u64, u64)>,
    /// This read sleeps first (a servo that stalls for several periods).
    pub stall: Option<(u64, Duration)>,
    /// This read blocks until the device's motors are zeroed once more (seen through
    /// [`FaultDevice::zeroes`], from this thread: nothing but another thread can zero them
    /// now), or 30 s pass: a servo stalled past the watchdog.
    pub stall_until_zero: Option<u64>,
    /// This read panics (a bug in the servo's path).
    pub panic_at: Option<u64>,
}

/// What a `stall_until_zero` stall saw, in order.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StallEvent {
    /// The read stalled; how often the motors had been zeroed by then.
    Began { zeroes: u64 },
    /// The motors were zeroed once more while the read was still stalled.
    ZeroWhileStalled,
    /// The read went on.
    Ended,
}

/// What the motors rendered after a write: (the read it followed, force).
pub type Rendered = (u64, [f64; 3]);

/// A look at the device's motors from any thread.
#[derive(Clone)]
pub struct Probe<T>(pub Arc<dyn Fn() -> T + Send + Sync>);

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
pub struct FaultDevice<D> {
    /// The wrapped device.
    pub inner: D,
    faults: Faults,
    reads: u64,
    held: Option<DeviceState>,
    /// Every command the servo wrote (forwarded or not), in order; shared, so a test can
    /// read it after the device moved into the servo thread.
    pub log: Arc<Mutex<Vec<ForceCommand>>>,
    /// How often the inner device's motors were zeroed so far (for a state probe: 1 while
    /// they render zero, else 0).
    pub zeroes: Option<Probe<u64>>,
    /// What the inner device's motors render, logged after each write with the read it
    /// followed.
    pub motors: Option<Probe<[f64; 3]>>,
    /// What the motors rendered after each write (filled when `motors` is set).
    pub rendered: Arc<Mutex<Vec<Rendered>>>,
    /// The events of a `stall_until_zero` stall.
    pub events: Arc<Mutex<Vec<StallEvent>>>,
}

impl<D: HapticDevice> FaultDevice<D> {
    /// `inner` with `faults` to inject, nothing read or written yet, no probes.
    pub fn new(inner: D, faults: Faults) -> Self {
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
    pub fn written(&self) -> Vec<ForceCommand> {
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

/// The simulated device without a ramp, held at the origin.
pub fn sim(faults: Faults) -> FaultDevice<SimDevice<Still>> {
    let mut c = SimConfig::default();
    c.safety.ramp_ticks = 1;
    FaultDevice::new(SimDevice::new(Still([0.0; 3]), c), faults)
}

/// The Falcon's motor commands at the reported position (the mock answers every frame).
pub fn falcon(mock: MockTransport) -> FalconDevice<MockTransport> {
    let mut c = FalconConfig::default();
    c.safety.ramp_ticks = 1;
    FalconDevice::new(mock, c)
}

/// A homed Falcon at encoder counts 200 on every axis, no button pressed.
pub fn falcon_report() -> FalconReport {
    FalconReport {
        encoders: [200, 200, 200],
        buttons: 0,
        homed: 0b111,
    }
}

/// `pipeline::run` (what `run` and `demo` call) with a device from `open`, no viewer, no
/// real-time settings, a small mesh.
pub fn pipeline_with(
    open: pipeline::DeviceFactory,
    kind: DeviceKind,
    ticks: u64,
) -> Result<pipeline::RunReport, tetradrill::error::CliError> {
    let sc = Setup {
        mesh: MeshSpec::new("builtin:block:4"),
        ..Setup::default()
    };
    let loaded = tetradrill::engine::load_mesh(&sc)?;
    pipeline::run(&sc, loaded, PipelineSetup::plain(kind, open, ticks), None)
}

/// The simulated device (default ramp, 500 ticks) with its hand held still at `at`, the motors
/// probed through its shared motors.
pub fn sim_probed(at: [f64; 3], faults: Faults) -> FaultDevice<SimDevice<Still>> {
    let mut dev = FaultDevice::new(SimDevice::new(Still(at), SimConfig::default()), faults);
    let m = dev.inner.motors();
    dev.zeroes = Some(Probe(Arc::new(move || {
        u64::from(m.output() == ForceCommand::OFF)
    })));
    let m = dev.inner.motors();
    dev.motors = Some(Probe(Arc::new(move || m.output().force)));
    dev
}
