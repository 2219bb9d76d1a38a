//! The QP subproblem of the SQP, assembled in Clarabel's conic form and solved by Clarabel.
//!
//! Variables `z = [d (n) | s (K) | t (mₑ) | p (q) | r (q)]`: the step, one epigraph variable per norm
//! term, elastic slacks of the inequalities violated at `x` (`mₑ` of them; the others hold at `d = 0`
//! and need none), and the positive/negative elastic parts of the equalities.
//!
//! ```text
//! minimize   ½ dᵀBd + gᵀd + Σ w_k s_k + Σ νᵢ tᵢ + Σ νⱼ (pⱼ + rⱼ)
//! subject to h + J_h d − p + r = 0                      zero cone        (q rows)
//!            c + J_c d + t ≥ 0   (t only where c < 0)   nonnegative cone (m rows)
//!            t, p, r ≥ 0                                nonnegative cone (mₑ + 2q rows)
//!            d ≤ d_up,  −d ≤ −d_lo                      nonnegative cone (2n rows: bounds ∩ step box)
//!            (s_k, A_k d + A_k x + b_k) ∈ SOC           one second-order cone per norm term
//! ```
//!
//! The feasibility variant drops the objective's `B`, `g` and norm terms and minimizes `Σ t + Σ p + Σ r`
//! (the smallest linearized ℓ1 violation reachable inside the step box). `d = 0`, `t = max(0, −c)`, … is
//! always feasible, so neither problem can be infeasible (the second-order correction changes `c` and
//! may be, which only means the correction is skipped); Clarabel's infeasibility verdicts are treated
//! as numerical failures by the caller.
//!
//! Clarabel has no warm start, but it can re-solve after a data update with the same sparsity: the
//! penalty weights `ν` live only in `q` ([`QpSubproblem::update_penalty`]) and a second-order correction only
//! changes `b` ([`QpSubproblem::update_constraint_values`]), so both reuse the factorization structure.
//!
//! Three guards against Clarabel's numerical failures on perfectly well-posed data:
//!
//! * Inequalities whose Jacobian row is all zero at `x` are left out of the conic problem: their
//!   linearization `cᵢ + 0·d ≥ 0` does not depend on `d` (it holds for every step or for none), and a
//!   row `cᵢ = 0`, `0·d + sᵢ = cᵢ` would force its cone slack to zero — an empty interior that the
//!   interior-point method handles badly. Their multipliers are reported as 0 and their (constant)
//!   linearized violation is accounted for by the caller, who evaluates it from `c` and `J` directly.
//! * A solve that ends in `MaxIterations`, `InsufficientProgress`, `NumericalError` or (for the
//!   subproblems that are feasible by construction, i.e. not a second-order correction) an
//!   infeasibility verdict is retried from scratch with fallback settings ([`FALLBACKS`]). Clarabel
//!   0.11's Ruiz equilibration can send its interior-point iteration into a limit cycle (the duality
//!   gap stalls at ~1e-2 while μ → 0, until `MaxIterations`) on small, well-conditioned QPs; the same
//!   problem without equilibration solves in ~10 iterations (oxfordcontrol/Clarabel.rs#217 reports
//!   the same behaviour).
//! * If every fallback fails too and the gradient has entries above 1, the objective is divided by
//!   the gradient's largest entry and solved once more (with the defaults, then each fallback): the same minimizer, with
//!   duals scaled by the same factor (undone before they are returned). The first QP of a nearly
//!   unstable rollout (`swing` at 1000 iterations per step, gradient entries from 1e10 down to
//!   1e-4) is `DualInfeasible` with every setting until it is scaled. Scaling only after a failure
//!   leaves every QP Clarabel solves as given bit for bit as it was.

use crate::linalg::Jacobian;
use crate::problem::NormData;
use clarabel::algebra::CscMatrix;
use clarabel::solver::{
    DefaultSettings, DefaultSettingsBuilder, DefaultSolution, DefaultSolver, IPSolver,
    SolverStatus, SupportedConeT,
};

