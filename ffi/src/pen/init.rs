//! A pen's memory laid out and built: the plan of its parts (those the counts give, then
//! those the meshes' shapes give, measured once the meshes are built) and `td_pen_init`.

use super::*;

/// What the meshes' shapes give, measured once they are built.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Measured {
    pen_graph: (usize, usize),
    object_graph: (usize, usize),
    rest: (usize, usize),
    words: usize,
    lists: (usize, usize, usize),
    buffers: usize,
}

/// Offsets of every part of a pen's memory.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct PenPlan {
    object_nodes: usize,
    object_tets: usize,
    pen_nodes: usize,
    pen_tets: usize,
    pen_cap: usize,
    object_cap: usize,
    handoff: usize,
    servo: usize,
    handoff_words: usize,
    handoff_len: usize,
    held: [usize; 4],
    now: [usize; 2],
    object_pos: usize,
    object_lines: usize,
    object_lines_n: usize,
    object_scratch: usize,
    pen_pos: usize,
    pen_lines: usize,
    pen_lines_n: usize,
    pen_scratch: usize,
    meshes: usize,
    hashes: [(usize, usize, usize, usize); 4],
    hash_slots: usize,
    rest_boxes: usize,
    clusters: usize,
    node_clusters: usize,
    rest_slot: usize,
    object_boxes: usize,
    cells_slot: usize,
    scene: usize,
    /// Bytes of the parts the counts give.
    pub(super) front: usize,
    pen_graph: (usize, usize),
    object_graph: (usize, usize),
    rest_grid: (usize, usize),
    words: usize,
    list_starts: usize,
    list_tets: usize,
    node_starts: usize,
    nodes: usize,
    buffers: usize,
    measured: Measured,
    size: usize,
    pub(super) align: usize,
}

/// Storage of a hash over `items` items of about `per` cells and `buckets` buckets each (a
/// prime number of buckets, as the host's `HashStore`): (starts, entries).
fn hash_sizes(items: usize, per: usize, buckets: usize) -> (usize, usize) {
    let b = prime_at_most(buckets.saturating_mul(items).clamp(3, u32::MAX as usize) as u32);
    (b as usize + 1, items.saturating_mul(per))
}

