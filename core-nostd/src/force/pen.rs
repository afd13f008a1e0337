//! The tet-mesh tool (the pen): from the pen's pose to its force, in two halves.
//!
//! The contact pass ([`pen_pass`]): move the pen's nodes to the pose; pen nodes inside the
//! object (object tets hashed or listed per grid cell once, only pen nodes in cells the object
//! occupies looked up); object nodes inside the pen (object nodes hashed once, queried over
//! the moved boxes of the pen's rest-frame clusters and looked up in the pen's rest grid of
//! tets); the consistent depth of both sets. The force: stiffness x (sum of the pen nodes'
//! depth x direction - sum of the object nodes' depth x direction), optionally through the
//! entry-plane remedy; damping; clamping; the displayed offset. [`pen_contact`] does both at
//! one pose; a servo that runs faster than the pass takes the force from the last pass
//! instead ([`super::pen_servo_force`]).
//!
//! ```
//! use tetradrill_core::depth::Penetration;
//! use tetradrill_core::force::{PenOptions, PenPass, PenState};
//! use tetradrill_core::prelude::*;
//!
//! // The force half of a tick, from what a pass found: two pen nodes 0.01 inside the object
//! // (directions out of it, +z) and one object node 0.02 inside the pen (out of the pen, -z).
//! let at = |n, depth, dir| Penetration { node: NodeId(n), depth, dir, ..Default::default() };
//! let pen = [at(0, 0.01, Vec3::Z), at(1, 0.01, Vec3::Z)];
//! let object = [at(7, 0.02, -Vec3::Z)];
//! let pass = PenPass { penetrations: (2, 1), ..Default::default() };
//! let world = [Vec3::ZERO, Vec3::new(0.01, 0.0, 0.0)]; // the pen's nodes at the pose
//!
//! let params = ForceParams { stiffness: 50.0, ..Default::default() };
//! let opts = PenOptions { params, ..Default::default() };
//! let tick = pass.contact(&world, &pen, &object, Vec3::ZERO, &opts, &mut PenState::default());
//! // 50 N per unit x (0.01 + 0.01 + 0.02) up; drawn 0.02 out so nothing shows inside.
//! assert!((tick.force - Vec3::Z * 2.0).length() < 1e-5);
//! assert!((tick.display_offset - Vec3::Z * 0.02).length() < 1e-6);
//! ```

use glam::{Affine3A, Quat, Vec3};

use super::entry::EntryPlane;
use super::response::{clamp_force, damping_force, display_offset, ForceParams, ToolState};
use crate::collide::{
    points_in_tets_walked, rigid_tets_over_points_coherent, Body, CollideReport, Collision,
    NearClusters, Occupancy, RigidTets, WalkStarts,
};
use crate::depth::{
    penetration_depth_of, DepthReport, DepthScratch, Listed, Method, NodeGraph, Penetration,
};
use crate::hash::{Aabb, SpatialHash};
use crate::ids::{NodeId, TetId};
use crate::mesh::Mesh;

