//! The tet-mesh tool (the pen) through the C interface, called as C calls it, against the
//! host's pen on the same poses: the host's contact scene on the heap (`pen::PenRig`, the
//! set-up's options and sizes) and its tick (`pen_contact`, which `replay --tool mesh:FILE`
//! matches bit for bit); the torque against the moment computed here, in f64, from the host's
//! penetrations.

use std::ptr;

use tetradrill::pen::{options, PenRig};
use tetradrill::setup::{Setup, Tool};
use tetradrill::traces::{Pose, PoseSource};
use tetradrill_core::force::{pen_contact, ForceDigest, PenState};
use tetradrill_core::{Quat, Vec3};
use tetradrill_ffi::*;

mod common;
use common::*;

/// The pen: the block of 2 scaled by 0.2 (a cube of edge 0.2 centred on the tip).
const PEN_SCALE: f64 = 0.2;

/// The demo with the pen as its tool.
fn setup() -> Setup {
    let mut sc = builtin("demo");
    sc.tool = Tool::parse("mesh:builtin:block:2", PEN_SCALE).expect("a mesh tool");
    sc
}

/// The pen's arrays as the host reads `builtin:block:2` at its scale: f32 positions made
/// f64, scaled, made f32.
fn pen_arrays() -> (Vec<f32>, Vec<u32>) {
    let (xyz, tets) = block_arrays(2);
    let xyz = xyz
        .iter()
        .map(|&v| (f64::from(v) * PEN_SCALE) as f32)
        .collect();
    (xyz, tets)
}

/// The demo's poses, then the pen turned (by rotations a trace could give whose norm is
/// exactly 1, so normalising them changes no bit) while pressed into the block's top face and
/// moved along it.
fn poses(sc: &Setup) -> Vec<Pose> {
    let loaded = tetradrill::engine::load_mesh(sc).expect("mesh");
    let src = PoseSource::new(&sc.poses, Some(&loaded.mesh)).expect("poses");
    let mut out: Vec<Pose> = (0..src.ticks()).map(|i| src.at(i)).collect();
    let turns = [
        [0.5f32, 0.5, 0.5, 0.5],
        [0.0, 1.0, 0.0, 0.0],
        [0.5, -0.5, 0.5, -0.5],
    ];
    for i in 0..1500u32 {
        let u = i as f32 / 1500.0;
        out.push(Pose {
            position: Vec3::new(-0.3 + 0.6 * u, 0.1 * u, 0.62 - 0.1 * u.min(0.5)),
            rotation: turns[(i / 500) as usize],
            buttons: 0,
        });
    }
    out
}

/// The moment about the tip of the penetrations' springs, in f64, from a pass's lists.
fn moment(
    rest: &[Vec3],
    object: &[Vec3],
    pen: &[tetradrill_core::depth::Penetration],
    objs: &[tetradrill_core::depth::Penetration],
    pose: &Pose,
    k: f32,
    max: f32,
) -> [f64; 3] {
    let [w, x, y, z] = pose.rotation;
    let rot = Quat::from_xyzw(x, y, z, w).normalize();
    let d = |v: Vec3| [f64::from(v.x), f64::from(v.y), f64::from(v.z)];
    let c = d(pose.position);
    let (mut sum, mut m) = ([0.0f64; 3], [0.0f64; 3]);
    let mut add = |at: [f64; 3], f: [f64; 3]| {
        let r = [at[0] - c[0], at[1] - c[1], at[2] - c[2]];
        for a in 0..3 {
            sum[a] += f[a];
        }
        m[0] += r[1] * f[2] - r[2] * f[1];
        m[1] += r[2] * f[0] - r[0] * f[2];
        m[2] += r[0] * f[1] - r[1] * f[0];
    };
    for q in pen {
        let at = d(pose.position + rot * rest[q.node.0 as usize]);
        add(at, d(q.dir).map(|v| v * f64::from(k) * f64::from(q.depth)));
    }
    for q in objs {
        let at = d(object[q.node.0 as usize]);
        add(at, d(q.dir).map(|v| -v * f64::from(k) * f64::from(q.depth)));
    }
    let l = (sum[0] * sum[0] + sum[1] * sum[1] + sum[2] * sum[2]).sqrt();
    let s = if l > f64::from(max) {
        f64::from(max) / l
    } else {
        1.0
    };
    m.map(|v| v * s)
}

/// What the host's pen gave: the force digest, each tick's moment, the most nodes inside.
struct Host {
    digest: u64,
    torques: Vec<[f64; 3]>,
    pen_max: usize,
    object_max: usize,
}

