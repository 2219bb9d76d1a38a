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
//! A residual norm `v‖r(x)‖` enters as a norm term with `A_k x + b_k = r(x)` and `A_k = J(x)`, its
//! Jacobian at the iterate: the Gauss–Newton (prox-linear) model.
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
//!   infeasibility verdict is retried from scratch with fallback settings ([`FALLBACKS`](solve::FALLBACKS)). Clarabel
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

mod csc;
mod solve;

use csc::TripletBuilder;
use solve::clarabel_settings;

use crate::linalg::Jacobian;
use crate::problem::{NormData, SparseRows};
use clarabel::algebra::CscMatrix;
use clarabel::solver::{DefaultSolver, SolverStatus, SupportedConeT};

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
    /// Per norm term, the rows of its matrix or of its residual's Jacobian at the current point
    /// ([`NormData::rows`]).
    pub norm_rows: Vec<&'a SparseRows>,
    /// `A_k x + b_k` (or the residual `r_k(x)`) at the current point.
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
            data.norms.iter().map(NormData::dim).collect()
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
        for (kk, rows) in data.norm_rows.iter().enumerate().take(k) {
            a.push(row, col_s + kk, -1.0);
            row += 1;
            for (i, arow) in rows.iter().enumerate() {
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
}

#[cfg(test)]
mod tests;
