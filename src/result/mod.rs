//! The result of a planning run — the schema of the result JSON that `clothopt optimize --out`
//! writes, Python's `Plan` wraps and `--start` reads back — and the pure functions on it.
//!
//! [`PlanResult`] holds the run's counts, metrics and arrays and one section per concern:
//! `stages` ([`Stage`]), `task` (the verdict, [`task`]), `safety` (the verdict's checks of the
//! motion between steps, the grippers and the colliders, [`safety`]), `strain` ([`strain`]),
//! `search` (the route search, [`search`]), `check` (other physics, [`check`]), `physics`
//! (which solver ran and how far its states are from equilibrium, [`physics`]) and `measures`
//! (the benchmarks' coverage and particle distance, [`measures`]). [`convert`] turns the JSON's nested
//! lists into the library's tensors and back; `json` reads `null` numbers and leaves untimed runs'
//! times out. Nothing here plans: [`crate::plan`], [`crate::search`] and
//! [`crate::physics_check`] fill these types in, and this module depends on none of them.

pub mod check;
pub mod convert;
mod json;
pub mod measures;
pub mod physics;
pub mod safety;
pub mod search;
pub mod strain;
pub mod task;

pub use check::{CheckPhysics, CheckRound, PhysicsCheck, BRANCH_HALVINGS};
pub use convert::{
    controls_from_nested, controls_to_nested, gripper_positions, mesh_triangles, state_points,
};
pub use measures::Measures;
pub use physics::{EquilibriumReport, PhysicsReport, EQUILIBRIUM_TOLERANCE};
pub use safety::{
    GripperClearance, LayerClearance, LayerPair, MotionCheck, PathMinimum, SafetyReport,
    SurfaceClearance, SURFACE_TOLERANCE,
};
pub use search::{CandidateReport, SearchMode, SearchReport};
pub use strain::{strain_report, StrainReport};
pub use task::{target_errors, Reason, TaskOutcome};

use crate::error::{Error, Result};
use autodiff::Tensor;
use cloth::Metrics;
use json::{is_nan, not_timed, null_as_nan};
use optim::Status;
use serde::Serialize;

/// A planning run's outcome: what the result JSON holds.
#[derive(Clone, Debug, Serialize, serde::Deserialize)]
pub struct PlanResult {
    /// Scene name.
    pub scene: String,
    /// Safety margin `δ`.
    pub delta: f64,
    /// Solver status (`converged`, `infeasible`, `iteration_limit`, `stalled`, …).
    pub status: String,
    /// The solver's one-line explanation.
    pub message: String,
    /// Solver iterations.
    pub iterations: usize,
    /// Rollouts simulated.
    pub evaluations: usize,
    /// Gradient evaluations (backward passes).
    pub gradient_evaluations: usize,
    /// Wall-clock seconds of the optimization; NaN when timing is not reported (`optimize
    /// --no-timing`), and then left out of the JSON so that identical runs write identical bytes.
    #[serde(skip_serializing_if = "is_nan", default = "not_timed")]
    pub wall_s: f64,
    /// Final KKT residual reported by the solver (∞ when its last QP gave no multipliers, NaN
    /// when it never evaluated one; JSON writes both as `null`, which reads back as NaN).
    #[serde(deserialize_with = "null_as_nan")]
    pub kkt_residual: f64,
    /// Max-norm violation of the optimizer's inequality rows (safety rows, control points against
    /// collider planes) at the returned controls; 0 when they all hold (NaN when the start could
    /// not be evaluated, `null` in JSON). See [`PlanResult::is_feasible`].
    #[serde(default, deserialize_with = "null_as_nan")]
    pub constraint_violation: f64,
    /// The paper's metrics at the returned controls. `min_sdf` and `min_sdf_swept` are `null`
    /// when the scene has no safety obstacle (there is no distance to measure; they read back as
    /// ∞), so a script should test for `null` before comparing them with `δ`.
    pub metrics: Metrics,
    /// Edge strain of the returned plan's rollout.
    #[serde(default)]
    pub strain: StrainReport,
    /// Absolute gripper (control point) positions at steps `0..=T`: `(T + 1) × controls × 3`.
    #[serde(default)]
    pub gripper_positions: Vec<Vec<[f64; 3]>>,
    /// Whether the plan achieved the task (targets within tolerance and safe) and, if not, why.
    #[serde(default)]
    pub task: TaskOutcome,
    /// The verdict's checks of the motion between the steps, the grippers and the colliders.
    #[serde(default)]
    pub safety: SafetyReport,
    /// The cloth benchmarks' measures of the final state (normalized coverage, mean particle
    /// distance; absent in results written before they were reported).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub measures: Option<Measures>,
    /// Which physics ran, why, and how far its states are from equilibrium (absent in results
    /// written before it was reported).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub physics: Option<PhysicsReport>,
    /// The optimizer's stages: the smooth κ warm-up (when it ran), then the sharp stage.
    #[serde(default)]
    pub stages: Vec<Stage>,
    /// Largest row violation counted as feasible ([`crate::plan::PlanOptions::tol_feasibility`]).
    #[serde(default = "default_tol_feasibility")]
    pub feasibility_tolerance: f64,
    /// What the user should know about the plan that its status does not say (a start inside a
    /// margin, a dip inside `δ` between steps, …).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub warnings: Vec<String>,
    /// The route search, when it ran ([`crate::search`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub search: Option<SearchReport>,
    /// The plan checked under other physics, when asked ([`crate::physics_check`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub check: Option<PhysicsCheck>,
    /// Cloth grid `[rows, cols]` (particle `r·cols + c`); `[0, 0]` for a mesh cloth.
    pub grid: [usize; 2],
    /// A mesh cloth's triangles (particle indices); absent for a grid, whose triangles follow
    /// from `grid`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub triangles: Option<Vec<[usize; 3]>>,
    /// Particle index of each control point.
    pub control_particles: Vec<usize>,
    /// Controls: `T × controls × 3`.
    pub controls: Vec<Vec<[f64; 3]>>,
    /// States `0..=T`: `(T + 1) × N × 3`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub states: Option<Vec<Vec<[f64; 3]>>>,
    /// The solver's status, for programs.
    #[serde(skip)]
    pub solver_status: Option<Status>,
    /// The last stage's quasi-Newton Hessian (not written), to start a later plan of the same
    /// task from ([`crate::plan::PlanOptions::initial_hessian`]).
    #[serde(skip)]
    pub hessian: Option<optim::DenseMatrix>,
}

