//! The front door for drilling: a [`Setup`] in, a mesh drilled tick by tick out.
//!
//! [`Drilling::new`] reads the mesh once and allocates every buffer its world needs (sized
//! for the tool on that mesh); [`Drilling::start`] makes a fresh world over them, a
//! [`DrillRun`], whose [`DrillRun::tick`] takes the tool's pose and gives the force for the
//! hand. What was removed, by region, and the drilled surface as triangles, come from the
//! run at any tick.
//!
//! ```
//! use tetradrill::prelude::*;
//!
//! let setup = Setup::new("builtin:block:4", Tool::sphere(0.1));
//! let mut drilling = Drilling::new(&setup)?;
//! let mut run = drilling.start()?;
//! // Down through the top face (z = 0.5) with the drill on, 0.2 deep after 200 ticks.
//! let mut force = Vec3::ZERO;
//! for i in 0..200 {
//!     let z = 0.6 - 0.3 * i as f32 / 200.0;
//!     force = run.tick(&Pose::drilling(Vec3::new(0.05, 0.05, z)));
//! }
//! assert!(force.z > 0.0, "the material pushes back up: {force}");
//! assert!(run.removed_volume() > 0.0);
//! assert!(run.surface().triangles() > 0);
//! # Ok::<(), tetradrill::Error>(())
//! ```

use tetradrill_core::force::ToolState;
use tetradrill_core::servo::{SimReport, World};
use tetradrill_core::Vec3;

use crate::engine::{self, EngineStorage, ShaftState, TickParams};
use crate::error::Error;
use crate::meshio::LoadedMesh;
use crate::setup::Setup;
use crate::traces::Pose;

/// A mesh ready to drill: its storage allocated once, its regions set, the tick's
/// parameters worked out.
#[derive(Debug)]
pub struct Drilling {
    store: EngineStorage,
    params: TickParams,
    /// Each tet's region label, in the world's tet order.
    tet_labels: Vec<i32>,
}

impl Drilling {
    /// Reads `setup`'s mesh and allocates the world's storage.
    ///
    /// # Errors
    /// A mesh that cannot be read ([`Error::Mesh`]), a value out of range
    /// ([`Error::Setup`]), a tet-mesh tool ([`Error::Unsupported`]: see
    /// [`crate::pen::PenRig`]), a soft body ([`Error::Unsupported`]: a [`DrillRun`] drills
    /// a rigid mesh; `tetradrill replay` and `run` drill a soft one), storage the heap
    /// refuses.
    pub fn new(setup: &Setup) -> Result<Self, Error> {
        let mesh = setup.mesh.load()?;
        Self::with_mesh(setup, mesh)
    }

    /// As [`Drilling::new`], over a mesh already loaded (its regions' labels are taken from
    /// it).
    ///
    /// # Errors
    /// As [`Drilling::new`].
    pub fn with_mesh(setup: &Setup, mesh: LoadedMesh) -> Result<Self, Error> {
        setup.check()?;
        if setup.soft().is_some() {
            // Drilled as rigid, the set-up's elasticity would be silently ignored.
            return Err(Error::Unsupported(
                "a soft body: Drilling drills a rigid mesh; drill a soft one with \
                 `tetradrill replay` or `run` (the set-up's body = soft)"
                    .into(),
            ));
        }
        let params = TickParams::of(setup)?;
        let mut store = EngineStorage::new(mesh.mesh, setup)?;
        store.set_labels(&mesh.labels, setup)?;
        Ok(Self {
            store,
            params,
            tet_labels: mesh.labels,
        })
    }

    /// The tick's parameters (the burr's radius, the force law, the drill's budget).
    pub fn params(&self) -> &TickParams {
        &self.params
    }

    /// The storage (its sizes, the regions' labels).
    pub fn storage(&self) -> &EngineStorage {
        &self.store
    }

    /// A fresh, untouched world over this storage: the mesh as loaded, nothing drilled.
    ///
    /// # Errors
    /// [`Error::World`] when the core refuses the storage.
    pub fn start(&mut self) -> Result<DrillRun<'_>, Error> {
        let labels = self.store.region_labels().to_vec();
        let world = self.store.world()?;
        Ok(DrillRun {
            world,
            params: self.params,
            tool: ToolState::default(),
            shaft: ShaftState::default(),
            region_labels: labels,
            tet_labels: &self.tet_labels,
            last: SimReport::default(),
        })
    }
}

