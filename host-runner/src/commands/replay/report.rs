//! What a replay reports: the summary JSON `replay --json` writes, and its parts.

use serde::Serialize;
use tetradrill_core::servo::Saturations;

use crate::engine::EngineStorage;
use crate::scenario::Scenario;
use crate::setup::Setup;
use crate::soft::DeformSummary;
use crate::stats::Summary;

/// The summary of a replay (the JSON `replay --json` writes).
#[derive(Debug, Serialize)]
pub struct ReplayReport {
    /// The scenario as run.
    pub scenario: Scenario,
    /// The mesh.
    pub mesh: MeshCounts,
    /// Ticks replayed.
    pub ticks: u64,
    /// Volume of the mesh before drilling.
    pub initial_volume: f64,
    /// Sum of the erased leaves' volumes.
    pub removed_volume: f64,
    /// The removed volume by region label (each leaf counts for its root tet's label); the
    /// values sum to `removed_volume`. Absent for a mesh tool, or a mesh of more than 256
    /// labels without materials.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub removed_by_region: Option<std::collections::BTreeMap<String, f64>>,
    /// The work against the feed and the cutting energy of what it cut (a world with
    /// regions only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub drill: Option<DrillSummary>,
    /// Hierarchy nodes instantiated (root slots included).
    pub hierarchy_nodes: usize,
    /// Visible faces of the drilled surface.
    pub visible_faces: u32,
    /// Connected pieces of remaining material, after the debris is erased.
    pub components: u32,
    /// Debris erased (detached pieces smaller than
    /// `tetradrill_core::hierarchy::DEBRIS_LEAVES` max-depth leaves; its volume is in
    /// `removed_volume`): by the drill's checks while drilling, and by the sweep over the
    /// whole object at the end.
    pub debris_erased: DebrisSummary,
    /// Forces.
    pub force: ForceSummary,
    /// FNV-1a hash of the bits of every tick's force, as hex: identical whenever the force
    /// series is bit-identical.
    pub force_digest: String,
    /// Per-tick compute times (simulation step + servo force); with `--repeat N`, each
    /// tick's fastest of the N runs.
    pub timing_us: TickTiming,
    /// Runs the timing is the fastest of (`--repeat`).
    pub runs: u32,
    /// Capacity saturations by kind.
    pub saturations: SaturationCounts,
    /// The high-water marks of the world's buffers beside their capacities (sphere tools
    /// only): what a board with little RAM sizes its buffers from.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub peaks: Option<PeakCounts>,
    /// The final state passed the core's `validate()` (mesh and hierarchy).
    pub valid: bool,
    /// The burr's buffers as sized for this mesh (sphere tools only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sizing: Option<SizingSummary>,
    /// The drill's shaft (`--tool drill:...` only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub shaft: Option<ShaftSummary>,
    /// Contact of a tet-mesh tool (`--tool mesh:FILE` only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub pen: Option<PenSummary>,
    /// The soft body (`--body soft` only): its largest displacement, step time and rate.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub deform: Option<DeformSummary>,
}

/// The regions cut by the feed (`[regions.LABEL] cutting_energy`; docs/DRILLING.md,
/// "Cutting resistance"): newton mesh units, joules for a mesh in metres.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct DrillSummary {
    /// Work done pushing the burr into material cut by the feed, against the contact's
    /// reaction (`F * max(0, -dc . n)` summed over the steps).
    pub cutting_work_j: f64,
    /// Each cut leaf's volume times its region's cutting energy, summed: the energy the
    /// removed material took.
    pub cutting_energy_j: f64,
    /// Work done and not yet spent on a leaf at the end.
    pub feed_pool_j: f64,
    /// Work done that bought no material: beyond what the pool keeps while no leaf waits,
    /// or left in it when the drill stopped.
    pub feed_dropped_j: f64,
}

impl DrillSummary {
    /// The figures of `world`'s regions (`None` without regions).
    pub fn of(world: &tetradrill_core::servo::World<'_>) -> Option<Self> {
        let r = world.regions()?;
        Some(Self {
            cutting_work_j: r.cutting_work(),
            cutting_energy_j: r.cutting_energy(),
            feed_pool_j: r.feed_pool(),
            feed_dropped_j: r.feed_dropped(),
        })
    }
}

