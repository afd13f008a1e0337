//! The [`Board`] of the STM32F405 as QEMU's `netduinoplus2` machine models it (`chip-f405`).
//!
//! - Motor outputs: the PWM duty of the three motors in TIM3's compare registers CCR1 to CCR3
//!   (`0x4000_0434` to `0x4000_043C`; its auto-reload is [`DUTY_MAX`], so a duty is the
//!   compare value), as a board drives its H-bridges; the directions and the drivers' enable
//!   are statics ([`MOTOR_REVERSE`], [`MOTOR_ENABLE`]): QEMU models no GPIO on this SoC, where
//!   a board has three direction pins and an enable pin. The fault path reads the compare
//!   registers back from the timer model.
//! - Encoders: none on the machine; the servo's device read is the scripted pose, so they read
//!   zero (a board counts them on three timers in encoder mode).
//! - Watchdog: QEMU models no IWDG on this SoC. TIM2 stands in for it: it counts
//!   [`WATCHDOG_PERIODS`] servo periods, the servo resets its counter every tick, and at the
//!   end of its count its update interrupt (IRQ 28, at a priority above every task) runs the
//!   fault path ([`interrupt`]). It catches a servo that stops feeding it, as an IWDG does; it
//!   is not independent of the core's clock as an IWDG is, and it resets nothing by itself
//!   (an IWDG resets the chip, and the enable's pull-down keeps the drivers off).
//! - Log sink: USART1 (`0x4001_1000`), which QEMU connects to its first serial port (stdio
//!   under `-nographic`).
//! - Reset: `SCB::sys_reset` (SYSRESETREQ); under `-no-reboot` QEMU exits.
//!
//! QEMU's timers count in virtual time at 1 GHz before their prescaler; under `-icount
//! shift=3` an instruction takes 8 ns, so one servo period (168,000 instructions) is
//! 1,344,000 ns: TIM2 divides by [`TIM2_PRESCALE`] (1.344 us a count, a thousandth of a period).

use core::ptr;
use core::sync::atomic::{AtomicBool, Ordering};

use crate::hw::{Board, MotorCommand, DUTY_MAX};

/// Each motor's direction (reverse) as a board's direction pin would hold it.
pub static MOTOR_REVERSE: [AtomicBool; 3] = [
    AtomicBool::new(false),
    AtomicBool::new(false),
    AtomicBool::new(false),
];
/// The motor drivers' enable.
pub static MOTOR_ENABLE: AtomicBool = AtomicBool::new(false);

const TIM2: usize = 0x4000_0000;
const TIM3: usize = 0x4000_0400;
const TIM_CR1: usize = 0x00;
const TIM_DIER: usize = 0x0C;
const TIM_SR: usize = 0x10;
const TIM_EGR: usize = 0x14;
const TIM_CNT: usize = 0x24;
const TIM_PSC: usize = 0x28;
const TIM_ARR: usize = 0x2C;
const TIM_CCR: [usize; 3] = [0x34, 0x38, 0x3C];
const TIM_CR1_CEN: u32 = 1;
const TIM_DIER_UIE: u32 = 1;
const TIM_EGR_UG: u32 = 1;

const USART1: usize = 0x4001_1000;
const USART_SR: usize = USART1;
const USART_DR: usize = USART1 + 0x04;
const USART_BRR: usize = USART1 + 0x08;
const USART_CR1: usize = USART1 + 0x0C;
const USART_SR_TXE: u32 = 1 << 7;
const USART_CR1_UE: u32 = 1 << 13;
const USART_CR1_TE: u32 = 1 << 3;

const NVIC_ISER0: usize = 0xE000_E100;
const NVIC_IPR: usize = 0xE000_E400;
/// TIM2's interrupt number on the STM32F405.
pub const TIM2_IRQ: u16 = 28;

/// TIM2's prescaler: QEMU's 1 GHz timer clock divided down to a thousandth of a servo period
/// (1,344 ns under `-icount shift=3`).
pub const TIM2_PRESCALE: u32 = 1_344;
/// TIM2 counts a servo period.
const TIM2_PER_PERIOD: u32 = 1_000;
/// Servo periods the watchdog allows between two feeds.
pub const WATCHDOG_PERIODS: u32 = 4;
/// Servo periods the fault path has for its report before the watchdog fires again.
pub const FAULT_WATCHDOG_PERIODS: u32 = 100;

fn read(addr: usize) -> u32 {
    // SAFETY: `addr` is one of the TIM2, TIM3, USART1 or NVIC registers above, word-aligned
    // and mapped on the STM32F405 (and QEMU's model of it); reading them has no side effect.
    unsafe { ptr::read_volatile(addr as *const u32) }
}

