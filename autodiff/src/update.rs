//! In-place updates of disjoint rows: the kernel of one Gauss–Seidel colour-set projection.
//!
//! Both the plain `f64` path and the recording [`crate::Tape`] call [`update_rows`], so their
//! forward values agree bit for bit.
//!
//! Here too the batch forms of every [`RowFn`]: the blanket [`DynRowFn`] implementation and its
//! in-place kernels for rows of points (fixed row widths, blocks of [`ROW_BLOCK`] rows, bounds
//! checked once up front, rayon above [`crate::rowfn::PARALLEL_MIN_ROWS`] rows).

use crate::index::RowIndex;
use crate::lanes::{lane_groups, lane_groups_vjp_seeds, lanes_for, PointBuffers, SharedRows};
use crate::rowfn::{
    for_each_row_chunk, for_row_ranges, with_scratch, DynRowFn, RowFn, ROW_BLOCK, SEED_CHUNK,
};
use crate::tensor::Tensor;
use std::ops::Range;

/// Checks that `f`, `index`, `state` and `carry` fit together for [`update_rows`].
///
/// # Panics
/// With a message naming the mismatch.
pub fn check_update(f: &dyn DynRowFn, index: &RowIndex, state: &Tensor, carry: &Tensor) {
    let n_in = index.arity() * state.cols() + carry.cols();
    assert!(
        f.n_in() == n_in && f.n_out() == n_in,
        "update_rows: the row function maps {} → {} values, but a row holds {} state rows of width {} plus {} carried values",
        f.n_in(),
        f.n_out(),
        index.arity(),
        state.cols(),
        carry.cols()
    );
    assert!(
        index.is_disjoint(),
        "update_rows: the row index repeats a row, so its rows cannot be updated independently"
    );
    assert!(
        index.bound() <= state.rows(),
        "update_rows: index {} out of range for a state of {} rows",
        index.bound().saturating_sub(1),
        state.rows()
    );
    assert_eq!(
        carry.rows(),
        index.rows(),
        "update_rows: carry has {} rows for {} batch rows",
        carry.rows(),
        index.rows()
    );
}

/// Gathers each batch row's state rows and carried values into `inputs` (`rows × n_in`).
pub fn gather_update_inputs(
    index: &RowIndex,
    state: &Tensor,
    carry: &Tensor,
    inputs: &mut Vec<f64>,
) {
    let (sc, cc) = (state.cols(), carry.cols());
    inputs.clear();
    inputs.reserve(index.rows() * (index.arity() * sc + cc));
    for k in 0..index.rows() {
        for &p in index.row(k) {
            inputs.extend_from_slice(state.row(p));
        }
        inputs.extend_from_slice(carry.row(k));
    }
}

/// Writes per-row values (`rows × n_in` layout of [`gather_update_inputs`]) back into the state
/// rows and the carry.
pub fn scatter_update_outputs(
    index: &RowIndex,
    values: &[f64],
    state: &mut Tensor,
    carry: &mut Tensor,
) {
    let (sc, cc) = (state.cols(), carry.cols());
    let width = index.arity() * sc + cc;
    for k in 0..index.rows() {
        let v = &values[k * width..(k + 1) * width];
        for (j, &p) in index.row(k).iter().enumerate() {
            state.row_mut(p).copy_from_slice(&v[j * sc..(j + 1) * sc]);
        }
        carry.row_mut(k).copy_from_slice(&v[index.arity() * sc..]);
    }
}

/// Replaces, for every batch row `k`, the state rows `index.row(k)` and carry row `k` by
/// `f(those rows, carry row)`. With `saved`, the gathered inputs (`rows × n_in`) are left there,
/// which is what a recording keeps for the backward pass.
///
/// # Panics
/// If the shapes do not fit (see [`check_update`]).
pub fn update_rows(
    f: &dyn DynRowFn,
    index: &RowIndex,
    state: &mut Tensor,
    carry: &mut Tensor,
    saved: Option<&mut Vec<f64>>,
) {
    check_update(f, index, state, carry);
    f.update_batch(index, state, carry, saved);
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
        // One seed takes the single-seed kernel.
        let many = state_adj.len() > 1;
        let fits = |s: &Tensor, c: &Tensor| many && points_layout(index, s, c);
        let kernel = |s: &mut [Tensor], c: &mut [Tensor]| {
            by_arity!(
                index.arity(),
                vjp_update_points_seeds(self, index, inputs, s, c)
            )
        };
        if in_seed_chunks(state_adj, carry_adj, fits, kernel) {
            return;
        }
        if state_adj.len() > 1 {
            for (s, c) in state_adj
                .chunks_mut(SEED_CHUNK)
                .zip(carry_adj.chunks_mut(SEED_CHUNK))
            {
                vjp_update_gathered_seeds(self, index, inputs, s, c);
            }
            return;
        }
        for (s, c) in state_adj.iter_mut().zip(carry_adj.iter_mut()) {
            self.vjp_update_batch(index, inputs, s, c);
        }
    }
}

