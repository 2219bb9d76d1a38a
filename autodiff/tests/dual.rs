//! Forward-mode duals against central finite differences: every `Real` function, second
//! derivatives through nested duals (Hessian–vector products), and `vjp_by_duals` for row
//! functions wider than one dual chunk.

#![allow(clippy::needless_range_loop)]

use autodiff::rowfn::VJP_CHUNK;
use autodiff::{vjp_by_duals, vjp_seeds_by_duals, Dual, Real, RowFn};
use proptest::prelude::*;
use proptest::test_runner::TestCaseError;

const REL: f64 = 1e-6;
const ABS: f64 = 1e-8;

type D1 = Dual<f64, 1>;
type D2 = Dual<f64, 2>;

fn close(an: f64, fd: f64, what: &str) -> Result<(), TestCaseError> {
    let err = (an - fd).abs();
    prop_assert!(
        an.is_finite() && (err <= ABS || err <= REL * an.abs().max(fd.abs())),
        "{what}: dual {an:e} vs central FD {fd:e} (abs err {err:e})"
    );
    Ok(())
}

fn step(x: f64) -> f64 {
    1e-6 * x.abs().max(1.0)
}

/// Central difference of `f` at `x`.
fn fd1(f: impl Fn(f64) -> f64, x: f64) -> f64 {
    let h = step(x);
    (f(x + h) - f(x - h)) / ((x + h) - (x - h))
}

/// Checks a unary function: value, first derivative (`Dual<f64, 1>`) against FD, and second
/// derivative (`Dual<Dual<f64, 1>, 1>`) against FD of the first.
fn check_unary(
    name: &str,
    f: fn(f64) -> f64,
    fd: fn(D1) -> D1,
    fdd: fn(Dual<D1, 1>) -> Dual<D1, 1>,
    x: f64,
) -> Result<(), TestCaseError> {
    let d = fd(D1::variable(x, 0));
    prop_assert_eq!(d.re, f(x), "{} value", name);
    close(d.eps[0], fd1(f, x), &format!("{name}'({x})"))?;
    // Nested: inner and outer directions both along x.
    let dd = fdd(Dual::variable(D1::variable(x, 0), 0));
    prop_assert_eq!(dd.re.re, f(x));
    prop_assert_eq!(dd.re.eps[0], d.eps[0], "{} inner derivative", name);
    prop_assert_eq!(dd.eps[0].re, d.eps[0], "{} outer derivative", name);
    let first = |y: f64| fd(D1::variable(y, 0)).eps[0];
    close(dd.eps[0].eps[0], fd1(first, x), &format!("{name}''({x})"))?;
    Ok(())
}

/// Checks a binary function in both arguments with `Dual<f64, 2>`, and its mixed and pure second
/// derivatives with `Dual<Dual<f64, 1>, 2>`.
fn check_binary(
    name: &str,
    f: fn(f64, f64) -> f64,
    fd: fn(D2, D2) -> D2,
    fdd: fn(Dual<D1, 2>, Dual<D1, 2>) -> Dual<D1, 2>,
    x: f64,
    y: f64,
) -> Result<(), TestCaseError> {
    let d = fd(D2::variable(x, 0), D2::variable(y, 1));
    prop_assert_eq!(d.re, f(x, y), "{} value", name);
    close(d.eps[0], fd1(|u| f(u, y), x), &format!("d{name}/dx"))?;
    close(d.eps[1], fd1(|v| f(x, v), y), &format!("d{name}/dy"))?;
    // Hessian columns: inner direction along x, then along y.
    let grad = |u: f64, v: f64| {
        let g = fd(D2::variable(u, 0), D2::variable(v, 1));
        [g.eps[0], g.eps[1]]
    };
    for inner in 0..2 {
        let seed = |k: usize| if k == inner { 1.0 } else { 0.0 };
        let h = fdd(
            Dual::variable(
                Dual {
                    re: x,
                    eps: [seed(0)],
                },
                0,
            ),
            Dual::variable(
                Dual {
                    re: y,
                    eps: [seed(1)],
                },
                1,
            ),
        );
        for (outer, he) in h.eps.iter().enumerate() {
            let num = if inner == 0 {
                fd1(|u| grad(u, y)[outer], x)
            } else {
                fd1(|v| grad(x, v)[outer], y)
            };
            close(he.eps[0], num, &format!("d²{name}/d{outer}d{inner}"))?;
        }
    }
    Ok(())
}

macro_rules! unary {
    ($name:ident, $strategy:expr, |$x:ident| $body:expr) => {
        proptest! {
            #![proptest_config(ProptestConfig::with_cases(256))]
            #[test]
            fn $name(x in $strategy) {
                fn g<R: Real>($x: R) -> R {
                    $body
                }
                check_unary(stringify!($name), g::<f64>, g::<D1>, g::<Dual<D1, 1>>, x)?;
            }
        }
    };
}

