//! The passivity observer through the C interface (`td_passivity_*`, `td_servo_storage`,
//! `td_penalty_storage`). Checked against physics simulated here in f64 (a mass bouncing on a
//! stiff, undamped wall under a zero-order hold gains energy; through the observer it does
//! not), against a fault (a tool driven past the force limit trips it, a healthy press does
//! not and passes its force bit for bit), against the spring energy of the world's burr
//! computed here from the pose, against the core's observer driven directly (bit for bit), and
//! for every bad call's status.

mod common;

use std::ptr;

use common::{builtin, c_world, params_of, Memory};
use tetradrill_core::force::{PassivityObserver, PassivityParams, Storage};
use tetradrill_core::Vec3;
use tetradrill_ffi::*;

fn tv(x: f32, y: f32, z: f32) -> TdVec3 {
    TdVec3 { x, y, z }
}

fn defaults() -> TdPassivityParams {
    let mut p = TdPassivityParams {
        dt: 0.0,
        max_damping: 0.0,
        max_force: 0.0,
        slack_j: 0.0,
        trip_j: 0.0,
        dissipate: 0,
        regrip_ticks: 0,
        act_without_storage: 0,
    };
    // SAFETY: a writable struct.
    assert_eq!(
        unsafe { td_passivity_params_default(&mut p) },
        TdStatus::TdOk
    );
    p
}

/// An observer in memory of its own.
struct Observer {
    _mem: Memory,
    h: *mut TdPassivity,
}

impl Observer {
    fn new(p: &TdPassivityParams) -> Result<Self, TdStatus> {
        let (mut size, mut align) = (0usize, 0usize);
        // SAFETY: valid out-pointers.
        assert_eq!(
            unsafe { td_passivity_size(&mut size, &mut align) },
            TdStatus::TdOk
        );
        let mem = Memory::new(size, align);
        let mut h = ptr::null_mut();
        // SAFETY: `size` bytes at `align`; a valid params pointer.
        let st = unsafe { td_passivity_init(mem.ptr.cast(), size, p, &mut h) };
        if st != TdStatus::TdOk {
            return Err(st);
        }
        Ok(Self { _mem: mem, h })
    }

    fn step(&self, at: TdVec3, f: TdVec3, storage: Option<TdStorage>, removing: u32) -> TdVec3 {
        let mut out = tv(f32::NAN, 0.0, 0.0);
        let s = storage
            .as_ref()
            .map_or(ptr::null(), |s| s as *const TdStorage);
        // SAFETY: a live handle; `s` null or a live struct; a writable output.
        let st = unsafe { td_passivity_step(self.h, at, f, s, removing, &mut out) };
        assert_eq!(st, TdStatus::TdOk);
        out
    }

    fn counts(&self) -> TdPassivityCounts {
        let mut c = TdPassivityCounts::default();
        // SAFETY: a live handle and a writable struct.
        assert_eq!(
            unsafe { td_passivity_counters(self.h, &mut c) },
            TdStatus::TdOk
        );
        c
    }
}

fn penalty(depth: f32, k: f32, max: f32) -> TdStorage {
    let mut s = TdStorage::default();
    // SAFETY: a writable struct.
    assert_eq!(
        unsafe { td_penalty_storage(depth, k, max, &mut s) },
        TdStatus::TdOk
    );
    s
}

/// A mass of 0.1 kg at 0.1 m/s along -z into an undamped wall at z = 0 of 20,000 N/m, the
/// wall's force held over each 1 ms tick (a zero-order hold), integrated exactly in f64, each
/// tick's force passed through `filter`. Returns the kinetic energy before and after the
/// bounce.
fn bounce(mut filter: impl FnMut(f64, f64, f64) -> f64) -> (f64, f64) {
    let (m, k, t) = (0.1f64, 20_000.0f64, 1e-3f64);
    let (mut z, mut v) = (0.002f64, -0.1f64);
    let before = 0.5 * m * v * v;
    for _ in 0..400 {
        let depth = (-z).max(0.0);
        let f = filter(z, k * depth, depth);
        z += v * t + 0.5 * f / m * t * t;
        v += f / m * t;
    }
    assert!(z > 0.0 && v > 0.0, "the mass bounced off: z {z}, v {v}");
    (before, 0.5 * m * v * v)
}

