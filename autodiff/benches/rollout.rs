//! A synthetic workload shaped like one XPBD rollout, recorded on the tape and differentiated.
//!
//! State: 100 particles × 3 (a 10 × 10 grid, jittered). Constraints: 10 disjoint index sets of 50
//! particle pairs each (arity 2; perfect matchings of the grid: horizontal and vertical edges,
//! diagonals, and two pseudo-random matchings), each projected by a generic XPBD distance
//! [`RowFn`] with a carried Lagrange multiplier λ. One iteration = the 10 sets in turn; the rollout
//! = 1,000 iterations = 10,000 batched nodes = 500,000 constraint rows.
//!
//! - `rollout/update_rows/…`: each set is one `Tape::update_rows` (gather the pair's rows and λ,
//!   apply the projection, write back in place — the Gauss–Seidel kernel; the state buffer moves
//!   along the chain);
//! - `rollout/gather_map_scatter/…`: the same projection as explicit `gather → map_rows →
//!   scatter_add → add` (a Jacobi-style update recorded from the basic ops; λ not carried).
//!
//! `…/forward` is `clear` + recording (values computed), `…/backward` is `Tape::vjp` from a seed on
//! the final state. Throughput is in constraint rows. After the criterion runs, a summary line
//! (`rollout summary: …`) gives ns/row forward and backward and bytes per recorded row
//! (`Tape::memory_bytes` / rows), from medians of a few direct timings.

use autodiff::{DynRowFn, Real, RowFn, RowIndex, Tape, Tensor, Var};
use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use std::hint::black_box;
use std::sync::Arc;
use std::time::{Duration, Instant};

const SIDE: usize = 10;
const PARTICLES: usize = SIDE * SIDE;
const SETS: usize = 10;
const ROWS_PER_SET: usize = PARTICLES / 2;
const ITERATIONS: usize = 1_000;
const ROWS: usize = ITERATIONS * SETS * ROWS_PER_SET;

/// XPBD distance constraint between two particles, with compliance and a carried multiplier:
/// `[xᵢ (3), xⱼ (3), λ] → [xᵢ', xⱼ', λ']`.
struct XpbdDistance {
    rest: Vec<f64>,
    /// Compliance over the squared time step (α̃).
    alpha: f64,
}

impl XpbdDistance {
    /// `Δλ` and the unit direction `n`.
    #[inline(always)]
    fn step<R: Real>(&self, row: usize, x: &[R], lambda: R) -> (R, [R; 3]) {
        let d = [x[0] - x[3], x[1] - x[4], x[2] - x[5]];
        let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        let c = len - self.rest[row];
        let dl = (-c - lambda * self.alpha) / (2.0 + self.alpha);
        let inv = R::one() / len;
        (dl, [d[0] * inv, d[1] * inv, d[2] * inv])
    }
}

impl RowFn for XpbdDistance {
    fn n_in(&self) -> usize {
        7
    }
    fn n_out(&self) -> usize {
        7
    }
    fn eval<R: Real>(&self, row: usize, x: &[R], out: &mut [R]) {
        let (dl, n) = self.step(row, x, x[6]);
        for k in 0..3 {
            out[k] = x[k] + n[k] * dl;
            out[3 + k] = x[3 + k] - n[k] * dl;
        }
        out[6] = x[6] + dl;
    }
}

/// The same projection as a displacement of the pair, without a carry: `[xᵢ, xⱼ] → [Δxᵢ, Δxⱼ]`.
struct DistanceDelta(XpbdDistance);

impl RowFn for DistanceDelta {
    fn n_in(&self) -> usize {
        6
    }
    fn n_out(&self) -> usize {
        6
    }
    fn eval<R: Real>(&self, row: usize, x: &[R], out: &mut [R]) {
        let (dl, n) = self.0.step(row, x, R::zero());
        for k in 0..3 {
            out[k] = n[k] * dl;
            out[3 + k] = -(n[k] * dl);
        }
    }
}

