//! The lock-free hand-over between the servo thread and the HD scheduler's callback.
//!
//! Two single-writer slots ([`Slot`], a sequence lock over atomics): the servo writes the
//! force command, the callback writes the device's state after each frame. Neither side ever
//! waits on the other: a writer stores and moves on; a reader that finds a write in progress
//! retries a bounded number of times and otherwise keeps what it read last. The counters next
//! to the slots (stall trips, warnings, the error that ended the callback) are plain atomics.

use std::sync::atomic::{fence, AtomicBool, AtomicU32, AtomicU64, Ordering};
use std::time::Instant;

/// How often a reader retries a slot whose writer was busy before it keeps its last value.
/// A write is a few dozen stores, so a second try almost always succeeds.
pub const READ_TRIES: usize = 8;

/// A single-writer, many-reader slot of `N` words: a sequence lock over atomics (no `unsafe`,
/// no lock). The sequence is odd while a write is under way.
///
/// # Bounded work
/// A write is `N + 2` atomic stores; a read at most [`READ_TRIES`] passes of `N + 2` loads.
#[derive(Debug)]
pub struct Slot<const N: usize> {
    seq: AtomicU64,
    words: [AtomicU64; N],
}

impl<const N: usize> Default for Slot<N> {
    fn default() -> Slot<N> {
        Slot {
            seq: AtomicU64::new(0),
            words: std::array::from_fn(|_| AtomicU64::new(0)),
        }
    }
}

impl<const N: usize> Slot<N> {
    /// Publishes `words`. Only one thread may write a slot (the servo the command, the
    /// callback the state); readers see the whole of one write or retry.
    pub fn write(&self, words: &[u64; N]) {
        let s = self.seq.load(Ordering::Relaxed);
        self.seq.store(s.wrapping_add(1), Ordering::Relaxed);
        fence(Ordering::Release);
        for (a, w) in self.words.iter().zip(words) {
            a.store(*w, Ordering::Relaxed);
        }
        self.seq.store(s.wrapping_add(2), Ordering::Release);
    }

    /// The last complete write, or `None` when every one of [`READ_TRIES`] tries met a write
    /// under way (the caller keeps its previous value). All zeros before the first write.
    pub fn read(&self) -> Option<[u64; N]> {
        for _ in 0..READ_TRIES {
            let s1 = self.seq.load(Ordering::Acquire);
            if s1 & 1 == 1 {
                std::hint::spin_loop();
                continue;
            }
            let mut out = [0u64; N];
            for (o, a) in out.iter_mut().zip(&self.words) {
                *o = a.load(Ordering::Relaxed);
            }
            fence(Ordering::Acquire);
            if self.seq.load(Ordering::Relaxed) == s1 {
                return Some(out);
            }
        }
        None
    }
}

/// The servo's force command as the callback reads it.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Command {
    /// Force, N, device frame (already clamped and ramped by the servo's safety filter).
    pub force: [f64; 3],
    /// Force output on (`hdEnable(HD_FORCE_OUTPUT)`).
    pub enable: bool,
    /// Commands written so far: the servo's heartbeat as the callback sees it (0: none yet).
    pub count: u64,
}

impl Command {
    fn words(&self) -> [u64; 5] {
        [
            self.force[0].to_bits(),
            self.force[1].to_bits(),
            self.force[2].to_bits(),
            u64::from(self.enable),
            self.count,
        ]
    }

    fn from_words(w: &[u64; 5]) -> Command {
        Command {
            force: [
                f64::from_bits(w[0]),
                f64::from_bits(w[1]),
                f64::from_bits(w[2]),
            ],
            enable: w[3] != 0,
            count: w[4],
        }
    }
}

/// The device's state after one of the callback's frames.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FrameState {
    /// `HD_CURRENT_POSITION`, mm.
    pub position_mm: [f64; 3],
    /// `HD_CURRENT_TRANSFORM`, column-major, translation in mm.
    pub transform: [f64; 16],
    /// `HD_CURRENT_BUTTONS`.
    pub buttons: u32,
    /// The stylus sits in its inkwell.
    pub inkwell: bool,
    /// Frames the callback has completed, this one included (0: none yet).
    pub frame: u64,
    /// When the frame ended, ns on the exchange's clock ([`Exchange::now_ns`]).
    pub at_ns: u64,
}

const STATE_WORDS: usize = 3 + 16 + 3;

impl FrameState {
    fn words(&self) -> [u64; STATE_WORDS] {
        let mut w = [0u64; STATE_WORDS];
        for (o, v) in w
            .iter_mut()
            .zip(self.position_mm.iter().chain(&self.transform))
        {
            *o = v.to_bits();
        }
        w[19] = u64::from(self.buttons) | (u64::from(self.inkwell) << 32);
        w[20] = self.frame;
        w[21] = self.at_ns;
        w
    }

