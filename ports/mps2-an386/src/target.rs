//! What differs between the targets: the board QEMU models and the clock the servo period
//! assumes. The default build is the Cortex-M4F on `mps2-an386`; the `m7` feature builds the
//! same application for the Cortex-M7 on `mps2-an500` (with `-C target-cpu=cortex-m7`, as
//! `scripts/port-check.sh --target m7` does; `--target m7sp` adds `-C target-feature=-fp64`
//! for the M7 parts whose FPU does single precision only). The chip features build it for a
//! named chip's memory map (`memory-f405.x.in`, `memory-h743.x.in`): `chip-f405`, an STM32F405
//! on QEMU's `netduinoplus2`; `chip-h743` (with `m7`), an STM32H743's regions on `mps2-an500`.

/// The target's name in the firmware's output.
#[cfg(not(any(feature = "m7", feature = "chip-f405")))]
pub const NAME: &str = "cortex-m4 (mps2-an386)";
/// The target's name in the firmware's output.
#[cfg(all(feature = "m7", not(feature = "chip-h743"), not(fpu_sp)))]
pub const NAME: &str = "cortex-m7 (mps2-an500)";
/// The target's name in the firmware's output: a Cortex-M7 whose FPU does single precision
/// only (fpv5-sp-d16, `-C target-feature=-fp64`), as many M7 parts have; f64 is software.
#[cfg(all(feature = "m7", not(feature = "chip-h743"), fpu_sp))]
pub const NAME: &str = "cortex-m7, single-precision fpu (mps2-an500)";
/// The target's name in the firmware's output.
#[cfg(feature = "chip-f405")]
pub const NAME: &str = "stm32f405 (netduinoplus2)";
/// The target's name in the firmware's output.
#[cfg(feature = "chip-h743")]
pub const NAME: &str = "stm32h743 (its regions on mps2-an500)";

/// The chip's short name (`chip=` in the output), or the board's on the MPS2 maps.
pub const CHIP: &str = if cfg!(feature = "chip-f405") {
    "f405"
} else if cfg!(feature = "chip-h743") {
    "h743"
} else if cfg!(feature = "m7") {
    "mps2-an500"
} else {
    "mps2-an386"
};

/// The core clock the servo period assumes: 168 MHz, an STM32F4-class Cortex-M4F.
#[cfg(not(feature = "m7"))]
pub const CLOCK_MHZ: u32 = 168;
/// The core clock the servo period assumes: 480 MHz, an STM32H7-class Cortex-M7.
#[cfg(feature = "m7")]
pub const CLOCK_MHZ: u32 = 480;

/// Instructions in one 1 kHz servo period at [`CLOCK_MHZ`], one instruction a cycle (QEMU's
/// `-icount` model; a real core loses cycles to wait states and stalls, an M7 gains some by
/// dual issue).
pub const PERIOD_INSTRUCTIONS: u32 = CLOCK_MHZ * 1000;
