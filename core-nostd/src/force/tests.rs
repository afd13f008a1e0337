use glam::{Affine3A, Mat4, Quat, Vec3};

use super::frames::{allocentric, camera, force_to_device};
use super::triangles::boundary_triangle;
use super::*;
use crate::collide::test_support::Store;
use crate::collide::{hash_tets, Body, Occupancy, OccupancyStorage, RigidTets, RigidTetsStorage};
use crate::depth::{hash_boundary_faces, NodeGraph, Penetration};
use crate::hash::{Aabb, HashEntry, SpatialHash};
use crate::ids::{NodeId, TetId};
use crate::storage::{Block, Line};

#[test]
fn sphere_pressed_into_flat_face() {
    let mut b = Store::<125, 384>::block(4, 0.25, Vec3::splat(-0.5));
    let b = b.mesh();
    let bb = Body::fixed(&b);
    let mut fs = [0u32; 64];
    let mut fe = [HashEntry::default(); 4096];
    let mut fh = SpatialHash::new(&mut fs, &mut fe, 0.25).unwrap();
    hash_boundary_faces(&mut fh, &bb);
    let (r, k) = (0.1f32, 500.0f32);
    for d in [0.0f32, 0.01, 0.05, 0.09, 0.15] {
        let c = Vec3::new(0.07, -0.13, 0.5 + r - d);
        let s = mesh_sphere_contact(&fh, &bb, c, r, 64);
        assert!((s.depth - d).abs() < 1e-6, "d {d}: {s:?}");
        assert!((s.normal - Vec3::Z).length() < 1e-6);
        let f = s.normal * (k * s.depth);
        assert!((f - Vec3::Z * k * d).length() < 1e-3);
    }
    // Far away: no triangles near, no contact.
    let s = mesh_sphere_contact(&fh, &bb, Vec3::splat(5.0), 0.1, 64);
    assert!(!s.touching() && s.triangles == 0);
    // The iterator form agrees with the hashed convenience.
    let tris = (0..b.tet_count() * 4).filter_map(|i| {
        let t = crate::ids::TetId::from_idx(i / 4);
        let f = (i % 4) as u8;
        bb.neighbour(t, f)
            .is_none()
            .then(|| boundary_triangle(&bb, t, f))
            .flatten()
    });
    let c = Vec3::new(0.2, 0.1, 0.55);
    let a = sphere_contact(c, 0.1, tris);
    let h = mesh_sphere_contact(&fh, &bb, c, 0.1, 64);
    assert!((a.depth - h.depth).abs() < 1e-7 && a.normal == h.normal);
}

#[test]
fn sphere_centre_inside_counts_the_full_distance() {
    let tri = [
        Vec3::new(-1.0, -1.0, 0.0),
        Vec3::new(1.0, -1.0, 0.0),
        Vec3::new(0.0, 1.0, 0.0),
    ];
    let s = sphere_contact(Vec3::new(0.0, 0.0, -0.3), 0.1, [tri]);
    assert!((s.depth - 0.4).abs() < 1e-6 && s.normal == Vec3::Z);
    let none = sphere_contact(Vec3::ZERO, 0.1, core::iter::empty());
    assert!(!none.touching());
    // Closest point on a degenerate triangle does not divide by zero.
    let deg = [Vec3::ZERO; 3];
    assert_eq!(closest_point_on_triangle(Vec3::ONE, deg), Vec3::ZERO);
}

