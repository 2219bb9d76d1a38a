//! clothopt: safe, physics-aware cloth manipulation planning.
//!
//! Glue between the `cloth` simulator and the `optim` solvers: [`problem::TrajectoryProblem`]
//! casts a cloth task as an optimization problem (its rows on the controls alone, robot limits
//! and grippers against the colliders, in `control_rows`); [`plan`] runs it and packages the
//! result, whose schema (the result JSON) is [`result`]; [`safety_check`] is the verdict's check
//! of the motion between the steps, the grippers and the colliders;
//! `plot` (the `viz` crate, feature `figures`) draws figures and `figures` builds them from rollouts; [`export`] formats way-points
//! and meshes for robots and viewers; [`output`] writes result files atomically.

pub mod anytime;
mod control_rows;
mod error;
pub mod export;
#[cfg(feature = "figures")]
pub mod figures;
pub mod fit;
pub mod outcome;
pub mod output;
pub mod physics_check;
pub mod plan;
pub mod problem;
pub mod request;
pub mod result;
pub mod safety_check;
pub mod search;
/// Plotting (the `viz` crate), for callers that draw their own figures.
#[cfg(feature = "figures")]
pub use viz as plot;
pub mod start_check;
pub mod strain;
mod summary;
pub mod target_check;
pub mod thin_colliders;
pub mod validate;

pub use error::{error_chain, Error, Result};