/// [`DynRowFn::vjp_update_batch_seeds`] for any layout (gather, pull back, scatter), up to
/// [`SEED_CHUNK`] seeds: each row's output adjoints of every seed are gathered side by side and
/// handed to [`RowFn::vjp_seeds`] at once, so work the seeds share (a dual Jacobian) is done once
/// per row. Each seed's result is bitwise that of [`DynRowFn::vjp_update_batch`].
fn vjp_update_gathered_seeds<F: RowFn>(
    f: &F,
    index: &RowIndex,
    inputs: &[f64],
    state_adj: &mut [Tensor],
    carry_adj: &mut [Tensor],
) {
    let seeds = state_adj.len();
    assert!(seeds <= SEED_CHUNK, "at most SEED_CHUNK seeds at once");
    let (n, rows) = (RowFn::n_in(f), index.rows());
    assert_eq!(inputs.len(), rows * n, "vjp_update_batch: saved inputs");
    // Per row: every seed's `n` adjoint values one after another.
    let width = seeds * n;
    let mut out_adj = vec![0.0; rows * width];
    let mut one = Vec::new();
    for (s, (state, carry)) in state_adj.iter().zip(carry_adj.iter()).enumerate() {
        gather_update_inputs(index, state, carry, &mut one);
        for (k, row) in one.chunks_exact(n).enumerate() {
            out_adj[k * width + s * n..k * width + (s + 1) * n].copy_from_slice(row);
        }
    }
    let mut in_adj = vec![0.0; rows * width];
    for_each_row_chunk(&mut in_adj, width, |first, ia| {
        for (k, a) in ia.chunks_exact_mut(width).enumerate() {
            let r = first + k;
            f.vjp_seeds(
                r,
                &inputs[r * n..(r + 1) * n],
                &out_adj[r * width..(r + 1) * width],
                a,
            );
        }
    });
    for (s, (state, carry)) in state_adj.iter_mut().zip(carry_adj.iter_mut()).enumerate() {
        one.clear();
        for row in in_adj.chunks_exact(width) {
            one.extend_from_slice(&row[s * n..(s + 1) * n]);
        }
        scatter_update_outputs(index, &one, state, carry);
    }
}

/// Runs `kernel` on the seeds' adjoints (one state and one carry adjoint per seed) in chunks of
/// at most [`SEED_CHUNK`] seeds when every seed's pair `fits`; returns whether it did.
fn in_seed_chunks(
    state_adj: &mut [Tensor],
    carry_adj: &mut [Tensor],
    fits: impl Fn(&Tensor, &Tensor) -> bool,
    mut kernel: impl FnMut(&mut [Tensor], &mut [Tensor]),
) -> bool {
    assert_eq!(
        state_adj.len(),
        carry_adj.len(),
        "one carry adjoint per seed"
    );
    if !state_adj
        .iter()
        .zip(carry_adj.iter())
        .all(|(s, c)| fits(s, c))
    {
        return false;
    }
    for (s, c) in state_adj
        .chunks_mut(SEED_CHUNK)
        .zip(carry_adj.chunks_mut(SEED_CHUNK))
    {
        kernel(s, c);
    }
    true
}

/// True when an update's rows are `1..=4` points (3 columns) and one carried value: the layout
/// the fixed-width kernels below serve.
fn points_layout(index: &RowIndex, state: &Tensor, carry: &Tensor) -> bool {
    state.cols() == 3 && carry.cols() == 1 && (1..=4).contains(&index.arity())
}

/// `kernel::<F, A, 1>(args)` for the arity `A` (1 to 4) of a [`points_layout`] update.
macro_rules! by_arity {
    ($arity:expr, $kernel:ident ( $($arg:expr),* )) => {
        match $arity {
            1 => $kernel::<F, 1, 1>($($arg),*),
            2 => $kernel::<F, 2, 1>($($arg),*),
            3 => $kernel::<F, 3, 1>($($arg),*),
            4 => $kernel::<F, 4, 1>($($arg),*),
            a => unreachable!("points_layout admits arities 1 to 4, not {a}"),
        }
    };
}
use by_arity;

