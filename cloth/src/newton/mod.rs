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
//! - [`psd`]: the per-constraint semidefinite projection of the Hessian's blocks;
//! - [`ordering`]: the fill-reducing elimination order, on the particle graph;
//! - [`factor`]: faer's sparse Cholesky (symbolic once, numeric per iteration);
//! - [`solve`]: the Newton iteration with backtracking line search on `Φ` and chord steps;
//! - [`continuation`]: the rollout, each step by branch following
//!   ([`NewtonSettings::load_halvings`]), each step's final factorization kept for the gradients;
//! - [`curvature`]: leaving a saddle of `Φ` along the exact Hessian's unstable mode;
//! - [`implicit`]: adjoints through `∂x_t/∂(x_{t−1}, u_t)`, one factorization per step for every
//!   cost (the forward's own, where it was kept).
//!
//! - [`contact`]: rigid one-sided rows on one particle (colliders) by an active-set projected
//!   Newton, whose converged state is XPBD's rigid (compliance 0) answer.
//!
//! Other rigid constraints (infinite stiffness, compliance 0: `"inf"` materials) have no finite
//! energy and are rejected with [`ClothError::NewtonUnsupported`].

pub mod assembly;
pub mod contact;
pub mod continuation;
pub mod curvature;
pub mod factor;
pub mod implicit;
pub mod ordering;
pub mod psd;
pub mod solve;
pub mod terms;

use crate::error::ClothError;
use crate::model::Model;

/// Default [`NewtonSettings::tolerance`]: `‖∇Φ‖` at most `1e-10` of its value at `x̃`.
pub const DEFAULT_TOLERANCE: f64 = 1e-10;
/// Default [`NewtonSettings::max_iterations`]: a guard against true non-convergence, not a
/// budget. Near the SQP's iterates on `u_obstacle` a step can need 171 iterations (measured over
/// 200 perturbed controls: long stretches on the projected Hessian while edges are compressed);
/// at the former cap of 50, 17 of those 200 rollouts failed, and the planner's line search,
/// which takes a failed evaluation for "step too long", shrank its steps to 1e-9 and stalled.
pub const DEFAULT_MAX_ITERATIONS: usize = 500;

/// Default [`NewtonSettings::load_halvings`]: the smallest increment is 1/1024 of a step's load.
/// Measured on `u_obstacle` (`optimize --physics newton --search off`): 0 stalls (the rollout
/// jumps between minima), 3 stalls, 6 converges after 244 SQP iterations (its smallest increments
/// still take projected paths), 8, 10 and 12 converge after 77, 63 and 169 to the same plan.
pub const DEFAULT_LOAD_HALVINGS: usize = 10;
/// Largest [`NewtonSettings::load_halvings`] (2^20 increments per step).
pub const MAX_LOAD_HALVINGS: usize = 20;

/// Convergence settings of the Newton solver.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NewtonSettings {
    /// A step has converged when `‖∇Φ(x)‖ ≤ tolerance · ‖∇Φ(x̃)‖`.
    pub tolerance: f64,
    /// Newton iterations per step before [`ClothError::NewtonNotConverged`].
    pub max_iterations: usize,
    /// Load steps (continuation) per time step: the step's load (its control move and gravity)
    /// is applied along a path of predicted states from one for which the previous state is the
    /// minimizer to `x̃`, in at least this many equal parts, each solve starting from the last
    /// one's minimizer. `1` with [`NewtonSettings::load_halvings`] `0` is one solve from `x̃`.
    pub load_steps: usize,
    /// Branch following: a load increment whose solve meets a state where the exact Hessian is
    /// not positive definite (so where it ends depends on the path: the start was not in the
    /// convex neighbourhood of the minimizer it continues) is abandoned and halved, at most this
    /// many times; the smallest increment takes whatever path it needs (past a fold or
    /// bifurcation of the branch) and leaves a saddle along its unstable mode. Where a step's
    /// `Φ` has several minima (a cloth that can buckle either way), one solve from `x̃` can end
    /// in either under a `1e-11` change of the controls; following the branch of the previous
    /// state, the rollout jumps only where that branch ends (`cloth/tests/newton_branches.rs`).
    /// The final state is a minimizer of the same `Φ`, so the implicit gradients are unchanged.
    pub load_halvings: usize,
    /// Chord steps ([`solve`]): after a whole step with the exact Hessian, the next steps reuse
    /// its factorization while the KKT residual falls by [`solve::CHORD_CONTRACTION`] per step.
    /// The returned state is a minimizer to the same tolerance either way.
    pub chord_steps: bool,
}

impl Default for NewtonSettings {
    fn default() -> Self {
        NewtonSettings {
            tolerance: DEFAULT_TOLERANCE,
            max_iterations: DEFAULT_MAX_ITERATIONS,
            load_steps: 1,
            load_halvings: DEFAULT_LOAD_HALVINGS,
            chord_steps: true,
        }
    }
}

/// Which method solves each quasi-static step.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub enum Solver {
    /// [`Model::iterations`] XPBD Gauss–Seidel sweeps (the paper's method), differentiated by
    /// unrolling.
    #[default]
    Xpbd,
    /// Newton's method to convergence, differentiated implicitly.
    Newton(NewtonSettings),
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
