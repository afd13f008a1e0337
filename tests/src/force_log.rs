//! A device that logs the magnitude of every force it is given, for tests that check what a
//! run actually sent.

use std::sync::{Arc, Mutex};

use tetradrill_device::{
    DeviceError, DeviceSpec, DeviceState, ForceCommand, HapticDevice, MotorCutoff, Vec3,
};

/// `inner`, with each write's force magnitude (0 with the motors off) pushed onto `writes`,
/// one a servo tick; everything else passed through.
pub struct ForceLog {
    /// The device written to.
    pub inner: Box<dyn HapticDevice>,
    /// The magnitudes written, newtons.
    pub writes: Arc<Mutex<Vec<f64>>>,
}

impl std::fmt::Debug for ForceLog {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ForceLog")
            .field("device", &self.inner.spec().name)
            .finish_non_exhaustive()
    }
}

impl HapticDevice for ForceLog {
    fn spec(&self) -> DeviceSpec {
        self.inner.spec()
    }
    fn read(&mut self) -> Result<DeviceState, DeviceError> {
        self.inner.read()
    }
    fn write(&mut self, command: &ForceCommand) -> Result<(), DeviceError> {
        let f = command.force;
        let n = if command.enable {
            (f[0] * f[0] + f[1] * f[1] + f[2] * f[2]).sqrt()
        } else {
            0.0
        };
        self.writes.lock().expect("log").push(n);
        self.inner.write(command)
    }
    fn calibrate(&mut self) -> Result<(), DeviceError> {
        self.inner.calibrate()
    }
    fn cutoff(&self) -> Option<Arc<dyn MotorCutoff>> {
        self.inner.cutoff()
    }
    fn position_resets(&self) -> u64 {
        self.inner.position_resets()
    }
    fn force_ready(&self) -> bool {
        self.inner.force_ready()
    }
    fn joint_force(&self, joint: usize, newtons: f64) -> Option<Vec3> {
        self.inner.joint_force(joint, newtons)
    }
}
