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
    /// default pulls them back one by one; a function may override it to share the work the
    /// seeds have in common.
    #[inline(always)]
    fn vjp_seeds(&self, row: usize, inputs: &[f64], out_adj: &[f64], in_adj: &mut [f64])
    where
        Self: Sized,
    {
        let (n_in, n_out) = (self.n_in(), self.n_out());
        for (oa, ia) in out_adj
            .chunks_exact(n_out)
            .zip(in_adj.chunks_exact_mut(n_in))
        {
            self.vjp(row, inputs, oa, ia);
        }
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
        // Points (3 columns) with one carried value: fixed row widths, so every copy is a move.
        if points_layout(index, state, carry) {
            let (s, c) = (state.data_mut(), carry.data_mut());
            return by_arity!(index.arity(), update_points(self, index, s, c, saved));
        }
        // Any other layout: gather, evaluate, scatter.
        let mut local = Vec::new();
        let inputs = saved.unwrap_or(&mut local);
        gather_update_inputs(index, state, carry, inputs);
        let mut outputs = vec![0.0; inputs.len()];
        self.eval_batch(inputs, &mut outputs);
        scatter_update_outputs(index, &outputs, state, carry);
    }
    fn vjp_update_batch(
        &self,
        index: &RowIndex,
        inputs: &[f64],
        state_adj: &mut Tensor,
        carry_adj: &mut Tensor,
    ) {
        if points_layout(index, state_adj, carry_adj) {
            let (s, c) = (state_adj.data_mut(), carry_adj.data_mut());
            return by_arity!(index.arity(), vjp_update_points(self, index, inputs, s, c));
        }
        let mut out_adj = Vec::new();
        gather_update_inputs(index, state_adj, carry_adj, &mut out_adj);
        let mut in_adj = vec![0.0; inputs.len()];
        self.vjp_batch(inputs, &out_adj, &mut in_adj);
        scatter_update_outputs(index, &in_adj, state_adj, carry_adj);
    }
    fn vjp_update_batch_seeds(
        &self,
        index: &RowIndex,
        inputs: &[f64],
        state_adj: &mut [Tensor],
        carry_adj: &mut [Tensor],
    ) {
        assert_eq!(
            state_adj.len(),
            carry_adj.len(),
            "one carry adjoint per seed"
        );
        let points = state_adj
            .iter()
            .zip(carry_adj.iter())
            .all(|(s, c)| points_layout(index, s, c));
        if state_adj.len() > 1 && points {
            for (s, c) in state_adj
                .chunks_mut(SEED_CHUNK)
                .zip(carry_adj.chunks_mut(SEED_CHUNK))
            {
                by_arity!(
                    index.arity(),
                    vjp_update_points_seeds(self, index, inputs, s, c)
                );
            }
            return;
        }
        for (s, c) in state_adj.iter_mut().zip(carry_adj.iter_mut()) {
            self.vjp_update_batch(index, inputs, s, c);
        }
    }
}

/// True when an update's rows are `1..=4` points (3 columns) and one carried value: the layout
/// the fixed-width kernels below serve.
fn points_layout(index: &RowIndex, state: &Tensor, carry: &Tensor) -> bool {
    state.cols() == 3 && carry.cols() == 1 && (1..=4).contains(&index.arity())
}

/// `kernel::<F, A>(args)` for the arity `A` (1 to 4) of a [`points_layout`] update.
macro_rules! by_arity {
    ($arity:expr, $kernel:ident ( $($arg:expr),* )) => {
        match $arity {
            1 => $kernel::<F, 1>($($arg),*),
            2 => $kernel::<F, 2>($($arg),*),
            3 => $kernel::<F, 3>($($arg),*),
            4 => $kernel::<F, 4>($($arg),*),
            a => unreachable!("points_layout admits arities 1 to 4, not {a}"),
        }
    };
}
use by_arity;

/// Largest row of [`update_points`]: four points and one carried value.
const MAX_POINT_ROW: usize = 13;

/// [`DynRowFn::update_batch`] for rows of `A` points (3 values each) and one carried value,
/// writing in place, [`ROW_BLOCK`] rows at a time. Rows share no point, so blocks run in any
/// order and chunks of rows in parallel on the same state.
#[inline(always)]
fn update_points<F: RowFn, const A: usize>(
    f: &F,
    index: &RowIndex,
    state: &mut [f64],
    carry: &mut [f64],
    saved: Option<&mut Vec<f64>>,
) {
    let rows = index.rows();
    let len = rows * (3 * A + 1);
    // The saved inputs are written straight into the buffer's spare capacity (every value once,
    // below), not zero-filled first: that fill was 4% of a recorded rollout.
    let saved = saved.map(|s| {
        s.clear();
        s.reserve(len);
        (
            SharedRows {
                ptr: s.as_mut_ptr(),
                len,
            },
            s,
        )
    });
    let saved_rows = saved.as_ref().map(|(rows, _)| *rows);
    let (state, carry) = (SharedRows::new(state), SharedRows::new(carry));
    // SAFETY (of `for_point_blocks`): `check_update` asserted the index is disjoint and in range.
    for_point_blocks::<A>(index, state, carry, |first, x, y| {
        if let Some(s) = saved_rows {
            // SAFETY: this block's rows of the saved inputs are written by this block alone.
            unsafe { s.write((3 * A + 1) * first, x) };
        }
        f.eval_rows(first, x, y);
    });
    if let Some((_, s)) = saved {
        // SAFETY: the blocks above wrote all `len` values (every row once).
        unsafe { s.set_len(len) };
    }
}