    fn from_words(w: &[u64; STATE_WORDS]) -> FrameState {
        let mut s = FrameState::default();
        for (v, b) in s
            .position_mm
            .iter_mut()
            .chain(s.transform.iter_mut())
            .zip(w)
        {
            *v = f64::from_bits(*b);
        }
        s.buttons = w[19] as u32;
        s.inkwell = (w[19] >> 32) & 1 == 1;
        s.frame = w[20];
        s.at_ns = w[21];
        s
    }
}

/// An HD error as `hdGetError` reports it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct HdError {
    /// The `HD_*` code.
    pub code: u32,
    /// The device's own code.
    pub internal: i32,
}

/// What a calibration request came to, as the callback reports it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Calibrated {
    /// `HD_CALIBRATION_OK`, or updated with one of the device's styles.
    Ok,
    /// `HD_CALIBRATION_NEEDS_MANUAL_INPUT`: the stylus must go in its inkwell.
    NeedsInkwell,
    /// The library answered with this code (an HD error, or a status it should not give).
    Code(u32),
}

impl Calibrated {
    fn word(self, request: u64) -> u64 {
        let v = match self {
            Calibrated::Ok => 1,
            Calibrated::NeedsInkwell => 2,
            Calibrated::Code(c) => 3 | (u64::from(c) << 8),
        };
        (request << 40) | v
    }

    fn from_word(w: u64) -> (u64, Option<Calibrated>) {
        let v = w & ((1 << 40) - 1);
        let r = match v & 0xff {
            1 => Some(Calibrated::Ok),
            2 => Some(Calibrated::NeedsInkwell),
            3 => Some(Calibrated::Code((v >> 8) as u32)),
            _ => None,
        };
        (w >> 40, r)
    }
}

/// Everything the servo thread and the scheduler's callback share: the two slots, the
/// callback's own bookkeeping (atomics it alone writes), and the counters both read.
#[derive(Debug)]
pub struct Exchange {
    origin: Instant,
    command: Slot<5>,
    state: Slot<STATE_WORDS>,
    // Written by the callback only.
    pub(crate) seen_count: AtomicU64,
    pub(crate) seen_at_ns: AtomicU64,
    pub(crate) stalled: AtomicBool,
    pub(crate) output_on: AtomicBool,
    pub(crate) applied: Slot<3>,
    pub(crate) frames: AtomicU64,
    stall_trips: AtomicU64,
    warnings: AtomicU64,
    last_warning: AtomicU32,
    /// The error that ended the callback: `code << 32 | internal as u32`, plus one bit so a
    /// zero code still reads as set (0: none).
    fatal: AtomicU64,
    stopped: AtomicBool,
    stop: AtomicBool,
    calibration_request: AtomicU64,
    calibration_result: AtomicU64,
}

impl Default for Exchange {
    fn default() -> Exchange {
        Exchange::new()
    }
}

const FATAL_SET: u64 = 1 << 63;

impl Exchange {
    /// An exchange with no command, no frame and a clock starting now.
    pub fn new() -> Exchange {
        Exchange {
            origin: Instant::now(),
            command: Slot::default(),
            state: Slot::default(),
            seen_count: AtomicU64::new(0),
            seen_at_ns: AtomicU64::new(0),
            stalled: AtomicBool::new(false),
            output_on: AtomicBool::new(false),
            applied: Slot::default(),
            frames: AtomicU64::new(0),
            stall_trips: AtomicU64::new(0),
            warnings: AtomicU64::new(0),
            last_warning: AtomicU32::new(0),
            fatal: AtomicU64::new(0),
            stopped: AtomicBool::new(false),
            stop: AtomicBool::new(false),
            calibration_request: AtomicU64::new(0),
            calibration_result: AtomicU64::new(0),
        }
    }

    /// Now on the exchange's monotonic clock, ns, at least 1. The callback stamps its frames
    /// with it and measures the servo's silence with it: one thread's clock, no skew.
    pub fn now_ns(&self) -> u64 {
        u64::try_from(self.origin.elapsed().as_nanos())
            .unwrap_or(u64::MAX - 1)
            .saturating_add(1)
    }

    /// The servo: publishes its command (the force it wants now).
    pub fn post_command(&self, command: &Command) {
        self.command.write(&command.words());
    }

    /// The callback: the servo's last command (`None`: the servo was writing; keep the last).
    pub fn command(&self) -> Option<Command> {
        self.command.read().map(|w| Command::from_words(&w))
    }

    /// The callback: publishes the state of the frame it just ended.
    pub fn post_state(&self, state: &FrameState) {
        self.state.write(&state.words());
    }

    /// The servo: the last frame's state (`None`: the callback was writing; keep the last).
    pub fn state(&self) -> Option<FrameState> {
        self.state.read().map(|w| FrameState::from_words(&w))
    }

    /// Times the callback zeroed the force because the servo's commands stopped coming.
    pub fn stall_trips(&self) -> u64 {
        self.stall_trips.load(Ordering::Acquire)
    }

    pub(crate) fn record_stall_trip(&self) {
        self.stall_trips.fetch_add(1, Ordering::AcqRel);
    }

