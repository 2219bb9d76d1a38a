//! Friction for smooth contact: IPC's lagged, smoothed Coulomb potential (Li et al. 2020).
//!
//! At the step's start `y` (the previous state), each free particle within `d̂` of a collider
//! primitive `j` with coefficient `μⱼ > 0` has a frictional contact: the barrier's normal force
//! `λⱼ = −Δt² κ b′(dⱼ(y))` (in `Φ`'s units) and the unit normal `nⱼ = ∇dⱼ(y)`, both lagged (held
//! fixed while the step is solved). The step's energy gains
//!
//! ```text
//! D(x) = Σⱼ μⱼ λⱼ f₀(|uⱼ|),   uⱼ = (I − nⱼnⱼᵀ)(x − y),
//! f₀(r) = r²/ε − r³/(3ε²) + ε/3  for r < ε,   r  otherwise,
//! ```
//!
//! the work of a Coulomb force `μλ` over the tangential displacement since the step's start,
//! smoothed below `ε` (C² at `ε`): a particle whose tangential load stays below `μλ` creeps by a
//! fraction of `ε` per step instead of sticking exactly, and one pulled harder slides with the
//! force `μλ` opposing its displacement. `D` is convex in `x`. Its dependence on `y` (through the
//! displacement, `λ` and `n`) enters the implicit gradient through [`ColliderBarrier::friction_cross`].

use super::barrier::ColliderBarrier;
use crate::geometry::{norm3, unit};
use crate::sdf::SignedDistance;
use autodiff::{Dual, Real};
use nalgebra::Vector3;

/// The smooth model's friction settings.
#[derive(Clone, Debug, PartialEq)]
pub struct FrictionParams {
    /// `μ` of each collider primitive, in the union's component order (0: frictionless).
    pub mu: Vec<f64>,
    /// The smoothing displacement `ε > 0`.
    pub epsilon: f64,
}

/// One frictional contact of a particle, lagged at the step's start.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LaggedContact {
    /// `μ λ` (in `Φ`'s units).
    pub mu_lambda: f64,
    /// The unit normal at the step's start.
    pub normal: [f64; 3],
}

impl ColliderBarrier {
    /// The frictional contacts of a particle whose step starts at `y` (none without friction).
    pub fn lagged(&self, y: &[f64]) -> Vec<LaggedContact> {
        let Some(f) = &self.friction else {
            return Vec::new();
        };
        let q = Vector3::new(y[0], y[1], y[2]);
        let d_hat = self.barrier.d_hat;
        if self.field.distance_within(&q, d_hat) >= d_hat {
            return Vec::new();
        }
        let n = self.field.component_count();
        let lifted: Vector3<Dual<f64, 3>> = Vector3::from_fn(|k, _| Dual::variable(q[k], k));
        let mut d = vec![Dual::<f64, 3>::constant(0.0); n];
        self.field.components_within(&lifted, d_hat, &mut d);
        let s = self.dt2 * self.barrier.kappa;
        d.iter()
            .zip(&f.mu)
            .filter(|(dj, &mu)| mu > 0.0 && dj.re > 0.0 && dj.re < d_hat)
            // A contact whose normal is undefined (a zero SDF gradient) has no tangent plane.
            .filter_map(|(dj, &mu)| {
                unit(&dj.eps).map(|normal| LaggedContact {
                    mu_lambda: -mu * s * self.barrier.shape(dj.re).1,
                    normal,
                })
            })
            .collect()
    }

    /// The particle's friction potential at `x` for its step's start `y` and contacts there.
    pub fn friction_energy(&self, x: &[f64], y: &[f64], contacts: &[LaggedContact]) -> f64 {
        let eps = self.epsilon();
        contacts
            .iter()
            .map(|c| c.mu_lambda * smoothed_slip(norm3(&tangential(c.normal, x, y)), eps))
            .sum()
    }

    /// The friction potential's gradient (added to `g`) and Hessian (added to `h`, row-major,
    /// semidefinite) at `x`.
    pub fn friction_derivatives(
        &self,
        x: &[f64],
        y: &[f64],
        contacts: &[LaggedContact],
        g: &mut [f64; 3],
        h: &mut [f64; 9],
    ) {
        let eps = self.epsilon();
        for c in contacts {
            let u = tangential(c.normal, x, y);
            // ∇D = μλ φ(r) u with φ = f₁(r)/r; ∇²D = μλ (φ P + φ′/r u uᵀ).
            let (phi, dphi_over_r) = slip_weights(norm3(&u), eps);
            let n = c.normal;
            for a in 0..3 {
                g[a] += c.mu_lambda * phi * u[a];
                for b in 0..3 {
                    let p_ab = f64::from(u8::from(a == b)) - n[a] * n[b];
                    h[3 * a + b] += c.mu_lambda * (phi * p_ab + dphi_over_r * u[a] * u[b]);
                }
            }
        }
    }

