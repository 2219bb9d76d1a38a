//! Whole-rollout evaluation: metrics, and gradients with respect to the controls by reverse mode.
//! When the whole rollout's recording fits `Model::checkpoint_budget`, every step is recorded during
//! the first forward and pulled back from there; otherwise each step is re-recorded in the backward
//! pass from its checkpoint (peak tape memory one time step, or one block of iterations, whatever
//! the horizon).

use crate::controls::Controls;
use crate::error::ClothError;
use crate::model::Model;
use crate::rollout::checkpoints::{Checkpoint, KeptCheckpoints};
use crate::rollout::cost::trajectory_irregularity;
use crate::rollout::metrics::{Evaluation, Metrics};
use crate::rollout::penetration::deeper;
use crate::xpbd::sim::{check_finite, control_entry, StepScratch};
use autodiff::{in_pool, Gradients, Tape, Tensor, Var};
use rayon::prelude::*;

/// A scalar function of a rollout that is a sum of per-step terms `Σ_t f(t, x^(t))`.
///
/// `f(tape, t, x_prev, x)` records its term for step `t` (1-based) from the states before and after
/// the step (`x^(t−1)`, `x^(t)`), or returns `None` when it has no term at that step.
pub type StepCost<'a> = &'a (dyn Fn(&mut Tape, usize, Var, Var) -> Option<Var> + Sync);

/// Reports the first non-finite entry of a gradient with respect to the controls.
fn check_gradient(name: &str, g: &Tensor) -> Result<(), ClothError> {
    match g.data().iter().position(|v| !v.is_finite()) {
        None => Ok(()),
        Some(i) => Err(ClothError::NonFinite {
            quantity: format!("{name} at {}", control_entry(i, g.cols())),
            value: g.data()[i],
        }),
    }
}

impl Model {
    /// The paper's metrics of a simulated rollout (`states` from [`Model::simulate`]).
    pub fn metrics(&self, states: &[Tensor], controls: &Controls, delta: f64) -> Metrics {
        let mut m = Metrics {
            min_sdf: f64::INFINITY,
            min_sdf_swept: f64::INFINITY,
            ..Metrics::default()
        };
        let mut tape = Tape::new();
        for (t, x) in states.iter().enumerate().skip(1) {
            tape.clear();
            let xv = tape.leaf(x.clone());
            if let Some(e) = self.record_energy(&mut tape, xv) {
                m.e += tape.value(e).item();
            }
            if self.safety.is_some() {
                // Exact below δ and at the minimum, which is all `C` and `min_sdf` read.
                let d = crate::sdf::batch::distances_within(&self.safety_obstacles, x, delta);
                let sdf = tape.leaf(Tensor::new(d.len(), 1, d));
                m.min_sdf = m.min_sdf.min(
                    tape.value(sdf)
                        .data()
                        .iter()
                        .copied()
                        .fold(f64::INFINITY, f64::min),
                );
                m.min_sdf_swept = m.min_sdf_swept.min(self.min_sdf_between(&states[t - 1], x));
                let c = Model::record_safety_of_sdf(&mut tape, sdf, delta);
                m.c += tape.value(c).item();
            }
            if t == self.task.horizon {
                let g = self.record_target_error(&mut tape, xv);
                m.g = tape.value(g).item();
            }
            m.max_penetration = deeper(m.max_penetration, self.penetration(x, t));
        }
        let (t_cost, _) = trajectory_irregularity(controls);
        m.t = t_cost;
        m.alpha_t = self.task.alpha * t_cost;
        m.beta_e = self.task.beta * m.e;
        m.l = m.g + m.alpha_t + m.beta_e;
        m
    }

    /// Simulates `controls` and evaluates the paper's metrics with safety margin `delta`;
    /// with `gradients`, also `dL/dU` and `dC/dU`.
    ///
    /// # Errors
    /// As [`Model::simulate`]; and [`ClothError::NonFinite`] when the rollout is finite but a metric
    /// (`G`, `T`, `E`, `C`, `L`) or a gradient entry is not, so no NaN or ∞ is returned silently.
    pub fn evaluate(
        &self,
        controls: &Controls,
        delta: f64,
        gradients: bool,
    ) -> Result<Evaluation, ClothError> {
        self.evaluate_with(controls, delta, gradients, gradients)
    }

