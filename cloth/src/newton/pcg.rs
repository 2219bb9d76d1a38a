//! Newton's linear solves by conjugate gradients preconditioned with a reused factorization
//! ([`crate::LinearSolver::Pcg`]).
//!
//! The preconditioner is the last successful Cholesky factorization of the system's [`Factor`]:
//! of the exact Hessian at an earlier iterate, load increment or time step (every solve ends
//! with the exact Hessian's factorization at its minimizer, which the next step starts from), or
//! of a projected Hessian. A Newton iteration first tries conjugate gradients on its matrix with
//! it ([`pcg`]); when they need more than [`crate::LinearSolver::Pcg`]'s `max_iterations`, when
//! the residual contracts by less than [`STALL`] in an iteration, or when they meet
//! a direction of non-positive curvature (`pᵀAp ≤ 0`: the matrix is not positive definite), the
//! iteration factorizes its matrix as the direct solver does ([`NewtonSystem::newton_matrix`]),
//! and that factorization (or, when it fails, the earlier one) preconditions the next ones. A
//! direction from conjugate gradients stands for the factorization's success: the matrix is
//! taken for positive definite when they converge without meeting non-positive curvature, which
//! is no proof (only a factorization is: the convergence test and the implicit gradient still
//! factorize). So branch following ([`crate::NewtonSettings::load_halvings`]) may see a load
//! increment leave the convex region only at its convergence test instead of at the first
//! iterate where the Hessian is indefinite (u_obstacle 40 × 40: 12 such tests instead of 5, the
//! same 17 rejected increments, the same minimizers within the tolerance). A matrix of another pattern (self-contact's, `Factor::swap_analysis`) comes with no
//! preconditioner, so its first iteration factorizes.

use super::curvature::sym_mul;
use super::factor::Factor;
use super::settings::LinearSolver;
use super::solve::{NewtonSystem, StepStats};
use super::NewtonSettings;
use crate::geometry::dot;

/// Conjugate gradients give up when an iteration shrinks the residual `‖r‖` by less than this
/// factor (tested before the preconditioner is applied to the new residual, so giving up costs no
/// solve that is not used). Each iteration costs a solve with the preconditioner and a product
/// with the matrix (at `u_obstacle` 40 × 40 a solve is about a sixteenth of a factorization:
/// criterion `newton_parts`, 0.64 against 10.3 ms). Measured there (forward pass, tolerance
/// 1e-2, 4 iterations): 0.5 gives 85 factorizations and 329 iterations, 0.8 76 and 401, none
/// (1.5) 74 and 458, at the same wall time within the noise.
pub const STALL: f64 = 0.5;

/// How conjugate gradients ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PcgEnd {
    /// The residual reached the tolerance.
    Converged,
    /// A search direction `p` had `pᵀAp ≤ 0` (or not a number): `A` is not positive definite.
    NegativeCurvature,
    /// An iteration shrank the residual by less than the given factor ([`STALL`] in Newton).
    Stalled,
    /// The iteration limit was reached first.
    NotConverged,
}

/// What conjugate gradients did: how they ended, after how many iterations (products with `A`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PcgOutcome {
    /// How they ended.
    pub end: PcgEnd,
    /// Iterations (products with `A` and solves with the preconditioner beyond the first).
    pub iterations: usize,
}

