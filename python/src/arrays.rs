//! NumPy arrays in and out: controls `(T, K, 3)`, states `(T+1, N, 3)`, all float64.

use autodiff::Tensor;
use cloth::{Controls, Model};
use numpy::ndarray::Array3;
use numpy::{AllowTypeChange, IntoPyArray, PyArray3, PyArrayLikeDyn};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

/// Controls given as an array-like of shape `(T, K, 3)` (or the flat `(T, 3K)`), checked against
/// `model`: `T` steps of the horizon, `K` control points, finite entries.
pub fn controls_in(
    model: &Model,
    controls: &PyArrayLikeDyn<'_, f64, AllowTypeChange>,
) -> PyResult<Controls> {
    let (t, k) = (model.task.horizon, model.n_controls());
    let view = controls.as_array();
    let shape = view.shape().to_vec();
    let fits = match shape.as_slice() {
        [rows, points, 3] => *rows == t && *points == k,
        [rows, cols] => *rows == t && *cols == 3 * k,
        _ => false,
    };
    if !fits {
        return Err(PyValueError::new_err(format!(
            "controls: expected shape ({t}, {k}, 3) (steps, control points, xyz) or ({t}, {}), got {shape:?}",
            3 * k
        )));
    }
    // Row-major order whatever the array's strides.
    let data: Vec<f64> = view.iter().copied().collect();
    let c = Tensor::new(t, 3 * k, data);
    model
        .check_controls(&c)
        .map_err(|e| crate::errors::to_py(e.into()))?;
    Ok(c)
}

/// A `T × 3K` tensor (controls or a gradient with respect to them) as an array `(T, K, 3)`.
pub fn controls_out<'py>(py: Python<'py>, c: &Tensor) -> Bound<'py, PyArray3<f64>> {
    let (t, k) = (c.rows(), c.cols() / 3);
    Array3::from_shape_vec((t, k, 3), c.data().to_vec())
        .expect("a T × 3K tensor holds T·K·3 numbers")
        .into_pyarray(py)
}

/// Nested `[step][point][xyz]` lists (as in a result) as an array `(steps, points, 3)`.
pub fn nested_out<'py>(py: Python<'py>, nested: &[Vec<[f64; 3]>]) -> Bound<'py, PyArray3<f64>> {
    let points = nested.first().map_or(0, Vec::len);
    let data: Vec<f64> = nested.iter().flatten().flatten().copied().collect();
    Array3::from_shape_vec((nested.len(), points, 3), data)
        .expect("every step holds the same number of points")
        .into_pyarray(py)
}

/// States `x⁰…xᵀ` (each `N × 3`) as one array `(T+1, N, 3)`.
pub fn states_out<'py>(py: Python<'py>, states: &[Tensor]) -> Bound<'py, PyArray3<f64>> {
    let n = states.first().map_or(0, Tensor::rows);
    let data: Vec<f64> = states
        .iter()
        .flat_map(|x| x.data().iter().copied())
        .collect();
    Array3::from_shape_vec((states.len(), n, 3), data)
        .expect("every state is N × 3")
        .into_pyarray(py)
}
