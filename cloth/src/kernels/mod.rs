//! Batch kernels of the forward XPBD projection for built-in constraint types.
//!
//! [`crate::projection::Projection`] hands each block of rows to
//! [`crate::constraint::Constraint::project_block`]; a type with a batch kernel projects the
//! whole block there (structure-of-arrays over the block's rows, SIMD across them), any other
//! type — every user constraint — keeps the generic per-row path, which stays the reference.
//! Each kernel gives the generic path's values bit for bit (`cloth/tests/kernels.rs`).

pub(crate) mod distance;
pub mod lanes;

/// A block of consecutive rows of one colour set, handed to a batch kernel.
pub struct ProjectionBlock<'a> {
    /// Constraint instance of each row.
    pub instances: &'a [usize],
    /// Inverse masses of each row's particles (`rows × ARITY`).
    pub inv_mass: &'a [f64],
    /// `α̃` of the set.
    pub compliance: f64,
    /// Each row's particle positions and multiplier (`rows × (3·ARITY + 1)`).
    pub inputs: &'a [f64],
    /// The projected rows, same layout; the kernel writes every value.
    pub outputs: &'a mut [f64],
}
