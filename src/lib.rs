//! clothopt: safe, physics-aware cloth manipulation planning.
//!
//! Glue between the `cloth` simulator and the `optim` solvers: [`problem::TrajectoryProblem`]
//! casts a cloth task as an optimization problem (its rows on the controls alone, robot limits
//! and collider planes, in `control_rows`); [`plan`] runs it and packages the result;
//! [`plot`] draws figures and [`figures`] builds them from rollouts; [`export`] writes way-points
//! and meshes for robots and viewers.

pub mod anytime;
mod control_rows;
pub mod export;
pub mod figures;
pub mod outcome;
pub mod plan;
pub mod plot;
pub mod problem;
pub mod request;
pub mod search;
pub mod start_check;
