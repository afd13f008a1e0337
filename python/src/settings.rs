//! A session's set-up from Python: a scenario (a TOML file or `builtin:NAME`, else the
//! defaults) with keyword overrides, each key a scenario key (`stiffness=150.0`,
//! `tool="sphere:0.05"`, `regions={1: {"hardness": 2.0}}`), turned into the typed
//! [`Setup`] once. Unknown keys and values out of range raise `InputError`.

use std::path::PathBuf;

use pyo3::prelude::*;
use pyo3::types::{PyDict, PyString};
use tetradrill::scenario::Scenario;
use tetradrill::setup::Setup;

use crate::errors;

/// The scenario `scenario` (a file, `builtin:NAME` or the defaults), `mesh` and `tool` when
/// given, then every key of `keys`, checked.
pub fn resolve(
    py: Python<'_>,
    scenario: Option<PathBuf>,
    mesh: Option<PathBuf>,
    tool: Option<String>,
    keys: Option<&Bound<'_, PyDict>>,
) -> PyResult<(Scenario, Setup)> {
    let mut sc = match &scenario {
        Some(p) => Scenario::load(&p.to_string_lossy()).map_err(errors::cli)?,
        None => Scenario::default(),
    };
    if let Some(m) = mesh {
        sc.mesh = m.to_string_lossy().into_owned();
    }
    if let Some(t) = tool {
        sc.tool = t;
    }
    if let Some(keys) = keys.filter(|k| !k.is_empty()) {
        // The keys as JSON over the scenario as JSON: serde's own names, defaults and checks
        // (an unknown key is refused with the keys there are). Paths become strings.
        let json = py.import("json")?;
        let fspath = py.import("os")?.getattr("fspath")?;
        let kwargs = PyDict::new(py);
        kwargs.set_item("default", fspath)?;
        let text: String = json
            .call_method("dumps", (keys,), Some(&kwargs))
            .map_err(|e| errors::input(format!("settings: {e}")))?
            .extract()?;
        let over: serde_json::Map<String, serde_json::Value> =
            serde_json::from_str(&text).map_err(|e| errors::input(format!("settings: {e}")))?;
        let mut base =
            serde_json::to_value(&sc).map_err(|e| errors::input(format!("settings: {e}")))?;
        if let Some(obj) = base.as_object_mut() {
            for (k, v) in over {
                obj.insert(k, v);
            }
        }
        sc = serde_json::from_value(base).map_err(|e| errors::input(format!("settings: {e}")))?;
    }
    let setup = sc.setup().map_err(errors::setup)?;
    Ok((sc, setup))
}

/// A tool keyword as Python gives it: a spec string (`"sphere:0.1"`, `"drill:R:L:r"`,
/// `"mesh:FILE"`), or a path-like (a tet-mesh tool's file).
pub fn tool_spec(tool: Option<&Bound<'_, PyAny>>) -> PyResult<Option<String>> {
    let Some(t) = tool else {
        return Ok(None);
    };
    if let Ok(s) = t.cast::<PyString>() {
        return Ok(Some(s.extract::<String>()?));
    }
    let p: PathBuf = t.extract()?;
    Ok(Some(format!("mesh:{}", p.display())))
}

/// The scenario as a dict of its keys (what `Drilling`, `Touching` and `replay` would run):
/// `scenario` (a TOML file or `builtin:NAME`; default: the defaults), then `mesh`, `tool` and
/// every other scenario key given.
///
/// Raises `InputError` for an unreadable scenario, an unknown key or a value out of range.
#[pyfunction]
#[pyo3(signature = (scenario=None, *, mesh=None, tool=None, **keys))]
pub fn scenario<'py>(
    py: Python<'py>,
    scenario: Option<PathBuf>,
    mesh: Option<PathBuf>,
    tool: Option<&Bound<'py, PyAny>>,
    keys: Option<&Bound<'py, PyDict>>,
) -> PyResult<Bound<'py, PyAny>> {
    let (sc, _) = resolve(py, scenario, mesh, tool_spec(tool)?, keys)?;
    as_python(py, &sc)
}

/// A scenario as a Python dict (through JSON).
pub fn as_python<'py>(py: Python<'py>, sc: &Scenario) -> PyResult<Bound<'py, PyAny>> {
    let text = serde_json::to_string(sc).map_err(|e| errors::input(format!("settings: {e}")))?;
    py.import("json")?.call_method1("loads", (text,))
}
