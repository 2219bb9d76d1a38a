//! Where a smooth-contact solve starts: the Newton predictor. Differentiating
//! `∇_f Φ(x_f, x_c) = 0` gives the free particles' first-order response to a move of the control
//! particles, `dx_f = −H_ff⁻¹ H_fc dx_c` (tangent to the active contact rows, as in
//! [`super::implicit`]); with `∇_f Φ` at the start added, it is the first Newton step of the
//! moved system. A solve that starts with only the grippers moved makes the cloth catch up over
//! many iterations; and under self-contact, a stage that moves only the grippers
//! ([`NewtonSystem::solve_moving_controls`]) stops where they would squeeze the cloth they press
//! on (the step filter keeps every pair's gap above a tenth of what it was), so a gripper pressed
//! onto cloth lying on a table crawls there in tens of staged solves. Moved with the grippers by
//! its response, the cloth makes way in the filters' eyes too.
//!
//! The predictor is a first-order guess, and can be a poor start: on `drop` lowered by 0.2 m a
//! step, the response compresses the hanging sheet (the mass term holds its bottom back) and
//! Newton from there crawls along the buckling mode for 500 iterations where it converges from
//! the previous state. So a solve from the predictor gets [`PREDICTED_ITERATIONS`]; one that
//! does not converge in them is solved again from the plain start.

use super::assembly::Pattern;
use super::solve::{NewtonSystem, StepStats};
use super::NewtonSettings;
use crate::error::ClothError;
use autodiff::Tensor;

/// Newton iterations a solve from the predictor may take before it is solved again from the
/// plain start. Measured: from the predictor the task suite's `fold_half` solves (its control
/// stages included) take 3 to 30, `lay_aside`'s 186 in all over 12 steps; on `drop` lowered by
/// 0.2 m a step, 500 do not converge (module docs).
pub const PREDICTED_ITERATIONS: usize = 60;

impl Pattern {
    /// The control particles' move from `x` to their places in `xt` (`N × 3` data, zero on the
    /// free particles' rows).
    pub(super) fn control_move(&self, x: &Tensor, xt: &Tensor) -> Vec<f64> {
        let mut delta = vec![0.0; x.data().len()];
        for p in (0..delta.len() / 3).filter(|&p| self.dof(p).is_none()) {
            for k in 0..3 {
                delta[3 * p + k] = xt.data()[3 * p + k] - x.data()[3 * p + k];
            }
        }
        delta
    }
}

impl NewtonSystem {
    /// The Newton predictor from `x` for the control particles' move `delta` (from
    /// [`Pattern::control_move`]) in the step whose predicted state is `xt`, given that the
    /// step filter allows `alpha` of that move with the cloth held at `x`: the fraction `a` and
    /// the state `x + a (δ_c, δ_f)`, `δ_f = −H_ff⁻¹ (∇_f Φ(x) + H_fc δ_c)`, at the largest `a`
    /// both barriers allow along it, when that is the whole move or more than `alpha`; `None`
    /// otherwise, as where the exact Hessian at `x` is not positive definite (the response is
    /// not defined there). Costs one factorization.
    pub(super) fn predicted_start(
        &mut self,
        x: &Tensor,
        xt: &Tensor,
        delta: &[f64],
        alpha: f64,
    ) -> Option<(f64, Tensor)> {
        // (`factorize_exact` fits the self-contact pattern to `x` first.)
        if !self.factorize_exact(x.data(), xt.data()) {
            return None;
        }
        // `factorize_exact` assembled ∇_f Φ(x) too.
        let mut rhs: Vec<f64> = self.grad.iter().map(|g| -g).collect();
        self.pattern
            .control_coupling(x.data(), |c, f, h| rhs[f] -= h * delta[c]);
        self.contacts.project_tangent(&mut rhs);
        self.factor.solve_in_place(&mut rhs, 1);
        self.contacts.project_tangent(&mut rhs);
        let mut full = delta.to_vec();
        self.pattern.scatter(&rhs, &mut full);
        let a = self.pattern.max_move(x.data(), &full);
        (a == 1.0 || a > alpha).then(|| {
            let mut start = x.clone();
            for (s, d) in start.data_mut().iter_mut().zip(&full) {
                *s += a * d;
            }
            (a, start)
        })
    }