/// A deterministic pseudo-random sequence (xorshift), for jitter and the random matchings.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }
    fn unit(&mut self) -> f64 {
        (self.next() >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    }
}

/// Ten perfect matchings of the 10 × 10 grid (each a disjoint set of 50 pairs).
fn matchings() -> Vec<Vec<usize>> {
    let id = |i: usize, j: usize| (i % SIDE) * SIDE + (j % SIDE);
    let mut sets = Vec::new();
    for shift in 0..2 {
        // Horizontal and vertical edges, even and odd (the odd ones wrap around).
        sets.push(
            (0..SIDE)
                .flat_map(|i| {
                    (0..SIDE / 2)
                        .flat_map(move |m| [id(i, 2 * m + shift), id(i, 2 * m + 1 + shift)])
                })
                .collect(),
        );
        sets.push(
            (0..SIDE)
                .flat_map(|j| {
                    (0..SIDE / 2)
                        .flat_map(move |m| [id(2 * m + shift, j), id(2 * m + 1 + shift, j)])
                })
                .collect(),
        );
        // Diagonals (i, j)–(i+1, j±1) between rows 2m+shift and 2m+1+shift.
        for dir in [1, SIDE - 1] {
            sets.push(
                (0..SIDE / 2)
                    .flat_map(|m| {
                        (0..SIDE).flat_map(move |j| {
                            [id(2 * m + shift, j), id(2 * m + 1 + shift, j + dir)]
                        })
                    })
                    .collect(),
            );
        }
    }
    let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
    while sets.len() < SETS {
        let mut p: Vec<usize> = (0..PARTICLES).collect();
        for k in (1..PARTICLES).rev() {
            p.swap(k, rng.next() as usize % (k + 1));
        }
        sets.push(p);
    }
    sets
}

struct Rollout {
    x0: Tensor,
    sets: Vec<Arc<RowIndex>>,
    project: Vec<Arc<dyn DynRowFn>>,
    delta: Vec<Arc<dyn DynRowFn>>,
}

impl Rollout {
    fn new() -> Self {
        let mut rng = Rng(0x2545_f491_4f6c_dd1d);
        let x0 = Tensor::new(
            PARTICLES,
            3,
            (0..PARTICLES * 3)
                .map(|k| {
                    let (p, c) = (k / 3, k % 3);
                    let grid = [(p / SIDE) as f64, (p % SIDE) as f64, 0.0][c];
                    grid + 0.1 * rng.unit()
                })
                .collect(),
        );
        let sets: Vec<Arc<RowIndex>> = matchings()
            .into_iter()
            .map(|m| {
                let idx = RowIndex::new(2, m);
                assert!(idx.is_disjoint() && idx.rows() == ROWS_PER_SET);
                Arc::new(idx)
            })
            .collect();
        let dist = |idx: &RowIndex| XpbdDistance {
            rest: (0..idx.rows())
                .map(|k| {
                    let (a, b) = (x0.row(idx.row(k)[0]), x0.row(idx.row(k)[1]));
                    0.95 * (0..3).map(|c| (a[c] - b[c]).powi(2)).sum::<f64>().sqrt()
                })
                .collect(),
            alpha: 1e-3,
        };
        let project = sets
            .iter()
            .map(|s| Arc::new(dist(s)) as Arc<dyn DynRowFn>)
            .collect();
        let delta = sets
            .iter()
            .map(|s| Arc::new(DistanceDelta(dist(s))) as Arc<dyn DynRowFn>)
            .collect();
        Rollout {
            x0,
            sets,
            project,
            delta,
        }
    }