    /// `∂(∇ₓD)/∂y` at `x` (row-major: row `a` is component `a` of `∇ₓD`, column `b` the
    /// derivative along `y_b`), through the displacement, `λ(y)` and `n(y)`: the step's coupling to
    /// its start beyond the mass term, for the implicit gradient. Forward duals along `y` on the
    /// generic [`ColliderBarrier::friction_gradient`].
    pub fn friction_cross(&self, x: &[f64], y: &[f64]) -> [f64; 9] {
        let yd: Vector3<Dual<f64, 3>> = Vector3::from_fn(|k, _| Dual::variable(y[k], k));
        let g = self.friction_gradient(x, &yd);
        std::array::from_fn(|k| g[k / 3].eps[k % 3])
    }

    /// `∇ₓD` at `x` with every lagged quantity recomputed from the start `y`, generic over `R`.
    fn friction_gradient<R: Real>(&self, x: &[f64], y: &Vector3<R>) -> Vector3<R> {
        let mut g = Vector3::zeros();
        let Some(f) = &self.friction else {
            return g;
        };
        let d_hat = self.barrier.d_hat;
        let n_comp = self.field.component_count();
        let lifted: Vector3<Dual<R, 3>> = Vector3::from_fn(|k, _| Dual::variable(y[k], k));
        let mut d = vec![Dual::<R, 3>::constant(R::cst(0.0)); n_comp];
        self.field.components_within(&lifted, d_hat, &mut d);
        let (eps, s) = (self.epsilon(), self.dt2 * self.barrier.kappa);
        let x = Vector3::new(R::cst(x[0]), R::cst(x[1]), R::cst(x[2]));
        for (dj, &mu) in d.iter().zip(&f.mu) {
            let dv = dj.re.value();
            if !(mu > 0.0 && dv > 0.0 && dv < d_hat) {
                continue;
            }
            let (dist, h) = (dj.re, R::cst(d_hat));
            let e = dist - h;
            let b1 = -(e * (dist / h).ln() * R::cst(2.0)) - e * e / dist;
            let mu_lambda = -(b1 * R::cst(mu * s));
            let n = Vector3::new(dj.eps[0], dj.eps[1], dj.eps[2]);
            let delta = x - y;
            let u = delta - n * n.dot(&delta);
            g += u * (mu_lambda * slip_weight(u.dot(&u), eps));
        }
        g
    }

    /// The smoothing displacement `ε` (meaningless without friction).
    fn epsilon(&self) -> f64 {
        self.friction.as_ref().map_or(1.0, |f| f.epsilon)
    }
}

/// `f₀(r)`: the slip `r` smoothed below `ε` (`r²/ε − r³/(3ε²) + ε/3`, C² at `ε`).
pub(crate) fn smoothed_slip(r: f64, eps: f64) -> f64 {
    if r < eps {
        r * r / eps - r * r * r / (3.0 * eps * eps) + eps / 3.0
    } else {
        r
    }
}

/// `φ = f₀′(r)/r` and `φ′(r)/r` at the slip `r ≥ 0`: `∇f₀(|u|) = φ u`,
/// `∇²f₀(|u|) = φ I + φ′/r u uᵀ` (semidefinite: `φ + r φ′ ≥ 0`).
pub(crate) fn slip_weights(r: f64, eps: f64) -> (f64, f64) {
    if r < eps {
        (
            2.0 / eps - r / (eps * eps),
            if r > 0.0 { -1.0 / (eps * eps * r) } else { 0.0 },
        )
    } else {
        (1.0 / r, -1.0 / (r * r * r))
    }
}

/// `φ` of [`slip_weights`] from the squared slip `r²`, generic over the scalar.
pub(crate) fn slip_weight<R: Real>(r2: R, eps: f64) -> R {
    if r2.value() == 0.0 {
        R::cst(2.0 / eps)
    } else if r2.value() < eps * eps {
        R::cst(2.0 / eps) - r2.sqrt() * R::cst(1.0 / (eps * eps))
    } else {
        r2.sqrt().recip()
    }
}

