//! The constraint terms of the Newton energy, type-erased: `C`, `∇C` and `∇²C` of one instance
//! from nested forward duals on the generic [`Constraint::c`], so any constraint type, built-in or
//! user-written, enters Newton's method without new code.

use crate::constraint::{Constraint, MAX_ARITY};
use autodiff::Dual;
use nalgebra::Vector3;
use std::sync::Arc;

/// Coordinates of the largest instance (`3 · MAX_ARITY`).
pub const MAX_DOF: usize = 3 * MAX_ARITY;

/// The instances of one constraint type with their particles and XPBD compliance.
pub trait ConstraintTerms: Send + Sync {
    /// Particles per instance.
    fn arity(&self) -> usize;
    /// True for `C ≥ 0` constraints (an energy term only while `C < 0`).
    fn inequality(&self) -> bool;
    /// Number of instances.
    fn count(&self) -> usize;
    /// The particles of instance `k`.
    fn particles(&self, k: usize) -> &[usize];
    /// `α̃ = 1/(k Δt²)`; 0 for a rigid constraint.
    fn compliance(&self) -> f64;
    /// `C` of instance `k` at its `3 · arity` coordinates `x`.
    fn value(&self, k: usize, x: &[f64]) -> f64;
    /// `C`, `∇C` (into `g[..d]`) and `∇²C` (row-major `d × d` into `h`), `d = 3 · arity`.
    fn second_order(&self, k: usize, x: &[f64], g: &mut [f64], h: &mut [f64]) -> f64;
}

/// [`ConstraintTerms`] of one constraint type.
pub struct Terms<C> {
    constraint: Arc<C>,
    particles: Vec<usize>,
    compliance: f64,
}

impl<C: Constraint> Terms<C> {
    /// The instances of `constraint` on `particles` (row-major, `ARITY` per instance).
    pub fn new(constraint: Arc<C>, particles: Vec<usize>, compliance: f64) -> Self {
        Terms {
            constraint,
            particles,
            compliance,
        }
    }
}

impl<C: Constraint> ConstraintTerms for Terms<C> {
    fn arity(&self) -> usize {
        C::ARITY
    }
    fn inequality(&self) -> bool {
        C::INEQUALITY
    }
    fn count(&self) -> usize {
        self.particles.len() / C::ARITY
    }
    fn particles(&self, k: usize) -> &[usize] {
        &self.particles[k * C::ARITY..(k + 1) * C::ARITY]
    }
    fn compliance(&self) -> f64 {
        self.compliance
    }
    fn value(&self, k: usize, x: &[f64]) -> f64 {
        let mut p = [Vector3::<f64>::zeros(); MAX_ARITY];
        for (i, pi) in p.iter_mut().take(C::ARITY).enumerate() {
            *pi = Vector3::new(x[3 * i], x[3 * i + 1], x[3 * i + 2]);
        }
        self.constraint.c(k, &p[..C::ARITY])
    }
    fn second_order(&self, k: usize, x: &[f64], g: &mut [f64], h: &mut [f64]) -> f64 {
        let c = self.constraint.as_ref();
        match C::ARITY {
            1 => second_order_n::<C, 3, 1>(c, k, x, g, h),
            2 => second_order_n::<C, 6, 2>(c, k, x, g, h),
            3 => second_order_n::<C, 9, 3>(c, k, x, g, h),
            4 => second_order_n::<C, 12, 4>(c, k, x, g, h),
            a => panic!("constraint arity {a} is not supported (1 to {MAX_ARITY})"),
        }
    }
}

/// `C`, `∇C` and `∇²C` by forward-over-forward duals in all `D` directions.
fn second_order_n<C: Constraint, const D: usize, const A: usize>(
    c: &C,
    instance: usize,
    x: &[f64],
    g: &mut [f64],
    h: &mut [f64],
) -> f64 {
    type Inner<const D: usize> = Dual<f64, D>;
    let mut p = [Vector3::<Dual<Inner<D>, D>>::zeros(); A];
    for (i, pi) in p.iter_mut().enumerate() {
        for k in 0..3 {
            let j = 3 * i + k;
            // Outer direction j over inner direction j: `eps[a].eps[b]` is `∂²C/∂xₐ∂x_b`.
            let mut v = Dual::<Inner<D>, D>::constant(Inner::<D>::variable(x[j], j));
            v.eps[j] = Inner::<D>::constant(1.0);
            pi[k] = v;
        }
    }
    let r = c.c(instance, &p);
    g[..D].copy_from_slice(&r.re.eps);
    for (row, e) in h.chunks_exact_mut(D).zip(&r.eps) {
        row.copy_from_slice(&e.eps);
    }
    r.re.re
}
