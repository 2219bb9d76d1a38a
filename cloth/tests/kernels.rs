//! The batch kernels of the forward projection ([`cloth::kernels`]) against the generic per-row
//! projection, which stays the reference: bit for bit, on random rows and on the special cases
//! (coincident particles, control particles of inverse mass 0, rigid rows of compliance 0 that
//! cannot move, non-finite inputs), for every block length 1 to 40 (groups of sixteen and of four AVX lanes, and scalar
//! tails).

mod common;

use autodiff::RowFn;
use cloth::constraint::Distance;
use cloth::projection::Projection;
use common::XorShift;
use std::sync::Arc;

/// Values per `Distance` row: two points and the multiplier.
const W: usize = 7;

/// Bits of `v`, with every NaN the same (payloads are not part of the contract).
fn bits(v: f64) -> u64 {
    if v.is_nan() {
        f64::NAN.to_bits()
    } else {
        v.to_bits()
    }
}

/// Projects `inputs` with the batch kernel (`eval_rows`) and row by row with the generic
/// kernel (`eval`), and asserts every output value has the same bits.
fn assert_kernel_matches(projection: &Projection<Distance>, inputs: &[f64], what: &str) {
    let rows = inputs.len() / W;
    let mut batch = vec![f64::NAN; inputs.len()];
    projection.eval_rows(0, inputs, &mut batch);
    for r in 0..rows {
        let mut reference = [0.0; W];
        projection.eval(r, &inputs[W * r..W * r + W], &mut reference);
        for j in 0..W {
            assert_eq!(
                bits(batch[W * r + j]),
                bits(reference[j]),
                "{what}: row {r} of {rows}, value {j}: kernel {:e} vs generic {:e} (input {:?})",
                batch[W * r + j],
                reference[j],
                &inputs[W * r..W * r + W]
            );
        }
    }
}

/// A projection of `rows` rows with random rest lengths and inverse masses (some 0).
fn projection(rng: &mut XorShift, rows: usize, compliance: f64) -> Projection<Distance> {
    let rest = (0..rows).map(|_| rng.uniform(0.0, 0.3)).collect();
    let inv_mass = (0..2 * rows)
        .map(|_| match (rng.next_f64() * 4.0) as u32 {
            0 => 0.0,
            _ => rng.uniform(0.1, 2.0),
        })
        .collect();
    // Rows visit the instances in a shuffled order, as colour sets do.
    let mut instances: Vec<usize> = (0..rows).collect();
    for i in (1..rows).rev() {
        instances.swap(i, (rng.next_f64() * (i + 1) as f64) as usize);
    }
    Projection::new(Arc::new(Distance { rest }), instances, inv_mass, compliance)
}

/// Random rows: points in a unit box, some coincident or nearly so, and random multipliers.
fn random_rows(rng: &mut XorShift, rows: usize) -> Vec<f64> {
    let mut x = Vec::with_capacity(W * rows);
    for _ in 0..rows {
        let p0 = rng.direction(3);
        let p1: Vec<f64> = match (rng.next_f64() * 5.0) as u32 {
            0 => p0.clone(),
            1 => p0.iter().map(|v| v + rng.uniform(-1e-12, 1e-12)).collect(),
            _ => rng.direction(3),
        };
        x.extend(p0);
        x.extend(p1);
        x.push(rng.uniform(-1.0, 1.0));
    }
    x
}

#[test]
fn distance_kernel_is_bitwise_the_generic_projection() {
    let mut rng = XorShift::new(16);
    for case in 0..400 {
        let rows = 1 + case % 40;
        let compliance = match case % 3 {
            0 => 0.0,
            1 => 1e-2,
            _ => rng.uniform(1e-6, 1.0),
        };
        let p = projection(&mut rng, rows, compliance);
        let x = random_rows(&mut rng, rows);
        assert_kernel_matches(&p, &x, &format!("case {case} (α̃ = {compliance:e})"));
    }
}

#[test]
fn distance_kernel_special_rows_match() {
    let mut rng = XorShift::new(7);
    // Rigid rows between two control particles (w = 0, α̃ = 0) cannot move; coincident
    // particles have ∇C = 0; infinities and NaN propagate as in the generic kernel.
    let special: [[f64; W]; 6] = [
        [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5],
        [1.0, 2.0, 3.0, 1.0, 2.0, 3.0, -0.25],
        [f64::INFINITY, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0],
        [f64::NAN, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0],
        [1e-300, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        [1e200, 1e200, 0.0, -1e200, 0.0, 0.0, 1.0],
    ];
    for compliance in [0.0, 1e-3] {
        for rows in [1, 3, 4, 7, 8, 16, 21, 36] {
            for k in 0..special.len() {
                let mut p = projection(&mut rng, rows, compliance);
                let mut x = random_rows(&mut rng, rows);
                let r = k % rows;
                x[W * r..W * r + W].copy_from_slice(&special[k]);
                assert_kernel_matches(&p, &x, &format!("special row {k} at {r} of {rows}"));
                // The same row between two control particles.
                p = Projection::new(
                    Arc::new(Distance {
                        rest: vec![0.1; rows],
                    }),
                    (0..rows).collect(),
                    vec![0.0; 2 * rows],
                    compliance,
                );
                assert_kernel_matches(&p, &x, &format!("control row {k} at {r} of {rows}"));
            }
        }
    }
}
