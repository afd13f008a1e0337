//! A soft body's step spread over servo ticks through the C interface (`td_link_*`, the core's
//! `soft::Link`). Checked against the core's link driven directly (the same loop, bit for bit:
//! each tick's force and units, the commits, the body's positions), against Newton's third law
//! with the link's lag (a free block's momentum is the impulse of every cycle's forces but the
//! last), for the work of each tick (the units the link computed, every tick), and for every
//! bad call's status.

mod common;

use std::ptr;

use common::soft::{assert_same_forces, block, defaults, lumped_masses, momentum, vec_bits, CSoft};
use common::{builtin, c_world, params_of, Memory};
use tetradrill::engine::{self, EngineStorage, TickParams};
use tetradrill::soft::SoftOwned;
use tetradrill::traces::Pose;
use tetradrill_core::force::ToolState;
use tetradrill_core::soft::{Link, LinkBuffers, Material, SoftParams, TET_UNITS};
use tetradrill_core::Vec3;
use tetradrill_ffi::*;

/// Servo ticks per soft-body step (a cycle).
const TICKS: u32 = 10;

/// The burr's centre at tick `i`: above the top face's middle (z = 0.5), lowered from just
/// touching to `press` deep over 200 ticks, then held.
fn centre(i: usize, radius: f32, press: f32) -> Vec3 {
    let s = (i as f32 / 200.0).min(1.0);
    Vec3::new(0.06, -0.04, 0.5 + radius - s * press)
}

fn tv(v: Vec3) -> TdVec3 {
    TdVec3 {
        x: v.x,
        y: v.y,
        z: v.z,
    }
}

/// A link in memory of its own.
struct CLink {
    _mem: Memory,
    h: *mut TdLink,
}

impl CLink {
    fn new(
        world: *mut TdWorld,
        soft: *mut TdSoft,
        nodes: u32,
        ticks: u32,
        dt: f32,
    ) -> Result<Self, TdStatus> {
        let (mut size, mut align) = (0usize, 0usize);
        // SAFETY: valid out-pointers.
        let st = unsafe { td_link_size(nodes, &mut size, &mut align) };
        if st != TdStatus::TdOk {
            return Err(st);
        }
        let mem = Memory::new(size, align);
        let mut h = ptr::null_mut();
        // SAFETY: `size` bytes at `align`, apart from the world's and the body's; live handles.
        let st = unsafe { td_link_init(mem.ptr.cast(), size, world, soft, ticks, dt, &mut h) };
        if st != TdStatus::TdOk {
            return Err(st);
        }
        Ok(Self { _mem: mem, h })
    }

    fn counts(&self) -> TdLinkCounts {
        let mut c = TdLinkCounts::default();
        // SAFETY: a live handle and a writable struct.
        assert_eq!(unsafe { td_link_counters(self.h, &mut c) }, TdStatus::TdOk);
        c
    }
}

/// What a run of the C loop gave.
struct Run {
    forces: Vec<Vec3>,
    units: Vec<u32>,
    commits: Vec<usize>,
    positions: Vec<f32>,
    velocities: Vec<f32>,
    counts: TdLinkCounts,
    soft: TdSoftCounts,
}

