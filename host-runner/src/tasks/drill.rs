//! The drill tool (`--tool drill:BURR_R:SHAFT_LEN:SHAFT_R`) in the real-time pipeline: what
//! the simulation task hands the servo ([`DrillContact`]: the burr's contact plane and the
//! shaft's passive points' planes from the same step, one triple buffer) and the servo's law
//! ([`DrillLaw`]: [`drill_force`] at every tick's pose).
//!
//! What runs where: the simulation task erodes with the burr along the swept path, then
//! tracks the passive points at the newest pose against the visible faces
//! ([`tetradrill_core::servo::World::track_shaft`]: a zone query and the face walk, which
//! gets what the burr's step left of the tick budget, `World::shaft_bound`) and publishes
//! the planes. The servo only springs from those
//! planes at the points' current positions: O([`MAX_PASSIVE`]) a tick, no face is looked at,
//! nothing allocates, locks or waits.

use std::sync::atomic::Ordering;

use tetradrill_core::force::{DrillTool, ToolState, MAX_PASSIVE};
use tetradrill_core::servo::{drill_force, ContactState, DrillState};
use tetradrill_core::{Quat, Vec3};

use crate::engine::TickParams;

use super::{burr_contact, BurrLaw, ForceLaw, LawContact, ServoCounters};

/// What one simulation step hands the servo for a drill: the burr's contact plane and the
/// shaft's passive points (their planes), both from the same step.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct DrillContact {
    /// The burr's contact plane (as [`BurrLaw`] gets it).
    pub burr: ContactState,
    /// The passive points' planes and the count in use.
    pub shaft: DrillState,
}

/// The shaft's figures a servo counted over a run (the run JSON's `shaft`).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ShaftCounts {
    /// Ticks whose planes gave a passive point a contact plane (a face within reach, or held).
    pub near_ticks: u64,
    /// Ticks with a passive point held at a face it had crossed.
    pub held_ticks: u64,
    /// Most passive points held in one tick.
    pub held_max: u32,
    /// Ticks in which a passive point's spring pushed (the shaft's part of the force was not
    /// zero).
    pub pushing_ticks: u64,
}

/// The drill's force law: [`drill_force`] from the latest [`DrillContact`] the simulation
/// published, at the tool's current position and axis (the servo extrapolates the burr's and
/// every passive point's plane, Turini et al. 2006, section 3.3), with the viewer's radius and
/// stiffness when it set them (`counters`). The burr's own part of the force goes to
/// `counters.burr_press_bits`: it, not the shaft's push, presses the burr into the material.
#[derive(Debug)]
pub struct DrillLaw<'a> {
    /// The scenario's parameters.
    pub params: TickParams,
    /// The drill's shape.
    pub tool: DrillTool,
    /// The simulation's planes.
    pub contact: &'a mut triple_buffer::Output<DrillContact>,
    /// The viewer's controls (radius and stiffness, 0 = the scenario's), and where the burr's
    /// force goes.
    pub counters: &'a ServoCounters,
    /// The burr's damping state.
    pub burr: ToolState,
    /// The shaft's damping state.
    pub shaft: ToolState,
    /// The contact behind the last force, when only the burr's spring was in it.
    pub last: Option<LawContact>,
    /// The shaft's figures so far.
    pub counts: ShaftCounts,
}

impl<'a> DrillLaw<'a> {
    /// The law for `tool` and `params` over `contact`, controlled through `counters`.
    pub fn new(
        params: TickParams,
        tool: DrillTool,
        contact: &'a mut triple_buffer::Output<DrillContact>,
        counters: &'a ServoCounters,
    ) -> Self {
        Self {
            params,
            tool,
            contact,
            counters,
            burr: ToolState::default(),
            shaft: ToolState::default(),
            last: None,
            counts: ShaftCounts::default(),
        }
    }
}

impl ForceLaw for DrillLaw<'_> {
    /// # Bounded work
    /// O([`MAX_PASSIVE`]): a triple-buffer read, [`drill_force`], one pass over the points.
    fn force(&mut self, _tick: u64, position: Vec3, rotation: Quat) -> Vec3 {
        let mut live = self.params;
        let mut tool = self.tool;
        let r = self.counters.radius_bits.load(Ordering::Relaxed);
        if r != 0 {
            live.radius = f32::from_bits(r);
            tool.burr_radius = live.radius;
        }
        let k = self.counters.stiffness_bits.load(Ordering::Relaxed);
        if k != 0 {
            live.force.stiffness = f32::from_bits(k);
        }
        let c = self.contact.read();
        let axis = DrillTool::axis(rotation);
        let (f, on_burr) = drill_force(
            &c.burr,
            &tool,
            position,
            axis,
            &c.shaft,
            &mut self.burr,
            &mut self.shaft,
            &live.force,
        );
        self.counters
            .burr_press_bits
            .store(on_burr.length().to_bits(), Ordering::Relaxed);
        // The shaft's springs at the points' current positions (drill_force's own sum).
        let mut pos = [Vec3::ZERO; MAX_PASSIVE];
        let n = tool
            .passive_positions(position, axis, &mut pos)
            .min(c.shaft.count);
        let (mut near, mut held, mut pushing) = (false, 0u32, false);
        for (pt, p) in c.shaft.points[..n].iter().zip(&pos[..n]) {
            near |= pt.plane.is_some();
            held += u32::from(pt.is_held());
            if let Some((q, nrm)) = pt.plane {
                pushing |= tool.shaft_radius - (*p - q).dot(nrm) > 0.0;
            }
        }
        let s = &mut self.counts;
        s.near_ticks += u64::from(near);
        s.held_ticks += u64::from(held > 0);
        s.held_max = s.held_max.max(held);
        s.pushing_ticks += u64::from(pushing);
        // The burr's penalty spring is the law's storage function only while the shaft adds
        // nothing: with a passive point pushing, the observer takes its classic form.
        self.last = (!pushing).then(|| burr_contact(&c.burr, position, live.radius, &live.force));
        f
    }

    fn contact(&self) -> Option<LawContact> {
        self.last
    }
}

/// The law of a drilling run: the plain burr's or the drill's.
#[derive(Debug)]
pub enum DrillingLaw<'a> {
    /// `sphere:R`.
    Burr(BurrLaw<'a>),
    /// `drill:BURR_R:SHAFT_LEN:SHAFT_R`.
    Drill(DrillLaw<'a>),
}

impl DrillingLaw<'_> {
    /// The drill's figures (`None` for the plain burr).
    pub fn shaft_counts(&self) -> Option<ShaftCounts> {
        match self {
            Self::Burr(_) => None,
            Self::Drill(d) => Some(d.counts),
        }
    }
}

impl ForceLaw for DrillingLaw<'_> {
    fn force(&mut self, tick: u64, position: Vec3, rotation: Quat) -> Vec3 {
        match self {
            Self::Burr(l) => l.force(tick, position, rotation),
            Self::Drill(l) => l.force(tick, position, rotation),
        }
    }

    fn contact(&self) -> Option<LawContact> {
        match self {
            Self::Burr(l) => l.contact(),
            Self::Drill(l) => l.contact(),
        }
    }
}
