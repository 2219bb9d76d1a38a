//! `clothopt.Rollout` (a simulated control sequence), `clothopt.Plan` (an optimizer's result) and
//! `clothopt.Fit` (a material fit's).

use crate::arrays::{controls_out, nested_out, states_out};
use crate::errors::to_py;
use clothopt::fit::{FitResult, FitStatus};
use clothopt::result::PlanResult;
use numpy::PyArray3;
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// The paper's metrics as a dict: `G`, `T`, `E`, `alpha_t`, `beta_e`, `C`, `min_sdf`,
/// `min_sdf_swept`, `L` (floats; `min_sdf` is `inf` without safety obstacles), and with colliders
/// `max_penetration`, a dict of `depth` (float), `step` and `particle` (ints), as in the JSON.
pub fn metrics_dict<'py>(py: Python<'py>, m: &cloth::Metrics) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    for (k, v) in [
        ("G", m.g),
        ("T", m.t),
        ("E", m.e),
        ("alpha_t", m.alpha_t),
        ("beta_e", m.beta_e),
        ("C", m.c),
        ("min_sdf", m.min_sdf),
        ("min_sdf_swept", m.min_sdf_swept),
        ("L", m.l),
    ] {
        d.set_item(k, v)?;
    }
    if let Some(p) = m.max_penetration {
        let pen = PyDict::new(py);
        pen.set_item("depth", p.depth)?;
        pen.set_item("step", p.step)?;
        pen.set_item("particle", p.particle)?;
        d.set_item("max_penetration", pen)?;
    }
    Ok(d)
}

/// A simulated control sequence: `states` `(T+1, N, 3)` (the first the rest state), `controls`
/// `(T, K, 3)`, `metrics` (dict, see `Scene.simulate`) at safety margin `delta`.
#[pyclass(module = "clothopt", frozen)]
pub struct Rollout {
    /// Particle positions per step, `(T+1, N, 3)` float64.
    #[pyo3(get)]
    states: Py<PyArray3<f64>>,
    /// The simulated controls, `(T, K, 3)` float64.
    #[pyo3(get)]
    controls: Py<PyArray3<f64>>,
    /// The safety margin the metrics were evaluated at.
    #[pyo3(get)]
    delta: f64,
    metrics: cloth::Metrics,
}

impl Rollout {
    /// A rollout from a Rust evaluation.
    pub fn new(
        py: Python<'_>,
        metrics: &cloth::Metrics,
        controls: &cloth::Controls,
        states: &[autodiff::Tensor],
        delta: f64,
    ) -> Self {
        Rollout {
            states: states_out(py, states).unbind(),
            controls: controls_out(py, controls).unbind(),
            delta,
            metrics: *metrics,
        }
    }
}

#[pymethods]
impl Rollout {
    /// The metrics: dict of `G`, `T`, `E`, `alpha_t`, `beta_e`, `C`, `min_sdf`, `min_sdf_swept`,
    /// `L`.
    #[getter]
    fn metrics<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        metrics_dict(py, &self.metrics)
    }

    fn __repr__(&self) -> String {
        let m = &self.metrics;
        format!(
            "Rollout(L={:.6}, G={:.6}, C={:.3e}, min_sdf={:.4}, delta={})",
            m.l, m.g, m.c, m.min_sdf, self.delta
        )
    }
}

/// An optimizer's result, the same record `clothopt optimize --out` writes.
///
/// `status` (e.g. "converged"), `achieved` (every target within tolerance and the plan safe),
/// `task` (the verdict: dict), `controls` `(T, K, 3)`, `states` `(T+1, N, 3)`, `metrics` (dict);
/// `to_json()`, `to_dict()` and `save(path)` give the whole record.
#[pyclass(module = "clothopt", frozen)]
pub struct Plan {
    result: PlanResult,
}

impl Plan {
    /// Wraps a planner result.
    pub fn new(result: PlanResult) -> Self {
        Plan { result }
    }
}

#[pymethods]
impl Plan {
    /// The summary `clothopt optimize` prints: verdict, counts, route-search candidates, metrics
    /// (`timing=False` leaves out the wall time).
    #[pyo3(signature = (timing = true))]
    fn summary(&self, timing: bool) -> String {
        self.result.summary(timing)
    }

