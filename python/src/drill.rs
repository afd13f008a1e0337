//! Drilling from Python: `Drilling` (a mesh read once, its storage allocated once, a run tick
//! by tick or a batch of poses at a time), its drilled `Surface`, and `replay` (a scenario's
//! trace from start to end, as `tetradrill replay` runs it).

use std::collections::BTreeMap;
use std::path::PathBuf;

use numpy::{PyArray1, PyArray2, PyArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use tetradrill::commands::replay::DrillSummary;
use tetradrill::scenario::Scenario;
use tetradrill::setup::{Setup, Tool};
use tetradrill::traces::{Pose, PoseSource, PERIOD_S};
use tetradrill::DrillRun;
use tetradrill_core::force::ForceDigest;
use tetradrill_core::hierarchy::DEBRIS_LEAVES;
use tetradrill_core::Vec3;

use crate::arrays::{self, Drill};
use crate::interrupt::Signals;
use crate::{errors, settings};

/// The library's drilling storage and the run over it, held together.
#[ouroboros::self_referencing]
struct Live {
    drilling: tetradrill::Drilling,
    #[borrows(mut drilling)]
    #[not_covariant]
    run: DrillRun<'this>,
}

impl std::fmt::Debug for Live {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Live").finish_non_exhaustive()
    }
}

impl Live {
    /// A fresh run over `drilling`.
    fn start(drilling: tetradrill::Drilling) -> PyResult<Self> {
        Live::try_new(drilling, |d| d.start()).map_err(errors::of)
    }
}

/// The Rust side of `Drilling`: everything but the Python object.
#[derive(Debug)]
pub struct Session {
    live: Option<Live>,
    scenario: Scenario,
    setup: Setup,
    poses: PoseSource,
    ticks: u64,
    digest: ForceDigest,
    warnings: Vec<String>,
}

/// Refuses what `Drilling` does not run: a tet-mesh tool.
fn drillable(setup: &Setup) -> PyResult<()> {
    if let Tool::Mesh { path, .. } = &setup.tool {
        return Err(errors::input(format!(
            "tool mesh:{}: a tet-mesh tool touches (tetradrill.Touching); Drilling and replay \
             take a burr (sphere:R or drill:R:L:r)",
            path.display()
        )));
    }
    Ok(())
}

impl Session {
    /// Reads the set-up's mesh and trace and allocates the storage.
    pub fn new(scenario: Scenario, setup: Setup) -> PyResult<Self> {
        drillable(&setup)?;
        let loaded = setup.mesh.load().map_err(errors::mesh)?;
        let warnings = loaded.warnings.clone();
        let poses = PoseSource::new(&setup.poses, Some(&loaded.mesh)).map_err(errors::of)?;
        let drilling = tetradrill::Drilling::with_mesh(&setup, loaded).map_err(errors::of)?;
        Ok(Self {
            live: Some(Live::start(drilling)?),
            scenario,
            setup,
            poses,
            ticks: 0,
            digest: ForceDigest::new(),
            warnings,
        })
    }

    fn live(&self) -> PyResult<&Live> {
        self.live
            .as_ref()
            .ok_or_else(|| errors::TetradrillError::new_err("the run could not be restarted"))
    }

    fn live_mut(&mut self) -> PyResult<&mut Live> {
        self.live
            .as_mut()
            .ok_or_else(|| errors::TetradrillError::new_err("the run could not be restarted"))
    }

