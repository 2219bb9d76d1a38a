//! Differentiable quasi-static XPBD cloth: scenes, constraints, the simulator, costs and SDFs.
//!
//! A [`Scene`](scene::Scene) (JSON) compiles to a [`Model`](model::Model) that holds only the
//! effects it calls for. Constraints are written once as a generic function `C` ([`constraint`]);
//! the projection's `∇C` and the backward pass both come from `autodiff`.
//!
//! - [`scene`]: the scene file format and its validation;
//! - [`mesh`]: the grid mesh and its constraints in canonical order;
//! - [`coloring`]: greedy colouring into independent sets;
//! - [`constraint`], [`projection`], [`sdf`]: constraint functions, their XPBD projection, obstacles;
//! - [`model`]: a scene compiled to its effects; [`sim`]: time stepping; [`cost`], [`grad`]: costs
//!   and gradients; [`strain`]: edge strain.

pub mod coloring;
pub mod constraint;
pub mod cost;
pub mod error;
pub mod grad;
pub mod mesh;
pub mod model;
pub mod projection;
pub mod refine;
pub mod scene;
pub mod sdf;
pub mod sim;
pub mod strain;

pub use error::ClothError;
pub use grad::{Evaluation, Metrics};
pub use model::Model;
/// The `nalgebra` this crate is built with: constraints take `nalgebra::Vector3<R>` points.
pub use nalgebra;
pub use scene::Scene;
pub use sim::Controls;
