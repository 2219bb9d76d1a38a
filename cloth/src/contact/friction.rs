//! Coulomb friction on colliders, in position-based form (Macklin et al. 2014, "Unified particle
//! physics for real-time applications", §6.1; Müller et al. 2020, "Detailed rigid body simulation
//! with extended position based dynamics").
//!
//! When some collider of a scene has `"friction": μ > 0`, the collider group's colour set is this
//! row function instead of the frictionless [`crate::constraint::Collision`] projection. One row
//! is one free particle; besides its position `p` it carries, through the step's Gauss–Seidel
//! iterations ([`Carry::StartPosition`](crate::xpbd::set::Carry::StartPosition)):
//!
//! - `x₀`: the particle's position at the step's start (before gravity), a copy of `x_prev`, so
//!   the recorded step differentiates through it back to `x_prev`;
//! - `D`: the normal correction the contact has applied this step (the contact's multiplier in
//!   length units, `Σ |Δp_n|`);
//! - `Λ`: the friction correction applied this step (a vector).
//!
//! Each iteration, for the nearest collider (signed distance `d`, gradient `n`, coefficient `μ`):
//! 1. contact: when `d < 0`, `p ← p − d·n/|n|²` and `D ← D − d/|n|` (the collider projection);
//! 2. friction, once the particle has touched this step (`D > 0`): with `n̂ = n/|n|` and the
//!    tangential displacement since the step's start `Δx_t = (I − n̂n̂ᵀ)(p − x₀)`, the correction
//!    that would stop the particle is `Λ* = Λ − Δx_t`; Coulomb's law bounds the total correction by
//!    `μD`: `Λ' = Λ*` when `|Λ*| ≤ μD` (sticking: the particle stays where it started, along the
//!    surface), else `Λ' = μD·Λ*/|Λ*|` (sliding: the displacement is reduced by `μD`);
//!    `p ← p + Λ' − Λ`, `Λ ← Λ'`.
//!
//! Static and kinetic coefficients are equal (`μ_s = μ_k = μ`), so the correction is continuous
//! across the stick/slip switch. Accumulating `D` and `Λ` over the iterations (rather than using
//! each iteration's penetration alone) keeps a resting particle held after the first iteration has
//! already put it on the surface, and bounds the whole step's friction by `μ` times its whole
//! normal correction, as Coulomb's law bounds impulses.
//!
//! Derivatives: the reference is `autodiff`'s dual VJP of [`RowFn::eval`]
//! ([`autodiff::vjp_by_duals`]); [`RowFn::vjp`] is overridden by its closed form (the adjoint of
//! the steps above, in reverse, with the field's `∇d` and `∂n/∂p` from one `Dual<f64, 3>`
//! evaluation), which `tests/friction_adjoint.rs` holds to the dual path. Both are those of the
//! branch taken: the rollout is not differentiable where a particle starts or stops touching
//! (`d = 0`, `D = 0`) or where `|Λ*| = μD` exactly (the stick/slip switch); elsewhere it is smooth.
//!
//! A row that has not touched this step (`D = 0`) only needs to know whether `d < 0`, so it asks
//! the fields a query bounded at 0 ([`SignedDistance::distance_gradient_within`]: a mesh stops its
//! search there); a touching row asks exactly. Values are the exact query's, bit for bit.

use crate::scene::Obstacle;
use crate::sdf::{SignedDistance, Union};
use crate::xpbd::set::{Carry, ProjectionSet};
use autodiff::update::PointRows;
use autodiff::{Dual, Real, RowFn, RowIndex};
use nalgebra::{Matrix3, Vector3};
use std::sync::Arc;

/// Values each row carries besides its particle: `x₀` (3), `D` (1), `Λ` (3).
pub const CARRY_WIDTH: usize = 7;

/// The collider projection with Coulomb friction, one row per free particle.
#[derive(Clone, Debug)]
pub struct FrictionalContact {
    /// Each collider obstacle's field with its friction coefficient, in scene order.
    colliders: Vec<(Union, f64)>,
}

