//! A soft body from Python: an elastic body (XPBD, linear elasticity) on a tet mesh, stepped
//! under loads, some nodes held, on one thread or two.
//!
//! The body holds its nodes and tets in its own order: two parts that share no node, each
//! part's tets in groups of four that share no node (`SoftOwned::in_two_parts`, as the host's
//! soft driver does), so a step runs on one thread (`SoftBody::step`) or on two
//! (`SoftBody::step_two`), the same bits. Every array in and out is in the caller's order.

use std::path::PathBuf;

use numpy::{AllowTypeChange, PyArray1, PyArray2, PyArrayLike2};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use tetradrill::meshio;
use tetradrill::soft::{
    on_two_threads, step_threads, SoftOwned, DEFAULT_POISSON, DEFAULT_YOUNG, TWO_THREADS_FROM_TETS,
};
use tetradrill_core::soft::{Material, SoftBody as CoreBody, SoftError, SoftParams, TwoParts};
use tetradrill_core::Vec3;

use crate::interrupt::Signals;
use crate::{arrays, errors};

/// A body's storage and the body over it, held together.
#[ouroboros::self_referencing]
struct Live {
    owned: SoftOwned,
    #[borrows(mut owned)]
    #[not_covariant]
    body: CoreBody<'this>,
}

impl std::fmt::Debug for Live {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Live").finish_non_exhaustive()
    }
}

/// An elastic body on a tet mesh, at rest until loaded.
///
/// `SoftBody(mesh="builtin:block:4", *, scale=1.0, young=5000.0, poisson=0.3,
/// density=1000.0, damping=0.0, substeps=10, iterations=1, gravity=None, threads=None)`:
/// the mesh (a file or a built-in name, coordinates times `scale`; units taken as metres),
/// Young's modulus (pascal), the Poisson ratio (`0..=0.49`), the density (kg/m^3), the
/// velocity damping rate (1/s), XPBD substeps and sweeps a step, gravity (m/s^2, 3 numbers),
/// threads a step runs on (1 or 2, the same bits; `None`: 2 for a body of at least 8,192
/// tets on a machine with two cores). `SoftBody.from_arrays` builds one from `nodes` and
/// `tets` arrays.
#[pyclass(module = "tetradrill")]
#[derive(Debug)]
pub struct SoftBody {
    live: Live,
    /// The caller's index of each of the body's tets.
    tet_of: Vec<u32>,
    /// The caller's index of each of the body's nodes.
    node_of: Vec<u32>,
    /// The body's index of each of the caller's nodes.
    body_node: Vec<u32>,
    /// The body's two parts, checked (`None`: the split left a part empty; one thread).
    parts: Option<TwoParts>,
    /// Threads a step runs on: 2 only with `parts`.
    threads: usize,
    /// The loads in the body's order, kept for the steps.
    loads: Vec<Vec3>,
    steps: u64,
    time: f64,
}

/// The material and parameters from the keywords.
#[allow(clippy::too_many_arguments)]
fn parts(
    young: f64,
    poisson: f64,
    density: f64,
    damping: f64,
    substeps: u32,
    iterations: u32,
    gravity: Option<&Bound<'_, PyAny>>,
) -> PyResult<(Material, SoftParams)> {
    let gravity = match gravity {
        Some(g) => arrays::vec3(g, "gravity")?,
        None => Vec3::ZERO,
    };
    Ok((
        Material {
            young: young as f32,
            poisson: poisson as f32,
            density: density as f32,
        },
        SoftParams {
            gravity,
            damping: damping as f32,
            substeps,
            iterations,
        },
    ))
}

/// The threads a body of `tets` tets steps on when the caller names none: two where the
/// machine has a core for each and the body is large enough to pay for the second thread's
/// start each sweep (the host driver's rule, `SoftDriver::with_threads`).
fn default_threads(tets: usize) -> usize {
    if tets >= TWO_THREADS_FROM_TETS {
        step_threads(1)
    } else {
        1
    }
}

impl SoftBody {
    fn over(
        owned: SoftOwned,
        material: Material,
        params: SoftParams,
        threads: Option<usize>,
    ) -> PyResult<Self> {
        if let Some(t) = threads.filter(|t| !(1..=2).contains(t)) {
            return Err(PyValueError::new_err(format!(
                "threads must be 1 or 2, got {t}"
            )));
        }
        let (owned, order) = owned.in_two_parts();
        // The core names a tet by the body's index: name the caller's.
        let caller_tet = |tet: u32| order.tet_of.get(tet as usize).copied().unwrap_or(tet);
        let live = Live::try_new(owned, |o| o.body(&[material], params)).map_err(|e| {
            let e = match e {
                SoftError::NodeOutOfRange { tet } => SoftError::NodeOutOfRange {
                    tet: caller_tet(tet),
                },
                SoftError::DegenerateTet { tet } => SoftError::DegenerateTet {
                    tet: caller_tet(tet),
                },
                SoftError::MaterialIndex { tet } => SoftError::MaterialIndex {
                    tet: caller_tet(tet),
                },
                e => e,
            };
            errors::input(e.to_string())
        })?;
        let parts = live.with_body(|b| order.parts(b));
        let tets = order.tet_of.len();
        let threads = if parts.is_some() {
            threads.unwrap_or_else(|| default_threads(tets))
        } else {
            1
        };
        Ok(Self {
            live,
            loads: vec![Vec3::ZERO; order.node_of.len()],
            tet_of: order.tet_of,
            node_of: order.node_of,
            body_node: order.body_node,
            parts,
            threads,
            steps: 0,
            time: 0.0,
        })
    }

