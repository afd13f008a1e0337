//! The simulated device (the default): a stylus on a spring-damper "hand".
//!
//! The hand follows a [`Path`] (a [`Trace`] or a scripted closure). The stylus is a point mass
//! tied to the hand by a spring and a damper; the force written back by the servo pushes the
//! stylus, so the loop reacts (a wall stops the stylus while the hand goes on).
//!
//! The clock is deterministic: each `read()` advances it by one servo period, fixed at
//! construction. Integration is semi-implicit Euler in plain `f64` arithmetic, so identical
//! inputs give bit-identical outputs on every run.
//!
//! Its "motors" are [`SimMotors`], shared atomics: what the stylus receives. They are also its
//! [`MotorCutoff`]: another thread zeroes them directly, and the write path honours the latch.

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Arc;

use crate::cutoff::{Cut, Latch, MotorCutoff};
use crate::device::{
    v3, CalibrationStyle, DeviceError, DeviceSpec, DeviceState, ForceCommand, HapticDevice, Quat,
    Vec3, QUAT_IDENTITY,
};
use crate::safety::{ForceSafety, SafetyConfig};
use crate::trace::Trace;

/// Where the hand is at a time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PathPoint {
    /// Hand position, m.
    pub position: Vec3,
    /// Hand (and stylus) rotation.
    pub rotation: Quat,
    /// Buttons pressed.
    pub buttons: u32,
}

/// A trajectory for the hand.
pub trait Path {
    /// The hand at time `t` (seconds on the device clock).
    fn at(&mut self, t: f64) -> PathPoint;
}

impl Path for Trace {
    fn at(&mut self, t: f64) -> PathPoint {
        match self.sample_at(t) {
            Some(s) => PathPoint {
                position: s.position,
                rotation: s.rotation,
                buttons: s.buttons,
            },
            None => PathPoint {
                position: [0.0; 3],
                rotation: QUAT_IDENTITY,
                buttons: 0,
            },
        }
    }
}

/// A scripted path: wraps a closure `t -> PathPoint`.
#[derive(Clone, Copy, Debug)]
pub struct Scripted<F>(pub F);

impl<F: FnMut(f64) -> PathPoint> Path for Scripted<F> {
    fn at(&mut self, t: f64) -> PathPoint {
        (self.0)(t)
    }
}

/// A hand that stays still at one point.
#[derive(Clone, Copy, Debug)]
pub struct Still(pub Vec3);

impl Path for Still {
    fn at(&mut self, _t: f64) -> PathPoint {
        PathPoint {
            position: self.0,
            rotation: QUAT_IDENTITY,
            buttons: 0,
        }
    }
}

/// A fault the simulated device can be built with (`run --sim-fault KIND`), to prove the
/// safety layers above the driver catch what a miswired or misconfigured device does.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum SimFault {
    /// None: the device as it should be.
    #[default]
    None,
    /// The stylus receives the opposite of the force the device renders (a reversed motor
    /// sign).
    ReversedForce,
    /// The reported x position is mirrored about the device's origin (a mirrored encoder);
    /// the stylus itself moves normally.
    MirroredX,
    /// Arm joint `N` (1-based, 1 to 3) has its motor wired the other way: the stylus receives
    /// that joint's share of the rendered force reversed. The simulated arm's joints are its
    /// three axes (x, y, z), so joint `N` is the force's component along axis `N`.
    MotorSign(u8),
}

impl SimFault {
    /// Every fault's name, as `--sim-fault` takes it (`motor-sign:N` with `N` from 1 to 3).
    pub const NAMES: [&'static str; 4] = ["none", "reversed-force", "mirrored-x", "motor-sign:N"];

    /// The fault named `s` (`none`, `reversed-force`, `mirrored-x`, `motor-sign:1` to
    /// `motor-sign:3`).
    pub fn parse(s: &str) -> Option<SimFault> {
        match s {
            "none" => Some(SimFault::None),
            "reversed-force" => Some(SimFault::ReversedForce),
            "mirrored-x" => Some(SimFault::MirroredX),
            "motor-sign:1" => Some(SimFault::MotorSign(1)),
            "motor-sign:2" => Some(SimFault::MotorSign(2)),
            "motor-sign:3" => Some(SimFault::MotorSign(3)),
            _ => None,
        }
    }

    /// Its name.
    pub fn name(self) -> &'static str {
        match self {
            SimFault::None => "none",
            SimFault::ReversedForce => "reversed-force",
            SimFault::MirroredX => "mirrored-x",
            SimFault::MotorSign(1) => "motor-sign:1",
            SimFault::MotorSign(2) => "motor-sign:2",
            SimFault::MotorSign(3) => "motor-sign:3",
            SimFault::MotorSign(_) => "motor-sign:?",
        }
    }
}

