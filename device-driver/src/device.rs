//! The device contract: [`HapticDevice`], its specification, state, command and errors.
//!
//! Modelled after CHAI3D's `cGenericHapticDevice` and OpenHaptics HDAPI. Units are SI:
//! metres, newtons, newton-metres, seconds. Vectors are plain `[f64; 3]`; rotations are unit
//! quaternions `[w, x, y, z]`.

use core::fmt;

/// A 3-vector in metres, newtons or radians depending on context.
pub type Vec3 = [f64; 3];
/// A unit quaternion `[w, x, y, z]`.
pub type Quat = [f64; 4];
/// The identity rotation.
pub const QUAT_IDENTITY: Quat = [1.0, 0.0, 0.0, 0.0];

/// How a device finds its zero (HDAPI's calibration styles plus the Falcon's homing).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CalibrationStyle {
    /// Nothing to do: absolute sensors or a simulated device.
    None,
    /// Encoders are reset at a known pose (HD_CALIBRATION_ENCODER_RESET).
    EncoderReset,
    /// The stylus is put in its inkwell / dock (HD_CALIBRATION_INKWELL).
    Inkwell,
    /// The user moves the grip through the workspace until each axis reports homed (Falcon).
    Homing,
}

/// What a device can do: limits after CHAI3D's `cHapticDeviceInfo`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DeviceSpec {
    /// Model name.
    pub name: &'static str,
    /// Peak force the device may render, N.
    pub max_force_n: f64,
    /// Force the device may hold indefinitely, N.
    pub max_continuous_force_n: f64,
    /// Thermal time constant of its motors' windings, s: how fast a force above the continuous
    /// one heats them (the host's continuous-force model derates the force by it).
    pub thermal_time_s: f64,
    /// Largest stable virtual stiffness, N/m.
    pub max_stiffness_n_per_m: f64,
    /// Largest stable virtual damping, N s/m.
    pub max_damping_n_s_per_m: f64,
    /// Radius of the usable workspace around the device origin, m.
    pub workspace_radius_m: f64,
    /// Degrees of freedom sensed (3 = position, 6 = position and rotation).
    pub dof_sensed: u8,
    /// Degrees of freedom actuated (3 = force only).
    pub dof_actuated: u8,
    /// How the device is calibrated.
    pub calibration: CalibrationStyle,
}

impl DeviceSpec {
    /// SensAble PHANTOM Omni (CHAI3D limits).
    pub const OMNI: DeviceSpec = DeviceSpec {
        name: "PHANTOM Omni",
        max_force_n: 3.3,
        max_continuous_force_n: 0.88,
        thermal_time_s: 20.0,
        max_stiffness_n_per_m: 700.0,
        max_damping_n_s_per_m: 5.0,
        workspace_radius_m: 0.10,
        dof_sensed: 6,
        dof_actuated: 3,
        calibration: CalibrationStyle::Inkwell,
    };
    /// Geomagic / 3D Systems Touch (CHAI3D limits).
    pub const TOUCH: DeviceSpec = DeviceSpec {
        name: "Touch",
        max_force_n: 3.3,
        max_continuous_force_n: 0.88,
        thermal_time_s: 20.0,
        max_stiffness_n_per_m: 400.0,
        max_damping_n_s_per_m: 4.0,
        workspace_radius_m: 0.075,
        dof_sensed: 6,
        dof_actuated: 3,
        calibration: CalibrationStyle::Inkwell,
    };
    /// Novint Falcon (CHAI3D limits).
    pub const FALCON: DeviceSpec = DeviceSpec {
        name: "Novint Falcon",
        max_force_n: 8.0,
        max_continuous_force_n: 8.0,
        thermal_time_s: 20.0,
        max_stiffness_n_per_m: 3000.0,
        max_damping_n_s_per_m: 20.0,
        workspace_radius_m: 0.04,
        dof_sensed: 3,
        dof_actuated: 3,
        calibration: CalibrationStyle::Homing,
    };
    /// The simulated device: Falcon-like limits so the same scenes feel the same.
    pub const SIM: DeviceSpec = DeviceSpec {
        name: "simulated",
        max_force_n: 8.0,
        max_continuous_force_n: 8.0,
        thermal_time_s: 20.0,
        max_stiffness_n_per_m: 3000.0,
        max_damping_n_s_per_m: 20.0,
        workspace_radius_m: 0.10,
        dof_sensed: 6,
        dof_actuated: 3,
        calibration: CalibrationStyle::None,
    };
}