/// [`DynRowFn::vjp_update_batch`] for the layout of [`update_points`].
#[inline(always)]
fn vjp_update_points<F: RowFn, const A: usize>(
    f: &F,
    index: &RowIndex,
    inputs: &[f64],
    state_adj: &mut [f64],
    carry_adj: &mut [f64],
) {
    check_adjoints::<A>(index, inputs, state_adj.len(), carry_adj.len());
    let (state, carry) = (SharedRows::new(state_adj), SharedRows::new(carry_adj));
    for_point_blocks::<A>(index, state, carry, |first, oa, ia| {
        let width = 3 * A + 1;
        let rows = oa.len() / width;
        // `vjp_rows` accumulates.
        ia.fill(0.0);
        f.vjp_rows(
            first,
            &inputs[width * first..width * (first + rows)],
            oa,
            ia,
        );
    });
}

/// Runs `body(first, rows_in, rows_out)` over an in-place update's rows in blocks of up to
/// [`ROW_BLOCK`]: `rows_in` holds the block's gathered rows (`A` points and a carried value
/// each); `body` writes all of `rows_out`, which goes back to the same rows after it.
///
/// The caller has checked that `index` is disjoint and in range for `state` and `carry`.
#[inline(always)]
fn for_point_blocks<const A: usize>(
    index: &RowIndex,
    state: SharedRows,
    carry: SharedRows,
    body: impl Fn(usize, &[f64], &mut [f64]) + Sync,
) {
    let idx = index.as_slice();
    for_row_ranges(index.rows(), |range| {
        // Computed here, not captured, so every copy below has a compile-time length.
        let width = 3 * A + 1;
        let mut x = [0.0; MAX_POINT_ROW * ROW_BLOCK];
        let mut y = [0.0; MAX_POINT_ROW * ROW_BLOCK];
        let mut first = range.start;
        while first < range.end {
            let n = ROW_BLOCK.min(range.end - first);
            // SAFETY: the index is disjoint and in range (checked by the caller), so the block's
            // points and carried values are touched by this block alone.
            unsafe {
                for b in 0..n {
                    let xb = &mut x[width * b..width * b + width];
                    gather_point_row::<A>(idx, first + b, state, carry, xb);
                }
                body(first, &x[..width * n], &mut y[..width * n]);
                for b in 0..n {
                    let yb = &y[width * b..width * b + width];
                    scatter_point_row::<A>(idx, first + b, state, carry, yb);
                }
            }
            first += n;
        }
    });
}

/// Checks that saved inputs and adjoints (of `state_len` and `carry_len` values) fit an
/// in-place update of `A` points per row, so the kernels may index them unchecked.
fn check_adjoints<const A: usize>(
    index: &RowIndex,
    inputs: &[f64],
    state_len: usize,
    carry_len: usize,
) {
    let rows = index.rows();
    assert_eq!(
        inputs.len(),
        rows * (3 * A + 1),
        "vjp_update_batch: saved inputs"
    );
    assert!(
        index.is_disjoint() && 3 * index.bound() <= state_len && carry_len == rows,
        "vjp_update_batch: index does not fit the adjoints"
    );
}