impl PenPlan {
    /// Lays out the parts the counts give, then, with `m`, those the meshes give.
    pub(super) fn of(p: &TdPenParams, m: Option<&Measured>) -> Result<Self, TdStatus> {
        let count = |v: u32| {
            if (1..=TD_MAX_COUNT).contains(&v) {
                Ok(v as usize)
            } else {
                Err(TdStatus::TdErrParams)
            }
        };
        let ok = |b: bool| {
            if b {
                Ok(())
            } else {
                Err(TdStatus::TdErrParams)
            }
        };
        let (on, ot, pn, pt) = (
            count(p.object_node_count)?,
            count(p.object_tet_count)?,
            count(p.pen_node_count)?,
            count(p.pen_tet_count)?,
        );
        ok(p.depth_method <= 1 && p.reuse_crossings <= 1 && p.entry_remedy <= 1)?;
        ok(p.max_steps >= 1 && p.max_cells >= 1)?;
        ok(non_negative(p.stiffness) && non_negative(p.damping))?;
        ok(p.max_force.is_finite() && p.max_force > 0.0 && p.dt.is_finite() && p.dt > 0.0)?;
        let cap = |v: u32, n: usize| if v == 0 { n } else { v as usize };
        let mut b = PenBuilder {
            layout: Layout::new::<PenHeader>(),
        };
        let mut plan = PenPlan {
            object_nodes: on,
            object_tets: ot,
            pen_nodes: pn,
            pen_tets: pt,
            pen_cap: cap(p.contact_capacity, pn),
            object_cap: cap(p.contact_capacity, on),
            ..PenPlan::default()
        };
        plan.handoff = b.put::<SharedPenHandoff>(1)?;
        plan.servo = b.put::<PenServoState>(1)?;
        plan.handoff_len =
            PenHandoff::words_for(plan.pen_cap, plan.object_cap).ok_or(TdStatus::TdErrParams)?;
        plan.handoff_words = b.put::<AtomicU32>(plan.handoff_len)?;
        for (i, h) in plan.held.iter_mut().enumerate() {
            *h = b.put::<Penetration>(if i < 2 { plan.pen_cap } else { plan.object_cap })?;
        }
        plan.now = [
            b.put::<Penetration>(plan.pen_cap)?,
            b.put::<Penetration>(plan.object_cap)?,
        ];
        plan.object_pos = b.put::<Vec3>(on)?;
        plan.object_lines_n = MeshStorage::lines(on, ot).ok_or(TdStatus::TdErrParams)?;
        plan.object_lines = b.put::<Line>(plan.object_lines_n)?;
        plan.object_scratch = b.put::<FaceKey>(4 * ot)?;
        plan.pen_pos = b.put::<Vec3>(pn)?;
        plan.pen_lines_n = MeshStorage::lines(pn, pt).ok_or(TdStatus::TdErrParams)?;
        plan.pen_lines = b.put::<Line>(plan.pen_lines_n)?;
        plan.pen_scratch = b.put::<FaceKey>(4 * pt)?;
        plan.meshes = b.put::<Mesh<'static>>(2)?;
        // The object's tets (16 entries and buckets a tet), nodes, boundary faces, and the
        // pen's boundary faces, as the host sizes them.
        let tet_hash = hash_sizes(ot, 16, 16);
        let tet_entries = if p.hash_capacity == 0 {
            tet_hash.1
        } else {
            p.hash_capacity as usize
        };
        let sizes = [
            (tet_hash.0, tet_entries),
            hash_sizes(on, 1, 2),
            hash_sizes(ot, 8, 2),
            hash_sizes(pt, 16, 2),
        ];
        for (h, (starts, entries)) in plan.hashes.iter_mut().zip(sizes) {
            *h = (
                b.put::<u32>(starts)?,
                starts,
                b.put::<HashEntry>(entries)?,
                entries,
            );
        }
        plan.hash_slots = b.put::<SpatialHash<'static>>(4)?;
        plan.rest_boxes = b.put::<Aabb>(pt)?;
        plan.clusters = b.put::<Aabb>(MAX_NEAR_CLUSTERS)?;
        plan.node_clusters = b.put::<u32>(pn)?;
        plan.rest_slot = b.put::<RigidTets<'static>>(1)?;
        plan.object_boxes = b.put::<Aabb>(ot)?;
        plan.cells_slot = b.put::<Occupancy<'static>>(1)?;
        plan.scene = b.put::<PenScene<'static, 'static, 'static>>(1)?;
        plan.front = b.layout.pad_to_align().size();
        if let Some(m) = m {
            plan.measured = *m;
            plan.pen_graph = (
                b.put::<u32>(m.pen_graph.0)?,
                b.put::<NodeId>(m.pen_graph.1)?,
            );
            plan.object_graph = (
                b.put::<u32>(m.object_graph.0)?,
                b.put::<NodeId>(m.object_graph.1)?,
            );
            plan.rest_grid = (b.put::<u32>(m.rest.0)?, b.put::<GridEntry>(m.rest.1)?);
            plan.words = b.put::<u32>(m.words)?;
            plan.list_starts = b.put::<u32>(m.lists.0)?;
            plan.list_tets = b.put::<GridEntry>(m.lists.1)?;
            plan.node_starts = b.put::<u32>(m.lists.2)?;
            plan.nodes = b.put::<ListedNode>(on)?;
            plan.buffers = b.put::<Line>(m.buffers)?;
        }
        let layout = b.layout.pad_to_align();
        plan.size = layout.size();
        plan.align = layout.align();
        Ok(plan)
    }

