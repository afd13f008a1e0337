//! Geomagic / 3D Systems Touch through the vendor's HD library (OpenHaptics HDAPI).
//!
//! There is no public protocol for the Touch. The loader `os::hdapi::HdApi` (feature `os`)
//! opens the vendor library (`libHD.so`) at run time and implements [`HdLibrary`] over it;
//! nothing is linked at build time and no vendor header is used. This codec has no `unsafe`:
//! the foreign calls are the loader's. [`MockHdLibrary`] stands in for tests.
//!
//! # Stall path
//! The Touch has no second path of its own to the motors, but the vendor library runs its own
//! scheduler thread. The device stamps a [`Heartbeat`] each time the servo reads or writes;
//! [`HdLibrary::stall_guard`] installs a callback in that scheduler which zeroes the force
//! whenever the heartbeat is older than [`STALL_LIMIT_NS`] (2 ms: two servo ticks), so a
//! stalled servo does not leave its last force applied. When the guard has acted, the next
//! enabled write ramps up from zero again.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::time::Instant;

use crate::device::{DeviceError, DeviceSpec, DeviceState, ForceCommand, HapticDevice, Quat};
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
/// Age of the servo's heartbeat after which the vendor scheduler's callback zeroes the force,
/// ns (2 ms: two ticks of the 1 kHz servo).
pub const STALL_LIMIT_NS: u64 = 2_000_000;

/// Whether a heartbeat stamped at `last_ns` (0: never stamped) is stale at `now_ns`: never
/// stamped, or more than `limit_ns` old. A clock that reads earlier than the stamp (another
/// thread's stamp landing between the two reads) is not stale.
pub const fn heartbeat_stale(last_ns: u64, now_ns: u64, limit_ns: u64) -> bool {
    last_ns == 0 || now_ns.saturating_sub(last_ns) > limit_ns
}

/// One look of the stall guard at `now_ns`: when `heartbeat` is stale (older than
/// `limit_ns`), records a trip and returns `true`: the caller (the vendor scheduler's
/// callback) then zeroes the force. This is the whole decision the callback makes.
///
/// # Bounded work
/// Two atomic operations.
pub fn guard_step(heartbeat: &Heartbeat, now_ns: u64, limit_ns: u64) -> bool {
    let stale = heartbeat.stale_at(now_ns, limit_ns);
    if stale {
        heartbeat.record_trip();
    }
    stale
}

/// The servo's heartbeat: a monotonic time stamp (ns since the heartbeat was made, plus one,
/// so 0 means "never") that the servo stores each tick and another thread reads, and the
/// number of times that thread zeroed the force. Atomics only: safe to touch from the vendor
/// scheduler's callback and from the servo.
///
/// # Bounded work
/// Every method is one clock read and one or two atomic operations.
#[derive(Debug)]
pub struct Heartbeat {
    origin: Instant,
    last_ns: AtomicU64,
    trips: AtomicU64,
}

impl Default for Heartbeat {
    fn default() -> Heartbeat {
        Heartbeat::new()
    }
}

impl Heartbeat {
    /// A heartbeat never stamped (stale until the first [`beat`](Self::beat)).
    pub fn new() -> Heartbeat {
        Heartbeat {
            origin: Instant::now(),
            last_ns: AtomicU64::new(0),
            trips: AtomicU64::new(0),
        }
    }

    /// Now on this heartbeat's clock (monotonic), ns, at least 1.
    pub fn now_ns(&self) -> u64 {
        u64::try_from(self.origin.elapsed().as_nanos())
            .unwrap_or(u64::MAX - 1)
            .saturating_add(1)
    }

    /// Stamps the heartbeat now.
    pub fn beat(&self) {
        self.beat_at(self.now_ns());
    }

    /// Stamps the heartbeat at `now_ns` (this heartbeat's clock; for tests with their own).
    pub fn beat_at(&self, now_ns: u64) {
        self.last_ns.store(now_ns, Ordering::Release);
    }