/// Largest row of the fixed-width kernels: `3A + C` values (four points and one carried value,
/// or one point and up to ten).
const MAX_POINT_ROW: usize = 13;

/// A row function served by the fixed-width in-place kernels when its update rows hold `A`
/// points and `C` carried values.
///
/// The blanket [`DynRowFn`] implementation of a [`RowFn`] uses those kernels for one carried
/// value (a multiplier) and gathers, evaluates and scatters through allocated buffers for any
/// other layout. A row function that carries more per row (a start position, accumulated
/// corrections) wraps itself in `PointRows` to get the fixed-width kernels for its layout too
/// (other layouts still take the general path). Values and gradients are those of the wrapped
/// function, bit for bit.
pub struct PointRows<F, const A: usize, const C: usize>(pub F);

impl<F: RowFn, const A: usize, const C: usize> PointRows<F, A, C> {
    /// Whether an update has this wrapper's layout.
    fn fits(index: &RowIndex, state: &Tensor, carry: &Tensor) -> bool {
        const {
            assert!(
                A >= 1 && C >= 1 && 3 * A + C <= MAX_POINT_ROW,
                "PointRows: 1 ≤ A, 1 ≤ C, 3A + C ≤ 13"
            )
        };
        state.cols() == 3 && carry.cols() == C && index.arity() == A
    }
}

impl<F: RowFn, const A: usize, const C: usize> DynRowFn for PointRows<F, A, C> {
    fn n_in(&self) -> usize {
        RowFn::n_in(&self.0)
    }
    fn n_out(&self) -> usize {
        RowFn::n_out(&self.0)
    }
    fn eval_batch(&self, input: &[f64], output: &mut [f64]) {
        DynRowFn::eval_batch(&self.0, input, output);
    }
    fn vjp_batch(&self, input: &[f64], out_adj: &[f64], in_adj: &mut [f64]) {
        DynRowFn::vjp_batch(&self.0, input, out_adj, in_adj);
    }
    fn update_batch(
        &self,
        index: &RowIndex,
        state: &mut Tensor,
        carry: &mut Tensor,
        saved: Option<&mut Vec<f64>>,
    ) {
        if !Self::fits(index, state, carry) {
            return self.0.update_batch(index, state, carry, saved);
        }
        update_points::<F, A, C>(&self.0, index, state.data_mut(), carry.data_mut(), saved);
    }
    fn vjp_update_batch(
        &self,
        index: &RowIndex,
        inputs: &[f64],
        state_adj: &mut Tensor,
        carry_adj: &mut Tensor,
    ) {
        if !Self::fits(index, state_adj, carry_adj) {
            return self.0.vjp_update_batch(index, inputs, state_adj, carry_adj);
        }
        let (s, c) = (state_adj.data_mut(), carry_adj.data_mut());
        vjp_update_points::<F, A, C>(&self.0, index, inputs, s, c);
    }
    fn vjp_update_batch_seeds(
        &self,
        index: &RowIndex,
        inputs: &[f64],
        state_adj: &mut [Tensor],
        carry_adj: &mut [Tensor],
    ) {
        let fits = |s: &Tensor, c: &Tensor| Self::fits(index, s, c);
        let kernel = |s: &mut [Tensor], c: &mut [Tensor]| {
            vjp_update_points_seeds::<F, A, C>(&self.0, index, inputs, s, c)
        };
        if !in_seed_chunks(state_adj, carry_adj, fits, kernel) {
            self.0
                .vjp_update_batch_seeds(index, inputs, state_adj, carry_adj);
        }
    }
}