    /// The solver's final status: "converged", "stalled", "no_progress", "iteration_limit", "time_limit", ….
    #[getter]
    fn status(&self) -> &str {
        &self.result.status
    }

    /// The solver's message.
    #[getter]
    fn message(&self) -> &str {
        &self.result.message
    }

    /// Whether the task is achieved: every target within `task.tolerance`, the plan safe.
    #[getter]
    fn achieved(&self) -> bool {
        self.result.task.achieved
    }

    /// Whether the plan keeps the safety margin (within the feasibility tolerance).
    #[getter]
    fn safe(&self) -> bool {
        self.result.is_safe()
    }

    /// The task verdict as a dict (`achieved`, `reason`, `explanation`, target errors, …).
    #[getter]
    fn task<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        json_value(py, &self.result.task)
    }

    /// The safety margin δ planned for.
    #[getter]
    fn delta(&self) -> f64 {
        self.result.delta
    }

    /// Optimizer iterations in all stages.
    #[getter]
    fn iterations(&self) -> usize {
        self.result.iterations
    }

    /// The planned controls, `(T, K, 3)` float64.
    #[getter]
    fn controls<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray3<f64>> {
        nested_out(py, &self.result.controls)
    }

    /// The planned rollout's states, `(T+1, N, 3)` float64 (None if the result has none).
    #[getter]
    fn states<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray3<f64>>> {
        self.result.states.as_deref().map(|s| nested_out(py, s))
    }

    /// The planned rollout's metrics (dict, as `Rollout.metrics`).
    #[getter]
    fn metrics<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        metrics_dict(py, &self.result.metrics)
    }

    /// Warnings attached to the result.
    #[getter]
    fn warnings(&self) -> Vec<String> {
        self.result.warnings.clone()
    }

    /// to_json() -> str: the result JSON, as `clothopt optimize --out` writes it.
    fn to_json(&self) -> PyResult<String> {
        serde_json::to_string_pretty(&self.result).map_err(|e| to_py(e.into()))
    }

    /// to_dict() -> dict: the result JSON as a dict.
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        json_value(py, &self.result)
    }

    /// save(path) -> None: writes the result JSON to `path` atomically (temporary file and
    /// rename), as `clothopt optimize --out` does.
    fn save(&self, path: std::path::PathBuf) -> PyResult<()> {
        clothopt::output::write_json_atomic(&path, &self.result).map_err(os_error)
    }

    fn __repr__(&self) -> String {
        let r = &self.result;
        format!(
            "Plan(scene={:?}, status={:?}, achieved={}, L={:.6}, min_sdf={:.4}, delta={}, iterations={})",
            r.scene, r.status, r.task.achieved, r.metrics.l, r.metrics.min_sdf, r.delta, r.iterations
        )
    }
}

/// A material fit's result, the same record `clothopt fit --out` writes, and the fitted scene.
///
/// `status` ("converged", "stalled", "iteration_limit"), `parameters` (dict by name of `field`,
/// `start`, `value`, `std_error`, `relative_std_error`, `identifiable`, `at_bound`), `noise`,
/// tracking errors, `fitted_scene` (a `Scene`); `to_json()`, `to_dict()`, `save(path)` give the
/// record, `save_scene(path)` the scene as `--scene-out` writes it.
#[pyclass(module = "clothopt", frozen)]
pub struct Fit {
    result: FitResult,
    /// The scene with the fitted values (and its contact barrier pinned), compiled: a `Scene`
    /// the caller (`Scene.fit`) makes, so that this module names no module above it.
    #[pyo3(get)]
    fitted_scene: Py<PyAny>,
}

impl Fit {
    /// Wraps a fit's result with its fitted scene as a Python `Scene`.
    pub fn new(result: FitResult, fitted_scene: Py<PyAny>) -> Self {
        Fit {
            result,
            fitted_scene,
        }
    }
}

#[pymethods]
impl Fit {
    /// The summary `clothopt fit` prints: status and counts, a line per parameter, the tracking
    /// error (`timing=False` leaves out the wall time).
    #[pyo3(signature = (timing = true))]
    fn summary(&self, timing: bool) -> String {
        self.result.summary(timing)
    }

