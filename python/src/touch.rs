//! Touching from Python: a tet-mesh tool (the pen) against an object, the consistent
//! penetration depth's force at each pose.

use std::path::PathBuf;

use numpy::{PyArray1, PyArray2};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use tetradrill::pen;
use tetradrill::scenario::Scenario;
use tetradrill::traces::Pose;
use tetradrill_core::force::PenContact;
use tetradrill_core::Vec3;

use crate::arrays::{self, Drill};
use crate::interrupt::Signals;
use crate::{errors, settings};

/// A tet-mesh tool (the pen) touching an object, neither drilled.
///
/// `Touching(mesh=None, tool=None, *, scenario=None, **keys)`: `tool` is `"mesh:FILE"` or the
/// tool's mesh file as a path (tip at the origin, axis +z); `mesh` the object; `tool_scale`,
/// `stiffness`, `damping`, `max_force`, `depth_method`, `crossings`, `entry_remedy` and the
/// other scenario keys as keywords. Reads both meshes once.
#[pyclass(module = "tetradrill")]
#[derive(Debug)]
pub struct Touching {
    inner: pen::Touching,
    scenario: Scenario,
}

#[pymethods]
impl Touching {
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
        let inner = py
            .detach(|| pen::Touching::new(&setup))
            .map_err(errors::of)?;
        Ok(Self {
            inner,
            scenario: sc,
        })
    }

    /// The pen at each row of `poses` (`N x 3` tip positions, or `N x 7` with quaternions
    /// turning its +z axis), one 1 ms tick each, from rest (the damping's memory starts
    /// afresh each call); the GIL released while they run. The forces on the hand, `N x 3`,
    /// newtons; with `full=True` a dict: `force`, `raw` (before damping and clamping),
    /// `display_offset` (where to draw the pen so it does not visibly penetrate, `N x 3`),
    /// `penetrations` (`N x 2`: pen nodes in the object, object nodes in the pen), `clamped`
    /// (`N` bools).
    #[pyo3(signature = (poses, *, full=false))]
    fn run<'py>(
        &mut self,
        py: Python<'py>,
        poses: &Bound<'py, PyAny>,
        full: bool,
    ) -> PyResult<Bound<'py, PyAny>> {
        let poses: Vec<Pose> = arrays::poses(poses, &Drill::All(false))?;
        let inner = &mut self.inner;
        let contacts: Vec<PenContact> = py
            .detach(|| {
                inner.run(|touch| {
                    let mut signals = Signals::new();
                    poses
                        .iter()
                        .map(|p| signals.check().map(|()| touch.tick(p)))
                        .collect::<PyResult<Vec<_>>>()
                })
            })
            .map_err(errors::of)??;
        let pick = |f: fn(&PenContact) -> Vec3| contacts.iter().map(f).collect::<Vec<_>>();
        let force = arrays::to_numpy(py, &pick(|c| c.force))?;
        if !full {
            return Ok(force.into_any());
        }
        let d = PyDict::new(py);
        d.set_item("force", force)?;
        d.set_item("raw", arrays::to_numpy(py, &pick(|c| c.raw))?)?;
        d.set_item(
            "display_offset",
            arrays::to_numpy(py, &pick(|c| c.display_offset))?,
        )?;
        let pens: Vec<[i64; 2]> = contacts
            .iter()
            .map(|c| [c.penetrations.0 as i64, c.penetrations.1 as i64])
            .collect();
        let pens: Bound<'py, PyArray2<i64>> = arrays::rows(py, &pens)?;
        d.set_item("penetrations", pens)?;
        let clamped: Vec<bool> = contacts.iter().map(|c| c.clamped).collect();
        d.set_item("clamped", PyArray1::from_vec(py, clamped))?;
        Ok(d.into_any())
    }

    /// The tool's node count.
    #[getter]
    fn tool_nodes(&self) -> usize {
        self.inner.rig().pen.positions().len()
    }

    /// The object's node count.
    #[getter]
    fn object_nodes(&self) -> usize {
        self.inner.rig().obj.positions().len()
    }

    /// The scenario this runs, as a dict of its keys.
    #[getter]
    fn scenario<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        settings::as_python(py, &self.scenario)
    }

    fn __repr__(&self) -> String {
        format!(
            "Touching(mesh={:?}, tool={:?})",
            self.scenario.mesh, self.scenario.tool
        )
    }
}