/// A real device the simulated one stands for (`run --sim-model omni|falcon|touch`): its
/// limits (the device's [`DeviceSpec`]: peak, continuous force, stiffness, damping,
/// workspace), its calibration and how it starts, so the host meets what it meets with the
/// device itself.
///
/// The hand starts at the device origin (the dock or the homed pose) and the path given to the
/// device begins [`SimModel::lead_in_s`] later:
/// - the Omni and the Touch start **docked in their inkwell** (`DeviceState::docked` while the
///   stylus is within [`DOCK_RADIUS_M`] of the origin) and render no force until calibrated
///   there ([`HapticDevice::calibrate`], [`DeviceError::NotDocked`] out of the dock); the hand
///   rests in the dock for [`DOCK_REST_S`], then moves to the path's start over
///   [`LEAD_IN_MOVE_S`];
/// - the Falcon starts **unhomed**: its reported position is off by [`UNHOMED_OFFSET_M`]
///   and it renders no force until homed; the hand rests for [`DOCK_REST_S`], makes the homing
///   stroke (down [`HOMING_STROKE_M`] along -z and back, over [`HOMING_STROKE_S`]; the axes
///   count as homed once the stylus is [`HOMING_INDEX_M`] down, when the reported position
///   jumps to the true one and [`HapticDevice::position_resets`] counts it), then moves to the
///   path's start over [`LEAD_IN_MOVE_S`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SimModel {
    /// The SensAble PHANTOM Omni ([`DeviceSpec::OMNI`]).
    Omni,
    /// The Novint Falcon ([`DeviceSpec::FALCON`]).
    Falcon,
    /// The Geomagic / 3D Systems Touch ([`DeviceSpec::TOUCH`]).
    Touch,
}

/// Seconds the hand rests at the device origin before it moves (the dock, the pose before the
/// homing stroke): long enough for the motor-sign self-test (three joints of 200 ms) on a still
/// hand.
pub const DOCK_REST_S: f64 = 1.0;
/// Seconds the hand takes from the device origin to the path's start (smoothstep).
pub const LEAD_IN_MOVE_S: f64 = 1.0;
/// The simulated inkwell: the stylus counts as docked within this distance of the origin, m.
pub const DOCK_RADIUS_M: f64 = 0.005;
/// The simulated Falcon's homing stroke: how far down (-z) the hand goes, m.
pub const HOMING_STROKE_M: f64 = 0.035;
/// The homing stroke's length, s (down and back, smoothstep each way).
pub const HOMING_STROKE_S: f64 = 1.0;
/// The stylus this far down (-z) passes the axes' index: homed, m.
pub const HOMING_INDEX_M: f64 = 0.03;
/// The simulated Falcon's reported position before homing, less the true one, m.
pub const UNHOMED_OFFSET_M: Vec3 = [0.003, -0.002, 0.005];

impl SimModel {
    /// Every model's name, as `--sim-model` takes it.
    pub const NAMES: [&'static str; 3] = ["omni", "falcon", "touch"];

    /// The model named `s` (`omni`, `falcon`, `touch`).
    pub fn parse(s: &str) -> Option<SimModel> {
        match s {
            "omni" => Some(SimModel::Omni),
            "falcon" => Some(SimModel::Falcon),
            "touch" => Some(SimModel::Touch),
            _ => None,
        }
    }

    /// Its name.
    pub fn name(self) -> &'static str {
        match self {
            SimModel::Omni => "omni",
            SimModel::Falcon => "falcon",
            SimModel::Touch => "touch",
        }
    }

    /// The device's specification (its limits and calibration style).
    pub fn spec(self) -> DeviceSpec {
        match self {
            SimModel::Omni => DeviceSpec::OMNI,
            SimModel::Falcon => DeviceSpec::FALCON,
            SimModel::Touch => DeviceSpec::TOUCH,
        }
    }

    /// Seconds from the start to where the device's path begins: the rest at the origin, the
    /// Falcon's homing stroke, the move to the path's start.
    pub fn lead_in_s(self) -> f64 {
        match self {
            SimModel::Falcon => DOCK_REST_S + HOMING_STROKE_S + LEAD_IN_MOVE_S,
            _ => DOCK_REST_S + LEAD_IN_MOVE_S,
        }
    }
}