    /// One tick per pose; the forces. A signal's exception (Ctrl-C) ends the run between two
    /// ticks: the ticks run are counted and in the digest, their forces dropped with the call.
    pub fn run(&mut self, poses: &[Pose]) -> PyResult<Vec<Vec3>> {
        let live = self
            .live
            .as_mut()
            .ok_or_else(|| errors::TetradrillError::new_err("the run could not be restarted"))?;
        let digest = &mut self.digest;
        let mut signals = Signals::new();
        let mut forces = Vec::with_capacity(poses.len());
        let failed =
            |e: &tetradrill::Error| errors::TetradrillError::new_err(format!("soft body: {e}"));
        let r = live.with_run_mut(|r| {
            // A soft body whose step the core refused stays refused until `reset()`.
            if let Some(e) = r.soft_error() {
                return Err(failed(e));
            }
            for p in poses {
                signals.check()?;
                let f = r.tick(p);
                digest.push(f);
                forces.push(f);
                if let Some(e) = r.soft_error() {
                    return Err(failed(e));
                }
            }
            Ok(())
        });
        self.ticks += forces.len() as u64;
        r.map(|()| forces)
    }

    /// The scenario's trace: `ticks` poses (default: the whole trace; a wander's 60 s).
    pub fn trace(&self, ticks: Option<u64>) -> Vec<Pose> {
        let n = match (ticks, &self.poses) {
            (Some(t), PoseSource::Wander { .. }) => t,
            (Some(t), p) => t.min(p.ticks()),
            (None, p) => p.ticks(),
        };
        (0..n).map(|i| self.poses.at(i)).collect()
    }

    /// The final sweep of the crumbs the drill left (what `tetradrill replay` does at its end).
    pub fn erase_debris(&mut self) -> PyResult<tetradrill_core::hierarchy::DebrisReport> {
        let max_depth = self.setup.drilling.max_depth;
        self.live_mut()?
            .with_run_mut(|r| {
                let w = r.world_mut();
                let mut scratch = vec![0u32; w.hierarchy().debris_scratch_needed()];
                w.remove_debris(DEBRIS_LEAVES, max_depth, &mut scratch)
            })
            .map_err(|e| errors::TetradrillError::new_err(format!("cannot erase the debris: {e}")))
    }

    /// Removed volume by region label.
    pub fn removed_by_region(&self) -> PyResult<BTreeMap<i32, f64>> {
        Ok(self
            .live()?
            .with_run(|r| r.removed_by_region().into_iter().collect()))
    }

    fn removed_volume(&self) -> PyResult<f64> {
        Ok(self.live()?.with_run(|r| r.removed_volume()))
    }

    /// The work against the feed and the cutting energy it paid for, as `tetradrill replay
    /// --json` writes them under `drill` (`None` on a world without regions).
    fn cutting(&self) -> PyResult<Option<DrillSummary>> {
        Ok(self.live()?.with_run(|r| DrillSummary::of(r.world())))
    }

    fn initial_volume(&self) -> PyResult<f64> {
        Ok(self.live()?.with_run(|r| r.initial_volume()))
    }

    /// The mesh's nodes where they are now (a soft body moves them).
    fn positions(&self) -> PyResult<Vec<Vec3>> {
        Ok(self.live()?.with_run(|r| r.positions().to_vec()))
    }

    /// A soft body's figures so far, `None` for a rigid mesh.
    fn soft(&self) -> PyResult<Option<tetradrill::soft::DeformSummary>> {
        Ok(self.live()?.with_run(|r| r.soft()))
    }
}

/// A soft body's figures as a dict: `steps`, `max_displacement` (mesh units), `rate_hz`,
/// `threads`, `fixed_nodes`, as `tetradrill replay --json`'s `deform`.
fn deform_dict<'py>(
    py: Python<'py>,
    d: &tetradrill::soft::DeformSummary,
) -> PyResult<Bound<'py, PyDict>> {
    let out = PyDict::new(py);
    out.set_item("steps", d.steps)?;
    out.set_item("max_displacement", d.max_displacement)?;
    out.set_item("rate_hz", d.rate_hz)?;
    out.set_item("threads", d.threads)?;
    out.set_item("fixed_nodes", d.fixed_nodes)?;
    Ok(out)
}

