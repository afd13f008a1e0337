//! The servo loop's body neither allocates nor frees after warm-up: a counting global
//! allocator, armed only on this test's thread, sees zero calls over a thousand ticks of
//! [`tetradrill::tasks::servo_io`] with the burr's law (the simulated device, the SPSC ring
//! and the contact triple buffer), in contact with a surface and out of it; nor does the way
//! back from a stall the watchdog caught ([`tetradrill::tasks::recover_from_stall`]); nor does
//! a mesh tool's tick ([`tetradrill::tasks::servo_io`] with
//! [`tetradrill::pen_tasks::PenLaw`]), nor its contact task, nor a drill's tick (with
//! [`tetradrill::tasks::DrillLaw`]: the burr's and the shaft's springs). The burr's ticks also push every
//! sample to a `--record` ring (full half of the time), record the timing histograms, look at
//! a stop request and end with the zero-force write of a clean stop.
//!
//! A test binary of its own: a global allocator is the whole process's, so the other tests
//! neither run under the counting one nor beside these.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

use crossbeam::queue::ArrayQueue;
use tetradrill::engine::TickParams;
use tetradrill::pen::PenRig;
use tetradrill::pen_pair::with_pass_runner;
use tetradrill::pen_tasks::{held_handoff, pen_contact_task, PenLaw, PenTaskReport};
use tetradrill::scenario::Scenario;
use tetradrill::setup::Setup;
use tetradrill::tasks::{
    recover_from_stall, servo_io, servo_tick, BurrLaw, DrillContact, DrillLaw, RecordRing,
    ServoCounters, ServoState, Shared, SimStatus, ToolSample, Workspace,
};
use tetradrill::watchdog::{zero_force, ServoWatch, StopRequest};
use tetradrill_core::force::{pen_pass, PenState};
use tetradrill_core::servo::ContactState;
use tetradrill_core::Vec3;
use tetradrill_device::{
    ForceCommand, HapticDevice, PathPoint, Scripted, SimConfig, SimDevice, Still, QUAT_IDENTITY,
};

struct Counting;

thread_local! {
    static ARMED: Cell<bool> = const { Cell::new(false) };
    static CALLS: Cell<u64> = const { Cell::new(0) };
}

fn note() {
    // `try_with`: the allocator may run while thread locals are torn down.
    let _ = ARMED.try_with(|a| {
        if a.get() {
            let _ = CALLS.try_with(|c| c.set(c.get() + 1));
        }
    });
}

// SAFETY: forwards every call to the system allocator unchanged; only counts them.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        note();
        // SAFETY: same contract as the caller's.
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        note();
        // SAFETY: same contract as the caller's.
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        note();
        // SAFETY: same contract as the caller's.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static ALLOC: Counting = Counting;

#[test]
fn servo_tick_allocates_nothing_after_warm_up() {
    let params = TickParams::of(&Setup::default()).expect("default scenario");
    // The stylus goes down through z = 0.5 and back up: out of contact, in it, out again.
    let path = Scripted(|t: f64| PathPoint {
        position: [0.0, 0.0, 0.8 - 0.5 * (t * 3.0).sin().abs()],
        rotation: QUAT_IDENTITY,
        buttons: 1,
    });
    let mut device = SimDevice::new(path, SimConfig::default());
    let ring = ArrayQueue::new(64);
    let plane = ContactState {
        valid: true,
        point: Vec3::new(0.0, 0.0, 0.5),
        normal: Vec3::Z,
        depth: 0.0,
        centre: Vec3::new(0.0, 0.0, 0.6),
        triangles: 1,
        stiffness: 0.0,
        vibration: tetradrill_core::servo::VibrationCue::default(),
        friction: 0.0,
    };
    let (mut input, mut output) =
        triple_buffer::TripleBuffer::new(&ContactState::default()).split();
    input.write(plane);
    let ws = Workspace {
        scale: 1.0,
        offset: Vec3::ZERO,
    };
    let record = std::sync::Arc::new(RecordRing::new(64));
    let mut st = ServoState {
        record: Some(record.clone()),
        ..ServoState::default()
    };
    let request = StopRequest::new();
    // The burr's law as the servo task runs it (the controls' atomics read every tick).
    let counters = ServoCounters::default();
    let mut law = BurrLaw::new(params, &mut output, &counters);
    let mut window_max = 0;
    let mut run = |from: u64, to: u64, st: &mut ServoState| {
        for tick in from..to {
            assert!(!request.is_requested());
            servo_io(&mut device, &ws, &mut law, &ring, st, tick).expect("tick");
            counters.record_wake(tick * 7919 % 3_000_000, tick, &mut window_max);
            counters.tick.record(tick * 104_729 % 200_000);
            // The simulation side drains the ring, the recorder its own every 128 ticks, so
            // that one is full half of the time (not counted: they are other tasks).
            if tick % 16 == 0 {
                ARMED.with(|a| a.set(false));
                while ring.pop().is_some() {}
                if tick % 128 == 0 {
                    while record.pop().is_some() {}
                }
                ARMED.with(|a| a.set(true));
            }
        }
    };
    ARMED.with(|a| a.set(false));
    run(0, 100, &mut st);
    CALLS.with(|c| c.set(0));
    ARMED.with(|a| a.set(true));
    run(100, 1100, &mut st);
    // A clean stop's tick: the request seen, zero force through the cutoff and the device.
    let cutoff = device.cutoff();
    ARMED.with(|a| a.set(false));
    request.request();
    ARMED.with(|a| a.set(true));
    assert!(request.is_requested());
    zero_force(&mut device, cutoff.as_deref()).expect("zero force");
    ARMED.with(|a| a.set(false));
    let calls = CALLS.with(|c| c.get());
    assert!(
        st.max_force > 0.0,
        "the stylus reached the surface: the contact path ran"
    );
    assert!(record.dropped() > 0, "the record ring was full at times");
    assert_eq!(counters.wake.count(), 1100);
    assert_eq!(device.applied_force(), [0.0; 3]);
    assert_eq!(calls, 0, "the servo tick allocated or freed {calls} times");

    // The counter itself works: an allocation on this thread while armed is seen.
    ARMED.with(|a| a.set(true));
    let v = std::hint::black_box(vec![1u8; 10]);
    ARMED.with(|a| a.set(false));
    drop(v);
    assert!(CALLS.with(|c| c.get()) >= 1);
}