/// The data of one subproblem, borrowed from the SQP state.
pub(crate) struct QpData<'a> {
    pub n: usize,
    /// Row-major `n × n` Hessian approximation (symmetric positive definite).
    pub hessian: &'a [f64],
    pub gradient: &'a [f64],
    pub ineq: &'a [f64],
    pub ineq_jac: &'a Jacobian,
    pub eq: &'a [f64],
    pub eq_jac: &'a Jacobian,
    pub norms: &'a [NormData],
    /// `A_k x + b_k` at the current point.
    pub norm_residuals: &'a [Vec<f64>],
    /// Box on the step: bounds of the variables intersected with the step bound.
    pub step_lower: &'a [f64],
    pub step_upper: &'a [f64],
}

/// `q` entries of the elastic variables: `ν_i` for the slack of elastic inequality `i`, `ν_{m+j}` for
/// both `p_j` and `r_j`.
fn elastic_costs(weights: &[f64], elastic: &[usize], m: usize, q: usize, out: &mut [f64]) {
    let me = elastic.len();
    for (o, &i) in out.iter_mut().zip(elastic) {
        *o = weights[i];
    }
    out[me..me + q].copy_from_slice(&weights[m..m + q]);
    out[me + q..me + 2 * q].copy_from_slice(&weights[m..m + q]);
}

/// Which problem to build.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum QpMode {
    /// The elastic SQP subproblem with per-constraint penalty weights `ν` (inequalities, then equalities).
    Optimality,
    /// Minimize the linearized ℓ1 violation only.
    Feasibility,
}

/// How Clarabel finished.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum QpOutcome {
    Solved,
    AlmostSolved,
    Failed(SolverStatus),
}

impl QpOutcome {
    pub(crate) fn is_usable(&self) -> bool {
        matches!(self, QpOutcome::Solved | QpOutcome::AlmostSolved)
    }
}

/// A subproblem solution in the SQP's sign conventions.
#[derive(Clone, Debug)]
pub(crate) struct QpSolution {
    pub outcome: QpOutcome,
    pub d: Vec<f64>,
    /// Inequality multipliers (`∇f + … = Jᵀλ`), raw from the cone duals.
    pub lambda: Vec<f64>,
    /// Equality multipliers.
    pub mu: Vec<f64>,
    /// Duals of the lower/upper step-box rows.
    pub box_lower: Vec<f64>,
    pub box_upper: Vec<f64>,
    /// Norm-term subgradients `y_k` (raw; `‖y_k‖ ≤ w_k` up to solver accuracy).
    pub norm_duals: Vec<Vec<f64>>,
}

/// Error building the subproblem (a bug or a Clarabel rejection, never user-data dependent in a way
/// the caller cannot handle).
#[derive(Debug, Clone)]
pub(crate) struct QpBuildError(pub String);

/// Row/column offsets of the blocks.
#[derive(Clone, Copy, Debug)]
struct Layout {
    n: usize,
    k: usize,
    q: usize,
    row_ineq: usize,
    row_box_up: usize,
    row_box_lo: usize,
    row_soc: usize,
}

/// Fallback settings tried, in order, when Clarabel fails with its defaults (see the module docs):
/// `(equilibrate, max_step_fraction, static_regularization_constant)`.
const FALLBACKS: [(bool, f64, f64); 3] =
    [(false, 0.99, 1e-8), (true, 0.9, 1e-8), (false, 0.9, 1e-7)];

/// The conic data, kept so that a failed solve can be repeated with fallback settings.
struct ConicData {
    p: CscMatrix<f64>,
    q: Vec<f64>,
    a: CscMatrix<f64>,
    b: Vec<f64>,
    cones: Vec<SupportedConeT<f64>>,
}

