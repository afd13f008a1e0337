//! The stack's measure and the memory the runtime does not initialise.
//!
//! The stack: cortex-m-rt's `paint-stack` feature fills everything between `_stack_end` (its
//! lowest address) and `_stack_start` (its top, the initial SP) with
//! [`cortex_m_rt::STACK_PAINT_VALUE`] in the reset handler, before `main` runs; the deepest
//! word that no longer holds the paint is the high-water mark ([`stack_max_bytes`], the guard
//! below excluded). The report prints start-up's mark (`stack_init_max_bytes`), the run's
//! (`stack_run_max_bytes`: `idle` paints the stack again below itself when it starts,
//! [`start_run`]) and the larger as `stack_max_bytes`.
//!
//! flip-link links the image with the stack below the statics (`_stack_end` the start of
//! RAM), so an overflow runs off the bottom of RAM instead of overwriting them. Below RAM lies
//! a reserved range that QEMU's MPS2 models read as zero and ignore writes to, so running off
//! RAM alone would not fault there: [`guard_stack`] makes the stack's lowest [`GUARD_BYTES`]
//! an MPU region no access is allowed to, and the MemManage handler puts the stack pointer
//! back at the top, stops the motors, prints `error: stack overflow` and resets ([`crate::fault`]) (in `init`, where
//! MemManage is masked, the fault escalates to the HardFault handler, which runs with the MPU
//! off and says the same when its frame lies in the guard). The guard is larger than any frame
//! of the firmware (the largest, `storage::place_world`'s, is 27 KB), so no frame can step over
//! it.
//!
//! Memory the runtime does not initialise: cortex-m-rt zeroes `.bss` and copies `.data`, and
//! nothing else. The `.psram` section (NOLOAD, outside RAM) holds `ConstStaticCell`s whose
//! taken flags must start false, so `__pre_init` (below) zeroes it, from `__spsram` to
//! `__epsram` (`memory.x.in`), before RAM is initialised: the firmware does not rely on the
//! memory starting zeroed. `.uninit` holds only RTIC's late resources, written by RTIC from
//! `init`'s return value before any task reads them.

use core::arch::global_asm;
use core::ptr;
use core::sync::atomic::{AtomicUsize, Ordering};

use cortex_m_rt::STACK_PAINT_VALUE;

// cortex-m-rt's reset handler calls `__pre_init` first (before zeroing `.bss`, copying `.data`
// and painting the stack): zero the `.psram` section word by word. Assembly, as no Rust code
// may run before RAM is initialised; it uses no stack.
#[cfg(not(feature = "garbage"))]
global_asm!(
    ".section .text.__pre_init, \"ax\"
     .global __pre_init
     .type __pre_init, %function
     .thumb_func
     __pre_init:",
    // Zero .psram.
    "ldr r0, =__spsram
     ldr r1, =__epsram
     movs r2, #0
     0:
     cmp r1, r0
     beq 1f
     stm r0!, {{r2}}
     b 0b
     1:
     bx lr
     .ltorg"
);

/// The pattern the `garbage` feature fills memory with at reset.
#[cfg(feature = "garbage")]
pub const GARBAGE: u32 = 0xa5a5_a5a5;

// With the `garbage` feature (`scripts/port-check.sh --garbage`), `__pre_init` first fills RAM
// from `_stack_end` to `__euninit` (the stack, `.data`, `.bss` and `.uninit`) and the `.psram`
// section with [`GARBAGE`], then zeroes `.psram` as above: a run that matches the host's digest
// proves that nothing reads memory the firmware or the runtime did not initialise (QEMU's
// loader itself zero-fills the image's `.bss` and `.uninit`).
#[cfg(feature = "garbage")]
global_asm!(
    ".section .text.__pre_init, \"ax\"
     .global __pre_init
     .type __pre_init, %function
     .thumb_func
     __pre_init:",
    // Fill RAM (the stack and the statics) with the pattern.
    "ldr r0, =_stack_end
     ldr r1, =__euninit
     ldr r2, =0xa5a5a5a5
     0:
     cmp r1, r0
     beq 1f
     stm r0!, {{r2}}
     b 0b
     1:",
    // Fill .psram with the pattern.
    "ldr r0, =__spsram
     ldr r1, =__epsram
     0:
     cmp r1, r0
     beq 1f
     stm r0!, {{r2}}
     b 0b
     1:",
    // Zero .psram.
    "ldr r0, =__spsram
     ldr r1, =__epsram
     movs r2, #0
     0:
     cmp r1, r0
     beq 1f
     stm r0!, {{r2}}
     b 0b
     1:
     bx lr
     .ltorg"
);

extern "C" {
    /// The stack's lowest address (cortex-m-rt's linker script; flip-link sets it).
    static _stack_end: u32;
    /// The stack's top, the initial SP.
    static _stack_start: u32;
}

/// Bytes of the stack guard: the MPU region at the bottom of the stack (a power of two, its
/// base aligned to it).
pub const GUARD_BYTES: usize = 64 * 1024;

/// The guard's base: `_stack_end` rounded up to [`GUARD_BYTES`] (`_stack_end` itself with
/// flip-link, the start of RAM).
fn guard_base() -> usize {
    let low = ptr::addr_of!(_stack_end) as usize;
    (low + GUARD_BYTES - 1) & !(GUARD_BYTES - 1)
}

