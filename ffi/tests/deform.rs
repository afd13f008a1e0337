//! A soft body touched through the C interface: a deformable world (`td_params.deformable`)
//! whose nodes follow the body (`td_world_set_positions`), the tool's reaction loading the body
//! where the world's contact is (`td_world_contact_at`, `td_soft_add_point_force`). Checked
//! against the core driven directly (the same loop, bit for bit), against Newton's third law
//! (a free block's momentum is the impulse of the servo's forces), on the tet indices the body
//! keeps in an order of its own (the caller's in and out), and for every bad call's status.

mod common;

use std::ptr;

use common::soft::{assert_same_forces, block, defaults, lumped_masses, momentum, vec_bits, CSoft};
use common::{block_arrays, builtin, c_world, params_of};
use tetradrill::engine::{self, EngineStorage, TickParams};
use tetradrill::soft::SoftOwned;
use tetradrill::traces::Pose;
use tetradrill_core::force::ToolState;
use tetradrill_core::soft::{Material, SoftParams};
use tetradrill_core::Vec3;
use tetradrill_ffi::*;

/// Servo ticks per soft-body step.
const TICKS_PER_STEP: usize = 5;

/// The burr's centre at tick `i`: above the top face's middle (z = 0.5), lowered from just
/// touching to `press` deep over 200 ticks, then held.
fn centre(i: usize, radius: f32, press: f32) -> Vec3 {
    let s = (i as f32 / 200.0).min(1.0);
    Vec3::new(0.06, -0.04, 0.5 + radius - s * press)
}

/// What a run of the C loop gave: each tick's force, the body's final positions and the
/// world's last contact point.
struct Run {
    forces: Vec<Vec3>,
    positions: Vec<f32>,
    velocities: Vec<f32>,
    contact: TdContactAt,
}

/// A soft body's settings for [`c_run`].
#[derive(Clone, Copy)]
struct Body {
    young: f32,
    density: f32,
    damping: f32,
    /// Its base held (the nodes at z = -0.5), else free.
    held: bool,
}

/// The block held at its base, damped (20 /s) to settle within the test's second.
const HELD: Body = Body {
    young: 5_000.0,
    density: 1_000.0,
    damping: 20.0,
    held: true,
};

/// The firmware scenario's world on the 4-block (made deformable when `deformable`) and a soft
/// `body`, the burr pressed `press` deep for `ticks` ticks with the drill off: each tick's
/// reaction loads the body at the contact, every [`TICKS_PER_STEP`] ticks the body steps under
/// their mean and the world takes its positions.
fn c_run(b: Body, press: f32, ticks: usize, deformable: bool) -> Run {
    let sc = builtin("firmware");
    let mut p = params_of(&sc, 4);
    p.deformable = u32::from(deformable);
    let (_mem, world) = c_world(&p, 4, None, &[]);
    let (xyz, tets) = block(4);
    let mut sp = defaults();
    sp.young = b.young;
    sp.density = b.density;
    sp.damping = b.damping;
    let body = CSoft::new(&xyz, &tets, &sp).expect("a body");
    if b.held {
        assert_eq!(body.hold_base(), 25, "the block's base");
    }
    let n = body.nodes;
    let mut loads = vec![0.0f32; 3 * n as usize];
    let mut forces = Vec::with_capacity(ticks);
    let mut contact = TdContactAt::default();
    let mean = 1.0 / TICKS_PER_STEP as f32;
    for i in 0..ticks {
        let c = centre(i, p.radius, press);
        let mut f = TdVec3::default();
        // SAFETY: a live world; writable outputs; `loads` holds `3 n` floats.
        unsafe {
            let at = TdVec3 {
                x: c.x,
                y: c.y,
                z: c.z,
            };
            assert_eq!(td_world_tick(world, at, 0, &mut f), TdStatus::TdOk);
            assert_eq!(td_world_contact_at(world, &mut contact), TdStatus::TdOk);
            let reaction = TdVec3 {
                x: -f.x,
                y: -f.y,
                z: -f.z,
            };
            if contact.tet != TD_NO_TET && f != TdVec3::default() {
                assert_eq!(
                    td_soft_add_point_force(
                        body.h,
                        contact.tet,
                        contact.point,
                        reaction,
                        loads.as_mut_ptr()
                    ),
                    TdStatus::TdOk
                );
            }
        }
        forces.push(Vec3::new(f.x, f.y, f.z));
        if (i + 1) % TICKS_PER_STEP != 0 || !deformable {
            continue;
        }
        loads.iter_mut().for_each(|l| *l *= mean);
        assert_eq!(
            body.step(TICKS_PER_STEP as f32 * p.dt, Some(&loads)),
            TdStatus::TdOk
        );
        loads.fill(0.0);
        let now = body.nodes(TdSoftField::TdSoftPositions);
        let mut rep = TdDeformReport::default();
        // SAFETY: a live world; `3 n` floats; a writable report.
        let st = unsafe { td_world_set_positions(world, now.as_ptr(), n, &mut rep) };
        assert_eq!(st, TdStatus::TdOk);
        assert_eq!(rep.hash_saturated, 0);
    }
    Run {
        forces,
        positions: body.nodes(TdSoftField::TdSoftPositions),
        velocities: body.nodes(TdSoftField::TdSoftVelocities),
        contact,
    }
}

