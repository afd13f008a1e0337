//! Two rates without a lock: the simulation publishes each step's contact into a
//! [`ContactHandoff`], and a [`Servo`] at the higher rate reads the newest one and reports its
//! force back, each side free to preempt the other (two threads, or a timer interrupt over a
//! background loop).
//!
//! The hand-off is two slots, each a sequence lock over atomic words: the simulation writes
//! the slot the servo is not pointed at, then points the servo at it. A servo that preempts
//! the simulation (an interrupt on the same core) always finds the slot it is pointed at
//! complete; a servo on another core that is overtaken twice while it reads sees the sequence
//! change and reads again, a bounded number of times, and keeps the contact it had when every
//! try was overtaken (counted, [`Servo::stale_reads`]). Every access is atomic, so there is no
//! data race whatever the interleaving, and no `unsafe`.
//!
//! The other way, the servo leaves the magnitude of its last force and a count of its ticks,
//! which the simulation turns into the pressing force of its next step
//! ([`ContactHandoff::pressing`], [`super::World::set_pressing`]).
//!
//! A drill's step hands over its burr's contact and its shaft's planes together, through a
//! [`super::DrillHandoff`] over the same two slots (`drill_handoff.rs`).
//!
//! One publisher and one servo at a time: the roles are the caller's to keep (two publishers
//! at once could hand the servo a contact mixed of both; nothing worse).

use core::sync::atomic::{fence, AtomicU32, Ordering};

use glam::Vec3;

use super::force::servo_force;
use super::{ContactState, VibrationCue};
use crate::force::{penalty_storage, ForceDigest, ForceParams, Storage, ToolState};

/// Words of a published contact: `valid`, point, normal, depth, centre, triangles, stiffness,
/// the vibration's frequency, amplitude and threshold, the friction, and the step's number.
pub(crate) const WORDS: usize = 18;

/// How many times [`ContactHandoff::latest`] reads a slot the publisher overtook before it
/// gives up for this tick.
pub const HANDOFF_TRIES: u32 = 4;

/// One sequence-locked copy of `N` words and the number of the write that made them: `seq`
/// is odd while they are written.
#[derive(Debug)]
struct Slot<const N: usize> {
    seq: AtomicU32,
    step: AtomicU32,
    words: [AtomicU32; N],
}

impl<const N: usize> Slot<N> {
    const fn new() -> Self {
        Self {
            seq: AtomicU32::new(0),
            step: AtomicU32::new(0),
            words: [const { AtomicU32::new(0) }; N],
        }
    }
}

/// Two sequence-locked slots of `N` words and the one the reader is pointed at: the lock-free
/// core of [`ContactHandoff`] and `super::DrillHandoff` (module docs). One writer and one
/// reader at a time; all zeros is empty.
#[derive(Debug)]
pub(crate) struct SeqPair<const N: usize> {
    slots: [Slot<N>; 2],
    /// The slot the reader reads (the newest complete one).
    newest: AtomicU32,
    /// Writes done.
    steps: AtomicU32,
    /// The number of the write the reader returned last: a read never goes back to an older
    /// one (the reader's own; one reader).
    seen: AtomicU32,
}

impl<const N: usize> SeqPair<N> {
    /// Empty: nothing written.
    pub(crate) const fn new() -> Self {
        Self {
            slots: [Slot::new(), Slot::new()],
            newest: AtomicU32::new(0),
            steps: AtomicU32::new(0),
            seen: AtomicU32::new(0),
        }
    }

    /// Writes `word(i, step)` for each `i < N` into the slot the reader is not pointed at,
    /// then points the reader at it; returns the write's number `step` (1 for the first).
    ///
    /// # Bounded work
    /// Constant: `N` word stores and the switch. Never waits.
    pub(crate) fn publish(&self, mut word: impl FnMut(usize, u32) -> u32) -> u32 {
        let step = self.steps.load(Ordering::Relaxed).wrapping_add(1);
        let next = (self.newest.load(Ordering::Relaxed) ^ 1) & 1;
        let slot = &self.slots[next as usize];
        let seq = slot.seq.load(Ordering::Relaxed);
        slot.seq.store(seq.wrapping_add(1), Ordering::Relaxed);
        // The odd sequence is ordered before the words: a reader that sees any new word sees
        // the odd (or a later) sequence on its second look.
        fence(Ordering::Release);
        for (i, w) in slot.words.iter().enumerate() {
            w.store(word(i, step), Ordering::Relaxed);
        }
        slot.step.store(step, Ordering::Relaxed);
        slot.seq.store(seq.wrapping_add(2), Ordering::Release);
        self.steps.store(step, Ordering::Relaxed);
        self.newest.store(next, Ordering::Release);
        step
    }

