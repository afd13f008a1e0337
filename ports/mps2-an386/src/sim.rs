//! The simulation half: what the lower-priority task does with each step the servo releases,
//! and the report at the end.

use core::sync::atomic::Ordering;

use crate::println;

use tetradrill_core::drill::DrillParams;
use tetradrill_core::servo::{SimReport, World};
use tetradrill_core::Vec3;

use crate::clock::{self, Calibration, Stats};
use crate::handoff::{Done, DoneTx, Release, ReleaseRx};
use crate::scenario;
use crate::servo::{Summary, SERVO_BUSY};

/// Set at build time (`TETRADRILL_TICK_LOG=1`) to print one line per step: instructions
/// (whole tick, simulate, the contact query redone) and the drill's counts (items taken, nodes
/// expanded, NTree nodes visited, nodes created, leaves erased), for fitting the drill's work
/// weights (`scripts/fit-work-weights.py`); then the candidate query redone (instructions,
/// tets), the contact search's nodes, the step's candidates, and the sphere memo's hits and
/// misses in the step. The diagnostics run inside the simulation task after the step's
/// contact is handed over, so they can make later steps late.
const TICK_LOG: bool = option_env!("TETRADRILL_TICK_LOG").is_some();
/// Set at build time (`TETRADRILL_PROFILE_FROM=N`) to call [`profile_mark`] before step N:
/// `scripts/m4-profile.sh` counts QEMU's executed blocks from that call on.
const PROFILE_FROM: Option<&str> = option_env!("TETRADRILL_PROFILE_FROM");

/// The simulation task's state (an RTIC local resource: only the simulation touches it).
pub struct Sim {
    world: &'static mut World<'static>,
    release: ReleaseRx,
    done: DoneTx,
    drill: DrillParams,
    calibration: Calibration,
    /// Instructions of two back-to-back [`clock::now`] calls.
    now_overhead: u64,
    step: Stats,
    whole: Stats,
    worst: SimReport,
    refused: u32,
    profile_from: Option<u32>,
    /// The soft body and its link (`builtin:firmware-soft`).
    #[cfg(scenario_soft)]
    soft: Option<crate::soft::SoftSim>,
    /// The force of the step being run (its reaction pushes the soft body).
    #[cfg(scenario_soft)]
    force: Vec3,
}

impl Sim {
    /// The simulation over `world`, fed by `release`, answering on `done`.
    pub fn new(
        world: &'static mut World<'static>,
        release: ReleaseRx,
        done: DoneTx,
        calibration: Calibration,
        now_overhead: u64,
    ) -> Self {
        Self {
            world,
            release,
            done,
            drill: scenario::drill_params(),
            calibration,
            now_overhead,
            step: Stats::default(),
            whole: Stats::default(),
            worst: SimReport::default(),
            refused: 0,
            profile_from: scenario::build_number(PROFILE_FROM),
            #[cfg(scenario_soft)]
            soft: None,
            #[cfg(scenario_soft)]
            force: Vec3::ZERO,
        }
    }

    /// Gives the simulation its soft body (`builtin:firmware-soft`).
    #[cfg(scenario_soft)]
    pub fn set_soft(&mut self, soft: crate::soft::SoftSim) {
        self.soft = Some(soft);
    }

    /// Runs every released step, in order (the PendSV handler's body).
    ///
    /// # Bounded work
    /// One `World::simulate` per released step; the servo releases one a tick.
    pub fn run(&mut self) {
        while let Some(msg) = self.release.dequeue() {
            match msg {
                Release::Step {
                    tick,
                    position,
                    drill_on,
                    pressing,
                    #[cfg(scenario_soft)]
                    force,
                    servo_instructions,
                } => {
                    #[cfg(scenario_soft)]
                    {
                        self.force = force;
                    }
                    self.world.set_pressing(pressing, scenario::DT);
                    self.step(tick, position, drill_on, servo_instructions)
                }
                Release::Finish(summary) => self.finish(&summary),
            }
        }
    }

