//! A drill's two rates without a lock: each simulation step ([`super::World::simulate_drill`])
//! publishes its burr's contact and its shaft's passive-point planes together into a
//! [`DrillHandoff`], and a [`DrillServo`] at the higher rate reads the newest pair and renders
//! the drill's force and torque ([`drill_force`], [`drill_torque`]) at its own pose.
//!
//! The hand-off is the two sequence-locked slots of [`ContactHandoff`] (`handoff.rs`), each
//! holding one step's contact, its number, the count of passive points and each point's
//! plane: the servo never renders a burr contact of one step with the shaft of another. The
//! way back (the burr's force pressing it into the material at the next step) is the
//! [`ContactHandoff`]'s ([`ContactHandoff::report_force`], [`ContactHandoff::pressing`]), so a
//! drill uses both: this one for the contact, that one for the pressing force.

use glam::Vec3;

use super::handoff::{Published, SeqPair, WORDS};
use super::passive::{drill_force, drill_torque, DrillState};
use super::{ContactHandoff, ContactState};
use crate::force::{DrillTool, ForceDigest, ForceParams, ToolState, MAX_PASSIVE};

/// Words of one passive point's plane: present, point, normal.
const PLANE_WORDS: usize = 7;

/// Words of a published drill contact: the burr's contact and the step's number (as
/// [`ContactHandoff`]'s), the passive points' count, and [`MAX_PASSIVE`] planes.
const DRILL_WORDS: usize = WORDS + 1 + PLANE_WORDS * MAX_PASSIVE;

/// A drill's contact as its servo receives it: the burr's contact, the shaft's planes and the
/// step's number (0: none yet).
#[derive(Clone, Copy, PartialEq, Debug, Default)]
pub struct DrillPublished {
    /// The burr's contact and the step's number.
    pub burr: Published,
    /// The shaft's passive points with their contact planes
    /// ([`crate::force::PassivePoint::plane`]; the proxies and held planes stay with the
    /// simulation, `None`).
    pub shaft: DrillState,
}

/// Word `k` of a shaft's words: its count, then each point's plane (zero past the end).
fn shaft_word(shaft: &DrillState, k: usize) -> u32 {
    let Some(k) = k.checked_sub(1) else {
        return shaft.count.min(MAX_PASSIVE) as u32;
    };
    let Some((p, n)) = shaft.points.get(k / PLANE_WORDS).and_then(|pt| pt.plane) else {
        return 0;
    };
    match k % PLANE_WORDS {
        0 => 1,
        1 => p.x.to_bits(),
        2 => p.y.to_bits(),
        3 => p.z.to_bits(),
        4 => n.x.to_bits(),
        5 => n.y.to_bits(),
        _ => n.z.to_bits(),
    }
}

impl DrillPublished {
    fn from_words(w: &[u32; DRILL_WORDS]) -> Self {
        let mut burr = [0u32; WORDS];
        burr.copy_from_slice(w.get(..WORDS).unwrap_or(&[0; WORDS]));
        let mut shaft = DrillState {
            count: w.get(WORDS).map_or(0, |&c| (c as usize).min(MAX_PASSIVE)),
            ..DrillState::default()
        };
        let planes = w.get(WORDS + 1..).unwrap_or(&[]);
        for (pt, c) in shaft
            .points
            .iter_mut()
            .zip(planes.chunks_exact(PLANE_WORDS))
        {
            let f = |i: usize| f32::from_bits(c.get(i).copied().unwrap_or(0));
            let present = c.first().is_some_and(|&v| v != 0);
            pt.plane = present.then(|| (Vec3::new(f(1), f(2), f(3)), Vec3::new(f(4), f(5), f(6))));
        }
        Self {
            burr: Published::from_words(burr),
            shaft,
        }
    }
}

/// The lock-free hand-off of a drill's contact between its simulation step and its servo
/// (module docs). All zeros is a valid empty hand-off.
#[derive(Debug)]
pub struct DrillHandoff {
    pair: SeqPair<DRILL_WORDS>,
}

impl Default for DrillHandoff {
    fn default() -> Self {
        Self::new()
    }
}

impl DrillHandoff {
    /// An empty hand-off: nothing published.
    pub const fn new() -> Self {
        Self {
            pair: SeqPair::new(),
        }
    }