    /// Records the rollout with `update_rows`; returns the final state.
    fn record_update(&self, t: &mut Tape) -> Var {
        t.clear();
        let mut x = t.leaf(self.x0.clone());
        let mut lambda: Vec<Var> = (0..SETS)
            .map(|_| t.leaf(Tensor::zeros(ROWS_PER_SET, 1)))
            .collect();
        for _ in 0..ITERATIONS {
            for ((f, set), l) in self.project.iter().zip(&self.sets).zip(&mut lambda) {
                (x, *l) = t.update_rows(f, set, x, *l);
            }
        }
        x
    }

    /// Records the rollout as gather → map_rows → scatter_add → add; returns the final state.
    fn record_gms(&self, t: &mut Tape) -> Var {
        t.clear();
        let mut x = t.leaf(self.x0.clone());
        for _ in 0..ITERATIONS {
            for s in 0..SETS {
                let pairs = t.gather(x, &self.sets[s]);
                let d = t.map_rows(&self.delta[s], pairs);
                let dx = t.scatter_add(d, &self.sets[s], PARTICLES);
                x = t.add(x, dx);
            }
        }
        x
    }
}

fn seed() -> Tensor {
    Tensor::new(
        PARTICLES,
        3,
        (0..PARTICLES * 3)
            .map(|k| ((k as f64) * 0.37).sin())
            .collect(),
    )
}

type Recorder = fn(&Rollout, &mut Tape) -> Var;

const VARIANTS: [(&str, Recorder); 2] = [
    ("update_rows", Rollout::record_update),
    ("gather_map_scatter", Rollout::record_gms),
];

fn bench_rollout(c: &mut Criterion) {
    let r = Rollout::new();
    let seed = seed();
    let mut group = c.benchmark_group("rollout");
    group.sample_size(10);
    group.warm_up_time(Duration::from_secs(1));
    group.measurement_time(Duration::from_secs(5));
    group.throughput(Throughput::Elements(ROWS as u64));
    for (name, record) in VARIANTS {
        let mut t = Tape::new();
        group.bench_function(format!("{name}/forward"), |b| {
            b.iter(|| black_box(record(&r, &mut t)))
        });
        let x = record(&r, &mut t);
        assert!(t.value(x).is_finite());
        group.bench_function(format!("{name}/backward"), |b| {
            b.iter(|| black_box(t.vjp(&[(x, seed.clone())])))
        });
    }
    group.finish();
}

fn median_ns(mut f: impl FnMut(), reps: usize) -> f64 {
    let mut times: Vec<f64> = (0..reps)
        .map(|_| {
            let t0 = Instant::now();
            f();
            t0.elapsed().as_nanos() as f64
        })
        .collect();
    times.sort_by(f64::total_cmp);
    times[reps / 2]
}

/// Direct timings and memory per row, printed so they can be copied.
fn summary(_c: &mut Criterion) {
    let r = Rollout::new();
    let seed = seed();
    for (name, record) in VARIANTS {
        let mut t = Tape::new();
        // The first recording allocates the tape's buffers; the timed ones reuse them.
        record(&r, &mut t);
        let fwd = median_ns(
            || {
                black_box(record(&r, &mut t));
            },
            7,
        );
        let x = record(&r, &mut t);
        let bwd = median_ns(
            || {
                black_box(t.vjp(&[(x, seed.clone())]));
            },
            7,
        );
        let bytes = t.memory_bytes();
        eprintln!(
            "rollout summary [{name}]: {ROWS} rows ({ITERATIONS} iterations × {SETS} sets × \
             {ROWS_PER_SET} rows), {} nodes | forward {:.1} ns/row ({:.2} ms) | backward {:.1} ns/row \
             ({:.2} ms) | {:.1} bytes/row ({:.2} MB recorded)",
            t.len(),
            fwd / ROWS as f64,
            fwd / 1e6,
            bwd / ROWS as f64,
            bwd / 1e6,
            bytes as f64 / ROWS as f64,
            bytes as f64 / 1e6,
        );
    }
}

criterion_group!(benches, bench_rollout, summary);
criterion_main!(benches);
