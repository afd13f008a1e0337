//! The surface exporter over the demo's drilling run: the renderer's buffers written a small
//! budget a frame, a mirror fed only from the change ranges equal to the buffers after every
//! call, the buffers equal to the visible faces (as an independent listing gives them, with
//! labels) whenever a call reports nothing pending, and every call's work within its bound.

use std::collections::BTreeMap;

use tetradrill::engine::{self, EngineStorage, TickParams};
use tetradrill::scenario;
use tetradrill::traces::PoseSource;
use tetradrill_core::force::ToolState;
use tetradrill_core::hierarchy::{
    ExportReport, Hierarchy, SlotRange, SurfaceBuffers, SurfaceExport, SurfaceSizes,
    SurfaceStorage, DEFAULT_CHANGES,
};
use tetradrill_core::mesh::Mesh;
use tetradrill_core::storage::{Block, Line};
use tetradrill_core::TetId;

/// Servo ticks a frame: 60 frames a second at 1 kHz.
const TICKS_A_FRAME: u64 = 17;
/// Work units a frame.
const BUDGET: u32 = 4096;
/// Triangle slots.
const SLOTS: usize = 1 << 18;

/// A face: its corners' bits and its label.
type Tri = ([u32; 9], i32);

fn tri(c: [[f32; 3]; 3], label: i32) -> Tri {
    let mut b = [0u32; 9];
    for (k, v) in c.iter().flatten().enumerate() {
        b[k] = v.to_bits();
    }
    (b, label)
}

/// A copy of the four buffers: positions, normals, labels, indices.
type Copy4 = (Vec<[f32; 3]>, Vec<[f32; 3]>, Vec<i32>, Vec<u32>);

/// The renderer's side: the buffers, the mirror and the range list.
struct Renderer {
    pos: Vec<[f32; 3]>,
    nrm: Vec<[f32; 3]>,
    lab: Vec<i32>,
    idx: Vec<u32>,
    mirror: Copy4,
    ranges: Vec<SlotRange>,
}

impl Renderer {
    fn new(slots: usize, ranges: usize) -> Self {
        let n = 3 * slots;
        Self {
            pos: vec![[0.0; 3]; n],
            nrm: vec![[0.0; 3]; n],
            lab: vec![0; n],
            idx: vec![0; n],
            mirror: (vec![[0.0; 3]; n], vec![[0.0; 3]; n], vec![0; n], vec![0; n]),
            ranges: vec![SlotRange::default(); ranges],
        }
    }

    fn update(
        &mut self,
        ex: &mut SurfaceExport<'_>,
        h: &Hierarchy<'_>,
        mesh: &Mesh<'_>,
        labels: &[i32],
        budget: u32,
    ) -> ExportReport {
        let mut out = SurfaceBuffers {
            positions: &mut self.pos,
            normals: &mut self.nrm,
            labels: &mut self.lab,
            indices: &mut self.idx,
            ranges: &mut self.ranges,
        };
        let rep = ex
            .update(h, mesh, |t| labels[t.idx()], budget, &mut out)
            .expect("buffers");
        let m = &mut self.mirror;
        for r in &self.ranges[..rep.ranges as usize] {
            let (a, b) = (3 * r.first as usize, 3 * (r.first + r.count) as usize);
            m.0[a..b].copy_from_slice(&self.pos[a..b]);
            m.1[a..b].copy_from_slice(&self.nrm[a..b]);
            m.2[a..b].copy_from_slice(&self.lab[a..b]);
            m.3[a..b].copy_from_slice(&self.idx[a..b]);
        }
        assert!(m.0 == self.pos && m.1 == self.nrm, "the mirror differs");
        assert!(m.2 == self.lab && m.3 == self.idx, "the mirror differs");
        rep
    }

    /// The live slots (indices not all zero) as faces.
    fn live(&self) -> Vec<Tri> {
        let mut v: Vec<Tri> = (0..self.idx.len() / 3)
            .filter(|&s| self.idx[3 * s..3 * s + 3] != [0, 0, 0])
            .map(|s| {
                let i = 3 * s as u32;
                assert_eq!(self.idx[3 * s..3 * s + 3], [i, i + 1, i + 2]);
                let c = [self.pos[3 * s], self.pos[3 * s + 1], self.pos[3 * s + 2]];
                tri(c, self.lab[3 * s])
            })
            .collect();
        v.sort_unstable();
        v
    }
}