/// A built subproblem owning its Clarabel solver.
pub(crate) struct QpSubproblem {
    solver: DefaultSolver<f64>,
    conic: ConicData,
    tolerance: f64,
    max_iterations: u32,
    layout: Layout,
    norm_dims: Vec<usize>,
    /// Total number of inequalities of the SQP problem.
    m_total: usize,
    /// Inequalities in the conic problem, in order: those whose Jacobian row is not all zero.
    kept: Vec<usize>,
    /// Inequalities with an elastic slack: those violated at `x` (the others hold at `d = 0`).
    elastic_ids: Vec<usize>,
    /// `d = 0` with the elastic slacks is feasible: false after a second-order correction changed `b`,
    /// whose infeasibility verdicts are then genuine and not worth a retry.
    feasible_by_construction: bool,
}

/// Clarabel settings: the defaults used for every first attempt, or a fallback.
fn clarabel_settings(
    tolerance: f64,
    max_iterations: u32,
    fallback: Option<(bool, f64, f64)>,
) -> Result<DefaultSettings<f64>, QpBuildError> {
    let mut b = DefaultSettingsBuilder::<f64>::default();
    b.verbose(false)
        .presolve_enable(false)
        .max_iter(max_iterations)
        .tol_gap_abs(tolerance)
        .tol_gap_rel(tolerance)
        .tol_feas(tolerance);
    if let Some((equilibrate, step, reg)) = fallback {
        b.equilibrate_enable(equilibrate)
            .max_step_fraction(step)
            .static_regularization_constant(reg);
    }
    b.build()
        .map_err(|e| QpBuildError(format!("Clarabel settings: {e}")))
}

/// Triplets pushed in increasing row order, compressed to CSC by a stable counting sort on columns
/// (so rows stay sorted within a column); duplicates are merged.
struct TripletBuilder {
    rows: Vec<usize>,
    cols: Vec<usize>,
    vals: Vec<f64>,
}

impl TripletBuilder {
    fn with_capacity(cap: usize) -> Self {
        Self {
            rows: Vec::with_capacity(cap),
            cols: Vec::with_capacity(cap),
            vals: Vec::with_capacity(cap),
        }
    }

    fn push(&mut self, r: usize, c: usize, v: f64) {
        self.rows.push(r);
        self.cols.push(c);
        self.vals.push(v);
    }

    fn into_csc(self, m: usize, n: usize) -> CscMatrix<f64> {
        let nnz = self.vals.len();
        let mut colptr = vec![0usize; n + 1];
        for &c in &self.cols {
            colptr[c + 1] += 1;
        }
        for j in 0..n {
            colptr[j + 1] += colptr[j];
        }
        let mut next = colptr.clone();
        let mut rowval = vec![0usize; nnz];
        let mut nzval = vec![0.0; nnz];
        for idx in 0..nnz {
            let c = self.cols[idx];
            let dst = next[c];
            rowval[dst] = self.rows[idx];
            nzval[dst] = self.vals[idx];
            next[c] += 1;
        }
        // Sort within columns if needed (sparse user input may be out of order) and merge duplicates.
        let mut out_colptr = vec![0usize; n + 1];
        let mut out_rows = Vec::with_capacity(nnz);
        let mut out_vals = Vec::with_capacity(nnz);
        for j in 0..n {
            let (a, b) = (colptr[j], colptr[j + 1]);
            let mut seg: Vec<(usize, f64)> = (a..b).map(|i| (rowval[i], nzval[i])).collect();
            if !seg.windows(2).all(|w| w[0].0 < w[1].0) {
                seg.sort_by_key(|e| e.0);
            }
            for (r, v) in seg {
                if out_rows.len() > out_colptr[j] && out_rows.last() == Some(&r) {
                    if let Some(last) = out_vals.last_mut() {
                        *last += v;
                    }
                } else {
                    out_rows.push(r);
                    out_vals.push(v);
                }
            }
            out_colptr[j + 1] = out_rows.len();
        }
        CscMatrix::new(m, n, out_colptr, out_rows, out_vals)
    }
}

