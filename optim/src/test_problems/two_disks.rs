//! Two disjoint disks: a locally infeasible problem for the solvers' infeasibility handling.

use crate::error::EvalError;
use crate::linalg::Jacobian;
use crate::problem::Problem;

/// `min x₀ + x₁` over two disjoint unit disks, `1 − ‖x‖² ≥ 0` and `1 − ‖x − (3, 0)‖² ≥ 0`: locally
/// infeasible, the ℓ1 violation is stationary at (1.5, 0) with max violation 1.25. With `far_disk`
/// = `Some(r²)`, a third row `r² − ‖x‖² ≥ 0` that stays far from active for large `r²`.
#[derive(Clone, Debug)]
pub struct TwoDisks {
    /// Squared radius of the optional third, far disk around the origin.
    pub far_disk: Option<f64>,
}

impl Problem for TwoDisks {
    fn num_variables(&self) -> usize {
        2
    }
    fn num_inequalities(&self) -> usize {
        2 + usize::from(self.far_disk.is_some())
    }
    fn objective(&mut self, x: &[f64]) -> Result<f64, EvalError> {
        Ok(x[0] + x[1])
    }
    fn gradient(&mut self, _x: &[f64], g: &mut [f64]) -> Result<(), EvalError> {
        g.copy_from_slice(&[1.0, 1.0]);
        Ok(())
    }
    fn inequalities(&mut self, x: &[f64], c: &mut [f64]) -> Result<(), EvalError> {
        let r0 = x[0] * x[0] + x[1] * x[1];
        c[0] = 1.0 - r0;
        c[1] = 1.0 - (x[0] - 3.0).powi(2) - x[1] * x[1];
        if let Some(r2) = self.far_disk {
            c[2] = r2 - r0;
        }
        Ok(())
    }
    fn inequality_jacobian(&mut self, x: &[f64], j: &mut Jacobian) -> Result<(), EvalError> {
        let rows: &[(usize, f64)] = if self.far_disk.is_some() {
            &[(0, 0.0), (1, 3.0), (2, 0.0)]
        } else {
            &[(0, 0.0), (1, 3.0)]
        };
        for &(i, cx) in rows {
            j.set(i, 0, -2.0 * (x[0] - cx));
            j.set(i, 1, -2.0 * x[1]);
        }
        Ok(())
    }
}
