//! The [`Problem`] trait and its building blocks: [`Bounds`] and [`NormTerm`].
//!
//! A problem is
//!
//! ```text
//! minimize    f(x) + Σ_k w_k ‖A_k x + b_k‖₂ + Σ_j v_j ‖r_j(x)‖₂
//! subject to  c(x) ≥ 0          (m inequalities)
//!             h(x) = 0          (p equalities)
//!             l ≤ x ≤ u         (bounds, ±∞ allowed)
//! ```
//!
//! `f`, `c`, `h` are smooth and supplied with derivatives; the norm terms are declared as data
//! ([`Problem::norm_terms`]) so the SQP can treat their kinks exactly. The residual norms
//! `v_j‖r_j(x)‖` ([`Problem::residual_norms`]) have nonlinear residuals the problem evaluates with
//! their Jacobians; the SQP models each by its linearization `v_j‖r_j + J_j d‖` (Gauss–Newton, or
//! prox-linear: the curvature of `r_j` is left out of the model, and out of the BFGS update).

use crate::error::{EvalError, OptimError};
use crate::linalg::{DenseMatrix, Jacobian, SparseMatrix};
use serde::{Deserialize, Serialize};

/// Box bounds `lower ≤ x ≤ upper`; use `f64::NEG_INFINITY` / `f64::INFINITY` for free sides.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Bounds {
    /// Lower bounds, one per variable.
    pub lower: Vec<f64>,
    /// Upper bounds, one per variable.
    pub upper: Vec<f64>,
}

impl Bounds {
    /// Bounds from explicit vectors.
    pub fn new(lower: Vec<f64>, upper: Vec<f64>) -> Self {
        Self { lower, upper }
    }

    /// No bounds on `n` variables.
    pub fn unbounded(n: usize) -> Self {
        Self {
            lower: vec![f64::NEG_INFINITY; n],
            upper: vec![f64::INFINITY; n],
        }
    }

    /// Every variable in `[lower, upper]`.
    pub fn uniform(n: usize, lower: f64, upper: f64) -> Self {
        Self {
            lower: vec![lower; n],
            upper: vec![upper; n],
        }
    }

    /// Checks lengths, NaNs and `lower ≤ upper`.
    pub(crate) fn validate(&self, n: usize) -> Result<(), OptimError> {
        for (what, v) in [("lower bounds", &self.lower), ("upper bounds", &self.upper)] {
            if v.len() != n {
                return Err(OptimError::DimensionMismatch {
                    what: what.into(),
                    expected: n,
                    got: v.len(),
                });
            }
        }
        for (i, (&l, &u)) in self.lower.iter().zip(&self.upper).enumerate() {
            if l.is_nan() || u.is_nan() {
                return Err(OptimError::InvalidProblem(format!(
                    "bound of x[{i}] is NaN"
                )));
            }
            if l > u || l == f64::INFINITY || u == f64::NEG_INFINITY {
                return Err(OptimError::InvalidProblem(format!(
                    "empty bounds for x[{i}]: [{l}, {u}]"
                )));
            }
        }
        Ok(())
    }

    /// Whether any side is finite.
    pub(crate) fn is_active(&self) -> bool {
        self.lower.iter().any(|l| l.is_finite()) || self.upper.iter().any(|u| u.is_finite())
    }
}

/// An objective term `weight · ‖A x + b‖₂`, non-smooth where `A x + b = 0`.
///
/// The SQP models it exactly with an epigraph variable `s ≥ ‖A(x+d) + b‖` in a second-order cone,
/// so iterates may sit exactly on the kink. L-BFGS, which has no such machinery, adds it to the
/// smooth objective with the subgradient convention `0` at the kink.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct NormTerm {
    /// Non-negative weight `w`.
    pub weight: f64,
    /// The `p × n` matrix `A` (triplets; duplicates summed).
    pub matrix: SparseMatrix,
    /// The offset `b` (length `p`).
    pub offset: Vec<f64>,
}

impl NormTerm {
    /// `weight · ‖matrix · x + offset‖`.
    pub fn new(weight: f64, matrix: SparseMatrix, offset: Vec<f64>) -> Self {
        Self {
            weight,
            matrix,
            offset,
        }
    }

    /// `weight · ‖matrix · x + offset‖` from a dense matrix.
    pub fn from_dense(weight: f64, matrix: &DenseMatrix, offset: Vec<f64>) -> Self {
        let mut a = SparseMatrix::new(matrix.nrows(), matrix.ncols());
        for i in 0..matrix.nrows() {
            for (j, &v) in matrix.row(i).iter().enumerate() {
                if v != 0.0 {
                    a.push(i, j, v);
                }
            }
        }
        Self::new(weight, a, offset)
    }

