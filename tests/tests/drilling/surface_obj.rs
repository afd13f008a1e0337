//! `tetradrill replay --surface OUT.obj` on the firmware's tooth, read back from the file
//! alone: shared vertices (`v`), unit normals (`vn`), faces `f a//na b//nb c//nc`, the drilled
//! faces in group `drilled` and the rest in `boundary`; the same triangles, as position
//! triples, as the host's flat listing of the visible faces after the same replay; and over
//! the `drilled` group the mean angle between neighbouring vertices' normals (each vertex's
//! the unit mean of its drilled corners' normals, over every edge) below 10 degrees, with few
//! corners left with their facet's own normal.

use std::collections::{HashMap, HashSet};
use std::process::Command;

use tetradrill::engine::{self, EngineStorage, TickParams};
use tetradrill::scenario;
use tetradrill::traces::PoseSource;
use tetradrill::Surface;
use tetradrill_core::force::ToolState;
use tetradrill_core::hierarchy::DEBRIS_LEAVES;
use tetradrill_tests::{scratch_dir, tetradrill_bin};

type V3 = [f64; 3];

fn sub(a: V3, b: V3) -> V3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
fn dot(a: V3, b: V3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
fn cross(a: V3, b: V3) -> V3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
fn unit(a: V3) -> V3 {
    let l = dot(a, a).sqrt();
    [a[0] / l, a[1] / l, a[2] / l]
}

/// An OBJ as read: positions (as written, `f32`), normals, and faces of each group as
/// (position index, normal index) triples, 0-based.
#[derive(Default)]
struct Obj {
    v: Vec<[f32; 3]>,
    vn: Vec<V3>,
    groups: HashMap<String, Vec<[(usize, usize); 3]>>,
}

fn read_obj(text: &str) -> Obj {
    let mut o = Obj::default();
    let mut group = String::new();
    let three = |rest: &[&str]| -> [f64; 3] {
        assert_eq!(rest.len(), 3, "three coordinates: {rest:?}");
        [0, 1, 2].map(|k| rest[k].parse::<f64>().expect("a number"))
    };
    for line in text.lines() {
        let t: Vec<&str> = line.split_whitespace().collect();
        match t.first().copied() {
            Some("v") => {
                o.v.push([0, 1, 2].map(|k| t[1 + k].parse::<f32>().expect("a coordinate")))
            }
            Some("vn") => o.vn.push(three(&t[1..])),
            Some("g") => group = t[1].to_string(),
            Some("f") => {
                assert_eq!(t.len(), 4, "a triangle: {line}");
                let c = [1, 2, 3].map(|k| {
                    let (a, n) = t[k].split_once("//").expect("f a//na b//nb c//nc");
                    let (a, n): (usize, usize) = (a.parse().unwrap(), n.parse().unwrap());
                    assert!(a >= 1 && n >= 1, "1-based: {line}");
                    (a - 1, n - 1)
                });
                o.groups.entry(group.clone()).or_default().push(c);
            }
            Some("#") | None => {}
            Some(other) => panic!("unexpected OBJ line kind {other:?}"),
        }
    }
    o
}

/// A triangle as position bits, rotated to start at its least corner (orientation kept).
fn tri_key(c: [[f32; 3]; 3]) -> [[u32; 3]; 3] {
    let b = c.map(|p| p.map(f32::to_bits));
    let i = (0..3).min_by_key(|&i| b[i]).unwrap();
    [b[i], b[(i + 1) % 3], b[(i + 2) % 3]]
}

/// The host's replay of the tooth (as `replay` runs it, its debris erased at the end) and
/// its visible faces as flat triangles.
fn flat_triangles() -> Vec<[[u32; 3]; 3]> {
    let sc = scenario::builtin("firmware-tooth")
        .expect("tooth")
        .setup()
        .expect("set-up");
    let loaded = engine::load_mesh(&sc).expect("mesh");
    let params = TickParams::of(&sc).expect("params");
    let poses = PoseSource::new(&sc.poses, Some(&loaded.mesh)).expect("poses");
    let mut store = EngineStorage::new(loaded.mesh, &sc).expect("storage");
    store.set_labels(&loaded.labels, &sc).expect("labels");
    let mut world = store.world().expect("world");
    let mut tool = ToolState::default();
    for i in 0..poses.ticks() {
        engine::tick(&mut world, &mut tool, &params, &poses.at(i));
    }
    let mut scratch = vec![0u32; world.hierarchy().debris_scratch_needed()];
    world
        .remove_debris(DEBRIS_LEAVES, sc.drilling.max_depth, &mut scratch)
        .expect("debris");
    let s = Surface::of(&world, &[]);
    let mut v: Vec<_> = s
        .corners
        .iter()
        .map(|c| tri_key(c.map(|p| p.to_array())))
        .collect();
    v.sort_unstable();
    v
}

#[test]
fn replay_surface_writes_shared_vertices_smooth_normals_and_a_drilled_group() {
    let dir = scratch_dir("surfaceobj", "tooth");
    let obj = dir.join("tooth.obj");
    let out = Command::new(tetradrill_bin())
        .args(["replay", "--scenario", "builtin:firmware-tooth", "--quiet"])
        .arg("--surface")
        .arg(&obj)
        .output()
        .expect("run tetradrill");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let o = read_obj(&std::fs::read_to_string(&obj).expect("read the OBJ"));
    let mut names: Vec<&String> = o.groups.keys().collect();
    names.sort();
    assert_eq!(names, ["boundary", "drilled"]);
    for n in &o.vn {
        assert!((dot(*n, *n).sqrt() - 1.0).abs() < 1e-5, "not unit: {n:?}");
    }
    // Shared: no two vertices at the same place, and far fewer vertices than corners.
    let all: Vec<[(usize, usize); 3]> = o.groups.values().flatten().copied().collect();
    let distinct: HashSet<[u32; 3]> = o.v.iter().map(|p| p.map(f32::to_bits)).collect();
    assert_eq!(distinct.len(), o.v.len(), "a position written twice");
    assert!(2 * o.v.len() < 3 * all.len(), "{} vertices", o.v.len());
    for c in all.iter().flatten() {
        assert!(c.0 < o.v.len() && c.1 < o.vn.len(), "an index past the end");
    }
    // The same triangles as the flat listing.
    let mut got: Vec<_> = all
        .iter()
        .map(|f| tri_key(f.map(|(a, _)| o.v[a])))
        .collect();
    got.sort_unstable();
    assert_eq!(got.len(), flat_triangles().len());
    assert!(
        got == flat_triangles(),
        "the triangles differ from the flat export"
    );

    // The done-when measure over the drilled group.
    let drilled = &o.groups["drilled"];
    assert!(drilled.len() > 1000, "{} drilled faces", drilled.len());
    let pos = |a: usize| o.v[a].map(f64::from);
    let (mut acc, mut flat, mut corners) = (HashMap::<usize, V3>::new(), 0usize, 0usize);
    for f in drilled {
        let [a, b, c] = f.map(|(v, _)| pos(v));
        let own = unit(cross(sub(b, a), sub(c, a)));
        for &(v, n) in f {
            let s = acc.entry(v).or_insert([0.0; 3]);
            for (a, b) in s.iter_mut().zip(o.vn[n]) {
                *a += b;
            }
            corners += 1;
            let d = sub(o.vn[n], own);
            if dot(d, d) < 1e-8 {
                flat += 1;
            }
        }
    }
    let vn: HashMap<usize, V3> = acc.into_iter().map(|(v, s)| (v, unit(s))).collect();
    let mut edges = HashSet::new();
    for f in drilled {
        for k in 0..3 {
            let (a, b) = (f[k].0, f[(k + 1) % 3].0);
            edges.insert((a.min(b), a.max(b)));
        }
    }
    let mean = edges
        .iter()
        .map(|&(a, b)| dot(vn[&a], vn[&b]).clamp(-1.0, 1.0).acos().to_degrees())
        .sum::<f64>()
        / edges.len() as f64;
    let flat_share = flat as f64 / corners as f64;
    println!(
        "tooth: {} drilled faces, {} edges, mean neighbour angle {mean:.2} degrees, {:.2} % \
         flat corners",
        drilled.len(),
        edges.len(),
        100.0 * flat_share
    );
    assert!(mean < 10.0, "mean angle {mean} degrees");
    assert!(flat_share < 0.02, "{flat} of {corners} corners flat");
}
