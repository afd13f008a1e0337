//! The fault path: whatever stops the program stops the motors first.
//!
//! A panic, a HardFault, a MemManage fault (the stack guard, [`crate::memory`]), a BusFault,
//! a UsageFault (the configurable three enabled in SHCSR by [`enable_fault_handlers`]), the
//! watchdog's NMI and every refusal the firmware cannot go on from ([`crate::fail`]) end in
//! [`stop`], which in this order:
//!
//! 1. zeroes the three motor outputs and drops the drivers' enable ([`crate::hw::Board::motors_off`]);
//! 2. masks interrupts (no task runs again; only an NMI can preempt) and zeroes them again, in
//!    case the servo preempted between the first write and the mask;
//! 3. turns the watchdog into a guard on the fault path itself ([`crate::hw::Board::fault_watchdog`]: a
//!    hung report still ends in a reset);
//! 4. reads the outputs back [`FAULT_SAMPLES`] times over two servo periods and counts the
//!    samples with any output live;
//! 5. logs (`fault=KIND`, the reason, `force_at_fault=` the force the servo last commanded,
//!    `force_after_fault_samples=`, `force_after_fault_n=` the live samples,
//!    `exit_status=1`) through the board's log sink, never semihosting;
//! 6. resets the board ([`crate::hw::Board::reset`]; QEMU's `-no-reboot` turns it into an exit).
//!
//! A run that ends normally goes through [`exit_success`]: motors off, `exit_status=0`, reset.
//!
//! Fault injection (`scripts/port-check.sh --inject`): built with `TETRADRILL_INJECT=panic`,
//! `hardfault` or `stall` and `TETRADRILL_INJECT_TICK=N` (default [`INJECT_TICK`]), the servo
//! faults at tick `N` right after writing that tick's force: a panic; a HardFault (an
//! undefined instruction with the UsageFault handler disabled, which escalates); or a stall
//! (the servo spins without feeding the watchdog, whose NMI stops it).
//!
//! The library does not know the board's type: [`crate::bind_board!`], invoked once by each
//! binary, defines the board hooks this module calls and installs the handlers.

use core::fmt::{self, Write};
use core::sync::atomic::Ordering;

extern "Rust" {
    fn tetradrill_board_motors_off();
    fn tetradrill_board_outputs_live() -> bool;
    fn tetradrill_board_fault_watchdog();
    fn tetradrill_board_log(s: &str);
    fn tetradrill_board_reset() -> !;
}

// SAFETY (the five below): the symbols are defined once, by `bind_board!`, with exactly these
// signatures, each forwarding to the bound board's function of the same name, which is safe
// to call from any context.
fn motors_off() {
    unsafe { tetradrill_board_motors_off() }
}
fn outputs_live() -> bool {
    unsafe { tetradrill_board_outputs_live() }
}
fn fault_watchdog() {
    unsafe { tetradrill_board_fault_watchdog() }
}
/// Writes `s` to the bound board's log sink.
pub fn log_str(s: &str) {
    unsafe { tetradrill_board_log(s) }
}
fn reset() -> ! {
    unsafe { tetradrill_board_reset() }
}

/// Prints one line to the board's log sink (the firmware's only output).
#[macro_export]
macro_rules! println {
    ($($arg:tt)*) => {
        $crate::fault::print_line(format_args!($($arg)*))
    };
}

/// Writes `args` and a newline to the board's log sink.
pub fn print_line(args: fmt::Arguments) {
    struct Sink;
    impl Write for Sink {
        fn write_str(&mut self, s: &str) -> fmt::Result {
            log_str(s);
            Ok(())
        }
    }
    let _ = Sink.write_fmt(args);
    log_str("\n");
}

/// Output samples the fault path takes after zeroing the motors.
pub const FAULT_SAMPLES: u32 = 20;

/// Reads the outputs back [`FAULT_SAMPLES`] times, a tenth of a servo period apart; returns
/// the samples with any output live.
fn sample_outputs() -> u32 {
    let mut live = 0;
    for _ in 0..FAULT_SAMPLES {
        if outputs_live() {
            live += 1;
        }
        // `delay(n)` runs n + 1 two-instruction iterations: a tenth of a period.
        cortex_m::asm::delay(crate::target::PERIOD_INSTRUCTIONS / 20);
    }
    live
}

/// Stops the motors, reports the fault `kind` (`panic`, `hardfault`, `memmanage`,
/// `busfault`, `usagefault`, `watchdog`, `error`) with `what`, and resets.
pub fn stop(kind: &str, what: fmt::Arguments) -> ! {
    motors_off();
    cortex_m::interrupt::disable();
    motors_off();
    fault_watchdog();
    let live = sample_outputs();
    let f = crate::servo::FORCE_OUT
        .each_ref()
        .map(|a| f32::from_bits(a.load(Ordering::Relaxed)));
    log_str("\n");
    println!("{}", what);
    println!("fault={}", kind);
    println!("force_at_fault={} {} {}", f[0], f[1], f[2]);
    println!("force_after_fault_samples={}", FAULT_SAMPLES);
    println!("force_after_fault_n={}", live);
    println!("exit_status=1");
    reset()
}

/// Ends a run that went well: motors off, `exit_status=0`, reset.
pub fn exit_success() -> ! {
    motors_off();
    println!("exit_status=0");
    reset()
}

/// Enables the configurable fault handlers (MemManage is enabled by the stack guard):
/// BusFault and UsageFault then run their own handlers instead of escalating to HardFault.
pub fn enable_fault_handlers(scb: &mut cortex_m::peripheral::SCB) {
    use cortex_m::peripheral::scb::Exception;
    scb.enable(Exception::BusFault);
    scb.enable(Exception::UsageFault);
}

