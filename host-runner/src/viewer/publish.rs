//! The simulation's side of the viewer: which coarse tets changed, and the snapshots that carry
//! their visible triangles.
//!
//! A drill step changes the trees of the tets it works on and, through Erase and Refine, the
//! visibility of their face neighbours' nodes. Work left pending in the drill's deque is done in
//! later steps, on the tets that were candidates when it was queued. So after every step that
//! created or erased nodes, the changed set is: this step's candidates, every candidate since
//! the deque was last empty (the backlog), and their face neighbours. Snapshots go out at most
//! every [`SNAPSHOT_PERIOD_NS`] and only when the queue has room; until then the changed tets
//! accumulate (at most every tet once), so nothing is lost when the viewer is slow.
//!
//! Cost: the simulation allocates the patches of a snapshot (one `Vec` per changed tet), at
//! most 60 times a second, never more than the visible triangles of the changed tets; the
//! bookkeeping is two `Vec`s sized once by the tet count.

use tetradrill_core::servo::World;
use tetradrill_core::{TetId, Vec3};

use super::handoff::SNAPSHOT_PERIOD_NS;
use super::handoff::{
    Controls, ControlsOut, Patch, RegionSlots, Snapshot, SnapshotQueue, SurfTri, ToolShape,
    ToolView,
};
use super::scene::Scene;
use super::smooth_live::{LiveSmooth, SmoothStore, SNAPSHOT_BUDGET};
use crate::viewer::handoff::SimStatus;

/// The simulation task's link to a viewer.
#[derive(Debug)]
pub struct SimViewer<'q> {
    queue: &'q SnapshotQueue,
    controls: Option<ControlsOut>,
    last_controls: Option<Controls>,
    dirty: Vec<bool>,
    list: Vec<u32>,
    in_backlog: Vec<bool>,
    backlog: Vec<u32>,
    full: bool,
    seq: u64,
    last_ns: u64,
    initial_volume: f64,
    tool_shape: Option<ToolShape>,
    regions: Option<RegionSlots>,
    region_colours: Option<super::handoff::RegionColours>,
    labels: Option<super::labels::LabelGridRef>,
    /// The smooth normals' storage until the first snapshot makes them.
    smooth_store: Option<&'q mut SmoothStore>,
    smooth: Option<LiveSmooth<'q>>,
    /// The world was rebuilt: the smooth normals start over at the next snapshot.
    smooth_reset: bool,
}

impl<'q> SimViewer<'q> {
    /// A link publishing into `queue` for a mesh of `tets` tets; `controls`, when given, is
    /// read once per step. The first snapshot is a full one.
    pub fn new(queue: &'q SnapshotQueue, controls: Option<ControlsOut>, tets: usize) -> Self {
        Self {
            queue,
            controls,
            last_controls: None,
            dirty: vec![false; tets],
            list: Vec::with_capacity(tets.min(4096)),
            in_backlog: vec![false; tets],
            backlog: Vec::with_capacity(tets.min(4096)),
            full: true,
            seq: 0,
            last_ns: 0,
            initial_volume: 0.0,
            tool_shape: None,
            regions: None,
            region_colours: None,
            labels: None,
            smooth_store: None,
            smooth: None,
            smooth_reset: false,
        }
    }

    /// Shades the surface with smooth per-corner normals kept in `store` (sized once; see
    /// [`super::smooth_live`]): made at the next snapshot, then brought a bounded step closer
    /// at each.
    pub fn set_smooth_store(&mut self, store: &'q mut SmoothStore) {
        self.smooth_store = Some(store);
        self.smooth = None;
        self.full = true;
    }

    /// Sets the object's region colours (sent with every full snapshot; see
    /// [`super::handoff::region_slots`]).
    pub fn set_regions(&mut self, regions: Option<RegionSlots>) {
        self.regions = regions;
    }

    /// Sets the colours the scenario gives the regions, in label order (sent with every
    /// full snapshot).
    pub fn set_region_colours(&mut self, colours: Option<Vec<Option<[f32; 3]>>>) {
        self.region_colours = colours.map(Into::into);
    }

