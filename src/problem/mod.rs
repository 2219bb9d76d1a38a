//! A cloth manipulation task as an [`optim::Problem`].
//!
//! Variables: the control sequence `U` flattened step by step (`T × controls × 3`). Objective:
//! the smooth part `βE`, the target term `G` as a residual norm (`target.rs`; or inside the
//! smooth part, [`TaskOptions::target_model`]), with `αT = α Σ_t ‖u_t − u_{t−1}‖` declared as
//! norm terms so the SQP treats their kinks exactly (epigraph second-order cones). Inequalities,
//! all `≥ 0`:
//! - the safety constraint, in one of two forms ([`SafetyForm`]);
//! - step rows (`step_rows.rs`), one per step and kind, pulled back through the rollout with the
//!   loss and safety rows: for `task.limits.max_strain`, `s_max − softmax_edges(strain) ≥ 0` (see
//!   [`TaskOptions::strain_kappa`]); under smooth self-contact, the held particles' clearance from
//!   the rest of the cloth;
//! - optionally ([`TaskOptions::goal_radius`]) one smooth row requiring every target particle to
//!   end within a radius of its position: the route search's last resort when a safe plan misses
//!   its targets, turning "reach the goal" from a cost into a constraint;
//! - smooth rows on the controls alone for `max_step` and `gripper_separation`, and one per
//!   control point and step keeping it out of the colliders other than planes
//!   (`src/control_rows.rs`);
//! - linear rows keeping every control point on the free side of every collider plane and inside
//!   `task.limits.workspace` at every step (the simulator pins control particles, so only these
//!   rows keep them out of the floor and the table).
//!
//! The safety rows (and the gripper rows) hold at the steps and, by default, on the straight
//! motion between them ([`TaskOptions::swept`], `safety.rs`). Grippers are cloth particles, so
//! the safety rows keep them `δ` from the safety obstacles too.
//!
//! Row order ([`RowLabel`]): safety, step rows (strain, held clearance), goal, control rows (step,
//! separation, colliders), linear rows (collider planes, workspace).

mod labels;
mod options;
mod safety;
mod step_rows;
mod target;

pub use labels::RowLabel;
pub use options::{
    SafetyForm, TaskOptions, DEFAULT_STRAIN_KAPPA, DEFAULT_TRIAL_WORK_FACTOR, GOAL_KAPPA,
};
pub use safety::start_inside_margin;
pub use step_rows::{StepRow, HELD_MARGIN};
pub use target::{residual as target_residual, TargetModel};

use crate::control_rows::{
    collider_rows, control_rows, gripper_collider_rows, workspace_rows, ControlRow, LinearRow,
};
use autodiff::{soft_min_value, soft_min_weights, RowIndex, Tape, Tensor, Var};
use cloth::StepCost;
use cloth::{ClothError, Controls, Model, RolloutLimits};
use optim::{DenseMatrix, EvalError, Jacobian, NormTerm, Problem, ResidualNorm};
use std::sync::atomic::AtomicBool;
use std::sync::Arc;
use std::time::Instant;

/// An owned per-step cost (see [`StepCost`]).
type BoxedStepCost<'a> = Box<dyn Fn(&mut Tape, usize, Var, Var) -> Option<Var> + Sync + 'a>;

/// Forward results at one point.
struct Forward {
    x: Vec<f64>,
    /// Newton iterations of each step of the rollout (0 under XPBD).
    work: Vec<usize>,
    states: Vec<Tensor>,
    smooth: f64,
    /// Per-step soft-min rows (per-step and aggregate forms).
    per_step: Vec<f64>,
    /// The constraint rows handed to the optimizer.
    safety: Vec<f64>,
    /// The step rows, kind by kind (`step_rows.rs`).
    step: Vec<f64>,
    /// The goal row, if any.
    goal: Vec<f64>,
    /// The target residual `x_targets(T) − p` when `G` is a residual norm, else empty.
    target: Vec<f64>,
}

