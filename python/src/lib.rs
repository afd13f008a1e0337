//! tetradrill for Python: the library's front door (drilling, touching with a tet-mesh tool,
//! a soft body, replaying a trace, reading a mesh file) as the extension module `tetradrill`,
//! numpy arrays in and out.
//!
//! | file          | what                                                                  |
//! |---------------|-----------------------------------------------------------------------|
//! | [`errors`]    | the exceptions, and the library's errors turned into them             |
//! | [`interrupt`] | Ctrl-C in a long call: Python's signals looked at every 50 ms         |
//! | [`arrays`]    | poses, drill flags and loads from numpy; vectors back to numpy        |
//! | [`settings`]  | a scenario (file or built-in) and keyword overrides, to a typed set-up |
//! | [`drill`]     | `Drilling`, `Surface` and `replay`                                    |
//! | [`touch`]     | `Touching`: a tet-mesh tool against an object                          |
//! | [`soft`]      | `SoftBody`: an elastic body stepped under loads                       |
//! | [`mesh`]      | `read_mesh`: a mesh file's nodes, tets and region labels              |
//!
//! The Python reference is docs/PYTHON.md. Long runs (`Drilling.run`, `replay`,
//! `Touching.run`, `SoftBody.run`) release the GIL while they compute and look at Python's
//! signals every 50 ms, so Ctrl-C ends them between two ticks or steps.

use pyo3::prelude::*;

pub mod arrays;
pub mod drill;
pub mod errors;
pub mod interrupt;
pub mod mesh;
pub mod settings;
pub mod soft;
pub mod touch;

/// The extension module.
#[pymodule]
#[pyo3(name = "tetradrill")]
fn tetradrill_module(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add("PERIOD_S", tetradrill::traces::PERIOD_S)?;
    m.add("TetradrillError", py.get_type::<errors::TetradrillError>())?;
    m.add("InputError", py.get_type::<errors::InputError>())?;
    m.add_class::<drill::Drilling>()?;
    m.add_class::<drill::Surface>()?;
    m.add_class::<touch::Touching>()?;
    m.add_class::<soft::SoftBody>()?;
    m.add_class::<mesh::Mesh>()?;
    m.add_function(wrap_pyfunction!(drill::replay, m)?)?;
    m.add_function(wrap_pyfunction!(mesh::read_mesh, m)?)?;
    m.add_function(wrap_pyfunction!(settings::scenario, m)?)?;
    Ok(())
}