    /// Minimizes `Φ` for the predicted state `xt` (control particles held at `xt`'s places) from
    /// the predictor `start` within [`PREDICTED_ITERATIONS`] ([`NewtonSystem::solve_from`]):
    /// `Ok(Err(spent))`, the work spent, when that does not converge, to be solved again from
    /// the plain start (its iterations are known where it ran out of them or stalled,
    /// [`ClothError::NewtonNotConverged`]; after another error, a saddle say, they count 0).
    ///
    /// # Errors
    /// A solve stopped by the rollout's limits ([`crate::Model::simulate_counted`]).
    pub(super) fn try_predicted(
        &mut self,
        start: &Tensor,
        xt: &Tensor,
        step: usize,
        settings: &NewtonSettings,
    ) -> Result<Result<(Tensor, StepStats), StepStats>, ClothError> {
        let budget = NewtonSettings {
            max_iterations: settings.max_iterations.min(PREDICTED_ITERATIONS),
            ..*settings
        };
        let before = self.factor.counts();
        let iterations = match self.solve_inner(start, xt, step, &budget, false) {
            Ok((x, stats)) => {
                let x = x.expect("a solve that may leave the convex region returns a state");
                return Ok(Ok((x, stats)));
            }
            Err(
                e @ (ClothError::NewtonWorkExceeded { .. } | ClothError::RolloutStopped { .. }),
            ) => return Err(e),
            Err(ClothError::NewtonNotConverged { iterations, .. }) => iterations,
            Err(_) => 0,
        };
        self.work_done += iterations;
        let failed = self.factor.counts().since(before);
        Ok(Err(StepStats {
            iterations,
            factorizations: failed.factorized,
            failed_factorizations: failed.failed,
            ..StepStats::default()
        }))
    }

    /// One solve of a step whose predicted state is `xt`, from `x` with the control particles
    /// moved by `alpha` of their move `delta` ([`Pattern::control_move`]; `alpha` is what the
    /// step filter allows with the cloth held at `x`): from the Newton predictor where
    /// [`NewtonSettings::predictor`] asks for it and it goes as far or farther
    /// ([`NewtonSystem::predicted_start`]; then the fraction it allows), else, or where that
    /// does not converge within [`PREDICTED_ITERATIONS`], from `x`. Returns the fraction of the
    /// move taken, the minimizer and the statistics of every attempt.
    ///
    /// # Errors
    /// As [`NewtonSystem::solve_from`].
    pub(super) fn solve_stage(
        &mut self,
        (x, xt): (&Tensor, &Tensor),
        (delta, alpha): (&[f64], f64),
        step: usize,
        settings: &NewtonSettings,
    ) -> Result<(f64, Tensor, StepStats), ClothError> {
        let mut stats = StepStats::default();
        if settings.predictor {
            let before = self.factor.counts();
            let predicted = self.predicted_start(x, xt, delta, alpha);
            let f = self.factor.counts().since(before);
            stats.factorizations += f.factorized;
            stats.failed_factorizations += f.failed;
            if let Some((a, start)) = predicted {
                match self.try_predicted(&start, &staged(xt, x, delta, a), step, settings)? {
                    Ok((xj, sj)) => {
                        stats.add_work(&sj);
                        (stats.residual, stats.at_roundoff) = (sj.residual, sj.at_roundoff);
                        return Ok((a, xj, stats));
                    }
                    Err(spent) => stats.add_work(&spent),
                }
            }
        }
        let (xj, sj) = self.solve_from(x, &staged(xt, x, delta, alpha), step, settings)?;
        stats.add_work(&sj);
        (stats.residual, stats.at_roundoff) = (sj.residual, sj.at_roundoff);
        Ok((alpha, xj, stats))
    }
}

/// The predicted state `xt` with the control particles moved from `x` by `alpha` of their move
/// `delta` ([`Pattern::control_move`]): the state a solve of that fraction of the move is for.
fn staged(xt: &Tensor, x: &Tensor, delta: &[f64], alpha: f64) -> Tensor {
    let mut target = xt.clone();
    if alpha < 1.0 {
        let (t, d) = (target.data_mut(), x.data());
        for (i, m) in delta.iter().enumerate().filter(|(_, m)| **m != 0.0) {
            t[i] = d[i] + alpha * m;
        }
    }
    target
}