/// A mesh being drilled by a burr, tick by tick (1 ms a tick).
///
/// `Drilling(mesh=None, tool=None, *, scenario=None, **keys)`: the scenario (a TOML file or
/// `builtin:NAME`; default: the built-in block and a 0.1 burr on the demo path), then `mesh`
/// (a file or `builtin:block:N`), `tool` (`"sphere:R"` or `"drill:R:L:r"`) and any other
/// scenario key (`stiffness=150.0`, `max_depth=4`, `regions={1: {"hardness": 2.0}}`). Reads
/// the mesh and the scenario's trace once and allocates every buffer once.
#[pyclass(module = "tetradrill")]
#[derive(Debug)]
pub struct Drilling {
    session: Session,
}

#[pymethods]
impl Drilling {
    #[new]
    #[pyo3(signature = (mesh=None, tool=None, *, scenario=None, **keys))]
    fn new(
        py: Python<'_>,
        mesh: Option<PathBuf>,
        tool: Option<&Bound<'_, PyAny>>,
        scenario: Option<PathBuf>,
        keys: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Self> {
        let (sc, setup) = settings::resolve(py, scenario, mesh, settings::tool_spec(tool)?, keys)?;
        Ok(Self {
            session: Session::new(sc, setup)?,
        })
    }

    /// One tick at `pose` (3 numbers, or 7 with the quaternion `w, x, y, z`), the drill on
    /// unless `drill=False`: the force on the hand, newtons, as an array of 3.
    #[pyo3(signature = (pose, drill=true))]
    fn tick<'py>(
        &mut self,
        py: Python<'py>,
        pose: &Bound<'py, PyAny>,
        drill: bool,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let p = arrays::pose(pose, drill)?;
        let f = self.session.run(&[p])?;
        arrays::to_numpy(py, &f)?.reshape([3])
    }

