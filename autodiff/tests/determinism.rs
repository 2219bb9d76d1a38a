//! Forward values and gradients are bitwise identical whatever the rayon thread count, on batches
//! large enough to take the parallel path (`rowfn::PARALLEL_MIN_ROWS`).

use autodiff::rowfn::PARALLEL_MIN_ROWS;
use autodiff::update;
use autodiff::{DynRowFn, Real, RowFn, RowIndex, Tape, Tensor};
use std::sync::Arc;

/// A nonlinear `R³ → R²` map.
struct Field;

impl RowFn for Field {
    fn n_in(&self) -> usize {
        3
    }
    fn n_out(&self) -> usize {
        2
    }
    fn eval<R: Real>(&self, row: usize, x: &[R], out: &mut [R]) {
        let r = (x[0] * x[0] + x[1] * x[1] + x[2] * x[2] + 1.0).sqrt();
        out[0] = (x[0] * 0.5).sin() * r + (x[2] * 0.1).exp() * (row % 5) as f64;
        out[1] = x[1].atan2(x[2] + 4.0) / r;
    }
}

/// XPBD distance projection with a carried multiplier: `[xᵢ, xⱼ, λ] → [xᵢ', xⱼ', λ']`.
struct Distance {
    alpha: f64,
}

impl RowFn for Distance {
    fn n_in(&self) -> usize {
        7
    }
    fn n_out(&self) -> usize {
        7
    }
    fn eval<R: Real>(&self, row: usize, x: &[R], out: &mut [R]) {
        let rest = 0.9 + 0.05 * (row % 4) as f64;
        let d = [x[0] - x[3], x[1] - x[4], x[2] - x[5]];
        let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        let dl = (-(len - rest) - x[6] * self.alpha) / (2.0 + self.alpha);
        for k in 0..3 {
            out[k] = x[k] + d[k] / len * dl;
            out[3 + k] = x[3 + k] - d[k] / len * dl;
        }
        out[6] = x[6] + dl;
    }
}

const ROWS: usize = 5_000;

struct Outcome {
    values: Vec<Tensor>,
    grads: Vec<Tensor>,
}

/// A chain of `2·ROWS` particles relaxed by two disjoint sets of `ROWS` (and `ROWS − 1`) edges,
/// plus a `ROWS`-row `map_rows`.
fn workload() -> Outcome {
    const { assert!(ROWS >= 2 * PARALLEL_MIN_ROWS) };
    let n = 2 * ROWS;
    let x0 = Tensor::new(
        n,
        3,
        (0..n * 3)
            .map(|k| {
                let noise = 0.2 * ((k as f64) * 0.377).sin();
                if k % 3 == 0 {
                    (k / 3) as f64 + noise
                } else {
                    noise
                }
            })
            .collect(),
    );
    let pts = Tensor::new(
        ROWS,
        3,
        (0..ROWS * 3)
            .map(|k| ((k as f64) * 0.913).cos() * 2.0)
            .collect(),
    );
    let set_a = Arc::new(RowIndex::new(
        2,
        (0..ROWS).flat_map(|k| [2 * k, 2 * k + 1]).collect(),
    ));
    let set_b = Arc::new(RowIndex::new(
        2,
        (0..ROWS - 1).flat_map(|k| [2 * k + 1, 2 * k + 2]).collect(),
    ));
    let dist: Arc<dyn DynRowFn> = Arc::new(Distance { alpha: 0.01 });
    let field: Arc<dyn DynRowFn> = Arc::new(Field);

    let mut t = Tape::new();
    let x = t.leaf(x0.clone());
    let p = t.leaf(pts.clone());
    let la0 = t.leaf(Tensor::zeros(ROWS, 1));
    let lb0 = t.leaf(Tensor::zeros(ROWS - 1, 1));
    let m = t.map_rows(&field, p);
    let (mut s, mut la, mut lb) = (x, la0, lb0);
    let (mut px, mut pla, mut plb) = (x0, Tensor::zeros(ROWS, 1), Tensor::zeros(ROWS - 1, 1));
    for _ in 0..3 {
        (s, la) = t.update_rows(&dist, &set_a, s, la);
        (s, lb) = t.update_rows(&dist, &set_b, s, lb);
        update::update_rows(dist.as_ref(), &set_a, &mut px, &mut pla, None);
        update::update_rows(dist.as_ref(), &set_b, &mut px, &mut plb, None);
    }
    // The recorded forward path is bitwise the plain f64 path.
    assert_eq!(t.value(s), &px);
    assert_eq!(t.value(la), &pla);
    let sq = t.square(s);
    let ls = t.sum(sq);
    let lm = t.sum(m);
    let ll = t.dot(la, la);
    let l1 = t.add(ls, lm);
    let loss = t.add(l1, ll);
    let values = vec![
        t.value(s).clone(),
        t.value(la).clone(),
        t.value(lb).clone(),
        t.value(m).clone(),
        t.value(loss).clone(),
    ];
    let g = t.backward(loss);
    let grads = vec![g.wrt(x), g.wrt(p), g.wrt(la0), g.wrt(lb0)];
    Outcome { values, grads }
}

fn in_pool(threads: usize) -> Outcome {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("rayon pool")
        .install(workload)
}

fn bits(ts: &[Tensor]) -> Vec<Vec<u64>> {
    ts.iter()
        .map(|t| t.data().iter().map(|v| v.to_bits()).collect())
        .collect()
}

#[test]
fn one_and_two_threads_agree_bitwise() {
    let one = in_pool(1);
    let two = in_pool(2);
    assert!(one.grads.iter().all(|g| g.is_finite() && g.max_abs() > 0.0));
    assert_eq!(
        bits(&one.values),
        bits(&two.values),
        "forward values differ"
    );
    assert_eq!(bits(&one.grads), bits(&two.grads), "gradients differ");
    // And with more threads than cores.
    let four = in_pool(4);
    assert_eq!(bits(&one.values), bits(&four.values));
    assert_eq!(bits(&one.grads), bits(&four.grads));
}
