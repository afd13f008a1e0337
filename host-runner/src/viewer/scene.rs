//! The viewer's copy of the surface: the vertex data of every visible triangle in fixed-size
//! chunks, so a changed coarse tet rewrites only its own chunks and the GPU buffer is updated
//! with one `glBufferSubData` per run of changed chunks.
//!
//! Allocator: chunk `i` holds [`CHUNK_TRIS`] triangles at vertices `[i*CHUNK_VERTS, ...)`. A
//! tet owns a list of chunks; the unused tail of its last chunk and every free chunk hold
//! zeroed (degenerate) triangles, which draw nothing, so the whole used range is drawn with one
//! call. Freed chunks are reused lowest first; the buffer doubles when it runs out (and is then
//! uploaded whole).

use std::cmp::Reverse;
use std::collections::{BinaryHeap, HashMap};

use tetradrill_core::Vec3;

use super::handoff::{Patch, Snapshot, SurfTri, ToolView};
use crate::viewer::handoff::SimStatus;

/// Triangles per chunk.
pub const CHUNK_TRIS: usize = 32;
/// Vertices per chunk.
pub const CHUNK_VERTS: usize = 3 * CHUNK_TRIS;
/// Floats per vertex: position, normal (the corner's smooth normal, else the face's), drilled
/// flag.
pub const VERTEX_FLOATS: usize = 7;
/// Floats per chunk.
pub const CHUNK_FLOATS: usize = CHUNK_VERTS * VERTEX_FLOATS;

/// The viewer's state of the surface, the tool and the status.
#[derive(Debug, Default)]
pub struct Scene {
    data: Vec<f32>,
    chunks: usize,
    high: usize,
    free: BinaryHeap<Reverse<u32>>,
    owned: HashMap<u32, Owned>,
    dirty: Vec<bool>,
    dirty_any: bool,
    grown: bool,
    tris: usize,
    drilled: usize,
    /// Last tool and force, if any.
    pub tool: Option<ToolView>,
    /// Last simulation status.
    pub status: SimStatus,
    /// Initial volume of the mesh.
    pub initial_volume: f64,
    /// Sequence number of the last snapshot applied.
    pub seq: u64,
    /// Snapshots applied.
    pub applied: u64,
    /// Bounds of every triangle ever shown (for the camera), if any.
    pub bounds: Option<(Vec3, Vec3)>,
    /// A mesh tool's shape (drawn instead of the burr's sphere), once a snapshot gave one.
    pub tool_shape: Option<super::handoff::ToolShape>,
    /// The colour slot of each coarse tet's region, once a snapshot gave them (none: every
    /// tet in slot 0, the surface colour).
    pub regions: Option<super::handoff::RegionSlots>,
    /// The colour the scenario gives each region, once a snapshot gave them.
    pub region_colours: Option<super::handoff::RegionColours>,
    /// The regions on a grid (the clip plane's section), once a snapshot gave them.
    pub labels: Option<super::labels::LabelGridRef>,
    /// Bounds of every drilled triangle ever shown, if any (the tool's work area).
    pub drilled_bounds: Option<(Vec3, Vec3)>,
}

impl Scene {
    /// An empty scene.
    pub fn new() -> Self {
        Self::default()
    }

    /// Applies one snapshot.
    pub fn apply(&mut self, s: Snapshot) {
        if s.full {
            self.clear();
        }
        if s.regions.is_some() {
            self.regions = s.regions;
        }
        if s.region_colours.is_some() {
            self.region_colours = s.region_colours;
        }
        if s.labels.is_some() {
            self.labels = s.labels;
        }
        for p in s.patches {
            self.set_patch(p);
        }
        self.tool = Some(s.tool);
        if s.tool_shape.is_some() {
            self.tool_shape = s.tool_shape;
        }
        self.status = s.status;
        self.initial_volume = s.initial_volume;
        self.seq = s.seq;
        self.applied += 1;
    }

