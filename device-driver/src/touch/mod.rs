//! Geomagic / 3D Systems Touch through the vendor's HD library (OpenHaptics HDAPI).
//!
//! There is no public protocol for the Touch. The loader `os::hdapi::HdApi` (feature `os`)
//! opens the vendor library (`libHD.so`) at run time and implements [`HdLibrary`] over it;
//! nothing is linked at build time and no vendor header is used. This codec has no `unsafe`:
//! the foreign calls are the loader's. [`MockHdLibrary`] stands in for tests.
//!
//! # The vendor scheduler's pattern
//! Every frame is begun and ended inside a callback the vendor scheduler runs at its own
//! 1 kHz (`hdScheduleAsynchronous`), as every public HDAPI driver does: the callback
//! ([`frame::callback_frame`]) reads the device and applies the servo's latest force in one
//! frame. The servo thread never calls the library on its tick; it exchanges with the
//! callback through lock-free slots ([`exchange::Exchange`]): the force command one way, the
//! device's state the other.
//!
//! # Stall path
//! The callback watches the servo's commands on its own clock: when no new one has come for
//! [`STALL_LIMIT_NS`] (5 ms), it sets a zero force until they come again (counted in
//! [`Exchange::stall_trips`]); the servo's safety filter then ramps the force up from zero.
//!
//! # Errors
//! After each frame the callback pops the library's error stack: the force warnings
//! ([`is_force_warning`], `HD_WARM_MOTORS` among them) are counted and the force ramps in
//! again; any other error turns force output off, ends the callback and, at the servo's next
//! read, the run, with the error's name.

pub mod exchange;
pub mod frame;
mod mock;

use std::sync::Arc;
use std::time::Duration;

pub use exchange::{Calibrated, Command, Exchange, FrameState, HdError};
pub use frame::{
    callback_frame, command_stale, error_name, is_force_warning, CallbackCode, HdFrame,
    STALL_LIMIT_NS,
};
pub use mock::{MockCall, MockHdLibrary};

use crate::device::{
    DeviceError, DeviceSpec, DeviceState, ForceCommand, HapticDevice, LibraryWarnings, Quat,
};
use crate::safety::{ForceSafety, SafetyConfig};

/// Library file names a loader should try, in order.
pub const HD_LIBRARY_NAMES: [&str; 3] = ["libHD.so", "libHD.so.3.4", "libHD.so.3.0"];
/// USB ids of the Touch: (vendor, product). Sources (public, none of them the vendor's own
/// list):
/// - `0301:2988`: the USB (CDC-ACM) Touch as the 2016 driver documents it and as
///   jhu-saw/sawSensablePhantom's README shows it in `dmesg` and `lsusb`;
/// - `2988:0302`: the same model as other units report it (bharatm11/Geomagic_Touch_ROS_Drivers
///   issue 2, `lsusb` output);
/// - `2988:0304`: the newer Touch (HID), the id of the udev rule (`99-3dsystems.rules`) of
///   the vendor's 2023 TouchDriver, as quoted in public ROS 2 launch files
///   (`Geomagic_Touch_ROS2/omni_common/launch/omni_state.launch.py`); not seen in an `lsusb`
///   listing.
pub const TOUCH_USB_IDS: [(u16, u16); 3] = [(0x0301, 0x2988), (0x2988, 0x0302), (0x2988, 0x0304)];
/// How long [`TouchDevice::new`] waits for the callback's first frame, and
/// [`TouchDevice::calibrate`] for its answer (outside the servo's ticks).
pub const START_WAIT: Duration = Duration::from_millis(500);
/// Servo reads in a row that find no new frame before the run ends with
/// [`DeviceError::NoFrame`] (the scheduler stopped calling back): 100 ms at 1 kHz.
pub const SILENT_READS: u32 = 100;
/// How long dropping the device waits for the callback to zero the force and end.
pub const STOP_WAIT: Duration = Duration::from_millis(20);

/// The HD library as the device needs it: initialise, and schedule the frame callback.
/// Positions in millimetres and transforms as HDAPI returns them.
pub trait HdLibrary {
    /// `hdInitDevice(HD_DEFAULT_DEVICE)` (or a named device), or make an opened device
    /// current on this thread.
    fn init(&mut self, name: Option<&str>) -> Result<(), DeviceError>;
    /// Schedules [`callback_frame`] over this library's frame calls with `exchange`, at the
    /// scheduler's highest priority (`hdScheduleAsynchronous`); it runs until it answers
    /// [`CallbackCode::Done`] or the library is dropped.
    fn schedule(&mut self, exchange: Arc<Exchange>) -> Result<(), DeviceError>;
    /// Runs the callback once when the library has no scheduler thread of its own (a test's
    /// stand-in, in lockstep with the servo). The vendor library's scheduler runs by itself:
    /// nothing to do (the default).
    fn pump(&mut self) {}
}

