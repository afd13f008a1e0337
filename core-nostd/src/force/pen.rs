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

use glam::{Affine3A, Quat, Vec3};

use super::entry::EntryPlane;
use super::response::{clamp_force, damping_force, display_offset, ForceParams, ToolState};
use crate::collide::{
    points_in_tets_walked, rigid_tets_over_points_coherent, Body, CollideReport, Collision,
    Occupancy, RigidTets, WalkStarts,
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
    /// Walk through tets (seed 000).
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
    /// Use the entry-plane remedy for the pen's nodes ([`EntryPlane`]).
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
    pub tool: ToolState,
    /// For the remedy.
    pub entry: EntryPlane,
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
    let (p, o) = pass.penetrations;
    let pens = bufs.pen_pens.get(..p).unwrap_or(&[]);
    let objs = bufs.object_pens.get(..o).unwrap_or(&[]);
    let world = &*bufs.world;
    let force = respond(
        |n| world.get(n.idx()).copied(),
        pens,
        objs,
        position,
        opts,
        state,
    );
    PenContact::of(pass, force)
}

/// The contact half of a tick: the pen's nodes at the pose ([`PenBuffers::world`]), the
/// collisions both ways and their consistent depths ([`PenBuffers::pen_pens`],
/// [`PenBuffers::object_pens`]; [`PenPass::penetrations`] says how many). Updates only
/// [`PenState::pen_listed`] and [`PenState::object_listed`].
///
/// When a collision list is full, it keeps last tick's nodes that still collide first
/// ([`PenState::pen_listed`], [`points_in_tets_walked`], [`rigid_tets_over_points_coherent`]) and
/// its depths follow edges to unlisted nodes on to the surface ([`Listed::Partial`], at most
/// `max_steps` tets): a node enters or leaves the list only as it enters or leaves the other
/// body, where its depth is near zero, so the force stays continuous.
///
/// # Bounded work
/// O(N_pen) to place the pen; collision: O(N_pen * (w + b + g)) for w = `max_walk`, b the
/// largest bucket of the object's tet hash and g the pen graph's largest node degree
/// ([`points_in_tets_walked`]) and, per pen cluster, one query of at most
/// [`crate::collide::MAX_CELLS_PER_TET`] cells of the object's node hash with a rest-hash
/// lookup per node met ([`rigid_tets_over_points_coherent`]; for poses far from the origin the
/// walk over every pen tet, O(T_pen * cells * b), twice at most); depth: see
/// [`penetration_depth_of`], bounded by the collision buffers and `max_steps` / `max_cells`.
/// Every buffer saturates as documented on the functions it is handed to;
/// [`PenContact::saturated`] tells.
pub fn pen_pass(
    scene: &PenScene<'_, '_, '_>,
    bufs: &mut PenBuffers<'_>,
    position: Vec3,
    rotation: Quat,
    opts: &PenOptions,
    state: &mut PenState,
) -> PenPass {
    let mut out = PenPass::default();
    let pose = Affine3A::from_rotation_translation(rotation, position);
    let rest = scene.pen.positions();
    let n = rest.len().min(bufs.world.len());
    out.world_short = n < rest.len();
    for (w, &r) in bufs.world.iter_mut().zip(rest.iter()) {
        *w = pose.transform_point3(r);
    }
    let world = bufs.world.get(..n).unwrap_or(&[]);
    // The pen's rest bounds moved (constant work); the moved nodes' own box only where those
    // cannot be trusted to hold them.
    let bounds = scene.pen_rest.moved_bounds(&pose).unwrap_or_else(|| {
        world
            .iter()
            .fold(Aabb::of::<0>([]), |b, &w| b.union(Aabb::point(w)))
    });
    let pen_body = Body::moved(scene.pen, world, rotation);
    bufs.pen_depth.set_reuse(opts.reuse_crossings);
    bufs.object_depth.set_reuse(opts.reuse_crossings);

    let mut pen_count = 0;
    let mut obj_count = 0;
    if bounds.overlaps(&scene.object_tets.bounds()) {
        // The pen's clusters whose moved boxes meet cells the object occupies: the others'
        // nodes are in no object tet, and no object node is in their tets.
        let near = scene.pen_rest.near(pose, scene.object_cells);
        out.pen_collisions = points_in_tets_walked(
            scene.object_tets,
            scene.object_cells,
            &scene.object,
            world,
            bufs.pen_hits,
            state.pen_listed,
            WalkStarts {
                found: bufs.pen_found,
                near: |i| scene.pen_graph.neighbours(NodeId::from_idx(i)),
                max_steps: if scene.object_walks { opts.max_walk } else { 0 },
            },
            |i| scene.pen_rest.node_near(i, &near),
        );
        out.object_collisions = rigid_tets_over_points_coherent(
            scene.object_nodes,
            scene.object.positions,
            scene.pen_rest,
            &pen_body,
            pose,
            &near,
            bufs.object_hits,
            state.object_listed,
            if scene.pen_walks { opts.max_walk } else { 0 },
        );
        let (m_obj, m_pen) = match (opts.method, scene.object_faces, scene.pen_faces) {
            (DepthMethod::Hashed, Some(of), Some(pf)) => (
                Method::Hashed {
                    faces: of,
                    world_to_hash: Affine3A::IDENTITY,
                    max_cells: opts.max_cells,
                },
                Method::Hashed {
                    faces: pf,
                    world_to_hash: pose.inverse(),
                    max_cells: opts.max_cells,
                },
            ),
            (method, _, _) => {
                out.hashed_unavailable = method == DepthMethod::Hashed;
                let t = Method::Traced {
                    max_steps: opts.max_steps,
                };
                (t, t)
            }
        };
        let listed = |list, r: &CollideReport| match r.saturated {
            false => Listed::All(list),
            true => Listed::Partial {
                list,
                max_steps: opts.max_steps,
            },
        };
        let pen_hits = bufs.pen_hits.get(..out.pen_collisions.count).unwrap_or(&[]);
        out.pen_depth = penetration_depth_of(
            world,
            &scene.pen_graph,
            &scene.object,
            listed(pen_hits, &out.pen_collisions),
            &m_obj,
            &mut bufs.pen_depth,
            bufs.pen_pens,
        );
        let obj_hits = bufs
            .object_hits
            .get(..out.object_collisions.count)
            .unwrap_or(&[]);
        out.object_depth = penetration_depth_of(
            scene.object.positions,
            &scene.object_graph,
            &pen_body,
            listed(obj_hits, &out.object_collisions),
            &m_pen,
            &mut bufs.object_depth,
            bufs.object_pens,
        );
        pen_count = out.pen_depth.written;
        obj_count = out.object_depth.written;
    }
    state.pen_listed = out.pen_collisions.count;
    state.object_listed = out.object_collisions.count;
    out.penetrations = (pen_count, obj_count);
    out
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