    /// Drops every triangle (the bounds seen so far stay; the drilled ones are made again by
    /// the patches that follow).
    pub fn clear(&mut self) {
        self.drilled_bounds = None;
        self.owned.clear();
        self.free.clear();
        self.data.iter_mut().for_each(|x| *x = 0.0);
        for i in 0..self.chunks {
            self.free.push(Reverse(i as u32));
        }
        self.high = 0;
        self.tris = 0;
        self.drilled = 0;
        self.grown = true;
    }

    /// Replaces the triangles of `p.tet` with `p.tris`.
    pub fn set_patch(&mut self, p: Patch) {
        let old = self.owned.remove(&p.tet).unwrap_or_default();
        self.tris -= old.tris;
        self.drilled -= old.drilled;
        let old = old.chunks;
        let need = p.tris.len().div_ceil(CHUNK_TRIS);
        let slot = self.region_slot(p.tet);
        let mut mine = old;
        while mine.len() > need {
            if let Some(c) = mine.pop() {
                self.zero_chunk(c);
                self.free.push(Reverse(c));
            }
        }
        while mine.len() < need {
            let c = self.alloc_chunk();
            mine.push(c);
        }
        for (k, &c) in mine.iter().enumerate() {
            let lo = k * CHUNK_TRIS;
            let hi = (lo + CHUNK_TRIS).min(p.tris.len());
            self.write_chunk(c, &p.tris[lo..hi], slot);
        }
        let drilled = p.tris.iter().filter(|t| t.drilled).count();
        self.tris += p.tris.len();
        self.drilled += drilled;
        for t in &p.tris {
            for c in t.corners {
                let v = Vec3::from_array(c);
                grow(&mut self.bounds, v);
                if t.drilled {
                    grow(&mut self.drilled_bounds, v);
                }
            }
        }
        if !mine.is_empty() {
            self.owned.insert(
                p.tet,
                Owned {
                    chunks: mine,
                    tris: p.tris.len(),
                    drilled,
                },
            );
        }
    }

    fn alloc_chunk(&mut self) -> u32 {
        let c = match self.free.pop() {
            Some(Reverse(c)) => c,
            None => {
                let old = self.chunks;
                let new = (old * 2).max(64);
                self.data.resize(new * CHUNK_FLOATS, 0.0);
                self.dirty.resize(new, false);
                for i in old + 1..new {
                    self.free.push(Reverse(i as u32));
                }
                self.chunks = new;
                self.grown = true;
                old as u32
            }
        };
        self.high = self.high.max(c as usize + 1);
        c
    }

    fn zero_chunk(&mut self, c: u32) {
        let base = c as usize * CHUNK_FLOATS;
        self.data[base..base + CHUNK_FLOATS]
            .iter_mut()
            .for_each(|x| *x = 0.0);
        self.mark(c);
    }

    /// The colour slot of coarse tet `tet` (0 without regions).
    pub fn region_slot(&self, tet: u32) -> u8 {
        self.regions
            .as_ref()
            .and_then(|r| r.get(tet as usize).copied())
            .unwrap_or(0)
    }

    /// Writes `tris` into chunk `c`; each vertex's flag is `drilled + 2 slot` (the shader
    /// takes both apart).
    fn write_chunk(&mut self, c: u32, tris: &[SurfTri], slot: u8) {
        let base = c as usize * CHUNK_FLOATS;
        let out = &mut self.data[base..base + CHUNK_FLOATS];
        out.iter_mut().for_each(|x| *x = 0.0);
        for (i, t) in tris.iter().enumerate() {
            let [a, b, cc] = t.corners.map(Vec3::from_array);
            let flat = (b - a).cross(cc - a).normalize_or_zero();
            for (k, p) in [a, b, cc].into_iter().enumerate() {
                let o = (3 * i + k) * VERTEX_FLOATS;
                let smooth = Vec3::from_array(t.normals[k]);
                let n = if smooth == Vec3::ZERO { flat } else { smooth };
                out[o..o + 7].copy_from_slice(&[
                    p.x,
                    p.y,
                    p.z,
                    n.x,
                    n.y,
                    n.z,
                    if t.drilled { 1.0 } else { 0.0 } + 2.0 * slot as f32,
                ]);
            }
        }
        self.mark(c);
    }

