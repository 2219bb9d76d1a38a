//! Central finite-difference checks of every `Tape` op, of the batched row ops (`map_rows`,
//! `update_rows`), of random compositions, and of `Tape::vjp` with non-trivial seeds.
//!
//! Each property builds a scalar loss on a tape from leaf tensors, takes
//! `tape.backward(loss).wrt(leaf)`, and compares every entry with a central difference of the
//! recorded forward value (step `1e-6·max(1, |x|)`), to a relative error of `1e-6` with an absolute
//! floor of `1e-8`. Random data keep clear of kinks by construction (|x| bounded away from 0 for
//! sqrt/relu, min/max and row-min/max ties rejected), so finite differences are meaningful.
//! Forward values are checked against plain reference implementations as well.

#![allow(clippy::needless_range_loop)]

use autodiff::update;
use autodiff::{DynRowFn, Real, RowFn, RowIndex, Tape, Tensor, Var};
use proptest::prelude::*;
use proptest::test_runner::TestCaseError;
use std::sync::Arc;

const REL: f64 = 1e-6;
const ABS: f64 = 1e-8;

// ---------------------------------------------------------------------------------------------
// Helpers
// ---------------------------------------------------------------------------------------------

/// Asserts `an ≈ fd` to `REL` relative error with an `ABS` absolute floor.
fn close(an: f64, fd: f64, what: &str) -> Result<(), TestCaseError> {
    let err = (an - fd).abs();
    prop_assert!(
        an.is_finite() && (err <= ABS || err <= REL * an.abs().max(fd.abs())),
        "{what}: tape {an:e} vs central FD {fd:e} (abs err {err:e})"
    );
    Ok(())
}

/// Records `build` on `tape` from fresh leaves holding `leaves`, returning the leaves and the
/// scalar loss.
fn record<F>(tape: &mut Tape, leaves: &[Tensor], build: &F) -> (Vec<Var>, Var)
where
    F: Fn(&mut Tape, &[Var]) -> Var,
{
    tape.clear();
    let vars: Vec<Var> = leaves.iter().map(|t| tape.leaf(t.clone())).collect();
    let loss = build(tape, &vars);
    (vars, loss)
}

/// The loss with entry `k` of leaf `li` shifted by `dx`.
fn shifted_loss<F>(
    tape: &mut Tape,
    leaves: &[Tensor],
    li: usize,
    k: usize,
    dx: f64,
    build: &F,
) -> f64
where
    F: Fn(&mut Tape, &[Var]) -> Var,
{
    let mut shifted = leaves.to_vec();
    shifted[li].data_mut()[k] += dx;
    let (_, l) = record(tape, &shifted, build);
    tape.value(l).item()
}

/// Central finite difference of the scalar `build` with respect to entry `k` of leaf `li`, step
/// `1e-6·max(1, |x|)`.
fn central_fd<F>(tape: &mut Tape, leaves: &[Tensor], li: usize, k: usize, build: &F) -> f64
where
    F: Fn(&mut Tape, &[Var]) -> Var,
{
    let x = leaves[li].data()[k];
    let h = 1e-6 * x.abs().max(1.0);
    let fp = shifted_loss(tape, leaves, li, k, h, build);
    let fm = shifted_loss(tape, leaves, li, k, -h, build);
    // The step actually taken (x ± h is rounded).
    (fp - fm) / ((x + h) - (x - h))
}

/// Fourth-order central difference (5-point stencil) with step `1e-4·max(1, |x|)`: truncation
/// error ~h⁴, rounding error ~ε|L|/h, both far below the tolerance.
fn richardson_fd<F>(tape: &mut Tape, leaves: &[Tensor], li: usize, k: usize, build: &F) -> f64
where
    F: Fn(&mut Tape, &[Var]) -> Var,
{
    let x = leaves[li].data()[k];
    let h = 1e-4 * x.abs().max(1.0);
    let d1 =
        shifted_loss(tape, leaves, li, k, h, build) - shifted_loss(tape, leaves, li, k, -h, build);
    let d2 = shifted_loss(tape, leaves, li, k, 2.0 * h, build)
        - shifted_loss(tape, leaves, li, k, -2.0 * h, build);
    (8.0 * d1 - d2) / (12.0 * h)
}

/// Checks the tape's derivative `an` of `build` with respect to entry `k` of leaf `li`.
///
/// The reference is the central difference at step `1e-6·max(1, |x|)`. Its own rounding error is
/// about `ε·|L|/h`, which for losses of magnitude ~10 after chains of projections reaches the
/// `1e-8` floor; only when that estimate disagrees is the tape's value compared with a
/// fourth-order estimate at a larger step, which has no such rounding problem. A wrong gradient
/// fails both.
fn check_entry<F>(
    an: f64,
    tape: &mut Tape,
    leaves: &[Tensor],
    li: usize,
    k: usize,
    build: &F,
    what: &str,
) -> Result<(), TestCaseError>
where
    F: Fn(&mut Tape, &[Var]) -> Var,
{
    let fd = central_fd(tape, leaves, li, k, build);
    if close(an, fd, what).is_ok() {
        return Ok(());
    }
    let fd4 = richardson_fd(tape, leaves, li, k, build);
    close(
        an,
        fd4,
        &format!("{what} (central FD {fd:e} also disagrees)"),
    )
}

/// The generic check: gradient of the scalar loss `build(tape, leaves)` from `Tape::backward`
/// against central finite differences, for every entry of every leaf.
fn fd_check<F>(leaves: &[Tensor], build: F) -> Result<(), TestCaseError>
where
    F: Fn(&mut Tape, &[Var]) -> Var,
{
    let mut tape = Tape::new();
    let (vars, loss) = record(&mut tape, leaves, &build);
    prop_assert_eq!(tape.shape(loss), (1, 1));
    prop_assert!(tape.value(loss).item().is_finite(), "loss is not finite");
    let grads = tape.backward(loss);
    let g: Vec<Tensor> = vars.iter().map(|&v| grads.wrt(v)).collect();
    for (li, leaf) in leaves.iter().enumerate() {
        prop_assert_eq!(g[li].shape(), leaf.shape(), "gradient shape of leaf {}", li);
        for k in 0..leaf.len() {
            let what = format!("d loss / d leaf{li}[{k}]");
            check_entry(g[li].data()[k], &mut tape, leaves, li, k, &build, &what)?;
        }
    }
    Ok(())
}

/// Deterministic, non-trivial weights for entry `k` (magnitudes in [0.5, 1.5), mixed signs).
fn weight(k: usize) -> f64 {
    let m = 0.5 + ((k as f64 + 1.0) * 0.618_033_988_749_895).fract();
    if k % 3 == 1 {
        -m
    } else {
        m
    }
}

/// `Σ wₖ yₖ` with the fixed weights above: a scalar that depends on every entry of `y`.
fn wsum(t: &mut Tape, y: Var) -> Var {
    let (r, c) = t.shape(y);
    let w = t.leaf(Tensor::new(r, c, (0..r * c).map(weight).collect()));
    t.dot(y, w)
}

