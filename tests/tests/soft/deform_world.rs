//! Oracle tests of a world whose mesh moves and deforms every step (`World::set_positions`):
//! refused input; the tet hash against brute force after every step of a deforming sequence;
//! the boundary normals against brute force in f64 at the deformed positions; hierarchy faces
//! of a deformed mesh against the barycentric map of their rest positions (f64); a rigid motion
//! of the nodes and the tool path giving the same forces rotated and the same removed volume;
//! drilling a soft block sagging under gravity against drilling the rigid block.

use std::collections::BTreeSet;

use glam::{Quat, Vec3};
use tetradrill::soft::SoftOwned;
use tetradrill_core::drill::DrillParams;
use tetradrill_core::force::{ForceParams, ToolState};
use tetradrill_core::hash::Aabb;
use tetradrill_core::servo::{servo_force, DeformError, WorldSizes};
use tetradrill_core::soft::{Material, SoftParams};
use tetradrill_core::TetId;
use tetradrill_tests::brute::{boundary_normals, overlaps, tet_boxes};
use tetradrill_tests::drill::{bey, det, face_of};
use tetradrill_tests::oracle::{dot, sub, D3};
use tetradrill_tests::search::{block_mesh, Store};

/// A smooth, non-affine deformation of the unit block at phase `s`: a bend in z growing with
/// x squared and a wave in y along z.
fn bend(p: Vec3, s: f32) -> Vec3 {
    let a = 0.15 * s.sin();
    let x = p.x + 0.5;
    Vec3::new(
        p.x + 0.05 * s.cos() * (3.0 * p.y).sin(),
        p.y + 0.5 * a * (3.0 * p.z).sin(),
        p.z + a * x * x,
    )
}

#[test]
fn refuses_bad_positions_and_a_world_without_rest() {
    let mut om = block_mesh(3);
    let rest0 = om.positions().to_vec();
    let mesh = om.view();
    let mut st = Store::new(mesh.tet_count(), 1 << 12);
    let mut world = st.world(mesh);
    let moved: Vec<Vec3> = rest0.iter().map(|&p| p + Vec3::X).collect();
    assert_eq!(world.set_positions(&moved), Err(DeformError::NoRest));
    let mut short = vec![Vec3::ZERO; rest0.len() - 1];
    assert!(matches!(
        world.enable_deformation(&mut short),
        Err(DeformError::RestTooShort { .. })
    ));
    let mut rest = vec![Vec3::ZERO; rest0.len()];
    world.enable_deformation(&mut rest).unwrap();
    assert_eq!(
        world.set_positions(&moved[1..]),
        Err(DeformError::Count {
            nodes: rest0.len(),
            got: rest0.len() - 1
        })
    );
    let mut bad = moved.clone();
    bad[5].y = f32::NAN;
    assert_eq!(
        world.set_positions(&bad),
        Err(DeformError::NotFinite { node: 5 })
    );
    // Nothing changed by the refusals.
    assert_eq!(world.mesh().positions(), &rest0[..]);
    let rep = world.set_positions(&moved).unwrap();
    assert!((rep.max_displacement - 1.0).abs() < 1e-6);
    assert_eq!(world.mesh().positions(), &moved[..]);
    assert_eq!(world.mesh().rest_positions(), &rest0[..]);
    assert!(DeformError::NotFinite { node: 5 }
        .to_string()
        .contains("node 5"));
}

