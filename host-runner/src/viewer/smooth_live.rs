//! Smooth per-corner normals for the viewer's surface, kept up to date while a run drills: the
//! core's [`SurfaceExport`] with [`SmoothNormals`] over storage sized once
//! ([`SmoothStore::for_world`]), brought a bounded step closer at each snapshot
//! ([`LiveSmooth::update`]). The viewer's patches keep their exact triangles from the
//! hierarchy; each takes its corners' normals from the exporter's slot of the same face, or
//! its own flat normal where the exporter has not caught up with the face (or had no slot
//! for it).

use std::collections::HashMap;

use tetradrill_core::hierarchy::{
    SlotRange, SmoothNormals, SmoothSizes, SmoothStats, SmoothStorage, SurfaceBuffers,
    SurfaceExport, SurfaceSizes, SurfaceStorage,
};
use tetradrill_core::servo::World;
use tetradrill_core::storage::{Block, Line};
use tetradrill_core::TetId;

/// Work units one [`LiveSmooth::update`] may spend (a vertex of `F` faces costs about `F^2`).
pub const SNAPSHOT_BUDGET: u32 = 1 << 16;

/// Triangle slots for a surface of `faces` visible faces: room for the drilled surface to
/// grow eightfold, at least 2^16.
pub fn slots_for(faces: usize) -> usize {
    faces.saturating_mul(8).max(1 << 16)
}

/// The storage of a [`LiveSmooth`], allocated once: the exporter's and the smooth normals'
/// lines.
#[derive(Debug)]
pub struct SmoothStore {
    slots: usize,
    tets: usize,
    surface: Vec<Line>,
    smooth: Vec<Line>,
}

impl SmoothStore {
    /// Storage for `slots` triangle slots over a mesh of `tets` coarse tets.
    pub fn new(slots: usize, tets: usize) -> Self {
        let sizes = SurfaceSizes::new(slots, tets);
        let ssizes = SmoothSizes::for_slots(slots);
        Self {
            slots,
            tets,
            surface: vec![Line::ZERO; sizes.lines().unwrap_or(0)],
            smooth: vec![Line::ZERO; ssizes.lines().unwrap_or(0)],
        }
    }

    /// Storage for `world` ([`slots_for`] its visible faces now).
    pub fn for_world(world: &World<'_>) -> Self {
        let mut faces = 0usize;
        world
            .hierarchy()
            .for_each_visible(world.mesh(), |_| faces += 1);
        Self::new(slots_for(faces), world.mesh().tet_count())
    }
}

/// The exporter with smooth normals and the buffers it writes (see the module's docs).
#[derive(Debug)]
pub struct LiveSmooth<'s> {
    ex: SurfaceExport<'s>,
    positions: Vec<[f32; 3]>,
    normals: Vec<[f32; 3]>,
    labels: Vec<i32>,
    indices: Vec<u32>,
    /// The coarse tet each slot held when last written (`u32::MAX`: none).
    owner: Vec<u32>,
    ranges: [SlotRange; 8],
    pending: u32,
}

impl<'s> LiveSmooth<'s> {
    /// The exporter over `store` for `world`, with crease angle
    /// [`SmoothNormals::CREASE_DEGREES`]; `None` when the storage does not fit the mesh.
    pub fn new(store: &'s mut SmoothStore, world: &World<'_>) -> Option<Self> {
        let slots = store.slots;
        let sizes = SurfaceSizes::new(slots, store.tets);
        let ssizes = SmoothSizes::for_slots(slots);
        let st = SurfaceStorage::carve(&sizes, &mut Block::from_lines(&mut store.surface)).ok()?;
        let sst = SmoothStorage::carve(&ssizes, &mut Block::from_lines(&mut store.smooth)).ok()?;
        let smooth = SmoothNormals::new(sst, SmoothNormals::CREASE_DEGREES).ok()?;
        let ex = SurfaceExport::new(st, world.hierarchy())
            .ok()?
            .with_smooth(smooth)
            .ok()?;
        let n = 3 * slots;
        Some(Self {
            ex,
            positions: vec![[0.0; 3]; n],
            normals: vec![[0.0; 3]; n],
            labels: vec![0; n],
            indices: vec![0; n],
            owner: vec![u32::MAX; slots],
            ranges: [SlotRange::default(); 8],
            pending: 1,
        })
    }

