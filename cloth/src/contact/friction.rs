//! Coulomb friction on colliders, in position-based form (Macklin et al. 2014, "Unified particle
//! physics for real-time applications", §6.1; Müller et al. 2020, "Detailed rigid body simulation
//! with extended position based dynamics").
//!
//! When some collider of a scene has `"friction": μ > 0`, the collider group's colour set is this
//! row function instead of the frictionless [`crate::constraint::Collision`] projection. One row
//! is one free particle; besides its position `p` it carries, through the step's Gauss–Seidel
//! iterations ([`Carry::StartPosition`](crate::model::Carry::StartPosition)):
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
//! Derivatives come from `autodiff`'s dual VJP of [`RowFn::eval`] (nothing hand-written). They are
//! those of the branch taken: the rollout is not differentiable where a particle starts or stops
//! touching (`d = 0`, `D = 0`) or where `|Λ*| = μD` exactly (the stick/slip switch); elsewhere it
//! is smooth.

use crate::model::{Carry, ProjectionSet};
use crate::scene::Obstacle;
use crate::sdf::{SignedDistance, Union};
use autodiff::{Real, RowFn, RowIndex};
use nalgebra::Vector3;
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
    /// first collider on a tie, as [`Union`]).
    fn nearest<R: Real>(&self, p: &Vector3<R>) -> (R, Vector3<R>, f64) {
        let mut best = (R::cst(f64::INFINITY), Vector3::zeros(), 0.0);
        for (k, (field, mu)) in self.colliders.iter().enumerate() {
            let (d, n) = field.distance_gradient(p);
            if k == 0 || d.value() < best.0.value() {
                best = (d, n, *mu);
            }
        }
        best
    }
}

impl FrictionalContact {
    /// The colour set of the frictional contact on `particles` (the free particles: each row
    /// moves one, so the rows are independent).
    pub fn projection_set(self, particles: Vec<usize>) -> ProjectionSet {
        ProjectionSet {
            projection: Arc::new(self),
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
    pub fn regime(&self, input: &[f64]) -> Regime {
        let mut out = [0.0; 3 + CARRY_WIDTH];
        self.project(input, &mut out)
    }

    /// The row's update (module docs), returning its regime.
    fn project<R: Real>(&self, x: &[R], out: &mut [R]) -> Regime {
        let v = |k: usize| Vector3::new(x[k], x[k + 1], x[k + 2]);
        let (mut p, start, mut depth, mut lambda) = (v(0), v(3), x[6], v(7));
        let (d, n, mu) = self.nearest(&p);
        let nn = n.dot(&n);
        let mut regime = Regime::Free;
        if nn.value() > 0.0 {
            if d.value() < 0.0 {
                p -= n * (d / nn);
                depth -= d / nn.sqrt();
            }
            if depth.value() > 0.0 {
                let unit = n / nn.sqrt();
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
}
