//! The pen-contact scene shared by the contact tests: the meshes, the pen rig, random poses near
//! the surface and one fresh tick.

use glam::{Quat, Vec3};
use rand::{Rng, SeedableRng};
use tetradrill::pen::PenRig;
use tetradrill_core::force::{pen_contact, PenBuffers, PenContact, PenOptions, PenScene, PenState};
use tetradrill_core::mesh::Mesh;

/// The pen tool (metres; the tests scale it x10 to 1.15 units with a 0.04 radius).
pub const PEN: &str = "models/pen_tool_gmsh.mesh";
/// The cow, about 1.5 units long.
pub const COW: &str = "models/spot_tetgen_q1.414.node";
/// The teddy bear.
pub const TEDDY: &str = "models/teddy_cgalbear_tetgen_q1.414.node";
/// The pen at `pen_scale` next to the object `obj` at `obj_scale` (the host's [`PenRig`]
/// builds the scene and buffers).
pub fn rig(pen_scale: f64, obj: &str, obj_scale: f64) -> PenRig {
    PenRig {
        pen: crate::load(PEN, pen_scale),
        obj: crate::load(obj, obj_scale),
    }
}

/// The object's first boundary node whose normal is within ~37 degrees of `axis`: its
/// position and normal (where the path tests start).
pub fn facing(rig: &mut PenRig, axis: Vec3) -> (Vec3, Vec3) {
    let obj = rig.obj.view();
    let b = (0..obj.node_count())
        .find(|&i| obj.nodes()[i].boundary() && obj.normals()[i].dot(axis) > 0.8)
        .expect("a boundary node facing the axis");
    (obj.positions()[b], obj.normals()[b])
}

/// Random pen poses whose tip is near the object's surface, pushed in by up to `depth`.
pub fn poses(obj: &Mesh<'_>, n: usize, depth: f32, seed: u64) -> Vec<(Vec3, Quat)> {
    let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
    let boundary: Vec<usize> = (0..obj.node_count())
        .filter(|&i| obj.nodes()[i].boundary())
        .collect();
    (0..n)
        .map(|_| {
            let b = boundary[rng.gen_range(0..boundary.len())];
            let nrm = obj.normals()[b];
            let tip = obj.positions()[b] - nrm * rng.gen_range(-0.02..depth);
            let q = Quat::from_xyzw(
                rng.gen_range(-1.0..1.0),
                rng.gen_range(-1.0..1.0),
                rng.gen_range(-1.0..1.0),
                rng.gen_range(-1.0..1.0),
            )
            .normalize();
            (tip, q)
        })
        .collect()
}

/// One pen tick at `pos`, `rot` from a fresh state with the default options (no damping
/// history, no entry plane, no list kept from a previous tick).
pub fn first_tick(
    scene: &PenScene<'_, '_, '_>,
    bufs: &mut PenBuffers<'_>,
    pos: Vec3,
    rot: Quat,
) -> PenContact {
    pen_contact(
        scene,
        bufs,
        pos,
        rot,
        &PenOptions::default(),
        &mut PenState::default(),
    )
}
