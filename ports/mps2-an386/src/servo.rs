//! The servo half: what the 1 kHz timer task does each tick.
//!
//! Per tick, in this order: read the device (the stand-in: the scripted pose of this tick),
//! take the contact of every simulation step that has finished (the one released last tick is
//! due now), compute [`servo_force`] on that contact at this tick's pose (held or ramped down
//! by the deadline-miss policy, [`crate::policy`], when the contact is late), write it to the
//! motors through the [`Board`] ([`crate::hw::motor_commands`]) and feed the watchdog, then
//! release the simulation step of this tick with this tick's pose and pend its task. The release rule the host's replay models
//! (`servo_lag = 1` in `builtin:firmware`): the force of tick `i` comes from the contact of the
//! step released at tick `i - 1`, which must have finished before tick `i`'s timer event.

use core::sync::atomic::{AtomicU32, Ordering};

use cortex_m::peripheral::SCB;

use tetradrill_core::force::{ForceDigest, ForceParams, ToolState};
use tetradrill_core::servo::{servo_force, ContactState};
use tetradrill_core::Vec3;

use crate::clock::{self, Stats};
use crate::handoff::{Done, DoneRx, Release, ReleaseTx};
use crate::hw::{motor_commands, Board, MotorCommand, OMNI};
use crate::policy::LatePolicy;
use crate::scenario::{self, Scenario};

/// Servo ticks from a step's release to the tick whose force uses its contact.
pub const LAG: u32 = 1;

/// The force the servo last commanded, N (the bits of x, y, z): what the motors were given
/// when a fault stops them ([`crate::fault`] reports it).
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
    /// The deadline-miss policy's counts (late ticks held, ramped, the longest run).
    pub late: LatePolicy,
}

impl Summary {
    /// Every kind of deadline miss.
    pub fn deadline_misses(&self) -> u32 {
        self.late_steps + self.overruns + self.refused
    }
}

/// The servo task's state (an RTIC local resource: only the servo touches it).
pub struct Servo<B: Board> {
    board: B,
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
    late: LatePolicy,
    finished: bool,
}

impl<B: Board> Servo<B> {
    /// The servo writing to `board`'s motors, running `ticks` ticks of `scenario` (its timer
    /// started).
    pub fn new(
        mut board: B,
        scenario: &'static Scenario,
        ticks: u32,
        release: ReleaseTx,
        done: DoneRx,
    ) -> Self {
        board.write_motors(&[MotorCommand::OFF; 3]);
        board.set_enable(true);
        Self {
            board,
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
            late: LatePolicy::default(),
            finished: false,
        }
    }

    /// One servo tick (the servo timer's handler's body).
    ///
    /// After the last scripted tick the motors are off and the timer keeps running, each tick
    /// only feeding the watchdog, until the simulation's report ends the run.
    ///
    /// # Bounded work
    /// One [`servo_force`], at most [`crate::handoff::SLOTS`] dequeues and one enqueue.
    #[inline(always)]
    pub fn tick(&mut self) {
        clock::EVENTS.fetch_add(1, Ordering::Release);
        if self.finished {
            self.board.feed_watchdog();
            return;
        }
        let i = self.tick;
        if i >= self.ticks {
            self.board.write_motors(&[MotorCommand::OFF; 3]);
            self.board.set_enable(false);
            self.board.feed_watchdog();
            let mut summary = self.summary;
            summary.ticks = self.ticks;
            summary.digest = self.digest.value();
            summary.late = self.late;
            if self.release.enqueue(Release::Finish(summary)).is_ok() {
                self.finished = true;
                SCB::set_pendsv();
            }
            return;
        }
        // The device read (the encoders are read; the pose is the script's).
        let _counts = self.board.read_encoders();
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
        let on_time = i < LAG || self.contact_tick == Some(i - LAG);
        if !on_time {
            self.summary.late_steps += 1;
        }
        let f = servo_force(
            &self.contact,
            position,
            scenario::RADIUS,
            &mut self.tool,
            &self.force,
        );
        let f = self.late.apply(on_time, f);
        self.board.write_motors(&motor_commands(f, &OMNI));
        write_force(f);
        self.board.feed_watchdog();
        crate::fault::maybe_inject(i);
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

/// Keeps the commanded force in [`FORCE_OUT`] (three stores).
#[inline(always)]
fn write_force(f: Vec3) {
    FORCE_OUT[0].store(f.x.to_bits(), Ordering::Relaxed);
    FORCE_OUT[1].store(f.y.to_bits(), Ordering::Relaxed);
    FORCE_OUT[2].store(f.z.to_bits(), Ordering::Relaxed);
}