    /// Sets the regions, their colours and their grid at once (sent with every full
    /// snapshot).
    pub fn set_regions_view(&mut self, view: RegionsView) {
        self.regions = view.slots;
        self.region_colours = view.colours;
        self.labels = view.labels;
    }

    /// Sets the shape a mesh tool is drawn with (sent with every full snapshot).
    pub fn set_tool_shape(&mut self, shape: ToolShape) {
        self.tool_shape = Some(shape);
    }

    /// Sets the mesh's initial volume shown by the viewer.
    pub fn set_initial_volume(&mut self, v: f64) {
        self.initial_volume = v;
    }

    /// The controls, when they changed since the last call.
    pub fn new_controls(&mut self) -> Option<Controls> {
        let c = *self.controls.as_mut()?.read();
        if self.last_controls == Some(c) {
            return None;
        }
        self.last_controls = Some(c);
        Some(c)
    }

    /// Starts over (after the world was rebuilt): the next snapshot is a full one, and the next
    /// [`new_controls`](Self::new_controls) hands the controls over again (the rebuilt
    /// simulation starts from the scenario's values and must take the viewer's).
    pub fn restart(&mut self) {
        self.last_controls = None;
        for &t in &self.list {
            self.dirty[t as usize] = false;
        }
        self.list.clear();
        self.clear_backlog();
        self.full = true;
        self.smooth_reset = true;
    }

    /// Notes that the world's nodes moved (a soft body's step): the next snapshot is a full
    /// one, every visible triangle at the new positions.
    pub fn note_deformed(&mut self) {
        self.full = true;
    }

    /// Notes what the last step of `world` may have changed (`changed`: it created or erased
    /// nodes).
    ///
    /// # Bounded work
    /// O(5 x (candidates + backlog)); the backlog holds each tet at most once.
    pub fn note_step(&mut self, world: &World<'_>, changed: bool) {
        for &t in world.candidates() {
            if let Some(b) = self.in_backlog.get_mut(t.idx()) {
                if !*b {
                    *b = true;
                    self.backlog.push(t.0);
                }
            }
        }
        if changed && !self.full {
            let mesh = world.mesh();
            for i in 0..self.backlog.len() {
                let t = TetId(self.backlog[i]);
                self.mark(t);
                for f in 0..4u8 {
                    let n = mesh.neighbour(t, f);
                    if n != TetId::NONE {
                        self.mark(n);
                    }
                }
            }
        }
        if world.pending() == 0 {
            self.clear_backlog();
        }
    }

    fn mark(&mut self, t: TetId) {
        if let Some(d) = self.dirty.get_mut(t.idx()) {
            if !*d {
                *d = true;
                self.list.push(t.0);
            }
        }
    }

    fn clear_backlog(&mut self) {
        for &t in &self.backlog {
            self.in_backlog[t as usize] = false;
        }
        self.backlog.clear();
    }

    /// Publishes a snapshot when one is due (`now_ns` at least a period after the last) and
    /// the queue has room; otherwise keeps the changes for later. Returns `true` when one went
    /// out.
    pub fn publish(
        &mut self,
        world: &World<'_>,
        tool: ToolView,
        status: &SimStatus,
        now_ns: u64,
    ) -> bool {
        if self.seq > 0 && now_ns.saturating_sub(self.last_ns) < SNAPSHOT_PERIOD_NS {
            return false;
        }
        self.publish_now(world, tool, status, now_ns)
    }

    /// Publishes a snapshot now if the queue has room.
    pub fn publish_now(
        &mut self,
        world: &World<'_>,
        tool: ToolView,
        status: &SimStatus,
        now_ns: u64,
    ) -> bool {
        if self.queue.full_requested() {
            self.restart();
        }
        if self.queue.refuses() {
            return false;
        }
        let full = self.full;
        let mut status = *status;
        self.update_smooth(world, full);
        if let Some(sm) = &self.smooth {
            let st = sm.stats();
            status.smooth_saturations = st.vertices_full.saturating_add(st.queue_full);
            status.smooth_pending = sm.pending();
        }
        let patches = if full {
            full_patches_with(world, self.smooth.as_ref())
        } else {
            self.changed_patches(world)
        };
        let s = Snapshot {
            seq: self.seq + 1,
            full,
            patches,
            tool,
            status,
            initial_volume: self.initial_volume,
            tool_shape: self.tool_shape.clone().filter(|_| full),
            regions: self.regions.clone().filter(|_| full),
            region_colours: self.region_colours.clone().filter(|_| full),
            labels: self.labels.clone().filter(|_| full),
        };
        match self.queue.try_publish(s) {
            Ok(()) => {
                self.seq += 1;
                self.last_ns = now_ns;
                self.full = false;
                for &t in &self.list {
                    self.dirty[t as usize] = false;
                }
                self.list.clear();
                true
            }
            Err(_) => false,
        }
    }

