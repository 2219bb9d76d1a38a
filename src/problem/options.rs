//! What a [`super::TrajectoryProblem`] optimizes and how: the weights and margin of the task, the
//! safety constraint's form, the sharpness of its smooth minima and maxima, the optional goal row.

use super::TargetModel;
use cloth::Model;

/// How the obstacle-avoidance constraint reaches the optimizer.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
#[serde(rename_all = "snake_case")]
pub enum SafetyForm {
    /// One smooth row per step: the soft minimum of the distances of every particle to every
    /// obstacle primitive (sphere, plane), `≥ δ`. Smooth even where the nearest sphere changes.
    PerStep,
    /// One smooth row: the soft minimum over every step, particle and primitive, `≥ δ`. Its
    /// gradient costs one backward pass (the per-step soft minima weighted by their softmax).
    Aggregate,
    /// The paper's scalar `C = −Σ_t Σ_i relu(δ − SDF(x_i^(t))) ≥ 0`.
    Scalar,
}

impl SafetyForm {
    /// Every form, in the order their names are listed.
    pub const ALL: [SafetyForm; 3] = [
        SafetyForm::PerStep,
        SafetyForm::Aggregate,
        SafetyForm::Scalar,
    ];

    /// The name Python and JSON give it (`"per_step"`, `"aggregate"`, `"scalar"`; the CLI spells
    /// `per_step` as `per-step`).
    pub fn name(self) -> &'static str {
        match self {
            SafetyForm::PerStep => "per_step",
            SafetyForm::Aggregate => "aggregate",
            SafetyForm::Scalar => "scalar",
        }
    }
}

/// What a [`TrajectoryProblem`](super::TrajectoryProblem) optimizes and how.
#[derive(Clone, Debug)]
pub struct TaskOptions {
    /// Safety margin `δ`.
    pub delta: f64,
    /// Weight of the trajectory irregularity `T`.
    pub alpha: f64,
    /// Weight of the elastic energy `E`.
    pub beta: f64,
    /// The safety constraint's form; `None` drops it (unconstrained apart from collider rows).
    pub safety: Option<SafetyForm>,
    /// Continuous safety (default `true`): the safety rows (every form) also keep the straight
    /// motion of every particle between consecutive steps `δ` away, each path at its exact
    /// minimizing point, and the gripper rows keep the grippers' motion out of the colliders;
    /// the verdict then checks the same. `false` is the step-only check (`--step-only`): rows
    /// and verdict at the `T` steps only.
    pub swept: bool,
    /// Sharpness `κ` (1/length) of the per-step soft minimum; it lies within `ln(count)/κ` below
    /// the true minimum, so the constraint is slightly conservative.
    pub kappa: f64,
    /// Sharpness of the smooth maximum over edges in the `max_strain` rows (dimensionless; default
    /// [`DEFAULT_STRAIN_KAPPA`]). The smooth maximum lies within `ln(edges)/κ` above the true
    /// one, so a plan meets the limit with up to that much to spare (0.011 on a 10 × 10 cloth at
    /// 500).
    pub strain_kappa: f64,
    /// Require every target particle to end (step `T`) within this distance of its position: one
    /// row `(r/2)·(1 − smax_i ‖x_i − p_i‖²/r²) ≥ 0`, with the soft maximum at sharpness
    /// [`GOAL_KAPPA`] (it lies within `ln(targets)/GOAL_KAPPA` above the true maximum, so a plan
    /// meeting the row has every target within `r·√(1 − ln(targets)/GOAL_KAPPA)`, 0.99 `r` for
    /// 10 targets). Near the bound the row reads `≈ r − max distance`. Default `None`: reaching
    /// the targets is left to the objective.
    pub goal_radius: Option<f64>,
    /// How the SQP models the target term `G` ([`TargetModel`]; default [`TargetModel::Bfgs`]).
    pub target_model: TargetModel,
    /// A trial point's rollout (one the optimizer asks values at, not yet derivatives) may take
    /// at most this many times the Newton iterations of the rollout at the last point whose
    /// gradient was evaluated (its iterate), step by step ([`TaskOptions::trial_schedule`]);
    /// past that the rollout stops and the trial counts as a failed evaluation, so the line
    /// search shortens the step. Where the cloth presses on itself or a collider, a long trial
    /// step's rollout can cost 10–40× an iterate's (`docs/performance.md`). Default
    /// [`DEFAULT_TRIAL_WORK_FACTOR`] (∞: never stops one). No effect under XPBD, whose rollouts
    /// cost the same for any controls.
    pub trial_work_factor: f64,
    /// Under smooth self-contact, one row per step keeping every gripper's particle at least
    /// [`super::step_rows::HELD_MARGIN`] `d̂` off the triangles not incident to it
    /// (`super::step_rows`). Default false: measured on the task suite (docs/experiments.md,
    /// "What the held-clearance rows cost"), they halve `fold_half`'s speed (achieved in
    /// 91–120 s instead of 60 s in three runs each), while `fold_towel` is 1.36× faster with them.
    pub held_clearance: bool,
}