/// `3 u^2 - 2 u^3` on `u` clamped to `[0, 1]`.
fn smoothstep(u: f64) -> f64 {
    let u = u.clamp(0.0, 1.0);
    u * u * (3.0 - 2.0 * u)
}

/// Parameters of the simulated device.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SimConfig {
    /// Servo period, s (1 ms for 1 kHz).
    pub period_s: f64,
    /// Stylus mass, kg.
    pub mass_kg: f64,
    /// Hand-to-stylus spring, N/m.
    pub hand_stiffness_n_per_m: f64,
    /// Hand-to-stylus damper, N s/m.
    pub hand_damping_n_s_per_m: f64,
    /// Device limits (clamp, reported by `spec()`).
    pub spec: DeviceSpec,
    /// Safety settings.
    pub safety: SafetyConfig,
    /// Fault injection: report a disconnect from this tick on (`None` = never).
    pub disconnect_at_tick: Option<u64>,
    /// Fault injection: a reversed force or a mirrored axis ([`SimFault`]).
    pub fault: SimFault,
    /// Integration steps per servo period (at least 1). With one, the stylus moves in
    /// lockstep with the servo (semi-implicit Euler at the servo period), which happens to
    /// cancel the energy a zero-order hold gives a stiff wall; with several, the stylus is
    /// a continuous-time mass under a force held over the period, as a real one is, and a
    /// stiff wall can oscillate.
    pub substeps: u32,
    /// The real device this one stands for ([`SimModel`]), if any: set with
    /// [`SimConfig::model`], which also takes the model's limits.
    pub model: Option<SimModel>,
}

impl SimConfig {
    /// This configuration standing for `model`: its [`DeviceSpec`] and a safety filter at its
    /// peak force (the other settings kept).
    pub fn model(self, model: SimModel) -> SimConfig {
        SimConfig {
            spec: model.spec(),
            safety: SafetyConfig {
                max_force_n: model.spec().max_force_n,
                ..self.safety
            },
            model: Some(model),
            ..self
        }
    }
}

impl Default for SimConfig {
    fn default() -> SimConfig {
        SimConfig {
            period_s: 1e-3,
            mass_kg: 0.1,
            hand_stiffness_n_per_m: 300.0,
            // Critical damping, 2 sqrt(k m) ~ 10.95: a hand holds a stylus without ringing.
            hand_damping_n_s_per_m: 11.0,
            spec: DeviceSpec::SIM,
            safety: SafetyConfig::for_max_force(DeviceSpec::SIM.max_force_n),
            disconnect_at_tick: None,
            fault: SimFault::None,
            substeps: 1,
            model: None,
        }
    }
}

/// The simulated device's motors: the force the stylus receives, in atomics shared with any
/// thread. Also the device's [`MotorCutoff`]: [`cut`](MotorCutoff::cut) zeroes them at once
/// (the direct zero) and sets the latch that the device's write path honours.
#[derive(Debug, Default)]
pub struct SimMotors {
    latch: Latch,
    enabled: AtomicBool,
    force: [AtomicU64; 3],
}

impl SimMotors {
    fn store(&self, out: &ForceCommand) {
        for (slot, v) in self.force.iter().zip(out.force) {
            slot.store(v.to_bits(), Ordering::Relaxed);
        }
        self.enabled.store(out.enable, Ordering::SeqCst);
    }

    /// What the motors render now: the force with the motors on, or [`ForceCommand::OFF`].
    pub fn output(&self) -> ForceCommand {
        if !self.enabled.load(Ordering::SeqCst) {
            return ForceCommand::OFF;
        }
        ForceCommand::force(
            self.force
                .each_ref()
                .map(|f| f64::from_bits(f.load(Ordering::Relaxed))),
        )
    }
}

impl MotorCutoff for SimMotors {
    fn cut(&self) -> Result<Cut, DeviceError> {
        self.latch.set();
        self.enabled.store(false, Ordering::SeqCst);
        Ok(Cut::Done)
    }

    fn is_cut(&self) -> bool {
        self.latch.is_set()
    }

    fn rearm(&self) {
        self.latch.clear();
    }
}

/// The simulated device. See the module docs.
#[derive(Debug)]
pub struct SimDevice<P> {
    path: P,
    config: SimConfig,
    safety: ForceSafety,
    motors: Arc<SimMotors>,
    tick: u64,
    started: bool,
    position: Vec3,
    velocity: Vec3,
    hand: PathPoint,
    hand_prev: Vec3,
    /// An inkwell model calibrated in its dock.
    calibrated: bool,
    /// The Falcon model homed.
    homed: bool,
    position_resets: u64,
}

