//! Smooth contact (`physics.contact.model = "smooth"`): a log-barrier potential in the signed
//! distance to each collider primitive, after IPC (Li et al. 2020).
//!
//! Each free particle at distance `dⱼ` from primitive `j` (a sphere, plane, capsule, box or mesh
//! of the colliders) carries `κ b(dⱼ)`, with
//!
//! ```text
//! b(d) = −(d − d̂)² ln(d / d̂)   for 0 < d < d̂,   0 for d ≥ d̂,   +∞ for d ≤ 0,
//! ```
//!
//! which is C² at `d̂` (`b`, `b′` and `b″` all vanish there) and grows without bound as `d → 0`.
//! Summing over primitives (rather than taking the barrier of the union's minimum) keeps the
//! potential smooth where two primitives are equally near. In Newton's `Φ` (energy × `Δt²`) the
//! term is `Δt² κ Σⱼ b(dⱼ)`, so a step is the minimizer of a smooth function of the state and the
//! controls, and the implicit gradient is that of a smooth map. Every state the solver visits
//! stays strictly outside the colliders: [`ColliderBarrier::max_step`] bounds each step so that
//! no particle's straight path comes closer than [`APPROACH`] of its current distance (the
//! segment minima of [`SignedDistance::min_along_segment`]), and `Φ` is `+∞` inside.

use super::smooth_friction::FrictionParams;
use crate::sdf::{SignedDistance, Union};
use autodiff::Dual;
use nalgebra::Vector3;
use std::sync::Arc;

/// A step may bring a particle at most this close to a collider, relative to its distance at
/// the step's start (a conservative time-of-impact filter: IPC's line-search filter).
pub const APPROACH: f64 = 0.1;
/// Halvings of a step the filter tries before it gives up on moving a particle (the step is
/// then 0 for the whole state).
const MAX_FILTER_HALVINGS: usize = 60;
/// How close (relative) [`ColliderBarrier::max_step`] bisects a limiting particle's step
/// length to the largest one its test allows.
pub const FILTER_PRECISION: f64 = 1e-12;

/// The barrier's shape: where it acts and how stiff it is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Barrier {
    /// The distance `d̂ > 0` below which the barrier acts.
    pub d_hat: f64,
    /// The stiffness `κ > 0` (energy per length squared).
    pub kappa: f64,
}

impl Barrier {
    /// `b(d)`, `b′(d)` and `b″(d)` (without `κ`); zero at and above `d̂`; `(+∞, −∞, +∞)` at or
    /// below 0.
    pub fn shape(&self, d: f64) -> (f64, f64, f64) {
        let h = self.d_hat;
        if d >= h {
            return (0.0, 0.0, 0.0);
        }
        if d <= 0.0 {
            return (f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY);
        }
        let (e, l) = (d - h, (d / h).ln());
        (
            -e * e * l,
            -2.0 * e * l - e * e / d,
            -2.0 * l - 4.0 * e / d + e * e / (d * d),
        )
    }
}

/// The smooth contact potential of a model's colliders, per free particle.
#[derive(Clone, Debug)]
pub struct ColliderBarrier {
    /// The colliders.
    pub field: Arc<Union>,
    /// The barrier's shape.
    pub barrier: Barrier,
    /// `Δt²`: the potential's scale in Newton's `Φ`.
    pub dt2: f64,
    /// Friction on the colliders (`"friction": μ` on an obstacle), see
    /// `cloth/src/contact/smooth_friction.rs`; `None` when every collider is frictionless.
    pub friction: Option<FrictionParams>,
}

/// One primitive's distance, gradient and Hessian (row-major) at a particle.
type Local = (f64, [f64; 3], [f64; 9]);

impl ColliderBarrier {
    /// The smallest signed distance of `p` to the colliders.
    pub fn distance(&self, p: &[f64]) -> f64 {
        self.field.distance(&Vector3::new(p[0], p[1], p[2]))
    }