    /// Starts over on `world` (rebuilt) in the same storage.
    ///
    /// # Bounded work
    /// O(storage).
    pub fn reset(&mut self, world: &World<'_>) {
        if self.ex.reset(world.hierarchy()).is_err() {
            return;
        }
        self.positions.fill([0.0; 3]);
        self.normals.fill([0.0; 3]);
        self.owner.fill(u32::MAX);
        self.pending = 1;
    }

    /// Brings the normals a step closer to `world`'s visible faces, for about `budget` work
    /// units; `mark` receives each coarse tet whose faces' slots were written (the face put
    /// in, freed, or its normals changed), the tet that held a freed slot too.
    ///
    /// # Bounded work
    /// The exporter's bound for `budget`, plus O(slots written).
    pub fn update(&mut self, world: &World<'_>, budget: u32, mut mark: impl FnMut(TetId)) {
        let mut out = SurfaceBuffers {
            positions: &mut self.positions,
            normals: &mut self.normals,
            labels: &mut self.labels,
            indices: &mut self.indices,
            ranges: &mut self.ranges,
        };
        let Ok(rep) = self
            .ex
            .update(world.hierarchy(), world.mesh(), |_| 0, budget, &mut out)
        else {
            return;
        };
        self.pending = rep.pending;
        for r in &self.ranges[..(rep.ranges as usize).min(self.ranges.len())] {
            for s in r.first..r.first.saturating_add(r.count) {
                let Some(o) = self.owner.get_mut(s as usize) else {
                    continue;
                };
                if *o != u32::MAX {
                    mark(TetId(*o));
                }
                *o = self.ex.slot_tet(s).map_or(u32::MAX, |t| t.0);
                if *o != u32::MAX {
                    mark(TetId(*o));
                }
            }
        }
    }

    /// Updates until nothing is pending (at most `calls` calls of [`SNAPSHOT_BUDGET`]).
    pub fn catch_up(&mut self, world: &World<'_>, calls: usize) {
        for _ in 0..calls {
            if self.pending == 0 {
                break;
            }
            self.update(world, SNAPSHOT_BUDGET, |_| {});
        }
    }

    /// Work left for later updates (0: every face and normal is current).
    pub fn pending(&self) -> u32 {
        self.pending
    }

    /// The smooth normals' counters (what went short).
    pub fn stats(&self) -> SmoothStats {
        self.ex
            .smooth()
            .map(SmoothNormals::stats)
            .unwrap_or_default()
    }

    /// The corners' normals of the faces of `tet`, `tris` as the hierarchy lists them now:
    /// `put(i, normals)` for each face `i` that the exporter holds in a slot of `tet` with the
    /// same corners (in any rotation; `normals` in the order of `tris[i]`); the others are
    /// left alone (the exporter has not caught up with them, or had no slot).
    ///
    /// # Bounded work
    /// O(tris + the tet's slots), a hash map of the slots.
    pub fn normals_of(
        &self,
        tet: TetId,
        tris: &[[[f32; 3]; 3]],
        mut put: impl FnMut(usize, [[f32; 3]; 3]),
    ) {
        let corner = |s: u32, k: usize| {
            let at = 3 * s as usize + k;
            self.positions
                .get(at)
                .zip(self.normals.get(at))
                .map(|(p, n)| (*p, *n))
        };
        let mut held: HashMap<[[u32; 3]; 3], u32> = HashMap::new();
        for s in self.ex.tet_slots(tet) {
            if let (Some(a), Some(b), Some(c)) = (corner(s, 0), corner(s, 1), corner(s, 2)) {
                held.insert(canonical([a.0, b.0, c.0]), s);
            }
        }
        for (i, corners) in tris.iter().enumerate() {
            let Some(&s) = held.get(&canonical(*corners)) else {
                continue;
            };
            let mut out = [[0.0f32; 3]; 3];
            for (k, c) in corners.iter().enumerate() {
                let n = (0..3)
                    .filter_map(|j| corner(s, j))
                    .find(|(p, _)| p == c)
                    .map(|(_, n)| n);
                out[k] = n.unwrap_or([0.0; 3]);
            }
            put(i, out);
        }
    }
}

/// A triangle's corners' bits, rotated to start at the smallest (the orientation kept).
fn canonical(c: [[f32; 3]; 3]) -> [[u32; 3]; 3] {
    let b = c.map(|p| p.map(f32::to_bits));
    let first = (0..3).min_by_key(|&k| b[k]).unwrap_or(0);
    [b[first], b[(first + 1) % 3], b[(first + 2) % 3]]
}
