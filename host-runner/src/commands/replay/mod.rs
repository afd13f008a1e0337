//! `tetradrill replay`: a deterministic offline run, tick by tick with no sleeping, through the
//! same core code path as the real-time servo; a summary JSON for scripts.

use std::path::PathBuf;

use tetradrill_core::force::{ForceDigest, ToolState};
use tetradrill_core::hierarchy::DEBRIS_LEAVES;
use tetradrill_core::Vec3;

use crate::engine::{self, EngineStorage, ShaftState, TickParams};
use crate::error::CliError;
use crate::platform::now_ns;
use crate::scenario::{Scenario, ScenarioFlags};
use crate::setup::{Setup, Tool};
use crate::soft::{SoftDriver, SoftSpec};
use crate::stats::{summarise_ns, Summary};
use crate::traces::PoseSource;

mod pen;
mod report;

use pen::replay_pen;
pub use report::*;

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
    /// Write each tick's force on the device as CSV (`tick,fx,fy,fz`, newtons), one row a
    /// tick.
    #[arg(long)]
    pub forces: Option<PathBuf>,
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
    /// Cut the screenshot open with a plane across an axis: `x`, `y` or `z` (through the
    /// tool's work area), or `x:AT` (at that coordinate); the section shows the regions.
    #[arg(long, value_name = "AXIS[:AT]", value_parser = crate::viewer::ClipSpec::parse)]
    pub clip: Option<crate::viewer::ClipSpec>,
    /// Write the burr's sound as a WAV file (44.1 kHz mono): its whine, whose pitch falls with
    /// the load, brighter in harder material, and its grinding while it removes.
    #[arg(long, value_name = "FILE.wav")]
    pub audio_out: Option<PathBuf>,
    /// Replay this many times from scratch (1 to 100; a sphere tool only) and time each tick
    /// as the fastest of the runs: the tick's cost without the preemption of a shared
    /// machine. Every run must give the same force digest (checked).
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=100))]
    pub repeat: u32,
}

/// Runs `replay`.
pub fn run(args: &ReplayArgs) -> Result<(), CliError> {
    let scenario = Scenario::from_flags(&args.scenario)?;
    let sc = scenario.setup()?;
    let soft = SoftSpec::of(&sc)?;
    // The mesh, read once: the world's, and a wander's waypoints.
    let loaded = engine::load_mesh(&sc)?;
    if let Tool::Mesh { path, scale } = &sc.tool {
        if args.repeat > 1 {
            return Err(CliError::input(
                "--repeat times a sphere tool's replay; a mesh tool's replay runs once",
            ));
        }
        return replay_pen(args, scenario, &sc, loaded, path, *scale);
    }
    if sc.pen.contact_period != 1 {
        return Err(CliError::input(
            "--contact-period spaces a mesh tool's contact passes; a sphere tool's replay \
             simulates every tick",
        ));
    }
    if sc.pen.pass_threads != 1 {
        return Err(CliError::input(
            "--pass-threads splits a mesh tool's contact pass over two threads; a sphere tool \
             has no such pass",
        ));
    }
    let mut view = crate::viewer::ViewOptions::of(true, args.screenshot.clone())?;
    view.clip = args.clip;
    let params = TickParams::of(&sc)?;
    // Created before the run, so a path that cannot be written stops it at once.
    let mut forces_out = args.forces.as_deref().map(ForcesCsv::create).transpose()?;
    let poses = PoseSource::new(&sc.poses, Some(&loaded.mesh))?;
    let ticks = replay_ticks(args, &poses);
    // The earlier runs of `--repeat`: timings and digests only, each from scratch.
    let mut fastest: Vec<u64> = Vec::new();
    let mut digests: Vec<u64> = Vec::new();
    for run in 1..args.repeat {
        if !args.quiet {
            errln!("replay: run {run} of {} (timing)", args.repeat);
        }
        let mut store = EngineStorage::new(loaded.mesh.clone(), &sc)?;
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
    let mut store = EngineStorage::new(loaded.mesh, &sc)?;
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
        nodes_bound: world.shaft_max_nodes().unwrap_or(0),
        ..ShaftSummary::default()
    });
    let mut digest = ForceDigest::new();
    let mut times = vec![0u64; ticks as usize];
    let (mut max_n, mut last, mut contact_ticks) = (0.0f32, Vec3::ZERO, 0u64);
    let mut last_pose = None;
    let mut candidates_peak = 0usize;
    let progress = !args.quiet && ticks >= 20_000;
    let mut sound = args
        .audio_out
        .as_ref()
        .map(|_| ReplaySound::new(&world, params.radius));
    for i in 0..ticks {
        let pose = poses.at(i);
        let (f, ns) = timed_tick(&mut world, &mut tool, &mut shaft, &params, &pose);
        if let Some(s) = shaft_sum.as_mut() {
            s.near_ticks += u64::from(shaft.last.near > 0);
            s.held_ticks += u64::from(shaft.last.held > 0);
            s.held_max = s.held_max.max(shaft.last.held);
            s.nodes_max = s.nodes_max.max(shaft.last.nodes);
            s.nodes_total += u64::from(shaft.last.nodes);
            s.cut_ticks += u64::from(shaft.last.cut);
            s.stale_points += u64::from(shaft.last.stale);
            s.hold_max = s.hold_max.max(world.shaft_reserve());
            s.hold_total += u64::from(world.shaft_reserve());
        }
        times[i as usize] = ns;
        digest.push(f);
        if let Some(out) = forces_out.as_mut() {
            out.row(i, f)?;
        }
        candidates_peak = candidates_peak.max(world.candidates().len());
        if let Some(d) = driver.as_mut() {
            d.after_tick(&mut world, f)?;
        }
        max_n = max_n.max(f.length());
        if f != Vec3::ZERO {
            contact_ticks += 1;
        }
        last = f;
        last_pose = Some(pose);
        if let Some(snd) = sound.as_mut() {
            snd.tick(&world, &pose, f);
        }
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
    let peaks = peak_counts(&world, candidates_peak, sizing.candidate_capacity);
    let t: Summary = summarise_ns(&fastest);
    // The crumbs the drill's discretisation leaves along the swept boundary go, then the
    // pieces left are counted.
    let during = world.debris();
    let mut scratch = vec![0u32; world.hierarchy().debris_scratch_needed()];
    let debris = world
        .remove_debris(DEBRIS_LEAVES, sc.drilling.max_depth, &mut scratch)
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
        drill: report::DrillSummary::of(&world),
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
        peaks: Some(peaks),
        valid: valid.is_ok(),
        sizing: Some(sizing.after(&world)),
        scenario,
        shaft: shaft_sum,
        pen: None,
        deform: driver.as_ref().map(SoftDriver::summary),
    };
    if let Some(path) = &args.surface {
        write_surface_obj(&world, path)?;
    }
    if let Some(out) = forces_out {
        out.finish()?;
    }
    print_summary(&rep);
    if let (Some(path), Some(snd)) = (&args.audio_out, &sound) {
        crate::audio::write_wav(path, snd.voice.samples())?;
        errln!("replay: the burr's sound written to {}", path.display());
    }
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
        let colours = engine::region_table(&loaded.labels, &sc.materials)
            .ok()
            .flatten()
            .map(|t| t.colours);
        let regions =
            crate::viewer::publish::RegionsView::of(world.mesh(), &loaded.labels, colours);
        let mut scene = crate::viewer::publish::scene_with_regions(&world, tool, status, &regions);
        crate::viewer::screenshot(&mut scene, path, view.clip)?;
    }
    valid.map_err(|e| CliError::failure(format!("the final state is invalid: {e}")))
}

