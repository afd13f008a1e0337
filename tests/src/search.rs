//! The contact-search tests' shared pieces: world storage, the unit block, and the exhaustive
//! search over every visible triangle near the tool (the oracle the hierarchy's branch and
//! bound is checked against).

use glam::Vec3;
use tetradrill::owned::OwnedMesh;
use tetradrill_core::builtin::{block, block_counts};
use tetradrill_core::drill::DrillParams;
use tetradrill_core::force::closest_point_on_triangle;
use tetradrill_core::hierarchy::{FaceRef, Hierarchy};
use tetradrill_core::mesh::{BuildOptions, Mesh};
use tetradrill_core::owned::WorldBuffers;
use tetradrill_core::servo::{World, WorldSizes};
use tetradrill_core::TetId;

/// Storage for one world: the core's owned-storage layer, sized for `tets` tets.
#[derive(Debug)]
pub struct Store(WorldBuffers);

impl Store {
    /// Storage for a world of `tets` tets and an arena of `arena` hierarchy nodes.
    pub fn new(tets: usize, arena: usize) -> Self {
        Self::sized(WorldSizes::new(tets, arena))
    }

    /// Storage of `sizes`.
    pub fn sized(sizes: WorldSizes) -> Self {
        Self(WorldBuffers::new(sizes).expect("storage"))
    }

    /// A world over `mesh` in this storage.
    pub fn world<'a>(&'a mut self, mesh: Mesh<'a>) -> World<'a> {
        self.0.world(mesh).expect("world")
    }
}

/// The generated block of `n` cubes a side filling the unit cube centred on the origin.
pub fn block_mesh(n: usize) -> OwnedMesh {
    let (nn, nt) = block_counts(n);
    let mut p = vec![Vec3::ZERO; nn];
    let mut t = vec![[0u32; 4]; nt];
    block(n, 1.0 / n as f32, Vec3::splat(-0.5), &mut p, &mut t).unwrap();
    OwnedMesh::build(p, &t, BuildOptions::default()).unwrap()
}

/// The exhaustive search: every visible triangle `for_each_visible_in` yields near the tool,
/// the closest within reach, ties to the smallest (tet, index, face).
pub fn exhaustive(
    h: &Hierarchy<'_>,
    mesh: &Mesh<'_>,
    cands: &[TetId],
    c: Vec3,
    reach: f32,
) -> Option<(f32, FaceRef, [Vec3; 3])> {
    exhaustive_uncut(h, mesh, cands, c, reach, None)
}

/// The rule of a cutting burr of radius `cut`, written out here: a triangle is skipped when
/// its three corners are within `cut` of `c`, or when `c` is behind its outward plane at its
/// closest point.
pub fn skipped(corners: [Vec3; 3], c: Vec3, cut: Option<f32>) -> bool {
    let Some(r) = cut else { return false };
    let all_in = corners.iter().all(|q| (*q - c).length() <= r);
    let x = closest_point_on_triangle(c, corners);
    let n = (corners[1] - corners[0]).cross(corners[2] - corners[0]);
    all_in || (c - x).dot(n) < 0.0
}

/// [`exhaustive`] for a burr cutting with radius `cut`.
pub fn exhaustive_uncut(
    h: &Hierarchy<'_>,
    mesh: &Mesh<'_>,
    cands: &[TetId],
    c: Vec3,
    reach: f32,
    cut: Option<f32>,
) -> Option<(f32, FaceRef, [Vec3; 3])> {
    let mut best: Option<(f32, FaceRef, [Vec3; 3])> = None;
    h.for_each_visible_in(mesh, cands, Some((c, reach)), |vt| {
        if skipped(vt.corners, c, cut) {
            return;
        }
        let d2 = (c - closest_point_on_triangle(c, vt.corners)).length_squared();
        let within = d2 <= reach * reach; // false for NaN too
        if !within {
            return;
        }
        let key = FaceRef {
            tet: vt.tet,
            index: vt.index,
            face: vt.face,
        };
        if best.is_none_or(|(bd, bk, _)| d2 < bd || (d2 == bd && key < bk)) {
            best = Some((d2, key, vt.corners));
        }
    });
    best
}

/// Runs `f` on a fresh world over the 4 x 4 x 4 block (drill depth 3, a budget that never
/// runs out) with a burr of radius 0.1 and reach 0.05: `f(world, params, r, reach)`.
pub fn on_block4(f: impl FnOnce(&mut World<'_>, &DrillParams, f32, f32)) {
    let mut om = block_mesh(4);
    let mesh = om.view();
    let mut st = Store::new(mesh.tet_count(), 1 << 16);
    let mut world = st.world(mesh);
    let params = DrillParams {
        max_depth: 3,
        min_area: 0.0,
        budget: 100_000,
    };
    f(&mut world, &params, 0.1, 0.05);
}
