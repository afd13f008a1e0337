//! [`MotorCutoff`]: a second way to a device's motors, for a supervisor thread that zeroes the
//! force while the servo thread is stalled (blocked, spinning, descheduled), perhaps in the
//! middle of a call on the same device.
//!
//! A cutoff has two halves:
//! - a **latch** ([`Latch`]) the backend honours on its own write path: while it is set, every
//!   command the servo writes goes out as zero force with the motors off (and the safety
//!   filter is disabled, so the next enabled write after [`MotorCutoff::rearm`] ramps up from
//!   zero);
//! - a **direct zero**: [`MotorCutoff::cut`] sets the latch, then puts zero force with the
//!   motors off on the device through a path that does not need the servo thread: the
//!   simulated device's motors are shared atomics ([`crate::sim`]); the Falcon and the Omni send
//!   one motor packet through their transport's [`OutPath`].
//!
//! Ordering: the supervisor sets the latch before it sends its zero; the servo's write path
//! sends its packet, then looks at the latch again and sends a zero after it when the latch is
//! set. Whichever thread's packet reaches the transport last, the last one is a zero.
//!
//! Nothing here waits for the servo thread: an [`OutPath`] held by the servo right now answers
//! [`Cut::Busy`] and the supervisor tries again; the latch then zeroes the next servo write.
//! Everything on the servo's side is an atomic load or store: no lock, no allocation.

use core::fmt;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Arc;

use crate::device::DeviceError;

/// What a [`MotorCutoff::cut`] achieved.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Cut {
    /// Zero force with the motors off is on its way to the device (or already there).
    Done,
    /// The path to the motors is in use by the servo thread right now; the latch is set, so
    /// the servo's next write goes out as zero. Call again.
    Busy,
}

/// A second way to a device's motors, usable from any thread. See the module docs.
pub trait MotorCutoff: Send + Sync + fmt::Debug {
    /// Sets the latch, then puts zero force with the motors off on the device, without the
    /// servo thread. Never waits for it.
    ///
    /// # Errors
    /// The transport's error (e.g. [`DeviceError::Disconnected`]: the device is gone, so its
    /// motors are not driven either). The latch is set whatever happens.
    fn cut(&self) -> Result<Cut, DeviceError>;
    /// Whether the latch is set (the device renders zero).
    fn is_cut(&self) -> bool;
    /// Clears the latch. The servo calls it once it has written [`ForceCommand::OFF`]
    /// through its own path, so its filter ramps up from zero on the next enabled write.
    ///
    /// [`ForceCommand::OFF`]: crate::ForceCommand::OFF
    fn rearm(&self);
}

/// The force-off latch: set by a supervisor, cleared by the servo (sequentially consistent,
/// so a write path that looks at it after sending its own packet sees a cut that came before).
#[derive(Debug, Default)]
pub struct Latch(AtomicBool);

impl Latch {
    /// Sets the latch.
    pub fn set(&self) {
        self.0.store(true, Ordering::SeqCst);
    }

    /// Whether it is set.
    pub fn is_set(&self) -> bool {
        self.0.load(Ordering::SeqCst)
    }

    /// Clears the latch.
    pub fn clear(&self) {
        self.0.store(false, Ordering::SeqCst);
    }
}

/// A transport's second way to the motors: one motor packet sent from a thread that is not the
/// servo's, possibly while the servo is inside a call on the same transport.
pub trait OutPath: Send + Sync + fmt::Debug {
    /// Sends one motor packet (the backend's own format: a Falcon command frame, an Omni output
    /// packet). Never waits for the servo thread: [`Cut::Busy`] when it holds the path.
    ///
    /// # Errors
    /// The transport's error.
    fn send(&self, packet: &[u8; PACKET_LEN]) -> Result<Cut, DeviceError>;
}

/// Length of the motor packets an [`OutPath`] sends (the Falcon's command frame and the Omni's
/// output packet are both 16 bytes).
pub const PACKET_LEN: usize = 16;

/// A [`MotorCutoff`] over an [`OutPath`]: the latch and the zero packet the backend keeps up
/// to date (the Falcon's carries its LED and homing bits).
#[derive(Debug)]
pub struct PacketCutoff {
    latch: Latch,
    out: Arc<dyn OutPath>,
    zero: [AtomicU64; 2],
}

impl PacketCutoff {
    /// A cutoff sending `zero` through `out`.
    pub fn new(out: Arc<dyn OutPath>, zero: &[u8; PACKET_LEN]) -> PacketCutoff {
        let c = PacketCutoff {
            latch: Latch::default(),
            out,
            zero: [AtomicU64::new(0), AtomicU64::new(0)],
        };
        c.set_zero_packet(zero);
        c
    }

    /// Replaces the zero packet (an atomic store of each half: callable on the servo path).
    pub fn set_zero_packet(&self, zero: &[u8; PACKET_LEN]) {
        for (half, slot) in zero.chunks_exact(8).zip(&self.zero) {
            let mut b = [0u8; 8];
            b.copy_from_slice(half);
            slot.store(u64::from_le_bytes(b), Ordering::Relaxed);
        }
    }

    /// The zero packet.
    pub fn zero_packet(&self) -> [u8; PACKET_LEN] {
        let mut p = [0u8; PACKET_LEN];
        for (half, slot) in p.chunks_exact_mut(8).zip(&self.zero) {
            half.copy_from_slice(&slot.load(Ordering::Relaxed).to_le_bytes());
        }
        p
    }
}

impl MotorCutoff for PacketCutoff {
    fn cut(&self) -> Result<Cut, DeviceError> {
        self.latch.set();
        self.out.send(&self.zero_packet())
    }

    fn is_cut(&self) -> bool {
        self.latch.is_set()
    }

    fn rearm(&self) {
        self.latch.clear();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::Mutex;

    #[derive(Debug, Default)]
    struct Recorder(Mutex<Vec<[u8; PACKET_LEN]>>);

    impl OutPath for Recorder {
        fn send(&self, packet: &[u8; PACKET_LEN]) -> Result<Cut, DeviceError> {
            self.0.lock().expect("recorder").push(*packet);
            Ok(Cut::Done)
        }
    }

    #[test]
    fn a_cut_sets_the_latch_and_sends_the_current_zero_packet() {
        let rec = Arc::new(Recorder::default());
        let first: [u8; PACKET_LEN] = core::array::from_fn(|i| i as u8);
        let c = PacketCutoff::new(rec.clone(), &first);
        assert!(!c.is_cut());
        let second: [u8; PACKET_LEN] = core::array::from_fn(|i| 200 - i as u8);
        c.set_zero_packet(&second);
        assert_eq!(c.cut(), Ok(Cut::Done));
        assert!(c.is_cut());
        assert_eq!(*rec.0.lock().expect("recorder"), vec![second]);
        c.rearm();
        assert!(!c.is_cut());
    }
}
