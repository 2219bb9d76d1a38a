//! Gradients of per-step costs through Newton-converged steps by the implicit function theorem.
//!
//! At a step's minimizer `∇_f Φ(x_f, x_c; x̃_f) = 0`, with `x̃_f = x_prev,f + ½gΔt²` and the control
//! particles `x_c = x_prev,c + u`. Differentiating, `H_ff dx_f = M dx̃_f − H_fc dx_c`, so an
//! adjoint `ā` of the step's state pulls back with `z = H_ff⁻¹ ā_f` to
//! `x̄_prev,f = M z` and `x̄_prev,c = ū = ā_c − H_cf z`. One factorization of the exact Hessian per
//! step serves every cost (the right-hand sides are solved together).
//!
//! With contact rows, the active ones are equalities at the minimizer (they do not depend on
//! `x_prev` or `u`): `z = P y` with `K y = P ā_f`, `K` the reduced Hessian of the Lagrangian
//! ([`super::contact`]), so `dx_f` stays in the contact surfaces' tangent planes.
//!
//! The matrix is the one the forward's convergence test factorized at the same state; where the
//! forward kept that factorization ([`super::continuation::NewtonKept`]) it is reused, after
//! checking that the assembled matrix is the kept one bit for bit.

use super::continuation::NewtonKept;
use super::factor::FactorCounts;
use super::solve::NewtonSystem;
use crate::controls::Controls;
use crate::model::Model;
use crate::rollout::grad::StepCost;
use autodiff::{Tape, Tensor};

impl Model {
    /// [`Model::gradients`] for a rollout simulated with [`Model::simulate_newton`].
    ///
    /// # Panics
    /// If the model has a rigid constraint group (the rollout could not have been simulated), or
    /// if the exact Hessian at a converged state is not positive definite (the state is a saddle
    /// of `Φ`, not a minimizer, and has no well-defined gradient).
    pub fn newton_gradients(
        &self,
        states: &[Tensor],
        controls: &Controls,
        costs: &[StepCost<'_>],
    ) -> Vec<Tensor> {
        self.newton_gradients_kept(states, controls, costs, None).0
    }

    /// [`Model::newton_gradients`] with what [`Model::simulate_newton_keeping`] kept of the
    /// rollout `states` (its system, factorizations and self-contact patterns): the same values
    /// bit for bit whatever the budget kept, with no factorization at the steps whose
    /// factorization was kept; and the gradient pass's factorizations
    /// ([`FactorCounts::reused`]: the kept ones it used). Under self-contact the patterns depend
    /// on the solve's path, so [`Model::newton_gradients`] from the states alone agrees to
    /// round-off, not bit for bit.
    ///
    /// # Panics
    /// As [`Model::newton_gradients`].
    pub fn newton_gradients_kept(
        &self,
        states: &[Tensor],
        controls: &Controls,
        costs: &[StepCost<'_>],
        kept: Option<NewtonKept>,
    ) -> (Vec<Tensor>, FactorCounts) {
        let (mut system, mut factors, patterns) = match kept {
            Some(k) => (k.system, k.factors, k.patterns),
            None => (
                NewtonSystem::new(self)
                    .expect("newton_gradients: the model has no rigid constraint group"),
                Vec::new(),
                Vec::new(),
            ),
        };
        let n_dof = system.pattern.n_dof;
        let before = system.factor.counts();
        let mut grads: Vec<Tensor> = costs.iter().map(|_| self.zero_controls()).collect();
        let (n, k) = (self.n_particles(), costs.len());
        let mut adjoints: Vec<Tensor> = costs.iter().map(|_| Tensor::zeros(n, 3)).collect();
        let mut tape = Tape::new();
        let mut rhs = vec![0.0; n_dof * k];
        for t in (1..=self.task.horizon).rev() {
            // Each cost's term at step t, pulled back to x_t and x_{t−1}.
            tape.clear();
            let xp = tape.leaf(states[t - 1].clone());
            let xv = tape.leaf(states[t].clone());
            let mut prev_adjoints: Vec<Tensor> = Vec::with_capacity(k);
            for (cost, adj) in costs.iter().zip(adjoints.iter_mut()) {
                match cost(&mut tape, t, xp, xv) {
                    Some(c) => {
                        let g = tape.vjp(&[(c, Tensor::scalar(1.0))]);
                        adj.add_assign(&g.wrt(xv));
                        prev_adjoints.push(g.wrt(xp));
                    }
                    None => prev_adjoints.push(Tensor::zeros(n, 3)),
                }
            }
            // The step's pull-back with one factorization.
            let u_t = self.step_controls(controls, t - 1);
            let xt = self.begin_step(&states[t - 1], &u_t);
            system.begin_step(&states[t - 1]);
            // Self-contact: the pattern the forward converged with (the kept factorization's),
            // else one holding the pairs at x_t.
            match patterns.get(t - 1) {
                Some(blocks) => system.adopt_self_blocks(blocks),
                None => system.fit_self_contact(states[t].data()),
            }
            if let Some(f) = factors.get_mut(t - 1).and_then(Option::take) {
                system.factor.insert(f);
            }
            assert!(
                system.factorize_exact(states[t].data(), xt.data()),
                "newton_gradients: the Hessian of Φ at the state of step {t} is not positive \
                 definite (a saddle, not a minimizer): its gradient is not defined"
            );
            for (j, adj) in adjoints.iter().enumerate() {
                let col = &mut rhs[j * n_dof..(j + 1) * n_dof];
                system.pattern.gather(adj.data(), col);
                system.contacts.project_tangent(col);
            }
            system.factor.solve_in_place(&mut rhs, k);
            for col in rhs.chunks_exact_mut(n_dof.max(1)) {
                system.contacts.project_tangent(col);
            }
            for j in 0..k {
                let z = &rhs[j * n_dof..(j + 1) * n_dof];
                let mut prev = std::mem::replace(&mut prev_adjoints[j], Tensor::zeros(0, 0));
                // ā_c − H_cf z, on the control particles' rows of a scratch state.
                let mut control = Tensor::zeros(n, 3);
                for &p in self.controls.as_slice() {
                    control.row_mut(p).copy_from_slice(adjoints[j].row(p));
                }
                system
                    .pattern
                    .sub_control_coupling(states[t].data(), z, control.data_mut());
                for (c, &p) in self.controls.as_slice().iter().enumerate() {
                    for d in 0..3 {
                        grads[j].row_mut(t - 1)[3 * c + d] = control.get(p, d);
                    }
                }
                system.pattern.add_mass_times(z, prev.data_mut());
                system
                    .pattern
                    .sub_start_coupling(states[t].data(), z, prev.data_mut());
                prev.add_assign(&control);
                adjoints[j] = prev;
            }
        }
        (grads, system.factor.counts().since(before))
    }
}
