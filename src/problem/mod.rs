//! A cloth manipulation task as an [`optim::Problem`].
//!
//! Variables: the control sequence `U` flattened step by step (`T × controls × 3`). Objective:
//! the smooth part `G + βE`, with `αT = α Σ_t ‖u_t − u_{t−1}‖` declared as norm terms so the SQP
//! treats their kinks exactly (epigraph second-order cones). Inequalities, all `≥ 0`:
//! - the safety constraint, in one of two forms ([`SafetyForm`]);
//! - one smooth row per step for `task.limits.max_strain`: `s_max − softmax_edges(strain) ≥ 0`,
//!   pulled back through the rollout with the loss and safety rows (see [`TaskOptions::strain_kappa`]);
//! - optionally ([`TaskOptions::goal_radius`]) one smooth row requiring every target particle to
//!   end within a radius of its position: the route search's last resort when a safe plan misses
//!   its targets, turning "reach the goal" from a cost into a constraint;
//! - smooth rows on the controls alone for `max_step` and `gripper_separation`
//!   (`src/control_rows.rs`);
//! - linear rows keeping every control point on the free side of every collider plane and inside
//!   `task.limits.workspace` at every step (the simulator pins control particles, so only this
//!   keeps them out of the floor).
//!
//! Grippers are cloth particles, so the safety rows keep them `δ` from the safety obstacles too.
//!
//! Row order: safety, strain, goal, control rows (step, separation), linear rows (colliders,
//! workspace).

mod options;

pub use options::{SafetyForm, TaskOptions, DEFAULT_STRAIN_KAPPA, GOAL_KAPPA};

use crate::control_rows::{collider_rows, control_rows, workspace_rows, ControlRow, LinearRow};
use autodiff::{soft_min_value, soft_min_weights, Tape, Tensor, Var};
use cloth::StepCost;
use cloth::{ClothError, Controls, Model};
use optim::{DenseMatrix, EvalError, Jacobian, NormTerm, Problem};

/// What one inequality row of a [`TrajectoryProblem`] constrains.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RowLabel {
    /// A safety row: of one step (per-step form), or of the whole rollout (`None`).
    Safety {
        /// The step `1..=T` the row constrains, `None` for the scalar and aggregate forms.
        step: Option<usize>,
    },
    /// The goal row: every target within [`TaskOptions::goal_radius`] at step `T`.
    Goal,
    /// A control point kept on the free side of a collider plane at one step.
    ColliderPlane {
        /// Index of the plane among the colliders.
        plane: usize,
        /// Index of the control point.
        control: usize,
        /// The step `1..=T`.
        step: usize,
    },
    /// A robot limit (`task.limits`) at one step.
    Limit {
        /// The limit: `max_strain`, `max_step`, `gripper_separation` or `workspace`.
        limit: &'static str,
        /// The step `1..=T` (for `max_step`, the step the move ends at).
        step: usize,
    },
}

impl std::fmt::Display for RowLabel {
    /// The row as a reader would name it: `safety at step 3`, `limit max_strain at step 4`, …
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match *self {
            RowLabel::Safety { step: Some(t) } => write!(f, "safety at step {t}"),
            RowLabel::Safety { step: None } => write!(f, "safety (whole rollout)"),
            RowLabel::Goal => write!(f, "goal (every target within the goal radius)"),
            RowLabel::ColliderPlane {
                plane,
                control,
                step,
            } => write!(
                f,
                "collider plane {plane} under control point {control} at step {step}"
            ),
            RowLabel::Limit { limit, step } => write!(f, "limit {limit} at step {step}"),
        }
    }
}

/// An owned per-step cost (see [`StepCost`]).
type BoxedStepCost<'a> = Box<dyn Fn(&mut Tape, usize, Var, Var) -> Option<Var> + Sync + 'a>;

/// Interpolation parameters of the swept-path samples between two steps.
const SWEPT_SAMPLES: [f64; 3] = [0.25, 0.5, 0.75];

/// Forward results at one point.
struct Forward {
    x: Vec<f64>,
    states: Vec<Tensor>,
    smooth: f64,
    /// Per-step soft-min rows (per-step and aggregate forms).
    per_step: Vec<f64>,
    /// The constraint rows handed to the optimizer.
    safety: Vec<f64>,
    /// The strain rows (`max_strain − smooth max strain`, steps 1..T).
    strain: Vec<f64>,
    /// The goal row, if any.
    goal: Vec<f64>,
}

/// The tape rows one backward pass pulls back, besides the objective.
struct PulledRows<'r> {
    /// Per-step safety rows (row `r` constrains step `r + 1`); the scalar and aggregate row is
    /// always pulled back.
    safety: &'r [usize],
    /// Strain rows.
    strain: &'r [usize],
    /// The goal row.
    goal: bool,
}