impl QpSubproblem {
    /// Assembles `P, q, A, b` and the cones, and sets up Clarabel.
    pub(crate) fn new(
        data: &QpData<'_>,
        mode: QpMode,
        weights: &[f64],
        tolerance: f64,
        max_iterations: u32,
    ) -> Result<Self, QpBuildError> {
        let n = data.n;
        let q = data.eq.len();
        let with_norms = matches!(mode, QpMode::Optimality);
        let k = if with_norms { data.norms.len() } else { 0 };
        let norm_dims: Vec<usize> = if with_norms {
            data.norms.iter().map(|nd| nd.rows.len()).collect()
        } else {
            Vec::new()
        };
        // Rows with an all-zero Jacobian are not part of the conic problem (see the module docs).
        let m_total = data.ineq.len();
        let row_norms = data.ineq_jac.row_inf_norms();
        let kept: Vec<usize> = (0..m_total).filter(|&i| row_norms[i] > 0.0).collect();
        let m = kept.len();
        let mut ineq_row = vec![usize::MAX; m_total];
        for (r, &i) in kept.iter().enumerate() {
            ineq_row[i] = r;
        }
        // Only constraints violated at x need an elastic slack: d = 0 satisfies the others, so the QP
        // stays feasible with far fewer variables and rows when most constraints hold (the usual case).
        let elastic: Vec<usize> = (0..m).filter(|&r| data.ineq[kept[r]] < 0.0).collect();
        let elastic_ids: Vec<usize> = elastic.iter().map(|&r| kept[r]).collect();
        let me = elastic.len();
        let nvar = n + k + me + 2 * q;
        let row_ineq = q;
        let row_slack = row_ineq + m;
        let row_box_up = row_slack + me + 2 * q;
        let row_box_lo = row_box_up + n;
        let row_soc = row_box_lo + n;
        let nrows = row_soc + norm_dims.iter().map(|p| p + 1).sum::<usize>();
        let layout = Layout {
            n,
            k,
            q,
            row_ineq,
            row_box_up,
            row_box_lo,
            row_soc,
        };
        let (col_s, col_t, col_p, col_r) = (n, n + k, n + k + me, n + k + me + q);

        // P: upper triangle of B (optimality mode only).
        let mut p_trip = TripletBuilder::with_capacity(n * (n + 1) / 2);
        if with_norms {
            for i in 0..n {
                for j in i..n {
                    let v = data.hessian[i * n + j];
                    if v != 0.0 {
                        p_trip.push(i, j, v);
                    }
                }
            }
        }
        let p_mat = p_trip.into_csc(nvar, nvar);

        // q: `[g | w_k | elastic costs]` (see `elastic_costs`), or `[0 | 1]` for the feasibility LP.
        let mut qv = vec![0.0; nvar];
        match mode {
            QpMode::Optimality => {
                qv[..n].copy_from_slice(data.gradient);
                for (kk, nd) in data.norms.iter().enumerate() {
                    qv[col_s + kk] = nd.weight;
                }
                elastic_costs(weights, &elastic_ids, m_total, q, &mut qv[col_t..]);
            }
            QpMode::Feasibility => qv[col_t..].fill(1.0),
        }

        // A, b (rows pushed in increasing order)
        let jac_nnz_hint = n * (m + q);
        let mut a = TripletBuilder::with_capacity(jac_nnz_hint + m + 2 * me + 6 * q + 2 * n);
        let mut b = vec![0.0; nrows];
        // Zero cone: J_h d − p + r = −h
        data.eq_jac.for_each_nonzero(|i, j, v| a.push(i, j, v));
        for (i, (bi, hi)) in b.iter_mut().zip(data.eq).enumerate() {
            a.push(i, col_p + i, -1.0);
            a.push(i, col_r + i, 1.0);
            *bi = -hi;
        }
        // Inequalities: −J_c d − t ≤ c
        data.ineq_jac.for_each_nonzero(|i, j, v| {
            if ineq_row[i] != usize::MAX {
                a.push(row_ineq + ineq_row[i], j, -v);
            }
        });
        for (r, &i) in kept.iter().enumerate() {
            b[row_ineq + r] = data.ineq[i];
        }
        for (kk, &r) in elastic.iter().enumerate() {
            a.push(row_ineq + r, col_t + kk, -1.0);
        }
        // Slacks ≥ 0
        for i in 0..me + 2 * q {
            a.push(row_slack + i, col_t + i, -1.0);
        }
        // Step box
        for j in 0..n {
            a.push(row_box_up + j, j, 1.0);
            b[row_box_up + j] = data.step_upper[j];
        }
        for j in 0..n {
            a.push(row_box_lo + j, j, -1.0);
            b[row_box_lo + j] = -data.step_lower[j];
        }
        // Second-order cones: (s_k, A_k d + r_k)
        let mut row = row_soc;
        for (kk, nd) in data.norms.iter().enumerate().take(k) {
            a.push(row, col_s + kk, -1.0);
            row += 1;
            for (i, arow) in nd.rows.iter().enumerate() {
                for &(j, v) in arow {
                    a.push(row, j, -v);
                }
                b[row] = data.norm_residuals[kk][i];
                row += 1;
            }
        }
        // The row-major Jacobian loop pushes rows in order per block, but the zero-cone block of a
        // sparse Jacobian may be unordered; `into_csc` sorts within columns where needed.
        let a_mat = a.into_csc(nrows, nvar);

        let mut cones = Vec::with_capacity(2 + k);
        if q > 0 {
            cones.push(SupportedConeT::ZeroConeT(q));
        }
        cones.push(SupportedConeT::NonnegativeConeT(m + me + 2 * q + 2 * n));
        for &p in &norm_dims {
            cones.push(SupportedConeT::SecondOrderConeT(p + 1));
        }

        let settings = clarabel_settings(tolerance, max_iterations, None)?;
        let solver = DefaultSolver::new(&p_mat, &qv, &a_mat, &b, &cones, settings)
            .map_err(|e| QpBuildError(format!("Clarabel setup: {e}")))?;
        Ok(Self {
            solver,
            conic: ConicData {
                p: p_mat,
                q: qv,
                a: a_mat,
                b,
                cones,
            },
            tolerance,
            max_iterations,
            layout,
            norm_dims,
            m_total,
            kept,
            elastic_ids,
            feasible_by_construction: true,
        })
    }