fn write(addr: usize, v: u32) {
    // SAFETY: `addr` is one of the registers above; the values written are the ones their
    // descriptions allow.
    unsafe { ptr::write_volatile(addr as *mut u32, v) }
}

fn write_byte(addr: usize, v: u8) {
    // SAFETY: `addr` is an NVIC priority byte of the interrupt above.
    unsafe { ptr::write_volatile(addr as *mut u8, v) }
}

/// The F405 board (no state: its outputs are registers and statics).
pub struct F405 {
    _private: (),
}

impl F405 {
    /// The board: TIM3's PWM at [`DUTY_MAX`] full scale, motors off, USART1 on. The watchdog
    /// starts with [`F405::start_watchdog`].
    pub fn new() -> Self {
        write(TIM3 + TIM_ARR, DUTY_MAX as u32);
        write(TIM3 + TIM_CR1, TIM_CR1_CEN);
        Self::motors_off();
        usart_on();
        Self { _private: () }
    }

    /// Starts the watchdog: TIM2 counting [`WATCHDOG_PERIODS`] servo periods, its update
    /// interrupt above every task.
    pub fn start_watchdog(&mut self) {
        load_watchdog(WATCHDOG_PERIODS);
        // Priority 0, the highest: above the servo's SysTick.
        write_byte(NVIC_IPR + TIM2_IRQ as usize, 0);
        write(NVIC_ISER0, 1 << TIM2_IRQ);
    }
}

impl Default for F405 {
    fn default() -> Self {
        Self::new()
    }
}

/// TIM2 counting `periods` servo periods from zero, its update interrupt enabled.
fn load_watchdog(periods: u32) {
    write(TIM2 + TIM_CR1, 0);
    write(TIM2 + TIM_PSC, TIM2_PRESCALE - 1);
    write(TIM2 + TIM_ARR, periods * TIM2_PER_PERIOD);
    write(TIM2 + TIM_EGR, TIM_EGR_UG);
    write(TIM2 + TIM_CNT, 0);
    write(TIM2 + TIM_SR, 0);
    write(TIM2 + TIM_DIER, TIM_DIER_UIE);
    write(TIM2 + TIM_CR1, TIM_CR1_CEN);
}

fn usart_on() {
    if read(USART_CR1) & USART_CR1_UE == 0 {
        // 115,200 baud from an 84 MHz APB2 (QEMU ignores the rate).
        write(USART_BRR, 0x2D9);
        write(USART_CR1, USART_CR1_UE | USART_CR1_TE);
    }
}

/// The interrupts the F405 build takes besides the Cortex-M exceptions (the binary's
/// `DefaultHandler`): TIM2's update is the watchdog's expiry, which runs the fault path; any
/// other is unexpected and stops the motors too.
pub fn interrupt(irqn: i16) -> ! {
    if irqn == TIM2_IRQ as i16 {
        crate::fault::stop(
            "watchdog",
            format_args!("watchdog: the servo stopped feeding it (TIM2)"),
        )
    }
    crate::fault::stop("error", format_args!("unexpected interrupt {}", irqn))
}

impl Board for F405 {
    #[inline(always)]
    fn write_motors(&mut self, commands: &[MotorCommand; 3]) {
        for ((ccr, rev), c) in TIM_CCR.iter().zip(&MOTOR_REVERSE).zip(commands) {
            rev.store(c.reverse, Ordering::Relaxed);
            write(TIM3 + ccr, c.duty as u32);
        }
    }

    fn set_enable(&mut self, on: bool) {
        MOTOR_ENABLE.store(on, Ordering::Relaxed);
    }

    #[inline(always)]
    fn read_encoders(&mut self) -> [i32; 3] {
        [0; 3]
    }

    #[inline(always)]
    fn feed_watchdog(&mut self) {
        write(TIM2 + TIM_CNT, 0);
    }

    fn motors_off() {
        for ccr in TIM_CCR {
            write(TIM3 + ccr, 0);
        }
        for rev in &MOTOR_REVERSE {
            rev.store(false, Ordering::SeqCst);
        }
        MOTOR_ENABLE.store(false, Ordering::SeqCst);
    }

    fn outputs_live() -> bool {
        MOTOR_ENABLE.load(Ordering::SeqCst) || TIM_CCR.iter().any(|&ccr| read(TIM3 + ccr) != 0)
    }

    fn fault_watchdog() {
        load_watchdog(FAULT_WATCHDOG_PERIODS);
    }

    fn log(s: &str) {
        usart_on();
        for b in s.bytes() {
            while read(USART_SR) & USART_SR_TXE == 0 {}
            write(USART_DR, b as u32);
        }
    }

    fn reset() -> ! {
        cortex_m::peripheral::SCB::sys_reset()
    }
}
