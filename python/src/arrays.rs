//! numpy in and out: poses (`N x 3` positions, or `N x 7` with a unit quaternion `w, x, y,
//! z`), drill flags (one for all, or one a pose), loads (`V x 3`); vectors back as `float64`
//! arrays.

use numpy::{AllowTypeChange, PyArray1, PyArray2, PyArrayLike1, PyArrayLike2, PyArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyBool;
use tetradrill::traces::Pose;
use tetradrill_core::script::DRILL_ON;
use tetradrill_core::Vec3;

/// The drill flag of every pose, or of each.
#[derive(Debug, Clone)]
pub enum Drill {
    /// The same for every pose.
    All(bool),
    /// One a pose.
    Each(Vec<bool>),
}

impl Drill {
    /// `drill` as Python gives it: `None` (on), a bool, or an array-like of bools.
    pub fn of(drill: Option<&Bound<'_, PyAny>>) -> PyResult<Self> {
        let Some(d) = drill else {
            return Ok(Self::All(true));
        };
        if let Ok(b) = d.cast::<PyBool>() {
            return Ok(Self::All(b.is_true()));
        }
        let a: PyArrayLike1<'_, bool, AllowTypeChange> = d.extract().map_err(|_| {
            PyValueError::new_err("drill must be a bool or one bool a pose (a 1-D array)")
        })?;
        Ok(Self::Each(a.as_array().to_vec()))
    }

    /// The flag of pose `i`.
    fn at(&self, i: usize) -> bool {
        match self {
            Self::All(b) => *b,
            Self::Each(v) => v.get(i).copied().unwrap_or(false),
        }
    }
}

/// A pose from one row: 3 values (position) or 7 (position, quaternion `w, x, y, z`).
fn pose_of(row: &[f64], drill: bool, i: usize) -> PyResult<Pose> {
    if let Some(k) = row.iter().position(|v| !v.is_finite()) {
        return Err(PyValueError::new_err(format!(
            "pose {i}: value {k} is {}, not a finite number",
            row[k]
        )));
    }
    let position = Vec3::new(row[0] as f32, row[1] as f32, row[2] as f32);
    let rotation = match row {
        [_, _, _, w, x, y, z] => {
            let n = (w * w + x * x + y * y + z * z).sqrt();
            if (n - 1.0).abs() > 1e-3 {
                return Err(PyValueError::new_err(format!(
                    "pose {i}: the quaternion (w, x, y, z) = ({w}, {x}, {y}, {z}) has length {n}, \
                     not 1"
                )));
            }
            [*w as f32, *x as f32, *y as f32, *z as f32]
        }
        _ => [1.0, 0.0, 0.0, 0.0],
    };
    Ok(Pose {
        position,
        rotation,
        buttons: if drill { DRILL_ON } else { 0 },
    })
}

/// Poses from an `N x 3` or `N x 7` array-like, with their drill flags.
pub fn poses(a: &Bound<'_, PyAny>, drill: &Drill) -> PyResult<Vec<Pose>> {
    let a: PyArrayLike2<'_, f64, AllowTypeChange> = a.extract().map_err(|_| {
        PyValueError::new_err(
            "poses must be a 2-D array of numbers, N x 3 (x, y, z) or N x 7 (x, y, z, qw, qx, \
             qy, qz)",
        )
    })?;
    let v = a.as_array();
    let (n, cols) = v.dim();
    if cols != 3 && cols != 7 {
        return Err(PyValueError::new_err(format!(
            "poses must be N x 3 (x, y, z) or N x 7 (x, y, z, qw, qx, qy, qz), got {n} x {cols}"
        )));
    }
    if let Drill::Each(d) = drill {
        if d.len() != n {
            return Err(PyValueError::new_err(format!(
                "{} drill flags for {n} poses",
                d.len()
            )));
        }
    }
    let mut row = [0.0f64; 7];
    (0..n)
        .map(|i| {
            for (k, r) in row.iter_mut().enumerate().take(cols) {
                *r = v[[i, k]];
            }
            pose_of(&row[..cols], drill.at(i), i)
        })
        .collect()
}

