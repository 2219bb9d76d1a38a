//! What a caller asks of a run, shared by the CLI and the Python package: a scene by name or
//! path ([`load_scene`]), and the `optimize` settings ([`OptimizeRequest`]) checked and turned into
//! [`PlanOptions`] and [`SearchOptions`]. Error messages name the setting the way the caller
//! spells it (`--delta` on the command line, `delta` from Python).

use crate::plan::{Optimizer, PlanOptions};
use crate::problem::{SafetyForm, TargetModel};
use crate::result::{SearchMode, FEASIBILITY_TOLERANCE};
use crate::search::SearchOptions;
use crate::validate::{
    ensure_factor_or_infinite, ensure_iterations, ensure_non_negative, ensure_positive,
    ensure_positive_or_infinite,
};
use crate::{Error, Result};
use cloth::{Model, Scene};
use std::path::Path;
use std::time::{Duration, Instant};

/// A built-in scene by name, or a scene JSON file by path (an existing path, or any name ending
/// in `.json`). An unknown name is an error listing the built-in scenes.
pub fn load_scene(name_or_path: &str) -> Result<Scene> {
    let path = Path::new(name_or_path);
    if path.exists() || name_or_path.ends_with(".json") {
        Ok(Scene::load(path)?)
    } else {
        // The error lists the built-in scenes itself; it stays the source, so a caller can tell
        // a bad scene from other errors.
        Scene::builtin(name_or_path).map_err(|source| Error::UnknownScene { source })
    }
}

/// A check of one numeric setting: its name as the caller spells it, and its value.
type Check = fn(&str, f64) -> Result<()>;

/// The settings of an `optimize` run; `None` takes the scene's own value.
#[derive(Clone, Debug)]
pub struct OptimizeRequest {
    /// Safety margin δ.
    pub delta: Option<f64>,
    /// Weight α of the trajectory irregularity.
    pub alpha: Option<f64>,
    /// Weight β of the elastic energy.
    pub beta: Option<f64>,
    /// Optimizer iteration limit per κ stage (default 200).
    pub iterations: usize,
    /// Form of the safety constraint (default per step).
    pub safety: SafetyForm,
    /// How the SQP models the target term (default BFGS: `G` in the smooth objective).
    pub target_model: TargetModel,
    /// Judge safety at the steps only (default false: the continuous check, which also keeps
    /// the straight motion between the steps δ away and the grippers' motion out of the
    /// colliders).
    pub step_only: bool,
    /// Sharpness κ of the soft minimum (default the planner's, 3000).
    pub kappa: Option<f64>,
    /// Jacobian reuse band (default off).
    pub reuse_band: Option<f64>,
    /// A trial rollout's Newton work bound, in multiples of its iterate's (default the
    /// planner's, [`crate::problem::DEFAULT_TRIAL_WORK_FACTOR`]; ∞ never stops one).
    pub trial_work_factor: Option<f64>,
    /// The optimizer (default SQP).
    pub solver: Optimizer,
    /// Route search mode (default auto).
    pub search: SearchMode,
    /// Most candidate routes of the search (default 6).
    pub starts: usize,
    /// Scaled KKT tolerance (default 1e-4).
    pub tol: f64,
    /// Feasibility tolerance (default [`FEASIBILITY_TOLERANCE`]).
    pub feasibility_tol: f64,
    /// Plan even when the cloth starts inside an obstacle.
    pub allow_unsafe_start: bool,
    /// Wall-clock limit in seconds.
    pub time_limit: Option<f64>,
}

impl Default for OptimizeRequest {
    /// The CLI's defaults.
    fn default() -> Self {
        OptimizeRequest {
            delta: None,
            alpha: None,
            beta: None,
            iterations: 200,
            safety: SafetyForm::PerStep,
            target_model: TargetModel::default(),
            step_only: false,
            kappa: None,
            reuse_band: None,
            trial_work_factor: None,
            solver: Optimizer::Sqp,
            search: SearchMode::Auto,
            starts: 6,
            tol: 1e-4,
            feasibility_tol: FEASIBILITY_TOLERANCE,
            allow_unsafe_start: false,
            time_limit: None,
        }
    }
}

impl OptimizeRequest {
    /// Checks every setting before any scene is read; an error names the setting as
    /// `name(field)` spells it (e.g. `delta` → `--delta`).
    pub fn check(&self, name: &dyn Fn(&str) -> String) -> Result<()> {
        let optional: [(&str, Option<f64>, Check); 6] = [
            ("delta", self.delta, ensure_non_negative),
            ("alpha", self.alpha, ensure_non_negative),
            ("beta", self.beta, ensure_non_negative),
            ("kappa", self.kappa, ensure_positive),
            ("reuse_band", self.reuse_band, ensure_positive_or_infinite),
            (
                "trial_work_factor",
                self.trial_work_factor,
                ensure_factor_or_infinite,
            ),
        ];
        for (field, value, check) in optional {
            if let Some(v) = value {
                check(&name(field), v)?;
            }
        }
        ensure_positive(&name("tol"), self.tol)?;
        ensure_positive(&name("feasibility_tol"), self.feasibility_tol)?;
        if let Some(limit) = self.time_limit {
            ensure_non_negative(&name("time_limit"), limit)?;
        }
        ensure_iterations(&name("iterations"), self.iterations)
    }