macro_rules! binary {
    ($name:ident, $strategy:expr, |$x:ident, $y:ident| $body:expr) => {
        proptest! {
            #![proptest_config(ProptestConfig::with_cases(256))]
            #[test]
            fn $name(($x, $y) in $strategy) {
                fn g<R: Real>($x: R, $y: R) -> R {
                    $body
                }
                check_binary(stringify!($name), g::<f64>, g::<D2>, g::<Dual<D1, 2>>, $x, $y)?;
            }
        }
    };
}

/// A value with magnitude in [lo, hi) and either sign.
fn signed(lo: f64, hi: f64) -> impl Strategy<Value = f64> {
    (lo..hi, any::<bool>()).prop_map(|(m, s)| if s { m } else { -m })
}

unary!(sqrt, 0.05f64..10.0, |x| x.sqrt());
unary!(abs, signed(0.05, 5.0), |x| x.abs());
unary!(exp, -5.0f64..5.0, |x| x.exp());
unary!(ln, 0.05f64..20.0, |x| x.ln());
unary!(sin, -10.0f64..10.0, |x| x.sin());
unary!(cos, -10.0f64..10.0, |x| x.cos());
unary!(relu, signed(0.05, 5.0), |x| x.relu());
unary!(square, -5.0f64..5.0, |x| x.square());
unary!(neg, -5.0f64..5.0, |x| -x);
unary!(powi_pos, -3.0f64..3.0, |x| x.powi(5)
    + x.powi(2)
    + x.powi(1)
    + x.powi(0));
unary!(powi_neg, signed(0.3, 3.0), |x| x.powi(-1) + x.powi(-3));
unary!(scalar_ops, -3.0f64..3.0, |x| ((x + 2.0) * 3.0 - 1.5) / 4.0
    + R::cst(2.0) * x);
unary!(composite, -2.0f64..2.0, |x| ((x * x + 1.0).sqrt()
    * x.sin())
.exp()
    / (x.cos() + 3.0)
    + (x * x + 2.0).ln());

/// Pairs away from the atan2 branch cut (y = 0, x < 0) and from the origin.
fn atan2_args() -> impl Strategy<Value = (f64, f64)> {
    (-3.0f64..3.0, -3.0f64..3.0).prop_filter("atan2 branch cut / origin", |&(y, x)| {
        y * y + x * x > 0.01 && !(x < 0.0 && y.abs() < 0.05)
    })
}

/// Pairs clear of ties.
fn untied() -> impl Strategy<Value = (f64, f64)> {
    (-3.0f64..3.0, -3.0f64..3.0).prop_filter("tie", |&(a, b)| (a - b).abs() > 1e-3)
}

binary!(atan2, atan2_args(), |y, x| y.atan2(x));
binary!(min, untied(), |a, b| a.min(b) * b + a);
binary!(max, untied(), |a, b| a.max(b) * a - b);
binary!(div, (-3.0f64..3.0, signed(0.3, 3.0)), |a, b| a / b);
binary!(mul_add_sub, (-3.0f64..3.0, -3.0f64..3.0), |a, b| a * b
    - (a + b) * a);
binary!(assign_ops, (-3.0f64..3.0, signed(0.3, 3.0)), |a, b| {
    let mut z = a;
    z += b;
    z *= a;
    z -= b;
    z /= b;
    z
});

// ---------------------------------------------------------------------------------------------
// Hessian–vector products through nested duals
// ---------------------------------------------------------------------------------------------

/// A nonlinear scalar function of 4 variables.
fn energy<R: Real>(x: &[R; 4]) -> R {
    let r = (x[0] * x[0] + x[1] * x[1] + 1.0).sqrt();
    r * (x[2] * 0.2).exp()
        + (x[0] * x[3]).sin()
        + x[1].atan2(x[2] + 4.0)
        + x[3].powi(3) / (x[0] * x[0] + 1.0)
        + (x[1] * x[1] + 2.0).ln()
        + (x[2] - x[3]).cos() * x[1]
}

fn gradient(x: &[f64; 4]) -> [f64; 4] {
    let xd: [Dual<f64, 4>; 4] = std::array::from_fn(|k| Dual::variable(x[k], k));
    energy(&xd).eps
}