/// Default [`TaskOptions::trial_work_factor`]: off. Measured (`docs/performance.md`): a factor of
/// 4 (2) brings the fold's first SQP iteration from a plain guess to 60 s (33–37 s) from 127 s
/// unbounded, the same iterates; but where nearby controls' rollouts differ 5× in work (u_obstacle under
/// Newton, 289–1,423 iterations) it stops trials the line search would have accepted, and that
/// plan took 67–168 SQP iterations and 251–1,130 simulations instead of 55 and 99.
pub const DEFAULT_TRIAL_WORK_FACTOR: f64 = f64::INFINITY;

/// Sharpness of the soft maximum over the targets' squared relative distances in the goal row.
pub const GOAL_KAPPA: f64 = 100.0;

/// Default [`TaskOptions::strain_kappa`].
pub const DEFAULT_STRAIN_KAPPA: f64 = 500.0;

impl TaskOptions {
    /// The scene's own weights and margin, the per-step safety form when the scene has safety
    /// obstacles, continuous safety, κ = 3000, the default target model.
    pub fn for_model(model: &Model) -> Self {
        TaskOptions {
            delta: model.task.delta,
            alpha: model.task.alpha,
            beta: model.task.beta,
            safety: model.safety.is_some().then_some(SafetyForm::PerStep),
            swept: true,
            kappa: 3000.0,
            strain_kappa: DEFAULT_STRAIN_KAPPA,
            goal_radius: None,
            target_model: TargetModel::default(),
            trial_work_factor: DEFAULT_TRIAL_WORK_FACTOR,
            held_clearance: false,
        }
    }

    /// True when `model` gets safety rows built on the soft minimum (sharpness `kappa`): the
    /// per-step and aggregate forms, on a model with safety obstacles.
    pub fn has_soft_min_rows(&self, model: &Model) -> bool {
        model.safety.is_some()
            && matches!(
                self.safety,
                Some(SafetyForm::PerStep | SafetyForm::Aggregate)
            )
    }

    /// The Newton iterations a trial's rollout may have taken by the end of each step, given its
    /// iterate's per step (`work`): [`TaskOptions::trial_work_factor`] times the iterate's up to
    /// that step plus one mean step. A trial that goes wrong early (a step whose solve would take
    /// hundreds of iterations where its iterate's took tens) stops there, not at the rollout's
    /// total. (A float-to-integer cast saturates: an infinite factor is no bound.)
    pub fn trial_schedule(&self, work: &[usize]) -> Vec<usize> {
        let mean = work.iter().sum::<usize>() as f64 / work.len().max(1) as f64;
        let mut done = 0;
        work.iter()
            .map(|w| {
                done += w;
                (self.trial_work_factor * (done as f64 + mean.max(1.0))).ceil() as usize
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_trial_schedule_follows_the_iterates_work_step_by_step() {
        let options = TaskOptions {
            delta: 0.1,
            alpha: 0.0,
            beta: 0.0,
            safety: None,
            swept: false,
            kappa: 3000.0,
            strain_kappa: DEFAULT_STRAIN_KAPPA,
            goal_radius: None,
            target_model: TargetModel::default(),
            trial_work_factor: 4.0,
            held_clearance: false,
        };
        // Steps of 10, 2 and 30 iterations (mean 14): 4 · (10 + 14), 4 · (12 + 14), 4 · (42 + 14).
        assert_eq!(options.trial_schedule(&[10, 2, 30]), [96, 104, 224]);
        let unbounded = TaskOptions {
            trial_work_factor: f64::INFINITY,
            ..options
        };
        assert!(unbounded
            .trial_schedule(&[5])
            .iter()
            .all(|&b| b == usize::MAX));
    }
}
