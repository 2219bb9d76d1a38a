//! Small dense tensors and a reverse-mode tape whose batched row functions are differentiated
//! generically.
//!
//! - [`Real`]: the scalar algebra (`f64`, and nesting forward-mode [`Dual`] numbers) every
//!   differentiable function is written against, once;
//! - [`Tensor`]: dense row-major `f64`, 1-D or 2-D;
//! - [`Tape`] + [`Var`]: tensor-level reverse mode, with the batched local-function op
//!   ([`Tape::map_rows`]) and the in-place Gauss–Seidel row update ([`Tape::update_rows`]) that
//!   record a whole batch of rows as one node;
//! - [`RowFn`]: a user function applied per row, whose vector–Jacobian product the engine derives.
//!
//! The crate knows nothing about cloth.

// Indexed loops over tangent components and row entries read like the formulas they implement.
#![allow(clippy::needless_range_loop)]

pub mod dual;
pub mod index;
pub mod lanes;
pub mod real;
pub mod rowfn;
pub mod simd;
pub mod tape;
pub mod tensor;
pub mod update;

pub use dual::Dual;
pub use index::RowIndex;
pub use real::Real;
pub use rowfn::{in_pool, vjp_by_duals, vjp_seeds_by_duals, DynRowFn, RowFn};
pub use simd::{F64x8, Mask8};
pub use tape::{soft_min_value, soft_min_weights, Gradients, Tape, Var};
pub use tensor::Tensor;