    /// Changes the elastic weights `ν` (optimality mode) keeping everything else: only the elastic
    /// part of `q` is rewritten.
    pub(crate) fn update_penalty(&mut self, weights: &[f64]) -> Result<(), QpBuildError> {
        let l = self.layout;
        let mut qv = self.conic.q.clone();
        elastic_costs(
            weights,
            &self.elastic_ids,
            self.m_total,
            l.q,
            &mut qv[l.n + l.k..],
        );
        self.solver
            .update_q(&qv)
            .map_err(|e| QpBuildError(format!("Clarabel update_q: {e}")))?;
        self.conic.q = qv;
        Ok(())
    }

    /// Replaces the constraint values `c`, `h` in the right-hand side (second-order correction:
    /// `c(x+d) − J d`, `h(x+d) − J_h d`), keeping the matrices and the other rows of `b` (slacks,
    /// step box, norm residuals).
    pub(crate) fn update_constraint_values(
        &mut self,
        ineq: &[f64],
        eq: &[f64],
    ) -> Result<(), QpBuildError> {
        let l = self.layout;
        let mut b = self.conic.b.clone();
        for (bi, hi) in b[..l.q].iter_mut().zip(eq) {
            *bi = -hi;
        }
        for (r, &i) in self.kept.iter().enumerate() {
            b[l.row_ineq + r] = ineq[i];
        }
        self.solver
            .update_b(&b)
            .map_err(|e| QpBuildError(format!("Clarabel update_b: {e}")))?;
        self.conic.b = b;
        self.feasible_by_construction = false;
        Ok(())
    }

