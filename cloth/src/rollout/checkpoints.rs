//! Block checkpoints kept from the plain forward.
//!
//! When a step's recording does not fit [`Model::checkpoint_budget`], the backward pass records
//! it in blocks of iterations, each from the state and multipliers at the block's start. Those
//! checkpoints used to be recomputed in the backward pass by sweeping the step once more; the
//! plain forward now keeps them on the way (a few states per step, far below the recordings'
//! bytes), so the backward pass does not run the step's sweeps a third time.

use crate::controls::Controls;
use crate::error::ClothError;
use crate::model::Model;
use crate::xpbd::sim::check_finite;
use autodiff::{in_pool, Tensor};

/// State and multipliers at the start of a block of iterations (every block but a step's first).
pub type Checkpoint = (Tensor, Vec<Tensor>);

/// Every step's block checkpoints (step `t` at `t − 1`).
pub type KeptCheckpoints = Vec<Vec<Checkpoint>>;

impl Model {
    /// The first iteration of each block that [`Model::gradients`] records at once (see
    /// [`Model::iterations_per_block`]); one block, `[0]`, when a whole step fits.
    pub fn block_starts(&self) -> Vec<usize> {
        (0..self.iterations.max(1))
            .step_by(self.iterations_per_block())
            .collect()
    }

    /// Sweeps one step from `x_prev` under the controls `u` with its iterations cut at `starts`
    /// (from [`Model::block_starts`]), returning the step's checkpoints (one per block after the
    /// first) and, with `finish`, its end state (`None` without).
    ///
    /// Sweeping the blocks one after another is sweeping the whole step: the end state is
    /// [`Model::step`]'s bit for bit.
    pub(crate) fn step_checkpoints(
        &self,
        x_prev: &Tensor,
        u: &Tensor,
        starts: &[usize],
        finish: bool,
    ) -> (Vec<Checkpoint>, Option<Tensor>) {
        let contacts = self.contact_sets(x_prev, u);
        let mut x = self.begin_step(x_prev, u);
        let mut lambdas = self.step_carries(x_prev, &contacts);
        let mut checkpoints = Vec::with_capacity(starts.len().saturating_sub(1));
        for w in starts.windows(2) {
            self.sweep(&mut x, &mut lambdas, w[1] - w[0], &contacts);
            checkpoints.push((x.clone(), lambdas.clone()));
        }
        if !finish {
            return (checkpoints, None);
        }
        let last = starts.last().copied().unwrap_or(0);
        self.sweep(
            &mut x,
            &mut lambdas,
            self.iterations.saturating_sub(last),
            &contacts,
        );
        (checkpoints, Some(x))
    }

    /// [`Model::simulate`] (the same states, bit for bit) that also keeps every step's block
    /// checkpoints for [`Model::gradients`] when steps are recorded in more than one block and
    /// all the checkpoints together take at most a quarter of [`Model::checkpoint_budget`];
    /// otherwise the checkpoints are `None` (and the backward pass recomputes them per step).
    ///
    /// # Errors
    /// As [`Model::simulate`].
    pub(crate) fn simulate_checkpointed(
        &self,
        controls: &Controls,
    ) -> Result<(Vec<Tensor>, Option<KeptCheckpoints>), ClothError> {
        let starts = self.block_starts();
        if starts.len() < 2 || matches!(self.solver, crate::newton::settings::Solver::Newton(_)) {
            return Ok((self.simulate(controls)?, None));
        }
        self.check_controls(controls)?;
        let budget = self.checkpoint_budget / 4;
        in_pool(|| {
            let horizon = self.task.horizon;
            let mut states = Vec::with_capacity(horizon + 1);
            states.push(self.start.clone());
            let mut kept = Some(Vec::with_capacity(horizon));
            let mut bytes = 0;
            for t in 1..=horizon {
                let u = self.step_controls(controls, t - 1);
                let (checkpoints, x) = self.step_checkpoints(&states[t - 1], &u, &starts, true);
                let x = x.expect("a finished step");
                check_finite(&x, t)?;
                bytes += checkpoints.iter().map(checkpoint_bytes).sum::<usize>();
                match kept.as_mut() {
                    Some(k) if bytes <= budget => k.push(checkpoints),
                    _ => kept = None,
                }
                states.push(x);
            }
            Ok((states, kept))
        })
    }
}

/// Bytes of one checkpoint's values.
fn checkpoint_bytes((x, lambdas): &Checkpoint) -> usize {
    let values = x.len() + lambdas.iter().map(Tensor::len).sum::<usize>();
    values * std::mem::size_of::<f64>()
}
