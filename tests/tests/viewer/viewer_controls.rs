//! The viewer's controls reaching the real-time tasks: the servo takes the published camera and
//! the stiffness control each tick (a held simulated device records the commands), the controls
//! reach the simulation, and reset ends the simulation task for a rebuild.

use std::sync::atomic::Ordering;

use tetradrill::engine::TickParams;
use tetradrill::rt::RtConfig;
use tetradrill::setup::Setup;
use tetradrill::tasks::{
    camera_handoff, servo_task, simulation_task, BurrLaw, DeviceFrame, Shared, SimEnd, SimStatus,
    ToolSample,
};
use tetradrill::viewer::handoff::{controls, Controls};
use tetradrill::viewer::publish::SimViewer;
use tetradrill_core::script::DRILL_ON;
use tetradrill_core::servo::ContactState;
use tetradrill_core::Vec3;
use tetradrill_device::{DeviceError, DeviceSpec, DeviceState, ForceCommand, HapticDevice};
use tetradrill_tests::viewer::{f64s, storage, MESH_UNITS};

/// A device held still at one position that records the forces written to it.
struct HeldDevice {
    position: [f64; 3],
    forces: Vec<[f64; 3]>,
}

impl HapticDevice for HeldDevice {
    fn spec(&self) -> DeviceSpec {
        DeviceSpec::SIM
    }
    fn read(&mut self) -> Result<DeviceState, DeviceError> {
        Ok(DeviceState {
            position: self.position,
            buttons: 0,
            ..DeviceState::ZERO
        })
    }
    fn write(&mut self, command: &ForceCommand) -> Result<(), DeviceError> {
        if command.enable {
            self.forces.push(command.force);
        }
        Ok(())
    }
    fn calibrate(&mut self) -> Result<(), DeviceError> {
        Ok(())
    }
}

#[test]
fn the_servo_takes_the_published_camera_and_the_stiffness_control_each_tick() {
    let params = TickParams::of(&Setup::default()).expect("params");
    let plane = ContactState {
        valid: true,
        point: Vec3::new(0.0, 0.0, 0.5),
        normal: Vec3::Z,
        depth: 0.0,
        centre: Vec3::ZERO,
        triangles: 1,
        stiffness: 0.0,
        vibration: tetradrill_core::servo::VibrationCue::default(),
        friction: 0.0,
    };
    // The burr sits a little into the top face, well under the force clamp.
    let depth = 0.2 * params.force.max_force / params.force.stiffness;
    assert!(depth < params.radius);
    let scene = Vec3::new(0.1, -0.2, 0.5 + params.radius - depth);
    let pivot = Vec3::new(0.0, 0.0, 0.25);
    // A camera turned about the scene's x axis: the device holds the burr where that turn
    // takes it to `scene`.
    let q = glam::Quat::from_rotation_x(1.1);
    let device_at = pivot + q.inverse() * (scene - pivot);
    let run = |camera: Option<[f32; 16]>, stiffness: Option<f32>| {
        let shared = Shared::new();
        if let Some(k) = stiffness {
            shared
                .counters
                .stiffness_bits
                .store(k.to_bits(), Ordering::Relaxed);
        }
        let (mut contact_in, mut contact_out) =
            triple_buffer::TripleBuffer::new(&ContactState::default()).split();
        contact_in.write(plane);
        let (mut cam_in, mut cam_out) = camera_handoff();
        if let Some(c) = camera {
            cam_in.write(c);
        }
        let mut dev = HeldDevice {
            position: f64s(device_at),
            forces: Vec::new(),
        };
        let mut law = BurrLaw::new(params, &mut contact_out, &shared.counters);
        let res = servo_task(
            &mut dev,
            RtConfig {
                fifo_priority: None,
                core: None,
                lock_memory: false,
            },
            20,
            MESH_UNITS,
            &mut law,
            &shared.ring,
            &shared.counters,
            &shared.stop,
            &tetradrill::watchdog::StopRequest::new(),
            None,
            DeviceFrame::new(pivot),
            Some(&mut cam_out),
            Default::default(),
        );
        assert_eq!(res.ticks, 20);
        let mut last = None;
        while let Some(s) = shared.ring.pop() {
            last = Some(s.position);
        }
        let f = dev.forces.last().copied().expect("forces written");
        (
            last.expect("samples"),
            Vec3::new(f[0] as f32, f[1] as f32, f[2] as f32),
            shared.counters.force(),
        )
    };
    let turn = glam::Mat4::from_quat(q).to_cols_array();
    let (at, f_dev, f_scene) = run(Some(turn), None);
    assert!(
        (at - scene).length() < 1e-5,
        "the burr at {at}, not {scene}"
    );
    let want = Vec3::Z * params.force.stiffness * depth;
    assert!(
        (f_scene - want).length() < 1e-3 * want.length(),
        "{f_scene} vs {want}"
    );
    assert!((f_dev - q.inverse() * f_scene).length() < 1e-4, "{f_dev}");
    // Double the stiffness through the control's atomic: the force doubles.
    let (_, f_dev2, _) = run(Some(turn), Some(2.0 * params.force.stiffness));
    assert!(
        (f_dev2 - 2.0 * f_dev).length() < 1e-3 * f_dev.length(),
        "{f_dev2} vs {f_dev}"
    );
    // With no camera published, the device is in the scene frame: the same hand position
    // is elsewhere in the scene.
    let (at, _, _) = run(None, None);
    assert!((at - device_at).length() < 1e-6);
}

