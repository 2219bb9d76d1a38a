//! Constraints written once as a generic function `C(p₀ … pₖ₋₁)`; every derivative can come
//! from `autodiff`.
//!
//! A new constraint type implements [`Constraint`]: its arity, whether it is an inequality, and
//! `c` generically over [`Real`]. That is all it needs: the XPBD projection then obtains `∇C` by
//! evaluating `c` on forward duals, and the backward pass `∇²C·v` from nested duals.
//!
//! A type may also override [`Constraint::gradient`] (a closed-form `∇C`, still generic over
//! [`Real`], so forward duals through it give `∇²C·v`) and [`Constraint::hessian_vectors`] (a
//! closed-form `∇²C·v` for several vectors at once), like a `custom_vjp`. The built-ins do; `tests/overrides.rs` checks each
//! override against the generic dual derivative, which [`Generic`] exposes for any constraint.
//!
//! # Conventions where `C` is not differentiable
//! The overrides return what the dual path returns there, which follows `autodiff`'s conventions:
//! - [`Distance`] at coincident particles (`|p₀ − p₁|² = 0`): `∇C = 0` and `∇²C·v = 0`;
//! - [`DihedralBending`] where `sin φ` and `cos φ` are both exactly 0 (a degenerate triangle):
//!   `∇C = 0`, `∇²C·v = 0`; with a zero-length shared edge `C` itself is NaN, as generically;
//! - a sphere at its centre: gradient 0, `∇²C·v = 0`; a tie between obstacles: the first one's
//!   derivatives (as [`Real::min`]).

use crate::geometry::{point, write_points};
use autodiff::simd::{read_lane, write_lane, LANES};
use autodiff::{Dual, F64x8, Real};
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
    /// True when `C` is affine in the positions (`∇²C = 0`, `∇C` the same everywhere): Newton's
    /// assembly then adds `k∇C∇Cᵀ`, the same at every state, from a sum made once per pattern.
    /// Claiming it for a constraint that is not affine gives Newton a wrong Hessian.
    const LINEAR: bool = false;
    /// The constraint function of `instance` at particle positions `p` (`p.len() == ARITY`).
    fn c<R: Real>(&self, instance: usize, p: &[Vector3<R>]) -> R;

    /// `C` and `∇C` of `instance`: `grad[3·i + k] = ∂C/∂pᵢₖ`; `x` holds `3·ARITY` coordinates.
    ///
    /// The default takes `∇C` from forward duals on [`Constraint::c`]. An override must agree
    /// with it (to rounding, and at the non-differentiable points listed in the module docs).
    #[inline(always)]
    fn gradient<R: Real>(&self, instance: usize, x: &[R], grad: &mut [R]) -> R
    where
        Self: Sized,
    {
        value_and_gradient_by_duals(self, instance, x, grad)
    }

    /// Whether [`Constraint::gradient_lanes`] is a lane-wise override: the XPBD sweep then
    /// projects this type's rows four at a time through it where the CPU has AVX2.
    const LANES: bool = false;

    /// `C` and `∇C` of four instances at once: lane `l` of `x[i]` and `grad[i]` belongs to
    /// `instances[l]`. An override (with [`Constraint::LANES`]) must give
    /// [`Constraint::gradient`]'s values bit for bit in every lane (the same operations in the
    /// same order, no fused multiply–add). The default calls [`Constraint::gradient`] per lane.
    #[inline(always)]
    fn gradient_lanes(&self, instances: [usize; LANES], x: &[F64x8], grad: &mut [F64x8]) -> F64x8
    where
        Self: Sized,
    {
        let (mut xl, mut gl) = ([0.0; MAX_D], [0.0; MAX_D]);
        let mut c = F64x8::splat(0.0);
        for (l, &instance) in instances.iter().enumerate() {
            read_lane(x, l, &mut xl);
            c.0[l] = self.gradient(instance, &xl[..x.len()], &mut gl[..x.len()]);
            write_lane(grad, l, &gl);
        }
        c
    }

    /// `∇²C(x)·v` of [`LANES`] instances at once for several vectors, in place: vector `s`
    /// is `vs[stride·s .. stride·s + 3·ARITY]` (`stride ≥ 3·ARITY`; the entries between vectors
    /// are left alone), and lane `l` of `x[i]` and of every vector belongs to `instances[l]`.
    /// An override (with [`Constraint::LANES`]) must give [`Constraint::hessian_vectors`]'
    /// values bit for bit in every lane. The default calls [`Constraint::hessian_vectors`] per
    /// lane, for up to eight vectors at a time.
    #[inline(always)]
    fn hessian_vectors_lanes(
        &self,
        instances: [usize; LANES],
        x: &[F64x8],
        vs: &mut [F64x8],
        stride: usize,
    ) where
        Self: Sized,
    {
        let d = 3 * Self::ARITY;
        let mut xl = [0.0; MAX_D];
        let mut vl = [[0.0; MAX_D]; 8];
        let vectors = vs.len().div_ceil(stride);
        for first in (0..vectors).step_by(8) {
            let chunk = first..vectors.min(first + 8);
            for (l, &instance) in instances.iter().enumerate() {
                read_lane(&x[..d], l, &mut xl);
                for (s, row) in chunk.clone().zip(vl.iter_mut()) {
                    read_lane(&vs[stride * s..stride * s + d], l, row);
                }
                self.hessian_vectors(instance, &xl[..d], &mut vl[..chunk.len()]);
                for (s, row) in chunk.clone().zip(vl.iter()) {
                    write_lane(&mut vs[stride * s..stride * s + d], l, &row[..d]);
                }
            }
        }
    }

    /// `∇²C(x)·v` for several vectors `v` at once, in place: each `vs[s][..3·ARITY]` in, its
    /// product out. The XPBD backward pass calls it with every seed's vector of a row, so what
    /// the vectors share (the point's own quantities, reciprocals) is computed once.
    ///
    /// The default is the forward-mode derivative of [`Constraint::gradient`] along every
    /// vector at once: one evaluation on duals as wide as the vectors (nested duals when
    /// `gradient` is not overridden), each vector's product bitwise that of a width-1 dual.
    /// This is the method to override for a closed-form `∇²C·v`.
    #[inline(always)]
    fn hessian_vectors(&self, instance: usize, x: &[f64], vs: &mut [RowVector])
    where
        Self: Sized,
    {
        hessian_vectors_by_duals(self, instance, x, vs)
    }
}