/// After every step of a bending sequence: the hash finds, for query boxes around the block,
/// exactly the tets whose box (made here) meets the query; the simulation step's candidates
/// are the tets whose box meets its zone; the boundary marks and normals are those found by
/// brute force in f64 at the deformed positions.
#[test]
fn hash_and_normals_follow_a_bending_block() {
    let mut om = block_mesh(5);
    let rest0 = om.positions().to_vec();
    let tets: Vec<[u32; 4]> = om.tets().iter().map(|t| t.nodes.map(|n| n.0)).collect();
    let mesh = om.view();
    let mut st = Store::new(mesh.tet_count(), 1 << 14);
    let mut world = st.world(mesh);
    let mut rest = vec![Vec3::ZERO; rest0.len()];
    world.enable_deformation(&mut rest).unwrap();
    let params = DrillParams {
        max_depth: 2,
        min_area: 0.0,
        budget: 100_000,
    };
    let (mut checked, mut boundary) = (0usize, 0usize);
    for k in 0..24 {
        let s = k as f32 * 0.4;
        let new: Vec<Vec3> = rest0.iter().map(|&p| bend(p, s)).collect();
        let rep = world.set_positions(&new).unwrap();
        assert!(!rep.hash_saturated);
        let own = tet_boxes(world.mesh());
        for q in 0..27 {
            let c = Vec3::new((q % 3) as f32, (q / 3 % 3) as f32, (q / 9) as f32) * 0.45
                - Vec3::splat(0.45)
                + Vec3::new(0.03 * s.sin(), 0.02, 0.05 * s.cos());
            let r = 0.08 + 0.02 * (q % 4) as f32;
            let qb = (c - Vec3::splat(r), c + Vec3::splat(r));
            let brute: BTreeSet<u32> = (0..own.len() as u32)
                .filter(|&t| overlaps(own[t as usize], qb))
                .collect();
            let mut found = BTreeSet::new();
            let whole = world
                .hash()
                .query_box_once(&Aabb::point(c).grown(r), u32::MAX, |item| {
                    if overlaps(own[item as usize], qb) {
                        found.insert(item);
                    }
                });
            assert!(whole);
            assert_eq!(found, brute, "step {k} query {q}");
            // The simulation step's candidates: every tet whose box meets the zone, once.
            let reach = 0.05;
            world.simulate(c, r, reach, false, &params);
            let zone = (c - Vec3::splat(r + reach), c + Vec3::splat(r + reach));
            let want: BTreeSet<u32> = (0..own.len() as u32)
                .filter(|&t| overlaps(own[t as usize], zone))
                .collect();
            let got: Vec<u32> = world.candidates().iter().map(|t| t.0).collect();
            assert_eq!(got.len(), want.len(), "step {k} query {q}: duplicates");
            assert_eq!(got.into_iter().collect::<BTreeSet<_>>(), want);
            checked += brute.len();
        }
        // Normals and boundary marks: brute force in f64 over the deformed positions.
        let want = boundary_normals(&new, &tets);
        for (i, want) in want.iter().enumerate() {
            let got = world.mesh().normals()[i];
            let node = world.mesh().node(tetradrill_core::NodeId::from_idx(i));
            assert_eq!(node.boundary(), want.is_some(), "step {k} node {i}");
            let want = want.unwrap_or([0.0; 3]);
            let err = sub(d3(got), want);
            assert!(
                dot(err, err).sqrt() < 1e-5,
                "step {k} node {i}: {got} vs {want:?}"
            );
            boundary += usize::from(node.boundary());
        }
    }
    assert_eq!(world.saturations().hash, 0);
    assert!(checked > 1000, "{checked} hits checked");
    // The 5^3 block's surface nodes, 6^3 - 4^3, at every step.
    assert_eq!(boundary, 24 * 152, "boundary normals checked");
}

/// Barycentric coordinates of `x` in tet `p` (f64).
fn bary(p: &[D3; 4], x: D3) -> [f64; 4] {
    let d = det(p);
    let b1 = det(&[p[0], x, p[2], p[3]]) / d;
    let b2 = det(&[p[0], p[1], x, p[3]]) / d;
    let b3 = det(&[p[0], p[1], p[2], x]) / d;
    [1.0 - b1 - b2 - b3, b1, b2, b3]
}

fn d3(v: Vec3) -> D3 {
    [v.x as f64, v.y as f64, v.z as f64]
}

/// The corners of node `index` of a tree by the test's own midpoint descent from `root`.
fn descend(root: [D3; 4], index: u32) -> [D3; 4] {
    let mut digits = Vec::new();
    let mut i = index;
    while i > 0 {
        digits.push(((i - 1) % 8) as usize);
        i = (i - 1) / 8;
    }
    let mut p = root;
    for &c in digits.iter().rev() {
        p = bey(&p)[c];
    }
    p
}

