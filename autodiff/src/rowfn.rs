//! Batched local functions: one generic function applied to every row of a tensor.
//!
//! A [`RowFn`] is written once, generically over [`Real`]. The engine evaluates it with `f64`
//! for values and derives its vector–Jacobian product itself with forward-mode duals on the saved
//! row inputs: nobody writes a derivative by hand. This is how XPBD constraint projections, energies
//! and signed distances are recorded: one tape node for a whole batch of rows.

use crate::dual::Dual;
use crate::real::Real;
use rayon::prelude::*;

/// Tangent width used when the engine derives a vector–Jacobian product with duals.
pub const VJP_CHUNK: usize = 8;

/// A function applied independently to each row of a `rows × n_in` tensor, giving `rows × n_out`.
///
/// `row` is the batch row index, so per-row constants (rest lengths, stiffness) live in `self`.
pub trait RowFn: Send + Sync {
    /// Inputs per row.
    fn n_in(&self) -> usize;
    /// Outputs per row.
    fn n_out(&self) -> usize;
    /// Evaluates the function on one row.
    fn eval<R: Real>(&self, row: usize, inputs: &[R], outputs: &mut [R]);

    /// Accumulates `in_adj += Jᵀ out_adj` for one row, `J` the Jacobian at `inputs`.
    ///
    /// The default derives it with forward-mode duals ([`vjp_by_duals`]); a type may override it
    /// with an equivalent, faster formulation, which tests then check against the default.
    fn vjp(&self, row: usize, inputs: &[f64], out_adj: &[f64], in_adj: &mut [f64])
    where
        Self: Sized,
    {
        vjp_by_duals(self, row, inputs, out_adj, in_adj);
    }
}

/// `in_adj += Jᵀ out_adj` for one row, derived by forward-mode duals in chunks of [`VJP_CHUNK`]
/// input directions.
pub fn vjp_by_duals<F: RowFn>(
    f: &F,
    row: usize,
    inputs: &[f64],
    out_adj: &[f64],
    in_adj: &mut [f64],
) {
    type D = Dual<f64, VJP_CHUNK>;
    let n_in = f.n_in();
    let mut x: Vec<D> = inputs.iter().map(|&v| D::constant(v)).collect();
    let mut y = vec![D::constant(0.0); f.n_out()];
    for start in (0..n_in).step_by(VJP_CHUNK) {
        let end = (start + VJP_CHUNK).min(n_in);
        for (k, xi) in x.iter_mut().enumerate() {
            *xi = if (start..end).contains(&k) {
                D::variable(inputs[k], k - start)
            } else {
                D::constant(inputs[k])
            };
        }
        f.eval(row, &x, &mut y);
        for (yo, &a) in y.iter().zip(out_adj) {
            if a != 0.0 {
                for k in start..end {
                    in_adj[k] += a * yo.eps[k - start];
                }
            }
        }
    }
}

/// Object-safe face of a [`RowFn`], so the tape can store any of them.
pub trait DynRowFn: Send + Sync {
    /// Inputs per row.
    fn n_in(&self) -> usize;
    /// Outputs per row.
    fn n_out(&self) -> usize;
    /// `f64` evaluation of one row.
    fn eval_f64(&self, row: usize, inputs: &[f64], outputs: &mut [f64]);
    /// `in_adj += Jᵀ out_adj` for one row.
    fn vjp_f64(&self, row: usize, inputs: &[f64], out_adj: &[f64], in_adj: &mut [f64]);
}

impl<F: RowFn> DynRowFn for F {
    fn n_in(&self) -> usize {
        RowFn::n_in(self)
    }
    fn n_out(&self) -> usize {
        RowFn::n_out(self)
    }
    fn eval_f64(&self, row: usize, inputs: &[f64], outputs: &mut [f64]) {
        self.eval(row, inputs, outputs);
    }
    fn vjp_f64(&self, row: usize, inputs: &[f64], out_adj: &[f64], in_adj: &mut [f64]) {
        self.vjp(row, inputs, out_adj, in_adj);
    }
}

/// Batches with fewer rows than this run on the calling thread; larger ones are split across the
/// rayon pool. Rows are independent, so the result is bitwise the same either way.
pub const PARALLEL_MIN_ROWS: usize = 512;

/// Rows per rayon task for large batches (fixed, so work splitting never depends on thread count).
const ROWS_PER_TASK: usize = 256;

/// Applies `f` to each row of `input` (`rows × n_in`, row-major), writing `rows × n_out` into `output`.
pub fn eval_rows(f: &dyn DynRowFn, input: &[f64], output: &mut [f64]) {
    let (n_in, n_out) = (f.n_in(), f.n_out());
    let rows = input
        .len()
        .checked_div(n_in)
        .unwrap_or_else(|| output.len() / n_out.max(1));
    let run = |first: usize, inp: &[f64], out: &mut [f64]| {
        for k in 0..out.len() / n_out.max(1) {
            f.eval_f64(
                first + k,
                &inp[k * n_in..(k + 1) * n_in],
                &mut out[k * n_out..(k + 1) * n_out],
            );
        }
    };
    if rows < PARALLEL_MIN_ROWS || n_out == 0 {
        run(0, input, output);
    } else {
        output
            .par_chunks_mut(ROWS_PER_TASK * n_out)
            .enumerate()
            .for_each(|(t, out)| {
                let first = t * ROWS_PER_TASK;
                let rows_here = out.len() / n_out;
                run(first, &input[first * n_in..(first + rows_here) * n_in], out);
            });
    }
}

/// For each row, accumulates `in_adj[row] += Jᵀ out_adj[row]`.
pub fn vjp_rows(f: &dyn DynRowFn, input: &[f64], out_adj: &[f64], in_adj: &mut [f64]) {
    let (n_in, n_out) = (f.n_in(), f.n_out());
    if n_in == 0 {
        return;
    }
    let rows = input.len() / n_in;
    let run = |first: usize, inp: &[f64], ia: &mut [f64]| {
        for k in 0..ia.len() / n_in {
            let r = first + k;
            f.vjp_f64(
                r,
                &inp[k * n_in..(k + 1) * n_in],
                &out_adj[r * n_out..(r + 1) * n_out],
                &mut ia[k * n_in..(k + 1) * n_in],
            );
        }
    };
    if rows < PARALLEL_MIN_ROWS {
        run(0, input, in_adj);
    } else {
        in_adj
            .par_chunks_mut(ROWS_PER_TASK * n_in)
            .enumerate()
            .for_each(|(t, ia)| {
                let first = t * ROWS_PER_TASK;
                let rows_here = ia.len() / n_in;
                run(first, &input[first * n_in..(first + rows_here) * n_in], ia);
            });
    }
}