fn host_pen(sc: &Setup, poses: &[Pose]) -> Host {
    let obj = tetradrill::engine::load_mesh(sc).expect("object").mesh;
    let pen = tetradrill::meshio::load(std::path::Path::new("builtin:block:2"), PEN_SCALE)
        .expect("pen")
        .mesh;
    let opts = options(sc);
    let mut rig = PenRig { pen, obj };
    let (host, _) = rig
        .with_sizes(sc.capacities.pen(), |scene, bufs| {
            let mut state = PenState::default();
            let mut out = Host {
                digest: 0,
                torques: Vec::new(),
                pen_max: 0,
                object_max: 0,
            };
            let mut digest = ForceDigest::new();
            for pose in poses {
                let [w, x, y, z] = pose.rotation;
                let rot = Quat::from_xyzw(x, y, z, w).normalize();
                let c = pen_contact(scene, bufs, pose.position, rot, &opts, &mut state);
                digest.push(c.force);
                let (np, no) = c.penetrations;
                out.torques.push(moment(
                    scene.pen.positions(),
                    scene.object.positions,
                    &bufs.pen_pens[..np],
                    &bufs.object_pens[..no],
                    pose,
                    opts.params.stiffness,
                    opts.params.max_force,
                ));
                out.pen_max = out.pen_max.max(c.pen_collisions.count);
                out.object_max = out.object_max.max(c.object_collisions.count);
            }
            out.digest = digest.value();
            out
        })
        .expect("the host's scene");
    host
}

/// A pen in fresh memory: the size asked, the init told how much more, the init again.
fn c_pen(p: &TdPenParams, bytes: &mut usize) -> (Memory, *mut TdPen) {
    let (obj_xyz, obj_tets) = block_arrays(8);
    let (pen_xyz, pen_tets) = pen_arrays();
    let (mut size, mut align) = (0usize, 0usize);
    // SAFETY: valid pointers.
    unsafe { assert_eq!(td_pen_size(p, &mut size, &mut align), TdStatus::TdOk) };
    let mut mem = Memory::new(size, align);
    let mut pen: *mut TdPen = ptr::null_mut();
    let (mut needed, mut bad) = (0usize, 0u32);
    let mut init = |mem: &Memory, len: usize, pen: &mut *mut TdPen, needed: &mut usize| {
        // SAFETY: memory of `len` bytes at the alignment asked for, arrays of the counts in
        // `p`.
        unsafe {
            td_pen_init(
                mem.ptr.cast(),
                len,
                p,
                obj_xyz.as_ptr(),
                obj_tets.as_ptr(),
                pen_xyz.as_ptr(),
                pen_tets.as_ptr(),
                pen,
                needed,
                &mut bad,
            )
        }
    };
    assert_eq!(
        init(&mem, size, &mut pen, &mut needed),
        TdStatus::TdErrTooSmall
    );
    assert!(needed > size, "{needed} after {size}");
    mem = Memory::new(needed, align);
    let want = needed;
    assert_eq!(init(&mem, want, &mut pen, &mut needed), TdStatus::TdOk);
    assert_eq!(needed, want, "the bytes in use are the bytes measured");
    *bytes = want;
    (mem, pen)
}

fn params() -> TdPenParams {
    let (on, ot) = tetradrill_core::builtin::block_counts(8);
    let (pn, pt) = tetradrill_core::builtin::block_counts(2);
    // SAFETY: all-zero is a valid TdPenParams (integers and floats).
    let mut p: TdPenParams = unsafe { std::mem::zeroed() };
    // SAFETY: a writable output.
    let st = unsafe { td_pen_params_default(on as u32, ot as u32, pn as u32, pt as u32, &mut p) };
    assert_eq!(st, TdStatus::TdOk);
    p
}

