//! tetradrill-device: the haptic device layer (see `docs/DEVICES.md`).
//!
//! Layer map:
//! - [`device`]: the [`HapticDevice`] trait, [`DeviceSpec`], [`DeviceState`], [`ForceCommand`],
//!   [`DeviceError`];
//! - [`safety`]: [`ForceSafety`], the clamp / ramp / watchdog / NaN filter every backend uses;
//! - [`cutoff`]: [`MotorCutoff`], the second way to the motors a supervisor thread uses to
//!   zero the force while the servo thread is stalled;
//! - [`sim`]: the simulated device (the default), a stylus on a spring-damper hand;
//! - [`trace`]: trace CSV parsing, recording and interpolation;
//! - [`falcon`]: Novint Falcon over USB (`rusb`) behind a [`falcon::Transport`];
//! - [`omni`]: SensAble PHANTOM Omni (IEEE-1394) protocol behind an [`omni::FirewireTransport`];
//! - [`touch`]: Geomagic / 3D Systems Touch through a run-time loaded [`touch::HdLibrary`];
//! - [`discovery`]: what is attached, for `tetradrill devices`;
//! - `os` (feature `os`, on by default): the operating system transports, the FireWire
//!   character device under the Omni ([`omni::FirewireTransport`]) and the run-time loader of
//!   the Touch's vendor HD library ([`touch::HdLibrary`]). They are the only modules with
//!   `unsafe` (each allows it for itself; every block is one system or library call with its
//!   `// SAFETY:` reason); without `os` the crate has none.
#![deny(unsafe_code)]
#![deny(missing_docs)]

pub mod cutoff;
pub mod device;
pub mod safety;
pub mod sim;
pub mod trace;

pub use cutoff::{Cut, MotorCutoff};
pub use device::{
    CalibrationStyle, DeviceError, DeviceKind, DeviceSpec, DeviceState, ForceCommand, HapticDevice,
    LibraryWarnings, Quat, Vec3, QUAT_IDENTITY,
};
pub use safety::{ForceSafety, SafetyConfig};
pub use sim::{Path, PathPoint, Scripted, SimConfig, SimDevice, SimFault, SimModel, Still};
pub use trace::{Trace, TraceError, TraceErrorKind, TraceSample, TRACE_HEADER};
pub mod discovery;
pub mod falcon;
pub mod omni;
#[cfg(feature = "os")]
pub mod os;
pub mod touch;

pub use discovery::{discover, open, open_sim, FoundDevice, OpenOptions};
