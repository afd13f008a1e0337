//! The motor-sign self-test (`devices --check --motors`, and once at the start of `run` on a
//! simulated device model): a small force that loads one arm joint at a time, with the stylus
//! free, and the joint's motion read back. A motor that turns its joint against the command
//! is reversed; a run with a reversed joint renders no force ([`Blocked`]).

use tetradrill_device::{
    DeviceError, DeviceKind, DeviceSpec, DeviceState, ForceCommand, HapticDevice,
};

/// The largest force at the tip while testing a joint, newtons.
pub const TEST_FORCE_N: f64 = 0.3;
/// Ticks (1 ms) the force is held on each joint.
pub const TEST_TICKS: u32 = 100;
/// Ticks with the motors off before and after each joint's test (the stylus settles).
pub const SETTLE_TICKS: u32 = 50;
/// The least joint motion that counts, rad (or m for a Cartesian joint): below it the joint
/// did not move.
pub const MIN_MOTION: f64 = 1e-6;

/// What the test found on one joint.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Verdict {
    /// The joint moved the way its motor was driven.
    SignOk,
    /// The joint moved against its motor: the motor's sign is wrong.
    Reversed,
    /// The joint did not move measurably (held too firmly, or in a stop).
    NoMotion,
}

/// One joint's result.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointCheck {
    /// The joint, 1-based.
    pub joint: u8,
    /// How far it moved along its motor's drive, rad (m for a Cartesian joint).
    pub moved: f64,
    /// The verdict.
    pub verdict: Verdict,
}

/// Runs the self-test on `device` (calibrated, its force ready): for each of its three arm
/// joints, [`SETTLE_TICKS`] with the motors off, then [`TEST_TICKS`] with the tip force that
/// loads only that joint ([`HapticDevice::joint_force`], [`TEST_FORCE_N`], which the device's
/// filter ramps), then [`SETTLE_TICKS`] off again; the joint's angle before and at the end of
/// the force gives its motion. `pace` sleeps 1 ms a tick (a real device; the simulated one
/// keeps its own clock). `None` when the device cannot say which force loads one joint or does
/// not render force yet.
///
/// # Errors
/// A device error; the motors are written off first.
pub fn self_test(
    device: &mut dyn HapticDevice,
    pace: bool,
) -> Result<Option<Vec<JointCheck>>, DeviceError> {
    if !device.force_ready() {
        return Ok(None);
    }
    let mut out = Vec::new();
    for j in 0..3u8 {
        let Some(f) = device.joint_force(usize::from(j), TEST_FORCE_N) else {
            return Ok(None);
        };
        let before = hold(device, &ForceCommand::OFF, SETTLE_TICKS, pace)?;
        let during = hold(device, &ForceCommand::force(f), TEST_TICKS, pace);
        let after = hold(device, &ForceCommand::OFF, SETTLE_TICKS, pace);
        let during = during?;
        after?;
        let moved = during.joint_angles[usize::from(j)] - before.joint_angles[usize::from(j)];
        let verdict = if moved > MIN_MOTION {
            Verdict::SignOk
        } else if moved < -MIN_MOTION {
            Verdict::Reversed
        } else {
            Verdict::NoMotion
        };
        out.push(JointCheck {
            joint: j + 1,
            moved,
            verdict,
        });
    }
    Ok(Some(out))
}

/// Writes `command` for `ticks` ticks (each a read then a write); the last reading.
fn hold(
    device: &mut dyn HapticDevice,
    command: &ForceCommand,
    ticks: u32,
    pace: bool,
) -> Result<DeviceState, DeviceError> {
    let mut last = DeviceState::ZERO;
    for _ in 0..ticks.max(1) {
        last = match device.read() {
            Ok(s) => s,
            Err(e) => {
                let _ = device.write(&ForceCommand::OFF);
                return Err(e);
            }
        };
        device.write(command)?;
        if pace {
            std::thread::sleep(std::time::Duration::from_millis(1));
        }
    }
    Ok(last)
}

/// The line for one joint: `joint 2: sign ok (moved 0.000213)`, or what to set in the device
/// file when it is reversed. `kind` is the device the test stands for (`omni_dac`: the Omni's
/// `dac_per_newton_metre` in use).
pub fn describe(check: &JointCheck, kind: DeviceKind, omni_dac: [f64; 3]) -> String {
    let j = check.joint;
    match check.verdict {
        Verdict::SignOk => format!("joint {j}: sign ok (moved {:+.6})", check.moved),
        Verdict::NoMotion => format!(
            "joint {j}: no motion measured ({:+.1e}): hold the stylus loosely and run the check again",
            check.moved
        ),
        Verdict::Reversed => {
            let fix = match kind {
                DeviceKind::Omni => {
                    let v = omni_dac[usize::from(j - 1)];
                    format!(
                        "set `dac_per_newton_metre[{j}] = {:.1}` in the device file's [omni] \
                         table (joint {j}'s motor sign; it is {v:.1})",
                        -v
                    )
                }
                _ => format!(
                    "no device-file key sets this motor's sign on the {kind}: check its wiring \
                     and driver"
                ),
            };
            format!("joint {j}: reversed ({:+.6}): {fix}", check.moved)
        }
    }
}

/// The joints found reversed, 1-based.
pub fn reversed(checks: &[JointCheck]) -> Vec<u8> {
    checks
        .iter()
        .filter(|c| c.verdict == Verdict::Reversed)
        .map(|c| c.joint)
        .collect()
}

/// A device with a reversed joint: read as usual, but every command goes out as
/// [`ForceCommand::OFF`] and [`HapticDevice::force_ready`] is `false`, so the servo renders
/// nothing.
pub struct Blocked(pub Box<dyn HapticDevice>);

impl std::fmt::Debug for Blocked {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_tuple("Blocked").field(&self.0.spec().name).finish()
    }
}

impl HapticDevice for Blocked {
    fn spec(&self) -> DeviceSpec {
        self.0.spec()
    }
    fn read(&mut self) -> Result<DeviceState, DeviceError> {
        self.0.read()
    }
    fn write(&mut self, _command: &ForceCommand) -> Result<(), DeviceError> {
        self.0.write(&ForceCommand::OFF)
    }
    fn calibrate(&mut self) -> Result<(), DeviceError> {
        self.0.calibrate()
    }
    fn cutoff(&self) -> Option<std::sync::Arc<dyn tetradrill_device::MotorCutoff>> {
        self.0.cutoff()
    }
    fn position_resets(&self) -> u64 {
        self.0.position_resets()
    }
    fn force_ready(&self) -> bool {
        false
    }
    fn library_warnings(&self) -> tetradrill_device::LibraryWarnings {
        self.0.library_warnings()
    }
}