#[test]
fn a_soft_block_touched_through_c_is_the_cores_bit_for_bit() {
    let (press, ticks) = (0.02, 400);
    let c = c_run(HELD, press, ticks, true);

    // The same loop on the core, through the host's storage for the scenario's world.
    let sc = builtin("firmware");
    let mut loaded = engine::load_mesh(&sc).expect("mesh");
    let params = TickParams::of(&sc).expect("tick params");
    let mut store = EngineStorage::new(loaded.mesh.clone(), &sc).expect("storage");
    store.enable_deformation().expect("deformation");
    let mut world = store.world().expect("world");
    // The body's tets in lane order, as the C body holds them; `body_tet` maps the world's.
    let (mut owned, tet_of) = SoftOwned::from_mesh(&loaded.mesh.view()).in_lanes();
    let mut body_tet = vec![0usize; tet_of.len()];
    for (i, &t) in tet_of.iter().enumerate() {
        body_tet[t as usize] = i;
    }
    let material = Material {
        young: HELD.young,
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
    let mut tool = ToolState::default();
    let mut external = vec![Vec3::ZERO; body.node_count()];
    let mut now = vec![Vec3::ZERO; body.node_count()];
    let mut forces = Vec::new();
    let mean = 1.0 / TICKS_PER_STEP as f32;
    for i in 0..ticks {
        let pose = Pose::at(centre(i, params.radius, press));
        let (f, _) = engine::tick(&mut world, &mut tool, &params, &pose);
        if let Some(t) = world.contact_tet() {
            if f != Vec3::ZERO {
                let own = body_tet[t.idx()];
                assert!(body.add_point_force(own, world.contact().point, -f, &mut external));
            }
        }
        forces.push(f);
        if (i + 1) % TICKS_PER_STEP == 0 {
            external.iter_mut().for_each(|e| *e *= mean);
            body.step(TICKS_PER_STEP as f32 * 1e-3, &external)
                .expect("step");
            external.fill(Vec3::ZERO);
            body.write_positions(&mut now);
            world.set_positions(&now).expect("positions");
        }
    }
    assert_same_forces(&c.forces, &forces);
    let want = vec_bits(&now);
    let got: Vec<u32> = c.positions.iter().map(|f| f.to_bits()).collect();
    assert_eq!(got, want, "the body's positions");
    let tet = world.contact_tet().map_or(TD_NO_TET, |t| t.idx() as u32);
    assert_eq!(c.contact.tet, tet);
    let p = world.contact().point;
    assert_eq!(
        [c.contact.point.x, c.contact.point.y, c.contact.point.z].map(f32::to_bits),
        p.to_array().map(f32::to_bits)
    );
}

#[test]
fn a_free_block_takes_the_burrs_impulse_and_moves_away_from_it() {
    // A light block, free, undamped: the burr pressed into its top pushes it down. Inside the
    // body's step the elastic constraints move no momentum, so the body's momentum is the
    // impulse of the reactions it was loaded with: the sum of the servo's forces times the
    // tick. The masses are the lumped ones (a quarter of each tet's mass to each corner),
    // computed here in f64 from the rest geometry.
    let free = Body {
        young: 5_000.0,
        density: 10.0,
        damping: 0.0,
        held: false,
    };
    let ticks = 1_000;
    let r = c_run(free, 0.02, ticks, true);
    let (xyz, tets) = block(4);
    let momentum = momentum(&lumped_masses(&xyz, &tets, 10.0), &r.velocities);
    let impulse: [f64; 3] = core::array::from_fn(|j| {
        -r.forces
            .iter()
            .map(|f| f64::from(f.to_array()[j]) * 1e-3)
            .sum::<f64>()
    });
    assert!(impulse[2] < -1e-3, "the burr pushed down: {impulse:?}");
    // Within 1 %: the body's velocities are its positions' change over a substep, in f32
    // (about 1e-3 of the momentum here); a load off by a tick's weight or a lost reaction
    // is off by far more.
    for j in 0..3 {
        let tol = 1e-2 * impulse[2].abs();
        assert!(
            (momentum[j] - impulse[j]).abs() < tol,
            "axis {j}: momentum {} against impulse {}",
            momentum[j],
            impulse[j]
        );
    }
    // The block moved away under the burr held still: the world followed it, so the contact
    // let go (a rigid world pushes back at the same pose to the end).
    let last = r.forces[ticks - 1];
    let rigid = c_run(free, 0.02, ticks, false).forces[ticks - 1];
    assert!(rigid.z > 3.0, "the rigid world's force {rigid}");
    assert_eq!(last, Vec3::ZERO, "the free block's force at the end");
    let drop = xyz
        .chunks(3)
        .zip(r.positions.chunks(3))
        .map(|(a, b)| a[2] - b[2])
        .sum::<f32>()
        / (xyz.len() / 3) as f32;
    assert!(drop > 0.02, "the block went down by {drop}");
}

#[test]
fn bad_calls_get_their_status_and_change_nothing() {
    let sc = builtin("firmware");
    let p = params_of(&sc, 4);
    let (_rigid_mem, rigid) = c_world(&p, 4, None, &[]);
    let mut q = p;
    q.deformable = 1;
    let (_mem, world) = c_world(&q, 4, None, &[]);
    let (xyz, _) = block_arrays(4);
    let n = (xyz.len() / 3) as u32;
    let mut bad = xyz.clone();
    bad[7] = f32::NAN;
    let mut at = TdContactAt::default();
    // SAFETY: live worlds; arrays of the lengths given, null or misaligned where refused.
    unsafe {
        assert_eq!(
            td_world_set_positions(rigid, xyz.as_ptr(), n, ptr::null_mut()),
            TdStatus::TdErrRigid
        );
        assert_eq!(
            td_world_set_positions(world, xyz.as_ptr(), n - 1, ptr::null_mut()),
            TdStatus::TdErrParams
        );
        assert_eq!(
            td_world_set_positions(world, bad.as_ptr(), n, ptr::null_mut()),
            TdStatus::TdErrInput
        );
        assert_eq!(
            td_world_set_positions(world, ptr::null(), n, ptr::null_mut()),
            TdStatus::TdErrNull
        );
        assert_eq!(
            td_world_set_positions(ptr::null_mut(), xyz.as_ptr(), n, ptr::null_mut()),
            TdStatus::TdErrNull
        );
        assert_eq!(
            td_world_contact_at(world, ptr::null_mut()),
            TdStatus::TdErrNull
        );
        // No step yet: no contact.
        assert_eq!(td_world_contact_at(world, &mut at), TdStatus::TdOk);
        assert_eq!(at.tet, TD_NO_TET);
        // The rest positions again: nothing moves.
        let mut rep = TdDeformReport::default();
        assert_eq!(
            td_world_set_positions(world, xyz.as_ptr(), n, &mut rep),
            TdStatus::TdOk
        );
        assert_eq!(rep.max_displacement, 0.0);
        assert_eq!(rep.hash_saturated, 0);
    }
    let (sxyz, stets) = block(4);
    let body = CSoft::new(&sxyz, &stets, &defaults()).expect("a body");
    let mut loads = vec![0.0f32; 3 * body.nodes as usize];
    let one = TdVec3 {
        x: 0.0,
        y: 0.0,
        z: -1.0,
    };
    let inside = TdVec3 {
        x: 0.3,
        y: 0.3,
        z: 0.3,
    };
    let tets = (stets.len() / 4) as u32;
    // SAFETY: a live body; `loads` of `3 n` floats, or null where refused.
    unsafe {
        assert_eq!(
            td_soft_add_point_force(body.h, tets, inside, one, loads.as_mut_ptr()),
            TdStatus::TdErrInput
        );
        let nan = TdVec3 { x: f32::NAN, ..one };
        assert_eq!(
            td_soft_add_point_force(body.h, 0, inside, nan, loads.as_mut_ptr()),
            TdStatus::TdErrInput
        );
        assert_eq!(
            td_soft_add_point_force(body.h, 0, inside, one, ptr::null_mut()),
            TdStatus::TdErrNull
        );
        assert!(loads.iter().all(|&l| l == 0.0), "nothing added on an error");
    }
}

/// The body keeps its tets in lane order (the core's `lane_order`), the caller's indices in
/// and out: a point force on a tet the order moved lands on that tet's nodes as given, and an
/// inverted tet the order moved is named by its given index.
#[test]
fn a_bodys_tets_are_named_by_the_callers_indices() {
    let (xyz, tets) = block(4);
    let t4: Vec<[u32; 4]> = tets.chunks(4).map(|c| [c[0], c[1], c[2], c[3]]).collect();
    let (mut tet_of, mut body_tet) = (vec![0u32; t4.len()], vec![0u32; t4.len()]);
    assert!(tetradrill_core::soft::lane_order(
        &t4,
        &mut tet_of,
        &mut body_tet
    ));
    let moved = (0..t4.len())
        .find(|&t| body_tet[t] as usize != t && tet_of[t] as usize != t)
        .expect("a tet the order moves");
    let body = CSoft::new(&xyz, &tets, &defaults()).expect("a body");
    let mut loads = vec![0.0f32; 3 * body.nodes as usize];
    let given = t4[moved];
    let centre = given
        .iter()
        .map(|&k| Vec3::from_slice(&xyz[3 * k as usize..]))
        .sum::<Vec3>()
        / 4.0;
    let at = TdVec3 {
        x: centre.x,
        y: centre.y,
        z: centre.z,
    };
    let down = TdVec3 {
        x: 0.0,
        y: 0.0,
        z: -1.0,
    };
    // SAFETY: a live body; `loads` of `3 n` floats.
    let st = unsafe { td_soft_add_point_force(body.h, moved as u32, at, down, loads.as_mut_ptr()) };
    assert_eq!(st, TdStatus::TdOk);
    // At the centre: a quarter on each of the given tet's four nodes, nothing elsewhere.
    for (k, c) in loads.chunks(3).enumerate() {
        let want = if given.contains(&(k as u32)) {
            -0.25
        } else {
            0.0
        };
        assert!(
            (c[2] - want).abs() < 1e-6 && c[0] == 0.0 && c[1] == 0.0,
            "node {k}: {c:?}"
        );
    }
    // The same tet turned inside out: refused, named as given.
    let mut bad = tets.clone();
    bad.swap(4 * moved + 1, 4 * moved + 2);
    match CSoft::new(&xyz, &bad, &defaults()) {
        Err((st, item)) => assert_eq!((st, item), (TdStatus::TdErrMesh, moved as u32)),
        Ok(_) => panic!("an inverted tet must be refused"),
    }
}

#[test]
fn a_deformable_world_asks_for_its_rest_and_spare_storage() {
    let sc = builtin("firmware");
    let p = params_of(&sc, 4);
    let mut q = p;
    q.deformable = 1;
    let (mut rigid, mut soft, mut align) = (0usize, 0usize, 0usize);
    // SAFETY: valid pointers.
    unsafe {
        assert_eq!(td_world_size(&p, &mut rigid, &mut align), TdStatus::TdOk);
        assert_eq!(td_world_size(&q, &mut soft, &mut align), TdStatus::TdOk);
    }
    let (nodes, tets) = (p.node_count as usize, p.tet_count as usize);
    // Rest and normals (12 bytes a node each), the hash's bucket offsets (4 bytes each, two
    // a tet) and entries, a box a tet (24 bytes): at least that, at most the alignment's
    // padding more.
    let at_least = 24 * nodes + 4 * (2 * tets + 2) + 24 * tets + 16 * p.hash_capacity as usize;
    let more = soft - rigid;
    assert!(
        (at_least..at_least + 5 * 64).contains(&more),
        "{more} bytes more, {at_least} expected"
    );
}