/// Drill a block at rest, deform it, and every visible face the hierarchy gives is the
/// barycentric map, through its deformed root tet, of the face's rest corners (f64, here).
#[test]
fn hierarchy_faces_are_the_barycentric_map_of_their_rest_corners() {
    let mut om = block_mesh(4);
    let rest0 = om.positions().to_vec();
    let mesh = om.view();
    let mut st = Store::new(mesh.tet_count(), 1 << 16);
    let mut world = st.world(mesh);
    let mut rest = vec![Vec3::ZERO; rest0.len()];
    world.enable_deformation(&mut rest).unwrap();
    let params = DrillParams {
        max_depth: 3,
        min_area: 0.0,
        budget: 1_000_000,
    };
    for k in 0..30 {
        let c = Vec3::new(-0.3 + 0.02 * k as f32, 0.1, 0.45 - 0.005 * k as f32);
        world.simulate(c, 0.12, 0.05, true, &params);
    }
    while world.pending() > 0 {
        world.simulate(Vec3::splat(9.0), 0.12, 0.0, false, &params);
    }
    let removed = world.hierarchy().removed_volume();
    assert!(removed > 0.0);
    let mut checked = 0;
    for step in 1..4 {
        let s = step as f32 * 0.7;
        let new: Vec<Vec3> = rest0.iter().map(|&p| bend(p, s)).collect();
        world.set_positions(&new).unwrap();
        // Removed volume is the rest state's, whatever the shape.
        assert_eq!(world.hierarchy().removed_volume(), removed);
        let mesh = world.mesh();
        world.hierarchy().for_each_visible(mesh, |vt| {
            let nodes = mesh.tet(vt.tet).nodes;
            let rest_root = nodes.map(|n| d3(rest0[n.idx()]));
            let def_root = nodes.map(|n| d3(new[n.idx()]));
            let leaf = descend(rest_root, vt.index);
            let face = face_of(&leaf, vt.face as usize);
            let want: Vec<D3> = face
                .iter()
                .map(|&x| {
                    let b = bary(&rest_root, x);
                    let mut y = [0.0; 3];
                    for (w, q) in b.iter().zip(def_root.iter()) {
                        for a in 0..3 {
                            y[a] += w * q[a];
                        }
                    }
                    y
                })
                .collect();
            // Each corner the hierarchy gives is one of the mapped corners (a bijection).
            let mut used = [false; 3];
            for c in vt.corners {
                let c = d3(c);
                let dist = |w: &D3| ((0..3).map(|a| (w[a] - c[a]).powi(2)).sum::<f64>()).sqrt();
                let (j, d) = (0..3)
                    .filter(|&j| !used[j])
                    .map(|j| (j, dist(&want[j])))
                    .min_by(|a, b| a.1.total_cmp(&b.1))
                    .unwrap();
                assert!(d < 2e-6, "face {:?}: corner off by {d}", vt.key());
                used[j] = true;
            }
            checked += 1;
        });
    }
    assert!(checked > 300, "{checked} faces checked");
}

/// The replay's tool path in the object frame (160 ticks) and whether the drill is on: down
/// into the top face, across, and up again, off the block's grid (no leaf corner exactly on
/// the burr's sphere, where rounding would decide).
fn path(k: usize) -> (Vec3, bool) {
    let c = if k < 40 {
        Vec3::new(-0.2, 0.05, 0.62 - 0.006 * k as f32)
    } else if k < 120 {
        Vec3::new(-0.2 + 0.005 * (k - 40) as f32, 0.05, 0.38)
    } else {
        Vec3::new(0.2, 0.05, 0.38 + 0.006 * (k - 120) as f32)
    };
    (
        c + Vec3::new(0.0123, 0.0371, 0.0049),
        (30..130).contains(&k),
    )
}

/// One step of a replay: the contact's point, normal and depth, and the servo's force.
#[derive(Clone, Copy, Debug)]
struct Tick {
    valid: bool,
    point: Vec3,
    normal: Vec3,
    depth: f32,
    /// The servo's force (its state carried from tick to tick).
    force: Vec3,
    /// The force of this tick's contact alone (a fresh servo state).
    spring: Vec3,
    /// The drill finished its work within the step.
    settled: bool,
}