/// Asserts that the recorded value of `y` equals `expected` (to rounding).
fn check_value(t: &Tape, y: Var, expected: &Tensor) -> Result<(), TestCaseError> {
    let v = t.value(y);
    prop_assert_eq!(v.shape(), expected.shape());
    for (k, (a, b)) in v.data().iter().zip(expected.data()).enumerate() {
        prop_assert!(
            (a - b).abs() <= 1e-14 * b.abs().max(1.0),
            "value[{}]: tape {} vs reference {}",
            k,
            a,
            b
        );
    }
    Ok(())
}

fn tensor(r: usize, c: usize, lo: f64, hi: f64) -> impl Strategy<Value = Tensor> {
    prop::collection::vec(lo..hi, r * c).prop_map(move |d| Tensor::new(r, c, d))
}

/// Values with magnitude in [0.1, 2): clear of the kinks at 0.
fn tensor_nonzero(r: usize, c: usize) -> impl Strategy<Value = Tensor> {
    prop::collection::vec((0.1f64..2.0, any::<bool>()), r * c).prop_map(move |d| {
        Tensor::new(
            r,
            c,
            d.into_iter().map(|(m, s)| if s { m } else { -m }).collect(),
        )
    })
}

fn shape() -> impl Strategy<Value = (usize, usize)> {
    (1usize..5, 1usize..5)
}

fn arc(f: impl RowFn + 'static) -> Arc<dyn DynRowFn> {
    Arc::new(f)
}

// ---------------------------------------------------------------------------------------------
// Leaf, gather, scatter_add, assign_rows
// ---------------------------------------------------------------------------------------------

fn gather_case() -> impl Strategy<Value = (Tensor, usize, Vec<usize>)> {
    (1usize..6, 1usize..4, 1usize..3, 1usize..6).prop_flat_map(|(n, c, arity, rows)| {
        (
            tensor(n, c, -2.0, 2.0),
            Just(arity),
            prop::collection::vec(0..n, rows * arity),
        )
    })
}

fn scatter_case() -> impl Strategy<Value = (Tensor, usize, Vec<usize>, usize)> {
    (1usize..6, 1usize..4, 1usize..3, 1usize..6).prop_flat_map(|(n, c, arity, rows)| {
        (
            tensor(rows, arity * c, -2.0, 2.0),
            Just(arity),
            prop::collection::vec(0..n, rows * arity),
            Just(n),
        )
    })
}

fn assign_case() -> impl Strategy<Value = (Tensor, Vec<usize>, Tensor)> {
    (1usize..7, 1usize..4)
        .prop_flat_map(|(n, c)| {
            (
                tensor(n, c, -2.0, 2.0),
                prop::sample::subsequence((0..n).collect::<Vec<_>>(), 1..=n).prop_shuffle(),
                Just(c),
            )
        })
        .prop_flat_map(|(dst, idx, c)| {
            let k = idx.len();
            (Just(dst), Just(idx), tensor(k, c, -2.0, 2.0))
        })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn fd_leaf(x in shape().prop_flat_map(|(r, c)| tensor(r, c, -3.0, 3.0))) {
        // The loss reads the leaf directly: its gradient is the weight tensor itself.
        let mut t = Tape::new();
        let v = t.leaf(x.clone());
        check_value(&t, v, &x)?;
        let l = wsum(&mut t, v);
        let g = t.backward(l).wrt(v);
        for (k, &gk) in g.data().iter().enumerate() {
            prop_assert_eq!(gk, weight(k));
        }
        fd_check(&[x], |t, v| wsum(t, v[0]))?;
    }

    #[test]
    fn fd_gather((src, arity, idx) in gather_case()) {
        let index = Arc::new(RowIndex::new(arity, idx.clone()));
        let c = src.cols();
        let mut t = Tape::new();
        let s = t.leaf(src.clone());
        let y = t.gather(s, &index);
        let expected: Vec<f64> = idx.iter().flat_map(|&p| src.row(p).to_vec()).collect();
        check_value(&t, y, &Tensor::new(index.rows(), arity * c, expected))?;
        fd_check(&[src], |t, v| {
            let y = t.gather(v[0], &index);
            let y2 = t.square(y);
            wsum(t, y2)
        })?;
    }

    #[test]
    fn fd_scatter_add((src, arity, idx, n) in scatter_case()) {
        let index = Arc::new(RowIndex::new(arity, idx.clone()));
        let c = src.cols() / arity;
        let mut t = Tape::new();
        let s = t.leaf(src.clone());
        let y = t.scatter_add(s, &index, n);
        let mut expected = Tensor::zeros(n, c);
        for (k, &p) in idx.iter().enumerate() {
            for j in 0..c {
                expected.data_mut()[p * c + j] += src.data()[k * c + j];
            }
        }
        check_value(&t, y, &expected)?;
        fd_check(&[src], |t, v| {
            let y = t.scatter_add(v[0], &index, n);
            let y2 = t.square(y);
            wsum(t, y2)
        })?;
    }

    #[test]
    fn fd_assign_rows((dst, idx, src) in assign_case()) {
        let index = Arc::new(RowIndex::single(idx.clone()));
        let mut t = Tape::new();
        let (d, s) = (t.leaf(dst.clone()), t.leaf(src.clone()));
        let y = t.assign_rows(d, &index, s);
        let mut expected = dst.clone();
        for (k, &p) in idx.iter().enumerate() {
            expected.row_mut(p).copy_from_slice(src.row(k));
        }
        check_value(&t, y, &expected)?;
        // Replaced rows of `dst` get exactly zero gradient.
        let l = wsum(&mut t, y);
        let gd = t.backward(l).wrt(d);
        for &p in &idx {
            prop_assert!(gd.row(p).iter().all(|&g| g == 0.0));
        }
        fd_check(&[dst, src], |t, v| {
            let y = t.assign_rows(v[0], &index, v[1]);
            let y2 = t.square(y);
            wsum(t, y2)
        })?;
    }
}

#[test]
fn gather_repeated_indices_accumulate() {
    // Row 1 is read three times (twice in one arity-2 row): its gradient is the sum.
    let mut t = Tape::new();
    let x = t.leaf(Tensor::from_rows(&[[1.0, 2.0], [3.0, 4.0], [5.0, 6.0]]));
    let index = Arc::new(RowIndex::new(2, vec![1, 1, 0, 1]));
    let y = t.gather(x, &index);
    assert_eq!(t.shape(y), (2, 4));
    assert_eq!(t.value(y).data(), &[3.0, 4.0, 3.0, 4.0, 1.0, 2.0, 3.0, 4.0]);
    let l = t.sum(y);
    let g = t.backward(l).wrt(x);
    assert_eq!(g.data(), &[1.0, 1.0, 3.0, 3.0, 0.0, 0.0]);
}

// ---------------------------------------------------------------------------------------------
// Elementwise binary ops with broadcasting
// ---------------------------------------------------------------------------------------------

#[derive(Clone, Copy, Debug)]
enum Bin {
    Add,
    Sub,
    Mul,
    Div,
    Min,
    Max,
}

impl Bin {
    fn record(self, t: &mut Tape, a: Var, b: Var) -> Var {
        match self {
            Bin::Add => t.add(a, b),
            Bin::Sub => t.sub(a, b),
            Bin::Mul => t.mul(a, b),
            Bin::Div => t.div(a, b),
            Bin::Min => t.min(a, b),
            Bin::Max => t.max(a, b),
        }
    }
    fn eval(self, x: f64, y: f64) -> f64 {
        match self {
            Bin::Add => x + y,
            Bin::Sub => x - y,
            Bin::Mul => x * y,
            Bin::Div => x / y,
            Bin::Min => x.min(y),
            Bin::Max => x.max(y),
        }
    }
}

