//! Cloth–cloth friction under Newton's method (`physics.self_collision.friction`): IPC's lagged,
//! smoothed Coulomb potential (Li et al. 2020, §5) on the self-contact pairs.
//!
//! At the step's start `y`, every self-contact pair within the barrier's reach (gap `s = d − h`
//! in `(0, d̂)`, [`super::self_barrier`]) has, lagged (held fixed while the step is solved): the
//! coefficients `cᵢ` of its nearest points (their difference is `r = Σ cᵢ yᵢ`,
//! [`Feature::closest`]), the unit normal `n = r/|r|`, and the barrier's normal force
//! `λ = −Δt² κ m b′(s)` (`m` the edge pair's mollifier, 1 for a vertex and a triangle). The
//! step's energy gains
//!
//! ```text
//! D(x) = Σ μ λ f₀(|u|),   u = (I − nnᵀ) Σᵢ cᵢ (xᵢ − yᵢ),
//! ```
//!
//! the work of the Coulomb force `μλ` over the tangential slip of the pair's nearest points since
//! the step's start, smoothed below `ε` as the colliders' friction is
//! ([`super::smooth_friction`]): layers pressed together hold each other while the load along
//! them stays below `μλ`, creeping by a fraction of `ε` per step, and slide beyond it. With
//! `φ = f₀′(r)/r`, `∇ᵢD = μλ φ cᵢ u` and `∇²ᵢₖD = cᵢcₖ μλ (φ P + φ′/r u uᵀ)` (`P = I − nnᵀ`),
//! semidefinite. Its dependence on the start `y` (the slip, `λ`, `n` and the `cᵢ`) enters the
//! implicit gradient through [`SelfBarrier::pair_friction_cross`].

use super::feature::Feature;
use super::self_barrier::{at, PairKind, SelfBarrier, SelfPair};
use super::smooth_friction::{slip_weight, slip_weights, smoothed_slip};
use autodiff::{Dual, Real};
use nalgebra::Vector3;

/// Cloth–cloth friction's settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SelfFriction {
    /// The Coulomb coefficient `μ > 0` between parts of the cloth.
    pub mu: f64,
    /// The smoothing slip `ε > 0`.
    pub epsilon: f64,
}

/// One frictional self-contact pair, lagged at the step's start.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LaggedPair {
    /// The pair.
    pub pair: SelfPair,
    /// The nearest points' coefficients `cᵢ` (the pair's particles in order).
    pub coefficients: [f64; 4],
    /// The unit normal `n` at the step's start.
    pub normal: [f64; 3],
    /// `μ λ` (in `Φ`'s units).
    pub mu_lambda: f64,
}

impl SelfBarrier {
    /// The frictional pairs among `pairs` (the pairs of the step's start `y`, `N × 3` data): those
    /// within the barrier's reach; none without friction.
    pub fn lagged_pairs(&self, y: &[f64], pairs: &[SelfPair]) -> Vec<LaggedPair> {
        let Some(f) = self.friction else {
            return Vec::new();
        };
        (pairs.iter())
            .filter_map(|pair| {
                let p = pair.particles.map(|q| at(y, q));
                let (mu_lambda, c, n) = self.lag(&f, pair, &self.feature(&p, pair.kind), &p)?;
                Some(LaggedPair {
                    pair: *pair,
                    coefficients: c,
                    normal: [n[0], n[1], n[2]],
                    mu_lambda,
                })
            })
            .collect()
    }

    /// The friction potential of the lagged pairs `lagged` at `x` for the step's start `y`.
    pub fn friction_energy(&self, x: &[f64], y: &[f64], lagged: &[LaggedPair]) -> f64 {
        let eps = self.friction.map_or(1.0, |f| f.epsilon);
        (lagged.iter())
            .map(|l| l.mu_lambda * smoothed_slip(slip(l, x, y).norm(), eps))
            .sum()
    }

    /// The lagged pair's friction gradient (12 coordinates, its particles in order) and Hessian
    /// (row-major 12 × 12, semidefinite) at `x` for the step's start `y` (both overwritten).
    pub fn pair_friction_derivatives(
        &self,
        x: &[f64],
        y: &[f64],
        l: &LaggedPair,
        g: &mut [f64; 12],
        h: &mut [f64; 144],
    ) {
        let eps = self.friction.map_or(1.0, |f| f.epsilon);
        let u = slip(l, x, y);
        let (phi, dphi_over_r) = slip_weights(u.norm(), eps);
        let n = Vector3::from(l.normal);
        // The 3 × 3 kernel μλ (φ P + φ′/r u uᵀ), then cᵢ cₖ times it per particle block.
        let kernel: [f64; 9] = std::array::from_fn(|k| {
            let (a, b) = (k / 3, k % 3);
            let p_ab = f64::from(u8::from(a == b)) - n[a] * n[b];
            l.mu_lambda * (phi * p_ab + dphi_over_r * u[a] * u[b])
        });
        let c = l.coefficients;
        for i in 0..4 {
            for a in 0..3 {
                g[3 * i + a] = l.mu_lambda * phi * c[i] * u[a];
                for k in 0..4 {
                    for b in 0..3 {
                        h[12 * (3 * i + a) + 3 * k + b] = c[i] * c[k] * kernel[3 * a + b];
                    }
                }
            }
        }
    }

