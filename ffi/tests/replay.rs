//! The C interface, called as C calls it, against the host's replay engine: the same scenario
//! gives the same force digest, removed volumes and saturations, and every bad pointer, size,
//! count, mesh, label and material gets its status.

use std::collections::BTreeMap;
use std::ffi::CStr;
use std::ptr;

use tetradrill_core::drill::Material;
use tetradrill_ffi::*;

mod common;
use common::*;

/// How the C side runs each tick.
#[derive(Clone, Copy, PartialEq)]
enum Ticks {
    /// `td_world_tick`.
    Whole,
    /// `td_world_simulate`, then `td_servo_force` on the world's servo: the two halves as two
    /// tasks would call them, the pressing force taken from the servo through the hand-off.
    Halves,
    /// The halves with `td_world_set_pressing` fed the last force by the caller.
    HalvesPressed,
    /// The halves told a pressing force of zero once, before the first step.
    HalvesUnpressed,
}

/// The demo path through the C interface: a world in fresh memory with `labels` (or none) and
/// `materials`, each `td_demo_pose` ticked as `ticks` says; the counters and every region's
/// removed volume at the end.
fn c_replay(
    p: &TdParams,
    n: usize,
    labels: Option<&[i32]>,
    materials: &[(i32, Material)],
    ticks: Ticks,
) -> (TdCounters, TdServoCounts, BTreeMap<i32, f64>) {
    let (xyz, tets) = block_arrays(n);
    let (mut size, mut align) = (0usize, 0usize);
    // SAFETY: valid pointers to initialised or writable values.
    unsafe {
        assert_eq!(td_world_size(p, &mut size, &mut align), TdStatus::TdOk);
    }
    let mem = Memory::new(size, align);
    let mut world: *mut TdWorld = ptr::null_mut();
    let mut bad = 0u32;
    // SAFETY: memory of the size and alignment asked for, arrays of the counts in `p`.
    let st = unsafe {
        td_world_init(
            mem.ptr.cast(),
            size,
            p,
            xyz.as_ptr(),
            tets.as_ptr(),
            labels.map_or(ptr::null(), <[i32]>::as_ptr),
            &mut world,
            &mut bad,
        )
    };
    assert_eq!(st, TdStatus::TdOk);
    for &(label, m) in materials {
        // SAFETY: a live world.
        let st = unsafe { td_world_set_region(world, label, m.hardness, m.threshold, m.stiffness) };
        assert_eq!(st, TdStatus::TdOk, "region {label}");
    }
    let mut servo: *mut TdServo = ptr::null_mut();
    // SAFETY: a live world, a writable output.
    unsafe { assert_eq!(td_world_servo(world, &mut servo), TdStatus::TdOk) };
    if ticks == Ticks::HalvesUnpressed {
        // SAFETY: a live world.
        unsafe { assert_eq!(td_world_set_pressing(world, 0.0, 0.0), TdStatus::TdOk) };
    }
    let mut force = TdVec3::default();
    for i in 0..td_demo_ticks() {
        let (mut pos, mut buttons) = (TdVec3::default(), 0u32);
        // SAFETY: a live world and writable outputs.
        unsafe {
            assert_eq!(td_demo_pose(i, &mut pos, &mut buttons), TdStatus::TdOk);
            if ticks == Ticks::Whole {
                assert_eq!(
                    td_world_tick(world, pos, buttons, &mut force),
                    TdStatus::TdOk
                );
                continue;
            }
            if ticks == Ticks::HalvesPressed {
                let pressing = (force.x * force.x + force.y * force.y + force.z * force.z).sqrt();
                let pressing = if i == 0 { 0.0 } else { pressing };
                let seconds = if i == 0 { 0.0 } else { p.dt };
                assert_eq!(
                    td_world_set_pressing(world, pressing, seconds),
                    TdStatus::TdOk
                );
            }
            assert_eq!(
                td_world_simulate(world, pos, buttons, ptr::null_mut()),
                TdStatus::TdOk
            );
            assert_eq!(td_servo_force(servo, pos, &mut force), TdStatus::TdOk);
        }
    }
    let (mut c, mut sc) = (TdCounters::default(), TdServoCounts::default());
    // SAFETY: a live world and its servo.
    unsafe {
        assert_eq!(td_world_counters(world, &mut c), TdStatus::TdOk);
        assert_eq!(td_servo_counters(servo, &mut sc), TdStatus::TdOk);
    }
    let mut by_region = BTreeMap::new();
    for i in 0..c.region_count {
        let mut r = TdRegion::default();
        // SAFETY: a live world, a writable output.
        unsafe { assert_eq!(td_world_region_at(world, i, &mut r), TdStatus::TdOk) };
        by_region.insert(r.label, r.removed_volume);
    }
    (c, sc, by_region)
}