/// One instance's coordinates (or a vector over them), padded to the largest arity. Entries past
/// `3·ARITY` are scratch: the XPBD kernels may leave any value there, and none is read back.
pub type RowVector = [f64; MAX_D];

/// Any constraint with its derivative overrides hidden: [`Constraint::gradient`] and
/// [`Constraint::hessian_vectors`] take their generic dual defaults. The reference the overrides
/// are tested against, and the generic side of the `generality` bench.
#[derive(Clone, Debug)]
pub struct Generic<C>(pub C);

impl<C: Constraint> Constraint for Generic<C> {
    const ARITY: usize = C::ARITY;
    const INEQUALITY: bool = C::INEQUALITY;
    #[inline(always)]
    fn c<R: Real>(&self, instance: usize, p: &[Vector3<R>]) -> R {
        self.0.c(instance, p)
    }
}

/// `C` and `∇C` of one instance through the type's [`Constraint::gradient`] (closed form where
/// the type provides one): `grad[3·i + k] = ∂C/∂pᵢₖ`. `x` holds `3·ARITY` coordinates.
#[inline(always)]
pub fn value_and_gradient<C: Constraint, R: Real>(
    c: &C,
    instance: usize,
    x: &[R],
    grad: &mut [R],
) -> R {
    c.gradient(instance, x, grad)
}