/// A plunge-and-pass drilling replay on the unit block of 8 cubes a side, through `motion`
/// (applied to every node and every tool position; `None`: the block as built, never moved).
/// Returns each tick, the removed volume and the erased leaves.
fn replay(motion: Option<&dyn Fn(Vec3) -> Vec3>) -> (Vec<Tick>, f64, BTreeSet<(u32, u32)>) {
    let mut om = block_mesh(8);
    let rest0 = om.positions().to_vec();
    let mesh = om.view();
    let mut st = Store::new(mesh.tet_count(), 1 << 18);
    let mut world = st.world(mesh);
    let mut rest = vec![Vec3::ZERO; rest0.len()];
    // Exact contacts (no node bound reached), so the answers do not depend on the order the
    // trees are walked in.
    world.set_contact_max_nodes(1 << 22);
    let map = |p: Vec3| motion.map_or(p, |m| m(p));
    if motion.is_some() {
        world.enable_deformation(&mut rest).unwrap();
        let moved: Vec<Vec3> = rest0.iter().map(|&p| map(p)).collect();
        world.set_positions(&moved).unwrap();
    }
    let params = DrillParams {
        max_depth: 4,
        min_area: 0.0,
        budget: 1_000_000,
    };
    let fp = ForceParams::default();
    let mut tool = ToolState::default();
    let (radius, reach) = (radius_of_replay(), 0.05);
    let mut ticks = Vec::new();
    for k in 0..160 {
        let (c, on) = path(k);
        let c = map(c);
        world.simulate(c, radius, reach, on, &params);
        let force = servo_force(world.contact(), c, radius, &mut tool, &fp);
        let spring = servo_force(world.contact(), c, radius, &mut ToolState::default(), &fp);
        let ct = world.contact();
        ticks.push(Tick {
            valid: ct.valid,
            point: ct.point,
            normal: ct.normal,
            depth: ct.depth,
            force,
            spring,
            settled: world.pending() == 0,
        });
    }
    assert_eq!(world.pending(), 0);
    assert_eq!(world.saturations().total(), 0, "{:?}", world.saturations());
    let h = world.hierarchy();
    let mut erased = BTreeSet::new();
    for t in 0..world.mesh().tet_count() {
        h.for_each_leaf(TetId::from_idx(t), |l| {
            if l.record.erased() {
                erased.insert((t as u32, l.index));
            }
        });
    }
    (ticks, h.removed_volume(), erased)
}

