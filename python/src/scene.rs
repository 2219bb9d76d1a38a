//! `clothopt.Scene`: a validated scene and its compiled model; simulate, differentiate, optimize.

use crate::arrays::{controls_in, controls_out};
use crate::errors::{bad_argument, observation_file_error, to_py};
use crate::results::{Fit, Plan, Rollout};
use cloth::{ConstraintRegistry, Model, Parameter};
use clothopt::fit::{fit, FitOptions, Observations};
use clothopt::physics_check::{plan_with_check, CheckRequest};
use clothopt::plan::{initial_controls, Optimizer};
use clothopt::problem::{SafetyForm, TargetModel};
use clothopt::request::{load_scene, OptimizeRequest};
use clothopt::result::{CheckPhysics, SearchMode};
use clothopt::search::plan_with_search;
use clothopt::validate::ensure_non_negative;
use numpy::{AllowTypeChange, IntoPyArray, PyArray3, PyArrayLikeDyn};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyString, PyType};
use std::path::PathBuf;

/// Controls as the Python API takes them: any float array-like `(T, K, 3)` or `(T, 3K)`.
type ControlsArg<'py> = PyArrayLikeDyn<'py, f64, AllowTypeChange>;

/// A cloth scene (cloth, material, physics, obstacles, task), validated and compiled.
///
/// Build one with `Scene.load(name_or_path)` or `Scene.from_dict(d)`. Controls are float64 arrays
/// of shape `(T, K, 3)`: one displacement per step `t` and control point `k`.
#[pyclass(module = "clothopt", frozen)]
pub struct Scene {
    scene: cloth::Scene,
    model: Model,
}

impl Scene {
    /// A scene, compiled.
    fn new(scene: cloth::Scene) -> PyResult<Self> {
        let model = Model::from_scene(&scene).map_err(|e| to_py(e.into()))?;
        Ok(Scene { scene, model })
    }

    /// The given controls, or the scene's initial guess.
    fn controls(&self, controls: Option<ControlsArg<'_>>) -> PyResult<cloth::Controls> {
        match controls {
            Some(c) => controls_in(&self.model, &c),
            None => initial_controls(&self.scene, &self.model).map_err(|e| to_py(e.into())),
        }
    }

    /// `delta`, checked, or the scene's own margin.
    fn delta(&self, delta: Option<f64>) -> PyResult<f64> {
        match delta {
            Some(d) => {
                ensure_non_negative("delta", d).map_err(bad_argument)?;
                Ok(d)
            }
            None => Ok(self.scene.task.delta),
        }
    }
}

/// One of the library's choice enums, by the names it gives its values.
trait Choice: Copy + 'static {
    /// Every value, in the order an error lists them.
    const ALL: &'static [Self];
    /// The value's `snake_case` name (`"per_step"`, `"sqp"`, `"auto"`).
    fn name(self) -> &'static str;
}

impl Choice for SafetyForm {
    const ALL: &'static [Self] = &SafetyForm::ALL;
    fn name(self) -> &'static str {
        SafetyForm::name(self)
    }
}

impl Choice for TargetModel {
    const ALL: &'static [Self] = &TargetModel::ALL;
    fn name(self) -> &'static str {
        TargetModel::name(self)
    }
}

impl Choice for Optimizer {
    const ALL: &'static [Self] = &Optimizer::ALL;
    fn name(self) -> &'static str {
        Optimizer::name(self)
    }
}

impl Choice for SearchMode {
    const ALL: &'static [Self] = &SearchMode::ALL;
    fn name(self) -> &'static str {
        SearchMode::name(self)
    }
}

/// A `snake_case` choice (`"per_step"`, `"sqp"`, `"auto"`), in any case and with `-` for `_`
/// (as the CLI spells `per-step`); an error lists the names.
fn choice<T: Choice>(field: &str, value: &str) -> PyResult<T> {
    let spelled = value.replace('-', "_");
    T::ALL
        .iter()
        .copied()
        .find(|v| v.name().eq_ignore_ascii_case(&spelled))
        .ok_or_else(|| {
            let names: Vec<String> = T::ALL.iter().map(|v| format!("'{}'", v.name())).collect();
            PyValueError::new_err(format!(
                "{field}: must be one of {}, got '{value}'",
                names.join(", ")
            ))
        })
}