/// The firmware scenario's world on the 4-block, deformable, and a soft body (young, density,
/// damping; its base held when `held`) linked to it, a step every [`TICKS`] ticks; the burr
/// pressed `press` deep for `ticks` ticks with the drill off.
fn c_run(young: f32, density: f32, damping: f32, held: bool, press: f32, ticks: usize) -> Run {
    let sc = builtin("firmware");
    let mut p = params_of(&sc, 4);
    p.deformable = 1;
    let (_mem, world) = c_world(&p, 4, None, &[]);
    let (xyz, tets) = block(4);
    let mut sp = defaults();
    sp.young = young;
    sp.density = density;
    sp.damping = damping;
    let body = CSoft::new(&xyz, &tets, &sp).expect("a body");
    if held {
        assert_eq!(body.hold_base(), 25, "the block's base");
    }
    let link = CLink::new(world, body.h, body.nodes, TICKS, p.dt).expect("a link");
    let mut run = Run {
        forces: Vec::with_capacity(ticks),
        units: Vec::with_capacity(ticks),
        commits: Vec::new(),
        positions: Vec::new(),
        velocities: Vec::new(),
        counts: TdLinkCounts::default(),
        soft: TdSoftCounts::default(),
    };
    for i in 0..ticks {
        let c = centre(i, p.radius, press);
        let mut f = TdVec3::default();
        let mut out = TdLinkReport::default();
        // SAFETY: live handles; writable outputs.
        unsafe {
            assert_eq!(td_world_tick(world, tv(c), 0, &mut f), TdStatus::TdOk);
            assert_eq!(
                td_link_tick(link.h, world, body.h, f, &mut out),
                TdStatus::TdOk
            );
        }
        run.forces.push(Vec3::new(f.x, f.y, f.z));
        run.units.push(out.units);
        if out.committed == 1 {
            assert_eq!(out.report.hash_saturated, 0);
            run.commits.push(i);
        }
    }
    run.positions = body.nodes(TdSoftField::TdSoftPositions);
    run.velocities = body.nodes(TdSoftField::TdSoftVelocities);
    run.counts = link.counts();
    run.soft = body.counts();
    run
}

#[test]
fn a_linked_block_through_c_is_the_cores_link_bit_for_bit() {
    let (press, ticks) = (0.02, 400);
    let c = c_run(5_000.0, 1_000.0, 20.0, true, press, ticks);

    // The same loop on the core's link, through the host's storage for the scenario's world.
    let sc = builtin("firmware");
    let mut loaded = engine::load_mesh(&sc).expect("mesh");
    let params = TickParams::of(&sc).expect("tick params");
    let mut store = EngineStorage::new(loaded.mesh.clone(), &sc).expect("storage");
    store.enable_deformation().expect("deformation");
    let mut world = store.world().expect("world");
    // The body's tets in lane order, as the C body holds them (the nodes in the world's order).
    let (mut owned, _) = SoftOwned::from_mesh(&loaded.mesh.view()).in_lanes();
    let material = Material {
        young: 5_000.0,
        poisson: 0.3,
        density: 1000.0,
    };
    let sp = SoftParams {
        gravity: Vec3::ZERO,
        damping: 20.0,
        substeps: 10,
        iterations: 1,
    };
    let mut body = owned.body(&[material], sp).expect("body");
    assert_eq!(body.fix_below(Vec3::new(0.0, 0.0, -0.49), Vec3::Z), 25);
    let mut link = Link::new(&body, &world, TICKS, 1e-3).expect("link");
    let n = body.node_count();
    let (mut a, mut b, mut next) = (
        vec![Vec3::ZERO; n],
        vec![Vec3::ZERO; n],
        vec![Vec3::ZERO; n],
    );
    let mut tool = ToolState::default();
    let (mut forces, mut units, mut commits) = (Vec::new(), Vec::new(), Vec::new());
    for i in 0..ticks {
        let pose = Pose::at(centre(i, params.radius, press));
        let (f, _) = engine::tick(&mut world, &mut tool, &params, &pose);
        let out = link
            .tick(
                &mut body,
                &mut world,
                LinkBuffers {
                    a: &mut a,
                    b: &mut b,
                    next: &mut next,
                },
                f,
            )
            .expect("tick");
        forces.push(f);
        units.push(out.units);
        if out.committed.is_some() {
            commits.push(i);
        }
    }
    assert_same_forces(&c.forces, &forces);
    assert_eq!(c.units, units, "each tick's units");
    assert_eq!(c.commits, commits, "the ticks that committed");
    let mut now = vec![Vec3::ZERO; n];
    body.write_positions(&mut now);
    let got: Vec<u32> = c.positions.iter().map(|f| f.to_bits()).collect();
    assert_eq!(got, vec_bits(&now), "the body's positions");
    let world_now: Vec<u32> = vec_bits(world.mesh().positions());
    assert_eq!(
        world_now,
        vec_bits(&next),
        "the world's positions are the last commit's"
    );
    assert_eq!(c.counts.steps, link.steps());
    assert_eq!(c.counts.units_per_tick, link.units_per_tick());
    assert_eq!(
        u64::from(c.counts.steps),
        c.soft.steps,
        "the body counts the link's steps"
    );
    let step = f64::from(TICKS) * f64::from(1e-3f32);
    assert!((c.soft.time - f64::from(c.counts.steps) * step).abs() < 1e-9);
}