    /// `∂(∇ₓD)/∂y` of `pair`'s friction at `x` for the step's start `y` (row-major 12 × 12: row
    /// `a` a coordinate of the gradient, column `b` one of the start, the pair's particles in
    /// order), through the slip, `λ`, `n` and the `cᵢ`, all recomputed from `y`: the step's
    /// coupling to its start beyond the mass term, for the implicit gradient. Forward duals
    /// along the start on the generic gradient. Zero when the pair is out of reach at `y`.
    pub fn pair_friction_cross(&self, x: &[f64], y: &[f64], pair: &SelfPair) -> [f64; 144] {
        let mut out = [0.0; 144];
        let Some(f) = self.friction else {
            return out;
        };
        let ys = pair.particles.map(|q| at(y, q));
        let lifted: [Vector3<Dual<f64, 12>>; 4] =
            std::array::from_fn(|i| Vector3::from_fn(|k, _| Dual::variable(ys[i][k], 3 * i + k)));
        let feature = self.feature(&ys, pair.kind);
        let Some((mu_lambda, c, n)) = self.lag(&f, pair, &feature, &lifted) else {
            return out;
        };
        let xs = pair.particles.map(|q| at(x, q));
        let delta = (0..4).fold(Vector3::zeros(), |s: Vector3<Dual<f64, 12>>, i| {
            s + (xs[i].map(Dual::constant) - lifted[i]) * c[i]
        });
        let u = delta - n * n.dot(&delta);
        let w = mu_lambda * slip_weight(u.dot(&u), f.epsilon);
        for i in 0..4 {
            let gi = u * (w * c[i]);
            for a in 0..3 {
                out[12 * (3 * i + a)..12 * (3 * i + a) + 12].copy_from_slice(&gi[a].eps);
            }
        }
        out
    }

    /// `(μλ, c, n)` of `pair` at the start points `y` with nearest features `feature` (found at
    /// `y`), generic over the scalar; `None` beyond the barrier's reach.
    fn lag<R: Real>(
        &self,
        f: &SelfFriction,
        pair: &SelfPair,
        feature: &Feature,
        y: &[Vector3<R>; 4],
    ) -> Option<(R, [R; 4], Vector3<R>)> {
        let (c, r) = feature.closest(y);
        let d = r.dot(&r).sqrt();
        let s = d - R::cst(self.thickness);
        let d_hat = self.barrier.d_hat;
        if !(s.value() > 0.0 && s.value() < d_hat) {
            return None;
        }
        // b′(s) = −2(s − d̂) ln(s/d̂) − (s − d̂)²/s.
        let e = s - R::cst(d_hat);
        let b1 = -(e * (s / R::cst(d_hat)).ln() * R::cst(2.0)) - e * e / s;
        let m = match pair.kind {
            PairKind::PointTriangle => R::cst(1.0),
            PairKind::EdgeEdge(eps) => {
                let e1 = y[1] - y[0];
                let e2 = y[3] - y[2];
                let cross = e1.cross(&e2);
                let q = cross.dot(&cross) / R::cst(eps);
                if q.value() < 1.0 {
                    (R::cst(2.0) - q) * q
                } else {
                    R::cst(1.0)
                }
            }
        };
        let mu_lambda = -(b1 * m * R::cst(f.mu * self.dt2 * self.barrier.kappa));
        (mu_lambda.value() > 0.0).then(|| (mu_lambda, c, r * d.recip()))
    }
}

/// The lagged pair's tangential slip `u = (I − nnᵀ) Σ cᵢ (xᵢ − yᵢ)` at `x` from `y`.
fn slip(l: &LaggedPair, x: &[f64], y: &[f64]) -> Vector3<f64> {
    let delta = (0..4).fold(Vector3::zeros(), |s: Vector3<f64>, i| {
        let q = l.pair.particles[i];
        s + (at(x, q) - at(y, q)) * l.coefficients[i]
    });
    let n = Vector3::from(l.normal);
    delta - n * n.dot(&delta)
}

#[cfg(test)]
mod tests {
    use super::SelfFriction;
    use crate::contact::self_barrier::{PairKind, SelfBarrier, SelfPair};

    fn four_points() -> SelfBarrier {
        let mut b = crate::contact::self_barrier::tests::four_points(0.02);
        b.friction = Some(SelfFriction {
            mu: 0.4,
            epsilon: 0.01,
        });
        b
    }

