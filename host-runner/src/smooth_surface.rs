//! The drilled surface with shared vertices and smooth normals, from the core's surface
//! exporter with [`SmoothNormals`]: what `replay --surface` writes as an OBJ.

use std::collections::HashMap;
use std::fmt::Write as _;

use tetradrill_core::hierarchy::{
    SlotRange, SmoothNormals, SmoothSizes, SmoothStats, SmoothStorage, SurfaceBuffers,
    SurfaceExport, SurfaceSizes, SurfaceStorage,
};
use tetradrill_core::servo::World;
use tetradrill_core::storage::{Block, Line};
use tetradrill_core::Vec3;

/// One triangle of a [`SmoothSurface`]: indices of its corners' positions and normals
/// (counter-clockwise seen from outside the material), its region label and whether it was
/// drilled (it lies on no boundary face of the coarse mesh).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SmoothFace {
    /// Indices into [`SmoothSurface::positions`].
    pub vertices: [u32; 3],
    /// Indices into [`SmoothSurface::normals`].
    pub normals: [u32; 3],
    /// Its coarse tet's region label.
    pub label: i32,
    /// Drilled (`true`) or the mesh's untouched boundary.
    pub drilled: bool,
}

/// The drilled surface with shared vertices (the subdivision lattice's exact keys) and
/// per-corner smooth normals within the crease angle ([`SmoothNormals`]).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SmoothSurface {
    /// Shared vertex positions.
    pub positions: Vec<Vec3>,
    /// Distinct corner normals (unit).
    pub normals: Vec<Vec3>,
    /// Triangles.
    pub faces: Vec<SmoothFace>,
    /// The smooth normals' counters: nothing short when `vertices_full` and `queue_full`
    /// are 0.
    pub stats: SmoothStats,
}

/// Work units an update call may spend (the export runs to completion here).
const BUDGET: u32 = 1 << 20;

impl SmoothSurface {
    /// The visible faces of `world` (labelled from `tet_labels`, one a coarse tet, 0 where it
    /// has none) with smooth normals of crease angle `crease_degrees`.
    ///
    /// # Bounded work
    /// O(visible faces x depth) to list them, plus the smooth normals' O(faces at a vertex^2)
    /// a vertex.
    pub fn of(world: &World<'_>, tet_labels: &[i32], crease_degrees: f32) -> Self {
        let (hier, mesh) = (world.hierarchy(), world.mesh());
        let mut faces = 0usize;
        hier.for_each_visible(mesh, |_| faces += 1);
        let slots = faces.max(1);
        let sizes = SurfaceSizes::new(slots, mesh.tet_count());
        let ssizes = SmoothSizes::for_slots(slots);
        let mut lines = vec![Line::ZERO; sizes.lines().unwrap_or(0)];
        let mut slines = vec![Line::ZERO; ssizes.lines().unwrap_or(0)];
        let made = SurfaceStorage::carve(&sizes, &mut Block::from_lines(&mut lines))
            .ok()
            .zip(SmoothStorage::carve(&ssizes, &mut Block::from_lines(&mut slines)).ok())
            .and_then(|(st, sst)| {
                let smooth = SmoothNormals::new(sst, crease_degrees).ok()?;
                SurfaceExport::new(st, hier).ok()?.with_smooth(smooth).ok()
            });
        let Some(mut ex) = made else {
            return Self::default();
        };
        let n = 3 * slots;
        let (mut p, mut nr, mut lab, mut ix) = (
            vec![[0.0f32; 3]; n],
            vec![[0.0f32; 3]; n],
            vec![0i32; n],
            vec![0u32; n],
        );
        let mut ranges = [SlotRange::default(); 4];
        let mut out = SurfaceBuffers {
            positions: &mut p,
            normals: &mut nr,
            labels: &mut lab,
            indices: &mut ix,
            ranges: &mut ranges,
        };
        let label = |t: tetradrill_core::TetId| tet_labels.get(t.idx()).copied().unwrap_or(0);
        // Every face has a slot: the export catches up in a bounded number of calls.
        for _ in 0..10_000 {
            match ex.update(hier, mesh, label, BUDGET, &mut out) {
                Ok(r) if r.pending > 0 => {}
                _ => break,
            }
        }
        let Some(sm) = ex.smooth() else {
            return Self::default();
        };
        let mut s = Self {
            stats: sm.stats(),
            ..Self::default()
        };
        let mut vmap: HashMap<u32, u32> = HashMap::new();
        let mut nmap: HashMap<[u32; 3], u32> = HashMap::new();
        for slot in 0..slots {
            let Some(verts) = sm.slot_vertices(slot as u32) else {
                continue;
            };
            let mut f = SmoothFace {
                vertices: [0; 3],
                normals: [0; 3],
                label: lab[3 * slot],
                drilled: sm.slot_drilled(slot as u32),
            };
            for (k, &v) in verts.iter().enumerate() {
                let at = 3 * slot + k;
                let pos = Vec3::from(p[at]);
                // A corner that found no shared vertex gets one of its own.
                f.vertices[k] = if v == u32::MAX {
                    s.positions.push(pos);
                    s.positions.len() as u32 - 1
                } else {
                    *vmap.entry(v).or_insert_with(|| {
                        s.positions.push(pos);
                        s.positions.len() as u32 - 1
                    })
                };
                let nb = nr[at].map(f32::to_bits);
                f.normals[k] = *nmap.entry(nb).or_insert_with(|| {
                    s.normals.push(Vec3::from(nr[at]));
                    s.normals.len() as u32 - 1
                });
            }
            s.faces.push(f);
        }
        s
    }

    /// Triangles.
    pub fn triangles(&self) -> usize {
        self.faces.len()
    }

    /// The surface as a Wavefront OBJ: shared vertices (`v`), normals (`vn`), the drilled
    /// faces in group `drilled` and the mesh's untouched boundary in group `boundary`
    /// (`f a//na b//nb c//nc`, 1-based).
    pub fn to_obj(&self) -> String {
        let mut out = String::from(
            "# tetradrill drilled surface: visible faces, shared vertices, smooth normals\n",
        );
        for p in &self.positions {
            let _ = writeln!(out, "v {} {} {}", p.x, p.y, p.z);
        }
        for n in &self.normals {
            let _ = writeln!(out, "vn {} {} {}", n.x, n.y, n.z);
        }
        for (group, drilled) in [("drilled", true), ("boundary", false)] {
            let _ = writeln!(out, "g {group}");
            for f in self.faces.iter().filter(|f| f.drilled == drilled) {
                let [a, b, c] = f.vertices.map(|v| v + 1);
                let [na, nb, nc] = f.normals.map(|n| n + 1);
                let _ = writeln!(out, "f {a}//{na} {b}//{nb} {c}//{nc}");
            }
        }
        out
    }
}