    /// The last stamp, ns (0: never).
    pub fn last_ns(&self) -> u64 {
        self.last_ns.load(Ordering::Acquire)
    }

    /// Whether the heartbeat is stale at `now_ns` ([`heartbeat_stale`] with `limit_ns`).
    pub fn stale_at(&self, now_ns: u64, limit_ns: u64) -> bool {
        heartbeat_stale(self.last_ns(), now_ns, limit_ns)
    }

    /// Whether the heartbeat is older than [`STALL_LIMIT_NS`] now.
    pub fn stale(&self) -> bool {
        self.stale_at(self.now_ns(), STALL_LIMIT_NS)
    }

    /// Records that the force was zeroed because the heartbeat was stale.
    pub fn record_trip(&self) {
        self.trips.fetch_add(1, Ordering::AcqRel);
    }

    /// How often the force was zeroed because the heartbeat was stale.
    pub fn trips(&self) -> u64 {
        self.trips.load(Ordering::Acquire)
    }
}

/// The subset of HDAPI the device needs. Positions in millimetres and transforms as HDAPI
/// returns them; errors mapped to [`DeviceError`] by the implementor
/// (e.g. [`DeviceError::LibraryCall`] with the HD error code).
pub trait HdLibrary {
    /// `hdInitDevice(HD_DEFAULT_DEVICE)` (or a named device).
    fn init(&mut self, name: Option<&str>) -> Result<(), DeviceError>;
    /// `hdBeginFrame`.
    fn begin_frame(&mut self) -> Result<(), DeviceError>;
    /// `hdEndFrame`.
    fn end_frame(&mut self) -> Result<(), DeviceError>;
    /// `hdGetDoublev(HD_CURRENT_POSITION)`, mm.
    fn position_mm(&mut self) -> Result<[f64; 3], DeviceError>;
    /// `hdGetDoublev(HD_CURRENT_TRANSFORM)`: 4x4 column-major, translation in mm.
    fn transform(&mut self) -> Result<[f64; 16], DeviceError>;
    /// `hdGetIntegerv(HD_CURRENT_BUTTONS)`.
    fn buttons(&mut self) -> Result<u32, DeviceError>;
    /// `hdGetIntegerv(HD_CURRENT_INKWELL_SWITCH)`: true when in the inkwell.
    fn inkwell(&mut self) -> Result<bool, DeviceError>;
    /// `hdSetDoublev(HD_CURRENT_FORCE)`, N.
    fn set_force(&mut self, force: [f64; 3]) -> Result<(), DeviceError>;
    /// `hdEnable(HD_FORCE_OUTPUT)` / `hdDisable(HD_FORCE_OUTPUT)`.
    fn enable_force(&mut self, on: bool) -> Result<(), DeviceError>;
    /// `hdUpdateCalibration` with the device's calibration style.
    fn update_calibration(&mut self) -> Result<(), DeviceError>;
    /// Installs a callback in the library's own scheduler that zeroes the force (and calls
    /// [`Heartbeat::record_trip`]) while `heartbeat` is stale ([`Heartbeat::stale`]).
    /// `Ok(false)` (the default) when the library offers no way to do it.
    fn stall_guard(&mut self, heartbeat: Arc<Heartbeat>) -> Result<bool, DeviceError> {
        let _ = heartbeat;
        Ok(false)
    }
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
pub struct TouchDevice<L> {
    lib: L,
    safety: ForceSafety,
    period_s: f64,
    tick: u64,
    force_on: bool,
    wrote: bool,
    heartbeat: Arc<Heartbeat>,
    guarded: bool,
    trips_seen: u64,
}

impl<L: HdLibrary> TouchDevice<L> {
    /// Initialises the device through the library and installs the stall guard
    /// ([`HdLibrary::stall_guard`]) when the library offers one.
    pub fn new(mut lib: L, name: Option<&str>) -> Result<TouchDevice<L>, DeviceError> {
        lib.init(name)?;
        let heartbeat = Arc::new(Heartbeat::new());
        let guarded = lib.stall_guard(Arc::clone(&heartbeat))?;
        Ok(TouchDevice {
            lib,
            safety: ForceSafety::new(SafetyConfig::for_max_force(DeviceSpec::TOUCH.max_force_n)),
            period_s: 1e-3,
            tick: 0,
            force_on: false,
            wrote: false,
            heartbeat,
            guarded,
            trips_seen: 0,
        })
    }

