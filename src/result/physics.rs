//! The `physics` section of a result: which step solver ran and why, and how far the plan's
//! states are from equilibrium, so that a verdict that rests on unconverged physics says so.

use autodiff::Tensor;
use cloth::scene::{ContactModel, PhysicsReason, SolverKind};
use cloth::{Controls, Model, Scene, Solver};
use serde::{Deserialize, Serialize};

/// Largest relative `‖∇Φ‖` of a step at which its state counts as an equilibrium: far above
/// Newton's default `physics.tolerance` (1e-10), far below where XPBD's sweeps stop (1e-2 and more
/// on the scenes measured, docs/physics.md "How far from equilibrium").
pub const EQUILIBRIUM_TOLERANCE: f64 = 1e-6;

/// Which physics ran and how close its states came to equilibrium.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PhysicsReport {
    /// The step solver: `xpbd` or `newton`.
    pub solver: SolverKind,
    /// Why this solver: `named`, `colliders`, `self_collision`, `free_space`, `rigid_material`, …
    pub reason: PhysicsReason,
    /// How the cloth touches the colliders (`rigid` or `smooth`); absent without colliders.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub contact: Option<ContactModel>,
    /// XPBD: Gauss–Seidel sweeps per step.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sweeps: Option<usize>,
    /// Newton: the relative `‖∇Φ‖` each step was solved to (`physics.tolerance`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tolerance: Option<f64>,
    /// How far the states are from equilibrium.
    pub equilibrium: EquilibriumReport,
}

/// Each step's relative `‖∇Φ‖` ([`cloth::Model::equilibrium_residuals`]).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct EquilibriumReport {
    /// Every step's state within [`EQUILIBRIUM_TOLERANCE`] of equilibrium (false when not
    /// measured).
    pub converged: bool,
    /// The largest relative residual; `null` when not measured.
    pub max_residual: Option<f64>,
    /// Its step (1-based); `null` when not measured.
    pub step: Option<usize>,
    /// The relative residual of steps `1..=T`; empty when not measured.
    pub per_step: Vec<f64>,
    /// What the measure leaves out (XPBD's friction or self-contact forces), or why there is
    /// none (a rigid material has no energy whose minimizer is the equilibrium).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub note: Option<String>,
}

impl PhysicsReport {
    /// The report of `states`, the rollout of `controls` on `model`, compiled from `scene`.
    pub fn of(scene: &Scene, model: &Model, states: &[Tensor], controls: &Controls) -> Self {
        let choice = scene.physics_choice();
        let (sweeps, tolerance) = match &model.solver {
            Solver::Xpbd => (Some(model.iterations), None),
            Solver::Newton(s) => (None, Some(s.tolerance)),
        };
        let equilibrium = match model.equilibrium_residuals(states, controls) {
            Ok(e) => {
                let max = e.max();
                EquilibriumReport {
                    converged: max.is_some_and(|(r, _)| r <= EQUILIBRIUM_TOLERANCE),
                    max_residual: max.map(|(r, _)| r),
                    step: max.map(|(_, t)| t),
                    per_step: e.per_step,
                    note: e.uncounted.map(str::to_string),
                }
            }
            Err(e) => EquilibriumReport {
                note: Some(format!("not measured: {e}")),
                ..EquilibriumReport::default()
            },
        };
        PhysicsReport {
            solver: choice.solver,
            reason: choice.reason,
            contact: scene.has_colliders().then(|| scene.contact_model()),
            sweeps,
            tolerance,
            equilibrium,
        }
    }

    /// The physics in words: `newton (smooth contact)`, `xpbd, 100 sweeps per step`.
    pub fn name(&self) -> String {
        let contact = match self.contact {
            Some(ContactModel::Smooth) => " (smooth contact)",
            Some(ContactModel::Rigid) => " (rigid contact)",
            None => "",
        };
        match self.sweeps {
            Some(n) => format!("{}{contact}, {n} sweeps per step", self.solver),
            None => format!("{}{contact}", self.solver),
        }
    }

    /// The summary's line: the physics, why, and how far from equilibrium its states are.
    pub fn summary_line(&self) -> String {
        let e = &self.equilibrium;
        let states = match (e.max_residual, e.step) {
            (Some(r), Some(_)) if e.converged => {
                format!("states at equilibrium (relative ‖∇Φ‖ ≤ {r:.1e})")
            }
            (Some(r), Some(t)) => format!(
                "states NOT at equilibrium (relative ‖∇Φ‖ up to {r:.1e}, step {t}): simulated \
                 to convergence the cloth ends elsewhere (--check newton re-plans until a plan \
                 holds there too)"
            ),
            _ => "equilibrium not measured".to_string(),
        };
        let note = e.note.as_ref().map_or(String::new(), |n| format!("; {n}"));
        format!(
            "physics {}: {}; {states}{note}",
            self.name(),
            self.reason.describe()
        )
    }

    /// The verdict line's caveat for a plan achieved on states that are not at equilibrium.
    pub fn caveat(&self) -> Option<String> {
        let e = &self.equilibrium;
        (!e.converged).then(|| match e.max_residual {
            Some(r) => format!(
                " on unconverged {} (relative ‖∇Φ‖ up to {r:.1e})",
                self.solver
            ),
            None => format!(" on {} (equilibrium not measured)", self.solver),
        })
    }
}