/// What stays fixed during a session: the pen at rest (tip at its origin), the static object,
/// their graphs and hashes (all built once at start-up).
#[derive(Clone, Copy, Debug)]
pub struct PenScene<'s, 'm, 'a> {
    /// The pen mesh at rest, in its own frame.
    pub pen: &'m Mesh<'a>,
    /// The pen's node graph.
    pub pen_graph: NodeGraph<'s>,
    /// The pen's tets gridded and clustered at rest ([`RigidTets::build`] over the pen at
    /// rest): object nodes are looked up in it.
    pub pen_rest: &'s RigidTets<'s>,
    /// The pen's boundary faces hashed at rest (only for [`DepthMethod::Hashed`]).
    pub pen_faces: Option<&'s SpatialHash<'s>>,
    /// The object where it stands.
    pub object: Body<'m, 'a>,
    /// The object's node graph.
    pub object_graph: NodeGraph<'s>,
    /// The object's tets hashed ([`crate::collide::hash_tets`]).
    pub object_tets: &'s SpatialHash<'s>,
    /// The object's nodes hashed ([`SpatialHash::rebuild_points`]).
    pub object_nodes: &'s SpatialHash<'s>,
    /// Where the object's tets are ([`Occupancy::build`] over the object): pen nodes and pen
    /// clusters away from it are not looked up. With tet lists ([`Occupancy::with_tet_lists`])
    /// pen nodes are looked up in them instead of `object_tets`.
    pub object_cells: &'s Occupancy<'s>,
    /// The object's boundary faces hashed (only for [`DepthMethod::Hashed`]).
    pub object_faces: Option<&'s SpatialHash<'s>>,
    /// `true` when pen nodes may be found by walking through the object's tets
    /// ([`PenOptions::max_walk`]): the object passes [`crate::collide::walks_exact`] and
    /// `object_tets` holds every tet. Otherwise every pen node is looked up in the hash.
    pub object_walks: bool,
    /// `true` when object nodes that were in the pen last tick may be found by walking
    /// through the pen's tets ([`PenOptions::max_walk`]): the pen passes
    /// [`crate::collide::walks_exact`] and `pen_rest` holds every pen tet.
    pub pen_walks: bool,
}

/// Per-tick storage; the lengths are the capacities.
#[derive(Debug)]
pub struct PenBuffers<'b> {
    /// The pen's nodes at the current pose (one per pen node).
    pub world: &'b mut [Vec3],
    /// Pen nodes inside object tets.
    pub pen_hits: &'b mut [Collision],
    /// Per pen node, the object tet it was found in this tick, where the walks of its
    /// neighbours start ([`WalkStarts::found`]; pen nodes beyond its length are looked up in
    /// the object's tet hash without a walk).
    pub pen_found: &'b mut [TetId],
    /// Object nodes inside pen tets.
    pub object_hits: &'b mut [Collision],
    /// Depths of the pen nodes.
    pub pen_pens: &'b mut [Penetration],
    /// Depths of the object nodes.
    pub object_pens: &'b mut [Penetration],
    /// Depth scratch over the pen's nodes.
    pub pen_depth: DepthScratch<'b>,
    /// Depth scratch over the object's nodes.
    pub object_depth: DepthScratch<'b>,
}

/// Which surface search the depth uses.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default)]
pub enum DepthMethod {
    /// Walk through tets (Praktikum report, section 4).
    #[default]
    Traced,
    /// Hashed boundary faces (Heidelberger 2004); falls back to traced when the scene has no
    /// face hashes (reported in [`PenContact::hashed_unavailable`]).
    Hashed,
}

/// Options of the pen tool.
#[derive(Clone, Copy, PartialEq, Debug)]
pub struct PenOptions {
    /// Force parameters.
    pub params: ForceParams,
    /// Surface search.
    pub method: DepthMethod,
    /// Longest traced walk, in tets.
    pub max_steps: u32,
    /// Most cells a hashed edge query may cover.
    pub max_cells: u32,
    /// Use the entry-plane remedy for the pen's nodes (`EntryPlane`).
    pub entry_remedy: bool,
    /// Most object tets a pen node's walk may test before the node is looked up in the
    /// object's tet hash instead ([`points_in_tets_walked`]; 0: always the hash; no walks
    /// unless [`PenScene::object_walks`]), and the most pen tets an object node that was in
    /// the pen last tick may walk ([`rigid_tets_over_points_coherent`]; only with
    /// [`PenScene::pen_walks`]). The same contacts either way.
    pub max_walk: u32,
    /// Let a border edge take the face it left the other body through last tick when it
    /// still leaves through it (one face test instead of a search;
    /// [`DepthScratch::with_crossings`], only where the scratches have crossing storage).
    /// Not exact where a fold of the surface comes between; off by default.
    pub reuse_crossings: bool,
}

impl Default for PenOptions {
    fn default() -> Self {
        Self {
            params: ForceParams::default(),
            method: DepthMethod::Traced,
            max_steps: 256,
            max_cells: 512,
            entry_remedy: false,
            max_walk: 8,
            reuse_crossings: false,
        }
    }
}

