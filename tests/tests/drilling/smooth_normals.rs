//! Smooth normals of the surface export over the demo's drilling run, against an f64
//! brute-force recomputation from the full visible face list after every third frame and the
//! last (the export updated and validated after every frame): vertices
//! shared by their positions' bits (not the exporter's lattice keys), face normals from the
//! corners in f64, drilled faces told from the mesh's boundary by the planes of the coarse
//! tets' boundary faces, then the documented rule: the three-ring average over drilled faces,
//! the two-ring average within the crease angle over boundary faces. Every corner normal is
//! unit length, and a boundary face's within the crease angle of its face's normal.

use std::collections::HashMap;

use tetradrill::engine::{self, EngineStorage, TickParams};
use tetradrill::scenario;
use tetradrill::traces::PoseSource;
use tetradrill_core::force::ToolState;
use tetradrill_core::hierarchy::{
    Hierarchy, SlotRange, SmoothNormals, SmoothSizes, SmoothStorage, SurfaceBuffers, SurfaceExport,
    SurfaceSizes, SurfaceStorage,
};
use tetradrill_core::mesh::Mesh;
use tetradrill_core::storage::{Block, Line};
use tetradrill_core::TetId;

const TICKS_A_FRAME: u64 = 17;
/// Frames between two brute-force comparisons (the recomputation is most of the test's time).
const FRAMES_A_COMPARISON: u64 = 3;
const BUDGET: u32 = 1 << 16;
const SLOTS: usize = 1 << 17;
const VERTS: usize = 1 << 17;
/// Agreement of a corner normal with the f64 recomputation (the exporter sums in f32 from
/// face normals rounded to 2^-20): 1e-4 is about 0.006 degrees.
const TOL: f64 = 1e-4;
/// The documented length below which a vertex's summed face normals cancel.
const CANCELLED: f64 = 1.0 / 256.0;

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
    if l == 0.0 {
        return [0.0; 3];
    }
    [a[0] / l, a[1] / l, a[2] / l]
}
fn add(a: V3, b: V3) -> V3 {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

type Bits = [u32; 3];

fn bits(p: [f32; 3]) -> Bits {
    p.map(f32::to_bits)
}

/// A face's three corner normals, each with whether it is near a decision, and whether the
/// face is drilled.
type Expected = ([(V3, bool); 3], bool);

/// `s`'s unit vector, zero when shorter than `CANCELLED`, and whether its length is near
/// that.
fn unit_cut(s: V3) -> (V3, bool) {
    let len = dot(s, s).sqrt();
    let near = (len - CANCELLED).abs() < 1e-4;
    (if len < CANCELLED { [0.0; 3] } else { unit(s) }, near)
}

/// `true` when visible face `corners` of coarse tet `t` lies on a boundary face of the coarse
/// mesh: on the plane of one of `t`'s boundary faces (face `j` opposite node `j`).
fn on_boundary(mesh: &Mesh<'_>, t: TetId, corners: &[V3; 3]) -> bool {
    let nodes = mesh.get_tet_nodes(t).expect("tet");
    let p = nodes.map(|n| mesh.position(n).to_array().map(f64::from));
    let size = (0..4)
        .flat_map(|a| (0..4).map(move |b| (a, b)))
        .map(|(a, b)| dot(sub(p[a], p[b]), sub(p[a], p[b])).sqrt())
        .fold(0.0, f64::max);
    (0..4u8).any(|j| {
        let [a, b, c]: [V3; 3] = [1, 2, 3].map(|k| p[(usize::from(j) + k) % 4]);
        let n = unit(cross(sub(b, a), sub(c, a)));
        mesh.is_boundary_face(t, j)
            && corners
                .iter()
                .all(|&q| dot(sub(q, a), n).abs() < 1e-5 * size)
    })
}

/// The f64 recomputation: for every face (by its corners' bits) the three corner normals,
/// and whether each is near a decision (then not compared); and whether it is drilled.
fn brute(h: &Hierarchy<'_>, mesh: &Mesh<'_>, cos: f64) -> HashMap<[Bits; 3], Expected> {
    let mut faces: Vec<[Bits; 3]> = Vec::new();
    let mut drilled: Vec<bool> = Vec::new();
    let pos = |b: Bits| b.map(|x| f64::from(f32::from_bits(x)));
    h.for_each_visible(mesh, |t| {
        let f = t.corners.map(|c| bits(c.to_array()));
        drilled.push(!on_boundary(mesh, t.tet, &f.map(pos)));
        faces.push(f);
    });
    let normal: Vec<V3> = faces
        .iter()
        .map(|f| {
            let [a, b, c] = f.map(pos);
            unit(cross(sub(b, a), sub(c, a)))
        })
        .collect();
    let mut at: HashMap<Bits, Vec<usize>> = HashMap::new();
    for (i, f) in faces.iter().enumerate() {
        for &v in f {
            at.entry(v).or_default().push(i);
        }
    }
    // N: per kind (0 boundary, 1 drilled), the unit sum of the normals of the vertex's
    // faces of that kind, zero when they cancel.
    let vn: [HashMap<Bits, (V3, bool)>; 2] = [false, true].map(|kind| {
        at.iter()
            .map(|(&v, fs)| {
                let s = fs
                    .iter()
                    .filter(|&&f| drilled[f] == kind)
                    .fold([0.0; 3], |s, &f| add(s, normal[f]));
                (v, unit_cut(s))
            })
            .collect()
    });
    // M: the unit sum over the vertex's drilled faces of N at their corners.
    let m: HashMap<Bits, (V3, bool)> = at
        .iter()
        .map(|(&v, fs)| {
            let (mut s, mut near) = ([0.0; 3], false);
            for &f in fs.iter().filter(|&&f| drilled[f]) {
                for w in faces[f] {
                    let (n, n_near) = vn[1][&w];
                    s = add(s, n);
                    near |= n_near;
                }
            }
            let (u, u_near) = unit_cut(s);
            (v, (u, near || u_near))
        })
        .collect();
    let mut out = HashMap::new();
    for (g, f) in faces.iter().enumerate() {
        let own = normal[g];
        let corner = |u: Bits| {
            let (mut s, mut near) = ([0.0; 3], false);
            for &f2 in &at[&u] {
                if drilled[f2] != drilled[g] {
                    continue;
                }
                if drilled[g] {
                    for w in faces[f2] {
                        let (n, n_near) = m[&w];
                        s = add(s, n);
                        near |= n_near;
                    }
                    continue;
                }
                let d = dot(normal[f2], own);
                near |= (d - cos).abs() < 1e-3;
                if d >= cos {
                    for w in faces[f2] {
                        let (n, n_near) = vn[0][&w];
                        s = add(s, n);
                        near |= n_near;
                    }
                }
            }
            let (mm, m_near) = unit_cut(s);
            near |= m_near;
            if !drilled[g] {
                near |= (dot(mm, own) - cos).abs() < 1e-3;
            }
            if mm == [0.0; 3] || (!drilled[g] && dot(mm, own) < cos) {
                (own, near)
            } else {
                (mm, near)
            }
        };
        out.insert(*f, (f.map(corner), drilled[g]));
    }
    out
}

#[test]
fn smooth_normals_equal_an_f64_recomputation_as_the_demo_drills() {
    let sc = scenario::builtin("demo")
        .expect("demo")
        .setup()
        .expect("set-up");
    let loaded = engine::load_mesh(&sc).expect("mesh");
    let params = TickParams::of(&sc).expect("params");
    let poses = PoseSource::new(&sc.poses, Some(&loaded.mesh)).expect("poses");
    let mut store = EngineStorage::new(loaded.mesh, &sc).expect("storage");
    let mut world = store.world().expect("world");
    let tets = world.mesh().tet_count();
    let sizes = SurfaceSizes::new(SLOTS, tets);
    let mut lines = vec![Line::ZERO; sizes.lines().expect("sizes")];
    let storage = SurfaceStorage::carve(&sizes, &mut Block::from_lines(&mut lines)).unwrap();
    let ssizes = SmoothSizes::new(SLOTS, VERTS, 4096);
    let mut slines = vec![Line::ZERO; ssizes.lines().expect("sizes")];
    let sst = SmoothStorage::carve(&ssizes, &mut Block::from_lines(&mut slines)).unwrap();
    let smooth = SmoothNormals::new(sst, SmoothNormals::CREASE_DEGREES).expect("smooth storage");
    let mut ex = SurfaceExport::new(storage, world.hierarchy())
        .expect("exporter")
        .with_smooth(smooth)
        .expect("smooth");
    let cos = f64::from(SmoothNormals::CREASE_DEGREES).to_radians().cos();
    let n = 3 * SLOTS;
    let (mut p, mut nr, mut l, mut ix) = (
        vec![[0.0f32; 3]; n],
        vec![[0.0f32; 3]; n],
        vec![0; n],
        vec![0u32; n],
    );
    let mut ranges = vec![SlotRange::default(); 64];
    let mut tool = ToolState::default();
    let (mut frames, mut compared, mut skipped, mut smoothed) = (0, 0u64, 0u64, 0u64);
    for i in 0..poses.ticks() {
        engine::tick(&mut world, &mut tool, &params, &poses.at(i));
        if (i + 1) % TICKS_A_FRAME != 0 && i + 1 != poses.ticks() {
            continue;
        }
        let (h, mesh) = (world.hierarchy(), world.mesh());
        let mut out = SurfaceBuffers {
            positions: &mut p,
            normals: &mut nr,
            labels: &mut l,
            indices: &mut ix,
            ranges: &mut ranges,
        };
        let mut calls = 0;
        while ex
            .update(h, mesh, |_| 1, BUDGET, &mut out)
            .expect("update")
            .pending
            > 0
        {
            calls += 1;
            assert!(calls < 1000, "never up to date at frame {frames}");
        }
        let stats = ex.smooth().expect("smooth").stats();
        assert_eq!((stats.vertices_full, stats.queue_full), (0, 0), "{stats:?}");
        ex.smooth().expect("smooth").validate().expect("valid");
        frames += 1;
        if frames % FRAMES_A_COMPARISON != 0 && i + 1 != poses.ticks() {
            continue;
        }
        let want = brute(h, mesh, cos);
        let mut live = 0;
        for s in 0..SLOTS {
            if ix[3 * s..3 * s + 3] == [0, 0, 0] {
                continue;
            }
            live += 1;
            let key = [p[3 * s], p[3 * s + 1], p[3 * s + 2]].map(bits);
            let (expect, drilled) = want.get(&key).expect("a live slot is a visible face");
            let sm = ex.smooth().expect("smooth");
            assert_eq!(
                sm.slot_drilled(s as u32),
                *drilled,
                "slot {s}: drilled or not"
            );
            let [a, b, c] = key.map(|b| b.map(|x| f64::from(f32::from_bits(x))));
            let own = unit(cross(sub(b, a), sub(c, a)));
            for k in 0..3 {
                let got = nr[3 * s + k].map(f64::from);
                assert!(
                    (dot(got, got).sqrt() - 1.0).abs() < 1e-5,
                    "not unit: {got:?}"
                );
                if !drilled {
                    assert!(dot(got, own) >= cos - 1e-5, "beyond the crease angle");
                }
                let (w, near) = expect[k];
                if near {
                    skipped += 1;
                    continue;
                }
                compared += 1;
                if dot(got, own) < 1.0 - 1e-9 {
                    smoothed += 1;
                }
                let d = sub(got, w);
                assert!(
                    dot(d, d).sqrt() < TOL,
                    "frame {frames}, slot {s} corner {k}: {got:?} against {w:?}"
                );
            }
        }
        assert_eq!(live, want.len(), "frame {frames}");
    }
    assert!(world.hierarchy().stats().erased > 1000, "the demo drills");
    assert!(
        smoothed * 2 > compared,
        "{smoothed} of {compared} corners smoothed"
    );
    println!(
        "smooth normals: {frames} frames, {compared} corners compared, {skipped} near a crease \
         decision, {smoothed} smoothed"
    );
}