/// The oracle: every visible face with its tet's label, sorted (the v_list's listing).
fn visible(h: &Hierarchy<'_>, mesh: &Mesh<'_>, labels: &[i32]) -> Vec<Tri> {
    let mut v = Vec::new();
    h.for_each_visible(mesh, |t| {
        v.push(tri(t.corners.map(|c| c.to_array()), labels[t.tet.idx()]));
    });
    v.sort_unstable();
    v
}

/// Visible faces a tet: the most one listing of a tet can cost with its slots.
fn faces_by_tet(h: &Hierarchy<'_>, mesh: &Mesh<'_>) -> BTreeMap<TetId, u32> {
    let mut m = BTreeMap::new();
    h.for_each_visible(mesh, |t| *m.entry(t.tet).or_insert(0) += 1);
    m
}

#[test]
fn the_demo_drilled_surface_reaches_the_buffers_through_the_change_ranges() {
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
    // Labels that tell tets apart (the demo's mesh has one region).
    let labels: Vec<i32> = (0..tets as i32).map(|t| 1000 + t).collect();
    let sizes = SurfaceSizes::new(SLOTS, tets);
    let mut lines = vec![Line::ZERO; sizes.lines().expect("sizes")];
    let storage = SurfaceStorage::carve(&sizes, &mut Block::from_lines(&mut lines)).unwrap();
    let mut ex = SurfaceExport::new(storage, world.hierarchy()).expect("exporter");
    let mut r = Renderer::new(SLOTS, 64);
    let mut tool = ToolState::default();
    let (mut calls, mut exact, mut worst_work, mut most_logged) = (0, 0, 0u32, 0u64);
    let mut most_written = 0;
    let mut last_count = world.hierarchy().change_count();
    let mut before = faces_by_tet(world.hierarchy(), world.mesh());
    let (mut step_count, mut most_a_step) = (last_count, 0);
    for i in 0..poses.ticks() {
        engine::tick(&mut world, &mut tool, &params, &poses.at(i));
        let count = world.hierarchy().change_count();
        most_a_step = most_a_step.max(count - step_count);
        step_count = count;
        if (i + 1) % TICKS_A_FRAME != 0 && i + 1 != poses.ticks() {
            continue;
        }
        let (h, mesh) = (world.hierarchy(), world.mesh());
        // The frame's entries fit the default change log.
        let logged = h.change_count() - last_count;
        most_logged = most_logged.max(logged);
        assert!(logged <= DEFAULT_CHANGES as u64, "a frame logged {logged}");
        last_count = h.change_count();
        let now = faces_by_tet(h, mesh);
        let rep = r.update(&mut ex, h, mesh, &labels, BUDGET);
        calls += 1;
        // One tet's listing at most past the budget: 1 + its faces + the slots it frees.
        let worst_tet = now
            .keys()
            .chain(before.keys())
            .map(|t| 1 + now.get(t).unwrap_or(&0) + before.get(t).unwrap_or(&0))
            .max()
            .unwrap_or(1);
        assert!(
            rep.work < BUDGET + worst_tet,
            "work {} at tick {i}",
            rep.work
        );
        worst_work = worst_work.max(rep.work);
        most_written = most_written.max(rep.written);
        assert_eq!(rep.dropped, 0, "{rep:?} capacity {}", ex.capacity());
        if rep.pending == 0 {
            exact += 1;
            assert_eq!(r.live(), visible(h, mesh, &labels), "tick {i}");
            assert_eq!(rep.live as usize, h.visible_face_count() as usize);
        }
        before = now;
    }
    // Up to date at the end, in a few more calls.
    for _ in 0..100 {
        let (h, mesh) = (world.hierarchy(), world.mesh());
        if r.update(&mut ex, h, mesh, &labels, BUDGET).pending == 0 {
            break;
        }
    }
    let (h, mesh) = (world.hierarchy(), world.mesh());
    assert_eq!(r.live(), visible(h, mesh, &labels));
    assert!(h.stats().erased > 1000, "the demo drills");
    assert!(exact >= 20, "{exact} of {calls} calls up to date");
    println!(
        "surface export: {calls} frames, {exact} up to date, most work {worst_work}, most \
         written {most_written}, most entries a frame {most_logged} (a step {most_a_step}), {} triangles, {tets} tets",
        h.visible_face_count()
    );
}