#[test]
fn clamp_damping_digest_frames() {
    assert_eq!(
        clamp_force(Vec3::new(3.0, 4.0, 0.0), 1.0),
        Vec3::new(0.6, 0.8, 0.0)
    );
    assert_eq!(clamp_force(Vec3::splat(f32::NAN), 1.0), Vec3::ZERO);
    assert_eq!(clamp_force(Vec3::X, 0.0), Vec3::ZERO);
    let p = ForceParams {
        stiffness: 1.0,
        damping: 2.0,
        max_force: 10.0,
        dt: 0.5,
        ..ForceParams::default()
    };
    let mut st = ToolState::default();
    assert_eq!(damping_force(&mut st, Vec3::ZERO, true, &p), Vec3::ZERO);
    assert_eq!(damping_force(&mut st, Vec3::X, true, &p), Vec3::X * -4.0);
    assert_eq!(damping_force(&mut st, Vec3::X * 2.0, false, &p), Vec3::ZERO);

    assert_eq!(force_digest(&[]), 0xcbf2_9ce4_8422_2325);
    let a = force_digest(&[Vec3::ZERO, Vec3::X]);
    assert_ne!(
        a,
        force_digest(&[Vec3::new(-0.0, 0.0, 0.0), Vec3::X]),
        "bit patterns count"
    );
    assert_ne!(a, force_digest(&[Vec3::X, Vec3::ZERO]), "order counts");
    let mut d = ForceDigest::new();
    d.push(Vec3::ZERO);
    d.push(Vec3::X);
    assert_eq!(d.value(), a);

    let m = Mat4::from_rotation_translation(Quat::from_rotation_y(0.4), Vec3::new(1.0, 2.0, 3.0));
    let t = Mat4::from_quat(Quat::from_rotation_x(-0.3));
    let c = camera(m, t);
    let pe = Mat4::from_translation(Vec3::new(0.1, 0.0, 0.0));
    let pa = allocentric(c, pe);
    assert!((pa.w_axis.truncate() - c.transform_point3(Vec3::new(0.1, 0.0, 0.0))).length() < 1e-6);
    let f_scene = c.transform_vector3(Vec3::Y);
    assert!((force_to_device(c, f_scene) - Vec3::Y).length() < 1e-6);
    assert_eq!(force_to_device(Mat4::ZERO, Vec3::X), Vec3::ZERO);
}

struct PenWorld {
    pen: Store<27, 48>,
    obj: Store<125, 384>,
}

fn pen_tick(
    w: &mut PenWorld,
    pos: Vec3,
    opts: &PenOptions,
    caps: usize,
    state: &mut PenState,
) -> PenContact {
    let pen = w.pen.mesh();
    let obj = w.obj.mesh();
    let ob = Body::fixed(&obj);
    let (mut pgo, mut pga) = ([0u32; 28], [NodeId::NONE; 256]);
    let pg = NodeGraph::build(&pen, &mut pgo, &mut pga).unwrap();
    let (mut ogo, mut oga) = ([0u32; 126], [NodeId::NONE; 1208]);
    let og = NodeGraph::build(&obj, &mut ogo, &mut oga).unwrap();
    let (mut ts, mut te) = ([0u32; 64], [HashEntry::default(); 8192]);
    let mut th = SpatialHash::new(&mut ts, &mut te, 0.25).unwrap();
    hash_tets(&mut th, &ob);
    let (mut ns, mut ne) = ([0u32; 64], [HashEntry::default(); 125]);
    let mut nh = SpatialHash::new(&mut ns, &mut ne, 0.25).unwrap();
    nh.rebuild_points(obj.positions());
    let (mut fs, mut fe) = ([0u32; 64], [HashEntry::default(); 4096]);
    let mut fh = SpatialHash::new(&mut fs, &mut fe, 0.25).unwrap();
    hash_boundary_faces(&mut fh, &ob);
    let (mut ps, mut pe) = ([0u32; 32], [HashEntry::default(); 2048]);
    let mut ph = SpatialHash::new(&mut ps, &mut pe, 0.1).unwrap();
    hash_boundary_faces(&mut ph, &Body::fixed(&pen));
    let (mut rs, mut re) = ([0u32; 64], [crate::collide::GridEntry::default(); 2048]);
    let (mut rb, mut rc) = ([Aabb::of::<0>([]); 48], [Aabb::of::<0>([]); 64]);
    let mut nc = [0u32; 27];
    let rest = RigidTets::build(
        &Body::fixed(&pen),
        RigidTetsStorage {
            grid_starts: &mut rs,
            grid_tets: &mut re,
            tet_boxes: &mut rb,
            clusters: &mut rc,
            node_clusters: &mut nc,
        },
        0.05,
        0.04,
        1e-4,
    )
    .unwrap();
    let (mut ow, mut ob_boxes) = ([0u32; 64], [Aabb::of::<0>([]); 384]);
    let cells = Occupancy::build(
        &ob,
        0.25,
        1e-4,
        OccupancyStorage {
            words: &mut ow,
            boxes: &mut ob_boxes,
        },
    )
    .unwrap();
    let scene = PenScene {
        pen: &pen,
        pen_graph: pg,
        pen_rest: &rest,
        pen_faces: Some(&ph),
        object: ob,
        object_graph: og,
        object_tets: &th,
        object_nodes: &nh,
        object_cells: &cells,
        object_faces: Some(&fh),
        object_walks: crate::collide::walks_exact(&ob),
        pen_walks: crate::collide::walks_exact(&Body::fixed(&pen)),
    };
    let sizes = PenBufferSizes {
        pen_contacts: caps.min(27),
        object_contacts: caps.min(125),
        pen_queue: caps.min(27),
        object_queue: caps.min(125),
        ..PenBufferSizes::nodes(27, 125)
    };
    // 182 lines at the most (every list as long as its body's nodes).
    let mut lines = [Line::ZERO; 182];
    let mut bufs = PenBuffers::carve(&sizes, &mut Block::from_lines(&mut lines)).unwrap();
    pen_contact(&scene, &mut bufs, pos, Quat::IDENTITY, opts, state)
}

