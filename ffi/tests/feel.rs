//! A region's feel through the C interface (`td_world_set_region_feel`, `td_world_cutting`,
//! `td_servo_set_spin`, `td_params.vibration_hz`), called as C calls it: the cutting
//! figures and forces against the host's replay engine on the same scenario file, the feed's
//! work against the work summed here from the C forces and the trace, the sideways pull
//! against the geometry worked by hand, and every status.

use std::path::PathBuf;
use std::ptr;

use tetradrill::commands::replay::DrillSummary;
use tetradrill::engine::{self, EngineStorage, ShaftState, TickParams};
use tetradrill::scenario::Scenario;
use tetradrill::setup::Setup;
use tetradrill::traces::{Pose, PoseSource};
use tetradrill_core::force::{DrillTool, ForceDigest, ToolState};
use tetradrill_core::{Quat, Vec3};
use tetradrill_ffi::*;

mod common;
use common::*;

/// A scratch folder for `name`.
fn scratch(name: &str) -> PathBuf {
    let dir =
        std::env::temp_dir().join(format!("tetradrill-ffi-feel-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("a scratch folder");
    dir
}

/// The set-up of a scenario file on the paper's cube (`builtin:cube12`, one region, label 0)
/// with `tool`, `extra` top-level keys, the `region` keys of `[regions.0]` and a trace of
/// `rows` (`t,x,y,z,qw,qx,qy,qz,buttons`), loaded as `tetradrill replay --scenario` loads it.
fn scenario(name: &str, tool: &str, extra: &str, region: &str, rows: &[String]) -> Setup {
    let dir = scratch(name);
    let trace = dir.join("trace.csv");
    let mut csv = String::from("t,x,y,z,qw,qx,qy,qz,buttons\n");
    for r in rows {
        csv.push_str(r);
        csv.push('\n');
    }
    std::fs::write(&trace, csv).expect("trace");
    let file = dir.join("scenario.toml");
    std::fs::write(
        &file,
        format!(
            "mesh = \"builtin:cube12\"\ntool = \"{tool}\"\ntrace = \"{}\"\n{extra}\n[regions.0]\n{region}\n",
            trace.display()
        ),
    )
    .expect("scenario");
    Scenario::load(file.to_str().expect("utf-8"))
        .expect("a scenario")
        .setup()
        .expect("a valid set-up")
}

/// The plunge of the host's cutting test: 0.2 above the cube's top face (z = 0.5) with the
/// drill on, down to 0.05 above it in 0.5 s, then 0.4 into the cube at 0.1 per second, held
/// 0.5 s; the tool's axis turned from +z by `q` (`qw,qx,qy,qz`).
const PLUNGE: [(f64, f64); 4] = [(0.0, 0.85), (0.5, 0.8), (4.5, 0.4), (5.0, 0.4)];

fn plunge_rows(q: &str) -> Vec<String> {
    PLUNGE
        .iter()
        .map(|(t, z)| format!("{t},0,0,{z},{q},1"))
        .collect()
}

/// The trace's height at `t` seconds (linear between the plunge's keys).
fn plunge_z(t: f64) -> f64 {
    for w in PLUNGE.windows(2) {
        let ((t0, z0), (t1, z1)) = (w[0], w[1]);
        if (t0..=t1).contains(&t) {
            return z0 + (z1 - z0) * (t - t0) / (t1 - t0);
        }
    }
    PLUNGE[PLUNGE.len() - 1].1
}

/// What a replay gave: the force digest, each tick's force, the cutting figures after the
/// debris sweep, and the poses.
struct Run {
    digest: u64,
    forces: Vec<[f32; 3]>,
    cutting: TdCutting,
    poses: Vec<Pose>,
}

/// The host's replay of `sc`, tick by tick as `replay` runs it (`engine::tick_tool`), the
/// debris swept at the end, the figures `replay --json` writes as `drill`.
fn host(sc: &Setup) -> Run {
    let loaded = engine::load_mesh(sc).expect("scenario mesh");
    let params = TickParams::of(sc).expect("tick params");
    let poses = PoseSource::new(&sc.poses, Some(&loaded.mesh)).expect("poses");
    let mut store = EngineStorage::new(loaded.mesh, sc).expect("storage");
    store.set_labels(&loaded.labels, sc).expect("labels");
    let mut world = store.world().expect("world");
    let (mut burr, mut shaft) = (ToolState::default(), ShaftState::default());
    let mut digest = ForceDigest::new();
    let (mut forces, mut ps) = (Vec::new(), Vec::new());
    for i in 0..poses.ticks() {
        let pose = poses.at(i);
        let (f, _) = engine::tick_tool(&mut world, &mut burr, &mut shaft, &params, &pose);
        digest.push(f);
        forces.push(f.to_array());
        ps.push(pose);
    }
    let mut scratch = vec![0u32; world.hierarchy().debris_scratch_needed()];
    world
        .remove_debris(
            tetradrill_core::hierarchy::DEBRIS_LEAVES,
            sc.drilling.max_depth,
            &mut scratch,
        )
        .expect("debris");
    let d = DrillSummary::of(&world).expect("a world with regions");
    Run {
        digest: digest.value(),
        forces,
        cutting: TdCutting {
            work: d.cutting_work_j,
            energy: d.cutting_energy_j,
            pool: d.feed_pool_j,
            dropped: d.feed_dropped_j,
        },
        poses: ps,
    }
}

fn td(v: Vec3) -> TdVec3 {
    TdVec3 {
        x: v.x,
        y: v.y,
        z: v.z,
    }
}

/// The spin a C program gives the servo at `pose`, as docs/FFI.md says the host sets it: the
/// tool's axis (the pose's rotated +z) times `sign` while the drill is on, zero while off.
fn spin_at(pose: &Pose, sign: f32) -> Vec3 {
    if pose.buttons & 1 == 0 {
        return Vec3::ZERO;
    }
    let [w, x, y, z] = pose.rotation;
    DrillTool::axis(Quat::from_xyzw(x, y, z, w)) * sign
}

/// `poses` through the C interface on the cube with `sc`'s parameters, materials and feel
/// (the regions' `vibration`, `cutting_energy`, `friction`, and `vibration_hz`), a drill of
/// `shaft` (length, radius) when given, the servo's spin from `spin(pose)` each tick; the
/// debris swept at the end.
fn c_run(
    sc: &Setup,
    shaft: Option<(f32, f32)>,
    poses: &[Pose],
    spin: impl Fn(&Pose) -> Vec3,
) -> Run {
    let mut p = params_of_mesh(sc);
    p.vibration_hz = sc.forces.vibration_hz as f32;
    let (_mem, world) = cube_world(&p, &materials(sc));
    for (&label, r) in &sc.materials.regions {
        let f = |v: Option<f64>| v.unwrap_or(0.0) as f32;
        // SAFETY: a live world.
        let st = unsafe {
            td_world_set_region_feel(
                world,
                label,
                f(r.vibration),
                f(r.cutting_energy),
                f(r.friction),
            )
        };
        assert_eq!(st, TdStatus::TdOk, "region {label}");
    }
    if let Some((length, radius)) = shaft {
        // SAFETY: a live world.
        assert_eq!(
            unsafe { td_world_set_drill(world, length, radius) },
            TdStatus::TdOk
        );
    }
    let mut servo: *mut TdServo = ptr::null_mut();
    // SAFETY: a live world, a writable handle.
    assert_eq!(unsafe { td_world_servo(world, &mut servo) }, TdStatus::TdOk);
    let mut forces = Vec::with_capacity(poses.len());
    for pose in poses {
        let (mut f, mut t) = (TdVec3::default(), TdVec3::default());
        // SAFETY: a live world and its servo, writable outputs; one task.
        unsafe {
            assert_eq!(td_servo_set_spin(servo, td(spin(pose))), TdStatus::TdOk);
            assert_eq!(
                td_world_tick_pose(world, td_pose(pose), pose.buttons, &mut f, &mut t),
                TdStatus::TdOk
            );
        }
        forces.push([f.x, f.y, f.z]);
    }
    let (mut len, mut pieces) = (0usize, 0u32);
    let mut cutting = TdCutting::default();
    let mut sc_counts = TdServoCounts::default();
    // SAFETY: a live world and servo, writable outputs, scratch of the length asked for.
    unsafe {
        assert_eq!(td_world_debris_scratch(world, &mut len), TdStatus::TdOk);
        let mut scratch = vec![0u32; len.max(1)];
        assert_eq!(
            td_world_remove_debris(world, scratch.as_mut_ptr(), scratch.len(), &mut pieces),
            TdStatus::TdOk
        );
        assert_eq!(td_world_cutting(world, &mut cutting), TdStatus::TdOk);
        assert_eq!(td_servo_counters(servo, &mut sc_counts), TdStatus::TdOk);
    }
    Run {
        digest: sc_counts.force_digest,
        forces,
        cutting,
        poses: poses.to_vec(),
    }
}

/// A world with `p`'s parameters on the paper's cube read as the host reads it
/// (`td_mesh_file_read("builtin:cube12")`), with `materials` set: the memory and the handle.
fn cube_world(
    p: &TdParams,
    materials: &[(i32, tetradrill_core::drill::Material)],
) -> (Memory, *mut TdWorld) {
    let name = c"builtin:cube12";
    let mut file: *mut TdMeshFile = ptr::null_mut();
    let mut a = std::mem::MaybeUninit::<TdMeshArrays>::uninit();
    let (mut size, mut align) = (0usize, 0usize);
    let mut world: *mut TdWorld = ptr::null_mut();
    let mut bad = 0u32;
    // SAFETY: a NUL-terminated name, writable outputs; the file's arrays of the counts it
    // gives, memory of the size and alignment asked for; the file freed once the world is
    // built (the world copies the mesh).
    let mem = unsafe {
        assert_eq!(
            td_mesh_file_read(name.as_ptr(), 1.0, &mut file, ptr::null_mut()),
            TdStatus::TdOk
        );
        assert_eq!(td_mesh_file_arrays(file, a.as_mut_ptr()), TdStatus::TdOk);
        let a = a.assume_init();
        assert_eq!((a.node_count, a.tet_count), (p.node_count, p.tet_count));
        assert_eq!(td_world_size(p, &mut size, &mut align), TdStatus::TdOk);
        let mem = Memory::new(size, align);
        let st = td_world_init(
            mem.ptr.cast(),
            size,
            p,
            a.positions,
            a.tets,
            a.labels,
            &mut world,
            &mut bad,
        );
        assert_eq!(st, TdStatus::TdOk);
        td_mesh_file_free(file);
        for &(label, m) in materials {
            let st = td_world_set_region(world, label, m.hardness, m.threshold, m.stiffness);
            assert_eq!(st, TdStatus::TdOk, "region {label}");
        }
        mem
    };
    (mem, world)
}

/// `work` is the energy, the pool and what was dropped, to rounding.
fn balanced(c: &TdCutting) -> bool {
    (c.work - c.energy - c.pool - c.dropped).abs() <= 1e-12 * c.work.max(1e-300)
}

#[test]
fn a_plunge_cut_by_the_feed_reports_the_hosts_work() {
    // 40 J per cubic unit, the host's cutting test's plunge.
    let e = 40.0;
    let sc = scenario(
        "plunge",
        "sphere:0.15",
        "",
        &format!("cutting_energy = {e}"),
        &plunge_rows("1,0,0,0"),
    );
    let h = host(&sc);
    let c = c_run(&sc, None, &h.poses, |p| spin_at(p, sc.forces.spin.sign()));
    assert_eq!(c.digest, h.digest, "force digest");
    // The host's `replay --json` figures, bit for bit.
    assert_eq!(c.cutting, h.cutting);
    let k = c.cutting;
    assert!(k.work > 0.0 && k.energy > 0.5 * k.work, "{k:?}");
    assert!(balanced(&k), "{k:?}");
    // The hand's work: -F . dx summed in f64 from the C forces and the trace's heights (the
    // force of tick i acts while the hand moves to tick i + 1's position).
    let f = &c.forces;
    let work: f64 = (0..f.len() - 1)
        .map(|i| {
            let dz = plunge_z((i + 1) as f64 / 1000.0) - plunge_z(i as f64 / 1000.0);
            -f64::from(f[i][2]) * dz
        })
        .sum();
    assert!(
        (k.work - work).abs() < 0.05 * work,
        "reported {} against {work} from the forces",
        k.work
    );
}

/// The press of the host's sideways-pull test: in the air, then the burr (radius 0.15) 0.03
/// into the cube's top face (z = 0.5), held; the tool's axis along +x all along (a quarter
/// turn about +y), the drill on.
fn press_rows() -> Vec<String> {
    let q = "0.70710678,0,0.70710678,0";
    [(0.0, 0.8), (0.3, 0.8), (0.8, 0.62), (2.0, 0.62)]
        .iter()
        .map(|(t, z)| format!("{t},0,0,{z},{q},1"))
        .collect()
}

#[test]
fn a_spinning_burr_through_c_is_pulled_along_spin_cross_normal() {
    // Nothing is removed (the threshold is above the clamp): the top face stays, its outward
    // normal +z. The axis is +x; clockwise seen from the handle the angular velocity is -x,
    // and the pull is along -x cross z = +y, mu times the normal force; counter-clockwise
    // along -y.
    let mu = 0.2f32;
    for (tool, shaft) in [
        ("sphere:0.15", None),
        ("drill:0.15:0.6:0.03", Some((0.6, 0.03))),
    ] {
        let rough = scenario(
            "press",
            tool,
            "",
            &format!("threshold = 100.0\nfriction = {mu}"),
            &press_rows(),
        );
        let smooth = scenario("smooth", tool, "", "threshold = 100.0", &press_rows());
        let h = host(&rough);
        let poses = &h.poses;
        let plain = c_run(&smooth, shaft, poses, |p| spin_at(p, -1.0)).forces;
        let cw = c_run(&rough, shaft, poses, |_| Vec3::new(-1.0, 0.0, 0.0));
        let ccw = c_run(&rough, shaft, poses, |_| Vec3::new(3.0, 0.0, 0.0)).forces;
        for t in 1000..2000 {
            let (p, a, b) = (plain[t], cw.forces[t], ccw[t]);
            assert!(
                p[2] > 5.0 && p[0] == 0.0 && p[1] == 0.0,
                "{tool} tick {t}: {p:?}"
            );
            for (f, sign) in [(a, 1.0), (b, -1.0)] {
                assert!(
                    (f[1] - sign * mu * f[2]).abs() < 1e-3 * f[2],
                    "{tool} tick {t}: {f:?}, not {sign} * {mu} * fz"
                );
                assert!(
                    f[0].abs() < 1e-4 && (f[2] - p[2]).abs() < 1e-4,
                    "{tool} tick {t}: {f:?}"
                );
            }
        }
        // The host's replay of the same scenario (clockwise, its default): the same forces.
        assert_eq!(cw.digest, h.digest, "{tool}");
        // No spin, or no friction: the plain forces bit for bit; the drill off: no pull.
        assert_eq!(
            c_run(&rough, shaft, poses, |_| Vec3::ZERO).forces,
            plain,
            "{tool}"
        );
        let off: Vec<Pose> = poses.iter().map(|p| Pose { buttons: 0, ..*p }).collect();
        let plain_off = c_run(&smooth, shaft, &off, |_| Vec3::ZERO).forces;
        let spun_off = c_run(&rough, shaft, &off, |_| Vec3::new(-1.0, 0.0, 0.0)).forces;
        assert_eq!(spun_off, plain_off, "{tool}");
        assert!(plain_off[1500][2] > 5.0, "{tool}");
    }
}

#[test]
fn every_feel_with_vibration_through_c_equals_the_hosts_replay() {
    // All of it at once: the plunge tilted 30 degrees about +y, spinning counter-clockwise,
    // with a vibration of 0.5 N at 250 Hz, a cutting energy and a friction.
    let sc = scenario(
        "all",
        "sphere:0.15",
        "vibration_hz = 250.0\nspin = \"ccw\"",
        "cutting_energy = 30.0\nvibration = 0.5\nfriction = 0.2",
        &plunge_rows("0.96592583,0,0.25881905,0"),
    );
    assert_eq!(sc.forces.spin.sign(), 1.0);
    let h = host(&sc);
    let c = c_run(&sc, None, &h.poses, |p| spin_at(p, 1.0));
    assert_eq!(c.digest, h.digest, "force digest");
    assert_eq!(c.forces, h.forces);
    assert_eq!(c.cutting, h.cutting);
    assert!(balanced(&c.cutting), "{:?}", c.cutting);
    // Each setting shows in the forces: without it the run differs.
    for (extra, region) in [
        (
            "spin = \"ccw\"",
            "cutting_energy = 30.0\nvibration = 0.5\nfriction = 0.2",
        ),
        (
            "vibration_hz = 250.0\nspin = \"ccw\"",
            "cutting_energy = 30.0\nvibration = 0.5",
        ),
        (
            "vibration_hz = 250.0\nspin = \"ccw\"",
            "vibration = 0.5\nfriction = 0.2",
        ),
    ] {
        let less = scenario(
            "less",
            "sphere:0.15",
            extra,
            region,
            &plunge_rows("0.96592583,0,0.25881905,0"),
        );
        let r = c_run(&less, None, &h.poses, |p| spin_at(p, 1.0));
        assert_ne!(r.digest, c.digest, "{extra} / {region}");
    }
}

/// A fresh world on the 2-block with no materials.
fn small_world() -> (Memory, *mut TdWorld, TdParams) {
    let (nn, nt) = tetradrill_core::builtin::block_counts(2);
    let mut p = demo_params_for(nn as u32, nt as u32);
    p.radius = 0.2;
    let (mem, w) = c_world(&p, 2, None, &[]);
    (mem, w, p)
}

fn demo_params_for(nodes: u32, tets: u32) -> TdParams {
    let mut p = std::mem::MaybeUninit::<TdParams>::uninit();
    // SAFETY: writable memory for a TdParams, initialised by the call on success.
    unsafe {
        assert_eq!(
            td_params_default(nodes, tets, p.as_mut_ptr()),
            TdStatus::TdOk
        );
        p.assume_init()
    }
}

fn region(w: *mut TdWorld, label: i32) -> TdRegion {
    let mut r = TdRegion::default();
    // SAFETY: a live world, a writable region.
    assert_eq!(unsafe { td_world_region(w, label, &mut r) }, TdStatus::TdOk);
    r
}

#[test]
fn feel_spin_and_cutting_calls_get_their_status() {
    let (_mem, w, p) = small_world();
    // SAFETY throughout: live handles or the null and misaligned pointers under test.
    unsafe {
        // The feel reads back; set_region after it keeps it, and it keeps set_region's.
        assert_eq!(
            td_world_set_region_feel(w, 0, 0.5, 40.0, 0.2),
            TdStatus::TdOk
        );
        assert_eq!(td_world_set_region(w, 0, 3.0, 1.0, 0.0), TdStatus::TdOk);
        let r = region(w, 0);
        assert_eq!(
            (
                r.hardness,
                r.threshold,
                r.vibration,
                r.cutting_energy,
                r.friction
            ),
            (3.0, 1.0, 0.5, 40.0, 0.2)
        );
        let mut at = TdRegion::default();
        assert_eq!(td_world_region_at(w, 0, &mut at), TdStatus::TdOk);
        assert_eq!(at, r);
        assert_eq!(
            td_world_set_region_feel(w, 0, 0.0, 0.0, 0.1),
            TdStatus::TdOk
        );
        let r = region(w, 0);
        assert_eq!(
            (r.hardness, r.vibration, r.cutting_energy, r.friction),
            (3.0, 0.0, 0.0, 0.1)
        );
        // Bad values, an unknown label, a bad world: refused, nothing changed.
        for (v, e, mu) in [
            (-1.0, 0.0, 0.0),
            (0.0, f32::NAN, 0.0),
            (0.0, 0.0, f32::INFINITY),
            (0.0, -0.5, 0.0),
        ] {
            assert_eq!(
                td_world_set_region_feel(w, 0, v, e, mu),
                TdStatus::TdErrParams
            );
        }
        assert_eq!(
            td_world_set_region_feel(w, 7, 0.0, 0.0, 0.0),
            TdStatus::TdErrLabel
        );
        assert_eq!(
            td_world_set_region_feel(ptr::null_mut(), 0, 0.0, 0.0, 0.0),
            TdStatus::TdErrNull
        );
        // Memory no init set up, aligned as a servo's part is (a cache line): the calls must
        // say NotInit, not Align, wherever the stack puts it.
        #[repr(C, align(64))]
        struct Junk([u64; 64]);
        let mut junk = Junk([0; 64]);
        let junk = &mut junk.0;
        assert_eq!(
            td_world_set_region_feel(junk.as_mut_ptr().cast(), 0, 0.0, 0.0, 0.0),
            TdStatus::TdErrNotInit
        );
        assert_eq!(region(w, 0), r, "an error changes nothing");
        // The cutting figures: zero before a step; null and misaligned outputs.
        let mut c = TdCutting {
            work: 9.0,
            ..TdCutting::default()
        };
        assert_eq!(td_world_cutting(w, &mut c), TdStatus::TdOk);
        assert_eq!(c, TdCutting::default());
        assert_eq!(td_world_cutting(w, ptr::null_mut()), TdStatus::TdErrNull);
        let mut raw = [0u8; 40];
        let odd = raw.as_mut_ptr().add(1).cast::<TdCutting>();
        assert_eq!(td_world_cutting(w, odd), TdStatus::TdErrAlign);
        assert_eq!(
            td_world_cutting(ptr::null_mut(), &mut c),
            TdStatus::TdErrNull
        );
        // The spin: a servo's, finite.
        let mut s: *mut TdServo = ptr::null_mut();
        assert_eq!(td_world_servo(w, &mut s), TdStatus::TdOk);
        let v = |x: f32| TdVec3 { x, y: 0.0, z: 0.0 };
        assert_eq!(td_servo_set_spin(s, v(-2.0)), TdStatus::TdOk);
        assert_eq!(td_servo_set_spin(s, v(0.0)), TdStatus::TdOk);
        assert_eq!(td_servo_set_spin(s, v(f32::NAN)), TdStatus::TdErrInput);
        assert_eq!(
            td_servo_set_spin(ptr::null_mut(), v(1.0)),
            TdStatus::TdErrNull
        );
        assert_eq!(
            td_servo_set_spin(junk.as_mut_ptr().cast(), v(1.0)),
            TdStatus::TdErrNotInit
        );
        // After the first step the feel is refused, as a material is.
        let mut f = TdVec3::default();
        assert_eq!(td_world_tick(w, v(5.0), 1, &mut f), TdStatus::TdOk);
        assert_eq!(
            td_world_set_region_feel(w, 0, 0.0, 0.0, 0.0),
            TdStatus::TdErrStarted
        );
        assert_eq!(region(w, 0), r);
        // A vibration above the servo's Nyquist frequency, or not a number: refused.
        let (mut size, mut align) = (0usize, 0usize);
        for hz in [-1.0, 500.5, f32::NAN] {
            let q = TdParams {
                vibration_hz: hz,
                ..p
            };
            assert_eq!(
                td_world_size(&q, &mut size, &mut align),
                TdStatus::TdErrParams,
                "{hz}"
            );
        }
        let q = TdParams {
            vibration_hz: 500.0,
            ..p
        };
        assert_eq!(td_world_size(&q, &mut size, &mut align), TdStatus::TdOk);
    }
}
