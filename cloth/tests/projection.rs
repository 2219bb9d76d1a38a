//! The structured vector–Jacobian product of the XPBD [`Projection`] (the adjoint of the update
//! formula, with `∇²C·v` from nested duals) against the engine's generic derivation
//! [`autodiff::vjp_by_duals`] (forward duals through `eval`, which itself takes `∇C` from duals),
//! and both against central finite differences of `eval`.
//!
//! Constraints: [`Distance`], [`DihedralBending`] (random non-degenerate quads, `|φ| < 2.5` so the
//! `atan2` branch cut at `±π` is far), [`IsometricBending`] (random weights at random
//! points), [`Collision`] with a [`SphereSet`] and with a [`Plane`], each
//! violated and not violated; random multipliers `λ`, inverse masses (each 0 with probability ½) and
//! compliance (0 or 1e-4–1). Several rows per projection, with permuted instances, so the per-row
//! data (instance, inverse masses) is exercised too.
//!
//! Tolerances: structured vs generic VJP `|a − b| ≤ 1e-10·max(|a|, |b|) + 1e-13·‖b‖∞` per input
//! component; VJPs vs FD (Richardson-extrapolated central difference, `h = 1e-6`, of
//! `⟨out_adj, eval(x + s·v)⟩`) `≤ 1e-6·max(|a|, |b|) + 1e-9·(1 + M)` with
//! `M = Σᵢ|out_adjᵢ|·max(|outᵢ|, |xᵢ|) + Σⱼ|FDⱼ|·max(|xⱼ|, 1)`: the FD's rounding noise scales with the
//! magnitude of what it sums, and `λ`'s output and the sensitivities reach `1/α̃` (1e4) for a row whose
//! particles are all pinned.
//!
//! The block and multi-seed methods the simulator's kernels call (`eval_rows`, `vjp_rows`, which
//! interleave rows; `vjp_seeds`, which shares `∇C` across seeds) must give `eval`'s and `vjp`'s
//! values bit for bit.
//!
//! Measured over 3000 cases per constraint type: the structured VJP agrees with the generic one to
//! at most 0.0073 of its tolerance (≈ 7e-13 relative), and both with the FD to at most 0.12 of its.

mod common;

use autodiff::{vjp_by_duals, RowFn};
use cloth::constraint::{
    value_and_gradient, Collision, Constraint, DihedralBending, Distance, IsometricBending,
};
use cloth::internals::Projection;
use cloth::sdf::{Plane, SphereSet};
use common::{dot, within, XorShift};
use nalgebra::Vector3;
use proptest::prelude::*;
use proptest::test_runner::TestCaseError;
use std::sync::Arc;

/// Rows per projection in these tests.
const ROWS: usize = 3;

/// `eval` on `f64`.
fn eval<C: Constraint>(p: &Projection<C>, row: usize, x: &[f64]) -> Vec<f64> {
    let mut out = vec![0.0; RowFn::n_out(p)];
    p.eval(row, x, &mut out);
    out
}

/// Checks one row: structured VJP vs `vjp_by_duals` vs FD, for random output adjoints.
fn check_row<C: Constraint>(
    p: &Projection<C>,
    row: usize,
    x: &[f64],
    rng: &mut XorShift,
) -> Result<(), TestCaseError> {
    let n = RowFn::n_in(p);
    prop_assert_eq!(x.len(), n);
    prop_assert_eq!(RowFn::n_out(p), n);
    for _ in 0..2 {
        let out_adj = rng.direction(n);
        // Both accumulate into a non-zero starting adjoint.
        let start = rng.direction(n);
        let mut structured = start.clone();
        RowFn::vjp(p, row, x, &out_adj, &mut structured);
        let mut generic = start.clone();
        vjp_by_duals(p, row, x, &out_adj, &mut generic);
        for v in [&mut structured, &mut generic] {
            for (a, s) in v.iter_mut().zip(&start) {
                *a -= s;
            }
        }
        prop_assert!(structured.iter().all(|v| v.is_finite()));
        let inf = generic.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        for (j, (a, b)) in structured.iter().zip(&generic).enumerate() {
            let tol = 1e-10 * a.abs().max(b.abs()) + 1e-13 * inf;
            prop_assert!(
                (a - b).abs() <= tol,
                "row {row} input {j}: structured VJP {a:e} vs generic {b:e}"
            );
        }
        // Finite differences of ⟨out_adj, eval(x + s·v)⟩ along each input coordinate and a
        // random direction.
        let h = 1e-6;
        let f = |d: &[f64], s: f64| {
            let xs: Vec<f64> = x.iter().zip(d).map(|(xi, di)| xi + s * di).collect();
            dot(&out_adj, &eval(p, row, &xs))
        };
        let fd = |d: &[f64]| {
            (8.0 * (f(d, h) - f(d, -h)) - (f(d, 2.0 * h) - f(d, -2.0 * h))) / (12.0 * h)
        };
        let mut dirs: Vec<Vec<f64>> = (0..n)
            .map(|j| (0..n).map(|k| f64::from(u8::from(j == k))).collect())
            .collect();
        dirs.push(rng.direction(n));
        let fds: Vec<f64> = dirs.iter().map(|d| fd(d)).collect();
        // The FD's rounding noise is ~ε/h times the magnitude of what is summed: the outputs
        // (λ's reaches 1e2–1e4 when α̃ is small and the particles cannot move) and the inputs
        // times their sensitivities (up to 1/α̃); the floor is 1e-9 per unit of that magnitude,
        // taken from the FD itself.
        let y = eval(p, row, x);
        let magnitude: f64 = out_adj
            .iter()
            .zip(y.iter().zip(x))
            .map(|(a, (yi, xi))| a.abs() * yi.abs().max(xi.abs()))
            .sum::<f64>()
            + fds[..n]
                .iter()
                .zip(x)
                .map(|(g, xi)| g.abs() * xi.abs().max(1.0))
                .sum::<f64>();
        let floor = 1e-9 * (1.0 + magnitude);
        for (d, &fd) in dirs.iter().zip(&fds) {
            for (name, v) in [("structured", &structured), ("generic", &generic)] {
                let an = dot(v, d);
                prop_assert!(
                    within(an, fd, 1e-6, floor),
                    "row {row}: {name} VJP·v = {an:e} vs FD {fd:e}"
                );
            }
        }
    }
    Ok(())
}

