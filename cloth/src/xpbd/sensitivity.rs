//! How an XPBD rollout moves with the physical parameters: forward sensitivities through the
//! unrolled sweeps.
//!
//! The step is re-run set by set with the plain path's kernel ([`update_rows`], so the states are
//! the rollout's bit for bit), and after every colour set each parameter's tangent of the state
//! and the carried values is pushed through the set's rows: `ṫ' = J ṫ + ∂out/∂ log θ`. `J`, the
//! row's Jacobian, comes from its row function's own vector–Jacobian products (one seed per
//! output, unit on every row at once, pulled back together so the rows' shared work is done
//! once), so every constraint type, a user's included, and the friction rows get exact tangents
//! without code of their own.
//!
//! The parameters' partials follow from the same Jacobian and the row's multiplier, because the
//! XPBD update `Δλ = (−C − α̃λ)/(S + α̃)`, `S = Σ wᵢ|∇ᵢC|²`, `p ← p + W∇C Δλ`, `λ ← λ + Δλ`
//! depends on the compliance `α̃ = 1/(kΔt²)` and the inverse masses `w` only through `α̃λ` and `S`:
//! with `J_λ` the column of `λ`,
//!
//! - stiffness (`∂α̃/∂ log k = −α̃`): `∂out/∂ log k = λ' (e_λ − J_λ)`;
//! - mass (`∂w/∂ log m = −w`): `∂out/∂ log m = Δλ J_λ`.
//!
//! The friction rows ([`crate::contact::friction`]) bound the friction correction by `μD`, `D` the
//! normal correction carried through the step, and depend on `μ` only through that bound, so
//! `∂out/∂ log μ = D' (J_D − e_D)` with `J_D` the column of `D`. Gravity enters at the step's start
//! (`x̃ = x_prev + ½gΔt²`).

use super::set::{Carry, ProjectionSet};
use crate::controls::Controls;
use crate::model::Model;
use crate::parameters::Parameter;
use autodiff::update::update_rows;
use autodiff::Tensor;

/// Where the friction rows carry the normal correction `D`: after the particle's position (3) and
/// its start position (3) ([`crate::contact::friction`]'s layout).
const FRICTION_D: usize = 6;

/// How a colour set depends on the parameters.
struct SetRole<'a> {
    set: &'a ProjectionSet,
    /// Its constraint group's name; `None` for the step's self-contact sets.
    group: Option<&'a str>,
    /// Whether its compliance is positive (a stiffness scales it).
    elastic: bool,
}

impl Model {
    /// `∂x_t/∂ log θ_p` of an XPBD rollout (see [`Model::parameter_tangents`]).
    pub(crate) fn xpbd_parameter_tangents(
        &self,
        states: &[Tensor],
        controls: &Controls,
        params: &[Parameter],
    ) -> Vec<Vec<Tensor>> {
        let n = self.n_particles();
        let mut tangents = vec![vec![Tensor::zeros(n, 3); params.len()]];
        for t in 1..=self.task.horizon {
            let prev = &states[t - 1];
            let u = self.step_controls(controls, t - 1);
            let contacts = self.contact_sets(prev, &u);
            let mut x = self.begin_step(prev, &u);
            let mut dx = tangents[t - 1].clone();
            if let Some(g) = self.gravity_step {
                for (j, p) in params.iter().enumerate() {
                    if *p == Parameter::Gravity {
                        add_gravity(&mut dx[j], g, self.controls.as_slice());
                    }
                }
            }
            let roles: Vec<SetRole> = (self.groups.iter())
                .flat_map(|g| {
                    let elastic = g.terms.compliance() > 0.0;
                    g.sets.iter().map(move |set| SetRole {
                        set,
                        group: Some(g.name.as_str()),
                        elastic,
                    })
                })
                .chain(contacts.iter().map(|set| SetRole {
                    set,
                    group: None,
                    elastic: false,
                }))
                .collect();
            let mut carries = self.step_carries(prev, &contacts);
            let mut seeds = Seeds::default();
            let mut dcarries: Vec<Vec<Tensor>> = (roles.iter().zip(&carries))
                .map(|(r, c)| {
                    (0..params.len())
                        .map(|j| start_carry_tangent(r.set, c, &tangents[t - 1][j]))
                        .collect()
                })
                .collect();
            for _ in 0..self.iterations {
                for ((role, carry), dcarry) in roles.iter().zip(&mut carries).zip(&mut dcarries) {
                    let mut inputs = Vec::new();
                    let set = role.set;
                    update_rows(
                        set.projection.as_ref(),
                        &set.index,
                        &mut x,
                        carry,
                        Some(&mut inputs),
                    );
                    let jac = seeds.row_jacobians(set, &inputs, n);
                    for (j, p) in params.iter().enumerate() {
                        push_tangent(role, p, &jac, &inputs, carry, &mut dx[j], &mut dcarry[j]);
                    }
                }
            }
            tangents.push(dx);
        }
        tangents
    }
}

/// `ẋ += ½gΔt²` on every particle but the controls (which [`Model::begin_step`] moves by `u`).
fn add_gravity(dx: &mut Tensor, g: [f64; 3], controls: &[usize]) {
    for p in 0..dx.rows() {
        if !controls.contains(&p) {
            for (v, gk) in dx.row_mut(p).iter_mut().zip(g) {
                *v += gk;
            }
        }
    }
}