impl FrictionalContact {
    /// The frictional contact of a scene's colliders, or `None` when no collider has a positive
    /// `friction` (then the frictionless projection is used, exactly as without the field).
    pub fn from_obstacles(obstacles: &[Obstacle]) -> Option<FrictionalContact> {
        let colliders: Vec<(Union, f64)> = obstacles
            .iter()
            .filter(|o| o.role().is_collider())
            .map(|o| (o.field(), o.friction().unwrap_or(0.0)))
            .collect();
        colliders
            .iter()
            .any(|&(_, mu)| mu > 0.0)
            .then_some(FrictionalContact { colliders })
    }

    /// The nearest collider's signed distance and gradient at `p`, with its coefficient (the
    /// first collider on a tie, as [`Union`]), each field queried with `bound`
    /// ([`SignedDistance::distance_gradient_within`]: exact wherever the nearest distance is at
    /// most `bound`).
    #[inline(always)]
    fn nearest<R: Real>(&self, p: &Vector3<R>, bound: f64) -> (R, Vector3<R>, f64) {
        let mut best = (R::cst(f64::INFINITY), Vector3::zeros(), 0.0);
        for (k, (field, mu)) in self.colliders.iter().enumerate() {
            let (d, n) = field.distance_gradient_within(p, bound);
            if k == 0 || d.value() < best.0.value() {
                best = (d, n, *mu);
            }
        }
        best
    }
}

impl FrictionalContact {
    /// The colour set of the frictional contact on `particles` (the free particles: each row
    /// moves one, so the rows are independent), served by `autodiff`'s fixed-width kernels for
    /// one point and [`CARRY_WIDTH`] carried values ([`PointRows`]).
    pub fn projection_set(self, particles: Vec<usize>) -> ProjectionSet {
        ProjectionSet {
            projection: Arc::new(PointRows::<_, 1, CARRY_WIDTH>(self)),
            index: Arc::new(RowIndex::single(particles)),
            carry: Carry::StartPosition { width: CARRY_WIDTH },
        }
    }
}

/// What a row's projection did, for tests and diagnostics.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Regime {
    /// The particle has not touched a collider this step (`D = 0`): nothing acts.
    Free,
    /// Friction cancels the tangential displacement (`|Λ*| ≤ μD`).
    Sticking,
    /// Friction reduces the tangential displacement by its bound (`|Λ*| > μD`).
    Sliding,
}

impl FrictionalContact {
    /// The regime of one row's projection at `input` (the row's `3 + CARRY_WIDTH` values).
    #[cfg(any(test, feature = "internals"))]
    pub fn regime(&self, input: &[f64]) -> Regime {
        let mut out = [0.0; 3 + CARRY_WIDTH];
        self.project(input, &mut out)
    }

    /// The bound of a row's field query: exact once the row has touched this step (`D > 0`,
    /// friction needs the normal wherever the particle is), else only whether `d < 0`.
    fn query_bound(depth: f64) -> f64 {
        if depth > 0.0 {
            f64::INFINITY
        } else {
            0.0
        }
    }

    /// The row's update (module docs), returning its regime.
    fn project<R: Real>(&self, x: &[R], out: &mut [R]) -> Regime {
        let v = |k: usize| Vector3::new(x[k], x[k + 1], x[k + 2]);
        let (mut p, start, mut depth, mut lambda) = (v(0), v(3), x[6], v(7));
        let (d, n, mu) = self.nearest(&p, Self::query_bound(depth.value()));
        let nn = n.dot(&n);
        let mut regime = Regime::Free;
        if nn.value() > 0.0 {
            let rho = nn.sqrt();
            if d.value() < 0.0 {
                p -= n * (d / nn);
                depth -= d / rho;
            }
            if depth.value() > 0.0 {
                let unit = n / rho;
                let moved = p - start;
                let tangential = moved - unit * unit.dot(&moved);
                let stick = lambda - tangential;
                let bound = depth * mu;
                let sq = stick.dot(&stick);
                let applied = if sq.value() <= bound.value() * bound.value() {
                    regime = Regime::Sticking;
                    stick
                } else {
                    regime = Regime::Sliding;
                    stick * (bound / sq.sqrt())
                };
                p += applied - lambda;
                lambda = applied;
            }
        }
        out[..3].copy_from_slice(p.as_slice());
        out[3..6].copy_from_slice(start.as_slice());
        out[6] = depth;
        out[7..10].copy_from_slice(lambda.as_slice());
        regime
    }
}

