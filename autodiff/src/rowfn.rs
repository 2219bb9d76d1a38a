//! Batched local functions: one generic function applied to every row of a tensor.
//!
//! A [`RowFn`] is written once, generically over [`Real`]. The engine evaluates it with `f64`
//! for values and derives its vector–Jacobian product itself with forward-mode duals on the saved
//! row inputs: nobody writes a derivative by hand. This is how XPBD constraint projections, energies
//! and signed distances are recorded: one tape node for a whole batch of rows.
//!
//! The batch forms of every [`RowFn`] (the blanket [`DynRowFn`] implementation and the in-place
//! kernels for rows of points) are in [`crate::update`].

use crate::dual::Dual;
use crate::index::RowIndex;
use crate::real::Real;
use crate::simd::{read_lane, write_lane, F64x8, LANES};
use crate::tensor::Tensor;
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

    /// Evaluates the consecutive rows `first, first + 1, …` of a block (`inputs`: rows × n_in,
    /// `outputs`: rows × n_out). The in-place kernels call it with blocks of up to [`ROW_BLOCK`]
    /// rows. The default evaluates row by row; a function whose row is one long dependency chain
    /// (a square root, then divisions) may override it to interleave the rows' chains, giving
    /// the same values as [`RowFn::eval`] bit for bit.
    #[inline(always)]
    fn eval_rows(&self, first: usize, inputs: &[f64], outputs: &mut [f64])
    where
        Self: Sized,
    {
        let (n_in, n_out) = (self.n_in(), self.n_out());
        for (k, (x, y)) in inputs
            .chunks_exact(n_in)
            .zip(outputs.chunks_exact_mut(n_out))
            .enumerate()
        {
            self.eval(first + k, x, y);
        }
    }

    /// Whether [`RowFn::eval_lanes`] is a lane-wise formulation: the in-place kernels then
    /// evaluate rows of points [`LANES`] at a time through it, gathered straight from the state
    /// into lanes, where the CPU has AVX2 (row by row elsewhere).
    const HAS_LANES: bool = false;

    /// Evaluates the rows `rows` lane-wise: `inputs[j]` holds input `j` of the rows (lane `l`
    /// is row `rows[l]`), `outputs[j]` receives output `j`. The rows are consecutive, except in
    /// a batch's last group of fewer than [`LANES`] rows, whose spare lanes repeat its last row
    /// (with its inputs, so they give its outputs, which the kernels write once more). An override
    /// (with [`RowFn::HAS_LANES`]) must give [`RowFn::eval`]'s values bit for bit in every lane
    /// (the same IEEE operations in the same order, no fused multiply–add). The default
    /// evaluates lane by lane through [`RowFn::eval`].
    #[inline(always)]
    fn eval_lanes(&self, rows: [usize; LANES], inputs: &[F64x8], outputs: &mut [F64x8])
    where
        Self: Sized,
    {
        let (mut x, mut y) = (vec![0.0; self.n_in()], vec![0.0; self.n_out()]);
        for l in 0..LANES {
            read_lane(inputs, l, &mut x);
            self.eval(rows[l], &x, &mut y);
            write_lane(outputs, l, &y);
        }
    }

    /// The vector–Jacobian products of the rows `rows` lane-wise for several seeds at once, as
    /// [`RowFn::eval_lanes`] is to [`RowFn::eval`]: `out_adj` holds `seeds` lane vectors of the
    /// outputs one after another (`seeds × n_out`), and `in_adj` receives the matching
    /// `seeds × n_in`, each seed's `Jᵀ out_adj` (what [`RowFn::vjp`] accumulates into zeros, bit
    /// for bit in every lane, for an override, which computes what the seeds share once). The
    /// default pulls back lane by lane and seed by seed through [`RowFn::vjp`].
    #[inline(always)]
    fn vjp_lanes_seeds(
        &self,
        rows: [usize; LANES],
        inputs: &[F64x8],
        out_adj: &[F64x8],
        in_adj: &mut [F64x8],
    ) where
        Self: Sized,
    {
        let (n_in, n_out) = (self.n_in(), self.n_out());
        let (mut x, mut oa, mut ia) = (vec![0.0; n_in], vec![0.0; n_out], vec![0.0; n_in]);
        for (seed_out, seed_in) in out_adj
            .chunks_exact(n_out)
            .zip(in_adj.chunks_exact_mut(n_in))
        {
            for l in 0..LANES {
                read_lane(inputs, l, &mut x);
                read_lane(seed_out, l, &mut oa);
                ia.fill(0.0);
                self.vjp(rows[l], &x, &oa, &mut ia);
                write_lane(seed_in, l, &ia);
            }
        }
    }

    /// [`RowFn::vjp`] for the consecutive rows of a block, as [`RowFn::eval_rows`] is to
    /// [`RowFn::eval`].
    #[inline(always)]
    fn vjp_rows(&self, first: usize, inputs: &[f64], out_adj: &[f64], in_adj: &mut [f64])
    where
        Self: Sized,
    {
        let (n_in, n_out) = (self.n_in(), self.n_out());
        for (k, ((x, oa), ia)) in inputs
            .chunks_exact(n_in)
            .zip(out_adj.chunks_exact(n_out))
            .zip(in_adj.chunks_exact_mut(n_in))
            .enumerate()
        {
            self.vjp(first + k, x, oa, ia);
        }
    }

    /// [`RowFn::vjp`] of one row for several seeds at once: `out_adj` holds `seeds` output
    /// adjoints one after another (`seeds × n_out`), `in_adj` the matching `seeds × n_in`. The
    /// default derives the row's Jacobian with duals once and applies it to every seed
    /// ([`vjp_seeds_by_duals`]; each seed's result is bitwise [`vjp_by_duals`]'s). A type that
    /// overrides [`RowFn::vjp`] overrides this too, so every seed takes its formulation.
    #[inline(always)]
    fn vjp_seeds(&self, row: usize, inputs: &[f64], out_adj: &[f64], in_adj: &mut [f64])
    where
        Self: Sized,
    {
        vjp_seeds_by_duals(self, row, inputs, out_adj, in_adj);
    }
}