/// `C` and `∇C` of one instance from forward duals on the generic `C` (the default of
/// [`Constraint::gradient`]).
#[inline(always)]
pub fn value_and_gradient_by_duals<C: Constraint, R: Real>(
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

/// `∇²C(x)·v` of `instance` for one vector, in place: `v` (`3·ARITY` entries) in, the product
/// out; [`Constraint::hessian_vectors`] of one vector. A free function, not a trait method, so a
/// type cannot override it by mistake (the projection calls `hessian_vectors`, which is the one
/// to override).
#[inline(always)]
pub fn hessian_vector<C: Constraint>(c: &C, instance: usize, x: &[f64], v: &mut [f64]) {
    let d = 3 * C::ARITY;
    let mut vs = [[0.0; MAX_D]];
    vs[0][..d].copy_from_slice(&v[..d]);
    c.hessian_vectors(instance, x, &mut vs);
    v[..d].copy_from_slice(&vs[0][..d]);
}

/// `∇²C(x)·v` of one instance, in place in `v`, as the derivative of [`Constraint::gradient`]
/// along `v` by a forward dual.
#[inline(always)]
pub fn hessian_vector_by_duals<C: Constraint>(c: &C, instance: usize, x: &[f64], v: &mut [f64]) {
    let d = 3 * C::ARITY;
    let mut vs = [[0.0; MAX_D]];
    vs[0][..d].copy_from_slice(&v[..d]);
    hessian_vectors_n::<C, 1>(c, instance, x, &mut vs);
    v[..d].copy_from_slice(&vs[0][..d]);
}

/// `∇²C(x)·v` of one instance for every vector of `vs`, in place, as the derivative of
/// [`Constraint::gradient`] along all of them by one forward dual (the default of
/// [`Constraint::hessian_vectors`]); its width is the next of 1, 4 or 8 at or above `vs.len()`,
/// and more vectors go in groups of 8.
#[inline(always)]
pub fn hessian_vectors_by_duals<C: Constraint>(
    c: &C,
    instance: usize,
    x: &[f64],
    vs: &mut [RowVector],
) {
    for group in vs.chunks_mut(8) {
        match group.len() {
            1 => hessian_vectors_n::<C, 1>(c, instance, x, group),
            2..=4 => hessian_vectors_n::<C, 4>(c, instance, x, group),
            _ => hessian_vectors_n::<C, 8>(c, instance, x, group),
        }
    }
}

/// [`hessian_vectors_by_duals`] with a dual of width `N ≥ vs.len()` (unused lanes carry 0).
#[inline(always)]
fn hessian_vectors_n<C: Constraint, const N: usize>(
    c: &C,
    instance: usize,
    x: &[f64],
    vs: &mut [RowVector],
) {
    type T<const N: usize> = Dual<f64, N>;
    let d = 3 * C::ARITY;
    let mut xt = [T::<N>::constant(0.0); MAX_D];
    for (j, xj) in xt[..d].iter_mut().enumerate() {
        xj.re = x[j];
        for (e, v) in xj.eps.iter_mut().zip(vs.iter()) {
            *e = v[j];
        }
    }
    let mut g = [T::<N>::constant(0.0); MAX_D];
    c.gradient(instance, &xt[..d], &mut g[..d]);
    for (s, v) in vs.iter_mut().enumerate() {
        for (h, e) in v[..d].iter_mut().zip(&g) {
            *h = e.eps[s];
        }
    }
}

/// Coordinates per instance of the largest arity.
const MAX_D: usize = 3 * MAX_ARITY;

/// `|v|` through [`Real::sqrt`] (re-exported from `cloth/src/geometry.rs` for constraint authors).
pub use crate::geometry::norm;

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

    /// `∇C = ±(p₀ − p₁)/|p₀ − p₁|`, bitwise the dual path's (both scale by `1/|p₀ − p₁|`).
    #[inline(always)]
    fn gradient<R: Real>(&self, instance: usize, x: &[R], g: &mut [R]) -> R {
        let d = point(x, 0) - point(x, 1);
        let s = d.dot(&d);
        let n = s.sqrt();
        if s.value() == 0.0 {
            g[..6].fill(R::zero());
        } else {
            let inv = n.recip();
            for k in 0..3 {
                g[k] = d[k] * inv;
                g[k + 3] = -g[k];
            }
        }
        n - self.rest[instance]
    }

    const LANES: bool = true;

    /// [`Distance::gradient`] in four lanes, bitwise.
    #[inline(always)]
    fn gradient_lanes(&self, instances: [usize; LANES], x: &[F64x8], g: &mut [F64x8]) -> F64x8 {
        let d = [x[0] - x[3], x[1] - x[4], x[2] - x[5]];
        let s = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
        let n = s.sqrt();
        let (zero, inv) = (s.eq_zero(), F64x8::splat(1.0) / n);
        for k in 0..3 {
            let gk = d[k] * inv;
            g[k] = F64x8::select(zero, F64x8::splat(0.0), gk);
            g[k + 3] = F64x8::select(zero, F64x8::splat(0.0), -gk);
        }
        n - F64x8::from_fn(|l| self.rest[instances[l]])
    }

    /// [`Distance::hessian_vectors`] in lanes, bitwise: `1/|d|` and `u` once for all vectors.
    #[inline(always)]
    fn hessian_vectors_lanes(
        &self,
        _instances: [usize; LANES],
        x: &[F64x8],
        vs: &mut [F64x8],
        stride: usize,
    ) {
        let d = [x[0] - x[3], x[1] - x[4], x[2] - x[5]];
        let s = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
        let (zero, inv) = (s.eq_zero(), F64x8::splat(1.0) / s.sqrt());
        let u = d.map(|dk| dk * inv);
        for v in vs.chunks_mut(stride) {
            let delta = [v[0] - v[3], v[1] - v[4], v[2] - v[5]];
            let t = u[0] * delta[0] + u[1] * delta[1] + u[2] * delta[2];
            for k in 0..3 {
                let h = (delta[k] - u[k] * t) * inv;
                v[k] = F64x8::select(zero, F64x8::splat(0.0), h);
                v[k + 3] = F64x8::select(zero, F64x8::splat(0.0), -h);
            }
        }
    }

    /// `∇²C·v`: `±(δ − u(u·δ))/|d|` with `d = p₀ − p₁`, `u = d/|d|`, `δ = v₀ − v₁`; `1/|d|`
    /// and `u` once for all the vectors, then only products and sums per vector.
    #[inline(always)]
    fn hessian_vectors(&self, _instance: usize, x: &[f64], vs: &mut [RowVector]) {
        let d = point(x, 0) - point(x, 1);
        let s = d.dot(&d);
        if s == 0.0 {
            return vs.iter_mut().for_each(|v| v[..6].fill(0.0));
        }
        let inv = s.sqrt().recip();
        let u = d * inv;
        for v in vs {
            let delta = point(v, 0) - point(v, 1);
            let h = (delta - u * u.dot(&delta)) * inv;
            for k in 0..3 {
                v[k] = h[k];
                v[k + 3] = -h[k];
            }
        }
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

    /// `∇φ` by the chain rule through [`DihedralBending::angle`]'s own steps, written out: with
    /// `e = p₁ − p₀`, `a = p₂ − p₀`, `b = p₃ − p₀`, `n₁ = a × e`, `n₂ = e × b`,
    /// `T = (n₁ × n₂)·e`, `S = T/|e|`, `K = n₁·n₂`, `φ = atan2(S, K)`.
    #[inline(always)]
    fn gradient<R: Real>(&self, instance: usize, x: &[R], g: &mut [R]) -> R {
        let p0 = point(x, 0);
        let e = point(x, 1) - p0;
        let a = point(x, 2) - p0;
        let b = point(x, 3) - p0;
        let n1 = a.cross(&e);
        let n2 = e.cross(&b);
        let m = n1.cross(&n2);
        let t = m.dot(&e);
        let l = norm(&e);
        let sin = t / l;
        let cos = n1.dot(&n2);
        let phi = sin.atan2(cos) - self.rest[instance];
        let r2 = sin * sin + cos * cos;
        if r2.value() == 0.0 {
            g[..12].fill(R::zero());
            return phi;
        }
        let inv = r2.recip();
        // Adjoints of S and K, then of n₁, n₂ and e (through S = T/|e| directly).
        let (a_s, a_k) = (cos * inv, -(sin * inv));
        let a_sl = a_s / l;
        let g_n1 = n2.cross(&e) * a_sl + n2 * a_k;
        let g_n2 = e.cross(&n1) * a_sl + n1 * a_k;
        let g_e = (m - e * (t / (l * l))) * a_sl + g_n1.cross(&a) + b.cross(&g_n2);
        let g_a = e.cross(&g_n1);
        let g_b = g_n2.cross(&e);
        let g_0 = -(g_e + g_a + g_b);
        write_points(g, [g_0, g_e, g_a, g_b]);
        phi
    }
}

/// Quadratic (isometric) bending on the two triangles sharing the edge `p₀p₁`, with opposite
/// vertices `p₂` (first triangle) and `p₃` (second), after Bergou et al., "A quadratic bending
/// model for inextensible surfaces" (2006): `C = (Σᵢ wᵢ pᵢ)ₐ`, one instance per coordinate axis
/// `a`, with `wᵢ = √(3/(A₀ + A₁))·Kᵢ` from the rest triangles' areas and cotangent weights
/// ([`IsometricBending::weights`]). `½k Σₐ C²` is the discrete Willmore energy of the stencil for
/// a cloth whose rest shape is flat and which bends without stretching. Every instance is linear
/// in the positions, so the model has no singular configuration: it stays smooth through a
/// crease folded flat, where the distance model's pair of particles meets and the dihedral
/// angle passes ±π.
#[derive(Clone, Debug)]
pub struct IsometricBending {
    /// The weights `wᵢ` of `p₀ … p₃` per instance.
    pub weights: Vec<[f64; 4]>,
    /// The coordinate axis (0, 1 or 2) per instance.
    pub axis: Vec<usize>,
}

impl IsometricBending {
    /// The weights `√(3/(A₀ + A₁))·K` of a stencil at rest, `K = (c₀₃ + c₀₄, c₀₁ + c₀₂,
    /// −c₀₁ − c₀₃, −c₀₂ − c₀₄)` with `c₀ⱼ` the cotangent of the angle between the shared edge and
    /// edge `j` (Bergou et al. 2006, eq. 7), and `A₀`, `A₁` the triangles' areas; `None` for a
    /// degenerate triangle. The weights sum to 0, and `Σᵢ Kᵢ pᵢ = 0` when the four points lie in a
    /// plane (the cotangent Laplacian's linear precision).
    pub fn weights(p: &[Vector3<f64>; 4]) -> Option<[f64; 4]> {
        let e0 = p[1] - p[0];
        let (e1, e2) = (p[2] - p[0], p[3] - p[0]);
        let (e3, e4) = (p[2] - p[1], p[3] - p[1]);
        let cot = |u: &Vector3<f64>, v: &Vector3<f64>| u.dot(v) / u.cross(v).norm();
        let (c01, c02) = (cot(&e0, &e1), cot(&e0, &e2));
        let (c03, c04) = (cot(&-e0, &e3), cot(&-e0, &e4));
        let area = 0.5 * (e0.cross(&e1).norm() + e0.cross(&e2).norm());
        let scale = (3.0 / area).sqrt();
        let k = [c03 + c04, c01 + c02, -c01 - c03, -c02 - c04].map(|k| scale * k);
        k.iter().all(|k| k.is_finite()).then_some(k)
    }
}

impl Constraint for IsometricBending {
    const ARITY: usize = 4;
    const LINEAR: bool = true;
    #[inline(always)]
    fn c<R: Real>(&self, instance: usize, p: &[Vector3<R>]) -> R {
        let (w, a) = (&self.weights[instance], self.axis[instance]);
        p[0][a] * w[0] + p[1][a] * w[1] + p[2][a] * w[2] + p[3][a] * w[3]
    }

    /// `∇C`: the weights on the instance's axis, 0 on the other coordinates.
    #[inline(always)]
    fn gradient<R: Real>(&self, instance: usize, x: &[R], g: &mut [R]) -> R {
        let (w, a) = (&self.weights[instance], self.axis[instance]);
        g[..12].fill(R::zero());
        for (i, &wi) in w.iter().enumerate() {
            g[3 * i + a] = R::cst(wi);
        }
        x[a] * w[0] + x[3 + a] * w[1] + x[6 + a] * w[2] + x[9 + a] * w[3]
    }

    /// `∇²C·v = 0`: the constraint is linear.
    #[inline(always)]
    fn hessian_vectors(&self, _instance: usize, _x: &[f64], vs: &mut [RowVector]) {
        for v in vs.iter_mut() {
            v[..12].fill(0.0);
        }
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

    /// `∇C` from the field's bounded query
    /// [`crate::sdf::SignedDistance::distance_gradient_within`] at bound 0: exact (the generic
    /// derivative) wherever `C ≤ 0`; where the particle is outside (`C > 0`, the row inactive:
    /// no projection, no derivative through it) it may be a positive lower bound of `C` with
    /// gradient 0, so a mesh's search stops early. The projection and its derivative are the
    /// exact field's, bitwise (`tests/mesh_query.rs`); [`Constraint::c`] stays exact.
    #[inline(always)]
    fn gradient<R: Real>(&self, _instance: usize, x: &[R], g: &mut [R]) -> R {
        let (d, n) = self.sdf.distance_gradient_within(&point(x, 0), 0.0);
        g[..3].copy_from_slice(n.as_slice());
        d
    }
}