/// One sample read from a device.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DeviceState {
    /// Device clock, seconds since the device was opened (never wall time for simulations).
    pub timestamp_s: f64,
    /// Device tick counter (one per `read`).
    pub tick: u64,
    /// Tool-tip position, m, in the device frame.
    pub position: Vec3,
    /// Stylus rotation, unit quaternion `[w, x, y, z]`.
    pub rotation: Quat,
    /// Joint angles, rad: three arm joints then up to three gimbal joints (0 when not sensed).
    pub joint_angles: [f64; 6],
    /// Button bit mask (bit 0 = first button = drill on).
    pub buttons: u32,
    /// Stylus in its dock / inkwell.
    pub docked: bool,
}

impl DeviceState {
    /// A state at the origin with identity rotation and nothing pressed.
    pub const ZERO: DeviceState = DeviceState {
        timestamp_s: 0.0,
        tick: 0,
        position: [0.0; 3],
        rotation: QUAT_IDENTITY,
        joint_angles: [0.0; 6],
        buttons: 0,
        docked: false,
    };
}

/// What the servo asks a device to render.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ForceCommand {
    /// Force on the tool tip, N, device frame.
    pub force: Vec3,
    /// Torque on the stylus, N m (ignored by 3-DOF-actuated devices).
    pub torque: Vec3,
    /// Motors on. With `false` the device renders nothing and the ramp restarts on re-enable.
    pub enable: bool,
}

impl ForceCommand {
    /// Motors off, no force.
    pub const OFF: ForceCommand = ForceCommand {
        force: [0.0; 3],
        torque: [0.0; 3],
        enable: false,
    };
    /// Motors on, no force.
    pub const ZERO: ForceCommand = ForceCommand {
        force: [0.0; 3],
        torque: [0.0; 3],
        enable: true,
    };

    /// Motors on with this force and no torque.
    pub const fn force(force: Vec3) -> ForceCommand {
        ForceCommand {
            force,
            torque: [0.0; 3],
            enable: true,
        }
    }
}

/// Which kind of device (the command line's `--device`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum DeviceKind {
    /// The simulated device.
    Sim,
    /// Novint Falcon over USB.
    Falcon,
    /// SensAble PHANTOM Omni over IEEE-1394.
    Omni,
    /// Geomagic / 3D Systems Touch through the vendor HD library.
    Touch,
    /// A device of the program's own, driven through [`HapticDevice`] (not a command-line
    /// choice).
    Custom,
}

impl DeviceKind {
    /// Every kind, in command-line order.
    pub const ALL: [DeviceKind; 4] = [
        DeviceKind::Sim,
        DeviceKind::Falcon,
        DeviceKind::Omni,
        DeviceKind::Touch,
    ];

    /// The command-line name.
    pub const fn name(self) -> &'static str {
        match self {
            DeviceKind::Sim => "sim",
            DeviceKind::Falcon => "falcon",
            DeviceKind::Omni => "omni",
            DeviceKind::Touch => "touch",
            DeviceKind::Custom => "custom",
        }
    }

    /// Parses a command-line name (`sim`, `falcon`, `omni`, `touch`).
    pub fn parse(name: &str) -> Option<DeviceKind> {
        DeviceKind::ALL.into_iter().find(|k| k.name() == name)
    }

    /// What discovery looks for, for "not found" messages.
    pub const fn looked_for(self) -> &'static str {
        match self {
            DeviceKind::Sim => "nothing (always available)",
            DeviceKind::Falcon => "USB 0403:cb48 (Novint Falcon, FTDI)",
            DeviceKind::Omni => {
                "an IEEE-1394 node with vendor OUI 0x000b99 (SensAble) under /dev/fw* and \
                 /sys/bus/firewire/devices"
            }
            DeviceKind::Touch => {
                "USB 0301:2988, 2988:0302 or 2988:0304 and the vendor HD library (libHD.so) at run time"
            }
            DeviceKind::Custom => "the program's own device",
        }
    }
}

