//! The XPBD projection of one colour set of constraints, as an `autodiff` row function.
//!
//! Row `k` holds the positions of constraint `k`'s particles and its multiplier `λ`:
//! `Δλ = (−C − α̃λ) / (Σᵢ wᵢ|∇ᵢC|² + α̃)`, `λ ← λ + Δλ`, `pᵢ ← pᵢ + wᵢ ∇ᵢC Δλ`.
//! Inequality constraints are projected only while `C < 0`.
//!
//! The forward pass takes `∇C` from [`Constraint::gradient`] (closed form for the built-ins,
//! forward duals on the generic `C` otherwise). The vector–Jacobian product is the adjoint of the
//! update formula above, with `∇C` and the Hessian–vector products
//! [`Constraint::hessian_vectors`] (again closed form or from duals), so it serves every
//! [`Constraint`] unchanged; a test checks it against the engine's generic dual-derived VJP.
//! What the seeds of a multi-seed pull-back share (`∇C`, `Δλ`, the reciprocal of the
//! denominator) is computed once per row; per seed there are only products and sums.

use crate::constraint::{value_and_gradient, Constraint, RowVector, MAX_ARITY};
use autodiff::rowfn::{with_scratch, ROW_BLOCK, SEED_CHUNK};
use autodiff::simd::LANES;
use autodiff::{F64x8, Mask8, Real, RowFn};
use std::sync::Arc;

const MAX_D: usize = 3 * MAX_ARITY;

/// The Gauss–Seidel projection of a set of constraints that share no particle.
pub struct Projection<C> {
    constraint: Arc<C>,
    /// Constraint instance of each row.
    instances: Vec<usize>,
    /// Inverse mass of each row's particles (`rows × ARITY`).
    inv_mass: Vec<f64>,
    /// The same in lanes when `C` has them: for each whole group of eight rows from row 0 (the
    /// lane-wise kernels' groups), `ARITY` vectors (point by point).
    lane_mass: Vec<F64x8>,
    /// `α̃ = 1/(k Δt²)`; 0 for a rigid constraint.
    compliance: f64,
}

impl<C: Constraint> Projection<C> {
    /// A projection over `instances` of `constraint`, with per-row particle inverse masses.
    ///
    /// # Panics
    /// If `inv_mass.len() != instances.len() · ARITY` or `compliance` is negative or not finite.
    pub fn new(
        constraint: Arc<C>,
        instances: Vec<usize>,
        inv_mass: Vec<f64>,
        compliance: f64,
    ) -> Self {
        assert_eq!(
            inv_mass.len(),
            instances.len() * C::ARITY,
            "Projection: one inverse mass per particle per row"
        );
        assert!(
            compliance >= 0.0 && compliance.is_finite(),
            "Projection: compliance must be finite and ≥ 0"
        );
        let groups = if C::LANES { instances.len() / LANES } else { 0 };
        let lane_mass = (0..groups)
            .flat_map(|group| {
                let w = &inv_mass;
                (0..C::ARITY)
                    .map(move |i| F64x8::from_fn(|l| w[(LANES * group + l) * C::ARITY + i]))
            })
            .collect();
        Projection {
            constraint,
            instances,
            inv_mass,
            lane_mass,
            compliance,
        }
    }

    /// Σᵢ wᵢ|gᵢ|² for row `row`.
    #[inline(always)]
    fn weighted_sq<R: Real>(&self, row: usize, g: &[R]) -> R {
        let w = &self.inv_mass[row * C::ARITY..(row + 1) * C::ARITY];
        let mut s = R::zero();
        for (i, &wi) in w.iter().enumerate() {
            let gi = &g[3 * i..3 * i + 3];
            s += (gi[0] * gi[0] + gi[1] * gi[1] + gi[2] * gi[2]) * wi;
        }
        s
    }
}

impl<C: Constraint> RowFn for Projection<C> {
    fn n_in(&self) -> usize {
        3 * C::ARITY + 1
    }
    fn n_out(&self) -> usize {
        3 * C::ARITY + 1
    }

    /// `∇C` and `C` go into `out` first and are replaced by the update there: no scratch.
    #[inline(always)]
    fn eval<R: Real>(&self, row: usize, input: &[R], out: &mut [R]) {
        let d = 3 * C::ARITY;
        out[d] = self.gradient(row, input, &mut out[..d]);
        self.finish_eval(row, input, out);
    }