/// Operand shape for broadcasting mode `m` against an `r × c` result: full, scalar, row, column.
fn mode_shape(m: u8, r: usize, c: usize) -> (usize, usize) {
    match m {
        0 => (r, c),
        1 => (1, 1),
        2 => (1, c),
        _ => (r, 1),
    }
}

fn bcast_get(t: &Tensor, i: usize, j: usize) -> f64 {
    let (r, c) = t.shape();
    t.get(if r == 1 { 0 } else { i }, if c == 1 { 0 } else { j })
}

fn binary_case(nonzero_b: bool) -> impl Strategy<Value = (Tensor, Tensor)> {
    (shape(), 0u8..4, 0u8..4).prop_flat_map(move |((r, c), ma, mb)| {
        let (sa, sb) = (mode_shape(ma, r, c), mode_shape(mb, r, c));
        let b = if nonzero_b {
            tensor_nonzero(sb.0, sb.1)
                .prop_map(|t| {
                    // |b| ≥ 0.5 for a well-conditioned quotient.
                    let d = t
                        .data()
                        .iter()
                        .map(|&v| v.signum() * (0.4 + v.abs()))
                        .collect();
                    Tensor::new(t.rows(), t.cols(), d)
                })
                .boxed()
        } else {
            tensor(sb.0, sb.1, -2.0, 2.0).boxed()
        };
        (tensor(sa.0, sa.1, -2.0, 2.0), b)
    })
}

fn check_binary(op: Bin, a: Tensor, b: Tensor) -> Result<(), TestCaseError> {
    let r = a.rows().max(b.rows());
    let c = a.cols().max(b.cols());
    if matches!(op, Bin::Min | Bin::Max) {
        // Keep clear of ties: the sub-gradient convention is tested separately.
        for i in 0..r {
            for j in 0..c {
                prop_assume!((bcast_get(&a, i, j) - bcast_get(&b, i, j)).abs() > 1e-3);
            }
        }
    }
    let mut t = Tape::new();
    let (va, vb) = (t.leaf(a.clone()), t.leaf(b.clone()));
    let y = op.record(&mut t, va, vb);
    let mut expected = Tensor::zeros(r, c);
    for i in 0..r {
        for j in 0..c {
            expected.data_mut()[i * c + j] = op.eval(bcast_get(&a, i, j), bcast_get(&b, i, j));
        }
    }
    check_value(&t, y, &expected)?;
    // Both operand orders, and the operand used against itself.
    fd_check(&[a.clone(), b.clone()], |t, v| {
        let y = op.record(t, v[0], v[1]);
        wsum(t, y)
    })?;
    fd_check(&[b, a], |t, v| {
        let y = op.record(t, v[1], v[0]);
        let z = t.square(y);
        wsum(t, z)
    })?;
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn fd_add((a, b) in binary_case(false)) { check_binary(Bin::Add, a, b)?; }
    #[test]
    fn fd_sub((a, b) in binary_case(false)) { check_binary(Bin::Sub, a, b)?; }
    #[test]
    fn fd_mul((a, b) in binary_case(false)) { check_binary(Bin::Mul, a, b)?; }
    #[test]
    fn fd_div((a, b) in binary_case(true)) { check_binary(Bin::Div, a, b)?; }
    #[test]
    fn fd_min((a, b) in binary_case(false)) { check_binary(Bin::Min, a, b)?; }
    #[test]
    fn fd_max((a, b) in binary_case(false)) { check_binary(Bin::Max, a, b)?; }
}