    /// The pass's buffers' sizes for the measured graphs.
    fn buffer_sizes(
        &self,
        p: &TdPenParams,
        pen_edges: usize,
        object_edges: usize,
    ) -> PenBufferSizes {
        let queue = |n: usize| {
            if p.queue_capacity == 0 {
                n
            } else {
                p.queue_capacity as usize
            }
        };
        PenBufferSizes {
            pen_contacts: self.pen_cap,
            object_contacts: self.object_cap,
            pen_queue: queue(self.pen_nodes),
            object_queue: queue(self.object_nodes),
            ..PenBufferSizes::nodes(self.pen_nodes, self.object_nodes)
        }
        .with_crossings(pen_edges, object_edges)
    }
}

/// Appends arrays to a layout, each at its alignment.
struct PenBuilder {
    layout: Layout,
}

impl PenBuilder {
    fn put<T>(&mut self, n: usize) -> Result<usize, TdStatus> {
        let array = Layout::array::<T>(n).map_err(|_| TdStatus::TdErrParams)?;
        let (layout, offset) = self
            .layout
            .extend(array)
            .map_err(|_| TdStatus::TdErrParams)?;
        self.layout = layout;
        Ok(offset)
    }
}

/// The options of the pass and the force from the parameters.
pub(super) fn options(p: &TdPenParams) -> PenOptions {
    PenOptions {
        params: ForceParams {
            stiffness: p.stiffness,
            damping: p.damping,
            max_force: p.max_force,
            dt: p.dt,
            ..ForceParams::default()
        },
        method: if p.depth_method == 1 {
            DepthMethod::Hashed
        } else {
            DepthMethod::Traced
        },
        max_steps: p.max_steps,
        max_cells: p.max_cells,
        entry_remedy: p.entry_remedy == 1,
        max_walk: p.max_walk,
        reuse_crossings: p.reuse_crossings == 1,
    }
}

/// `n` copies of `v` from `base + at`, as a slice.
///
/// # Safety
/// As `carve` (lib.rs).
unsafe fn slice<T: Copy>(base: *mut u8, at: usize, n: usize, v: T) -> &'static mut [T] {
    // SAFETY: passed on.
    unsafe { carve(base, at, n, v) }
}

/// Writes `v` at `base + at` and returns it.
///
/// # Safety
/// `base + at` is aligned for `T` and inside memory the caller owns for `'static`, which
/// nothing else borrows.
unsafe fn place<T>(base: *mut u8, at: usize, v: T) -> &'static mut T {
    // SAFETY: the function's contract.
    unsafe {
        let p = base.add(at).cast::<T>();
        p.write(v);
        &mut *p
    }
}

/// A hash over its planned storage with cells of `cell`.
///
/// # Safety
/// As `slice`, with `h` a hash's parts of the plan.
unsafe fn hash_at(
    base: *mut u8,
    h: (usize, usize, usize, usize),
    cell: f32,
) -> Result<SpatialHash<'static>, TdStatus> {
    // SAFETY: the plan's parts of this hash.
    let (starts, entries) = unsafe {
        (
            slice(base, h.0, h.1, 0u32),
            slice(base, h.2, h.3, HashEntry::default()),
        )
    };
    SpatialHash::new(starts, entries, cell).map_err(|_| TdStatus::TdErrWorld)
}