/// State carried from tick to tick (with the same [`PenBuffers`]: the collision lists stay in
/// them from one tick to the next).
#[derive(Clone, Copy, PartialEq, Debug, Default)]
pub struct PenState {
    /// For damping.
    pub(crate) tool: ToolState,
    /// For the remedy.
    pub(crate) entry: EntryPlane,
    /// Entries of [`PenBuffers::pen_hits`] written last tick: a full list keeps those nodes
    /// first ([`points_in_tets_walked`]).
    pub pen_listed: usize,
    /// Entries of [`PenBuffers::object_hits`] written last tick
    /// ([`rigid_tets_over_points_coherent`]).
    pub object_listed: usize,
}

/// One tick's result.
#[derive(Clone, Copy, PartialEq, Debug, Default)]
pub struct PenContact {
    /// The contact force before damping and clamping.
    pub raw: Vec3,
    /// The force to render (damped, clamped).
    pub force: Vec3,
    /// Where to draw the pen relative to its pose so it does not visibly penetrate.
    pub display_offset: Vec3,
    /// Pen nodes in the object.
    pub pen_collisions: CollideReport,
    /// Object nodes in the pen.
    pub object_collisions: CollideReport,
    /// Depth of the pen nodes.
    pub pen_depth: DepthReport,
    /// Depth of the object nodes.
    pub object_depth: DepthReport,
    /// Penetrations written (pen nodes, object nodes).
    pub penetrations: (usize, usize),
    /// `true` when the world buffer is shorter than the pen (nodes beyond it ignored).
    pub world_short: bool,
    /// `true` when [`DepthMethod::Hashed`] was asked for without face hashes.
    pub hashed_unavailable: bool,
    /// `true` when the force was clamped.
    pub clamped: bool,
}

impl PenPass {
    /// `true` when any buffer filled in this pass (the result is valid but incomplete).
    pub fn saturated(&self) -> bool {
        self.world_short || self.contacts_full() || self.queue_full()
    }

    /// `true` when a collision list or a depth output filled (`contact_capacity`).
    pub fn contacts_full(&self) -> bool {
        self.pen_collisions.saturated
            || self.object_collisions.saturated
            || self.pen_depth.out_full
            || self.object_depth.out_full
    }

    /// `true` when a depth propagation queue filled (`queue_capacity`).
    pub fn queue_full(&self) -> bool {
        self.pen_depth.queue_full || self.object_depth.queue_full
    }
}

impl PenContact {
    /// `true` when any buffer filled this tick (the result is valid but incomplete).
    pub fn saturated(&self) -> bool {
        self.pass().saturated()
    }

    /// The contact half of this tick.
    pub fn pass(&self) -> PenPass {
        PenPass {
            pen_collisions: self.pen_collisions,
            object_collisions: self.object_collisions,
            pen_depth: self.pen_depth,
            object_depth: self.object_depth,
            penetrations: self.penetrations,
            world_short: self.world_short,
            hashed_unavailable: self.hashed_unavailable,
        }
    }
}

/// What the contact half of a tick found ([`pen_pass`]).
#[derive(Clone, Copy, PartialEq, Debug, Default)]
pub struct PenPass {
    /// Pen nodes in the object.
    pub pen_collisions: CollideReport,
    /// Object nodes in the pen.
    pub object_collisions: CollideReport,
    /// Depth of the pen nodes.
    pub pen_depth: DepthReport,
    /// Depth of the object nodes.
    pub object_depth: DepthReport,
    /// Penetrations written (pen nodes in [`PenBuffers::pen_pens`], object nodes in
    /// [`PenBuffers::object_pens`]).
    pub penetrations: (usize, usize),
    /// `true` when the world buffer is shorter than the pen (nodes beyond it ignored).
    pub world_short: bool,
    /// `true` when [`DepthMethod::Hashed`] was asked for without face hashes.
    pub hashed_unavailable: bool,
}

