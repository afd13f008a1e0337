//! tetradrill-core, unchanged, on a Cortex-M4F: the host's `builtin:firmware` scenario tick by
//! tick, with the force digest the host's `replay` prints and instruction counts per tick.
//!
//! Runs on QEMU's `mps2-an386` machine (see `.cargo/config.toml`, `docs/PORTING.md`). Output
//! and exit status go through semihosting; a panic or a fault exits non-zero.
//!
//! | piece          | what it is here                                                      |
//! |----------------|----------------------------------------------------------------------|
//! | [`storage`]    | every slice the core borrows, in statics sized by `WorldSizes`       |
//! | [`clock`]      | SysTick as an instruction counter under `-icount`                    |
//! | [`main`]       | build the block, the world, run the script, print, exit              |
//!
//! Every tick does exactly what the host's `engine::tick` does: `World::simulate` at the
//! scripted pose, then `servo_force` at the same pose, then the digest.

#![no_std]
#![no_main]

mod clock;
mod storage;

use cortex_m_rt::{entry, exception, ExceptionFrame};
use cortex_m_semihosting::{debug, hprintln};

use tetradrill_core::builtin;
use tetradrill_core::drill::DrillParams;
use tetradrill_core::force::{closest_point_on_triangle, ForceDigest, ForceParams, ToolState};
use tetradrill_core::mesh::{BuildOptions, FaceKey, Mesh, MeshStorage};
use tetradrill_core::script::{DEMO, DRILL_ON};
use tetradrill_core::servo::{servo_force, SimReport, World};
use tetradrill_core::Vec3;

use storage::{Storage, NODES, TETS};

/// Cubes per side of the built-in block (`builtin:block:4`).
pub const BLOCK_N: usize = 4;
/// Hierarchy arena nodes (`hierarchy_capacity` of `builtin:firmware`).
pub const ARENA: usize = 20_000;
/// Scripted ticks to run: the whole demo path (6001), or fewer when set at build time with
/// `TETRADRILL_TICKS=N` (the host then runs `replay --ticks N`).
const TICKS: Option<&str> = option_env!("TETRADRILL_TICKS");
/// Set at build time (`TETRADRILL_TICK_LOG=1`) to print one line per tick: instructions
/// (whole tick, simulate, the contact query redone) and the drill's counts (items taken, nodes
/// expanded, NTree nodes visited, nodes created, leaves erased), for fitting the drill's work
/// weights (`scripts/fit-work-weights.py`); then the candidate query redone (instructions,
/// tets), the contact search's nodes, the step's candidates, and the sphere memo's hits and
/// misses in the step.
const TICK_LOG: bool = option_env!("TETRADRILL_TICK_LOG").is_some();
/// Set at build time (`TETRADRILL_PROFILE_FROM=N`) to call [`profile_mark`] before tick N:
/// `scripts/m4-profile.sh` counts QEMU's executed blocks from that call on, so the profile
/// covers the ticks from N (where the worst ticks are) and not the start-up.
const PROFILE_FROM: Option<&str> = option_env!("TETRADRILL_PROFILE_FROM");

/// The scenario's numbers exactly as the host derives them (`TickParams::of`): the host parses
/// f64 and converts to f32, so the firmware writes the same f64 literals and converts.
mod scenario {
    /// `tool = "sphere:0.1"`.
    pub const RADIUS: f32 = 0.1_f64 as f32;
    /// The servo's extrapolation range: half the radius.
    pub const REACH: f32 = 0.5 * RADIUS;
    /// N/m.
    pub const STIFFNESS: f32 = 200.0_f64 as f32;
    /// N s/m.
    pub const DAMPING: f32 = 0.5_f64 as f32;
    /// N.
    pub const MAX_FORCE: f32 = 8.0_f64 as f32;
    /// `PERIOD_S` of the host, 1 kHz.
    pub const DT: f32 = 1e-3_f64 as f32;
    /// Deepest refinement level.
    pub const MAX_DEPTH: u8 = 4;
    /// Smallest face area refined.
    pub const MIN_AREA: f32 = 0.0_f64 as f32;
    /// Drill work units per tick.
    pub const BUDGET: u32 = 300;
    /// Drill work units per tick for this build: [`BUDGET`], or `TETRADRILL_BUDGET=N` at build
    /// time for a settings sweep (the host then runs `replay --scenario builtin:firmware
    /// --budget-per-tick N`).
    pub fn budget() -> u32 {
        super::build_number(option_env!("TETRADRILL_BUDGET")).unwrap_or(BUDGET)
    }
    /// Hierarchy nodes one contact search may test (`contact_search_nodes`).
    pub const CONTACT_NODES: u32 = 64;
    /// [`CONTACT_NODES`], or `TETRADRILL_CONTACT_NODES=N` at build time (host:
    /// `--contact-search-nodes N`).
    pub fn contact_nodes() -> u32 {
        super::build_number(option_env!("TETRADRILL_CONTACT_NODES")).unwrap_or(CONTACT_NODES)
    }
}