    /// [`Model::evaluate`] with `dL/dU` only: one forward and one backward pass, the work of a
    /// value-and-gradient of `L` (what an unconstrained optimizer needs).
    ///
    /// # Errors
    /// As [`Model::evaluate`].
    pub fn evaluate_loss_gradient(
        &self,
        controls: &Controls,
        delta: f64,
    ) -> Result<Evaluation, ClothError> {
        self.evaluate_with(controls, delta, true, false)
    }

    fn evaluate_with(
        &self,
        controls: &Controls,
        delta: f64,
        want_l: bool,
        want_c: bool,
    ) -> Result<Evaluation, ClothError> {
        let beta = self.task.beta;
        let loss = |tape: &mut Tape, t: usize, _: Var, x: Var| self.record_loss(tape, t, x, beta);
        let safety = |tape: &mut Tape, _: usize, _: Var, x: Var| self.record_safety(tape, x, delta);
        let mut costs: Vec<StepCost<'_>> = Vec::new();
        if want_l {
            costs.push(&loss);
        }
        if want_c {
            costs.push(&safety);
        }
        let rollout = self.simulate_recording(controls, &costs)?;
        let metrics = self.metrics(&rollout.states, controls, delta);
        let m = &metrics;
        for (quantity, value) in [("G", m.g), ("T", m.t), ("E", m.e), ("C", m.c), ("L", m.l)] {
            if !value.is_finite() {
                return Err(ClothError::NonFinite {
                    quantity: quantity.into(),
                    value,
                });
            }
        }
        let (states, grads) = rollout.gradients(self, controls, &costs);
        let mut grads = grads.into_iter();
        let grad_l = want_l
            .then(|| {
                let mut gl = grads.next().expect("one gradient per cost");
                let (_, t_grad) = trajectory_irregularity(controls);
                for (a, b) in gl.data_mut().iter_mut().zip(t_grad.data()) {
                    *a += self.task.alpha * b;
                }
                check_gradient("dL/dU", &gl).map(|()| gl)
            })
            .transpose()?;
        let grad_c = want_c
            .then(|| {
                let gc = grads.next().expect("one gradient per cost");
                check_gradient("dC/dU", &gc).map(|()| gc)
            })
            .transpose()?;
        Ok(Evaluation {
            metrics,
            states,
            grad_l,
            grad_c,
        })
    }

    /// Records the state part of the loss at step `t`: `β·E(x)`, plus `G` at the last step.
    pub fn record_loss(&self, tape: &mut Tape, t: usize, x: Var, beta: f64) -> Option<Var> {
        let e = if beta != 0.0 {
            self.record_energy(tape, x).map(|e| tape.scale(e, beta))
        } else {
            None
        };
        let g = (t == self.task.horizon).then(|| self.record_target_error(tape, x));
        match (e, g) {
            (Some(e), Some(g)) => Some(tape.add(e, g)),
            (e, g) => e.or(g),
        }
    }

    /// The smallest signed distance to the safety obstacles along every particle's straight path
    /// from `a` to `b` (∞ without safety obstacles).
    pub fn min_sdf_between(&self, a: &Tensor, b: &Tensor) -> f64 {
        if self.safety_obstacles.is_empty() {
            return f64::INFINITY;
        }
        crate::sdf::batch::min_along_segments(&self.safety_obstacles, a, b)
    }

