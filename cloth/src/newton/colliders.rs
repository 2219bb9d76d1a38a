//! Smooth contact with the colliders in Newton's system: each free particle's barrier and lagged
//! friction ([`crate::contact::barrier`], [`crate::contact::smooth_friction`]) and the edge
//! points' barrier ([`super::edge_points`]) — their part of `Φ`, its gradient and Hessian, the
//! step filter that keeps every iterate outside, and the check that a solve starts outside.

use super::assembly::{HessianKind, Pattern, NONE};
use super::psd::project_psd;
use crate::ClothError;

impl Pattern {
    /// The colliders' part of `Φ(x)`: the particles' barrier and friction, and the edge points'.
    pub(super) fn collider_energy(&self, x: &[f64]) -> f64 {
        let mut phi = 0.0;
        if let Some((b, _)) = &self.barrier {
            for (p, &d) in self.dof_of.iter().enumerate() {
                if d != NONE {
                    phi += b.energy(&x[3 * p..3 * p + 3]);
                }
            }
            if let Some((start, lagged)) = &self.friction {
                for (p, contacts) in lagged.iter().enumerate() {
                    if !contacts.is_empty() {
                        let r = 3 * p..3 * p + 3;
                        phi += b.friction_energy(&x[r.clone()], &start[r], contacts);
                    }
                }
            }
        }
        if let Some(e) = &self.edge_points {
            phi += e.energy(x);
        }
        phi
    }

    /// Smooth contact or self-contact with friction: lags the frictional contacts at the step's
    /// start `y` (the previous state, full `N × 3` data); every energy and assembly until the
    /// next call is the step's from `y`. Nothing without friction.
    pub fn begin_step(&mut self, y: &[f64]) {
        if let Some(e) = &mut self.edge_points {
            e.begin_step(y);
        }
        self.begin_self_friction(y);
        let Some((b, _)) = &self.barrier else {
            return;
        };
        if b.friction.is_none() {
            return;
        }
        let lagged = self
            .dof_of
            .iter()
            .enumerate()
            .map(|(p, &d)| {
                if d == NONE {
                    Vec::new()
                } else {
                    b.lagged(&y[3 * p..3 * p + 3])
                }
            })
            .collect();
        self.friction = Some((y.to_vec(), lagged));
    }

    /// The colliders' part of `∇Φ` into `grad` and, with `values`, of its Hessian (each
    /// primitive's block projected to semidefinite for [`HessianKind::Projected`]). A particle
    /// on or inside a collider has no derivative and adds nothing: only the predicted state `x̃`
    /// can be there (the solver's iterates are filtered to stay outside), where the gradient
    /// serves as the tolerance's scale.
    pub(super) fn assemble_colliders(
        &self,
        x: &[f64],
        grad: &mut [f64],
        mut values: Option<(&mut [f64], HessianKind)>,
    ) {
        if let Some(e) = &self.edge_points {
            e.assemble(x, grad, values.as_mut().map(|(v, k)| (&mut **v, *k)));
        }
        let Some((barrier, diagonal)) = &self.barrier else {
            return;
        };
        for (p, &d) in self.dof_of.iter().enumerate() {
            if d == NONE {
                continue;
            }
            let (mut g, mut h) = ([0.0; 3], [0.0; 9]);
            let project = matches!(values, Some((_, HessianKind::Projected)));
            let point = &x[3 * p..3 * p + 3];
            if !barrier.derivatives(point, &mut g, &mut h, |block| {
                if project {
                    project_psd(block, 3);
                }
            }) {
                continue;
            }
            if let Some((start, lagged)) = &self.friction {
                let contacts = &lagged[p];
                if !contacts.is_empty() {
                    let y = &start[3 * p..3 * p + 3];
                    barrier.friction_derivatives(point, y, contacts, &mut g, &mut h);
                }
            }
            let d = d as usize;
            for k in 0..3 {
                grad[d + k] += g[k];
            }
            if let Some((v, _)) = values.as_mut() {
                for (&i, &hv) in diagonal[d / 3].iter().zip(&h) {
                    if i != NONE {
                        v[i as usize] += hv;
                    }
                }
            }
        }
    }

    /// `alpha` times the largest step length in `[0, 1]` the colliders' barrier allows for every
    /// free particle `p` (degree of freedom `d`) moving by `alpha · moved(p, d)` from `x`
    /// ([`crate::contact::barrier::ColliderBarrier::max_step`]); `alpha` without the barrier. The self-contact filter
    /// gives `alpha`: a step it shortens is scaled down for the colliders too.
    pub(super) fn colliders_allow(
        &self,
        x: &[f64],
        alpha: f64,
        moved: impl Fn(usize, usize) -> [f64; 3],
    ) -> f64 {
        let Some((barrier, _)) = &self.barrier else {
            return alpha;
        };
        let moves = (self.dof_of.iter().enumerate())
            .filter(|&(_, &d)| d != NONE)
            .map(|(p, &d)| {
                (
                    &x[3 * p..3 * p + 3],
                    moved(p, d as usize).map(|v| v * alpha),
                )
            });
        let alpha = alpha * barrier.max_step(moves);
        match &self.edge_points {
            Some(e) => alpha * e.max_step(x, |p, d| moved(p, d).map(|v| v * alpha)),
            None => alpha,
        }
    }

    /// Smooth contact: the error for a solve that would start at `x` with a free particle or an
    /// edge point on or inside a collider (the barrier is infinite there). Self-contact has its
    /// own test ([`Pattern::self_penetration`]).
    pub(super) fn check_outside(&self, x: &[f64], step: usize) -> Result<(), ClothError> {
        let Some((barrier, _)) = self.barrier.as_ref() else {
            return Ok(());
        };
        let inside = (self.dof_of.iter().enumerate())
            .filter(|&(_, &d)| d != NONE)
            .map(|(p, _)| (p, barrier.distance(&x[3 * p..3 * p + 3])))
            .find(|&(_, d)| d <= 0.0);
        if let Some((particle, distance)) = inside {
            return Err(ClothError::ContactPenetration {
                step,
                particle,
                distance,
            });
        }
        match self
            .edge_points
            .as_ref()
            .and_then(|e| e.edges.penetration(x))
        {
            Some((point, distance)) => Err(ClothError::EdgeContactPenetration {
                step,
                edge: [point.a, point.b],
                t: point.t,
                distance,
            }),
            None => Ok(()),
        }
    }
}