    /// Makes, resets or updates the smooth normals (to completion for a full snapshot), and
    /// marks the tets whose slots changed.
    fn update_smooth(&mut self, world: &World<'_>, full: bool) {
        if let Some(store) = self.smooth_store.take() {
            self.smooth = LiveSmooth::new(store, world);
            self.smooth_reset = false;
        }
        let Some(sm) = self.smooth.as_mut() else {
            return;
        };
        if std::mem::take(&mut self.smooth_reset) {
            sm.reset(world);
        }
        if full {
            sm.catch_up(world, CATCH_UP_CALLS);
            return;
        }
        let (dirty, list) = (&mut self.dirty, &mut self.list);
        sm.update(world, SNAPSHOT_BUDGET, |t| {
            if let Some(d) = dirty.get_mut(t.idx()) {
                if !*d {
                    *d = true;
                    list.push(t.0);
                }
            }
        });
    }

    fn changed_patches(&self, world: &World<'_>) -> Vec<Patch> {
        let mut out = Vec::with_capacity(self.list.len());
        for &t in &self.list {
            let mut tris = Vec::new();
            let tet = TetId(t);
            world
                .hierarchy()
                .for_each_visible_in(world.mesh(), &[tet], None, |vt| {
                    tris.push(surf_tri(world, tet, vt.corners));
                });
            if let Some(sm) = &self.smooth {
                smooth_tris(sm, tet, &mut tris);
            }
            out.push(Patch { tet: t, tris });
        }
        out
    }
}

/// Calls of [`SNAPSHOT_BUDGET`] a full snapshot may spend catching the smooth normals up
/// (work left over is done at the next snapshots).
pub const CATCH_UP_CALLS: usize = 4096;

/// Gives `tris` (the faces of `tet`, as listed now) the smooth normals `sm` has for them.
fn smooth_tris(sm: &LiveSmooth<'_>, tet: TetId, tris: &mut [SurfTri]) {
    let corners: Vec<[[f32; 3]; 3]> = tris.iter().map(|t| t.corners).collect();
    sm.normals_of(tet, &corners, |i, n| {
        if let Some(t) = tris.get_mut(i) {
            t.normals = n;
        }
    });
}

/// Every visible triangle of `world`, one patch per coarse tet that has any.
///
/// # Bounded work
/// O(visible triangles x log) (a sort by tet).
pub fn full_patches(world: &World<'_>) -> Vec<Patch> {
    full_patches_with(world, None)
}

/// Every visible triangle of `world` as [`full_patches`], with the smooth normals of `smooth`
/// where it has them.
pub fn full_patches_with(world: &World<'_>, smooth: Option<&LiveSmooth<'_>>) -> Vec<Patch> {
    let mut all: Vec<(u32, SurfTri)> = Vec::new();
    world.hierarchy().for_each_visible(world.mesh(), |vt| {
        all.push((vt.tet.0, surf_tri(world, vt.tet, vt.corners)));
    });
    all.sort_by_key(|(t, _)| *t);
    let mut out: Vec<Patch> = Vec::new();
    for (t, tri) in all {
        match out.last_mut() {
            Some(p) if p.tet == t => p.tris.push(tri),
            _ => out.push(Patch {
                tet: t,
                tris: vec![tri],
            }),
        }
    }
    if let Some(sm) = smooth {
        for p in &mut out {
            smooth_tris(sm, TetId(p.tet), &mut p.tris);
        }
    }
    out
}

