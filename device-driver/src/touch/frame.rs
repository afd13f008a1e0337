//! One frame of the HD scheduler's callback: the only place the Touch's frames are begun and
//! ended (OpenHaptics' pattern: every device read and force write of a servo tick between
//! `hdBeginFrame` and `hdEndFrame`, inside a callback the vendor scheduler runs at 1 kHz).
//!
//! [`callback_frame`] is written over the [`HdFrame`] calls, so the loader's `extern "C"`
//! callback (`os::hdapi`) and the tests' stand-ins run the same code.

use std::sync::atomic::Ordering::Relaxed;

use super::exchange::{Calibrated, Exchange, FrameState, HdError};

/// Age of the servo's last new command after which the callback zeroes the force, ns, on the
/// callback's own clock (five ticks of the 1 kHz servo). The tolerance covers a servo tick
/// that wakes late (2.6 ms was the worst wake-up of a SCHED_FIFO thread measured beside two
/// builds, docs/TIMING.md) plus the callback's own period; a servo that stops is cut within
/// 6 ms.
pub const STALL_LIMIT_NS: u64 = 5_000_000;

/// Most errors popped from the library's error stack after a frame (bounded work).
pub const MAX_ERRORS_PER_FRAME: usize = 8;

/// `HD_CALLBACK_DONE` / `HD_CALLBACK_CONTINUE` (hdDefines.h) as the callback's answer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CallbackCode {
    /// Run again at the scheduler's next tick.
    Continue,
    /// Unschedule: stopped on request or ended by an error.
    Done,
}

/// The HD calls one frame makes, in the scheduler's thread. Errors are not returned per call:
/// as in OpenHaptics' own callbacks, the frame makes its calls and then pops the library's
/// error stack ([`HdFrame::next_error`]).
pub trait HdFrame {
    /// `hdBeginFrame(hHD)`.
    fn begin_frame(&mut self);
    /// `hdEndFrame(hHD)`.
    fn end_frame(&mut self);
    /// `hdGetDoublev(HD_CURRENT_POSITION)`, mm.
    fn position_mm(&mut self) -> [f64; 3];
    /// `hdGetDoublev(HD_CURRENT_TRANSFORM)`: 4x4 column-major, translation in mm.
    fn transform(&mut self) -> [f64; 16];
    /// `hdGetIntegerv(HD_CURRENT_BUTTONS)`.
    fn buttons(&mut self) -> u32;
    /// The stylus sits in its inkwell (`HD_CURRENT_INKWELL_SWITCH`, read as the loader
    /// documents).
    fn inkwell(&mut self) -> bool;
    /// `hdSetDoublev(HD_CURRENT_FORCE)`, N.
    fn set_force(&mut self, force: [f64; 3]);
    /// `hdEnable(HD_FORCE_OUTPUT)` / `hdDisable(HD_FORCE_OUTPUT)`.
    fn enable_force(&mut self, on: bool);
    /// `hdGetIntegerv(HD_CALIBRATION_STYLE)`: the styles the device supports.
    fn calibration_styles(&mut self) -> u32;
    /// `hdCheckCalibration()`.
    fn check_calibration(&mut self) -> u32;
    /// `hdUpdateCalibration(style)`.
    fn update_calibration(&mut self, style: u32);
    /// `hdGetError()`: the most recent error not popped yet, `None` when the stack is empty.
    fn next_error(&mut self) -> Option<HdError>;
}