/// What the force half of a tick gives ([`pen_contact`], [`super::pen_servo_force`]).
#[derive(Clone, Copy, PartialEq, Debug, Default)]
pub struct PenForce {
    /// The contact force before damping and clamping.
    pub raw: Vec3,
    /// The force to render (damped, clamped).
    pub force: Vec3,
    /// Where to draw the pen relative to its pose so it does not visibly penetrate.
    pub display_offset: Vec3,
    /// `true` when the force was clamped.
    pub clamped: bool,
}

impl PenContact {
    fn of(pass: PenPass, force: PenForce) -> Self {
        Self {
            raw: force.raw,
            force: force.force,
            display_offset: force.display_offset,
            pen_collisions: pass.pen_collisions,
            object_collisions: pass.object_collisions,
            pen_depth: pass.pen_depth,
            object_depth: pass.object_depth,
            penetrations: pass.penetrations,
            world_short: pass.world_short,
            hashed_unavailable: pass.hashed_unavailable,
            clamped: force.clamped,
        }
    }
}

/// One servo tick of the pen tool at `position` (its tip) and `rotation`: [`pen_pass`], then
/// the force from its penetrations at the same pose. The same force, bit for bit, as
/// [`super::pen_servo_force`] from that pass at that pose.
///
/// # Bounded work
/// [`pen_pass`]'s, plus O(penetrations) for the force.
pub fn pen_contact(
    scene: &PenScene<'_, '_, '_>,
    bufs: &mut PenBuffers<'_>,
    position: Vec3,
    rotation: Quat,
    opts: &PenOptions,
    state: &mut PenState,
) -> PenContact {
    let pass = pen_pass(scene, bufs, position, rotation, opts, state);
    pass.contact(
        bufs.world,
        bufs.pen_pens,
        bufs.object_pens,
        position,
        opts,
        state,
    )
}

impl PenPass {
    /// The tick from this pass at the pose it was made at (`position`): the force from its
    /// penetrations, `pen_pens` and `object_pens` the buffers the pass wrote them to and
    /// `world` the pen's nodes at the pose. [`pen_contact`] is [`pen_pass`] then this.
    ///
    /// # Bounded work
    /// O(penetrations).
    pub fn contact(
        self,
        world: &[Vec3],
        pen_pens: &[Penetration],
        object_pens: &[Penetration],
        position: Vec3,
        opts: &PenOptions,
        state: &mut PenState,
    ) -> PenContact {
        let (p, o) = self.penetrations;
        let pens = pen_pens.get(..p).unwrap_or(&[]);
        let objs = object_pens.get(..o).unwrap_or(&[]);
        let force = respond(
            |n| world.get(n.idx()).copied(),
            pens,
            objs,
            position,
            opts,
            state,
        );
        PenContact::of(self, force)
    }
}

/// The contact half of a tick: the pen's nodes at the pose ([`PenBuffers::world`]), the
/// collisions both ways and their consistent depths ([`PenBuffers::pen_pens`],
/// [`PenBuffers::object_pens`]; [`PenPass::penetrations`] says how many). Updates only
/// [`PenState::pen_listed`] and [`PenState::object_listed`].
///
/// It is [`pen_place`], then [`pen_side`] and [`object_side`], which share nothing they write:
/// a host with two cores may run the sides at once (the same results, bit for bit).
///
/// When a collision list is full, it keeps last tick's nodes that still collide first
/// ([`PenState::pen_listed`], [`points_in_tets_walked`], [`rigid_tets_over_points_coherent`]) and
/// its depths follow edges to unlisted nodes on to the surface (`Listed::Partial`, at most
/// `max_steps` tets): a node enters or leaves the list only as it enters or leaves the other
/// body, where its depth is near zero, so the force stays continuous.
///
/// # Bounded work
/// [`pen_place`]'s, [`pen_side`]'s and [`object_side`]'s. Every buffer saturates as documented
/// on the functions it is handed to; [`PenContact::saturated`] tells.
pub fn pen_pass(
    scene: &PenScene<'_, '_, '_>,
    bufs: &mut PenBuffers<'_>,
    position: Vec3,
    rotation: Quat,
    opts: &PenOptions,
    state: &mut PenState,
) -> PenPass {
    let at = pen_place(scene, bufs.world, position, rotation);
    let (world, found, pen, object) = bufs.sides();
    let pen = pen_side(scene, &at, world, found, pen, opts, state.pen_listed);
    let object = object_side(scene, &at, world, object, opts, state.object_listed);
    at.pass(pen, object, opts, state)
}

