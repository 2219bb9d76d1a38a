//! Counting, validating evaluation of a [`Problem`] at a point.

use crate::error::{EvalError, OptimError};
use crate::linalg::{norm2, norm_inf, Jacobian};
use crate::problem::{linear_residual, sort_row, Bounds, NormData, NormKind, Problem, SparseRows};

/// Values at one point.
#[derive(Clone, Debug)]
pub(crate) struct PointValues {
    pub x: Vec<f64>,
    /// Smooth objective `f(x)`.
    pub f: f64,
    /// `Σ w_k ‖r_k‖`.
    pub f_norms: f64,
    /// Norm residuals: `r_k = A_k x + b_k`, then the residual norms' `r_j(x)`.
    pub residuals: Vec<Vec<f64>>,
    /// Scaled constraint values `sᵢ cᵢ(x)` (see [`Evaluator::set_scaling`]).
    pub c: Vec<f64>,
    /// Scaled equality values.
    pub h: Vec<f64>,
    /// Max-norm violation of the *unscaled* constraints.
    pub violation_unscaled: f64,
}

impl PointValues {
    /// Total objective.
    pub(crate) fn objective(&self) -> f64 {
        self.f + self.f_norms
    }

    /// ℓ1 constraint violation.
    pub(crate) fn violation_l1(&self) -> f64 {
        self.c.iter().map(|v| (-v).max(0.0)).sum::<f64>()
            + self.h.iter().map(|v| v.abs()).sum::<f64>()
    }

    /// Max-norm violation of the unscaled constraints (what is reported and tested).
    pub(crate) fn violation_inf(&self) -> f64 {
        self.violation_unscaled
    }

    /// Weighted ℓ1 violation `Σ νᵢ max(0, −cᵢ) + Σ ν_{m+j} |h_j|`.
    pub(crate) fn weighted_violation(&self, weights: &[f64]) -> f64 {
        let m = self.c.len();
        self.c
            .iter()
            .zip(weights)
            .map(|(c, w)| w * (-c).max(0.0))
            .sum::<f64>()
            + self
                .h
                .iter()
                .zip(&weights[m..])
                .map(|(h, w)| w * h.abs())
                .sum::<f64>()
    }

    /// ℓ1 merit `f + Σ w‖r‖ + Σ νᵢ violᵢ`.
    pub(crate) fn merit(&self, weights: &[f64]) -> f64 {
        self.objective() + self.weighted_violation(weights)
    }
}

/// Derivatives at one point.
#[derive(Clone, Debug)]
pub(crate) struct PointDerivatives {
    pub g: Vec<f64>,
    pub jc: Jacobian,
    pub jh: Jacobian,
    /// Inequality rows of `jc` kept from an earlier iterate instead of evaluated here (see
    /// [`SqpSettings::jacobian_reuse_margin`](crate::SqpSettings)).
    pub kept: Vec<bool>,
    /// Per norm term, the Jacobian of a residual norm's residual (empty for a linear term, whose
    /// rows are its matrix: [`NormData::rows`]).
    pub norm_jac: Vec<SparseRows>,
}

impl PointDerivatives {
    /// True when some row of `jc` was kept from an earlier iterate.
    pub(crate) fn has_kept_rows(&self) -> bool {
        self.kept.contains(&true)
    }
}

/// Relative accuracy to which a kept Jacobian row must have predicted its constraint's change over
/// the last step to be kept again.
pub(crate) const REUSE_PREDICTION: f64 = 0.1;

/// What [`Evaluator::derivatives_reusing`] may reuse: the last iterate's values and derivatives,
/// and the values at the new point.
pub(crate) struct Reuse<'a> {
    pub from: &'a PointValues,
    pub previous: &'a PointDerivatives,
    pub values: &'a PointValues,
}

/// Wraps a problem with evaluation counters and validation.
pub(crate) struct Evaluator<'p, P: Problem + ?Sized> {
    pub problem: &'p mut P,
    pub n: usize,
    pub m: usize,
    pub q: usize,
    pub norms: Vec<NormData>,
    pub lower: Vec<f64>,
    pub upper: Vec<f64>,
    pub has_bounds: bool,
    pub function_evaluations: usize,
    pub gradient_evaluations: usize,
    /// Row scaling of the inequalities (1 unless [`Evaluator::set_scaling`] was called).
    pub c_scale: Vec<f64>,
    /// Row scaling of the equalities.
    pub h_scale: Vec<f64>,
    /// Inequality rows at least this far above zero may keep their previous Jacobian rows.
    pub reuse_margin: Option<f64>,
    /// Why the problem declined an evaluation because the run must stop, if it did
    /// ([`EvalError::interrupted`]).
    pub interruption: Option<String>,
}

