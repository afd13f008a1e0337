//! `tetradrill replay`: a deterministic offline run, tick by tick with no sleeping, through the
//! same core code path as the real-time servo; a summary JSON for scripts.

use std::path::PathBuf;

use serde::Serialize;
use tetradrill_core::depth::Penetration;
use tetradrill_core::force::{
    pen_servo_force, ForceDigest, HeldContact, PenState, ServoScratch, ToolState,
};
use tetradrill_core::hierarchy::DEBRIS_LEAVES;
use tetradrill_core::servo::Saturations;
use tetradrill_core::Quat;
use tetradrill_core::Vec3;

use crate::engine::{self, EngineStorage, ShaftState, TickParams};
use crate::error::CliError;
use crate::pen::{PenRig, PenSizes};
use crate::pen_pair::with_pass_runner;
use crate::platform::now_ns;
use crate::scenario::{Scenario, ScenarioFlags, ToolKind};
use crate::soft::{DeformSummary, SoftDriver, SoftSpec};
use crate::stats::{summarise_ns, Summary};
use crate::traces::PoseSource;

/// Arguments of `replay`.
#[derive(Debug, clap::Args)]
pub struct ReplayArgs {
    /// Scenario settings (mesh, trace, tool, stiffness, drilling limits).
    #[command(flatten)]
    pub scenario: ScenarioFlags,
    /// Write the summary as JSON.
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Write the drilled surface (the visible faces) as a Wavefront OBJ.
    #[arg(long)]
    pub surface: Option<PathBuf>,
    /// Replay at most this many ticks (default: the whole trace; 60 s of a wander).
    #[arg(long, allow_negative_numbers = true)]
    pub ticks: Option<u64>,
    /// No progress bar.
    #[arg(long)]
    pub quiet: bool,
    /// Write a PNG of the drilled surface, the tool and the force at the end (no display
    /// needed).
    #[arg(long)]
    pub screenshot: Option<PathBuf>,
    /// Replay this many times from scratch (1 to 100; a sphere tool only) and time each tick
    /// as the fastest of the runs: the tick's cost without the preemption of a shared
    /// machine. Every run must give the same force digest (checked).
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=100))]
    pub repeat: u32,
}

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

/// The buffers a burr run chose from the tool and the mesh ([`engine::ToolSizing`]).
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
}

impl SizingSummary {
    /// What `store` chose for `sc` (the query cells are the world's, set afterwards).
    pub fn of(store: &EngineStorage, sc: &Scenario) -> Self {
        Self {
            boundary_edge: store.tool_sizing().map_or(0.0, |z| z.boundary_edge),
            candidate_capacity: store.candidate_capacity(),
            candidates_from_tool: sc.candidate_capacity.is_none(),
            max_cells: store.tool_sizing().map_or(0, |z| z.max_cells),
            hierarchy_capacity: store.hierarchy_capacity(),
        }
    }

