//! The viewer's smooth shading: the scene a live link builds while the demo drills the block
//! carries a unit normal at every corner, corners of one face differ where the surface bends,
//! and once the link has caught up its normals are those a scene built from scratch has.

use std::collections::HashMap;

use tetradrill::engine::{self, TickParams};
use tetradrill::tasks::SimStatus;
use tetradrill::traces::PoseSource;
use tetradrill::viewer::handoff::{SnapshotQueue, ToolView};
use tetradrill::viewer::publish::{scene_of, SimViewer};
use tetradrill::viewer::scene::{Scene, VERTEX_FLOATS};
use tetradrill::viewer::smooth_live::SmoothStore;
use tetradrill_core::force::ToolState;
use tetradrill_tests::viewer::storage;

/// Each drawn triangle of `scene`: its corners' positions, normals and flag.
fn drawn(scene: &Scene) -> Vec<[[f32; 7]; 3]> {
    scene
        .data()
        .chunks_exact(3 * VERTEX_FLOATS)
        .filter(|t| t.iter().any(|x| *x != 0.0))
        .map(|t| {
            let mut v = [[0.0f32; 7]; 3];
            for (k, c) in v.iter_mut().enumerate() {
                c.copy_from_slice(&t[k * VERTEX_FLOATS..k * VERTEX_FLOATS + 7]);
            }
            v
        })
        .collect()
}

fn flat(t: &[[f32; 7]; 3]) -> [f64; 3] {
    let p = t.map(|c| [c[0] as f64, c[1] as f64, c[2] as f64]);
    let (u, v) = (
        [p[1][0] - p[0][0], p[1][1] - p[0][1], p[1][2] - p[0][2]],
        [p[2][0] - p[0][0], p[2][1] - p[0][1], p[2][2] - p[0][2]],
    );
    let n = [
        u[1] * v[2] - u[2] * v[1],
        u[2] * v[0] - u[0] * v[2],
        u[0] * v[1] - u[1] * v[0],
    ];
    let l = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
    n.map(|x| x / l)
}

#[test]
fn the_live_scene_has_a_smooth_unit_normal_at_every_corner() {
    let (mut store, sc) = storage("builtin:block:8");
    let params = TickParams::of(&sc).expect("params");
    let mut world = store.world().expect("world");
    let queue = SnapshotQueue::with_capacity(4);
    let mut smooth = SmoothStore::for_world(&world);
    let mut link = SimViewer::new(&queue, None, world.mesh().tet_count());
    link.set_smooth_store(&mut smooth);
    let poses = PoseSource::new(&tetradrill::setup::Poses::Demo, None).expect("demo path");
    let mut tool = ToolState::default();
    let mut scene = Scene::new();
    for i in 0..2000u64 {
        let pose = poses.at(i);
        let (_, rep) = engine::tick(&mut world, &mut tool, &params, &pose);
        link.note_step(&world, rep.drill.created + rep.drill.erased > 0);
        link.publish(
            &world,
            ToolView::default(),
            &SimStatus::default(),
            i * 20_000_000,
        );
        while let Some(s) = queue.take() {
            scene.apply(s);
        }
    }
    assert!(world.hierarchy().removed_volume() > 0.0);
    // The link catches up a bounded step a snapshot.
    for k in 0..1000u64 {
        assert!(link.publish_now(&world, ToolView::default(), &SimStatus::default(), k));
        scene.apply(queue.take().expect("published"));
        if scene.status.smooth_pending == 0 {
            break;
        }
    }
    assert_eq!(scene.status.smooth_pending, 0, "caught up");
    assert_eq!(scene.status.smooth_saturations, 0, "nothing went short");
    let live = drawn(&scene);
    assert_eq!(live.len(), world.hierarchy().visible_face_count() as usize);
    let (mut bent, mut drilled) = (0usize, 0usize);
    for t in &live {
        for c in t {
            let len = (c[3] * c[3] + c[4] * c[4] + c[5] * c[5]).sqrt();
            assert!((len - 1.0).abs() < 1e-4, "a unit normal at {c:?}");
        }
        if t[0][6] % 2.0 == 1.0 {
            drilled += 1;
            let f = flat(t);
            let off = t
                .iter()
                .filter(|c| {
                    let d = c[3] as f64 * f[0] + c[4] as f64 * f[1] + c[5] as f64 * f[2];
                    d < 0.999
                })
                .count();
            let differ = t[0][3..6] != t[1][3..6] || t[0][3..6] != t[2][3..6];
            if off > 0 && differ {
                bent += 1;
            }
        }
    }
    assert!(drilled > 100, "{drilled} drilled triangles");
    assert!(
        bent * 2 > drilled,
        "most drilled faces shaded per corner: {bent} of {drilled}"
    );
    // What a scene built from scratch shows, face by face (corners as positions).
    let fresh = drawn(&scene_of(&world, None, SimStatus::default()));
    let key = |t: &[[f32; 7]; 3]| t.map(|c| [c[0], c[1], c[2]].map(f32::to_bits));
    let of: HashMap<_, _> = fresh.iter().map(|t| (key(t), *t)).collect();
    assert_eq!(of.len(), live.len());
    for t in &live {
        let f = of.get(&key(t)).expect("the same face from scratch");
        for k in 0..3 {
            for c in 3..6 {
                assert!(
                    (t[k][c] - f[k][c]).abs() < 1e-5,
                    "corner {k} of {t:?} against {f:?}"
                );
            }
        }
    }
}
