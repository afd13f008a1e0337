//! What the application needs of a board: the [`Board`] trait (motor outputs, encoders, the
//! watchdog's feed, a log sink), and the mapping from the servo's force to the three motor
//! commands the outputs take.
//!
//! Two boards implement it: QEMU's MPS2 machines ([`crate::mps2::Mps2`]: the motor outputs a
//! static "DAC" the fault path reads back, the CMSDK APB watchdog, UART0) and the STM32H743
//! board crate (`ports/stm32h743`: PWM and an enable pin, three quadrature encoder timers,
//! the independent watchdog, a USART).
//!
//! The methods on `&mut self` are the servo's, called from its task only. The associated
//! functions without `self` ([`Board::motors_off`], [`Board::outputs_live`],
//! [`Board::fault_watchdog`], [`Board::log`], [`Board::reset`]) are the fault path's: they
//! must work from any handler, in any state the program can be in (before `init`, with the
//! servo interrupted half-way through a write), so they write the hardware registers
//! directly. [`crate::bind_board!`] hands them to the library's fault path and installs the
//! panic and fault handlers.

use tetradrill_core::Vec3;

/// One motor's command as the output stage takes it: a PWM duty (0 to [`DUTY_MAX`]) and a
/// direction (an H-bridge's sign-magnitude drive).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct MotorCommand {
    /// Duty, 0 (off) to [`DUTY_MAX`] (full).
    pub duty: u16,
    /// Drive the motor backwards.
    pub reverse: bool,
}

impl MotorCommand {
    /// No torque.
    pub const OFF: Self = Self {
        duty: 0,
        reverse: false,
    };

    /// The command as one signed value (duty, negative when reversed).
    pub fn signed(self) -> i32 {
        if self.reverse {
            -(self.duty as i32)
        } else {
            self.duty as i32
        }
    }
}

/// Full duty: the 12-bit range of the Touch/Omni's motor DAC (+-2047 around zero,
/// `docs/devices/omni.toml`), kept as the PWM's full scale so the constants carry over.
pub const DUTY_MAX: u16 = 2047;

/// What turns a force into motor commands: the device's constants.
#[derive(Clone, Copy, Debug)]
pub struct MotorParams {
    /// Lever from a motor's joint to the tool, m: the force along an axis times it is that
    /// axis's motor torque (the stand-in for the device's Jacobian transpose at its home pose).
    pub lever_m: f32,
    /// Duty counts per N m of motor torque, sign included (the motor's direction relative to
    /// its axis).
    pub duty_per_newton_metre: [f32; 3],
}

/// The Touch/Omni's constants (`docs/devices/omni.toml`): 0.13335 m links and
/// `dac_per_newton_metre = [4096, -4096, 4096]`.
pub const OMNI: MotorParams = MotorParams {
    lever_m: 0.13335,
    duty_per_newton_metre: [4096.0, -4096.0, 4096.0],
};

/// Encoder counts per joint radian of the Touch/Omni: `counts_per_rev = 15000`
/// (`docs/devices/omni.toml`) over 2 pi.
pub const OMNI_COUNTS_PER_RADIAN: f32 = 15_000.0 / core::f32::consts::TAU;

/// The three motor commands for force `f`: each axis's torque through `p`, and when one
/// command would pass [`DUTY_MAX`] all three scaled down together, keeping the force's
/// direction. A non-finite force gives [`MotorCommand::OFF`] on every motor.
pub fn motor_commands(f: Vec3, p: &MotorParams) -> [MotorCommand; 3] {
    let raw = [f.x, f.y, f.z].map(|c| c * p.lever_m);
    let mut duty = [0.0f32; 3];
    for k in 0..3 {
        duty[k] = raw[k] * p.duty_per_newton_metre[k];
    }
    if !duty.iter().all(|d| d.is_finite()) {
        return [MotorCommand::OFF; 3];
    }
    let peak = duty.iter().fold(0.0f32, |m, d| m.max(d.abs()));
    let scale = if peak > DUTY_MAX as f32 {
        DUTY_MAX as f32 / peak
    } else {
        1.0
    };
    duty.map(|d| {
        let d = d * scale;
        MotorCommand {
            // Within 0..=DUTY_MAX by the scaling; `as` saturates anyway.
            duty: (d.abs() + 0.5) as u16,
            reverse: d < 0.0,
        }
    })
}

/// A board the application runs on.
pub trait Board {
    /// Writes the three motor commands (the servo, every tick).
    fn write_motors(&mut self, commands: &[MotorCommand; 3]);
    /// Raises or drops the motor drivers' enable.
    fn set_enable(&mut self, on: bool);
    /// The three joint encoders' counts.
    fn read_encoders(&mut self) -> [i32; 3];
    /// Feeds the watchdog (the servo, every tick).
    fn feed_watchdog(&mut self);

    /// Zeroes the three motor outputs and drops the enable, from any context.
    fn motors_off();
    /// Whether any motor output (read back from the hardware) is non-zero or the enable is
    /// raised.
    fn outputs_live() -> bool;
    /// After a fault: the watchdog left running to reset the board should the fault path
    /// hang, with time enough for its report first.
    fn fault_watchdog();
    /// Writes `s` to the log sink, waiting for room (from any context).
    fn log(s: &str);
    /// Resets the board.
    fn reset() -> !;
}
