//! Quasi-static XPBD time stepping: a plain `f64` path and a recorded path, bitwise equal.
//!
//! One step (the paper's Algorithm 1): every particle `x ← x_prev + ½gΔt²`; control particles
//! `x_k ← x_prev_k + u_k`; `λ ← 0`; then `iterations` Gauss–Seidel sweeps over the colour sets of
//! every constraint group in order. Both paths run the same [`autodiff::update::update_rows`]
//! kernel on the same inputs, so their states agree bit for bit.

use super::set::{Carry, ProjectionSet};
use crate::controls::Controls;
use crate::error::ClothError;
use crate::model::Model;
use autodiff::update::update_rows;
use autodiff::{in_pool, Tape, Tensor, Var};

/// Reusable buffers of the plain path.
#[derive(Default)]
pub struct StepScratch {
    lambdas: Vec<Tensor>,
}

impl Model {
    /// Checks that `controls` has one row of `3 × n_controls` finite values per time step.
    pub fn check_controls(&self, controls: &Controls) -> Result<(), ClothError> {
        let (t, k) = (self.task.horizon, self.n_controls());
        if controls.shape() != (t, 3 * k) {
            return Err(ClothError::Controls(format!(
                "expected {t} steps × {k} control points × 3, got {} steps × {} values",
                controls.rows(),
                controls.cols()
            )));
        }
        if let Some(i) = controls.data().iter().position(|v| !v.is_finite()) {
            return Err(ClothError::Controls(format!(
                "{} is not finite",
                control_entry(i, 3 * k)
            )));
        }
        Ok(())
    }

    /// Zero controls for the model's horizon.
    pub fn zero_controls(&self) -> Controls {
        Tensor::zeros(self.task.horizon, 3 * self.n_controls())
    }

    /// The controls of step `t` as an `n_controls × 3` tensor.
    pub fn step_controls(&self, controls: &Controls, t: usize) -> Tensor {
        Tensor::new(self.n_controls(), 3, controls.row(t).to_vec())
    }

    /// One time step on plain `f64` data.
    pub fn step(&self, x_prev: &Tensor, u: &Tensor, scratch: &mut StepScratch) -> Tensor {
        let contacts = self.contact_sets(x_prev, u);
        let mut x = self.begin_step(x_prev, u);
        // λ ← 0 (and every other carry to its start), reusing the previous step's tensors.
        let fits = (scratch.lambdas.iter().map(Tensor::shape)).eq(self
            .step_sets(&contacts)
            .map(|s| (s.index.rows(), s.carry_width())));
        if fits {
            for (set, l) in self.step_sets(&contacts).zip(&mut scratch.lambdas) {
                set.start_carry(x_prev, l);
            }
        } else {
            scratch.lambdas = self.step_carries(x_prev, &contacts);
        }
        self.sweep(&mut x, &mut scratch.lambdas, self.iterations, &contacts);
        x
    }

    /// The state a step's sweeps start from: `x_prev` moved by gravity, control particles by `u`.
    pub fn begin_step(&self, x_prev: &Tensor, u: &Tensor) -> Tensor {
        let mut x = x_prev.clone();
        if let Some(g) = self.gravity_step {
            for row in x.data_mut().chunks_exact_mut(3) {
                for k in 0..3 {
                    row[k] += g[k];
                }
            }
        }
        for (k, &p) in self.controls.as_slice().iter().enumerate() {
            for j in 0..3 {
                x.row_mut(p)[j] = x_prev.get(p, j) + u.get(k, j);
            }
        }
        x
    }

    /// The carries of a step of the model's own sets that starts from `x_prev`, one tensor per
    /// colour set in sweep order: zero multipliers `λ`, and the start positions of
    /// [`Carry::StartPosition`] sets.
    pub fn initial_carries(&self, x_prev: &Tensor) -> Vec<Tensor> {
        self.step_carries(x_prev, &[])
    }

    /// [`Model::initial_carries`] for a step's sets: the model's, then the step's `contacts`.
    pub fn step_carries(&self, x_prev: &Tensor, contacts: &[ProjectionSet]) -> Vec<Tensor> {
        self.step_sets(contacts)
            .map(|s| {
                let mut carry = Tensor::zeros(s.index.rows(), s.carry_width());
                s.start_carry(x_prev, &mut carry);
                carry
            })
            .collect()
    }

    /// `iterations` Gauss–Seidel sweeps over every colour set of a step (the model's, then the
    /// step's `contacts` from [`Model::contact_sets`]), in place.
    pub fn sweep(
        &self,
        x: &mut Tensor,
        lambdas: &mut [Tensor],
        iterations: usize,
        contacts: &[ProjectionSet],
    ) {
        for _ in 0..iterations {
            for (set, lambda) in self.step_sets(contacts).zip(lambdas.iter_mut()) {
                update_rows(set.projection.as_ref(), &set.index, x, lambda, None);
            }
        }
    }

    /// Every colour set of every group, in sweep order.
    pub fn sets(&self) -> impl Iterator<Item = &ProjectionSet> + Clone {
        self.groups.iter().flat_map(|g| &g.sets)
    }