/// The most of each world buffer a replay used, beside its capacity (counted before the
/// final debris sweep). A peak below its capacity never saturated; a peak at it may have
/// (the saturation counts say).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
pub struct PeakCounts {
    /// Hierarchy arena nodes handed out (`Hierarchy::arena_used`, the arena's high-water
    /// mark; the v_list needs `HierarchyStorage::vlist_needed` of it).
    pub arena_nodes: usize,
    /// Hierarchy arena capacity.
    pub arena_capacity: usize,
    /// The most items the drill's coarse pending ring held at once.
    pub pending_coarse: usize,
    /// The coarse ring's capacity (the deque less its fine half).
    pub pending_coarse_capacity: usize,
    /// The most items the fine pending ring held at once.
    pub pending_fine: usize,
    /// The fine ring's capacity (half the deque from `FINE_MIN_DEQUE` entries up, else 0).
    pub pending_fine_capacity: usize,
    /// The longest candidate list a simulation step used.
    pub candidates: usize,
    /// The candidate storage (in thirds with a candidate gather: the list in use is one).
    pub candidate_capacity: usize,
    /// Entries the tet hash stored.
    pub hash_entries: usize,
    /// The tet hash's entry capacity.
    pub hash_capacity: usize,
}

/// The buffers a burr run chose from the tool and the mesh ([`crate::engine::ToolSizing`]).
#[derive(Debug, Clone, Copy, Default, Serialize)]
pub struct SizingSummary {
    /// Mean box side of the mesh's boundary tets, mesh units (0 when not sized).
    pub boundary_edge: f64,
    /// Candidate list entries.
    pub candidate_capacity: usize,
    /// `true` when the list was sized from the tool, `false` when the scenario set it.
    pub candidates_from_tool: bool,
    /// Most hash cells one step's zone query visits.
    pub max_cells: u32,
    /// Hierarchy arena nodes (sized from the tool, the mesh and `--max-depth` unless the
    /// scenario set `hierarchy_capacity`).
    pub hierarchy_capacity: usize,
    /// Work units a step of the candidate gather (the scenario's `zone_gather_work`, or
    /// chosen for a large zone), absent for the one-shot query every step.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub zone_gather_work: Option<u32>,
    /// Steps an exact gather answered with the one-shot query (the burr outran it), absent
    /// without one.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub zone_gather_fallbacks: Option<u32>,
    /// The drill's finest leaf edge, mesh units (`Setup::drill_resolution`: the one set, or
    /// the burr's radius over `RESOLUTION_PER_RADIUS`); 0: none, every tet to `max_depth`.
    pub resolution: f64,
}

impl SizingSummary {
    /// What `store` chose for `sc` (the query cells are the world's, set afterwards).
    pub fn of(store: &EngineStorage, sc: &Setup) -> Self {
        Self {
            boundary_edge: store.tool_sizing().map_or(0.0, |z| z.boundary_edge),
            candidate_capacity: store.candidate_capacity(),
            candidates_from_tool: sc.capacities.candidates.is_none(),
            max_cells: store.tool_sizing().map_or(0, |z| z.max_cells),
            hierarchy_capacity: store.hierarchy_capacity(),
            zone_gather_work: store.zone_gather().map(|z| z.work()),
            zone_gather_fallbacks: None,
            resolution: sc.drill_resolution(),
        }
    }

    /// This summary with the steps `world`'s exact gather fell back (after the run).
    pub fn after(self, world: &tetradrill_core::servo::World<'_>) -> Self {
        Self {
            zone_gather_fallbacks: world
                .zone_gather()
                .filter(|z| z.is_exact())
                .map(|z| z.fallbacks()),
            ..self
        }
    }

    /// One line for the summary.
    pub fn line(&self) -> String {
        let gather = match (self.zone_gather_work, self.zone_gather_fallbacks) {
            (Some(w), Some(f)) => {
                format!("; candidates gathered {w} units a step, the one-shot query on {f} step(s)")
            }
            (Some(w), None) => format!("; candidates gathered {w} units a step"),
            _ => String::new(),
        };
        let leaf = if self.resolution > 0.0 {
            format!("; leaves down to {:.4e} units", self.resolution)
        } else {
            String::new()
        };
        format!(
            "sized for the burr: {} candidates ({}), {} query cells, {} hierarchy nodes (boundary tets {:.4} units){gather}{leaf}",
            self.candidate_capacity,
            if self.candidates_from_tool {
                "from the tool and the mesh"
            } else {
                "candidate_capacity"
            },
            self.max_cells,
            self.hierarchy_capacity,
            self.boundary_edge
        )
    }
}