/// Inverse masses for `ROWS` rows of `arity` particles: each 0 (a pinned / control particle) with
/// probability ½, else in [0.1, 2].
fn inverse_masses(rng: &mut XorShift, arity: usize) -> Vec<f64> {
    (0..ROWS * arity)
        .map(|_| {
            if rng.next_f64() < 0.5 {
                0.0
            } else {
                rng.uniform(0.1, 2.0)
            }
        })
        .collect()
}

fn compliance() -> impl Strategy<Value = f64> {
    prop_oneof![Just(0.0), (-4.0..0.0f64).prop_map(|e| 10f64.powf(e))]
}

fn random_point(rng: &mut XorShift, r: f64) -> Vector3<f64> {
    Vector3::new(rng.uniform(-r, r), rng.uniform(-r, r), rng.uniform(-r, r))
}

/// A row's input: the points, then `λ`.
fn row_input(points: &[Vector3<f64>], lambda: f64) -> Vec<f64> {
    let mut v: Vec<f64> = points.iter().flat_map(|p| [p.x, p.y, p.z]).collect();
    v.push(lambda);
    v
}

/// Runs `check_row` on every row.
fn check_rows<C: Constraint>(
    p: &Projection<C>,
    inputs: &[Vec<f64>],
    rng: &mut XorShift,
) -> Result<(), TestCaseError> {
    for (row, x) in inputs.iter().enumerate() {
        check_row(p, row, x, rng)?;
    }
    check_block(p, inputs, rng)
}

/// The block and multi-seed methods the in-place kernels call (`eval_rows`, `vjp_rows`,
/// `vjp_seeds`) give the per-row methods' values bit for bit.
fn check_block<C: Constraint>(
    p: &Projection<C>,
    inputs: &[Vec<f64>],
    rng: &mut XorShift,
) -> Result<(), TestCaseError> {
    let n = RowFn::n_in(p);
    let block: Vec<f64> = inputs.concat();
    let mut outputs = vec![0.0; block.len()];
    p.eval_rows(0, &block, &mut outputs);
    let out_adj = rng.direction(block.len());
    let mut in_adj = rng.direction(block.len());
    let start = in_adj.clone();
    p.vjp_rows(0, &block, &out_adj, &mut in_adj);
    for (row, x) in inputs.iter().enumerate() {
        let r = row * n..(row + 1) * n;
        prop_assert_eq!(
            &outputs[r.clone()],
            &eval(p, row, x)[..],
            "eval_rows, row {}",
            row
        );
        let mut one = start[r.clone()].to_vec();
        RowFn::vjp(p, row, x, &out_adj[r.clone()], &mut one);
        prop_assert_eq!(&in_adj[r], &one[..], "vjp_rows, row {}", row);
        // Five seeds through one row at once.
        let seeds_out = rng.direction(5 * n);
        let mut seeds_in = rng.direction(5 * n);
        let mut one_by_one = seeds_in.clone();
        p.vjp_seeds(row, x, &seeds_out, &mut seeds_in);
        for (oa, ia) in seeds_out.chunks(n).zip(one_by_one.chunks_mut(n)) {
            RowFn::vjp(p, row, x, oa, ia);
        }
        prop_assert_eq!(&seeds_in, &one_by_one, "vjp_seeds, row {}", row);
    }
    Ok(())
}