#[test]
fn the_pen_gives_the_hosts_digest_and_its_penetrations_moment() {
    let sc = setup();
    let poses = poses(&sc);
    let host = host_pen(&sc, &poses);
    let p = params();
    // The host's defaults are the set-up's: its forces, its pen options.
    let opts = options(&sc);
    assert_eq!(
        (p.stiffness, p.damping, p.max_force, p.dt),
        (
            opts.params.stiffness,
            opts.params.damping,
            opts.params.max_force,
            opts.params.dt
        )
    );
    assert_eq!(p.reuse_crossings == 1, opts.reuse_crossings);
    let mut bytes = 0;
    let (_mem, pen) = c_pen(&p, &mut bytes);
    let mut servo: *mut TdPenServo = ptr::null_mut();
    // SAFETY: a live pen.
    unsafe { assert_eq!(td_pen_servo_handle(pen, &mut servo), TdStatus::TdOk) };
    let mut pushed = 0;
    for (i, pose) in poses.iter().enumerate() {
        let (mut f, mut t) = (TdVec3::default(), TdVec3::default());
        // SAFETY: a live pen, writable outputs.
        let st = unsafe { td_pen_tick(pen, td_pose(pose), &mut f, &mut t) };
        assert_eq!(st, TdStatus::TdOk);
        let want = host.torques[i];
        let got = [t.x, t.y, t.z].map(f64::from);
        let size = want.iter().map(|v| v.abs()).fold(0.0, f64::max);
        let err = (0..3).map(|a| (got[a] - want[a]).abs()).fold(0.0, f64::max);
        assert!(
            err <= 1e-5 + 1e-4 * size,
            "tick {i}: torque {got:?}, want {want:?}"
        );
        pushed += usize::from(size > 1e-3);
    }
    assert!(pushed > 500, "a moment on {pushed} ticks");
    let (mut c, mut s) = (TdPenCounts::default(), TdPenServoCounts::default());
    // SAFETY: a live pen and its servo.
    unsafe {
        assert_eq!(td_pen_counters(pen, &mut c), TdStatus::TdOk);
        assert_eq!(td_pen_servo_counters(servo, &mut s), TdStatus::TdOk);
    }
    assert_eq!(
        format!("{:016x}", s.force_digest),
        format!("{:016x}", host.digest),
        "the C interface's pen digest differs from the host's"
    );
    assert_eq!(s.servo_ticks, poses.len() as u64);
    assert_eq!((s.stale_reads, s.step), (0, poses.len() as u32));
    assert!(s.contact_ticks > 1000, "{}", s.contact_ticks);
    assert_eq!(c.passes, poses.len() as u64);
    assert_eq!(c.pen_collisions_max as usize, host.pen_max);
    assert_eq!(c.object_collisions_max as usize, host.object_max);
    assert_eq!(c.bytes, bytes as u64);
}

/// Two tasks' calls one after the other, and a servo that renders a pass from a pose the
/// pen has left: the whole tick's digest when it keeps up, and the pass carried to the new
/// pose otherwise (the host's `pen_servo_force` from the same pass).
#[test]
fn the_pens_halves_are_its_whole_tick() {
    let sc = setup();
    let poses = poses(&sc);
    let p = params();
    let mut bytes = 0;
    let run = |halves: bool| {
        let (_mem, pen) = c_pen(&p, &mut 0);
        let mut servo: *mut TdPenServo = ptr::null_mut();
        let mut s = TdPenServoCounts::default();
        // SAFETY: a live pen, its servo, writable outputs.
        unsafe {
            assert_eq!(td_pen_servo_handle(pen, &mut servo), TdStatus::TdOk);
            for pose in &poses {
                let (mut f, mut t) = (TdVec3::default(), TdVec3::default());
                let at = td_pose(pose);
                if halves {
                    assert_eq!(td_pen_simulate(pen, at, ptr::null_mut()), TdStatus::TdOk);
                    assert_eq!(
                        td_pen_servo_wrench(servo, at, &mut f, &mut t),
                        TdStatus::TdOk
                    );
                } else {
                    assert_eq!(td_pen_tick(pen, at, &mut f, &mut t), TdStatus::TdOk);
                }
            }
            assert_eq!(td_pen_servo_counters(servo, &mut s), TdStatus::TdOk);
        }
        s
    };
    let (whole, halves) = (run(false), run(true));
    assert_eq!(halves.force_digest, whole.force_digest);
    assert_eq!(halves.torque_digest, whole.torque_digest);
    // A servo at twice the rate: each pass rendered at its pose, then halfway to the next.
    let (_mem, pen) = c_pen(&p, &mut bytes);
    let mut servo: *mut TdPenServo = ptr::null_mut();
    // SAFETY: a live pen.
    unsafe { assert_eq!(td_pen_servo_handle(pen, &mut servo), TdStatus::TdOk) };
    let mut moved = 0;
    for w in poses.windows(2).take(6000) {
        let mid = Pose {
            position: (w[0].position + w[1].position) * 0.5,
            ..w[0]
        };
        let (mut f, mut t, mut g) = (TdVec3::default(), TdVec3::default(), TdVec3::default());
        // SAFETY: as above.
        unsafe {
            assert_eq!(
                td_pen_tick(pen, td_pose(&w[0]), &mut f, &mut t),
                TdStatus::TdOk
            );
            assert_eq!(
                td_pen_servo_wrench(servo, td_pose(&mid), &mut g, &mut t),
                TdStatus::TdOk
            );
        }
        moved += usize::from(f != g);
    }
    assert!(moved > 100, "the carried force follows the pose: {moved}");
}