/// The pen placed at a pose ([`pen_place`]): what both sides of a pass read.
#[derive(Clone, Copy, Debug)]
pub struct PenPlacement<'c> {
    pose: Affine3A,
    rotation: Quat,
    /// Pen nodes placed: the pen's, or the world buffer's length when that is shorter.
    placed: usize,
    world_short: bool,
    /// Both bodies' boundary faces hashed ([`DepthMethod::Hashed`] possible).
    faces: bool,
    /// The pen's clusters near the object; `None` when the pen's bounds miss the object's.
    near: Option<NearClusters<'c>>,
}

/// What one side of a pass found ([`pen_side`], [`object_side`]).
#[derive(Clone, Copy, PartialEq, Debug, Default)]
pub struct SideReport {
    /// Nodes of this side inside the other body.
    pub collisions: CollideReport,
    /// Their depths.
    pub depth: DepthReport,
}

/// One side's storage: its collision list, its depths and its depth scratch (a view of
/// [`PenBuffers`], [`PenBuffers::sides`]).
#[derive(Debug)]
pub struct SideBuffers<'s, 'b> {
    /// Nodes of this side inside the other body.
    pub hits: &'s mut [Collision],
    /// Their depths.
    pub pens: &'s mut [Penetration],
    /// Depth scratch over this side's nodes.
    pub depth: &'s mut DepthScratch<'b>,
}

impl<'b> SideBuffers<'_, 'b> {
    /// The same storage, borrowed again (to hand it to a side and keep it).
    pub fn reborrow(&mut self) -> SideBuffers<'_, 'b> {
        SideBuffers {
            hits: &mut *self.hits,
            pens: &mut *self.pens,
            depth: &mut *self.depth,
        }
    }
}

impl<'b> PenBuffers<'b> {
    /// Forgets what the buffers carry from tick to tick (the pen nodes' found tets, both
    /// depths' remembered crossings), so that a pass with a fresh [`PenState`] gives the bits
    /// of the first pass over freshly carved buffers (a session started again).
    ///
    /// # Bounded work
    /// O(pen nodes + crossings).
    pub fn forget(&mut self) {
        self.pen_found.fill(TetId::NONE);
        self.pen_depth.forget_crossings();
        self.object_depth.forget_crossings();
    }

    /// The buffers as the two sides of a pass use them: the pen's nodes at the pose, the pen
    /// nodes' found tets, the pen side's storage and the object side's.
    pub fn sides(
        &mut self,
    ) -> (
        &[Vec3],
        &mut [TetId],
        SideBuffers<'_, 'b>,
        SideBuffers<'_, 'b>,
    ) {
        (
            &*self.world,
            &mut *self.pen_found,
            SideBuffers {
                hits: &mut *self.pen_hits,
                pens: &mut *self.pen_pens,
                depth: &mut self.pen_depth,
            },
            SideBuffers {
                hits: &mut *self.object_hits,
                pens: &mut *self.object_pens,
                depth: &mut self.object_depth,
            },
        )
    }
}

