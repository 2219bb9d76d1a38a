//! Differentiable quasi-static XPBD cloth: scenes, constraints, the simulator, costs and SDFs.
//!
//! A [`Scene`](scene::Scene) (JSON) compiles to a [`Model`](model::Model) that holds only the
//! effects it calls for. Constraints are written once as a generic function `C` ([`constraint`]);
//! the projection's `∇C` and the backward pass both come from `autodiff`.
//!
//! - [`scene`]: the scene file format, its validation, built-ins and JSON printing;
//! - [`layout`]: the geometry a scene derives (rest positions, control and target indices);
//! - [`geometry`]: shared vector helpers; [`obj`]: the OBJ triangle-mesh reader;
//! - [`mesh`]: the grid mesh and its constraints in canonical order;
//! - [`coloring`]: greedy colouring into independent sets;
//! - [`contact`]: contacts found during the simulation (self-collision);
//! - [`constraint`], [`projection`], [`sdf`]: constraint functions, their XPBD projection, obstacles
//!   (spheres, planes, capsules, boxes, closed meshes);
//! - [`contact`]: contact effects beyond the collider constraint (friction);
//! - [`controls`]: the controls tensor viewed by (step, gripper);
//! - [`model`]: a scene compiled to its effects; [`registry`]: constraint types scene files name; [`sim`]: time stepping; [`cost`], [`grad`]: costs
//!   and gradients;
//! - [`strain`]: edge strain;
//! - [`newton`]: the converged (Newton) step and its implicit gradients, beside XPBD.

pub mod coloring;
pub mod constraint;
pub mod contact;
pub mod controls;
pub mod cost;
pub mod error;
pub mod geometry;
pub mod grad;
pub mod layout;
pub mod mesh;
pub mod model;
pub mod newton;
pub mod obj;
pub mod projection;
pub mod refine;
pub mod registry;
pub mod scene;
pub mod sdf;
pub mod sim;
pub mod strain;

pub use controls::ControlsView;
pub use error::ClothError;
pub use grad::{Evaluation, Metrics};
pub use model::Model;
/// The `nalgebra` this crate is built with: constraints take `nalgebra::Vector3<R>` points.
pub use nalgebra;
pub use registry::ConstraintRegistry;
pub use scene::Scene;
pub use sim::Controls;
