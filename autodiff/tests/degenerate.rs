//! The documented conventions at near-degenerate and non-differentiable points (see the module
//! docs of `autodiff::real` and `autodiff::tape`): tiny and zero norms, `relu(0)`, `sqrt(0)`, ties
//! of `min`/`max` and of `row_min`/`row_max`, `abs(0)`, `atan2(0, 0)`.

#![allow(clippy::needless_range_loop)]

use autodiff::{Dual, Real, Tape, Tensor};

type D3 = Dual<f64, 3>;
type D1 = Dual<f64, 1>;

/// `|v|` through the scalar algebra, as a row function would write it.
fn norm<R: Real>(v: &[R; 3]) -> R {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}

fn assert_rel(a: f64, b: f64, tol: f64, what: &str) {
    assert!(
        (a - b).abs() <= tol * b.abs().max(f64::MIN_POSITIVE),
        "{what}: {a:e} vs {b:e}"
    );
}

const DIRS: [[f64; 3]; 4] = [
    [3.0, 4.0, 12.0],
    [-1.0, 0.0, 0.0],
    [0.3, -0.7, 0.2],
    [-5.0, 2.0, -1.0],
];

#[test]
fn norm_of_a_1e_12_vector_has_the_unit_gradient_through_the_tape() {
    for dir in DIRS {
        let d = dir.iter().map(|x| x * x).sum::<f64>().sqrt();
        let v: Vec<f64> = dir.iter().map(|x| 1e-12 * x).collect();
        let mut t = Tape::new();
        let x = t.leaf(Tensor::new(1, 3, v.clone()));
        let n = t.row_norm(x);
        assert_rel(t.value(n).item(), 1e-12 * d, 1e-15, "|v|");
        let l = t.sum(n);
        let g = t.backward(l).wrt(x);
        for k in 0..3 {
            assert_rel(g.data()[k], dir[k] / d, 1e-14, "d|v|/dv");
        }
        // A central difference scaled to the vector's size agrees as well.
        for k in 0..3 {
            let h = 1e-6 * v[k].abs().max(1e-12);
            let f = |s: f64| {
                let mut w = v.clone();
                w[k] += s;
                w.iter().map(|x| x * x).sum::<f64>().sqrt()
            };
            let fd = (f(h) - f(-h)) / (2.0 * h);
            assert!(
                (g.data()[k] - fd).abs() <= 1e-8,
                "FD {fd} vs {}",
                g.data()[k]
            );
        }
    }
}

#[test]
fn norm_of_a_1e_12_vector_has_the_unit_gradient_through_duals() {
    for dir in DIRS {
        let d = dir.iter().map(|x| x * x).sum::<f64>().sqrt();
        let v: [D3; 3] = std::array::from_fn(|k| D3::variable(1e-12 * dir[k], k));
        let n = norm(&v);
        assert_rel(n.re, 1e-12 * d, 1e-15, "|v|");
        for k in 0..3 {
            assert_rel(n.eps[k], dir[k] / d, 1e-14, "d|v|/dv");
        }
    }
}

#[test]
fn norm_of_a_zero_vector_has_gradient_zero() {
    // Tape: a zero row among non-zero rows.
    let mut t = Tape::new();
    let x = t.leaf(Tensor::from_rows(&[
        [0.0, 0.0, 0.0],
        [3.0, 0.0, 4.0],
        [-0.0, 0.0, -0.0],
    ]));
    let n = t.row_norm(x);
    assert_eq!(t.value(n).data(), &[0.0, 5.0, 0.0]);
    let l = t.sum(n);
    let g = t.backward(l).wrt(x);
    assert!(g.is_finite());
    assert_eq!(g.row(0), &[0.0; 3]);
    assert_eq!(g.row(2), &[0.0; 3]);
    assert_rel(g.get(1, 0), 0.6, 1e-15, "row 1");
    assert_rel(g.get(1, 2), 0.8, 1e-15, "row 1");

    // Duals: gradient 0, and through nested duals the second derivatives are finite (0) too.
    let v: [D3; 3] = std::array::from_fn(|k| D3::variable(0.0, k));
    let n = norm(&v);
    assert_eq!((n.re, n.eps), (0.0, [0.0; 3]));
    let vv: [Dual<D1, 3>; 3] = std::array::from_fn(|k| Dual::variable(D1::variable(0.0, 0), k));
    let nn = norm(&vv);
    assert_eq!(nn.re.re, 0.0);
    for e in nn.eps {
        assert_eq!((e.re, e.eps[0]), (0.0, 0.0));
    }
}

#[test]
fn norm_below_the_squared_underflow_is_treated_as_zero() {
    // |v|² underflows below ~1.5e-154: such a row is the zero vector (value 0, gradient 0) — finite,
    // never NaN. Just above, the exact unit gradient.
    let mut t = Tape::new();
    let x = t.leaf(Tensor::from_rows(&[[3e-170, 4e-170], [3e-150, 4e-150]]));
    let n = t.row_norm(x);
    let l = t.sum(n);
    let g = t.backward(l).wrt(x);
    assert!(g.is_finite());
    assert_eq!(g.row(0), &[0.0, 0.0]);
    assert_rel(g.get(1, 0), 0.6, 1e-14, "d|v|/dv₀");
    assert_rel(g.get(1, 1), 0.8, 1e-14, "d|v|/dv₁");
    let v = [
        D3::variable(3e-170, 0),
        D3::variable(4e-170, 1),
        D3::constant(0.0),
    ];
    let nd = norm(&v);
    assert!(nd.eps.iter().all(|e| *e == 0.0));
}