/// Places the pen at `position` (its tip) and `rotation`: its nodes into `world` (as many as
/// it holds), and the clusters of its rest frame near the object.
///
/// # Bounded work
/// O(N_pen) to place the pen, and [`RigidTets::near`]'s (per pen cluster, one box transform
/// and at most [`crate::collide::MAX_CELLS_PER_TET`] cells of the object's occupancy).
pub fn pen_place<'s>(
    scene: &PenScene<'s, '_, '_>,
    world: &mut [Vec3],
    position: Vec3,
    rotation: Quat,
) -> PenPlacement<'s> {
    let pose = Affine3A::from_rotation_translation(rotation, position);
    let rest = scene.pen.positions();
    let placed = rest.len().min(world.len());
    for (w, &r) in world.iter_mut().zip(rest.iter()) {
        *w = pose.transform_point3(r);
    }
    let world = world.get(..placed).unwrap_or(&[]);
    // The pen's rest bounds moved (constant work); the moved nodes' own box only where those
    // cannot be trusted to hold them.
    let bounds = scene.pen_rest.moved_bounds(&pose).unwrap_or_else(|| {
        world
            .iter()
            .fold(Aabb::of::<0>([]), |b, &w| b.union(Aabb::point(w)))
    });
    // The pen's clusters whose moved boxes meet cells the object occupies: the others' nodes
    // are in no object tet, and no object node is in their tets.
    let near = bounds
        .overlaps(&scene.object_tets.bounds())
        .then(|| scene.pen_rest.near(pose, scene.object_cells));
    PenPlacement {
        pose,
        rotation,
        placed,
        world_short: placed < rest.len(),
        faces: scene.object_faces.is_some() && scene.pen_faces.is_some(),
        near,
    }
}

impl PenPlacement<'_> {
    /// The pass from its two sides; updates [`PenState::pen_listed`] and
    /// [`PenState::object_listed`].
    ///
    /// # Bounded work
    /// Constant.
    pub fn pass(
        &self,
        pen: SideReport,
        object: SideReport,
        opts: &PenOptions,
        state: &mut PenState,
    ) -> PenPass {
        state.pen_listed = pen.collisions.count;
        state.object_listed = object.collisions.count;
        PenPass {
            pen_collisions: pen.collisions,
            object_collisions: object.collisions,
            pen_depth: pen.depth,
            object_depth: object.depth,
            penetrations: (pen.depth.written, object.depth.written),
            world_short: self.world_short,
            hashed_unavailable: self.near.is_some()
                && opts.method == DepthMethod::Hashed
                && !self.faces,
        }
    }
}
/// The pen side of a pass: the pen's nodes inside object tets ([`points_in_tets_walked`],
/// `found` the pen nodes' found tets, [`PenBuffers::pen_found`]) and their consistent depths
/// against the object. `world` is the buffer [`pen_place`] filled for `at`; `listed` is
/// [`PenState::pen_listed`].
///
/// # Bounded work
/// Collision: O(N_pen * (w + b + g)) for w = `max_walk`, b the largest bucket of the object's
/// tet hash and g the pen graph's largest node degree ([`points_in_tets_walked`]); depth: see
/// `penetration_depth_of`, bounded by `side`'s buffers and `max_steps` / `max_cells`. Nothing
/// when the pen is away from the object.
pub fn pen_side(
    scene: &PenScene<'_, '_, '_>,
    at: &PenPlacement<'_>,
    world: &[Vec3],
    found: &mut [TetId],
    side: SideBuffers<'_, '_>,
    opts: &PenOptions,
    listed: usize,
) -> SideReport {
    side.depth.set_reuse(opts.reuse_crossings);
    let Some(near) = &at.near else {
        return SideReport::default();
    };
    let world = world.get(..at.placed).unwrap_or(&[]);
    let collisions = points_in_tets_walked(
        scene.object_tets,
        scene.object_cells,
        &scene.object,
        world,
        side.hits,
        listed,
        WalkStarts {
            found,
            near: |i| scene.pen_graph.neighbours(NodeId::from_idx(i)),
            max_steps: if scene.object_walks { opts.max_walk } else { 0 },
        },
        |i| scene.pen_rest.node_near(i, near),
    );
    let method = match (opts.method, scene.object_faces, scene.pen_faces) {
        (DepthMethod::Hashed, Some(faces), Some(_)) => Method::Hashed {
            faces,
            world_to_hash: Affine3A::IDENTITY,
            max_cells: opts.max_cells,
        },
        _ => Method::Traced {
            max_steps: opts.max_steps,
        },
    };
    let hits = side.hits.get(..collisions.count).unwrap_or(&[]);
    let depth = penetration_depth_of(
        world,
        &scene.pen_graph,
        &scene.object,
        listed_of(hits, &collisions, opts),
        &method,
        side.depth,
        side.pens,
    );
    SideReport { collisions, depth }
}