/// The tangent of a set's carry at the step's start: the start positions' tangents for
/// [`Carry::StartPosition`], zero otherwise.
fn start_carry_tangent(set: &ProjectionSet, carry: &Tensor, dprev: &Tensor) -> Tensor {
    let mut d = Tensor::zeros(carry.rows(), carry.cols());
    if let Carry::StartPosition { .. } = set.carry {
        for (k, &p) in set.index.as_slice().iter().enumerate() {
            d.row_mut(k)[..3].copy_from_slice(dprev.row(p));
        }
    }
    d
}

/// The unit seeds of [`Seeds::row_jacobians`], kept between sets: one state adjoint (`N × 3`)
/// per output, zero but for the rows of the set being pulled back.
#[derive(Default)]
struct Seeds {
    states: Vec<Tensor>,
}

impl Seeds {
    /// Every row's Jacobian (`n_out × n_in`, row-major, rows after one another) at the gathered
    /// `inputs` of `set` (a state of `n` particles): row `o` of each is the pull-back of the unit
    /// seed on output `o`, all outputs in one multi-seed pass.
    fn row_jacobians(&mut self, set: &ProjectionSet, inputs: &[f64], n: usize) -> Vec<f64> {
        let f = set.projection.as_ref();
        let (n_in, n_out) = (f.n_in(), f.n_out());
        let positions = 3 * set.index.arity();
        let rows = set.index.rows();
        if self.states.len() < n_out || self.states.first().is_some_and(|t| t.rows() != n) {
            self.states = (0..n_out).map(|_| Tensor::zeros(n, 3)).collect();
        }
        let states = &mut self.states[..n_out];
        let mut carries: Vec<Tensor> = (0..n_out)
            .map(|_| Tensor::zeros(rows, n_in - positions))
            .collect();
        for r in 0..rows {
            let particles = set.index.row(r);
            for (o, (state, carry)) in states.iter_mut().zip(&mut carries).enumerate() {
                if o < positions {
                    state.row_mut(particles[o / 3])[o % 3] = 1.0;
                } else {
                    carry.row_mut(r)[o - positions] = 1.0;
                }
            }
        }
        f.vjp_update_batch_seeds(&set.index, inputs, states, &mut carries);
        let mut jac = vec![0.0; rows * n_out * n_in];
        for r in 0..rows {
            let particles = set.index.row(r);
            for (o, (state, carry)) in states.iter().zip(&carries).enumerate() {
                let at = (r * n_out + o) * n_in;
                for (i, &q) in particles.iter().enumerate() {
                    jac[at + 3 * i..at + 3 * i + 3].copy_from_slice(state.row(q));
                }
                jac[at + positions..at + n_in].copy_from_slice(carry.row(r));
            }
        }
        // Zero the rows used, for the next set.
        for state in states.iter_mut() {
            for r in 0..rows {
                for &q in set.index.row(r) {
                    state.row_mut(q).fill(0.0);
                }
            }
        }
        jac
    }
}

/// Pushes one parameter's tangent (`dx`, `dcarry`) through a set's rows: `J ṫ` plus the
/// parameter's partial (the module's docs). `inputs` are the rows' gathered inputs, `carry` the
/// carried values after the update.
fn push_tangent(
    role: &SetRole,
    p: &Parameter,
    jac: &[f64],
    inputs: &[f64],
    carry: &Tensor,
    dx: &mut Tensor,
    dcarry: &mut Tensor,
) {
    let set = role.set;
    let f = set.projection.as_ref();
    let (n_in, n_out) = (f.n_in(), f.n_out());
    let arity = set.index.arity();
    let positions = 3 * arity;
    let mut tin = vec![0.0; n_in];
    let mut tout = vec![0.0; n_out];
    let multiplier = set.carry == Carry::Multiplier;
    for r in 0..set.index.rows() {
        let particles = set.index.row(r);
        for (i, &q) in particles.iter().enumerate() {
            tin[3 * i..3 * i + 3].copy_from_slice(dx.row(q));
        }
        tin[positions..].copy_from_slice(dcarry.row(r));
        let j = &jac[r * n_out * n_in..(r + 1) * n_out * n_in];
        for (o, t) in tout.iter_mut().enumerate() {
            *t = (0..n_in).map(|i| j[o * n_in + i] * tin[i]).sum();
        }
        // The partial: a multiple of a column of J, less a unit vector.
        let (column, coefficient, unit) = match p {
            Parameter::Stiffness(name)
                if multiplier && role.elastic && role.group == Some(name) =>
            {
                (positions, -carry.get(r, 0), Some(positions))
            }
            Parameter::Mass if multiplier => {
                let dlambda = carry.get(r, 0) - inputs[r * n_in + positions];
                (positions, dlambda, None)
            }
            Parameter::Friction if !multiplier => {
                (FRICTION_D, carry.get(r, FRICTION_D - 3), Some(FRICTION_D))
            }
            _ => (0, 0.0, None),
        };
        if coefficient != 0.0 {
            for (o, t) in tout.iter_mut().enumerate() {
                *t += coefficient * j[o * n_in + column];
            }
            if let Some(u) = unit {
                tout[u] -= coefficient;
            }
        }
        for (i, &q) in particles.iter().enumerate() {
            dx.row_mut(q).copy_from_slice(&tout[3 * i..3 * i + 3]);
        }
        dcarry.row_mut(r).copy_from_slice(&tout[positions..]);
    }
}