/// [`DynRowFn::vjp_update_batch_seeds`] for the layout of [`update_points`], up to
/// [`SEED_CHUNK`] seeds: each row's saved inputs are read once and handed to
/// [`RowFn::vjp_seeds`] with every seed's output adjoint.
fn vjp_update_points_seeds<F: RowFn, const A: usize>(
    f: &F,
    index: &RowIndex,
    inputs: &[f64],
    state_adj: &mut [Tensor],
    carry_adj: &mut [Tensor],
) {
    let seeds = state_adj.len();
    assert!(seeds <= SEED_CHUNK, "at most SEED_CHUNK seeds at once");
    for (s, c) in state_adj.iter().zip(carry_adj.iter()) {
        check_adjoints::<A>(index, inputs, s.data().len(), c.data().len());
    }
    // Fixed arrays, not vectors: this runs once per update node and seed chunk.
    let (mut states, mut carries) = (
        [SharedRows::EMPTY; SEED_CHUNK],
        [SharedRows::EMPTY; SEED_CHUNK],
    );
    for (k, (s, c)) in state_adj.iter_mut().zip(carry_adj.iter_mut()).enumerate() {
        states[k] = SharedRows::new(s.data_mut());
        carries[k] = SharedRows::new(c.data_mut());
    }
    let (states, carries) = (&states[..seeds], &carries[..seeds]);
    let idx = index.as_slice();
    for_row_ranges(index.rows(), |range| {
        let width = 3 * A + 1;
        let mut oa = [0.0; MAX_POINT_ROW * SEED_CHUNK];
        let mut ia = [0.0; MAX_POINT_ROW * SEED_CHUNK];
        for k in range {
            // SAFETY: as in `update_points` (asserted above), for every seed's buffers.
            unsafe {
                for (s, (&state, &carry)) in states.iter().zip(carries).enumerate() {
                    let ob = &mut oa[width * s..width * s + width];
                    gather_point_row::<A>(idx, k, state, carry, ob);
                    ia[width * s..width * s + width].fill(0.0);
                }
                f.vjp_seeds(
                    k,
                    &inputs[width * k..width * k + width],
                    &oa[..width * seeds],
                    &mut ia[..width * seeds],
                );
                for (s, (&state, &carry)) in states.iter().zip(carries).enumerate() {
                    let ib = &ia[width * s..width * s + width];
                    scatter_point_row::<A>(idx, k, state, carry, ib);
                }
            }
        }
    });
}

/// Copies row `k`'s `A` points and carried value into `dst` (`3A + 1` values).
///
/// # Safety
/// As [`SharedRows::slice`]: the index is in range for `state` and `carry`, and no other task
/// touches row `k`'s values.
#[inline(always)]
unsafe fn gather_point_row<const A: usize>(
    idx: &[usize],
    k: usize,
    state: SharedRows,
    carry: SharedRows,
    dst: &mut [f64],
) {
    for (j, &p) in idx[A * k..A * k + A].iter().enumerate() {
        dst[3 * j..3 * j + 3].copy_from_slice(state.slice(3 * p, 3));
    }
    dst[3 * A] = carry.slice(k, 1)[0];
}

/// Writes `src` (`3A + 1` values) back to row `k`'s points and carried value.
///
/// # Safety
/// As [`gather_point_row`].
#[inline(always)]
unsafe fn scatter_point_row<const A: usize>(
    idx: &[usize],
    k: usize,
    state: SharedRows,
    carry: SharedRows,
    src: &[f64],
) {
    for (j, &p) in idx[A * k..A * k + A].iter().enumerate() {
        state
            .slice(3 * p, 3)
            .copy_from_slice(&src[3 * j..3 * j + 3]);
    }
    carry.slice(k, 1)[0] = src[3 * A];
}

/// A buffer that several rayon tasks write at once, each to values no other task touches.
#[derive(Clone, Copy)]
struct SharedRows {
    ptr: *mut f64,
    len: usize,
}

// SAFETY: only used for writes to disjoint ranges (see `update_points`).
unsafe impl Send for SharedRows {}
unsafe impl Sync for SharedRows {}

impl SharedRows {
    /// No buffer (a placeholder in fixed arrays).
    const EMPTY: SharedRows = SharedRows {
        ptr: std::ptr::null_mut(),
        len: 0,
    };

    fn new(data: &mut [f64]) -> Self {
        SharedRows {
            ptr: data.as_mut_ptr(),
            len: data.len(),
        }
    }

    /// Copies `src` to the values from `start`, which may be uninitialized (no reference to them
    /// is made).
    ///
    /// # Safety
    /// As [`SharedRows::slice`].
    #[inline(always)]
    unsafe fn write(self, start: usize, src: &[f64]) {
        debug_assert!(start + src.len() <= self.len);
        std::ptr::copy_nonoverlapping(src.as_ptr(), self.ptr.add(start), src.len());
    }

    /// `n` values from `start`.
    ///
    /// # Safety
    /// They must lie inside the buffer (the kernels check their index's bound up front), and no
    /// other live reference may overlap them.
    #[inline(always)]
    #[allow(clippy::mut_from_ref)]
    unsafe fn slice<'a>(self, start: usize, n: usize) -> &'a mut [f64] {
        debug_assert!(
            start + n <= self.len,
            "SharedRows: {start}+{n} > {}",
            self.len
        );
        std::slice::from_raw_parts_mut(self.ptr.add(start), n)
    }
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
fn for_row_ranges(rows: usize, run: impl Fn(std::ops::Range<usize>) + Sync) {
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
fn for_each_row_chunk(data: &mut [f64], width: usize, run: impl Fn(usize, &mut [f64]) + Sync) {
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
