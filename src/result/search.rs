//! The `search` section of a result: the route search's mode and every candidate it planned
//! ([`crate::search`] runs the search).

use serde::{Deserialize, Serialize};

/// When the planner searches for other routes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
#[serde(rename_all = "snake_case")]
pub enum SearchMode {
    /// Only when the plan from the initial guess does not achieve the task.
    Auto,
    /// Always, even when the first plan achieves the task.
    Always,
    /// Never: plan from the initial guess only.
    Off,
}

impl SearchMode {
    /// Every mode, in the order their names are listed.
    pub const ALL: [SearchMode; 3] = [SearchMode::Auto, SearchMode::Always, SearchMode::Off];

    /// The name the result JSON, the CLI and Python give it (`"auto"`, `"always"`, `"off"`).
    pub fn name(self) -> &'static str {
        match self {
            SearchMode::Auto => "auto",
            SearchMode::Always => "always",
            SearchMode::Off => "off",
        }
    }
}

/// One planned candidate, as listed in the result.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct CandidateReport {
    /// How the route was built (`initial guess` for the first plan).
    pub route: String,
    /// `first` (the plan from the given start), `goal` (a safe plan that missed, planned again
    /// with its targets as a constraint), `goal_identity` (the same from the identity Hessian,
    /// after a `goal` stage from the plan's own ended short), `restored` (a goal stage's plan that
    /// ended just outside the task's rows, planned on without the goal row), `cheap`, `polished`
    /// or `continued` (the best plan planned on where the cheap stage could not finish in the
    /// time left).
    pub stage: String,
    /// Solver status of that stage.
    pub status: String,
    /// Safe at the returned controls.
    pub safe: bool,
    /// Task achieved.
    pub achieved: bool,
    /// Objective `L` (∞ for a candidate whose rollout failed, `null` in JSON).
    #[serde(rename = "L", deserialize_with = "cloth::null_as_infinity")]
    pub l: f64,
    /// Target error `G` (∞ for a candidate whose rollout failed, `null` in JSON).
    #[serde(rename = "G", deserialize_with = "cloth::null_as_infinity")]
    pub g: f64,
    /// Smallest signed distance to the safety obstacles over the rollout (∞ without any,
    /// `null` in JSON, which reads back as ∞).
    #[serde(deserialize_with = "cloth::null_as_infinity")]
    pub min_sdf: f64,
    /// Rollouts simulated by that stage.
    pub simulations: usize,
    /// Optimizer iterations of that stage.
    #[serde(default)]
    pub iterations: usize,
    /// Gradient evaluations (backward passes) of that stage.
    #[serde(default)]
    pub gradient_evaluations: usize,
    /// Wall-clock seconds of that stage (left out under `--no-timing`).
    #[serde(
        skip_serializing_if = "super::json::is_nan",
        default = "super::json::not_timed"
    )]
    pub wall_s: f64,
    /// This is the plan returned.
    pub kept: bool,
    /// Why the candidate could not be planned (status `failed`), e.g. its rollout's error;
    /// absent otherwise.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub error: Option<String>,
}

/// The search section of a result.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct SearchReport {
    /// The mode it ran in.
    pub mode: SearchMode,
    /// Every planned candidate, the first plan first.
    pub candidates: Vec<CandidateReport>,
    /// Rollouts simulated by the whole search (the first plan included).
    pub simulations: usize,
    /// Optimizer iterations of the whole search (the first plan included; 0 in results
    /// written before it was recorded).
    #[serde(default)]
    pub iterations: usize,
    /// Gradient evaluations of the whole search (the first plan included).
    #[serde(default)]
    pub gradient_evaluations: usize,
}
