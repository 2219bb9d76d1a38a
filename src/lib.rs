//! clothopt: safe, physics-aware cloth manipulation planning.
//!
//! Glue between the `cloth` simulator and the `optim` solvers: [`problem::TrajectoryProblem`]
//! casts a cloth task as an optimization problem; [`plan`] runs it and packages the result;
//! [`plot`] draws the figures.

pub mod plan;
pub mod plot;
pub mod problem;
