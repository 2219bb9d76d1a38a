//! The price of generality: three distance projections of one colour set of 2,000 disjoint
//! constraints, updating a state of 4,000 particles in place, forward and backward:
//! - `generic`: `Projection<Generic<Distance>>`, whose `∇C` and `∇²C·v` come from duals on the
//!   generic `C` — what a user constraint that writes only `C` gets;
//! - `override`: `Projection<Distance>` with its closed-form derivative overrides (what the
//!   simulator runs for the built-in);
//! - `hand`: a distance projection and its adjoint derived by hand, written only here.
//!
//! The first two go through the engine's kernels (`update_batch` / `vjp_update_batch`, the path
//! the simulator takes), the hand-written one through its own loop. The bench first checks that
//! all three agree.
//!
//! `RAYON_NUM_THREADS=1 cargo bench -p cloth --bench generality`

use autodiff::{DynRowFn, RowIndex, Tensor};
use cloth::constraint::{Distance, Generic};
use cloth::internals::Projection;
use criterion::{criterion_group, criterion_main, BatchSize, Criterion, Throughput};
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

/// One colour set: `ROWS` constraints on disjoint, shuffled particle pairs.
struct Set {
    index: RowIndex,
    state: Tensor,
    lambda: Tensor,
    state_adj: Tensor,
    lambda_adj: Tensor,
    rest: Vec<f64>,
    w: Vec<f64>,
}

fn set() -> Set {
    let n = 2 * ROWS;
    let mut particles: Vec<usize> = (0..n).collect();
    for (i, r) in numbers(n, 3).iter().enumerate() {
        let j = i + ((r.abs() * (n - i) as f64) as usize).min(n - i - 1);
        particles.swap(i, j);
    }
    let mut state = Tensor::new(n, 3, numbers(3 * n, 7));
    // Pull each pair apart along x so rest lengths near 1 are violated by a realistic amount.
    for k in 0..ROWS {
        state.row_mut(particles[2 * k + 1])[0] += 1.5;
    }
    Set {
        index: RowIndex::new(2, particles),
        state,
        lambda: Tensor::new(ROWS, 1, numbers(ROWS, 5).iter().map(|v| 0.1 * v).collect()),
        state_adj: Tensor::new(n, 3, numbers(3 * n, 17)),
        lambda_adj: Tensor::new(ROWS, 1, numbers(ROWS, 19)),
        rest: numbers(ROWS, 11).iter().map(|v| 1.0 + 0.2 * v).collect(),
        w: numbers(2 * ROWS, 13)
            .iter()
            .map(|v| 0.5 + 0.5 * v.abs())
            .collect(),
    }
}

/// The distance projection of one row, specialised by hand.
#[inline(always)]
fn project(x: &[f64; 7], rest: f64, w: [f64; 2]) -> [f64; 7] {
    let d = [x[0] - x[3], x[1] - x[4], x[2] - x[5]];
    let l = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
    let n = [d[0] / l, d[1] / l, d[2] / l];
    let dl = (-(l - rest) - COMPLIANCE * x[6]) / (w[0] + w[1] + COMPLIANCE);
    let mut out = [0.0; 7];
    for k in 0..3 {
        out[k] = x[k] + w[0] * n[k] * dl;
        out[3 + k] = x[3 + k] - w[1] * n[k] * dl;
    }
    out[6] = x[6] + dl;
    out
}

/// Its adjoint, derived by hand: `∇C = (n, −n)`, `∇²C = (P, −P; −P, P)/l` with `P = I − nnᵀ`.
#[inline(always)]
fn project_vjp(x: &[f64], rest: f64, w: [f64; 2], oa: &[f64; 7]) -> [f64; 7] {
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
    let mut ia = [0.0; 7];
    for k in 0..3 {
        let a_d = (a_n[k] - n_dot * n[k]) / l - a_num * n[k];
        ia[k] = oa[k] + a_d;
        ia[3 + k] = oa[3 + k] - a_d;
    }
    ia[6] = oa[6] - COMPLIANCE * a_num;
    ia
}

/// Row `k`'s two points and carried value.
#[inline(always)]
fn gather(s: &Set, x: &[f64], l: &[f64], k: usize) -> [f64; 7] {
    let (i, j) = (s.index.row(k)[0], s.index.row(k)[1]);
    [
        x[3 * i],
        x[3 * i + 1],
        x[3 * i + 2],
        x[3 * j],
        x[3 * j + 1],
        x[3 * j + 2],
        l[k],
    ]
}

/// Writes row `k`'s two points and carried value back.
#[inline(always)]
fn scatter(s: &Set, x: &mut [f64], l: &mut [f64], k: usize, v: &[f64; 7]) {
    let (i, j) = (s.index.row(k)[0], s.index.row(k)[1]);
    x[3 * i..3 * i + 3].copy_from_slice(&v[..3]);
    x[3 * j..3 * j + 3].copy_from_slice(&v[3..6]);
    l[k] = v[6];
}

/// The hand-written set update, in place; with `saved`, keeps each row's inputs.
fn hand_update(s: &Set, state: &mut Tensor, lambda: &mut Tensor, mut saved: Option<&mut Vec<f64>>) {
    let (x, l) = (state.data_mut(), lambda.data_mut());
    for k in 0..ROWS {
        let input = gather(s, x, l, k);
        if let Some(v) = saved.as_deref_mut() {
            v.extend_from_slice(&input);
        }
        let out = project(&input, s.rest[k], [s.w[2 * k], s.w[2 * k + 1]]);
        scatter(s, x, l, k, &out);
    }
}

