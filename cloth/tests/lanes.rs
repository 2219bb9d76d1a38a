//! The lane-wise colour-set kernel (eight rows at once, gathered straight from the state into
//! AVX2 lanes: `autodiff/src/lanes.rs` with `Projection::eval_lanes` and
//! `Distance::gradient_lanes`) and its pull-backs, of one seed and of several at once
//! (`Projection::vjp_lanes_seeds`, one seed or several, and `Distance::hessian_vectors_lanes`),
//! against the row-by-row kernels they replace where the CPU has AVX2: states, multipliers, the
//! recorded inputs and the adjoints must be bitwise equal.
//!
//! Random colour sets of `Distance` rows (0 to 40 rows, so groups of eight and every tail length;
//! now and then 600 rows, so the rows are split into tasks), random states with some rows'
//! particles coincident (`∇C` = 0, the zero branch), inverse masses 0 with probability ¼ (rows
//! of two pinned particles do not move when rigid), compliance 0 or in `[1e-6, 1]`, and random
//! multipliers. The same for a constraint with `LANES` but the trait's default lane methods.
//! On a CPU without AVX2 both sides take the row-by-row kernel.

mod common;

use autodiff::lanes::without_lanes;
use autodiff::update::update_rows;
use autodiff::Real;
use autodiff::{DynRowFn, RowIndex, Tensor};
use cloth::constraint::{Constraint, Distance, RowVector};
use cloth::internals::Projection;
use common::XorShift;
use nalgebra::Vector3;
use proptest::prelude::*;
use proptest::test_runner::TestCaseError;
use std::sync::Arc;

/// A random colour set of `rows` distance rows over `2·rows + 3` particles, its state and its
/// multipliers.
fn colour_set<C: Constraint>(
    seed: u64,
    rows: usize,
    alpha: f64,
    constraint: impl FnOnce(Distance) -> C,
) -> (Projection<C>, RowIndex, Tensor, Tensor) {
    let mut rng = XorShift::new(seed);
    let n = 2 * rows + 3;
    // A random permutation's first 2·rows particles, paired: disjoint rows.
    let mut perm: Vec<usize> = (0..n).collect();
    for i in (1..n).rev() {
        perm.swap(i, (rng.next_f64() * (i + 1) as f64) as usize);
    }
    let idx = perm[..2 * rows].to_vec();
    let mut state: Vec<f64> = (0..3 * n).map(|_| rng.uniform(-2.0, 2.0)).collect();
    for pair in idx.chunks_exact(2) {
        if rng.next_f64() < 0.1 {
            let (a, b) = (3 * pair[0], 3 * pair[1]);
            for k in 0..3 {
                state[b + k] = state[a + k];
            }
        }
    }
    let inv_mass: Vec<f64> = (0..2 * rows)
        .map(|_| match rng.next_f64() < 0.25 {
            true => 0.0,
            false => rng.uniform(0.1, 10.0),
        })
        .collect();
    let rest: Vec<f64> = (0..rows + 2).map(|_| rng.uniform(0.0, 2.0)).collect();
    let instances: Vec<usize> = (0..rows).map(|k| (k * 7 + 1) % (rows + 2)).collect();
    let carry: Vec<f64> = (0..rows).map(|_| rng.uniform(-1.0, 1.0)).collect();
    let constraint = Arc::new(constraint(Distance { rest }));
    let projection = Projection::new(constraint, instances, inv_mass, alpha);
    (
        projection,
        RowIndex::new(2, idx),
        Tensor::new(n, 3, state),
        Tensor::new(rows, 1, carry),
    )
}