#[test]
fn coming_back_from_a_stall_allocates_nothing() {
    let params = TickParams::of(&Setup::default()).expect("default scenario");
    let mut device = SimDevice::new(Still([0.0, 0.0, 0.55]), SimConfig::default());
    let cutoff = device.cutoff().expect("the simulated device has a cutoff");
    let watch = ServoWatch::default();
    let ring = ArrayQueue::new(64);
    let plane = ContactState {
        valid: true,
        point: Vec3::new(0.0, 0.0, 0.5),
        normal: Vec3::Z,
        depth: 0.0,
        centre: Vec3::new(0.0, 0.0, 0.6),
        triangles: 1,
        stiffness: 0.0,
        vibration: tetradrill_core::servo::VibrationCue::default(),
        friction: 0.0,
    };
    let ws = Workspace {
        scale: 1.0,
        offset: Vec3::ZERO,
    };
    let mut st = ServoState::default();
    let tick = |t: u64, st: &mut ServoState, device: &mut SimDevice<Still>| {
        recover_from_stall(device, Some(&*cutoff), &watch, 0);
        servo_tick(device, &ws, &params, &plane, &ring, st, t).expect("tick");
        watch.beat(t + 1);
        while ring.pop().is_some() {}
    };
    ARMED.with(|a| a.set(false));
    for t in 0..600 {
        tick(t, &mut st, &mut device);
    }
    assert!(device.applied_force()[2] > 0.0, "in contact before the cut");
    // The watchdog's cut (another thread's job; the atomics are the same from here), then the
    // servo's ticks: the way back and the ramp, counted.
    cutoff.cut().expect("cut");
    CALLS.with(|c| c.set(0));
    ARMED.with(|a| a.set(true));
    let came_back = recover_from_stall(&mut device, Some(&*cutoff), &watch, 0);
    for t in 600..700 {
        tick(t, &mut st, &mut device);
    }
    ARMED.with(|a| a.set(false));
    let calls = CALLS.with(|c| c.get());
    assert!(came_back, "the latch was seen");
    assert!(!cutoff.is_cut(), "re-armed");
    let f = device.applied_force()[2];
    assert!(
        f > 0.0 && device.motors().output() != ForceCommand::OFF,
        "force again: {f}"
    );
    assert_eq!(calls, 0, "coming back allocated or freed {calls} times");
}

