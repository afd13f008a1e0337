//! How big a world's buffers are: sized for the tool on the mesh ([`ToolSizing`]), or as
//! the set-up's capacities ask ([`world_sizes`]).

use tetradrill_core::collide::ZONE_MARGIN_RADII;
use tetradrill_core::force::MAX_PASSIVE;
use tetradrill_core::servo::{WorldSizes, DEFAULT_MAX_CELLS, DEFAULT_PENDING};
use tetradrill_core::TetId;

use crate::error::Error;
use crate::owned::OwnedMesh;
use crate::setup::{Capacities, SetupError, Tool, DEFAULT_HIERARCHY_CAPACITY};

/// What a burr needs on a mesh: the candidate list and the zone query's cells, sized from the
/// tool's radius against the size of the tets at the mesh's boundary (where a burr works).
///
/// A step looks for tets in the box `radius + reach` around the burr (`reach` = half the
/// radius, [`super::TickParams::reach`]), widened by one more radius for the several burr positions
/// one step may queue. The tets whose boxes meet it number about `(L + 2 e)^3 / v` for a box
/// side `L`, boundary tets of mean box side `e` and mean volume `v`; the list gets 1.5 times
/// that (at least the core's 1,024). The query visits at most as many cells as that zone
/// covers at the hash's cell size (the mesh's average edge), twice over (at least the core's
/// 4,096). A burr of 4 mm on a mesh of 0.3 mm tets needs about a hundred times what the same
/// burr needs on a mesh of 1.4 mm tets: fixed defaults would starve it (every step saturated,
/// nothing drilled).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ToolSizing {
    /// Burr radius the sizes are for, mesh units.
    pub radius: f64,
    /// Mean box side of the tets with a boundary face, mesh units.
    pub boundary_edge: f64,
    /// Mean volume of the tets with a boundary face, cubic mesh units.
    pub boundary_volume: f64,
    /// Candidate list entries.
    pub candidates: usize,
    /// Most hash cells one step's zone query visits ([`tetradrill_core::servo::World::set_max_cells`]).
    pub max_cells: u32,
    /// Pending drill work items: two for every tet whose box meets one burr position's box
    /// (a new position queues one item per tet it touches; refining them queues more), at
    /// least the core's [`DEFAULT_PENDING`].
    pub pending: usize,
    /// Hierarchy arena nodes: the drilled surface a burr leaves grows with its area in
    /// boundary tets, `(radius / e)^2`, and with its leaves per tet face, four times for every
    /// level of `--max-depth` past [`SIZED_FOR_DEPTH`]; so [`DEFAULT_HIERARCHY_CAPACITY`]
    /// (enough for a burr about one tet wide at that depth) times both, between the default
    /// and [`MAX_SIZED_ARENA`].
    pub arena: usize,
    /// Work units a step of the candidate gather chosen for a large zone
    /// ([`GATHER_FROM_TETS`]; an exact `tetradrill_core::collide::ZoneGather`), `None`:
    /// the one-shot query every step.
    pub gather_work: Option<u32>,
}

/// Tets about the burr's zone from which its candidates are gathered over steps instead of
/// queried each step: the one-shot query scans every hash entry of the zone's cells, each
/// step (on a 2-million-tet re-mesh of the teddy, burr 0.03, about 18,000 tets and 230,000
/// host instructions a step, half the tick), while an exact gather scans its box's a part a
/// step and queries the hash only on a step the burr outruns it. Below this the one-shot
/// query is cheap and every existing run stays as it was.
pub const GATHER_FROM_TETS: f64 = 8_192.0;

/// Steps one gather of a whole box takes at the work chosen: a burr crossing half the
/// gather's margin (a tenth of its radius) in as many steps, 6 radii a second at 1 kHz, does
/// not outrun it (a faster burr's step falls back to the one-shot query; the box's tets are
/// overestimated about twice, so the gathers keep up with faster burrs in practice: one step
/// fell back along `scripts/clinical-drill.sh --moving` at up to 10 radii a second). On
/// that path the fine teddy's tick p99 was 148-182 us with 8 parts of 7,000 units, 146-149
/// us with 16 of 3,500.
pub const GATHER_STEPS: f64 = 16.0;

/// The least work a step of a chosen gather does (the firmware scenarios' figure).
pub const GATHER_MIN_WORK: u32 = 2_000;

