//! A soft body through the C interface: free fall against an f64 reference of the
//! integrator, a loaded and held body against the host's own body bit for bit, and a status
//! for every bad handle, pointer, count, parameter and mesh.

mod common;

use std::ptr;

use common::soft::{block, defaults, CSoft};
use common::Memory;
use tetradrill::soft::SoftOwned;
use tetradrill_core::soft::{Material, SoftParams};
use tetradrill_core::Vec3;
use tetradrill_ffi::*;

#[test]
fn a_free_body_falls_as_the_integrator_does_in_f64_and_keeps_its_shape() {
    let (xyz, tets) = block(3);
    let mut p = defaults();
    p.gravity = TdVec3 {
        x: 0.0,
        y: 0.0,
        z: -9.81,
    };
    p.substeps = 4;
    let b = CSoft::new(&xyz, &tets, &p).expect("a body");
    let (dt, steps) = (0.01f32, 30);
    for _ in 0..steps {
        assert_eq!(b.step(dt, None), TdStatus::TdOk);
    }
    // Semi-implicit Euler over the substeps, in f64: v += g h, x += v h.
    let h = f64::from(dt) / 4.0;
    let (mut v, mut x) = (0.0f64, 0.0f64);
    for _ in 0..steps * 4 {
        v += -9.81f32 as f64 * h;
        x += v * h;
    }
    let d = b.nodes(TdSoftField::TdSoftDisplacements);
    let vel = b.nodes(TdSoftField::TdSoftVelocities);
    assert!(x < -0.04, "the body has fallen ({x})");
    for (dk, vk) in d.chunks(3).zip(vel.chunks(3)) {
        assert!(
            dk[0].abs() < 1e-6 && dk[1].abs() < 1e-6,
            "no sideways drift: {dk:?}"
        );
        assert!(
            (f64::from(dk[2]) - x).abs() < 1e-4 * x.abs(),
            "{} against {x}",
            dk[2]
        );
        assert!(
            (f64::from(vk[2]) - v).abs() < 1e-4 * v.abs(),
            "{} against {v}",
            vk[2]
        );
    }
    let pos = b.nodes(TdSoftField::TdSoftPositions);
    let rest = b.nodes(TdSoftField::TdSoftRest);
    assert_eq!(rest, xyz, "the rest positions as given");
    for ((p, r), d) in pos.iter().zip(&rest).zip(&d) {
        assert_eq!(*p, r + d);
    }
    let c = b.counts();
    assert_eq!(c.steps, steps as u64);
    assert!((c.time - 0.3).abs() < 1e-6);
    assert!(
        c.elastic_energy < 1e-9,
        "a rigid fall strains nothing: {}",
        c.elastic_energy
    );
    assert_eq!(c.fixed_nodes, 0);
}

