//! Batched local functions: one generic function applied to every row of a tensor.
//!
//! A [`RowFn`] is written once, generically over [`Real`]. The engine evaluates it with `f64`
//! for values and derives its vector–Jacobian product itself with forward-mode duals on the saved
//! row inputs: nobody writes a derivative by hand. This is how XPBD constraint projections, energies
//! and signed distances are recorded: one tape node for a whole batch of rows.

use crate::dual::Dual;
use crate::index::RowIndex;
use crate::real::Real;
use crate::tensor::Tensor;
use crate::update::{gather_update_inputs, scatter_update_outputs};
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
///
/// Its methods work on whole batches, so the blanket implementation monomorphises the row loop
/// and inlines the user's `eval` (no dynamic dispatch per row).
pub trait DynRowFn: Send + Sync {
    /// Inputs per row.
    fn n_in(&self) -> usize;
    /// Outputs per row.
    fn n_out(&self) -> usize;
    /// Applies the function to each row of `input` (`rows × n_in`), writing `rows × n_out`.
    fn eval_batch(&self, input: &[f64], output: &mut [f64]);
    /// For each row, accumulates `in_adj[row] += Jᵀ out_adj[row]`.
    fn vjp_batch(&self, input: &[f64], out_adj: &[f64], in_adj: &mut [f64]);
    /// For each batch row `k`, replaces the state rows `index.row(k)` and carry row `k` by the
    /// function of (those rows, carry row), in place. With `saved`, the gathered inputs
    /// (`rows × n_in`) are left there for a backward pass. The index must be disjoint.
    fn update_batch(
        &self,
        index: &RowIndex,
        state: &mut Tensor,
        carry: &mut Tensor,
        saved: Option<&mut Vec<f64>>,
    );
}

impl<F: RowFn> DynRowFn for F {
    fn n_in(&self) -> usize {
        RowFn::n_in(self)
    }
    fn n_out(&self) -> usize {
        RowFn::n_out(self)
    }
    fn eval_batch(&self, input: &[f64], output: &mut [f64]) {
        let (n_in, n_out) = (RowFn::n_in(self), RowFn::n_out(self));
        for_each_row_chunk(output, n_out, |first, out| {
            for (k, o) in out.chunks_exact_mut(n_out).enumerate() {
                let r = first + k;
                self.eval(r, &input[r * n_in..(r + 1) * n_in], o);
            }
        });
    }
    fn vjp_batch(&self, input: &[f64], out_adj: &[f64], in_adj: &mut [f64]) {
        let (n_in, n_out) = (RowFn::n_in(self), RowFn::n_out(self));
        for_each_row_chunk(in_adj, n_in, |first, ia| {
            for (k, a) in ia.chunks_exact_mut(n_in).enumerate() {
                let r = first + k;
                let (x, oa) = (
                    &input[r * n_in..(r + 1) * n_in],
                    &out_adj[r * n_out..(r + 1) * n_out],
                );
                self.vjp(r, x, oa, a);
            }
        });
    }
    fn update_batch(
        &self,
        index: &RowIndex,
        state: &mut Tensor,
        carry: &mut Tensor,
        saved: Option<&mut Vec<f64>>,
    ) {
        let rows = index.rows();
        if rows >= PARALLEL_MIN_ROWS {
            // Gather, evaluate in parallel, scatter.
            let mut local = Vec::new();
            let inputs = saved.unwrap_or(&mut local);
            gather_update_inputs(index, state, carry, inputs);
            let mut outputs = vec![0.0; inputs.len()];
            self.eval_batch(inputs, &mut outputs);
            scatter_update_outputs(index, &outputs, state, carry);
            return;
        }
        // Small batch: one row at a time through a stack buffer; a recording also keeps the inputs.
        let (sc, cc, arity) = (state.cols(), carry.cols(), index.arity());
        let width = arity * sc + cc;
        let mut saved = saved;
        if let Some(s) = saved.as_deref_mut() {
            s.clear();
            s.reserve(rows * width);
        }
        let mut buf_in = [0.0; STACK_ROW];
        let mut buf_out = [0.0; STACK_ROW];
        let (mut heap_in, mut heap_out) = (Vec::new(), Vec::new());
        let (x, y): (&mut [f64], &mut [f64]) = if width <= STACK_ROW {
            (&mut buf_in[..width], &mut buf_out[..width])
        } else {
            heap_in.resize(width, 0.0);
            heap_out.resize(width, 0.0);
            (&mut heap_in, &mut heap_out)
        };
        for k in 0..rows {
            let idx = index.row(k);
            for (j, &p) in idx.iter().enumerate() {
                copy_small(&mut x[j * sc..(j + 1) * sc], state.row(p));
            }
            copy_small(&mut x[arity * sc..], carry.row(k));
            if let Some(s) = saved.as_deref_mut() {
                s.extend_from_slice(x);
            }
            self.eval(k, x, y);
            for (j, &p) in idx.iter().enumerate() {
                copy_small(state.row_mut(p), &y[j * sc..(j + 1) * sc]);
            }
            copy_small(carry.row_mut(k), &y[arity * sc..]);
        }
    }
}

/// Calls `run(first_row, rows)` on consecutive chunks of `data` (rows of `width` values): the
/// whole of it on this thread below [`PARALLEL_MIN_ROWS`] rows, else fixed chunks of
/// `ROWS_PER_TASK` rows on the rayon pool (fixed, so results never depend on the thread count).
fn for_each_row_chunk(data: &mut [f64], width: usize, run: impl Fn(usize, &mut [f64]) + Sync) {
    if width == 0 {
        return;
    }
    if data.len() / width < PARALLEL_MIN_ROWS {
        run(0, data);
    } else {
        data.par_chunks_mut(ROWS_PER_TASK * width)
            .enumerate()
            .for_each(|(t, chunk)| run(t * ROWS_PER_TASK, chunk));
    }
}

/// Copies a short row; widths 1 and 3 (a multiplier, a point) compile to plain moves instead of a
/// `memcpy` call, which dominated the cost of small Gauss–Seidel updates.
#[inline(always)]
fn copy_small(dst: &mut [f64], src: &[f64]) {
    match src.len() {
        0 => {}
        1 => dst[0] = src[0],
        3 => dst[..3].copy_from_slice(&src[..3]),
        _ => dst.copy_from_slice(src),
    }
}

/// Row widths up to this go through stack buffers in [`DynRowFn::update_batch`].
const STACK_ROW: usize = 32;

/// Batches with fewer rows than this run on the calling thread; larger ones are split across the
/// rayon pool. Rows are independent, so the result is bitwise the same either way.
pub const PARALLEL_MIN_ROWS: usize = 512;

/// Rows per rayon task for large batches (fixed, so work splitting never depends on thread count).
const ROWS_PER_TASK: usize = 256;

/// Applies `f` to each row of `input` (`rows × n_in`, row-major), writing `rows × n_out` into `output`.
pub fn eval_rows(f: &dyn DynRowFn, input: &[f64], output: &mut [f64]) {
    f.eval_batch(input, output);
}

/// For each row, accumulates `in_adj[row] += Jᵀ out_adj[row]`.
pub fn vjp_rows(f: &dyn DynRowFn, input: &[f64], out_adj: &[f64], in_adj: &mut [f64]) {
    f.vjp_batch(input, out_adj, in_adj);
}