/// `(∇f(x), H(x) v)` with `Dual<Dual<f64, 1>, 4>`: inner direction `v`, outer the four axes.
fn hvp(x: &[f64; 4], v: &[f64; 4]) -> ([f64; 4], [f64; 4]) {
    let xd: [Dual<D1, 4>; 4] = std::array::from_fn(|k| {
        Dual::variable(
            Dual {
                re: x[k],
                eps: [v[k]],
            },
            k,
        )
    });
    let e = energy(&xd);
    (
        std::array::from_fn(|k| e.eps[k].re),
        std::array::from_fn(|k| e.eps[k].eps[0]),
    )
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn hessian_vector_product_matches_fd_of_gradient(
        x in prop::array::uniform4(-2.0f64..2.0),
        v in prop::array::uniform4(-1.0f64..1.0),
    ) {
        let (g, hv) = hvp(&x, &v);
        // The outer level reproduces the first-order gradient exactly.
        prop_assert_eq!(g, gradient(&x));
        // The energy's value is untouched by nesting.
        let xd: [Dual<D1, 4>; 4] = std::array::from_fn(|k| Dual::variable(Dual { re: x[k], eps: [v[k]] }, k));
        prop_assert_eq!(energy(&xd).re.re, energy(&x));
        // H v against a central difference of the gradient along v.
        let h = 1e-6;
        let xp: [f64; 4] = std::array::from_fn(|k| x[k] + h * v[k]);
        let xm: [f64; 4] = std::array::from_fn(|k| x[k] - h * v[k]);
        let (gp, gm) = (gradient(&xp), gradient(&xm));
        for k in 0..4 {
            close(hv[k], (gp[k] - gm[k]) / (2.0 * h), &format!("(Hv)[{k}]"))?;
        }
        // The inner level of the primal part is the directional derivative ∇f·v.
        let dir: f64 = (0..4).map(|k| g[k] * v[k]).sum();
        close(energy(&xd).re.eps[0], dir, "∇f·v")?;
    }

    #[test]
    fn hessian_is_symmetric(x in prop::array::uniform4(-2.0f64..2.0)) {
        let cols: Vec<[f64; 4]> = (0..4)
            .map(|j| hvp(&x, &std::array::from_fn(|k| if k == j { 1.0 } else { 0.0 })).1)
            .collect();
        for i in 0..4 {
            for j in 0..i {
                close(cols[i][j], cols[j][i], &format!("H[{i}][{j}] vs H[{j}][{i}]"))?;
            }
        }
    }
}

// ---------------------------------------------------------------------------------------------
// vjp_by_duals for wide row functions (chunking over VJP_CHUNK directions)
// ---------------------------------------------------------------------------------------------

/// `R^n → R^m`, every output depending nonlinearly on every input.
struct Dense {
    n: usize,
    m: usize,
}

impl RowFn for Dense {
    fn n_in(&self) -> usize {
        self.n
    }
    fn n_out(&self) -> usize {
        self.m
    }
    fn eval<R: Real>(&self, row: usize, x: &[R], out: &mut [R]) {
        for (j, o) in out.iter_mut().enumerate() {
            let mut s = R::cst(0.1 * row as f64);
            let mut q = R::cst(1.0);
            for (i, &xi) in x.iter().enumerate() {
                let a = ((i * 7 + j * 3) % 11) as f64 * 0.1 - 0.5;
                s += xi * a;
                q += xi * xi * (0.1 * (j + 1) as f64);
            }
            *o = s.sin() * q.sqrt() + (s * 0.3).exp() * x[j % self.n];
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(128))]

    #[test]
    fn vjp_by_duals_matches_fd(
        (n, m, x, w, acc, row) in (1usize..20, 1usize..5).prop_flat_map(|(n, m)| (
            Just(n),
            Just(m),
            prop::collection::vec(-1.0f64..1.0, n),
            prop::collection::vec(-1.0f64..1.0, m),
            prop::collection::vec(-1.0f64..1.0, n),
            0usize..4,
        ))
    ) {
        let f = Dense { n, m };
        // vjp_by_duals accumulates into in_adj.
        let mut in_adj = acc.clone();
        vjp_by_duals(&f, row, &x, &w, &mut in_adj);
        // The default RowFn::vjp is the same.
        let mut via_trait = acc.clone();
        f.vjp(row, &x, &w, &mut via_trait);
        prop_assert_eq!(&in_adj, &via_trait);
        let phi = |x: &[f64]| {
            let mut out = vec![0.0; m];
            f.eval(row, x, &mut out);
            out.iter().zip(&w).map(|(o, w)| o * w).sum::<f64>()
        };
        for i in 0..n {
            let h = step(x[i]);
            let mut xp = x.clone();
            xp[i] += h;
            let mut xm = x.clone();
            xm[i] -= h;
            let fd = (phi(&xp) - phi(&xm)) / (xp[i] - xm[i]);
            close(in_adj[i] - acc[i], fd, &format!("input {i} of {n}"))?;
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(128))]