    fn mark(&mut self, c: u32) {
        self.dirty[c as usize] = true;
        self.dirty_any = true;
    }

    /// The tool's work area: the drilled faces and the tool, with a margin of a few tool
    /// radii (at least a tenth of the scene's size); before anything is drilled, the tool
    /// with a margin of six radii (at least a sixth of the scene). `None` without a tool and
    /// without drilled faces.
    pub fn work_area(&self) -> Option<(Vec3, Vec3)> {
        let diag = self.bounds.map_or(1.0, |(lo, hi)| (hi - lo).length());
        let tool = self.tool.map(|t| (t.shown, t.radius));
        let (mut area, pad) = match (self.drilled_bounds, tool) {
            (Some(d), _) => (d, (3.0 * tool.map_or(0.0, |t| t.1)).max(0.1 * diag)),
            (None, Some((p, r))) => ((p, p), (6.0 * r).max(diag / 6.0)),
            (None, None) => return None,
        };
        if let Some((p, _)) = tool.filter(|_| self.drilled_bounds.is_some()) {
            // A tool far from the work (lifted away) does not widen it past the scene.
            if self.bounds.is_none_or(|(lo, hi)| {
                p.cmpge(lo - diag * 0.1).all() && p.cmple(hi + diag * 0.1).all()
            }) {
                area = (area.0.min(p), area.1.max(p));
            }
        }
        Some((area.0 - Vec3::splat(pad), area.1 + Vec3::splat(pad)))
    }

    /// Visible triangles held.
    pub fn triangle_count(&self) -> usize {
        self.tris
    }

    /// Drilled triangles held.
    pub fn drilled_count(&self) -> usize {
        self.drilled
    }

    /// Coarse tets with triangles.
    pub fn patch_count(&self) -> usize {
        self.owned.len()
    }

    /// Vertices to draw (the used range, degenerate padding included).
    pub fn draw_vertices(&self) -> usize {
        self.high * CHUNK_VERTS
    }

    /// All vertex data (`chunks * CHUNK_FLOATS` floats).
    pub fn data(&self) -> &[f32] {
        &self.data
    }

    /// Chunks allocated.
    pub fn capacity_chunks(&self) -> usize {
        self.chunks
    }

    /// What the GPU copy needs: `Whole` after the buffer grew or was cleared, else the runs of
    /// changed chunks `(first, count)`. Clears the marks.
    pub fn take_updates(&mut self) -> Updates {
        if self.grown {
            self.grown = false;
            self.dirty_any = false;
            self.dirty.iter_mut().for_each(|d| *d = false);
            return Updates::Whole;
        }
        if !self.dirty_any {
            return Updates::Runs(Vec::new());
        }
        self.dirty_any = false;
        let mut runs: Vec<(usize, usize)> = Vec::new();
        for i in 0..self.chunks {
            if std::mem::take(&mut self.dirty[i]) {
                match runs.last_mut() {
                    Some((s, n)) if *s + *n == i => *n += 1,
                    _ => runs.push((i, 1)),
                }
            }
        }
        Updates::Runs(runs)
    }
}

/// Widens `b` to hold `v`.
fn grow(b: &mut Option<(Vec3, Vec3)>, v: Vec3) {
    *b = Some(match *b {
        None => (v, v),
        Some((lo, hi)) => (lo.min(v), hi.max(v)),
    });
}

/// What to upload.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Updates {
    /// The whole buffer (it grew or was cleared).
    Whole,
    /// Runs of changed chunks, `(first chunk, chunks)`.
    Runs(Vec<(usize, usize)>),
}

/// The chunks of one coarse tet and what they hold.
#[derive(Debug, Default)]
struct Owned {
    chunks: Vec<u32>,
    tris: usize,
    drilled: usize,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::viewer::handoff::ToolView;