    /// The term of one particle at `p` in `Φ`: `Δt² κ Σⱼ b(dⱼ)`; `+∞` when `p` is on or inside
    /// a collider.
    pub fn energy(&self, p: &[f64]) -> f64 {
        let h = self.barrier.d_hat;
        self.with_components(p, |d| {
            if d.iter().all(|&dj| dj >= h) {
                return 0.0;
            }
            let sum: f64 = d.iter().map(|&dj| self.barrier.shape(dj).0).sum();
            self.dt2 * self.barrier.kappa * sum
        })
    }

    /// `f` of the distances of `p` to each primitive within `d̂`
    /// ([`Union::components_within`]), held on the stack for up to 16 primitives.
    fn with_components<T>(&self, p: &[f64], f: impl FnOnce(&[f64]) -> T) -> T {
        let q = Vector3::new(p[0], p[1], p[2]);
        let n = self.field.component_count();
        let (mut stack, mut heap) = ([0.0; 16], Vec::new());
        let d = if n <= stack.len() {
            &mut stack[..n]
        } else {
            heap.resize(n, 0.0);
            &mut heap[..]
        };
        self.field.components_within(&q, self.barrier.d_hat, d);
        f(d)
    }

    /// The term's gradient (added to `g`) and Hessian (added to `h`, row-major `3 × 3`) at `p`;
    /// each primitive's block `Δt² κ (b″ ∇d∇dᵀ + b′ ∇²d)` is first passed through `each` (the
    /// Newton assembly's semidefinite projection, or nothing). Returns false, adding nothing,
    /// where `p` is on or inside a collider (the barrier has no derivative there).
    pub fn derivatives(
        &self,
        p: &[f64],
        g: &mut [f64; 3],
        h: &mut [f64; 9],
        mut each: impl FnMut(&mut [f64; 9]),
    ) -> bool {
        let q = Vector3::new(p[0], p[1], p[2]);
        let d_hat = self.barrier.d_hat;
        let active = self.with_components(p, |d| {
            let nearest = d.iter().copied().fold(f64::INFINITY, f64::min);
            if nearest >= d_hat {
                Some(Vec::new())
            } else if nearest <= 0.0 {
                None
            } else {
                Some(self.active_primitives(&q, d))
            }
        });
        let Some(active) = active else {
            return false;
        };
        let s = self.dt2 * self.barrier.kappa;
        for (d, grad, hess) in active {
            let (_, b1, b2) = self.barrier.shape(d);
            let mut block = [0.0; 9];
            for a in 0..3 {
                g[a] += s * b1 * grad[a];
                for b in 0..3 {
                    block[3 * a + b] = s * (b2 * grad[a] * grad[b] + b1 * hess[3 * a + b]);
                }
            }
            each(&mut block);
            for (hv, bv) in h.iter_mut().zip(&block) {
                *hv += bv;
            }
        }
        true
    }

    /// Distance, gradient and Hessian of every primitive nearer than `d̂` to `q` (`plain`: the
    /// distances to each, [`Union::components_within`]), by second-order forward duals on
    /// [`Union::component_within`].
    fn active_primitives(&self, q: &Vector3<f64>, plain: &[f64]) -> Vec<Local> {
        type D2 = Dual<Dual<f64, 3>, 3>;
        let d_hat = self.barrier.d_hat;
        let x: Vector3<D2> = Vector3::from_fn(|k, _| D2 {
            re: Dual::variable(q[k], k),
            eps: std::array::from_fn(|j| Dual::constant(if j == k { 1.0 } else { 0.0 })),
        });
        plain
            .iter()
            .enumerate()
            .filter(|(_, &d)| d < d_hat)
            .map(|(j, &d)| {
                let v = self.field.component_within(j, &x, d_hat);
                let grad = std::array::from_fn(|a| v.re.eps[a]);
                let hess = std::array::from_fn(|k| v.eps[k / 3].eps[k % 3]);
                (d, grad, hess)
            })
            .collect()
    }