impl fmt::Display for DeviceKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// Everything that can go wrong talking to a device. Small and `Copy`; nothing here panics.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DeviceError {
    /// No such device attached.
    NotFound(DeviceKind),
    /// The device went away (unplugged, bus reset, powered off). Force is zeroed.
    Disconnected,
    /// The device did not answer in time.
    Timeout,
    /// A command held NaN or an infinite value; it was refused and force is zeroed.
    NonFiniteCommand,
    /// No complete frame could be assembled from what the device sent.
    NoFrame,
    /// The device identified itself as something else (e.g. the wrong FireWire OUI).
    WrongDevice {
        /// What was read instead.
        found: u32,
    },
    /// A start-up register did not read back what the protocol expects.
    RegisterCheck {
        /// Register address.
        address: u32,
        /// Expected value.
        expected: u8,
        /// Value read.
        found: u8,
    },
    /// The firmware loader's handshake failed at this step (1-based).
    FirmwareHandshake {
        /// Step of the handshake.
        step: u8,
    },
    /// The firmware echo did not match at this byte offset.
    FirmwareMismatch {
        /// Offset in the firmware file of the first block that failed.
        offset: u32,
    },
    /// The firmware file could not be read or is empty.
    FirmwareFile,
    /// No firmware answered a status frame at start-up (none loaded, or it stopped).
    FirmwareNotRunning,
    /// Inkwell calibration asked for while the stylus is not docked.
    NotDocked,
    /// Position could not be computed from the joint readings (out of the mechanism's range).
    Kinematics,
    /// No usable report (no complete frame, or no position solved from it) for this many
    /// ticks in a row; each held the last position. Force is zeroed.
    ReportsLost {
        /// Ticks in a row without a usable report.
        in_row: u32,
    },
    /// The vendor's HD library is not installed / could not be loaded.
    LibraryNotFound,
    /// The vendor library reported an error code.
    LibraryCall {
        /// The library's error code.
        code: u32,
    },
    /// Any other transport failure, with a short reason.
    Transport(&'static str),
    /// This backend cannot be opened in this build (e.g. no FireWire transport yet).
    Unsupported(DeviceKind),
}

impl fmt::Display for DeviceError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            DeviceError::NotFound(k) => {
                write!(f, "no {k} device found (looked for {})", k.looked_for())
            }
            DeviceError::Disconnected => f.write_str("device disconnected"),
            DeviceError::Timeout => f.write_str("device did not answer in time"),
            DeviceError::NonFiniteCommand => {
                f.write_str("force command held NaN or infinity; refused, force zeroed")
            }
            DeviceError::NoFrame => f.write_str("no complete frame received from the device"),
            DeviceError::WrongDevice { found } => {
                write!(f, "device identification failed (read {found:#010x})")
            }
            DeviceError::RegisterCheck {
                address,
                expected,
                found,
            } => write!(
                f,
                "register {address:#06x} read {found:#04x}, expected {expected:#04x}"
            ),
            DeviceError::FirmwareHandshake { step } => {
                write!(f, "firmware loader handshake failed at step {step}")
            }
            DeviceError::FirmwareMismatch { offset } => {
                write!(f, "firmware echo mismatch in the block at byte {offset}")
            }
            DeviceError::FirmwareFile => f.write_str("firmware file missing, unreadable or empty"),
            DeviceError::FirmwareNotRunning => {
                f.write_str("no firmware answers (no status frame came back)")
            }
            DeviceError::NotDocked => f.write_str("put the stylus in its inkwell to calibrate"),
            DeviceError::Kinematics => f.write_str("joint readings outside the mechanism's range"),
            DeviceError::ReportsLost { in_row } => write!(
                f,
                "no usable report for {in_row} ticks in a row (missed frames or failed \
                 kinematics solves, each holding the last position); force zeroed"
            ),
            DeviceError::LibraryNotFound => f.write_str(
                "vendor HD library (libHD.so, OpenHaptics / Touch device drivers) not found",
            ),
            DeviceError::LibraryCall { code } => write!(
                f,
                "vendor library error {code:#06x} ({})",
                crate::touch::error_name(code)
            ),
            DeviceError::Transport(why) => write!(f, "transport error: {why}"),
            DeviceError::Unsupported(k) => {
                write!(f, "the {k} backend cannot be opened in this build")
            }
        }
    }
}

impl std::error::Error for DeviceError {}

