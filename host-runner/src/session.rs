//! The front door for drilling: a [`Setup`] in, a mesh drilled tick by tick out.
//!
//! [`Drilling::new`] reads the mesh once and allocates every buffer its world needs (sized
//! for the tool on that mesh); [`Drilling::start`] makes a fresh world over them, a
//! [`DrillRun`], whose [`DrillRun::tick`] takes the tool's pose and gives the force for the
//! hand. What was removed, by region, and the drilled surface as triangles, come from the
//! run at any tick.
//!
//! A set-up with a soft body (`body = soft`) is drilled as `tetradrill replay --body soft`
//! drills it: the world deforms, each tick's reaction loads the body where the burr touches
//! it, and at the set-up's soft rate the body steps and the world takes its positions
//! ([`SoftDriver`]; docs/SOFT.md). [`DrillRun::positions`] gives the nodes where they are.
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
use crate::soft::{DeformSummary, SoftDriver, SoftOwned, SoftSpec};
use crate::traces::Pose;

/// A mesh ready to drill: its storage allocated once, its regions set, the tick's
/// parameters worked out.
#[derive(Debug)]
pub struct Drilling {
    store: EngineStorage,
    params: TickParams,
    /// Each tet's region label, in the world's tet order.
    tet_labels: Vec<i32>,
    /// A soft body's settings and storage (`body = soft`), the world's storage deforming.
    soft: Option<(SoftSpec, SoftOwned)>,
}

impl Drilling {
    /// Reads `setup`'s mesh and allocates the world's storage (and a soft body's, for
    /// `body = soft`).
    ///
    /// # Errors
    /// A mesh that cannot be read ([`Error::Mesh`]), a value out of range
    /// ([`Error::Setup`]), a tet-mesh tool ([`Error::Unsupported`]: see
    /// [`crate::pen::PenRig`]), storage the heap refuses.
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
        let params = TickParams::of(setup)?;
        let spec = SoftSpec::of(setup)?;
        let mut store = EngineStorage::new(mesh.mesh, setup)?;
        store.set_labels(&mesh.labels, setup)?;
        let soft = match spec {
            Some(spec) => {
                let owned = store.soft_body(&spec, &mesh.labels)?;
                Some((spec, owned))
            }
            None => None,
        };
        Ok(Self {
            store,
            params,
            tet_labels: mesh.labels,
            soft,
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

    /// A fresh, untouched world over this storage: the mesh as loaded, nothing drilled (a
    /// soft body at rest).
    ///
    /// # Errors
    /// [`Error::World`] when the core refuses the storage; a soft body the core refuses.
    pub fn start(&mut self) -> Result<DrillRun<'_>, Error> {
        let Self {
            store,
            params,
            tet_labels,
            soft,
        } = self;
        let labels = store.region_labels().to_vec();
        let world = store.world()?;
        let soft = match soft {
            Some((spec, owned)) => Some(SoftDriver::unattended(owned, spec)?),
            None => None,
        };
        Ok(DrillRun {
            world,
            params: *params,
            tool: ToolState::default(),
            shaft: ShaftState::default(),
            region_labels: labels,
            tet_labels,
            last: SimReport::default(),
            soft,
            soft_error: None,
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
    soft: Option<SoftDriver<'a>>,
    soft_error: Option<Error>,
}

impl<'a> DrillRun<'a> {
    /// One 1 ms tick at `pose`: the simulation step (candidates, budgeted drilling when the
    /// pose's drill button is down, the contact with the drilled surface), then the servo's
    /// force on the hand, newtons. A soft body then takes the force's reaction at the
    /// contact, and at its rate steps and moves the world ([`SoftDriver::after_tick`]); a step
    /// the core refuses stops the body where it was ([`DrillRun::soft_error`]).
    ///
    /// # Bounded work
    /// The core's: the drill's budget per tick and the contact search's node bound; a soft
    /// body's step, on its ticks, O(substeps x (nodes + tets)) and the world's update.
    pub fn tick(&mut self, pose: &Pose) -> Vec3 {
        let (f, rep) = engine::tick_tool(
            &mut self.world,
            &mut self.tool,
            &mut self.shaft,
            &self.params,
            pose,
        );
        self.last = rep;
        if self.soft_error.is_none() {
            if let Some(d) = self.soft.as_mut() {
                if let Err(e) = d.after_tick(&mut self.world, f) {
                    self.soft_error = Some(e);
                }
            }
        }
        f
    }

    /// The mesh's nodes where they are now: where a soft body moved them, else as loaded.
    pub fn positions(&self) -> &[Vec3] {
        self.world.mesh().positions()
    }

    /// A soft body's figures so far (steps, the largest displacement, the materials), or
    /// `None` for a rigid mesh.
    pub fn soft(&self) -> Option<DeformSummary> {
        self.soft.as_ref().map(SoftDriver::summary)
    }

    /// The step a soft body's core refused, if one did: the body has stayed where it was
    /// since (it does not happen on a body the set-up's checks let through, with positions
    /// the physics keeps finite).
    pub fn soft_error(&self) -> Option<&Error> {
        self.soft_error.as_ref()
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
    fn a_soft_body_gives_way_under_the_burr_where_a_rigid_one_does_not() {
        // The burr pressed 0.02 into the top (z = 0.5) of the 4-block held at its base, the
        // drill off: the soft block's top sinks under it and pushes back less.
        let mut setup = Setup::new("builtin:block:4", Tool::sphere(0.1));
        let press = |setup: &Setup| {
            let mut d = Drilling::new(setup).expect("a drilling");
            let mut run = d.start().expect("a run");
            let mut f = Vec3::ZERO;
            for i in 0..600 {
                let s = (i as f32 / 200.0).min(1.0);
                f = run.tick(&Pose::at(Vec3::new(0.06, -0.04, 0.6 - 0.02 * s)));
            }
            assert!(run.soft_error().is_none());
            let top = run
                .positions()
                .iter()
                .map(|p| p.z)
                .fold(f32::INFINITY, f32::min);
            let lowest_top = run
                .positions()
                .iter()
                .zip(run.world().mesh().rest_positions())
                .filter(|(_, r)| r.z > 0.49)
                .map(|(p, _)| p.z)
                .fold(f32::INFINITY, f32::min);
            (f, top, lowest_top, run.soft().map(|s| s.steps))
        };
        let (rigid, bottom, rigid_top, none) = press(&setup);
        assert_eq!(none, None);
        assert_eq!((bottom, rigid_top), (-0.5, 0.5));
        setup.body = Body::Soft(SoftSettings {
            young: Some(2_000.0),
            ..SoftSettings::default()
        });
        let (soft, bottom, soft_top, steps) = press(&setup);
        assert!(steps.is_some_and(|s| s > 0), "the body stepped: {steps:?}");
        assert_eq!(bottom, -0.5, "the base is held");
        assert!(soft_top < 0.5 - 1e-3, "the top sinks: {soft_top}");
        assert!(
            soft.z > 0.0 && soft.z < rigid.z,
            "soft {soft} against rigid {rigid}"
        );
    }
}
