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
}

impl SimFault {
    /// Every fault's name, as `--sim-fault` takes it.
    pub const NAMES: [&'static str; 3] = ["none", "reversed-force", "mirrored-x"];

    /// The fault named `s` (`none`, `reversed-force`, `mirrored-x`).
    pub fn parse(s: &str) -> Option<SimFault> {
        match s {
            "none" => Some(SimFault::None),
            "reversed-force" => Some(SimFault::ReversedForce),
            "mirrored-x" => Some(SimFault::MirroredX),
            _ => None,
        }
    }

    /// Its name.
    pub fn name(self) -> &'static str {
        match self {
            SimFault::None => "none",
            SimFault::ReversedForce => "reversed-force",
            SimFault::MirroredX => "mirrored-x",
        }
    }
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
}

impl<P: Path> SimDevice<P> {
    /// A device whose stylus starts at rest at the hand's position at t = 0.
    pub fn new(mut path: P, config: SimConfig) -> SimDevice<P> {
        let hand = path.at(0.0);
        let mut config = config;
        if !(config.period_s.is_finite() && config.period_s > 0.0) {
            config.period_s = 1e-3;
        }
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
        }
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
        let hand = self.path.at(t);
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
    }

    /// The stylus position the device reports: the true one, x mirrored under
    /// [`SimFault::MirroredX`].
    fn reported(&self) -> Vec3 {
        let [x, y, z] = self.position;
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
        Ok(DeviceState {
            timestamp_s: self.time(),
            tick: self.tick,
            position: self.reported(),
            rotation: self.hand.rotation,
            joint_angles: [0.0; 6],
            buttons: self.hand.buttons,
            docked: false,
        })
    }

    fn write(&mut self, command: &ForceCommand) -> Result<(), DeviceError> {
        if self.disconnected() {
            self.safety.disable();
            self.publish();
            return Err(DeviceError::Disconnected);
        }
        let command = if self.motors.latch.is_set() {
            &ForceCommand::OFF
        } else {
            command
        };
        let r = self.safety.filter(command).map(|_| ());
        self.publish();
        r
    }

    fn calibrate(&mut self) -> Result<(), DeviceError> {
        debug_assert_eq!(self.config.spec.calibration, CalibrationStyle::None);
        Ok(())
    }

    fn cutoff(&self) -> Option<Arc<dyn MotorCutoff>> {
        Some(self.motors() as Arc<dyn MotorCutoff>)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn line(t: f64) -> PathPoint {
        PathPoint {
            position: [0.05 * t, 0.0, 0.0],
            rotation: QUAT_IDENTITY,
            buttons: 1,
        }
    }

    fn no_ramp() -> SimConfig {
        let mut c = SimConfig::default();
        c.safety.ramp_ticks = 1;
        c
    }

    /// A wall at x = 0.02 rendered by a penalty spring: the servo the sim exists to drive.
    fn run(ticks: usize, config: SimConfig) -> Vec<DeviceState> {
        let mut dev = SimDevice::new(Scripted(line), config);
        let mut out = Vec::new();
        for _ in 0..ticks {
            let s = dev.read().unwrap();
            let depth = s.position[0] - 0.02;
            let f = if depth > 0.0 {
                [-2000.0 * depth, 0.0, 0.0]
            } else {
                [0.0; 3]
            };
            dev.write(&ForceCommand::force(f)).unwrap();
            out.push(s);
        }
        out
    }

    #[test]
    fn deterministic_bit_for_bit() {
        let a = run(3000, no_ramp());
        let b = run(3000, no_ramp());
        assert_eq!(a.len(), b.len());
        for (x, y) in a.iter().zip(&b) {
            assert_eq!(x.timestamp_s.to_bits(), y.timestamp_s.to_bits());
            assert_eq!(x.position.map(f64::to_bits), y.position.map(f64::to_bits));
        }
        // The clock is the tick count times the period, never wall time.
        assert_eq!(a[1000].timestamp_s, 1000.0 * 1e-3);
        assert_eq!(a[1000].tick, 1000);
    }

    #[test]
    fn stylus_follows_hand_without_force() {
        let mut dev = SimDevice::new(Scripted(line), SimConfig::default());
        let mut last = DeviceState::ZERO;
        for _ in 0..2000 {
            last = dev.read().unwrap();
            dev.write(&ForceCommand::ZERO).unwrap();
        }
        // Hand at 0.1 m after 2 s; a steadily moving hand leads the stylus by about
        // c * v / k = 4 * 0.05 / 300 m.
        assert!(
            (last.position[0] - (0.1 - 4.0 * 0.05 / 300.0)).abs() < 1e-3,
            "{:?}",
            last.position
        );
        assert_eq!(last.buttons, 1);
    }

    #[test]
    fn force_pushes_back_the_stylus() {
        // The hand stops at x = 0.03 m, behind a wall at 0.02 m (2000 N/m). The stylus settles
        // where the hand spring (300 N/m) balances the wall: 300 (0.03 - x) = 2000 (x - 0.02).
        let stop = |t: f64| PathPoint {
            position: [(0.05 * t).min(0.03), 0.0, 0.0],
            rotation: QUAT_IDENTITY,
            buttons: 0,
        };
        let mut dev = SimDevice::new(Scripted(stop), no_ramp());
        let mut s = DeviceState::ZERO;
        for _ in 0..4000 {
            s = dev.read().unwrap();
            let depth = s.position[0] - 0.02;
            let f = if depth > 0.0 {
                [-2000.0 * depth, 0.0, 0.0]
            } else {
                [0.0; 3]
            };
            dev.write(&ForceCommand::force(f)).unwrap();
        }
        let want = (300.0 * 0.03 + 2000.0 * 0.02) / 2300.0;
        assert!(
            (s.position[0] - want).abs() < 1e-5,
            "stylus at {} want {want}",
            s.position[0]
        );
        // Without the wall it reaches the hand.
        let mut dev = SimDevice::new(Scripted(stop), no_ramp());
        for _ in 0..4000 {
            s = dev.read().unwrap();
            dev.write(&ForceCommand::ZERO).unwrap();
        }
        assert!((s.position[0] - 0.03).abs() < 1e-5);
    }

    #[test]
    fn a_reversed_force_pushes_the_stylus_the_other_way() {
        // A 2 N force along +x on a stylus held by the hand at the origin settles where the
        // hand spring (300 N/m) balances it: +2/300 m, and -2/300 m with the fault.
        for (fault, sign) in [(SimFault::None, 1.0), (SimFault::ReversedForce, -1.0)] {
            let c = SimConfig { fault, ..no_ramp() };
            let mut dev = SimDevice::new(Still([0.0; 3]), c);
            let mut s = DeviceState::ZERO;
            for _ in 0..3000 {
                s = dev.read().unwrap();
                dev.write(&ForceCommand::force([2.0, 0.0, 0.0])).unwrap();
            }
            let want = sign * 2.0 / 300.0;
            assert!(
                (s.position[0] - want).abs() < 1e-6,
                "{fault:?}: {:?}",
                s.position
            );
        }
    }

    #[test]
    fn a_mirrored_x_reports_minus_x_while_the_stylus_moves_normally() {
        let c = SimConfig {
            fault: SimFault::MirroredX,
            ..SimConfig::default()
        };
        let mut dev = SimDevice::new(Scripted(line), c);
        let mut plain = SimDevice::new(Scripted(line), SimConfig::default());
        for _ in 0..500 {
            let s = dev.read().unwrap();
            let p = plain.read().unwrap();
            assert_eq!(dev.true_position(), p.position);
            assert_eq!(s.position, [-p.position[0], p.position[1], p.position[2]]);
            dev.write(&ForceCommand::ZERO).unwrap();
            plain.write(&ForceCommand::ZERO).unwrap();
        }
        assert!(plain.true_position()[0] > 0.02);
    }

    #[test]
    fn one_substep_is_the_lockstep_integration_and_more_converge() {
        // The hand steps 1 cm away at t = 0: the undamped part of the stylus's response
        // against the exact solution of m x'' = k (1 cm - x) - c x' (underdamped, f64).
        let step = |_t: f64| PathPoint {
            position: [0.01, 0.0, 0.0],
            rotation: QUAT_IDENTITY,
            buttons: 0,
        };
        let run = |substeps: u32| {
            let c = SimConfig {
                substeps,
                hand_damping_n_s_per_m: 2.0,
                ..no_ramp()
            };
            let mut dev = SimDevice::new(Scripted(step), c);
            dev.position = [0.0; 3];
            dev.hand_prev = [0.01, 0.0, 0.0];
            let mut out = Vec::new();
            for _ in 0..200 {
                out.push(dev.read().unwrap().position[0]);
                dev.write(&ForceCommand::ZERO).unwrap();
            }
            out
        };
        let (m, k, c) = (0.1f64, 300.0f64, 2.0f64);
        let wd = (k / m - (c / (2.0 * m)).powi(2)).sqrt();
        let zeta_w = c / (2.0 * m);
        let exact = |t: f64| {
            0.01 * (1.0 - (-zeta_w * t).exp() * ((wd * t).cos() + zeta_w / wd * (wd * t).sin()))
        };
        let err = |xs: &[f64]| {
            xs.iter()
                .enumerate()
                .map(|(i, x)| (x - exact(i as f64 * 1e-3)).abs())
                .fold(0.0, f64::max)
        };
        let (one, many) = (run(1), run(20));
        assert!(
            err(&many) < 0.2 * err(&one),
            "{} vs {}",
            err(&many),
            err(&one)
        );
        assert!(err(&many) < 2e-4, "{}", err(&many));
    }

    #[test]
    fn a_cut_zeroes_the_motors_at_once_and_holds_them_until_rearmed() {
        let mut c = SimConfig::default();
        c.safety.ramp_ticks = 10;
        let mut dev = SimDevice::new(Still([0.0; 3]), c);
        for _ in 0..20 {
            dev.read().unwrap();
            dev.write(&ForceCommand::force([2.0, 0.0, 0.0])).unwrap();
        }
        assert_eq!(dev.applied_force(), [2.0, 0.0, 0.0]);
        // Another thread cuts through the shared motors: zero at once, without the device.
        let cut = dev.cutoff().expect("the simulated device has a cutoff");
        let seen = std::thread::scope(|s| {
            s.spawn(|| {
                cut.cut().unwrap();
                dev.motors().output()
            })
            .join()
            .unwrap()
        });
        assert_eq!(seen, ForceCommand::OFF);
        assert_eq!(dev.applied_force(), [0.0; 3]);
        // While the latch is set, the servo's writes render zero with the motors off.
        for _ in 0..5 {
            dev.read().unwrap();
            dev.write(&ForceCommand::force([2.0, 0.0, 0.0])).unwrap();
            assert_eq!(dev.motors().output(), ForceCommand::OFF);
        }
        // Rearmed: the next enabled write ramps from zero (1/10 of the force), not a jump.
        cut.rearm();
        dev.read().unwrap();
        dev.write(&ForceCommand::force([2.0, 0.0, 0.0])).unwrap();
        assert!(
            (dev.applied_force()[0] - 0.2).abs() < 1e-12,
            "{:?}",
            dev.applied_force()
        );
    }

    #[test]
    fn disconnect_is_an_error_and_zeroes_force() {
        let mut c = no_ramp();
        c.disconnect_at_tick = Some(10);
        let mut dev = SimDevice::new(Still([0.0; 3]), c);
        for _ in 0..10 {
            dev.read().unwrap();
            dev.write(&ForceCommand::force([1.0, 0.0, 0.0])).unwrap();
        }
        assert_eq!(dev.read(), Err(DeviceError::Disconnected));
        assert_eq!(
            dev.write(&ForceCommand::force([1.0, 0.0, 0.0])),
            Err(DeviceError::Disconnected)
        );
        assert_eq!(dev.applied_force(), [0.0; 3]);
    }

    #[test]
    fn plays_back_a_trace() {
        let text = "t,x,y,z,qw,qx,qy,qz,buttons\n0,0,0,0,1,0,0,0,0\n1,0,0.01,0,1,0,0,0,1\n";
        let trace = Trace::parse(text, "p").unwrap();
        let mut dev = SimDevice::new(trace, SimConfig::default());
        let mut s = DeviceState::ZERO;
        for _ in 0..=1500 {
            s = dev.read().unwrap();
            dev.write(&ForceCommand::ZERO).unwrap();
        }
        assert!((s.position[1] - 0.01).abs() < 1e-4);
        assert_eq!(s.buttons, 1);
    }
}