    #[inline(always)]
    fn vjp(&self, row: usize, input: &[f64], out_adj: &[f64], in_adj: &mut [f64]) {
        self.vjp_seeds(row, input, out_adj, in_adj);
    }

    /// Two passes over the block: every row's `C` and `∇C` first (into the row's outputs, as
    /// in [`Projection::eval`]), then every row's update, so the rows' long dependency chains
    /// (square root, then divisions) overlap.
    #[inline(always)]
    fn eval_rows(&self, first: usize, inputs: &[f64], outputs: &mut [f64]) {
        let (w, d) = (3 * C::ARITY + 1, 3 * C::ARITY);
        let rows = inputs.len() / w;
        for b in 0..rows {
            let (x, y) = (&inputs[w * b..w * b + w], &mut outputs[w * b..w * b + w]);
            y[d] = self.gradient(first + b, x, &mut y[..d]);
        }
        for b in 0..rows {
            let (x, y) = (&inputs[w * b..w * b + w], &mut outputs[w * b..w * b + w]);
            self.finish_eval(first + b, x, y);
        }
    }

    /// Passes over the block as in [`Projection::eval_rows`]: every row's `C` and `∇C`, then
    /// every row's shared quantities and adjoint up to the direction of its `∇²C·v`, then the
    /// (independent, so overlapping) Hessian–vector products, then the position adjoints.
    #[inline(always)]
    fn vjp_rows(&self, first: usize, inputs: &[f64], out_adj: &[f64], in_adj: &mut [f64]) {
        with_scratch(&VECTORS, fresh_vectors, |(g, a_g)| {
            self.vjp_block(first, inputs, out_adj, in_adj, g, a_g)
        });
    }

    const HAS_LANES: bool = C::LANES;

    /// [`Projection::eval`] of [`LANES`] rows in lanes ([`Constraint::gradient_lanes`]),
    /// bitwise: a lane whose row does not move keeps its inputs (selected, not branched on).
    #[inline(always)]
    fn eval_lanes(&self, rows: [usize; LANES], x: &[F64x8], y: &mut [F64x8]) {
        let d = 3 * C::ARITY;
        let instances = std::array::from_fn(|l| self.instances[rows[l]]);
        let c = self
            .constraint
            .gradient_lanes(instances, &x[..d], &mut y[..d]);
        let w = self.lane_masses(rows);
        let (still, _, dlambda) = self.step_lanes(x, c, y, &w);
        for j in 0..d {
            y[j] = F64x8::select(still, x[j], x[j] + y[j] * w[j / 3] * dlambda);
        }
        y[d] = F64x8::select(still, x[d], x[d] + dlambda);
    }

    /// [`Projection::vjp`] of [`LANES`] rows in lanes for several seeds (into zeros), bitwise:
    /// the adjoint of [`Projection::eval_lanes`] as `vjp_block` computes it row by row. `C`,
    /// `∇C`, `Δλ` and the reciprocal of the
    /// denominator once for all of them, and one call of [`Constraint::hessian_vectors_lanes`]
    /// for every seed's vector (each seed's adjoint of `∇C` is built in its `in_adj`).
    #[inline(always)]
    fn vjp_lanes_seeds(&self, rows: [usize; LANES], x: &[F64x8], oa: &[F64x8], ia: &mut [F64x8]) {
        let d = 3 * C::ARITY;
        let seeds = oa.len() / (d + 1);
        debug_assert!(seeds <= SEED_CHUNK && ia.len() == oa.len());
        let instances = std::array::from_fn(|l| self.instances[rows[l]]);
        let mut g = [F64x8::default(); MAX_D];
        let c = self
            .constraint
            .gradient_lanes(instances, &x[..d], &mut g[..d]);
        let w = self.lane_masses(rows);
        let (still, denom, dlambda) = self.step_lanes(x, c, &g, &w);
        let inv_denom = F64x8::splat(1.0) / denom;
        let dlambda_inv_denom = dlambda * inv_denom;
        // As `seed_head`, per seed: the adjoints of Δλ, its numerator and denominator, and of
        // ∇C (into the seed's `in_adj`, where its Hessian–vector product replaces it).
        let mut a_num = [F64x8::default(); SEED_CHUNK];
        for (s, a_num) in a_num[..seeds].iter_mut().enumerate() {
            let r = (d + 1) * s..(d + 1) * (s + 1);
            let (oa, a_g) = (&oa[r.clone()], &mut ia[r]);
            let mut a_dl = oa[d];
            for j in 0..d {
                a_dl = a_dl + w[j / 3] * g[j] * oa[j];
            }
            *a_num = a_dl * inv_denom;
            let a_den2 = F64x8::splat(-2.0) * (a_dl * dlambda_inv_denom);
            for j in 0..d {
                a_g[j] = w[j / 3] * (dlambda * oa[j] + a_den2 * g[j]);
            }
        }
        self.constraint
            .hessian_vectors_lanes(instances, &x[..d], ia, d + 1);
        // The identity part (added to zeros), then `seed_head`'s and `seed_tail`'s terms.
        let zero = F64x8::splat(0.0);
        let alpha = F64x8::splat(self.compliance);
        for (s, &a_num) in a_num[..seeds].iter().enumerate() {
            let r = (d + 1) * s..(d + 1) * (s + 1);
            let (oa, ia) = (&oa[r.clone()], &mut ia[r]);
            let id = zero + oa[d];
            ia[d] = F64x8::select(still, id, id - alpha * a_num);
            for j in 0..d {
                let id = zero + oa[j];
                ia[j] = F64x8::select(still, id, id + (ia[j] - a_num * g[j]));
            }
        }
    }

