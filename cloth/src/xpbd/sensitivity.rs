//! How an XPBD rollout moves with the physical parameters: forward sensitivities through the
//! unrolled sweeps.
//!
//! The step is re-run set by set with the plain path's kernel ([`update_rows`], so the states are
//! the rollout's bit for bit), and after every colour set each parameter's tangent of the state
//! and the carried values is pushed through the set's rows: `ṫ' = J ṫ + ∂out/∂ log θ`. `J`, the
//! row's Jacobian, comes from its row function's own vector–Jacobian products (one per output,
//! unit seeds on every row at once), so every constraint type, a user's included, and the
//! friction rows get exact tangents without code of their own.
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
                    let jac = row_jacobians(set, &inputs);
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

/// Every row's Jacobian (`n_out × n_in`, row-major, rows after one another) at the gathered
/// `inputs`, from the row function's vector–Jacobian products.
fn row_jacobians(set: &ProjectionSet, inputs: &[f64]) -> Vec<f64> {
    let f = set.projection.as_ref();
    let (n_in, n_out) = (f.n_in(), f.n_out());
    let rows = inputs.len() / n_in.max(1);
    let mut jac = vec![0.0; rows * n_out * n_in];
    let (mut seed, mut adj) = (vec![0.0; rows * n_out], vec![0.0; rows * n_in]);
    for o in 0..n_out {
        seed.iter_mut()
            .enumerate()
            .for_each(|(i, s)| *s = f64::from(u8::from(i % n_out == o)));
        adj.fill(0.0);
        f.vjp_batch(inputs, &seed, &mut adj);
        for r in 0..rows {
            let at = (r * n_out + o) * n_in;
            jac[at..at + n_in].copy_from_slice(&adj[r * n_in..(r + 1) * n_in]);
        }
    }
    jac
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
