//! In-place updates of disjoint rows: the kernel of one Gauss–Seidel colour-set projection.
//!
//! Both the plain `f64` path and the recording [`crate::Tape`] call [`update_rows`], so their
//! forward values agree bit for bit.

use crate::index::RowIndex;
use crate::rowfn::DynRowFn;
use crate::tensor::Tensor;

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
