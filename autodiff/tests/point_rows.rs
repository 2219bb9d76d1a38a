//! `PointRows`: a row function carrying several values per row, served by the fixed-width
//! in-place kernels, gives bit for bit what the general (gather, evaluate, scatter) path gives:
//! the update with and without saved inputs, its adjoint, and the multi-seed adjoint (more seeds
//! than one chunk).

use autodiff::rowfn::{PARALLEL_MIN_ROWS, SEED_CHUNK};
use autodiff::update::{update_rows, PointRows};
use autodiff::{DynRowFn, Real, RowFn, RowIndex, Tensor};

/// `A` points and `C` carried values per row, mixed nonlinearly: every output depends on every
/// input, so a misplaced value changes the result.
struct Mix<const A: usize, const C: usize>;

impl<const A: usize, const C: usize> RowFn for Mix<A, C> {
    fn n_in(&self) -> usize {
        3 * A + C
    }
    fn n_out(&self) -> usize {
        3 * A + C
    }
    fn eval<R: Real>(&self, row: usize, x: &[R], out: &mut [R]) {
        let mut s = R::cst(0.1 * (row % 7) as f64);
        for (k, &v) in x.iter().enumerate() {
            s += v * (k as f64 + 1.0);
        }
        let w = (s * s + 1.0).sqrt();
        for (k, o) in out.iter_mut().enumerate() {
            *o = x[k] + (s * 0.01 * (k as f64 + 1.0)).sin() / w;
        }
    }
}

/// A deterministic fill in `[-1, 1)`.
fn filled(rows: usize, cols: usize, seed: u64) -> Tensor {
    let mut z = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
    let data = (0..rows * cols)
        .map(|_| {
            z ^= z << 13;
            z ^= z >> 7;
            z ^= z << 17;
            2.0 * ((z >> 11) as f64 / (1u64 << 53) as f64) - 1.0
        })
        .collect();
    Tensor::new(rows, cols, data)
}

fn bits(t: &Tensor) -> Vec<u64> {
    t.data().iter().map(|v| v.to_bits()).collect()
}

/// Checks one layout on `rows` rows (a reversed, interleaved index, so rows are scattered).
fn check<const A: usize, const C: usize>(rows: usize) {
    let particles = A * rows + 5;
    let idx: Vec<usize> = (0..A * rows).rev().collect();
    let index = RowIndex::new(A, idx);
    let general: &dyn DynRowFn = &Mix::<A, C>;
    let fixed: &dyn DynRowFn = &PointRows::<_, A, C>(Mix::<A, C>);
    // The update, with saved inputs.
    let (state, carry) = (filled(particles, 3, 1), filled(rows, C, 2));
    let run = |f: &dyn DynRowFn| {
        let (mut s, mut c, mut saved) = (state.clone(), carry.clone(), Vec::new());
        update_rows(f, &index, &mut s, &mut c, Some(&mut saved));
        let (mut s2, mut c2) = (state.clone(), carry.clone());
        update_rows(f, &index, &mut s2, &mut c2, None);
        assert_eq!((bits(&s), bits(&c)), (bits(&s2), bits(&c2)));
        (s, c, saved)
    };
    let (sg, cg, saved_g) = run(general);
    let (sf, cf, saved_f) = run(fixed);
    assert_eq!(bits(&sg), bits(&sf), "state, A = {A}, C = {C}");
    assert_eq!(bits(&cg), bits(&cf), "carry, A = {A}, C = {C}");
    assert_eq!(saved_g, saved_f);
    assert_ne!(bits(&sg), bits(&state));
    // The adjoint, one seed.
    let (sa, ca) = (filled(particles, 3, 3), filled(rows, C, 4));
    let adjoint = |f: &dyn DynRowFn| {
        let (mut s, mut c) = (sa.clone(), ca.clone());
        f.vjp_update_batch(&index, &saved_g, &mut s, &mut c);
        (bits(&s), bits(&c))
    };
    assert_eq!(adjoint(general), adjoint(fixed));
    // Several seeds (more than one chunk), against one seed at a time.
    let seeds = SEED_CHUNK + 3;
    let states: Vec<Tensor> = (0..seeds)
        .map(|k| filled(particles, 3, 10 + k as u64))
        .collect();
    let carries: Vec<Tensor> = (0..seeds).map(|k| filled(rows, C, 40 + k as u64)).collect();
    let many = |f: &dyn DynRowFn| {
        let (mut s, mut c) = (states.clone(), carries.clone());
        f.vjp_update_batch_seeds(&index, &saved_g, &mut s, &mut c);
        (
            s.iter().map(bits).collect::<Vec<_>>(),
            c.iter().map(bits).collect::<Vec<_>>(),
        )
    };
    let one_by_one = {
        let (mut s, mut c) = (states.clone(), carries.clone());
        for (s, c) in s.iter_mut().zip(c.iter_mut()) {
            general.vjp_update_batch(&index, &saved_g, s, c);
        }
        (
            s.iter().map(bits).collect::<Vec<_>>(),
            c.iter().map(bits).collect::<Vec<_>>(),
        )
    };
    assert_eq!(many(fixed), one_by_one);
    assert_eq!(many(general), one_by_one);
}

#[test]
fn point_rows_match_the_general_path_bitwise() {
    // Fewer rows than a block, a few blocks, and enough rows for the parallel path.
    for rows in [3, 37, PARALLEL_MIN_ROWS + 100] {
        check::<1, 7>(rows);
        check::<1, 3>(rows);
        check::<2, 4>(rows);
        check::<3, 1>(rows);
    }
}