/// The object side of a pass: the object's nodes inside pen tets
/// ([`rigid_tets_over_points_coherent`]) and their consistent depths against the pen. `world`
/// is the buffer [`pen_place`] filled for `at`; `listed` is [`PenState::object_listed`].
///
/// # Bounded work
/// Collision: per near pen cluster, a read of at most [`crate::collide::MAX_CELLS_PER_TET`]
/// cells of the object's node lists (or of its node hash when the occupancy has none) with a
/// rest-grid lookup per node met in the cluster's cell ([`rigid_tets_over_points_coherent`];
/// for poses far from the origin the walk over every pen tet, O(T_pen * cells * b), twice at
/// most); depth: see `penetration_depth_of`, bounded by
/// `side`'s buffers and `max_steps` / `max_cells`. Nothing when the pen is away from the
/// object.
pub fn object_side(
    scene: &PenScene<'_, '_, '_>,
    at: &PenPlacement<'_>,
    world: &[Vec3],
    side: SideBuffers<'_, '_>,
    opts: &PenOptions,
    listed: usize,
) -> SideReport {
    side.depth.set_reuse(opts.reuse_crossings);
    let Some(near) = &at.near else {
        return SideReport::default();
    };
    let world = world.get(..at.placed).unwrap_or(&[]);
    let pen_body = Body::moved(scene.pen, world, at.rotation);
    let collisions = rigid_tets_over_points_coherent(
        scene.object_nodes,
        scene.object.positions,
        scene.pen_rest,
        &pen_body,
        at.pose,
        near,
        side.hits,
        listed,
        if scene.pen_walks { opts.max_walk } else { 0 },
    );
    let method = match (opts.method, scene.object_faces, scene.pen_faces) {
        (DepthMethod::Hashed, Some(_), Some(faces)) => Method::Hashed {
            faces,
            world_to_hash: at.pose.inverse(),
            max_cells: opts.max_cells,
        },
        _ => Method::Traced {
            max_steps: opts.max_steps,
        },
    };
    let hits = side.hits.get(..collisions.count).unwrap_or(&[]);
    let depth = penetration_depth_of(
        scene.object.positions,
        &scene.object_graph,
        &pen_body,
        listed_of(hits, &collisions, opts),
        &method,
        side.depth,
        side.pens,
    );
    SideReport { collisions, depth }
}

/// A side's collisions as its depth lists them: all of them, or (the list full) a partial
/// list whose depths follow edges to unlisted nodes.
fn listed_of<'l>(list: &'l [Collision], r: &CollideReport, opts: &PenOptions) -> Listed<'l> {
    match r.saturated {
        false => Listed::All(list),
        true => Listed::Partial {
            list,
            max_steps: opts.max_steps,
        },
    }
}

/// The force from penetrations (`at` gives a pen node's position, for the entry plane):
/// stiffness x (the pen nodes' depths along their directions, or the entry plane's, minus the
/// object nodes'), damping, clamping, the displayed offset.
///
/// # Bounded work
/// O(penetrations).
pub(super) fn respond<P: Fn(NodeId) -> Option<Vec3>>(
    at: P,
    pen: &[Penetration],
    object: &[Penetration],
    position: Vec3,
    opts: &PenOptions,
    state: &mut PenState,
) -> PenForce {
    let k = opts.params.stiffness;
    let mut raw = Vec3::ZERO;
    if opts.entry_remedy {
        raw += state.entry.force_at(at, pen, k);
    } else {
        for p in pen {
            raw += p.dir * (k * p.depth);
        }
    }
    for p in object {
        raw -= p.dir * (k * p.depth);
    }
    let in_contact = !pen.is_empty() || !object.is_empty();
    let total = raw + damping_force(&mut state.tool, position, in_contact, &opts.params);
    let force = clamp_force(total, opts.params.max_force);
    PenForce {
        raw,
        force,
        display_offset: display_offset(force, pen, object),
        clamped: force != total,
    }
}