    /// `C`, `∇C`, `Δλ` and the reciprocals once for all the seeds; per seed only products and
    /// sums, and one call of [`Constraint::hessian_vectors`] for every seed's vector.
    #[inline(always)]
    fn vjp_seeds(&self, row: usize, input: &[f64], out_adj: &[f64], in_adj: &mut [f64]) {
        with_scratch(&VECTORS, fresh_vectors, |(g, a_g)| {
            self.vjp_row_seeds(row, input, out_adj, in_adj, &mut g[0], a_g)
        });
    }
}

/// Vectors of one block's rows (or one row's seeds): `∇C` and the adjoints of `∇C`.
type BlockVectors = [RowVector; ROW_BLOCK];

const _: () = assert!(
    ROW_BLOCK == SEED_CHUNK,
    "one scratch serves blocks and seeds"
);

thread_local! {
    /// Each thread's [`BlockVectors`] pair, kept so that a block does not zero 1.5 kB first
    /// (that `memset` was 2–4% of a rollout with its gradient).
    static VECTORS: std::cell::RefCell<(BlockVectors, BlockVectors)> =
        const { std::cell::RefCell::new(([[0.0; MAX_D]; ROW_BLOCK], [[0.0; MAX_D]; ROW_BLOCK])) };
}

/// A zeroed [`BlockVectors`] pair, when a caller up the stack holds this thread's.
fn fresh_vectors() -> (BlockVectors, BlockVectors) {
    ([[0.0; MAX_D]; ROW_BLOCK], [[0.0; MAX_D]; ROW_BLOCK])
}

impl<C: Constraint> Projection<C> {
    /// [`RowFn::vjp_rows`] with `g` and `a_g` as scratch for the block's `∇C` and adjoints.
    #[inline(always)]
    fn vjp_block(
        &self,
        first: usize,
        inputs: &[f64],
        out_adj: &[f64],
        in_adj: &mut [f64],
        g: &mut BlockVectors,
        a_g: &mut BlockVectors,
    ) {
        let w = 3 * C::ARITY + 1;
        let rows = inputs.len() / w;
        let mut c = [0.0; ROW_BLOCK];
        for b in 0..rows {
            c[b] = self.gradient(first + b, &inputs[w * b..w * b + w], &mut g[b]);
        }
        let mut steps = [None; ROW_BLOCK];
        let mut a_num = [0.0; ROW_BLOCK];
        for b in 0..rows {
            let (row, r) = (first + b, w * b..w * b + w);
            steps[b] = self.row_step(row, &inputs[r.clone()], c[b], &g[b]);
            add_identity::<C>(&out_adj[r.clone()], &mut in_adj[r.clone()]);
            if let Some(step) = &steps[b] {
                let (oa, ia) = (&out_adj[r.clone()], &mut in_adj[r]);
                a_num[b] = self.seed_head(row, &g[b], step, oa, ia, &mut a_g[b]);
            }
        }
        for b in 0..rows {
            if steps[b].is_some() {
                let x = &inputs[w * b..w * b + w];
                self.hessian_vectors(first + b, x, std::slice::from_mut(&mut a_g[b]));
            }
        }
        for b in 0..rows {
            if steps[b].is_some() {
                seed_tail::<C>(&g[b], a_num[b], &a_g[b], &mut in_adj[w * b..w * b + w]);
            }
        }
    }