/// `step_only`, or the old `swept` saying the opposite (`swept=False` is `step_only=True`); neither
/// given is the default, the continuous check; both given and contradicting each other is an
/// error naming them.
fn step_only_choice(step_only: Option<bool>, swept: Option<bool>) -> PyResult<bool> {
    match (step_only, swept) {
        (Some(step_only), Some(swept)) if swept == step_only => {
            Err(PyValueError::new_err(format!(
                "step_only={} and swept={} contradict each other: swept=True is the default \
                 (the motion between the steps is checked), step_only=True turns it off",
                py_bool(step_only),
                py_bool(swept)
            )))
        }
        (Some(step_only), _) => Ok(step_only),
        (None, Some(swept)) => Ok(!swept),
        (None, None) => Ok(false),
    }
}

/// Observations as `Scene.fit` takes them: the file's JSON, or the file.
enum ObservedArg {
    Text(String),
    File(PathBuf),
}

/// A dict (the observation JSON as Python objects; NumPy arrays and scalars allowed) as JSON
/// text, or a `str` / `os.PathLike` as the file's path.
fn observed_arg(observed: &Bound<'_, PyAny>) -> PyResult<ObservedArg> {
    let py = observed.py();
    if observed.is_instance_of::<PyDict>() {
        // `default` turns NumPy values (arrays, float64, int64) into lists and numbers.
        let kwargs = PyDict::new(py);
        let tolist = py
            .import("operator")?
            .call_method1("methodcaller", ("tolist",))?;
        kwargs.set_item("default", tolist)?;
        let text = (py.import("json")?)
            .call_method("dumps", (observed,), Some(&kwargs))
            .map_err(|e| {
                PyTypeError::new_err(format!("observed: not writable as JSON: {}", e.value(py)))
            })?;
        return Ok(ObservedArg::Text(text.extract()?));
    }
    observed
        .extract::<PathBuf>()
        .map(ObservedArg::File)
        .map_err(|_| {
            PyTypeError::new_err(format!(
                "observed: expected the observation JSON as a dict, or its file's path, got {}",
                type_name(observed)
            ))
        })
}

/// The parameter names of `params`: a list of names or one string, each split at commas as
/// `--params` is.
fn parameter_names(params: &Bound<'_, PyAny>) -> PyResult<Vec<String>> {
    let items: Vec<String> = if params.is_instance_of::<PyString>() {
        vec![params.extract()?]
    } else {
        params.extract().map_err(|_| {
            PyTypeError::new_err(format!(
                "params: expected a list of parameter names or a comma-separated string, got {}",
                type_name(params)
            ))
        })?
    };
    Ok(items
        .iter()
        .flat_map(|s| s.split(','))
        .map(|p| p.trim().to_string())
        .collect())
}

/// The Python type name of `value`, for an error.
fn type_name(value: &Bound<'_, PyAny>) -> String {
    value
        .get_type()
        .name()
        .map_or_else(|_| "?".into(), |n| n.to_string())
}

/// `True` or `False`, as Python spells them.
fn py_bool(b: bool) -> &'static str {
    if b {
        "True"
    } else {
        "False"
    }
}

/// What `Scene.grad` returns: the values dict, `dL_dU` and `dC_dU`.
type GradTuple<'py> = (
    Bound<'py, PyDict>,
    Bound<'py, PyArray3<f64>>,
    Bound<'py, PyArray3<f64>>,
);

#[pymethods]
impl Scene {
    /// Scene.load(name_or_path: str) -> Scene
    ///
    /// A built-in scene by name (see `clothopt.builtin_scenes()`), or a scene JSON file by path.
    /// Raises ValueError for an invalid scene (the message names the field, e.g.
    /// `task.horizon: must be at least 1`) or an unknown name, FileNotFoundError for a missing file.
    #[classmethod]
    fn load(_cls: &Bound<'_, PyType>, name_or_path: &str) -> PyResult<Self> {
        let scene = load_scene(name_or_path).map_err(to_py)?;
        Scene::new(scene)
    }

    /// Scene.from_dict(d: dict) -> Scene
    ///
    /// A scene from a dict in the scene JSON format (`docs/scene-format.md`), e.g. one from
    /// `Scene.to_dict()` with a field changed. Raises ValueError naming the bad field.
    #[classmethod]
    fn from_dict(_cls: &Bound<'_, PyType>, d: &Bound<'_, PyAny>) -> PyResult<Self> {
        let py = d.py();
        let text: String = py.import("json")?.call_method1("dumps", (d,))?.extract()?;
        let scene = cloth::Scene::from_json_str(&text).map_err(|e| to_py(e.into()))?;
        Scene::new(scene)
    }