    /// The newest complete words into `out`, `true`; `false` (and `out` not meaningful) when
    /// every one of [`HANDOFF_TRIES`] reads was overtaken by the writer (only possible when
    /// the two run on different cores). Before the first write: all zeros.
    ///
    /// # Bounded work
    /// At most [`HANDOFF_TRIES`] reads of `N` words. Never waits.
    ///
    /// A read never returns an older write than the one before it: on another core the reader
    /// may load the pointer before the writer moves it twice, find the slot it points at
    /// already holding the newer write, and on its next read load the pointer as it was in
    /// between, at the slot holding the write before. Each slot carries its write's number,
    /// and a read that would go back counts as overtaken.
    pub(crate) fn latest(&self, out: &mut [u32; N]) -> bool {
        let seen = self.seen.load(Ordering::Relaxed);
        for _ in 0..HANDOFF_TRIES {
            let slot = &self.slots[(self.newest.load(Ordering::Acquire) & 1) as usize];
            let before = slot.seq.load(Ordering::Acquire);
            if before & 1 != 0 {
                continue;
            }
            for (v, w) in out.iter_mut().zip(&slot.words) {
                *v = w.load(Ordering::Relaxed);
            }
            let step = slot.step.load(Ordering::Relaxed);
            // The words are read before the second look at the sequence.
            fence(Ordering::Acquire);
            if slot.seq.load(Ordering::Relaxed) == before {
                // Wrapping order: older when `seen` is less than 2^31 ahead of `step`.
                if (seen.wrapping_sub(step) as i32) > 0 {
                    continue;
                }
                self.seen.store(step, Ordering::Relaxed);
                return true;
            }
        }
        false
    }
}

/// A contact as the servo receives it: the simulation step's [`ContactState`] and that step's
/// number (1 for the first published; 0 for none yet).
#[derive(Clone, Copy, PartialEq, Debug, Default)]
pub struct Published {
    /// The step's contact.
    pub contact: ContactState,
    /// The step's number, counted by the publisher from 1.
    pub step: u32,
}

impl Published {
    pub(crate) fn to_words(self) -> [u32; WORDS] {
        let c = &self.contact;
        [
            u32::from(c.valid),
            c.point.x.to_bits(),
            c.point.y.to_bits(),
            c.point.z.to_bits(),
            c.normal.x.to_bits(),
            c.normal.y.to_bits(),
            c.normal.z.to_bits(),
            c.depth.to_bits(),
            c.centre.x.to_bits(),
            c.centre.y.to_bits(),
            c.centre.z.to_bits(),
            c.triangles,
            c.stiffness.to_bits(),
            c.vibration.hz.to_bits(),
            c.vibration.amplitude.to_bits(),
            c.vibration.threshold.to_bits(),
            c.friction.to_bits(),
            self.step,
        ]
    }

    pub(crate) fn from_words(w: [u32; WORDS]) -> Self {
        let f = |i: usize| f32::from_bits(w[i]);
        let v = |i: usize| Vec3::new(f(i), f(i + 1), f(i + 2));
        Self {
            contact: ContactState {
                valid: w[0] != 0,
                point: v(1),
                normal: v(4),
                depth: f(7),
                centre: v(8),
                triangles: w[11],
                stiffness: f(12),
                vibration: VibrationCue {
                    hz: f(13),
                    amplitude: f(14),
                    threshold: f(15),
                },
                friction: f(16),
            },
            step: w[17],
        }
    }
}