    /// Several seeds at once (the default `vjp_seeds`, one dual Jacobian for all of them) give
    /// each seed's `vjp_by_duals` bit for bit, across widths that take the stack and the heap
    /// buffers and every chunk boundary.
    #[test]
    fn vjp_seeds_by_duals_matches_each_seed_alone(
        (n, m, x, w, row) in (1usize..20, 1usize..5, 1usize..12).prop_flat_map(|(n, m, seeds)| (
            Just(n),
            Just(m),
            prop::collection::vec(-1.0f64..1.0, n),
            prop::collection::vec(-1.0f64..1.0, m * seeds),
            0usize..4,
        ))
    ) {
        let f = Dense { n, m };
        let seeds = w.len() / m;
        let acc: Vec<f64> = (0..n * seeds).map(|k| (k % 7) as f64 * 0.25 - 0.5).collect();
        let mut together = acc.clone();
        f.vjp_seeds(row, &x, &w, &mut together);
        let mut direct = acc.clone();
        vjp_seeds_by_duals(&f, row, &x, &w, &mut direct);
        prop_assert_eq!(&together, &direct);
        for s in 0..seeds {
            let mut alone = acc[s * n..(s + 1) * n].to_vec();
            vjp_by_duals(&f, row, &x, &w[s * m..(s + 1) * m], &mut alone);
            prop_assert_eq!(&together[s * n..(s + 1) * n], &alone[..], "seed {} of {}", s, seeds);
        }
    }
}

#[test]
fn vjp_by_duals_chunk_boundaries() {
    // Widths around multiples of the chunk: every input receives its derivative exactly once.
    for n in [
        VJP_CHUNK - 1,
        VJP_CHUNK,
        VJP_CHUNK + 1,
        2 * VJP_CHUNK,
        2 * VJP_CHUNK + 3,
    ] {
        // A linear function: the VJP is exactly the weights.
        struct Lin(usize);
        impl RowFn for Lin {
            fn n_in(&self) -> usize {
                self.0
            }
            fn n_out(&self) -> usize {
                1
            }
            fn eval<R: Real>(&self, _row: usize, x: &[R], out: &mut [R]) {
                out[0] = R::zero();
                for (i, &xi) in x.iter().enumerate() {
                    out[0] += xi * (i as f64 + 1.0);
                }
            }
        }
        let x: Vec<f64> = (0..n).map(|i| i as f64 * 0.5 - 2.0).collect();
        let mut adj = vec![0.0; n];
        vjp_by_duals(&Lin(n), 0, &x, &[2.0], &mut adj);
        let expected: Vec<f64> = (0..n).map(|i| 2.0 * (i as f64 + 1.0)).collect();
        assert_eq!(adj, expected, "n_in = {n}");
    }
}

// ---------------------------------------------------------------------------------------------
// The primal part of a dual is bitwise the plain f64 evaluation
// ---------------------------------------------------------------------------------------------

/// Regression: `Dual / Dual` and `Dual / f64` used to form the primal as `a · (1/b)`, which can
/// differ from `a / b` in the last bit, so a function's value through duals was not the plain
/// `f64` value (and a value-dependent branch — min, max, relu — could disagree between the two).
#[test]
fn dual_division_primal_is_the_f64_quotient() {
    let (a, b) = (-2.3132471951825795, 1.2433167471225444);
    assert_ne!(
        a * (1.0 / b),
        a / b,
        "a pair where the two roundings differ"
    );
    assert_eq!((D1::variable(a, 0) / D1::constant(b)).re, a / b);
    assert_eq!((D1::variable(a, 0) / b).re, a / b);
    let nested = Dual::<D1, 2>::variable(D1::variable(a, 0), 0) / Dual::constant(D1::constant(b));
    assert_eq!(nested.re.re, a / b);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn dual_primal_is_bitwise_plain(x in prop::array::uniform4(-2.0f64..2.0)) {
        let plain = energy(&x);
        let d: [Dual<f64, 4>; 4] = std::array::from_fn(|k| Dual::variable(x[k], k));
        prop_assert_eq!(energy(&d).re, plain);
        let dd: [Dual<D1, 4>; 4] = std::array::from_fn(|k| Dual::variable(D1::variable(x[k], 0), k));
        prop_assert_eq!(energy(&dd).re.re, plain);
        // The outer level's derivatives are bitwise the first-order ones.
        let first = energy(&d).eps;
        let nested = energy(&dd).eps;
        for k in 0..4 {
            prop_assert_eq!(nested[k].re, first[k]);
        }
    }
}