    /// with_initial_state(positions, settle=True) -> Scene
    ///
    /// The same scene with the cloth starting at `positions` (array-like `(N, 3)`, particle order:
    /// a grid's `r·cols + c`, a mesh's vertex order) instead of its rest shape: its
    /// `cloth.initial_state`. A start that is not at rest is settled by quasi-static steps with
    /// the grippers held (`settle=True`, said in a plan's warnings) or refused (`settle=False`);
    /// one inside a collider or through itself raises ValueError naming `cloth.initial_state`.
    #[pyo3(signature = (positions, settle=true))]
    fn with_initial_state(
        &self,
        positions: PyArrayLikeDyn<'_, f64, AllowTypeChange>,
        settle: bool,
    ) -> PyResult<Self> {
        let n = self.model.n_particles();
        let view = positions.as_array();
        if view.shape() != [n, 3] {
            return Err(PyValueError::new_err(format!(
                "positions: expected shape ({n}, 3) (particles, xyz), got {:?}",
                view.shape()
            )));
        }
        let data: Vec<f64> = view.iter().copied().collect();
        let mut scene = self.scene.clone();
        scene.cloth.initial_state = Some(cloth::scene::InitialState {
            obj: None,
            positions: Some(data.chunks_exact(3).map(|p| [p[0], p[1], p[2]]).collect()),
            recipe: None,
            settle,
            settle_steps: None,
            obj_data: None,
        });
        scene.validate().map_err(|e| to_py(e.into()))?;
        Scene::new(scene)
    }

