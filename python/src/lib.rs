//! Python bindings of clothopt: the native module `clothopt._clothopt` behind the `clothopt`
//! package (`python/clothopt/`). Arrays are NumPy float64; the GIL is released while Rust runs.

mod arrays;
mod errors;
mod results;
mod scene;

use pyo3::prelude::*;

/// builtin_scenes() -> dict[str, str]: the built-in scene names and their one-line descriptions.
#[pyfunction]
fn builtin_scenes() -> Vec<(String, String)> {
    cloth::Scene::builtin_names()
        .iter()
        .map(|(n, d)| (n.to_string(), d.to_string()))
        .collect()
}

/// The native module.
#[pymodule]
fn _clothopt(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<scene::Scene>()?;
    m.add_class::<results::Rollout>()?;
    m.add_class::<results::Plan>()?;
    m.add_class::<results::Fit>()?;
    m.add_function(wrap_pyfunction!(builtin_scenes, m)?)?;
    Ok(())
}