    /// Force warnings the library reported (`HD_WARM_MOTORS` and the other errors OpenHaptics'
    /// `hduIsForceError` names); the run goes on through them.
    pub fn warnings(&self) -> u64 {
        self.warnings.load(Ordering::Acquire)
    }

    /// The code of the last warning (0: none).
    pub fn last_warning(&self) -> u32 {
        self.last_warning.load(Ordering::Acquire)
    }

    pub(crate) fn record_warning(&self, code: u32) {
        self.last_warning.store(code, Ordering::Release);
        self.warnings.fetch_add(1, Ordering::AcqRel);
    }

    /// The error that ended the callback (and so the run), if one did.
    pub fn fatal(&self) -> Option<HdError> {
        let w = self.fatal.load(Ordering::Acquire);
        (w & FATAL_SET != 0).then_some(HdError {
            code: ((w >> 32) as u32) & 0x7fff_ffff,
            internal: w as u32 as i32,
        })
    }

    pub(crate) fn record_fatal(&self, e: HdError) {
        let w = FATAL_SET | (u64::from(e.code & 0x7fff_ffff) << 32) | u64::from(e.internal as u32);
        // The first error is the one to report.
        let _ = self
            .fatal
            .compare_exchange(0, w, Ordering::AcqRel, Ordering::Acquire);
    }

    /// Asks the callback to zero the force, turn force output off and end.
    pub fn request_stop(&self) {
        self.stop.store(true, Ordering::Release);
    }

    pub(crate) fn stop_requested(&self) -> bool {
        self.stop.load(Ordering::Acquire)
    }

    /// The callback has ended (stopped on request or by an error): no frame follows.
    pub fn stopped(&self) -> bool {
        self.stopped.load(Ordering::Acquire)
    }

    pub(crate) fn mark_stopped(&self) {
        self.stopped.store(true, Ordering::Release);
    }

    /// The servo: asks for a calibration check in the callback's next frame; returns the
    /// request's number for [`calibration`](Self::calibration).
    pub fn request_calibration(&self) -> u64 {
        self.calibration_request.fetch_add(1, Ordering::AcqRel) + 1
    }

    /// The callback: the calibration request not answered yet, if any.
    pub(crate) fn pending_calibration(&self) -> Option<u64> {
        let asked = self.calibration_request.load(Ordering::Acquire);
        let (answered, _) = Calibrated::from_word(self.calibration_result.load(Ordering::Acquire));
        (asked > answered).then_some(asked)
    }

    pub(crate) fn answer_calibration(&self, request: u64, result: Calibrated) {
        self.calibration_result
            .store(result.word(request), Ordering::Release);
    }

    /// The answer to calibration request `request`, once the callback has given it.
    pub fn calibration(&self, request: u64) -> Option<Calibrated> {
        let (answered, r) = Calibrated::from_word(self.calibration_result.load(Ordering::Acquire));
        if answered >= request {
            r
        } else {
            None
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::Arc;

    #[test]
    fn a_reader_never_sees_half_a_write() {
        // One writer stores words that are all equal; a reader on another thread must only
        // ever see all-equal words.
        let slot = Arc::new(Slot::<16>::default());
        let w = Arc::clone(&slot);
        let writer = std::thread::spawn(move || {
            for i in 1..=200_000u64 {
                w.write(&[i; 16]);
            }
        });
        let mut seen = 0u64;
        let mut last = 0u64;
        while !writer.is_finished() || seen == 0 {
            if let Some(words) = slot.read() {
                assert!(words.iter().all(|x| *x == words[0]), "torn: {words:?}");
                assert!(words[0] >= last, "went back: {} after {last}", words[0]);
                last = words[0];
                seen += 1;
            }
        }
        writer.join().expect("writer");
        assert_eq!(slot.read(), Some([200_000; 16]));
    }

    #[test]
    fn words_round_trip() {
        let c = Command {
            force: [1.5, -0.0, f64::MIN_POSITIVE],
            enable: true,
            count: 7,
        };
        assert_eq!(Command::from_words(&c.words()), c);
        let s = FrameState {
            position_mm: [1.0, 2.0, -3.0],
            transform: std::array::from_fn(|i| i as f64 * 0.5),
            buttons: 0xffff_ffff,
            inkwell: true,
            frame: 9,
            at_ns: 123,
        };
        assert_eq!(FrameState::from_words(&s.words()), s);
        let x = Exchange::new();
        assert_eq!(x.fatal(), None);
        x.record_fatal(HdError {
            code: 0,
            internal: -5,
        });
        x.record_fatal(HdError {
            code: 0x0302,
            internal: 1,
        });
        assert_eq!(
            x.fatal(),
            Some(HdError {
                code: 0,
                internal: -5
            }),
            "the first error stays, a zero code included"
        );
        let r = x.request_calibration();
        assert_eq!(x.pending_calibration(), Some(r));
        assert_eq!(x.calibration(r), None);
        x.answer_calibration(r, Calibrated::Code(0x0102));
        assert_eq!(x.pending_calibration(), None);
        assert_eq!(x.calibration(r), Some(Calibrated::Code(0x0102)));
    }
}