/// Rotation quaternion of a column-major 4x4 transform's upper 3x3.
pub fn quat_from_transform(m: &[f64; 16]) -> Quat {
    let (r00, r11, r22) = (m[0], m[5], m[10]);
    let (r01, r02, r10, r12, r20, r21) = (m[4], m[8], m[1], m[9], m[2], m[6]);
    let tr = r00 + r11 + r22;
    let q = if tr > 0.0 {
        let s = (tr + 1.0).sqrt() * 2.0;
        [0.25 * s, (r21 - r12) / s, (r02 - r20) / s, (r10 - r01) / s]
    } else if r00 > r11 && r00 > r22 {
        let s = (1.0 + r00 - r11 - r22).sqrt() * 2.0;
        [(r21 - r12) / s, 0.25 * s, (r01 + r10) / s, (r02 + r20) / s]
    } else if r11 > r22 {
        let s = (1.0 + r11 - r00 - r22).sqrt() * 2.0;
        [(r02 - r20) / s, (r01 + r10) / s, 0.25 * s, (r12 + r21) / s]
    } else {
        let s = (1.0 + r22 - r00 - r11).sqrt() * 2.0;
        [(r10 - r01) / s, (r02 + r20) / s, (r12 + r21) / s, 0.25 * s]
    };
    let n = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]).sqrt();
    if n > 0.0 && n.is_finite() {
        [q[0] / n, q[1] / n, q[2] / n, q[3] / n]
    } else {
        [1.0, 0.0, 0.0, 0.0]
    }
}

/// A Touch (or any HDAPI device) through an [`HdLibrary`].
#[derive(Debug)]
pub struct TouchDevice<L: HdLibrary> {
    lib: L,
    exchange: Arc<Exchange>,
    safety: ForceSafety,
    period_s: f64,
    tick: u64,
    wrote: bool,
    commands: u64,
    last: FrameState,
    silent_reads: u32,
    trips_seen: u64,
    warnings_seen: u64,
}

/// The device crate's error for an HD error code.
fn code_error(code: u32) -> DeviceError {
    match code {
        // HD_DEVICE_FAULT, HD_COMM_ERROR (hdDefines.h).
        0x0300 | 0x0302 => DeviceError::Disconnected,
        code => DeviceError::LibraryCall { code },
    }
}

impl<L: HdLibrary> TouchDevice<L> {
    /// Initialises the device through the library, schedules the frame callback and waits
    /// (at most [`START_WAIT`]) for its first frame.
    pub fn new(mut lib: L, name: Option<&str>) -> Result<TouchDevice<L>, DeviceError> {
        lib.init(name)?;
        let exchange = Arc::new(Exchange::new());
        lib.schedule(Arc::clone(&exchange))?;
        let mut dev = TouchDevice {
            lib,
            exchange,
            safety: ForceSafety::new(SafetyConfig::for_max_force(DeviceSpec::TOUCH.max_force_n)),
            period_s: 1e-3,
            tick: 0,
            wrote: false,
            commands: 0,
            last: FrameState::default(),
            silent_reads: 0,
            trips_seen: 0,
            warnings_seen: 0,
        };
        dev.post(&ForceCommand::OFF);
        let started = std::time::Instant::now();
        loop {
            dev.lib.pump();
            dev.check()?;
            if let Some(s) = dev.exchange.state().filter(|s| s.frame > 0) {
                dev.last = s;
                return Ok(dev);
            }
            if started.elapsed() > START_WAIT {
                return Err(DeviceError::NoFrame);
            }
            std::thread::sleep(Duration::from_millis(1));
        }
    }

    /// What the servo and the callback share (counters: stall trips, warnings, frames).
    pub fn exchange(&self) -> &Arc<Exchange> {
        &self.exchange
    }

    /// Replaces the safety settings.
    pub fn with_safety(mut self, config: SafetyConfig) -> TouchDevice<L> {
        self.safety = ForceSafety::new(config);
        self
    }

    /// The library (e.g. to inspect a mock).
    pub fn library(&self) -> &L {
        &self.lib
    }

    /// The library, mutable (e.g. to run a mock's callback as a stalled servo would see it).
    pub fn library_mut(&mut self) -> &mut L {
        &mut self.lib
    }

    /// The safety filter (counters).
    pub fn safety(&self) -> &ForceSafety {
        &self.safety
    }

