//! The price of generality: the generic XPBD projection (`Projection<Distance>`, whose `∇C` and
//! backward pass come from duals on the generic `C`) against a distance projection and its
//! adjoint derived by hand, written only here. Both run over the same 2,000 rows, forward and
//! backward; the bench first checks that they agree.
//!
//! `cargo bench -p cloth --bench generality`

use autodiff::{DynRowFn, RowFn};
use cloth::constraint::Distance;
use cloth::projection::Projection;
use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use std::hint::black_box;
use std::sync::Arc;

const ROWS: usize = 2000;
const COMPLIANCE: f64 = 1e-2;

/// Deterministic pseudo-random numbers in [-1, 1).
fn numbers(n: usize, mut s: u64) -> Vec<f64> {
    (0..n)
        .map(|_| {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 11) as f64 / (1u64 << 52) as f64 - 1.0
        })
        .collect()
}

struct Rows {
    input: Vec<f64>,
    out_adj: Vec<f64>,
    rest: Vec<f64>,
    w: Vec<f64>,
}

fn rows() -> Rows {
    let r = numbers(ROWS * 7, 7);
    let mut input = Vec::with_capacity(ROWS * 7);
    for k in 0..ROWS {
        let q = &r[7 * k..7 * k + 7];
        input.extend_from_slice(&[q[0], q[1], q[2], q[3] + 1.5, q[4], q[5], 0.1 * q[6]]);
    }
    let rest = numbers(ROWS, 11).iter().map(|v| 1.0 + 0.2 * v).collect();
    let w = numbers(2 * ROWS, 13)
        .iter()
        .map(|v| 0.5 + 0.5 * v.abs())
        .collect();
    Rows {
        input,
        out_adj: numbers(ROWS * 7, 17),
        rest,
        w,
    }
}

/// The distance projection, specialised by hand.
#[inline(always)]
fn project(x: &[f64], rest: f64, w: [f64; 2], out: &mut [f64]) {
    let d = [x[0] - x[3], x[1] - x[4], x[2] - x[5]];
    let l = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
    let n = [d[0] / l, d[1] / l, d[2] / l];
    let dl = (-(l - rest) - COMPLIANCE * x[6]) / (w[0] + w[1] + COMPLIANCE);
    for k in 0..3 {
        out[k] = x[k] + w[0] * n[k] * dl;
        out[3 + k] = x[3 + k] - w[1] * n[k] * dl;
    }
    out[6] = x[6] + dl;
}

/// Its adjoint, derived by hand: `∇C = (n, −n)`, `∇²C = (P, −P; −P, P)/l` with `P = I − nnᵀ`.
#[inline(always)]
fn project_vjp(x: &[f64], rest: f64, w: [f64; 2], oa: &[f64], ia: &mut [f64]) {
    let d = [x[0] - x[3], x[1] - x[4], x[2] - x[5]];
    let l = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
    let n = [d[0] / l, d[1] / l, d[2] / l];
    let den = w[0] + w[1] + COMPLIANCE;
    let dl = (-(l - rest) - COMPLIANCE * x[6]) / den;
    // |∇C|² = 2 is constant for a distance constraint, so Δλ's denominator has no x-derivative.
    let mut a_dl = oa[6];
    for k in 0..3 {
        a_dl += n[k] * (w[0] * oa[k] - w[1] * oa[3 + k]);
    }
    let a_num = a_dl / den;
    // Adjoint of n from the position updates; n = d/l, ∂n/∂d = P/l.
    let a_n: [f64; 3] = std::array::from_fn(|k| dl * (w[0] * oa[k] - w[1] * oa[3 + k]));
    let n_dot = n[0] * a_n[0] + n[1] * a_n[1] + n[2] * a_n[2];
    for k in 0..3 {
        let a_d = (a_n[k] - n_dot * n[k]) / l - a_num * n[k];
        ia[k] += oa[k] + a_d;
        ia[3 + k] += oa[3 + k] - a_d;
    }
    ia[6] += oa[6] - COMPLIANCE * a_num;
}

fn generality(c: &mut Criterion) {
    let data = rows();
    let generic = Projection::new(
        Arc::new(Distance {
            rest: data.rest.clone(),
        }),
        (0..ROWS).collect(),
        data.w.clone(),
        COMPLIANCE,
    );
    let w = |k: usize| [data.w[2 * k], data.w[2 * k + 1]];

    // The two must agree before their times mean anything.
    let (mut a, mut b) = (vec![0.0; ROWS * 7], vec![0.0; ROWS * 7]);
    generic.eval_batch(&data.input, &mut a);
    for k in 0..ROWS {
        project(
            &data.input[7 * k..7 * k + 7],
            data.rest[k],
            w(k),
            &mut b[7 * k..7 * k + 7],
        );
    }
    let fwd_err = a
        .iter()
        .zip(&b)
        .map(|(p, q)| (p - q).abs())
        .fold(0.0, f64::max);
    let (mut ga, mut gb) = (vec![0.0; ROWS * 7], vec![0.0; ROWS * 7]);
    generic.vjp_batch(&data.input, &data.out_adj, &mut ga);
    for k in 0..ROWS {
        let s = 7 * k..7 * k + 7;
        project_vjp(
            &data.input[s.clone()],
            data.rest[k],
            w(k),
            &data.out_adj[s.clone()],
            &mut gb[s],
        );
    }
    let bwd_err = ga
        .iter()
        .zip(&gb)
        .map(|(p, q)| (p - q).abs())
        .fold(0.0, f64::max);
    assert!(
        fwd_err < 1e-12 && bwd_err < 1e-10,
        "generic vs hand: forward {fwd_err:e}, backward {bwd_err:e}"
    );
    eprintln!(
        "generic vs hand-specialised agree: forward max diff {fwd_err:.1e}, backward {bwd_err:.1e}"
    );

    let mut group = c.benchmark_group("distance_projection");
    group.throughput(Throughput::Elements(ROWS as u64));
    group.bench_function("forward/generic", |bench| {
        bench.iter(|| generic.eval_batch(black_box(&data.input), &mut a))
    });
    group.bench_function("forward/hand", |bench| {
        bench.iter(|| {
            for k in 0..ROWS {
                project(
                    black_box(&data.input[7 * k..7 * k + 7]),
                    data.rest[k],
                    w(k),
                    &mut b[7 * k..7 * k + 7],
                );
            }
        })
    });
    group.bench_function("backward/generic", |bench| {
        bench.iter(|| generic.vjp_batch(black_box(&data.input), &data.out_adj, &mut ga))
    });
    group.bench_function("backward/hand", |bench| {
        bench.iter(|| {
            for k in 0..ROWS {
                let s = 7 * k..7 * k + 7;
                project_vjp(
                    black_box(&data.input[s.clone()]),
                    data.rest[k],
                    w(k),
                    &data.out_adj[s.clone()],
                    &mut gb[s],
                );
            }
        })
    });
    group.finish();
    // The generic forward also runs through `RowFn::eval` for one row, as the simulator does.
    black_box(RowFn::n_in(&generic));
}

criterion_group!(benches, generality);
criterion_main!(benches);