/// Three sweeps of the set (so moved rows move again), recording the last, and the last's
/// pull-back of random adjoints, alone and as one of 1 to 8 seeds at once: the final state,
/// multipliers, saved inputs and the adjoints as bits.
fn sweeps<C: Constraint>(
    p: &Projection<C>,
    index: &RowIndex,
    state: &Tensor,
    carry: &Tensor,
    seed: u64,
) -> Vec<u64> {
    let (mut state, mut carry, mut saved) = (state.clone(), carry.clone(), vec![f64::NAN; 5]);
    for sweep in 0..3 {
        let record = (sweep == 2).then_some(&mut saved);
        update_rows(p, index, &mut state, &mut carry, record);
    }
    let mut rng = XorShift::new(seed ^ 0x5eed);
    let (n, rows) = (state.rows(), carry.rows());
    let mut state_adj = Tensor::new(n, 3, rng.direction(3 * n));
    let mut carry_adj = Tensor::new(rows, 1, rng.direction(rows));
    p.vjp_update_batch(index, &saved, &mut state_adj, &mut carry_adj);
    let seeds = 1 + (rng.next_f64() * 8.0) as usize;
    let mut states: Vec<Tensor> = (0..seeds)
        .map(|_| Tensor::new(n, 3, rng.direction(3 * n)))
        .collect();
    let mut carries: Vec<Tensor> = (0..seeds)
        .map(|_| Tensor::new(rows, 1, rng.direction(rows)))
        .collect();
    p.vjp_update_batch_seeds(index, &saved, &mut states, &mut carries);
    let values = state.data().iter().chain(carry.data()).chain(&saved);
    let adjoints = state_adj.data().iter().chain(carry_adj.data());
    let seeded = states.iter().chain(&carries).flat_map(|t| t.data());
    values
        .chain(adjoints)
        .chain(seeded)
        .map(|v| v.to_bits())
        .collect()
}

/// `Distance` with [`Constraint::LANES`] but without its lane-wise overrides, so the kernels
/// take the trait's default `gradient_lanes` and `hessian_vectors_lanes` (row by row in lanes).
struct DefaultLanes(Distance);

impl Constraint for DefaultLanes {
    const ARITY: usize = 2;
    const LANES: bool = true;
    fn c<R: Real>(&self, instance: usize, p: &[Vector3<R>]) -> R {
        self.0.c(instance, p)
    }
    fn gradient<R: Real>(&self, instance: usize, x: &[R], grad: &mut [R]) -> R {
        self.0.gradient(instance, x, grad)
    }
    fn hessian_vectors(&self, instance: usize, x: &[f64], vs: &mut [RowVector]) {
        self.0.hessian_vectors(instance, x, vs)
    }
}

/// Sweeps and pull-back of a random colour set through the lanes and row by row, bitwise.
fn check<C: Constraint>(
    seed: u64,
    rows: usize,
    alpha: f64,
    constraint: impl FnOnce(Distance) -> C,
) -> Result<(), TestCaseError> {
    let (p, index, state, carry) = colour_set(seed, rows, alpha, constraint);
    let lanes = sweeps(&p, &index, &state, &carry, seed);
    let by_rows = without_lanes(|| sweeps(&p, &index, &state, &carry, seed));
    prop_assert_eq!(lanes.len(), by_rows.len());
    for (i, (a, b)) in lanes.iter().zip(&by_rows).enumerate() {
        let (x, y) = (f64::from_bits(*a), f64::from_bits(*b));
        prop_assert_eq!(a, b, "value {} differs: {:e} vs {:e}", i, x, y);
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 400, ..ProptestConfig::default() })]

    #[test]
    fn lanes_match_rows_bitwise(
        seed in any::<u64>(),
        rows in prop_oneof![9 => 0usize..40, 1 => Just(600usize)],
        alpha in prop_oneof![Just(0.0), 1e-6f64..1.0],
    ) {
        check(seed, rows, alpha, |d| d)?;
    }

    #[test]
    fn default_lane_methods_match_rows_bitwise(
        seed in any::<u64>(),
        rows in 0usize..40,
        alpha in prop_oneof![Just(0.0), 1e-6f64..1.0],
    ) {
        check(seed, rows, alpha, DefaultLanes)?;
    }
}