/// Builds a mesh from C arrays into its planned parts; a refused mesh writes its item (or'ed
/// with `flag`) to `bad_item`.
///
/// # Safety
/// `xyz` holds `3 * nodes` floats and `tets` `4 * tets` indices, outside the memory; the parts
/// are the plan's.
#[allow(clippy::too_many_arguments)]
unsafe fn mesh_at(
    base: *mut u8,
    (pos_at, lines_at, lines, scratch_at): (usize, usize, usize, usize),
    (nodes, tets): (usize, usize),
    xyz: *const f32,
    tet_nodes: *const u32,
    bad_item: *mut u32,
    flag: u32,
) -> Result<Mesh<'static>, TdStatus> {
    // SAFETY: the caller's contract on the arrays and the plan's parts.
    let (xyz, tet_nodes, pos, mesh_lines, scratch) = unsafe {
        (
            core::slice::from_raw_parts(xyz, 3 * nodes),
            core::slice::from_raw_parts(tet_nodes.cast::<[u32; 4]>(), tets),
            slice(base, pos_at, nodes, Vec3::ZERO),
            slice(base, lines_at, lines, Line::ZERO),
            slice(base, scratch_at, 4 * tets, FaceKey::default()),
        )
    };
    for (p, c) in pos.iter_mut().zip(xyz.chunks_exact(3)) {
        *p = Vec3::new(c[0], c[1], c[2]);
    }
    let storage = MeshStorage::carve(nodes, tets, &mut Block::from_lines(mesh_lines))
        .map_err(|_| TdStatus::TdErrTooSmall)?;
    Mesh::build(pos, tet_nodes, storage, scratch, BuildOptions::default()).map_err(|e| {
        // SAFETY: the caller's contract on `bad_item`.
        unsafe { report_bad(bad_item, bad_index(&e) | flag) };
        TdStatus::TdErrMesh
    })
}