/// Seeds per call of [`RowFn::vjp_seeds`] from the in-place kernels.
pub const SEED_CHUNK: usize = 8;

/// Rows per block handed to [`RowFn::eval_rows`] and [`RowFn::vjp_rows`] by the in-place kernels.
pub const ROW_BLOCK: usize = 8;

/// `in_adj += Jᵀ out_adj` for one row, derived by forward-mode duals in chunks of [`VJP_CHUNK`]
/// input directions.
pub fn vjp_by_duals<F: RowFn>(
    f: &F,
    row: usize,
    inputs: &[f64],
    out_adj: &[f64],
    in_adj: &mut [f64],
) {
    vjp_seeds_by_duals(f, row, inputs, out_adj, in_adj);
}

/// Row widths up to which [`vjp_seeds_by_duals`] keeps its duals on the stack.
const STACK_ROW: usize = 16;

/// [`vjp_by_duals`] for several seeds (`out_adj`: `seeds × n_out`, `in_adj`: `seeds × n_in`,
/// accumulated): each chunk of [`VJP_CHUNK`] input directions is evaluated once and its
/// derivatives applied to every seed, so the cost of the duals does not grow with the seeds.
/// Every seed's adjoint is accumulated in [`vjp_by_duals`]'s order, so bitwise equal to it.
pub fn vjp_seeds_by_duals<F: RowFn>(
    f: &F,
    row: usize,
    inputs: &[f64],
    out_adj: &[f64],
    in_adj: &mut [f64],
) {
    type D = Dual<f64, VJP_CHUNK>;
    let (n_in, n_out) = (f.n_in(), f.n_out());
    let (mut x_stack, mut y_stack) = ([D::constant(0.0); STACK_ROW], [D::constant(0.0); STACK_ROW]);
    let (mut x_heap, mut y_heap) = (Vec::new(), Vec::new());
    let (x, y): (&mut [D], &mut [D]) = if n_in <= STACK_ROW && n_out <= STACK_ROW {
        (&mut x_stack[..n_in], &mut y_stack[..n_out])
    } else {
        x_heap.resize(n_in, D::constant(0.0));
        y_heap.resize(n_out, D::constant(0.0));
        (&mut x_heap, &mut y_heap)
    };
    for start in (0..n_in).step_by(VJP_CHUNK) {
        let end = (start + VJP_CHUNK).min(n_in);
        for (k, xi) in x.iter_mut().enumerate() {
            *xi = if (start..end).contains(&k) {
                D::variable(inputs[k], k - start)
            } else {
                D::constant(inputs[k])
            };
        }
        f.eval(row, x, y);
        for (oa, ia) in out_adj
            .chunks_exact(n_out)
            .zip(in_adj.chunks_exact_mut(n_in))
        {
            for (yo, &a) in y.iter().zip(oa) {
                if a != 0.0 {
                    for k in start..end {
                        ia[k] += a * yo.eps[k - start];
                    }
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
    /// The adjoint of [`DynRowFn::update_batch`], in place: on entry `state_adj` and `carry_adj`
    /// hold the adjoints of the updated state and carry; on exit, those of the state and carry
    /// before the update. `inputs` are the values `update_batch` saved.
    fn vjp_update_batch(
        &self,
        index: &RowIndex,
        inputs: &[f64],
        state_adj: &mut Tensor,
        carry_adj: &mut Tensor,
    );
    /// [`DynRowFn::vjp_update_batch`] for several independent adjoints at once (one state and
    /// one carry adjoint per seed).
    fn vjp_update_batch_seeds(
        &self,
        index: &RowIndex,
        inputs: &[f64],
        state_adj: &mut [Tensor],
        carry_adj: &mut [Tensor],
    );
}

/// Runs `run` on this thread's value of `key`, or on a fresh `fresh()` when a caller up the stack
/// holds it: scratch for kernels that write every value before reading it, so no call pays to
/// zero it (per-call zeroing of the in-place kernels' block buffers was 4–7% of a rollout with its
/// gradient).
#[inline(always)]
pub fn with_scratch<T: 'static, R>(
    key: &'static std::thread::LocalKey<std::cell::RefCell<T>>,
    fresh: impl FnOnce() -> T,
    run: impl FnOnce(&mut T) -> R,
) -> R {
    key.with(|cell| match cell.try_borrow_mut() {
        Ok(mut value) => run(&mut value),
        Err(_) => run(&mut fresh()),
    })
}

/// Runs `work` on a thread of the rayon pool (directly when already on one).
///
/// Long sequences of small parallel sections — a Gauss–Seidel sweep splits every colour set —
/// should run inside the pool: splitting from outside hands each section to the pool and blocks
/// the caller, an operating-system round trip that cost more than the projections themselves.
pub fn in_pool<T: Send>(work: impl FnOnce() -> T + Send) -> T {
    if rayon::current_thread_index().is_some() || rayon::current_num_threads() == 1 {
        work()
    } else {
        rayon::scope(|_| work())
    }
}

/// Calls `run` on the rows `0..rows`: at once on this thread below [`PARALLEL_MIN_ROWS`] rows,
/// else in fixed ranges of `ROWS_PER_TASK` rows on the rayon pool.
pub(crate) fn for_row_ranges(rows: usize, run: impl Fn(std::ops::Range<usize>) + Sync) {
    // One thread: no hand-off to the pool (it cost more than the projections themselves).
    if rows < PARALLEL_MIN_ROWS || rayon::current_num_threads() == 1 {
        run(0..rows);
    } else {
        (0..rows.div_ceil(ROWS_PER_TASK))
            .into_par_iter()
            .for_each(|t| run(t * ROWS_PER_TASK..((t + 1) * ROWS_PER_TASK).min(rows)));
    }
}

/// Calls `run(first_row, rows)` on consecutive chunks of `data` (rows of `width` values): the
/// whole of it on this thread below [`PARALLEL_MIN_ROWS`] rows, else fixed chunks of
/// `ROWS_PER_TASK` rows on the rayon pool (fixed, so results never depend on the thread count).
pub(crate) fn for_each_row_chunk(
    data: &mut [f64],
    width: usize,
    run: impl Fn(usize, &mut [f64]) + Sync,
) {
    if width == 0 {
        return;
    }
    if data.len() / width < PARALLEL_MIN_ROWS || rayon::current_num_threads() == 1 {
        run(0, data);
    } else {
        data.par_chunks_mut(ROWS_PER_TASK * width)
            .enumerate()
            .for_each(|(t, chunk)| run(t * ROWS_PER_TASK, chunk));
    }
}

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
