//! tetradrill-core, unchanged, on a Cortex-M4F or a Cortex-M7 as an RTIC 2 application on
//! QEMU's MPS2 machines: a 1 kHz servo task at the highest priority and the simulation task
//! below it, preempted by it, with lock-free hand-offs between them. The application is the
//! package's library (`src/lib.rs`); this binary binds it to the MPS2 board
//! ([`tetradrill_mps2_an386::mps2::Mps2`]) and to SysTick.
//!
//! Runs on QEMU's `mps2-an386` machine (`mps2-an500` with the `m7` feature; see
//! `.cargo/config.toml`, `docs/PORTING.md`). Output goes through UART0; a run ends with a
//! reset (`-no-reboot` makes QEMU exit), its last line `exit_status=0`, or `exit_status=1`
//! after a panic, a fault or a refused storage, the motors stopped first.
//!
//! | task           | what it is here                                                          |
//! |----------------|--------------------------------------------------------------------------|
//! | `servo_tick`   | SysTick, priority 2: device read, `Servo::tick`, motor write, watchdog feed |
//! | `simulation`   | PendSV, priority 1: `Sim::run`, one `World::simulate` per release          |
//! | `idle`         | sleeps (`wfi`) between them                                               |

#![no_std]
#![no_main]

use tetradrill_mps2_an386 as fw;

fw::bind_board!(fw::mps2::Mps2);

#[rtic::app(device = tetradrill_mps2_an386::board, peripherals = false)]
mod app {
    use tetradrill_mps2_an386 as fw;

    use fw::handoff::{DoneQueue, ReleaseQueue};
    use fw::mps2::Mps2;
    use fw::println;
    use fw::servo::Servo;
    use fw::sim::Sim;

    #[shared]
    struct Shared {}

    #[local]
    struct Local {
        servo: Servo<Mps2>,
        sim: Sim,
    }

    #[init(local = [
        releases: ReleaseQueue = ReleaseQueue::new(),
        dones: DoneQueue = DoneQueue::new(),
    ])]
    fn init(cx: init::Context) -> (Shared, Local) {
        let mut core = cx.core;
        let mut board = Mps2::new();
        fw::memory::guard_stack(&mut core.MPU, &mut core.SCB);
        fw::fault::enable_fault_handlers(&mut core.SCB);
        let cal = fw::clock::calibrate(&mut core.SYST);
        let costs = fw::unit_costs(cal.overhead);
        println!(
            "unit_costs: Vec3::length {} closest_point_on_triangle {} f64 mul+add {} (instructions)",
            costs[0],
            costs[1],
            costs[2]
        );
        let world = fw::build_world();
        #[cfg(scenario_soft)]
        let soft = fw::soft::SoftSim::new(world);
        let (release_tx, release_rx) = cx.local.releases.split();
        let (done_tx, done_rx) = cx.local.dones.split();
        let scenario = fw::scenario::path();
        let ticks = scenario.ticks();
        board.start_watchdog();
        fw::clock::start_servo_timer(&mut core.SYST);
        let a = fw::clock::now();
        let b = fw::clock::now();
        let now_overhead = fw::clock::instructions(b - a);
        #[allow(unused_mut)]
        let mut sim = Sim::new(world, release_rx, done_tx, cal, now_overhead);
        #[cfg(scenario_soft)]
        sim.set_soft(soft);
        let servo = Servo::new(board, scenario, ticks, release_tx, done_rx);
        (Shared {}, Local { servo, sim })
    }

    #[idle]
    fn idle(_: idle::Context) -> ! {
        fw::memory::start_run();
        loop {
            cortex_m::asm::wfi();
        }
    }

    /// The 1 kHz servo: the SysTick exception at the highest priority.
    #[task(binds = SysTick, priority = 2, local = [servo])]
    fn servo_tick(cx: servo_tick::Context) {
        cx.local.servo.tick();
    }

    /// The simulation: PendSV below the servo, pended by each release.
    #[task(binds = PendSV, priority = 1, local = [sim])]
    fn simulation(cx: simulation::Context) {
        cx.local.sim.run();
    }
}