/// A non-degenerate dihedral quad: shared edge `p₀p₁`, wings `p₂`, `p₃` at distances 0.3–1 from
/// the edge's line, at a dihedral angle of magnitude < 2.5 (away from the ±π branch cut).
fn dihedral_quad(rng: &mut XorShift) -> [Vector3<f64>; 4] {
    let p0 = random_point(rng, 1.0);
    let e = loop {
        let e = random_point(rng, 1.0);
        if e.norm() > 0.5 {
            break e;
        }
    };
    let p1 = p0 + e;
    let t = e.normalize();
    let a = {
        let r = random_point(rng, 1.0);
        let a = r - t * r.dot(&t);
        if a.norm() < 1e-3 {
            t.cross(&Vector3::new(1.0, 0.0, 0.0)).normalize()
        } else {
            a.normalize()
        }
    };
    let b = t.cross(&a);
    let theta2 = rng.uniform(0.0, std::f64::consts::TAU);
    let theta3 = theta2 + std::f64::consts::PI + rng.uniform(-2.5, 2.5);
    let wing = |theta: f64, rng: &mut XorShift| {
        p0 + e * rng.uniform(0.1, 0.9) + (a * theta.cos() + b * theta.sin()) * rng.uniform(0.3, 1.0)
    };
    let p2 = wing(theta2, rng);
    let p3 = wing(theta3, rng);
    [p0, p1, p2, p3]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    /// Distance constraints (rest lengths 0.5–1.5 × the current length, so both stretched and
    /// compressed), arbitrary masses including pinned particles and rigid (0) compliance.
    #[test]
    fn distance_vjp_matches_duals_and_fd(seed in any::<u64>(), alpha in compliance()) {
        let mut rng = XorShift::new(seed);
        let mut rest = Vec::new();
        let mut inputs = Vec::new();
        for _ in 0..ROWS {
            let (p, q) = loop {
                let (p, q) = (random_point(&mut rng, 1.0), random_point(&mut rng, 1.0));
                if (p - q).norm() > 0.1 {
                    break (p, q);
                }
            };
            rest.push((p - q).norm() * rng.uniform(0.5, 1.5));
            inputs.push(row_input(&[p, q], rng.uniform(-1.0, 1.0)));
        }
        // Row k evaluates instance (k + 1) % ROWS: rows and instances differ.
        let instances: Vec<usize> = (0..ROWS).map(|k| (k + 1) % ROWS).collect();
        let rest: Vec<f64> = (0..ROWS).map(|i| rest[(i + ROWS - 1) % ROWS]).collect();
        let p = Projection::new(Arc::new(Distance { rest }), instances, inverse_masses(&mut rng, 2), alpha);
        check_rows(&p, &inputs, &mut rng)?;
    }

    /// Dihedral bending on random non-degenerate quads with random rest angles.
    #[test]
    fn dihedral_vjp_matches_duals_and_fd(seed in any::<u64>(), alpha in compliance()) {
        let mut rng = XorShift::new(seed);
        let mut rest = Vec::new();
        let mut inputs = Vec::new();
        for _ in 0..ROWS {
            let q = dihedral_quad(&mut rng);
            let phi = DihedralBending::angle(&q);
            prop_assert!(phi.abs() < 2.5 + 1e-9, "constructed angle {phi}");
            rest.push(rng.uniform(-1.0, 1.0));
            inputs.push(row_input(&q, rng.uniform(-1.0, 1.0)));
        }
        let instances: Vec<usize> = (0..ROWS).collect();
        let p = Projection::new(Arc::new(DihedralBending { rest }), instances, inverse_masses(&mut rng, 4), alpha);
        check_rows(&p, &inputs, &mut rng)?;
    }

    /// Isometric bending: random weights (the row is linear, so its VJP does not depend on them
    /// summing to 0), random points, one row per axis.
    #[test]
    fn isometric_vjp_matches_duals_and_fd(seed in any::<u64>(), alpha in compliance()) {
        let mut rng = XorShift::new(seed);
        let weights: Vec<[f64; 4]> = (0..ROWS)
            .map(|_| std::array::from_fn(|_| rng.uniform(-5.0, 5.0)))
            .collect();
        let inputs: Vec<Vec<f64>> = (0..ROWS)
            .map(|_| {
                let q: Vec<Vector3<f64>> = (0..4).map(|_| random_point(&mut rng, 1.0)).collect();
                row_input(&q, rng.uniform(-1.0, 1.0))
            })
            .collect();
        let bending = IsometricBending { weights, axis: (0..ROWS).map(|a| a % 3).collect() };
        let p = Projection::new(Arc::new(bending), (0..ROWS).collect(), inverse_masses(&mut rng, 4), alpha);
        check_rows(&p, &inputs, &mut rng)?;
    }

    /// Sphere-set collider: each particle either inside some sphere (violated, projected) or
    /// outside all of them (untouched: the VJP is exactly the identity), away from ties and centres.
    #[test]
    fn sphere_collision_vjp_matches_duals_and_fd(seed in any::<u64>(), alpha in compliance()) {
        let mut rng = XorShift::new(seed);
        let k = 1 + (seed % 3) as usize;
        let sdf = SphereSet {
            centers: (0..k).map(|_| { let c = random_point(&mut rng, 1.0); [c.x, c.y, c.z] }).collect(),
            radii: (0..k).map(|_| rng.uniform(0.3, 0.8)).collect(),
        };
        let distances = |p: &Vector3<f64>| -> Vec<f64> {
            sdf.centers.iter().zip(&sdf.radii)
                .map(|(c, r)| (p - Vector3::new(c[0], c[1], c[2])).norm() - r)
                .collect()
        };
        let mut inputs = Vec::new();
        let mut violated = Vec::new();
        while inputs.len() < ROWS {
            let p = random_point(&mut rng, 1.5);
            let mut d = distances(&p);
            d.sort_by(|a, b| a.total_cmp(b));
            let centre_far = sdf.centers.iter().all(|c| (p - Vector3::new(c[0], c[1], c[2])).norm() > 0.05);
            if d[0].abs() > 1e-3 && (d.len() < 2 || d[1] - d[0] > 1e-3) && centre_far {
                violated.push(d[0] < 0.0);
                inputs.push(row_input(&[p], rng.uniform(-1.0, 1.0)));
            }
        }
        let w = inverse_masses(&mut rng, 1);
        let c = Arc::new(Collision { sdf });
        let p = Projection::new(c.clone(), (0..ROWS).collect(), w.clone(), alpha);
        check_rows(&p, &inputs, &mut rng)?;
        check_single_particle_rows(c.as_ref(), &p, &inputs, &violated, &w, alpha)?;
    }

    /// Plane collider, violated and not.
    #[test]
    fn plane_collision_vjp_matches_duals_and_fd(seed in any::<u64>(), alpha in compliance()) {
        let mut rng = XorShift::new(seed);
        let n = random_point(&mut rng, 1.0).normalize();
        let q = random_point(&mut rng, 0.5);
        let sdf = Plane { point: [q.x, q.y, q.z], normal: [n.x, n.y, n.z] };
        let mut inputs = Vec::new();
        let mut violated = Vec::new();
        while inputs.len() < ROWS {
            let p = random_point(&mut rng, 1.5);
            let c = (p - q).dot(&n);
            if c.abs() > 1e-3 {
                violated.push(c < 0.0);
                inputs.push(row_input(&[p], rng.uniform(-1.0, 1.0)));
            }
        }
        let w = inverse_masses(&mut rng, 1);
        let c = Arc::new(Collision { sdf });
        let p = Projection::new(c.clone(), (0..ROWS).collect(), w.clone(), alpha);
        check_rows(&p, &inputs, &mut rng)?;
        check_single_particle_rows(c.as_ref(), &p, &inputs, &violated, &w, alpha)?;
    }
}