/// One pose from a 1-D array-like of 3 or 7 numbers.
pub fn pose(a: &Bound<'_, PyAny>, drill: bool) -> PyResult<Pose> {
    let a: PyArrayLike1<'_, f64, AllowTypeChange> = a.extract().map_err(|_| {
        PyValueError::new_err("a pose is 3 numbers (x, y, z) or 7 (x, y, z, qw, qx, qy, qz)")
    })?;
    let v = a.as_array().to_vec();
    if v.len() != 3 && v.len() != 7 {
        return Err(PyValueError::new_err(format!(
            "a pose is 3 numbers (x, y, z) or 7 (x, y, z, qw, qx, qy, qz), got {}",
            v.len()
        )));
    }
    pose_of(&v, drill, 0)
}

/// A `V x 3` array-like of vectors (`None`: `n` zero vectors), checked to have `n` rows.
pub fn vectors(a: Option<&Bound<'_, PyAny>>, n: usize, what: &str) -> PyResult<Vec<Vec3>> {
    let Some(a) = a else {
        return Ok(vec![Vec3::ZERO; n]);
    };
    let a: PyArrayLike2<'_, f64, AllowTypeChange> = a
        .extract()
        .map_err(|_| PyValueError::new_err(format!("{what} must be a 2-D array, {n} x 3")))?;
    let v = a.as_array();
    if v.dim() != (n, 3) {
        let (r, c) = v.dim();
        return Err(PyValueError::new_err(format!(
            "{what} must be {n} x 3, got {r} x {c}"
        )));
    }
    let out: Vec<Vec3> = v
        .rows()
        .into_iter()
        .map(|r| Vec3::new(r[0] as f32, r[1] as f32, r[2] as f32))
        .collect();
    if out.iter().any(|p| !p.is_finite()) {
        return Err(PyValueError::new_err(format!(
            "{what}: every value must be a finite number"
        )));
    }
    Ok(out)
}

/// One 3-vector from an array-like of 3 numbers.
pub fn vec3(a: &Bound<'_, PyAny>, what: &str) -> PyResult<Vec3> {
    let a: PyArrayLike1<'_, f64, AllowTypeChange> = a
        .extract()
        .map_err(|_| PyValueError::new_err(format!("{what} must be 3 numbers")))?;
    match a.as_array().to_vec()[..] {
        [x, y, z] if x.is_finite() && y.is_finite() && z.is_finite() => {
            Ok(Vec3::new(x as f32, y as f32, z as f32))
        }
        _ => Err(PyValueError::new_err(format!(
            "{what} must be 3 finite numbers"
        ))),
    }
}

/// Vectors as an `N x 3` `float64` array.
pub fn to_numpy<'py>(py: Python<'py>, v: &[Vec3]) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let flat: Vec<f64> = v
        .iter()
        .flat_map(|p| [f64::from(p.x), f64::from(p.y), f64::from(p.z)])
        .collect();
    PyArray1::from_vec(py, flat).reshape([v.len(), 3])
}

/// Rows of `K` values as an `N x K` array.
pub fn rows<'py, T: numpy::Element + Clone, const K: usize>(
    py: Python<'py>,
    v: &[[T; K]],
) -> PyResult<Bound<'py, PyArray2<T>>> {
    let flat: Vec<T> = v.iter().flat_map(|r| r.iter().cloned()).collect();
    PyArray1::from_vec(py, flat).reshape([v.len(), K])
}

/// Poses as numpy: an `N x 7` array (position, quaternion `w, x, y, z`) and `N` drill flags.
pub type PoseArrays<'py> = (Bound<'py, PyArray2<f64>>, Bound<'py, PyArray1<bool>>);

/// Poses as an `N x 7` array (position, quaternion `w, x, y, z`) and their drill flags.
pub fn poses_to_numpy<'py>(py: Python<'py>, poses: &[Pose]) -> PyResult<PoseArrays<'py>> {
    let rows7: Vec<[f64; 7]> = poses
        .iter()
        .map(|p| {
            let [w, x, y, z] = p.rotation.map(f64::from);
            [
                f64::from(p.position.x),
                f64::from(p.position.y),
                f64::from(p.position.z),
                w,
                x,
                y,
                z,
            ]
        })
        .collect();
    let drill: Vec<bool> = poses.iter().map(|p| p.buttons & DRILL_ON != 0).collect();
    Ok((rows(py, &rows7)?, PyArray1::from_vec(py, drill)))
}
