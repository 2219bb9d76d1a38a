//! The constraint terms of the Newton energy, type-erased: `C`, `∇C` and `∇²C` of one instance
//! through the type's [`Constraint::gradient`] and [`Constraint::hessian_vectors`], whose
//! defaults are forward duals on the generic [`Constraint::c`], so any constraint type, built-in
//! or user-written, enters Newton's method without new code, and a type with closed-form
//! derivatives assembles with them.

use crate::constraint::{Constraint, MAX_ARITY};
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
    /// True when `C` is affine in the positions ([`crate::constraint::Constraint::LINEAR`]).
    fn linear(&self) -> bool {
        false
    }
    /// Number of instances.
    fn count(&self) -> usize;
    /// The particles of instance `k`.
    fn particles(&self, k: usize) -> &[usize];
    /// `α̃ = 1/(k Δt²)`; 0 for a rigid constraint.
    fn compliance(&self) -> f64;
    /// `C` of instance `k` at its `3 · arity` coordinates `x`.
    fn value(&self, k: usize, x: &[f64]) -> f64;
    /// `C` and `∇C` (into `g[..d]`), `d = 3 · arity`: [`ConstraintTerms::second_order`]
    /// without the Hessian, the same values bit for bit.
    fn first_order(&self, k: usize, x: &[f64], g: &mut [f64]) -> f64;
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
    fn linear(&self) -> bool {
        C::LINEAR && !C::INEQUALITY
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
    fn first_order(&self, k: usize, x: &[f64], g: &mut [f64]) -> f64 {
        let d = 3 * C::ARITY;
        self.constraint.gradient(k, &x[..d], &mut g[..d])
    }
    fn second_order(&self, k: usize, x: &[f64], g: &mut [f64], h: &mut [f64]) -> f64 {
        let c = self.constraint.as_ref();
        match C::ARITY {
            1 => second_order_n::<C, 3>(c, k, x, g, h),
            2 => second_order_n::<C, 6>(c, k, x, g, h),
            3 => second_order_n::<C, 9>(c, k, x, g, h),
            4 => second_order_n::<C, 12>(c, k, x, g, h),
            a => panic!("constraint arity {a} is not supported (1 to {MAX_ARITY})"),
        }
    }
}

/// `C`, `∇C` and `∇²C` through the type's [`Constraint::gradient`] and
/// [`Constraint::hessian_vectors`] on the `D` unit vectors: closed form where the type overrides
/// them (`Distance`'s `∇²C` costs a few products instead of a nested dual 49 numbers wide),
/// forward duals on the generic `C` where it does not.
fn second_order_n<C: Constraint, const D: usize>(
    c: &C,
    instance: usize,
    x: &[f64],
    g: &mut [f64],
    h: &mut [f64],
) -> f64 {
    let value = c.gradient(instance, &x[..D], &mut g[..D]);
    let mut columns = [[0.0; MAX_DOF]; D];
    for (j, col) in columns.iter_mut().enumerate() {
        col[j] = 1.0;
    }
    c.hessian_vectors(instance, &x[..D], &mut columns);
    // `∇²C eⱼ` is column j, which is row j of the symmetric `∇²C`.
    for (row, col) in h.chunks_exact_mut(D).zip(&columns) {
        row.copy_from_slice(&col[..D]);
    }
    value
}

#[cfg(test)]
mod tests {
    use super::{ConstraintTerms, Terms};
    use crate::constraint::{Collision, Constraint, DihedralBending, Distance, Generic};
    use crate::sdf::SphereSet;
    use proptest::prelude::*;
    use std::sync::Arc;

    /// `(C, ∇C, ∇²C)` of instance 0 at `x`.
    fn second_order<C: Constraint>(c: C, x: &[f64]) -> (f64, Vec<f64>, Vec<f64>) {
        let d = 3 * C::ARITY;
        let terms = Terms::new(Arc::new(c), (0..C::ARITY).collect(), 1.0);
        let (mut g, mut h) = (vec![0.0; d], vec![0.0; d * d]);
        let v = terms.second_order(0, &x[..d], &mut g, &mut h);
        // Without the Hessian: the same `C` and `∇C`, bit for bit.
        let mut g1 = vec![0.0; d];
        let v1 = terms.first_order(0, &x[..d], &mut g1);
        assert_eq!(v1.to_bits(), v.to_bits());
        assert!(g1.iter().zip(&g).all(|(a, b)| a.to_bits() == b.to_bits()));
        (v, g, h)
    }

    /// The closed-form path (the type's overrides) against the dual path (`Generic`), and the
    /// Hessian against central differences of the gradient.
    fn check<C: Constraint + Clone>(c: C, x: &[f64]) -> Result<(), TestCaseError> {
        let d = 3 * C::ARITY;
        let (v, g, h) = second_order(c.clone(), x);
        let (vr, gr, hr) = second_order(Generic(c.clone()), x);
        let close = |a: f64, b: f64, tol: f64| (a - b).abs() <= tol * (1.0 + a.abs().max(b.abs()));
        prop_assert!(close(v, vr, 1e-14), "C {v} vs {vr}");
        for (a, b) in g.iter().zip(&gr).chain(h.iter().zip(&hr)) {
            prop_assert!(
                close(*a, *b, 1e-12),
                "{a} vs {b}: {g:?} {h:?} vs {gr:?} {hr:?}"
            );
        }
        let eps = 1e-6;
        for j in 0..d {
            let (mut xp, mut xm) = (x.to_vec(), x.to_vec());
            xp[j] += eps;
            xm[j] -= eps;
            let (gp, gm) = (
                second_order(c.clone(), &xp).1,
                second_order(c.clone(), &xm).1,
            );
            for i in 0..d {
                let fd = (gp[i] - gm[i]) / (2.0 * eps);
                prop_assert!(
                    close(h[i * d + j], fd, 1e-5),
                    "∇²C[{i},{j}] {} vs {fd}",
                    h[i * d + j]
                );
            }
        }
        Ok(())
    }

    proptest! {
        #[test]
        fn second_order_matches_the_dual_path_and_differences(
            x in proptest::collection::vec(-1.0f64..1.0, 12),
        ) {
            // Points spread apart so lengths and angles stay away from their kinks.
            let x: Vec<f64> = x.iter().enumerate().map(|(i, v)| v + (i / 3) as f64 * 1.5).collect();
            check(Distance { rest: vec![0.7] }, &x)?;
            check(DihedralBending { rest: vec![0.3] }, &[x[0], x[1], x[2], x[3], x[4], x[5],
                x[6] + 0.5, x[7] - 2.0, x[8], x[9] - 1.0, x[10] + 1.0, x[11] - 3.0])?;
            let spheres = SphereSet { centers: vec![[0.2, -0.1, 0.3], [1.0, 1.0, 1.0]], radii: vec![0.5, 0.25] };
            check(Collision { sdf: spheres }, &x)?;
        }
    }
}
