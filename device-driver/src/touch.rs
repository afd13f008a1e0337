//! Geomagic / 3D Systems Touch through the vendor's HD library (OpenHaptics HDAPI).
//!
//! There is no public protocol for the Touch. The loader `os::hdapi::HdApi` (feature `os`)
//! opens the vendor library (`libHD.so`) at run time and implements [`HdLibrary`] over it;
//! nothing is linked at build time and no vendor header is used. This codec has no `unsafe`:
//! the foreign calls are the loader's. [`MockHdLibrary`] stands in for tests.

use crate::device::{DeviceError, DeviceSpec, DeviceState, ForceCommand, HapticDevice, Quat};
use crate::safety::{ForceSafety, SafetyConfig};

/// Library file names a loader should try, in order.
pub const HD_LIBRARY_NAMES: [&str; 3] = ["libHD.so", "libHD.so.3.4", "libHD.so.3.0"];
/// USB ids of the Touch (CDC-ACM): (vendor, product).
pub const TOUCH_USB_IDS: [(u16, u16); 2] = [(0x0301, 0x2988), (0x2988, 0x0302)];

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
}

impl<L: HdLibrary> TouchDevice<L> {
    /// Initialises the device through the library.
    pub fn new(mut lib: L, name: Option<&str>) -> Result<TouchDevice<L>, DeviceError> {
        lib.init(name)?;
        Ok(TouchDevice {
            lib,
            safety: ForceSafety::new(SafetyConfig::for_max_force(DeviceSpec::TOUCH.max_force_n)),
            period_s: 1e-3,
            tick: 0,
            force_on: false,
            wrote: false,
        })
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
    frames: usize,
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
