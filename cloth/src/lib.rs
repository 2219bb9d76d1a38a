//! Differentiable quasi-static XPBD cloth: scenes, meshes, constraint colouring, simulation and costs.
//!
//! * [`scene`]: the JSON scene format ([`scene::Scene`]), its validation and the built-in scenes.
//! * [`mesh`]: the grid mesh ([`mesh::GridMesh`]) and the canonical constraint orderings.
//! * [`coloring`]: greedy colouring of constraints into independent sets.

pub mod coloring;
pub mod mesh;
pub mod scene;