    fn step(&mut self, tick: u32, position: Vec3, drill_on: bool, servo_instructions: u32) {
        if self.profile_from == Some(tick) {
            profile_mark();
        }
        crate::fault::maybe_late(tick);
        let memo0 = (
            self.world.sphere_memo().hits(),
            self.world.sphere_memo().misses(),
        );
        let busy0 = SERVO_BUSY.load(Ordering::Acquire);
        let t0 = clock::now();
        let rep = self.world.simulate(
            position,
            scenario::RADIUS,
            scenario::REACH,
            drill_on,
            &self.drill,
        );
        let t1 = clock::now();
        let busy = SERVO_BUSY.load(Ordering::Acquire).wrapping_sub(busy0);
        let done = Done {
            tick,
            contact: *self.world.contact(),
        };
        if self.done.enqueue(done).is_err() {
            self.refused += 1;
        }
        // The step's own instructions: the servo ticks that preempted it are taken out.
        let counts = (t1 - t0).saturating_sub(busy as u64);
        let n = clock::instructions(counts).saturating_sub(self.now_overhead);
        self.step.add(tick, n);
        // The soft body's share of the tick, after the contact is handed over.
        #[cfg(scenario_soft)]
        let n = n + self.soft.as_mut().map_or(0, |s| {
            s.tick(self.world, tick, self.force, self.now_overhead)
        });
        self.whole.add(tick, n + servo_instructions as u64);
        if self.whole.max_at == tick {
            self.worst = rep;
        }
        if TICK_LOG {
            self.log(tick, n, servo_instructions, &rep, position, memo0);
        }
    }

    /// The per-step diagnostic line of [`TICK_LOG`].
    fn log(
        &self,
        tick: u32,
        sim: u64,
        servo: u32,
        rep: &SimReport,
        position: Vec3,
        memo0: (u32, u32),
    ) {
        let reach = scenario::RADIUS + scenario::REACH;
        let oh = self.now_overhead;
        let c0 = clock::now();
        nearest_visible(self.world, position, reach);
        let c1 = clock::now();
        let q0 = clock::now();
        let nq = candidate_query(self.world, position, reach);
        let q1 = clock::now();
        let d = &rep.drill;
        println!(
            "tick {} {} {} {} {} {} {} {} {} {} {} {} {} {} {}",
            tick,
            sim + servo as u64,
            sim,
            clock::instructions(c1 - c0).saturating_sub(oh),
            d.taken,
            d.expanded,
            d.visits,
            d.created,
            d.erased,
            clock::instructions(q1 - q0).saturating_sub(oh),
            nq,
            rep.contact_nodes,
            rep.candidates,
            self.world.sphere_memo().hits() - memo0.0,
            self.world.sphere_memo().misses() - memo0.1
        );
    }