/// Drilling a soft block sagging under gravity (clamped at its base, small strain) along the
/// replay's path in the object frame (each path point carried by the body's deformation, here)
/// removes within 5 % of the volume the rigid block loses along the same path.
#[test]
fn drilling_a_slightly_deformed_soft_block_removes_the_rigid_volume() {
    let (_, rigid, _) = replay(None);
    let mut om = block_mesh(8);
    let mut soft = SoftOwned::from_mesh(&om.view());
    let rest0 = soft.rest.clone();
    let tets = soft.tets.clone();
    let mut body = soft
        .body(
            &[Material {
                young: 5e5,
                poisson: 0.3,
                density: 1000.0,
            }],
            SoftParams {
                gravity: Vec3::new(0.0, 0.0, -9.81),
                damping: 20.0,
                substeps: 10,
                iterations: 1,
            },
        )
        .unwrap();
    assert!(body.fix_below(Vec3::new(0.0, 0.0, -0.49), Vec3::Z) > 0);
    let dt = 1e-3;
    let none = vec![Vec3::ZERO; rest0.len()];
    for _ in 0..400 {
        body.step(dt, &none).unwrap();
    }
    let mesh = om.view();
    let mut st = Store::new(mesh.tet_count(), 1 << 18);
    let mut world = st.world(mesh);
    world.set_contact_max_nodes(1 << 22);
    let mut rest = vec![Vec3::ZERO; rest0.len()];
    world.enable_deformation(&mut rest).unwrap();
    let params = DrillParams {
        max_depth: 4,
        min_area: 0.0,
        budget: 1_000_000,
    };
    let mut now = vec![Vec3::ZERO; rest0.len()];
    let mut max_disp = 0.0f32;
    for k in 0..160 {
        body.step(dt, &none).unwrap();
        body.write_positions(&mut now);
        max_disp = max_disp.max(world.set_positions(&now).unwrap().max_displacement);
        // The path point carried by the deformation: its rest tet's corners, barycentric (f64).
        let (x, on) = path(k);
        let c = tets
            .iter()
            .find_map(|t| {
                let p = t.map(|n| d3(rest0[n as usize]));
                let b = bary(&p, d3(x));
                b.iter().all(|&w| w >= -1e-12).then(|| {
                    let mut y = [0.0f64; 3];
                    for (w, &n) in b.iter().zip(t) {
                        let q = d3(now[n as usize]);
                        for a in 0..3 {
                            y[a] += w * q[a];
                        }
                    }
                    Vec3::new(y[0] as f32, y[1] as f32, y[2] as f32)
                })
            })
            .unwrap_or(x);
        world.simulate(c, radius_of_replay(), 0.05, on, &params);
    }
    while world.pending() > 0 {
        world.simulate(Vec3::splat(9.0), radius_of_replay(), 0.0, false, &params);
    }
    assert_eq!(world.saturations().total(), 0, "{:?}", world.saturations());
    let soft_v = world.hierarchy().removed_volume();
    let rel = (soft_v - rigid).abs() / rigid;
    eprintln!("soft block: sag {max_disp}, removed {soft_v} vs rigid {rigid} ({rel:e})");
    // Small strain, but a real deformation.
    assert!(max_disp > 2e-3 && max_disp < 0.03, "sag {max_disp}");
    assert!(rel <= 0.05, "removed {soft_v} vs rigid {rigid}");
}

/// A quarter turn about z (exact in f32 on the block's coordinates, multiples of 1/8) gives
/// the same replay bit for bit: every force and normal turned, every depth and the removed
/// volume equal, the same leaves erased.
#[test]
fn a_quarter_turn_gives_the_same_replay_bit_for_bit() {
    let (a, va, ea) = replay(None);
    // The exact quarter turn of a vector: (x, y, z) -> (-y, x, z).
    let turn = |v: Vec3| Vec3::new(-v.y, v.x, v.z);
    let (b, vb, eb) = replay(Some(&turn));
    assert!(va > 1e-3, "removed {va}");
    assert_eq!(ea, eb);
    assert_eq!(va, vb);
    let mut touching = 0;
    for (k, (x, y)) in a.iter().zip(&b).enumerate() {
        assert_eq!(x.valid, y.valid, "tick {k}");
        assert_eq!(x.depth.to_bits(), y.depth.to_bits(), "tick {k}");
        assert_eq!(turn(x.normal), y.normal, "tick {k}");
        assert_eq!(turn(x.point), y.point, "tick {k}");
        assert_eq!(turn(x.force), y.force, "tick {k}");
        touching += usize::from(x.force != Vec3::ZERO);
    }
    assert!(touching > 100, "{touching} ticks with a force");
}

/// `v` turned by unit quaternion `q`, in f64: `v + 2w (u x v) + 2 u x (u x v)`.
fn rotate(q: Quat, v: D3) -> D3 {
    let (u, w) = ([q.x as f64, q.y as f64, q.z as f64], q.w as f64);
    let cr = |a: D3, b: D3| {
        [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ]
    };
    let t = cr(u, v);
    let tt = cr(u, t);
    [0, 1, 2].map(|i| v[i] + 2.0 * w * t[i] + 2.0 * tt[i])
}