    /// `weight · ‖x[first] − x[second]‖` for index lists of equal length, in `n` variables
    /// (e.g. the difference of two consecutive controls `u_t − u_{t−1}`).
    pub fn difference(weight: f64, n: usize, first: &[usize], second: &[usize]) -> Self {
        let mut a = SparseMatrix::new(first.len().max(second.len()), n);
        for (r, &j) in first.iter().enumerate() {
            a.push(r, j, 1.0);
        }
        for (r, &j) in second.iter().enumerate() {
            a.push(r, j, -1.0);
        }
        Self::new(weight, a, vec![0.0; first.len().max(second.len())])
    }

    /// `weight · ‖x[indices] − center‖` in `n` variables.
    pub fn distance_to(weight: f64, n: usize, indices: &[usize], center: &[f64]) -> Self {
        let mut a = SparseMatrix::new(indices.len(), n);
        for (r, &j) in indices.iter().enumerate() {
            a.push(r, j, 1.0);
        }
        Self::new(weight, a, center.iter().map(|c| -c).collect())
    }
}

/// A declared objective term `weight · ‖r(x)‖₂` whose residual `r` (length `dimension`) is a
/// smooth nonlinear function the problem evaluates ([`Problem::residual`]) with its Jacobian
/// ([`Problem::residual_jacobian`]).
///
/// The SQP models it at each iterate by `weight · ‖r(x) + J(x) d‖` in a second-order cone, exactly
/// as a [`NormTerm`] with `A = J(x)`: a Gauss–Newton (prox-linear) model, which needs no curvature
/// estimate of `r` and is exact to first order. Its line search and results use the true
/// `‖r(x)‖`. L-BFGS adds it to the smooth objective with the gradient `weight · Jᵀr/‖r‖` (0 at
/// `r = 0`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ResidualNorm {
    /// Non-negative weight.
    pub weight: f64,
    /// Length of the residual `r` (≥ 1).
    pub dimension: usize,
}

impl ResidualNorm {
    /// `weight · ‖r(x)‖` with `r` of length `dimension`.
    pub fn new(weight: f64, dimension: usize) -> Self {
        Self { weight, dimension }
    }
}

/// A smooth, possibly constrained, minimization problem:
/// `min f(x) + Σ w_k‖A_k x + b_k‖ + Σ v_j‖r_j(x)‖  s.t.  c(x) ≥ 0, h(x) = 0, l ≤ x ≤ u`.
///
/// Only [`num_variables`](Problem::num_variables), [`objective`](Problem::objective) and
/// [`gradient`](Problem::gradient) are required. Methods take `&mut self` so an implementation may cache
/// work shared between calls at the same `x` (the solvers evaluate the objective and the constraints at a
/// trial point first, and their derivatives only once that point is accepted).
///
/// Any evaluation may fail with an [`EvalError`]; non-finite values count as failures too.
pub trait Problem {
    /// Number of variables `n`.
    fn num_variables(&self) -> usize;

    /// Number of inequality constraints `c(x) ≥ 0` (default 0).
    fn num_inequalities(&self) -> usize {
        0
    }

    /// Number of equality constraints `h(x) = 0` (default 0).
    fn num_equalities(&self) -> usize {
        0
    }

    /// Box bounds on the variables (default: none).
    fn bounds(&self) -> Option<Bounds> {
        None
    }

    /// Declared Euclidean-norm objective terms, excluded from [`objective`](Problem::objective) and
    /// [`gradient`](Problem::gradient) (default: none).
    fn norm_terms(&self) -> Vec<NormTerm> {
        Vec::new()
    }

    /// Declared nonlinear residual-norm objective terms `v_j‖r_j(x)‖`, excluded from
    /// [`objective`](Problem::objective) and [`gradient`](Problem::gradient) (default: none). A
    /// problem declaring some implements [`residual`](Problem::residual) and
    /// [`residual_jacobian`](Problem::residual_jacobian).
    fn residual_norms(&self) -> Vec<ResidualNorm> {
        Vec::new()
    }

    /// Writes the residual `r_j(x)` of residual norm `j` into `r` (length its `dimension`).
    fn residual(&mut self, _x: &[f64], _j: usize, _r: &mut [f64]) -> Result<(), EvalError> {
        Err(EvalError::new("Problem::residual is not implemented"))
    }

    /// Fills the `dimension × n` Jacobian of residual `j` (handed over zeroed, dense; may be
    /// replaced by a sparse one). The solvers call it after [`residual`](Problem::residual) at
    /// the same `x`, together with the other derivatives of an accepted point.
    fn residual_jacobian(
        &mut self,
        _x: &[f64],
        _j: usize,
        _jac: &mut Jacobian,
    ) -> Result<(), EvalError> {
        Err(EvalError::new(
            "Problem::residual_jacobian is not implemented",
        ))
    }