    /// Gradients of several per-step costs with respect to the controls, by reverse mode over the
    /// rollout `states` (from [`Model::simulate`]): each step is re-recorded from its checkpoint,
    /// pulled back once per cost, and dropped.
    pub fn gradients(
        &self,
        states: &[Tensor],
        controls: &Controls,
        costs: &[StepCost<'_>],
    ) -> Vec<Tensor> {
        if costs.is_empty() {
            return Vec::new();
        }
        if let crate::newton::settings::Solver::Newton(_) = self.solver {
            return self.newton_gradients(states, controls, costs);
        }
        in_pool(|| self.gradients_in_pool(states, controls, costs, None))
    }

    /// Bytes one recorded Gauss–Seidel iteration keeps for the backward pass.
    pub fn recorded_bytes_per_iteration(&self) -> usize {
        let per_set = |s: &crate::xpbd::set::ProjectionSet| {
            s.index.rows() * s.projection.n_in() * std::mem::size_of::<f64>()
        };
        self.sets().map(per_set).sum()
    }

    /// Iterations recorded at once by [`Model::gradients`]: the whole step when two recordings
    /// (one pulled back while the next is recorded) fit [`Model::checkpoint_budget`], else equal
    /// blocks that do.
    pub fn iterations_per_block(&self) -> usize {
        let per = self.recorded_bytes_per_iteration().max(1);
        let fit = (self.checkpoint_budget / 2 / per).max(1);
        if fit >= self.iterations {
            self.iterations.max(1)
        } else {
            self.iterations.div_ceil(self.iterations.div_ceil(fit))
        }
    }

    /// [`Model::gradients`] on the rayon pool, with every step's block checkpoints when the
    /// forward kept them ([`Model::simulate_checkpointed`]).
    fn gradients_in_pool(
        &self,
        states: &[Tensor],
        controls: &Controls,
        costs: &[StepCost<'_>],
        kept: Option<&[Vec<Checkpoint>]>,
    ) -> Vec<Tensor> {
        let mut grads: Vec<Tensor> = costs.iter().map(|_| self.zero_controls()).collect();
        // Per cost: the adjoint of the state (and of the multipliers, inside a step) where the
        // pull-back has reached.
        let mut adjoints: Vec<Adjoint> = costs.iter().map(|_| Adjoint::default()).collect();
        let starts = self.block_starts();
        // Segments in the order the pull-back visits them: last step first, last block first.
        let segments: Vec<Segment> = (1..=self.task.horizon)
            .rev()
            .flat_map(|t| {
                let starts = &starts;
                (0..starts.len()).rev().map(move |b| Segment {
                    t,
                    block: b,
                    last: b + 1 == starts.len(),
                    iterations: starts.get(b + 1).unwrap_or(&self.iterations) - starts[b],
                })
            })
            .collect();
        let mut recorder = Recorder {
            model: self,
            controls,
            costs,
            starts: &starts,
            kept,
            checkpoints: None,
        };
        let before = |seg: &Segment| &states[seg.t - 1];
        let first_tape = self.tapes.take();
        let mut current = recorder.record(&segments[0], before(&segments[0]), first_tape);
        if rayon::current_num_threads() == 1 {
            // One thread: one recording at a time, its tape reused for the next.
            for (k, seg) in segments.iter().enumerate() {
                self.pull_back(&current, seg, &mut adjoints, &mut grads);
                if let Some(next) = segments.get(k + 1) {
                    let tape = std::mem::take(&mut current.tape);
                    current = recorder.record(next, before(next), tape);
                }
            }
            self.tapes.give(current.tape, self.checkpoint_budget);
            return grads;
        }
        // While one segment is pulled back, the next one is recorded on the other thread.
        let mut spare = self.tapes.take();
        for (k, seg) in segments.iter().enumerate() {
            let (_, next) = rayon::join(
                || self.pull_back(&current, seg, &mut adjoints, &mut grads),
                || {
                    segments
                        .get(k + 1)
                        .map(|s| recorder.record(s, before(s), std::mem::take(&mut spare)))
                },
            );
            if let Some(next) = next {
                spare = std::mem::replace(&mut current, next).tape;
            }
        }
        self.tapes.give(current.tape, self.checkpoint_budget);
        self.tapes.give(spare, self.checkpoint_budget);
        grads
    }

    /// Pulls every cost's adjoint back through one recorded segment.
    fn pull_back(
        &self,
        rec: &Recording,
        seg: &Segment,
        adjoints: &mut [Adjoint],
        grads: &mut [Tensor],
    ) {
        // Every cost's pull-back reads the same recording: they run together, in one group per
        // thread.
        let mut seeds: Vec<Vec<(Var, Tensor)>> = rec
            .terms
            .iter()
            .zip(adjoints.iter_mut())
            .map(|(term, adjoint)| {
                let mut seeds = Vec::new();
                if let Some(adj) = adjoint.state.take() {
                    seeds.push((rec.x, adj));
                }
                for (l, adj) in rec.lambdas.iter().zip(adjoint.lambdas.drain(..)) {
                    seeds.push((*l, adj));
                }
                if let Some(c) = term {
                    seeds.push((*c, Tensor::scalar(1.0)));
                }
                seeds
            })
            .collect();
        let live: Vec<usize> = (0..seeds.len()).filter(|&i| !seeds[i].is_empty()).collect();
        let group = live.len().div_ceil(rayon::current_num_threads()).max(1);
        let groups: Vec<Vec<Vec<(Var, Tensor)>>> = live
            .chunks(group)
            .map(|g| g.iter().map(|&i| std::mem::take(&mut seeds[i])).collect())
            .collect();
        let tape = &rec.tape;
        let gradients: Vec<Gradients> = groups
            .par_iter()
            .flat_map_iter(|g| tape.vjp_many(g))
            .collect();
        let (first, last) = (seg.block == 0, seg.last);
        for (&i, g) in live.iter().zip(gradients) {
            let (adjoint, grad) = (&mut adjoints[i], &mut grads[i]);
            let mut state = g.wrt(if first { rec.x_prev } else { rec.x_in });
            if !first {
                adjoint.lambdas = rec.lambdas_in.iter().map(|&l| g.wrt(l)).collect();
            }
            // Costs read `x_prev` in the last block; the first block adds the dynamics' part.
            if last && !first {
                adjoint.x_prev = Some(g.wrt(rec.x_prev));
            }
            if first {
                grad.row_mut(seg.t - 1).copy_from_slice(g.wrt(rec.u).data());
                if let Some(extra) = adjoint.x_prev.take() {
                    state.add_assign(&extra);
                }
            }
            adjoint.state = Some(state);
        }
    }
}

/// A rollout from [`Model::simulate_recording`]: its states and, when the whole rollout's
/// recording fit [`Model::checkpoint_budget`], every step's recording for the backward pass.
pub struct RecordedRollout {
    /// `T + 1` states, the first the rest state.
    pub states: Vec<Tensor>,
    /// One recording per step (step `t` at `t − 1`), or `None` when they did not fit.
    recordings: Option<Vec<Recording>>,
    /// Under Newton: the system and the steps' factorizations kept for the implicit gradients.
    newton: Option<crate::newton::continuation::NewtonKept>,
    /// Without recordings: every step's block checkpoints, when the forward kept them
    /// ([`Model::simulate_checkpointed`]).
    pub(crate) checkpoints: Option<KeptCheckpoints>,
}

impl RecordedRollout {
    /// Without recordings: how many block checkpoints the forward kept for the backward pass
    /// (`Model::simulate_checkpointed`), or `None` when it kept none.
    pub fn kept_checkpoints(&self) -> Option<usize> {
        let kept = self.checkpoints.as_ref()?;
        Some(kept.iter().map(Vec::len).sum())
    }

    /// Bytes held by the step recordings ([`Tape::memory_bytes`]), or `None` when the rollout
    /// was simulated plainly (its gradients then re-record each step from its checkpoint).
    pub fn recorded_bytes(&self) -> Option<usize> {
        let recs = self.recordings.as_ref()?;
        Some(recs.iter().map(|r| r.tape.memory_bytes()).sum())
    }

    /// Under Newton: the steps whose factorization was kept for the gradients, and their bytes
    /// ([`crate::NewtonKept`]).
    pub fn kept_factorizations(&self) -> Option<(usize, usize)> {
        self.newton.as_ref().map(|k| (k.steps(), k.bytes()))
    }

    /// The states and the gradients of `costs` (the costs the rollout was recorded with) with
    /// respect to the controls: pulled back through the recordings when there are some, else by
    /// [`Model::gradients`] from the states. Both give the same values bit for bit.
    ///
    /// # Panics
    /// If `costs` has another length than at recording.
    pub fn gradients(
        self,
        model: &Model,
        controls: &Controls,
        costs: &[StepCost<'_>],
    ) -> (Vec<Tensor>, Vec<Tensor>) {
        if costs.is_empty() {
            return (self.states, Vec::new());
        }
        if let (Some(kept), crate::newton::settings::Solver::Newton(_)) =
            (self.newton, model.solver)
        {
            let grads = model.newton_gradients_kept(&self.states, controls, costs, Some(kept));
            return (self.states, grads.0);
        }
        let Some(mut recordings) = self.recordings else {
            let grads = match &self.checkpoints {
                Some(kept) => {
                    in_pool(|| model.gradients_in_pool(&self.states, controls, costs, Some(kept)))
                }
                None => model.gradients(&self.states, controls, costs),
            };
            return (self.states, grads);
        };
        let grads = in_pool(|| {
            let mut grads: Vec<Tensor> = costs.iter().map(|_| model.zero_controls()).collect();
            let mut adjoints: Vec<Adjoint> = costs.iter().map(|_| Adjoint::default()).collect();
            // Last step first; each recording is dropped once pulled back.
            while let Some(rec) = recordings.pop() {
                assert_eq!(rec.terms.len(), costs.len(), "the recorded costs");
                let seg = Segment::whole(model, recordings.len() + 1);
                model.pull_back(&rec, &seg, &mut adjoints, &mut grads);
                model.tapes.give(rec.tape, model.checkpoint_budget);
            }
            grads
        });
        (self.states, grads)
    }
}

impl Model {
    /// Simulates `controls` as [`Model::simulate`] does (the same states, bit for bit) and, when
    /// the whole rollout's recording fits [`Model::checkpoint_budget`], records every step with
    /// `costs` on the way, so its gradients need no second forward pass.
    ///
    /// Whether it fits: `horizon × iterations ×` [`Model::recorded_bytes_per_iteration`] is a
    /// lower bound, checked first; then the recordings' actual bytes are summed as they are made,
    /// and they are all dropped (the rest simulated plainly) as soon as the first step's bytes
    /// times the horizon, or the running total, exceed the budget. Memory so stays within the
    /// budget plus one step's recording.
    ///
    /// # Errors
    /// As [`Model::simulate`].
    pub fn simulate_recording(
        &self,
        controls: &Controls,
        costs: &[StepCost<'_>],
    ) -> Result<RecordedRollout, ClothError> {
        let horizon = self.task.horizon;
        let lower_bound = horizon * self.iterations.max(1) * self.recorded_bytes_per_iteration();
        // Newton steps are differentiated implicitly, not by recording their iterations; the
        // forward keeps its factorizations for that within the budget.
        if let crate::newton::settings::Solver::Newton(settings) = self.solver {
            let budget = if costs.is_empty() {
                0
            } else {
                self.checkpoint_budget
            };
            let rollout = self.simulate_newton_keeping(controls, &settings, budget)?;
            return Ok(RecordedRollout {
                states: rollout.states,
                recordings: None,
                newton: Some(rollout.kept),
                checkpoints: None,
            });
        }
        if costs.is_empty() {
            return Ok(RecordedRollout {
                states: self.simulate(controls)?,
                recordings: None,
                newton: None,
                checkpoints: None,
            });
        }
        if lower_bound > self.checkpoint_budget {
            let (states, checkpoints) = self.simulate_checkpointed(controls)?;
            return Ok(RecordedRollout {
                states,
                recordings: None,
                newton: None,
                checkpoints,
            });
        }
        self.check_controls(controls)?;
        in_pool(|| {
            let mut states = Vec::with_capacity(horizon + 1);
            states.push(self.start.clone());
            let mut recordings = Some(Vec::with_capacity(horizon));
            let (mut total, mut scratch) = (0, StepScratch::default());
            let mut recorder = Recorder {
                model: self,
                controls,
                costs,
                starts: &[0],
                kept: None,
                checkpoints: None,
            };
            for t in 1..=horizon {
                let x = match recordings.as_mut() {
                    Some(recs) => {
                        let tape = self.tapes.take();
                        let rec = recorder.record(&Segment::whole(self, t), &states[t - 1], tape);
                        let x = rec.tape.value(rec.x).clone();
                        let bytes = rec.tape.memory_bytes();
                        total += bytes;
                        if bytes.saturating_mul(horizon) > self.checkpoint_budget
                            || total > self.checkpoint_budget
                        {
                            recordings = None;
                        } else {
                            recs.push(rec);
                        }
                        x
                    }
                    None => self.step(
                        &states[t - 1],
                        &self.step_controls(controls, t - 1),
                        &mut scratch,
                    ),
                };
                check_finite(&x, t)?;
                states.push(x);
            }
            Ok(RecordedRollout {
                states,
                recordings,
                newton: None,
                checkpoints: None,
            })
        })
    }
}

/// A block of one step's iterations, the unit [`Model::gradients`] records and pulls back.
struct Segment {
    /// The step (1-based).
    t: usize,
    /// The block within the step (block 0 starts from `x_prev` and the controls).
    block: usize,
    /// The step's last block (the costs are recorded on it).
    last: bool,
    /// Gauss–Seidel iterations in the block.
    iterations: usize,
}

impl Segment {
    /// The whole of step `t` as one block.
    fn whole(model: &Model, t: usize) -> Segment {
        Segment {
            t,
            block: 0,
            last: true,
            iterations: model.iterations,
        }
    }
}

/// One recorded segment and the variables the pull-back needs.
struct Recording {
    tape: Tape,
    x_prev: Var,
    u: Var,
    /// The block's input state (after gravity and controls for a first block).
    x_in: Var,
    /// The block's input multipliers.
    lambdas_in: Vec<Var>,
    /// The block's output state and multipliers.
    x: Var,
    lambdas: Vec<Var>,
    /// Each cost's term (last blocks only).
    terms: Vec<Option<Var>>,
}

/// Records segments; keeps the current step's block checkpoints.
struct Recorder<'a> {
    model: &'a Model,
    controls: &'a Controls,
    costs: &'a [StepCost<'a>],
    starts: &'a [usize],
    /// Every step's checkpoints, when the forward kept them (step `t` at `t − 1`).
    kept: Option<&'a [Vec<Checkpoint>]>,
    /// `(step, checkpoints)` of the step being recorded (computed here when not `kept`).
    checkpoints: Option<(usize, Vec<Checkpoint>)>,
}

impl Recorder<'_> {
    /// Records segment `seg` on `tape`, from the state `x_prev` before its step.
    fn record(&mut self, seg: &Segment, x_prev: &Tensor, mut tape: Tape) -> Recording {
        let (m, t) = (self.model, seg.t);
        let u_t = m.step_controls(self.controls, t - 1);
        // The step's self-contacts: a function of the same state and controls as the forward's,
        // so the same sets, bit for bit.
        let contacts = m.contact_sets(x_prev, &u_t);
        if self.starts.len() > 1
            && self.kept.is_none()
            && self.checkpoints.as_ref().map(|c| c.0) != Some(t)
        {
            let (checkpoints, _) = m.step_checkpoints(x_prev, &u_t, self.starts, false);
            self.checkpoints = Some((t, checkpoints));
        }
        tape.clear();
        let x_prev = tape.leaf(x_prev.clone());
        let u = tape.leaf(u_t);
        let (x_in, lambdas_in) = if seg.block == 0 {
            let x = m.record_begin_step(&mut tape, x_prev, u);
            (x, m.record_initial_carries(&mut tape, x_prev, &contacts))
        } else {
            let checkpoints = match self.kept {
                Some(kept) => &kept[t - 1],
                None => {
                    &self
                        .checkpoints
                        .as_ref()
                        .expect("checkpoints of this step")
                        .1
                }
            };
            let (x, l) = &checkpoints[seg.block - 1];
            let x = tape.leaf(x.clone());
            (x, l.iter().map(|l| tape.leaf(l.clone())).collect())
        };
        let mut lambdas = lambdas_in.clone();
        let x = m.record_sweeps(&mut tape, x_in, &mut lambdas, seg.iterations, &contacts);
        let terms = self
            .costs
            .iter()
            .map(|f| {
                if seg.last {
                    f(&mut tape, t, x_prev, x)
                } else {
                    None
                }
            })
            .collect();
        Recording {
            tape,
            x_prev,
            u,
            x_in,
            lambdas_in,
            x,
            lambdas,
            terms,
        }
    }
}

/// One cost's adjoint during [`Model::gradients`].
#[derive(Default)]
struct Adjoint {
    /// Of the state where the pull-back has reached.
    state: Option<Tensor>,
    /// Of the multipliers there (inside a step; empty at a step's start).
    lambdas: Vec<Tensor>,
    /// Of the step's `x_prev` through the cost terms, waiting for the step's first block.
    x_prev: Option<Tensor>,
}
