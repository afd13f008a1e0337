//! The little RTIC needs to know about the board (`#[rtic::app(device = crate::board)]`): the
//! priority bits of its NVIC. The application binds only Cortex-M exceptions (SysTick for the
//! servo, PendSV for the simulation), so it needs no peripheral access crate and no interrupt
//! vector of the board's own.

/// Priority bits the MPS2 FPGA images implement (AN386 and AN500 both give 3, 8 levels).
pub const NVIC_PRIO_BITS: u8 = 3;