#[test]
fn every_tick_does_its_share_and_a_step_commits_every_cycle() {
    let ticks = 30 * TICKS as usize;
    let c = c_run(5_000.0, 1_000.0, 20.0, true, 0.02, ticks);
    // A commit at each cycle's last tick, none elsewhere.
    let want: Vec<usize> = (0..ticks)
        .filter(|i| (i + 1) % TICKS as usize == 0)
        .collect();
    assert_eq!(c.commits, want);
    assert_eq!(c.counts.steps as usize, want.len());
    assert_eq!(c.counts.late, 0);
    assert_eq!(c.counts.ticks, TICKS);
    // The cycle's units spread evenly: by each tick of a cycle but its last, the units done
    // are the ticks' shares so far, less than one piece (a tet solve, the largest) of it left
    // over; the last tick finishes what is left.
    let per = u64::from(c.counts.units_per_tick);
    let piece = u64::from(TET_UNITS);
    for cycle in c.units.chunks(TICKS as usize) {
        let mut done = 0u64;
        for (j, &u) in cycle[..TICKS as usize - 1].iter().enumerate() {
            done += u64::from(u);
            let share = (j as u64 + 1) * per;
            assert!(
                done <= share && done + piece > share,
                "tick {j}: {done} units done against {share} shared"
            );
        }
    }
    let cycle = c.counts.cycle_units;
    let total: u64 = c.units.iter().map(|&u| u64::from(u)).sum();
    let cycles = (ticks / TICKS as usize) as u64;
    assert_eq!(total, cycles * cycle, "every cycle's units, no more");
    assert!(c.units.iter().all(|&u| u > 0));
}

#[test]
fn a_free_linked_block_takes_the_impulse_of_every_cycle_but_the_last() {
    // A light block, free, undamped, the burr pressed into its top. Step k is loaded with the
    // mean reaction of cycle k - 1 over a cycle's time, so after a run of whole cycles the
    // body's momentum is the impulse of the servo's forces over every cycle but the last (the
    // reaction it gathered has not loaded a step yet). The masses are lumped (a quarter of each
    // tet's mass to each corner), computed here in f64 from the rest geometry.
    let ticks = 25 * TICKS as usize;
    let r = c_run(5_000.0, 10.0, 0.0, false, 0.02, ticks);
    let (xyz, tets) = block(4);
    let momentum = momentum(&lumped_masses(&xyz, &tets, 10.0), &r.velocities);
    let loaded = ticks - TICKS as usize;
    let impulse = |range: std::ops::Range<usize>| -> [f64; 3] {
        core::array::from_fn(|j| {
            -r.forces[range.clone()]
                .iter()
                .map(|f| f64::from(f.to_array()[j]) * 1e-3)
                .sum::<f64>()
        })
    };
    let want = impulse(0..loaded);
    let last = impulse(loaded..ticks);
    assert!(want[2] < -1e-3, "the burr pushed down: {want:?}");
    // The last cycle's impulse is what tells the lag apart: it must be far over the tolerance.
    let tol = 1e-2 * want[2].abs();
    assert!(
        last[2].abs() > 3.0 * tol,
        "the last cycle's impulse {last:?}"
    );
    for j in 0..3 {
        assert!(
            (momentum[j] - want[j]).abs() < tol,
            "axis {j}: momentum {} against the impulse {} of the loaded cycles (the last's {})",
            momentum[j],
            want[j],
            last[j]
        );
    }
}

