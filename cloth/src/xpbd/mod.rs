//! The paper's solver: quasi-static XPBD, one step as Gauss–Seidel sweeps over independent colour
//! sets of constraint projections.
//!
//! - [`set`]: a colour set as the sweeps see it (projection, particles, carried values);
//! - [`coloring`]: greedy colouring of constraints into independent sets;
//! - [`projection`]: the XPBD update of one colour set as an `autodiff` row function;
//! - [`sim`]: time stepping, on a plain path and a recorded (tape) path, bitwise equal;
//! - `sensitivity`: how the rollout moves with the physical parameters (forward, through the
//!   unrolled sweeps).

pub mod coloring;
pub mod projection;
mod sensitivity;
pub mod set;
pub mod sim;