/// Gradients at one point.
struct Backward {
    x: Vec<f64>,
    objective: Vec<f64>,
    /// Gradients of the safety rows (zero where not `computed`).
    safety: Vec<Vec<f64>>,
    /// Gradients of the strain rows (zero where not `computed`).
    strain: Vec<Vec<f64>>,
    /// Gradient of the goal row, if any (zero where not `computed`).
    goal: Vec<Vec<f64>>,
    /// Which safety rows, then strain rows, then the goal row were pulled back.
    computed: Vec<bool>,
}

/// The cloth task as an optimization problem (see the module docs).
pub struct TrajectoryProblem<'a> {
    model: &'a Model,
    options: TaskOptions,
    /// Smooth rows on the controls alone (step size, gripper separation).
    control: Vec<ControlRow>,
    linear: Vec<LinearRow>,
    forward: Option<Forward>,
    backward: Option<Backward>,
    /// The solver's starting approximation of the Lagrangian's Hessian, if any.
    initial_hessian: Option<DenseMatrix>,
    /// Rollouts simulated so far.
    pub simulations: usize,
    /// Gradient evaluations (backward passes over the rollout) so far.
    pub gradient_evaluations: usize,
}

impl<'a> TrajectoryProblem<'a> {
    /// The problem of `model`'s task with `options`.
    pub fn new(model: &'a Model, options: TaskOptions) -> Self {
        let mut linear = collider_rows(model);
        linear.extend(workspace_rows(model));
        TrajectoryProblem {
            model,
            options,
            control: control_rows(model),
            linear,
            forward: None,
            backward: None,
            initial_hessian: None,
            simulations: 0,
            gradient_evaluations: 0,
        }
    }

    /// Hands the solver `hessian` as its starting approximation of the Lagrangian's Hessian
    /// (`n × n`, symmetric positive definite), e.g. the previous continuation stage's
    /// [`optim::Solution::hessian`].
    pub fn with_initial_hessian(mut self, hessian: Option<DenseMatrix>) -> Self {
        self.initial_hessian = hessian;
        self
    }