/// The mesh tool's servo tick ([`servo_io`] with [`PenLaw`]): the pen's tip pressed into the
/// block's top face and lifted, tilting, while another task (here the same thread, disarmed)
/// publishes a contact pass every third tick; a thousand armed ticks allocate nothing.
#[test]
fn the_pen_servo_tick_allocates_nothing_after_warm_up() {
    let pen = tetradrill_tests::mesh("models/pen_tool_gmsh.mesh");
    let sc = Scenario {
        tool: format!("mesh:{}", pen.display()),
        tool_scale: 5.0,
        stiffness: 20.0,
        ..Scenario::default()
    }
    .setup()
    .expect("a valid set-up");
    let obj = tetradrill::engine::load_mesh(&sc).expect("block").mesh;
    let tool = tetradrill::meshio::load(&pen, sc.tool.scale()).expect("pen");
    let opts = tetradrill::pen::options(&sc);
    let path = Scripted(|t: f64| {
        let a = 0.4 * (t * 2.0).sin();
        PathPoint {
            position: [0.1 * (t * 3.0).sin(), 0.0, 0.5 - 0.04 * (t * 5.0).sin()],
            rotation: [(a / 2.0).cos(), 0.0, (a / 2.0).sin(), 0.0],
            buttons: 0,
        }
    });
    let mut device = SimDevice::new(path, SimConfig::default());
    let ws = Workspace {
        scale: 1.0,
        offset: Vec3::ZERO,
    };
    let mut rig = PenRig {
        pen: tool.mesh,
        obj,
    };
    let ((calls, max_force), _) = rig
        .with_sizes(sc.capacities.pen(), |scene, bufs| {
            let ring = ArrayQueue::new(64);
            let (mut held_in, held_out) = held_handoff(bufs.pen_pens.len(), bufs.object_pens.len());
            let counters = ServoCounters::default();
            let mut law = PenLaw::new(scene, &counters, held_out, opts);
            let mut pass_state = PenState::default();
            let mut st = ServoState::default();
            let mut run = |from: u64, to: u64, st: &mut ServoState| {
                for tick in from..to {
                    servo_io(&mut device, &ws, &mut law, &ring, st, tick).expect("tick");
                    // The contact task's share (not counted: another task).
                    ARMED.with(|a| a.set(false));
                    let mut latest = None;
                    while let Some(s) = ring.pop() {
                        latest = Some(s);
                    }
                    if let Some(s) = latest.filter(|_| tick % 3 == 0) {
                        let pass =
                            pen_pass(scene, bufs, s.position, s.rotation, &opts, &mut pass_state);
                        let (np, no) = pass.penetrations;
                        held_in.input_buffer_mut().set(
                            tick + 1,
                            &s,
                            &bufs.pen_pens[..np],
                            &bufs.object_pens[..no],
                        );
                        held_in.publish();
                    }
                    ARMED.with(|a| a.set(true));
                }
            };
            ARMED.with(|a| a.set(false));
            run(0, 100, &mut st);
            // What the armed ticks did, alone.
            st.max_force = 0.0;
            CALLS.with(|c| c.set(0));
            ARMED.with(|a| a.set(true));
            run(100, 1100, &mut st);
            ARMED.with(|a| a.set(false));
            (CALLS.with(|c| c.get()), st.max_force)
        })
        .expect("the rig");
    assert!(
        max_force > 0.0,
        "the pen touched the block in the armed ticks: the carry ran"
    );
    assert_eq!(
        calls, 0,
        "the pen's servo tick allocated or freed {calls} times"
    );
}

/// The pen's contact task ([`pen_contact_task`], headless) allocates nothing after start-up:
/// armed on the task's own thread while another thread feeds it tool samples pressing the
/// tip into the block and lifting it, it runs its passes and publishes them with no
/// allocator call (its pass-time vector has its room beforehand); on one thread and with the
/// passes' object side on a second ([`with_pass_runner`]: the hand-overs allocate nothing
/// either, on the task's thread).
#[test]
fn the_pen_contact_task_allocates_nothing() {
    for threads in [1, 2] {
        contact_task_allocates_nothing(threads);
    }
}