    /// One tick per row of `poses` (`N x 3`, or `N x 7` with quaternions), the GIL released
    /// while they run; `drill` is a bool for all or one bool a pose (default on). The forces,
    /// `N x 3`, newtons.
    #[pyo3(signature = (poses, drill=None))]
    fn run<'py>(
        &mut self,
        py: Python<'py>,
        poses: &Bound<'py, PyAny>,
        drill: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let poses = arrays::poses(poses, &Drill::of(drill)?)?;
        let session = &mut self.session;
        let forces = py.detach(|| session.run(&poses))?;
        arrays::to_numpy(py, &forces)
    }

    /// The scenario's trace as arrays: `(poses, drill)`, `poses` `N x 7` (position,
    /// quaternion `w, x, y, z`), `drill` `N` bools; `ticks` of them (default: the whole trace,
    /// 60 s of a wander).
    #[pyo3(signature = (ticks=None))]
    fn trace_poses<'py>(
        &self,
        py: Python<'py>,
        ticks: Option<u64>,
    ) -> PyResult<arrays::PoseArrays<'py>> {
        arrays::poses_to_numpy(py, &self.session.trace(ticks))
    }

    /// Starts again from the mesh as loaded: nothing drilled, no tick run.
    fn reset(&mut self) -> PyResult<()> {
        let s = &mut self.session;
        let live = s
            .live
            .take()
            .ok_or_else(|| errors::TetradrillError::new_err("the run could not be restarted"))?;
        s.live = Some(Live::start(live.into_heads().drilling)?);
        s.ticks = 0;
        s.digest = ForceDigest::new();
        Ok(())
    }

    /// Erases the pieces of material the drill cut loose (at most 8 finest leaves each), as
    /// `tetradrill replay` does at its end; their volume joins the removed volume. A dict:
    /// `pieces`, `nodes` (leaves), `volume` (cubic mesh units), `components` (pieces of
    /// material left).
    fn erase_debris<'py>(&mut self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let r = self.session.erase_debris()?;
        let d = PyDict::new(py);
        d.set_item("pieces", r.pieces)?;
        d.set_item("nodes", r.nodes)?;
        d.set_item("volume", r.volume)?;
        d.set_item("components", r.components)?;
        Ok(d)
    }

    /// The drilled surface now (every visible face).
    fn surface(&self, py: Python<'_>) -> PyResult<Surface> {
        let (s, smooth) = self.session.live()?.with_run(|r| {
            let smooth = tetradrill::smooth_surface::SmoothSurface::of(
                r.world(),
                &[],
                tetradrill_core::hierarchy::SmoothNormals::CREASE_DEGREES,
            );
            (r.surface(), smooth)
        });
        Surface::of(py, s, &smooth)
    }

    /// Checks the mesh's and the drilled hierarchy's invariants; raises `TetradrillError`
    /// naming the first one broken.
    fn validate(&self) -> PyResult<()> {
        self.session
            .live()?
            .with_run(|r| tetradrill::engine::validate(r.world()))
            .map_err(|e| errors::TetradrillError::new_err(format!("invalid state: {e}")))
    }

    /// Volume removed so far, by region label: `{label: volume}`, cubic mesh units (label 0
    /// alone on a mesh without labels).
    #[getter]
    fn removed_by_region(&self) -> PyResult<BTreeMap<i32, f64>> {
        self.session.removed_by_region()
    }

    /// Volume removed so far, cubic mesh units.
    #[getter]
    fn removed_volume(&self) -> PyResult<f64> {
        self.session.removed_volume()
    }

    /// The regions cut by the feed (`cutting_energy`; docs/DRILLING.md, "Cutting
    /// resistance"), so far: `{"cutting_work_j", "cutting_energy_j", "feed_pool_j",
    /// "feed_dropped_j"}`, newton mesh units (joules for a mesh in metres), the work being the
    /// other three added up; `tetradrill replay --json`'s `drill` after the same poses and
    /// `erase_debris()`. `None` on a world without regions.
    #[getter]
    fn cutting<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
        self.session
            .cutting()?
            .map(|c| cutting_dict(py, &c))
            .transpose()
    }

    /// The mesh's volume before drilling, cubic mesh units.
    #[getter]
    fn initial_volume(&self) -> PyResult<f64> {
        self.session.initial_volume()
    }

    /// The mesh's nodes where they are now, `N x 3`, in the mesh's node order: where a soft
    /// body (`body="soft"`) has moved them, else as loaded.
    #[getter]
    fn positions<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        arrays::to_numpy(py, &self.session.positions()?)
    }

    /// A soft body's figures so far (`body="soft"`): `steps`, `max_displacement`,
    /// `rate_hz`, `threads`, `fixed_nodes`, as `tetradrill replay --json`'s `deform`; `None`
    /// for a rigid mesh.
    #[getter]
    fn soft<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
        self.session
            .soft()?
            .map(|d| deform_dict(py, &d))
            .transpose()
    }

    /// Ticks run since the start (or the last `reset`).
    #[getter]
    fn ticks(&self) -> u64 {
        self.session.ticks
    }

    /// Seconds of simulated time since the start: `ticks * PERIOD_S`.
    #[getter]
    fn time(&self) -> f64 {
        self.session.ticks as f64 * PERIOD_S
    }

    /// The force digest of every tick since the start, 16 hex digits (`tetradrill replay`'s
    /// `force_digest` for the same poses).
    #[getter]
    fn force_digest(&self) -> String {
        format!("{:016x}", self.session.digest.value())
    }

    /// The burr's radius, mesh units.
    #[getter]
    fn radius(&self) -> f64 {
        match self.session.setup.tool {
            Tool::Sphere { radius } => radius,
            Tool::Drill { burr, .. } => burr,
            Tool::Mesh { .. } => 0.0,
        }
    }

    /// The scenario this runs, as a dict of its keys.
    #[getter]
    fn scenario<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        settings::as_python(py, &self.session.scenario)
    }

    /// What reading the mesh noted (one line each).
    #[getter]
    fn warnings(&self) -> Vec<String> {
        self.session.warnings.clone()
    }

    fn __repr__(&self) -> String {
        format!(
            "Drilling(mesh={:?}, tool={:?}, ticks={})",
            self.session.scenario.mesh, self.session.scenario.tool, self.session.ticks
        )
    }
}