#[test]
fn bad_calls_get_their_status() {
    let sc = builtin("firmware");
    let mut p = params_of(&sc, 4);
    p.deformable = 1;
    let (_mem, world) = c_world(&p, 4, None, &[]);
    let mut rigid_p = params_of(&sc, 4);
    rigid_p.deformable = 0;
    let (_rmem, rigid) = c_world(&rigid_p, 4, None, &[]);
    let (xyz, tets) = block(4);
    let body = CSoft::new(&xyz, &tets, &defaults()).expect("a body");
    let other = CSoft::new(&xyz, &tets, &defaults()).expect("a body");
    let (b2xyz, b2tets) = block(2);
    let small = CSoft::new(&b2xyz, &b2tets, &defaults()).expect("a body");
    let n = body.nodes;

    let (mut size, mut align) = (0usize, 0usize);
    // SAFETY: the calls below pass live handles or deliberately bad pointers, which the
    // interface refuses before reading them.
    unsafe {
        assert_eq!(
            td_link_size(0, &mut size, &mut align),
            TdStatus::TdErrParams
        );
        assert_eq!(
            td_link_size(n, ptr::null_mut(), &mut align),
            TdStatus::TdErrNull
        );
        assert_eq!(td_link_size(n, &mut size, &mut align), TdStatus::TdOk);
        assert!(size >= 36 * n as usize && align >= 4);
    }
    let init = |w: *mut TdWorld, s: *mut TdSoft, ticks: u32, dt: f32| {
        CLink::new(w, s, n, ticks, dt).map(|_| ())
    };
    assert_eq!(init(rigid, body.h, TICKS, 1e-3), Err(TdStatus::TdErrRigid));
    assert_eq!(init(world, body.h, 0, 1e-3), Err(TdStatus::TdErrParams));
    assert_eq!(init(world, body.h, TICKS, 0.0), Err(TdStatus::TdErrParams));
    assert_eq!(
        init(world, body.h, TICKS, f32::NAN),
        Err(TdStatus::TdErrParams)
    );
    assert_eq!(
        init(world, small.h, TICKS, 1e-3),
        Err(TdStatus::TdErrParams)
    );
    assert_eq!(
        init(world, ptr::null_mut(), TICKS, 1e-3),
        Err(TdStatus::TdErrNull)
    );
    let mut junk = [0u64; 64];
    let fake = junk.as_mut_ptr().cast::<TdSoft>();
    assert_eq!(init(world, fake, TICKS, 1e-3), Err(TdStatus::TdErrNotInit));
    {
        // Memory too short; then no handle.
        let mut h = ptr::null_mut();
        let mem = Memory::new(size, align);
        // SAFETY: `size - 1` bytes of `size` given; live handles.
        let st =
            unsafe { td_link_init(mem.ptr.cast(), size - 1, world, body.h, TICKS, 1e-3, &mut h) };
        assert_eq!(st, TdStatus::TdErrTooSmall);
        assert!(h.is_null());
    }

    let link = CLink::new(world, body.h, n, TICKS, 1e-3).expect("a link");
    let zero = TdVec3::default();
    let mut out = TdLinkReport::default();
    // SAFETY: live handles, or ones the interface refuses before use.
    unsafe {
        // Not the world or the body it was made for.
        assert_eq!(
            td_link_tick(link.h, rigid, body.h, zero, &mut out),
            TdStatus::TdErrParams
        );
        assert_eq!(
            td_link_tick(link.h, world, other.h, zero, &mut out),
            TdStatus::TdErrParams
        );
        let nan = TdVec3 {
            x: f32::NAN,
            y: 0.0,
            z: 0.0,
        };
        assert_eq!(
            td_link_tick(link.h, world, body.h, nan, &mut out),
            TdStatus::TdErrInput
        );
        assert_eq!(link.counts().steps, 0);
        assert_eq!(
            td_link_tick(ptr::null_mut(), world, body.h, zero, &mut out),
            TdStatus::TdErrNull
        );
        let fake_link = junk.as_mut_ptr().cast::<TdLink>();
        assert_eq!(
            td_link_tick(fake_link, world, body.h, zero, &mut out),
            TdStatus::TdErrNotInit
        );
        // A cycle holds the body and the world from its first tick to its commit: at every
        // tick of it (the physics, then the positions written, then the world's update
        // prepared) the body's own step and held nodes, the world's whole update, a second
        // link on either and another link's tick are refused.
        let second = CLink::new(world, other.h, n, TICKS, 1e-3).expect("a link on the world");
        let rest = body.nodes(TdSoftField::TdSoftRest);
        let origin = TdVec3::default();
        for tick in 0..TICKS - 1 {
            assert_eq!(
                td_link_tick(link.h, world, body.h, zero, &mut out),
                TdStatus::TdOk
            );
            assert_eq!(out.committed, 0);
            assert_eq!(body.step(1e-3, None), TdStatus::TdErrBusy, "tick {tick}");
            assert_eq!(td_soft_set_fixed(body.h, 0, 1), TdStatus::TdErrBusy);
            let st = td_soft_fix_below(body.h, origin, origin, ptr::null_mut());
            assert_eq!(st, TdStatus::TdErrBusy);
            let st = td_world_set_positions(world, rest.as_ptr(), n, ptr::null_mut());
            assert_eq!(st, TdStatus::TdErrBusy, "tick {tick}");
            assert_eq!(init(world, body.h, TICKS, 1e-3), Err(TdStatus::TdErrBusy));
            assert_eq!(init(world, small.h, TICKS, 1e-3), Err(TdStatus::TdErrBusy));
            let st = td_link_tick(second.h, world, other.h, zero, &mut out);
            assert_eq!(st, TdStatus::TdErrBusy, "another link on the world");
        }
        assert_eq!(second.counts().steps, 0);
        assert_eq!(
            td_link_tick(link.h, world, body.h, zero, &mut out),
            TdStatus::TdOk
        );
        assert_eq!(out.committed, 1);
        assert_eq!(link.counts().steps, 1);
        // Between cycles both are free again.
        let st = td_world_set_positions(world, rest.as_ptr(), n, ptr::null_mut());
        assert_eq!(st, TdStatus::TdOk);
        assert_eq!(td_soft_set_fixed(body.h, 0, 0), TdStatus::TdOk);
        assert_eq!(body.step(1e-3, None), TdStatus::TdOk);
        // The link's memory apart from the handles it borrows.
        let (mut size, mut align) = (0usize, 0usize);
        assert_eq!(td_link_size(n, &mut size, &mut align), TdStatus::TdOk);
        let mut h = ptr::null_mut();
        let st = td_link_init(body.h.cast(), size, world, body.h, TICKS, 1e-3, &mut h);
        assert_eq!(
            st,
            TdStatus::TdErrParams,
            "the body's memory given as the link's"
        );
        // The counters' and the size's bad pointers.
        let mut c = TdLinkCounts::default();
        assert_eq!(
            td_link_counters(ptr::null_mut(), &mut c),
            TdStatus::TdErrNull
        );
        assert_eq!(
            td_link_counters(link.h, ptr::null_mut()),
            TdStatus::TdErrNull
        );
        let fake_link = junk.as_mut_ptr().cast::<TdLink>();
        assert_eq!(td_link_counters(fake_link, &mut c), TdStatus::TdErrNotInit);
        assert_eq!(
            td_link_size(n, &mut size, ptr::null_mut()),
            TdStatus::TdErrNull
        );
        assert_eq!(
            td_link_size(1 << 29, &mut size, &mut align),
            TdStatus::TdErrParams
        );
        let st = td_link_init(ptr::null_mut(), size, world, body.h, TICKS, 1e-3, &mut h);
        assert_eq!(st, TdStatus::TdErrNull);
        let mem = Memory::new(size, align);
        let st = td_link_init(
            mem.ptr.cast(),
            size,
            world,
            body.h,
            TICKS,
            1e-3,
            ptr::null_mut(),
        );
        assert_eq!(st, TdStatus::TdErrNull);
        let odd = mem.ptr.wrapping_add(1);
        let st = td_link_init(odd.cast(), size - 1, world, body.h, TICKS, 1e-3, &mut h);
        assert_eq!(st, TdStatus::TdErrAlign);
        let name = std::ffi::CStr::from_ptr(td_status_name(TdStatus::TdErrBusy as i32));
        assert!(name.to_str().expect("utf-8").contains("td_link_tick"));
    }
}
