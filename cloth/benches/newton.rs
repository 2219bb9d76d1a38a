//! Whole rollouts of `u_obstacle` (T = 10) with the Newton solver (`physics.solver = "newton"`,
//! default tolerance) at mesh sizes n = 10, 20, 40, from the scene's initial guess, beside the
//! XPBD ones of `benches/rollout.rs`:
//! - `newton_forward`: simulate and evaluate the metrics;
//! - `newton_forward_grad_l`: the same plus `dL/dU` by implicit differentiation;
//! - `newton_pcg_forward_grad_l`: the same with `physics.linear_solver = "pcg"` (Newton's systems
//!   by conjugate gradients preconditioned with a reused factorization).
//!
//! Single thread: `RAYON_NUM_THREADS=1 cargo bench -p cloth --bench newton`.

use cloth::scene::{LinearSolverKind, SolverKind};
use cloth::{Model, Scene};
use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use std::hint::black_box;

fn newton(c: &mut Criterion) {
    let mut group = c.benchmark_group("u_obstacle");
    group.sample_size(10);
    for n in [10, 20, 40] {
        let base = Scene::builtin("u_obstacle").expect("built-in scene");
        let mut scene = base.refined(n, n).expect("refined scene");
        scene.physics.solver = SolverKind::Newton;
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

criterion_group!(benches, newton);
criterion_main!(benches);