#[test]
fn a_bounce_on_a_stiff_undamped_wall_gains_energy_and_the_observer_takes_it_out() {
    // Held over the tick, the wall pushes longer on the way out than on the way in: the
    // mass leaves faster than it came (Colgate's bound, b < K T / 2, is broken with b = 0).
    let (before, raw) = bounce(|_, f, _| f);
    assert!(
        raw > 1.2 * before,
        "the held wall gave {raw} J from {before} J"
    );
    let mut p = defaults();
    p.max_damping = 100.0;
    let obs = Observer::new(&p).expect("observer");
    let (before, filtered) = bounce(|z, f, depth| {
        let s = penalty(depth as f32, 20_000.0, f32::INFINITY);
        let out = obs.step(tv(0.0, 0.0, z as f32), tv(0.0, 0.0, f as f32), Some(s), 0);
        f64::from(out.z)
    });
    // The slack (0.1 mJ) is what the observer leaves: the mass leaves with at most that much
    // more than it brought.
    assert!(
        filtered <= before + 1.5e-4,
        "through the observer {filtered} J from {before} J (raw {raw} J)"
    );
    let c = obs.counts();
    assert!(c.dissipated_j > 0.0 && c.tripped == 0);
}

#[test]
fn a_tool_driven_past_the_force_limit_trips_and_a_healthy_press_does_not() {
    // A wall of 200 N/m clamped at 8 N (reached 4 cm deep), a tool driven into it 1 mm a
    // tick, as a reversed motor drives it: some 8 N x 2 cm past the limit by tick 60, over
    // the 50 mJ trip.
    let p = defaults();
    let obs = Observer::new(&p).expect("observer");
    let mut out = tv(0.0, 0.0, 0.0);
    let mut tripped_at = None;
    for tick in 0..60 {
        let depth = 0.001 * tick as f32;
        let f = (200.0 * depth).min(8.0);
        out = obs.step(
            tv(0.0, 0.0, -depth),
            tv(0.0, 0.0, f),
            Some(penalty(depth, 200.0, 8.0)),
            0,
        );
        if tripped_at.is_none() && obs.counts().tripped == 1 {
            tripped_at = Some(tick);
        }
    }
    let c = obs.counts();
    assert_eq!((c.tripped, c.trips), (1, 1));
    assert_eq!(
        (out.x, out.y, out.z),
        (0.0, 0.0, 0.0),
        "a tripped observer sends zero"
    );
    // 50 mJ past the limit: 8 N over 6.25 mm past 40 mm, so the trip comes near tick 47.
    let at = tripped_at.expect("tripped");
    assert!((45..=49).contains(&at), "tripped at tick {at}");
    assert!(c.trip_measure_j_max >= 0.05);
    // Recovered, the output is the force again.
    // SAFETY: a live handle.
    assert_eq!(
        unsafe { td_passivity_reset(obs.h, 0, 1, 0) },
        TdStatus::TdOk
    );
    let back = obs.step(tv(0.0, 0.0, 0.1), tv(0.0, 0.0, 0.5), None, 0);
    assert_eq!(
        back.z.to_bits(),
        0.5f32.to_bits(),
        "recovered, the force passes"
    );
    assert_eq!(obs.counts().tripped, 0);

    // A healthy press: 2 cm in over a second and held; the force passes bit for bit. (A
    // held undamped spring pressed in generates K dx^2 / 2 a tick: 20 um a tick keeps the
    // sum within the 0.1 mJ slack; 200 um a tick passes it in 25 ticks.)
    let obs = Observer::new(&p).expect("observer");
    for tick in 0..1500 {
        let depth = 0.02 * (tick as f32 / 1000.0).min(1.0);
        let f = tv(0.0, 0.0, (200.0 * depth).min(8.0));
        let out = obs.step(tv(0.0, 0.0, -depth), f, Some(penalty(depth, 200.0, 8.0)), 0);
        assert_eq!(out.z.to_bits(), f.z.to_bits(), "tick {tick}");
    }
    assert_eq!(obs.counts().trips, 0);
}