    /// The servo's heartbeat, which the stall guard reads.
    pub fn heartbeat(&self) -> &Arc<Heartbeat> {
        &self.heartbeat
    }

    /// Whether the library's scheduler runs the stall guard.
    pub fn stall_guarded(&self) -> bool {
        self.guarded
    }

    /// Stamps the heartbeat; when the guard zeroed the force since the last look, the filter
    /// restarts so the force ramps up again instead of jumping back.
    fn beat(&mut self) {
        self.heartbeat.beat();
        let trips = self.heartbeat.trips();
        if trips != self.trips_seen {
            self.trips_seen = trips;
            self.safety.disable();
        }
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

    /// The safety filter (counters).
    pub fn safety(&self) -> &ForceSafety {
        &self.safety
    }

    fn render(&mut self, out: &ForceCommand) -> Result<(), DeviceError> {
        if out.enable != self.force_on {
            self.lib.enable_force(out.enable)?;
            self.force_on = out.enable;
        }
        self.lib.begin_frame()?;
        let set = self
            .lib
            .set_force(if out.enable { out.force } else { [0.0; 3] });
        let end = self.lib.end_frame();
        set.and(end)
    }

    fn fail(&mut self, e: DeviceError) -> DeviceError {
        self.safety.disable();
        // Best effort: the library may already be gone.
        let _ = self.lib.enable_force(false);
        self.force_on = false;
        e
    }
}

impl<L: HdLibrary> HapticDevice for TouchDevice<L> {
    fn spec(&self) -> DeviceSpec {
        DeviceSpec::TOUCH
    }

    fn read(&mut self) -> Result<DeviceState, DeviceError> {
        self.beat();
        let out = self.safety.tick();
        if !self.wrote {
            self.render(&out).map_err(|e| self.fail(e))?;
        }
        self.wrote = false;
        let frame = (|| {
            self.lib.begin_frame()?;
            let p = self.lib.position_mm()?;
            let m = self.lib.transform()?;
            let buttons = self.lib.buttons()?;
            let docked = self.lib.inkwell()?;
            self.lib.end_frame()?;
            Ok::<_, DeviceError>((p, m, buttons, docked))
        })();
        let (p, m, buttons, docked) = frame.map_err(|e| self.fail(e))?;
        self.tick += 1;
        Ok(DeviceState {
            timestamp_s: self.tick as f64 * self.period_s,
            tick: self.tick,
            position: [p[0] * 1e-3, p[1] * 1e-3, p[2] * 1e-3],
            rotation: quat_from_transform(&m),
            joint_angles: [0.0; 6],
            buttons,
            docked,
        })
    }

    fn write(&mut self, command: &ForceCommand) -> Result<(), DeviceError> {
        self.wrote = true;
        self.beat();
        match self.safety.filter(command) {
            Ok(out) => self.render(&out).map_err(|e| self.fail(e)),
            Err(e) => {
                self.render(&ForceCommand::OFF).map_err(|e| self.fail(e))?;
                Err(e)
            }
        }
    }