#[test]
fn broadcast_shapes() {
    // Every pairing of full / scalar / row / column operands, on either side.
    let mut t = Tape::new();
    let full = t.leaf(Tensor::zeros(3, 4));
    let scalar = t.leaf(Tensor::scalar(1.0));
    let row = t.leaf(Tensor::zeros(1, 4));
    let col = t.leaf(Tensor::zeros(3, 1));
    let all = [
        (full, (3, 4)),
        (scalar, (1, 1)),
        (row, (1, 4)),
        (col, (3, 1)),
    ];
    for &(a, sa) in &all {
        for &(b, sb) in &all {
            let y = t.add(a, b);
            let expected = (sa.0.max(sb.0), sa.1.max(sb.1));
            assert_eq!(t.shape(y), expected, "{sa:?} + {sb:?}");
            let l = t.sum(y);
            let g = t.backward(l);
            assert_eq!(g.wrt(a).shape(), sa);
            assert_eq!(g.wrt(b).shape(), sb);
            // Each operand entry is read (result elements) / (operand elements) times.
            let n = (expected.0 * expected.1) as f64;
            if a != b {
                assert!(g
                    .wrt(a)
                    .data()
                    .iter()
                    .all(|&x| x == n / (sa.0 * sa.1) as f64));
            }
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Unary ops
// ---------------------------------------------------------------------------------------------

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn fd_neg(x in shape().prop_flat_map(|(r, c)| tensor(r, c, -3.0, 3.0))) {
        let mut t = Tape::new();
        let v = t.leaf(x.clone());
        let y = t.neg(v);
        let e: Vec<f64> = x.data().iter().map(|a| -a).collect();
        check_value(&t, y, &Tensor::new(x.rows(), x.cols(), e))?;
        fd_check(&[x], |t, v| { let y = t.neg(v[0]); let z = t.square(y); wsum(t, z) })?;
    }

    #[test]
    fn fd_square(x in shape().prop_flat_map(|(r, c)| tensor(r, c, -3.0, 3.0))) {
        let mut t = Tape::new();
        let v = t.leaf(x.clone());
        let y = t.square(v);
        let e: Vec<f64> = x.data().iter().map(|a| a * a).collect();
        check_value(&t, y, &Tensor::new(x.rows(), x.cols(), e))?;
        fd_check(&[x], |t, v| { let y = t.square(v[0]); wsum(t, y) })?;
    }

    #[test]
    fn fd_sqrt(x in shape().prop_flat_map(|(r, c)| tensor(r, c, 0.1, 4.0))) {
        let mut t = Tape::new();
        let v = t.leaf(x.clone());
        let y = t.sqrt(v);
        let e: Vec<f64> = x.data().iter().map(|a| a.sqrt()).collect();
        check_value(&t, y, &Tensor::new(x.rows(), x.cols(), e))?;
        fd_check(&[x], |t, v| { let y = t.sqrt(v[0]); wsum(t, y) })?;
    }

    #[test]
    fn fd_relu(x in shape().prop_flat_map(|(r, c)| tensor_nonzero(r, c))) {
        let mut t = Tape::new();
        let v = t.leaf(x.clone());
        let y = t.relu(v);
        let e: Vec<f64> = x.data().iter().map(|a| a.max(0.0)).collect();
        check_value(&t, y, &Tensor::new(x.rows(), x.cols(), e))?;
        fd_check(&[x], |t, v| { let y = t.relu(v[0]); let z = t.square(y); wsum(t, z) })?;
    }

    #[test]
    fn fd_add_scalar(
        x in shape().prop_flat_map(|(r, c)| tensor(r, c, -3.0, 3.0)),
        c in -3.0f64..3.0,
    ) {
        let mut t = Tape::new();
        let v = t.leaf(x.clone());
        let y = t.add_scalar(v, c);
        let e: Vec<f64> = x.data().iter().map(|a| a + c).collect();
        check_value(&t, y, &Tensor::new(x.rows(), x.cols(), e))?;
        fd_check(&[x], |t, v| { let y = t.add_scalar(v[0], c); let z = t.square(y); wsum(t, z) })?;
    }

    #[test]
    fn fd_scale(
        x in shape().prop_flat_map(|(r, c)| tensor(r, c, -3.0, 3.0)),
        c in -3.0f64..3.0,
    ) {
        let mut t = Tape::new();
        let v = t.leaf(x.clone());
        let y = t.scale(v, c);
        let e: Vec<f64> = x.data().iter().map(|a| c * a).collect();
        check_value(&t, y, &Tensor::new(x.rows(), x.cols(), e))?;
        fd_check(&[x], |t, v| { let y = t.scale(v[0], c); let z = t.square(y); wsum(t, z) })?;
    }
}

// ---------------------------------------------------------------------------------------------
// Reductions and concatenation
// ---------------------------------------------------------------------------------------------

fn no_row_tie(x: &Tensor) -> bool {
    (0..x.rows()).all(|i| {
        let row = x.row(i);
        row.iter()
            .enumerate()
            .all(|(a, &u)| row[a + 1..].iter().all(|&w| (u - w).abs() > 1e-3))
    })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn fd_sum(x in shape().prop_flat_map(|(r, c)| tensor(r, c, -3.0, 3.0))) {
        let mut t = Tape::new();
        let v = t.leaf(x.clone());
        let y = t.sum(v);
        check_value(&t, y, &Tensor::scalar(x.data().iter().sum()))?;
        fd_check(&[x], |t, v| { let y = t.square(v[0]); let s = t.sum(y); t.square(s) })?;
    }

    #[test]
    fn fd_row_sum(x in shape().prop_flat_map(|(r, c)| tensor(r, c, -3.0, 3.0))) {
        let mut t = Tape::new();
        let v = t.leaf(x.clone());
        let y = t.row_sum(v);
        let e = (0..x.rows()).map(|i| x.row(i).iter().sum()).collect();
        check_value(&t, y, &Tensor::vector(e))?;
        fd_check(&[x], |t, v| { let y = t.row_sum(v[0]); let z = t.square(y); wsum(t, z) })?;
    }

    #[test]
    fn fd_row_norm(x in shape().prop_flat_map(|(r, c)| tensor_nonzero(r, c))) {
        let mut t = Tape::new();
        let v = t.leaf(x.clone());
        let y = t.row_norm(v);
        let e = (0..x.rows())
            .map(|i| x.row(i).iter().map(|a| a * a).sum::<f64>().sqrt())
            .collect();
        check_value(&t, y, &Tensor::vector(e))?;
        fd_check(&[x], |t, v| { let y = t.row_norm(v[0]); wsum(t, y) })?;
    }

    #[test]
    fn fd_dot((a, b) in shape().prop_flat_map(|(r, c)| (tensor(r, c, -2.0, 2.0), tensor(r, c, -2.0, 2.0)))) {
        let mut t = Tape::new();
        let (va, vb) = (t.leaf(a.clone()), t.leaf(b.clone()));
        let y = t.dot(va, vb);
        let e = a.data().iter().zip(b.data()).map(|(x, y)| x * y).sum();
        check_value(&t, y, &Tensor::scalar(e))?;
        fd_check(&[a, b], |t, v| { let y = t.dot(v[0], v[1]); t.square(y) })?;
        // A tensor dotted with itself.
    }

    #[test]
    fn fd_row_min(x in shape().prop_flat_map(|(r, c)| tensor(r, c, -2.0, 2.0))) {
        prop_assume!(no_row_tie(&x));
        let mut t = Tape::new();
        let v = t.leaf(x.clone());
        let y = t.row_min(v);
        let e = (0..x.rows()).map(|i| x.row(i).iter().copied().fold(f64::INFINITY, f64::min)).collect();
        check_value(&t, y, &Tensor::vector(e))?;
        fd_check(&[x], |t, v| { let y = t.row_min(v[0]); let z = t.square(y); wsum(t, z) })?;
    }

    #[test]
    fn fd_row_max(x in shape().prop_flat_map(|(r, c)| tensor(r, c, -2.0, 2.0))) {
        prop_assume!(no_row_tie(&x));
        let mut t = Tape::new();
        let v = t.leaf(x.clone());
        let y = t.row_max(v);
        let e = (0..x.rows()).map(|i| x.row(i).iter().copied().fold(f64::NEG_INFINITY, f64::max)).collect();
        check_value(&t, y, &Tensor::vector(e))?;
        fd_check(&[x], |t, v| { let y = t.row_max(v[0]); let z = t.square(y); wsum(t, z) })?;
    }

    #[test]
    fn fd_concat_rows(parts in (1usize..4, 1usize..4).prop_flat_map(|(n, c)| {
        prop::collection::vec((1usize..4).prop_flat_map(move |r| tensor(r, c, -2.0, 2.0)), n)
    })) {
        let mut t = Tape::new();
        let vs: Vec<Var> = parts.iter().map(|p| t.leaf(p.clone())).collect();
        let y = t.concat_rows(&vs);
        let rows = parts.iter().map(|p| p.rows()).sum();
        let e = parts.iter().flat_map(|p| p.data().to_vec()).collect();
        check_value(&t, y, &Tensor::new(rows, parts[0].cols(), e))?;
        fd_check(&parts, |t, v| { let y = t.concat_rows(v); let z = t.square(y); wsum(t, z) })?;
    }

    #[test]
    fn fd_concat_cols(parts in (1usize..4, 1usize..4).prop_flat_map(|(n, r)| {
        prop::collection::vec((1usize..4).prop_flat_map(move |c| tensor(r, c, -2.0, 2.0)), n)
    })) {
        let mut t = Tape::new();
        let vs: Vec<Var> = parts.iter().map(|p| t.leaf(p.clone())).collect();
        let y = t.concat_cols(&vs);
        let r = parts[0].rows();
        let cols = parts.iter().map(|p| p.cols()).sum();
        let e = (0..r).flat_map(|i| parts.iter().flat_map(move |p| p.row(i).to_vec())).collect();
        check_value(&t, y, &Tensor::new(r, cols, e))?;
        fd_check(&parts, |t, v| { let y = t.concat_cols(v); let z = t.square(y); wsum(t, z) })?;
    }
}

#[test]
fn concat_same_var_twice() {
    let mut t = Tape::new();
    let x = t.leaf(Tensor::from_rows(&[[1.0, 2.0]]));
    let r = t.concat_rows(&[x, x]);
    let c = t.concat_cols(&[x, x, x]);
    let (lr, lc) = (t.sum(r), t.sum(c));
    let l = t.add(lr, lc);
    assert_eq!(t.backward(l).wrt(x).data(), &[5.0, 5.0]);
}

// ---------------------------------------------------------------------------------------------
// map_rows: the batched local-function op
// ---------------------------------------------------------------------------------------------

/// A nonlinear row function `R³ → R²` using sqrt, exp, sin, atan2 and powi, with a per-row
/// parameter.
struct Wavy {
    p: Vec<f64>,
}

impl RowFn for Wavy {
    fn n_in(&self) -> usize {
        3
    }
    fn n_out(&self) -> usize {
        2
    }
    fn eval<R: Real>(&self, row: usize, x: &[R], out: &mut [R]) {
        let p = self.p[row % self.p.len()];
        let r = (x[0] * x[0] + x[1] * x[1] + p).sqrt();
        // x[2] ≥ -2 keeps atan2 away from its branch cut and the origin.
        out[0] = r * (x[2] * 0.3).exp() + (x[0] * x[1]).sin();
        out[1] = x[1].atan2(x[2] + 3.0) * x[0].powi(3) + (x[2] * x[2] + 1.0).powi(-2) * p;
    }
}

/// A row function `R¹¹ → R³`: more inputs than one dual chunk.
struct Wide;

impl RowFn for Wide {
    fn n_in(&self) -> usize {
        11
    }
    fn n_out(&self) -> usize {
        3
    }
    fn eval<R: Real>(&self, row: usize, x: &[R], out: &mut [R]) {
        let mut s = R::cst(row as f64 * 0.1);
        let mut q = R::zero();
        for (i, &xi) in x.iter().enumerate() {
            s += xi * (i as f64 + 1.0) * 0.1;
            q += xi * xi;
        }
        out[0] = s.sin();
        out[1] = (q + 1.0).sqrt() * x[10];
        out[2] = (x[0] * x[9]).exp() - x[5] * s;
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn fd_map_rows(
        (x, p) in (1usize..8).prop_flat_map(|r| (
            tensor(r, 3, -2.0, 2.0),
            prop::collection::vec(0.2f64..2.0, r),
        ))
    ) {
        let f = arc(Wavy { p: p.clone() });
        let mut t = Tape::new();
        let v = t.leaf(x.clone());
        let y = t.map_rows(&f, v);
        let mut e = vec![0.0; x.rows() * 2];
        for i in 0..x.rows() {
            Wavy { p: p.clone() }.eval(i, x.row(i), &mut e[2 * i..2 * i + 2]);
        }
        check_value(&t, y, &Tensor::new(x.rows(), 2, e))?;
        fd_check(&[x], |t, v| { let y = t.map_rows(&f, v[0]); wsum(t, y) })?;
    }

    #[test]
    fn fd_map_rows_wide(x in (1usize..4).prop_flat_map(|r| tensor(r, 11, -1.0, 1.0))) {
        let f = arc(Wide);
        fd_check(&[x], |t, v| { let y = t.map_rows(&f, v[0]); wsum(t, y) })?;
    }
}

#[test]
fn fd_map_rows_parallel_batch() {
    // Enough rows for the rayon path. Rows are independent, so the central difference of entry
    // (i, j) is taken on row i's own weighted outputs (a sum over all rows would drown it in
    // rounding).
    let rows = autodiff::rowfn::PARALLEL_MIN_ROWS + 37;
    let x = Tensor::new(
        rows,
        3,
        (0..rows * 3)
            .map(|k| ((k as f64) * 0.731).sin() * 1.9)
            .collect(),
    );
    let p: Vec<f64> = (0..rows).map(|i| 0.3 + (i % 7) as f64 * 0.2).collect();
    let wavy = Wavy { p: p.clone() };
    let f = arc(Wavy { p });
    let mut t = Tape::new();
    let v = t.leaf(x.clone());
    let y = t.map_rows(&f, v);
    let l = wsum(&mut t, y);
    let g = t.backward(l).wrt(v);
    let row_loss = |i: usize, row: &[f64]| {
        let mut out = [0.0; 2];
        wavy.eval(i, row, &mut out);
        weight(2 * i) * out[0] + weight(2 * i + 1) * out[1]
    };
    for i in 0..rows {
        for j in 0..3 {
            let mut row = x.row(i).to_vec();
            let h = 1e-6 * row[j].abs().max(1.0);
            let x0 = row[j];
            row[j] = x0 + h;
            let fp = row_loss(i, &row);
            row[j] = x0 - h;
            let fm = row_loss(i, &row);
            let fd = (fp - fm) / ((x0 + h) - (x0 - h));
            close(g.get(i, j), fd, &format!("entry ({i}, {j})")).unwrap();
        }
    }
}

// ---------------------------------------------------------------------------------------------
// update_rows: in-place Gauss–Seidel row updates with a carry
// ---------------------------------------------------------------------------------------------

/// An XPBD distance projection between two particles with a carried Lagrange multiplier λ:
/// inputs and outputs `[xᵢ (3), xⱼ (3), λ]`.
struct XpbdDistance {
    rest: Vec<f64>,
    alpha: f64,
    w: [f64; 2],
}

impl RowFn for XpbdDistance {
    fn n_in(&self) -> usize {
        7
    }
    fn n_out(&self) -> usize {
        7
    }
    fn eval<R: Real>(&self, row: usize, x: &[R], out: &mut [R]) {
        let d = [x[0] - x[3], x[1] - x[4], x[2] - x[5]];
        let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        let c = len - self.rest[row];
        let lambda = x[6];
        let dl = (-c - lambda * self.alpha) / (self.w[0] + self.w[1] + self.alpha);
        for k in 0..3 {
            let n = d[k] / len;
            out[k] = x[k] + n * dl * self.w[0];
            out[3 + k] = x[3 + k] - n * dl * self.w[1];
        }
        out[6] = lambda + dl;
    }
}

/// A chain of `n` particles near `(1.1 i, 0, 0)` (so every pair is well separated) and the two
/// disjoint edge sets `{(0,1), (2,3), …}` and `{(1,2), (3,4), …}`.
#[derive(Clone, Debug)]
struct ChainCase {
    x: Tensor,
    rest: Vec<f64>,
    lam_a: Tensor,
    lam_b: Tensor,
    alpha: f64,
    sweeps: usize,
    pre_use: bool,
}

fn chain_case() -> impl Strategy<Value = ChainCase> {
    (3usize..9).prop_flat_map(|n| {
        let (na, nb) = (n / 2, (n - 1) / 2);
        (
            prop::collection::vec(-0.25f64..0.25, n * 3),
            prop::collection::vec(0.7f64..1.5, n),
            tensor(na, 1, -0.3, 0.3),
            tensor(nb, 1, -0.3, 0.3),
            0.0f64..0.5,
            1usize..4,
            any::<bool>(),
        )
            .prop_map(move |(noise, rest, lam_a, lam_b, alpha, sweeps, pre_use)| {
                let x = (0..n * 3)
                    .map(|k| {
                        noise[k]
                            + if k % 3 == 0 {
                                1.1 * (k / 3) as f64
                            } else {
                                0.0
                            }
                    })
                    .collect();
                ChainCase {
                    x: Tensor::new(n, 3, x),
                    rest,
                    lam_a,
                    lam_b,
                    alpha,
                    sweeps,
                    pre_use,
                }
            })
    })
}

fn chain_sets(n: usize) -> (Arc<RowIndex>, Arc<RowIndex>) {
    let a = (0..n / 2).flat_map(|k| [2 * k, 2 * k + 1]).collect();
    let b = (0..(n - 1) / 2)
        .flat_map(|k| [2 * k + 1, 2 * k + 2])
        .collect();
    (Arc::new(RowIndex::new(2, a)), Arc::new(RowIndex::new(2, b)))
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn fd_update_rows(case in chain_case()) {
        let n = case.x.rows();
        let (set_a, set_b) = chain_sets(n);
        let f_a = arc(XpbdDistance { rest: case.rest[..set_a.rows()].to_vec(), alpha: case.alpha, w: [1.0, 0.7] });
        let f_b = arc(XpbdDistance { rest: case.rest[set_a.rows()..].to_vec(), alpha: case.alpha, w: [0.8, 1.0] });
        let sweeps = case.sweeps;
        let pre_use = case.pre_use;
        let build = |t: &mut Tape, v: &[Var]| {
            // A non-leaf state: moved by the first update unless something else read it first.
            let mut x = t.scale(v[0], 1.0);
            let aux = if pre_use { Some(t.row_norm(x)) } else { None };
            let (mut la, mut lb) = (v[1], v[2]);
            for _ in 0..sweeps {
                (x, la) = t.update_rows(&f_a, &set_a, x, la);
                (x, lb) = t.update_rows(&f_b, &set_b, x, lb);
            }
            let xs = t.map_rows(&arc(Wavy { p: vec![0.5] }), x);
            let mut l = wsum(t, xs);
            for extra in [Some(la), Some(lb), aux].into_iter().flatten() {
                let e = wsum(t, extra);
                l = t.add(l, e);
            }
            l
        };
        // Forward: the recorded path agrees bit for bit with the plain f64 path.
        let mut t = Tape::new();
        let leaves = [case.x.clone(), case.lam_a.clone(), case.lam_b.clone()];
        let vars: Vec<Var> = leaves.iter().map(|l| t.leaf(l.clone())).collect();
        let (mut x, mut la, mut lb) = (vars[0], vars[1], vars[2]);
        let (mut px, mut pla, mut plb) = (case.x.clone(), case.lam_a.clone(), case.lam_b.clone());
        for _ in 0..sweeps {
            (x, la) = t.update_rows(&f_a, &set_a, x, la);
            (x, lb) = t.update_rows(&f_b, &set_b, x, lb);
            update::update_rows(f_a.as_ref(), &set_a, &mut px, &mut pla, None);
            update::update_rows(f_b.as_ref(), &set_b, &mut px, &mut plb, None);
        }
        prop_assert_eq!(t.value(x), &px);
        prop_assert_eq!(t.value(la), &pla);
        prop_assert_eq!(t.value(lb), &plb);
        fd_check(&leaves, build)?;
    }
}

/// `vjp_many` of one seed set per pick (`(mask, value seed)`: the `live` outputs the mask
/// selects, with pseudo-random values) gives each set's `vjp` bit for bit at every leaf of `vars`.
fn vjp_many_matches_vjp(
    t: &Tape,
    live: &[Var],
    picks: &[(u64, u64)],
    vars: &[Var],
) -> Result<(), TestCaseError> {
    let seeds: Vec<Vec<(Var, Tensor)>> = picks
        .iter()
        .map(|&(mask, value_seed)| {
            live.iter()
                .enumerate()
                .filter(|(i, _)| mask >> i & 1 == 1)
                .map(|(i, &v)| {
                    let (r, c) = t.value(v).shape();
                    let data = (0..r * c)
                        .map(|k| ((value_seed + 7 * k as u64 + i as u64) % 97) as f64 / 48.0 - 1.0)
                        .collect();
                    (v, Tensor::new(r, c, data))
                })
                .collect()
        })
        .collect();
    let together = t.vjp_many(&seeds);
    prop_assert_eq!(together.len(), seeds.len());
    for (g, s) in together.iter().zip(&seeds) {
        let alone = t.vjp(s);
        for &v in vars {
            prop_assert_eq!(g.wrt(v), alone.wrt(v));
        }
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(128))]

    /// `vjp_many` (every seed pulled back together, Gauss–Seidel nodes through
    /// `vjp_update_batch_seeds`) gives each seed's `vjp` bit for bit: up to 11 seeds (more than
    /// one `SEED_CHUNK`), each on a random subset of the final state and multipliers (a seed on
    /// `λ_b` alone reaches a `set_b` node before any state adjoint exists).
    #[test]
    fn vjp_many_matches_separate_vjps(
        case in chain_case(),
        picks in prop::collection::vec((any::<u64>(), 0u64..1 << 20), 1..12),
    ) {
        let n = case.x.rows();
        let (set_a, set_b) = chain_sets(n);
        let f_a = arc(XpbdDistance { rest: case.rest[..set_a.rows()].to_vec(), alpha: case.alpha, w: [1.0, 0.7] });
        let f_b = arc(XpbdDistance { rest: case.rest[set_a.rows()..].to_vec(), alpha: case.alpha, w: [0.8, 1.0] });
        let mut t = Tape::new();
        let leaves = [case.x.clone(), case.lam_a.clone(), case.lam_b.clone()];
        let vars: Vec<Var> = leaves.iter().map(|l| t.leaf(l.clone())).collect();
        let (mut x, mut la, mut lb) = (t.scale(vars[0], 1.0), vars[1], vars[2]);
        let mut outputs = Vec::new();
        for _ in 0..case.sweeps {
            (x, la) = t.update_rows(&f_a, &set_a, x, la);
            outputs.push(x);
            (x, lb) = t.update_rows(&f_b, &set_b, x, lb);
            outputs.push(x);
        }
        // The intermediate states were moved by the next update: seed only the live ones.
        let live = [*outputs.last().unwrap(), la, lb];
        vjp_many_matches_vjp(&t, &live, &picks, &vars)?;
    }
}

/// [`XpbdDistance`] with a second carried value (`[xᵢ, xⱼ, λ, κ]`, `κ ← 0.5κ + λ'`): a carry of
/// width 2, so its updates take the general (gather, pull back, scatter) kernels.
struct XpbdDistanceCarry2(XpbdDistance);

impl RowFn for XpbdDistanceCarry2 {
    fn n_in(&self) -> usize {
        8
    }
    fn n_out(&self) -> usize {
        8
    }
    fn eval<R: Real>(&self, row: usize, x: &[R], out: &mut [R]) {
        self.0.eval(row, &x[..7], &mut out[..7]);
        out[7] = x[7] * 0.5 + out[6] * out[6];
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(128))]

    /// `vjp_many` through updates whose rows are not points with one carried value (a carry of
    /// width 2: the gathered multi-seed kernel, one dual Jacobian per row for up to `SEED_CHUNK`
    /// seeds) gives each seed's `vjp` bit for bit, with up to 11 seeds.
    #[test]
    fn vjp_many_matches_separate_vjps_for_wide_carries(
        case in chain_case(),
        picks in prop::collection::vec((any::<u64>(), 0u64..1 << 20), 1..12),
    ) {
        let n = case.x.rows();
        let (set_a, set_b) = chain_sets(n);
        let wide = |f: XpbdDistance| arc(XpbdDistanceCarry2(f));
        let f_a = wide(XpbdDistance { rest: case.rest[..set_a.rows()].to_vec(), alpha: case.alpha, w: [1.0, 0.7] });
        let f_b = wide(XpbdDistance { rest: case.rest[set_a.rows()..].to_vec(), alpha: case.alpha, w: [0.8, 1.0] });
        let widen = |l: &Tensor| {
            let data = l.data().iter().flat_map(|&v| [v, 0.5 * v + 0.1]).collect();
            Tensor::new(l.rows(), 2, data)
        };
        let mut t = Tape::new();
        let leaves = [case.x.clone(), widen(&case.lam_a), widen(&case.lam_b)];
        let vars: Vec<Var> = leaves.iter().map(|l| t.leaf(l.clone())).collect();
        let (mut x, mut la, mut lb) = (t.scale(vars[0], 1.0), vars[1], vars[2]);
        for _ in 0..case.sweeps {
            (x, la) = t.update_rows(&f_a, &set_a, x, la);
            (x, lb) = t.update_rows(&f_b, &set_b, x, lb);
        }
        vjp_many_matches_vjp(&t, &[x, la, lb], &picks, &vars)?;
    }
}

// ---------------------------------------------------------------------------------------------
// Random compositions
// ---------------------------------------------------------------------------------------------

/// A smooth row function `R^{2c} → R^c` for compositions after `concat_cols`.
struct Mix {
    c: usize,
}

impl RowFn for Mix {
    fn n_in(&self) -> usize {
        2 * self.c
    }
    fn n_out(&self) -> usize {
        self.c
    }
    fn eval<R: Real>(&self, _row: usize, x: &[R], out: &mut [R]) {
        for j in 0..self.c {
            let (a, b) = (x[j], x[self.c + j]);
            out[j] = a.sin() * b + (b * 0.5).cos() * (a * a + 1.0).sqrt();
        }
    }
}

/// A row update `R^{c+1} → R^{c+1}` (state row plus a carried scalar) for compositions.
struct Relax {
    c: usize,
}

impl RowFn for Relax {
    fn n_in(&self) -> usize {
        self.c + 1
    }
    fn n_out(&self) -> usize {
        self.c + 1
    }
    fn eval<R: Real>(&self, _row: usize, x: &[R], out: &mut [R]) {
        let k = x[self.c];
        let mut q = R::zero();
        for j in 0..self.c {
            q += x[j] * x[j];
        }
        let s = (q + 1.0).sqrt();
        for j in 0..self.c {
            out[j] = x[j] / s + k * 0.3;
        }
        out[self.c] = (k * 0.5).sin() + s;
    }
}

/// One step of a random program over a pool of same-shaped (`r × c`) values.
#[derive(Clone, Debug)]
struct Step {
    op: u8,
    a: usize,
    b: usize,
    k: f64,
    perm: Vec<usize>,
}

#[derive(Clone, Debug)]
struct Program {
    leaves: Vec<Tensor>,
    steps: Vec<Step>,
}

const N_OPS: u8 = 22;

fn program() -> impl Strategy<Value = Program> {
    (1usize..5, 1usize..4, 1usize..4, 2usize..9).prop_flat_map(|(r, c, n_leaves, n_steps)| {
        let step = (
            0..N_OPS,
            0usize..64,
            0usize..64,
            -1.5f64..1.5,
            prop::collection::vec(0..2 * r, r),
        )
            .prop_map(|(op, a, b, k, perm)| Step { op, a, b, k, perm });
        (
            prop::collection::vec(tensor(r, c, -1.5, 1.5), n_leaves),
            prop::collection::vec(step, n_steps),
        )
            .prop_map(|(leaves, steps)| Program { leaves, steps })
    })
}

/// Runs the program; `None` when a step would sit within `1e-4` of a kink (the case is rejected).
fn run_program(p: &Program, t: &mut Tape, leaves: &[Var]) -> Option<Var> {
    let mut pool: Vec<Var> = leaves.to_vec();
    let (r, c) = p.leaves[0].shape();
    let clear_of_kink = |t: &Tape, v: Var| t.value(v).data().iter().all(|x| x.abs() > 1e-4);
    for s in &p.steps {
        let a = pool[s.a % pool.len()];
        let b = pool[s.b % pool.len()];
        let y = match s.op {
            0 => t.add(a, b),
            1 => t.sub(a, b),
            2 => t.mul(a, b),
            3 => {
                let b2 = t.square(b);
                let den = t.add_scalar(b2, 1.0);
                t.div(a, den)
            }
            4 | 5 => {
                let d = t.sub(a, b);
                if !clear_of_kink(t, d) {
                    return None;
                }
                if s.op == 4 {
                    t.min(a, b)
                } else {
                    t.max(a, b)
                }
            }
            6 => t.neg(a),
            7 => t.square(a),
            8 => {
                let a2 = t.square(a);
                let s2 = t.add_scalar(a2, 0.5);
                t.sqrt(s2)
            }
            9 => {
                if !clear_of_kink(t, a) {
                    return None;
                }
                t.relu(a)
            }
            10 => t.add_scalar(a, s.k),
            11 => t.scale(a, s.k),
            12 => {
                // Scalar broadcast back onto the pool's shape.
                let s = t.sum(a);
                let s = t.scale(s, 0.2);
                t.mul(b, s)
            }
            13 => {
                let rs = t.row_sum(a);
                t.sub(b, rs)
            }
            14 => {
                let n = t.row_norm(a);
                let n1 = t.add_scalar(n, 0.1);
                t.div(b, n1)
            }
            15 => {
                let d = t.dot(a, b);
                let d = t.scale(d, 0.1);
                t.add(a, d)
            }
            16 | 17 => {
                // Column r×1 broadcast, on the left.
                let v = t.value(a);
                let ok = (0..r).all(|i| {
                    let row = v.row(i);
                    let best = if s.op == 16 {
                        row.iter().copied().fold(f64::INFINITY, f64::min)
                    } else {
                        row.iter().copied().fold(f64::NEG_INFINITY, f64::max)
                    };
                    row.iter().filter(|&&x| (x - best).abs() <= 1e-4).count() == 1
                });
                if !ok {
                    return None;
                }
                let m = if s.op == 16 {
                    t.row_min(a)
                } else {
                    t.row_max(a)
                };
                t.mul(m, b)
            }
            18 => {
                // concat_rows, then gather r rows back (with repeats).
                let cat = t.concat_rows(&[a, b]);
                t.gather(cat, &Arc::new(RowIndex::single(s.perm.clone())))
            }
            19 => {
                let cat = t.concat_cols(&[a, b]);
                t.map_rows(&arc(Mix { c }), cat)
            }
            20 => {
                // scatter_add of r rows into r rows.
                let idx: Vec<usize> = s.perm.iter().map(|&i| i % r).collect();
                t.scatter_add(a, &Arc::new(RowIndex::single(idx)), r)
            }
            _ => {
                // update_rows on a disjoint subset of rows, with a carry computed from `b`.
                let mut rows: Vec<usize> = s.perm.iter().map(|&i| i % r).collect();
                rows.sort_unstable();
                rows.dedup();
                let sel = Arc::new(RowIndex::single(rows));
                let g = t.gather(b, &sel);
                let carry = t.row_sum(g);
                let (ns, nc) = t.update_rows(&arc(Relax { c }), &sel, a, carry);
                // `a` may have been moved: replace it in the pool.
                let pos = s.a % pool.len();
                pool[pos] = ns;
                let cs = t.sum(nc);
                t.mul(ns, cs)
            }
        };
        pool.push(y);
    }
    // Every pool value that is still readable contributes.
    let mut loss: Option<Var> = None;
    // (An `update_rows` step replaced its possibly moved state in the pool, so all are readable.)
    for (i, &v) in pool.iter().enumerate() {
        let term = wsum(t, v);
        let term = t.scale(term, 1.0 / (i + 1) as f64);
        loss = Some(match loss {
            Some(l) => t.add(l, term),
            None => term,
        });
    }
    loss
}

proptest! {
    // About one program in six sits on a kink and is rejected.
    #![proptest_config(ProptestConfig { cases: 256, max_global_rejects: 4096, ..ProptestConfig::default() })]

    #[test]
    fn fd_random_compositions(p in program()) {
        // Reject programs that sit on a kink, or whose values blow up.
        let mut probe = Tape::new();
        let vars: Vec<Var> = p.leaves.iter().map(|l| probe.leaf(l.clone())).collect();
        let loss = run_program(&p, &mut probe, &vars);
        prop_assume!(loss.is_some());
        let l = probe.value(loss.unwrap()).item();
        prop_assume!(l.is_finite() && l.abs() < 1e4);
        fd_check(&p.leaves, |t, v| run_program(&p, t, v).expect("same program, same kinks"))?;
    }
}

// ---------------------------------------------------------------------------------------------
// vjp with non-trivial seeds on non-scalar outputs
// ---------------------------------------------------------------------------------------------

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn fd_vjp_seeded(case in chain_case(), seed_x in tensor(8, 3, -1.0, 1.0), seed_m in tensor(8, 2, -1.0, 1.0)) {
        let n = case.x.rows();
        let (set_a, set_b) = chain_sets(n);
        let f_a = arc(XpbdDistance { rest: case.rest[..set_a.rows()].to_vec(), alpha: case.alpha, w: [1.0, 1.0] });
        let f_b = arc(XpbdDistance { rest: case.rest[set_a.rows()..].to_vec(), alpha: case.alpha, w: [1.0, 0.5] });
        let wavy = arc(Wavy { p: vec![0.3, 0.9] });
        // Seeds: on the final state (n × 3), on a map_rows output (n × 2), on the last carry.
        let sx = Tensor::new(n, 3, seed_x.data()[..n * 3].to_vec());
        let sm = Tensor::new(n, 2, seed_m.data()[..n * 2].to_vec());
        let sl = Tensor::new(case.lam_b.rows(), 1, seed_m.data()[..case.lam_b.rows()].to_vec());
        let forward = |t: &mut Tape, v: &[Var]| {
            let m = t.map_rows(&wavy, v[0]);
            let (mut x, mut la, mut lb) = (v[0], v[1], v[2]);
            for _ in 0..case.sweeps {
                (x, la) = t.update_rows(&f_a, &set_a, x, la);
                (x, lb) = t.update_rows(&f_b, &set_b, x, lb);
            }
            (x, m, lb)
        };
        // The scalar whose gradient the vjp must equal: Σ ⟨seedᵢ, outputᵢ⟩.
        let scalar = |t: &mut Tape, v: &[Var]| {
            let (x, m, lb) = forward(t, v);
            let (kx, km, kl) = (t.leaf(sx.clone()), t.leaf(sm.clone()), t.leaf(sl.clone()));
            let (a, b, c) = (t.dot(x, kx), t.dot(m, km), t.dot(lb, kl));
            let ab = t.add(a, b);
            t.add(ab, c)
        };
        let leaves = [case.x.clone(), case.lam_a.clone(), case.lam_b.clone()];
        let mut t = Tape::new();
        let v: Vec<Var> = leaves.iter().map(|l| t.leaf(l.clone())).collect();
        let (x, m, lb) = forward(&mut t, &v);
        let g = t.vjp(&[(x, sx.clone()), (m, sm.clone()), (lb, sl.clone())]);
        // Seed on the carry alone: the update node has no state adjoint, only a carry adjoint.
        let g_carry_only = t.vjp(&[(lb, sl.clone())]);
        let mut ft = Tape::new();
        for (li, leaf) in leaves.iter().enumerate() {
            let gl = g.wrt(v[li]);
            prop_assert_eq!(gl.shape(), leaf.shape());
            let carry_scalar = |t: &mut Tape, v: &[Var]| {
                let (_, _, lb) = forward(t, v);
                let kl = t.leaf(sl.clone());
                t.dot(lb, kl)
            };
            let gc = g_carry_only.wrt(v[li]);
            for k in 0..leaf.len() {
                check_entry(gl.data()[k], &mut ft, &leaves, li, k, &scalar, &format!("vjp leaf{li}[{k}]"))?;
                check_entry(gc.data()[k], &mut ft, &leaves, li, k, &carry_scalar, &format!("carry-only vjp leaf{li}[{k}]"))?;
            }
        }
    }
}