fn contact_task_allocates_nothing(threads: u32) {
    let pen = tetradrill_tests::mesh("models/pen_tool_gmsh.mesh");
    let sc = Scenario {
        tool: format!("mesh:{}", pen.display()),
        tool_scale: 5.0,
        ..Scenario::default()
    }
    .setup()
    .expect("a valid set-up");
    let obj = tetradrill::engine::load_mesh(&sc).expect("block").mesh;
    let tool = tetradrill::meshio::load(&pen, sc.tool.scale()).expect("pen");
    let opts = tetradrill::pen::options(&sc);
    let mut rig = PenRig {
        pen: tool.mesh,
        obj,
    };
    let ((calls, report), _) = rig
        .with_sizes(sc.capacities.pen(), |scene, bufs| {
            let shared = Shared::new();
            let (mut held_in, held_out) = held_handoff(bufs.pen_pens.len(), bufs.object_pens.len());
            let (mut status_in, mut status_out) =
                triple_buffer::TripleBuffer::new(&SimStatus::default()).split();
            let mut report = PenTaskReport::new();
            let calls = std::thread::scope(|s| {
                let sh = &shared;
                let task = s.spawn(|| {
                    with_pass_runner(scene, bufs, threads, |runner| {
                        CALLS.with(|c| c.set(0));
                        ARMED.with(|a| a.set(true));
                        pen_contact_task(
                            runner,
                            &opts,
                            sh,
                            &mut held_in,
                            &mut status_in,
                            &mut report,
                            None,
                        );
                        ARMED.with(|a| a.set(false));
                        CALLS.with(|c| c.get())
                    })
                });
                // At least 2,000 samples and 20 passes (a loaded machine runs fewer passes
                // over the same samples), at most 200,000 samples.
                for tick in 0..200_000u64 {
                    if tick >= 2000 && status_out.read().steps >= 20 {
                        break;
                    }
                    let t = tick as f32 / 1000.0;
                    let sample = ToolSample {
                        tick,
                        position: Vec3::new(
                            0.1 * (t * 3.0).sin(),
                            0.0,
                            0.5 - 0.04 * (t * 5.0).sin(),
                        ),
                        rotation: glam::Quat::from_rotation_y(0.3 * (t * 2.0).sin()),
                        buttons: 0,
                    };
                    while sh.ring.push(sample).is_err() {
                        std::thread::yield_now();
                    }
                    if tick % 50 == 0 {
                        std::thread::sleep(std::time::Duration::from_millis(1));
                    }
                }
                sh.stop.store(true, std::sync::atomic::Ordering::Relaxed);
                task.join().expect("the contact task")
            });
            drop(held_out);
            (calls, report)
        })
        .expect("the rig");
    assert!(
        report.passes > 10,
        "{threads} threads: {} passes",
        report.passes
    );
    assert!(
        report.pen_collisions_max > 0,
        "{threads} threads: the pen went in"
    );
    assert_eq!(
        calls, 0,
        "{threads} threads: the contact task allocated or freed {calls} times"
    );
}

#[test]
fn a_drill_servo_tick_allocates_nothing_after_warm_up() {
    let sc = Scenario {
        tool: "drill:0.1:0.6:0.03".into(),
        ..Scenario::default()
    }
    .setup()
    .expect("a valid set-up");
    let params = TickParams::of(&sc).expect("a drill scenario");
    let tool = params.shaft.expect("a drill");
    // The tool lying along +x (a quarter turn about y), going down through z = 0.5 and back
    // up: the burr and every passive point spring from the top face's plane.
    let q = tetradrill_core::Quat::from_rotation_y(std::f32::consts::FRAC_PI_2);
    let path = Scripted(move |t: f64| PathPoint {
        position: [0.0, 0.0, 0.8 - 0.5 * (t * 3.0).sin().abs()],
        rotation: [q.w as f64, q.x as f64, q.y as f64, q.z as f64],
        buttons: 0,
    });
    let mut device = SimDevice::new(path, SimConfig::default());
    let ring = ArrayQueue::new(64);
    let top = (Vec3::new(0.0, 0.0, 0.5), Vec3::Z);
    let mut planes = DrillContact {
        burr: ContactState {
            valid: true,
            point: top.0,
            normal: top.1,
            depth: 0.0,
            centre: Vec3::new(0.0, 0.0, 0.6),
            triangles: 1,
            stiffness: 0.0,
            vibration: tetradrill_core::servo::VibrationCue::default(),
            friction: 0.0,
        },
        ..DrillContact::default()
    };
    planes.shaft.count = tool.passive_count();
    for p in planes.shaft.points.iter_mut() {
        p.plane = Some(top);
    }
    let (mut input, mut output) = triple_buffer::TripleBuffer::new(&planes).split();
    input.write(planes);
    let ws = Workspace {
        scale: 1.0,
        offset: Vec3::ZERO,
    };
    let mut st = ServoState::default();
    let counters = ServoCounters::default();
    let mut law = DrillLaw::new(params, tool, &mut output, &counters);
    let mut run = |from: u64, to: u64, st: &mut ServoState, law: &mut DrillLaw<'_>| {
        for tick in from..to {
            servo_io(&mut device, &ws, law, &ring, st, tick).expect("tick");
            if tick % 16 == 0 {
                ARMED.with(|a| a.set(false));
                while ring.pop().is_some() {}
                ARMED.with(|a| a.set(true));
            }
        }
    };
    ARMED.with(|a| a.set(false));
    run(0, 100, &mut st, &mut law);
    CALLS.with(|c| c.set(0));
    ARMED.with(|a| a.set(true));
    run(100, 1100, &mut st, &mut law);
    ARMED.with(|a| a.set(false));
    let calls = CALLS.with(|c| c.get());
    assert!(
        law.counts.pushing_ticks > 0,
        "the shaft pushed: {:?}",
        law.counts
    );
    assert!(st.max_force > 0.0);
    assert_eq!(
        calls, 0,
        "the drill's servo tick allocated or freed {calls} times"
    );
}