/// `HD_CALIBRATION_OK 0x5000` (hdDefines.h).
pub const HD_CALIBRATION_OK: u32 = 0x5000;
/// `HD_CALIBRATION_NEEDS_UPDATE 0x5001` (hdDefines.h).
pub const HD_CALIBRATION_NEEDS_UPDATE: u32 = 0x5001;
/// `HD_CALIBRATION_NEEDS_MANUAL_INPUT 0x5002` (hdDefines.h).
pub const HD_CALIBRATION_NEEDS_MANUAL_INPUT: u32 = 0x5002;
/// `HD_CALIBRATION_ENCODER_RESET (1 << 0)` (hdDefines.h, calibration styles).
pub const HD_CALIBRATION_ENCODER_RESET: u32 = 1 << 0;
/// `HD_CALIBRATION_AUTO (1 << 1)` (hdDefines.h, calibration styles).
pub const HD_CALIBRATION_AUTO: u32 = 1 << 1;
/// `HD_CALIBRATION_INKWELL (1 << 2)` (hdDefines.h, calibration styles).
pub const HD_CALIBRATION_INKWELL: u32 = 1 << 2;
/// `HD_INVALID_OPERATION 0x0102` (hdDefines.h, function errors).
pub const HD_INVALID_OPERATION: u32 = 0x0102;

/// The name of an HDAPI error code (hdDefines.h, error codes), or `"HD error"`.
pub fn error_name(code: u32) -> &'static str {
    match code {
        0x0000 => "HD_SUCCESS",
        0x0100 => "HD_INVALID_ENUM",
        0x0101 => "HD_INVALID_VALUE",
        0x0102 => "HD_INVALID_OPERATION",
        0x0103 => "HD_INVALID_INPUT_TYPE",
        0x0104 => "HD_BAD_HANDLE",
        0x0200 => "HD_WARM_MOTORS",
        0x0201 => "HD_EXCEEDED_MAX_FORCE",
        0x0202 => "HD_EXCEEDED_MAX_FORCE_IMPULSE",
        0x0203 => "HD_EXCEEDED_MAX_VELOCITY",
        0x0204 => "HD_FORCE_ERROR",
        0x0300 => "HD_DEVICE_FAULT",
        0x0301 => "HD_DEVICE_ALREADY_INITIATED",
        0x0302 => "HD_COMM_ERROR",
        0x0303 => "HD_COMM_CONFIG_ERROR",
        0x0304 => "HD_TIMER_ERROR",
        0x0400 => "HD_ILLEGAL_BEGIN",
        0x0401 => "HD_ILLEGAL_END",
        0x0402 => "HD_FRAME_ERROR",
        0x0500 => "HD_INVALID_PRIORITY",
        0x0501 => "HD_SCHEDULER_FULL",
        0x0600 => "HD_INVALID_LICENSE",
        _ => "HD error",
    }
}

/// Whether an HD error is a force warning the run goes on through: the codes OpenHaptics'
/// `hduIsForceError` (its utility library, `hduError.cpp`, as published in public
/// repositories) calls recoverable: `HD_WARM_MOTORS`, `HD_EXCEEDED_MAX_FORCE`,
/// `HD_EXCEEDED_MAX_VELOCITY`, `HD_FORCE_ERROR`. The vendor's examples answer them by
/// resetting the contact and going on; every other error ends their callback.
pub const fn is_force_warning(code: u32) -> bool {
    matches!(code, 0x0200 | 0x0201 | 0x0203 | 0x0204)
}

/// Whether the servo's commands are stale at `now_ns`: none seen yet (`seen_at_ns` 0) or the
/// last new one older than `limit_ns`. A clock reading earlier than the stamp is not stale.
pub const fn command_stale(seen_at_ns: u64, now_ns: u64, limit_ns: u64) -> bool {
    seen_at_ns == 0 || now_ns.saturating_sub(seen_at_ns) > limit_ns
}