#[entry]
fn main() -> ! {
    let cp = cortex_m::Peripherals::take().unwrap_or_else(|| fail("peripherals taken twice"));
    let mut clock = clock::Clock::start(cp.SYST);
    let cal = clock.calibrate();
    hprintln!(
        "calibration: delay loop of {} instructions measured {} (read overhead {})",
        cal.expected,
        cal.measured,
        cal.overhead
    );

    let costs = unit_costs(&mut clock, cal.overhead);
    hprintln!(
        "unit_costs: Vec3::length {} closest_point_on_triangle {} f64 mul+add {} (instructions)",
        costs[0],
        costs[1],
        costs[2]
    );

    hprintln!(
        "settings: budget {} contact_nodes {}",
        scenario::budget(),
        scenario::contact_nodes()
    );

    let st = Storage::take();

    // The unit block, exactly as the host's `builtin:block:N` makes it.
    let edge = 1.0 / BLOCK_N as f32;
    let mut tet_nodes = [[0u32; 4]; TETS];
    if builtin::block(
        BLOCK_N,
        edge,
        Vec3::splat(-0.5),
        st.positions,
        &mut tet_nodes,
    )
    .is_none()
    {
        fail("block storage too small");
    }
    let mesh = build_mesh(st.positions, &tet_nodes, st.mesh);
    let mut world = World::new(mesh, st.world).unwrap_or_else(|_| fail("world storage refused"));
    world.set_contact_max_nodes(scenario::contact_nodes());

    let drill = DrillParams {
        max_depth: scenario::MAX_DEPTH,
        min_area: scenario::MIN_AREA,
        budget: scenario::budget(),
    };
    let force = ForceParams {
        stiffness: scenario::STIFFNESS,
        damping: scenario::DAMPING,
        max_force: scenario::MAX_FORCE,
        dt: scenario::DT,
        ..ForceParams::default()
    };
    let ticks = TICKS
        .and_then(|s| s.parse::<u32>().ok())
        .map_or(DEMO.ticks(), |t| t.min(DEMO.ticks()));

    let mut tool = ToolState::default();
    let mut digest = ForceDigest::new();
    let mut whole = clock::Stats::default();
    let mut sim = clock::Stats::default();
    let mut servo = clock::Stats::default();
    let mut contact = clock::Stats::default();
    let mut query = clock::Stats::default();
    let mut worst = SimReport::default();
    let mut contact_ticks = 0u32;
    let run_start = clock.now();
    let profile_from = PROFILE_FROM.and_then(|s| s.parse::<u32>().ok());
    for i in 0..ticks {
        if profile_from == Some(i) {
            profile_mark();
        }
        let (position, buttons) = DEMO.at(i);
        let drill_on = buttons & DRILL_ON != 0;
        let memo0 = (world.sphere_memo().hits(), world.sphere_memo().misses());
        let t0 = clock.now();
        let rep = world.simulate(
            position,
            scenario::RADIUS,
            scenario::REACH,
            drill_on,
            &drill,
        );
        let t1 = clock.now();
        let f = servo_force(
            world.contact(),
            position,
            scenario::RADIUS,
            &mut tool,
            &force,
        );
        let t2 = clock.now();
        digest.push(f);
        if f != Vec3::ZERO {
            contact_ticks += 1;
        }
        let oh = cal.overhead;
        sim.add(i, clock::instructions(t1 - t0).saturating_sub(oh));
        servo.add(i, clock::instructions(t2 - t1).saturating_sub(oh));
        whole.add(i, clock::instructions(t2 - t0).saturating_sub(2 * oh));
        if whole.max_at == i {
            worst = rep;
        }
        // Diagnostics, outside the tick (and left out of a profile): the contact search and
        // the candidate query of `simulate` done again, to split the simulation's cost into
        // query, contact and drill.
        let (mut c0, mut c1, mut q0, mut q1, mut nq) = (0, 0, 0, 0, 0);
        if profile_from.is_none() {
            c0 = clock.now();
            nearest_visible(&world, position, scenario::RADIUS + scenario::REACH);
            c1 = clock.now();
            contact.add(i, clock::instructions(c1 - c0).saturating_sub(oh));
            q0 = clock.now();
            nq = candidate_query(&world, position, scenario::RADIUS + scenario::REACH);
            q1 = clock.now();
            query.add(i, clock::instructions(q1 - q0).saturating_sub(oh));
        }
        if TICK_LOG {
            let d = &rep.drill;
            hprintln!(
                "tick {} {} {} {} {} {} {} {} {} {} {} {} {} {} {}",
                i,
                clock::instructions(t2 - t0).saturating_sub(2 * oh),
                clock::instructions(t1 - t0).saturating_sub(oh),
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
                world.sphere_memo().hits() - memo0.0,
                world.sphere_memo().misses() - memo0.1
            );
        }
    }
    let total = clock::instructions(clock.now() - run_start);

    let sat = world.saturations();
    hprintln!("force_digest={:016x}", digest.value());
    hprintln!("ticks={}", ticks);
    hprintln!("contact_ticks={}", contact_ticks);
    hprintln!("instructions_per_tick_max={}", whole.max);
    hprintln!("instructions_per_tick_mean={}", whole.mean());
    hprintln!("instructions_per_tick_max_at={}", whole.max_at);
    hprintln!("simulate_instructions_max={}", sim.max);
    hprintln!("simulate_instructions_mean={}", sim.mean());
    hprintln!("servo_force_instructions_max={}", servo.max);
    hprintln!("servo_force_instructions_mean={}", servo.mean());
    hprintln!("contact_query_instructions_max={}", contact.max);
    hprintln!("contact_query_instructions_mean={}", contact.mean());
    hprintln!("candidate_query_instructions_max={}", query.max);
    hprintln!("candidate_query_instructions_mean={}", query.mean());
    hprintln!(
        "worst_tick: candidates {} triangles {} contact nodes {} drill work {} created {} erased {} pending {}",
        worst.candidates,
        worst.triangles,
        worst.contact_nodes,
        worst.drill.work,
        worst.drill.created,
        worst.drill.erased,
        worst.drill.pending
    );
    hprintln!("instructions_total={}", total);
    hprintln!(
        "saturations={} (hash {}, candidates {}, arena {}, pending {}, contact {})",
        sat.total(),
        sat.hash,
        sat.candidates,
        sat.arena,
        sat.pending,
        sat.contact
    );
    hprintln!("hierarchy_nodes={}", world.hierarchy().node_count());
    debug::exit(debug::EXIT_SUCCESS);
    loop {
        cortex_m::asm::nop();
    }
}