    /// Publishes a step's burr contact and its shaft's planes (`shaft`'s points in use, as
    /// [`super::World::simulate_drill`] left them); returns the step's number (1 for the
    /// first).
    ///
    /// # Bounded work
    /// Constant: 239 word stores into the slot the servo is not reading, then the switch.
    /// Never waits. One publisher at a time.
    pub fn publish(&self, contact: &ContactState, shaft: &DrillState) -> u32 {
        // The contact's words once; the last of them is the step's number.
        let head = Published {
            contact: *contact,
            step: 0,
        }
        .to_words();
        self.pair.publish(|i, step| match i.checked_sub(WORDS) {
            Some(k) => shaft_word(shaft, k),
            None if i + 1 == WORDS => step,
            None => head.get(i).copied().unwrap_or(0),
        })
    }

    /// The newest published drill contact, or `None` when every one of
    /// [`super::HANDOFF_TRIES`] reads was overtaken by the publisher (only possible when the
    /// two run on different cores). Before the first publish: no contact, no shaft, step 0.
    ///
    /// # Bounded work
    /// At most [`super::HANDOFF_TRIES`] reads of 239 words. Never waits.
    pub fn latest(&self) -> Option<DrillPublished> {
        let mut words = [0u32; DRILL_WORDS];
        self.pair
            .latest(&mut words)
            .then(|| DrillPublished::from_words(&words))
    }
}

/// The servo's own state for a drill fed through a [`DrillHandoff`]: the drill's shape, the
/// contact it renders from, the burr's and the shaft's damping states, the force settings,
/// and the digests of the forces and torques it rendered.
#[derive(Clone, Copy, Debug)]
pub struct DrillServo {
    tool: DrillTool,
    contact: DrillPublished,
    burr: ToolState,
    shaft: ToolState,
    params: ForceParams,
    digest: ForceDigest,
    torque_digest: ForceDigest,
    ticks: u64,
    contact_ticks: u64,
    stale_reads: u64,
}

impl DrillServo {
    /// A servo for the drill `tool` with the force settings `params`, no contact yet.
    pub fn new(tool: DrillTool, params: ForceParams) -> Self {
        Self {
            tool,
            contact: DrillPublished::default(),
            burr: ToolState::default(),
            shaft: ToolState::default(),
            params,
            digest: ForceDigest::new(),
            torque_digest: ForceDigest::new(),
            ticks: 0,
            contact_ticks: 0,
            stale_reads: 0,
        }
    }

    /// One servo tick with the burr at `centre` and the shaft along the unit `axis`: takes
    /// the newest drill contact from `handoff` (or keeps the last one when every read was
    /// overtaken, counted), renders [`drill_force`] and [`drill_torque`] from it, reports the
    /// burr's own force through `press` (what presses the burr at the next step, as a
    /// single-task replay sets it) and adds the force and the torque to their digests.
    /// Returns `(force, torque)`.
    ///
    /// # Bounded work
    /// Constant: [`DrillHandoff::latest`], then O([`MAX_PASSIVE`]) for the force and the
    /// torque. Never waits, allocates or panics; a non-finite `centre` gives zero burr force.
    pub fn tick(
        &mut self,
        handoff: &DrillHandoff,
        press: &ContactHandoff,
        centre: Vec3,
        axis: Vec3,
    ) -> (Vec3, Vec3) {
        match handoff.latest() {
            Some(p) => self.contact = p,
            None => self.stale_reads += 1,
        }
        let (f, on_burr) = drill_force(
            &self.contact.burr.contact,
            &self.tool,
            centre,
            axis,
            &self.contact.shaft,
            &mut self.burr,
            &mut self.shaft,
            &self.params,
        );
        let t = drill_torque(&self.tool, centre, axis, &self.contact.shaft, &self.params);
        press.report_force(on_burr);
        self.digest.push(f);
        self.torque_digest.push(t);
        self.ticks += 1;
        if f != Vec3::ZERO {
            self.contact_ticks += 1;
        }
        (f, t)
    }

    /// Sets the burr's spin for the next ticks ([`ToolState::set_spin`] of the burr's state):
    /// the direction of its angular velocity, kept until set again (zero or not finite:
    /// none). A burr contact with a friction coefficient then pulls the drill sideways
    /// ([`crate::servo::servo_force`], "Sideways pull"); the shaft does not spin against
    /// anything.
    ///
    /// # Bounded work
    /// Constant.
    pub fn set_spin(&mut self, omega: Vec3) {
        self.burr.set_spin(omega);
    }

    /// The drill's shape.
    pub fn tool(&self) -> &DrillTool {
        &self.tool
    }

    /// Digest of every force rendered, as [`ForceDigest`].
    pub fn digest(&self) -> u64 {
        self.digest.value()
    }

    /// Digest of every torque rendered, as [`ForceDigest`].
    pub fn torque_digest(&self) -> u64 {
        self.torque_digest.value()
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
        self.contact.burr.step
    }
}
