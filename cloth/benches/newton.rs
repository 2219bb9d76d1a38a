//! Whole rollouts of `u_obstacle` (T = 10) with the Newton solver (`physics.solver = "newton"`,
//! default tolerance) at mesh sizes n = 10, 20, 40, from the scene's initial guess, beside the
//! XPBD ones of `benches/rollout.rs`:
//! - `newton_forward`: simulate and evaluate the metrics;
//! - `newton_forward_grad_l`: the same plus `dL/dU` by implicit differentiation;
//! - `newton_pcg_forward_grad_l`: the same with `physics.linear_solver = "pcg"` (Newton's systems
//!   by conjugate gradients preconditioned with a reused factorization).
//!
//! and the parts of one Newton iteration at the converged state of step 5 (`newton_parts`, n = 20
//! and 40): `gradient` (`∇Φ` assembled), `hessian` (`∇Φ` and the exact Hessian assembled),
//! `factorize` (the exact Hessian assembled and factorized) and `solve` (one solve with that
//! factorization), which price the iterations of a rollout.
//!
//! Single thread: `RAYON_NUM_THREADS=1 cargo bench -p cloth --bench newton`.

use cloth::internals::{HessianKind, NewtonSystem};
use cloth::scene::{LinearSolverKind, SolverKind};
use cloth::{Model, Scene, Solver};
use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use std::hint::black_box;

fn newton(c: &mut Criterion) {
    let mut group = c.benchmark_group("u_obstacle");
    group.sample_size(10);
    for n in [10, 20, 40] {
        let base = Scene::builtin("u_obstacle").expect("built-in scene");
        let mut scene = base.refined(n, n).expect("refined scene");
        scene.physics.solver = Some(SolverKind::Newton);
        let model = Model::from_scene(&scene).expect("model");
        let (u, delta) = (scene.initial_controls(), scene.task.delta);
        group.bench_with_input(BenchmarkId::new("newton_forward", n), &n, |b, _| {
            b.iter(|| black_box(model.evaluate(&u, delta, false).expect("converged")))
        });
        group.bench_with_input(BenchmarkId::new("newton_forward_grad_l", n), &n, |b, _| {
            b.iter(|| black_box(model.evaluate_loss_gradient(&u, delta).expect("converged")))
        });
        scene.physics.linear_solver = LinearSolverKind::Pcg;
        let pcg = Model::from_scene(&scene).expect("model");
        group.bench_with_input(
            BenchmarkId::new("newton_pcg_forward_grad_l", n),
            &n,
            |b, _| b.iter(|| black_box(pcg.evaluate_loss_gradient(&u, delta).expect("converged"))),
        );
    }
    group.finish();
}

fn newton_parts(c: &mut Criterion) {
    let mut group = c.benchmark_group("u_obstacle/newton_parts");
    group.sample_size(20);
    for n in [20, 40] {
        let mut scene = Scene::builtin("u_obstacle")
            .expect("built-in scene")
            .refined(n, n)
            .expect("refined scene");
        scene.physics.solver = Some(SolverKind::Newton);
        let model = Model::from_scene(&scene).expect("model");
        let Solver::Newton(settings) = model.solver else {
            unreachable!("a Newton scene")
        };
        let (states, _) = model
            .simulate_newton(&scene.initial_controls(), &settings)
            .expect("converged");
        // Two states a round-off apart, alternated, so that every factorization is new work (a
        // matrix equal bit for bit to the factorized one would be reused: checked below).
        let x = states[5].data().to_vec();
        let y: Vec<f64> = (x.iter().enumerate())
            .map(|(i, v)| v + if i % 2 == 0 { 1e-9 } else { -1e-9 })
            .collect();
        let mut system = NewtonSystem::new(&model).expect("Newton system");
        let mut grad = vec![0.0; system.pattern.n_dof];
        let mut values = vec![0.0; system.pattern.nnz()];
        group.bench_with_input(BenchmarkId::new("gradient", n), &n, |b, _| {
            b.iter(|| system.pattern.assemble(&x, &x, &mut grad, None))
        });
        group.bench_with_input(BenchmarkId::new("hessian", n), &n, |b, _| {
            let kind = HessianKind::Exact;
            b.iter(|| {
                system
                    .pattern
                    .assemble(&x, &x, &mut grad, Some((&mut values, kind)))
            })
        });
        let mut flip = false;
        group.bench_with_input(BenchmarkId::new("factorize", n), &n, |b, _| {
            b.iter(|| {
                flip = !flip;
                let at = if flip { &x } else { &y };
                assert!(system.factorize_exact(at, at), "a minimizer's Hessian");
            })
        });
        assert_eq!(
            system.factor.counts().reused,
            0,
            "every factorization is new work"
        );
        let mut rhs = vec![1.0; system.pattern.n_dof];
        group.bench_with_input(BenchmarkId::new("solve", n), &n, |b, _| {
            b.iter(|| system.factor.solve_in_place(black_box(&mut rhs), 1))
        });
    }
    group.finish();
}

criterion_group!(benches, newton, newton_parts);
criterion_main!(benches);