impl RowFn for FrictionalContact {
    fn n_in(&self) -> usize {
        3 + CARRY_WIDTH
    }
    fn n_out(&self) -> usize {
        3 + CARRY_WIDTH
    }

    fn eval<R: Real>(&self, _row: usize, x: &[R], out: &mut [R]) {
        self.project(x, out);
    }

    /// The closed-form adjoint ([`FrictionalContact::linearize`], then
    /// [`Linearization::pull_back`]).
    fn vjp(&self, _row: usize, x: &[f64], out_adj: &[f64], in_adj: &mut [f64]) {
        self.linearize(x).pull_back(out_adj, in_adj);
    }

    /// One linearization for all the seeds.
    fn vjp_seeds(&self, _row: usize, x: &[f64], out_adj: &[f64], in_adj: &mut [f64]) {
        let lin = self.linearize(x);
        let w = 3 + CARRY_WIDTH;
        for (oa, ia) in out_adj.chunks_exact(w).zip(in_adj.chunks_exact_mut(w)) {
            lin.pull_back(oa, ia);
        }
    }
}

/// One row's forward values that its adjoint needs ([`FrictionalContact::linearize`]).
#[derive(Clone, Copy, Debug)]
struct Linearization {
    /// What the row did: `None` when it leaves everything unchanged (no field gradient, or not
    /// touching), else the contact's and friction's quantities.
    active: Option<Active>,
}

/// A moving row's quantities (names as in the module docs).
#[derive(Clone, Copy, Debug)]
struct Active {
    /// The field's `∇d` at `p` (derivative of the distance, from duals).
    grad_d: Vector3<f64>,
    /// `∂n/∂p`: row `i` is `∇nᵢ`.
    jac_n: Matrix3<f64>,
    /// `d`, `n`, `|n|² `, `|n|`.
    d: f64,
    n: Vector3<f64>,
    nn: f64,
    rho: f64,
    /// The friction step, when the row has touched (`D' > 0`).
    friction: Option<FrictionStep>,
}

/// The friction step's quantities of a touching row.
#[derive(Clone, Copy, Debug)]
struct FrictionStep {
    /// `n̂`, `p' − x₀` after the contact, `n̂·(p' − x₀)`.
    unit: Vector3<f64>,
    moved: Vector3<f64>,
    unit_moved: f64,
    /// `Λ* = Λ − Δx_t`, `μ`, `μD'`.
    stick: Vector3<f64>,
    mu: f64,
    bound: f64,
    /// Sliding: `|Λ*|` and `|Λ*|²` (`None` while sticking).
    sliding: Option<(f64, f64)>,
}