/// One callback frame at `now_ns` (the exchange's clock): take the servo's command, begin a
/// frame, read the device, apply the force (zero while the servo's commands are older than
/// [`STALL_LIMIT_NS`] or force is off), answer a calibration request, end the frame, pop the
/// errors (force warnings counted, any other error recorded as fatal: force output off and
/// the callback ends), publish the state.
///
/// # Bounded work
/// One frame of at most 12 HD calls plus [`MAX_ERRORS_PER_FRAME`] error pops, a calibration
/// check and update when one is asked for, and a few dozen atomic operations. Never blocks,
/// allocates or panics: it runs in the vendor's scheduler thread.
pub fn callback_frame<F: HdFrame + ?Sized>(hd: &mut F, x: &Exchange, now_ns: u64) -> CallbackCode {
    if x.stopped() {
        return CallbackCode::Done;
    }
    let stop = x.stop_requested();
    let cmd = x.command();
    let fresh = match cmd {
        Some(c) if c.count != 0 && c.count != x.seen_count.load(Relaxed) => {
            x.seen_count.store(c.count, Relaxed);
            x.seen_at_ns.store(now_ns, Relaxed);
            x.applied.write(&c.force.map(f64::to_bits));
            true
        }
        _ => false,
    };
    let stalled = !fresh && command_stale(x.seen_at_ns.load(Relaxed), now_ns, STALL_LIMIT_NS);
    if stalled && !x.stalled.load(Relaxed) && x.seen_count.load(Relaxed) != 0 {
        x.record_stall_trip();
    }
    x.stalled.store(stalled, Relaxed);
    // A torn read keeps the command applied last (the servo wrote at that very instant).
    let (force, enable) = match cmd {
        Some(c) => (c.force, c.enable),
        None => (
            x.applied.read().map_or([0.0; 3], |w| w.map(f64::from_bits)),
            x.output_on.load(Relaxed),
        ),
    };
    let enable = enable && !stop;

    hd.begin_frame();
    let position_mm = hd.position_mm();
    let transform = hd.transform();
    let buttons = hd.buttons();
    let inkwell = hd.inkwell();
    if enable != x.output_on.load(Relaxed) {
        hd.enable_force(enable);
        x.output_on.store(enable, Relaxed);
    }
    hd.set_force(if enable && !stalled { force } else { [0.0; 3] });
    let calibration = x.pending_calibration().map(|r| (r, calibrate(hd)));
    hd.end_frame();

    let mut fatal = None;
    for _ in 0..MAX_ERRORS_PER_FRAME {
        match hd.next_error() {
            None => break,
            Some(e) if is_force_warning(e.code) => x.record_warning(e.code),
            Some(e) => {
                fatal.get_or_insert(e);
            }
        }
    }
    if let Some((request, result)) = calibration {
        let result = match fatal {
            Some(e) => Calibrated::Code(e.code),
            None => result,
        };
        x.answer_calibration(request, result);
    }
    let frame = x.frames.fetch_add(1, Relaxed) + 1;
    x.post_state(&FrameState {
        position_mm,
        transform,
        buttons,
        inkwell,
        frame,
        at_ns: now_ns,
    });
    if let Some(e) = fatal {
        x.record_fatal(e);
    }
    if fatal.is_some() || stop {
        // Off outside a frame, as the vendor's examples do before they unschedule; errors
        // this raises are left on the stack for nobody: the callback ends here.
        hd.enable_force(false);
        x.output_on.store(false, Relaxed);
        x.mark_stopped();
        return CallbackCode::Done;
    }
    CallbackCode::Continue
}

/// Inside the frame: `hdCheckCalibration`, and when it needs an update, `hdUpdateCalibration`
/// with the first style the device supports of automatic, inkwell, encoder reset.
fn calibrate<F: HdFrame + ?Sized>(hd: &mut F) -> Calibrated {
    match hd.check_calibration() {
        HD_CALIBRATION_OK => Calibrated::Ok,
        HD_CALIBRATION_NEEDS_MANUAL_INPUT => Calibrated::NeedsInkwell,
        HD_CALIBRATION_NEEDS_UPDATE => {
            let styles = hd.calibration_styles();
            match [
                HD_CALIBRATION_AUTO,
                HD_CALIBRATION_INKWELL,
                HD_CALIBRATION_ENCODER_RESET,
            ]
            .into_iter()
            .find(|s| styles & s != 0)
            {
                Some(style) => {
                    hd.update_calibration(style);
                    Calibrated::Ok
                }
                None => Calibrated::Code(HD_INVALID_OPERATION),
            }
        }
        other => Calibrated::Code(other),
    }
}
