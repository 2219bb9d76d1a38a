//! A gradient a reader can check: a chain of particles relaxed by Gauss–Seidel distance
//! projections (recorded with `Tape::update_rows`), loss = squared distance of the chain's end to a
//! target. Prints the tape's gradient beside a central finite-difference estimate.
//!
//! `cargo run --release -p autodiff --example gradient_check`

use autodiff::{Real, RowFn, RowIndex, Tape, Tensor};
use std::sync::Arc;

/// Projects `|xᵢ − xⱼ| = rest` with inverse masses `w` (a PBD distance constraint, no compliance).
struct Distance {
    rest: f64,
    /// Inverse masses of the two particles, per batch row.
    w: Vec<[f64; 2]>,
}

impl RowFn for Distance {
    fn n_in(&self) -> usize {
        6
    }
    fn n_out(&self) -> usize {
        6
    }
    fn eval<R: Real>(&self, row: usize, x: &[R], out: &mut [R]) {
        let w = self.w[row];
        let d = [x[0] - x[3], x[1] - x[4], x[2] - x[5]];
        let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        let c = len - self.rest;
        let s = c / (len * (w[0] + w[1]));
        for k in 0..3 {
            out[k] = x[k] - d[k] * s * w[0];
            out[3 + k] = x[3 + k] + d[k] * s * w[1];
        }
    }
}

fn loss(anchor: [f64; 3], record: &mut Tape) -> (f64, [f64; 3]) {
    record.clear();
    let n = 4;
    let mut x0 = vec![[0.0, 0.0, 0.0]; n];
    x0[0] = anchor;
    for (i, p) in x0.iter_mut().enumerate().skip(1) {
        *p = [0.3 * i as f64, -0.2 * i as f64, 0.1];
    }
    let anchor_var = record.leaf(Tensor::from_rows(&[anchor]));
    let free = record.leaf(Tensor::from_rows(&x0[1..]));
    let mut x = record.concat_rows(&[anchor_var, free]);
    // Two independent sets: edges (0,1),(2,3) then (1,2); the anchor (particle 0) has inverse mass 0.
    let f_a: Arc<dyn autodiff::DynRowFn> = Arc::new(Distance {
        rest: 0.5,
        w: vec![[0.0, 1.0], [1.0, 1.0]],
    });
    let f_b: Arc<dyn autodiff::DynRowFn> = Arc::new(Distance {
        rest: 0.5,
        w: vec![[1.0, 1.0]],
    });
    let set_a = Arc::new(RowIndex::new(2, vec![0, 1, 2, 3]));
    let set_b = Arc::new(RowIndex::new(2, vec![1, 2]));
    let no_carry_1 = record.leaf(Tensor::zeros(2, 0));
    let no_carry_2 = record.leaf(Tensor::zeros(1, 0));
    for _ in 0..20 {
        x = record.update_rows(&f_a, &set_a, x, no_carry_1).0;
        x = record.update_rows(&f_b, &set_b, x, no_carry_2).0;
    }
    let end = record.gather(x, &Arc::new(RowIndex::single(vec![n - 1])));
    let target = record.leaf(Tensor::from_rows(&[[1.0, 0.5, -0.5]]));
    let diff = record.sub(end, target);
    let sq = record.square(diff);
    let l = record.sum(sq);
    let value = record.value(l).item();
    let g = record.backward(l).wrt(anchor_var);
    (value, [g.get(0, 0), g.get(0, 1), g.get(0, 2)])
}

fn main() {
    let anchor = [0.1, 0.2, 0.3];
    let mut tape = Tape::new();
    let (l, grad) = loss(anchor, &mut tape);
    println!("chain of 4 particles, 20 Gauss–Seidel sweeps; L = |x_end − target|² = {l:.12}");
    println!(
        "{:>10} {:>20} {:>20} {:>10}",
        "dL/d", "tape (reverse mode)", "central FD", "rel. err"
    );
    let h = 1e-6;
    let mut worst: f64 = 0.0;
    for k in 0..3 {
        let (mut p, mut m) = (anchor, anchor);
        p[k] += h;
        m[k] -= h;
        let fd = (loss(p, &mut tape).0 - loss(m, &mut tape).0) / (2.0 * h);
        let rel = (grad[k] - fd).abs() / fd.abs().max(1e-12);
        worst = worst.max(rel);
        println!(
            "{:>10} {:>20.12} {:>20.12} {:>10.2e}",
            ["anchor.x", "anchor.y", "anchor.z"][k],
            grad[k],
            fd,
            rel
        );
    }
    println!(
        "worst relative error {worst:.2e} ({})",
        if worst < 1e-6 { "agree" } else { "DISAGREE" }
    );
    if worst >= 1e-6 {
        std::process::exit(1);
    }
}