/// A drilled surface: a triangle soup (faces of different subdivision levels need not share
/// corners), counter-clockwise seen from outside the material.
///
/// `vertices` `3T x 3` (mesh units), `triangles` `T x 3` (indices into `vertices`: row `i` is
/// `3i, 3i+1, 3i+2`), `normals` `3T x 3` (each triangle's unit normal, outward, at its three
/// corners), `smooth_normals` `3T x 3` (each corner's smooth normal: the core's shared
/// vertices, a three-ring average on the drilled faces, the boundary's within 75 degrees; as
/// `tetradrill replay --surface` writes them), `labels` `T` (each triangle's region label),
/// `area` (square mesh units).
#[pyclass(module = "tetradrill", frozen)]
#[derive(Debug)]
pub struct Surface {
    #[pyo3(get)]
    vertices: Py<PyArray2<f64>>,
    #[pyo3(get)]
    triangles: Py<PyArray2<i64>>,
    #[pyo3(get)]
    normals: Py<PyArray2<f64>>,
    #[pyo3(get)]
    smooth_normals: Py<PyArray2<f64>>,
    #[pyo3(get)]
    labels: Py<PyArray1<i32>>,
    #[pyo3(get)]
    area: f64,
    inner: tetradrill::Surface,
}

/// A triangle's corners' bits, rotated to start at the smallest (the orientation kept), and
/// the rotation.
fn canonical(c: [Vec3; 3]) -> ([[u32; 3]; 3], usize) {
    let b = c.map(|p| p.to_array().map(f32::to_bits));
    let first = (0..3).min_by_key(|&k| b[k]).unwrap_or(0);
    ([b[first], b[(first + 1) % 3], b[(first + 2) % 3]], first)
}

impl Surface {
    fn of(
        py: Python<'_>,
        s: tetradrill::Surface,
        smooth: &tetradrill::smooth_surface::SmoothSurface,
    ) -> PyResult<Self> {
        // The smooth surface's faces by their corners, each corner's normal in that order.
        let mut by_corners = std::collections::HashMap::new();
        for f in &smooth.faces {
            let p = f.vertices.map(|v| smooth.positions[v as usize]);
            let n = f.normals.map(|v| smooth.normals[v as usize]);
            let (key, first) = canonical(p);
            by_corners.insert(key, [0, 1, 2].map(|k| n[(first + k) % 3]));
        }
        let smooth_normals: Vec<Vec3> = s
            .corners
            .iter()
            .flat_map(|&c| {
                let flat = (c[1] - c[0]).cross(c[2] - c[0]).normalize_or_zero();
                let (key, first) = canonical(c);
                match by_corners.get(&key) {
                    Some(n) => [0, 1, 2].map(|k| n[(k + 3 - first) % 3]),
                    None => [flat; 3],
                }
            })
            .collect();
        let vertices: Vec<Vec3> = s.corners.iter().flatten().copied().collect();
        let triangles: Vec<[i64; 3]> = (0..s.corners.len() as i64)
            .map(|i| [3 * i, 3 * i + 1, 3 * i + 2])
            .collect();
        let normals: Vec<Vec3> = s
            .corners
            .iter()
            .flat_map(|[a, b, c]| [(*b - *a).cross(*c - *a).normalize_or_zero(); 3])
            .collect();
        Ok(Self {
            vertices: arrays::to_numpy(py, &vertices)?.unbind(),
            triangles: arrays::rows(py, &triangles)?.unbind(),
            normals: arrays::to_numpy(py, &normals)?.unbind(),
            smooth_normals: arrays::to_numpy(py, &smooth_normals)?.unbind(),
            labels: PyArray1::from_vec(py, s.labels.clone()).unbind(),
            area: s.area(),
            inner: s,
        })
    }
}

#[pymethods]
impl Surface {
    /// The surface as a Wavefront OBJ text (a vertex triple and a face a triangle).
    fn to_obj(&self) -> String {
        self.inner.to_obj()
    }

    /// Triangles.
    fn __len__(&self) -> usize {
        self.inner.triangles()
    }

