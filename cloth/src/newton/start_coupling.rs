//! Smooth and cloth–cloth friction's coupling of a step's state to its start,
//! `D_xy = ∂(∇ₓD)/∂y`, in both directions: transposed for the implicit gradient
//! ([`super::implicit`]), forward for the parameter sensitivities ([`super::sensitivity`]).

use super::assembly::Pattern;

impl Pattern {
    /// `y −= D_xyᵀ z` on the free particles' rows of full `N × 3` data: the friction potential's
    /// coupling of the state to the step's start ([`crate::contact::barrier::ColliderBarrier::friction_cross`]), at `x`,
    /// for the implicit gradient (`z` in degree-of-freedom order). Nothing without friction.
    pub fn sub_start_coupling(&self, x: &[f64], z: &[f64], y: &mut [f64]) {
        self.for_each_start_coupling(x, |p, d, cross| {
            for b in 0..3 {
                y[3 * p + b] -= (0..3).map(|a| cross[3 * a + b] * z[d + a]).sum::<f64>();
            }
        });
    }

    /// `rhs −= D_xy ẏ` (`rhs` in degree-of-freedom order, `ẏ` full `N × 3` data): the same
    /// coupling forward, for sensitivities ([`super::sensitivity`]). Nothing without friction.
    pub fn sub_start_coupling_forward(&self, x: &[f64], dy: &[f64], rhs: &mut [f64]) {
        self.for_each_start_coupling(x, |p, d, cross| {
            for a in 0..3 {
                rhs[d + a] -= (0..3)
                    .map(|b| cross[3 * a + b] * dy[3 * p + b])
                    .sum::<f64>();
            }
        });
    }

    /// Calls `f(start particle, state degree of freedom, ∂(∇ₓD)/∂y)` for every free particle
    /// with frictional contacts at the step's start (its own), for every pair of particles of an
    /// edge point with some, and of a frictional self-contact pair, at `x`.
    fn for_each_start_coupling(&self, x: &[f64], mut f: impl FnMut(usize, usize, &[f64; 9])) {
        if let Some(e) = &self.edge_points {
            e.for_each_start_coupling(x, &mut f);
        }
        self.for_each_self_start_coupling(x, &mut f);
        let (Some((b, _)), Some((start, lagged))) = (&self.barrier, &self.friction) else {
            return;
        };
        for (p, contacts) in lagged.iter().enumerate() {
            let Some(d) = self.dof(p).filter(|_| !contacts.is_empty()) else {
                continue;
            };
            let r = 3 * p..3 * p + 3;
            f(p, d, &b.friction_cross(&x[r.clone()], &start[r]));
        }
    }
}