/// The squared distance to the nearest visible triangle within `reach` of `centre`, over the
/// world's current candidates: the contact search of `World::simulate`, redone without its
/// hint (so a little more work than inside the tick).
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

/// A whole number given at build time (an empty or unset variable is `None`).
fn build_number(v: Option<&str>) -> Option<u32> {
    v.and_then(|s| s.parse().ok())
}

/// Marks where a profile starts (see [`PROFILE_FROM`]): QEMU's execution log names this
/// function when it runs.
#[inline(never)]
fn profile_mark() {
    core::hint::black_box(0u32);
}

/// The candidate query of `World::simulate` redone alone (a diagnostic): the coarse tets
/// whose box meets the box `reach` around `centre`, through the static hash, each once. The
/// tick's own query also covers the burr positions it queues, so this is a little less.
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

/// Instructions for a few primitives the core leans on (a diagnostic for docs/PORTING.md):
/// `Vec3::length` (glam through libm's software `sqrtf` on this target), the point-triangle
/// distance, and one f64 multiply-add (software on a single-precision FPU).
#[inline(never)]
fn unit_costs(clock: &mut clock::Clock, overhead: u64) -> [u64; 3] {
    use core::hint::black_box;
    let v = black_box(Vec3::new(0.3, -0.2, 0.7));
    let tri = black_box([
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::new(1.0, 0.0, 0.1),
        Vec3::new(0.0, 1.0, 0.2),
    ]);
    let (a, b, c) = (black_box(1.25f64), black_box(3.5f64), black_box(0.75f64));
    let t0 = clock.now();
    black_box(black_box(v).length());
    let t1 = clock.now();
    black_box(closest_point_on_triangle(black_box(v), tri));
    let t2 = clock.now();
    black_box(black_box(a) * b + c);
    let t3 = clock.now();
    [t1 - t0, t2 - t1, t3 - t2].map(|d| clock::instructions(d).saturating_sub(overhead))
}

/// Builds the core mesh over the static storage. The face scratch (`4 * TETS` keys, 24 KB) is
/// needed only here, so it lives on this function's stack frame and is free afterwards.
#[inline(never)]
fn build_mesh(
    positions: &'static mut [Vec3],
    tet_nodes: &[[u32; 4]],
    storage: MeshStorage<'static>,
) -> Mesh<'static> {
    let mut scratch = [FaceKey::default(); 4 * TETS];
    debug_assert_eq!(positions.len(), NODES);
    Mesh::build(
        positions,
        tet_nodes,
        storage,
        &mut scratch,
        BuildOptions::default(),
    )
    .unwrap_or_else(|_| fail("mesh build failed"))
}

/// Prints `reason` and exits QEMU with a failure status.
fn fail(reason: &str) -> ! {
    hprintln!("error: {}", reason);
    exit_failure()
}

fn exit_failure() -> ! {
    debug::exit(debug::EXIT_FAILURE);
    loop {
        cortex_m::asm::nop();
    }
}

#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    hprintln!("panic: {}", info);
    exit_failure()
}

// cortex-m-rt requires the HardFault handler to be declared `unsafe fn`; its body is safe.
#[exception]
unsafe fn HardFault(ef: &ExceptionFrame) -> ! {
    hprintln!("hard fault at pc {:#010x}", ef.pc());
    exit_failure()
}

#[exception]
fn SysTick() {
    clock::wrapped();
}