    /// An initial approximation of the Hessian of the Lagrangian of the smooth part, symmetric positive
    /// definite `n × n` (default: none, the SQP starts from the identity and rescales after its first step).
    fn initial_hessian(&self) -> Option<DenseMatrix> {
        None
    }

    /// Whether the iterate `x`, evaluated just before, meets a goal the problem has beyond
    /// optimality, e.g. a planning task's targets within their tolerance (default: never). The
    /// SQP's progress test ends a run whose whole steps no longer lower the objective or the KKT
    /// residual only at such points: there the caller has what it asked for, and elsewhere a
    /// slow descent may still be worth its iterations.
    fn goal_reached(&mut self, _x: &[f64]) -> bool {
        false
    }

    /// The smooth objective `f(x)`.
    fn objective(&mut self, x: &[f64]) -> Result<f64, EvalError>;

    /// Writes `∇f(x)` into `grad` (length `n`).
    fn gradient(&mut self, x: &[f64], grad: &mut [f64]) -> Result<(), EvalError>;

    /// Writes `c(x)` into `c` (length `m`).
    fn inequalities(&mut self, _x: &[f64], c: &mut [f64]) -> Result<(), EvalError> {
        if c.is_empty() {
            Ok(())
        } else {
            Err(EvalError::new("Problem::inequalities is not implemented"))
        }
    }

    /// Fills the `m × n` Jacobian of `c` (handed over zeroed, dense; may be replaced by a sparse one).
    fn inequality_jacobian(&mut self, _x: &[f64], jac: &mut Jacobian) -> Result<(), EvalError> {
        if jac.nrows() == 0 {
            Ok(())
        } else {
            Err(EvalError::new(
                "Problem::inequality_jacobian is not implemented",
            ))
        }
    }

    /// Fills the rows of the Jacobian of `c` marked in `wanted` (same conventions as
    /// [`inequality_jacobian`](Problem::inequality_jacobian)); the other rows may be left zero. The
    /// SQP solver calls this only with [`SqpSettings::jacobian_reuse_margin`](crate::SqpSettings)
    /// set, and keeps its previous values for the rows not wanted, whatever this method writes there.
    /// The default fills every row through `inequality_jacobian`; a problem whose rows cost work
    /// each (a backward pass per row, say) overrides it to skip them.
    fn inequality_jacobian_rows(
        &mut self,
        x: &[f64],
        _wanted: &[bool],
        jac: &mut Jacobian,
    ) -> Result<(), EvalError> {
        self.inequality_jacobian(x, jac)
    }

    /// Writes `h(x)` into `h` (length `p`).
    fn equalities(&mut self, _x: &[f64], h: &mut [f64]) -> Result<(), EvalError> {
        if h.is_empty() {
            Ok(())
        } else {
            Err(EvalError::new("Problem::equalities is not implemented"))
        }
    }

    /// Fills the `p × n` Jacobian of `h` (handed over zeroed, dense; may be replaced by a sparse one).
    fn equality_jacobian(&mut self, _x: &[f64], jac: &mut Jacobian) -> Result<(), EvalError> {
        if jac.nrows() == 0 {
            Ok(())
        } else {
            Err(EvalError::new(
                "Problem::equality_jacobian is not implemented",
            ))
        }
    }
}

/// Rows of a sparse matrix: each row's `(column, value)` entries, sorted, without duplicates.
pub(crate) type SparseRows = Vec<Vec<(usize, f64)>>;

/// What a validated norm term's residual is.
#[derive(Clone, Debug)]
pub(crate) enum NormKind {
    /// `A x + b`: the rows of `A` and the offset `b`.
    Linear { rows: SparseRows, offset: Vec<f64> },
    /// The problem's residual norm `index` ([`Problem::residual`]), of length `dim`.
    Residual { index: usize, dim: usize },
}

/// A validated norm term (declared [`NormTerm`]s first, then [`ResidualNorm`]s), ready for fast
/// residual evaluation.
#[derive(Clone, Debug)]
pub(crate) struct NormData {
    pub weight: f64,
    pub kind: NormKind,
}

/// `Err` unless `weight` is finite and non-negative (`what` names the term).
fn check_weight(weight: f64, what: &str) -> Result<(), OptimError> {
    if weight.is_finite() && weight >= 0.0 {
        Ok(())
    } else {
        Err(OptimError::InvalidProblem(format!(
            "{what} has weight {weight}, expected a finite value ≥ 0"
        )))
    }
}