/// An inequality row that is satisfied, or a row that cannot move (`Σ w|∇C|² + α̃ = 0`), is left
/// exactly as it is, and its VJP is exactly the identity; a violated movable row moves, and when
/// rigid it solves the linearised constraint: `C(x) + ∇C(x)·(x' − x) = 0`.
fn check_single_particle_rows<C: Constraint>(
    constraint: &C,
    p: &Projection<C>,
    inputs: &[Vec<f64>],
    violated: &[bool],
    w: &[f64],
    alpha: f64,
) -> Result<(), TestCaseError> {
    for (row, x) in inputs.iter().enumerate() {
        let out = eval(p, row, x);
        let adj: Vec<f64> = (0..x.len()).map(|j| 0.5 + j as f64).collect();
        let mut a = vec![0.0; x.len()];
        RowFn::vjp(p, row, x, &adj, &mut a);
        let frozen = w[row] == 0.0 && alpha == 0.0;
        if !violated[row] || frozen {
            prop_assert_eq!(&out, x, "row {} must be untouched", row);
            prop_assert_eq!(&a, &adj, "row {}: the VJP must be the identity", row);
        } else {
            prop_assert!(out != *x, "violated row {} must move", row);
            if alpha == 0.0 {
                let mut g = [0.0; 3];
                let c: f64 = value_and_gradient(constraint, row, &x[..3], &mut g);
                let lin = c + (0..3).map(|k| g[k] * (out[k] - x[k])).sum::<f64>();
                prop_assert!(
                    lin.abs() < 1e-12,
                    "rigid projection solves the linearisation: {}",
                    lin
                );
            }
        }
    }
    Ok(())
}