/// One optimizer stage of a plan.
#[derive(Clone, Debug, Serialize, serde::Deserialize)]
pub struct Stage {
    /// Sharpness `κ` of the soft-min safety rows in this stage (`null` without them).
    pub kappa: Option<f64>,
    /// Iterations of this stage.
    pub iterations: usize,
    /// How the stage ended.
    pub status: String,
}

/// The feasibility tolerance of a result that does not say (written before it was recorded).
fn default_tol_feasibility() -> f64 {
    FEASIBILITY_TOLERANCE
}

/// Largest constraint violation a plan may have and still count as feasible: the SQP's own
/// feasibility tolerance (the default `SqpSettings::tol_feasibility`, unscaled constraints).
pub const FEASIBILITY_TOLERANCE: f64 = optim::DEFAULT_TOL_FEASIBILITY;

impl PlanResult {
    /// True when the returned controls satisfy the optimizer's constraints (violation at most
    /// [`PlanResult::feasibility_tolerance`]) and the solver did not declare the problem infeasible. Whatever
    /// the status (`converged`, `iteration_limit`, …), a plan that is not feasible is not safe to
    /// execute.
    pub fn is_feasible(&self) -> bool {
        self.status != "infeasible" && self.constraint_violation <= self.feasibility_tolerance
    }

    /// True when the plan's own rollout is [safe](is_safe) at its margin and passes the
    /// verdict's other checks ([`PlanResult::safety`]: the motion between the steps, the grippers
    /// and the colliders).
    pub fn is_safe(&self) -> bool {
        is_safe(&self.metrics) && self.safety.failures.is_empty()
    }

    /// Leaves every wall-clock time out (NaN, not serialized), so that identical runs write
    /// identical bytes.
    pub fn drop_timing(&mut self) {
        self.wall_s = f64::NAN;
        if let Some(search) = &mut self.search {
            for c in &mut search.candidates {
                c.wall_s = f64::NAN;
            }
        }
    }

    /// True when the solver converged and the plan [is safe](PlanResult::is_safe).
    pub fn is_safe_and_converged(&self) -> bool {
        self.status == "converged" && self.is_safe()
    }
}

/// Largest total safety violation `−C` a safe rollout may have (see [`is_safe`]).
pub const SAFETY_TOLERANCE: f64 = 1e-6;

/// The safety judgement of a rollout's metrics: `C ≥ −1e−6` ([`SAFETY_TOLERANCE`]) for the
/// margin `δ` they were computed with. `C = −Σ_t Σ_i relu(δ − SDF)` sums every particle's
/// intrusion at every step, so no particle is more than 1e−6 inside the margin (`C = 0`
/// without safety obstacles).
pub fn is_safe(metrics: &Metrics) -> bool {
    metrics.c >= -SAFETY_TOLERANCE
}

/// The states of a result as tensors (`N × 3` each).
pub fn states_of(result: &PlanResult) -> Result<Vec<Tensor>> {
    let states = result.states.as_ref().ok_or(Error::NoStates)?;
    Ok(states
        .iter()
        .map(|s| Tensor::new(s.len(), 3, s.iter().flatten().copied().collect()))
        .collect())
}