    /// A step's colour sets in sweep order: the model's, then the step's `contacts`.
    pub fn step_sets<'a>(
        &'a self,
        contacts: &'a [ProjectionSet],
    ) -> impl Iterator<Item = &'a ProjectionSet> + Clone {
        self.sets().chain(contacts)
    }

    /// Records one time step on `tape` from the state `x_prev` and controls `u` (`n_controls × 3`).
    pub fn record_step(&self, tape: &mut Tape, x_prev: Var, u: Var) -> Var {
        let contacts = self.contact_sets(tape.value(x_prev), tape.value(u));
        let x = self.record_begin_step(tape, x_prev, u);
        let mut lambdas = self.record_initial_carries(tape, x_prev, &contacts);
        self.record_sweeps(tape, x, &mut lambdas, self.iterations, &contacts)
    }

    /// Records [`Model::begin_step`].
    pub fn record_begin_step(&self, tape: &mut Tape, x_prev: Var, u: Var) -> Var {
        let mut x = match self.gravity_step {
            Some(g) => {
                let g = tape.leaf(Tensor::new(1, 3, g.to_vec()));
                tape.add(x_prev, g)
            }
            None => x_prev,
        };
        if self.n_controls() > 0 {
            let held = tape.gather(x_prev, &self.controls);
            let moved = tape.add(held, u);
            x = tape.assign_rows(x, &self.controls, moved);
        }
        x
    }

    /// Records [`Model::step_carries`] from `x_prev` on `tape`: zero multipliers are leaves,
    /// start positions are gathered from `x_prev` (so the step's gradient reaches it through them).
    pub fn record_initial_carries(
        &self,
        tape: &mut Tape,
        x_prev: Var,
        contacts: &[ProjectionSet],
    ) -> Vec<Var> {
        self.step_sets(contacts)
            .map(|s| match s.carry {
                Carry::Multiplier => tape.leaf(Tensor::zeros(s.index.rows(), 1)),
                Carry::StartPosition { width } => {
                    let start = tape.gather(x_prev, &s.index);
                    let rest = tape.leaf(Tensor::zeros(s.index.rows(), width - 3));
                    tape.concat_cols(&[start, rest])
                }
            })
            .collect()
    }

    /// Records [`Model::sweep`]: returns the new state; `lambdas` become the new multipliers.
    pub fn record_sweeps(
        &self,
        tape: &mut Tape,
        mut x: Var,
        lambdas: &mut [Var],
        iterations: usize,
        contacts: &[ProjectionSet],
    ) -> Var {
        for _ in 0..iterations {
            for (set, lambda) in self.step_sets(contacts).zip(lambdas.iter_mut()) {
                let (nx, nl) = tape.update_rows(&set.projection, &set.index, x, *lambda);
                x = nx;
                *lambda = nl;
            }
        }
        x
    }

    /// Simulates `controls` from the rest state: `T + 1` states, the first the rest state.
    ///
    /// # Errors
    /// If the controls do not fit the model, or a state stops being finite (naming the step and
    /// particle).
    pub fn simulate(&self, controls: &Controls) -> Result<Vec<Tensor>, ClothError> {
        if let crate::newton::settings::Solver::Newton(settings) = &self.solver {
            return self.simulate_newton(controls, settings).map(|(s, _)| s);
        }
        self.check_controls(controls)?;
        in_pool(|| {
            let mut states = Vec::with_capacity(self.task.horizon + 1);
            states.push(self.start.clone());
            let mut scratch = StepScratch::default();
            for t in 0..self.task.horizon {
                let x = self.step(&states[t], &self.step_controls(controls, t), &mut scratch);
                check_finite(&x, t + 1)?;
                states.push(x);
            }
            Ok(states)
        })
    }
}

impl ProjectionSet {
    /// Values carried per row (1 for a multiplier).
    pub fn carry_width(&self) -> usize {
        match self.carry {
            Carry::Multiplier => 1,
            Carry::StartPosition { width } => width,
        }
    }

    /// Sets `carry` (`rows × carry_width`) to its value at the start of a step from `x_prev`.
    pub fn start_carry(&self, x_prev: &Tensor, carry: &mut Tensor) {
        carry.data_mut().fill(0.0);
        if let Carry::StartPosition { .. } = self.carry {
            for (k, &p) in self.index.as_slice().iter().enumerate() {
                carry.row_mut(k)[..3].copy_from_slice(x_prev.row(p));
            }
        }
    }
}

/// Names entry `i` of a controls-shaped tensor with rows of `width` values: "step t, control k,
/// component j", with steps counted from 1 (row `t − 1` acts during step `t`).
pub(crate) fn control_entry(i: usize, width: usize) -> String {
    let width = width.max(1);
    format!(
        "step {}, control {}, component {}",
        i / width + 1,
        (i % width) / 3,
        i % 3
    )
}

/// Reports the first non-finite particle of a state.
pub fn check_finite(x: &Tensor, step: usize) -> Result<(), ClothError> {
    match (0..x.rows()).find(|&p| x.row(p).iter().any(|v| !v.is_finite())) {
        None => Ok(()),
        Some(p) => Err(ClothError::Diverged {
            step,
            particle: p,
            position: [x.get(p, 0), x.get(p, 1), x.get(p, 2)],
        }),
    }
}