#[test]
fn demo_digest_equals_the_hosts_replay() {
    let sc = builtin("demo");
    assert_eq!(sc.mesh.to_string(), "builtin:block:8");
    let host = host_replay(&sc);
    let labels = block_labels(8);
    let (c, servo, by_region) = c_replay(
        &params_of(&sc, 8),
        8,
        Some(&labels),
        &materials(&sc),
        Ticks::Whole,
    );
    assert_eq!(
        format!("{:016x}", servo.force_digest),
        format!("{:016x}", host.digest),
        "the C interface's demo digest differs from the host's replay"
    );
    assert_eq!(c.removed_volume, host.removed);
    assert_eq!(saturations(&c), host.sat);
    assert_eq!(c.sat_total, host.sat.total());
    assert_eq!(by_region, host.by_region, "removed_by_region");
    assert_eq!(c.region_count, 2, "the shell and the core");
    assert!(
        by_region.values().all(|&v| v > 0.0),
        "the demo drills both regions: {by_region:?}"
    );
    assert_eq!(servo.servo_ticks, 6001);
    assert_eq!(c.simulate_steps, 6001);
    assert_eq!(
        (servo.stale_reads, servo.step),
        (0, 6001),
        "one task: never overtaken"
    );
    assert!(c.removed_volume > 0.0, "the demo drills");
    assert!((c.initial_volume - 1.0).abs() < 1e-6, "unit block");
}

#[test]
fn the_demo_in_two_halves_needs_the_pressing_force() {
    let sc = builtin("demo");
    let host = host_replay(&sc);
    let labels = block_labels(8);
    let p = params_of(&sc, 8);
    // The halves, the servo's force pressing through the hand-off: the host's run, tick for
    // tick.
    let (c, servo, by_region) = c_replay(&p, 8, Some(&labels), &materials(&sc), Ticks::Halves);
    assert_eq!(servo.force_digest, host.digest);
    assert_eq!(by_region, host.by_region);
    assert_eq!(c.removed_volume, host.removed);
    // The same with the caller feeding the previous tick's force itself.
    let (_, servo, by_region) =
        c_replay(&p, 8, Some(&labels), &materials(&sc), Ticks::HalvesPressed);
    assert_eq!(servo.force_digest, host.digest);
    assert_eq!(by_region, host.by_region);
    // Told a force of zero, the burr presses with none: below both thresholds, nothing goes.
    let (c, servo, by_region) = c_replay(
        &p,
        8,
        Some(&labels),
        &materials(&sc),
        Ticks::HalvesUnpressed,
    );
    assert_eq!(c.removed_volume, 0.0);
    assert!(by_region.values().all(|&v| v == 0.0));
    assert_ne!(servo.force_digest, host.digest);
}

#[test]
fn firmware_digest_equals_the_hosts_replay() {
    let sc = builtin("firmware");
    assert_eq!(sc.mesh.to_string(), "builtin:block:4");
    assert!(
        sc.materials.regions.is_empty(),
        "no materials in the firmware scenario"
    );
    let host = host_replay(&sc);
    // Without labels, as the Cortex-M example runs it: one region, label 0, holding all.
    let (c, servo, by_region) = c_replay(&params_of(&sc, 4), 4, None, &[], Ticks::Whole);
    assert_eq!(servo.force_digest, host.digest);
    assert_eq!(c.removed_volume, host.removed);
    assert_eq!(saturations(&c), host.sat);
    assert_eq!(by_region.keys().copied().collect::<Vec<_>>(), [0]);
    let whole: f64 = host.by_region.values().sum();
    assert!(c.removed_volume > 0.0);
    assert!((by_region[&0] - whole).abs() <= 1e-12 * whole);
}