/// The usable stack's bounds, `(lowest, top)` as addresses: above the guard, below
/// `_stack_start`.
fn stack_bounds() -> (usize, usize) {
    // Only the addresses of the linker's symbols, never their contents.
    (
        guard_base() + GUARD_BYTES,
        ptr::addr_of!(_stack_start) as usize,
    )
}

/// Makes the [`GUARD_BYTES`] at the bottom of the stack an MPU region with no access
/// (privileged code included; the default memory map everywhere else) and enables the
/// MemManage exception, whose handler reports the overflow. Called first in `init`.
pub fn guard_stack(mpu: &mut cortex_m::peripheral::MPU, scb: &mut cortex_m::peripheral::SCB) {
    const ENABLE: u32 = 1;
    // RASR.SIZE: the region is 2^(SIZE + 1) bytes.
    const SIZE: u32 = GUARD_BYTES.trailing_zeros() - 1;
    // RASR.XN; AP = 0b000 (no access) and TEX, S, C, B = 0.
    const XN: u32 = 1 << 28;
    // CTRL: ENABLE, PRIVDEFENA (the default map for privileged accesses outside the regions).
    const CTRL: u32 = 1 | (1 << 2);
    // SAFETY: region 0 is the only MPU region, covering the guard alone (RAM nothing else
    // uses: the stack's region below the measured and bounded high-water mark); the default
    // map stays in force everywhere else, so no access the firmware makes changes meaning.
    unsafe {
        mpu.rnr.write(0);
        mpu.rbar.write(guard_base() as u32);
        mpu.rasr.write(XN | (SIZE << 1) | ENABLE);
        mpu.ctrl.write(CTRL);
    }
    cortex_m::asm::dsb();
    cortex_m::asm::isb();
    scb.enable(cortex_m::peripheral::scb::Exception::MemoryManagement);
}

// The MemManage handler: the only MPU region is the guard, so a MemManage fault is the stack
// running into it. The stack pointer is in the guard, so the handler first puts it back at the
// top (the program does not go on), then reports.
global_asm!(
    ".section .text.MemoryManagement, \"ax\"
     .global MemoryManagement
     .type MemoryManagement, %function
     .thumb_func
     MemoryManagement:
     ldr r0, =_stack_start
     msr msp, r0
     isb
     b {report}
     .ltorg",
    report = sym stack_overflow,
);

/// Stops the motors and reports `error: stack overflow` ([`crate::fault::stop`]; entered from
/// the MemManage handler with a fresh stack).
extern "C" fn stack_overflow() -> ! {
    crate::fault::stop(
        "memmanage",
        format_args!("error: stack overflow: the stack ran into its guard"),
    )
}

/// Whether `addr` lies in the stack's guard: a hard fault whose frame is there is a stack
/// overflow that happened with MemManage masked (in `init`, or escalated), the MPU being off
/// in the HardFault handler.
pub fn in_guard(addr: usize) -> bool {
    (guard_base()..guard_base() + GUARD_BYTES).contains(&addr)
}

/// Bytes of the usable stack (from the guard's top to `_stack_start`).
pub fn stack_bytes() -> usize {
    let (low, top) = stack_bounds();
    top - low
}

/// The high-water mark of start-up (reset, `init`, and whatever ran before `idle` started),
/// kept by [`start_run`].
static INIT_MAX: AtomicUsize = AtomicUsize::new(0);

/// Called first thing in `idle`: keeps the high-water mark so far as start-up's
/// ([`init_max_bytes`]), then paints the stack again below the current stack pointer, so
/// that [`stack_max_bytes`] afterwards measures the run alone (the tasks and `idle`). A task
/// preempting the painting pushes its frame below the stack pointer and pops it before the
/// painting goes on, so only dead words are painted.
pub fn start_run() {
    INIT_MAX.store(stack_max_bytes(), Ordering::Relaxed);
    let (low, _) = stack_bounds();
    let sp = cortex_m::register::msp::read() as usize;
    let mut at = low;
    while at + 4 <= sp {
        // SAFETY: [low, sp) is RAM below the current stack pointer: no frame lives there
        // (an exception's frame comes and goes between two of these stores).
        unsafe { ptr::write_volatile(at as *mut u32, STACK_PAINT_VALUE) };
        at += 4;
    }
}

/// The stack's high-water mark during start-up (see [`start_run`]).
pub fn init_max_bytes() -> usize {
    INIT_MAX.load(Ordering::Relaxed)
}

/// The stack's high-water mark in bytes: from the top down to the deepest word that no longer
/// holds the paint. A word the program happened to write with the paint's value at the very
/// bottom of its deepest frame would hide that word (4 bytes) from the mark.
pub fn stack_max_bytes() -> usize {
    let (low, top) = stack_bounds();
    let mut at = low;
    // SAFETY: every word of [low, top) is RAM the reset handler painted; the words below the
    // current stack pointer are not borrowed by anything, and volatile reads of them do not
    // disturb the frames above.
    while at < top && unsafe { ptr::read_volatile(at as *const u32) } == STACK_PAINT_VALUE {
        at += 4;
    }
    top - at
}