#[test]
fn pen_calls_get_their_status() {
    let p = params();
    let (obj_xyz, obj_tets) = block_arrays(8);
    let (pen_xyz, mut pen_tets) = pen_arrays();
    let (mut size, mut align) = (0usize, 0usize);
    // SAFETY: valid, null or deliberately bad pointers; the functions check first.
    unsafe {
        let mut q = p;
        q.pen_tet_count = 0;
        assert_eq!(
            td_pen_size(&q, &mut size, &mut align),
            TdStatus::TdErrParams
        );
        q = p;
        q.max_force = f32::NAN;
        assert_eq!(
            td_pen_size(&q, &mut size, &mut align),
            TdStatus::TdErrParams
        );
        q = p;
        q.depth_method = 2;
        assert_eq!(
            td_pen_size(&q, &mut size, &mut align),
            TdStatus::TdErrParams
        );
        assert_eq!(
            td_pen_size(ptr::null(), &mut size, &mut align),
            TdStatus::TdErrNull
        );
        assert_eq!(td_pen_size(&p, &mut size, &mut align), TdStatus::TdOk);
        assert_eq!(align, 64);
        let big = Memory::new(4 * size + (1 << 20), align);
        let (mut pen, mut needed, mut bad) = (ptr::null_mut(), 0usize, 0u32);
        // A pen tet naming a node twice: refused, the pen's tet named with the top bit.
        pen_tets[4 * 3 + 1] = pen_tets[4 * 3];
        let st = td_pen_init(
            big.ptr.cast(),
            4 * size + (1 << 20),
            &p,
            obj_xyz.as_ptr(),
            obj_tets.as_ptr(),
            pen_xyz.as_ptr(),
            pen_tets.as_ptr(),
            &mut pen,
            &mut needed,
            &mut bad,
        );
        assert_eq!(st, TdStatus::TdErrMesh);
        assert_eq!(bad, TD_PEN_ITEM | 3);
        // Short of the counts' part: told that part.
        let st = td_pen_init(
            big.ptr.cast(),
            size - 1,
            &p,
            obj_xyz.as_ptr(),
            obj_tets.as_ptr(),
            pen_xyz.as_ptr(),
            pen_tets.as_ptr(),
            &mut pen,
            &mut needed,
            &mut bad,
        );
        assert_eq!((st, needed), (TdStatus::TdErrTooSmall, size));
        // A pen handle to memory with no pen, and null or misaligned pointers.
        let pose = TdPose {
            position: TdVec3::default(),
            rotation: TdQuat {
                w: 1.0,
                x: 0.0,
                y: 0.0,
                z: 0.0,
            },
        };
        let (mut f, mut t) = (TdVec3::default(), TdVec3::default());
        let not_a_pen = big.ptr.cast::<TdPen>();
        assert_eq!(
            td_pen_tick(not_a_pen, pose, &mut f, &mut t),
            TdStatus::TdErrNotInit
        );
        assert_eq!(
            td_pen_simulate(ptr::null_mut(), pose, ptr::null_mut()),
            TdStatus::TdErrNull
        );
        let (_mem, pen) = c_pen(&p, &mut 0);
        let mut zero = pose;
        zero.rotation.w = 0.0;
        assert_eq!(td_pen_tick(pen, zero, &mut f, &mut t), TdStatus::TdErrInput);
        let mut nan = pose;
        nan.position.x = f32::NAN;
        assert_eq!(
            td_pen_simulate(pen, nan, ptr::null_mut()),
            TdStatus::TdErrInput
        );
        assert_eq!(
            td_pen_tick(pen, pose, ptr::null_mut(), &mut t),
            TdStatus::TdErrNull
        );
        let mut c = TdPenCounts::default();
        assert_eq!(td_pen_counters(pen, &mut c), TdStatus::TdOk);
        assert_eq!(c.passes, 0, "the refused calls did nothing");
        let mut report = TdPenReport::default();
        assert_eq!(td_pen_simulate(pen, pose, &mut report), TdStatus::TdOk);
        assert!(
            report.pen_collisions > 0,
            "the pen's tip in the block: {report:?}"
        );
    }
}