    /// `loads` (the caller's order) into the body's order.
    fn take_loads(&mut self, loads: &[Vec3]) {
        for (slot, &k) in self.loads.iter_mut().zip(&self.node_of) {
            *slot = loads.get(k as usize).copied().unwrap_or(Vec3::ZERO);
        }
    }

    /// One vector a node in the body's order, back in the caller's.
    fn in_caller_order(&self, v: &[Vec3]) -> Vec<Vec3> {
        let mut out = vec![Vec3::ZERO; v.len()];
        for (&x, &k) in v.iter().zip(&self.node_of) {
            if let Some(slot) = out.get_mut(k as usize) {
                *slot = x;
            }
        }
        out
    }

    /// `n` steps; a signal's exception (Ctrl-C) or a step's error ends them early, the steps
    /// taken counted.
    fn step_n(&mut self, n: u64, dt: f64, loads: &[Vec3]) -> PyResult<()> {
        self.take_loads(loads);
        let (loads, parts) = (&self.loads, self.parts.filter(|_| self.threads == 2));
        let mut signals = Signals::new();
        let mut done = 0u64;
        let r = self.live.with_body_mut(|b| {
            while done < n {
                signals.check()?;
                match parts {
                    Some(p) => b.step_two(dt as f32, loads, p, &mut on_two_threads),
                    None => b.step(dt as f32, loads),
                }
                .map_err(|e| PyValueError::new_err(e.to_string()))?;
                done += 1;
            }
            Ok(())
        });
        self.steps += done;
        self.time += done as f64 * dt;
        r
    }
}

