//! [`Link`]: a soft body coupled to a [`World`] with its step spread over servo ticks, so that
//! every tick's added work is bounded and known (a board whose tick cannot hold a whole step).
//!
//! A cycle is `ticks` ticks. At the cycle's first tick, step k begins, loaded with the mean
//! reaction the tool pushed on the body over the previous cycle; its work is spread over the
//! cycle, the same amount each tick: the load scaled to its mean, the physics
//! ([`SoftBody::advance`]), the new positions written, and the world's update prepared
//! ([`World::prepare_positions`]); at the cycle's last tick the world takes the new positions
//! ([`World::commit_positions`]). Every tick the tool's reaction (minus the servo's force, at
//! the world's contact point in its contact tet) is gathered for the next step.
//!
//! So the positions the world shows lag: a reaction gathered in cycle k moves the world at the
//! end of cycle k + 1 (between one and two cycles later), against up to one cycle for a whole
//! step run at the cycle's last tick. Everything is in fixed order and fixed amounts, so two
//! runs (a host and a firmware) give the same bits.

use core::fmt;

use glam::Vec3;

use super::{spread_point_force, SoftBody, StepError, NODE_UNITS, TET_UNITS};
use crate::hash::REBUILD_ITEM_UNITS;
use crate::servo::{
    DeformError, DeformReport, World, PREP_BOX_UNITS, PREP_FACE_UNITS, PREP_NODE_UNITS,
    PREP_NORMALISE_UNITS,
};

/// Units of one node in the link's own passes (the load scaled to its mean; the new position
/// written and the load cleared). All the spread step's units are sized from Cortex-M4
/// instruction counts, one unit about 37 instructions (docs/SOFT.md, "A step spread over
/// ticks").
pub(crate) const LINK_NODE_UNITS: u32 = 1;

/// The caller's buffers, one entry per node each: two loads (one gathers the reaction of the
/// cycle under way while the other loads the step under way; the link swaps their roles) and
/// the positions the step under way hands the world. Handed to every [`Link::tick`], the
/// same buffers each time; all zero at the start.
#[derive(Debug)]
pub struct LinkBuffers<'b> {
    /// The first load buffer.
    pub a: &'b mut [Vec3],
    /// The second load buffer.
    pub b: &'b mut [Vec3],
    /// The next positions.
    pub next: &'b mut [Vec3],
}

/// Why a [`Link`] was refused or a tick failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum LinkError {
    /// `ticks` is zero or the step length not finite and positive.
    Cycle,
    /// The world has no spare storage ([`World::set_spare`]).
    NoSpare,
    /// A buffer (named) is not one entry per node, or the body and the world differ in
    /// node count.
    Length(&'static str),
    /// The body refused to begin a step.
    Step(StepError),
    /// The world refused the positions.
    Deform(DeformError),
}

impl fmt::Display for LinkError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Cycle => f.write_str("soft link: ticks must be at least 1 and dt positive"),
            Self::NoSpare => f.write_str("soft link: the world has no spare storage"),
            Self::Length(what) => write!(f, "soft link: {what} is not one entry per node"),
            Self::Step(e) => write!(f, "soft link: {e}"),
            Self::Deform(e) => write!(f, "soft link: {e}"),
        }
    }
}

impl core::error::Error for LinkError {}

/// The passes of a cycle.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Phase {
    /// The load scaled to the mean of the cycle it was gathered in.
    Scale,
    /// The physics.
    Physics,
    /// New positions written, the load cleared for the next gathering.
    Write,
    /// The world's update prepared.
    Prepare,
    /// Waiting for the cycle's last tick.
    Ready,
}

/// What one [`Link::tick`] did.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct LinkTick {
    /// Units done this tick (at most [`Link::units_per_tick`] plus the credit carried from
    /// the tick before, which is under the largest step's units).
    pub units: u32,
    /// The commit's report, on a cycle's last tick.
    pub committed: Option<DeformReport>,
}

/// A soft body's step spread over servo ticks; see the module docs. It holds no storage of
/// its own: the body, the world and the [`LinkBuffers`] are handed to each [`Link::tick`].
#[derive(Debug, Clone)]
pub struct Link {
    ticks: u32,
    dt: f32,
    per_tick: u32,
    cycle_units: u64,
    tick: u32,
    gathered: u32,
    /// `true`: buffer `b` gathers and `a` loads the step; `false`: the other way round.
    flipped: bool,
    phase: Phase,
    at: usize,
    mean: f32,
    credit: u32,
    steps: u32,
    late: u32,
    max_displacement: f32,
}