#[test]
fn a_loaded_held_body_steps_to_the_bits_of_the_hosts() {
    let (xyz, tets) = block(4);
    let mut p = defaults();
    p.gravity = TdVec3 {
        x: 0.0,
        y: 0.0,
        z: -9.81,
    };
    p.young = 20_000.0;
    p.damping = 2.0;
    let b = CSoft::new(&xyz, &tets, &p).expect("a body");
    let n = b.nodes as usize;
    let held = b.hold_base();
    assert_eq!(held, 25, "the block's bottom face");
    // One top node held too.
    let top = xyz.chunks(3).position(|c| c[2] > 0.49).expect("a top node");
    // SAFETY: a live handle.
    assert_eq!(
        unsafe { td_soft_set_fixed(b.h, top as u32, 1) },
        TdStatus::TdOk
    );
    // A push on the top nodes, sideways and down.
    let loads: Vec<f32> = xyz
        .chunks(3)
        .flat_map(|c| {
            if c[2] > 0.49 {
                [0.5, 0.0, -1.0]
            } else {
                [0.0; 3]
            }
        })
        .collect();

    let rest: Vec<Vec3> = xyz.chunks(3).map(|c| Vec3::new(c[0], c[1], c[2])).collect();
    let t4: Vec<[u32; 4]> = tets.chunks(4).map(|c| [c[0], c[1], c[2], c[3]]).collect();
    // The C body holds its tets in lane order (the core's `lane_order`), as the host's does.
    let (mut owned, _) = SoftOwned::new(rest, t4).in_lanes();
    let material = Material {
        young: 20_000.0,
        poisson: 0.3,
        density: 1000.0,
    };
    let params = SoftParams {
        gravity: Vec3::new(0.0, 0.0, -9.81),
        damping: 2.0,
        substeps: 10,
        iterations: 1,
    };
    let mut host = owned.body(&[material], params).expect("the host's body");
    host.fix_below(Vec3::new(0.0, 0.0, -0.49), Vec3::Z);
    host.set_fixed(top, true);
    let host_loads: Vec<Vec3> = loads
        .chunks(3)
        .map(|c| Vec3::new(c[0], c[1], c[2]))
        .collect();
    for _ in 0..25 {
        assert_eq!(b.step(0.004, Some(&loads)), TdStatus::TdOk);
        host.step(0.004, &host_loads).expect("host step");
    }
    let want: Vec<f32> = host
        .displacements()
        .iter()
        .flat_map(|v| v.to_array())
        .collect();
    let got = b.nodes(TdSoftField::TdSoftDisplacements);
    assert_eq!(got.len(), 3 * n);
    assert!(
        got.iter().any(|d| d.abs() > 1e-4),
        "the load moves the block"
    );
    assert_eq!(
        got.iter().map(|f| f.to_bits()).collect::<Vec<_>>(),
        want.iter().map(|f| f.to_bits()).collect::<Vec<_>>()
    );
    for (k, c) in got.chunks(3).enumerate() {
        if xyz[3 * k + 2] < -0.49 || k == top {
            assert_eq!(c, [0.0; 3], "held node {k} stays");
        }
    }
    let c = b.counts();
    assert_eq!(c.fixed_nodes, 26);
    assert_eq!(c.elastic_energy, host.elastic_energy());
    assert_eq!(c.kinetic_energy, host.kinetic_energy());
    assert!(c.elastic_energy > 0.0);
}