    fn calibrate(&mut self) -> Result<(), DeviceError> {
        self.lib.update_calibration()
    }
}

/// A scripted HD library for tests: a stylus path in mm, recorded forces, optional failure.
#[derive(Debug, Default)]
pub struct MockHdLibrary {
    /// Position returned by the next reads, mm.
    pub position_mm: [f64; 3],
    /// Buttons returned.
    pub buttons: u32,
    /// Every force set, N.
    pub forces: Vec<[f64; 3]>,
    /// Force output enabled.
    pub force_enabled: bool,
    /// Frames begun and not ended.
    pub open_frames: i32,
    /// After this many frames every call fails with `Disconnected`.
    pub fail_after_frames: Option<usize>,
    /// Not installed: `init` fails with `LibraryNotFound`.
    pub missing: bool,
    /// The heartbeat handed to [`HdLibrary::stall_guard`]; a test plays the scheduler's
    /// callback with it ([`MockHdLibrary::scheduler_tick`]).
    pub guard: Option<Arc<Heartbeat>>,
    /// Offer no stall guard (`stall_guard` answers `Ok(false)`).
    pub no_guard: bool,
    frames: usize,
}

impl MockHdLibrary {
    /// What the vendor scheduler's callback does at `now_ns` on the heartbeat's clock:
    /// [`guard_step`] with [`STALL_LIMIT_NS`], and a zero force when it says so. Returns
    /// whether it zeroed.
    pub fn scheduler_tick(&mut self, now_ns: u64) -> bool {
        let Some(hb) = self.guard.clone() else {
            return false;
        };
        let zero = guard_step(&hb, now_ns, STALL_LIMIT_NS);
        if zero {
            self.forces.push([0.0; 3]);
        }
        zero
    }
}

impl MockHdLibrary {
    fn alive(&self) -> Result<(), DeviceError> {
        match self.fail_after_frames {
            Some(n) if self.frames >= n => Err(DeviceError::Disconnected),
            _ => Ok(()),
        }
    }
}

impl HdLibrary for MockHdLibrary {
    fn init(&mut self, _name: Option<&str>) -> Result<(), DeviceError> {
        if self.missing {
            Err(DeviceError::LibraryNotFound)
        } else {
            Ok(())
        }
    }
    fn begin_frame(&mut self) -> Result<(), DeviceError> {
        self.alive()?;
        self.frames += 1;
        self.open_frames += 1;
        Ok(())
    }
    fn end_frame(&mut self) -> Result<(), DeviceError> {
        self.open_frames -= 1;
        Ok(())
    }
    fn position_mm(&mut self) -> Result<[f64; 3], DeviceError> {
        self.alive()?;
        Ok(self.position_mm)
    }
    fn transform(&mut self) -> Result<[f64; 16], DeviceError> {
        let p = self.position_mm;
        Ok([
            1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, p[0], p[1], p[2], 1.0,
        ])
    }
    fn buttons(&mut self) -> Result<u32, DeviceError> {
        Ok(self.buttons)
    }
    fn inkwell(&mut self) -> Result<bool, DeviceError> {
        Ok(false)
    }
    fn set_force(&mut self, force: [f64; 3]) -> Result<(), DeviceError> {
        self.alive()?;
        self.forces.push(force);
        Ok(())
    }
    fn enable_force(&mut self, on: bool) -> Result<(), DeviceError> {
        self.force_enabled = on;
        Ok(())
    }
    fn update_calibration(&mut self) -> Result<(), DeviceError> {
        Ok(())
    }
    fn stall_guard(&mut self, heartbeat: Arc<Heartbeat>) -> Result<bool, DeviceError> {
        if self.no_guard {
            return Ok(false);
        }
        self.guard = Some(heartbeat);
        Ok(true)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
    fn reads_in_metres_clamps_and_disconnects() {
        let lib = MockHdLibrary {
            position_mm: [10.0, -20.0, 5.0],
            buttons: 2,
            fail_after_frames: Some(7),
            ..Default::default()
        };
        let mut dev = TouchDevice::new(lib, None)
            .unwrap()
            .with_safety(SafetyConfig {
                ramp_ticks: 1,
                ..SafetyConfig::for_max_force(3.3)
            });
        let s = dev.read().unwrap();
        assert_eq!(s.position, [0.010, -0.020, 0.005]);
        assert_eq!(s.buttons, 2);
        assert_eq!(s.rotation, [1.0, 0.0, 0.0, 0.0]);
        dev.write(&ForceCommand::force([0.0, 10.0, 0.0])).unwrap();
        assert_eq!(dev.library().forces.last().copied(), Some([0.0, 3.3, 0.0]));
        assert!(dev.library().force_enabled);
        assert_eq!(dev.library().open_frames, 0);
        let mut err = None;
        for _ in 0..5 {
            if let Err(e) = dev
                .read()
                .and_then(|_| dev.write(&ForceCommand::force([1.0, 0.0, 0.0])))
            {
                err = Some(e);
                break;
            }
        }
        assert_eq!(err, Some(DeviceError::Disconnected));
        assert!(!dev.library().force_enabled);
    }

    #[test]
    fn heartbeat_older_than_the_limit_is_stale() {
        // Written out: a stamp at 10 ms, the limit 2 ms.
        assert!(heartbeat_stale(0, 5, STALL_LIMIT_NS), "never stamped");
        assert!(!heartbeat_stale(10_000_000, 10_000_000, STALL_LIMIT_NS));
        assert!(
            !heartbeat_stale(10_000_000, 12_000_000, STALL_LIMIT_NS),
            "exactly 2 ms"
        );
        assert!(heartbeat_stale(10_000_000, 12_000_001, STALL_LIMIT_NS));
        assert!(
            !heartbeat_stale(10_000_000, 9_000_000, STALL_LIMIT_NS),
            "clock behind"
        );
        let hb = Heartbeat::new();
        assert!(
            guard_step(&hb, 1, STALL_LIMIT_NS),
            "stale before the first beat"
        );
        hb.beat_at(3_000_000);
        assert!(!guard_step(&hb, 4_500_000, STALL_LIMIT_NS));
        assert!(guard_step(&hb, 5_500_000, STALL_LIMIT_NS));
        assert_eq!(hb.trips(), 2);
        // The real clock: a fresh beat is not stale.
        hb.beat();
        assert!(hb.last_ns() >= 1);
        assert!(!hb.stale_at(hb.last_ns(), STALL_LIMIT_NS));
    }

    #[test]
    fn a_stalled_servo_gets_its_force_zeroed_by_the_scheduler_and_then_ramps() {
        let mut dev = TouchDevice::new(MockHdLibrary::default(), None)
            .unwrap()
            .with_safety(SafetyConfig {
                ramp_ticks: 4,
                ..SafetyConfig::for_max_force(3.3)
            });
        assert!(dev.stall_guarded());
        let push = ForceCommand::force([0.0, 0.0, 2.0]);
        for _ in 0..6 {
            dev.read().unwrap();
            dev.write(&push).unwrap();
        }
        assert_eq!(dev.library().forces.last().copied(), Some([0.0, 0.0, 2.0]));
        // The scheduler looks 1 ms after the servo's last stamp: nothing to do.
        let last = dev.heartbeat().last_ns();
        assert!(!dev.lib.scheduler_tick(last + 1_000_000));
        // The servo stalls: 3 ms later the scheduler zeroes the force.
        assert!(dev.lib.scheduler_tick(last + 3_000_000));
        assert_eq!(dev.library().forces.last().copied(), Some([0.0; 3]));
        assert_eq!(dev.heartbeat().trips(), 1);
        // The servo comes back: its force ramps again from a quarter, not a jump to 2 N.
        dev.read().unwrap();
        dev.write(&push).unwrap();
        assert_eq!(dev.library().forces.last().copied(), Some([0.0, 0.0, 0.5]));
        // A library without a guard says so.
        let lib = MockHdLibrary {
            no_guard: true,
            ..Default::default()
        };
        assert!(!TouchDevice::new(lib, None).unwrap().stall_guarded());
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