/// Builds the object (`object_positions`, `object_tets`: `3 * object_node_count` floats and
/// `4 * object_tet_count` node indices) and the pen (`pen_positions`, `pen_tets`: at rest,
/// its tip at the origin, its axis along +z) as the host builds mesh files, then the contact
/// scene over them as `tetradrill replay --tool mesh:FILE` does (node graphs; the object's
/// tets, nodes and boundary faces hashed with cells of its average edge; the pen's boundary
/// faces hashed; the pen's rest grid and clusters; the object's occupancy grid with its tet
/// and node lists) and the pass's buffers, all in `mem` (`len` bytes at `td_pen_size`'s
/// alignment), and writes the pen's handle (`mem`) to `*out`.
///
/// The memory: at least `td_pen_size`'s bytes, in which the meshes are built and the rest
/// measured; when `len` holds less than the whole, `TD_ERR_TOO_SMALL` with the bytes needed in
/// `*needed` (when not null): call again with that many. On success `*needed` is the bytes in
/// use. A firmware with a fixed buffer gives it whole and calls once.
///
/// # Bounded work
/// Once, before the servo runs: O(T log T) for each mesh's build, O(T) for the graphs and
/// hashes, and the grids' O(cells each tet box meets), for T tets; O(every capacity) to
/// initialise the buffers and the hand-off.
///
/// # Errors
/// `TD_ERR_NULL` / `TD_ERR_ALIGN` for a pointer, `TD_ERR_PARAMS` as `td_pen_size`,
/// `TD_ERR_TOO_SMALL` (`*needed`), `TD_ERR_MESH` for refused arrays (`*bad_item` names the
/// object's tet or node, or the pen's with the top bit `TD_PEN_ITEM` set), `TD_ERR_WORLD`
/// when the scene cannot be built over the meshes (a mesh without edges, a hash that fills
/// with `hash_capacity` 0, a grid that cannot be laid). The memory holds no pen on an error.
///
/// # Safety
/// `params` points at an initialised `td_pen_params`; the arrays at the counts it states, none
/// inside `mem`; `mem` at `len` writable bytes the caller keeps, and does not otherwise use,
/// while it uses the pen; `out` at a writable `td_pen *`; `needed` at a writable `size_t` or
/// null; `bad_item` at a writable `uint32_t` or null.
#[no_mangle]
#[allow(clippy::too_many_arguments)]
pub unsafe extern "C" fn td_pen_init(
    mem: *mut c_void,
    len: usize,
    params: *const TdPenParams,
    object_positions: *const f32,
    object_tets: *const u32,
    pen_positions: *const f32,
    pen_tets: *const u32,
    out: *mut *mut TdPen,
    needed: *mut usize,
    bad_item: *mut u32,
) -> TdStatus {
    status(|| {
        check_ptr(out)?;
        for p in [object_positions, pen_positions] {
            check_ptr(p)?;
        }
        for t in [object_tets, pen_tets] {
            check_ptr(t)?;
        }
        if !needed.is_null() {
            check_ptr(needed)?;
        }
        // SAFETY: the caller's contract on `params`; `get` checks null and alignment.
        let p = unsafe { get(params) }?;
        let front = PenPlan::of(&p, None)?;
        // Its length is checked against each part below (`needed` says how much).
        let base = caller_memory(mem, len, 0, front.align)?;
        let tell = |bytes: usize| {
            if !needed.is_null() {
                // SAFETY: checked above; writable by the caller's contract.
                unsafe { needed.write(bytes) };
            }
        };
        if len < front.front {
            tell(front.front);
            return Err(TdStatus::TdErrTooSmall);
        }
        // SAFETY: `mem` holds at least a header and a servo state (the front), aligned: their
        // handles are refused from here until the init succeeds.
        unsafe {
            ptr::addr_of_mut!((*base.cast::<PenHeader>()).magic).write(0);
            ptr::addr_of_mut!((*base.add(front.servo).cast::<PenServoState>()).magic).write(0);
        }
        // The meshes, in the front.
        // SAFETY: the plan's parts, inside `len`; the arrays by the caller's contract.
        let (object, pen) = unsafe {
            (
                mesh_at(
                    base,
                    (
                        front.object_pos,
                        front.object_lines,
                        front.object_lines_n,
                        front.object_scratch,
                    ),
                    (front.object_nodes, front.object_tets),
                    object_positions,
                    object_tets,
                    bad_item,
                    0,
                )?,
                mesh_at(
                    base,
                    (
                        front.pen_pos,
                        front.pen_lines,
                        front.pen_lines_n,
                        front.pen_scratch,
                    ),
                    (front.pen_nodes, front.pen_tets),
                    pen_positions,
                    pen_tets,
                    bad_item,
                    TD_PEN_ITEM,
                )?,
            )
        };
        // SAFETY: the plan's two mesh slots.
        let (object, pen): (&'static Mesh<'static>, &'static Mesh<'static>) = unsafe {
            (
                place(base, front.meshes, object),
                place(base, front.meshes + size_of::<Mesh<'static>>(), pen),
            )
        };
        // What the shapes give.
        let ob = Body::fixed(object);
        let pb = Body::fixed(pen);
        let cell = average_edge_length(object);
        let pen_edge = average_edge_length(pen);
        // SAFETY: the plan's rest boxes, in the front.
        let rest_boxes =
            unsafe { slice(base, front.rest_boxes, front.pen_tets, Aabb::of::<0>([])) };
        let rest = RigidTets::grid_sizes(
            &pb,
            REST_GRID_EDGE * pen_edge,
            REST_MARGIN * pen_edge,
            rest_boxes,
        )
        .unwrap_or((2, 0));
        let words = occupancy_words(object, cell);
        let lists = Occupancy::list_sizes(
            &ob,
            cell,
            OCCUPANCY_MARGIN * cell,
            words,
            OCCUPANCY_LIST_SPLIT,
        )
        .map_err(|_| TdStatus::TdErrWorld)?;
        let (pen_graph, object_graph) = (graph_sizes(pen), graph_sizes(object));
        let buffers = front
            .buffer_sizes(&p, pen_graph.1, object_graph.1)
            .lines()
            .ok_or(TdStatus::TdErrParams)?;
        let m = Measured {
            pen_graph,
            object_graph,
            rest,
            words,
            lists,
            buffers,
        };
        let plan = PenPlan::of(&p, Some(&m))?;
        if len < plan.size {
            tell(plan.size);
            return Err(TdStatus::TdErrTooSmall);
        }
        tell(plan.size);

        // The graphs.
        // SAFETY: every part below is the plan's, inside `plan.size <= len` bytes, apart.
        let (pg, og) = unsafe {
            (
                NodeGraph::build(
                    pen,
                    slice(base, plan.pen_graph.0, pen_graph.0, 0u32),
                    slice(base, plan.pen_graph.1, pen_graph.1, NodeId::NONE),
                ),
                NodeGraph::build(
                    object,
                    slice(base, plan.object_graph.0, object_graph.0, 0u32),
                    slice(base, plan.object_graph.1, object_graph.1, NodeId::NONE),
                ),
            )
        };
        let (pg, og) = (
            pg.map_err(|_| TdStatus::TdErrWorld)?,
            og.map_err(|_| TdStatus::TdErrWorld)?,
        );
        // The hashes.
        let mut hash_saturations = 0;
        // SAFETY: as above.
        let mut th = unsafe { hash_at(base, plan.hashes[0], cell) }?;
        let tets_hashed = !hash_tets(&mut th, &ob).saturated;
        if !tets_hashed {
            if p.hash_capacity == 0 {
                return Err(TdStatus::TdErrWorld);
            }
            hash_saturations += 1;
        }
        // SAFETY: as above.
        let mut nh = unsafe { hash_at(base, plan.hashes[1], cell) }?;
        if nh.rebuild_points(object.positions()).saturated {
            return Err(TdStatus::TdErrWorld);
        }
        // SAFETY: as above.
        let mut fh = unsafe { hash_at(base, plan.hashes[2], cell) }?;
        if hash_boundary_faces(&mut fh, &ob).saturated {
            return Err(TdStatus::TdErrWorld);
        }
        // SAFETY: as above.
        let mut ph = unsafe { hash_at(base, plan.hashes[3], pen_edge) }?;
        if hash_boundary_faces(&mut ph, &pb).saturated {
            return Err(TdStatus::TdErrWorld);
        }
        let hs = size_of::<SpatialHash<'static>>();
        // SAFETY: the plan's four hash slots.
        let (th, nh, fh, ph): (&'static _, &'static _, &'static _, &'static _) = unsafe {
            (
                &*place(base, plan.hash_slots, th),
                &*place(base, plan.hash_slots + hs, nh),
                &*place(base, plan.hash_slots + 2 * hs, fh),
                &*place(base, plan.hash_slots + 3 * hs, ph),
            )
        };
        // The pen at rest.
        let empty = Aabb::of::<0>([]);
        // SAFETY: as above.
        let rest_storage = unsafe {
            RigidTetsStorage {
                grid_starts: slice(base, plan.rest_grid.0, rest.0, 0u32),
                grid_tets: slice(base, plan.rest_grid.1, rest.1, GridEntry::default()),
                tet_boxes: slice(base, plan.rest_boxes, plan.pen_tets, empty),
                clusters: slice(base, plan.clusters, MAX_NEAR_CLUSTERS, empty),
                node_clusters: slice(base, plan.node_clusters, plan.pen_nodes, 0u32),
            }
        };
        let pen_rest = RigidTets::build(
            &pb,
            rest_storage,
            REST_GRID_EDGE * pen_edge,
            CLUSTER_EDGE * cell,
            REST_MARGIN * pen_edge,
        )
        .map_err(|_| TdStatus::TdErrWorld)?;
        // SAFETY: the plan's slot.
        let pen_rest: &'static RigidTets<'static> =
            unsafe { place(base, plan.rest_slot, pen_rest) };
        // The object's cells.
        // SAFETY: as above.
        let cells = unsafe {
            let storage = OccupancyStorage {
                words: slice(base, plan.words, words, 0u32),
                boxes: slice(base, plan.object_boxes, plan.object_tets, empty),
            };
            Occupancy::build(&ob, cell, OCCUPANCY_MARGIN * cell, storage)
                .and_then(|g| {
                    g.with_tet_lists(
                        &ob,
                        OCCUPANCY_LIST_SPLIT,
                        slice(base, plan.list_starts, lists.0, 0u32),
                        slice(base, plan.list_tets, lists.1, GridEntry::default()),
                    )
                })
                .and_then(|g| {
                    g.with_node_lists(
                        &ob,
                        slice(base, plan.node_starts, lists.2, 0u32),
                        slice(base, plan.nodes, plan.object_nodes, ListedNode::default()),
                    )
                })
        }
        .map_err(|_| TdStatus::TdErrWorld)?;
        // SAFETY: the plan's slot.
        let cells: &'static Occupancy<'static> = unsafe { place(base, plan.cells_slot, cells) };
        let scene = PenScene {
            pen,
            pen_graph: pg,
            pen_rest,
            pen_faces: Some(ph),
            object: ob,
            object_graph: og,
            object_tets: th,
            object_nodes: nh,
            object_cells: cells,
            object_faces: Some(fh),
            object_walks: tets_hashed && walks_exact(&ob),
            pen_walks: walks_exact(&pb),
        };
        // SAFETY: the plan's slot.
        let scene: &'static PenScene<'static, 'static, 'static> =
            unsafe { place(base, plan.scene, scene) };
        // The pass's buffers.
        // SAFETY: as above.
        let lines = unsafe { slice(base, plan.buffers, buffers, Line::ZERO) };
        let bufs = PenBuffers::carve(
            &front.buffer_sizes(&p, pen_graph.1, object_graph.1),
            &mut Block::from_lines(lines),
        )
        .map_err(|_| TdStatus::TdErrTooSmall)?;
        // The hand-off.
        // SAFETY: the plan's words, each written before it is borrowed.
        let words: &'static [AtomicU32] = unsafe {
            let w = base.add(plan.handoff_words).cast::<AtomicU32>();
            for i in 0..plan.handoff_len {
                w.add(i).write(AtomicU32::new(0));
            }
            core::slice::from_raw_parts(w, plan.handoff_len)
        };
        let handoff =
            PenHandoff::new(words, plan.pen_cap, plan.object_cap).ok_or(TdStatus::TdErrTooSmall)?;
        // SAFETY: the plan's slot.
        let handoff: &'static PenHandoff<'static> =
            unsafe { &place(base, plan.handoff, SharedPenHandoff(handoff)).0 };
        let opts = options(&p);
        let none = Penetration::default();
        // SAFETY: the plan's servo parts; the magic comes with the state.
        let servo = unsafe {
            let s = base.add(plan.servo).cast::<PenServoState>();
            s.write(PenServoState {
                magic: PEN_SERVO_MAGIC,
                scene,
                handoff,
                opts,
                state: PenState::default(),
                held_pen: [
                    slice(base, plan.held[0], plan.pen_cap, none),
                    slice(base, plan.held[1], plan.pen_cap, none),
                ],
                held_object: [
                    slice(base, plan.held[2], plan.object_cap, none),
                    slice(base, plan.held[3], plan.object_cap, none),
                ],
                current: 0,
                held: PenPublished::default(),
                now_pen: slice(base, plan.now[0], plan.pen_cap, none),
                now_object: slice(base, plan.now[1], plan.object_cap, none),
                digest: ForceDigest::new(),
                torque_digest: ForceDigest::new(),
                counts: TdPenServoCounts::default(),
            });
            s
        };
        let header = PenHeader {
            magic: PEN_MAGIC,
            scene,
            bufs,
            handoff,
            servo,
            opts,
            state: PenState::default(),
            counters: TdPenCounts {
                hash_saturations,
                bytes: plan.size as u64,
                ..TdPenCounts::default()
            },
        };
        // SAFETY: the memory's start, aligned; written whole, the magic with it.
        unsafe {
            base.cast::<PenHeader>().write(header);
            put(out, base.cast::<TdPen>())
        }
    })
}
