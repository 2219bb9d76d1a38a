//! Converged quasi-static physics: Newton's method on the energy whose minimizer XPBD iterates
//! toward, with gradients by the implicit function theorem.
//!
//! One step minimizes `Φ(x) = ½ (x − x̃)ᵀ M (x − x̃) + Σⱼ ½ Cⱼ(x)² / α̃ⱼ` over the free particles,
//! where `x̃` is [`Model::begin_step`]'s state (previous state plus `½gΔt²`, control particles at
//! `x_prev + u`, held fixed), `M = diag(1/w)` and `α̃ = 1/(kΔt²)` the XPBD compliance; an
//! inequality constraint (`C ≥ 0`) has a term only while `C < 0`. `∇Φ = 0` is XPBD's
//! stationarity condition `M(x − x̃) = Σ ∇Cⱼ λⱼ`, `λⱼ = −Cⱼ/α̃ⱼ`.
//!
//! - [`terms`]: `C`, `∇C`, `∇²C` of any constraint type, through its overrides or duals;
//! - [`assembly`]: the sparse pattern (fixed per model), `Φ`, `∇Φ` and the Hessian;
//! - `colliders`: smooth contact's terms in them, its step filter and its start check;
//! - [`psd`]: the per-constraint semidefinite projection of the Hessian's blocks;
//! - [`ordering`]: the fill-reducing elimination order, on the particle graph;
//! - [`factor`]: faer's sparse Cholesky (symbolic once, numeric per iteration);
//! - [`pcg`]: conjugate gradients preconditioned with a reused factorization, instead of a
//!   factorization per iteration ([`LinearSolver::Pcg`]);
//! - [`solve`]: the Newton iteration with backtracking line search on `Φ` and chord steps;
//! - [`continuation`]: the rollout, each step by branch following
//!   ([`NewtonSettings::load_halvings`]), each step's final factorization kept for the gradients;
//! - [`curvature`]: leaving a saddle of `Φ` along the exact Hessian's unstable mode;
//! - [`residual`]: how far any solver's states are from equilibrium, on Newton's scale;
//! - `control_tangents`: how the converged states move with the controls (forward), to predict
//!   a trial rollout's states;
//! - `sensitivity`: how the converged states move with the physical parameters (forward);
//! - `start_coupling`: smooth friction's coupling of a step's state to its start;
//! - [`implicit`]: adjoints through `∂x_t/∂(x_{t−1}, u_t)`, one factorization per step for every
//!   cost (the forward's own, where it was kept).
//!
//! - `self_contact`: the self-contact barrier's terms, and the pattern that follows its pairs;
//! - `edge_points`: the barrier of points along the edges against colliders narrower than them;
//! - [`contact`]: rigid one-sided rows on one particle (colliders) by an active-set projected
//!   Newton, whose converged state is XPBD's rigid (compliance 0) answer.
//!
//! Other rigid constraints (infinite stiffness, compliance 0: `"inf"` materials) have no finite
//! energy and are rejected with [`ClothError::NewtonUnsupported`].

pub mod assembly;
mod colliders;
pub mod contact;
pub mod continuation;
pub mod control_tangents;
pub mod curvature;
mod edge_points;
pub mod factor;
pub mod implicit;
pub mod ordering;
pub mod pcg;
mod predictor;
pub mod psd;
pub mod residual;
mod self_contact;
mod sensitivity;
pub mod settings;
pub mod solve;
mod start_coupling;
pub mod stats;
pub mod terms;

pub use settings::{
    LinearSolver, NewtonSettings, Solver, DEFAULT_LOAD_HALVINGS, DEFAULT_MAX_ITERATIONS,
    DEFAULT_PCG_MAX_ITERATIONS, DEFAULT_PCG_TOLERANCE, DEFAULT_TOLERANCE,
};

use crate::error::ClothError;
use crate::model::Model;

impl Model {
    /// Whether Newton's method can solve this model (`check_supported`); the error names the
    /// first constraint group it cannot.
    ///
    /// # Errors
    /// [`ClothError::NewtonUnsupported`].
    pub fn supports_newton(&self) -> Result<(), ClothError> {
        check_supported(self)
    }
}

/// Rejects models Newton's method cannot solve: a rigid constraint group (compliance 0) other
/// than contact rows ([`contact::is_contact`]), or a particle with two contact rows.
///
/// # Errors
/// [`ClothError::NewtonUnsupported`] naming the first such group.
pub fn check_supported(model: &Model) -> Result<(), ClothError> {
    let rigid = model
        .groups
        .iter()
        .find(|g| g.terms.compliance() == 0.0 && !contact::is_contact(g.terms.as_ref()));
    if let Some(g) = rigid {
        return Err(ClothError::NewtonUnsupported {
            group: g.name.clone(),
            reason: "it is rigid (infinite stiffness, compliance 0), so it has no finite \
                     energy; give it a finite stiffness or use physics.solver \"xpbd\" (rigid \
                     one-sided constraints on one particle, like colliders, are supported)"
                .into(),
        });
    }
    let mut seen = vec![false; model.n_particles()];
    for g in model
        .groups
        .iter()
        .filter(|g| contact::is_contact(g.terms.as_ref()))
    {
        for k in 0..g.terms.count() {
            let p = g.terms.particles(k)[0];
            if std::mem::replace(&mut seen[p], true) {
                return Err(ClothError::NewtonUnsupported {
                    group: g.name.clone(),
                    reason: format!(
                        "particle {p} has a second rigid contact row; give each particle at most \
                         one (a union of obstacles is one row) or use physics.solver \"xpbd\""
                    ),
                });
            }
        }
    }
    Ok(())
}
