//! How a Newton-converged rollout moves with the physical parameters: forward sensitivities.
//!
//! At a step's minimizer `g = ∇_f Φ(x_t; x_{t−1}, θ) = 0`. Differentiating with respect to a
//! parameter's log-factor `s` ([`crate::parameters`]), with the controls fixed,
//!
//! ```text
//! H_ff ẋ_t = −∂g/∂s + M ẋ_{t−1} − D_xy ẋ_{t−1},
//! ```
//!
//! `M` from `x̃ = x_{t−1} + ½gΔt²` and `D_xy` the lagged friction's coupling to the step's start.
//! `∂g/∂s` is the gradient of the part of `Φ` the parameter scales: a constraint group's
//! `Σ k C∇C`, the inertia and gravity term `M(x − x̃)` for the mass, `−M·½gΔt²` for gravity, the
//! friction potential's gradient for friction. With rigid contact rows the solve is the implicit
//! gradient's (`super::implicit`): `ẋ` stays in the active contacts' tangent planes. One
//! factorization per step serves every parameter. Forward mode suits a fit: a few parameters,
//! many observed coordinates.

use super::assembly::gather_local;
use super::solve::NewtonSystem;
use crate::controls::Controls;
use crate::error::ClothError;
use crate::model::Model;
use crate::parameters::Parameter;
use autodiff::Tensor;

impl Model {
    /// `∂x_t/∂ log θ_p` of a Newton rollout (see [`Model::parameter_tangents`]).
    pub(crate) fn newton_parameter_tangents(
        &self,
        states: &[Tensor],
        controls: &Controls,
        params: &[Parameter],
    ) -> Result<Vec<Vec<Tensor>>, ClothError> {
        let mut system = NewtonSystem::new(self)?;
        let (n, k, n_dof) = (self.n_particles(), params.len(), system.pattern.n_dof);
        let mut tangents = vec![vec![Tensor::zeros(n, 3); k]];
        let mut rhs = vec![0.0; n_dof * k];
        for t in 1..=self.task.horizon {
            let x = &states[t];
            let xt = self.factorize_converged(&mut system, states, controls, t)?;
            for (j, p) in params.iter().enumerate() {
                let col = &mut rhs[j * n_dof..(j + 1) * n_dof];
                self.parameter_gradient(&system, p, x.data(), xt.data(), col);
                col.iter_mut().for_each(|v| *v = -*v);
                self.add_previous_tangent(&system, x.data(), tangents[t - 1][j].data(), col);
                system.contacts.project_tangent(col);
            }
            system.factor.solve_in_place(&mut rhs, k);
            let step: Vec<Tensor> = rhs
                .chunks_exact(n_dof.max(1))
                .take(k)
                .map(|z| {
                    let mut v = z.to_vec();
                    system.contacts.project_tangent(&mut v);
                    let mut full = Tensor::zeros(n, 3);
                    system.pattern.scatter(&v, full.data_mut());
                    full
                })
                .collect();
            tangents.push(if n_dof == 0 {
                vec![Tensor::zeros(n, 3); k]
            } else {
                step
            });
        }
        Ok(tangents)
    }

    /// Factorizes the exact Hessian of step `t`'s `Φ` (started from `states[t − 1]`) at its
    /// converged state `states[t]`, the self-contact pattern fitted there; returns the step's
    /// predicted state `x̃`.
    ///
    /// # Errors
    /// [`ClothError::NewtonSaddle`] where that Hessian is not positive definite (not a
    /// minimizer: the state's tangents are not defined).
    pub(super) fn factorize_converged(
        &self,
        system: &mut NewtonSystem,
        states: &[Tensor],
        controls: &Controls,
        t: usize,
    ) -> Result<Tensor, ClothError> {
        let (prev, x) = (&states[t - 1], &states[t]);
        let xt = self.begin_step(prev, &self.step_controls(controls, t - 1));
        system.begin_step(prev);
        system.fit_self_contact(x.data());
        if !system.factorize_exact(x.data(), xt.data()) {
            return Err(ClothError::NewtonSaddle {
                step: t,
                residual: f64::NAN,
            });
        }
        Ok(xt)
    }

    /// `∂(∇_f Φ)/∂ log θ` at `x` (full data; `xt` the step's predicted state) into `out` (degree
    /// of freedom order).
    fn parameter_gradient(
        &self,
        system: &NewtonSystem,
        p: &Parameter,
        x: &[f64],
        xt: &[f64],
        out: &mut [f64],
    ) {
        out.fill(0.0);
        let pattern = &system.pattern;
        match p {
            Parameter::Stiffness(name) => {
                let mut local = [0.0; super::terms::MAX_DOF];
                let mut g = [0.0; super::terms::MAX_DOF];
                for group in self.groups.iter().filter(|g| &g.name == name) {
                    let terms = group.terms.as_ref();
                    let s = 1.0 / terms.compliance();
                    for k in 0..terms.count() {
                        let ps = terms.particles(k);
                        let d = gather_local(ps, x, &mut local);
                        let c = terms.first_order(k, &local[..d], &mut g[..d]);
                        if terms.inequality() && c >= 0.0 {
                            continue;
                        }
                        for a in 0..d {
                            if let Some(da) = pattern.dof(ps[a / 3]) {
                                out[da + a % 3] += s * c * g[a];
                            }
                        }
                    }
                }
            }
            Parameter::Mass | Parameter::Gravity => {
                let gs = self.gravity_step.unwrap_or([0.0; 3]);
                for (q, &w) in self.inv_mass.iter().enumerate() {
                    let Some(d) = pattern.dof(q).filter(|_| w > 0.0) else {
                        continue;
                    };
                    for a in 0..3 {
                        out[d + a] = match p {
                            Parameter::Mass => (x[3 * q + a] - xt[3 * q + a]) / w,
                            _ => -gs[a] / w,
                        };
                    }
                }
            }
            Parameter::Friction => {
                pattern.add_self_friction(x, out, None);
                let (Some(barrier), Some((start, lagged))) =
                    (&self.contact_barrier, &pattern.friction)
                else {
                    return;
                };
                for (q, contacts) in lagged.iter().enumerate() {
                    let Some(d) = pattern.dof(q).filter(|_| !contacts.is_empty()) else {
                        continue;
                    };
                    let (mut g, mut h) = ([0.0; 3], [0.0; 9]);
                    let r = 3 * q..3 * q + 3;
                    barrier.friction_derivatives(
                        &x[r.clone()],
                        &start[r],
                        contacts,
                        &mut g,
                        &mut h,
                    );
                    for (o, v) in out[d..d + 3].iter_mut().zip(g) {
                        *o += v;
                    }
                }
                if let Some(e) = &pattern.edge_points {
                    e.add_friction_gradient(x, out);
                }
            }
        }
    }

    /// `rhs += M ẋ_{t−1} − D_xy ẋ_{t−1}` on the free particles (`prev` full data).
    pub(super) fn add_previous_tangent(
        &self,
        system: &NewtonSystem,
        x: &[f64],
        prev: &[f64],
        rhs: &mut [f64],
    ) {
        let pattern = &system.pattern;
        for (q, &w) in self.inv_mass.iter().enumerate() {
            if let Some(d) = pattern.dof(q).filter(|_| w > 0.0) {
                for a in 0..3 {
                    rhs[d + a] += prev[3 * q + a] / w;
                }
            }
        }
        pattern.sub_start_coupling_forward(x, prev, rhs);
    }
}