    /// The largest step length `α ∈ [0, 1]` such that moving every free particle `p` in a
    /// straight line from `x_p` to `x_p + α δ_p` keeps its distance to the colliders at least
    /// [`APPROACH`] times its distance at `x_p`, to a relative [`FILTER_PRECISION`]. `particles`
    /// lists the particles with their moves. A particle that cannot move clear of the colliders
    /// at all (already on a surface) gives 0.
    ///
    /// A limiting particle's length is bracketed by halvings and then bisected, not left at a
    /// power of one half: the length is then a continuous function of the state and the moves,
    /// where halvings jump between 1 and ½. Solves stage their control moves by it, so a jump
    /// there sends the cloth down another path, and a plan's rollout jumps with it (measured:
    /// controls 1.3e-5 m apart ended at `L` 1.06 and 1.92 on the diagonal fold).
    pub fn max_step<'a>(&self, moves: impl Iterator<Item = (&'a [f64], [f64; 3])>) -> f64 {
        let mut alpha: f64 = 1.0;
        for (p, delta) in moves {
            let len = delta.iter().map(|v| v * v).sum::<f64>().sqrt();
            if len == 0.0 {
                continue;
            }
            let a = Vector3::new(p[0], p[1], p[2]);
            let d0 = self
                .field
                .distance_within(&a, self.barrier.d_hat + alpha * len);
            // 1-Lipschitz: a move shorter than (1 − APPROACH) d₀ cannot come closer.
            if alpha * len <= (1.0 - APPROACH) * d0 {
                continue;
            }
            let floor = APPROACH * d0;
            let dir = Vector3::new(delta[0], delta[1], delta[2]);
            // The smallest distance along `[0, t]` falls as `t` grows: its test is monotone.
            let clear = |t: f64| {
                self.field
                    .min_along_segment_within(&a, &(a + dir * t), floor)
                    >= floor
            };
            let mut halvings = 0;
            while !clear(alpha) {
                alpha *= 0.5;
                halvings += 1;
                if halvings == MAX_FILTER_HALVINGS {
                    return 0.0;
                }
            }
            if halvings > 0 {
                let mut blocked = 2.0 * alpha;
                while blocked - alpha > FILTER_PRECISION * blocked {
                    let mid = 0.5 * (alpha + blocked);
                    if clear(mid) {
                        alpha = mid;
                    } else {
                        blocked = mid;
                    }
                }
            }
        }
        alpha
    }
}

#[cfg(test)]
mod tests {
    use super::{Barrier, ColliderBarrier};
    use crate::sdf::{Plane, Union};
    use std::sync::Arc;

    #[test]
    fn shape_is_c2_at_d_hat_and_matches_central_differences_inside() {
        let b = Barrier {
            d_hat: 0.01,
            kappa: 1.0,
        };
        assert_eq!(b.shape(0.01), (0.0, 0.0, 0.0));
        let below = b.shape(0.01 * (1.0 - 1e-6));
        assert!(below.0.abs() < 1e-20 && below.1.abs() < 1e-13 && below.2.abs() < 1e-5);
        for d in [1e-4, 1e-3, 5e-3, 9e-3] {
            let (_, d1, d2) = b.shape(d);
            let h = 1e-7 * d;
            let fd1 = (b.shape(d + h).0 - b.shape(d - h).0) / (2.0 * h);
            let fd2 = (b.shape(d + h).1 - b.shape(d - h).1) / (2.0 * h);
            assert!((fd1 - d1).abs() <= 1e-6 * d1.abs(), "b′({d}) {d1} vs {fd1}");
            assert!((fd2 - d2).abs() <= 1e-6 * d2.abs(), "b″({d}) {d2} vs {fd2}");
            assert!(d1 < 0.0 && d2 > 0.0, "decreasing and convex below d̂");
        }
        assert_eq!(b.shape(0.0).0, f64::INFINITY);
    }

    fn floor() -> ColliderBarrier {
        let mut field = Union::default();
        field.planes.push(Plane {
            point: [0.0, 0.0, 0.0],
            normal: [0.0, 0.0, 1.0],
        });
        ColliderBarrier {
            field: Arc::new(field),
            barrier: Barrier {
                d_hat: 0.1,
                kappa: 2.0,
            },
            dt2: 0.25,
            friction: None,
        }
    }

