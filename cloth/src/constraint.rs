//! Constraints written once as a generic function `C(p₀ … pₖ₋₁)`; every derivative comes from
//! `autodiff`.
//!
//! A new constraint type implements [`Constraint`]: its arity, whether it is an inequality, and
//! `c` generically over [`Real`]. The XPBD projection obtains `∇C` by evaluating `c` on forward
//! duals, and the backward pass differentiates that projection again (nested duals). Nothing is
//! derived by hand.

use autodiff::{Dual, Real};
use nalgebra::Vector3;

/// The largest arity a constraint may have (its gradient is carried by `Dual<_, 3·arity>`).
pub const MAX_ARITY: usize = 4;

/// A positional constraint `C(p₀ … pₖ₋₁) = 0` (or `≥ 0` for an inequality) on `ARITY` particles.
///
/// `instance` identifies which of the type's constraints is evaluated, so per-instance data such
/// as rest lengths lives in `self`.
pub trait Constraint: Send + Sync + 'static {
    /// Particles per instance, 1 to [`MAX_ARITY`].
    const ARITY: usize;
    /// True for `C ≥ 0` constraints, projected only when violated.
    const INEQUALITY: bool = false;
    /// The constraint function of `instance` at particle positions `p` (`p.len() == ARITY`).
    fn c<R: Real>(&self, instance: usize, p: &[Vector3<R>]) -> R;
}

/// `C` and `∇C` of one instance: `grad[3·i + k] = ∂C/∂pᵢₖ`. `x` holds `3·ARITY` coordinates.
#[inline(always)]
pub fn value_and_gradient<C: Constraint, R: Real>(
    c: &C,
    instance: usize,
    x: &[R],
    grad: &mut [R],
) -> R {
    match C::ARITY {
        1 => value_and_gradient_n::<C, R, 3, 1>(c, instance, x, grad),
        2 => value_and_gradient_n::<C, R, 6, 2>(c, instance, x, grad),
        3 => value_and_gradient_n::<C, R, 9, 3>(c, instance, x, grad),
        4 => value_and_gradient_n::<C, R, 12, 4>(c, instance, x, grad),
        a => panic!("constraint arity {a} is not supported (1 to {MAX_ARITY})"),
    }
}

#[inline(always)]
fn value_and_gradient_n<C: Constraint, R: Real, const D: usize, const A: usize>(
    c: &C,
    instance: usize,
    x: &[R],
    grad: &mut [R],
) -> R {
    // A plain loop, not `array::from_fn`: its closure was not inlined, which kept every seed
    // in memory and cost more than the constraint itself.
    let mut p = [Vector3::<Dual<R, D>>::zeros(); A];
    for (i, pi) in p.iter_mut().enumerate() {
        for k in 0..3 {
            pi[k] = Dual::variable(x[3 * i + k], 3 * i + k);
        }
    }
    let v = c.c(instance, &p);
    grad[..D].copy_from_slice(&v.eps);
    v.re
}

/// `|v|` through [`Real::sqrt`], so a zero vector has gradient 0.
#[inline]
pub fn norm<R: Real>(v: &Vector3<R>) -> R {
    v.dot(v).sqrt()
}

/// `C = |p₀ − p₁| − d⁰`: the paper's stretch and (distance-type) bending constraint.
#[derive(Clone, Debug)]
pub struct Distance {
    /// Rest length `d⁰` per instance.
    pub rest: Vec<f64>,
}

impl Constraint for Distance {
    const ARITY: usize = 2;
    #[inline(always)]
    fn c<R: Real>(&self, instance: usize, p: &[Vector3<R>]) -> R {
        norm(&(p[0] - p[1])) - self.rest[instance]
    }
}

/// Dihedral-angle bending on two triangles sharing the edge `p₀p₁`, with opposite vertices `p₂`
/// (first triangle) and `p₃` (second): `C = φ − φ⁰`, `φ` the signed angle between the triangle
/// normals about the shared edge, computed with `atan2` so it stays smooth through flat (`φ = 0`).
#[derive(Clone, Debug)]
pub struct DihedralBending {
    /// Rest angle `φ⁰` per instance.
    pub rest: Vec<f64>,
}

impl DihedralBending {
    /// The signed dihedral angle of the four points.
    pub fn angle<R: Real>(p: &[Vector3<R>]) -> R {
        let e = p[1] - p[0];
        let n1 = (p[2] - p[0]).cross(&e);
        let n2 = e.cross(&(p[3] - p[0]));
        let sin = n1.cross(&n2).dot(&e) / norm(&e);
        let cos = n1.dot(&n2);
        sin.atan2(cos)
    }
}

impl Constraint for DihedralBending {
    const ARITY: usize = 4;
    fn c<R: Real>(&self, instance: usize, p: &[Vector3<R>]) -> R {
        Self::angle(p) - self.rest[instance]
    }
}

/// A physical collider on single particles: `C = SDF(p) ≥ 0` for a signed-distance field.
#[derive(Clone, Debug)]
pub struct Collision<S> {
    /// The obstacle's signed distance.
    pub sdf: S,
}

impl<S: crate::sdf::SignedDistance> Constraint for Collision<S> {
    const ARITY: usize = 1;
    const INEQUALITY: bool = true;
    #[inline(always)]
    fn c<R: Real>(&self, _instance: usize, p: &[Vector3<R>]) -> R {
        self.sdf.distance(&p[0])
    }
}