/// The world's high-water marks after a run whose longest candidate list was `candidates`,
/// `candidate_capacity` the world's candidate storage.
fn peak_counts(
    world: &tetradrill_core::servo::World<'_>,
    candidates: usize,
    candidate_capacity: usize,
) -> PeakCounts {
    let h = world.hierarchy();
    let [pending_coarse, pending_coarse_capacity, pending_fine, pending_fine_capacity] =
        world.pending_peaks();
    PeakCounts {
        arena_nodes: h.arena_used(),
        arena_capacity: h.capacity(),
        pending_coarse,
        pending_coarse_capacity,
        pending_fine,
        pending_fine_capacity,
        candidates,
        candidate_capacity,
        hash_entries: world.hash().len(),
        hash_capacity: world.hash().capacity(),
    }
}

/// A deforming world over `store` and the soft body's storage, its materials set from the
/// mesh's region `labels`, when the scenario has a soft body.
fn soft_owned(
    store: &mut EngineStorage,
    spec: Option<&SoftSpec>,
    labels: &[i32],
) -> Result<Option<crate::soft::SoftOwned>, CliError> {
    Ok(spec.map(|s| store.soft_body(s, labels)).transpose()?)
}

/// The soft body's driver over `owned` when the scenario has one.
fn soft_driver<'a>(
    spec: Option<&SoftSpec>,
    owned: Option<&'a mut crate::soft::SoftOwned>,
) -> Result<Option<SoftDriver<'a>>, CliError> {
    match (spec, owned) {
        (Some(s), Some(o)) => Ok(Some(SoftDriver::unattended(o, s)?)),
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
    if let Some(s) = &r.shaft {
        let bound = match s.nodes_bound {
            0 => "unbounded".to_owned(),
            b => format!(
                "at most {b} nodes a tick, cut on {} ticks, {:.0} held a tick from the drill's share",
                s.cut_ticks,
                s.hold_total as f64 / r.ticks.max(1) as f64
            ),
        };
        outln!(
            "shaft: {} passive points, a point within reach {} ticks, held {} ticks; walk {bound} \
             (largest {}), {} point-ticks on an earlier tick's state",
            s.passive_points,
            s.near_ticks,
            s.held_ticks,
            s.nodes_max,
            s.stale_points
        );
    }
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

/// Writes the visible faces as an OBJ with shared vertices and smooth normals (the core's
/// `SmoothNormals` at its default crease angle), the drilled faces in group `drilled` and
/// the mesh's untouched boundary in group `boundary`.
pub fn write_surface_obj(
    world: &tetradrill_core::servo::World<'_>,
    path: &std::path::Path,
) -> Result<(), CliError> {
    let crease = tetradrill_core::hierarchy::SmoothNormals::CREASE_DEGREES;
    let s = crate::smooth_surface::SmoothSurface::of(world, &[], crease);
    std::fs::write(path, s.to_obj())
        .map_err(|e| CliError::failure(format!("{}: cannot write: {e}", path.display())))
}

/// The burr's sound along a replay: the drill's button, the force while it cuts, the
/// material it cut last (the region whose removed volume grew most this tick) and how fast it
/// removes.
struct ReplaySound {
    voice: crate::audio::BurrVoice,
    removed: Vec<f64>,
    hardness: Vec<f64>,
    hardest: f64,
    region: Option<usize>,
    /// The volume per second that grinds at full loudness: the burr's own volume in 0.2 s.
    full_rate: f64,
    total: f64,
}

impl ReplaySound {
    fn new(world: &tetradrill_core::servo::World<'_>, radius: f32) -> Self {
        let table = world
            .regions()
            .map(|r| r.table().to_vec())
            .unwrap_or_default();
        let hardness: Vec<f64> = table
            .iter()
            .map(|r| f64::from(r.material.hardness))
            .collect();
        let r = f64::from(radius);
        Self {
            voice: crate::audio::BurrVoice::new(crate::audio::BurrSound::default()),
            removed: table.iter().map(|r| r.removed()).collect(),
            hardest: hardness.iter().copied().fold(0.0, f64::max),
            hardness,
            region: None,
            full_rate: 4.0 / 3.0 * std::f64::consts::PI * r * r * r / 0.2,
            total: world.hierarchy().removed_volume(),
        }
    }

    fn tick(&mut self, world: &tetradrill_core::servo::World<'_>, pose: &crate::Pose, f: Vec3) {
        if let Some(r) = world.regions() {
            let mut best = 0.0;
            for (i, reg) in r.table().iter().enumerate() {
                let d = reg.removed() - self.removed.get(i).copied().unwrap_or(0.0);
                if d > best {
                    best = d;
                    self.region = Some(i);
                }
                if let Some(x) = self.removed.get_mut(i) {
                    *x = reg.removed();
                }
            }
        }
        let total = world.hierarchy().removed_volume();
        let rate = (total - self.total).max(0.0) / 0.001;
        self.total = total;
        let on = pose.buttons & tetradrill_core::script::DRILL_ON != 0;
        let hardness = self
            .region
            .and_then(|i| self.hardness.get(i).copied())
            .unwrap_or(0.0);
        self.voice.tick(&crate::audio::TickSound {
            on,
            load_n: if on { f64::from(f.length()) } else { 0.0 },
            brightness: crate::audio::brightness(hardness, self.hardest),
            grinding: (rate / self.full_rate.max(1e-30)).min(1.0),
        });
    }
}

/// `replay --forces`: each tick's force on the device, `tick,fx,fy,fz` in newtons.
pub(super) struct ForcesCsv {
    path: PathBuf,
    out: std::io::BufWriter<std::fs::File>,
}

impl ForcesCsv {
    /// Creates `path` and writes the header (exit 2 when it cannot be created: a bad
    /// argument, found before the run).
    pub(super) fn create(path: &std::path::Path) -> Result<Self, CliError> {
        use std::io::Write;
        let file = std::fs::File::create(path).map_err(|e| {
            CliError::input(format!("{}: --forces: cannot create: {e}", path.display()))
        })?;
        let mut out = std::io::BufWriter::new(file);
        writeln!(out, "tick,fx,fy,fz").map_err(|e| Self::error(path, &e))?;
        Ok(Self {
            path: path.to_path_buf(),
            out,
        })
    }

    /// Tick `tick`'s force `f`.
    pub(super) fn row(&mut self, tick: u64, f: Vec3) -> Result<(), CliError> {
        use std::io::Write;
        writeln!(self.out, "{tick},{},{},{}", f.x, f.y, f.z)
            .map_err(|e| Self::error(&self.path, &e))
    }

    /// Flushes what is buffered.
    pub(super) fn finish(mut self) -> Result<(), CliError> {
        use std::io::Write;
        self.out.flush().map_err(|e| Self::error(&self.path, &e))
    }

    fn error(path: &std::path::Path, e: &std::io::Error) -> CliError {
        CliError::failure(format!("{}: --forces: cannot write: {e}", path.display()))
    }
}