    /// [`RowFn::vjp_seeds`] with `g` and `a_g` as scratch for the row's `∇C` and the seeds'
    /// adjoints of it.
    #[inline(always)]
    fn vjp_row_seeds(
        &self,
        row: usize,
        input: &[f64],
        out_adj: &[f64],
        in_adj: &mut [f64],
        g: &mut RowVector,
        a_g: &mut BlockVectors,
    ) {
        let w = 3 * C::ARITY + 1;
        let seeds = out_adj.len() / w;
        assert!(
            seeds <= SEED_CHUNK,
            "Projection::vjp_seeds: at most SEED_CHUNK seeds"
        );
        for s in 0..seeds {
            let r = w * s..w * s + w;
            add_identity::<C>(&out_adj[r.clone()], &mut in_adj[r]);
        }
        let c = self.gradient(row, input, g);
        let Some(step) = self.row_step(row, input, c, g) else {
            return;
        };
        let mut a_num = [0.0; SEED_CHUNK];
        for s in 0..seeds {
            let r = w * s..w * s + w;
            let (oa, ia) = (&out_adj[r.clone()], &mut in_adj[r]);
            a_num[s] = self.seed_head(row, g, &step, oa, ia, &mut a_g[s]);
        }
        self.hessian_vectors(row, input, &mut a_g[..seeds]);
        for s in 0..seeds {
            seed_tail::<C>(g, a_num[s], &a_g[s], &mut in_adj[w * s..w * s + w]);
        }
    }
}

/// The identity part of a row's update adjoint: `in_adj += out_adj` (positions and `λ`).
#[inline(always)]
fn add_identity<C: Constraint>(out_adj: &[f64], in_adj: &mut [f64]) {
    let d = 3 * C::ARITY;
    for (a, o) in in_adj[..=d].iter_mut().zip(&out_adj[..=d]) {
        *a += o;
    }
}

/// What every seed's adjoint through one moving row shares besides `∇C`: `Δλ` and the
/// reciprocal of the denominator, so a seed costs only products and sums.
#[derive(Clone, Copy)]
struct RowStep {
    /// `Δλ`.
    dlambda: f64,
    /// `1 / (Σᵢ wᵢ|∇ᵢC|² + α̃)`.
    inv_denom: f64,
    /// `Δλ / (Σᵢ wᵢ|∇ᵢC|² + α̃)`.
    dlambda_inv_denom: f64,
}

/// The position adjoints of one seed: `−a_num·∇C` (through `C`) `+ ∇²C·a_g` (through `∇C`),
/// given `hv = ∇²C·a_g`.
#[inline(always)]
fn seed_tail<C: Constraint>(g: &[f64; MAX_D], a_num: f64, hv: &[f64; MAX_D], in_adj: &mut [f64]) {
    for j in 0..3 * C::ARITY {
        in_adj[j] += hv[j] - a_num * g[j];
    }
}

impl<C: Constraint> Projection<C> {
    /// The inverse masses of the rows `rows` (as [`RowFn::eval_lanes`] hands them), point by
    /// point: a whole aligned group's from [`Projection::lane_mass`], others gathered.
    #[inline(always)]
    fn lane_masses(&self, rows: [usize; LANES]) -> [F64x8; MAX_ARITY] {
        let mut w = [F64x8::splat(0.0); MAX_ARITY];
        let first = rows[0];
        if first % LANES == 0 && rows[LANES - 1] == first + LANES - 1 {
            let group = &self.lane_mass[first / LANES * C::ARITY..][..C::ARITY];
            w[..C::ARITY].copy_from_slice(group);
        } else {
            for (i, wi) in w[..C::ARITY].iter_mut().enumerate() {
                *wi = F64x8::from_fn(|l| self.inv_mass[rows[l] * C::ARITY + i]);
            }
        }
        w
    }

    /// [`Projection::step_of`] in lanes: the lanes whose row does not move, the denominator
    /// and `Δλ` (meaningless in the lanes that do not move).
    #[inline(always)]
    fn step_lanes(
        &self,
        x: &[F64x8],
        c: F64x8,
        g: &[F64x8],
        w: &[F64x8; MAX_ARITY],
    ) -> (Mask8, F64x8, F64x8) {
        // As `weighted_sq`, lane by lane.
        let mut s = F64x8::splat(0.0);
        for i in 0..C::ARITY {
            let g = &g[3 * i..3 * i + 3];
            s = s + (g[0] * g[0] + g[1] * g[1] + g[2] * g[2]) * w[i];
        }
        let alpha = F64x8::splat(self.compliance);
        let denom = s + alpha;
        let dlambda = (-c - x[3 * C::ARITY] * alpha) / denom;
        let mut still = denom.eq_zero();
        if C::INEQUALITY {
            still = still.or(c.ge_zero());
        }
        (still, denom, dlambda)
    }

