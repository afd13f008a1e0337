//! The [`Board`] of QEMU's MPS2 machines (`mps2-an386`, `mps2-an500`).
//!
//! - Motor outputs: a static "DAC" ([`MOTOR_OUT`], the three signed commands, and
//!   [`MOTOR_ENABLE`]): what a driver stage would latch, read back by the fault path.
//! - Encoders: none on the machine; the servo's device read is the scripted pose, so they
//!   read zero.
//! - Watchdog: the CMSDK APB watchdog QEMU models at `0x4000_8000`, clocked at 25 MHz like
//!   SysTick, its interrupt wired to the NMI. It counts down from [`WATCHDOG_PERIODS`] servo
//!   periods; the servo reloads it every tick; at zero it raises the NMI (whose handler stops
//!   the motors and resets), and at zero a second time with the interrupt still raised it
//!   resets the machine itself (RESEN).
//! - Log sink: the CMSDK UART0 at `0x4000_4000`, which QEMU connects to its first serial
//!   port (stdio under `-nographic`).
//! - Reset: `SCB::sys_reset` (SYSRESETREQ); under `-no-reboot` QEMU exits.

use core::ptr;
use core::sync::atomic::{AtomicBool, AtomicI32, Ordering};

use crate::clock::PERIOD_COUNTS;
use crate::hw::{Board, MotorCommand};

/// The three motor commands as the output stage holds them (duty, negative reversed).
pub static MOTOR_OUT: [AtomicI32; 3] = [AtomicI32::new(0), AtomicI32::new(0), AtomicI32::new(0)];
/// The motor drivers' enable.
pub static MOTOR_ENABLE: AtomicBool = AtomicBool::new(false);

const UART0: usize = 0x4000_4000;
const UART_DATA: usize = UART0;
const UART_STATE: usize = UART0 + 0x04;
const UART_CTRL: usize = UART0 + 0x08;
const UART_BAUDDIV: usize = UART0 + 0x10;
const UART_TX_FULL: u32 = 1;
const UART_TX_ENABLE: u32 = 1;

const WDOG: usize = 0x4000_8000;
const WDOG_LOAD: usize = WDOG;
const WDOG_CTRL: usize = WDOG + 0x08;
const WDOG_INTCLR: usize = WDOG + 0x0C;
const WDOG_LOCK: usize = WDOG + 0xC00;
const WDOG_UNLOCK: u32 = 0x1ACC_E551;
const WDOG_INTEN: u32 = 1;
const WDOG_RESEN: u32 = 2;

/// Servo periods the watchdog allows between two feeds.
pub const WATCHDOG_PERIODS: u32 = 4;
/// Servo periods the fault path has for its report before the watchdog's NMI.
pub const FAULT_WATCHDOG_PERIODS: u32 = 100;

fn read(addr: usize) -> u32 {
    // SAFETY: `addr` is one of the UART0 or watchdog registers above, word-aligned and mapped
    // on both MPS2 machines; reading them has no side effect.
    unsafe { ptr::read_volatile(addr as *const u32) }
}

fn write(addr: usize, v: u32) {
    // SAFETY: `addr` is one of the UART0 or watchdog registers above; the values written are
    // the ones their descriptions allow.
    unsafe { ptr::write_volatile(addr as *mut u32, v) }
}

/// The MPS2 board (no state: its outputs are statics and registers).
pub struct Mps2 {
    _private: (),
}

impl Mps2 {
    /// The board: motors off, the UART on. The watchdog starts with [`Mps2::start_watchdog`].
    pub fn new() -> Self {
        Self::motors_off();
        uart_on();
        Self { _private: () }
    }

    /// Starts the watchdog: [`WATCHDOG_PERIODS`] servo periods, NMI then reset.
    pub fn start_watchdog(&mut self) {
        write(WDOG_LOCK, WDOG_UNLOCK);
        write(WDOG_LOAD, WATCHDOG_PERIODS * PERIOD_COUNTS);
        write(WDOG_CTRL, WDOG_INTEN | WDOG_RESEN);
        write(WDOG_LOCK, 0);
    }
}

impl Default for Mps2 {
    fn default() -> Self {
        Self::new()
    }
}

fn uart_on() {
    if read(UART_CTRL) & UART_TX_ENABLE == 0 {
        write(UART_BAUDDIV, 16);
        write(UART_CTRL, UART_TX_ENABLE);
    }
}

impl Board for Mps2 {
    #[inline(always)]
    fn write_motors(&mut self, commands: &[MotorCommand; 3]) {
        for (out, c) in MOTOR_OUT.iter().zip(commands) {
            out.store(c.signed(), Ordering::Relaxed);
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
        // INTCLR reloads the counter (and clears an interrupt not yet taken).
        write(WDOG_LOCK, WDOG_UNLOCK);
        write(WDOG_INTCLR, 1);
        write(WDOG_LOCK, 0);
    }

    fn motors_off() {
        for out in &MOTOR_OUT {
            out.store(0, Ordering::SeqCst);
        }
        MOTOR_ENABLE.store(false, Ordering::SeqCst);
    }

    fn outputs_live() -> bool {
        MOTOR_ENABLE.load(Ordering::SeqCst)
            || MOTOR_OUT.iter().any(|o| o.load(Ordering::SeqCst) != 0)
    }

    fn fault_watchdog() {
        write(WDOG_LOCK, WDOG_UNLOCK);
        write(WDOG_LOAD, FAULT_WATCHDOG_PERIODS * PERIOD_COUNTS);
        write(WDOG_INTCLR, 1);
        write(WDOG_LOCK, 0);
    }

    fn log(s: &str) {
        uart_on();
        for b in s.bytes() {
            while read(UART_STATE) & UART_TX_FULL != 0 {}
            write(UART_DATA, b as u32);
        }
    }

    fn reset() -> ! {
        // Let the last byte leave.
        while read(UART_STATE) & UART_TX_FULL != 0 {}
        cortex_m::peripheral::SCB::sys_reset()
    }
}