    /// The model.
    pub fn model(&self) -> &'a Model {
        self.model
    }

    /// The options.
    pub fn options(&self) -> &TaskOptions {
        &self.options
    }

    /// Number of safety rows (0, 1 or `T`).
    fn safety_rows(&self) -> usize {
        match (self.options.safety, self.model.safety.is_some()) {
            (Some(SafetyForm::PerStep), true) => self.model.task.horizon,
            (Some(SafetyForm::Scalar | SafetyForm::Aggregate), true) => 1,
            _ => 0,
        }
    }

    /// Number of strain rows (`T` with a `max_strain` limit on a cloth with stretch edges, else 0).
    fn strain_rows(&self) -> usize {
        if self.model.task.limits.max_strain.is_some() && self.model.strain.is_some() {
            self.model.task.horizon
        } else {
            0
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

    /// Records the strain row of step `t`: `max_strain − smooth max strain`.
    fn record_step_strain(&self, tape: &mut Tape, x: Var) -> Option<Var> {
        let limit = self.model.task.limits.max_strain?;
        let soft = self
            .model
            .record_soft_max_strain(tape, x, self.options.strain_kappa)?;
        let negated = tape.neg(soft);
        Some(tape.add_scalar(negated, limit))
    }

    /// What each inequality row constrains, in row order (safety rows, strain rows, the goal row,
    /// step and separation rows, collider rows, workspace rows).
    pub fn row_labels(&self) -> Vec<RowLabel> {
        let mut labels: Vec<RowLabel> = match self.options.safety {
            Some(SafetyForm::PerStep) => (1..=self.safety_rows())
                .map(|t| RowLabel::Safety { step: Some(t) })
                .collect(),
            _ => vec![RowLabel::Safety { step: None }; self.safety_rows()],
        };
        labels.extend((1..=self.strain_rows()).map(|step| RowLabel::Limit {
            limit: "max_strain",
            step,
        }));
        labels.extend((0..self.goal_rows()).map(|_| RowLabel::Goal));
        labels.extend(self.control.iter().map(|row| {
            let (limit, step) = row.label();
            RowLabel::Limit { limit, step }
        }));
        let (planes, k, horizon) = (
            self.model.colliders.planes.len(),
            self.model.n_controls(),
            self.model.task.horizon,
        );
        for plane in 0..planes {
            for control in 0..k {
                labels.extend((1..=horizon).map(|step| RowLabel::ColliderPlane {
                    plane,
                    control,
                    step,
                }));
            }
        }
        // Workspace rows: per control point, step, axis, the lower then the upper bound.
        let workspace = self.linear.len() - planes * k * horizon;
        labels.extend((0..workspace).map(|r| RowLabel::Limit {
            limit: "workspace",
            step: 1 + (r / 6) % horizon,
        }));
        labels
    }

    /// Controls tensor of a variable vector.
    pub fn controls(&self, x: &[f64]) -> Controls {
        Tensor::new(
            self.model.task.horizon,
            3 * self.model.n_controls(),
            x.to_vec(),
        )
    }

    /// Records the per-step safety term of step `t` (row `t − 1`): soft-min signed distance − δ.
    fn record_step_safety(&self, tape: &mut Tape, x_prev: Var, x: Var) -> Option<Var> {
        let kappa = self.options.kappa;
        let mut parts = vec![self
            .model
            .record_sdf_components_for_soft_min(tape, x, kappa)?];
        if self.options.swept {
            for s in SWEPT_SAMPLES {
                let a = tape.scale(x_prev, 1.0 - s);
                let b = tape.scale(x, s);
                let mid = tape.add(a, b);
                parts.push(
                    self.model
                        .record_sdf_components_for_soft_min(tape, mid, kappa)?,
                );
            }
        }
        let all = tape.concat_rows(&parts);
        let soft = tape.soft_min(all, kappa);
        Some(tape.add_scalar(soft, -self.options.delta))
    }

    fn ensure_forward(&mut self, x: &[f64]) -> Result<&Forward, EvalError> {
        if self.forward.as_ref().is_none_or(|f| f.x != x) {
            let controls = self.controls(x);
            self.simulations += 1;
            let states = self.model.simulate(&controls).map_err(eval_error)?;
            let mut tape = Tape::new();
            let mut smooth = 0.0;
            let mut safety = vec![0.0; self.safety_rows()];
            let mut per_step = Vec::new();
            let mut strain = Vec::with_capacity(self.strain_rows());
            let mut goal = Vec::with_capacity(self.goal_rows());
            for t in 1..states.len() {
                tape.clear();
                let xp = tape.leaf(states[t - 1].clone());
                let xv = tape.leaf(states[t].clone());
                if let Some(l) = self.model.record_loss(&mut tape, t, xv, self.options.beta) {
                    smooth += tape.value(l).item();
                }
                match self.options.safety {
                    Some(SafetyForm::PerStep | SafetyForm::Aggregate) if !safety.is_empty() => {
                        if let Some(c) = self.record_step_safety(&mut tape, xp, xv) {
                            per_step.push(tape.value(c).item());
                        }
                    }
                    Some(SafetyForm::Scalar) if !safety.is_empty() => {
                        if let Some(c) = self.model.record_safety(&mut tape, xv, self.options.delta)
                        {
                            safety[0] += tape.value(c).item();
                        }
                    }
                    _ => {}
                }
                if self.strain_rows() > 0 {
                    if let Some(s) = self.record_step_strain(&mut tape, xv) {
                        strain.push(tape.value(s).item());
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
            self.forward = Some(Forward {
                x: x.to_vec(),
                states,
                smooth,
                per_step,
                safety,
                strain,
                goal,
            });
        }
        self.forward
            .as_ref()
            .ok_or_else(|| EvalError::new("no forward evaluation"))
    }

    /// Which tape rows (safety, strain, goal) a backward pass must pull back, in that order: those
    /// in `wanted_rows` (the optimizer's mask over every inequality row; all of them for `None`).
    /// The scalar and aggregate safety row is built from every step, so it is always pulled back.
    fn wanted_tape_rows(&self, wanted_rows: Option<&[bool]>) -> Vec<bool> {
        let rows = self.safety_rows();
        let strain_rows = self.strain_rows();
        let goal_rows = self.goal_rows();
        let mut wanted: Vec<bool> = match wanted_rows {
            Some(w) if self.options.safety == Some(SafetyForm::PerStep) => w[..rows].to_vec(),
            _ => vec![true; rows],
        };
        wanted.extend_from_slice(&match wanted_rows {
            Some(w) => w[rows..rows + strain_rows].to_vec(),
            None => vec![true; strain_rows],
        });
        let tape_rows = rows + strain_rows;
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
            self.ensure_forward(x)?;
            let backward = self.pull_back(x, wanted)?;
            self.gradient_evaluations += 1;
            self.backward = Some(backward);
        }
        self.backward
            .as_ref()
            .ok_or_else(|| EvalError::new("no gradient evaluation"))
    }

    /// One backward pass at `x`, whose forward pass is cached: the objective's gradient and those
    /// of the tape rows in `wanted`, every cost pulled back through the rollout together
    /// ([`Model::gradients`]), in the order loss, safety, strain, goal.
    fn pull_back(&self, x: &[f64], wanted: Vec<bool>) -> Result<Backward, EvalError> {
        let forward = self
            .forward
            .as_ref()
            .ok_or_else(|| EvalError::new("no forward evaluation"))?;
        let (rows, strain_rows, goal_rows) =
            (self.safety_rows(), self.strain_rows(), self.goal_rows());
        let controls = self.controls(x);
        let beta = self.options.beta;
        let model = self.model;
        let loss =
            move |tape: &mut Tape, t: usize, _: Var, xv: Var| model.record_loss(tape, t, xv, beta);
        let delta = self.options.delta;
        let scalar =
            move |tape: &mut Tape, _: usize, _: Var, xv: Var| model.record_safety(tape, xv, delta);
        // Per-step rows asked for; the others keep a zero row here.
        let active: Vec<usize> = match self.options.safety {
            Some(SafetyForm::PerStep) => (0..rows).filter(|&r| wanted[r]).collect(),
            _ => Vec::new(),
        };
        let per_step = self.step_row_costs(&active, |this, tape, xp, xv| {
            this.record_step_safety(tape, xp, xv)
        });
        // Aggregate: Σ_t w_t s_t with the softmax weights w_t of the per-step rows s_t.
        let weights = soft_min_weights(&forward.per_step, self.options.kappa);
        let aggregate = |tape: &mut Tape, t: usize, xp: Var, xv: Var| {
            let w = weights.get(t - 1).copied().filter(|&w| w > 0.0)?;
            let s = self.record_step_safety(tape, xp, xv)?;
            Some(tape.scale(s, w))
        };
        let strain_active: Vec<usize> = (0..strain_rows).filter(|&r| wanted[rows + r]).collect();
        let strain_costs = self.step_row_costs(&strain_active, |this, tape, _, xv| {
            this.record_step_strain(tape, xv)
        });
        let horizon = self.model.task.horizon;
        let want_goal = goal_rows > 0 && wanted[rows + strain_rows];
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
        costs.extend(strain_costs.iter().map(|b| b.as_ref() as StepCost<'_>));
        if want_goal {
            costs.push(&goal_cost);
        }
        let grads = self.model.gradients(&forward.states, &controls, &costs);
        let pulled = PulledRows {
            safety: &active,
            strain: &strain_active,
            goal: want_goal,
        };
        Ok(self.sort_gradients(x, grads, &pulled, wanted))
    }

    /// One step cost per row in `rows` (row `r` constrains step `r + 1`): `record` at that step,
    /// nothing at the others.
    fn step_row_costs(
        &self,
        rows: &[usize],
        record: fn(&Self, &mut Tape, Var, Var) -> Option<Var>,
    ) -> Vec<BoxedStepCost<'_>> {
        rows.iter()
            .map(|&row| {
                Box::new(move |tape: &mut Tape, t: usize, xp: Var, xv: Var| {
                    (t == row + 1).then(|| record(self, tape, xp, xv)).flatten()
                }) as BoxedStepCost<'_>
            })
            .collect()
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
        let mut strain = vec![vec![0.0; x.len()]; self.strain_rows()];
        for (&r, g) in pulled.strain.iter().zip(grads.by_ref()) {
            strain[r] = g.into_data();
        }
        let mut goal = vec![vec![0.0; x.len()]; self.goal_rows()];
        if pulled.goal {
            if let (Some(row), Some(g)) = (goal.first_mut(), grads.next()) {
                *row = g.into_data();
            }
        }
        Backward {
            x: x.to_vec(),
            objective,
            safety,
            strain,
            goal,
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
            .chain(&backward.strain)
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
        Ok(self.ensure_forward(x)?.states.clone())
    }
}

fn eval_error(e: ClothError) -> EvalError {
    EvalError::new(e.to_string())
}

impl Problem for TrajectoryProblem<'_> {
    fn num_variables(&self) -> usize {
        self.model.task.horizon * 3 * self.model.n_controls()
    }

    fn num_inequalities(&self) -> usize {
        self.safety_rows()
            + self.strain_rows()
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

    fn objective(&mut self, x: &[f64]) -> Result<f64, EvalError> {
        Ok(self.ensure_forward(x)?.smooth)
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
        let (k, s, g) = (self.safety_rows(), self.strain_rows(), self.goal_rows());
        let forward = self.ensure_forward(x)?;
        c[..k].copy_from_slice(&forward.safety);
        c[k..k + s].copy_from_slice(&forward.strain);
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