impl<'p, P: Problem + ?Sized> Evaluator<'p, P> {
    /// Validates the problem's static description and the starting point.
    pub(crate) fn new(problem: &'p mut P, x0: &[f64]) -> Result<Self, OptimError> {
        let n = problem.num_variables();
        if n == 0 {
            return Err(OptimError::InvalidProblem(
                "the problem has no variables".into(),
            ));
        }
        if x0.len() != n {
            return Err(OptimError::InvalidStartingPoint(format!(
                "x0 has length {}, expected {n}",
                x0.len()
            )));
        }
        if let Some(i) = x0.iter().position(|v| !v.is_finite()) {
            return Err(OptimError::InvalidStartingPoint(format!(
                "x0[{i}] = {} is not finite",
                x0[i]
            )));
        }
        let bounds = problem.bounds();
        let has_bounds = bounds.as_ref().is_some_and(Bounds::is_active);
        let bounds = bounds.unwrap_or_else(|| Bounds::unbounded(n));
        bounds.validate(n)?;
        let norms = NormData::from_terms(&problem.norm_terms(), &problem.residual_norms(), n)?;
        let (problem_m, problem_q) = (problem.num_inequalities(), problem.num_equalities());
        Ok(Self {
            n,
            m: problem.num_inequalities(),
            q: problem.num_equalities(),
            norms,
            lower: bounds.lower,
            upper: bounds.upper,
            has_bounds,
            problem,
            function_evaluations: 0,
            gradient_evaluations: 0,
            c_scale: vec![1.0; problem_m],
            h_scale: vec![1.0; problem_q],
            reuse_margin: None,
            interruption: None,
        })
    }

    /// Clamps `x` into the bounds.
    pub(crate) fn project(&self, x: &mut [f64]) {
        for ((xi, l), u) in x.iter_mut().zip(&self.lower).zip(&self.upper) {
            *xi = xi.clamp(*l, *u);
        }
    }

    /// Objective, norm terms and constraints at `x`. An error that interrupts the run
    /// ([`EvalError::interrupted`]) is also kept in [`Evaluator::interruption`].
    pub(crate) fn values(&mut self, x: &[f64]) -> Result<PointValues, EvalError> {
        self.function_evaluations += 1;
        let values = self.evaluate_values(x);
        if let Err(e) = &values {
            if e.is_interrupt() {
                self.interruption = Some(e.to_string());
            }
        }
        values
    }

    fn evaluate_values(&mut self, x: &[f64]) -> Result<PointValues, EvalError> {
        let f = self.problem.objective(x)?;
        if !f.is_finite() {
            return Err(EvalError::new(format!("objective is not finite ({f})")));
        }
        let mut c = vec![0.0; self.m];
        self.problem.inequalities(x, &mut c)?;
        if let Some(i) = c.iter().position(|v| !v.is_finite()) {
            return Err(EvalError::new(format!("inequality {i} is not finite")));
        }
        let mut h = vec![0.0; self.q];
        self.problem.equalities(x, &mut h)?;
        if let Some(i) = h.iter().position(|v| !v.is_finite()) {
            return Err(EvalError::new(format!("equality {i} is not finite")));
        }
        let violation_unscaled = c.iter().fold(0.0_f64, |m, v| m.max(-v)).max(norm_inf(&h));
        for (ci, s) in c.iter_mut().zip(&self.c_scale) {
            *ci *= s;
        }
        for (hi, s) in h.iter_mut().zip(&self.h_scale) {
            *hi *= s;
        }
        let residuals = self.norm_residuals(x)?;
        let f_norms = self
            .norms
            .iter()
            .zip(&residuals)
            .map(|(nd, r)| nd.weight * norm2(r))
            .sum();
        Ok(PointValues {
            x: x.to_vec(),
            f,
            f_norms,
            residuals,
            c,
            h,
            violation_unscaled,
        })
    }

    /// Every norm term's residual at `x`: `A x + b`, or the problem's residual, checked.
    fn norm_residuals(&mut self, x: &[f64]) -> Result<Vec<Vec<f64>>, EvalError> {
        let mut out = Vec::with_capacity(self.norms.len());
        for nd in &self.norms {
            out.push(match &nd.kind {
                NormKind::Linear { rows, offset } => linear_residual(rows, offset, x),
                NormKind::Residual { index, dim } => {
                    let mut r = vec![0.0; *dim];
                    self.problem.residual(x, *index, &mut r)?;
                    if let Some(i) = r.iter().position(|v| !v.is_finite()) {
                        return Err(EvalError::new(format!(
                            "entry {i} of residual {index} is not finite"
                        )));
                    }
                    r
                }
            });
        }
        Ok(out)
    }