    /// `C` and `∇C` (into `g[..3·ARITY]`) of row `row` at its input positions.
    #[inline(always)]
    fn gradient<R: Real>(&self, row: usize, input: &[R], g: &mut [R]) -> R {
        let d = 3 * C::ARITY;
        value_and_gradient(
            self.constraint.as_ref(),
            self.instances[row],
            &input[..d],
            g,
        )
    }

    /// The update of row `row` in place in `out`, which holds `(∇C, C)` on entry.
    #[inline(always)]
    fn finish_eval<R: Real>(&self, row: usize, input: &[R], out: &mut [R]) {
        let d = 3 * C::ARITY;
        let Some((_, dlambda)) = self.step_of(row, input, out[d], &out[..d]) else {
            // `d` is a compile-time constant per constraint type: this unrolls to moves.
            return out[..=d].copy_from_slice(&input[..=d]);
        };
        let lambda = input[d];
        let w = &self.inv_mass[row * C::ARITY..(row + 1) * C::ARITY];
        for j in 0..d {
            out[j] = input[j] + out[j] * w[j / 3] * dlambda;
        }
        out[d] = lambda + dlambda;
    }

    /// The row's denominator `Σᵢ wᵢ|∇ᵢC|² + α̃` and `Δλ`, or `None` when the row does not move.
    #[inline(always)]
    fn step_of<R: Real>(&self, row: usize, input: &[R], c: R, g: &[R]) -> Option<(R, R)> {
        if C::INEQUALITY && c.value() >= 0.0 {
            return None;
        }
        let denom = self.weighted_sq(row, g) + self.compliance;
        if denom.value() == 0.0 {
            return None;
        }
        let dlambda = (-c - input[3 * C::ARITY] * self.compliance) / denom;
        Some((denom, dlambda))
    }

    /// What every seed's adjoint through row `row` shares (see [`RowStep`]), or `None` when the
    /// row does not move (then the identity part is the whole adjoint).
    #[inline(always)]
    fn row_step(&self, row: usize, input: &[f64], c: f64, g: &[f64; MAX_D]) -> Option<RowStep> {
        let (denom, dlambda) = self.step_of(row, input, c, g)?;
        let inv_denom = 1.0 / denom;
        Some(RowStep {
            dlambda,
            inv_denom,
            dlambda_inv_denom: dlambda * inv_denom,
        })
    }

    /// The first part of one seed's adjoint through a moving row (after the identity part):
    /// `λ`'s adjoint into `in_adj` and the adjoint `a_g` of `∇C`. Returns the adjoint of `Δλ`'s
    /// numerator.
    #[inline(always)]
    fn seed_head(
        &self,
        row: usize,
        g: &[f64; MAX_D],
        step: &RowStep,
        out_adj: &[f64],
        in_adj: &mut [f64],
        a_g: &mut [f64; MAX_D],
    ) -> f64 {
        let d = 3 * C::ARITY;
        let w = &self.inv_mass[row * C::ARITY..(row + 1) * C::ARITY];
        // Adjoint of Δλ, then of its numerator and denominator.
        let mut a_dl = out_adj[d];
        for j in 0..d {
            a_dl += w[j / 3] * g[j] * out_adj[j];
        }
        let a_num = a_dl * step.inv_denom;
        let a_den2 = -2.0 * (a_dl * step.dlambda_inv_denom);
        in_adj[d] -= self.compliance * a_num;
        // Adjoint of ∇C: from pᵢ += wᵢ∇ᵢC Δλ and from the denominator Σ wᵢ|∇ᵢC|².
        for j in 0..d {
            a_g[j] = w[j / 3] * (step.dlambda * out_adj[j] + a_den2 * g[j]);
        }
        a_num
    }

    /// `∇²C·v` of row `row` at its input positions for every vector of `vs`, in place.
    #[inline(always)]
    fn hessian_vectors(&self, row: usize, input: &[f64], vs: &mut [RowVector]) {
        let d = 3 * C::ARITY;
        self.constraint
            .hessian_vectors(self.instances[row], &input[..d], vs);
    }
}
