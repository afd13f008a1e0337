//! A scripted HD library for tests: a stylus at a set position, every force set recorded,
//! errors injected at chosen frames. Its "scheduler" has no thread: [`HdLibrary::pump`] runs
//! one callback frame each servo read, so a test is deterministic; the threaded path (the
//! vendor scheduler's own thread) is tested through the loader and a C stand-in library.

use std::sync::Arc;

use super::exchange::{Exchange, HdError};
use super::frame::{callback_frame, CallbackCode, HdFrame, HD_CALIBRATION_OK};
use super::HdLibrary;
use crate::device::DeviceError;

/// One call the callback made, in order (for checks of the frame discipline).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum MockCall {
    /// `hdBeginFrame`, and whether it came from inside the scheduler's callback.
    Begin {
        /// Made by the callback.
        in_callback: bool,
    },
    /// `hdEndFrame`.
    End,
    /// `hdSetDoublev(HD_CURRENT_FORCE)` while a frame was open (`true`) or not.
    SetForce {
        /// A frame was open.
        in_frame: bool,
    },
}

/// The scripted library.
#[derive(Debug)]
pub struct MockHdLibrary {
    /// Position returned by the next reads, mm.
    pub position_mm: [f64; 3],
    /// Buttons returned.
    pub buttons: u32,
    /// The inkwell switch (`true`: docked).
    pub inkwell: bool,
    /// Every force set, N.
    pub forces: Vec<[f64; 3]>,
    /// Force output enabled.
    pub force_enabled: bool,
    /// Frames begun and not ended.
    pub open_frames: i32,
    /// From this frame on, every frame raises `HD_COMM_ERROR` (the device unplugged).
    pub fail_after_frames: Option<usize>,
    /// Errors to raise in a frame: (frame number, 1-based, code).
    pub raise: Vec<(usize, u32)>,
    /// What `hdCheckCalibration` answers.
    pub calibration_status: u32,
    /// Calibration updates made, with their style.
    pub calibration_updates: Vec<u32>,
    /// Not installed: `init` fails with `LibraryNotFound`.
    pub missing: bool,
    /// No scheduler: `pump` runs nothing (a library whose callback never runs).
    pub no_scheduler: bool,
    /// The calls of every frame, in order.
    pub calls: Vec<MockCall>,
    /// Frames begun.
    pub frames: usize,
    pub(crate) errors: Vec<HdError>,
    pub(crate) in_callback: bool,
    pub(crate) exchange: Option<Arc<Exchange>>,
}

impl Default for MockHdLibrary {
    fn default() -> MockHdLibrary {
        MockHdLibrary {
            position_mm: [0.0; 3],
            buttons: 0,
            inkwell: false,
            forces: Vec::new(),
            force_enabled: false,
            open_frames: 0,
            fail_after_frames: None,
            raise: Vec::new(),
            calibration_status: HD_CALIBRATION_OK,
            calibration_updates: Vec::new(),
            missing: false,
            no_scheduler: false,
            calls: Vec::new(),
            frames: 0,
            errors: Vec::new(),
            in_callback: false,
            exchange: None,
        }
    }
}

impl MockHdLibrary {
    /// Runs the scheduled callback once at `now_ns` (the exchange's clock), as the vendor
    /// scheduler would; `None` when nothing is scheduled.
    pub fn run_callback(&mut self, now_ns: u64) -> Option<CallbackCode> {
        let x = self.exchange.clone()?;
        self.in_callback = true;
        let code = callback_frame(self, &x, now_ns);
        self.in_callback = false;
        Some(code)
    }

    /// The exchange the device scheduled, once it has.
    pub fn exchange(&self) -> Option<&Arc<Exchange>> {
        self.exchange.as_ref()
    }
}

impl HdLibrary for MockHdLibrary {
    fn init(&mut self, _name: Option<&str>) -> Result<(), DeviceError> {
        if self.missing {
            Err(DeviceError::LibraryNotFound)
        } else {
            Ok(())
        }
    }

    fn schedule(&mut self, exchange: Arc<Exchange>) -> Result<(), DeviceError> {
        self.exchange = Some(exchange);
        Ok(())
    }

    fn pump(&mut self) {
        if self.no_scheduler {
            return;
        }
        if let Some(now) = self.exchange.as_ref().map(|x| x.now_ns()) {
            self.run_callback(now);
        }
    }
}

impl HdFrame for MockHdLibrary {
    fn begin_frame(&mut self) {
        self.calls.push(MockCall::Begin {
            in_callback: self.in_callback,
        });
        self.frames += 1;
        self.open_frames += 1;
        if self.fail_after_frames.is_some_and(|n| self.frames > n) {
            self.errors.push(HdError {
                code: 0x0302,
                internal: 0,
            });
        }
        let f = self.frames;
        let raised: Vec<u32> = self
            .raise
            .iter()
            .filter(|(n, _)| *n == f)
            .map(|(_, c)| *c)
            .collect();
        for code in raised {
            self.errors.push(HdError { code, internal: 0 });
        }
    }
    fn end_frame(&mut self) {
        self.calls.push(MockCall::End);
        self.open_frames -= 1;
    }
    fn position_mm(&mut self) -> [f64; 3] {
        self.position_mm
    }
    fn transform(&mut self) -> [f64; 16] {
        let p = self.position_mm;
        [
            1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, p[0], p[1], p[2], 1.0,
        ]
    }
    fn buttons(&mut self) -> u32 {
        self.buttons
    }
    fn inkwell(&mut self) -> bool {
        self.inkwell
    }
    fn set_force(&mut self, force: [f64; 3]) {
        self.calls.push(MockCall::SetForce {
            in_frame: self.open_frames > 0,
        });
        self.forces.push(force);
    }
    fn enable_force(&mut self, on: bool) {
        self.force_enabled = on;
    }
    fn calibration_styles(&mut self) -> u32 {
        super::frame::HD_CALIBRATION_INKWELL | super::frame::HD_CALIBRATION_ENCODER_RESET
    }
    fn check_calibration(&mut self) -> u32 {
        self.calibration_status
    }
    fn update_calibration(&mut self, style: u32) {
        self.calibration_updates.push(style);
        self.calibration_status = HD_CALIBRATION_OK;
    }
    fn next_error(&mut self) -> Option<HdError> {
        self.errors.pop()
    }
}