#[pymethods]
impl SoftBody {
    #[new]
    #[pyo3(signature = (mesh=PathBuf::from("builtin:block:4"), *, scale=1.0, young=DEFAULT_YOUNG,
        poisson=DEFAULT_POISSON, density=1000.0, damping=0.0, substeps=10, iterations=1,
        gravity=None, threads=None))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        py: Python<'_>,
        mesh: PathBuf,
        scale: f64,
        young: f64,
        poisson: f64,
        density: f64,
        damping: f64,
        substeps: u32,
        iterations: u32,
        gravity: Option<&Bound<'_, PyAny>>,
        threads: Option<usize>,
    ) -> PyResult<Self> {
        let (material, params) = parts(
            young, poisson, density, damping, substeps, iterations, gravity,
        )?;
        let mut loaded = py
            .detach(|| meshio::load(&mesh, scale))
            .map_err(errors::mesh)?;
        let owned = SoftOwned::from_mesh(&loaded.mesh.view());
        Self::over(owned, material, params, threads)
    }

    /// A body over `nodes` (`N x 3`, metres) and `tets` (`T x 4` node indices, each tet
    /// positively oriented: `(b - a) x (c - a) . (d - a) > 0`), the other keywords as
    /// `SoftBody`'s. A flat or inverted tet is named by its row in `tets`.
    #[staticmethod]
    #[pyo3(signature = (nodes, tets, *, young=DEFAULT_YOUNG, poisson=DEFAULT_POISSON,
        density=1000.0, damping=0.0, substeps=10, iterations=1, gravity=None, threads=None))]
    #[allow(clippy::too_many_arguments)]
    fn from_arrays(
        nodes: &Bound<'_, PyAny>,
        tets: &Bound<'_, PyAny>,
        young: f64,
        poisson: f64,
        density: f64,
        damping: f64,
        substeps: u32,
        iterations: u32,
        gravity: Option<&Bound<'_, PyAny>>,
        threads: Option<usize>,
    ) -> PyResult<Self> {
        let (material, params) = parts(
            young, poisson, density, damping, substeps, iterations, gravity,
        )?;
        let n = nodes
            .extract::<PyArrayLike2<'_, f64, AllowTypeChange>>()
            .map_err(|_| PyValueError::new_err("nodes must be a 2-D array, N x 3"))?
            .as_array()
            .nrows();
        let rest = arrays::vectors(Some(nodes), n, "nodes")?;
        let t: PyArrayLike2<'_, i64, AllowTypeChange> = tets
            .extract()
            .map_err(|_| PyValueError::new_err("tets must be a 2-D integer array, T x 4"))?;
        let t = t.as_array();
        if t.ncols() != 4 {
            return Err(PyValueError::new_err(format!(
                "tets must be T x 4, got {} x {}",
                t.nrows(),
                t.ncols()
            )));
        }
        let tets = t
            .rows()
            .into_iter()
            .enumerate()
            .map(|(i, r)| {
                let mut out = [0u32; 4];
                for (o, &v) in out.iter_mut().zip(r.iter()) {
                    *o = u32::try_from(v)
                        .ok()
                        .filter(|&v| (v as usize) < n)
                        .ok_or_else(|| {
                            PyValueError::new_err(format!(
                                "tet {i}: node index {v} is not in 0..{n}"
                            ))
                        })?;
                }
                Ok(out)
            })
            .collect::<PyResult<Vec<_>>>()?;
        Self::over(SoftOwned::new(rest, tets), material, params, threads)
    }

    /// One step of `dt` seconds under `loads` (`N x 3` newtons on the nodes; default none).
    #[pyo3(signature = (dt, loads=None))]
    fn step(&mut self, dt: f64, loads: Option<&Bound<'_, PyAny>>) -> PyResult<()> {
        let loads = arrays::vectors(loads, self.node_count(), "loads")?;
        self.step_n(1, dt, &loads)
    }

    /// `steps` steps of `dt` seconds under the same `loads`, the GIL released while they run.
    #[pyo3(signature = (steps, dt, loads=None))]
    fn run(
        &mut self,
        py: Python<'_>,
        steps: u64,
        dt: f64,
        loads: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<()> {
        let loads = arrays::vectors(loads, self.node_count(), "loads")?;
        py.detach(|| self.step_n(steps, dt, &loads))
    }

    /// Holds every node whose rest position is on or below the plane through `origin` with
    /// upward normal `up`; returns how many.
    fn fix_below(&mut self, origin: &Bound<'_, PyAny>, up: &Bound<'_, PyAny>) -> PyResult<usize> {
        let (o, u) = (arrays::vec3(origin, "origin")?, arrays::vec3(up, "up")?);
        Ok(self.live.with_body_mut(|b| b.fix_below(o, u)))
    }

    /// Holds (`True`) or frees node `i`; `False` past the end.
    fn set_fixed(&mut self, i: usize, fixed: bool) -> bool {
        let Some(&k) = self.body_node.get(i) else {
            return false;
        };
        self.live.with_body_mut(|b| b.set_fixed(k as usize, fixed))
    }

    /// Threads a step runs on: 1, or 2 (the body's two parts' sweeps side by side).
    #[getter]
    fn threads(&self) -> usize {
        self.threads
    }

    /// Nodes.
    #[getter]
    fn node_count(&self) -> usize {
        self.live.with_body(|b| b.node_count())
    }

    /// Tets.
    #[getter]
    fn tet_count(&self) -> usize {
        self.live.with_body(|b| b.tet_count())
    }

    /// Rest positions, `N x 3`.
    #[getter]
    fn rest<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let v = self.live.with_body(|b| self.in_caller_order(b.rest()));
        arrays::to_numpy(py, &v)
    }

    /// Tets, `T x 4` node indices (positively oriented), in the order they were given.
    #[getter]
    fn tets<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<i64>>> {
        let mut t = vec![[0i64; 4]; self.tet_of.len()];
        self.live.with_body(|b| {
            for (tet, &at) in b.tets().iter().zip(&self.tet_of) {
                if let Some(slot) = t.get_mut(at as usize) {
                    *slot =
                        tet.map(|k| i64::from(self.node_of.get(k as usize).copied().unwrap_or(k)));
                }
            }
        });
        arrays::rows(py, &t)
    }

    /// Displacements from rest, `N x 3`.
    #[getter]
    fn displacements<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let v = self
            .live
            .with_body(|b| self.in_caller_order(b.displacements()));
        arrays::to_numpy(py, &v)
    }

    /// Current positions (rest plus displacement), `N x 3`.
    #[getter]
    fn positions<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let p = self.live.with_body(|b| {
            let mut p = vec![Vec3::ZERO; b.node_count()];
            b.write_positions(&mut p);
            self.in_caller_order(&p)
        });
        arrays::to_numpy(py, &p)
    }

    /// Velocities, `N x 3`.
    #[getter]
    fn velocities<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let v = self
            .live
            .with_body(|b| self.in_caller_order(b.velocities()));
        arrays::to_numpy(py, &v)
    }

    /// Which nodes are held (or massless), `N` bools.
    #[getter]
    fn fixed<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<bool>> {
        let f = self.live.with_body(|b| {
            self.body_node
                .iter()
                .map(|&k| b.is_fixed(k as usize))
                .collect()
        });
        PyArray1::from_vec(py, f)
    }

    /// Elastic energy, joules.
    #[getter]
    fn elastic_energy(&self) -> f64 {
        self.live.with_body(|b| b.elastic_energy())
    }

    /// Kinetic energy, joules.
    #[getter]
    fn kinetic_energy(&self) -> f64 {
        self.live.with_body(|b| b.kinetic_energy())
    }

    /// Steps taken.
    #[getter]
    fn steps(&self) -> u64 {
        self.steps
    }

    /// Simulated time, seconds (the sum of the steps' `dt`).
    #[getter]
    fn time(&self) -> f64 {
        self.time
    }

    fn __repr__(&self) -> String {
        format!(
            "SoftBody(nodes={}, tets={}, steps={}, threads={})",
            self.node_count(),
            self.tet_count(),
            self.steps,
            self.threads
        )
    }
}