/// A visible triangle of `tet`, marked drilled unless it lies in one of the tet's boundary
/// faces (a refined leaf's face on the original surface is not drilled; a root's face inside
/// the mesh, bared when its neighbour was erased, is).
pub fn surf_tri(world: &World<'_>, tet: TetId, corners: [Vec3; 3]) -> SurfTri {
    let mesh = world.mesh();
    let mut original = false;
    for f in 0..4u8 {
        if !mesh.is_boundary_face(tet, f) {
            continue;
        }
        let p = mesh.face_positions(tet, f);
        let n = (p[1] - p[0]).cross(p[2] - p[0]);
        let scale = (p[1] - p[0]).length().max((p[2] - p[0]).length());
        let len = n.length();
        if len <= 0.0 {
            continue;
        }
        let n = n / len;
        let tol = 1e-4 * scale;
        if corners.iter().all(|c| n.dot(*c - p[0]).abs() <= tol) {
            original = true;
            break;
        }
    }
    SurfTri {
        corners: corners.map(|c| c.to_array()),
        normals: [[0.0; 3]; 3],
        drilled: !original,
    }
}

/// The tool as the viewer shows it, from the contact plane of the last step: the burr moved
/// back along the plane's normal by its depth.
pub fn tool_view(
    world: &World<'_>,
    position: Vec3,
    radius: f32,
    force: Vec3,
    drilling: bool,
) -> ToolView {
    let c = world.contact();
    let shown = if c.valid && c.depth > 0.0 && c.depth.is_finite() {
        position + c.normal * c.depth
    } else {
        position
    };
    ToolView {
        position,
        shown,
        radius,
        force,
        drilling,
        rotation: tetradrill_core::Quat::IDENTITY,
        shaft: None,
    }
}

/// `tv` with the drill's shaft (`shaft`, when the tool is a drill) along the axis of the
/// pose's `rotation` (`[w, x, y, z]`).
///
/// The tool is drawn moved out of the material as far as its deepest passive point is in
/// (along the passive points' summed push, `state`'s planes), unless the burr's own
/// displayed offset is larger: the shaft never visibly passes a face it is held at.
pub fn with_shaft(
    tv: ToolView,
    shaft: Option<tetradrill_core::force::DrillTool>,
    rotation: [f32; 4],
    state: &tetradrill_core::servo::DrillState,
) -> ToolView {
    let [w, x, y, z] = rotation;
    let q = tetradrill_core::Quat::from_xyzw(x, y, z, w);
    let mut shown = tv.shown;
    if let Some(d) = shaft {
        let axis = tetradrill_core::force::DrillTool::axis(q);
        let mut pos = [Vec3::ZERO; tetradrill_core::force::MAX_PASSIVE];
        let n = d
            .passive_positions(tv.position, axis, &mut pos)
            .min(state.count);
        let (mut push, mut deep) = (Vec3::ZERO, Vec::with_capacity(n));
        for (pt, &p) in state.points().iter().zip(&pos[..n]) {
            if let Some((c, nrm)) = pt.plane {
                let depth = d.shaft_radius - (p - c).dot(nrm);
                if depth > 0.0 {
                    push += nrm * depth;
                    deep.push((nrm, depth));
                }
            }
        }
        let dir = push.normalize_or_zero();
        let m = deep
            .iter()
            .map(|(nrm, depth)| depth * nrm.dot(dir))
            .fold(0.0f32, f32::max);
        if m > (tv.shown - tv.position).length() {
            shown = tv.position + dir * m;
        }
    }
    ToolView {
        shown,
        shaft: shaft.map(|d| super::handoff::ShaftView {
            axis: tetradrill_core::force::DrillTool::axis(q),
            from: d.burr_radius,
            length: d.shaft_length,
            radius: d.shaft_radius,
        }),
        ..tv
    }
}