/// The armed fault (`TETRADRILL_INJECT`; empty or unset: none).
const INJECT: Option<&str> = option_env!("TETRADRILL_INJECT");
/// The injection's default tick: the block's tool is pressing into the surface then.
pub const INJECT_TICK: u32 = 400;

/// Whether this build has a fault armed.
pub const fn armed() -> bool {
    match INJECT {
        Some(s) => !s.is_empty(),
        None => false,
    }
}

/// The tick the armed fault fires at.
pub fn inject_tick() -> u32 {
    crate::scenario::build_number(option_env!("TETRADRILL_INJECT_TICK")).unwrap_or(INJECT_TICK)
}

/// Fires the armed fault when `tick` is its tick (the servo calls it after each force write;
/// nothing when no fault is armed, or when the armed one is `late`, the simulation's).
#[inline(always)]
pub fn maybe_inject(tick: u32) {
    if armed() && tick == inject_tick() && !late_armed() {
        inject();
    }
}

/// Whether this build makes one simulation step late (`TETRADRILL_INJECT=late`): not a fault,
/// a step that overruns, to exercise the servo's deadline-miss policy ([`crate::policy`]).
pub fn late_armed() -> bool {
    matches!(INJECT, Some("late"))
}

/// Servo periods the step released at the injection tick spins before it simulates.
pub const LATE_PERIODS: u64 = 15;

/// With `late` armed, spins [`LATE_PERIODS`] servo periods when `tick` is the injection tick
/// (the simulation task calls it before each step; the servo preempts the spin and finds its
/// contacts late).
#[inline(always)]
pub fn maybe_late(tick: u32) {
    if late_armed() && tick == inject_tick() {
        let until = crate::clock::now() + LATE_PERIODS * crate::clock::PERIOD_COUNTS as u64;
        while crate::clock::now() < until {
            core::hint::spin_loop();
        }
    }
}

#[inline(never)]
fn inject() {
    match INJECT.unwrap_or("") {
        "panic" => panic!("injected at tick {}", inject_tick()),
        "hardfault" => {
            // The UsageFault handler disabled, an undefined instruction escalates to HardFault.
            // SAFETY: one read-modify-write of SHCSR from the servo's handler; the program
            // faults on the next instruction and never returns here.
            unsafe {
                (*cortex_m::peripheral::SCB::PTR)
                    .shcsr
                    .modify(|v| v & !(1 << 18));
            }
            cortex_m::asm::udf()
        }
        "stall" => loop {
            cortex_m::asm::nop();
        },
        other => crate::fail_args(format_args!("unknown TETRADRILL_INJECT '{}'", other)),
    }
}

/// Binds a board to the library's fault path and installs the handlers; invoke it once in
/// the binary, with the board's type: `bind_board!(Mps2)`.
///
/// It defines the board hooks [`stop`] calls, the panic handler, and the HardFault,
/// BusFault, UsageFault and NMI handlers, each of which calls [`stop`] (the MemManage handler
/// is [`crate::memory`]'s). The binary depends on `cortex-m-rt`.
#[macro_export]
macro_rules! bind_board {
    ($board:ty) => {
        #[no_mangle]
        fn tetradrill_board_motors_off() {
            <$board as $crate::hw::Board>::motors_off()
        }
        #[no_mangle]
        fn tetradrill_board_outputs_live() -> bool {
            <$board as $crate::hw::Board>::outputs_live()
        }
        #[no_mangle]
        fn tetradrill_board_fault_watchdog() {
            <$board as $crate::hw::Board>::fault_watchdog()
        }
        #[no_mangle]
        fn tetradrill_board_log(s: &str) {
            <$board as $crate::hw::Board>::log(s)
        }
        #[no_mangle]
        fn tetradrill_board_reset() -> ! {
            <$board as $crate::hw::Board>::reset()
        }

        #[panic_handler]
        fn panic(info: &core::panic::PanicInfo) -> ! {
            $crate::fault::stop("panic", format_args!("panic: {}", info))
        }

        // cortex-m-rt requires the HardFault and NMI handlers to be declared `unsafe fn`;
        // their bodies are safe.
        #[cortex_m_rt::exception]
        unsafe fn HardFault(ef: &cortex_m_rt::ExceptionFrame) -> ! {
            $crate::fault::hard_fault(ef)
        }

        #[cortex_m_rt::exception]
        fn BusFault() -> ! {
            $crate::fault::stop("busfault", format_args!("bus fault"))
        }

        #[cortex_m_rt::exception]
        fn UsageFault() -> ! {
            $crate::fault::stop("usagefault", format_args!("usage fault"))
        }

        #[cortex_m_rt::exception]
        unsafe fn NonMaskableInt() -> ! {
            $crate::fault::stop(
                "watchdog",
                format_args!("watchdog: the servo stopped feeding it (NMI)"),
            )
        }
    };
}

/// The HardFault handler's body: a frame in the stack guard is a stack overflow taken with
/// MemManage masked.
pub fn hard_fault(ef: &cortex_m_rt::ExceptionFrame) -> ! {
    if crate::memory::in_guard(ef as *const cortex_m_rt::ExceptionFrame as usize) {
        stop(
            "memmanage",
            format_args!("error: stack overflow: the stack ran into its guard (hard fault)"),
        );
    }
    stop(
        "hardfault",
        format_args!("hard fault at pc {:#010x}", ef.pc()),
    )
}