    /// How the fit ended: "converged", "stalled" or "iteration_limit".
    #[getter]
    fn status(&self) -> PyResult<String> {
        let value = serde_json::to_value(self.result.status).map_err(|e| to_py(e.into()))?;
        Ok(value.as_str().unwrap_or_default().to_string())
    }

    /// Whether it converged (the CLI exits 0 then, 3 otherwise).
    #[getter]
    fn converged(&self) -> bool {
        self.result.status == FitStatus::Converged
    }

    /// The fitted parameters by name, each a dict of `field`, `start`, `value`, `std_error`,
    /// `relative_std_error` (None when not determined), `identifiable`, `at_bound`.
    #[getter]
    fn parameters<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        json_value(py, &self.result.parameters)
    }

    /// The observations' noise: dict of `value` and `source` ("given" or "estimated").
    #[getter]
    fn noise<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        json_value(py, &self.result.noise)
    }

    /// Levenberg–Marquardt iterations.
    #[getter]
    fn iterations(&self) -> usize {
        self.result.iterations
    }

    /// Rollouts simulated.
    #[getter]
    fn simulations(&self) -> usize {
        self.result.simulations
    }

    /// Wall time (s).
    #[getter]
    fn wall_s(&self) -> f64 {
        self.result.wall_s
    }

    /// Tracked points.
    #[getter]
    fn points(&self) -> usize {
        self.result.points
    }

    /// RMS distance of the tracked points to their observations at the start.
    #[getter]
    fn rms_error_start(&self) -> f64 {
        self.result.rms_error_start
    }

    /// RMS distance at the fit.
    #[getter]
    fn rms_error(&self) -> f64 {
        self.result.rms_error
    }

    /// The largest distance at the fit.
    #[getter]
    fn max_error(&self) -> f64 {
        self.result.max_error
    }

    /// Per step, the RMS distance of the points seen then (None where none was).
    #[getter]
    fn residual_per_step(&self) -> Vec<Option<f64>> {
        self.result.residual_per_step.clone()
    }

    /// to_json() -> str: the result JSON, as `clothopt fit --out` writes it.
    fn to_json(&self) -> PyResult<String> {
        serde_json::to_string_pretty(&self.result).map_err(|e| to_py(e.into()))
    }

    /// to_dict() -> dict: the result JSON as a dict.
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        json_value(py, &self.result)
    }

    /// save(path) -> None: writes the result JSON to `path` atomically, as `--out` does.
    fn save(&self, path: std::path::PathBuf) -> PyResult<()> {
        clothopt::output::write_json_atomic(&path, &self.result).map_err(os_error)
    }

    /// save_scene(path) -> None: writes the fitted scene to `path` atomically, as
    /// `--scene-out` does (the same bytes).
    fn save_scene(&self, path: std::path::PathBuf) -> PyResult<()> {
        let text = cloth::scene::to_json_pretty_compact(&self.result.fitted_scene)
            .map_err(|e| to_py(e.into()))?;
        clothopt::output::write_atomic(&path, format!("{text}\n").as_bytes()).map_err(os_error)
    }

    fn __repr__(&self) -> PyResult<String> {
        let values: Vec<String> = (self.result.parameters.iter())
            .map(|(name, p)| format!("{name}={:.6e}", p.value))
            .collect();
        Ok(format!(
            "Fit(scene={:?}, status={:?}, {}, rms_error={:.3e}, iterations={})",
            self.result.scene,
            self.status()?,
            values.join(", "),
            self.result.rms_error,
            self.result.iterations
        ))
    }
}

/// A failed write as an `OSError` with the CLI's message.
fn os_error(e: clothopt::Error) -> PyErr {
    pyo3::exceptions::PyOSError::new_err(clothopt::error_chain(&e))
}

/// A serializable value as plain Python objects (through JSON).
fn json_value<'py, T: serde::Serialize>(py: Python<'py>, value: &T) -> PyResult<Bound<'py, PyAny>> {
    let text = serde_json::to_string(value).map_err(|e| to_py(e.into()))?;
    py.import("json")?.call_method1("loads", (text,))
}
