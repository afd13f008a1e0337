//! The servo on a thread of its own beside the simulation, through the C interface: the two
//! calls overlap freely and the drilling still removes what the host's replay removes.

use std::ptr;
use std::sync::atomic::{AtomicBool, AtomicU32, Ordering};

use tetradrill_ffi::*;

mod common;
use common::*;

/// A pointer that crosses to the servo's thread (the interface's contract makes the servo's
/// memory the servo's alone).
struct ServoPtr(*mut TdServo);
// SAFETY: the servo's part of the world's memory is used by that thread alone while it runs.
unsafe impl Send for ServoPtr {}

/// The firmware scenario with the servo on a thread of its own, free-running beside the
/// steps: every call succeeds, the servo sees the steps in order, and the drilling (no
/// materials here, so the pressing force does not steer it) removes what the host's replay
/// removes.
#[test]
fn a_servo_thread_beside_the_steps_sees_them_in_order() {
    let sc = builtin("firmware");
    let host = host_replay(&sc);
    let p = params_of(&sc, 4);
    let (xyz, tets) = block_arrays(4);
    let (mut size, mut align) = (0usize, 0usize);
    let mut world: *mut TdWorld = ptr::null_mut();
    let mut servo: *mut TdServo = ptr::null_mut();
    // SAFETY: valid pointers; memory of the size and alignment asked for.
    let mem = unsafe {
        assert_eq!(td_world_size(&p, &mut size, &mut align), TdStatus::TdOk);
        let mem = Memory::new(size, align);
        let st = td_world_init(
            mem.ptr.cast(),
            size,
            &p,
            xyz.as_ptr(),
            tets.as_ptr(),
            ptr::null(),
            &mut world,
            ptr::null_mut(),
        );
        assert_eq!(st, TdStatus::TdOk);
        assert_eq!(td_world_servo(world, &mut servo), TdStatus::TdOk);
        mem
    };
    let (tick, done) = (AtomicU32::new(0), AtomicBool::new(false));
    // The step the servo last rendered from, u32::MAX before its first tick.
    let seen = AtomicU32::new(u32::MAX);
    let handle = ServoPtr(servo);
    let (ticks, steps_seen) = std::thread::scope(|s| {
        let servo_thread = s.spawn(|| {
            let servo = handle;
            let (mut ticks, mut last, mut steps_seen) = (0u64, 0u32, 0u32);
            while !done.load(Ordering::Acquire) {
                let (mut pos, mut buttons, mut f) = (TdVec3::default(), 0u32, TdVec3::default());
                let mut c = TdServoCounts::default();
                // SAFETY: this thread is the servo's only caller.
                unsafe {
                    let i = tick.load(Ordering::Relaxed);
                    assert_eq!(td_demo_pose(i, &mut pos, &mut buttons), TdStatus::TdOk);
                    assert_eq!(td_servo_force(servo.0, pos, &mut f), TdStatus::TdOk);
                    assert_eq!(td_servo_counters(servo.0, &mut c), TdStatus::TdOk);
                }
                assert!(c.step >= last, "step {} after {last}", c.step);
                steps_seen += u32::from(c.step != last);
                last = c.step;
                seen.store(c.step, Ordering::Release);
                ticks += 1;
                assert!(f.x.is_finite() && f.y.is_finite() && f.z.is_finite());
            }
            (ticks, steps_seen)
        });
        // Waits (a bounded time, and not for a servo thread that stopped) until the servo has
        // rendered from step `step`.
        let wait_for = |step: u32| {
            let start = std::time::Instant::now();
            while seen.load(Ordering::Acquire) != step
                && !servo_thread.is_finished()
                && start.elapsed().as_secs() < 60
            {
                std::thread::yield_now();
            }
        };
        wait_for(0);
        for i in 0..td_demo_ticks() {
            let (mut pos, mut buttons) = (TdVec3::default(), 0u32);
            tick.store(i, Ordering::Relaxed);
            // SAFETY: this thread is the world's only caller.
            unsafe {
                assert_eq!(td_demo_pose(i, &mut pos, &mut buttons), TdStatus::TdOk);
                assert_eq!(
                    td_world_simulate(world, pos, buttons, ptr::null_mut()),
                    TdStatus::TdOk
                );
            }
        }
        wait_for(td_demo_ticks());
        done.store(true, Ordering::Release);
        servo_thread.join().expect("the servo thread")
    });
    let (mut c, mut sc) = (TdCounters::default(), TdServoCounts::default());
    let mut f = TdVec3::default();
    // SAFETY: both threads are done; the world and its servo are this thread's again.
    unsafe {
        assert_eq!(
            td_servo_force(servo, TdVec3::default(), &mut f),
            TdStatus::TdOk
        );
        assert_eq!(td_servo_counters(servo, &mut sc), TdStatus::TdOk);
        assert_eq!(td_world_counters(world, &mut c), TdStatus::TdOk);
    }
    assert_eq!(
        sc.step,
        td_demo_ticks(),
        "the last step's contact, once both are done"
    );
    assert_eq!(sc.servo_ticks, ticks + 1);
    assert!(ticks >= 2, "a tick before the steps and one after");
    assert!(steps_seen >= 1, "the servo saw the steps go by");
    assert_eq!(c.removed_volume, host.removed);
    drop(mem);
}