#[test]
fn the_controls_reach_the_simulation() {
    let (mut store, sc) = storage("builtin:block:8");
    let mut params = TickParams::of(&sc).expect("params");
    // The step finishes its work (the comparisons below are of whole erosions, not of how
    // much of them one budget buys).
    params.drill.budget = u32::MAX;
    let initial = Controls {
        radius: params.radius,
        stiffness: params.force.stiffness,
        max_depth: params.drill.max_depth,
        paused: false,
        reset: 0,
    };
    // One simulation step over a short plunge into the top face, with `c` set.
    let mut step = |c: Controls| {
        let mut world = store.world().expect("world");
        let shared = Shared::new();
        for i in 0..40 {
            let z = 0.5 + params.radius - 0.01 * i as f32;
            shared
                .ring
                .push(ToolSample {
                    tick: i,
                    position: Vec3::new(0.0, 0.0, z),
                    buttons: DRILL_ON,
                    ..ToolSample::default()
                })
                .expect("room");
        }
        let (mut cin, cout) = controls(initial);
        cin.write(c);
        let mut link = SimViewer::new(&shared.snapshots, Some(cout), world.mesh().tet_count());
        let (mut contact_in, _contact_out) =
            triple_buffer::TripleBuffer::new(&ContactState::default()).split();
        let (mut status_in, _status_out) =
            triple_buffer::TripleBuffer::new(&SimStatus::default()).split();
        shared.stop.store(true, Ordering::Relaxed);
        let end = simulation_task(
            &mut world,
            params,
            &shared.ring,
            &mut contact_in,
            &mut status_in,
            &shared.stop,
            &shared.counters,
            Some(&mut link),
            None,
        );
        assert_eq!(end, SimEnd::Stopped);
        let bits = |a: &std::sync::atomic::AtomicU32| f32::from_bits(a.load(Ordering::Relaxed));
        (
            world.hierarchy().removed_volume(),
            bits(&shared.counters.radius_bits),
            bits(&shared.counters.stiffness_bits),
        )
    };
    let (base, r, k) = step(initial);
    assert!(base > 0.0);
    assert_eq!((r, k), (initial.radius, initial.stiffness));
    let (paused, _, _) = step(Controls {
        paused: true,
        ..initial
    });
    assert_eq!(paused, 0.0, "pause removes nothing");
    let (wide, r, k) = step(Controls {
        radius: 2.0 * initial.radius,
        stiffness: 0.5 * initial.stiffness,
        ..initial
    });
    assert!(wide > 2.0 * base, "a burr twice as wide: {wide} vs {base}");
    assert_eq!((r, k), (2.0 * initial.radius, 0.5 * initial.stiffness));
    let (shallow, _, _) = step(Controls {
        max_depth: 0,
        ..initial
    });
    assert!(
        shallow != base,
        "max depth 0 drills whole coarse tets: {shallow} vs {base}"
    );
}

#[test]
fn reset_ends_the_simulation_task_for_a_rebuild() {
    let (mut store, sc) = storage("builtin:block:8");
    let params = TickParams::of(&sc).expect("params");
    let initial = Controls {
        radius: params.radius,
        stiffness: params.force.stiffness,
        max_depth: params.drill.max_depth,
        paused: false,
        reset: 0,
    };
    let mut world = store.world().expect("world");
    let shared = Shared::new();
    let (mut cin, cout) = controls(initial);
    let mut link = SimViewer::new(&shared.snapshots, Some(cout), world.mesh().tet_count());
    let (mut contact_in, _contact_out) =
        triple_buffer::TripleBuffer::new(&ContactState::default()).split();
    let (mut status_in, _status_out) =
        triple_buffer::TripleBuffer::new(&SimStatus::default()).split();
    let end = std::thread::scope(|s| {
        let task = s.spawn(|| {
            simulation_task(
                &mut world,
                params,
                &shared.ring,
                &mut contact_in,
                &mut status_in,
                &shared.stop,
                &shared.counters,
                Some(&mut link),
                None,
            )
        });
        // Once the task took the first controls (it stores the radius for the servo), press
        // reset.
        while shared.counters.radius_bits.load(Ordering::Relaxed) == 0 {
            std::thread::yield_now();
        }
        cin.write(Controls {
            reset: 1,
            ..initial
        });
        // No answer in 10 s: stop it, and the assertion below fails.
        for _ in 0..10_000 {
            if task.is_finished() {
                break;
            }
            std::thread::sleep(std::time::Duration::from_millis(1));
        }
        shared.stop.store(true, Ordering::Relaxed);
        task.join().expect("simulation task")
    });
    assert_eq!(end, SimEnd::Reset);
}