/// The tape rows one backward pass pulls back, besides the objective.
struct PulledRows<'r> {
    /// Per-step safety rows (row `r` constrains step `r + 1`); the scalar and aggregate row is
    /// always pulled back.
    safety: &'r [usize],
    /// Step rows.
    step: &'r [usize],
    /// The goal row.
    goal: bool,
}

/// Gradients at one point.
struct Backward {
    x: Vec<f64>,
    objective: Vec<f64>,
    /// Gradients of the safety rows (zero where not `computed`).
    safety: Vec<Vec<f64>>,
    /// Gradients of the step rows (zero where not `computed`).
    step: Vec<Vec<f64>>,
    /// Gradient of the goal row, if any (zero where not `computed`).
    goal: Vec<Vec<f64>>,
    /// Gradients of the target residual's entries when `G` is a residual norm (always pulled
    /// back), else empty.
    target: Vec<Vec<f64>>,
    /// Which safety rows, then step rows, then the goal row were pulled back.
    computed: Vec<bool>,
}

/// The cloth task as an optimization problem (see the module docs).
pub struct TrajectoryProblem<'a> {
    model: &'a Model,
    options: TaskOptions,
    /// Smooth rows on the controls alone (step size, gripper separation, grippers against the
    /// colliders).
    control: Vec<ControlRow>,
    /// The particles whose rest state lies within `δ` of the safety obstacles (`safety.rs`).
    start_inside_margin: Option<Arc<RowIndex>>,
    linear: Vec<LinearRow>,
    forward: Option<Forward>,
    backward: Option<Backward>,
    /// The solver's starting approximation of the Lagrangian's Hessian, if any.
    initial_hessian: Option<DenseMatrix>,
    /// Rollouts simulated so far.
    pub simulations: usize,
    /// Gradient evaluations (backward passes over the rollout) so far.
    pub gradient_evaluations: usize,
    /// Newton iterations of each step of the rollout at the last point whose gradient was
    /// evaluated: the reference of [`TaskOptions::trial_work_factor`].
    iterate_work: Option<Vec<usize>>,
    /// The run's deadline and stop flag: a trial's rollout stops at them
    /// ([`TrajectoryProblem::with_stop`]).
    stop: RolloutLimits,
}

impl<'a> TrajectoryProblem<'a> {
    /// The problem of `model`'s task with `options`.
    pub fn new(model: &'a Model, options: TaskOptions) -> Self {
        let mut linear = collider_rows(model);
        linear.extend(workspace_rows(model));
        let mut control = control_rows(model);
        control.extend(gripper_collider_rows(model, options.kappa, options.swept));
        let start_inside_margin = safety::start_inside_margin_index(model, options.delta);
        TrajectoryProblem {
            model,
            options,
            control,
            start_inside_margin,
            linear,
            forward: None,
            backward: None,
            initial_hessian: None,
            simulations: 0,
            gradient_evaluations: 0,
            iterate_work: None,
            stop: RolloutLimits::default(),
        }
    }

    /// Hands the solver `hessian` as its starting approximation of the Lagrangian's Hessian
    /// (`n × n`, symmetric positive definite), e.g. the previous continuation stage's
    /// [`optim::Solution::hessian`].
    pub fn with_initial_hessian(mut self, hessian: Option<DenseMatrix>) -> Self {
        self.initial_hessian = hessian;
        self
    }

    /// Stops trial rollouts (values at points that are not iterates, once an iterate's gradient
    /// was evaluated) once `deadline` has passed or `stop` is raised: such an evaluation ends
    /// with [`EvalError::interrupted`], and the solver returns its last iterate. The starting
    /// point and iterates' derivatives are always completed.
    pub fn with_stop(mut self, deadline: Option<Instant>, stop: Option<Arc<AtomicBool>>) -> Self {
        self.stop = RolloutLimits {
            deadline,
            stop,
            ..RolloutLimits::default()
        };
        self
    }

    /// Lifts [`TrajectoryProblem::with_stop`]'s deadline and flag: the solver has returned, and
    /// what follows (the plan's verdict) evaluates the problem to the end.
    pub fn lift_stop(&mut self) {
        self.stop = RolloutLimits::default();
    }