impl FrictionalContact {
    /// The row's forward pass at `x` (in `f64`, the branches of [`FrictionalContact::project`])
    /// with what its adjoint needs; the field's value and derivatives from one `Dual<f64, 3>`
    /// query (its values are bitwise the plain query's, so the branches are the forward's).
    fn linearize(&self, x: &[f64]) -> Linearization {
        let v = |k: usize| Vector3::new(x[k], x[k + 1], x[k + 2]);
        let (p, start, depth, lambda) = (v(0), v(3), x[6], v(7));
        let q = Vector3::from_fn(|k, _| Dual::<f64, 3>::variable(p[k], k));
        let (dd, nd, mu) = self.nearest(&q, Self::query_bound(depth));
        let (d, n) = (dd.re, nd.map(|c| c.re));
        let nn = n.dot(&n);
        if nn <= 0.0 || (d >= 0.0 && depth <= 0.0) {
            // No gradient, or free (then `D' = D ≤ 0`): the identity.
            return Linearization { active: None };
        }
        let grad_d = Vector3::from(dd.eps);
        let jac_n = Matrix3::from_fn(|i, j| nd[i].eps[j]);
        let rho = nn.sqrt();
        let (mut p1, mut depth1) = (p, depth);
        if d < 0.0 {
            p1 -= n * (d / nn);
            depth1 -= d / rho;
        }
        let friction = (depth1 > 0.0).then(|| {
            let unit = n / rho;
            let moved = p1 - start;
            let unit_moved = unit.dot(&moved);
            let stick = lambda - (moved - unit * unit_moved);
            let bound = depth1 * mu;
            let sq = stick.dot(&stick);
            let sliding = (sq > bound * bound).then(|| (sq.sqrt(), sq));
            FrictionStep {
                unit,
                moved,
                unit_moved,
                stick,
                mu,
                bound,
                sliding,
            }
        });
        Linearization {
            active: Some(Active {
                grad_d,
                jac_n,
                d,
                n,
                nn,
                rho,
                friction,
            }),
        }
    }
}

impl Linearization {
    /// `in_adj += Jᵀ out_adj` for the row (both `3 + CARRY_WIDTH` values): the steps of
    /// [`FrictionalContact::project`] in reverse.
    fn pull_back(&self, out_adj: &[f64], in_adj: &mut [f64]) {
        let v = |s: &[f64], k: usize| Vector3::new(s[k], s[k + 1], s[k + 2]);
        let Some(a) = &self.active else {
            for (i, o) in in_adj.iter_mut().zip(out_adj) {
                *i += o;
            }
            return;
        };
        let (a_p2, a_depth1, a_lambda2) = (v(out_adj, 0), out_adj[6], v(out_adj, 7));
        // The start position passes through.
        let mut a_start = v(out_adj, 3);
        let mut a_n = Vector3::zeros();
        let (a_p1, a_depth1, a_lambda) = match &a.friction {
            None => (a_p2, a_depth1, a_lambda2),
            Some(f) => {
                // p'' = p' + Λ' − Λ, Λ'' = Λ' (the applied correction).
                let a_applied = a_p2 + a_lambda2;
                let mut a_lambda = -a_p2;
                let (a_stick, a_bound) = match f.sliding {
                    None => (a_applied, 0.0),
                    Some((r, sq)) => {
                        // Λ' = Λ*·(b/|Λ*|).
                        let s_a = f.stick.dot(&a_applied);
                        let a_stick =
                            a_applied * (f.bound / r) - f.stick * (f.bound * s_a / (r * sq));
                        (a_stick, s_a / r)
                    }
                };
                // Λ* = Λ − (m − n̂(n̂·m)), m = p' − x₀.
                a_lambda += a_stick;
                let a_t = -a_stick;
                let u_at = f.unit.dot(&a_t);
                let a_moved = a_t - f.unit * u_at;
                let a_unit = -(a_t * f.unit_moved + f.moved * u_at);
                a_start -= a_moved;
                // n̂ = n/|n|.
                a_n += (a_unit - f.unit * f.unit.dot(&a_unit)) / a.rho;
                (a_p2 + a_moved, a_depth1 + f.mu * a_bound, a_lambda)
            }
        };
        let mut a_d = 0.0;
        if a.d < 0.0 {
            // The contact projected: p' = p − n·d/|n|², D' = D − d/|n|.
            let c = a.d / a.nn;
            let n_ap = a.n.dot(&a_p1);
            a_n += -a_p1 * c + a.n * (2.0 * c * n_ap / a.nn);
            a_d -= n_ap / a.nn + a_depth1 / a.rho;
            a_n += a.n * (a_depth1 * a.d / (a.rho * a.nn));
        }
        // The field: (d, n) at p.
        let a_p = a_p1 + a.grad_d * a_d + a.jac_n.transpose() * a_n;
        for k in 0..3 {
            in_adj[k] += a_p[k];
            in_adj[3 + k] += a_start[k];
            in_adj[7 + k] += a_lambda[k];
        }
        in_adj[6] += a_depth1;
    }
}