    /// One line for the summary.
    pub fn line(&self) -> String {
        format!(
            "sized for the burr: {} candidates ({}), {} query cells, {} hierarchy nodes (boundary tets {:.4} units)",
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

/// Runs `replay`.
pub fn run(args: &ReplayArgs) -> Result<(), CliError> {
    let sc = Scenario::from_flags(&args.scenario)?;
    let soft = SoftSpec::of(&sc)?;
    if let ToolKind::Mesh(pen) = sc.tool_kind().map_err(CliError::input)? {
        if args.repeat > 1 {
            return Err(CliError::input(
                "--repeat times a sphere tool's replay; a mesh tool's replay runs once",
            ));
        }
        return replay_pen(args, sc, &pen);
    }
    if sc.contact_period != 1 {
        return Err(CliError::input(
            "--contact-period spaces a mesh tool's contact passes; a sphere tool's replay \
             simulates every tick",
        ));
    }
    if sc.pass_threads != 1 {
        return Err(CliError::input(
            "--pass-threads splits a mesh tool's contact pass over two threads; a sphere tool \
             has no such pass",
        ));
    }
    let view = crate::viewer::ViewOptions::of(true, args.screenshot.clone())?;
    let params = TickParams::of(&sc)?;
    let poses = PoseSource::for_scenario(&sc)?;
    let loaded = engine::load_mesh(&sc)?;
    let ticks = replay_ticks(args, &poses);
    // The earlier runs of `--repeat`: timings and digests only, each from scratch.
    let mut fastest: Vec<u64> = Vec::new();
    let mut digests: Vec<u64> = Vec::new();
    for run in 1..args.repeat {
        if !args.quiet {
            errln!("replay: run {run} of {} (timing)", args.repeat);
        }
        let mut store = EngineStorage::try_allocate(loaded.mesh.clone(), &sc)?;
        store.set_labels(&loaded.labels, &sc)?;
        let mut owned = soft_owned(&mut store, soft.as_ref(), &loaded.labels)?;
        let mut world = store.world()?;
        let mut driver = soft_driver(soft.as_ref(), owned.as_mut())?;
        let mut tool = ToolState::default();
        let mut shaft = ShaftState::default();
        let mut digest = ForceDigest::new();
        let mut times = vec![0u64; ticks as usize];
        for i in 0..ticks {
            let (f, ns) = timed_tick(&mut world, &mut tool, &mut shaft, &params, &poses.at(i));
            times[i as usize] = ns;
            digest.push(f);
            if let Some(d) = driver.as_mut() {
                d.after_tick(&mut world, f)?;
            }
        }
        keep_fastest(&mut fastest, &times);
        digests.push(digest.value());
    }
    let mut store = EngineStorage::try_allocate(loaded.mesh, &sc)?;
    store.set_labels(&loaded.labels, &sc)?;
    let region_labels = store.region_labels().to_vec();
    let sizing = SizingSummary::of(&store, &sc);
    let mut owned = soft_owned(&mut store, soft.as_ref(), &loaded.labels)?;
    let mut world = store.world()?;
    let mut driver = soft_driver(soft.as_ref(), owned.as_mut())?;
    let sizing = SizingSummary {
        max_cells: world.max_cells(),
        ..sizing
    };
    let initial_volume = world.mesh().volume();

    let mut tool = ToolState::default();
    let mut shaft = ShaftState::default();
    let mut shaft_sum = params.shaft.map(|d| ShaftSummary {
        passive_points: d.passive_count(),
        ..ShaftSummary::default()
    });
    let mut digest = ForceDigest::new();
    let mut times = vec![0u64; ticks as usize];
    let (mut max_n, mut last, mut contact_ticks) = (0.0f32, Vec3::ZERO, 0u64);
    let mut last_pose = None;
    let progress = !args.quiet && ticks >= 20_000;
    for i in 0..ticks {
        let pose = poses.at(i);
        let (f, ns) = timed_tick(&mut world, &mut tool, &mut shaft, &params, &pose);
        if let Some(s) = shaft_sum.as_mut() {
            s.near_ticks += u64::from(shaft.last.near > 0);
            s.held_ticks += u64::from(shaft.last.held > 0);
            s.held_max = s.held_max.max(shaft.last.held);
        }
        times[i as usize] = ns;
        digest.push(f);
        if let Some(d) = driver.as_mut() {
            d.after_tick(&mut world, f)?;
        }
        max_n = max_n.max(f.length());
        if f != Vec3::ZERO {
            contact_ticks += 1;
        }
        last = f;
        last_pose = Some(pose);
        if progress && i % 5000 == 0 {
            err!(
                "\rreplay: {:>3}% ({i}/{ticks} ticks)",
                i * 100 / ticks.max(1)
            );
        }
    }
    if progress {
        errln!("\rreplay: 100% ({ticks}/{ticks} ticks)");
    }
    if let Some(d) = digests.iter().find(|&&d| d != digest.value()) {
        return Err(CliError::failure(format!(
            "the runs of --repeat differ: force digest {d:016x} in an earlier run, {:016x} in \
             the last (the replay is not deterministic)",
            digest.value()
        )));
    }
    keep_fastest(&mut fastest, &times);
    let t: Summary = summarise_ns(&fastest);
    // The crumbs the drill's discretisation leaves along the swept boundary go, then the
    // pieces left are counted.
    let during = world.debris();
    let mut scratch = vec![0u32; world.hierarchy().debris_scratch_needed()];
    let debris = world
        .remove_debris(DEBRIS_LEAVES, sc.max_depth, &mut scratch)
        .map_err(|e| CliError::failure(format!("cannot erase the debris: {e}")))?;
    let h = world.hierarchy();
    let components = debris.components;
    let valid = engine::validate(&world);
    let rep = ReplayReport {
        mesh: MeshCounts {
            nodes: world.mesh().node_count(),
            tets: world.mesh().tet_count(),
            boundary_faces: world.mesh().stats().boundary_faces,
        },
        ticks,
        initial_volume,
        removed_volume: h.removed_volume(),
        removed_by_region: engine::removed_by_region(&world, &region_labels),
        hierarchy_nodes: h.node_count(),
        visible_faces: h.visible_face_count(),
        components,
        debris_erased: DebrisSummary {
            pieces: during.pieces + debris.pieces,
            nodes: during.nodes + debris.nodes,
            volume: during.volume + debris.volume,
            final_sweep: debris.pieces,
            saturations: during.saturations,
        },
        force: ForceSummary {
            max_n,
            last: last.to_array(),
            contact_ticks,
        },
        force_digest: format!("{:016x}", digest.value()),
        timing_us: TickTiming::from(t),
        runs: args.repeat,
        saturations: SaturationCounts::from(world.saturations()),
        valid: valid.is_ok(),
        sizing: Some(sizing),
        scenario: sc,
        shaft: shaft_sum,
        pen: None,
        deform: driver.as_ref().map(SoftDriver::summary),
    };
    if let Some(path) = &args.surface {
        write_surface_obj(&world, path)?;
    }
    print_summary(&rep);
    if let Some(path) = &args.json {
        crate::report::write_json(path, &rep)?;
    }
    if let Some(path) = &view.screenshot {
        let tool = last_pose.map(|p| {
            let on = p.buttons & tetradrill_core::script::DRILL_ON != 0;
            let tv = crate::viewer::publish::tool_view(&world, p.position, params.radius, last, on);
            crate::viewer::publish::with_shaft(tv, params.shaft, p.rotation, &shaft.drill)
        });
        let status = crate::tasks::SimStatus {
            steps: rep.ticks,
            removed_volume: rep.removed_volume,
            hierarchy_nodes: rep.hierarchy_nodes,
            visible_faces: rep.visible_faces,
            saturations: rep.saturations.total,
            ..Default::default()
        };
        let mut scene = crate::viewer::publish::scene_of(&world, tool, status);
        crate::viewer::screenshot(&mut scene, path)?;
    }
    valid.map_err(|e| CliError::failure(format!("the final state is invalid: {e}")))
}

/// A deforming world over `store` and the soft body's storage, its materials set from the
/// mesh's region `labels`, when the scenario has a soft body.
fn soft_owned(
    store: &mut EngineStorage,
    spec: Option<&SoftSpec>,
    labels: &[i32],
) -> Result<Option<crate::soft::SoftOwned>, CliError> {
    let Some(spec) = spec else {
        return Ok(None);
    };
    store.enable_deformation()?;
    let mut owned = store.soft_owned();
    owned.set_regions(labels, spec)?;
    Ok(Some(owned))
}

/// The soft body's driver over `owned` when the scenario has one.
fn soft_driver<'a>(
    spec: Option<&SoftSpec>,
    owned: Option<&'a mut crate::soft::SoftOwned>,
) -> Result<Option<SoftDriver<'a>>, CliError> {
    match (spec, owned) {
        (Some(s), Some(o)) => SoftDriver::new(o, s).map(Some),
        _ => Ok(None),
    }
}

/// One [`engine::tick_tool`] at `pose`: the force and the tick's duration in nanoseconds.
fn timed_tick(
    world: &mut tetradrill_core::servo::World<'_>,
    tool: &mut ToolState,
    shaft: &mut ShaftState,
    params: &TickParams,
    pose: &crate::traces::Pose,
) -> (Vec3, u64) {
    let t0 = now_ns();
    let (f, _) = engine::tick_tool(world, tool, shaft, params, pose);
    (f, now_ns() - t0)
}

/// `fastest[i] = min(fastest[i], times[i])`; an empty `fastest` takes `times`.
fn keep_fastest(fastest: &mut Vec<u64>, times: &[u64]) {
    if fastest.is_empty() {
        fastest.extend_from_slice(times);
    } else {
        for (f, &t) in fastest.iter_mut().zip(times) {
            *f = (*f).min(t);
        }
    }
}

/// Ticks to replay: `--ticks` when given, capped at the source's length.
fn replay_ticks(args: &ReplayArgs, poses: &PoseSource) -> u64 {
    match (args.ticks, poses) {
        // A wander has no end: `--ticks` sets its length.
        (Some(t), PoseSource::Wander { .. }) => t,
        (Some(t), _) => t.min(poses.ticks()),
        (None, _) => poses.ticks(),
    }
}

/// `replay --tool mesh:FILE`: the tet-mesh tool (the pen) against the object, contact only
/// (consistent penetration depth, Praktikum report, section 4): the tool sits at the trace's pose
/// each tick (tip at the position, identity rotation = axis along +z).
fn replay_pen(args: &ReplayArgs, sc: Scenario, pen_path: &std::path::Path) -> Result<(), CliError> {
    if args.surface.is_some() || args.screenshot.is_some() {
        return Err(CliError::input(
            "--surface and --screenshot show the drilled surface: they need a sphere:R tool",
        ));
    }
    let poses = PoseSource::for_scenario(&sc)?;
    let obj = engine::load_mesh(&sc)?.mesh;
    let pen = crate::meshio::load(pen_path, sc.tool_scale)?;
    for w in &pen.warnings {
        errln!("tetradrill: warning: {w}");
    }
    let ticks = replay_ticks(args, &poses);
    // The object is not drilled here: its components come from an untouched hierarchy.
    let mut store = crate::pen::object_store(obj.clone(), &sc)?;
    let world = store.world()?;
    // The object is only read: its state is checked once, at the end as at the start.
    let valid = engine::validate(&world);
    let h = world.hierarchy();
    let mut scratch = vec![0u32; h.components_scratch_needed()];
    let components = h
        .components(world.mesh(), &mut scratch)
        .map_err(|e| CliError::failure(format!("cannot count components: {e}")))?;
    let (initial_volume, counts, visible_faces) = (
        world.mesh().volume(),
        MeshCounts {
            nodes: world.mesh().node_count(),
            tets: world.mesh().tet_count(),
            boundary_faces: world.mesh().stats().boundary_faces,
        },
        h.visible_face_count(),
    );
    let opts = crate::pen::options(&sc);
    let mut pen_info = PenSummary {
        tool_nodes: pen.mesh.positions().len(),
        tool_tets: pen.mesh.tets().len(),
        depth_method: format!("{:?}", sc.depth_method).to_lowercase(),
        ..PenSummary::default()
    };
    let mut rig = PenRig { pen: pen.mesh, obj };
    let mut times = vec![0u64; ticks as usize];
    let mut digest = ForceDigest::new();
    let (mut max_n, mut last, mut contact_ticks) = (0.0f32, Vec3::ZERO, 0u64);
    let mut sat = SaturationCounts::default();
    let progress = !args.quiet && ticks >= 20_000;
    let sizes = PenSizes::of(&sc);
    let period = u64::from(sc.contact_period.max(1));
    pen_info.contact_period = sc.contact_period;
    pen_info.pass_threads = sc.pass_threads;
    let mut servo_times = vec![0u64; ticks as usize];
    let mut pass_times = Vec::with_capacity(ticks.div_ceil(period) as usize);
    let (ran, setup) = rig
        .with_sizes(sizes, |scene, bufs| {
            let mut state = PenState::default();
            // The servo's scratch: as many penetrations as the pass may write.
            let mut now_pen = vec![Penetration::default(); bufs.pen_pens.len()];
            let mut now_obj = vec![Penetration::default(); bufs.object_pens.len()];
            let mut now = ServoScratch {
                pen: &mut now_pen,
                object: &mut now_obj,
            };
            let mut held = (Vec3::ZERO, Quat::IDENTITY, (0usize, 0usize));
            with_pass_runner(scene, bufs, sc.pass_threads, |runner| {
                for i in 0..ticks {
                    let pose = poses.at(i);
                    let [w, x, y, z] = pose.rotation;
                    let rot = Quat::from_xyzw(x, y, z, w).normalize();
                    let t0 = now_ns();
                    let pass = (i % period == 0)
                        .then(|| runner.pass(pose.position, rot, &opts, &mut state))
                        .transpose()?;
                    let t1 = now_ns();
                    if let Some(c) = &pass {
                        held = (pose.position, rot, c.penetrations);
                    }
                    let (pens, objs) = runner.pens();
                    let contact = HeldContact {
                        position: held.0,
                        rotation: held.1,
                        pen: pens.get(..held.2 .0).unwrap_or(&[]),
                        object: objs.get(..held.2 .1).unwrap_or(&[]),
                    };
                    let f = pen_servo_force(
                        scene,
                        &contact,
                        &mut now,
                        pose.position,
                        rot,
                        &opts,
                        &mut state,
                    );
                    let t2 = now_ns();
                    times[i as usize] = t2 - t0;
                    servo_times[i as usize] = t2 - t1;
                    digest.push(f.force.force);
                    max_n = max_n.max(f.force.force.length());
                    contact_ticks += (f.force.force != Vec3::ZERO) as u64;
                    last = f.force.force;
                    pen_info.clamped_ticks += f.force.clamped as u64;
                    pen_info.servo_short_ticks += f.short as u64;
                    let Some(c) = pass else { continue };
                    pass_times.push(t1 - t0);
                    pen_info.passes += 1;
                    pen_info.pen_collisions_max =
                        pen_info.pen_collisions_max.max(c.pen_collisions.count);
                    pen_info.object_collisions_max = pen_info
                        .object_collisions_max
                        .max(c.object_collisions.count);
                    pen_info.unreached += (c.pen_depth.unreached + c.object_depth.unreached) as u64;
                    pen_info.border_edges +=
                        (c.pen_depth.border_edges + c.object_depth.border_edges) as u64;
                    pen_info.reused_crossings +=
                        (c.pen_depth.reused + c.object_depth.reused) as u64;
                    pen_info.saturated_ticks += c.saturated() as u64;
                    sat.contacts += c.contacts_full() as u32;
                    sat.queue += c.queue_full() as u32;
                    if progress && i % 5000 == 0 {
                        err!(
                            "\rreplay: {:>3}% ({i}/{ticks} ticks)",
                            i * 100 / ticks.max(1)
                        );
                    }
                }
                Ok(())
            })
        })
        .map_err(|e| CliError::failure(format!("cannot set up the tool contact: {e}")))?;
    ran.map_err(|e: crate::pen_pair::WorkerGone| CliError::failure(e.to_string()))?;
    if progress {
        errln!("\rreplay: 100% ({ticks}/{ticks} ticks)");
    }
    let t = summarise_ns(&times);
    pen_info.servo_us = TickTiming::from(summarise_ns(&servo_times));
    pen_info.pass_us = TickTiming::from(summarise_ns(&pass_times));
    let rep = ReplayReport {
        mesh: counts,
        ticks,
        initial_volume,
        removed_volume: 0.0,
        removed_by_region: None,
        hierarchy_nodes: h.node_count(),
        visible_faces,
        components,
        debris_erased: DebrisSummary::default(),
        force: ForceSummary {
            max_n,
            last: last.to_array(),
            contact_ticks,
        },
        force_digest: format!("{:016x}", digest.value()),
        timing_us: TickTiming::from(t),
        runs: 1,
        saturations: SaturationCounts {
            hash: setup.hash_saturations,
            ..sat
        }
        .totalled(),
        valid: valid.is_ok(),
        scenario: sc,
        sizing: None,
        shaft: None,
        pen: Some(pen_info),
        deform: None,
    };
    print_summary(&rep);
    if let Some(p) = &rep.pen {
        outln!(
            "tool {} nodes / {} tets, depth {}: most tool nodes inside {}, object nodes inside {}, \
             unreached {}, clamped ticks {}, crossings reused {} of {}",
            p.tool_nodes,
            p.tool_tets,
            p.depth_method,
            p.pen_collisions_max,
            p.object_collisions_max,
            p.unreached,
            p.clamped_ticks,
            p.reused_crossings,
            p.border_edges
        );
        outln!(
            "servo half us: mean {:.1}  p99 {:.1}  max {:.1};  {} contact passes (every {} \
             ticks, {} thread{}) us: mean {:.1}  p99 {:.1}  max {:.1}",
            p.servo_us.tick_mean,
            p.servo_us.tick_p99,
            p.servo_us.tick_max,
            p.passes,
            p.contact_period,
            p.pass_threads,
            if p.pass_threads == 1 { "" } else { "s" },
            p.pass_us.tick_mean,
            p.pass_us.tick_p99,
            p.pass_us.tick_max
        );
    }
    if let Some(path) = &args.json {
        crate::report::write_json(path, &rep)?;
    }
    valid.map_err(|e| CliError::failure(format!("the object's state is invalid: {e}")))
}

fn print_summary(r: &ReplayReport) {
    outln!(
        "replayed {} ticks on {} ({} nodes, {} tets)",
        r.ticks,
        r.scenario.mesh,
        r.mesh.nodes,
        r.mesh.tets
    );
    outln!(
        "removed volume {} of {} ({:.2}%), {} hierarchy nodes, {} visible faces, {} component(s)",
        crate::stats::volume_text(r.removed_volume, r.initial_volume),
        crate::stats::volume_text(r.initial_volume, r.initial_volume),
        100.0 * r.removed_volume / r.initial_volume.max(f64::MIN_POSITIVE),
        r.hierarchy_nodes,
        r.visible_faces,
        r.components
    );
    if r.debris_erased.pieces > 0 {
        outln!(
            "debris erased: {} piece(s) ({} by the final sweep), {} leaves, volume {:.3e} (in the \
             removed volume)",
            r.debris_erased.pieces,
            r.debris_erased.final_sweep,
            r.debris_erased.nodes,
            r.debris_erased.volume
        );
    }
    outln!(
        "force max {:.3} N, final [{:.3}, {:.3}, {:.3}] N, digest {}",
        r.force.max_n,
        r.force.last[0],
        r.force.last[1],
        r.force.last[2],
        r.force_digest
    );
    let of = if r.runs > 1 {
        format!(" (each tick's fastest of {} runs)", r.runs)
    } else {
        String::new()
    };
    outln!(
        "tick us{of}: mean {:.1}  p99 {:.1}  p99.9 {:.1}  max {:.1};  saturations {}",
        r.timing_us.tick_mean,
        r.timing_us.tick_p99,
        r.timing_us.tick_p999,
        r.timing_us.tick_max,
        r.saturations
    );
    if let Some(z) = &r.sizing {
        outln!("{}", z.line());
    }
    if let Some(d) = &r.deform {
        outln!("{}", d.line());
    }
    for w in r.saturations.warnings(r.ticks) {
        errln!("tetradrill: warning: {w}");
    }
}

/// Writes the visible faces as an OBJ (one vertex triple per face: the drilled surface is a
/// set of triangles of different levels that need not share corners).
pub fn write_surface_obj(
    world: &tetradrill_core::servo::World<'_>,
    path: &std::path::Path,
) -> Result<(), CliError> {
    use std::fmt::Write as _;
    let mut out = String::from("# tetradrill drilled surface: visible faces\n");
    let mut n = 0usize;
    world.hierarchy().for_each_visible(world.mesh(), |t| {
        for c in t.corners {
            let _ = writeln!(out, "v {} {} {}", c.x, c.y, c.z);
        }
        let _ = writeln!(out, "f {} {} {}", n + 1, n + 2, n + 3);
        n += 3;
    });
    std::fs::write(path, out)
        .map_err(|e| CliError::failure(format!("{}: cannot write: {e}", path.display())))
}