/// The largest units one step of a cycle takes.
const MOST_UNITS: u32 = {
    let mut m = TET_UNITS;
    if REBUILD_ITEM_UNITS > m {
        m = REBUILD_ITEM_UNITS;
    }
    let prep = [
        PREP_NODE_UNITS,
        PREP_BOX_UNITS,
        PREP_FACE_UNITS,
        PREP_NORMALISE_UNITS,
    ];
    let mut i = 0;
    while i < prep.len() {
        if prep[i] > m {
            m = prep[i];
        }
        i += 1;
    }
    m
};

impl Link {
    /// A link stepping `body` by `dt` every `ticks` ticks, its work spread evenly over the
    /// cycle: `ceil((cycle units + largest step) / ticks)` units a tick, computed here once
    /// (cycle units: [`SoftBody::step_units`] + [`World::prepare_units`] + two node passes).
    ///
    /// # Bounded work
    /// Constant.
    ///
    /// # Errors
    /// [`LinkError::Cycle`] for zero ticks or a bad `dt`, [`LinkError::NoSpare`] when the
    /// world has no spare storage, [`LinkError::Length`] when body and world differ in nodes.
    pub fn new(
        body: &SoftBody<'_>,
        world: &World<'_>,
        ticks: u32,
        dt: f32,
    ) -> Result<Self, LinkError> {
        if ticks == 0 || !(dt.is_finite() && dt > 0.0) {
            return Err(LinkError::Cycle);
        }
        if body.node_count() != world.mesh().node_count() {
            return Err(LinkError::Length("the world's mesh"));
        }
        let prep = world.prepare_units().ok_or(LinkError::NoSpare)?;
        let nodes = 2 * body.node_count() as u64 * u64::from(LINK_NODE_UNITS);
        let cycle_units = nodes + body.step_units() + prep;
        let per_tick = (cycle_units + u64::from(MOST_UNITS)).div_ceil(u64::from(ticks));
        Ok(Self {
            ticks,
            dt,
            per_tick: per_tick.min(u64::from(u32::MAX)) as u32,
            cycle_units,
            tick: 0,
            gathered: 0,
            flipped: false,
            phase: Phase::Ready,
            at: 0,
            mean: 1.0,
            credit: 0,
            steps: 0,
            late: 0,
            max_displacement: 0.0,
        })
    }

    /// Units a tick: the cycle's units spread evenly.
    pub fn units_per_tick(&self) -> u32 {
        self.per_tick
    }

    /// Units of one cycle's work (the commit aside).
    pub fn cycle_units(&self) -> u64 {
        self.cycle_units
    }

    /// Ticks a cycle.
    pub fn ticks(&self) -> u32 {
        self.ticks
    }

    /// The servo tick's length: a step is `ticks x dt` long.
    pub fn dt(&self) -> f32 {
        self.dt
    }

    /// Steps committed so far.
    pub fn steps(&self) -> u32 {
        self.steps
    }

    /// Cycles whose work was not done by their last tick and was finished there (none when
    /// the units a tick are as [`Link::new`] computes them: a check).
    pub fn late(&self) -> u32 {
        self.late
    }

    /// The largest distance of a node from rest the world has taken so far.
    pub fn max_displacement(&self) -> f32 {
        self.max_displacement
    }