    /// Prints the results (`key=value` lines) and ends the run ([`crate::exit_success`]).
    fn finish(&self, s: &Summary) -> ! {
        let cal = &self.calibration;
        println!(
            "calibration: delay loop of {} instructions measured {} (read overhead {})",
            cal.expected, cal.measured, cal.overhead
        );
        println!(
            "target={} clock_mhz={} period_instructions={}",
            crate::target::NAME,
            crate::target::CLOCK_MHZ,
            crate::target::PERIOD_INSTRUCTIONS
        );
        println!(
            "settings: scenario {} budget {} contact_nodes {} servo_lag {} zone_gather_work {}",
            scenario::NAME,
            scenario::budget(),
            scenario::contact_nodes(),
            crate::servo::LAG,
            self.world.zone_gather().map_or(0, |z| z.work())
        );
        println!("force_digest={:016x}", s.digest);
        println!("ticks={}", s.ticks);
        println!("contact_ticks={}", s.contact_ticks);
        println!("servo_latency_instructions_max={}", s.latency.max);
        println!("servo_latency_instructions_mean={}", s.latency.mean());
        println!("servo_latency_instructions_max_at={}", s.latency.max_at);
        println!("servo_tick_instructions_max={}", s.busy.max);
        println!("servo_tick_instructions_mean={}", s.busy.mean());
        println!("sim_step_instructions_max={}", self.step.max);
        println!("sim_step_instructions_mean={}", self.step.mean());
        println!("sim_step_instructions_max_at={}", self.step.max_at);
        println!("instructions_per_tick_max={}", self.whole.max);
        println!("instructions_per_tick_mean={}", self.whole.mean());
        println!("instructions_per_tick_max_at={}", self.whole.max_at);
        println!("deadline_misses={}", s.deadline_misses() + self.refused);
        println!(
            "deadline_misses_by_kind: late steps {} servo overruns {} releases refused {} contacts refused {}",
            s.late_steps,
            s.overruns,
            s.refused,
            self.refused
        );
        println!("late_ticks_held={}", s.late.held);
        println!("late_ticks_ramped={}", s.late.ramped);
        println!("late_ticks_longest_run={}", s.late.longest);
        print_late_run(&s.late);
        let w = &self.worst;
        println!(
            "worst_tick: candidates {} triangles {} contact nodes {} drill work {} created {} erased {} pending {}",
            w.candidates,
            w.triangles,
            w.contact_nodes,
            w.drill.work,
            w.drill.created,
            w.drill.erased,
            w.drill.pending
        );
        let sat = self.world.saturations();
        println!(
            "saturations={} (hash {}, candidates {}, arena {}, pending {}, contact {})",
            sat.total(),
            sat.hash,
            sat.candidates,
            sat.arena,
            sat.pending,
            sat.contact
        );
        println!("hierarchy_nodes={}", self.world.hierarchy().node_count());
        println!("stack_bytes={}", crate::memory::stack_bytes());
        let run = crate::memory::stack_max_bytes();
        let init = crate::memory::init_max_bytes();
        println!("stack_init_max_bytes={}", init);
        println!("stack_run_max_bytes={}", run);
        println!("stack_max_bytes={}", init.max(run));
        #[cfg(feature = "garbage")]
        println!("memory_at_reset={:#010x}", crate::memory::GARBAGE);
        #[cfg(scenario_soft)]
        if let Some(soft) = self.soft.as_ref() {
            soft.report();
        }
        crate::exit_success()
    }
}

/// The squared distance to the nearest visible triangle within `reach` of `centre`, over the
/// world's current candidates: the contact search of `World::simulate`, redone without its
/// hint (so a little more work than inside the step).
#[inline(never)]
fn nearest_visible(world: &World<'_>, centre: Vec3, reach: f32) -> f32 {
    world
        .hierarchy()
        .nearest_visible(
            world.mesh(),
            world.candidates(),
            centre,
            reach,
            None,
            world.contact_max_nodes(),
        )
        .d2
}

/// The candidate query of `World::simulate` redone alone (a diagnostic): the coarse tets
/// whose box meets the box `reach` around `centre`, through the static hash, each once.
#[inline(never)]
fn candidate_query(world: &World<'_>, centre: Vec3, reach: f32) -> u32 {
    let zone = tetradrill_core::hash::Aabb::point(centre).grown(reach);
    let mesh = world.mesh();
    let mut n = 0u32;
    world.hash().query_box_once(&zone, 4096, |item| {
        let t = tetradrill_core::TetId(item);
        if t.idx() < mesh.tet_count() && zone.overlaps_points(&mesh.tet_positions(t)) {
            n += 1;
        }
    });
    n
}

/// Marks where a profile starts (see [`PROFILE_FROM`]): QEMU's execution log names this
/// function when it runs.
#[inline(never)]
fn profile_mark() {
    core::hint::black_box(0u32);
}

/// `late_first_run_force_n=` the last on-time force's magnitude, then the written force's on
/// each recorded late tick of the first run (newtons, 4 decimals).
fn print_late_run(late: &crate::policy::LatePolicy) {
    let n = late.first_run_len as usize;
    let mut line: heapless::String<256> = heapless::String::new();
    for (i, f) in late.first_run[..=n.min(late.first_run.len() - 1)]
        .iter()
        .enumerate()
    {
        let sep = if i == 0 { "" } else { "," };
        let _ = core::fmt::Write::write_fmt(&mut line, format_args!("{sep}{f:.4}"));
    }
    if n > 0 {
        println!("late_first_run_force_n={}", line);
    }
}