/// A world being drilled, tick by tick.
#[derive(Debug)]
pub struct DrillRun<'a> {
    world: World<'a>,
    params: TickParams,
    tool: ToolState,
    shaft: ShaftState,
    region_labels: Vec<i32>,
    tet_labels: &'a [i32],
    last: SimReport,
}

impl<'a> DrillRun<'a> {
    /// One 1 ms tick at `pose`: the simulation step (candidates, budgeted drilling when the
    /// pose's drill button is down, the contact with the drilled surface), then the servo's
    /// force on the hand, newtons.
    ///
    /// # Bounded work
    /// The core's: the drill's budget per tick and the contact search's node bound.
    pub fn tick(&mut self, pose: &Pose) -> Vec3 {
        let (f, rep) = engine::tick_tool(
            &mut self.world,
            &mut self.tool,
            &mut self.shaft,
            &self.params,
            pose,
        );
        self.last = rep;
        f
    }

    /// What the last tick's simulation step did.
    pub fn last_step(&self) -> &SimReport {
        &self.last
    }

    /// Volume removed so far, cubic mesh units.
    pub fn removed_volume(&self) -> f64 {
        self.world.hierarchy().removed_volume()
    }

    /// The mesh's volume before drilling, cubic mesh units.
    pub fn initial_volume(&self) -> f64 {
        self.world.mesh().volume()
    }

    /// Volume removed from each region, by region label, in label order (one entry, label
    /// 0 or the mesh's one label, on a mesh without labels).
    pub fn removed_by_region(&self) -> Vec<(i32, f64)> {
        match self.world.regions() {
            Some(r) => self
                .region_labels
                .iter()
                .zip(r.table())
                .map(|(&l, reg)| (l, reg.removed()))
                .collect(),
            None => vec![(0, self.removed_volume())],
        }
    }

    /// The drilled surface now: every visible face, with its region label.
    ///
    /// # Bounded work
    /// O(visible faces x depth).
    pub fn surface(&self) -> Surface {
        Surface::of(&self.world, self.tet_labels)
    }

    /// The core's world, for everything else (the hierarchy, the contact, the counters).
    pub fn world(&self) -> &World<'a> {
        &self.world
    }

    /// The core's world, mutably (the pressing force, the settings of the contact search).
    pub fn world_mut(&mut self) -> &mut World<'a> {
        &mut self.world
    }
}

/// A drilled surface: triangles with three corners of their own each (faces of different
/// levels of the subdivision need not share corners), counter-clockwise seen from outside
/// the material, each with its region label.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Surface {
    /// Three corners a triangle.
    pub corners: Vec<[Vec3; 3]>,
    /// Each triangle's region label (its coarse tet's).
    pub labels: Vec<i32>,
}

impl Surface {
    /// The visible faces of `world`, labelled from `tet_labels` (one per coarse tet; 0 where
    /// it has none).
    pub fn of(world: &World<'_>, tet_labels: &[i32]) -> Self {
        let mut s = Self::default();
        world.hierarchy().for_each_visible(world.mesh(), |t| {
            s.corners.push(t.corners);
            s.labels
                .push(tet_labels.get(t.tet.idx()).copied().unwrap_or(0));
        });
        s
    }

    /// Triangles.
    pub fn triangles(&self) -> usize {
        self.corners.len()
    }

    /// The surface's area, square mesh units.
    pub fn area(&self) -> f64 {
        self.corners
            .iter()
            .map(|[a, b, c]| 0.5 * f64::from((*b - *a).cross(*c - *a).length()))
            .sum()
    }

    /// The surface as a Wavefront OBJ (a vertex triple and a face a triangle).
    pub fn to_obj(&self) -> String {
        use std::fmt::Write as _;
        let mut out = String::from("# tetradrill drilled surface: visible faces\n");
        for (i, t) in self.corners.iter().enumerate() {
            for c in t {
                let _ = writeln!(out, "v {} {} {}", c.x, c.y, c.z);
            }
            let n = 3 * i;
            let _ = writeln!(out, "f {} {} {}", n + 1, n + 2, n + 3);
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::setup::{Body, SoftSettings, Tool};

    #[test]
    fn a_soft_body_is_refused_not_drilled_as_rigid() {
        let mut setup = Setup::new("builtin:block:2", Tool::sphere(0.1));
        assert!(Drilling::new(&setup).is_ok());
        setup.body = Body::Soft(SoftSettings::default());
        match Drilling::new(&setup) {
            Err(Error::Unsupported(m)) => assert!(m.contains("soft body"), "{m}"),
            other => panic!("a soft set-up must be refused, got {other:?}"),
        }
    }
}
