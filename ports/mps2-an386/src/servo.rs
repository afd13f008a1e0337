//! The servo half: what the 1 kHz timer task does each tick.
//!
//! Per tick, in this order: read the device (the stand-in: the scripted pose of this tick),
//! take the contact of every simulation step that has finished (the one released last tick is
//! due now), compute [`servo_force`] on that contact at this tick's pose, write the force (the
//! stand-in: three atomic stores, [`FORCE_OUT`]), then release the simulation step of this tick
//! with this tick's pose and pend its task. The release rule the host's replay models
//! (`servo_lag = 1` in `builtin:firmware`): the force of tick `i` comes from the contact of the
//! step released at tick `i - 1`, which must have finished before tick `i`'s timer event.

use core::sync::atomic::{AtomicU32, Ordering};

use cortex_m::peripheral::{SCB, SYST};

use tetradrill_core::force::{ForceDigest, ForceParams, ToolState};
use tetradrill_core::servo::{servo_force, ContactState};
use tetradrill_core::Vec3;

use crate::clock::{self, Stats};
use crate::handoff::{Done, DoneRx, Release, ReleaseTx};
use crate::scenario::{self, Scenario};

/// Servo ticks from a step's release to the tick whose force uses its contact.
pub const LAG: u32 = 1;

/// The force output (the stand-in for the motor drivers): the bits of x, y, z.
pub static FORCE_OUT: [AtomicU32; 3] = [AtomicU32::new(0), AtomicU32::new(0), AtomicU32::new(0)];

/// SysTick counts the servo has been busy, from each timer event to the end of its handler
/// (wrapping): the simulation subtracts what fell inside its step.
pub static SERVO_BUSY: AtomicU32 = AtomicU32::new(0);

/// What the servo measured over the scenario, handed to the simulation at the end.
#[derive(Clone, Copy, Debug, Default)]
pub struct Summary {
    /// Servo ticks run.
    pub ticks: u32,
    /// FNV-1a 64 of every tick's force.
    pub digest: u64,
    /// Ticks with a non-zero force.
    pub contact_ticks: u32,
    /// Instructions from the timer event to the force write.
    pub latency: Stats,
    /// Instructions from the timer event to the end of the servo's handler.
    pub busy: Stats,
    /// Ticks whose due contact was not there (its step had not finished): deadline misses.
    pub late_steps: u32,
    /// Ticks whose handler was still running at the next timer event: deadline misses.
    pub overruns: u32,
    /// Releases the full queue refused: deadline misses.
    pub refused: u32,
}

impl Summary {
    /// Every kind of deadline miss.
    pub fn deadline_misses(&self) -> u32 {
        self.late_steps + self.overruns + self.refused
    }
}

/// The servo task's state (an RTIC local resource: only the servo touches it).
pub struct Servo {
    syst: SYST,
    scenario: &'static Scenario,
    tick: u32,
    ticks: u32,
    release: ReleaseTx,
    done: DoneRx,
    contact: ContactState,
    contact_tick: Option<u32>,
    tool: ToolState,
    force: ForceParams,
    digest: ForceDigest,
    summary: Summary,
    finished: bool,
}

impl Servo {
    /// The servo over the started timer `syst`, running `ticks` ticks of `scenario`.
    pub fn new(
        syst: SYST,
        scenario: &'static Scenario,
        ticks: u32,
        release: ReleaseTx,
        done: DoneRx,
    ) -> Self {
        Self {
            syst,
            scenario,
            tick: 0,
            ticks,
            release,
            done,
            contact: ContactState::default(),
            contact_tick: None,
            tool: ToolState::default(),
            force: scenario::force_params(),
            digest: ForceDigest::new(),
            summary: Summary::default(),
            finished: false,
        }
    }

    /// One servo tick (the SysTick handler's body).
    ///
    /// # Bounded work
    /// One [`servo_force`], at most [`crate::handoff::SLOTS`] dequeues and one enqueue.
    #[inline(always)]
    pub fn tick(&mut self) {
        clock::EVENTS.fetch_add(1, Ordering::Release);
        if self.finished {
            return;
        }
        let i = self.tick;
        if i >= self.ticks {
            let mut summary = self.summary;
            summary.ticks = self.ticks;
            summary.digest = self.digest.value();
            if self.release.enqueue(Release::Finish(summary)).is_ok() {
                clock::stop_servo_timer(&mut self.syst);
                self.finished = true;
                SCB::set_pendsv();
            }
            return;
        }
        // The device read.
        let (position, drill_on) = self.scenario.pose(i);
        // The contact that is due: the newest step released at or before tick i - LAG.
        while let Some(&Done { tick, contact }) = self.done.peek() {
            if tick + LAG > i {
                break;
            }
            self.contact = contact;
            self.contact_tick = Some(tick);
            self.done.dequeue();
        }
        if i >= LAG && self.contact_tick != Some(i - LAG) {
            self.summary.late_steps += 1;
        }
        let f = servo_force(
            &self.contact,
            position,
            scenario::RADIUS,
            &mut self.tool,
            &self.force,
        );
        write_force(f);
        let latency = clock::instructions_since_event();
        self.summary.latency.add(i, latency as u64);
        self.digest.push(f);
        if f != Vec3::ZERO {
            self.summary.contact_ticks += 1;
        }
        let servo_instructions = clock::instructions_since_event();
        let step = Release::Step {
            tick: i,
            position,
            drill_on,
            pressing: f.length(),
            #[cfg(scenario_soft)]
            force: f,
            servo_instructions,
        };
        if self.release.enqueue(step).is_err() {
            self.summary.refused += 1;
        }
        SCB::set_pendsv();
        self.tick = i + 1;
        let busy = clock::since_event();
        SERVO_BUSY.fetch_add(busy, Ordering::Release);
        self.summary.busy.add(i, clock::instructions(busy as u64));
        if SCB::is_pendst_pending() {
            self.summary.overruns += 1;
        }
    }
}

/// Writes the force to the output (three stores).
#[inline(always)]
fn write_force(f: Vec3) {
    FORCE_OUT[0].store(f.x.to_bits(), Ordering::Relaxed);
    FORCE_OUT[1].store(f.y.to_bits(), Ordering::Relaxed);
    FORCE_OUT[2].store(f.z.to_bits(), Ordering::Relaxed);
}