    /// One servo tick whose force on the user was `force`, after the world's simulation step
    /// of that tick: begins a step at a cycle's first tick, gathers the reaction (`-force`
    /// at the world's contact point, spread over its contact tet's corners at the world's
    /// positions), does this tick's share of the cycle's work and, at the cycle's last tick,
    /// commits the new positions to the world.
    ///
    /// # Bounded work
    /// At most [`Link::units_per_tick`] units plus the credit carried from the last tick
    /// (less than the largest step, [`TET_UNITS`]), plus a commit
    /// ([`World::commit_positions`]) on a cycle's last tick.
    ///
    /// # Errors
    /// [`LinkError::Length`] for a buffer that is not one entry per node; a step or update
    /// the core refuses ([`LinkError::Step`], [`LinkError::Deform`]: not on a body and world
    /// [`Link::new`] accepted, with positions the physics keeps finite).
    pub fn tick(
        &mut self,
        body: &mut SoftBody<'_>,
        world: &mut World<'_>,
        buffers: LinkBuffers<'_>,
        force: Vec3,
    ) -> Result<LinkTick, LinkError> {
        let n = body.node_count();
        let LinkBuffers { a, b, next } = buffers;
        for (what, len) in [("a", a.len()), ("b", b.len()), ("next", next.len())] {
            if len != n {
                return Err(LinkError::Length(what));
            }
        }
        if self.tick == 0 {
            // The body first: a body that refuses the step (one already under way) leaves the
            // link as it was, its gathered reactions kept for a later try.
            body.begin_step(self.ticks as f32 * self.dt)
                .map_err(LinkError::Step)?;
            if self.phase != Phase::Ready {
                // Not reached with the units `new` computes (a cycle's last tick finishes it).
                self.late += 1;
            }
            self.flipped = !self.flipped;
            self.mean = 1.0 / self.gathered.max(1) as f32;
            self.gathered = 0;
            self.credit = 0;
            self.phase = Phase::Scale;
            self.at = 0;
        }
        let (gather, load) = if self.flipped { (b, a) } else { (a, b) };
        if let Some(t) = world.contact_tet() {
            if force != Vec3::ZERO {
                let ids = world.mesh().tet_nodes(t);
                if ids.iter().all(|k| k.idx() < n) {
                    let p = world.mesh().tet_positions(t);
                    if let Some(parts) = spread_point_force(p, world.contact().point, -force) {
                        for (k, f) in ids.iter().zip(parts) {
                            gather[k.idx()] += f;
                        }
                    }
                }
            }
        }
        self.gathered = self.gathered.saturating_add(1);
        self.credit = self.credit.saturating_add(self.per_tick);
        let last = self.tick + 1 == self.ticks;
        let budget = if last { u32::MAX } else { self.credit };
        let done = self.work(body, world, load, next, budget)?;
        self.credit = self.credit.saturating_sub(done);
        let mut out = LinkTick {
            units: done,
            committed: None,
        };
        if last {
            if done > self.per_tick.saturating_add(MOST_UNITS) {
                self.late += 1;
            }
            let rep = world.commit_positions(next).map_err(LinkError::Deform)?;
            self.max_displacement = self.max_displacement.max(rep.max_displacement);
            self.steps = self.steps.wrapping_add(1);
            out.committed = Some(rep);
            self.tick = 0;
        } else {
            self.tick += 1;
        }
        Ok(out)
    }

    /// The cycle's work, in order, within `budget` units; returns the units done.
    fn work(
        &mut self,
        body: &mut SoftBody<'_>,
        world: &mut World<'_>,
        load: &mut [Vec3],
        next: &mut [Vec3],
        budget: u32,
    ) -> Result<u32, LinkError> {
        let n = load.len();
        let mut left = budget;
        loop {
            match self.phase {
                Phase::Scale => {
                    if self.at >= n {
                        self.phase = Phase::Physics;
                        self.at = 0;
                        continue;
                    }
                    if left < LINK_NODE_UNITS {
                        break;
                    }
                    left -= LINK_NODE_UNITS;
                    load[self.at] *= self.mean;
                    self.at += 1;
                }
                Phase::Physics => {
                    let adv = body.advance(load, left.min(u32::MAX - NODE_UNITS));
                    left -= adv.units;
                    if !adv.done {
                        break;
                    }
                    self.phase = Phase::Write;
                }
                Phase::Write => {
                    if self.at >= n {
                        self.phase = Phase::Prepare;
                        self.at = 0;
                        continue;
                    }
                    if left < LINK_NODE_UNITS {
                        break;
                    }
                    left -= LINK_NODE_UNITS;
                    next[self.at] = body.position(self.at).unwrap_or_default();
                    load[self.at] = Vec3::ZERO;
                    self.at += 1;
                }
                Phase::Prepare => {
                    let p = world
                        .prepare_positions(next, left)
                        .map_err(LinkError::Deform)?;
                    left -= p.units;
                    if !p.ready {
                        break;
                    }
                    self.phase = Phase::Ready;
                }
                Phase::Ready => break,
            }
        }
        Ok(budget - left)
    }
}