    /// Posts `out` for the callback's next frame.
    fn post(&mut self, out: &ForceCommand) {
        self.commands += 1;
        self.exchange.post_command(&Command {
            force: if out.enable { out.force } else { [0.0; 3] },
            enable: out.enable,
            count: self.commands,
        });
    }

    /// The error that ended the callback, as the device crate's error.
    fn check(&self) -> Result<(), DeviceError> {
        match self.exchange.fatal() {
            Some(e) => Err(code_error(e.code)),
            None => Ok(()),
        }
    }

    fn fail(&mut self, e: DeviceError) -> DeviceError {
        self.safety.disable();
        self.post(&ForceCommand::OFF);
        e
    }
}

impl<L: HdLibrary> HapticDevice for TouchDevice<L> {
    fn spec(&self) -> DeviceSpec {
        DeviceSpec::TOUCH
    }

    /// The callback's latest frame. Bounded: a slot read and a few atomics; the library is
    /// not called.
    fn read(&mut self) -> Result<DeviceState, DeviceError> {
        self.lib.pump();
        self.check().map_err(|e| self.fail(e))?;
        // A stall trip or a force warning: the force ramps in again from zero.
        let (trips, warnings) = (self.exchange.stall_trips(), self.exchange.warnings());
        if (trips, warnings) != (self.trips_seen, self.warnings_seen) {
            (self.trips_seen, self.warnings_seen) = (trips, warnings);
            self.safety.disable();
        }
        let out = self.safety.tick();
        if !self.wrote {
            self.post(&out);
        }
        self.wrote = false;
        let s = self.exchange.state().unwrap_or(self.last);
        if s.frame == self.last.frame {
            self.silent_reads += 1;
            if self.silent_reads > SILENT_READS {
                return Err(self.fail(DeviceError::NoFrame));
            }
        } else {
            self.silent_reads = 0;
        }
        self.last = s;
        self.tick += 1;
        let p = s.position_mm;
        Ok(DeviceState {
            timestamp_s: self.tick as f64 * self.period_s,
            tick: self.tick,
            position: [p[0] * 1e-3, p[1] * 1e-3, p[2] * 1e-3],
            rotation: quat_from_transform(&s.transform),
            joint_angles: [0.0; 6],
            buttons: s.buttons,
            docked: s.inkwell,
        })
    }

    /// Filters the command and posts it for the callback. Bounded: the filter and a slot
    /// write.
    fn write(&mut self, command: &ForceCommand) -> Result<(), DeviceError> {
        self.wrote = true;
        self.check().map_err(|e| self.fail(e))?;
        match self.safety.filter(command) {
            Ok(out) => {
                self.post(&out);
                Ok(())
            }
            Err(e) => {
                self.post(&ForceCommand::OFF);
                Err(e)
            }
        }
    }

    /// Asks the callback to check the calibration in its next frame and update it with the
    /// device's style when needed; waits at most [`START_WAIT`] (not a servo-tick call).
    /// `NotDocked` when the library asks for the stylus in its inkwell.
    fn calibrate(&mut self) -> Result<(), DeviceError> {
        let request = self.exchange.request_calibration();
        let started = std::time::Instant::now();
        loop {
            self.lib.pump();
            self.check()?;
            match self.exchange.calibration(request) {
                Some(Calibrated::Ok) => return Ok(()),
                Some(Calibrated::NeedsInkwell) => return Err(DeviceError::NotDocked),
                Some(Calibrated::Code(c)) => return Err(code_error(c)),
                None if started.elapsed() > START_WAIT => return Err(DeviceError::NoFrame),
                None => std::thread::sleep(Duration::from_millis(1)),
            }
        }
    }

    fn library_warnings(&self) -> LibraryWarnings {
        let count = self.exchange.warnings();
        LibraryWarnings {
            count,
            last: (count > 0).then(|| error_name(self.exchange.last_warning())),
        }
    }
}