/// Solves `A x = b` from `x = 0` by conjugate gradients with the preconditioner `M`: `apply`
/// writes `A v` into its second argument, `precondition` replaces a vector `r` by `M⁻¹ r`
/// (symmetric positive semidefinite). Converged when the residual of the recurrence has
/// `‖r‖ ≤ tolerance · ‖b‖` (for a Newton system `H d = −∇Φ` the inexact Newton condition
/// `‖H d + ∇Φ‖ ≤ η ‖∇Φ‖`, tested before the preconditioner is applied to `r`, so a converged
/// iteration costs one product and one preconditioner solve); at most `max_iterations`
/// iterations, and [`PcgEnd::Stalled`] when an iteration shrinks `‖r‖` by less than `stall`
/// (Newton's: [`STALL`]; `f64::INFINITY` never gives up early). `x` holds the last iterate
/// whatever the end (the solution only when [`PcgEnd::Converged`]).
pub fn pcg(
    mut apply: impl FnMut(&[f64], &mut [f64]),
    mut precondition: impl FnMut(&mut [f64]),
    b: &[f64],
    x: &mut [f64],
    (tolerance, max_iterations, stall): (f64, usize, f64),
) -> PcgOutcome {
    let n = b.len();
    x.fill(0.0);
    let end = |end, iterations| PcgOutcome { end, iterations };
    let target = tolerance * dot(b, b).sqrt();
    if target == 0.0 {
        return end(PcgEnd::Converged, 0);
    }
    let mut r = b.to_vec();
    let mut r_norm = target / tolerance;
    let mut z = r.clone();
    precondition(&mut z);
    let mut rz = dot(&r, &z);
    let mut p = z.clone();
    let mut q = vec![0.0; n];
    for k in 1..=max_iterations {
        apply(&p, &mut q);
        let curvature = dot(&p, &q);
        if !(curvature > 0.0 && rz > 0.0) {
            return end(PcgEnd::NegativeCurvature, k);
        }
        let alpha = rz / curvature;
        for ((xi, ri), (pi, qi)) in x.iter_mut().zip(r.iter_mut()).zip(p.iter().zip(&q)) {
            *xi += alpha * pi;
            *ri -= alpha * qi;
        }
        let r_next = dot(&r, &r).sqrt();
        if r_next <= target {
            return end(PcgEnd::Converged, k);
        }
        if r_next.is_nan() || r_next >= stall * r_norm {
            return end(PcgEnd::Stalled, k);
        }
        if k == max_iterations {
            break;
        }
        r_norm = r_next;
        z.copy_from_slice(&r);
        precondition(&mut z);
        let rz_next = dot(&r, &z);
        let beta = rz_next / rz;
        for (pi, zi) in p.iter_mut().zip(&z) {
            *pi = zi + beta * *pi;
        }
        rz = rz_next;
    }
    end(PcgEnd::NotConverged, max_iterations)
}

impl NewtonSystem {
    /// Makes the Newton matrix in `values` (the exact or the projected Hessian) ready for the
    /// Newton direction; false when it is not positive definite. With
    /// [`LinearSolver::Pcg`] and `iterative` (not a convergence test, which needs the
    /// factorization), and a factorization of an earlier matrix at hand, the direction comes
    /// from [`pcg`] when it converges; otherwise (and with [`LinearSolver::Direct`]) the matrix
    /// is factorized.
    pub(super) fn newton_matrix(
        &mut self,
        iterative: bool,
        settings: &NewtonSettings,
        stats: &mut StepStats,
    ) -> bool {
        self.pcg_direction = false;
        let LinearSolver::Pcg {
            tolerance,
            max_iterations,
        } = settings.linear_solver
        else {
            return self.factor.factorize(&self.pattern, &self.values);
        };
        self.factor.keep_on_failure();
        // A factorization of this very matrix costs nothing (the next load increment starts
        // where the last one's convergence test factorized).
        if !iterative || !self.factor.has_factorization() || self.factor.holds(&self.values) {
            return self.factor.factorize(&self.pattern, &self.values);
        }
        let mut b: Vec<f64> = self.grad.iter().map(|g| -g).collect();
        self.contacts.project_tangent(&mut b);
        let (pattern, values, factor, contacts) =
            (&self.pattern, &self.values, &self.factor, &self.contacts);
        let outcome = pcg(
            |v, y| sym_mul(pattern, values, v, y),
            |r| precondition(factor, contacts, r),
            &b,
            &mut self.dir,
            (tolerance, max_iterations, STALL),
        );
        stats.pcg_iterations += outcome.iterations;
        if outcome.end == PcgEnd::Converged {
            self.contacts.project_tangent(&mut self.dir);
            stats.pcg_solves += 1;
            self.pcg_direction = true;
            return true;
        }
        stats.pcg_fallbacks += 1;
        self.factor.factorize(&self.pattern, &self.values)
    }
}

/// `r ← P M⁻¹ r` with `M` the factorization at hand and `P` the projection onto the active
/// contacts' tangent planes (the factorization may be of another active set).
fn precondition(factor: &Factor, contacts: &super::contact::Contacts, r: &mut [f64]) {
    factor.solve_in_place(r, 1);
    contacts.project_tangent(r);
}