#[test]
fn the_c_observer_is_the_cores_bit_for_bit() {
    // A tool wandering in and out of a wall at 2,000 N/m clamped at 3 N, the drill on for a
    // stretch, a restart in the middle: the same outputs and counts as the core's observer.
    let mut p = defaults();
    p.max_force = 3.0;
    p.act_without_storage = 1;
    let obs = Observer::new(&p).expect("observer");
    let mut core = PassivityObserver::default();
    core.set_params(PassivityParams {
        max_force: 3.0,
        act_without_storage: true,
        ..PassivityParams::default()
    });
    let mut seed = 7u64;
    let mut rand = move || {
        seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((seed >> 33) as f32) / (1u64 << 31) as f32 - 0.5
    };
    let mut z = 0.001f32;
    let mut damped = 0;
    for tick in 0..3000u32 {
        z += 0.0004 * rand() - 0.00001;
        let depth = (-z).max(0.0);
        let f = Vec3::new(0.3 * rand(), 0.0, (2000.0 * depth).min(3.0));
        let at = Vec3::new(0.0, 0.0, z);
        let with_storage = tick % 7 != 0;
        let removing = u32::from((1000..1500).contains(&tick));
        let s = penalty(depth, 2000.0, 3.0);
        let cs = with_storage.then_some(Storage {
            stored_j: s.stored_j,
            past_limit_j: s.past_limit_j,
        });
        let c_out = obs.step(
            tv(at.x, at.y, at.z),
            tv(f.x, f.y, f.z),
            with_storage.then_some(s),
            removing,
        );
        let want = if removing == 1 {
            core.step_removing(at, f, cs)
        } else {
            core.step(at, f, cs)
        };
        assert_eq!(
            [c_out.x, c_out.y, c_out.z].map(f32::to_bits),
            want.to_array().map(f32::to_bits),
            "tick {tick}"
        );
        damped += usize::from(want != f);
        if tick == 2000 {
            // SAFETY: a live handle.
            assert_eq!(
                unsafe { td_passivity_reset(obs.h, 1, 0, 0) },
                TdStatus::TdOk
            );
            core.restart();
        }
        if tick == 1700 {
            // A lost tick: refused, and the observer forgets its history as the core does
            // for a pose that is not finite.
            let mut o = tv(0.0, 0.0, 0.0);
            let (bad, one) = (tv(f32::NAN, 0.0, 0.0), tv(0.0, 0.0, 1.0));
            // SAFETY: a live handle and a writable output.
            let st = unsafe { td_passivity_step(obs.h, bad, one, ptr::null(), 0, &mut o) };
            assert_eq!(st, TdStatus::TdErrInput);
            core.step(Vec3::NAN, Vec3::ZERO, None);
        }
    }
    assert!(damped > 0, "the damper acted on some ticks");
    let c = obs.counts();
    assert_eq!(c.trips, core.trips());
    assert_eq!(
        c.generated_j_max.to_bits(),
        core.generated_j_max().to_bits()
    );
    assert_eq!(c.dissipated_j.to_bits(), core.dissipated_j().to_bits());
}