/// The lock-free hand-off between a simulation step and the servo (module docs).
///
/// All zeros is a valid empty hand-off (no contact, no servo tick), so memory cleared by the
/// start-up code or [`ContactHandoff::new`] both do.
///
/// ```
/// use tetradrill_core::force::ForceParams;
/// use tetradrill_core::servo::{ContactHandoff, ContactState, Servo};
/// use tetradrill_core::Vec3;
///
/// static HANDOFF: ContactHandoff = ContactHandoff::new();
/// let mut servo = Servo::new(0.1, ForceParams::default());
/// std::thread::scope(|s| {
///     // The simulation's side: a step's contact, a plane 0.02 into the burr.
///     s.spawn(|| {
///         let plane = ContactState { valid: true, normal: Vec3::Z, ..Default::default() };
///         HANDOFF.publish(&plane);
///     });
/// });
/// // The servo's side, at its own rate: the force from the newest contact.
/// let f = servo.tick(&HANDOFF, Vec3::new(0.0, 0.0, 0.08));
/// assert_eq!(servo.step(), 1);
/// assert!(f.z > 0.0, "pushed out of the material");
/// // And back: the step learns how hard the burr pressed, for how many servo ticks.
/// let mut seen = 0;
/// assert_eq!(HANDOFF.pressing(&mut seen), Some((f.length(), 1)));
/// ```
#[derive(Debug)]
pub struct ContactHandoff {
    /// The published contacts.
    pair: SeqPair<WORDS>,
    /// Bits of the magnitude of the servo's last force, newtons.
    force: AtomicU32,
    /// Servo ticks reported (wrapping).
    ticks: AtomicU32,
}

impl Default for ContactHandoff {
    fn default() -> Self {
        Self::new()
    }
}

impl ContactHandoff {
    /// An empty hand-off: no contact published, no servo tick.
    pub const fn new() -> Self {
        Self {
            pair: SeqPair::new(),
            force: AtomicU32::new(0),
            ticks: AtomicU32::new(0),
        }
    }

    /// Publishes a step's contact; returns its step number (1 for the first).
    ///
    /// # Bounded work
    /// Constant: 14 word stores into the slot the servo is not reading, then the switch.
    /// Never waits. One publisher at a time (module docs).
    pub fn publish(&self, contact: &ContactState) -> u32 {
        // The contact's words once; the last is the step's number.
        let words = Published {
            contact: *contact,
            step: 0,
        }
        .to_words();
        self.pair.publish(|i, step| {
            if i + 1 == WORDS {
                step
            } else {
                words.get(i).copied().unwrap_or(0)
            }
        })
    }

    /// The newest published contact, or `None` when every one of [`HANDOFF_TRIES`] reads was
    /// overtaken by the publisher (only possible when the two run on different cores). Before
    /// the first publish: the empty contact of step 0.
    ///
    /// # Bounded work
    /// At most [`HANDOFF_TRIES`] reads of 18 words. Never waits.
    pub fn latest(&self) -> Option<Published> {
        let mut words = [0; WORDS];
        self.pair
            .latest(&mut words)
            .then(|| Published::from_words(words))
    }

    /// The servo's side: leaves the magnitude of the force it just rendered and counts the
    /// tick.
    ///
    /// # Bounded work
    /// Constant. One servo at a time (module docs).
    pub fn report_force(&self, force: Vec3) {
        self.force
            .store(force.length().to_bits(), Ordering::Relaxed);
        let t = self.ticks.load(Ordering::Relaxed).wrapping_add(1);
        self.ticks.store(t, Ordering::Release);
    }

    /// The simulation's side: the servo's last force magnitude (newtons) and the servo ticks
    /// since `seen`, which is moved to now; `None` when the servo has not ticked since.
    /// [`super::World::set_pressing`] with the force for `ticks * dt` seconds feeds the
    /// materials as a single-task replay does.
    ///
    /// The two values are read one after the other: a servo tick between the reads gives
    /// the newer force with the older count (off by one tick, caught up at the next call).
    ///
    /// # Bounded work
    /// Constant.
    pub fn pressing(&self, seen: &mut u32) -> Option<(f32, u32)> {
        let now = self.ticks.load(Ordering::Acquire);
        let ticks = now.wrapping_sub(*seen);
        if ticks == 0 {
            return None;
        }
        *seen = now;
        Some((f32::from_bits(self.force.load(Ordering::Relaxed)), ticks))
    }
}

/// The servo's own state for a spherical burr fed through a [`ContactHandoff`]: the contact
/// it renders from, the tool state between ticks, the force settings and the digest of what
/// it rendered.
#[derive(Clone, Copy, Debug)]
pub struct Servo {
    contact: ContactState,
    step: u32,
    tool: ToolState,
    params: ForceParams,
    radius: f32,
    digest: ForceDigest,
    ticks: u64,
    contact_ticks: u64,
    stale_reads: u64,
}