    fn gradient(b: &SelfBarrier, pair: &SelfPair, x: &[f64], y: &[f64]) -> [f64; 12] {
        let mut g = [0.0; 12];
        if let Some(l) = b.lagged_pairs(y, &[*pair]).first() {
            b.pair_friction_derivatives(x, y, l, &mut g, &mut [0.0; 144]);
        }
        g
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig { cases: 64, .. Default::default() })]

        /// A vertex–triangle or edge–edge pair's friction: its gradient and Hessian against
        /// central differences of the potential and of the gradient at `x`, and its coupling to
        /// the start against central differences of the gradient in `y` (every lagged quantity
        /// recomputed), for slips below and above `ε`; the Hessian is semidefinite.
        #[test]
        fn pair_friction_derivatives_match_central_differences(
            coords in proptest::collection::vec(-0.5f64..0.5, 12),
            moves in proptest::collection::vec(-1.0f64..1.0, 12),
            edge in proptest::bool::ANY,
            lift in 0.05f64..0.11,
            large in proptest::bool::ANY,
        ) {
            let b = four_points();
            let mut y = coords.clone();
            for v in y.iter_mut().skip(2).step_by(3) {
                *v *= 0.02;
            }
            // ε = 1 puts every edge pair in the mollifier's region (|e₁ × e₂|² < 1 here).
            let eps = if lift > 0.08 { 1.0 } else { 1e-3 * 0.25 * 0.25 };
            let kind = if edge { PairKind::EdgeEdge(eps) } else { PairKind::PointTriangle };
            for q in 0..(if edge { 2 } else { 1 }) {
                y[3 * q + 2] += lift;
            }
            let pair = SelfPair { particles: [0, 1, 2, 3], kind };
            let gap = b.distance(&y, &pair) - b.thickness;
            proptest::prop_assume!(gap > 0.01 && gap < 0.09);
            let lagged = b.lagged_pairs(&y, &[pair]);
            proptest::prop_assert_eq!(lagged.len(), 1);
            let scale = if large { 0.05 } else { 0.004 };
            let x: Vec<f64> = y.iter().zip(&moves).map(|(a, m)| a + scale * m).collect();
            let (mut g, mut h) = ([0.0; 12], [0.0; 144]);
            b.pair_friction_derivatives(&x, &y, &lagged[0], &mut g, &mut h);
            let energy = |x: &[f64]| b.friction_energy(x, &y, &lagged);
            let step = 1e-7;
            let gscale = g.iter().fold(1e-12f64, |m, v| m.max(v.abs()));
            let hscale = h.iter().fold(1e-12f64, |m, v| m.max(v.abs()));
            let cross = b.pair_friction_cross(&x, &y, &pair);
            let cscale = cross.iter().fold(1e-12f64, |m, v| m.max(v.abs()));
            for k in 0..12 {
                let (mut up, mut down) = (x.clone(), x.clone());
                up[k] += step;
                down[k] -= step;
                let fd = (energy(&up) - energy(&down)) / (2.0 * step);
                proptest::prop_assert!((fd - g[k]).abs() <= 1e-5 * gscale, "∂{k}: {fd} vs {}", g[k]);
                let (mut gu, mut gd) = ([0.0; 12], [0.0; 12]);
                b.pair_friction_derivatives(&up, &y, &lagged[0], &mut gu, &mut [0.0; 144]);
                b.pair_friction_derivatives(&down, &y, &lagged[0], &mut gd, &mut [0.0; 144]);
                for a in 0..12 {
                    let fd2 = (gu[a] - gd[a]) / (2.0 * step);
                    proptest::prop_assert!(
                        (fd2 - h[12 * a + k]).abs() <= 1e-4 * hscale,
                        "∂²{a},{k}: {fd2} vs {}", h[12 * a + k]
                    );
                }
                let (mut yu, mut yd) = (y.clone(), y.clone());
                yu[k] += step;
                yd[k] -= step;
                let (gu, gd) = (gradient(&b, &pair, &x, &yu), gradient(&b, &pair, &x, &yd));
                for a in 0..12 {
                    let fd3 = (gu[a] - gd[a]) / (2.0 * step);
                    proptest::prop_assert!(
                        (fd3 - cross[12 * a + k]).abs() <= 1e-4 * cscale,
                        "∂g{a}/∂y{k}: {fd3} vs {}", cross[12 * a + k]
                    );
                }
            }
            // Semidefinite: vᵀHv ≥ 0 along the coordinate axes, the slip and random mixes.
            for v in (0..12).map(|k| {
                let mut v = [0.0; 12];
                v[k] = 1.0;
                v
            }).chain([std::array::from_fn(|k| moves[k]), std::array::from_fn(|k| moves[(k * 5) % 12] - moves[k])]) {
                let q: f64 = (0..12).map(|a| (0..12).map(|c| v[a] * h[12 * a + c] * v[c]).sum::<f64>()).sum();
                proptest::prop_assert!(q >= -1e-9 * hscale, "vᵀHv = {q}");
            }
        }
    }

    /// A pair beyond the barrier's reach at the start has no friction.
    #[test]
    fn a_pair_out_of_reach_has_no_friction() {
        let b = four_points();
        let pair = SelfPair {
            particles: [0, 1, 2, 3],
            kind: PairKind::PointTriangle,
        };
        let y = [0.2, 0.2, 0.15, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0];
        assert!(b.lagged_pairs(&y, &[pair]).is_empty());
        assert_eq!(b.pair_friction_cross(&y, &y, &pair), [0.0; 144]);
    }
}