impl NormData {
    /// The validated terms: `terms`, then `residuals`, in `n` variables.
    pub(crate) fn from_terms(
        terms: &[NormTerm],
        residuals: &[ResidualNorm],
        n: usize,
    ) -> Result<Vec<NormData>, OptimError> {
        let mut out: Vec<NormData> = terms
            .iter()
            .enumerate()
            .map(|(k, t)| Self::linear(k, t, n))
            .collect::<Result<_, _>>()?;
        for (index, r) in residuals.iter().enumerate() {
            check_weight(r.weight, &format!("residual norm {index}"))?;
            if r.dimension == 0 {
                return Err(OptimError::InvalidProblem(format!(
                    "residual norm {index} has dimension 0"
                )));
            }
            out.push(NormData {
                weight: r.weight,
                kind: NormKind::Residual {
                    index,
                    dim: r.dimension,
                },
            });
        }
        Ok(out)
    }

    /// The validated linear norm term `k`.
    fn linear(k: usize, t: &NormTerm, n: usize) -> Result<NormData, OptimError> {
        check_weight(t.weight, &format!("norm term {k}"))?;
        if t.matrix.ncols() != n {
            return Err(OptimError::DimensionMismatch {
                what: format!("columns of norm term {k}"),
                expected: n,
                got: t.matrix.ncols(),
            });
        }
        let p = t.matrix.nrows();
        if t.offset.len() != p {
            return Err(OptimError::DimensionMismatch {
                what: format!("offset of norm term {k}"),
                expected: p,
                got: t.offset.len(),
            });
        }
        if p == 0 {
            return Err(OptimError::InvalidProblem(format!(
                "norm term {k} has no rows"
            )));
        }
        if t.offset.iter().any(|v| !v.is_finite()) {
            return Err(OptimError::InvalidProblem(format!(
                "norm term {k} has a non-finite offset"
            )));
        }
        let mut rows: SparseRows = vec![Vec::new(); p];
        for &(i, j, v) in t.matrix.entries() {
            if i >= p || j >= n || !v.is_finite() {
                return Err(OptimError::InvalidProblem(format!(
                    "norm term {k} has an invalid entry ({i}, {j}, {v})"
                )));
            }
            rows[i].push((j, v));
        }
        for row in &mut rows {
            sort_row(row);
        }
        Ok(NormData {
            weight: t.weight,
            kind: NormKind::Linear {
                rows,
                offset: t.offset.clone(),
            },
        })
    }

    /// Length of the residual.
    pub(crate) fn dim(&self) -> usize {
        match &self.kind {
            NormKind::Linear { rows, .. } => rows.len(),
            NormKind::Residual { dim, .. } => *dim,
        }
    }

    /// The rows of the residual's Jacobian: `A` for a linear term, else `jacobian` (the
    /// problem's, evaluated at the iterate).
    pub(crate) fn rows<'a>(&'a self, jacobian: &'a SparseRows) -> &'a SparseRows {
        match &self.kind {
            NormKind::Linear { rows, .. } => rows,
            NormKind::Residual { .. } => jacobian,
        }
    }

    /// The model of the residual after the step `d` from `x`, where the residual is `r` and its
    /// Jacobian `jacobian`: `A(x + d) + b` for a linear term (exact), `r + J d` for a residual
    /// norm.
    pub(crate) fn model_residual(
        &self,
        x: &[f64],
        r: &[f64],
        jacobian: &SparseRows,
        d: &[f64],
    ) -> Vec<f64> {
        match &self.kind {
            NormKind::Linear { rows, offset } => {
                let xd: Vec<f64> = x.iter().zip(d).map(|(a, b)| a + b).collect();
                linear_residual(rows, offset, &xd)
            }
            NormKind::Residual { .. } => r
                .iter()
                .zip(jacobian)
                .map(|(ri, row)| ri + row.iter().map(|&(j, v)| v * d[j]).sum::<f64>())
                .collect(),
        }
    }
}

/// Sorts a sparse row by column, summing duplicate entries.
pub(crate) fn sort_row(row: &mut Vec<(usize, f64)>) {
    row.sort_by_key(|e| e.0);
    row.dedup_by(|later, earlier| {
        if later.0 == earlier.0 {
            earlier.1 += later.1;
            true
        } else {
            false
        }
    });
}

/// `A x + b` for `A`'s rows and `b`.
pub(crate) fn linear_residual(rows: &SparseRows, offset: &[f64], x: &[f64]) -> Vec<f64> {
    rows.iter()
        .zip(offset)
        .map(|(row, b)| b + row.iter().map(|&(j, v)| v * x[j]).sum::<f64>())
        .collect()
}

/// `out += Aᵀ y` for `A`'s rows.
pub(crate) fn tmul_add(rows: &SparseRows, y: &[f64], out: &mut [f64]) {
    for (row, &yi) in rows.iter().zip(y) {
        for &(j, v) in row {
            out[j] += v * yi;
        }
    }
}
