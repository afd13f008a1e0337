//! A tet-mesh tool's (the pen's) two rates without a lock: each contact pass
//! ([`crate::force::pen_pass`]) publishes the pose it was made at and its penetrations into a
//! [`PenHandoff`], and the servo at the higher rate reads the newest pass and carries it to its
//! own pose ([`crate::force::pen_servo_force`]), as `tetradrill replay --tool mesh:FILE` holds
//! a pass for its servo.
//!
//! The hand-off is two sequence-locked slots, as [`super::ContactHandoff`]'s, over words the
//! caller provides (their number depends on the contact capacities:
//! [`PenHandoff::words_for`]): each holds one pass's pose, its counts and up to the capacities'
//! penetrations, written whole into the slot the servo is not pointed at before the servo is
//! pointed at it. A servo on another core overtaken while it reads tries again, at most
//! [`super::HANDOFF_TRIES`] times, and reads into buffers of its own, so it can keep the pass
//! it had. Every access is atomic; no `unsafe`.

use core::sync::atomic::{fence, AtomicU32, Ordering};

use glam::{Quat, Vec3};

use super::HANDOFF_TRIES;
use crate::depth::Penetration;

/// Words of a slot's head: sequence, step, the two counts, the position and the rotation.
const HEAD: usize = 2 + 2 + 3 + 4;

/// Words of one penetration.
const ENTRY: usize = core::mem::size_of::<Penetration>() / 4;

/// A pass as the servo receives it: its pose, how many penetrations of each side it holds
/// (written to the servo's buffers by [`PenHandoff::latest`]) and its number (0: none yet).
#[derive(Clone, Copy, PartialEq, Debug)]
pub struct PenPublished {
    /// The pen's tip at the pass.
    pub position: Vec3,
    /// The pen's rotation at the pass.
    pub rotation: Quat,
    /// Pen nodes inside the object.
    pub pen: usize,
    /// Object nodes inside the pen.
    pub object: usize,
    /// The pass's number, counted by the publisher from 1.
    pub step: u32,
}

impl Default for PenPublished {
    fn default() -> Self {
        Self {
            position: Vec3::ZERO,
            rotation: Quat::IDENTITY,
            pen: 0,
            object: 0,
            step: 0,
        }
    }
}

/// The lock-free hand-off of a pen's passes to its servo (module docs), over the caller's
/// words. All zeros is empty (no pass: the identity pose, no penetration).
#[derive(Debug)]
pub struct PenHandoff<'a> {
    words: &'a [AtomicU32],
    pen_capacity: usize,
    object_capacity: usize,
    /// The slot the servo reads (the newest complete one).
    newest: AtomicU32,
    /// Passes published.
    steps: AtomicU32,
}

impl<'a> PenHandoff<'a> {
    /// Words a hand-off of `pen` pen penetrations and `object` object penetrations a pass
    /// needs (both slots); `None` when the count overflows.
    ///
    /// # Bounded work
    /// Constant.
    pub const fn words_for(pen: usize, object: usize) -> Option<usize> {
        let Some(entries) = pen.checked_add(object) else {
            return None;
        };
        let Some(words) = entries.checked_mul(ENTRY) else {
            return None;
        };
        let Some(slot) = words.checked_add(HEAD) else {
            return None;
        };
        slot.checked_mul(2)
    }

    /// A hand-off over `words` for passes of at most `pen` and `object` penetrations (more
    /// are cut off at publishing, counted by the publisher); the words are cleared. `None`
    /// when `words` is shorter than [`PenHandoff::words_for`].
    ///
    /// # Bounded work
    /// O(words).
    pub fn new(words: &'a [AtomicU32], pen: usize, object: usize) -> Option<Self> {
        let need = Self::words_for(pen, object)?;
        let words = words.get(..need)?;
        for w in words {
            w.store(0, Ordering::Relaxed);
        }
        Some(Self {
            words,
            pen_capacity: pen,
            object_capacity: object,
            newest: AtomicU32::new(0),
            steps: AtomicU32::new(0),
        })
    }

    /// The capacities: (pen, object) penetrations a pass hands over.
    pub fn capacities(&self) -> (usize, usize) {
        (self.pen_capacity, self.object_capacity)
    }