#[test]
fn sqrt_at_zero_has_derivative_zero() {
    let mut t = Tape::new();
    let x = t.leaf(Tensor::from_rows(&[[0.0, 4.0]]));
    let y = t.sqrt(x);
    assert_eq!(t.value(y).data(), &[0.0, 2.0]);
    let l = t.sum(y);
    assert_eq!(t.backward(l).wrt(x).data(), &[0.0, 0.25]);
    let d = D1::variable(0.0, 0).sqrt();
    assert_eq!((d.re, d.eps[0]), (0.0, 0.0));
}

#[test]
fn relu_at_zero_has_derivative_zero() {
    let mut t = Tape::new();
    let x = t.leaf(Tensor::from_rows(&[[0.0, -0.0, 2.0, -1.0]]));
    let y = t.relu(x);
    assert_eq!(t.value(y).data(), &[0.0, 0.0, 2.0, 0.0]);
    let l = t.sum(y);
    assert_eq!(t.backward(l).wrt(x).data(), &[0.0, 0.0, 1.0, 0.0]);
    for z in [0.0, -0.0] {
        let d = D1::variable(z, 0).relu();
        assert_eq!((d.re, d.eps[0]), (0.0, 0.0));
    }
}

#[test]
fn min_max_ties_pass_the_gradient_to_the_first_argument() {
    let mut t = Tape::new();
    let a = t.leaf(Tensor::from_rows(&[[1.0, 2.0, 3.0]]));
    let b = t.leaf(Tensor::from_rows(&[[1.0, 5.0, 3.0]]));
    // A tie against a broadcast scalar as well.
    let s = t.leaf(Tensor::scalar(2.0));
    for first_is_a in [true, false] {
        let (p, q) = if first_is_a { (a, b) } else { (b, a) };
        let mn = t.min(p, q);
        let mx = t.max(p, q);
        let sm = t.sum(mn);
        let sx = t.sum(mx);
        let gmin = t.backward(sm);
        let gmax = t.backward(sx);
        // Columns 0 and 2 tie: the gradient goes to the first argument only. Column 1 (a < b)
        // goes to the smaller / larger one.
        let (lo, hi) = if first_is_a { (1.0, 0.0) } else { (0.0, 1.0) };
        assert_eq!(gmin.wrt(p).data(), &[1.0, lo, 1.0]);
        assert_eq!(gmin.wrt(q).data(), &[0.0, hi, 0.0]);
        assert_eq!(gmax.wrt(p).data(), &[1.0, hi, 1.0]);
        assert_eq!(gmax.wrt(q).data(), &[0.0, lo, 0.0]);
    }
    let m = t.min(s, a);
    let l = t.sum(m);
    let g = t.backward(l);
    assert_eq!(g.wrt(s).item(), 2.0); // ties at column 1, and 2 < 3 at column 2
    assert_eq!(g.wrt(a).data(), &[1.0, 0.0, 0.0]);
    // Duals: the tangent of the first argument.
    let (x, y) = (
        Dual::<f64, 2>::variable(1.5, 0),
        Dual::<f64, 2>::variable(1.5, 1),
    );
    assert_eq!(x.min(y).eps, [1.0, 0.0]);
    assert_eq!(x.max(y).eps, [1.0, 0.0]);
    assert_eq!(y.min(x).eps, [0.0, 1.0]);
    assert_eq!(y.max(x).eps, [0.0, 1.0]);
}

#[test]
fn row_min_max_ties_pass_the_gradient_to_the_first_column() {
    let mut t = Tape::new();
    let x = t.leaf(Tensor::from_rows(&[
        [2.0, 0.5, 0.5, 2.0],
        [1.0, 1.0, 1.0, 1.0],
        [7.0, -3.0, 7.0, -3.0],
    ]));
    let mn = t.row_min(x);
    let mx = t.row_max(x);
    assert_eq!(t.value(mn).data(), &[0.5, 1.0, -3.0]);
    assert_eq!(t.value(mx).data(), &[2.0, 1.0, 7.0]);
    let (smn, smx) = (t.sum(mn), t.sum(mx));
    assert_eq!(
        t.backward(smn).wrt(x).data(),
        &[0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0]
    );
    assert_eq!(
        t.backward(smx).wrt(x).data(),
        &[1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0]
    );
}

#[test]
fn abs_and_atan2_at_the_origin_have_derivative_zero() {
    let d = D1::variable(0.0, 0).abs();
    assert_eq!((d.re, d.eps[0]), (0.0, 0.0));
    let (y, x) = (
        Dual::<f64, 2>::variable(0.0, 0),
        Dual::<f64, 2>::variable(0.0, 1),
    );
    let a = y.atan2(x);
    assert_eq!((a.re, a.eps), (0.0, [0.0, 0.0]));
}