fn demo_params() -> TdParams {
    let (nn, nt) = tetradrill_core::builtin::block_counts(2);
    // SAFETY: all-zero is a valid TdParams (integers and floats).
    let mut p: TdParams = unsafe { std::mem::zeroed() };
    // SAFETY: valid pointer.
    unsafe { td_params_default(nn as u32, nt as u32, &mut p) };
    p.hierarchy_capacity = 4096;
    p.pending_capacity = 1024;
    p
}

#[test]
fn bad_pointers_sizes_and_counts_get_their_status() {
    let p = demo_params();
    let (xyz, tets) = block_arrays(2);
    let (mut size, mut align) = (0usize, 0usize);
    // SAFETY: every pointer below is valid, null, or deliberately misaligned; the functions
    // check before they touch any.
    unsafe {
        assert_eq!(
            td_params_default(1, 1, ptr::null_mut()),
            TdStatus::TdErrNull
        );
        assert_eq!(
            td_world_size(ptr::null(), &mut size, &mut align),
            TdStatus::TdErrNull
        );
        assert_eq!(
            td_world_size(&p, ptr::null_mut(), &mut align),
            TdStatus::TdErrNull
        );
        let mut q = p;
        q.tet_count = 0;
        assert_eq!(
            td_world_size(&q, &mut size, &mut align),
            TdStatus::TdErrParams
        );
        q = p;
        q.radius = f32::NAN;
        assert_eq!(
            td_world_size(&q, &mut size, &mut align),
            TdStatus::TdErrParams
        );
        q = p;
        q.hierarchy_capacity = 7;
        assert_eq!(
            td_world_size(&q, &mut size, &mut align),
            TdStatus::TdErrParams
        );
        q = p;
        q.max_depth = 10;
        assert_eq!(
            td_world_size(&q, &mut size, &mut align),
            TdStatus::TdErrParams
        );
        q = p;
        q.tet_count = TD_MAX_COUNT + 1;
        assert_eq!(
            td_world_size(&q, &mut size, &mut align),
            TdStatus::TdErrParams
        );
        assert_eq!(td_world_size(&p, &mut size, &mut align), TdStatus::TdOk);
        assert!(align.is_power_of_two() && size > STATE_BYTES);

        let mem = Memory::new(size + align, align);
        let mut world: *mut TdWorld = ptr::null_mut();
        let init = |m: *mut u8, len: usize, w: &mut *mut TdWorld| {
            td_world_init(
                m.cast(),
                len,
                &p,
                xyz.as_ptr(),
                tets.as_ptr(),
                ptr::null(),
                w,
                ptr::null_mut(),
            )
        };
        assert_eq!(init(ptr::null_mut(), size, &mut world), TdStatus::TdErrNull);
        assert_eq!(init(mem.ptr.add(1), size, &mut world), TdStatus::TdErrAlign);
        assert_eq!(init(mem.ptr, size - 1, &mut world), TdStatus::TdErrTooSmall);
        assert!(world.is_null(), "no handle from a failed init");
        // A world pointer into memory that holds no world: refused, not read as one.
        let mut f = TdVec3::default();
        let at = TdVec3 {
            x: 0.0,
            y: 0.0,
            z: 0.9,
        };
        let mut servo: *mut TdServo = ptr::null_mut();
        assert_eq!(
            td_world_servo(mem.ptr.cast(), &mut servo),
            TdStatus::TdErrNotInit
        );
        assert_eq!(
            td_servo_force(mem.ptr.add(64).cast(), at, &mut f),
            TdStatus::TdErrNotInit
        );
        assert_eq!(
            td_servo_force(ptr::null_mut(), at, &mut f),
            TdStatus::TdErrNull
        );
        assert_eq!(
            td_world_tick(ptr::null_mut(), at, 0, &mut f),
            TdStatus::TdErrNull
        );
        assert_eq!(
            td_world_tick(mem.ptr.add(1).cast(), at, 0, &mut f),
            TdStatus::TdErrAlign
        );

        assert_eq!(init(mem.ptr, size, &mut world), TdStatus::TdOk);
        assert_eq!(world.cast::<u8>(), mem.ptr, "the handle is the memory");
        let nan = TdVec3 { x: f32::NAN, ..at };
        assert_eq!(td_world_tick(world, nan, 1, &mut f), TdStatus::TdErrInput);
        assert_eq!(td_world_servo(world, ptr::null_mut()), TdStatus::TdErrNull);
        assert_eq!(td_world_servo(world, &mut servo), TdStatus::TdOk);
        assert_eq!(
            td_servo_force(servo, at, ptr::null_mut()),
            TdStatus::TdErrNull
        );
        assert_eq!(td_servo_force(servo, nan, &mut f), TdStatus::TdErrInput);
        assert_eq!(
            td_servo_force(servo.cast::<u8>().add(1).cast(), at, &mut f),
            TdStatus::TdErrAlign
        );
        let mut rep = TdSimReport::default();
        assert_eq!(td_world_simulate(world, at, 0, &mut rep), TdStatus::TdOk);
        assert_eq!(
            td_world_simulate(
                world,
                at,
                0,
                (&mut rep as *mut TdSimReport).cast::<u8>().add(1).cast()
            ),
            TdStatus::TdErrAlign
        );
        let (mut c, mut sc) = (TdCounters::default(), TdServoCounts::default());
        assert_eq!(td_world_counters(world, &mut c), TdStatus::TdOk);
        assert_eq!(td_servo_counters(servo, &mut sc), TdStatus::TdOk);
        assert_eq!(
            (c.simulate_steps, sc.servo_ticks),
            (1, 0),
            "refused calls count nothing"
        );

        // A failed init over a live world leaves no world behind.
        let mut q = p;
        q.radius = -1.0;
        assert_eq!(
            td_world_init(
                mem.ptr.cast(),
                size,
                &q,
                xyz.as_ptr(),
                tets.as_ptr(),
                ptr::null(),
                &mut world,
                ptr::null_mut()
            ),
            TdStatus::TdErrParams
        );
        // Parameters are checked before the memory is touched: the world is still there.
        assert_eq!(td_world_counters(world, &mut c), TdStatus::TdOk);
        let mut bad_tets = tets.clone();
        bad_tets[4 * 5 + 2] = 999;
        let mut bad = 0u32;
        assert_eq!(
            td_world_init(
                mem.ptr.cast(),
                size,
                &p,
                xyz.as_ptr(),
                bad_tets.as_ptr(),
                ptr::null(),
                &mut world,
                &mut bad
            ),
            TdStatus::TdErrMesh
        );
        assert_eq!(bad, 5, "the tet naming a node out of range");
        assert_eq!(td_world_counters(world, &mut c), TdStatus::TdErrNotInit);
        assert_eq!(
            td_servo_force(servo, at, &mut f),
            TdStatus::TdErrNotInit,
            "the old world's servo is gone with it"
        );
        let mut flat = xyz.clone();
        flat[3 * 7 + 1] = f32::INFINITY;
        assert_eq!(
            td_world_init(
                mem.ptr.cast(),
                size,
                &p,
                flat.as_ptr(),
                tets.as_ptr(),
                ptr::null(),
                &mut world,
                &mut bad
            ),
            TdStatus::TdErrMesh
        );
        assert_eq!(bad, 7, "the node that is not finite");
    }
}