    /// Every residual norm's Jacobian at `x` as sparse rows (empty for linear terms), checked.
    fn norm_jacobians(&mut self, x: &[f64]) -> Result<Vec<SparseRows>, EvalError> {
        let mut out = Vec::with_capacity(self.norms.len());
        for nd in &self.norms {
            let NormKind::Residual { index, dim } = nd.kind else {
                out.push(Vec::new());
                continue;
            };
            let mut jac = Jacobian::dense(dim, self.n);
            self.problem.residual_jacobian(x, index, &mut jac)?;
            jac.validate(dim, self.n)
                .map_err(|e| EvalError::new(format!("Jacobian of residual {index}: {e}")))?;
            let mut rows: SparseRows = vec![Vec::new(); dim];
            jac.for_each_nonzero(|i, j, v| rows[i].push((j, v)));
            rows.iter_mut().for_each(sort_row);
            out.push(rows);
        }
        Ok(out)
    }

    /// Gradient-based constraint scaling (as in IPOPT): `sᵢ = min(1, max_gradient / ‖∇cᵢ(x₀)‖∞)`,
    /// fixed for the run, applied to the already evaluated `pt`/`dv` at `x₀` and to every later evaluation.
    pub(crate) fn set_scaling(
        &mut self,
        max_gradient: f64,
        pt: &mut PointValues,
        dv: &mut PointDerivatives,
    ) {
        let rule = |g: f64| {
            if g > max_gradient {
                max_gradient / g
            } else {
                1.0
            }
        };
        self.c_scale = dv.jc.row_inf_norms().into_iter().map(rule).collect();
        self.h_scale = dv.jh.row_inf_norms().into_iter().map(rule).collect();
        for (ci, s) in pt.c.iter_mut().zip(&self.c_scale) {
            *ci *= s;
        }
        for (hi, s) in pt.h.iter_mut().zip(&self.h_scale) {
            *hi *= s;
        }
        dv.jc.scale_rows(&self.c_scale);
        dv.jh.scale_rows(&self.h_scale);
    }

    /// Gradient and Jacobians at `x`, every row evaluated.
    pub(crate) fn derivatives(&mut self, x: &[f64]) -> Result<PointDerivatives, EvalError> {
        self.derivatives_reusing(x, None)
    }

    /// Gradient and Jacobians at `x`. With `reuse` and a [`Evaluator::reuse_margin`], an
    /// inequality row keeps its value at the last iterate instead of being evaluated when its
    /// unscaled value is at least the margin and its kept row predicted its change over the step
    /// to [`REUSE_PREDICTION`] of that change.
    pub(crate) fn derivatives_reusing(
        &mut self,
        x: &[f64],
        reuse: Option<Reuse<'_>>,
    ) -> Result<PointDerivatives, EvalError> {
        self.gradient_evaluations += 1;
        let kept: Vec<bool> = match (self.reuse_margin, &reuse) {
            (Some(margin), Some(r)) => {
                let step: Vec<f64> = x.iter().zip(&r.from.x).map(|(a, b)| a - b).collect();
                let mut predicted = vec![0.0; self.m];
                r.previous.jc.mul_vec(&step, &mut predicted);
                (0..self.m)
                    .map(|i| {
                        let change = r.values.c[i] - r.from.c[i];
                        let error = (change - predicted[i]).abs();
                        r.values.c[i] / self.c_scale[i] >= margin
                            && error <= REUSE_PREDICTION * change.abs().max(predicted[i].abs())
                    })
                    .collect()
            }
            _ => vec![false; self.m],
        };
        // The Jacobian before the gradient: a problem that computes ∇f and the rows in one
        // backward pass then knows which rows it is asked for.
        let mut jc = Jacobian::dense(self.m, self.n);
        if self.m > 0 {
            if kept.contains(&true) {
                let wanted: Vec<bool> = kept.iter().map(|k| !k).collect();
                self.problem.inequality_jacobian_rows(x, &wanted, &mut jc)?;
            } else {
                self.problem.inequality_jacobian(x, &mut jc)?;
            }
            jc.validate(self.m, self.n).map_err(EvalError::new)?;
            jc.scale_rows(&self.c_scale);
            if let Some(r) = reuse {
                jc.replace_rows(&r.previous.jc, &kept);
            }
        }
        let norm_jac = self.norm_jacobians(x)?;
        let mut g = vec![0.0; self.n];
        self.problem.gradient(x, &mut g)?;
        if let Some(i) = g.iter().position(|v| !v.is_finite()) {
            return Err(EvalError::new(format!("gradient entry {i} is not finite")));
        }
        let mut jh = Jacobian::dense(self.q, self.n);
        if self.q > 0 {
            self.problem.equality_jacobian(x, &mut jh)?;
            jh.validate(self.q, self.n).map_err(EvalError::new)?;
            jh.scale_rows(&self.h_scale);
        }
        Ok(PointDerivatives {
            g,
            jc,
            jh,
            kept,
            norm_jac,
        })
    }
}
