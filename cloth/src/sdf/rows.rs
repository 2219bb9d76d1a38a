//! The safety field as row functions of the particles, for the tape: each particle's signed
//! distance to the safety obstacles, and to each of their primitives.

use super::{SignedDistance, Union};
use autodiff::{Real, RowFn};
use nalgebra::Vector3;
use std::sync::Arc;

/// Signed distance of each particle to the safety obstacles (`3 → 1`), exact wherever it is at
/// most `bound` and a lower bound above it elsewhere ([`SignedDistance::distance_within`];
/// `bound = ∞`: exact everywhere).
pub(crate) struct ParticleSdf {
    pub(crate) field: Arc<Union>,
    pub(crate) bound: f64,
}

impl RowFn for ParticleSdf {
    fn n_in(&self) -> usize {
        3
    }
    fn n_out(&self) -> usize {
        1
    }
    fn eval<R: Real>(&self, _row: usize, x: &[R], out: &mut [R]) {
        out[0] = (self.field).distance_within(&Vector3::new(x[0], x[1], x[2]), self.bound);
    }
}

/// Signed distance of each particle to each primitive of the safety obstacles
/// (`3 → components`), each bounded by `bound` as [`Union::components_within`].
pub(crate) struct ParticleSdfComponents {
    pub(crate) field: Arc<Union>,
    pub(crate) bound: f64,
}

impl RowFn for ParticleSdfComponents {
    fn n_in(&self) -> usize {
        3
    }
    fn n_out(&self) -> usize {
        self.field.component_count()
    }
    fn eval<R: Real>(&self, _row: usize, x: &[R], out: &mut [R]) {
        (self.field).components_within(&Vector3::new(x[0], x[1], x[2]), self.bound, out);
    }
}