    /// Runs Clarabel and extracts the solution. If Clarabel fails numerically, the same data is
    /// solved again from scratch with each of the [`FALLBACKS`] settings, then (when the gradient
    /// has entries above 1) with the objective scaled, until one succeeds (see the module docs);
    /// if none does, the outcome is the failure status of the first attempt.
    pub(crate) fn solve(&mut self) -> QpSolution {
        self.solver.solve();
        let first = self.extract(&self.solver.solution);
        let retry = match first.outcome {
            QpOutcome::Solved | QpOutcome::AlmostSolved => false,
            QpOutcome::Failed(
                SolverStatus::MaxIterations
                | SolverStatus::InsufficientProgress
                | SolverStatus::NumericalError,
            ) => true,
            QpOutcome::Failed(
                SolverStatus::PrimalInfeasible
                | SolverStatus::AlmostPrimalInfeasible
                | SolverStatus::DualInfeasible
                | SolverStatus::AlmostDualInfeasible,
            ) => self.feasible_by_construction,
            // MaxTime (no limit is set), CallbackTerminated, Unsolved.
            QpOutcome::Failed(_) => false,
        };
        if !retry {
            return first;
        }
        for fallback in FALLBACKS {
            if let Some(sol) = self.solve_usable(None, Some(fallback)) {
                return sol;
            }
        }
        // A gradient of 1e10 defeats every setting: divided by its largest entry, the objective
        // has the same minimizer, and the duals are scaled by the same factor.
        let largest = self.conic.q[..self.layout.n]
            .iter()
            .fold(0.0_f64, |m, v| m.max(v.abs()));
        if largest > 1.0 {
            for fallback in std::iter::once(None).chain(FALLBACKS.map(Some)) {
                if let Some(sol) = self.solve_usable(Some(1.0 / largest), fallback) {
                    return sol;
                }
            }
        }
        first
    }

    /// Solves the data from scratch with Clarabel's `fallback` settings (defaults if `None`)
    /// and the objective (`P`, `q`) multiplied by `scale` if given (the duals returned are
    /// those of the data as built); `None` unless the solution is usable.
    fn solve_usable(
        &self,
        scale: Option<f64>,
        fallback: Option<(bool, f64, f64)>,
    ) -> Option<QpSolution> {
        let settings = clarabel_settings(self.tolerance, self.max_iterations, fallback).ok()?;
        let c = &self.conic;
        let scaled;
        let (p, q) = match scale {
            None => (&c.p, &c.q),
            Some(s) => {
                let mut p = c.p.clone();
                p.nzval.iter_mut().for_each(|v| *v *= s);
                scaled = (p, c.q.iter().map(|v| v * s).collect::<Vec<f64>>());
                (&scaled.0, &scaled.1)
            }
        };
        let mut solver = DefaultSolver::new(p, q, &c.a, &c.b, &c.cones, settings).ok()?;
        solver.solve();
        if let Some(s) = scale {
            solver.solution.z.iter_mut().for_each(|v| *v /= s);
        }
        Some(self.extract(&solver.solution)).filter(|sol| sol.outcome.is_usable())
    }

