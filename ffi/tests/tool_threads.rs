//! The drill's and the pen's servos on threads of their own beside their steps, through the
//! C interface: the calls overlap freely, the servo sees whole steps in order, and what the
//! steps do alone (the drill's removal without materials, its shaft, the pen's passes) is what
//! one task does.

use std::ptr;
use std::sync::atomic::{AtomicBool, AtomicU32, Ordering};

use tetradrill_ffi::*;

mod common;
use common::*;

/// A handle that crosses to the servo's thread (the interface's contract makes the servo's
/// memory the servo's alone).
struct Handle<T>(*mut T);
// SAFETY: the servo's part of the memory is used by that thread alone while it runs.
unsafe impl<T> Send for Handle<T> {}
// SAFETY: a handle is shared only to be used by one thread at a time: the world's or pen's by
// the stepping thread, the servo's by the servo's thread (or by either when the other is not
// running).
unsafe impl<T> Sync for Handle<T> {}

/// The demo's pose `i` with a tilted rotation (a unit quaternion, 60 degrees about x+y).
fn pose(i: u32) -> TdPose {
    let (mut position, mut buttons) = (TdVec3::default(), 0u32);
    // SAFETY: writable outputs.
    unsafe { assert_eq!(td_demo_pose(i, &mut position, &mut buttons), TdStatus::TdOk) };
    TdPose {
        position,
        rotation: TdQuat {
            w: 0.8660254,
            x: 0.35355339,
            y: 0.35355339,
            z: 0.0,
        },
    }
}

/// Runs `step(i)` for every demo tick on this thread and `servo(i)` (returning the step it
/// rendered from) free-running on another, the servo at the step's newest pose; checks the
/// servo's steps never go back. Returns the servo's ticks.
fn beside(step: impl Fn(u32), servo: impl Fn(u32) -> u32 + Send + Sync) -> u64 {
    let (tick, done, seen) = (
        AtomicU32::new(0),
        AtomicBool::new(false),
        AtomicU32::new(u32::MAX),
    );
    std::thread::scope(|s| {
        let t = s.spawn(|| {
            let (mut ticks, mut last) = (0u64, 0u32);
            while !done.load(Ordering::Acquire) {
                let got = servo(tick.load(Ordering::Relaxed));
                assert!(got >= last, "step {got} after {last}");
                last = got;
                seen.store(got, Ordering::Release);
                ticks += 1;
            }
            ticks
        });
        let wait_for = |n: u32| {
            let start = std::time::Instant::now();
            while seen.load(Ordering::Acquire) != n
                && !t.is_finished()
                && start.elapsed().as_secs() < 60
            {
                std::thread::yield_now();
            }
        };
        wait_for(0);
        for i in 0..td_demo_ticks() {
            tick.store(i, Ordering::Relaxed);
            step(i);
        }
        wait_for(td_demo_ticks());
        done.store(true, Ordering::Release);
        t.join().expect("the servo thread")
    })
}

#[test]
fn a_drills_servo_thread_beside_its_steps() {
    let p = params_of(&builtin("firmware"), 4);
    let mut p = p;
    p.servo_lag = 0;
    let drill = |threads: bool| {
        let (_mem, world) = c_world(&p, 4, None, &[]);
        let mut servo: *mut TdServo = ptr::null_mut();
        // SAFETY: a live world.
        unsafe {
            assert_eq!(td_world_set_drill(world, 0.6, 0.03), TdStatus::TdOk);
            assert_eq!(td_world_servo(world, &mut servo), TdStatus::TdOk);
        }
        let (w, sv) = (Handle(world), Handle(servo));
        let step = |i: u32| {
            let w = &w;
            // SAFETY: this thread is the world's only caller.
            let st = unsafe { td_world_simulate_pose(w.0, pose(i), 1, ptr::null_mut()) };
            assert_eq!(st, TdStatus::TdOk);
        };
        let render = |i: u32| {
            let sv = &sv;
            let (mut f, mut t, mut c) = (
                TdVec3::default(),
                TdVec3::default(),
                TdServoCounts::default(),
            );
            // SAFETY: this thread is the servo's only caller.
            unsafe {
                assert_eq!(
                    td_servo_wrench(sv.0, pose(i), &mut f, &mut t),
                    TdStatus::TdOk
                );
                assert_eq!(td_servo_counters(sv.0, &mut c), TdStatus::TdOk);
            }
            assert!([f.x, f.y, f.z, t.x, t.y, t.z].iter().all(|v| v.is_finite()));
            c.step
        };
        if threads {
            assert!(beside(step, render) >= 2);
        } else {
            for i in 0..td_demo_ticks() {
                step(i);
                render(i);
            }
        }
        let (mut c, mut s) = (TdCounters::default(), TdShaftCounts::default());
        // SAFETY: the threads are done.
        unsafe {
            assert_eq!(td_world_counters(world, &mut c), TdStatus::TdOk);
            assert_eq!(td_world_shaft(world, &mut s), TdStatus::TdOk);
        }
        (c.removed_volume, s)
    };
    let (one, two) = (drill(false), drill(true));
    assert!(one.0 > 0.0 && one.1.near_ticks > 0, "{one:?}");
    assert_eq!(two, one, "the steps do alone what one task does");
}

