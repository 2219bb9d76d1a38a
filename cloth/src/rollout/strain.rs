//! Edge strain: the relative stretch `|x_i − x_j|/L₀ − 1` of every stretch edge, recorded on a
//! tape (so a strain limit's gradient comes from the same backward pass as the loss's), and its
//! exact per-step maximum for reports.

use crate::model::Model;
use autodiff::{Real, RowFn, Tape, Tensor, Var};

/// Relative stretch of each edge (`6 → 1`: both end points in, `|x_i − x_j|/L₀ − 1` out).
pub(crate) struct EdgeStrain {
    /// Rest length `L₀` per edge (> 0).
    pub rest: Vec<f64>,
}

impl RowFn for EdgeStrain {
    fn n_in(&self) -> usize {
        6
    }
    fn n_out(&self) -> usize {
        1
    }
    fn eval<R: Real>(&self, row: usize, x: &[R], out: &mut [R]) {
        let d2 = (0..3).fold(R::cst(0.0), |acc, k| acc + (x[k] - x[k + 3]).square());
        out[0] = d2.sqrt() * R::cst(1.0 / self.rest[row]) - R::cst(1.0);
    }
}

impl Model {
    /// Records the strain of every stretch edge (`edges × 1`); `None` when the cloth has none.
    pub fn record_strain(&self, tape: &mut Tape, x: Var) -> Option<Var> {
        let (f, index) = self.strain.as_ref()?;
        let ends = tape.gather(x, index);
        Some(tape.map_rows(f, ends))
    }

    /// Records the smooth maximum of the edge strains, `(1/κ) log Σ exp(κ sᵢ)` (`1 × 1`): never
    /// below the true maximum and at most `ln(edges)/κ` above it, so a limit on it is
    /// conservative by at most that much. `None` when the cloth has no stretch edge.
    pub fn record_soft_max_strain(&self, tape: &mut Tape, x: Var, kappa: f64) -> Option<Var> {
        let strain = self.record_strain(tape, x)?;
        let negated = tape.neg(strain);
        let soft = tape.soft_min(negated, kappa);
        Some(tape.neg(soft))
    }

    /// The largest edge strain of each state (0 for a cloth without stretch edges).
    pub fn max_strain_per_step(&self, states: &[Tensor]) -> Vec<f64> {
        let mut tape = Tape::new();
        states
            .iter()
            .map(|x| {
                tape.clear();
                let xv = tape.leaf(x.clone());
                self.record_strain(&mut tape, xv).map_or(0.0, |s| {
                    tape.value(s)
                        .data()
                        .iter()
                        .copied()
                        .fold(f64::NEG_INFINITY, f64::max)
                })
            })
            .collect()
    }
}