/// Contact figures of a tet-mesh tool replay.
#[derive(Debug, Default, Serialize)]
pub struct PenSummary {
    /// Tool nodes and tets.
    pub tool_nodes: usize,
    /// Tool tets.
    pub tool_tets: usize,
    /// Depth method used.
    pub depth_method: String,
    /// Most tool nodes inside the object in one tick.
    pub pen_collisions_max: usize,
    /// Most object nodes inside the tool in one tick.
    pub object_collisions_max: usize,
    /// Colliding nodes that got no depth (a region without a border edge), summed over ticks.
    pub unreached: u64,
    /// Ticks whose force was clamped.
    pub clamped_ticks: u64,
    /// Ticks in which a buffer saturated.
    pub saturated_ticks: u64,
    /// Border edges met, both bodies, summed over ticks.
    pub border_edges: u64,
    /// Of them, crossings taken from last tick's face without a search (`crossings = "reuse"`).
    pub reused_crossings: u64,
    /// Servo ticks per contact pass (`contact_period`).
    pub contact_period: u32,
    /// Threads of a contact pass (`pass_threads`).
    pub pass_threads: u32,
    /// Contact passes run.
    pub passes: u64,
    /// Time of the servo half alone (the force carried from the last pass), every tick.
    pub servo_us: TickTiming,
    /// Time of the contact passes alone.
    pub pass_us: TickTiming,
    /// Ticks whose servo could not carry every held penetration (left out of the force).
    pub servo_short_ticks: u64,
}

/// The passive points of a drill's shaft over a replay.
#[derive(Debug, Default, Clone, Copy, Serialize)]
pub struct ShaftSummary {
    /// Passive points along the shaft.
    pub passive_points: usize,
    /// Ticks in which a passive point had a contact plane (a face within reach, or held).
    pub near_ticks: u64,
    /// Ticks in which a passive point was held at a face it had crossed.
    pub held_ticks: u64,
    /// Most passive points held in one tick.
    pub held_max: u32,
    /// The bound on the shaft's walk, hierarchy nodes a tick (`--shaft-nodes`; 0: none).
    pub nodes_bound: u32,
    /// Most hierarchy nodes the shaft's walk entered in one tick.
    pub nodes_max: u32,
    /// Hierarchy nodes the shaft's walk entered, summed over the ticks.
    pub nodes_total: u64,
    /// Ticks whose walk was cut at the bound (its points kept their last state).
    pub cut_ticks: u64,
    /// Passive points left with an earlier tick's state, summed over the ticks.
    pub stale_points: u64,
    /// Most nodes held for the shaft's walk out of the drill's share of a tick, under the
    /// tick budget (`tetradrill_core::servo::World::shaft_reserve`).
    pub hold_max: u32,
    /// Nodes held for the shaft's walk, summed over the ticks (6 drill units each).
    pub hold_total: u64,
}

/// The debris a replay erased ([`tetradrill_core::hierarchy::CrumbStats`] while drilling,
/// [`tetradrill_core::hierarchy::DebrisReport`] at the end).
#[derive(Debug, Default, Clone, Copy, Serialize)]
pub struct DebrisSummary {
    /// Pieces erased.
    pub pieces: u32,
    /// Hierarchy leaves erased.
    pub nodes: u32,
    /// Volume erased.
    pub volume: f64,
    /// Of the pieces, those the final sweep found (the drill's checks missed them: their
    /// storage was full, or their seeds still waited for budget).
    pub final_sweep: u32,
    /// Debris checks whose storage was full (each treated as "not debris").
    pub saturations: u32,
}

impl DebrisSummary {
    /// What the drill's checks erased while drilling (no final sweep).
    pub fn during(c: tetradrill_core::hierarchy::CrumbStats) -> Self {
        Self {
            pieces: c.pieces,
            nodes: c.nodes,
            volume: c.volume,
            final_sweep: 0,
            saturations: c.saturations,
        }
    }
}

/// Mesh counts of a report.
#[derive(Debug, Serialize)]
pub struct MeshCounts {
    /// Nodes.
    pub nodes: usize,
    /// Tets.
    pub tets: usize,
    /// Boundary faces.
    pub boundary_faces: u32,
}

/// Force figures of a report.
#[derive(Debug, Serialize)]
pub struct ForceSummary {
    /// Largest force magnitude, newtons.
    pub max_n: f32,
    /// Force at the last tick, newtons.
    #[serde(rename = "final")]
    pub last: [f32; 3],
    /// Ticks with a non-zero force.
    pub contact_ticks: u64,
}

