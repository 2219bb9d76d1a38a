//! Solving a built subproblem: Clarabel with its defaults, then the fallback settings and the
//! scaled objective (see the parent module's docs), and reading the solution back.

/// Fallback settings tried, in order, when Clarabel fails with its defaults (see the module docs):
/// `(equilibrate, max_step_fraction, static_regularization_constant)`.
use super::{QpBuildError, QpOutcome, QpSolution, QpSubproblem};
use clarabel::solver::{
    DefaultSettings, DefaultSettingsBuilder, DefaultSolution, DefaultSolver, IPSolver, SolverStatus,
};

pub(super) const FALLBACKS: [(bool, f64, f64); 3] =
    [(false, 0.99, 1e-8), (true, 0.9, 1e-8), (false, 0.9, 1e-7)];

/// Clarabel settings: the defaults used for every first attempt, or a fallback.
pub(super) fn clarabel_settings(
    tolerance: f64,
    max_iterations: u32,
    fallback: Option<(bool, f64, f64)>,
) -> Result<DefaultSettings<f64>, QpBuildError> {
    let mut b = DefaultSettingsBuilder::<f64>::default();
    b.verbose(false)
        .presolve_enable(false)
        .max_iter(max_iterations)
        .tol_gap_abs(tolerance)
        .tol_gap_rel(tolerance)
        .tol_feas(tolerance);
    if let Some((equilibrate, step, reg)) = fallback {
        b.equilibrate_enable(equilibrate)
            .max_step_fraction(step)
            .static_regularization_constant(reg);
    }
    b.build()
        .map_err(|e| QpBuildError(format!("Clarabel settings: {e}")))
}

impl QpSubproblem {
    /// Runs Clarabel and extracts the solution. If Clarabel fails numerically, the same data is
    /// solved again from scratch with each of the [`FALLBACKS`] settings, then (when the gradient
    /// has entries above 1) with the objective scaled, until one succeeds (see the module docs);
    /// if none does, the outcome is the failure status of the first attempt.
    pub(crate) fn solve(&mut self) -> QpSolution {
        self.solver.solve();
        let first = self.extract(&self.solver.solution);
        let retry = match first.outcome {
            QpOutcome::Solved | QpOutcome::AlmostSolved => false,
            QpOutcome::Failed(
                SolverStatus::MaxIterations
                | SolverStatus::InsufficientProgress
                | SolverStatus::NumericalError,
            ) => true,
            QpOutcome::Failed(
                SolverStatus::PrimalInfeasible
                | SolverStatus::AlmostPrimalInfeasible
                | SolverStatus::DualInfeasible
                | SolverStatus::AlmostDualInfeasible,
            ) => self.feasible_by_construction,
            // MaxTime (no limit is set), CallbackTerminated, Unsolved.
            QpOutcome::Failed(_) => false,
        };
        if !retry {
            return first;
        }
        for fallback in FALLBACKS {
            if let Some(sol) = self.solve_usable(None, Some(fallback)) {
                return sol;
            }
        }
        // A gradient of 1e10 defeats every setting: divided by its largest entry, the objective
        // has the same minimizer, and the duals are scaled by the same factor.
        let largest = self.conic.q[..self.layout.n]
            .iter()
            .fold(0.0_f64, |m, v| m.max(v.abs()));
        if largest > 1.0 {
            for fallback in std::iter::once(None).chain(FALLBACKS.map(Some)) {
                if let Some(sol) = self.solve_usable(Some(1.0 / largest), fallback) {
                    return sol;
                }
            }
        }
        first
    }

    /// Solves the data from scratch with Clarabel's `fallback` settings (defaults if `None`)
    /// and the objective (`P`, `q`) multiplied by `scale` if given (the duals returned are
    /// those of the data as built); `None` unless the solution is usable.
    pub(super) fn solve_usable(
        &self,
        scale: Option<f64>,
        fallback: Option<(bool, f64, f64)>,
    ) -> Option<QpSolution> {
        let settings = clarabel_settings(self.tolerance, self.max_iterations, fallback).ok()?;
        let c = &self.conic;
        let scaled;
        let (p, q) = match scale {
            None => (&c.p, &c.q),
            Some(s) => {
                let mut p = c.p.clone();
                p.nzval.iter_mut().for_each(|v| *v *= s);
                scaled = (p, c.q.iter().map(|v| v * s).collect::<Vec<f64>>());
                (&scaled.0, &scaled.1)
            }
        };
        let mut solver = DefaultSolver::new(p, q, &c.a, &c.b, &c.cones, settings).ok()?;
        solver.solve();
        if let Some(s) = scale {
            solver.solution.z.iter_mut().for_each(|v| *v /= s);
        }
        Some(self.extract(&solver.solution)).filter(|sol| sol.outcome.is_usable())
    }

    /// A Clarabel solution in the SQP's conventions.
    pub(super) fn extract(&self, sol: &DefaultSolution<f64>) -> QpSolution {
        let l = self.layout;
        let outcome = match sol.status {
            SolverStatus::Solved => QpOutcome::Solved,
            SolverStatus::AlmostSolved => QpOutcome::AlmostSolved,
            other => QpOutcome::Failed(other),
        };
        let x = &sol.x;
        let z = &sol.z;
        let d = x[..l.n].to_vec();
        // Rows left out of the conic problem (all-zero Jacobian row) get multiplier 0.
        let mut lambda = vec![0.0; self.m_total];
        for (r, &i) in self.kept.iter().enumerate() {
            lambda[i] = z[l.row_ineq + r];
        }
        let mu = z[..l.q].iter().map(|v| -v).collect();
        let box_upper = z[l.row_box_up..l.row_box_up + l.n].to_vec();
        let box_lower = z[l.row_box_lo..l.row_box_lo + l.n].to_vec();
        let mut norm_duals = Vec::with_capacity(l.k);
        let mut row = l.row_soc;
        for &p in &self.norm_dims {
            norm_duals.push(z[row + 1..row + 1 + p].iter().map(|v| -v).collect());
            row += p + 1;
        }
        QpSolution {
            outcome,
            d,
            lambda,
            mu,
            box_lower,
            box_upper,
            norm_duals,
        }
    }
}