#[test]
fn the_servo_gives_the_burrs_spring_energy_at_the_pose() {
    // The firmware scenario's block (top face at z = 0.5), the burr (radius 0.1, 200 N per
    // unit, 8 N limit) pressed `d` deep above its middle and held: the spring holds K d^2 / 2,
    // computed here in f64.
    let sc = builtin("firmware");
    let p = params_of(&sc, 4);
    let (_mem, world) = c_world(&p, 4, None, &[]);
    let mut servo = ptr::null_mut();
    // SAFETY: a live world; a writable handle.
    assert_eq!(unsafe { td_world_servo(world, &mut servo) }, TdStatus::TdOk);
    for d in [0.005f32, 0.02, 0.039, 0.05] {
        let at = tv(0.06, -0.04, 0.5 + p.radius - d);
        let (mut f, mut depth, mut s) = (tv(0.0, 0.0, 0.0), f32::NAN, TdStorage::default());
        for _ in 0..50 {
            // SAFETY: a live world and servo; writable outputs.
            unsafe {
                assert_eq!(td_world_tick(world, at, 0, &mut f), TdStatus::TdOk);
                assert_eq!(
                    td_servo_storage(servo, at, &mut depth, &mut s),
                    TdStatus::TdOk
                );
            }
        }
        let dd = f64::from(0.5f32 + p.radius) - f64::from(at.z);
        assert!(
            (f64::from(depth) - dd).abs() < 1e-6,
            "depth {depth} against {dd}"
        );
        // K d^2 / 2 up to the limit's depth F / K (0.04), then F a unit of depth past it.
        let (k, fmax) = (f64::from(p.stiffness), f64::from(p.max_force));
        let at_limit = fmax / k;
        let past = fmax * (dd - at_limit).max(0.0);
        let want = 0.5 * k * dd.min(at_limit).powi(2) + past;
        assert!(
            (f64::from(s.stored_j) - want).abs() < 1e-4 * want,
            "stored {} against {want}",
            s.stored_j
        );
        let past_got = f64::from(s.past_limit_j);
        assert!(
            (past_got - past).abs() < 1e-4 * want,
            "past {past_got} against {past}"
        );
        // The force the servo rendered is the same spring's.
        let spring = (k * dd).min(fmax);
        assert!(
            (f64::from(f.z) - spring).abs() < 1e-3 * spring,
            "force {} against {spring}",
            f.z
        );
    }
    // Out of contact: nothing.
    let above = tv(0.06, -0.04, 0.9);
    let (mut f, mut depth, mut s) = (tv(0.0, 0.0, 0.0), 1.0f32, penalty(1.0, 1.0, 1.0));
    for _ in 0..50 {
        // SAFETY: as above.
        unsafe {
            assert_eq!(td_world_tick(world, above, 0, &mut f), TdStatus::TdOk);
            assert_eq!(
                td_servo_storage(servo, above, &mut depth, &mut s),
                TdStatus::TdOk
            );
        }
    }
    assert_eq!((depth, s), (0.0, TdStorage::default()));

    // A region of its own stiffness (1,000 N per unit) under the burr: the servo renders it,
    // and the storage is its spring's, K d^2 / 2 with its K.
    let (_mem2, world) = c_world(&p, 4, None, &[]);
    // SAFETY: a live world before its first step; a writable handle.
    unsafe {
        assert_eq!(
            td_world_set_region(world, 0, 1e9, 0.0, 1000.0),
            TdStatus::TdOk
        );
        assert_eq!(td_world_servo(world, &mut servo), TdStatus::TdOk);
    }
    let d = 0.005f32;
    let at = tv(0.06, -0.04, 0.5 + p.radius - d);
    let mut out_depth = f32::NAN;
    for _ in 0..50 {
        // SAFETY: as above.
        unsafe {
            assert_eq!(td_world_tick(world, at, 0, &mut f), TdStatus::TdOk);
            let st = td_servo_storage(servo, at, ptr::null_mut(), &mut s);
            assert_eq!(st, TdStatus::TdOk);
            let st = td_servo_storage(servo, at, &mut out_depth, &mut s);
            assert_eq!(st, TdStatus::TdOk);
        }
    }
    let dd = f64::from(0.5f32 + p.radius) - f64::from(at.z);
    let want = 0.5 * 1000.0 * dd * dd;
    let got = f64::from(s.stored_j);
    assert!(
        (got - want).abs() < 1e-4 * want,
        "stored {got} against {want}"
    );
    assert!(
        (f64::from(f.z) - 1000.0 * dd).abs() < 1.0 * dd,
        "force {}",
        f.z
    );
}