#[test]
fn every_status_has_its_own_line() {
    let names: Vec<String> = (0..=14)
        .map(|code| {
            // SAFETY: td_status_name returns a static NUL-terminated string.
            unsafe { CStr::from_ptr(td_status_name(code)) }
                .to_str()
                .expect("ASCII")
                .to_owned()
        })
        .collect();
    assert_eq!(names[0], "ok");
    for (i, a) in names.iter().enumerate() {
        assert!(names[i + 1..].iter().all(|b| b != a), "{a} appears twice");
    }
    // SAFETY: as above.
    let unknown = unsafe { CStr::from_ptr(td_status_name(99)) };
    assert_eq!(unknown.to_str(), Ok("unknown status"));
    assert_eq!(TdStatus::TdErrInput as i32, 8);
    assert_eq!(TdStatus::TdErrStarted as i32, 10);
    assert_eq!(TdStatus::TdErrRigid as i32, 13);
    assert_eq!(TdStatus::TdErrBusy as i32, 14);
    assert_ne!(names[14], "unknown status");
    // SAFETY: as above.
    let past = unsafe { CStr::from_ptr(td_status_name(15)) };
    assert_eq!(past.to_str(), Ok("unknown status"));
}

#[test]
fn labels_materials_and_pressing_get_their_status() {
    let mut p = demo_params();
    let (xyz, tets) = block_arrays(2);
    // Labels out of order and with gaps: the regions come in ascending label order.
    let labels: Vec<i32> = (0..tets.len() / 4).map(|t| [7, -3, 7, 40][t % 4]).collect();
    let (mut size, mut align) = (0usize, 0usize);
    // SAFETY: every pointer below is valid, null, or deliberately misaligned; the functions
    // check before they touch any.
    unsafe {
        assert_eq!(td_world_size(&p, &mut size, &mut align), TdStatus::TdOk);
        let mem = Memory::new(size + 4, align);
        let mut world: *mut TdWorld = ptr::null_mut();
        let mut bad = u32::MAX;
        let init = |p: &TdParams, l: *const i32, w: &mut *mut TdWorld, bad: &mut u32| {
            td_world_init(
                mem.ptr.cast(),
                size + 4,
                p,
                xyz.as_ptr(),
                tets.as_ptr(),
                l,
                w,
                bad,
            )
        };
        let odd = labels.as_ptr().cast::<u8>().add(1).cast::<i32>();
        assert_eq!(init(&p, odd, &mut world, &mut bad), TdStatus::TdErrAlign);
        // Two slots for three distinct labels: refused at the first tet of the third (tet 3,
        // label 40, after 7 and -3).
        p.region_capacity = 2;
        let (mut small, mut small_align) = (0usize, 0usize);
        assert_eq!(
            td_world_size(&p, &mut small, &mut small_align),
            TdStatus::TdOk
        );
        assert!(small < size, "fewer region slots take less memory");
        assert_eq!(
            init(&p, labels.as_ptr(), &mut world, &mut bad),
            TdStatus::TdErrLabel
        );
        assert_eq!(bad, 3);
        p.region_capacity = 3;
        assert_eq!(
            init(&p, labels.as_ptr(), &mut world, &mut bad),
            TdStatus::TdOk
        );
        let mut c = TdCounters::default();
        assert_eq!(td_world_counters(world, &mut c), TdStatus::TdOk);
        assert_eq!(c.region_count, 3);
        let mut r = TdRegion::default();
        let listed: Vec<i32> = (0..3)
            .map(|i| {
                assert_eq!(td_world_region_at(world, i, &mut r), TdStatus::TdOk);
                r.label
            })
            .collect();
        assert_eq!(listed, [-3, 7, 40]);
        assert_eq!(td_world_region_at(world, 3, &mut r), TdStatus::TdErrLabel);
        assert_eq!(
            td_world_region(world, 7, ptr::null_mut()),
            TdStatus::TdErrNull
        );
        assert_eq!(td_world_region(world, 8, &mut r), TdStatus::TdErrLabel);

        // Materials: checked values, known labels, before the first step.
        assert_eq!(
            td_world_set_region(world, 7, 300.0, 2.0, 150.0),
            TdStatus::TdOk
        );
        assert_eq!(
            td_world_set_region(world, 8, 300.0, 2.0, 150.0),
            TdStatus::TdErrLabel
        );
        for (h, t, k) in [
            (-1.0, 0.0, 0.0),
            (0.0, f32::NAN, 0.0),
            (0.0, 0.0, f32::INFINITY),
        ] {
            assert_eq!(
                td_world_set_region(world, 40, h, t, k),
                TdStatus::TdErrParams
            );
        }
        assert_eq!(td_world_region(world, 7, &mut r), TdStatus::TdOk);
        assert_eq!(
            (
                r.label,
                r.hardness,
                r.threshold,
                r.stiffness,
                r.removed_volume
            ),
            (7, 300.0, 2.0, 150.0, 0.0)
        );
        assert_eq!(td_world_region(world, 40, &mut r), TdStatus::TdOk);
        assert_eq!(
            (r.hardness, r.threshold, r.stiffness),
            (0.0, 0.0, 0.0),
            "refused values change nothing"
        );

        // Pressing: finite and non-negative.
        for (f, s) in [
            (-1.0, 1e-3),
            (f32::NAN, 1e-3),
            (1.0, -1e-3),
            (1.0, f32::INFINITY),
        ] {
            assert_eq!(td_world_set_pressing(world, f, s), TdStatus::TdErrInput);
        }
        assert_eq!(td_world_set_pressing(world, 3.0, 1e-3), TdStatus::TdOk);
        assert_eq!(
            td_world_set_pressing(ptr::null_mut(), 3.0, 1e-3),
            TdStatus::TdErrNull
        );

        // A refused step does not start the world; a done one does.
        let nan = TdVec3 {
            x: f32::NAN,
            y: 0.0,
            z: 0.0,
        };
        assert_eq!(
            td_world_simulate(world, nan, 1, ptr::null_mut()),
            TdStatus::TdErrInput
        );
        assert_eq!(
            td_world_set_region(world, 40, 1.0, 0.0, 0.0),
            TdStatus::TdOk
        );
        let at = TdVec3 {
            x: 0.0,
            y: 0.0,
            z: 0.9,
        };
        assert_eq!(
            td_world_simulate(world, at, 1, ptr::null_mut()),
            TdStatus::TdOk
        );
        assert_eq!(
            td_world_set_region(world, 7, 1.0, 0.0, 0.0),
            TdStatus::TdErrStarted
        );
        // The materials set before the start are the core's now.
        assert_eq!(td_world_region(world, 7, &mut r), TdStatus::TdOk);
        assert_eq!((r.hardness, r.threshold, r.stiffness), (300.0, 2.0, 150.0));
        assert_eq!(td_world_region(world, 40, &mut r), TdStatus::TdOk);
        assert_eq!(r.hardness, 1.0);

        // Without labels: one region, label 0.
        assert_eq!(init(&p, ptr::null(), &mut world, &mut bad), TdStatus::TdOk);
        assert_eq!(td_world_counters(world, &mut c), TdStatus::TdOk);
        assert_eq!(c.region_count, 1);
        assert_eq!(td_world_region_at(world, 0, &mut r), TdStatus::TdOk);
        assert_eq!(r.label, 0);
        assert_eq!(td_world_region(world, 7, &mut r), TdStatus::TdErrLabel);
    }
}

#[test]
fn demo_pose_follows_the_script() {
    let (mut pos, mut buttons) = (TdVec3::default(), 7u32);
    // SAFETY: writable outputs, then null ones.
    unsafe {
        assert_eq!(td_demo_pose(0, &mut pos, &mut buttons), TdStatus::TdOk);
        assert_eq!((pos.z, buttons), (0.9, 0));
        assert_eq!(td_demo_pose(1000, &mut pos, &mut buttons), TdStatus::TdOk);
        assert_eq!(buttons, 1, "drilling at tick 1000");
        assert_eq!(
            td_demo_pose(0, ptr::null_mut(), &mut buttons),
            TdStatus::TdErrNull
        );
    }
    assert_eq!(td_demo_ticks(), 6001);
}