    fn slot(&self, k: u32) -> &'a [AtomicU32] {
        let len = self.words.len() / 2;
        let at = if k & 1 == 0 { 0 } else { len };
        self.words.get(at..at + len).unwrap_or(&[])
    }

    /// Publishes a pass made at `position` and `rotation` with the penetrations `pen` and
    /// `object` (cut to the capacities); returns the pass's number (1 for the first) and
    /// whether a list was cut.
    ///
    /// # Bounded work
    /// O(capacities): the head and the penetrations' 7 words each, stored into the slot the
    /// servo is not reading, then the switch. Never waits. One publisher at a time.
    pub fn publish(
        &self,
        position: Vec3,
        rotation: Quat,
        pen: &[Penetration],
        object: &[Penetration],
    ) -> (u32, bool) {
        let step = self.steps.load(Ordering::Relaxed).wrapping_add(1);
        let next = (self.newest.load(Ordering::Relaxed) ^ 1) & 1;
        let slot = self.slot(next);
        let (np, no) = (
            pen.len().min(self.pen_capacity),
            object.len().min(self.object_capacity),
        );
        let Some((seq, body)) = slot.split_first() else {
            return (step, true);
        };
        let s = seq.load(Ordering::Relaxed);
        seq.store(s.wrapping_add(1), Ordering::Relaxed);
        // The odd sequence is ordered before the words (as `ContactHandoff::publish`).
        fence(Ordering::Release);
        let head = [
            step,
            np as u32,
            no as u32,
            position.x.to_bits(),
            position.y.to_bits(),
            position.z.to_bits(),
            rotation.x.to_bits(),
            rotation.y.to_bits(),
            rotation.z.to_bits(),
            rotation.w.to_bits(),
        ];
        for (w, v) in body.iter().zip(head) {
            w.store(v, Ordering::Relaxed);
        }
        let entries = body.get(HEAD - 1..).unwrap_or(&[]);
        let pen_words = self.pen_capacity * ENTRY;
        let (pen_at, object_at) = entries.split_at(pen_words.min(entries.len()));
        let store = |at: &[AtomicU32], list: &[Penetration]| {
            for (c, p) in at.chunks_exact(ENTRY).zip(list) {
                let v: [u32; ENTRY] = bytemuck::cast(*p);
                for (w, x) in c.iter().zip(v) {
                    w.store(x, Ordering::Relaxed);
                }
            }
        };
        store(pen_at, pen.get(..np).unwrap_or(&[]));
        store(object_at, object.get(..no).unwrap_or(&[]));
        seq.store(s.wrapping_add(2), Ordering::Release);
        self.steps.store(step, Ordering::Relaxed);
        self.newest.store(next, Ordering::Release);
        (step, np < pen.len() || no < object.len())
    }

    /// The newest published pass, its penetrations written to the front of `pen` and
    /// `object` (at most their lengths); `None` when every one of [`HANDOFF_TRIES`] reads was
    /// overtaken by the publisher (only possible when the two run on different cores), and
    /// then the buffers hold no whole pass. Before the first publish: step 0, no penetration.
    ///
    /// # Bounded work
    /// At most [`HANDOFF_TRIES`] reads of the head and the pass's penetrations (at most the
    /// capacities). Never waits.
    pub fn latest(
        &self,
        pen: &mut [Penetration],
        object: &mut [Penetration],
    ) -> Option<PenPublished> {
        for _ in 0..HANDOFF_TRIES {
            let slot = self.slot(self.newest.load(Ordering::Acquire));
            let (seq, body) = slot.split_first()?;
            let before = seq.load(Ordering::Acquire);
            if before & 1 != 0 {
                continue;
            }
            let mut head = [0u32; HEAD - 1];
            for (v, w) in head.iter_mut().zip(body) {
                *v = w.load(Ordering::Relaxed);
            }
            let np = (head[1] as usize).min(self.pen_capacity).min(pen.len());
            let no = (head[2] as usize)
                .min(self.object_capacity)
                .min(object.len());
            let entries = body.get(HEAD - 1..).unwrap_or(&[]);
            let pen_words = self.pen_capacity * ENTRY;
            let (pen_at, object_at) = entries.split_at(pen_words.min(entries.len()));
            let load = |at: &[AtomicU32], list: &mut [Penetration]| {
                for (c, p) in at.chunks_exact(ENTRY).zip(list) {
                    let mut v = [0u32; ENTRY];
                    for (x, w) in v.iter_mut().zip(c) {
                        *x = w.load(Ordering::Relaxed);
                    }
                    *p = bytemuck::cast(v);
                }
            };
            load(pen_at, pen.get_mut(..np).unwrap_or(&mut []));
            load(object_at, object.get_mut(..no).unwrap_or(&mut []));
            // The words are read before the second look at the sequence.
            fence(Ordering::Acquire);
            if seq.load(Ordering::Relaxed) == before {
                let f = |i: usize| f32::from_bits(head[i]);
                let step = head[0];
                return Some(if step == 0 {
                    PenPublished::default()
                } else {
                    PenPublished {
                        position: Vec3::new(f(3), f(4), f(5)),
                        rotation: Quat::from_xyzw(f(6), f(7), f(8), f(9)),
                        pen: np,
                        object: no,
                        step,
                    }
                });
            }
        }
        None
    }
}