#[test]
fn bad_calls_get_their_status() {
    let p = defaults();
    let obs = Observer::new(&p).expect("observer");
    let mut out = tv(0.0, 0.0, 0.0);
    let z = tv(0.0, 0.0, 0.0);
    for bad in [
        TdPassivityParams { dt: 0.0, ..p },
        TdPassivityParams { dt: f32::NAN, ..p },
        TdPassivityParams {
            max_damping: -1.0,
            ..p
        },
        TdPassivityParams {
            max_force: 0.0,
            ..p
        },
        TdPassivityParams { slack_j: -1.0, ..p },
        TdPassivityParams { trip_j: 0.0, ..p },
        TdPassivityParams { dissipate: 2, ..p },
        TdPassivityParams {
            act_without_storage: 2,
            ..p
        },
    ] {
        assert_eq!(
            Observer::new(&bad).err(),
            Some(TdStatus::TdErrParams),
            "{bad:?}"
        );
    }
    let nan = TdStorage {
        stored_j: f32::NAN,
        past_limit_j: 0.0,
    };
    let mut junk = [0u64; 32];
    // SAFETY: live handles, or pointers the interface refuses before use.
    unsafe {
        let (mut size, mut align) = (0usize, 0usize);
        assert_eq!(
            td_passivity_size(ptr::null_mut(), &mut align),
            TdStatus::TdErrNull
        );
        assert_eq!(td_passivity_size(&mut size, &mut align), TdStatus::TdOk);
        let mut h = ptr::null_mut();
        let mem = Memory::new(size, align);
        assert_eq!(
            td_passivity_init(mem.ptr.cast(), size - 1, &p, &mut h),
            TdStatus::TdErrTooSmall
        );
        assert_eq!(
            td_passivity_init(mem.ptr.cast(), size, ptr::null(), &mut h),
            TdStatus::TdErrNull
        );
        let nan_pose = tv(f32::NAN, 0.0, 0.0);
        assert_eq!(
            td_passivity_step(obs.h, nan_pose, z, ptr::null(), 0, &mut out),
            TdStatus::TdErrInput
        );
        assert_eq!(
            td_passivity_step(obs.h, z, nan_pose, ptr::null(), 0, &mut out),
            TdStatus::TdErrInput
        );
        assert_eq!(
            td_passivity_step(obs.h, z, z, &nan, 0, &mut out),
            TdStatus::TdErrInput
        );
        assert_eq!(
            td_passivity_step(obs.h, z, z, ptr::null(), 2, &mut out),
            TdStatus::TdErrInput
        );
        assert_eq!(
            td_passivity_step(obs.h, z, z, ptr::null(), 0, ptr::null_mut()),
            TdStatus::TdErrNull
        );
        let fake = junk.as_mut_ptr().cast::<TdPassivity>();
        assert_eq!(
            td_passivity_step(fake, z, z, ptr::null(), 0, &mut out),
            TdStatus::TdErrNotInit
        );
        assert_eq!(td_passivity_reset(obs.h, 2, 0, 0), TdStatus::TdErrParams);
        assert_eq!(td_passivity_reset(obs.h, 0, 0, 1), TdStatus::TdOk);
        assert_eq!(obs.counts().tripped, 1, "tripped by the caller's check");
        assert_eq!(
            td_penalty_storage(0.1, 1.0, 1.0, ptr::null_mut()),
            TdStatus::TdErrNull
        );
        let nan_past = TdStorage {
            stored_j: 0.0,
            past_limit_j: f32::NAN,
        };
        let st = td_passivity_step(obs.h, z, z, &nan_past, 0, &mut out);
        assert_eq!(st, TdStatus::TdErrInput);
        let odd = (&nan_past as *const TdStorage)
            .cast::<u8>()
            .wrapping_add(1)
            .cast::<TdStorage>();
        let st = td_passivity_step(obs.h, z, z, odd, 0, &mut out);
        assert_eq!(st, TdStatus::TdErrAlign);
        assert_eq!(td_passivity_reset(obs.h, 0, 2, 0), TdStatus::TdErrParams);
        assert_eq!(td_passivity_reset(obs.h, 0, 0, 2), TdStatus::TdErrParams);
        let st = td_passivity_reset(ptr::null_mut(), 1, 0, 0);
        assert_eq!(st, TdStatus::TdErrNull);
        assert_eq!(td_passivity_reset(fake, 1, 0, 0), TdStatus::TdErrNotInit);
        let mut c = TdPassivityCounts::default();
        let st = td_passivity_counters(obs.h, ptr::null_mut());
        assert_eq!(st, TdStatus::TdErrNull);
        assert_eq!(td_passivity_counters(fake, &mut c), TdStatus::TdErrNotInit);
        let st = td_passivity_init(ptr::null_mut(), size, &p, &mut h);
        assert_eq!(st, TdStatus::TdErrNull);
        let st = td_passivity_init(mem.ptr.cast(), size, &p, ptr::null_mut());
        assert_eq!(st, TdStatus::TdErrNull);
        let odd_mem = mem.ptr.wrapping_add(1);
        let st = td_passivity_init(odd_mem.cast(), size - 1, &p, &mut h);
        assert_eq!(st, TdStatus::TdErrAlign);
        // A drill's world has no single spring.
        let sc = builtin("firmware");
        let mut wp = params_of(&sc, 4);
        wp.servo_lag = 0;
        let (_mem, world) = c_world(&wp, 4, None, &[]);
        assert_eq!(td_world_set_drill(world, 0.6, 0.03), TdStatus::TdOk);
        let mut servo = ptr::null_mut();
        assert_eq!(td_world_servo(world, &mut servo), TdStatus::TdOk);
        let mut s = TdStorage::default();
        assert_eq!(
            td_servo_storage(servo, z, ptr::null_mut(), &mut s),
            TdStatus::TdErrParams
        );
        // A sphere's servo: bad pointers and poses.
        let (_mem3, world) = c_world(&params_of(&sc, 4), 4, None, &[]);
        assert_eq!(td_world_servo(world, &mut servo), TdStatus::TdOk);
        let st = td_servo_storage(servo, z, ptr::null_mut(), ptr::null_mut());
        assert_eq!(st, TdStatus::TdErrNull);
        let mut depth = [0.0f32; 2];
        let odd_depth = depth
            .as_mut_ptr()
            .cast::<u8>()
            .wrapping_add(1)
            .cast::<f32>();
        let st = td_servo_storage(servo, z, odd_depth, &mut s);
        assert_eq!(st, TdStatus::TdErrAlign);
        let bad_pose = tv(f32::NAN, 0.0, 0.0);
        let st = td_servo_storage(servo, bad_pose, depth.as_mut_ptr(), &mut s);
        assert_eq!(st, TdStatus::TdErrInput);
        let fake_servo = junk.as_mut_ptr().cast::<TdServo>();
        let st = td_servo_storage(fake_servo, z, ptr::null_mut(), &mut s);
        assert_eq!(st, TdStatus::TdErrNotInit);
    }
    // Refused steps count nothing: a fresh observer given only bad ticks has seen no energy.
    let fresh = Observer::new(&p).expect("observer");
    let mut o = tv(0.0, 0.0, 0.0);
    for bad in [tv(f32::NAN, 0.0, 0.0), tv(0.0, f32::INFINITY, 0.0)] {
        // SAFETY: a live handle and a writable output.
        let st = unsafe { td_passivity_step(fresh.h, z, bad, ptr::null(), 0, &mut o) };
        assert_eq!(st, TdStatus::TdErrInput);
    }
    let c = fresh.counts();
    assert_eq!((c.generated_j_max, c.dissipated_j, c.trips), (0.0, 0.0, 0));
}
