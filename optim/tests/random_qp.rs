//! Property test: random strictly convex QPs with a known optimum, built through the KKT conditions.
//!
//! `min ½xᵀQx + gᵀx  s.t.  Ax ≥ b`, `Q = LLᵀ + I`. Pick `x*`, an active set `S` (at most `n` random rows,
//! so linearly independent almost surely), multipliers `λ_S > 0` and slacks `> 0` for the others;
//! set `b_i = a_iᵀx*` on `S`, `b_i = a_iᵀx* − slack_i` off it, and `g = Aᵀλ − Qx*`. Then `x*` is the
//! unique optimum. Given the exact Hessian as its initial matrix, the SQP must find it in one or two
//! iterations from any start.
//!
//! A second property injects degenerate rows — all-zero rows (`0 ≥ 0` when active, `0 ≥ −slack`
//! otherwise) and exact duplicates of earlier rows (identical constraints when both are active) —
//! which are legitimate input: the optimum is still unique, only the multipliers are not.

use optim::{DenseMatrix, EvalError, Jacobian, Problem, SqpSettings, SqpSolver, Status};
use proptest::prelude::*;

struct RandomQp {
    n: usize,
    q: Vec<f64>,
    g: Vec<f64>,
    a: DenseMatrix,
    b: Vec<f64>,
}

impl Problem for RandomQp {
    fn num_variables(&self) -> usize {
        self.n
    }
    fn num_inequalities(&self) -> usize {
        self.b.len()
    }
    fn initial_hessian(&self) -> Option<DenseMatrix> {
        DenseMatrix::from_row_major(self.n, self.n, self.q.clone())
    }
    fn objective(&mut self, x: &[f64]) -> Result<f64, EvalError> {
        let n = self.n;
        let mut f = 0.0;
        for i in 0..n {
            f += self.g[i] * x[i];
            for j in 0..n {
                f += 0.5 * x[i] * self.q[i * n + j] * x[j];
            }
        }
        Ok(f)
    }
    fn gradient(&mut self, x: &[f64], grad: &mut [f64]) -> Result<(), EvalError> {
        let n = self.n;
        for (i, gi) in grad.iter_mut().enumerate() {
            *gi = self.g[i] + (0..n).map(|j| self.q[i * n + j] * x[j]).sum::<f64>();
        }
        Ok(())
    }
    fn inequalities(&mut self, x: &[f64], c: &mut [f64]) -> Result<(), EvalError> {
        for (i, ci) in c.iter_mut().enumerate() {
            *ci = self.a.row(i).iter().zip(x).map(|(a, x)| a * x).sum::<f64>() - self.b[i];
        }
        Ok(())
    }
    fn inequality_jacobian(&mut self, _x: &[f64], jac: &mut Jacobian) -> Result<(), EvalError> {
        *jac = Jacobian::Dense(self.a.clone());
        Ok(())
    }
}

/// Inputs: dimensions, raw numbers in [-1, 1] from which everything is built.
fn qp_strategy() -> impl Strategy<Value = (usize, usize, usize, Vec<f64>)> {
    (2usize..7, 1usize..8).prop_flat_map(|(n, m)| {
        let k_max = m.min(n);
        (
            Just(n),
            Just(m),
            0..=k_max,
            prop::collection::vec(-1.0f64..1.0, n * n + m * n + 3 * n + 2 * m),
        )
    })
}

/// Row `i` of `A` as drawn, or all zero (`0`), or a copy of an earlier row (`1 + j`, `j < i`).
#[derive(Clone, Copy, Debug)]
enum RowKind {
    Drawn,
    Zero,
    Copy(usize),
}

fn build(n: usize, m: usize, k: usize, raw: &[f64]) -> (RandomQp, Vec<f64>, Vec<f64>) {
    build_with_rows(n, m, k, raw, &vec![RowKind::Drawn; m])
}

fn build_with_rows(
    n: usize,
    m: usize,
    k: usize,
    raw: &[f64],
    kinds: &[RowKind],
) -> (RandomQp, Vec<f64>, Vec<f64>) {
    let mut it = raw.iter().copied();
    let mut next = || it.next().unwrap_or(0.0);
    let l: Vec<f64> = (0..n * n).map(|_| next()).collect();
    let mut q = vec![0.0; n * n];
    for i in 0..n {
        for j in 0..n {
            q[i * n + j] = (0..n).map(|t| l[i * n + t] * l[j * n + t]).sum::<f64>();
        }
        q[i * n + i] += 1.0;
    }
    let mut a_data: Vec<f64> = (0..m * n).map(|_| next()).collect();
    for (i, kind) in kinds.iter().enumerate() {
        match *kind {
            RowKind::Drawn => {}
            RowKind::Zero => a_data[i * n..(i + 1) * n].fill(0.0),
            RowKind::Copy(j) => {
                assert!(j < i);
                a_data.copy_within(j * n..(j + 1) * n, i * n);
            }
        }
    }
    let a = DenseMatrix::from_row_major(m, n, a_data).expect("shape");
    let x_star: Vec<f64> = (0..n).map(|_| 2.0 * next()).collect();
    let x0: Vec<f64> = (0..n).map(|_| 3.0 * next()).collect();
    let _spare: Vec<f64> = (0..n).map(|_| next()).collect();
    let lambda: Vec<f64> = (0..m)
        .map(|i| {
            let v = 0.5 + 0.75 * (next() + 1.0);
            if i < k {
                v
            } else {
                0.0
            }
        })
        .collect();
    let b: Vec<f64> = (0..m)
        .map(|i| {
            let ax: f64 = a.row(i).iter().zip(&x_star).map(|(a, x)| a * x).sum();
            let slack = 0.5 + 0.75 * (next() + 1.0);
            if i < k {
                ax
            } else {
                ax - slack
            }
        })
        .collect();
    let g: Vec<f64> = (0..n)
        .map(|j| {
            let at_lambda: f64 = (0..m).map(|i| a.get(i, j) * lambda[i]).sum();
            let qx: f64 = (0..n).map(|t| q[j * n + t] * x_star[t]).sum();
            at_lambda - qx
        })
        .collect();
    (RandomQp { n, q, g, a, b }, x_star, x0)
}