    fn __repr__(&self) -> String {
        format!(
            "Surface(triangles={}, area={})",
            self.inner.triangles(),
            self.inner.area()
        )
    }
}

/// The cutting figures as `tetradrill replay --json`'s `drill` names them.
fn cutting_dict<'py>(py: Python<'py>, c: &DrillSummary) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("cutting_work_j", c.cutting_work_j)?;
    d.set_item("cutting_energy_j", c.cutting_energy_j)?;
    d.set_item("feed_pool_j", c.feed_pool_j)?;
    d.set_item("feed_dropped_j", c.feed_dropped_j)?;
    Ok(d)
}

/// Replays a scenario's trace from start to end as `tetradrill replay` does: every tick, then
/// the final sweep of the debris. `scenario` is a TOML file or `builtin:NAME` (default: the
/// demo's set-up); `trace=` (a CSV file, `builtin:demo`, `builtin:tooth-access`,
/// `wander:SEED`), `mesh=`, `tool=` and any other scenario key override it; `ticks` cuts the
/// trace short (or sets a wander's length). The GIL is released while the ticks run.
///
/// Returns a dict: `ticks`, `forces` (`N x 3`, newtons), `poses` (`N x 7`), `drill` (`N`
/// bools), `initial_volume`, `removed_volume`, `removed_by_region` (`{label: volume}`),
/// `debris_erased` (the final sweep's), `cutting` (`replay --json`'s `drill`, as `Drilling.cutting`;
/// a world with regions only), `max_force` (newtons), `contact_ticks`, `force_digest`,
/// `scenario` (the keys run).
#[pyfunction]
#[pyo3(signature = (scenario=None, *, ticks=None, mesh=None, tool=None, **keys))]
pub fn replay<'py>(
    py: Python<'py>,
    scenario: Option<PathBuf>,
    ticks: Option<u64>,
    mesh: Option<PathBuf>,
    tool: Option<&Bound<'py, PyAny>>,
    keys: Option<&Bound<'py, PyDict>>,
) -> PyResult<Bound<'py, PyDict>> {
    let (sc, setup) = settings::resolve(py, scenario, mesh, settings::tool_spec(tool)?, keys)?;
    let mut session = py.detach(|| Session::new(sc, setup))?;
    let poses = session.trace(ticks);
    let (forces, debris) = py.detach(|| -> PyResult<_> {
        let f = session.run(&poses)?;
        Ok((f, session.erase_debris()?))
    })?;
    let max_force = forces.iter().map(|f| f.length()).fold(0.0f32, f32::max);
    let contact_ticks = forces.iter().filter(|f| **f != Vec3::ZERO).count();
    let (pose_rows, drill) = arrays::poses_to_numpy(py, &poses)?;
    let d = PyDict::new(py);
    d.set_item("ticks", poses.len())?;
    d.set_item("forces", arrays::to_numpy(py, &forces)?)?;
    d.set_item("poses", pose_rows)?;
    d.set_item("drill", drill)?;
    d.set_item("initial_volume", session.initial_volume()?)?;
    d.set_item("removed_volume", session.removed_volume()?)?;
    d.set_item("removed_by_region", session.removed_by_region()?)?;
    let de = PyDict::new(py);
    de.set_item("pieces", debris.pieces)?;
    de.set_item("nodes", debris.nodes)?;
    de.set_item("volume", debris.volume)?;
    de.set_item("components", debris.components)?;
    d.set_item("debris_erased", de)?;
    if let Some(c) = session.cutting()? {
        d.set_item("cutting", cutting_dict(py, &c)?)?;
    }
    if let Some(s) = session.soft()? {
        d.set_item("deform", deform_dict(py, &s)?)?;
    }
    d.set_item("max_force", f64::from(max_force))?;
    d.set_item("contact_ticks", contact_ticks)?;
    d.set_item("force_digest", format!("{:016x}", session.digest.value()))?;
    d.set_item("scenario", settings::as_python(py, &session.scenario)?)?;
    Ok(d)
}