#[test]
fn a_pens_servo_thread_beside_its_passes() {
    let (on, ot) = tetradrill_core::builtin::block_counts(8);
    let (pn, pt) = tetradrill_core::builtin::block_counts(2);
    // SAFETY: all-zero is a valid TdPenParams.
    let mut p: TdPenParams = unsafe { std::mem::zeroed() };
    // SAFETY: a writable output.
    unsafe { td_pen_params_default(on as u32, ot as u32, pn as u32, pt as u32, &mut p) };
    let (obj_xyz, obj_tets) = block_arrays(8);
    let (pen_xyz, pen_tets) = block_arrays(2);
    let pen_xyz: Vec<f32> = pen_xyz.iter().map(|v| v * 0.2).collect();
    let (mut size, mut align, mut needed) = (0usize, 0usize, 0usize);
    let mut pen: *mut TdPen = ptr::null_mut();
    let mut servo: *mut TdPenServo = ptr::null_mut();
    // SAFETY: valid pointers; memory asked for, then the bytes measured.
    let _mem = unsafe {
        assert_eq!(td_pen_size(&p, &mut size, &mut align), TdStatus::TdOk);
        let mut mem = Memory::new(size, align);
        let init = |mem: &Memory, len: usize, pen: &mut *mut TdPen, needed: &mut usize| {
            td_pen_init(
                mem.ptr.cast(),
                len,
                &p,
                obj_xyz.as_ptr(),
                obj_tets.as_ptr(),
                pen_xyz.as_ptr(),
                pen_tets.as_ptr(),
                pen,
                needed,
                ptr::null_mut(),
            )
        };
        if init(&mem, size, &mut pen, &mut needed) == TdStatus::TdErrTooSmall {
            mem = Memory::new(needed, align);
            assert_eq!(init(&mem, needed, &mut pen, &mut needed), TdStatus::TdOk);
        }
        assert_eq!(td_pen_servo_handle(pen, &mut servo), TdStatus::TdOk);
        mem
    };
    let (pn_, sv) = (Handle(pen), Handle(servo));
    let contact = AtomicU32::new(0);
    let ticks = beside(
        |i| {
            let pn_ = &pn_;
            // SAFETY: this thread is the pen's only caller.
            let st = unsafe { td_pen_simulate(pn_.0, pose(i), ptr::null_mut()) };
            assert_eq!(st, TdStatus::TdOk);
        },
        |i| {
            let sv = &sv;
            let (mut f, mut t, mut c) = (
                TdVec3::default(),
                TdVec3::default(),
                TdPenServoCounts::default(),
            );
            // SAFETY: this thread is the servo's only caller.
            unsafe {
                assert_eq!(
                    td_pen_servo_wrench(sv.0, pose(i), &mut f, &mut t),
                    TdStatus::TdOk
                );
                assert_eq!(td_pen_servo_counters(sv.0, &mut c), TdStatus::TdOk);
            }
            assert!([f.x, f.y, f.z, t.x, t.y, t.z].iter().all(|v| v.is_finite()));
            contact.fetch_add(
                u32::from(f.x != 0.0 || f.y != 0.0 || f.z != 0.0),
                Ordering::Relaxed,
            );
            c.step
        },
    );
    let mut c = TdPenCounts::default();
    // SAFETY: the threads are done.
    unsafe { assert_eq!(td_pen_counters(pen, &mut c), TdStatus::TdOk) };
    assert_eq!(c.passes, u64::from(td_demo_ticks()));
    assert!(ticks >= 2);
    assert!(
        contact.load(Ordering::Relaxed) > 0,
        "the pen was pushed back"
    );
}
