//! Feasibility restoration at a run's end ([`SqpSettings::restoration_steps`]): a run that stops
//! without converging on an infeasible iterate is moved onto its rows by minimum-norm corrections,
//! the objective ignored.
//!
//! The merit line search weighs a step's decrease of the violation against its change of the
//! objective. Near a point just outside the rows, the violation's share of the merit is tiny, and
//! where the objective is rough (a simulator's contact switches, its solver's tolerance) every
//! step the QP proposes is rejected for the objective's noise: the run ends with rows violated by
//! far less than anything the objective can rank, although the rows themselves (a robot's step
//! limit, linear in the controls) are met by one step. The correction is the QP
//!
//! ```text
//! minimize ½‖d‖² + Σ νᵢ tᵢ   subject to the elastic linearized rows at x, inside the step box,
//! ```
//!
//! its point evaluated, and kept while it lowers the max-norm violation; the run ends at the
//! corrected point only if that is feasible, with its own objective (reported, never hidden).

use crate::eval::{Evaluator, PointDerivatives, PointValues};
use crate::linalg::{norm_inf, DenseMatrix};
use crate::problem::Problem;
use crate::qp::{QpMode, QpSubproblem};

use super::state::State;
use super::step::StepBox;
use super::SqpSolver;

/// The smallest elastic weight of a correction: its multipliers are those of a minimum-norm
/// projection, the size of the correction over the rows' gradients, so any weight the run's
/// steering reached, or this, keeps the rows exact.
const MIN_WEIGHT: f64 = 1e3;

impl SqpSolver {
    /// Restores feasibility at `state`'s iterate when it violates its rows
    /// ([`SqpSettings::restoration_steps`](crate::SqpSettings::restoration_steps) corrections at
    /// most). On success the iterate becomes the corrected point (its KKT residual unknown: NaN;
    /// its derivatives are not evaluated, so the run must end there) and the returned text says
    /// what the correction did; `None` leaves `state` as it was.
    pub(super) fn restore_feasibility<P: Problem + ?Sized>(
        &self,
        ev: &mut Evaluator<'_, P>,
        state: &mut State,
    ) -> Option<String> {
        let s = &self.settings;
        let start_violation = state.pt.violation_inf();
        if s.restoration_steps == 0 || start_violation <= s.tol_feasibility {
            return None;
        }
        let weights: Vec<f64> = state.penalty.iter().map(|w| w.max(MIN_WEIGHT)).collect();
        let identity = DenseMatrix::identity(ev.n);
        let zero_gradient = vec![0.0; ev.n];
        let mut pt = state.pt.clone();
        let mut dv = state.dv.clone();
        for k in 0..s.restoration_steps {
            if k > 0 {
                dv = ev.derivatives(&pt.x).ok()?;
            }
            let corrected = self.correction(
                ev,
                (&pt, &dv),
                (identity.as_slice(), &zero_gradient),
                &weights,
            )?;
            if corrected.violation_inf() >= pt.violation_inf() {
                return None;
            }
            pt = corrected;
            if pt.violation_inf() <= s.tol_feasibility {
                let moved = pt.x.iter().zip(&state.pt.x).map(|(a, b)| (a - b).abs());
                let message = format!(
                    "a feasibility correction ({} step{}, ‖Δx‖∞ = {:.2e}) took the violation from \
                     {start_violation:.2e} to {:.2e} and the objective from {:.6e} to {:.6e}",
                    k + 1,
                    if k == 0 { "" } else { "s" },
                    moved.fold(0.0, f64::max),
                    pt.violation_inf(),
                    state.pt.objective(),
                    pt.objective(),
                );
                // The run ends here: the point's derivatives are not needed.
                state.pt = pt;
                state.kkt = f64::NAN;
                return Some(message);
            }
        }
        None
    }

    /// The evaluated point of one minimum-norm correction from `pt` (derivatives `dv`), the
    /// QP's Hessian and gradient `(identity, zero)`; `None` when the QP fails or the point
    /// cannot be evaluated.
    fn correction<P: Problem + ?Sized>(
        &self,
        ev: &mut Evaluator<'_, P>,
        (pt, dv): (&PointValues, &PointDerivatives),
        (identity, zero): (&[f64], &[f64]),
        weights: &[f64],
    ) -> Option<PointValues> {
        let s = &self.settings;
        let bx = StepBox::new(&pt.x, &ev.lower, &ev.upper, s.step_bound_scale);
        let mut data = bx.qp_data(identity, pt, dv, &[]);
        data.gradient = zero;
        data.norm_residuals = &[];
        let mut qp = QpSubproblem::new(
            &data,
            QpMode::Optimality,
            weights,
            s.qp_tolerance,
            s.qp_max_iterations,
        )
        .ok()?;
        let sol = qp.solve();
        if !sol.outcome.is_usable() || norm_inf(&sol.d) == 0.0 {
            return None;
        }
        let d = bx.clamp(&sol.d);
        let mut x: Vec<f64> = pt.x.iter().zip(&d).map(|(x, d)| x + d).collect();
        ev.project(&mut x);
        ev.values(&x).ok()
    }
}
