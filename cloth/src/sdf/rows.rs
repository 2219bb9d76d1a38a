//! The safety field as row functions of the particles, for the tape: each particle's signed
//! distance to the safety obstacles, and to each of their primitives; and the same along each
//! particle's straight motion between two states (rows `[a, b]`).

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

/// The signed distance of each particle's straight motion `a → b` to each primitive of the safety
/// obstacles (minus its crossing depth for a box the motion enters), at the primitive's own
/// minimizing point of the segment (`6 → components`, the row
/// `[a, b]`; [`Union::segment_components`]): the continuous safety rows' entries, whose dual
/// derivative is the segment minimum's gradient.
pub(crate) struct SegmentSdfComponents {
    pub(crate) field: Arc<Union>,
}

impl RowFn for SegmentSdfComponents {
    fn n_in(&self) -> usize {
        6
    }
    fn n_out(&self) -> usize {
        self.field.component_count()
    }
    fn eval<R: Real>(&self, _row: usize, x: &[R], out: &mut [R]) {
        let (a, b) = (
            Vector3::new(x[0], x[1], x[2]),
            Vector3::new(x[3], x[4], x[5]),
        );
        self.field.segment_components(&a, &b, out);
    }
}

/// The smallest signed distance of each particle's straight motion `a → b` to the safety
/// obstacles (`6 → 1`), exact wherever it is at most `bound` and a lower bound above it elsewhere
/// ([`Union::segment_distance_within`]).
pub(crate) struct SegmentSdf {
    pub(crate) field: Arc<Union>,
    pub(crate) bound: f64,
}

impl RowFn for SegmentSdf {
    fn n_in(&self) -> usize {
        6
    }
    fn n_out(&self) -> usize {
        1
    }
    fn eval<R: Real>(&self, _row: usize, x: &[R], out: &mut [R]) {
        let (a, b) = (
            Vector3::new(x[0], x[1], x[2]),
            Vector3::new(x[3], x[4], x[5]),
        );
        out[0] = self.field.segment_distance_within(&a, &b, self.bound);
    }
}