    fn tri(z: f32, drilled: bool) -> SurfTri {
        SurfTri {
            corners: [[0.0, 0.0, z], [1.0, 0.0, z], [0.0, 1.0, z]],
            normals: [[0.0; 3]; 3],
            drilled,
        }
    }

    #[test]
    fn patches_reuse_chunks_and_only_changed_runs_upload() {
        let mut s = Scene::new();
        s.set_patch(Patch {
            tet: 1,
            tris: vec![tri(0.0, false); 40],
        });
        s.set_patch(Patch {
            tet: 2,
            tris: vec![tri(1.0, false); 5],
        });
        assert_eq!(s.take_updates(), Updates::Whole);
        assert_eq!((s.triangle_count(), s.patch_count()), (45, 2));
        assert_eq!(s.draw_vertices(), 3 * CHUNK_VERTS);
        // Tet 1 shrinks to one chunk: its second chunk is zeroed and freed.
        s.set_patch(Patch {
            tet: 1,
            tris: vec![tri(0.0, true); 3],
        });
        assert_eq!(s.take_updates(), Updates::Runs(vec![(0, 2)]));
        assert_eq!((s.triangle_count(), s.drilled_count()), (8, 3));
        // The freed chunk is reused first.
        s.set_patch(Patch {
            tet: 7,
            tris: vec![tri(2.0, true); 1],
        });
        assert_eq!(s.take_updates(), Updates::Runs(vec![(1, 1)]));
        s.set_patch(Patch {
            tet: 2,
            tris: Vec::new(),
        });
        assert_eq!(s.patch_count(), 2);
        assert_eq!(s.triangle_count(), 4);
        assert_eq!(s.take_updates(), Updates::Runs(vec![(2, 1)]));
        assert_eq!(s.take_updates(), Updates::Runs(Vec::new()));
    }

    #[test]
    fn the_work_area_is_the_drilled_faces_and_the_tool_with_a_margin() {
        let mut s = Scene::new();
        assert_eq!(s.work_area(), None);
        // A scene 10 wide; nothing drilled: the tool with six radii (at least a sixth of the
        // scene's diagonal).
        s.set_patch(Patch {
            tet: 0,
            tris: vec![SurfTri {
                corners: [[0.0, 0.0, 0.0], [10.0, 0.0, 0.0], [0.0, 10.0, 0.0]],
                normals: [[0.0; 3]; 3],
                drilled: false,
            }],
        });
        s.tool = Some(ToolView {
            shown: Vec3::new(5.0, 5.0, 1.0),
            radius: 0.5,
            ..ToolView::default()
        });
        let diag = Vec3::new(10.0, 10.0, 0.0).length();
        let (lo, hi) = s.work_area().expect("the tool");
        let pad = (6.0 * 0.5f32).max(diag / 6.0);
        assert!((lo - Vec3::new(5.0 - pad, 5.0 - pad, 1.0 - pad)).length() < 1e-5);
        assert!((hi - Vec3::new(5.0 + pad, 5.0 + pad, 1.0 + pad)).length() < 1e-5);
        // A drilled triangle: it and the tool, with three radii (at least a tenth of the
        // diagonal).
        s.set_patch(Patch {
            tet: 1,
            tris: vec![tri(0.0, true)],
        });
        let (lo, hi) = s.work_area().expect("drilled");
        let pad = (3.0 * 0.5f32).max(0.1 * diag);
        assert!((lo - Vec3::new(-pad, -pad, -pad)).length() < 1e-5, "{lo}");
        assert!(
            (hi - Vec3::new(5.0 + pad, 5.0 + pad, 1.0 + pad)).length() < 1e-5,
            "{hi}"
        );
        // A tool lifted far away does not widen it.
        s.tool = Some(ToolView {
            shown: Vec3::new(5.0, 5.0, 100.0),
            radius: 0.5,
            ..ToolView::default()
        });
        let (_, hi) = s.work_area().expect("drilled");
        assert!(
            (hi - Vec3::new(1.0 + pad, 1.0 + pad, pad)).length() < 1e-5,
            "{hi}"
        );
    }
}