/// A general rotation and a translation: at every tick where both runs' drill finished its
/// work within the step (the drilled state is then the same; a step cut short leaves a part
/// that depends on the order the hash lists the tets in), the contact's force turned within
/// 1e-4 of the largest force (f32 rounding of the turned positions; 5.1e-5 measured) and the
/// depth within 1e-5 of the radius; the same leaves erased and the same removed volume (within 1e-5
/// relative).
#[test]
fn a_rigid_motion_gives_the_same_forces_turned_and_the_same_removed_volume() {
    let (a, va, ea) = replay(None);
    let q = Quat::from_axis_angle(Vec3::new(1.0, 2.0, 3.0).normalize(), 0.7);
    let t = Vec3::new(0.03, -0.12, 0.21);
    let (b, vb, eb) = replay(Some(&|p| q * p + t));
    let fmax = a.iter().map(|x| x.spring.length()).fold(0.0f32, f32::max);
    assert!(fmax > 0.0);
    let (mut worst, mut compared) = (0.0f32, 0);
    for (k, (x, y)) in a.iter().zip(&b).enumerate() {
        if !(x.settled && y.settled) {
            continue;
        }
        compared += 1;
        // (f64 rotation of the unmoved run's force, here.)
        let turned = rotate(q, d3(x.spring));
        let f = d3(y.spring);
        let err = (0..3)
            .map(|i| (turned[i] - f[i]).powi(2))
            .sum::<f64>()
            .sqrt() as f32;
        worst = worst.max(err / fmax);
        assert_eq!(x.valid, y.valid, "tick {k}");
        assert!(
            (x.depth - y.depth).abs() <= 1e-5 * radius_of_replay(),
            "tick {k}: depth {} vs {}",
            x.depth,
            y.depth
        );
    }
    let rel = ((va - vb) / va).abs();
    eprintln!(
        "rigid motion: {compared} ticks, force error {worst:e} of the largest, volume {rel:e}"
    );
    assert!(compared >= 150, "{compared} ticks compared");
    // The positions turned in f32 carry a rounding of about 6e-8 of their size; a leaf
    // triangle of edge 1/128 turns that into its normal's direction, so 1e-4 (measured: 5.1e-5).
    assert!(worst <= 1e-4, "force error {worst:e} of the largest force");
    assert_eq!(ea, eb);
    assert!(rel <= 1e-5, "removed volume {va} vs {vb}");
}

/// The burr radius of [`replay`].
fn radius_of_replay() -> f32 {
    0.1013
}

/// A hash with entries for the rest shape only: stretching the block three times in x runs it
/// out (reported and counted, the first tets that fit kept and found), and the rest shape
/// fits again.
#[test]
fn a_stretched_mesh_that_overflows_the_hash_is_counted_and_recovers() {
    let mut om = block_mesh(4);
    let rest0 = om.positions().to_vec();
    let mesh = om.view();
    let mut sizes = WorldSizes::new(mesh.tet_count(), 1 << 12);
    let mut st = Store::sized(sizes);
    let world = st.world(mesh);
    let at_rest = world.hash().len();
    drop(world);
    sizes.hash_entries = at_rest + at_rest / 4;
    let mut st = Store::sized(sizes);
    let mesh = om.view();
    let mut world = st.world(mesh);
    assert_eq!(world.saturations().hash, 0);
    let mut rest = vec![Vec3::ZERO; rest0.len()];
    world.enable_deformation(&mut rest).unwrap();
    let stretched: Vec<Vec3> = rest0
        .iter()
        .map(|&p| p * Vec3::new(3.0, 1.0, 1.0))
        .collect();
    let rep = world.set_positions(&stretched).unwrap();
    assert!(rep.hash_saturated);
    assert_eq!(world.saturations().hash, 1);
    // The tets kept are found where they are.
    let own = tet_boxes(world.mesh());
    let whole = (Vec3::splat(-9.0), Vec3::splat(9.0));
    let mut found = BTreeSet::new();
    world
        .hash()
        .query_box_once(&Aabb::point(Vec3::ZERO).grown(9.0), u32::MAX, |i| {
            if overlaps(own[i as usize], whole) {
                found.insert(i);
            }
        });
    assert!(!found.is_empty() && found.len() < own.len());
    assert!(
        found.iter().all(|&t| (t as usize) < found.len()),
        "the first tets kept"
    );
    let rep = world.set_positions(&rest0).unwrap();
    assert!(!rep.hash_saturated);
    assert_eq!(rep.max_displacement, 0.0);
    assert_eq!(world.hash().len(), at_rest);
    assert_eq!(world.saturations().hash, 1);
}