impl<P: Path> SimDevice<P> {
    /// A device whose stylus starts at rest at the hand's position at t = 0.
    /// With a [`SimConfig::model`], the stylus starts at the device origin and the path
    /// begins [`SimModel::lead_in_s`] later ([`SimModel`]).
    pub fn new(mut path: P, config: SimConfig) -> SimDevice<P> {
        let mut config = config;
        if !(config.period_s.is_finite() && config.period_s > 0.0) {
            config.period_s = 1e-3;
        }
        let hand = match config.model {
            Some(_) => PathPoint {
                position: [0.0; 3],
                ..path.at(0.0)
            },
            None => path.at(0.0),
        };
        SimDevice {
            path,
            safety: ForceSafety::new(config.safety),
            motors: Arc::default(),
            config,
            tick: 0,
            started: false,
            position: hand.position,
            velocity: [0.0; 3],
            hand,
            hand_prev: hand.position,
            calibrated: false,
            homed: false,
            position_resets: 0,
        }
    }

    /// The hand at device time `t`: the path's, or with a model the rest at the origin, the
    /// Falcon's homing stroke and the move to the path's start first ([`SimModel`]).
    fn hand_at(&mut self, t: f64) -> PathPoint {
        let Some(model) = self.config.model else {
            return self.path.at(t);
        };
        let lead = model.lead_in_s();
        if t >= lead {
            return self.path.at(t - lead);
        }
        let start = self.path.at(0.0);
        let origin = PathPoint {
            position: [0.0; 3],
            ..start
        };
        let mut u = t - DOCK_REST_S;
        if u < 0.0 {
            return origin;
        }
        if model == SimModel::Falcon {
            if u < HOMING_STROKE_S {
                // Down and back, each half a smoothstep.
                let half = 0.5 * HOMING_STROKE_S;
                let down = if u < half {
                    smoothstep(u / half)
                } else {
                    1.0 - smoothstep((u - half) / half)
                };
                return PathPoint {
                    position: [0.0, 0.0, -HOMING_STROKE_M * down],
                    ..origin
                };
            }
            u -= HOMING_STROKE_S;
        }
        PathPoint {
            position: v3::scale(start.position, smoothstep(u / LEAD_IN_MOVE_S)),
            ..origin
        }
    }

    /// Whether the stylus is in its simulated inkwell (an inkwell model within
    /// [`DOCK_RADIUS_M`] of the origin).
    fn docked(&self) -> bool {
        self.config.spec.calibration == CalibrationStyle::Inkwell
            && self.config.model.is_some()
            && v3::norm(self.position) <= DOCK_RADIUS_M
    }

    /// Device time, s.
    pub fn time(&self) -> f64 {
        self.tick as f64 * self.config.period_s
    }

    /// The hand's current position (where the user "wants" to be).
    pub fn hand_position(&self) -> Vec3 {
        self.hand.position
    }

    /// The force the stylus currently receives from the device, N.
    pub fn applied_force(&self) -> Vec3 {
        self.motors.output().force
    }

    /// The motors, shared: what the stylus receives, readable from any thread.
    pub fn motors(&self) -> Arc<SimMotors> {
        Arc::clone(&self.motors)
    }

    /// Puts the filter's output on the motors; while the latch is set, zero with the motors
    /// off (and the filter disabled, so the next enabled write ramps). The latch is looked at
    /// again after the store: a cut that came in between is not overwritten.
    fn publish(&mut self) {
        if self.motors.latch.is_set() {
            self.safety.disable();
        }
        self.motors.store(&self.safety.output());
        if self.motors.latch.is_set() {
            self.safety.disable();
            self.motors.store(&ForceCommand::OFF);
        }
    }

    /// The safety filter (counters).
    pub fn safety(&self) -> &ForceSafety {
        &self.safety
    }