/// The boundary triangles of a tool mesh in its own frame, counter-clockwise seen from outside
/// (each face's corners ordered along its outward normal).
pub fn tool_shape(mesh: &tetradrill_core::mesh::Mesh<'_>) -> ToolShape {
    let mut tris = Vec::new();
    for t in 0..mesh.tet_count() {
        let t = TetId(t as u32);
        for f in 0..4u8 {
            if !mesh.is_boundary_face(t, f) {
                continue;
            }
            let [a, b, c] = mesh.face_positions(t, f);
            let outward = (b - a).cross(c - a).dot(mesh.face_normal(t, f)) >= 0.0;
            tris.push(if outward { [a, b, c] } else { [a, c, b] });
        }
    }
    tris.into()
}

/// The scene of `world` as it is now: every visible triangle with its smooth normals, the
/// tool and the status.
pub fn scene_of(world: &World<'_>, tool: Option<ToolView>, status: SimStatus) -> Scene {
    scene_with_regions(world, tool, status, &RegionsView::default())
}

/// The regions as the viewer shows them: each coarse tet's colour slot, the scenario's
/// colours, and the regions on a grid for the clip plane's section.
#[derive(Debug, Clone, Default)]
pub struct RegionsView {
    /// Each coarse tet's colour slot (`None`: one region).
    pub slots: Option<RegionSlots>,
    /// The scenario's colours, in label order.
    pub colours: Option<super::handoff::RegionColours>,
    /// The regions on a grid.
    pub labels: Option<super::labels::LabelGridRef>,
}

impl RegionsView {
    /// The view of `mesh` with region `labels` (one per tet) and the scenario's `colours`.
    /// Work: the grid's cells over every tet's bounding box, once (not on the servo path).
    pub fn of(
        mesh: &tetradrill_core::mesh::Mesh<'_>,
        labels: &[i32],
        colours: Option<Vec<Option<[f32; 3]>>>,
    ) -> RegionsView {
        let slots = super::handoff::region_slots(labels);
        let labels = slots.as_ref().and_then(|s| {
            super::labels::LabelGrid::of_mesh(mesh, s, super::labels::GRID_CELLS)
                .map(std::sync::Arc::new)
        });
        RegionsView {
            slots,
            colours: colours.map(Into::into),
            labels,
        }
    }
}

/// [`scene_of`] with the regions coloured and gridded as `regions` says.
pub fn scene_with_regions(
    world: &World<'_>,
    tool: Option<ToolView>,
    status: SimStatus,
    regions: &RegionsView,
) -> Scene {
    let mut store = SmoothStore::for_world(world);
    let mut smooth = LiveSmooth::new(&mut store, world);
    let mut status = status;
    if let Some(sm) = smooth.as_mut() {
        sm.catch_up(world, CATCH_UP_CALLS);
        let st = sm.stats();
        status.smooth_saturations = st.vertices_full.saturating_add(st.queue_full);
        status.smooth_pending = sm.pending();
    }
    let mut scene = Scene::new();
    scene.apply(Snapshot {
        seq: 1,
        full: true,
        patches: full_patches_with(world, smooth.as_ref()),
        tool: tool.unwrap_or_default(),
        status,
        initial_volume: world.mesh().volume(),
        tool_shape: None,
        regions: regions.slots.clone(),
        region_colours: regions.colours.clone(),
        labels: regions.labels.clone(),
    });
    if tool.is_none() {
        scene.tool = None;
    }
    scene
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::viewer::handoff::controls;

    #[test]
    fn after_a_restart_the_controls_are_handed_over_again() {
        let q = SnapshotQueue::with_capacity(2);
        let initial = Controls {
            radius: 0.1,
            stiffness: 100.0,
            max_depth: 3,
            paused: false,
            reset: 0,
        };
        let (mut input, output) = controls(initial);
        let mut v = SimViewer::new(&q, Some(output), 4);
        assert_eq!(v.new_controls(), Some(initial));
        assert_eq!(v.new_controls(), None);
        let changed = Controls {
            radius: 0.2,
            paused: true,
            reset: 1,
            ..initial
        };
        input.write(changed);
        assert_eq!(v.new_controls(), Some(changed));
        assert_eq!(v.new_controls(), None);
        // The world was rebuilt from the scenario: it must take the viewer's values again.
        v.restart();
        assert_eq!(v.new_controls(), Some(changed));
    }
}