/// Tick timing of a report, microseconds.
#[derive(Debug, Default, Serialize)]
pub struct TickTiming {
    /// Mean.
    pub tick_mean: f64,
    /// 99th percentile.
    pub tick_p99: f64,
    /// 99.9th percentile.
    pub tick_p999: f64,
    /// Largest.
    pub tick_max: f64,
}

impl From<Summary> for TickTiming {
    fn from(t: Summary) -> Self {
        Self {
            tick_mean: t.mean,
            tick_p99: t.p99,
            tick_p999: t.p999,
            tick_max: t.max,
        }
    }
}

/// Saturations by kind, and their total.
#[derive(Debug, Default, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct SaturationCounts {
    /// All kinds.
    pub total: u32,
    /// Static hash builds out of entries (`--hash-capacity`).
    pub hash: u32,
    /// Steps whose candidate list filled (`--candidate-capacity`).
    pub candidates: u32,
    /// Refinements refused, arena full (`--hierarchy-capacity`, `--vlist-capacity`).
    pub arena: u32,
    /// Drill work dropped, pending deque full (`--pending-capacity`).
    pub pending: u32,
    /// Contact searches that reached their node bound and kept the last contact plane
    /// (`--contact-search-nodes`).
    pub contact_search: u32,
    /// Mesh-tool ticks whose collision list filled (`--contact-capacity`).
    pub contacts: u32,
    /// Mesh-tool ticks whose depth propagation queue filled (`--queue-capacity`).
    pub queue: u32,
}

impl SaturationCounts {
    /// With `total` set to the sum of the kinds.
    pub fn totalled(self) -> Self {
        Self {
            total: self.hash
                + self.candidates
                + self.arena
                + self.pending
                + self.contact_search
                + self.contacts
                + self.queue,
            ..self
        }
    }
}

impl SaturationCounts {
    /// One warning line for each kind of saturation that stops material removal or contact,
    /// naming the flag and scenario key that raise the buffer, and how often it happened in
    /// the run's `ticks`.
    /// Contact searches cut short by their node bound are not among them: they answer with
    /// the closest face met (docs/SAFETY.md).
    pub fn warnings(&self, ticks: u64) -> Vec<String> {
        let kinds = [
            (
                self.candidates,
                "the candidate list was full or the burr's zone too wide: tets near the burr were \
                 left out; raise --candidate-capacity (key candidate_capacity)",
            ),
            (
                self.arena,
                "the hierarchy arena was full: refinements were refused and the drilled surface \
                 stopped short of --max-depth; raise --hierarchy-capacity (key \
                 hierarchy_capacity)",
            ),
            (
                self.pending,
                "the pending deque was full: drill work was dropped and material in the burr's \
                 path was left; raise --pending-capacity (key pending_capacity)",
            ),
            (
                self.hash,
                "the hash ran out of entries: tets were left out of collision; raise \
                 --hash-capacity (key hash_capacity)",
            ),
            (
                self.contacts,
                "the mesh tool's collision list was full; raise --contact-capacity (key \
                 contact_capacity)",
            ),
            (
                self.queue,
                "the mesh tool's depth queue was full; raise --queue-capacity (key \
                 queue_capacity)",
            ),
        ];
        kinds
            .iter()
            .filter(|(n, _)| *n > 0)
            .map(|(n, what)| format!("{what} ({n} times in {ticks} ticks)"))
            .collect()
    }
}

impl std::fmt::Display for SaturationCounts {
    /// The total, then the kinds that are not zero: `12 (arena 9, pending 3)`.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}", self.total)?;
        let kinds = [
            ("hash", self.hash),
            ("candidates", self.candidates),
            ("arena", self.arena),
            ("pending", self.pending),
            ("contact search", self.contact_search),
            ("contacts", self.contacts),
            ("queue", self.queue),
        ];
        let mut first = true;
        for (name, n) in kinds.iter().filter(|(_, n)| *n > 0) {
            f.write_str(if first { " (" } else { ", " })?;
            write!(f, "{name} {n}")?;
            first = false;
        }
        if !first {
            f.write_str(")")?;
        }
        Ok(())
    }
}

impl From<Saturations> for SaturationCounts {
    fn from(s: Saturations) -> Self {
        Self {
            hash: s.hash,
            candidates: s.candidates,
            arena: s.arena,
            pending: s.pending,
            contact_search: s.contact,
            ..Self::default()
        }
        .totalled()
    }
}
