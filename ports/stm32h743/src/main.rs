//! tetradrill's firmware on an STM32H743: the application of the firmware package's library
//! (the servo, the simulation, the hand-offs, the scenario, the storage, the fault path), bound
//! here to the chip: clocks at 480 MHz (VOS0), the 1 kHz servo on TIM6's update interrupt at
//! the highest priority, the simulation on PendSV below it, the board's motor outputs,
//! encoders, watchdog and log ([`h743::H743`]).

#![no_std]
#![no_main]

mod h743;

use tetradrill_mps2_an386 as fw;

fw::bind_board!(h743::H743);

#[rtic::app(device = stm32h7xx_hal::pac, peripherals = true)]
mod app {
    use stm32h7xx_hal::independent_watchdog::IndependentWatchdog;
    use stm32h7xx_hal::pac;
    use stm32h7xx_hal::prelude::*;
    use stm32h7xx_hal::qei::QeiExt;
    use stm32h7xx_hal::rcc;
    use stm32h7xx_hal::timer::{Event, Timer};

    use tetradrill_mps2_an386 as fw;

    use fw::handoff::{DoneQueue, ReleaseQueue};
    use fw::println;
    use fw::servo::Servo;
    use fw::sim::Sim;

    use crate::h743::{H743, WATCHDOG_MS};

    #[shared]
    struct Shared {}

    #[local]
    struct Local {
        servo: Servo<H743>,
        sim: Sim,
        timer: Timer<pac::TIM6>,
    }

    #[init(local = [
        releases: ReleaseQueue = ReleaseQueue::new(),
        dones: DoneQueue = DoneQueue::new(),
    ])]
    fn init(cx: init::Context) -> (Shared, Local) {
        let dp = cx.device;
        let mut core = cx.core;

        // 480 MHz needs VOS0.
        let pwrcfg = dp.PWR.constrain().vos0(&dp.SYSCFG).freeze();
        let ccdr = dp
            .RCC
            .constrain()
            .sys_ck(480.MHz())
            .pll1_strategy(rcc::PllConfigStrategy::Iterative)
            .freeze(pwrcfg, &dp.SYSCFG);

        let gpioa = dp.GPIOA.split(ccdr.peripheral.GPIOA);
        let gpiob = dp.GPIOB.split(ccdr.peripheral.GPIOB);
        let gpiod = dp.GPIOD.split(ccdr.peripheral.GPIOD);
        let gpioe = dp.GPIOE.split(ccdr.peripheral.GPIOE);

        // The log: USART3 (the handle is dropped; the board writes its registers).
        let _serial = dp
            .USART3
            .serial(
                (gpiod.pd8.into_alternate(), gpiod.pd9.into_alternate()),
                115_200.bps(),
                ccdr.peripheral.USART3,
                &ccdr.clocks,
            )
            .unwrap_or_else(|_| fw::fail("USART3 refused its configuration"));

        // The enable first, low; then the direction pins and the PWM at zero duty.
        let _enable = gpioe.pe5.into_push_pull_output();
        let _dirs = (
            gpioe.pe2.into_push_pull_output(),
            gpioe.pe3.into_push_pull_output(),
            gpioe.pe4.into_push_pull_output(),
        );
        let (mut m1, mut m2, mut m3) = dp.TIM1.pwm(
            (
                gpioe.pe9.into_alternate(),
                gpioe.pe11.into_alternate(),
                gpioe.pe13.into_alternate(),
            ),
            20.kHz(),
            ccdr.peripheral.TIM1,
            &ccdr.clocks,
        );
        m1.set_duty(0);
        m2.set_duty(0);
        m3.set_duty(0);
        m1.enable();
        m2.enable();
        m3.enable();

        // The encoders.
        let encoders = (
            dp.TIM2.qei(
                (gpioa.pa15.into_alternate(), gpiob.pb3.into_alternate()),
                ccdr.peripheral.TIM2,
            ),
            dp.TIM3.qei(
                (gpiob.pb4.into_alternate(), gpiob.pb5.into_alternate()),
                ccdr.peripheral.TIM3,
            ),
            dp.TIM4.qei(
                (gpiod.pd12.into_alternate(), gpiod.pd13.into_alternate()),
                ccdr.peripheral.TIM4,
            ),
        );

        fw::memory::guard_stack(&mut core.MPU, &mut core.SCB);
        fw::fault::enable_fault_handlers(&mut core.SCB);
        // SysTick: the instruction counter of the measurements (the servo's timer is TIM6).
        let cal = fw::clock::calibrate(&mut core.SYST);
        println!(
            "target=stm32h743 sys_ck_hz={} servo=TIM6",
            ccdr.clocks.sys_ck().raw()
        );
        let world = fw::build_world();
        let (release_tx, release_rx) = cx.local.releases.split();
        let (done_tx, done_rx) = cx.local.dones.split();
        let scenario = fw::scenario::path();
        let ticks = scenario.ticks();

        let mut watchdog = IndependentWatchdog::new(dp.IWDG);
        watchdog.start(WATCHDOG_MS.millis());
        let board = H743::new(encoders, watchdog);

        let mut timer = dp.TIM6.timer(1.kHz(), ccdr.peripheral.TIM6, &ccdr.clocks);
        timer.listen(Event::TimeOut);
        let a = fw::clock::now();
        let b = fw::clock::now();
        let now_overhead = fw::clock::instructions(b - a);
        let sim = Sim::new(world, release_rx, done_tx, cal, now_overhead);
        let servo = Servo::new(board, scenario, ticks, release_tx, done_rx);
        (Shared {}, Local { servo, sim, timer })
    }

    #[idle]
    fn idle(_: idle::Context) -> ! {
        fw::memory::start_run();
        loop {
            cortex_m::asm::wfi();
        }
    }

    /// The 1 kHz servo: TIM6's update at the highest priority.
    #[task(binds = TIM6_DAC, priority = 2, local = [servo, timer])]
    fn servo_tick(cx: servo_tick::Context) {
        cx.local.timer.clear_irq();
        cx.local.servo.tick();
    }

    /// The simulation: PendSV below the servo, pended by each release.
    #[task(binds = PendSV, priority = 1, local = [sim])]
    fn simulation(cx: simulation::Context) {
        cx.local.sim.run();
    }
}