/// `(I − nnᵀ)(x − y)`.
fn tangential(n: [f64; 3], x: &[f64], y: &[f64]) -> [f64; 3] {
    let d = [x[0] - y[0], x[1] - y[1], x[2] - y[2]];
    let dn = d[0] * n[0] + d[1] * n[1] + d[2] * n[2];
    std::array::from_fn(|k| d[k] - n[k] * dn)
}

#[cfg(test)]
mod tests {
    use super::{FrictionParams, LaggedContact};
    use crate::contact::barrier::{Barrier, ColliderBarrier};
    use crate::sdf::{Plane, Union};
    use std::sync::Arc;

    fn tilted() -> ColliderBarrier {
        let mut field = Union::default();
        let n = [0.3f64, 0.0, 1.0];
        let l = (n[0] * n[0] + n[2] * n[2]).sqrt();
        field.planes.push(Plane {
            point: [0.0, 0.0, 0.0],
            normal: [n[0] / l, 0.0, n[2] / l],
        });
        ColliderBarrier {
            field: Arc::new(field),
            barrier: Barrier {
                d_hat: 0.1,
                kappa: 3.0,
            },
            dt2: 0.01,
            friction: Some(FrictionParams {
                mu: vec![0.5],
                epsilon: 0.01,
            }),
        }
    }

    fn energy_at(c: &ColliderBarrier, x: [f64; 3], y: [f64; 3]) -> f64 {
        c.friction_energy(&x, &y, &c.lagged(&y))
    }

    fn gradient_at(c: &ColliderBarrier, x: [f64; 3], y: [f64; 3]) -> [f64; 3] {
        let mut g = [0.0; 3];
        c.friction_derivatives(&x, &y, &c.lagged(&y), &mut g, &mut [0.0; 9]);
        g
    }

    #[test]
    fn derivatives_match_central_differences_inside_and_outside_the_smoothing() {
        let c = tilted();
        let y = [0.1, 0.2, 0.05];
        let lagged: Vec<LaggedContact> = c.lagged(&y);
        assert_eq!(lagged.len(), 1);
        assert!(lagged[0].mu_lambda > 0.0);
        // A small tangential move (r < ε) and a large one (r > ε).
        for shift in [[0.003, 0.002, 0.0], [0.04, -0.02, 0.01]] {
            let x = [y[0] + shift[0], y[1] + shift[1], y[2] + shift[2]];
            let (mut g, mut h) = ([0.0; 3], [0.0; 9]);
            c.friction_derivatives(&x, &y, &lagged, &mut g, &mut h);
            let step = 1e-7;
            for k in 0..3 {
                let (mut xp, mut xm) = (x, x);
                xp[k] += step;
                xm[k] -= step;
                let fd = (energy_at(&c, xp, y) - energy_at(&c, xm, y)) / (2.0 * step);
                assert!((fd - g[k]).abs() <= 1e-6 * g.iter().map(|v| v.abs()).sum::<f64>());
                let (gp, gm) = (gradient_at(&c, xp, y), gradient_at(&c, xm, y));
                for a in 0..3 {
                    let fd2 = (gp[a] - gm[a]) / (2.0 * step);
                    let scale = h.iter().map(|v| v.abs()).fold(0.0, f64::max);
                    assert!((fd2 - h[3 * a + k]).abs() <= 1e-5 * scale, "H[{a}][{k}]");
                }
            }
        }
    }

    #[test]
    fn the_cross_derivative_matches_central_differences_in_the_start() {
        let c = tilted();
        let y = [0.1, 0.2, 0.05];
        let x = [0.107, 0.195, 0.052];
        let cross = c.friction_cross(&x, &y);
        let step = 1e-7;
        for b in 0..3 {
            let (mut yp, mut ym) = (y, y);
            yp[b] += step;
            ym[b] -= step;
            let (gp, gm) = (gradient_at(&c, x, yp), gradient_at(&c, x, ym));
            for a in 0..3 {
                let fd = (gp[a] - gm[a]) / (2.0 * step);
                let scale = cross.iter().map(|v| v.abs()).fold(0.0, f64::max);
                assert!(
                    (fd - cross[3 * a + b]).abs() <= 1e-5 * scale,
                    "∂g{a}/∂y{b}: {} vs {fd}",
                    cross[3 * a + b]
                );
            }
        }
    }
}
