//! The [`Board`] of an STM32H743 board (the pins of a Nucleo-H743ZI; docs/PORTING.md, "A
//! new board").
//!
//! | what                    | peripheral, pins                                          |
//! |-------------------------|-----------------------------------------------------------|
//! | motor PWM, 3 channels   | TIM1 CH1-3 on PE9, PE11, PE13 (AF1), 20 kHz               |
//! | motor direction         | PE2, PE3, PE4 (push-pull, high: reverse)                  |
//! | motor drivers' enable   | PE5 (push-pull, high: enabled; needs a pull-down on the board so it reads low in reset) |
//! | encoders                | TIM2 on PA15/PB3 (AF1), TIM3 on PB4/PB5 (AF2), TIM4 on PD12/PD13 (AF2) |
//! | watchdog                | IWDG, [`WATCHDOG_MS`] ms                                   |
//! | log                     | USART3 TX on PD8 (AF7), 115,200 baud (the Nucleo's ST-LINK virtual COM port) |
//!
//! The servo's path (`write_motors`, `feed_watchdog`) and the fault path write the same
//! registers: a duty is TIM1's CCR1-3 (the PWM's full scale maps [`DUTY_MAX`] to the timer's
//! period), a direction or the enable is a GPIOE BSRR write. The fault path uses them through
//! their addresses alone, so it works whatever state the HAL's handles are in.
//!
//! The IWDG cannot be stopped or interrupt: its expiry resets the chip, which puts every pin
//! in its reset state (analog, high impedance): the enable's pull-down then holds the drivers
//! off. After a fault the log feeds it once per byte sent, so a report at 115,200 baud is not
//! cut short while a hung one still ends in a reset.

use core::ptr;
use core::sync::atomic::{AtomicBool, Ordering};

use stm32h7xx_hal::hal::Qei as _;
use stm32h7xx_hal::independent_watchdog::IndependentWatchdog;
use stm32h7xx_hal::pac;
use stm32h7xx_hal::qei::Qei;

use tetradrill_mps2_an386::hw::{Board, MotorCommand, DUTY_MAX};

/// The watchdog's timeout: four servo periods and a margin.
pub const WATCHDOG_MS: u32 = 5;

const TIM1_CCR: [usize; 3] = [0x4001_0034, 0x4001_0038, 0x4001_003C];
const TIM1_ARR: usize = 0x4001_002C;
const GPIOE_ODR: usize = 0x5802_1014;
const GPIOE_BSRR: usize = 0x5802_1018;
const DIR_PINS: [u32; 3] = [2, 3, 4];
const ENABLE_PIN: u32 = 5;
const USART3_ISR: usize = 0x4000_481C;
const USART3_TDR: usize = 0x4000_4828;
/// ISR.TXE (TXFNF with the FIFO): room for a byte.
const USART_TXE: u32 = 1 << 7;
/// ISR.TC: the last byte has left.
const USART_TC: u32 = 1 << 6;
/// Status reads a byte may wait (a byte at 115,200 baud is 87 us, under 42,000 cycles).
const TX_SPINS: u32 = 200_000;
const IWDG_KR: usize = 0x5800_4800;
const IWDG_RELOAD: u32 = 0xAAAA;

/// Set by the fault path: the log then feeds the watchdog.
static FAULTED: AtomicBool = AtomicBool::new(false);

fn read(addr: usize) -> u32 {
    // SAFETY: `addr` is one of the TIM1, GPIOE, USART3 or IWDG registers above, word-aligned,
    // their peripherals clocked by `H743::new` before the servo or a fault after `init` uses
    // them (a read of an unclocked peripheral returns zero on the H7).
    unsafe { ptr::read_volatile(addr as *const u32) }
}

fn write(addr: usize, v: u32) {
    // SAFETY: as `read`; the values are the registers' documented ones (a duty within ARR,
    // BSRR set/reset bits, a USART data byte, the IWDG's reload key).
    unsafe { ptr::write_volatile(addr as *mut u32, v) }
}

/// The board's state: the encoders and the watchdog (the outputs are registers).
pub struct H743 {
    encoders: (Qei<pac::TIM2>, Qei<pac::TIM3>, Qei<pac::TIM4>),
    watchdog: IndependentWatchdog,
}

impl H743 {
    /// The board over its configured encoders and started watchdog (see `main.rs`'s `init`
    /// for the clocks, the PWM and the pins).
    pub fn new(
        encoders: (Qei<pac::TIM2>, Qei<pac::TIM3>, Qei<pac::TIM4>),
        watchdog: IndependentWatchdog,
    ) -> Self {
        Self::motors_off();
        Self { encoders, watchdog }
    }
}

/// The CCR value for `duty` (0 to [`DUTY_MAX`]) at TIM1's period.
fn ccr(duty: u16) -> u32 {
    let arr = read(TIM1_ARR) & 0xFFFF;
    (duty.min(DUTY_MAX) as u32 * (arr + 1)) / DUTY_MAX as u32
}

impl Board for H743 {
    fn write_motors(&mut self, commands: &[MotorCommand; 3]) {
        let mut bsrr = 0;
        for (k, c) in commands.iter().enumerate() {
            let pin = DIR_PINS[k];
            bsrr |= if c.reverse { 1 << pin } else { 1 << (pin + 16) };
        }
        write(GPIOE_BSRR, bsrr);
        for (k, c) in commands.iter().enumerate() {
            write(TIM1_CCR[k], ccr(c.duty));
        }
    }

    fn set_enable(&mut self, on: bool) {
        write(
            GPIOE_BSRR,
            if on {
                1 << ENABLE_PIN
            } else {
                1 << (ENABLE_PIN + 16)
            },
        );
    }

    fn read_encoders(&mut self) -> [i32; 3] {
        [
            self.encoders.0.count() as i32,
            self.encoders.1.count() as i16 as i32,
            self.encoders.2.count() as i16 as i32,
        ]
    }

    fn feed_watchdog(&mut self) {
        self.watchdog.feed();
    }

    fn motors_off() {
        for a in TIM1_CCR {
            write(a, 0);
        }
        write(GPIOE_BSRR, 1 << (ENABLE_PIN + 16));
    }

    fn outputs_live() -> bool {
        read(GPIOE_ODR) & (1 << ENABLE_PIN) != 0 || TIM1_CCR.iter().any(|&a| read(a) != 0)
    }

    fn fault_watchdog() {
        FAULTED.store(true, Ordering::SeqCst);
        write(IWDG_KR, IWDG_RELOAD);
    }

    fn log(s: &str) {
        let faulted = FAULTED.load(Ordering::Relaxed);
        for b in s.bytes() {
            // Bounded: before `init` has clocked USART3 its status reads zero.
            let mut spins = 0u32;
            while read(USART3_ISR) & USART_TXE == 0 && spins < TX_SPINS {
                spins += 1;
            }
            write(USART3_TDR, b as u32);
            if faulted {
                write(IWDG_KR, IWDG_RELOAD);
            }
        }
    }

    fn reset() -> ! {
        let mut spins = 0u32;
        while read(USART3_ISR) & USART_TC == 0 && spins < TX_SPINS {
            spins += 1;
        }
        cortex_m::peripheral::SCB::sys_reset()
    }
}
