//! Dense damped (Powell) BFGS approximation of the Hessian of the Lagrangian.

use crate::linalg::{dot, symv};

/// What an update did.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum BfgsUpdate {
    /// Plain BFGS update (`sᵀy ≥ θ sᵀBs`).
    Plain,
    /// Powell-damped update (`y` replaced by `θy + (1−θ)Bs`).
    Damped,
    /// Skipped (step too small or numerically unusable).
    Skipped,
}

/// `B`, kept symmetric positive definite by Powell's damping.
#[derive(Clone, Debug)]
pub(crate) struct DampedBfgs {
    n: usize,
    b: Vec<f64>,
    initial: Option<Vec<f64>>,
    /// Whether the next update may rescale an identity `B` first (Nocedal & Wright eq. 6.20).
    rescale_pending: bool,
    damping: f64,
    /// Scale `yᵀy / sᵀy` of the last curvature pair, used when resetting.
    last_scale: f64,
    updates: usize,
    /// `B` is a multiple of the identity (the last fallback of [`DampedBfgs::reset`]).
    at_identity: bool,
}

impl DampedBfgs {
    /// Starts from `initial` (validated SPD by the caller) or the identity.
    pub(crate) fn new(n: usize, initial: Option<Vec<f64>>, damping: f64) -> Self {
        let mut s = Self {
            n,
            b: Vec::new(),
            rescale_pending: initial.is_none(),
            initial,
            damping,
            last_scale: 1.0,
            updates: 0,
            at_identity: false,
        };
        s.reset_to_initial();
        s
    }

    fn reset_to_initial(&mut self) {
        self.b = match &self.initial {
            Some(b0) => b0.clone(),
            None => identity(self.n, 1.0),
        };
        self.at_identity = self.initial.is_none();
    }

    /// Restarts from the user's initial matrix after updates; from a multiple of the identity
    /// (scaled by the last curvature estimate) without one, or when that matrix itself just failed.
    pub(crate) fn reset(&mut self) {
        if self.initial.is_some() && self.updates > 0 {
            self.reset_to_initial();
        } else {
            // An initial matrix that failed before any update leaves no curvature estimate: the
            // next pair rescales the identity, as on a cold start.
            self.rescale_pending |= self.initial.is_some() && self.updates == 0;
            self.b = identity(self.n, self.last_scale);
            self.at_identity = true;
        }
        self.updates = 0;
    }

    /// Whether a reset has nothing new to offer: `B` is a fresh multiple of the identity.
    pub(crate) fn is_fresh(&self) -> bool {
        self.updates == 0 && self.at_identity
    }

    /// Row-major `n × n` matrix.
    pub(crate) fn matrix(&self) -> &[f64] {
        &self.b
    }

    /// Damped BFGS update with step `s` and gradient-of-Lagrangian change `y`.
    pub(crate) fn update(&mut self, s: &[f64], y: &[f64]) -> BfgsUpdate {
        let n = self.n;
        let ss = dot(s, s);
        if ss == 0.0 || !ss.is_finite() || y.iter().any(|v| !v.is_finite()) {
            return BfgsUpdate::Skipped;
        }
        let sy = dot(s, y);
        let yy = dot(y, y);
        if self.rescale_pending && sy > 0.0 && yy > 0.0 {
            let gamma = yy / sy;
            if gamma.is_finite() && gamma > 0.0 {
                self.b = identity(n, gamma);
            }
            self.rescale_pending = false;
        }
        let mut bs = vec![0.0; n];
        symv(&self.b, n, s, &mut bs);
        let sbs = dot(s, &bs);
        if !(sbs > 0.0 && sbs.is_finite()) {
            return BfgsUpdate::Skipped;
        }
        let (r, kind) = if sy >= self.damping * sbs {
            (y.to_vec(), BfgsUpdate::Plain)
        } else {
            let theta = (1.0 - self.damping) * sbs / (sbs - sy);
            let r: Vec<f64> = y
                .iter()
                .zip(&bs)
                .map(|(yi, bsi)| theta * yi + (1.0 - theta) * bsi)
                .collect();
            (r, BfgsUpdate::Damped)
        };
        let sr = dot(s, &r);
        if !(sr > 0.0 && sr.is_finite()) {
            return BfgsUpdate::Skipped;
        }
        let mut next = self.b.clone();
        for i in 0..n {
            for j in i..n {
                let v = self.b[i * n + j] - bs[i] * bs[j] / sbs + r[i] * r[j] / sr;
                next[i * n + j] = v;
                next[j * n + i] = v;
            }
        }
        if next.iter().any(|v| !v.is_finite()) {
            return BfgsUpdate::Skipped;
        }
        self.b = next;
        let rr = dot(&r, &r);
        self.last_scale = (rr / sr).clamp(1e-8, 1e8);
        self.updates += 1;
        kind
    }
}

fn identity(n: usize, scale: f64) -> Vec<f64> {
    let mut b = vec![0.0; n * n];
    for i in 0..n {
        b[i * n + i] = scale;
    }
    b
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::linalg::is_positive_definite;

    #[test]
    fn secant_condition_holds_and_damping_keeps_definiteness() {
        let mut b = DampedBfgs::new(2, None, 0.2);
        // Positive curvature: plain update satisfies B s = y.
        let kind = b.update(&[1.0, 0.0], &[2.0, 1.0]);
        assert_eq!(kind, BfgsUpdate::Plain);
        let mut bs = [0.0; 2];
        symv(b.matrix(), 2, &[1.0, 0.0], &mut bs);
        assert!((bs[0] - 2.0).abs() < 1e-12 && (bs[1] - 1.0).abs() < 1e-12);
        // Negative curvature: damped, still positive definite.
        let kind = b.update(&[0.0, 1.0], &[0.0, -3.0]);
        assert_eq!(kind, BfgsUpdate::Damped);
        assert!(is_positive_definite(b.matrix(), 2));
        b.reset();
        assert!(b.is_fresh());
    }

    #[test]
    fn reset_returns_to_the_initial_matrix_then_to_the_identity() {
        let h = vec![4.0, 1.0, 1.0, 3.0];
        let mut b = DampedBfgs::new(2, Some(h.clone()), 0.2);
        // A fresh initial matrix is not the last resort: a reset tries the identity.
        assert!(!b.is_fresh());
        b.reset();
        assert!(b.is_fresh());
        assert_eq!(b.matrix(), [1.0, 0.0, 0.0, 1.0]);
        // After updates, a reset returns to the initial matrix first.
        let mut b = DampedBfgs::new(2, Some(h.clone()), 0.2);
        b.update(&[1.0, 0.0], &[2.0, 1.0]);
        b.reset();
        assert_eq!(b.matrix(), h);
        assert!(!b.is_fresh());
        b.reset();
        assert!(b.is_fresh());
    }

    #[test]
    fn exact_hessian_is_a_fixed_point() {
        let h = vec![4.0, 1.0, 1.0, 3.0];
        let mut b = DampedBfgs::new(2, Some(h.clone()), 0.2);
        let s = [0.3, -0.7];
        let mut y = [0.0; 2];
        symv(&h, 2, &s, &mut y);
        b.update(&s, &y);
        for (a, e) in b.matrix().iter().zip(&h) {
            assert!((a - e).abs() < 1e-12);
        }
    }
}