impl Servo {
    /// A servo for a burr of `radius` with the force settings `params`, no contact yet.
    pub fn new(radius: f32, params: ForceParams) -> Self {
        Self {
            contact: ContactState::default(),
            step: 0,
            tool: ToolState::default(),
            params,
            radius,
            digest: ForceDigest::default(),
            ticks: 0,
            contact_ticks: 0,
            stale_reads: 0,
        }
    }

    /// One servo tick: takes the newest contact from `handoff` (or keeps the last one when
    /// every read was overtaken, counted), the force at `centre` from it ([`servo_force`]),
    /// reported back through `handoff` and added to the digest.
    ///
    /// # Bounded work
    /// Constant: [`ContactHandoff::latest`] and [`servo_force`]. Never waits, allocates or
    /// panics; a non-finite `centre` gives zero force.
    pub fn tick(&mut self, handoff: &ContactHandoff, centre: Vec3) -> Vec3 {
        match handoff.latest() {
            Some(p) => {
                self.contact = p.contact;
                self.step = p.step;
            }
            None => self.stale_reads += 1,
        }
        let f = servo_force(
            &self.contact,
            centre,
            self.radius,
            &mut self.tool,
            &self.params,
        );
        handoff.report_force(f);
        self.digest.push(f);
        self.ticks += 1;
        if f != Vec3::ZERO {
            self.contact_ticks += 1;
        }
        f
    }

    /// Sets the burr's spin for the next ticks ([`ToolState::set_spin`]): the direction of its
    /// angular velocity, kept until set again (zero or not finite: none). A contact with a
    /// friction coefficient then pulls the burr sideways ([`servo_force`], "Sideways pull").
    ///
    /// # Bounded work
    /// Constant.
    pub fn set_spin(&mut self, omega: Vec3) {
        self.tool.set_spin(omega);
    }

    /// Digest of every force rendered, as [`ForceDigest`].
    pub fn digest(&self) -> u64 {
        self.digest.value()
    }

    /// Ticks run.
    pub fn ticks(&self) -> u64 {
        self.ticks
    }

    /// Ticks with a force other than zero.
    pub fn contact_ticks(&self) -> u64 {
        self.contact_ticks
    }

    /// Ticks that kept the previous contact because the publisher overtook every read.
    pub fn stale_reads(&self) -> u64 {
        self.stale_reads
    }

    /// The step number of the contact in use (0: none yet).
    pub fn step(&self) -> u32 {
        self.step
    }

    /// The force settings.
    pub fn params(&self) -> &ForceParams {
        &self.params
    }

    /// The burr's depth at `centre` below the plane of the contact in use (the one the last
    /// [`Servo::tick`] read) and the energy its penalty spring holds there
    /// ([`penalty_storage`] with the stiffness [`servo_force`] renders: the material's under
    /// the contact, else the settings', and the settings' force limit), in newton mesh units:
    /// what a [`crate::force::PassivityObserver`] is fed beside the force. Zero out of contact
    /// or for a non-finite `centre`.
    ///
    /// # Bounded work
    /// Constant.
    pub fn storage(&self, centre: Vec3) -> (f32, Storage) {
        burr_storage(&self.contact, centre, self.radius, &self.params)
    }
}

/// A burr of `radius` at `centre` on `contact`: its depth below the contact's plane and the
/// energy its penalty spring holds there ([`penalty_storage`] with the stiffness
/// [`servo_force`] renders, the material's under the contact or else `params`', and `params`'
/// force limit), newton mesh units. Zero out of contact or for a non-finite `centre`.
///
/// # Bounded work
/// Constant.
pub fn burr_storage(
    contact: &ContactState,
    centre: Vec3,
    radius: f32,
    params: &ForceParams,
) -> (f32, Storage) {
    let depth = radius - (centre - contact.point).dot(contact.normal);
    if !(contact.valid && depth.is_finite() && depth > 0.0) {
        return (0.0, Storage::default());
    }
    let k = if contact.stiffness > 0.0 && contact.stiffness.is_finite() {
        contact.stiffness
    } else {
        params.stiffness
    };
    (depth, penalty_storage(depth, k, params.max_force))
}
