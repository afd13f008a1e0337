//! Mesh files from Python: `read_mesh` gives a file's nodes, tets and region labels as the
//! file lists them.

use std::path::PathBuf;

use numpy::{PyArray1, PyArray2};
use pyo3::prelude::*;
use tetradrill::meshio::{self, ReadOptions};

use crate::{arrays, errors};

/// A mesh as its file lists it (file order, 0-based node indices).
///
/// `nodes` `N x 3` (file units, `float64`), `tets` `T x 4` (node indices, `int64`), `labels`
/// `T` (region labels, `int32`; 0 for every tet of a file without labels), `tet_lines` `T`
/// (each tet's line in the file, 0 where unknown), `format` (e.g. `"gmsh 2.2"`),
/// `label_source` (where the labels came from, or `None`), `warnings` (one line each).
#[pyclass(module = "tetradrill", frozen)]
#[derive(Debug)]
pub struct Mesh {
    #[pyo3(get)]
    nodes: Py<PyArray2<f64>>,
    #[pyo3(get)]
    tets: Py<PyArray2<i64>>,
    #[pyo3(get)]
    labels: Py<PyArray1<i32>>,
    #[pyo3(get)]
    tet_lines: Py<PyArray1<i64>>,
    #[pyo3(get)]
    format: &'static str,
    #[pyo3(get)]
    label_source: Option<String>,
    #[pyo3(get)]
    warnings: Vec<String>,
}

#[pymethods]
impl Mesh {
    fn __repr__(&self, py: Python<'_>) -> String {
        format!(
            "Mesh(format={:?}, nodes={}, tets={})",
            self.format,
            numpy::PyUntypedArrayMethods::shape(self.nodes.bind(py))[0],
            numpy::PyUntypedArrayMethods::shape(self.tets.bind(py))[0]
        )
    }
}

/// Reads a mesh file (TetGen `.node`/`.ele`, MEDIT `.mesh`/`.meshb`, Gmsh `.msh`, VTK `.vtk`,
/// `.vtu`, each also `.gz`) or a built-in name (`builtin:cube12`, `builtin:block:N`), as it
/// lists its nodes, tets and region labels. `region_array` names the integer cell array of a
/// VTK or VTU file that holds the labels.
///
/// Raises `InputError` with `FILE:LINE: reason` for a bad file.
#[pyfunction]
#[pyo3(signature = (path, *, region_array=None))]
pub fn read_mesh(py: Python<'_>, path: PathBuf, region_array: Option<String>) -> PyResult<Mesh> {
    let options = ReadOptions {
        region_array,
        ..ReadOptions::default()
    };
    let raw = py
        .detach(|| meshio::read_with(&path, &options))
        .map_err(errors::mesh)?;
    let tets: Vec<[i64; 4]> = raw.tets.iter().map(|t| t.map(i64::from)).collect();
    let lines: Vec<i64> = raw.tet_lines.iter().map(|&l| l as i64).collect();
    Ok(Mesh {
        nodes: arrays::rows(py, &raw.positions)?.unbind(),
        tets: arrays::rows(py, &tets)?.unbind(),
        labels: PyArray1::from_vec(py, raw.labels).unbind(),
        tet_lines: PyArray1::from_vec(py, lines).unbind(),
        format: raw.format,
        label_source: raw.label_source,
        warnings: raw.warnings,
    })
}