/// Two-way coupling: a burr held pressing into the top of a soft block, its reaction spread
/// over the touched tet's nodes (`SoftBody::add_point_force`) and the body's positions handed
/// to the world every step: the top dents under the burr, the contact gets shallower than on the
/// rigid block (the body gives, the force drops), and the block returns to rest when released.
#[test]
fn a_pressed_soft_block_dents_gives_and_returns_to_rest() {
    let mut om = block_mesh(8);
    let mut soft = SoftOwned::from_mesh(&om.view());
    let rest0 = soft.rest.clone();
    let mut body = soft
        .body(
            &[Material {
                young: 1e4,
                poisson: 0.3,
                density: 1000.0,
            }],
            SoftParams {
                gravity: Vec3::ZERO,
                damping: 10.0,
                substeps: 10,
                iterations: 1,
            },
        )
        .unwrap();
    assert!(body.fix_below(Vec3::new(0.0, 0.0, -0.49), Vec3::Z) > 0);
    let mesh = om.view();
    let mut st = Store::new(mesh.tet_count(), 1 << 14);
    let mut world = st.world(mesh);
    let mut rest = vec![Vec3::ZERO; rest0.len()];
    world.enable_deformation(&mut rest).unwrap();
    let params = DrillParams {
        max_depth: 2,
        min_area: 0.0,
        budget: 100_000,
    };
    // A spring below the clamp at this press, so the force follows the depth.
    let fp = ForceParams {
        stiffness: 500.0,
        max_force: 100.0,
        ..ForceParams::default()
    };
    let (radius, press) = (0.15, 0.03);
    let centre = Vec3::new(0.0123, 0.0371, 0.5 + radius - press);
    // The rigid block's contact at that pose.
    world.simulate(centre, radius, 0.05, false, &params);
    let rigid = *world.contact();
    assert!(rigid.valid && (rigid.depth - press).abs() < 1e-5);
    let rigid_force = fp.stiffness * rigid.depth;
    let top = (0..rest0.len())
        .filter(|&i| rest0[i].z > 0.49)
        .min_by(|&a, &b| {
            let d = |i: usize| (rest0[i] - centre).truncate().length();
            d(a).total_cmp(&d(b))
        })
        .unwrap();
    let mut now = vec![Vec3::ZERO; rest0.len()];
    let mut external = vec![Vec3::ZERO; rest0.len()];
    let mut tool = ToolState::default();
    let mut force = Vec3::ZERO;
    for _ in 0..1500 {
        world.simulate(centre, radius, 0.05, false, &params);
        force = servo_force(world.contact(), centre, radius, &mut tool, &fp);
        external.fill(Vec3::ZERO);
        if let Some(t) = world.contact_tet() {
            // The material feels the opposite of the tool's force, at the contact point.
            assert!(body.add_point_force(t.idx(), world.contact().point, -force, &mut external));
        }
        body.step(1e-3, &external).unwrap();
        body.write_positions(&mut now);
        world.set_positions(&now).unwrap();
    }
    let dent = rest0[top].z - now[top].z;
    let depth = world.contact().depth;
    eprintln!(
        "pressed: dent {dent}, depth {depth} (rigid {}), force {} (rigid {})",
        rigid.depth,
        force.length(),
        rigid_force
    );
    assert!(dent > 0.1 * press, "dent {dent}");
    assert!(depth > 0.0 && depth < 0.9 * rigid.depth, "depth {depth}");
    // At rest the force is the spring's at the shallower depth: the user feels the body give.
    assert!((force.length() - fp.stiffness * depth).abs() < 0.02 * rigid_force);
    assert!(force.length() < 0.9 * rigid_force);
    // Settled: the body's dent and the burr's depth add up to the press (the surface under the
    // burr moved down by what the burr no longer penetrates), within a tenth.
    assert!(
        ((dent + depth) - press).abs() < 0.1 * press,
        "{dent} + {depth}"
    );
    // Released: back to rest.
    for _ in 0..4000 {
        body.step(1e-3, &[]).unwrap();
    }
    body.write_positions(&mut now);
    let rep = world.set_positions(&now).unwrap();
    assert!(
        rep.max_displacement < 0.01 * dent,
        "{} left",
        rep.max_displacement
    );
}