/// The `--max-depth` [`DEFAULT_HIERARCHY_CAPACITY`] is meant for (the default depth).
pub const SIZED_FOR_DEPTH: u8 = 5;

/// The largest arena [`ToolSizing`] chooses on its own: 2^23 nodes (128 MiB). A burr
/// wider than that is meant for a finer `--max-depth`'s leaves than the mesh needs; set
/// `--hierarchy-capacity` to go further.
pub const MAX_SIZED_ARENA: usize = 1 << 23;

impl ToolSizing {
    /// The sizes for a burr of `radius` on `mesh`, drilling down to `max_depth`.
    ///
    /// Work: O(T) over the mesh's tets, once at start-up.
    pub fn of(mesh: &OwnedMesh, radius: f64, max_depth: u8) -> Self {
        let positions = mesh.positions();
        let (mut side, mut vol, mut n) = (0.0f64, 0.0f64, 0usize);
        let (mut all_side, mut all_edge, mut mesh_volume) = (0.0f64, 0.0f64, 0.0f64);
        for tet in mesh.tets() {
            // f32 is plenty for a size estimate.
            let p = tet.nodes.map(|v| positions[v.idx()]);
            let lo = p[0].min(p[1]).min(p[2]).min(p[3]);
            let hi = p[0].max(p[1]).max(p[2]).max(p[3]);
            let s = (hi - lo).max_element() as f64;
            all_side += s;
            let volume = (p[1] - p[0]).dot((p[2] - p[0]).cross(p[3] - p[0])).abs() as f64 / 6.0;
            mesh_volume += volume;
            for a in 0..4 {
                for b in a + 1..4 {
                    all_edge += (p[a] - p[b]).length() as f64;
                }
            }
            if tet.neighbours.contains(&TetId::NONE) {
                side += s;
                vol += volume;
                n += 1;
            }
        }
        let tets = mesh.tets().len().max(1) as f64;
        let (e, v) = if n > 0 && vol > 0.0 {
            (side / n as f64, vol / n as f64)
        } else {
            (all_side / tets, 1.0)
        };
        let zone = 2.0 * (radius + 0.5 * radius) + radius;
        let defaults = WorldSizes::new(0, 0);
        let estimate = (zone + 2.0 * e).powi(3) / v;
        let candidates = ((1.5 * estimate).ceil() as usize)
            .max(defaults.candidates)
            .min(mesh.tets().len().max(defaults.candidates));
        let cell = all_edge / (6.0 * tets);
        let per_axis = if cell > 0.0 {
            (zone / cell).ceil() + 2.0
        } else {
            16.0
        };
        let max_cells = (2.0 * per_axis.powi(3)).min(u32::MAX as f64) as u32;
        // A large zone's candidates are gathered over steps. A gathered box is one step's
        // zone (the burr's box grown by the radius and the reach, `3 r` a side) grown by the
        // gather's margin on every side; it holds about `side^3 / V` tets of mean volume `V`
        // and box side `E`, each in about `(E / cell + 1)^3` cells, and a gather scans its
        // cells and those entries in `GATHER_STEPS` parts (on the fine teddy, 0.03: 729
        // cells and 24,000 entries where the box is half inside the mesh). Each third of the
        // storage (see `ZoneGather`) holds a list as long as the one-shot query's, or a box's
        // tets and half again.
        let mean_volume = mesh_volume / tets;
        let side = (3.0 + 4.0 * f64::from(ZONE_MARGIN_RADII)) * radius;
        let box_tets = side.powi(3) / mean_volume;
        let gathered = estimate >= GATHER_FROM_TETS && cell > 0.0 && mean_volume > 0.0;
        let gather_work = gathered.then(|| {
            let cells = (side / cell + 1.0).powi(3);
            let entries = box_tets * (all_side / tets / cell + 1.0).powi(3);
            (((cells + entries) / GATHER_STEPS).ceil() as u32).max(GATHER_MIN_WORK)
        });
        let candidates = if gathered {
            let listed = (1.5 * box_tets).ceil() as usize;
            3 * candidates.max(listed.min(mesh.tets().len()))
        } else {
            candidates
        };
        let sphere = (2.0 * radius + 2.0 * e).powi(3) / v;
        let pending = ((2.0 * sphere).ceil() as usize).max(DEFAULT_PENDING);
        let widths = if e > 0.0 { (radius / e).max(1.0) } else { 1.0 };
        let deeper = 4f64.powi(i32::from(max_depth.saturating_sub(SIZED_FOR_DEPTH)));
        let arena = ((DEFAULT_HIERARCHY_CAPACITY as f64) * widths * widths * deeper)
            .min(MAX_SIZED_ARENA as f64) as usize;
        Self {
            radius,
            boundary_edge: e,
            boundary_volume: v,
            arena,
            pending,
            candidates,
            max_cells: max_cells.max(DEFAULT_MAX_CELLS),
            gather_work,
        }
    }
}