    #[test]
    fn derivatives_of_a_plane_barrier_match_central_differences() {
        let c = floor();
        let p = [0.3, -0.2, 0.04];
        let (mut g, mut h) = ([0.0; 3], [0.0; 9]);
        assert!(c.derivatives(&p, &mut g, &mut h, |_| {}));
        let step = 1e-7;
        let at = |z: f64| c.energy(&[p[0], p[1], z]);
        let fd = (at(p[2] + step) - at(p[2] - step)) / (2.0 * step);
        assert!((fd - g[2]).abs() <= 1e-6 * g[2].abs(), "{fd} vs {}", g[2]);
        assert_eq!((g[0], g[1]), (0.0, 0.0));
        let mut g2 = [0.0; 3];
        c.derivatives(&[p[0], p[1], p[2] + step], &mut g2, &mut [0.0; 9], |_| {});
        let mut g1 = [0.0; 3];
        c.derivatives(&[p[0], p[1], p[2] - step], &mut g1, &mut [0.0; 9], |_| {});
        let fd2 = (g2[2] - g1[2]) / (2.0 * step);
        assert!((fd2 - h[8]).abs() <= 1e-6 * h[8].abs(), "{fd2} vs {}", h[8]);
        assert!(!c.derivatives(&[0.0, 0.0, -1e-3], &mut g, &mut h, |_| {}));
    }

    #[test]
    fn the_step_filter_keeps_a_tenth_of_the_distance() {
        let c = floor();
        let p = [0.0, 0.0, 0.05];
        // Straight down by 1: the segment would cross the floor; the step ends where the point
        // is 0.005 above it (not at a power of one half below that).
        let alpha = c.max_step(std::iter::once((&p[..], [0.0, 0.0, -1.0])));
        assert!(0.05 - alpha >= 0.005, "{alpha}");
        assert!((alpha - 0.045).abs() <= 1e-11 * 0.045, "{alpha}");
        // Sideways: no approach, the whole step.
        assert_eq!(c.max_step(std::iter::once((&p[..], [1.0, 0.0, 0.0]))), 1.0);
    }

    /// The allowed length moves with the move: a downward move of length `ℓ` is allowed
    /// `0.045 / ℓ` of it, so the distance it allows, `α ℓ`, stays 0.045 as `ℓ` sweeps past the
    /// lengths where halvings would jump (0.09, 0.18, …), and slanted moves keep it in depth.
    #[test]
    fn the_allowed_length_is_continuous_in_the_move() {
        let c = floor();
        let p = [0.0, 0.0, 0.05];
        for k in 0..200 {
            let len = 0.06 + 0.002 * k as f64;
            let alpha = c.max_step(std::iter::once((&p[..], [0.0, 0.0, -len])));
            assert!(
                (alpha * len - 0.045).abs() <= 1e-11,
                "ℓ {len}: α ℓ {}",
                alpha * len
            );
            let slanted = c.max_step(std::iter::once((&p[..], [len, 0.3, -len])));
            assert!((slanted * len - 0.045).abs() <= 1e-11, "ℓ {len}: {slanted}");
        }
    }

    #[test]
    fn a_thin_plate_stops_a_crossing_move() {
        let mut field = Union::default();
        field.boxes.push(crate::sdf::Cuboid::new(
            [0.0, -1.4, 1.5],
            [0.3, 0.001, 0.3],
            None,
        ));
        let c = ColliderBarrier {
            field: Arc::new(field),
            barrier: Barrier {
                d_hat: 0.03,
                kappa: 1.0,
            },
            dt2: 0.01,
            friction: None,
        };
        let p = [-0.25, -1.5, 1.75];
        let alpha = c.max_step(std::iter::once((&p[..], [0.0, 0.25, 0.0])));
        assert!(alpha * 0.25 <= 0.099 - 0.0099 + 1e-12, "{alpha}");
    }
}