    /// start() -> ndarray (N, 3): the cloth's positions at step 0 (its rest shape, or its
    /// initial state as placed).
    fn start<'py>(&self, py: Python<'py>) -> Bound<'py, numpy::PyArray2<f64>> {
        let x = &self.model.start;
        numpy::ndarray::Array2::from_shape_vec((x.rows(), 3), x.data().to_vec())
            .expect("an N × 3 tensor")
            .into_pyarray(py)
    }

    /// to_dict() -> dict: the scene in the scene JSON format.
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        py.import("json")?
            .call_method1("loads", (self.scene.to_json_pretty(),))
    }

    /// The scene's name.
    #[getter]
    fn name(&self) -> &str {
        &self.scene.name
    }

    /// Number of steps `T` of the horizon.
    #[getter]
    fn horizon(&self) -> usize {
        self.model.task.horizon
    }

    /// Number of cloth particles `N`.
    #[getter]
    fn n_particles(&self) -> usize {
        self.model.n_particles()
    }

    /// Number of control points `K` (grippers).
    #[getter]
    fn n_controls(&self) -> usize {
        self.model.n_controls()
    }

    /// The scene's safety margin δ.
    #[getter]
    fn delta_default(&self) -> f64 {
        self.scene.task.delta
    }

    /// Shape `(T, K, 3)` of the controls.
    #[getter]
    fn controls_shape(&self) -> (usize, usize, usize) {
        (self.model.task.horizon, self.model.n_controls(), 3)
    }

    /// initial_controls() -> ndarray (T, K, 3): the scene's initial guess.
    fn initial_controls<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray3<f64>>> {
        let c = self.controls(None)?;
        Ok(controls_out(py, &c))
    }

    /// simulate(controls=None, delta=None) -> Rollout
    ///
    /// Simulates `controls` (array-like `(T, K, 3)`; default the initial guess) and evaluates the
    /// metrics with safety margin `delta` (default the scene's). The rollout's `states` are
    /// `(T+1, N, 3)`, the first the rest state. The GIL is released while it runs.
    #[pyo3(signature = (controls=None, delta=None))]
    fn simulate(
        &self,
        py: Python<'_>,
        controls: Option<ControlsArg<'_>>,
        delta: Option<f64>,
    ) -> PyResult<Rollout> {
        let u = self.controls(controls)?;
        let delta = self.delta(delta)?;
        let ev = py
            .detach(|| self.model.evaluate(&u, delta, false))
            .map_err(|e| to_py(e.into()))?;
        Ok(Rollout::new(py, &ev.metrics, &u, &ev.states, delta))
    }

    /// grad(controls=None, delta=None) -> (values, dL_dU, dC_dU)
    ///
    /// The CLI's `grad`: `values` is a dict with `L`, `G`, `T`, `E`, `C`, `min_sdf` (float);
    /// `dL_dU` and `dC_dU` are the gradients of `L = G + αT + βE` and of the safety measure `C`
    /// with respect to the controls, each `(T, K, 3)` float64 (`dC_dU` is zero for a scene
    /// without safety obstacles, where `C` is 0). The GIL is released while it runs.
    #[pyo3(signature = (controls=None, delta=None))]
    fn grad<'py>(
        &self,
        py: Python<'py>,
        controls: Option<ControlsArg<'py>>,
        delta: Option<f64>,
    ) -> PyResult<GradTuple<'py>> {
        let u = self.controls(controls)?;
        let delta = self.delta(delta)?;
        let ev = py
            .detach(|| self.model.evaluate(&u, delta, true))
            .map_err(|e| to_py(e.into()))?;
        let m = ev.metrics;
        let values = PyDict::new(py);
        for (k, v) in [
            ("L", m.l),
            ("G", m.g),
            ("T", m.t),
            ("E", m.e),
            ("C", m.c),
            ("min_sdf", m.min_sdf),
        ] {
            values.set_item(k, v)?;
        }
        let zero = || autodiff::Tensor::zeros(u.rows(), u.cols());
        let grad_l = ev.grad_l.unwrap_or_else(zero);
        let grad_c = ev.grad_c.unwrap_or_else(zero);
        Ok((values, controls_out(py, &grad_l), controls_out(py, &grad_c)))
    }

    /// optimize(delta=None, *, alpha=None, beta=None, iterations=200, solver="sqp",
    /// search="auto", starts=6, safety="per_step", step_only=None, swept=None, kappa=None,
    /// reuse_band=None, trial_work_factor=None, tol=1e-4, feasibility_tol=1e-8,
    /// allow_unsafe_start=False,
    /// time_limit=None, start=None, timing=True, check=None, check_rounds=3,
    /// target_model="bfgs") -> Plan
    ///
    /// Plans the scene's task exactly as `clothopt optimize` does (same defaults; `None` takes
    /// the scene's value): `solver` is "sqp" or "lbfgs", `search` "auto", "always" or "off",
    /// `safety` "per_step", "aggregate" or "scalar"; `step_only=True` judges safety at the steps
    /// only (as `--step-only`; by default (`None`, `False`) the motion between the steps is checked too, and
    /// `swept=True`, the old way to ask for that, is accepted; `swept=False` means
    /// `step_only=True`); `start` the starting controls
    /// `(T, K, 3)` (default the initial guess); `time_limit` in seconds; `timing=False` leaves the
    /// wall-clock time out of the result (as `--no-timing`); `check` ("xpbd:N", "newton",
    /// "newton:TOL" or "newton-branch[:H]") re-simulates the plan under that physics and re-plans with a raised margin
    /// up to `check_rounds` times where it is unsafe there (as `--check`); `target_model`
    /// "bfgs" or "gauss_newton" (as `--target-model`); `trial_work_factor` bounds a line-search
    /// trial's Newton rollout (as `--trial-work-factor`). Raises ValueError for a bad setting
    /// (named as here, e.g. `delta must be a finite number ≥ 0, got -1`). The GIL is released
    /// while it runs.
    #[pyo3(signature = (
        delta=None, *, alpha=None, beta=None, iterations=200, solver="sqp", search="auto",
        starts=6, safety="per_step", step_only=None, swept=None, kappa=None, reuse_band=None,
        trial_work_factor=None,
        tol=1e-4,
        feasibility_tol=clothopt::result::FEASIBILITY_TOLERANCE, allow_unsafe_start=false,
        time_limit=None, start=None, timing=true, check=None, check_rounds=3,
        target_model="bfgs"
    ))]
    #[allow(clippy::too_many_arguments)]
    fn optimize(
        &self,
        py: Python<'_>,
        delta: Option<f64>,
        alpha: Option<f64>,
        beta: Option<f64>,
        iterations: usize,
        solver: &str,
        search: &str,
        starts: usize,
        safety: &str,
        step_only: Option<bool>,
        swept: Option<bool>,
        kappa: Option<f64>,
        reuse_band: Option<f64>,
        trial_work_factor: Option<f64>,
        tol: f64,
        feasibility_tol: f64,
        allow_unsafe_start: bool,
        time_limit: Option<f64>,
        start: Option<ControlsArg<'_>>,
        timing: bool,
        check: Option<&str>,
        check_rounds: usize,
        target_model: &str,
    ) -> PyResult<Plan> {
        let request = OptimizeRequest {
            delta,
            alpha,
            beta,
            iterations,
            safety: choice::<SafetyForm>("safety", safety)?,
            target_model: choice::<TargetModel>("target_model", target_model)?,
            step_only: step_only_choice(step_only, swept)?,
            kappa,
            reuse_band,
            trial_work_factor,
            solver: choice("solver", solver)?,
            search: choice::<SearchMode>("search", search)?,
            starts,
            tol,
            feasibility_tol,
            allow_unsafe_start,
            time_limit,
        };
        let field = |f: &str| f.to_string();
        request.check(&field).map_err(bad_argument)?;
        let u = self.controls(start)?;
        let (options, search) = request.options(&self.model, &field).map_err(bad_argument)?;
        let check = check
            .map(str::parse::<CheckPhysics>)
            .transpose()
            .map_err(bad_argument)?;
        let run_plan = |delta: f64, start: &cloth::Controls| {
            let mut options = options.clone();
            options.task.delta = delta;
            plan_with_search(&self.model, &self.scene, start, &options, &search, |_| {})
        };
        let mut result = py
            .detach(|| {
                let check = check.map(|physics| CheckRequest {
                    physics,
                    rounds: check_rounds,
                });
                plan_with_check(
                    &self.model,
                    &self.scene,
                    check,
                    options.task.delta,
                    &u,
                    run_plan,
                )
            })
            .map_err(to_py)?;
        if !timing {
            result.drop_timing();
        }
        if let Some(warning) = clothopt::strain::strain_warning(&self.model, &result) {
            result.warnings.push(warning);
        }
        Ok(Plan::new(result))
    }

    /// fit(observed, params, max_iterations=50, range=1e3) -> Fit
    ///
    /// Fits material parameters to observed motion exactly as `clothopt fit` does, starting
    /// from this scene's values: `observed` is the observation JSON as a dict (NumPy arrays
    /// allowed) or its file's path; `params` names the parameters ("stretch", "bending", a
    /// custom constraint type, "mass", "gravity", "friction") as a list or comma-separated;
    /// each stays within `[v/range, v·range]`. Raises ValueError with the CLI's message for a
    /// bad observation (naming the field, e.g. `observations: points[0].particle: …`), parameter
    /// or setting, FileNotFoundError for a missing file. The GIL is released while it runs.
    #[pyo3(signature = (
        observed, params, max_iterations=FitOptions::default().max_iterations,
        range=FitOptions::default().range
    ), text_signature = "($self, observed, params, max_iterations=50, range=1e3)")]
    fn fit(
        &self,
        py: Python<'_>,
        observed: &Bound<'_, PyAny>,
        params: &Bound<'_, PyAny>,
        max_iterations: usize,
        range: f64,
    ) -> PyResult<Fit> {
        let observed = observed_arg(observed)?;
        let params: Vec<Parameter> = (parameter_names(params)?.iter())
            .map(|p| Parameter::parse(p))
            .collect();
        let options = FitOptions {
            max_iterations,
            range,
            ..FitOptions::default()
        };
        let result = py.detach(|| {
            let observed = match &observed {
                ObservedArg::Text(text) => {
                    Observations::parse(text, &self.scene, &self.model).map_err(to_py)?
                }
                ObservedArg::File(path) => Observations::read(path, &self.scene, &self.model)
                    .map_err(|e| observation_file_error(path, e))?,
            };
            let registry = ConstraintRegistry::new();
            fit(&self.scene, &registry, &observed, &params, &options).map_err(to_py)
        })?;
        let fitted = Py::new(py, Scene::new(result.fitted_scene.clone())?)?;
        Ok(Fit::new(result, fitted.into_any()))
    }

    fn __repr__(&self) -> String {
        let cloth = match &self.scene.cloth.mesh {
            Some(file) => format!("mesh={file:?} ({} vertices)", self.model.n_particles()),
            None => format!(
                "grid=({}, {})",
                self.scene.cloth.rows, self.scene.cloth.cols
            ),
        };
        format!(
            "Scene(name={:?}, {cloth}, horizon={}, controls={}, delta={}, effects={:?})",
            self.scene.name,
            self.model.task.horizon,
            self.model.n_controls(),
            self.scene.task.delta,
            self.model.effects()
        )
    }
}