#[test]
fn vjp_matches_backward_of_dot() {
    // vjp with seed S on a non-scalar output equals backward of ⟨S, y⟩, bit for bit.
    let mut t = Tape::new();
    let x = t.leaf(Tensor::from_rows(&[[0.3, -1.2, 0.7], [1.1, 0.4, -0.6]]));
    let f = arc(Wavy { p: vec![0.4, 1.3] });
    let y = t.map_rows(&f, x);
    let seed = Tensor::from_rows(&[[0.25, -2.0], [1.5, 0.125]]);
    let gv = t.vjp(&[(y, seed.clone())]).wrt(x);
    let s = t.leaf(seed);
    let l = t.dot(y, s);
    let gb = t.backward(l).wrt(x);
    assert_eq!(gv, gb);
}

// ---------------------------------------------------------------------------------------------
// Accumulation over several uses
// ---------------------------------------------------------------------------------------------

#[test]
fn var_used_three_times_accumulates_exactly() {
    // y = x·x + x: x is read three times, dy/dx = 2x + 1. Dyadic values make it exact.
    for &x0 in &[0.375, -2.25, 1.5, 3.0, -0.5, 0.0, 1024.0] {
        let mut t = Tape::new();
        let x = t.leaf(Tensor::scalar(x0));
        let xx = t.mul(x, x);
        let y = t.add(xx, x);
        assert_eq!(t.value(y).item(), x0 * x0 + x0);
        assert_eq!(t.backward(y).wrt(x).item(), 2.0 * x0 + 1.0, "x = {x0}");
    }
    // The same through a tensor with broadcasting: x (2×2) used three times, once against a row.
    let mut t = Tape::new();
    let data = [0.5, -1.25, 2.0, 0.75];
    let x = t.leaf(Tensor::new(2, 2, data.to_vec()));
    let xx = t.mul(x, x);
    let y = t.add(xx, x);
    let l = t.sum(y);
    let g = t.backward(l).wrt(x);
    let expected: Vec<f64> = data.iter().map(|&v| 2.0 * v + 1.0).collect();
    assert_eq!(g.data(), &expected[..]);
}