fn pen_world() -> PenWorld {
    PenWorld {
        pen: Store::block(2, 0.05, Vec3::new(-0.05, -0.05, 0.0)),
        obj: Store::block(4, 0.25, Vec3::splat(-0.5)),
    }
}

#[test]
fn pen_block_pressed_into_top_face() {
    let mut w = pen_world();
    let mut opts = PenOptions {
        params: ForceParams {
            stiffness: 100.0,
            damping: 0.0,
            max_force: 1e6,
            dt: 1e-3,
            ..ForceParams::default()
        },
        ..PenOptions::default()
    };
    let d = 0.03;
    let c = pen_tick(
        &mut w,
        Vec3::new(0.11, 0.12, 0.5 - d),
        &opts,
        1000,
        &mut PenState::default(),
    );
    // 9 bottom nodes at depth d (the middle level at 0.025 is outside).
    assert_eq!(c.penetrations, (9, 0));
    assert!(
        (c.raw - Vec3::Z * 100.0 * 9.0 * d).length() < 1e-3,
        "{:?}",
        c.raw
    );
    assert!((c.display_offset - Vec3::Z * d).length() < 1e-5);
    opts.method = DepthMethod::Hashed;
    let h = pen_tick(
        &mut w,
        Vec3::new(0.11, 0.12, 0.5 - d),
        &opts,
        1000,
        &mut PenState::default(),
    );
    assert_eq!(
        h.raw.to_array().map(f32::to_bits),
        c.raw.to_array().map(f32::to_bits)
    );
    // Fully outside: zero force.
    let o = pen_tick(
        &mut w,
        Vec3::new(0.0, 0.0, 0.6),
        &opts,
        1000,
        &mut PenState::default(),
    );
    assert_eq!((o.force, o.penetrations), (Vec3::ZERO, (0, 0)));
    // Clamping.
    opts.params.max_force = 1.0;
    let m = pen_tick(
        &mut w,
        Vec3::new(0.11, 0.12, 0.5 - d),
        &opts,
        1000,
        &mut PenState::default(),
    );
    assert!(m.clamped && (m.force.length() - 1.0).abs() < 1e-6);
}

#[test]
fn pen_tiny_capacities_saturate_without_panic() {
    let mut w = pen_world();
    let opts = PenOptions::default();
    for caps in [0, 1, 3] {
        let c = pen_tick(
            &mut w,
            Vec3::new(0.01, 0.02, 0.4),
            &opts,
            caps,
            &mut PenState::default(),
        );
        assert!(c.saturated(), "caps {caps}");
        assert!(c.force.is_finite());
    }
    let _ = Affine3A::IDENTITY;
}

/// The thin-pen remedy: the entry plane measures a contact's depth from where it began.
#[test]
fn entry_plane_keeps_the_first_surface_plane() {
    use super::entry::EntryPlane;
    // A contact begins: one tool node 0.01 below a floor at z = 0 (direction out of it: +z).
    let mut entry = EntryPlane::default();
    let mut at = [Vec3::new(0.0, 0.0, -0.01)];
    let first = Penetration {
        node: NodeId(0),
        depth: 0.01,
        dir: Vec3::Z,
        ..Default::default()
    };
    assert!((entry.force(&at, &[first], 100.0) - Vec3::Z).length() < 1e-5);
    assert_eq!(entry.plane(), Some((Vec3::ZERO, Vec3::Z)));

    // Pushed sideways and deeper, the node's consistent depth turns sideways (a thin pen's
    // jump); the entry plane still measures it 0.03 deep, straight up.
    at[0] = Vec3::new(0.2, 0.0, -0.03);
    let sideways = Penetration {
        depth: 0.05,
        dir: Vec3::X,
        ..first
    };
    assert!((entry.force(&at, &[sideways], 100.0) - Vec3::Z * 3.0).length() < 1e-4);

    // The contact ends: the plane is forgotten.
    entry.force(&at, &[], 100.0);
    assert_eq!(entry.plane(), None);
}

