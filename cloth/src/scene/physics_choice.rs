//! The physics a scene calls for: which step solver runs when `physics.solver` names none, and
//! why.
//!
//! The rule (measured in docs/performance.md, "The physics a scene calls for"): Newton's method,
//! whose states are minimizers of the step's energy to `physics.tolerance`, wherever it can
//! simulate the scene; XPBD only where Newton cannot (a rigid material or constraint, friction on
//! the rigid contact model). With colliders Newton gets the smooth contact model
//! ([`Scene::contact_model`]). XPBD's fixed number of sweeps leaves its states a relative
//! `‖∇Φ‖` of 1e-2 and more from equilibrium on every free-space scene measured, and more the
//! larger the cloth, so there is no cloth on which it converges and Newton would not serve.

use super::format::{ContactModel, SolverKind, Stiffness};
use super::Scene;
use serde::{Deserialize, Serialize};

/// Why a scene runs the solver it runs ([`Scene::physics_choice`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PhysicsReason {
    /// `physics.solver` names it (or `--physics` set it).
    Named,
    /// A material stiffness is `"inf"`: rigid, which has no finite energy for Newton.
    RigidMaterial,
    /// A custom constraint is rigid (`"inf"` stiffness).
    RigidCustomConstraint,
    /// `physics.contact.model` is `"rigid"` and a collider has friction, which Newton's rigid
    /// contact does not model.
    RigidContactFriction,
    /// The scene has colliders: Newton with smooth contact.
    Colliders,
    /// The cloth collides with itself: Newton's self-contact barrier.
    SelfCollision,
    /// Free space: Newton's states are equilibria, XPBD's sweeps are not.
    FreeSpace,
}

impl PhysicsReason {
    /// The reason in words, for summaries and results (e.g. "the scene has colliders").
    pub fn describe(self) -> &'static str {
        match self {
            PhysicsReason::Named => "named by the scene (physics.solver) or --physics",
            PhysicsReason::RigidMaterial => {
                "a material is rigid (\"inf\" stiffness), which only XPBD simulates"
            }
            PhysicsReason::RigidCustomConstraint => {
                "a custom constraint is rigid (\"inf\" stiffness), which only XPBD simulates"
            }
            PhysicsReason::RigidContactFriction => {
                "friction on the rigid contact model, which only XPBD simulates"
            }
            PhysicsReason::Colliders => "the scene has colliders",
            PhysicsReason::SelfCollision => "the cloth collides with itself",
            PhysicsReason::FreeSpace => {
                "free space: Newton's states are equilibria, XPBD's sweeps stop short of them"
            }
        }
    }
}

/// The step solver a scene runs and why.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PhysicsChoice {
    /// The solver.
    pub solver: SolverKind,
    /// Why.
    pub reason: PhysicsReason,
}

impl Scene {
    /// True when an obstacle is a physical collider (role `"collider"` or `"both"`).
    pub fn has_colliders(&self) -> bool {
        self.obstacles.iter().any(|o| o.role().is_collider())
    }

    /// The solver `physics.solver` names, else the one the scene calls for (module docs): XPBD
    /// where Newton cannot simulate the scene, else Newton.
    pub fn physics_choice(&self) -> PhysicsChoice {
        let choice = |solver, reason| PhysicsChoice { solver, reason };
        if let Some(solver) = self.physics.solver {
            return choice(solver, PhysicsReason::Named);
        }
        if let Some(reason) = self.newton_cannot() {
            return choice(SolverKind::Xpbd, reason);
        }
        let reason = if self.has_colliders() {
            PhysicsReason::Colliders
        } else if self.physics.self_collision.is_some() {
            PhysicsReason::SelfCollision
        } else {
            PhysicsReason::FreeSpace
        };
        choice(SolverKind::Newton, reason)
    }

    /// The step solver ([`Scene::physics_choice`]).
    pub fn solver_kind(&self) -> SolverKind {
        self.physics_choice().solver
    }

    /// What in the scene Newton's method cannot simulate, if anything.
    fn newton_cannot(&self) -> Option<PhysicsReason> {
        let material = &self.material;
        let bending_rigid = material
            .bending
            .as_ref()
            .is_some_and(|b| b.stiffness == Stiffness::Infinite);
        if material.stretch == Stiffness::Infinite || bending_rigid {
            return Some(PhysicsReason::RigidMaterial);
        }
        if self
            .custom_constraints
            .iter()
            .any(|c| c.stiffness == Stiffness::Infinite)
        {
            return Some(PhysicsReason::RigidCustomConstraint);
        }
        let rigid_named = self
            .physics
            .contact
            .as_ref()
            .is_some_and(|c| c.model == ContactModel::Rigid);
        if rigid_named && self.obstacles.iter().any(|o| o.friction().is_some()) {
            return Some(PhysicsReason::RigidContactFriction);
        }
        None
    }
}