/// One haptic device. Every backend runs its commands through a
/// [`ForceSafety`](crate::safety::ForceSafety) filter, so callers cannot bypass the limits.
///
/// The servo calls `read()` then `write()` once per tick.
pub trait HapticDevice {
    /// Limits and capabilities.
    fn spec(&self) -> DeviceSpec;
    /// Reads one sample; advances the device tick (and the watchdog).
    fn read(&mut self) -> Result<DeviceState, DeviceError>;
    /// Sends a force command. It is clamped, ramped and checked before it reaches the motors.
    fn write(&mut self, command: &ForceCommand) -> Result<(), DeviceError>;
    /// Starts or performs calibration (see [`DeviceSpec::calibration`]).
    fn calibrate(&mut self) -> Result<(), DeviceError>;
    /// A second way to this device's motors that another thread can use while the servo
    /// thread is stalled ([`MotorCutoff`](crate::cutoff::MotorCutoff)); `None` (the default)
    /// when the device can be reached only through the servo's own calls.
    fn cutoff(&self) -> Option<std::sync::Arc<dyn crate::cutoff::MotorCutoff>> {
        None
    }
    /// How often the device reset its reported position (e.g. the Falcon's homing resets an
    /// axis's encoder, so the position jumps). A host that differentiates positions restarts
    /// its velocity filter when this changes. 0 (the default) for devices that never do.
    fn position_resets(&self) -> u64 {
        0
    }
    /// Whether the device renders force now: `false` while it waits for its calibration (the
    /// Falcon before homing, an inkwell device before its calibration in the dock), when it
    /// gates every command to zero itself. A host pauses what it integrates over the rendered
    /// force (the passivity observer) until this turns `true`. `true` (the default) for
    /// devices that need nothing.
    fn force_ready(&self) -> bool {
        true
    }
    /// The tip force, N (device frame), that loads only arm joint `joint` (0-based) at the
    /// current pose with `newtons` at the tip, for the motor-sign self-test; `None` (the
    /// default) when the backend cannot say (no kinematics exposed, or no such joint).
    fn joint_force(&self, joint: usize, newtons: f64) -> Option<Vec3> {
        let _ = (joint, newtons);
        None
    }
    /// Warnings the device's vendor library reported that the run went on through (the
    /// Touch's force warnings, `HD_WARM_MOTORS` among them); none (the default) for devices
    /// without such a library.
    fn library_warnings(&self) -> LibraryWarnings {
        LibraryWarnings::default()
    }
}

/// Warnings a device's vendor library reported ([`HapticDevice::library_warnings`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LibraryWarnings {
    /// How many.
    pub count: u64,
    /// The last one's name.
    pub last: Option<&'static str>,
}

impl<D: HapticDevice + ?Sized> HapticDevice for Box<D> {
    fn spec(&self) -> DeviceSpec {
        (**self).spec()
    }
    fn read(&mut self) -> Result<DeviceState, DeviceError> {
        (**self).read()
    }
    fn write(&mut self, command: &ForceCommand) -> Result<(), DeviceError> {
        (**self).write(command)
    }
    fn calibrate(&mut self) -> Result<(), DeviceError> {
        (**self).calibrate()
    }
    fn cutoff(&self) -> Option<std::sync::Arc<dyn crate::cutoff::MotorCutoff>> {
        (**self).cutoff()
    }
    fn position_resets(&self) -> u64 {
        (**self).position_resets()
    }
    fn force_ready(&self) -> bool {
        (**self).force_ready()
    }
    fn joint_force(&self, joint: usize, newtons: f64) -> Option<Vec3> {
        (**self).joint_force(joint, newtons)
    }
    fn library_warnings(&self) -> LibraryWarnings {
        (**self).library_warnings()
    }
}

/// Small vector helpers shared by the backends.
pub(crate) mod v3 {
    use super::Vec3;
    pub fn add(a: Vec3, b: Vec3) -> Vec3 {
        [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
    }
    pub fn sub(a: Vec3, b: Vec3) -> Vec3 {
        [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
    }
    pub fn scale(a: Vec3, s: f64) -> Vec3 {
        [a[0] * s, a[1] * s, a[2] * s]
    }
    pub fn dot(a: Vec3, b: Vec3) -> f64 {
        a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
    }
    pub fn norm(a: Vec3) -> f64 {
        dot(a, a).sqrt()
    }
    pub fn finite(a: Vec3) -> bool {
        a.iter().all(|x| x.is_finite())
    }
}
