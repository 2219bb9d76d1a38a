//! Differentiable quasi-static cloth: scenes, constraints, the simulator (XPBD and Newton), costs,
//! gradients and signed distances.
//!
//! A [`Scene`] (JSON, the [`scene`] module) compiles to a [`Model`] that holds only the effects it
//! calls for. [`Model::simulate`] rolls it out under [`Controls`]; [`Model::evaluate`] returns the
//! paper's [`Metrics`] and their gradients, [`Model::gradients`] those of any per-step costs
//! ([`StepCost`]). Constraints are written once as a generic function `C` (the [`constraint`]
//! module); the projection's `∇C`, the backward pass and Newton's Hessians all come from
//! `autodiff`. Obstacles are signed-distance fields (the [`sdf`] module).
//!
//! Inside (private; see `ARCHITECTURE.md`): `model` (the compiled data and the compiler), `xpbd`
//! (colour sets, projections, time stepping), `newton` (the converged step and its implicit
//! gradients), `rollout` (costs, strain, gradients), `contact` (friction, self-collision), and the
//! scene-derived geometry (`layout`, `mesh`, `obj`, `refine`, `controls`).

pub mod constraint;
pub mod scene;
pub mod sdf;

mod contact;
mod controls;
mod error;
mod geometry;
mod layout;
mod mesh;
mod model;
mod newton;
mod obj;
mod parameters;
mod refine;
mod registry;
mod rollout;
mod start;
mod xpbd;

pub use contact::crossings::{crossings, intersections, Crossings};
pub use controls::{controls_from_file, controls_from_steps, Controls, ControlsView};
pub use error::ClothError;
pub use mesh::ClothMesh;
pub use model::{ConstraintGroup, Model, StartReport, TaskSpec, DEFAULT_CHECKPOINT_BUDGET};
/// The `nalgebra` this crate is built with: constraints take `nalgebra::Vector3<R>` points.
pub use nalgebra;
pub use newton::continuation::{NewtonKept, NewtonRollout};
pub use newton::control_tangents::ControlTangents;
pub use newton::factor::FactorCounts;
pub use newton::residual::Equilibrium;
pub use newton::solve::StepStats;
pub use newton::{
    LinearSolver, NewtonSettings, Solver, DEFAULT_LOAD_HALVINGS, DEFAULT_MAX_ITERATIONS,
    DEFAULT_PCG_MAX_ITERATIONS, DEFAULT_PCG_TOLERANCE, DEFAULT_TOLERANCE,
};
pub use obj::{ObjError, ObjMesh};
pub use parameters::Parameter;
pub use registry::{ConstraintRegistry, CustomInput};
pub use rollout::grad::{RecordedRollout, StepCost};
pub use rollout::layers::LayerGap;
pub use rollout::limits::RolloutLimits;
pub use rollout::metrics::{null_as_infinity, Evaluation, Metrics};
pub use rollout::penetration::Penetration;
pub use scene::Scene;
pub use start::REST_TOLERANCE;
pub use xpbd::set::{Carry, ProjectionSet};

/// The simulator's building blocks, for this crate's own tests, benches and examples (feature
/// `internals`): not part of the API, and free to change.
#[cfg(feature = "internals")]
#[doc(hidden)]
pub mod internals {
    pub use crate::contact::edge_edge::{EdgeEdge, EdgePair};
    pub use crate::contact::friction::{FrictionalContact, Regime, CARRY_WIDTH};
    pub use crate::contact::self_collision::{ContactPair, SelfCollision, VertexTriangle};
    pub use crate::mesh::GridMesh;
    pub use crate::newton::assembly::{HessianKind, Pattern};
    pub use crate::newton::factor::Factor;
    pub use crate::newton::pcg::{pcg, PcgEnd, PcgOutcome};
    pub use crate::newton::solve::NewtonSystem;
    pub use crate::rollout::cost::{trajectory_irregularity, NEGLIGIBLE_WEIGHT_EXPONENT};
    pub use crate::sdf::batch::distances_within;
    pub use crate::sdf::bvh::Bvh;
    pub use crate::xpbd::coloring::{greedy_coloring, independent_sets};
    pub use crate::xpbd::projection::Projection;
}
