//! A colour set as the sweeps see it: its projection, the particles of each row, and what each
//! row carries through a step's iterations.

use autodiff::{DynRowFn, RowIndex};
use std::sync::Arc;

/// One Gauss–Seidel colour set: a projection and the particles of each of its rows.
#[derive(Clone)]
pub struct ProjectionSet {
    /// The projection row function (row = one constraint).
    pub projection: Arc<dyn DynRowFn>,
    /// Particles of each row.
    pub index: Arc<RowIndex>,
    /// What each row carries through a step's iterations besides its particles.
    pub carry: Carry,
}

/// The per-row values a colour set carries through a step's Gauss–Seidel iterations (the
/// `carry` of [`autodiff::update::update_rows`]), and how each step starts them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Carry {
    /// One XPBD multiplier `λ`, zero at each step's start.
    Multiplier,
    /// The row's (single) particle's position at the step's start, copied from the previous
    /// state, then `width − 3` values starting at zero (`cloth/src/contact/friction.rs`).
    StartPosition {
        /// Carried values per row (≥ 3).
        width: usize,
    },
}