    /// The planner's and the route search's options for `model` (checks `starts`; call
    /// [`OptimizeRequest::check`] first). A time limit starts counting now.
    pub fn options(
        &self,
        model: &Model,
        name: &dyn Fn(&str) -> String,
    ) -> Result<(PlanOptions, SearchOptions)> {
        let mut options = PlanOptions::for_model(model);
        options.iterations = self.iterations;
        options.solver = self.solver;
        if let Some(d) = self.delta {
            options.task.delta = d;
        }
        options.task.alpha = self.alpha.unwrap_or(options.task.alpha);
        options.task.beta = self.beta.unwrap_or(options.task.beta);
        options.task.safety = model.safety.is_some().then_some(self.safety);
        options.task.swept = !self.step_only;
        options.task.target_model = self.target_model;
        options.tol_optimality = self.tol;
        options.tol_feasibility = self.feasibility_tol;
        options.allow_unsafe_start = self.allow_unsafe_start;
        options.task.kappa = self.kappa.unwrap_or(options.task.kappa);
        options.reuse_band = self.reuse_band.unwrap_or(options.reuse_band);
        if let Some(f) = self.trial_work_factor {
            options.task.trial_work_factor = f;
        }
        ensure_iterations(&name("starts"), self.starts)?;
        let search = SearchOptions {
            mode: self.search,
            max_candidates: self.starts,
            random_starts: SearchOptions::default().random_starts.min(self.starts / 4),
            ..SearchOptions::default()
        };
        if let Some(limit) = self.time_limit {
            options.deadline = Some(Instant::now() + Duration::from_secs_f64(limit));
        }
        Ok((options, search))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::result::MotionCheck;

    /// The names of a choice enum's values: `name()` in `ALL` order, the JSON spelling, and
    /// under `cli` clap's (kebab-case, in declaration order), which Python's choices matched
    /// before they used `name()` and the CLI still parses.
    fn check_names<T>(all: &[T], name: fn(T) -> &'static str, expected: &[&str])
    where
        T: Copy + serde::Serialize + std::fmt::Debug,
    {
        let names: Vec<&str> = all.iter().map(|&v| name(v)).collect();
        assert_eq!(names, expected);
        for &v in all {
            let json = serde_json::to_string(&v).expect("serializes");
            assert_eq!(json, format!("\"{}\"", name(v)), "{v:?}");
        }
    }

    #[test]
    fn choice_names_are_the_json_spellings() {
        check_names(&Optimizer::ALL, Optimizer::name, &["sqp", "lbfgs"]);
        check_names(
            &SafetyForm::ALL,
            SafetyForm::name,
            &["per_step", "aggregate", "scalar"],
        );
        check_names(
            &SearchMode::ALL,
            SearchMode::name,
            &["auto", "always", "off"],
        );
        check_names(
            &TargetModel::ALL,
            TargetModel::name,
            &["gauss_newton", "bfgs"],
        );
        // The verdict's reasons, which the summary's first line prints by these names.
        check_names(
            &crate::result::Reason::ALL,
            crate::result::Reason::name,
            &[
                "achieved",
                "no_safe_plan",
                "unreachable_target",
                "targets_cannot_rest",
                "iteration_limit",
                "stopped",
                "stalled",
                "safety_active",
                "limits_active",
                "local_minimum",
            ],
        );
        check_names(
            &[MotionCheck::Continuous, MotionCheck::StepOnly],
            MotionCheck::name,
            &["continuous", "step_only"],
        );
    }

    #[cfg(feature = "cli")]
    #[test]
    fn choice_names_are_the_cli_spellings() {
        fn clap_names<T: clap::ValueEnum>() -> Vec<String> {
            T::value_variants()
                .iter()
                .filter_map(|v| v.to_possible_value())
                .map(|p| p.get_name().replace('-', "_"))
                .collect()
        }
        let names = |all: Vec<&str>| all.into_iter().map(String::from).collect::<Vec<_>>();
        assert_eq!(
            clap_names::<Optimizer>(),
            names(Optimizer::ALL.map(Optimizer::name).to_vec())
        );
        assert_eq!(
            clap_names::<SafetyForm>(),
            names(SafetyForm::ALL.map(SafetyForm::name).to_vec())
        );
        assert_eq!(
            clap_names::<TargetModel>(),
            names(TargetModel::ALL.map(TargetModel::name).to_vec())
        );
        assert_eq!(
            clap_names::<SearchMode>(),
            names(SearchMode::ALL.map(SearchMode::name).to_vec())
        );
    }
}