/// The storage sizes of a world over a mesh of `tets` tets: the core's defaults
/// ([`WorldSizes::new`]) with the set-up's capacities. A v_list smaller than the arena needs
/// shrinks the arena to what it can list (every block of 8 adds 7 leaves).
///
/// # Errors
/// A v_list shorter than the mesh's tet count (one entry per coarse tet is the least the
/// hierarchy needs), naming the key and the flag.
pub fn world_sizes(tets: usize, capacities: &Capacities) -> Result<WorldSizes, Error> {
    world_sizes_for(tets, capacities, None)
}

/// [`world_sizes`] with the candidate list, pending deque and arena sized for the burr on the
/// mesh (`sizing`) where the capacities leave them unset.
pub(super) fn world_sizes_for(
    tets: usize,
    c: &Capacities,
    sizing: Option<&ToolSizing>,
) -> Result<WorldSizes, Error> {
    let pending = match (c.pending, sizing) {
        (Some(p), _) => p,
        (None, Some(z)) => z.pending,
        (None, None) => DEFAULT_PENDING,
    };
    let arena = match (c.hierarchy, sizing) {
        (Some(a), _) => a,
        (None, Some(z)) => z.arena,
        (None, None) => DEFAULT_HIERARCHY_CAPACITY,
    };
    let mut s = WorldSizes::new(tets, arena).with_pending(pending);
    s.candidates = match (c.candidates, sizing) {
        (Some(c), _) => c,
        (None, Some(z)) => z.candidates,
        (None, None) => s.candidates,
    };
    if let Some(h) = c.hash {
        s.hash_entries = h;
    }
    if let Some(v) = c.vlist {
        if v < tets {
            return Err(Error::Setup(SetupError::new(
                "vlist_capacity",
                format!(
                    "vlist_capacity (--vlist-capacity) {v} is below the mesh's {tets} coarse tets \
                 (the v_list needs one entry per tet)"
                ),
            )));
        }
        s.vlist = v;
        s.arena = s.arena.min((v - tets) / 7 * 8);
    }
    Ok(s)
}

impl ToolSizing {
    /// The sizes for `tool` on `mesh` drilling down to `max_depth`: a burr's own; a drill's
    /// with the candidate list and the zone query grown to the shaft's reach (a burr as wide
    /// as the whole tool, for those two only); `None` for a tet-mesh tool.
    pub fn for_tool(mesh: &OwnedMesh, tool: &Tool, max_depth: u8) -> Option<Self> {
        match *tool {
            Tool::Sphere { radius } => Some(Self::of(mesh, radius, max_depth)),
            Tool::Drill {
                burr, shaft_radius, ..
            } => {
                // The burr as a sphere; each of the shaft's passive points lists the tets
                // near it and its proxy (`World::track_shaft`): a box `2 (shaft radius +
                // its reach)` a side (the reach half the shaft's radius, as the burr's is
                // half the burr's: `DrillTool::shaft_reach`), grown by a burr radius of the
                // proxy's travel, for at most `MAX_PASSIVE` points, in the first third of the
                // storage with a gather.
                let z = Self::of(mesh, burr, max_depth);
                let side = 3.0 * shaft_radius + burr;
                let e = z.boundary_edge;
                let per_point = if z.boundary_volume > 0.0 {
                    1.5 * (side + 2.0 * e).powi(3) / z.boundary_volume
                } else {
                    0.0
                };
                let shaft = ((MAX_PASSIVE as f64 * per_point).ceil() as usize)
                    .min(MAX_PASSIVE * mesh.tets().len());
                let thirds = if z.gather_work.is_some() { 3 } else { 1 };
                Some(Self {
                    candidates: z.candidates.max(thirds * shaft),
                    ..z
                })
            }
            Tool::Mesh { .. } => None,
        }
    }
}
