//! Contact effects beyond the fixed one-sided collider rows: friction on colliders, and
//! contacts found during the simulation rather than at model build (self-collision).

pub mod barrier;
pub mod crossings;
pub mod distance;
pub mod edge_edge;
pub mod edge_points;
mod feature;
pub mod friction;
pub(crate) mod grid;
pub mod self_barrier;
pub mod self_candidates;
pub mod self_collision;
pub mod self_filter;
pub mod self_friction;
mod sets;
pub mod smooth_friction;