impl<L: HdLibrary> Drop for TouchDevice<L> {
    /// Asks the callback for a last frame with zero force and force output off, and waits for
    /// it at most [`STOP_WAIT`]; the library's own drop then stops its scheduler.
    fn drop(&mut self) {
        self.exchange.request_stop();
        let started = std::time::Instant::now();
        while !self.exchange.stopped() && started.elapsed() < STOP_WAIT {
            self.lib.pump();
            if !self.exchange.stopped() {
                std::thread::sleep(Duration::from_millis(1));
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::frame::{HD_CALIBRATION_INKWELL, HD_CALIBRATION_NEEDS_MANUAL_INPUT};
    use super::*;

    fn device(lib: MockHdLibrary, ramp_ticks: u32) -> TouchDevice<MockHdLibrary> {
        TouchDevice::new(lib, None)
            .expect("the mock starts")
            .with_safety(SafetyConfig {
                ramp_ticks,
                ..SafetyConfig::for_max_force(3.3)
            })
    }

    #[test]
    fn missing_library_is_a_clear_error() {
        let lib = MockHdLibrary {
            missing: true,
            ..Default::default()
        };
        let e = TouchDevice::new(lib, None).err();
        assert_eq!(e, Some(DeviceError::LibraryNotFound));
        assert!(e
            .map(|e| e.to_string())
            .unwrap_or_default()
            .contains("libHD.so"));
    }

    #[test]
    fn a_library_whose_scheduler_never_calls_back_does_not_start() {
        let lib = MockHdLibrary {
            no_scheduler: true,
            ..Default::default()
        };
        assert_eq!(
            TouchDevice::new(lib, None).err(),
            Some(DeviceError::NoFrame)
        );
    }

    #[test]
    fn reads_in_metres_clamps_and_disconnects() {
        let lib = MockHdLibrary {
            position_mm: [10.0, -20.0, 5.0],
            buttons: 2,
            fail_after_frames: Some(7),
            ..Default::default()
        };
        let mut dev = device(lib, 1);
        let s = dev.read().unwrap();
        assert_eq!(s.position, [0.010, -0.020, 0.005]);
        assert_eq!(s.buttons, 2);
        assert_eq!(s.rotation, [1.0, 0.0, 0.0, 0.0]);
        dev.write(&ForceCommand::force([0.0, 10.0, 0.0])).unwrap();
        // The callback applies it in its next frame.
        dev.read().unwrap();
        assert_eq!(dev.library().forces.last().copied(), Some([0.0, 3.3, 0.0]));
        assert!(dev.library().force_enabled);
        assert_eq!(dev.library().open_frames, 0);
        let mut err = None;
        for _ in 0..10 {
            if let Err(e) = dev
                .read()
                .and_then(|_| dev.write(&ForceCommand::force([1.0, 0.0, 0.0])))
            {
                err = Some(e);
                break;
            }
        }
        assert_eq!(err, Some(DeviceError::Disconnected));
        assert!(
            !dev.library().force_enabled,
            "the callback turned force off"
        );
        assert!(dev.exchange().stopped(), "and ended");
        assert_eq!(dev.library().frames, 8, "no frame after the error's");
        assert_eq!(dev.read().err(), Some(DeviceError::Disconnected));
    }

    #[test]
    fn frames_are_begun_and_ended_only_inside_the_callback() {
        let mut dev = device(MockHdLibrary::default(), 4);
        dev.calibrate().unwrap();
        for _ in 0..20 {
            dev.read().unwrap();
            dev.write(&ForceCommand::force([0.0, 0.0, 1.0])).unwrap();
        }
        let calls = &dev.library().calls;
        let begins = calls
            .iter()
            .filter(|c| matches!(c, MockCall::Begin { .. }))
            .count();
        assert_eq!(begins, dev.library().frames);
        assert!(begins >= 21, "{begins} frames");
        assert!(calls.iter().all(|c| match c {
            MockCall::Begin { in_callback } => *in_callback,
            MockCall::SetForce { in_frame } => *in_frame,
            MockCall::End => true,
        }));
        // Begin and end alternate.
        let mut open = false;
        for c in calls {
            match c {
                MockCall::Begin { .. } => {
                    assert!(!open);
                    open = true;
                }
                MockCall::End => {
                    assert!(open);
                    open = false;
                }
                MockCall::SetForce { .. } => assert!(open),
            }
        }
        // Stopping: a last frame at zero force, force output off, the callback done.
        dev.exchange().request_stop();
        dev.library_mut().pump();
        assert_eq!(dev.library().forces.last().copied(), Some([0.0; 3]));
        assert!(!dev.library().force_enabled);
        assert!(dev.exchange().stopped());
        let frames = dev.library().frames;
        dev.library_mut().pump();
        assert_eq!(dev.library().frames, frames, "no frame after the last");
    }

    #[test]
    fn commands_older_than_the_limit_are_stale() {
        // Written out: a command seen at 10 ms, the limit 5 ms.
        assert!(command_stale(0, 5, STALL_LIMIT_NS), "none seen");
        assert!(!command_stale(10_000_000, 10_000_000, STALL_LIMIT_NS));
        assert!(
            !command_stale(10_000_000, 15_000_000, STALL_LIMIT_NS),
            "exactly 5 ms"
        );
        assert!(command_stale(10_000_000, 15_000_001, STALL_LIMIT_NS));
        assert!(
            !command_stale(10_000_000, 9_000_000, STALL_LIMIT_NS),
            "clock behind"
        );
    }

    #[test]
    fn a_stalled_servo_gets_its_force_zeroed_by_the_callback_and_then_ramps() {
        let mut dev = device(MockHdLibrary::default(), 4);
        let push = ForceCommand::force([0.0, 0.0, 2.0]);
        for _ in 0..6 {
            dev.read().unwrap();
            dev.write(&push).unwrap();
        }
        // The callback, on its own clock: the new command at t, then nothing from the servo.
        let t = dev.exchange().now_ns();
        assert_eq!(
            dev.library_mut().run_callback(t),
            Some(CallbackCode::Continue)
        );
        assert_eq!(dev.library().forces.last().copied(), Some([0.0, 0.0, 2.0]));
        // A late servo tick (3 ms) is within the tolerance.
        dev.library_mut().run_callback(t + 3_000_000);
        assert_eq!(dev.library().forces.last().copied(), Some([0.0, 0.0, 2.0]));
        assert_eq!(dev.exchange().stall_trips(), 0);
        // A stalled one (6 ms): zero force, one trip however many frames it lasts.
        for k in 0..3 {
            dev.library_mut()
                .run_callback(t + 6_000_000 + k * 1_000_000);
            assert_eq!(dev.library().forces.last().copied(), Some([0.0; 3]));
        }
        assert_eq!(dev.exchange().stall_trips(), 1);
        // The servo comes back: its force ramps again from a quarter, not a jump to 2 N.
        dev.read().unwrap();
        dev.write(&push).unwrap();
        dev.read().unwrap();
        assert_eq!(dev.library().forces.last().copied(), Some([0.0, 0.0, 0.5]));
    }

    #[test]
    fn force_warnings_are_counted_and_other_errors_end_the_run() {
        let lib = MockHdLibrary {
            raise: vec![(5, 0x0200), (9, 0x0201)],
            ..Default::default()
        };
        let mut dev = device(lib, 4);
        let push = ForceCommand::force([0.0, 2.0, 0.0]);
        for _ in 0..12 {
            dev.read().unwrap();
            dev.write(&push).unwrap();
        }
        let w = dev.library_warnings();
        assert_eq!(w.count, 2);
        assert_eq!(w.last, Some("HD_EXCEEDED_MAX_FORCE"));
        assert!(dev.library().force_enabled, "warnings leave the force on");
        // Each warning restarted the ramp: the forces after frame 9 climb again.
        let f: Vec<f64> = dev.library().forces.iter().map(|f| f[1]).collect();
        assert!(f[9] < f[8], "{f:?}");

        let lib = MockHdLibrary {
            raise: vec![(4, 0x0304)],
            ..Default::default()
        };
        let mut dev = device(lib, 1);
        let mut err = None;
        for _ in 0..6 {
            if let Err(e) = dev.read().and_then(|_| dev.write(&push)) {
                err = Some(e);
                break;
            }
        }
        assert_eq!(err, Some(DeviceError::LibraryCall { code: 0x0304 }));
        assert!(err
            .map(|e| e.to_string())
            .unwrap_or_default()
            .contains("HD_TIMER_ERROR"));
        assert!(!dev.library().force_enabled);
    }

    #[test]
    fn calibration_runs_in_a_frame_of_the_callback() {
        let lib = MockHdLibrary {
            calibration_status: super::frame::HD_CALIBRATION_NEEDS_UPDATE,
            ..Default::default()
        };
        let mut dev = device(lib, 1);
        dev.calibrate().unwrap();
        // The mock offers inkwell and encoder reset: inkwell comes first.
        assert_eq!(dev.library().calibration_updates, [HD_CALIBRATION_INKWELL]);
        dev.calibrate().unwrap();
        assert_eq!(
            dev.library().calibration_updates.len(),
            1,
            "already calibrated"
        );
        dev.library_mut().calibration_status = HD_CALIBRATION_NEEDS_MANUAL_INPUT;
        assert_eq!(dev.calibrate(), Err(DeviceError::NotDocked));
    }

    #[test]
    fn transform_to_quaternion() {
        // 90 degrees about z: x -> y. Column-major: first column (0, 1, 0).
        let m = [
            0.0, 1.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0,
        ];
        let q = quat_from_transform(&m);
        let h = core::f64::consts::FRAC_1_SQRT_2;
        assert!(
            (q[0] - h).abs() < 1e-12 && (q[3] - h).abs() < 1e-12,
            "{q:?}"
        );
    }
}