    /// The model.
    pub fn model(&self) -> &'a Model {
        self.model
    }

    /// The options.
    pub fn options(&self) -> &TaskOptions {
        &self.options
    }

    /// Entries of the target residual when `G` is a residual norm (3 per target), else 0.
    fn target_entries(&self) -> usize {
        match self.options.target_model {
            TargetModel::GaussNewton => target::residual_len(self.model),
            TargetModel::Bfgs => 0,
        }
    }

    /// Number of goal rows (1 with a [`TaskOptions::goal_radius`] and targets, else 0).
    fn goal_rows(&self) -> usize {
        usize::from(self.options.goal_radius.is_some() && self.model.task.targets.rows() > 0)
    }

    /// Records the goal row on the final state `x` (see [`TaskOptions::goal_radius`]).
    fn record_goal(&self, tape: &mut Tape, x: Var) -> Option<Var> {
        let r = self.options.goal_radius?;
        let reached = tape.gather(x, &self.model.task.targets);
        let target = tape.leaf(self.model.task.target_positions.clone());
        let diff = tape.sub(reached, target);
        let sq = tape.square(diff);
        let dist2 = tape.row_sum(sq);
        // smax(e) = −smin(−e) over the relative squared distances e_i = d_i²/r².
        let neg_rel = tape.scale(dist2, -1.0 / (r * r));
        let smin = tape.soft_min(neg_rel, GOAL_KAPPA);
        // (r/2)(1 − smax) = (r/2)(1 + smin).
        let one_plus = tape.add_scalar(smin, 1.0);
        Some(tape.scale(one_plus, 0.5 * r))
    }

    /// Records the smooth part of the loss at step `t` on state `x` (`βE`, and `G` unless it is
    /// a residual norm).
    fn record_loss(&self, tape: &mut Tape, t: usize, x: Var) -> Option<Var> {
        let (target_model, beta) = (self.options.target_model, self.options.beta);
        target::record_smooth_loss(self.model, target_model, tape, t, x, beta)
    }

    /// Controls tensor of a variable vector.
    pub fn controls(&self, x: &[f64]) -> Controls {
        Tensor::new(
            self.model.task.horizon,
            3 * self.model.n_controls(),
            x.to_vec(),
        )
    }

    /// The forward pass at `x` (cached): the rollout and every cost and row on it. A `trial`
    /// (values asked for, not derivatives) is bounded in work by
    /// [`TaskOptions::trial_work_factor`].
    fn ensure_forward(&mut self, x: &[f64], trial: bool) -> Result<&Forward, EvalError> {
        if self.forward.as_ref().is_none_or(|f| f.x != x) {
            let controls = self.controls(x);
            self.simulations += 1;
            // A trial's rollout stops past its work schedule (`TaskOptions::trial_work_factor`)
            // and at the run's deadline; the starting point (no iterate yet) is not a trial.
            let limits = match (trial, &self.iterate_work) {
                (true, Some(work)) => RolloutLimits {
                    cumulative_iterations: self.options.trial_schedule(work),
                    ..self.stop.clone()
                },
                _ => RolloutLimits::default(),
            };
            let (states, work) = (self.model)
                .simulate_counted(&controls, &limits)
                .map_err(eval_error)?;
            let mut tape = Tape::new();
            let mut smooth = 0.0;
            let mut safety = vec![0.0; self.safety_rows()];
            let mut per_step = Vec::new();
            let kinds = self.step_row_kinds();
            let mut step = vec![Vec::with_capacity(states.len()); kinds.len()];
            let mut goal = Vec::with_capacity(self.goal_rows());
            for t in 1..states.len() {
                tape.clear();
                let xp = tape.leaf(states[t - 1].clone());
                let xv = tape.leaf(states[t].clone());
                if let Some(l) = self.record_loss(&mut tape, t, xv) {
                    smooth += tape.value(l).item();
                }
                match self.options.safety {
                    Some(SafetyForm::PerStep | SafetyForm::Aggregate) if !safety.is_empty() => {
                        if let Some(c) = self.record_step_safety(&mut tape, t, xp, xv) {
                            per_step.push(tape.value(c).item());
                        }
                    }
                    Some(SafetyForm::Scalar) if !safety.is_empty() => {
                        if let Some(c) = self.record_scalar_safety(&mut tape, t, xp, xv) {
                            safety[0] += tape.value(c).item();
                        }
                    }
                    _ => {}
                }
                for (&kind, values) in kinds.iter().zip(&mut step) {
                    if let Some(s) = self.record_step_row(kind, &mut tape, xv) {
                        values.push(tape.value(s).item());
                    }
                }
                if t == self.model.task.horizon && self.goal_rows() > 0 {
                    if let Some(g) = self.record_goal(&mut tape, xv) {
                        goal.push(tape.value(g).item());
                    }
                }
            }
            match self.options.safety {
                Some(SafetyForm::PerStep) if !safety.is_empty() => {
                    safety.copy_from_slice(&per_step)
                }
                Some(SafetyForm::Aggregate) if !safety.is_empty() => {
                    safety[0] = soft_min_value(&per_step, self.options.kappa);
                }
                _ => {}
            }
            let target = match (self.target_entries(), states.last()) {
                (n, Some(last)) if n > 0 => target::residual(self.model, last),
                _ => Vec::new(),
            };
            self.forward = Some(Forward {
                x: x.to_vec(),
                work,
                states,
                smooth,
                per_step,
                safety,
                step: step.concat(),
                goal,
                target,
            });
        }
        self.forward
            .as_ref()
            .ok_or_else(|| EvalError::new("no forward evaluation"))
    }

    /// Which tape rows (safety, step, goal) a backward pass must pull back, in that order: those
    /// in `wanted_rows` (the optimizer's mask over every inequality row; all of them for `None`).
    /// The scalar and aggregate safety row is built from every step, so it is always pulled back.
    fn wanted_tape_rows(&self, wanted_rows: Option<&[bool]>) -> Vec<bool> {
        let rows = self.safety_rows();
        let step_rows = self.step_rows();
        let goal_rows = self.goal_rows();
        let mut wanted: Vec<bool> = match wanted_rows {
            Some(w) if self.options.safety == Some(SafetyForm::PerStep) => w[..rows].to_vec(),
            _ => vec![true; rows],
        };
        wanted.extend_from_slice(&match wanted_rows {
            Some(w) => w[rows..rows + step_rows].to_vec(),
            None => vec![true; step_rows],
        });
        let tape_rows = rows + step_rows;
        wanted.extend_from_slice(&match wanted_rows {
            Some(w) => w[tape_rows..tape_rows + goal_rows].to_vec(),
            None => vec![true; goal_rows],
        });
        wanted
    }

    /// The gradients at `x`, with at least the rows in `wanted_rows` (all of them for `None`;
    /// see [`TrajectoryProblem::wanted_tape_rows`]) pulled back: the cached ones when they cover
    /// them, else a new backward pass ([`TrajectoryProblem::pull_back`]). Per-step rows not
    /// wanted cost no backward pass.
    fn ensure_backward(
        &mut self,
        x: &[f64],
        wanted_rows: Option<&[bool]>,
    ) -> Result<&Backward, EvalError> {
        let wanted = self.wanted_tape_rows(wanted_rows);
        let cached = self
            .backward
            .as_ref()
            .is_some_and(|b| b.x == x && wanted.iter().zip(&b.computed).all(|(&w, &c)| c || !w));
        if !cached {
            self.ensure_forward(x, false)?;
            let backward = self.pull_back(x, wanted)?;
            self.gradient_evaluations += 1;
            self.iterate_work = self.forward.as_ref().map(|f| f.work.clone());
            self.backward = Some(backward);
        }
        self.backward
            .as_ref()
            .ok_or_else(|| EvalError::new("no gradient evaluation"))
    }

    /// One backward pass at `x`, whose forward pass is cached: the objective's gradient and those
    /// of the tape rows in `wanted`, every cost pulled back through the rollout together
    /// ([`Model::gradients`]), in the order loss, safety, step rows, goal, target residual entries
    /// (when `G` is a residual norm: one seed per entry, fewer than the controls).
    fn pull_back(&self, x: &[f64], wanted: Vec<bool>) -> Result<Backward, EvalError> {
        let forward = self
            .forward
            .as_ref()
            .ok_or_else(|| EvalError::new("no forward evaluation"))?;
        let (rows, step_rows, goal_rows) = (self.safety_rows(), self.step_rows(), self.goal_rows());
        let controls = self.controls(x);
        let loss = |tape: &mut Tape, t: usize, _: Var, xv: Var| self.record_loss(tape, t, xv);
        let scalar = |tape: &mut Tape, t: usize, xp: Var, xv: Var| {
            self.record_scalar_safety(tape, t, xp, xv)
        };
        // Per-step rows asked for; the others keep a zero row here.
        let active: Vec<usize> = match self.options.safety {
            Some(SafetyForm::PerStep) => (0..rows).filter(|&r| wanted[r]).collect(),
            _ => Vec::new(),
        };
        let per_step = row_costs(
            &active,
            |r| r + 1,
            |_, tape, t, xp, xv| self.record_step_safety(tape, t, xp, xv),
        );
        // Aggregate: Σ_t w_t s_t with the softmax weights w_t of the per-step rows s_t.
        let weights = soft_min_weights(&forward.per_step, self.options.kappa);
        let aggregate = |tape: &mut Tape, t: usize, xp: Var, xv: Var| {
            let w = weights.get(t - 1).copied().filter(|&w| w > 0.0)?;
            let s = self.record_step_safety(tape, t, xp, xv)?;
            Some(tape.scale(s, w))
        };
        let step_active: Vec<usize> = (0..step_rows).filter(|&r| wanted[rows + r]).collect();
        let (kinds, horizon) = (self.step_row_kinds(), self.model.task.horizon);
        let step_costs = row_costs(
            &step_active,
            |r| r % horizon + 1,
            |r, tape, _, _, xv| self.record_step_row(kinds[r / horizon], tape, xv),
        );
        let want_goal = goal_rows > 0 && wanted[rows + step_rows];
        let goal_cost = move |tape: &mut Tape, t: usize, _: Var, xv: Var| {
            (t == horizon).then(|| self.record_goal(tape, xv)).flatten()
        };
        let mut costs: Vec<StepCost<'_>> = vec![&loss];
        match self.options.safety {
            Some(SafetyForm::Scalar) if rows == 1 => costs.push(&scalar),
            Some(SafetyForm::Aggregate) if rows == 1 => costs.push(&aggregate),
            Some(SafetyForm::PerStep) => {
                costs.extend(per_step.iter().map(|b| b.as_ref() as StepCost<'_>))
            }
            _ => {}
        }
        costs.extend(step_costs.iter().map(|b| b.as_ref() as StepCost<'_>));
        if want_goal {
            costs.push(&goal_cost);
        }
        let model = self.model;
        let target_costs: Vec<BoxedStepCost<'_>> = (0..self.target_entries())
            .map(|i| {
                Box::new(move |tape: &mut Tape, t: usize, _: Var, xv: Var| {
                    (t == horizon).then(|| target::record_entry(model, tape, xv, i))
                }) as BoxedStepCost<'_>
            })
            .collect();
        costs.extend(target_costs.iter().map(|b| b.as_ref() as StepCost<'_>));
        let grads = self.model.gradients(&forward.states, &controls, &costs);
        let pulled = PulledRows {
            safety: &active,
            step: &step_active,
            goal: want_goal,
        };
        Ok(self.sort_gradients(x, grads, &pulled, wanted))
    }

    /// The gradients of a backward pass at `x`, in cost order (the objective's, then those of the
    /// `pulled` rows), as a [`Backward`] whose rows not pulled back are zero; `wanted` records
    /// which were asked for.
    fn sort_gradients(
        &self,
        x: &[f64],
        grads: Vec<Tensor>,
        pulled: &PulledRows<'_>,
        wanted: Vec<bool>,
    ) -> Backward {
        let mut grads = grads.into_iter();
        let objective = grads.next().map(Tensor::into_data).unwrap_or_default();
        let mut safety = vec![vec![0.0; x.len()]; self.safety_rows()];
        match self.options.safety {
            Some(SafetyForm::Scalar | SafetyForm::Aggregate) => {
                for (row, g) in safety.iter_mut().zip(grads.by_ref()) {
                    *row = g.into_data();
                }
            }
            Some(SafetyForm::PerStep) => {
                for (&r, g) in pulled.safety.iter().zip(grads.by_ref()) {
                    safety[r] = g.into_data();
                }
            }
            None => {}
        }
        let mut step = vec![vec![0.0; x.len()]; self.step_rows()];
        for (&r, g) in pulled.step.iter().zip(grads.by_ref()) {
            step[r] = g.into_data();
        }
        let mut goal = vec![vec![0.0; x.len()]; self.goal_rows()];
        if pulled.goal {
            if let (Some(row), Some(g)) = (goal.first_mut(), grads.next()) {
                *row = g.into_data();
            }
        }
        let target = grads.map(Tensor::into_data).collect();
        Backward {
            x: x.to_vec(),
            objective,
            safety,
            step,
            goal,
            target,
            computed: wanted,
        }
    }

    /// Fills the Jacobian of the inequalities at `x`: the safety rows in `wanted` (all for `None`),
    /// and the linear collider rows.
    fn fill_jacobian(
        &mut self,
        x: &[f64],
        wanted: Option<&[bool]>,
        jac: &mut Jacobian,
    ) -> Result<(), EvalError> {
        let backward = self.ensure_backward(x, wanted)?;
        let tape_rows: Vec<Vec<f64>> = backward
            .safety
            .iter()
            .chain(&backward.step)
            .chain(&backward.goal)
            .cloned()
            .collect();
        let k = tape_rows.len();
        let Jacobian::Dense(m) = jac else {
            return Err(EvalError::new("expected a dense Jacobian"));
        };
        for (r, row) in tape_rows.iter().enumerate() {
            m.row_mut(r).copy_from_slice(row);
        }
        for (r, row) in self.control.iter().enumerate() {
            row.gradient(self.model, x, m.row_mut(k + r));
        }
        let k = k + self.control.len();
        for (r, row) in self.linear.iter().enumerate() {
            for &(j, a) in &row.coeffs {
                m.row_mut(k + r)[j] = a;
            }
        }
        Ok(())
    }

    /// The states of the last simulated rollout at `x` (simulating if needed).
    pub fn states(&mut self, x: &[f64]) -> Result<Vec<Tensor>, EvalError> {
        Ok(self.ensure_forward(x, false)?.states.clone())
    }
}

/// One step cost per row in `rows`: `record(row, …)` at the row's step `step_of(row)`, nothing
/// at the others.
fn row_costs<'a, R>(
    rows: &[usize],
    step_of: impl Fn(usize) -> usize,
    record: R,
) -> Vec<BoxedStepCost<'a>>
where
    R: Fn(usize, &mut Tape, usize, Var, Var) -> Option<Var> + Sync + Copy + 'a,
{
    rows.iter()
        .map(|&row| {
            let step = step_of(row);
            Box::new(move |tape: &mut Tape, t: usize, xp: Var, xv: Var| {
                (t == step).then(|| record(row, tape, t, xp, xv)).flatten()
            }) as BoxedStepCost<'a>
        })
        .collect()
}

fn eval_error(e: ClothError) -> EvalError {
    match e {
        ClothError::RolloutStopped { .. } => EvalError::interrupted(e.to_string()),
        _ => EvalError::new(e.to_string()),
    }
}

impl Problem for TrajectoryProblem<'_> {
    fn num_variables(&self) -> usize {
        self.model.task.horizon * 3 * self.model.n_controls()
    }

    fn num_inequalities(&self) -> usize {
        self.safety_rows()
            + self.step_rows()
            + self.goal_rows()
            + self.control.len()
            + self.linear.len()
    }

    fn initial_hessian(&self) -> Option<DenseMatrix> {
        self.initial_hessian.clone()
    }

    fn norm_terms(&self) -> Vec<NormTerm> {
        if self.options.alpha == 0.0 {
            return Vec::new();
        }
        let n = self.num_variables();
        let w = 3 * self.model.n_controls();
        (1..self.model.task.horizon)
            .map(|t| {
                let now: Vec<usize> = (t * w..(t + 1) * w).collect();
                let before: Vec<usize> = ((t - 1) * w..t * w).collect();
                NormTerm::difference(self.options.alpha, n, &now, &before)
            })
            .collect()
    }

    fn residual_norms(&self) -> Vec<ResidualNorm> {
        match self.target_entries() {
            0 => Vec::new(),
            n => vec![ResidualNorm::new(1.0, n)],
        }
    }

    fn residual(&mut self, x: &[f64], _j: usize, r: &mut [f64]) -> Result<(), EvalError> {
        r.copy_from_slice(&self.ensure_forward(x, true)?.target);
        Ok(())
    }

    fn residual_jacobian(
        &mut self,
        x: &[f64],
        _j: usize,
        jac: &mut Jacobian,
    ) -> Result<(), EvalError> {
        // Every backward pass pulls the residual back, whatever rows it was asked for.
        let none = vec![false; self.num_inequalities()];
        let backward = self.ensure_backward(x, Some(&none))?;
        let Jacobian::Dense(m) = jac else {
            return Err(EvalError::new("expected a dense Jacobian"));
        };
        for (i, row) in backward.target.iter().enumerate() {
            m.row_mut(i).copy_from_slice(row);
        }
        Ok(())
    }

    /// Every target within the task's tolerance at the rollout's last state, judged on the
    /// cached rollout of `x` (the solver asks at the iterate it just evaluated; anything else
    /// counts as not reached rather than costing a rollout).
    fn goal_reached(&mut self, x: &[f64]) -> bool {
        let tolerance = self.model.task.tolerance;
        let last = (self.forward.as_ref())
            .filter(|f| f.x == x)
            .and_then(|f| f.states.last());
        last.is_some_and(|state| {
            let errors = crate::result::target_errors(self.model, state);
            !errors.is_empty() && errors.iter().all(|&e| e <= tolerance)
        })
    }

    fn objective(&mut self, x: &[f64]) -> Result<f64, EvalError> {
        Ok(self.ensure_forward(x, true)?.smooth)
    }

    fn gradient(&mut self, x: &[f64], grad: &mut [f64]) -> Result<(), EvalError> {
        // After the Jacobian (the SQP asks for it first) its backward pass is reused whatever rows
        // it pulled back; at a new point every row is pulled back with ∇L.
        let none = vec![false; self.num_inequalities()];
        let seen = self.backward.as_ref().is_some_and(|b| b.x == x);
        grad.copy_from_slice(
            &self
                .ensure_backward(x, seen.then_some(&none[..]))?
                .objective,
        );
        Ok(())
    }

    fn inequalities(&mut self, x: &[f64], c: &mut [f64]) -> Result<(), EvalError> {
        let (k, s, g) = (self.safety_rows(), self.step_rows(), self.goal_rows());
        let forward = self.ensure_forward(x, true)?;
        c[..k].copy_from_slice(&forward.safety);
        c[k..k + s].copy_from_slice(&forward.step);
        c[k + s..k + s + g].copy_from_slice(&forward.goal);
        let model = self.model;
        let control = self.control.iter().map(|row| row.value(model, x));
        let linear = self.linear.iter().map(|row| row.value(x));
        for (ci, v) in c[k + s + g..].iter_mut().zip(control.chain(linear)) {
            *ci = v;
        }
        Ok(())
    }

    fn inequality_jacobian(&mut self, x: &[f64], jac: &mut Jacobian) -> Result<(), EvalError> {
        self.fill_jacobian(x, None, jac)
    }

    fn inequality_jacobian_rows(
        &mut self,
        x: &[f64],
        wanted: &[bool],
        jac: &mut Jacobian,
    ) -> Result<(), EvalError> {
        self.fill_jacobian(x, Some(wanted), jac)
    }
}
