//! A tet-mesh tool (the pen) against an object: the storage the core's
//! [`pen_contact`](tetradrill_core::force::pen_contact) needs, allocated once, and the scene
//! built over it (the core's `owned::PenRig`, re-exported here), the options and sizes a
//! set-up asks for, and the front door for touching ([`Touching`]). Used by
//! `replay --tool mesh:FILE`, the contact tests and the benches.

use tetradrill_core::force::{
    DepthMethod as PenMethod, ForceParams, PenBuffers, PenOptions, PenScene,
};
pub use tetradrill_core::owned::{
    occupancy_words, HashStore, ObjectCells, PenRest, PenRig, PenSetup, PenSizes, RigError,
    CLUSTER_EDGE, OCCUPANCY_LIST_SPLIT, OCCUPANCY_MARGIN, REST_GRID_EDGE, REST_MARGIN,
};

use crate::owned::OwnedMesh;

/// The pen options a set-up asks for: its stiffness, damping and force clamp at the servo's
/// period, its depth method, crossing rule and entry-plane remedy.
pub fn options(setup: &crate::setup::Setup) -> PenOptions {
    use crate::setup::{Crossings, DepthMethod};
    let f = &setup.forces;
    PenOptions {
        params: ForceParams {
            stiffness: f.stiffness as f32,
            damping: f.damping as f32,
            max_force: f.max_force as f32,
            dt: crate::traces::PERIOD_S as f32,
            ..ForceParams::default()
        },
        method: match setup.pen.depth_method {
            DepthMethod::Traced => PenMethod::Traced,
            DepthMethod::Hashed => PenMethod::Hashed,
        },
        reuse_crossings: setup.pen.crossings == Crossings::Reuse,
        entry_remedy: setup.pen.entry_remedy,
        ..PenOptions::default()
    }
}

/// Storage for an object a mesh tool touches but does not drill: its mesh and an untouched
/// hierarchy (the object's surface, components and checks come from it), the smallest the
/// scenario's other capacities allow.
///
/// # Errors
/// Storage the set-up's sizes cannot give (naming the capacity).
pub fn object_store(
    obj: OwnedMesh,
    setup: &crate::setup::Setup,
) -> Result<crate::engine::EngineStorage, crate::error::Error> {
    let mut untouched = setup.clone();
    untouched.capacities.hierarchy = Some(8);
    crate::engine::EngineStorage::new(obj, &untouched)
}

/// The front door for touching: an object and a tet-mesh tool (the set-up's
/// `Tool::Mesh`), read once; [`Touching::run`] builds the contact scene and hands a
/// [`Touch`] to the caller, whose [`Touch::tick`] gives the force of the pen at each pose.
///
/// ```
/// use tetradrill::pen::Touching;
/// use tetradrill::prelude::*;
///
/// let pen = concat!(env!("CARGO_MANIFEST_DIR"), "/../tests/data/meshes/models/pen_tool_gmsh.mesh");
/// let setup = Setup::new("builtin:block:4", Tool::mesh(pen));
/// let mut touching = Touching::new(&setup)?;
/// let force = touching.run(|touch| {
///     // The pen's tip 0.02 into the block's top face (z = 0.5), its axis up.
///     touch.tick(&Pose::at(Vec3::new(0.0, 0.0, 0.48))).force
/// })?;
/// assert!(force.z > 0.0, "the block pushes the pen back up: {force}");
/// # Ok::<(), tetradrill::Error>(())
/// ```
#[derive(Debug)]
pub struct Touching {
    rig: PenRig,
    sizes: PenSizes,
    opts: PenOptions,
}

impl Touching {
    /// Reads the set-up's object and its tet-mesh tool.
    ///
    /// # Errors
    /// [`crate::Error::Unsupported`] when the tool is a burr; a mesh that cannot be read.
    pub fn new(setup: &crate::setup::Setup) -> Result<Self, crate::error::Error> {
        let crate::setup::Tool::Mesh { path, scale } = &setup.tool else {
            return Err(crate::error::Error::Unsupported(format!(
                "tool {}: touching takes a tet-mesh tool (mesh:FILE)",
                setup.tool
            )));
        };
        setup.check()?;
        let obj = setup.mesh.load()?;
        let pen = crate::meshio::load(path, *scale)?;
        Ok(Self {
            rig: PenRig {
                pen: pen.mesh,
                obj: obj.mesh,
            },
            sizes: setup.capacities.pen(),
            opts: options(setup),
        })
    }

    /// The tool and the object.
    pub fn rig(&self) -> &PenRig {
        &self.rig
    }

    /// Builds the contact scene (the object's hashes and grids, the pen's rest frame) and runs
    /// `f` with it.
    ///
    /// # Errors
    /// [`crate::Error::Rig`] when the scene cannot be built from these meshes and sizes.
    pub fn run<R>(
        &mut self,
        f: impl FnOnce(&mut Touch<'_, '_>) -> R,
    ) -> Result<R, crate::error::Error> {
        let opts = self.opts;
        self.rig
            .with_sizes(self.sizes, |scene, bufs| {
                let mut touch = Touch {
                    scene,
                    bufs,
                    opts,
                    state: tetradrill_core::force::PenState::default(),
                };
                f(&mut touch)
            })
            .map(|(r, _)| r)
            .map_err(|e| crate::error::Error::Rig(format!("the pen's contact scene: {e}")))
    }
}

/// A pen touching an object, tick by tick (from [`Touching::run`]).
pub struct Touch<'s, 'b> {
    scene: &'s PenScene<'s, 's, 's>,
    bufs: &'s mut PenBuffers<'b>,
    opts: PenOptions,
    state: tetradrill_core::force::PenState,
}

impl std::fmt::Debug for Touch<'_, '_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Touch").finish_non_exhaustive()
    }
}

impl Touch<'_, '_> {
    /// Back to rest: the next tick gives the bits of the first of a [`Touching::run`] (no
    /// damping memory, no lists, found tets or crossings carried from earlier ticks).
    ///
    /// # Bounded work
    /// O(pen nodes + crossings).
    pub fn reset(&mut self) {
        self.state = tetradrill_core::force::PenState::default();
        self.bufs.forget();
    }

    /// The pen at `pose` (tip at the position, axis +z turned by the rotation): its
    /// collisions with the object, their consistent penetration depths, and the force on the
    /// hand (damped, clamped), with where to draw the pen so it does not visibly penetrate.
    ///
    /// # Bounded work
    /// The core's `pen_contact`: the buffers' capacities bound every list.
    pub fn tick(&mut self, pose: &crate::traces::Pose) -> tetradrill_core::force::PenContact {
        let [w, x, y, z] = pose.rotation;
        tetradrill_core::force::pen_contact(
            self.scene,
            self.bufs,
            pose.position,
            tetradrill_core::Quat::from_xyzw(x, y, z, w),
            &self.opts,
            &mut self.state,
        )
    }
}