#[test]
fn every_bad_call_gets_its_status_and_changes_nothing() {
    let (xyz, tets) = block(2);
    let p = defaults();
    let (nodes, tcount) = ((xyz.len() / 3) as u32, (tets.len() / 4) as u32);
    let (mut size, mut align) = (0usize, 0usize);
    // SAFETY: valid or null out-pointers, as each case says.
    unsafe {
        assert_eq!(
            td_soft_size(0, 1, &mut size, &mut align),
            TdStatus::TdErrParams
        );
        assert_eq!(
            td_soft_size(1, TD_MAX_COUNT + 1, &mut size, &mut align),
            TdStatus::TdErrParams
        );
        assert_eq!(
            td_soft_size(nodes, tcount, ptr::null_mut(), &mut align),
            TdStatus::TdErrNull
        );
        assert_eq!(
            td_soft_size(nodes, tcount, &mut size, &mut align),
            TdStatus::TdOk
        );
        assert_eq!(td_soft_params_default(ptr::null_mut()), TdStatus::TdErrNull);
    }
    let mem = Memory::new(size + align, align);
    let init = |mem: *mut u8, len: usize, xyz: &[f32], tets: &[u32], p: &TdSoftParams| {
        let mut h = ptr::null_mut();
        let mut bad = u32::MAX;
        // SAFETY: the arrays' lengths match the counts; the memory is `len` bytes.
        let st = unsafe {
            td_soft_init(
                mem.cast(),
                len,
                xyz.as_ptr(),
                (xyz.len() / 3) as u32,
                tets.as_ptr(),
                (tets.len() / 4) as u32,
                p,
                &mut h,
                &mut bad,
            )
        };
        (st, h, bad)
    };
    assert_eq!(
        init(mem.ptr, size - 1, &xyz, &tets, &p).0,
        TdStatus::TdErrTooSmall
    );
    // SAFETY: one byte into the allocation, still `size` bytes before its end.
    let off = unsafe { mem.ptr.add(1) };
    assert_eq!(init(off, size, &xyz, &tets, &p).0, TdStatus::TdErrAlign);
    for bad_p in [
        TdSoftParams { young: -1.0, ..p },
        TdSoftParams { poisson: 0.5, ..p },
        TdSoftParams { density: 0.0, ..p },
        TdSoftParams { substeps: 0, ..p },
        TdSoftParams {
            iterations: 101,
            ..p
        },
        TdSoftParams {
            gravity: TdVec3 {
                x: f32::NAN,
                y: 0.0,
                z: 0.0,
            },
            ..p
        },
    ] {
        assert_eq!(
            init(mem.ptr, size, &xyz, &tets, &bad_p).0,
            TdStatus::TdErrParams,
            "{bad_p:?}"
        );
    }
    let mut flipped = tets.clone();
    flipped.swap(4 * 5 + 1, 4 * 5 + 2);
    assert_eq!(init(mem.ptr, size, &xyz, &flipped, &p).2, 5);
    assert_eq!(
        init(mem.ptr, size, &xyz, &flipped, &p).0,
        TdStatus::TdErrMesh
    );
    let mut out_of_range = tets.clone();
    out_of_range[4 * 7] = nodes;
    assert_eq!(
        init(mem.ptr, size, &xyz, &out_of_range, &p).0,
        TdStatus::TdErrMesh
    );
    let mut nan = xyz.clone();
    nan[3 * 4 + 1] = f32::INFINITY;
    let (st, _, bad) = init(mem.ptr, size, &nan, &tets, &p);
    assert_eq!((st, bad), (TdStatus::TdErrMesh, 4));

    // A refused init leaves no body behind.
    let stale = mem.ptr.cast::<TdSoft>();
    // SAFETY: the memory a failed init was given.
    assert_eq!(
        unsafe { td_soft_step(stale, 0.01, ptr::null()) },
        TdStatus::TdErrNotInit
    );

    let (st, h, _) = init(mem.ptr, size, &xyz, &tets, &p);
    assert_eq!(st, TdStatus::TdOk);
    let mut out = vec![0.0f32; 3 * nodes as usize];
    let loads = vec![f32::NAN; 3 * nodes as usize];
    // SAFETY: a live handle, and pointers as each case says.
    unsafe {
        assert_eq!(td_soft_step(h, 0.0, ptr::null()), TdStatus::TdErrInput);
        assert_eq!(td_soft_step(h, f32::NAN, ptr::null()), TdStatus::TdErrInput);
        assert_eq!(td_soft_step(h, 0.01, loads.as_ptr()), TdStatus::TdErrInput);
        assert_eq!(
            td_soft_step(ptr::null_mut(), 0.01, ptr::null()),
            TdStatus::TdErrNull
        );
        assert_eq!(
            td_soft_nodes(
                h,
                TdSoftField::TdSoftPositions as u32,
                out.as_mut_ptr(),
                nodes + 1
            ),
            TdStatus::TdErrParams
        );
        assert_eq!(
            td_soft_nodes(
                h,
                TdSoftField::TdSoftPositions as u32,
                ptr::null_mut(),
                nodes
            ),
            TdStatus::TdErrNull
        );
        assert_eq!(td_soft_set_fixed(h, nodes, 1), TdStatus::TdErrParams);
        let inf = TdVec3 {
            x: f32::INFINITY,
            y: 0.0,
            z: 0.0,
        };
        assert_eq!(
            td_soft_fix_below(h, inf, inf, ptr::null_mut()),
            TdStatus::TdErrInput
        );
        let mut c = TdSoftCounts::default();
        assert_eq!(td_soft_counters(h, &mut c), TdStatus::TdOk);
        assert_eq!(
            (c.steps, c.fixed_nodes),
            (0, 0),
            "no bad call stepped or held"
        );
        assert_eq!(
            td_soft_nodes(h, 4, out.as_mut_ptr(), nodes),
            TdStatus::TdErrParams
        );
        assert_eq!(
            td_soft_nodes(
                h,
                TdSoftField::TdSoftDisplacements as u32,
                out.as_mut_ptr(),
                nodes
            ),
            TdStatus::TdOk
        );
    }
    assert!(out.iter().all(|&d| d == 0.0), "the body is still at rest");
}