    fn step(&mut self) {
        let dt = self.config.period_s;
        self.tick += 1;
        let t = self.time();
        let hand = self.hand_at(t);
        let hand_pos = if v3::finite(hand.position) {
            hand.position
        } else {
            self.hand.position
        };
        let hand_vel = v3::scale(v3::sub(hand_pos, self.hand_prev), 1.0 / dt);
        self.hand_prev = hand_pos;
        self.hand = PathPoint {
            position: hand_pos,
            ..hand
        };
        let device = self.motors.output().force;
        let device = match self.config.fault {
            SimFault::ReversedForce => v3::scale(device, -1.0),
            SimFault::MotorSign(j @ 1..=3) => {
                let mut d = device;
                d[usize::from(j) - 1] = -d[usize::from(j) - 1];
                d
            }
            _ => device,
        };
        let n = self.config.substeps.max(1);
        let h = dt / f64::from(n);
        for _ in 0..n {
            let spring = v3::scale(
                v3::sub(hand_pos, self.position),
                self.config.hand_stiffness_n_per_m,
            );
            let damper = v3::scale(
                v3::sub(hand_vel, self.velocity),
                self.config.hand_damping_n_s_per_m,
            );
            let total = v3::add(v3::add(spring, damper), device);
            let accel = v3::scale(total, 1.0 / self.config.mass_kg);
            self.velocity = v3::add(self.velocity, v3::scale(accel, h));
            self.position = v3::add(self.position, v3::scale(self.velocity, h));
        }
        if self.config.model == Some(SimModel::Falcon)
            && !self.homed
            && self.position[2] <= -HOMING_INDEX_M
        {
            self.homed = true;
            self.position_resets += 1;
        }
    }

    /// The stylus position the device reports: the true one, x mirrored under
    /// [`SimFault::MirroredX`].
    fn reported(&self) -> Vec3 {
        let [x, y, z] = if self.config.model == Some(SimModel::Falcon) && !self.homed {
            v3::add(self.position, UNHOMED_OFFSET_M)
        } else {
            self.position
        };
        match self.config.fault {
            SimFault::MirroredX => [-x, y, z],
            _ => [x, y, z],
        }
    }

    /// Where the stylus really is (unlike [`HapticDevice::read`] under
    /// [`SimFault::MirroredX`]).
    pub fn true_position(&self) -> Vec3 {
        self.position
    }

    fn disconnected(&self) -> bool {
        matches!(self.config.disconnect_at_tick, Some(k) if self.tick >= k)
    }
}

impl<P: Path> HapticDevice for SimDevice<P> {
    fn spec(&self) -> DeviceSpec {
        self.config.spec
    }

    fn read(&mut self) -> Result<DeviceState, DeviceError> {
        if self.started {
            self.step();
        }
        self.started = true;
        if self.disconnected() {
            self.safety.disable();
            self.publish();
            return Err(DeviceError::Disconnected);
        }
        self.safety.tick();
        self.publish();
        let position = self.reported();
        let mut joint_angles = [0.0; 6];
        if self.config.model.is_some() {
            // The simulated arm's joints are its axes.
            joint_angles[..3].copy_from_slice(&position);
        }
        Ok(DeviceState {
            timestamp_s: self.time(),
            tick: self.tick,
            position,
            rotation: self.hand.rotation,
            joint_angles,
            buttons: self.hand.buttons,
            docked: self.docked(),
        })
    }

    fn write(&mut self, command: &ForceCommand) -> Result<(), DeviceError> {
        if self.disconnected() {
            self.safety.disable();
            self.publish();
            return Err(DeviceError::Disconnected);
        }
        // A cut, or a model that is not homed or calibrated yet: nothing is rendered.
        let command = if self.motors.latch.is_set() || !self.force_ready() {
            &ForceCommand::OFF
        } else {
            command
        };
        let r = self.safety.filter(command).map(|_| ());
        self.publish();
        r
    }

    /// Nothing to do, but an inkwell model calibrates only in its dock
    /// ([`DeviceError::NotDocked`] elsewhere); the Falcon model homes by moving.
    fn calibrate(&mut self) -> Result<(), DeviceError> {
        if self.config.model.is_some() && self.config.spec.calibration == CalibrationStyle::Inkwell
        {
            if !self.docked() {
                return Err(DeviceError::NotDocked);
            }
            self.calibrated = true;
        }
        Ok(())
    }

    fn cutoff(&self) -> Option<Arc<dyn MotorCutoff>> {
        Some(self.motors() as Arc<dyn MotorCutoff>)
    }

    fn position_resets(&self) -> u64 {
        self.position_resets
    }

    /// Always, but for a model: an inkwell one once calibrated, the Falcon once homed.
    fn force_ready(&self) -> bool {
        match self.config.model {
            None => true,
            Some(SimModel::Falcon) => self.homed,
            Some(_) => self.calibrated,
        }
    }

    /// The simulated arm's joints are its axes: `newtons` along axis `joint`.
    fn joint_force(&self, joint: usize, newtons: f64) -> Option<Vec3> {
        let mut f = [0.0; 3];
        *f.get_mut(joint)? = newtons;
        Some(f)
    }
}

#[cfg(test)]
mod tests;