    /// A Clarabel solution in the SQP's conventions.
    fn extract(&self, sol: &DefaultSolution<f64>) -> QpSolution {
        let l = self.layout;
        let outcome = match sol.status {
            SolverStatus::Solved => QpOutcome::Solved,
            SolverStatus::AlmostSolved => QpOutcome::AlmostSolved,
            other => QpOutcome::Failed(other),
        };
        let x = &sol.x;
        let z = &sol.z;
        let d = x[..l.n].to_vec();
        // Rows left out of the conic problem (all-zero Jacobian row) get multiplier 0.
        let mut lambda = vec![0.0; self.m_total];
        for (r, &i) in self.kept.iter().enumerate() {
            lambda[i] = z[l.row_ineq + r];
        }
        let mu = z[..l.q].iter().map(|v| -v).collect();
        let box_upper = z[l.row_box_up..l.row_box_up + l.n].to_vec();
        let box_lower = z[l.row_box_lo..l.row_box_lo + l.n].to_vec();
        let mut norm_duals = Vec::with_capacity(l.k);
        let mut row = l.row_soc;
        for &p in &self.norm_dims {
            norm_duals.push(z[row + 1..row + 1 + p].iter().map(|v| -v).collect());
            row += p + 1;
        }
        QpSolution {
            outcome,
            d,
            lambda,
            mu,
            box_lower,
            box_upper,
            norm_duals,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::linalg::{DenseMatrix, SparseMatrix};
    use crate::problem::NormTerm;

    #[test]
    fn triplets_compress_sorted_and_merged() {
        let mut t = TripletBuilder::with_capacity(4);
        t.push(2, 0, 1.0);
        t.push(0, 0, 2.0);
        t.push(0, 0, 3.0);
        t.push(1, 1, 4.0);
        let c = t.into_csc(3, 2);
        assert_eq!(c.colptr, vec![0, 2, 3]);
        assert_eq!(c.rowval, vec![0, 2, 1]);
        assert_eq!(c.nzval, vec![5.0, 1.0, 4.0]);
        assert!(c.check_format().is_ok());
    }

    #[test]
    fn huge_gradient_gives_the_clipped_step_and_unscaled_duals() {
        // The first QP of `swing` simulated with 1000 iterations per step, in miniature: 10 steps of
        // 6 controls from rest, identity Hessian, the step box ±0.5, one norm term per step
        // difference, and the rollout's gradient, whose entries fall from 1e10 (a nearly unstable
        // rollout) to 1e-4 over the steps. Clarabel reports `DualInfeasible` on this data with its defaults and
        // with every fallback setting; divided by its largest entry, it solves.
        let (steps, width) = (10, 6);
        let n = steps * width;
        // ∂L/∂U of `swing` at rest with 1000 iterations per step, rounded to 4 digits.
        #[rustfmt::skip]
        let g: [f64; 60] = [
            1.0608e-01, 1.0317e+10, -3.4232e-01, -1.4497e-01, 1.0532e+07, -3.3580e-01,
            1.0787e-01, 2.2234e+09, -3.4387e-01, -1.4346e-01, 7.0376e+06, -3.3259e-01,
            1.1037e-01, 9.2754e+07, -3.4610e-01, -1.4131e-01, 3.0972e+05, -3.2830e-01,
            1.1375e-01, 1.7099e+06, -3.4897e-01, -1.3826e-01, 5.3813e+03, -3.2231e-01,
            1.1813e-01, 2.0921e+04, -3.5232e-01, -1.3387e-01, 6.0166e+01, -3.1374e-01,
            1.2349e-01, 2.0704e+02, -3.5540e-01, -1.2746e-01, 3.9819e-01, -3.0116e-01,
            1.2921e-01, 1.8185e+00, -3.5595e-01, -1.1787e-01, -6.4515e-02, -2.8216e-01,
            1.3302e-01, -1.1337e-02, -3.4787e-01, -1.0314e-01, -3.3442e-02, -2.5236e-01,
            1.2818e-01, -7.1756e-03, -3.1571e-01, -8.0007e-02, -1.0328e-02, -2.0352e-01,
            9.6148e-02, -3.6904e-04, -2.2175e-01, -4.4340e-02, -8.2904e-04, -1.2139e-01,
        ];
        let mut h = vec![0.0; n * n];
        for j in 0..n {
            h[j * n + j] = 1.0;
        }
        let terms: Vec<NormTerm> = (1..steps)
            .map(|t| {
                let mut a = SparseMatrix::new(width, n);
                for k in 0..width {
                    a.push(k, width * (t - 1) + k, -1.0);
                    a.push(k, width * t + k, 1.0);
                }
                NormTerm::new(1.0, a, vec![0.0; width])
            })
            .collect();
        let norms = NormData::from_terms(&terms, n).expect("norm terms");
        let residuals = vec![vec![0.0; width]; steps - 1];
        let (jc, je) = (Jacobian::dense(0, n), Jacobian::dense(0, n));
        let (lo, up) = (vec![-0.5; n], vec![0.5; n]);
        let data = QpData {
            n,
            hessian: &h,
            gradient: &g,
            ineq: &[],
            ineq_jac: &jc,
            eq: &[],
            eq_jac: &je,
            norms: &norms,
            norm_residuals: &residuals,
            step_lower: &lo,
            step_upper: &up,
        };
        let mut qp = QpSubproblem::new(&data, QpMode::Optimality, &[], 1e-9, 200).expect("build");
        // The premise: the data as built defeats the defaults and every fallback.
        qp.solver.solve();
        assert!(!qp.extract(&qp.solver.solution).outcome.is_usable());
        for fallback in FALLBACKS {
            assert!(qp.solve_usable(None, Some(fallback)).is_none());
        }
        let s = qp.solve();
        assert!(s.outcome.is_usable(), "{:?}", s.outcome);
        // The steep coordinates (within 1e6 of the steepest: the solve's accuracy is relative to
        // the largest entry) sit on the box, against their gradient, and their box duals
        // (unscaled) balance the gradient: d + g + z_up − z_lo − (norm terms) = 0, the norm
        // terms' part at most 2 (two unit-weight terms per coordinate).
        let largest = g.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
        for j in (0..n).filter(|&j| g[j].abs() >= 1e-6 * largest) {
            let want = -0.5 * g[j].signum();
            assert!((s.d[j] - want).abs() < 1e-6, "d[{j}] = {} ≠ {want}", s.d[j]);
            let dual = s.box_upper[j] - s.box_lower[j];
            let residual = s.d[j] + g[j] + dual;
            assert!(residual.abs() <= 2.0 + 1e-9, "stationarity {j}: {residual}");
        }
        assert!(s.d.iter().all(|d| d.abs() <= 0.5 + 1e-9), "{:?}", s.d);
    }

    #[test]
    fn box_constrained_qp_matches_closed_form() {
        // min ½‖d‖² + gᵀd, d ∈ [-1, 1]², c: d0 + d1 ≥ 0.5 − 0 (c = −0.5, J = [1, 1])
        let g = [1.0, -3.0];
        let h = [1.0, 0.0, 0.0, 1.0];
        let jc = Jacobian::Dense(DenseMatrix::from_rows(&[vec![1.0, 1.0]]).unwrap());
        let je = Jacobian::dense(0, 2);
        let data = QpData {
            n: 2,
            hessian: &h,
            gradient: &g,
            ineq: &[-0.5],
            ineq_jac: &jc,
            eq: &[],
            eq_jac: &je,
            norms: &[],
            norm_residuals: &[],
            step_lower: &[-1.0, -1.0],
            step_upper: &[1.0, 1.0],
        };
        let mut qp =
            QpSubproblem::new(&data, QpMode::Optimality, &[100.0], 1e-9, 100).expect("build");
        let s = qp.solve();
        assert!(s.outcome.is_usable());
        // Unconstrained minimizer (-1, 3) clipped: d1 = 1 (upper bound), d0 = -1, d0 + d1 = 0 ≥ 0.5? No:
        // the linear constraint is active: d0 + d1 = 0.5 with d1 = 1 → d0 = -0.5.
        assert!((s.d[0] + 0.5).abs() < 1e-6, "{:?}", s.d);
        assert!((s.d[1] - 1.0).abs() < 1e-6, "{:?}", s.d);
        // Stationarity in d0: d0 + g0 = λ → λ = 0.5
        assert!((s.lambda[0] - 0.5).abs() < 1e-6);
    }
}