/// [`DynRowFn::update_batch`] for rows of `A` points (3 values each) and `C` carried values,
/// writing in place, [`ROW_BLOCK`] rows at a time. Rows share no point, so blocks run in any
/// order and chunks of rows in parallel on the same state.
#[inline(always)]
fn update_points<F: RowFn, const A: usize, const C: usize>(
    f: &F,
    index: &RowIndex,
    state: &mut [f64],
    carry: &mut [f64],
    saved: Option<&mut Vec<f64>>,
) {
    let rows = index.rows();
    let len = rows * (3 * A + C);
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
    let lanes = C == 1 && lanes_for::<F>();
    let buf = PointBuffers {
        state,
        carry,
        saved: saved_rows.unwrap_or(SharedRows::EMPTY),
    };
    let (f_ref, idx) = (f, index.as_slice());
    // SAFETY (of `lane_groups` and `for_point_blocks`): `check_update` asserted the index is disjoint
    // and in range, `lanes_for` that the CPU has AVX2, and `saved` has room for every row.
    let head = |range: Range<usize>| match lanes {
        true => unsafe { lane_groups::<F, A>(f_ref, idx, range, buf) },
        false => range.start,
    };
    for_point_blocks::<A, C>(index, state, carry, head, |first, x, y| {
        if let Some(s) = saved_rows {
            // Row by row: a copy of compile-time length is a few moves, where one of the whole
            // block's (its row count known only here) was a `memcpy` call, 2–3% of a rollout.
            let width = 3 * A + C;
            for b in 0..x.len() / width {
                let row = &x[width * b..width * b + width];
                // SAFETY: this block's rows of the saved inputs are written by this block alone.
                unsafe { s.write(width * (first + b), row) };
            }
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
fn vjp_update_points<F: RowFn, const A: usize, const C: usize>(
    f: &F,
    index: &RowIndex,
    inputs: &[f64],
    state_adj: &mut [f64],
    carry_adj: &mut [f64],
) {
    check_adjoints::<A, C>(index, inputs, state_adj.len(), carry_adj.len());
    let (state, carry) = (SharedRows::new(state_adj), SharedRows::new(carry_adj));
    let lanes = C == 1 && lanes_for::<F>();
    let idx = index.as_slice();
    // SAFETY (of `lane_groups_vjp_seeds`, one seed): `check_adjoints` asserted the index and
    // inputs fit, `lanes_for` that the CPU has AVX2.
    let head = |range: Range<usize>| match lanes {
        true => unsafe { lane_groups_vjp_seeds::<F, A>(f, idx, range, inputs, &[state], &[carry]) },
        false => range.start,
    };
    for_point_blocks::<A, C>(index, state, carry, head, |first, oa, ia| {
        let width = 3 * A + C;
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
/// [`ROW_BLOCK`]: `rows_in` holds the block's gathered rows (`A` points and `C` carried values
/// each); `body` writes all of `rows_out`, which goes back to the same rows after it. Each
/// task's range of rows is first handed to `head`, which does a first part of it itself and
/// returns where `body`'s blocks start.
///
/// The caller has checked that `index` is disjoint and in range for `state` and `carry`.
#[inline(always)]
fn for_point_blocks<const A: usize, const C: usize>(
    index: &RowIndex,
    state: SharedRows,
    carry: SharedRows,
    head: impl Fn(Range<usize>) -> usize + Sync,
    body: impl Fn(usize, &[f64], &mut [f64]) + Sync,
) {
    let idx = index.as_slice();
    for_row_ranges(index.rows(), |range| {
        let range = head(range.clone())..range.end;
        let fresh = || {
            (
                [0.0; MAX_POINT_ROW * ROW_BLOCK],
                [0.0; MAX_POINT_ROW * ROW_BLOCK],
            )
        };
        with_scratch(&BLOCK_SCRATCH, fresh, |(x, y)| {
            point_blocks::<A, C>(idx, range, state, carry, x, y, &body)
        })
    });
}

/// Rows of a block staged by [`for_point_blocks`]: its gathered rows, and the body's outputs.
type BlockRows = [f64; MAX_POINT_ROW * ROW_BLOCK];

thread_local! {
    /// Each thread's [`BlockRows`] pair, kept so that a colour set's call does not zero
    /// 1.7 kB first (that `memset` was 2–5% of a rollout with its gradient).
    static BLOCK_SCRATCH: std::cell::RefCell<(BlockRows, BlockRows)> =
        const { std::cell::RefCell::new(([0.0; MAX_POINT_ROW * ROW_BLOCK], [0.0; MAX_POINT_ROW * ROW_BLOCK])) };
}

/// The rows `range` of [`for_point_blocks`], staged through `x` and `y`.
#[inline(always)]
fn point_blocks<const A: usize, const C: usize>(
    idx: &[usize],
    range: Range<usize>,
    state: SharedRows,
    carry: SharedRows,
    x: &mut BlockRows,
    y: &mut BlockRows,
    body: &impl Fn(usize, &[f64], &mut [f64]),
) {
    // Computed here, not captured, so every copy below has a compile-time length.
    let width = 3 * A + C;
    let mut first = range.start;
    while first < range.end {
        let n = ROW_BLOCK.min(range.end - first);
        // SAFETY: the index is disjoint and in range (checked by the caller), so the block's
        // points and carried values are touched by this block alone.
        unsafe {
            for b in 0..n {
                let xb = &mut x[width * b..width * b + width];
                gather_point_row::<A, C>(idx, first + b, state, carry, xb);
            }
            body(first, &x[..width * n], &mut y[..width * n]);
            for b in 0..n {
                let yb = &y[width * b..width * b + width];
                scatter_point_row::<A, C>(idx, first + b, state, carry, yb);
            }
        }
        first += n;
    }
}

/// Checks that saved inputs and adjoints (of `state_len` and `carry_len` values) fit an
/// in-place update of `A` points and `C` carried values per row, so the kernels may index them
/// unchecked.
fn check_adjoints<const A: usize, const C: usize>(
    index: &RowIndex,
    inputs: &[f64],
    state_len: usize,
    carry_len: usize,
) {
    let rows = index.rows();
    assert_eq!(
        inputs.len(),
        rows * (3 * A + C),
        "vjp_update_batch: saved inputs"
    );
    assert!(
        index.is_disjoint() && 3 * index.bound() <= state_len && carry_len == C * rows,
        "vjp_update_batch: index does not fit the adjoints"
    );
}

/// [`DynRowFn::vjp_update_batch_seeds`] for the layout of [`update_points`], up to
/// [`SEED_CHUNK`] seeds: each row's saved inputs are read once and handed to
/// [`RowFn::vjp_seeds`] with every seed's output adjoint, or, where the lane-wise kernel runs,
/// each group of [`crate::simd::LANES`] rows' to [`RowFn::vjp_lanes_seeds`].
fn vjp_update_points_seeds<F: RowFn, const A: usize, const C: usize>(
    f: &F,
    index: &RowIndex,
    inputs: &[f64],
    state_adj: &mut [Tensor],
    carry_adj: &mut [Tensor],
) {
    let seeds = state_adj.len();
    assert!(seeds <= SEED_CHUNK, "at most SEED_CHUNK seeds at once");
    for (s, c) in state_adj.iter().zip(carry_adj.iter()) {
        check_adjoints::<A, C>(index, inputs, s.data().len(), c.data().len());
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
    let lanes = C == 1 && lanes_for::<F>();
    for_row_ranges(index.rows(), |range| {
        // SAFETY (of `lane_groups_vjp_seeds`): `check_adjoints` asserted the index and inputs
        // fit every seed's buffers, `lanes_for` that the CPU has AVX2.
        let start = match lanes {
            true => unsafe {
                lane_groups_vjp_seeds::<F, A>(f, idx, range.clone(), inputs, states, carries)
            },
            false => range.start,
        };
        let width = 3 * A + C;
        let mut oa = [0.0; MAX_POINT_ROW * SEED_CHUNK];
        let mut ia = [0.0; MAX_POINT_ROW * SEED_CHUNK];
        for k in start..range.end {
            // SAFETY: as in `update_points` (asserted above), for every seed's buffers.
            unsafe {
                for (s, (&state, &carry)) in states.iter().zip(carries).enumerate() {
                    let ob = &mut oa[width * s..width * s + width];
                    gather_point_row::<A, C>(idx, k, state, carry, ob);
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
                    scatter_point_row::<A, C>(idx, k, state, carry, ib);
                }
            }
        }
    });
}

/// Copies row `k`'s `A` points and `C` carried values into `dst` (`3A + C` values).
///
/// # Safety
/// As [`SharedRows::slice`]: the index is in range for `state` and `carry`, and no other task
/// touches row `k`'s values.
#[inline(always)]
unsafe fn gather_point_row<const A: usize, const C: usize>(
    idx: &[usize],
    k: usize,
    state: SharedRows,
    carry: SharedRows,
    dst: &mut [f64],
) {
    for (j, &p) in idx[A * k..A * k + A].iter().enumerate() {
        dst[3 * j..3 * j + 3].copy_from_slice(state.slice(3 * p, 3));
    }
    if C == 1 {
        // One value: a move (a one-element copy was 2% more instructions on a whole rollout).
        dst[3 * A] = carry.slice(k, 1)[0];
    } else {
        dst[3 * A..3 * A + C].copy_from_slice(carry.slice(C * k, C));
    }
}

/// Writes `src` (`3A + C` values) back to row `k`'s points and carried values.
///
/// # Safety
/// As [`gather_point_row`].
#[inline(always)]
unsafe fn scatter_point_row<const A: usize, const C: usize>(
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
    if C == 1 {
        carry.slice(k, 1)[0] = src[3 * A];
    } else {
        carry
            .slice(C * k, C)
            .copy_from_slice(&src[3 * A..3 * A + C]);
    }
}