/// A passive point that jumps through a floor in one tick is held at the face it entered.
#[test]
fn passive_point_cannot_tunnel_through_a_floor() {
    use super::passive::{passive_force, PassivePoint, PassiveProbe};
    // A floor at z = 0 (outward +z) and a passive point that jumps 0.3 through it in one tick.
    let floor = [
        Vec3::new(-1.0, -1.0, 0.0),
        Vec3::new(1.0, -1.0, 0.0),
        Vec3::new(0.0, 1.0, 0.0),
    ];
    let mut point = PassivePoint::default();
    let (above, below) = (Vec3::new(0.0, 0.0, 0.05), Vec3::new(0.0, 0.0, -0.3));
    for to in [above, below] {
        let mut probe = PassiveProbe::new(&point, to, 0.1);
        probe.offer(floor, (0, 0, 0));
        probe.finish(&mut point);
    }

    // It did not tunnel: it is held at the face it entered, which pushes it back out with
    // 100 N per unit x (radius 0.05 + 0.3 behind the face).
    assert!(point.is_held());
    let (force, pushing) = passive_force(&[point], &[below], 0.05, 100.0, 50.0);
    assert_eq!(pushing, 1);
    assert!((force - Vec3::Z * 35.0).length() < 1e-4);
}

/// Damping from the tool's velocity, and the displayed tool drawn out by the deepest node.
#[test]
fn damping_and_display_offset() {
    // No velocity on the first tick; then 1 mm down in a 1 ms tick: 2 N s per unit x 1 unit/s, up.
    let params = ForceParams {
        damping: 2.0,
        ..ForceParams::default()
    };
    let mut tool = ToolState::default();
    assert_eq!(
        damping_force(&mut tool, Vec3::ZERO, true, &params),
        Vec3::ZERO
    );
    let damping = damping_force(&mut tool, Vec3::new(0.0, 0.0, -0.001), true, &params);
    assert!((damping - Vec3::Z * 2.0).length() < 1e-3);

    // The tool is drawn out along the force by its deepest node's depth.
    let at = |depth| Penetration {
        depth,
        dir: Vec3::Z,
        ..Default::default()
    };
    let offset = display_offset(Vec3::Z * 3.0, &[at(0.02), at(0.01)], &[]);
    assert!((offset - Vec3::Z * 0.02).length() < 1e-7);
}

/// The 12-tet cube's boundary faces as outward triangles, and a burr pressed into its top.
#[test]
fn cube_boundary_triangles_and_a_burr_on_top() {
    let mut store = Store::<9, 12>::cube12(1.0, Vec3::ZERO);
    let mesh = store.refinable_mesh();
    let body = Body::fixed(&mesh);

    // The cube's 12 boundary faces as outward counter-clockwise triangles.
    let mut faces = [[Vec3::ZERO; 3]; 12];
    let mut n = 0;
    for t in (0..12).map(TetId) {
        for f in (0..4).filter(|&f| mesh.is_boundary_face(t, f)) {
            if let Some(tri) = boundary_triangle(&body, t, f) {
                faces[n] = tri;
                n += 1;
            }
        }
    }
    assert_eq!(n, 12);
    assert!(faces
        .iter()
        .all(|&[a, b, c]| (b - a).cross(c - a).dot(a) > 0.0));

    // A burr of radius 0.1 centred 0.05 above the top face is 0.05 into it, pushed up.
    let contact = sphere_contact(Vec3::new(0.1, 0.2, 0.55), 0.1, faces.iter().copied());
    assert!(contact.touching() && (contact.depth - 0.05).abs() < 1e-6);
    assert!((contact.normal - Vec3::Z).length() < 1e-6);
}

/// A drill's passive points run along its axis from the burr's surface to the handle.
#[test]
fn drill_passive_points_from_burr_to_handle() {
    let tool = DrillTool {
        burr_radius: 0.1,
        shaft_length: 0.6,
        shaft_radius: 0.05,
    };
    // Passive points from the burr's surface to the handle, a shaft radius apart: 10 gaps.
    assert_eq!(tool.passive_count(), 11);

    // The tool turned a quarter about x: its axis (+z at rest) points along -y.
    let axis = DrillTool::axis(Quat::from_rotation_x(core::f32::consts::FRAC_PI_2));
    assert!((axis + Vec3::Y).length() < 1e-6);
    let mut at = [Vec3::ZERO; MAX_PASSIVE];
    let n = tool.passive_positions(Vec3::ZERO, axis, &mut at);
    assert!((at[0] - axis * 0.1).length() < 1e-6);
    assert!((at[n - 1] - tool.handle(Vec3::ZERO, axis)).length() < 1e-6);
}