/// The hand-written adjoint of [`hand_update`], in place.
fn hand_vjp(s: &Set, saved: &[f64], state_adj: &mut Tensor, lambda_adj: &mut Tensor) {
    let (g, gl) = (state_adj.data_mut(), lambda_adj.data_mut());
    for k in 0..ROWS {
        let oa = gather(s, g, gl, k);
        let ia = project_vjp(
            &saved[7 * k..7 * k + 7],
            s.rest[k],
            [s.w[2 * k], s.w[2 * k + 1]],
            &oa,
        );
        scatter(s, g, gl, k, &ia);
    }
}

fn max_diff(a: &Tensor, b: &Tensor) -> f64 {
    a.data()
        .iter()
        .zip(b.data())
        .map(|(p, q)| (p - q).abs())
        .fold(0.0, f64::max)
}

fn generality(c: &mut Criterion) {
    let s = set();
    let distance = Distance {
        rest: s.rest.clone(),
    };
    let generic = Projection::new(
        Arc::new(Generic(distance.clone())),
        (0..ROWS).collect(),
        s.w.clone(),
        COMPLIANCE,
    );
    let overridden = Projection::new(
        Arc::new(distance),
        (0..ROWS).collect(),
        s.w.clone(),
        COMPLIANCE,
    );

    // The two must agree before their times mean anything.
    let (mut xa, mut la, mut saved) = (s.state.clone(), s.lambda.clone(), Vec::new());
    generic.update_batch(&s.index, &mut xa, &mut la, Some(&mut saved));
    let (mut xb, mut lb, mut saved_b) = (s.state.clone(), s.lambda.clone(), Vec::new());
    hand_update(&s, &mut xb, &mut lb, Some(&mut saved_b));
    let fwd_err = max_diff(&xa, &xb).max(max_diff(&la, &lb));
    let (mut ga, mut gla) = (s.state_adj.clone(), s.lambda_adj.clone());
    generic.vjp_update_batch(&s.index, &saved, &mut ga, &mut gla);
    let (mut gb, mut glb) = (s.state_adj.clone(), s.lambda_adj.clone());
    hand_vjp(&s, &saved_b, &mut gb, &mut glb);
    let bwd_err = max_diff(&ga, &gb).max(max_diff(&gla, &glb));
    assert!(
        fwd_err < 1e-12 && bwd_err < 1e-10,
        "generic vs hand: forward {fwd_err:e}, backward {bwd_err:e}"
    );
    eprintln!(
        "generic vs hand-specialised agree: forward max diff {fwd_err:.1e}, backward {bwd_err:.1e}"
    );
    let (mut xo, mut lo, mut saved_o) = (s.state.clone(), s.lambda.clone(), Vec::new());
    overridden.update_batch(&s.index, &mut xo, &mut lo, Some(&mut saved_o));
    let (mut go, mut glo) = (s.state_adj.clone(), s.lambda_adj.clone());
    overridden.vjp_update_batch(&s.index, &saved_o, &mut go, &mut glo);
    let (fwd_o, bwd_o) = (
        max_diff(&xa, &xo).max(max_diff(&la, &lo)),
        max_diff(&ga, &go).max(max_diff(&gla, &glo)),
    );
    assert!(
        fwd_o < 1e-12 && bwd_o < 1e-10,
        "generic vs override: forward {fwd_o:e}, backward {bwd_o:e}"
    );
    eprintln!("generic vs override agree: forward max diff {fwd_o:.1e}, backward {bwd_o:.1e}");

    let mut group = c.benchmark_group("distance_projection");
    group.throughput(Throughput::Elements(ROWS as u64));
    let fresh_state = || (s.state.clone(), s.lambda.clone());
    group.bench_function("forward/generic", |b| {
        b.iter_batched_ref(
            fresh_state,
            |(x, l)| generic.update_batch(&s.index, x, l, None),
            BatchSize::SmallInput,
        )
    });
    group.bench_function("forward/override", |b| {
        b.iter_batched_ref(
            fresh_state,
            |(x, l)| overridden.update_batch(&s.index, x, l, None),
            BatchSize::SmallInput,
        )
    });
    group.bench_function("forward/hand", |b| {
        b.iter_batched_ref(
            fresh_state,
            |(x, l)| hand_update(&s, x, l, None),
            BatchSize::SmallInput,
        )
    });
    let fresh_adj = || (s.state_adj.clone(), s.lambda_adj.clone());
    group.bench_function("backward/generic", |b| {
        b.iter_batched_ref(
            fresh_adj,
            |(g, gl)| generic.vjp_update_batch(&s.index, black_box(&saved), g, gl),
            BatchSize::SmallInput,
        )
    });
    group.bench_function("backward/override", |b| {
        b.iter_batched_ref(
            fresh_adj,
            |(g, gl)| overridden.vjp_update_batch(&s.index, black_box(&saved_o), g, gl),
            BatchSize::SmallInput,
        )
    });
    group.bench_function("backward/hand", |b| {
        b.iter_batched_ref(
            fresh_adj,
            |(g, gl)| hand_vjp(&s, black_box(&saved), g, gl),
            BatchSize::SmallInput,
        )
    });
    group.finish();
}

criterion_group!(benches, generality);
criterion_main!(benches);
