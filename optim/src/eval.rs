//! Counting, validating evaluation of a [`Problem`] at a point.

use crate::error::{EvalError, OptimError};
use crate::linalg::{norm2, norm_inf, Jacobian};
use crate::problem::{Bounds, NormData, Problem};

/// Values at one point.
#[derive(Clone, Debug)]
pub(crate) struct PointValues {
    pub x: Vec<f64>,
    /// Smooth objective `f(x)`.
    pub f: f64,
    /// `Σ w_k ‖r_k‖`.
    pub f_norms: f64,
    /// Norm residuals `r_k = A_k x + b_k`.
    pub residuals: Vec<Vec<f64>>,
    pub c: Vec<f64>,
    pub h: Vec<f64>,
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

    /// Max-norm constraint violation.
    pub(crate) fn violation_inf(&self) -> f64 {
        let ci = self.c.iter().fold(0.0_f64, |m, v| m.max(-v));
        ci.max(norm_inf(&self.h))
    }

    /// ℓ1 merit `f + Σ w‖r‖ + ν · viol₁`.
    pub(crate) fn merit(&self, penalty: f64) -> f64 {
        self.objective() + penalty * self.violation_l1()
    }
}

/// Derivatives at one point.
#[derive(Clone, Debug)]
pub(crate) struct PointDerivatives {
    pub g: Vec<f64>,
    pub jc: Jacobian,
    pub jh: Jacobian,
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
        let norms = NormData::from_terms(&problem.norm_terms(), n)?;
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
        })
    }

    /// Clamps `x` into the bounds.
    pub(crate) fn project(&self, x: &mut [f64]) {
        for ((xi, l), u) in x.iter_mut().zip(&self.lower).zip(&self.upper) {
            *xi = xi.clamp(*l, *u);
        }
    }

    /// Objective, norm terms and constraints at `x`.
    pub(crate) fn values(&mut self, x: &[f64]) -> Result<PointValues, EvalError> {
        self.function_evaluations += 1;
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
        let residuals: Vec<Vec<f64>> = self.norms.iter().map(|nd| nd.residual(x)).collect();
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
        })
    }

    /// Gradient and Jacobians at `x`.
    pub(crate) fn derivatives(&mut self, x: &[f64]) -> Result<PointDerivatives, EvalError> {
        self.gradient_evaluations += 1;
        let mut g = vec![0.0; self.n];
        self.problem.gradient(x, &mut g)?;
        if let Some(i) = g.iter().position(|v| !v.is_finite()) {
            return Err(EvalError::new(format!("gradient entry {i} is not finite")));
        }
        let mut jc = Jacobian::dense(self.m, self.n);
        if self.m > 0 {
            jc.clear();
            self.problem.inequality_jacobian(x, &mut jc)?;
            jc.validate(self.m, self.n).map_err(EvalError::new)?;
        }
        let mut jh = Jacobian::dense(self.q, self.n);
        if self.q > 0 {
            self.problem.equality_jacobian(x, &mut jh)?;
            jh.validate(self.q, self.n).map_err(EvalError::new)?;
        }
        Ok(PointDerivatives { g, jc, jh })
    }
}