/// Smallest singular-value proxy: reject draws whose active rows are nearly dependent (the optimum is
/// then still unique but the multipliers are ill-determined and "1e-6" is no longer meaningful).
/// Exactly zero rows and exact copies of earlier active rows are deliberate degeneracies (see
/// [`RowKind`]), not near-dependence, and are skipped.
fn well_conditioned(qp: &RandomQp, k: usize) -> bool {
    // Gram–Schmidt on the active rows.
    let mut basis: Vec<Vec<f64>> = Vec::new();
    for i in 0..k {
        let row = qp.a.row(i);
        if row.iter().all(|&v| v == 0.0) || (0..i).any(|j| qp.a.row(j) == row) {
            continue;
        }
        let mut v = row.to_vec();
        let norm0 = v.iter().map(|x| x * x).sum::<f64>().sqrt();
        for bv in &basis {
            let p: f64 = v.iter().zip(bv).map(|(a, b)| a * b).sum();
            for (x, y) in v.iter_mut().zip(bv) {
                *x -= p * y;
            }
        }
        let norm = v.iter().map(|x| x * x).sum::<f64>().sqrt();
        if norm < 0.1 * norm0.max(1e-300) || norm0 < 0.1 {
            return false;
        }
        basis.push(v.into_iter().map(|x| x / norm).collect());
    }
    true
}

/// `m` row kinds: mostly drawn, some zero, some copies of a random earlier row.
fn row_kinds(m: usize) -> impl Strategy<Value = Vec<RowKind>> {
    prop::collection::vec((0u8..4, any::<prop::sample::Index>()), m).prop_map(|v| {
        v.into_iter()
            .enumerate()
            .map(|(i, (t, idx))| match t {
                1 => RowKind::Zero,
                2 if i > 0 => RowKind::Copy(idx.index(i)),
                _ => RowKind::Drawn,
            })
            .collect()
    })
}

fn degenerate_qp_strategy() -> impl Strategy<Value = (usize, usize, usize, Vec<f64>, Vec<RowKind>)>
{
    qp_strategy()
        .prop_flat_map(|(n, m, k, raw)| (Just(n), Just(m), Just(k), Just(raw), row_kinds(m)))
}

fn check_solved(qp: &mut RandomQp, x_star: &[f64], x0: &[f64]) -> Result<(), TestCaseError> {
    let solver = SqpSolver::new(SqpSettings::default()).unwrap();
    let sol = solver.solve(qp, x0).unwrap();
    prop_assert_eq!(sol.status, Status::Converged, "{}", sol.message);
    prop_assert!(sol.iterations <= 2, "took {} iterations", sol.iterations);
    let scale = 1.0 + x_star.iter().fold(0.0f64, |a, v| a.max(v.abs()));
    for (x, xs) in sol.x.iter().zip(x_star) {
        prop_assert!(
            (x - xs).abs() <= 1e-6 * scale,
            "x = {:?}, x* = {:?}",
            sol.x,
            x_star
        );
    }
    Ok(())
}

/// 256 cases per property, or `PROPTEST_CASES` (an explicit count would otherwise override it), with
/// the rejection budget of `well_conditioned` scaled along.
fn config() -> ProptestConfig {
    let cases = std::env::var("PROPTEST_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(256);
    ProptestConfig {
        cases,
        max_global_rejects: cases.max(1024),
        ..ProptestConfig::default()
    }
}

proptest! {
    #![proptest_config(config())]

    #[test]
    fn random_convex_qp_solved_in_one_or_two_iterations((n, m, k, raw) in qp_strategy()) {
        let (mut qp, x_star, x0) = build(n, m, k, &raw);
        prop_assume!(well_conditioned(&qp, k));
        check_solved(&mut qp, &x_star, &x0)?;
    }

    #[test]
    fn random_convex_qp_with_zero_and_duplicate_rows(
        (n, m, k, raw, kinds) in degenerate_qp_strategy()
    ) {
        let (mut qp, x_star, x0) = build_with_rows(n, m, k, &raw, &kinds);
        prop_assume!(well_conditioned(&qp, k));
        check_solved(&mut qp, &x_star, &x0)?;
    }
}
